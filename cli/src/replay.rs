//! `avacraft replay session.mcap`: re-simulates every recorded episode from what the
//! recording itself holds (the session description with the scenario's text and the
//! environment configuration, each episode's seed, the actions the simulator applied) and
//! compares the full-state hash the simulator published at every step with the
//! re-simulated one, naming the first step where they differ. No flag is needed; `--video`
//! renders the first episode.

use anyhow::{Result, bail};
use avacraft_engine::{Env, Scenario, Team};
use avacraft_msgs::{ActionBatch, DecodeError, EpisodeStatus, RosMessage, SessionInfo, decode};
use avacraft_nodes::{Topic, TopicKind, Topics};
use avacraft_sim_node::SessionError;
use clap::Args;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Args, Debug, Clone)]
pub struct ReplayArgs {
    /// The recording (MCAP, as `avacraft record` or `launch` writes it).
    pub file: PathBuf,
    /// Render the first replayed episode (team 1's annotated view) to this GIF.
    #[arg(long)]
    pub video: Option<PathBuf>,
    /// `--foxglove`: every replayed episode is shown live as it is re-simulated, at
    /// `--foxglove-speed`.
    #[command(flatten)]
    pub live: crate::live::LiveArgs,
}

/// Why a recording cannot be replayed at all.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("not an MCAP file")]
    NotMcap(#[source] mcap::McapError),
    #[error(
        "no session description (topic `<namespace>/session`, type {}): the recording was made before recordings carried the scenario text, the environment configuration and per-step state hashes; record it again with this version",
        SessionInfo::TYPE_NAME
    )]
    NoSession,
    #[error(
        "topic {topic}: {type_name} recorded as {found}, this build reads {expected}: the recording was made by another version of avacraft"
    )]
    TypeMismatch { topic: String, type_name: &'static str, found: String, expected: &'static str },
    #[error("a {type_name} message on {topic} does not decode")]
    Decode {
        topic: String,
        type_name: &'static str,
        #[source]
        source: DecodeError,
    },
    #[error("no episode status (topic `<namespace>/status`): nothing to replay")]
    NoEpisodes,
    #[error("topics of two namespaces ({0} and {1}): a recording holds one deployment")]
    Namespaces(String, String),
    #[error("episode {episode}: step {step} is recorded twice, differently: a recording holds one session")]
    Duplicate { episode: u64, step: u32 },
    #[error("no episode was recorded from its first step (a recorder that joined late): {0}")]
    NoWholeEpisode(String),
    #[error("episode {episode}: the recorded session is unusable")]
    Session {
        episode: u64,
        #[source]
        source: Box<SessionError>,
    },
}

/// One recorded episode: the session it ran in, its seed, and per step what the simulator
/// published (status, with the full-state hash) and applied.
#[derive(Debug, Clone)]
pub struct RecordedEpisode {
    pub session: SessionInfo,
    pub seed: u64,
    pub statuses: BTreeMap<u32, EpisodeStatus>,
    pub applied: BTreeMap<u32, ActionBatch>,
    /// When each step's status was recorded (its MCAP log time, nanoseconds): where the
    /// live view's channels are put when a recording gets them.
    pub status_times: BTreeMap<u32, u64>,
}

/// What a recording holds for replay.
#[derive(Debug, Clone, Default)]
pub struct Recording {
    pub episodes: BTreeMap<u64, RecordedEpisode>,
    /// Why reading stopped before the end of the file (cut short or damaged), if it did.
    pub truncated: Option<String>,
    /// Episodes that cannot be replayed, and why (recorded from a later step only).
    pub skipped: Vec<(u64, String)>,
}

/// How a replayed episode differs from its recording.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Mismatch {
    /// The first step whose state (before that step's actions) differs from the recorded one.
    State { step: u32, game_loop: u32, expected: u64, got: u64 },
    /// The recording lacks the actions applied at this step, so the replay cannot go on.
    MissingActions { step: u32 },
    /// A recorded applied action is not one the engine can take.
    BadAction { step: u32, why: String },
    /// Every recorded state matched but the episode ends differently.
    End { expected: String, got: String },
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Mismatch::State { step, game_loop, expected, got } => {
                write!(f, "diverges at step {step} (game loop {game_loop}): recorded state hash {expected:016x}, re-simulated {got:016x}")
            }
            Mismatch::MissingActions { step } => write!(f, "the recording has no applied actions for step {step}"),
            Mismatch::BadAction { step, why } => write!(f, "step {step}: a recorded applied action is unusable: {why}"),
            Mismatch::End { expected, got } => write!(f, "the recording ends with {expected}, the re-simulation with {got}"),
        }
    }
}

/// One episode's verdict.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReplayResult {
    pub episode: u64,
    pub seed: u64,
    pub scenario: String,
    /// Steps re-simulated.
    pub steps: u32,
    /// Recorded states compared with the re-simulation.
    pub compared_steps: usize,
    /// Whether the recording holds the episode's end.
    pub complete: bool,
    pub trajectory_hash: u64,
    /// The first difference, or `None` when the trajectory matches.
    pub mismatch: Option<Mismatch>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Session,
    Status,
    Applied,
}

/// Which of the replay's topics a channel is (by its name, parsed in `avacraft_nodes`, and
/// its type), with its namespace; `Ok(None)` for the other channels. A channel of the right
/// topic whose type is not this build's is an error (decoding it would misread it).
fn classify(ch: &mcap::Channel<'_>) -> Result<Option<(Kind, String)>, ReplayError> {
    let Ok(topic) = Topic::parse(&ch.topic) else { return Ok(None) };
    let (ns, _) = topic.namespace_and_base();
    let Ok(topics) = Topics::new(ns) else { return Ok(None) };
    let (kind, type_name, hash, schema) = match topics.classify(&topic) {
        Some(TopicKind::Session) => (Kind::Session, SessionInfo::TYPE_NAME, SessionInfo::type_hash(), SessionInfo::schema()),
        Some(TopicKind::Status) => (Kind::Status, EpisodeStatus::TYPE_NAME, EpisodeStatus::type_hash(), EpisodeStatus::schema()),
        Some(TopicKind::Applied) => (Kind::Applied, ActionBatch::TYPE_NAME, ActionBatch::type_hash(), ActionBatch::schema()),
        _ => return Ok(None),
    };
    let recorded = ch.schema.as_ref();
    // rosbag2 and our recorder store the type hash; without one, the schema text decides.
    let found = match (ch.metadata.get("topic_type_hash"), recorded) {
        (Some(h), _) if h == hash => None,
        (Some(h), s) => Some(format!("{} with type hash {h}", s.map_or("no schema", |s| s.name.as_str()))),
        (None, Some(s)) if s.name == type_name && s.data.as_ref() == schema.as_bytes() => None,
        (None, s) => Some(format!("{} with another definition", s.map_or("no schema", |s| s.name.as_str()))),
    };
    match found {
        None => Ok(Some((kind, ns.to_owned()))),
        Some(found) => Err(ReplayError::TypeMismatch { topic: ch.topic.clone(), type_name, found, expected: hash }),
    }
}

fn decoded<T: RosMessage>(m: &mcap::Message<'_>) -> Result<T, ReplayError> {
    decode(&m.data).map_err(|source| ReplayError::Decode { topic: m.channel.topic.clone(), type_name: T::TYPE_NAME, source })
}

/// Reads what a replay needs from an MCAP recording's bytes.
pub fn read_recording(bytes: &[u8]) -> Result<Recording, ReplayError> {
    let stream = mcap::MessageStream::new(bytes).map_err(ReplayError::NotMcap)?;
    let mut channels: BTreeMap<u16, Option<Kind>> = BTreeMap::new();
    let mut wrong_type = None;
    let mut namespace: Option<String> = None;
    let mut sessions: BTreeMap<u64, SessionInfo> = BTreeMap::new();
    let mut statuses: BTreeMap<u64, BTreeMap<u32, EpisodeStatus>> = BTreeMap::new();
    let mut applied: BTreeMap<u64, BTreeMap<u32, ActionBatch>> = BTreeMap::new();
    let mut times: BTreeMap<u64, BTreeMap<u32, u64>> = BTreeMap::new();
    let (mut read, mut truncated) = (0u64, None);
    for m in stream {
        let m = match m {
            Ok(m) => m,
            // Nothing readable at all (the magic is checked on the first read).
            Err(e) if read == 0 => return Err(ReplayError::NotMcap(e)),
            Err(e) => {
                // The chunks before the damage are intact: replay what they hold.
                truncated = Some(format!("unreadable after {read} messages: {e}"));
                break;
            }
        };
        read += 1;
        let kind = match channels.get(&m.channel.id) {
            Some(k) => *k,
            None => {
                let k = match classify(&m.channel) {
                    Ok(Some((k, ns))) => {
                        match &namespace {
                            Some(n) if *n != ns => return Err(ReplayError::Namespaces(n.clone(), ns)),
                            _ => namespace = Some(ns),
                        }
                        Some(k)
                    }
                    Ok(None) => None,
                    Err(e) => {
                        wrong_type.get_or_insert(e);
                        None
                    }
                };
                channels.insert(m.channel.id, k);
                k
            }
        };
        match kind {
            Some(Kind::Session) => {
                let s: SessionInfo = decoded(&m)?;
                sessions.insert(s.episode, s);
            }
            Some(Kind::Status) => {
                let s: EpisodeStatus = decoded(&m)?;
                let (episode, step) = (s.episode, s.step);
                times.entry(episode).or_default().entry(step).or_insert(m.log_time);
                match statuses.entry(episode).or_default().entry(step) {
                    std::collections::btree_map::Entry::Vacant(v) => {
                        v.insert(s);
                    }
                    std::collections::btree_map::Entry::Occupied(o) if *o.get() != s => {
                        return Err(ReplayError::Duplicate { episode, step });
                    }
                    std::collections::btree_map::Entry::Occupied(_) => {}
                }
            }
            Some(Kind::Applied) => {
                let b: ActionBatch = decoded(&m)?;
                applied.entry(b.episode).or_default().insert(b.step, b);
            }
            None => {}
        }
    }
    // A recording from before sessions were recorded also has statuses of another type:
    // name the missing session first, it is what such a file lacks.
    if sessions.is_empty() {
        return Err(ReplayError::NoSession);
    }
    if let Some(e) = wrong_type {
        return Err(e);
    }
    if statuses.is_empty() {
        return Err(ReplayError::NoEpisodes);
    }
    let (mut episodes, mut skipped) = (BTreeMap::new(), Vec::new());
    for (episode, st) in statuses {
        // A recorder that joined during an episode has neither its start nor, maybe, the
        // session announced at that start: the episode is skipped, the later ones replay.
        let first = st.keys().next().copied().unwrap_or(0);
        let session = sessions.range(..=episode).next_back().map(|(_, s)| s.clone());
        let (0, Some(session)) = (first, session) else {
            let why =
                if first > 0 { format!("the recording starts at its step {first}") } else { "no session description before it".into() };
            skipped.push((episode, why));
            continue;
        };
        let seed = st.values().next().map_or(0, |s| s.seed);
        let applied = applied.remove(&episode).unwrap_or_default();
        let status_times = times.remove(&episode).unwrap_or_default();
        episodes.insert(episode, RecordedEpisode { session, seed, statuses: st, applied, status_times });
    }
    if episodes.is_empty() {
        let all: Vec<String> = skipped.iter().map(|(e, why)| format!("episode {e}: {why}")).collect();
        return Err(ReplayError::NoWholeEpisode(all.join("; ")));
    }
    Ok(Recording { episodes, truncated, skipped })
}

use avacraft_sim_node::result_code;

/// Called with the environment after every re-simulated step of the first episode.
pub type FrameSink<'a> = dyn FnMut(&Env) -> Result<()> + 'a;

/// Re-simulates one recorded episode and compares it with the recording, step by step.
pub fn replay_episode(episode: u64, rec: &RecordedEpisode, mut frames: Option<&mut FrameSink<'_>>) -> Result<ReplayResult> {
    let session_err = |source| ReplayError::Session { episode, source: Box::new(source) };
    let scenario = Arc::new(avacraft_sim_node::scenario(&rec.session).map_err(session_err)?);
    let cfg = avacraft_sim_node::env_config(&rec.session).map_err(session_err)?;
    replay_in(Env::new(Arc::clone(&scenario), cfg, rec.seed), episode, &scenario, rec, &mut frames)
}

fn replay_in(
    mut env: Env,
    episode: u64,
    scenario: &Scenario,
    rec: &RecordedEpisode,
    frames: &mut Option<&mut FrameSink<'_>>,
) -> Result<ReplayResult> {
    let last = rec.statuses.last_key_value().map(|(_, s)| s.clone());
    let last_step = last.as_ref().map_or(0, |s| s.step);
    let (mut compared, mut mismatch) = (0, None);
    'steps: loop {
        let step = env.steps();
        if let Some(st) = rec.statuses.get(&step) {
            compared += 1;
            let got = env.state_hash();
            if got != st.state_hash {
                mismatch = Some(Mismatch::State { step, game_loop: st.game_loop, expected: st.state_hash, got });
                break;
            }
        }
        if env.done() || step >= last_step {
            break;
        }
        let Some(batch) = rec.applied.get(&step) else {
            mismatch = Some(Mismatch::MissingActions { step });
            break;
        };
        for act in &batch.actions {
            let action = match avacraft_sim_node::action_from_msg(env.world(), act) {
                Ok(a) => a,
                Err(e) => {
                    mismatch = Some(Mismatch::BadAction { step, why: e.to_string() });
                    break 'steps;
                }
            };
            let team = env.world().unit(action.unit).map_or(Team::One, |u| u.team);
            // The simulator applied it; should the engine refuse it here, the states part
            // and the next comparison says where.
            let _ = env.submit(team, &[action]);
        }
        env.step();
        if let Some(sink) = frames.as_mut() {
            sink(&env)?;
        }
    }
    let complete = last.as_ref().is_some_and(|s| s.result != EpisodeStatus::RUNNING);
    if mismatch.is_none()
        && let Some(end) = last.as_ref().filter(|_| complete)
    {
        let got = (env.steps(), result_code(env.outcome()), env.trajectory_hash());
        if (end.step, end.result, end.trajectory_hash) != got {
            let show = |(s, r, h): (u32, u8, u64)| format!("step {s}, result {r}, trajectory {h:016x}");
            mismatch = Some(Mismatch::End { expected: show((end.step, end.result, end.trajectory_hash)), got: show(got) });
        }
    }
    Ok(ReplayResult {
        episode,
        seed: rec.seed,
        scenario: scenario.name.clone(),
        steps: env.steps(),
        compared_steps: compared,
        complete,
        trajectory_hash: env.trajectory_hash(),
        mismatch,
    })
}

/// Re-simulates every episode of a recording; `frames` sees the first one.
pub fn replay_recording(rec: &Recording, mut frames: Option<&mut FrameSink<'_>>) -> Result<Vec<ReplayResult>> {
    let mut out = Vec::new();
    for (&episode, ep) in &rec.episodes {
        let sink = if out.is_empty() { frames.as_deref_mut() } else { None };
        out.push(replay_episode(episode, ep, sink)?);
    }
    Ok(out)
}

pub fn run(a: &ReplayArgs, out: &mut dyn Write) -> Result<()> {
    use anyhow::Context;
    let file = a.file.display();
    let bytes = std::fs::read(&a.file).with_context(|| format!("replay: reading {file}"))?;
    let rec = read_recording(&bytes).with_context(|| format!("replay: {file}"))?;
    if let Some(why) = &rec.truncated {
        writeln!(out, "warning: {file} is cut short ({why}); replaying what it holds")?;
    }
    for (episode, why) in &rec.skipped {
        writeln!(out, "episode {episode}: skipped, not replayable: {why}")?;
    }
    let mut video = match &a.video {
        Some(p) => {
            Some((avacraft_render::VideoWriter::create(p, 100)?, avacraft_render::FrameBuilder::new(), avacraft_render::CpuBackend::new()))
        }
        None => None,
    };
    let mut live = a.live.start("replay")?;
    let mut results = Vec::new();
    for (k, (&episode, ep)) in rec.episodes.iter().enumerate() {
        let watched = k == 0 || live.is_some();
        let mut sink = |env: &Env| -> Result<()> {
            if k == 0
                && let Some((w, fb, cpu)) = video.as_mut()
            {
                w.push(&cpu.render(&fb.vlm(env.world(), Team::One, 640, 480, &avacraft_render::VlmOptions::default())))?;
            }
            if let Some(l) = live.as_mut() {
                l.step(env);
            }
            Ok(())
        };
        results.push(replay_episode(episode, ep, if watched { Some(&mut sink) } else { None }).with_context(|| format!("replay: {file}"))?);
    }
    if let Some((w, ..)) = video {
        w.finish()?;
    }
    if let Some(l) = &live {
        eprintln!("{}", l.summary());
    }
    let mut bad = 0;
    for r in &results {
        let head = format!("episode {} (seed {}, {})", r.episode, r.seed, r.scenario);
        match (&r.mismatch, r.complete) {
            (None, true) => writeln!(
                out,
                "{head}: {} steps, every recorded state matches ({} compared), trajectory {:016x}",
                r.steps, r.compared_steps, r.trajectory_hash
            )?,
            (None, false) => writeln!(
                out,
                "{head}: the recording ends at step {} before the episode does; the {} recorded states match",
                r.steps, r.compared_steps
            )?,
            (Some(m), _) => {
                bad += 1;
                writeln!(out, "{head}: MISMATCH: {m}")?;
            }
        }
    }
    if bad > 0 {
        bail!("replay: {bad} of {} episodes do not match {file}", results.len());
    }
    Ok(())
}
