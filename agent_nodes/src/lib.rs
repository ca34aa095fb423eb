//! Agent nodes: a process hosting a policy for one unit or a role group. It subscribes only
//! to its own units' observation topics and publishes its actions on its own topic, so the
//! simulator knows who sent them. A restarted agent node rejoins at the next step: it keeps
//! no state the simulator depends on.

mod policy;

pub use policy::{AttackMove, FocusFire, POLICIES, UnitPolicy, UnknownPolicy, by_name};

use avacraft_msgs::{ActionBatch, UnitObservation};
use avacraft_nodes::{AgentId, Node, NodeError, Qos, Shutdown, TeamNo, Topics, UnitTag};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// What one agent node controls.
#[derive(Debug)]
pub struct AgentConfig {
    pub id: AgentId,
    /// The team of its units (their observation topics are under the team's prefix).
    pub team: TeamNo,
    pub units: Vec<UnitTag>,
}

/// Counters of a run, for logs and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AgentStats {
    pub batches: u64,
    pub malformed: u64,
}

/// How long after the first observation of a step the node acts even if some of its units'
/// observations are still missing.
const GATHER: Duration = Duration::from_millis(200);

/// Runs until `shutdown` (or `max_batches` batches, for tests and benchmarks).
pub fn run(
    node: &Node,
    topics: &Topics,
    cfg: &AgentConfig,
    policy: &mut dyn UnitPolicy,
    shutdown: &Shutdown,
    max_batches: Option<u64>,
) -> Result<AgentStats, NodeError> {
    let reliable = Qos::Reliable { depth: 10 };
    let subs = cfg
        .units
        .iter()
        .map(|&u| node.subscriber::<UnitObservation>(topics.unit_obs(cfg.team, u).as_str(), reliable))
        .collect::<Result<Vec<_>, _>>()?;
    let mut out = node.publisher::<ActionBatch>(&topics.actions(&cfg.id), reliable)?;
    let mut stats = AgentStats::default();
    // Observations of the step being gathered, by unit; keyed by (episode, step).
    let mut pending: BTreeMap<(u64, u32), (Instant, BTreeMap<u32, UnitObservation>)> = BTreeMap::new();
    let mut last_done: Option<(u64, u32)> = None;
    tracing::info!(agent = %cfg.id, units = cfg.units.len(), policy = policy.name(), "agent node up");
    while !shutdown.requested() && max_batches.is_none_or(|m| stats.batches < m) {
        let mut got = false;
        for s in &subs {
            while let Some(r) = s.try_recv()? {
                got = true;
                match r.msg {
                    Ok(o) => {
                        // Only the unit this topic is for (a spoofed sample cannot act for others).
                        if !cfg.units.iter().any(|u| u.get() == o.unit_tag) || !r.key.contains(&format!("/unit_{}/obs/", o.unit_tag)) {
                            stats.malformed += 1;
                            continue;
                        }
                        let key = (o.episode, o.step);
                        // A restarted simulator counts episodes from 0 again.
                        if last_done.is_some_and(|d| o.episode < d.0) {
                            last_done = None;
                        }
                        if last_done.is_some_and(|d| key <= d) {
                            continue;
                        }
                        pending.entry(key).or_insert_with(|| (Instant::now(), BTreeMap::new())).1.insert(o.unit_tag, o);
                    }
                    Err(e) => {
                        stats.malformed += 1;
                        tracing::warn!(agent = %cfg.id, error = %e, "malformed observation ignored");
                    }
                }
            }
        }
        // Act on the newest complete step (or one gathered for long enough); older ones are stale.
        let ready = pending.iter().rev().find(|(_, (t0, m))| m.len() == cfg.units.len() || t0.elapsed() >= GATHER).map(|(k, _)| *k);
        if let Some(key) = ready {
            let obs = pending.remove(&key).map(|(_, m)| m).unwrap_or_default();
            pending.retain(|k, _| *k > key);
            let obs: Vec<UnitObservation> = obs.into_values().collect();
            let actions = policy.act(&obs);
            let header = obs.first().map(|o| o.header.clone()).unwrap_or_default();
            out.put(&ActionBatch { header, episode: key.0, step: key.1, agent_id: cfg.id.to_string(), actions })?;
            stats.batches += 1;
            last_done = Some(key);
        } else if !got {
            // Block on the first unit's topic for a moment instead of sleeping: an agent
            // node of one unit (the common case) then reacts as soon as its observation lands.
            if let Some(first) = subs.first()
                && let Some(r) = first.recv_timeout(Duration::from_millis(1))?
            {
                match r.msg {
                    Ok(o) if o.unit_tag == cfg.units[0].get() => {
                        if last_done.is_some_and(|d| o.episode < d.0) {
                            last_done = None;
                        }
                        if last_done.is_none_or(|d| (o.episode, o.step) > d) {
                            pending.entry((o.episode, o.step)).or_insert_with(|| (Instant::now(), BTreeMap::new())).1.insert(o.unit_tag, o);
                        }
                    }
                    _ => stats.malformed += 1,
                }
            }
        }
    }
    Ok(stats)
}
