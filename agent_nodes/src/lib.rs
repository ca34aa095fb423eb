//! Agent nodes: a process hosting one [`Agent`] for one unit or a role group. It subscribes
//! only to its own units' observation topics and publishes its actions on its own topic, so
//! the simulator knows who sent them. Observations become the engine's [`AgentObs`] through
//! the lossless wire conversion and are folded into the [`GroupObs`] the agent acts on: the
//! same values an in-process run of the same grouping hands it, so it plays the same game.
//! A restarted agent node rejoins at the next step: it keeps no state the simulator needs.
#![forbid(unsafe_code)]

mod command;
mod features;
mod frames;
pub use command::{CommandedConfig, run_commander, run_role_group};
pub use features::{EncoderError, EncoderStats, run_encoder};

use avacraft_engine::agent::{Agent, AgentCtx, AgentObs, GroupObs, agent_seed, check_action, complete};
use avacraft_engine::{Action, Scenario, Team, UnitId};
use avacraft_msgs::{ActionBatch, UnitObservation};
use avacraft_nodes::{AgentId, Node, NodeError, Qos, Shutdown, TeamNo, TopicKind, Topics, UnitTag, wire};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What one agent node controls.
#[derive(Debug)]
pub struct AgentConfig {
    pub id: AgentId,
    /// The team of its units (their observation topics are under the team's prefix).
    pub team: TeamNo,
    pub units: Vec<UnitTag>,
    /// The scenario being played (a player knows the map).
    pub scenario: Arc<Scenario>,
    /// The team's encoder node serves this node's network ([`run_encoder`]): it acts on the
    /// encodings on `team_<n>/features` instead of running the encoder on the frames.
    pub encoded: bool,
}

/// Counters of a run, for logs and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AgentStats {
    pub batches: u64,
    /// Samples refused: undecodable, on the wrong topic, or with fields that name nothing.
    pub malformed: u64,
    /// Actions sent although the observation's check (the engine's rules,
    /// [`check_action`]) says the simulator will refuse them: the policy's mistakes. They are
    /// sent all the same, as an in-process run submits them, so both play the same game.
    pub doomed: u64,
    /// Steps acted on with the team encoder node's encoding instead of frames.
    pub encoded: u64,
}

/// The policy's actions for `g`, completed with no-ops, and counted in `stats.doomed` where
/// the simulator will refuse them.
pub(crate) fn act(agent: &mut dyn Agent, g: &GroupObs, scenario: &Scenario, stats: &mut AgentStats) -> Vec<Action> {
    let actions = complete(agent.act(g), g);
    for a in &actions {
        if let Err(e) = check_action(g, &scenario.terrain, a) {
            stats.doomed += 1;
            tracing::debug!(unit = a.unit.tag(), error = %e, "the simulator will refuse this action");
        }
    }
    actions
}

/// How long after the first observation of a step the node acts even if some of its units'
/// observations are still missing (a lost sample must not stall the node for good).
pub(crate) const GATHER: Duration = Duration::from_millis(500);

/// How long a node of one unit blocks on its observations before looking at its shutdown
/// flag again.
const IDLE: Duration = Duration::from_millis(50);

/// Observations gathered for one step, by unit tag, with when the first came and its stamp.
type Pending = BTreeMap<(u64, u32), (Instant, avacraft_msgs::Time, BTreeMap<u32, AgentObs>)>;

/// Runs until `shutdown` (or `max_batches` batches, for tests and benchmarks).
pub fn run(
    node: &Node,
    topics: &Topics,
    cfg: &AgentConfig,
    agent: &mut dyn Agent,
    shutdown: &Shutdown,
    max_batches: Option<u64>,
) -> Result<AgentStats, NodeError> {
    let reliable = Qos::Reliable { depth: 10 };
    let subs = cfg
        .units
        .iter()
        .map(|&u| node.subscriber::<UnitObservation>(&topics.unit_obs(cfg.team, u), reliable))
        .collect::<Result<Vec<_>, _>>()?;
    let mut out = node.publisher::<ActionBatch>(&topics.actions(&cfg.id), reliable)?;
    // An image-mode network also reads its team's frames of the step, or the team encoder
    // node's encoding of them.
    let mut encoded = if cfg.encoded { features::FeatureFeed::open(node, topics, cfg.team, agent.encoder())? } else { None };
    let mut feed = if encoded.is_some() { None } else { frames::FrameFeed::open(node, topics, cfg.team, agent.frames())? };
    let team = Team::from(cfg.team);
    let order: Vec<u32> = cfg.scenario.agent_order(team).iter().map(|id| id.tag()).collect();
    let tags: Vec<u32> = cfg.units.iter().map(|u| u.get()).collect();
    let mut stats = AgentStats::default();
    let mut pending: Pending = BTreeMap::new();
    let mut last_done: Option<(u64, u32)> = None;
    // The episode (number, seed) the agent was last reset for.
    let mut episode: Option<(u64, u64)> = None;
    // The episode's scenario (a procedural scenario's draw for its seed).
    let mut scenario = Arc::clone(&cfg.scenario);
    let mut warned = false;
    tracing::info!(agent = %cfg.id, units = cfg.units.len(), policy = agent.name(), "agent node up");
    while !shutdown.requested() && max_batches.is_none_or(|m| stats.batches < m) {
        let mut got = false;
        for s in &subs {
            while let Some(r) = s.try_recv()? {
                got = true;
                accept(cfg, topics, r, &mut pending, &mut last_done, &mut stats);
            }
        }
        if let Some(f) = encoded.as_mut() {
            got |= f.poll(topics, &mut stats)?;
        }
        if encoded.is_some() || feed.is_some() {
            if let Some(f) = feed.as_mut() {
                got |= f.poll(topics, &mut stats)?;
            }
            if !warned && pending.values().any(|(t0, _, _)| t0.elapsed() >= 4 * GATHER) {
                warned = true;
                tracing::warn!(agent = %cfg.id, "observations wait for their frames (or the team encoder node's encoding of them): does the simulator draw them, is the encoder node up?");
            }
        }
        // Act on the newest complete step (or one gathered for long enough) whose frames are
        // here if the network reads some; older ones are stale.
        let framed = |stamp: &avacraft_msgs::Time| {
            feed.as_ref().is_none_or(|f| f.has(*stamp)) && encoded.as_ref().is_none_or(|f| f.at(*stamp).is_some())
        };
        let ready = pending
            .iter()
            .rev()
            .find(|(_, (t0, stamp, m))| (m.len() == cfg.units.len() || t0.elapsed() >= GATHER) && framed(stamp))
            .map(|(k, (_, stamp, _))| (*k, *stamp));
        if let Some((key, stamp)) = ready {
            let shown = feed.as_ref().and_then(|f| f.at(stamp));
            let obs: Vec<AgentObs> = pending.remove(&key).map(|(_, _, m)| m.into_values().collect()).unwrap_or_default();
            pending.retain(|k, _| *k > key);
            let Some(first) = obs.first() else { continue };
            if episode != Some((first.episode, first.seed)) {
                let units: Vec<UnitId> = cfg.units.iter().map(|&u| UnitId::from(u)).collect();
                let seed = agent_seed(first.seed, team, tags[0]);
                scenario = cfg.scenario.episode(first.seed);
                agent.reset(&AgentCtx { scenario: Arc::clone(&scenario), team, units, seed });
                episode = Some((first.episode, first.seed));
            }
            let header = avacraft_msgs::Header::default();
            let index = |id: UnitId| order.iter().position(|&t| t == id.tag()).unwrap_or(0);
            if let Some(f) = &shown {
                agent.see(f);
            }
            if let Some(e) = encoded.as_ref().and_then(|f| f.at(stamp)) {
                agent.see_encoded(e);
                stats.encoded += 1;
            }
            let actions = GroupObs::fold(&obs, index).map(|g| act(agent, &g, &scenario, &mut stats)).unwrap_or_default();
            let actions = actions.iter().map(wire::unit_action).collect();
            out.put(&ActionBatch { header, episode: key.0, step: key.1, agent_id: cfg.id.to_string(), actions })?;
            stats.batches += 1;
            last_done = Some(key);
        } else if !got {
            // Block on the first unit's topic instead of sleeping: an agent node of one unit
            // (the common case) then reacts as soon as its observation lands, and sleeps
            // between steps instead of waking every millisecond (23 such nodes on 2 cores
            // spent a fifth of the machine on those wake-ups). A node of several units, or
            // one waiting for frames, looks at its other inputs every millisecond.
            let nap = if subs.len() == 1 && feed.is_none() && encoded.is_none() { IDLE } else { Duration::from_millis(1) };
            if let Some(first) = subs.first()
                && let Some(r) = first.recv_timeout(nap)?
            {
                accept(cfg, topics, r, &mut pending, &mut last_done, &mut stats);
            }
        }
    }
    Ok(stats)
}

/// Files one received observation under its step, or counts it as malformed.
fn accept(
    cfg: &AgentConfig,
    topics: &Topics,
    r: avacraft_nodes::Received<UnitObservation>,
    pending: &mut Pending,
    last_done: &mut Option<(u64, u32)>,
    stats: &mut AgentStats,
) {
    let o = match r.msg {
        Ok(o) => o,
        Err(e) => {
            stats.malformed += 1;
            tracing::warn!(agent = %cfg.id, error = %e, "malformed observation ignored");
            return;
        }
    };
    // Only the unit this topic is for (a spoofed sample cannot act for others).
    let on_its_topic = matches!(topics.classify(&r.topic), Some(TopicKind::UnitObs(t, u)) if t == cfg.team && u.get() == o.unit_tag);
    if !cfg.units.iter().any(|u| u.get() == o.unit_tag) || !on_its_topic {
        stats.malformed += 1;
        return;
    }
    let obs = match wire::agent_obs(&o, Team::from(cfg.team)) {
        Ok(obs) => obs,
        Err(e) => {
            stats.malformed += 1;
            tracing::warn!(agent = %cfg.id, error = %e, "observation refused");
            return;
        }
    };
    let key = (o.episode, o.step);
    // A restarted simulator counts episodes from 0 again.
    if last_done.is_some_and(|d| o.episode < d.0) {
        *last_done = None;
    }
    if last_done.is_some_and(|d| key <= d) {
        return;
    }
    pending.entry(key).or_insert_with(|| (Instant::now(), o.header.stamp, BTreeMap::new())).2.insert(o.unit_tag, obs);
}
