//! The node loop: episodes played back to back, each step's observations published and
//! its actions gathered from the wire under the clock's rule.

use crate::command::{Command, OrderCounts};
use crate::config::{Clock, FrameSpec, SimConfig};
use crate::convert::{action_from_msg, header, unit_of, unit_state};
use crate::session::session_info;
use avacraft_engine::agent::Reads;
use avacraft_engine::{Env, Outcome, Team, UnitId};
use avacraft_msgs::{ActionBatch, EpisodeStatus, TeamObservation};
use avacraft_nodes::{AgentId, FrameKind, Node, NodeError, NodeName, Qos, Shutdown, TeamNo, TopicKind, Topics, UnitTag};
use avacraft_render::{CpuBackend, FrameBuilder, VlmOptions};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One finished episode.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EpisodeSummary {
    pub episode: u64,
    pub seed: u64,
    pub result: Outcome,
    pub steps: u32,
    pub game_loops: u32,
    pub trajectory_hash: String,
    pub refused_actions: [u32; 2],
    pub missing_actions: [u32; 2],
    pub foreign_actions: [u32; 2],
    pub malformed_messages: u32,
    /// Commanders' orders refused (naming a dead or foreign unit, a unit twice or none, an
    /// unknown group) and missing at a step's deadline, per team.
    #[serde(default)]
    pub refused_orders: [u32; 2],
    #[serde(default)]
    pub missing_orders: [u32; 2],
    /// Units that changed role group, per team.
    #[serde(default)]
    pub role_changes: [u32; 2],
    /// Wall time of the episode.
    pub wall_seconds: f64,
    /// Observation-to-action round trip per step (publishing every observation until the
    /// last owned unit's action arrived), 50th and 99th percentile, microseconds.
    pub round_trip_us: [u64; 2],
    /// Where the round trip goes, 50th percentiles over the steps, microseconds.
    #[serde(default)]
    pub round_trip_parts_us: RoundTripParts,
}

/// A step's round trip in three legs, timed by the wall clock every process on a host shares
/// (each message carries its publisher's send time, rmw_zenoh's attachment).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RoundTripParts {
    /// The simulator encoding and publishing the step: orders, observations, frames, status.
    pub publish: u64,
    /// From the first observation sent to the last answering agent node sending its actions:
    /// delivery, the node's wake-up and gathering, the policy's act, encoding.
    pub to_agents: u64,
    /// From that node's send to the simulator holding the batch: delivery and its wake-up.
    pub back: u64,
}

/// The legs of every step of an episode.
#[derive(Default)]
struct Legs {
    publish: Vec<u64>,
    to_agents: Vec<u64>,
    back: Vec<u64>,
}

impl Legs {
    fn parts(&self) -> RoundTripParts {
        let p50 = |v: &Vec<u64>| percentiles(v.clone())[0];
        RoundTripParts { publish: p50(&self.publish), to_agents: p50(&self.to_agents), back: p50(&self.back) }
    }
}

fn percentiles(mut v: Vec<u64>) -> [u64; 2] {
    if v.is_empty() {
        return [0, 0];
    }
    v.sort_unstable();
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    [at(0.5), at(0.99)]
}

/// Why the node stopped early.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Node(#[from] NodeError),
    #[error("endpoints {missing:?} did not appear within {seconds:.1} s")]
    AgentsMissing { missing: Vec<String>, seconds: f64 },
    #[error("stopped by a signal after {episodes} episodes")]
    Interrupted { episodes: usize },
}

/// Counters of one episode (indexed by team).
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    missing: [u32; 2],
    foreign: [u32; 2],
    refused_wire: [u32; 2],
    malformed: u32,
}

/// An outcome as `EpisodeStatus` carries it (`RUNNING` while there is none).
pub fn result_code(o: Option<Outcome>) -> u8 {
    match o {
        None => EpisodeStatus::RUNNING,
        Some(Outcome::Win) => EpisodeStatus::WIN,
        Some(Outcome::Loss) => EpisodeStatus::LOSS,
        Some(Outcome::Draw) => EpisodeStatus::DRAW,
    }
}

/// Runs every episode of `cfg`; returns their summaries.
pub fn run(node: &Node, topics: &Topics, cfg: &SimConfig, shutdown: &Shutdown) -> Result<Vec<EpisodeSummary>, SimError> {
    run_watched(node, topics, cfg, shutdown, &mut |_| {})
}

/// [`run`], showing the environment to `watch` at every step (after the step's
/// observations are out) and at each episode's end: the live view (`--foxglove`).
pub fn run_watched(
    node: &Node,
    topics: &Topics,
    cfg: &SimConfig,
    shutdown: &Shutdown,
    watch: &mut dyn FnMut(&Env),
) -> Result<Vec<EpisodeSummary>, SimError> {
    let mut env = Env::new(Arc::clone(&cfg.scenario), cfg.env.clone(), cfg.seeds.first().copied().unwrap_or(1));
    let teams: Vec<Team> = Team::BOTH.into_iter().filter(|t| env.is_agent_team(*t)).collect();
    let reliable = Qos::Reliable { depth: 10 };
    let mut unit_pubs = BTreeMap::new();
    for &team in &teams {
        for &id in env.agents(team) {
            let tag = UnitTag::from(id);
            let no = TeamNo::from(team);
            unit_pubs.insert(id, node.publisher(&topics.unit_obs(no, tag), reliable)?);
        }
    }
    let mut team_pubs = BTreeMap::new();
    for &team in &teams {
        let no = TeamNo::from(team);
        team_pubs.insert(team, node.publisher::<TeamObservation>(&topics.team_obs(no), reliable)?);
    }
    let mut status_pub = node.publisher::<EpisodeStatus>(&topics.status(), reliable)?;
    // What a recording needs to replay alone; sent now for whoever listens already, and at
    // every episode's start for a recorder that joins later.
    let mut session_pub = node.publisher::<avacraft_msgs::SessionInfo>(&topics.session(), reliable)?;
    session_pub.put(&session_info(cfg, 0, header(env.world(), "map")))?;
    let mut applied_pub = node.publisher::<ActionBatch>(&topics.applied(), reliable)?;
    let mut frames = Frames::new(node, topics, &teams, cfg.frames.clone())?;
    let mut roles_pub = node.publisher::<avacraft_msgs::RoleAssignment>(&topics.roles(), reliable)?;
    let actions = node.subscriber::<ActionBatch>(topics.any_actions(), reliable)?;
    let mut command = Command::new(node, topics, cfg)?;
    // Each team's messages carry what its nodes read, as in-process runs build for them.
    let reads: BTreeMap<Team, Reads> = teams.iter().map(|&t| (t, cfg.team_reads(TeamNo::from(t)))).collect();
    wait_for_agents(node, topics, cfg, shutdown)?;
    let mut out = Vec::new();
    for (episode, &seed) in cfg.seeds.iter().enumerate() {
        if shutdown.requested() {
            return Err(SimError::Interrupted { episodes: out.len() });
        }
        env.reset(seed);
        let mut counts = Counts::default();
        let mut owners = cfg.owners.clone();
        let mut orders = OrderCounts::default();
        command.reset();
        let episode = episode as u64;
        let started = Instant::now();
        let mut trips = Vec::new();
        let mut legs = Legs::default();
        tracing::info!(episode, seed, scenario = %cfg.scenario.name, "episode starts");
        session_pub.put(&session_info(cfg, episode, header(env.world(), "map")))?;
        roles_pub.put(&roles(&env, &owners, episode))?;
        loop {
            let t0 = Instant::now();
            command.publish(&env, &owners, episode)?;
            let obs_ns = avacraft_nodes::now_ns();
            publish_step(&env, &reads, episode, &mut unit_pubs, &mut team_pubs)?;
            frames.publish(&env)?;
            status_pub.put(&status(&env, cfg, episode, seed, &counts))?;
            legs.publish.push(t0.elapsed().as_micros() as u64);
            watch(&env);
            let mut wait =
                Wait { cfg, topics, owners: &owners, command: &mut command, orders: &mut orders, episode, shutdown, started, last: None };
            let applied = collect_actions(&mut env, &teams, &actions, &mut wait, &mut counts)?;
            trips.push(t0.elapsed().as_micros() as u64);
            if let Some((sent, arrived)) = wait.last {
                legs.to_agents.push(((sent - obs_ns).max(0) / 1000) as u64);
                legs.back.push(((arrived - sent).max(0) / 1000) as u64);
            }
            applied_pub.put(&ActionBatch {
                header: header(env.world(), "map"),
                episode,
                step: env.steps(),
                agent_id: "sim".into(),
                actions: applied,
            })?;
            if shutdown.requested() {
                return Err(SimError::Interrupted { episodes: out.len() });
            }
            let done = env.step().done;
            // Ownership follows the checked orders from the next step on.
            if command.apply(&mut owners, &mut orders) {
                roles_pub.put(&roles(&env, &owners, episode))?;
            }
            if done {
                break;
            }
        }
        // Final observations (units see the end) and the final status.
        publish_step(&env, &reads, episode, &mut unit_pubs, &mut team_pubs)?;
        status_pub.put(&status(&env, cfg, episode, seed, &counts))?;
        watch(&env);
        let refused = env.refused();
        let s = EpisodeSummary {
            episode,
            seed,
            result: env.outcome().unwrap_or(Outcome::Draw),
            steps: env.steps(),
            game_loops: env.world().tick(),
            trajectory_hash: format!("{:016x}", env.trajectory_hash()),
            refused_actions: [refused[0] + counts.refused_wire[0], refused[1] + counts.refused_wire[1]],
            missing_actions: counts.missing,
            foreign_actions: counts.foreign,
            malformed_messages: counts.malformed,
            refused_orders: orders.refused,
            missing_orders: orders.missing,
            role_changes: orders.changes,
            wall_seconds: started.elapsed().as_secs_f64(),
            round_trip_us: percentiles(trips),
            round_trip_parts_us: legs.parts(),
        };
        tracing::info!(episode, result = ?s.result, steps = s.steps, missing = ?s.missing_actions, foreign = ?s.foreign_actions, malformed = s.malformed_messages, "episode ends");
        out.push(s);
    }
    Ok(out)
}

/// Who owns which units this episode (the launch file's groups; each group is a role).
fn roles(env: &Env, owners: &BTreeMap<UnitTag, AgentId>, episode: u64) -> avacraft_msgs::RoleAssignment {
    let mut groups: BTreeMap<&AgentId, Vec<u32>> = BTreeMap::new();
    for (tag, agent) in owners {
        groups.entry(agent).or_default().push(tag.get());
    }
    avacraft_msgs::RoleAssignment {
        header: header(env.world(), "map"),
        episode,
        step: env.steps(),
        team: 0,
        groups: groups
            .into_iter()
            .map(|(a, units)| avacraft_msgs::RoleGroup {
                role: avacraft_msgs::RoleGroup::ROLE_NONE,
                agent_id: a.to_string(),
                unit_tags: units,
            })
            .collect(),
        plan: String::new(),
        priority_tags: Vec::new(),
    }
}

fn status(env: &Env, cfg: &SimConfig, episode: u64, seed: u64, c: &Counts) -> EpisodeStatus {
    let refused = env.refused();
    let reward = env.outcome().map_or([0.0, 0.0], |o| [o.sparse_reward(), o.for_team(Team::Two).sparse_reward()]);
    EpisodeStatus {
        header: header(env.world(), "map"),
        episode,
        seed,
        scenario: cfg.scenario.name.clone(),
        step: env.steps(),
        game_loop: env.world().tick(),
        result: result_code(env.outcome()),
        reward,
        refused_actions: [refused[0] + c.refused_wire[0], refused[1] + c.refused_wire[1]],
        missing_actions: c.missing,
        foreign_actions: c.foreign,
        malformed_messages: c.malformed,
        state_hash: env.state_hash(),
        trajectory_hash: env.trajectory_hash(),
    }
}

fn publish_step(
    env: &Env,
    reads: &BTreeMap<Team, Reads>,
    episode: u64,
    unit_pubs: &mut BTreeMap<UnitId, avacraft_nodes::Publisher<avacraft_msgs::UnitObservation>>,
    team_pubs: &mut BTreeMap<Team, avacraft_nodes::Publisher<TeamObservation>>,
) -> Result<(), NodeError> {
    for (&team, &reads) in reads {
        // The units' observations are the engine's own, built with what the team's nodes
        // read (what in-process agents get), so a deployed policy sees exactly what it
        // would see in-process.
        let obs = env.agent_observations_of(team, episode, env.agents(team), reads);
        let w = env.world();
        if let Some(p) = team_pubs.get_mut(&team) {
            let units = avacraft_engine::unit_list(w, team).iter().map(unit_state).collect();
            let msg = TeamObservation {
                header: header(w, "map"),
                episode,
                step: env.steps(),
                game_loop: w.tick(),
                team: team.player(),
                units,
                effects: avacraft_engine::agent::effects(env, team).iter().map(avacraft_nodes::wire::area_effect).collect(),
                text: obs
                    .first()
                    .map(|o| o.text.to_string())
                    .filter(|t| !t.is_empty())
                    .unwrap_or_else(|| avacraft_engine::describe(env, team)),
            };
            p.put(&msg)?;
        }
        for o in &obs {
            if let Some(p) = unit_pubs.get_mut(&o.unit) {
                p.put(&avacraft_nodes::wire::unit_observation(o, header(w, "map")))?;
            }
        }
    }
    Ok(())
}

/// Waits until every agent node has declared its observation subscriptions and its action
/// publisher (and the recorder its subscription, when one is expected): a node's own token
/// appears before its endpoints, so waiting for nodes alone could lose step 0.
fn wait_for_agents(node: &Node, topics: &Topics, cfg: &SimConfig, shutdown: &Shutdown) -> Result<(), SimError> {
    use avacraft_nodes::ros::{TokenKind, parse_token};
    let ns = avacraft_nodes::ros::mangle(topics.namespace());
    // (kind, node name, topic or none for any)
    let mut wanted: BTreeSet<(TokenKind, String, Option<avacraft_nodes::Topic>)> = BTreeSet::new();
    let env = Env::new(Arc::clone(&cfg.scenario), cfg.env.clone(), 0);
    for (tag, agent) in &cfg.owners {
        if cfg.dds_agents.contains(agent) {
            wanted.insert((TokenKind::Publisher, NodeName::bridge().to_string(), Some(topics.actions(agent))));
            continue;
        }
        let name = NodeName::agent(agent).to_string();
        let Some(team) = unit_of(&env, tag.get()).map(|u| TeamNo::from(u.team)) else { continue };
        wanted.insert((TokenKind::Subscription, name.clone(), Some(topics.unit_obs(team, *tag))));
        wanted.insert((TokenKind::Publisher, name, Some(topics.actions(agent))));
    }
    for c in &cfg.commands {
        let name = NodeName::agent(&c.commander).to_string();
        wanted.insert((TokenKind::Publisher, name.clone(), Some(topics.orders(c.team))));
        wanted.insert((TokenKind::Subscription, name, Some(topics.team_roles(c.team))));
    }
    if cfg.wait_for_recorder {
        wanted.insert((TokenKind::Subscription, NodeName::recorder().to_string(), None));
    }
    if wanted.is_empty() {
        return Ok(());
    }
    let start = Instant::now();
    loop {
        let tokens: Vec<_> = node.alive_tokens(Duration::from_millis(500))?.iter().filter_map(|t| parse_token(t)).collect();
        let have = |(kind, name, topic): &(TokenKind, String, Option<avacraft_nodes::Topic>)| {
            tokens.iter().any(|t| t.kind == *kind && t.namespace == ns && t.node == *name && (topic.is_none() || t.topic == *topic))
        };
        let missing: Vec<String> =
            wanted.iter().filter(|w| !have(w)).map(|(k, n, t)| format!("{n} {k:?} {}", t.as_ref().map_or("*", |t| t.as_str()))).collect();
        if missing.is_empty() {
            tracing::info!(endpoints = wanted.len(), "every agent node is up");
            return Ok(());
        }
        if shutdown.requested() {
            return Err(SimError::Interrupted { episodes: 0 });
        }
        if start.elapsed() > cfg.startup_timeout {
            return Err(SimError::AgentsMissing { missing, seconds: start.elapsed().as_secs_f64() });
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// What a step waits for besides the actions.
struct Wait<'a> {
    cfg: &'a SimConfig,
    topics: &'a Topics,
    /// Who owns which unit this step.
    owners: &'a BTreeMap<UnitTag, AgentId>,
    command: &'a mut Command,
    orders: &'a mut OrderCounts,
    episode: u64,
    shutdown: &'a Shutdown,
    started: Instant,
    /// The last action batch of this step that counted: its send time and arrival (wall
    /// clock, nanoseconds).
    last: Option<(i64, i64)>,
}

/// Gathers the actions of this step from the wire and submits them; returns the ones the
/// engine accepted, in the order applied (published for replay). Commanders' orders for the
/// step are gathered too (and checked, to apply after the step).
fn collect_actions(
    env: &mut Env,
    teams: &[Team],
    sub: &avacraft_nodes::Subscriber<ActionBatch>,
    w: &mut Wait<'_>,
    c: &mut Counts,
) -> Result<Vec<avacraft_msgs::UnitAction>, NodeError> {
    let (cfg, topics, episode, shutdown, episode_start) = (w.cfg, w.topics, w.episode, w.shutdown, w.started);
    let step = env.steps();
    let mut applied = Vec::new();
    // Units whose action this step is still awaited: live units with an owner.
    let mut waiting: BTreeSet<UnitId> = BTreeSet::new();
    for &team in teams {
        for u in env.world().alive(team) {
            if w.owners.contains_key(&UnitTag::from(u.id)) {
                waiting.insert(u.id);
            }
        }
    }
    let (deadline, realtime) = match cfg.clock {
        Clock::Lockstep { deadline } => (Instant::now() + deadline, false),
        // An absolute schedule from the episode's start, so publishing and rendering do not
        // make the clock drift.
        Clock::RealTime => (
            episode_start
                + Duration::from_secs_f64((step + 1) as f64 * cfg.env.step_mul.get() as f64 / f64::from(avacraft_engine::LOOPS_PER_SECOND)),
            true,
        ),
    };
    w.command.expect(episode, step);
    while (realtime || !waiting.is_empty() || w.command.waiting()) && !shutdown.requested() {
        let now = Instant::now();
        if now >= deadline {
            break;
        }
        w.command.receive(env, episode, step, w.orders)?;
        // Orders come on their own topics: look there often while any is awaited.
        let slice = if w.command.waiting() { Duration::from_millis(2) } else { Duration::from_millis(50) };
        let Some(r) = sub.recv_timeout((deadline - now).min(slice))? else { continue };
        let arrived = avacraft_nodes::now_ns();
        let Some(TopicKind::Actions(agent)) = topics.classify(&r.topic) else {
            c.malformed += 1;
            continue;
        };
        // The sender's team: the team of the units it owns (foreign actions count against it).
        let sender_team = cfg.team_of(&agent).map(TeamNo::team);
        let si = sender_team.map_or(0, |t| t.index());
        let batch = match r.msg {
            Ok(b) => b,
            Err(e) => {
                tracing::warn!(%agent, error = %e, "malformed action batch refused");
                c.malformed += 1;
                continue;
            }
        };
        // Ownership first, whatever step the batch is for.
        let (mine, foreign): (Vec<_>, Vec<_>) =
            batch.actions.iter().partition(|a| UnitTag::new(a.unit_tag).ok().and_then(|t| w.owners.get(&t)) == Some(&agent));
        if !foreign.is_empty() {
            tracing::warn!(%agent, units = ?foreign.iter().map(|a| a.unit_tag).collect::<Vec<_>>(), "actions for units this agent node does not own refused");
            c.foreign[si] += foreign.len() as u32;
        }
        // In lockstep only this step's answer counts; in real time a late answer applies now.
        let current = batch.episode == episode && (batch.step == step || (realtime && batch.step < step));
        if !current {
            continue;
        }
        if let Some(att) = &r.attachment {
            w.last = Some((att.source_ns, arrived));
        }
        for a in mine {
            let Some(unit) = unit_of(env, a.unit_tag).map(|u| (u.id, u.team)) else { continue };
            // The owner answered for this unit, even if the answer turns out unusable.
            waiting.remove(&unit.0);
            match action_from_msg(env.world(), a) {
                Ok(action) => match env.submit(unit.1, &[action]).remove(0) {
                    Ok(()) => applied.push(a.clone()),
                    Err(e) => tracing::debug!(%agent, error = %e, "action refused by the engine"),
                },
                Err(e) => {
                    tracing::warn!(%agent, error = %e, "bad action refused");
                    c.refused_wire[unit.1.index()] += 1;
                }
            }
        }
    }
    for id in waiting {
        let ti = env.world().unit(id).map_or(0, |u| u.team.index());
        c.missing[ti] += 1;
    }
    w.command.deadline(w.orders);
    Ok(applied)
}

/// Renders and publishes each agent team's frames (best effort for viewers, reliably when
/// agent nodes read them).
struct Frames {
    spec: Option<FrameSpec>,
    pubs: Vec<(Team, FrameKind, avacraft_nodes::Publisher<avacraft_msgs::Image>)>,
    /// The same frames zero-copy through iceoryx2 for local readers, service
    /// `<namespace>/team_<n>/<kind>` (without the leading '/'); `None` where shared memory
    /// is unavailable (the Zenoh topic still carries them).
    shm: Vec<Option<avacraft_nodes::frames::FramePublisher>>,
    seq: u64,
    builder: FrameBuilder,
    cpu: CpuBackend,
}

impl Frames {
    fn new(node: &Node, topics: &Topics, teams: &[Team], spec: Option<FrameSpec>) -> Result<Frames, NodeError> {
        let mut pubs = Vec::new();
        if let Some(s) = &spec {
            // A network's frames must all arrive (each step's matches its observations); a
            // viewer's are worthless late.
            let qos = if s.for_agents { Qos::Reliable { depth: 10 } } else { Qos::BestEffort { depth: 1 } };
            for &team in teams {
                let no = TeamNo::from(team);
                for &k in &s.kinds {
                    pubs.push((team, k, node.publisher(&topics.frames(no, k), qos)?));
                }
            }
        }
        let shm = match &spec {
            Some(s) => pubs
                .iter()
                .map(|(team, k, _)| {
                    let (w, h) = match k {
                        FrameKind::Screen => s.screen,
                        FrameKind::Minimap => s.minimap,
                        FrameKind::Vlm => s.vlm,
                    };
                    let service = topics.frame_service(TeamNo::from(*team), *k);
                    let max = avacraft_nodes::frames::FrameHeader::SIZE + (w * h * 3) as usize;
                    avacraft_nodes::frames::FramePublisher::open(&service, max, 8)
                        .map_err(|e| tracing::warn!(error = %e, "no shared-memory frames; Zenoh only"))
                        .ok()
                })
                .collect(),
            None => Vec::new(),
        };
        Ok(Frames { spec, pubs, shm, seq: 0, builder: FrameBuilder::new(), cpu: CpuBackend::new() })
    }

    fn publish(&mut self, env: &Env) -> Result<(), NodeError> {
        let Some(spec) = &self.spec else { return Ok(()) };
        if !env.steps().is_multiple_of(spec.every.max(1)) {
            return Ok(());
        }
        let w = env.world();
        self.seq += 1;
        for (i, (team, kind, p)) in self.pubs.iter_mut().enumerate() {
            let ((width, height), scene) = match kind {
                FrameKind::Screen => (spec.screen, self.builder.screen(w, *team, spec.screen.0, spec.screen.1)),
                FrameKind::Minimap => (spec.minimap, self.builder.minimap(w, *team, spec.minimap.0, spec.minimap.1)),
                FrameKind::Vlm => (spec.vlm, self.builder.vlm(w, *team, spec.vlm.0, spec.vlm.1, &VlmOptions::default())),
            };
            let img = self.cpu.render(&scene);
            if let Some(Some(shm)) = self.shm.get_mut(i) {
                let h = avacraft_nodes::frames::FrameHeader::packed(
                    self.seq,
                    avacraft_nodes::now_ns(),
                    width,
                    height,
                    avacraft_nodes::frames::Encoding::Rgb8,
                );
                if let Err(e) = shm.publish(h, img.as_raw()) {
                    tracing::warn!(error = %e, "shared-memory frame dropped");
                }
            }
            p.put(&avacraft_msgs::Image {
                header: header(w, kind.name()),
                height,
                width,
                encoding: "rgb8".into(),
                is_bigendian: 0,
                step: width * 3,
                data: img.into_raw(),
            })?;
        }
        Ok(())
    }
}
