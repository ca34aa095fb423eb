//! The frame plan of image networks: a team's per-unit agent nodes of one network would each
//! run its image encoder on the same team frames every step. The team's encoder node runs it
//! once ([`run_encoder`]) and publishes the result on `team_<n>/features`; those nodes then
//! act on it ([`FeatureFeed`]) as they would have on the frames: the same numbers, from the
//! same code, so the game is the one an in-process run plays.

use crate::AgentStats;
use crate::frames::FrameFeed;
use avacraft_engine::agent::Agent;
use avacraft_msgs::{Header, TeamFeatures, Time};
use avacraft_nodes::{Node, NodeError, Qos, Shutdown, Subscriber, TeamNo, TopicKind, Topics};
use std::time::Duration;

/// The team's newest encoding of the agent's network, with its stamp.
pub(crate) struct FeatureFeed {
    encoder: String,
    team: TeamNo,
    sub: Subscriber<TeamFeatures>,
    latest: Option<(Time, Vec<f32>)>,
}

impl FeatureFeed {
    /// Subscribes to `team`'s encodings when the agent has an encoder to share.
    pub(crate) fn open(node: &Node, topics: &Topics, team: TeamNo, encoder: Option<String>) -> Result<Option<FeatureFeed>, NodeError> {
        let Some(encoder) = encoder else { return Ok(None) };
        let sub = node.subscriber::<TeamFeatures>(&topics.features(team), Qos::Reliable { depth: 10 })?;
        Ok(Some(FeatureFeed { encoder, team, sub, latest: None }))
    }

    /// Takes what arrived; an encoding of another network or team, or off its topic, counts
    /// as malformed. Whether anything arrived.
    pub(crate) fn poll(&mut self, topics: &Topics, stats: &mut AgentStats) -> Result<bool, NodeError> {
        let mut got = false;
        while let Some(r) = self.sub.try_recv()? {
            got = true;
            let on_topic = topics.classify(&r.topic) == Some(TopicKind::Features(self.team));
            match r.msg {
                Ok(f) if on_topic && f.team == self.team.get() && f.encoder == self.encoder => {
                    self.latest = Some((f.header.stamp, f.data));
                }
                Ok(f) => {
                    stats.malformed += 1;
                    tracing::warn!(encoder = %f.encoder, team = f.team, "an encoding of another network or team was ignored");
                }
                Err(e) => {
                    stats.malformed += 1;
                    tracing::warn!(error = %e, "malformed encoding ignored");
                }
            }
        }
        Ok(got)
    }

    /// The encoding of the step stamped `stamp`, once it is here.
    pub(crate) fn at(&self, stamp: Time) -> Option<&[f32]> {
        self.latest.as_ref().filter(|(s, _)| *s == stamp).map(|(_, d)| d.as_slice())
    }
}

/// Counters of an encoder node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EncoderStats {
    /// Encodings published (one per step whose frames arrived).
    pub encoded: u64,
    /// Frames refused (another size or encoding, undecodable) and frames the network could
    /// not encode.
    pub malformed: u64,
}

/// Why an encoder node cannot run.
#[derive(Debug, thiserror::Error)]
pub enum EncoderError {
    #[error("policy `{0}` has no image encoder to share (an encoder node serves networks trained on rgb or hybrid observations)")]
    NoEncoder(String),
    #[error(transparent)]
    Node(#[from] NodeError),
}

/// Runs a team's encoder node until `shutdown` (or `max` encodings): for each step's pair of
/// frames, `agent`'s team encoding ([`Agent::encode`]) on `team_<n>/features`.
pub fn run_encoder(
    node: &Node,
    topics: &Topics,
    team: TeamNo,
    agent: &dyn Agent,
    shutdown: &Shutdown,
    max: Option<u64>,
) -> Result<EncoderStats, EncoderError> {
    let no_encoder = || EncoderError::NoEncoder(agent.name().to_owned());
    let (Some(name), Some(need)) = (agent.encoder(), agent.frames()) else { return Err(no_encoder()) };
    let mut feed = FrameFeed::open(node, topics, team, Some(need))?.ok_or_else(no_encoder)?;
    let mut out = node.publisher::<TeamFeatures>(&topics.features(team), Qos::Reliable { depth: 10 })?;
    let mut stats = EncoderStats::default();
    let mut agent_stats = AgentStats::default();
    let mut done: Option<Time> = None;
    tracing::info!(team = team.get(), encoder = %name, "encoder node up");
    while !shutdown.requested() && max.is_none_or(|m| stats.encoded < m) {
        let got = feed.poll(topics, &mut agent_stats)?;
        stats.malformed = agent_stats.malformed;
        match feed.newest().filter(|s| Some(*s) != done).and_then(|s| feed.at(s).map(|f| (s, f))) {
            Some((stamp, frames)) => {
                done = Some(stamp);
                match agent.encode(&frames) {
                    Some(data) => {
                        let header = Header { stamp, frame_id: "map".into() };
                        out.put(&TeamFeatures { header, team: team.get(), encoder: name.clone(), data })?;
                        stats.encoded += 1;
                    }
                    None => {
                        stats.malformed += 1;
                        tracing::warn!(team = team.get(), "frames the network cannot encode");
                    }
                }
            }
            None if !got => std::thread::sleep(Duration::from_micros(200)),
            None => {}
        }
    }
    Ok(stats)
}
