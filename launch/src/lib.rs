//! Launch files (YAML): which scenario, clock, seeds and episodes, which agent nodes own
//! which units with which policy, the recorder, and the Zenoh router. Parsed with unknown
//! fields refused, then validated into a [`Plan`]; every error names the file, the field
//! and the value.
#![forbid(unsafe_code)]

use avacraft_ava::AvaRun;
use avacraft_engine::agent::{AgentTeam, CommandedTeam, GroupRole, Grouping, RoleGroupSpec};
use avacraft_engine::{Controllers, Env, EnvConfig, Mode, OpponentKind, Scenario, Team};
mod command;
mod deploy;
pub mod policy;

pub use command::{CommanderPlan, CommanderPolicy, ROTATE_EVERY, ROTATE_POLICY};
pub use deploy::{BridgePlan, BridgeTopic, CertError, RawBridge, RawSecurity, Security, access_control, write_certs};
pub use policy::{AVA_POLICY, DDS_POLICY, MARL_PREFIX, MarlCheckpoint, PolicyError, PolicySpec};

use avacraft_nodes::{AgentId, TeamNo, UnitTag};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLaunch {
    pub scenario: String,
    #[serde(default = "lockstep")]
    pub clock: String,
    #[serde(default = "deadline")]
    pub deadline_ms: u64,
    #[serde(default = "one")]
    pub episodes: u64,
    #[serde(default = "one")]
    pub seed: u64,
    #[serde(default)]
    pub opponent: Option<String>,
    #[serde(default = "router")]
    pub router: String,
    #[serde(default)]
    pub record: Option<PathBuf>,
    #[serde(default)]
    pub frames: Option<RawFrames>,
    pub agents: Vec<RawAgent>,
    /// Host names; the first runs the router, the simulator and the recorder. Default: one
    /// host, `local`.
    #[serde(default)]
    pub hosts: Vec<String>,
    #[serde(default)]
    pub security: Option<RawSecurity>,
    #[serde(default)]
    pub bridge: Option<RawBridge>,
    /// Settings of the agents whose policy is `ava` (an agent entry may have its own).
    #[serde(default)]
    pub ava: Option<avacraft_ava::AvaSpec>,
}

/// Rendered frames the simulator publishes (`sensor_msgs/Image` per agent team).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawFrames {
    /// Any of `screen`, `minimap`, `vlm`.
    pub kinds: Vec<String>,
    #[serde(default = "screen_size")]
    pub screen: [u32; 2],
    #[serde(default = "minimap_size")]
    pub minimap: [u32; 2],
    #[serde(default = "vlm_size")]
    pub vlm: [u32; 2],
    #[serde(default = "one32")]
    pub every: u32,
}

fn screen_size() -> [u32; 2] {
    [160, 120]
}
fn minimap_size() -> [u32; 2] {
    [32, 32]
}
fn vlm_size() -> [u32; 2] {
    [1920, 1080]
}
fn one32() -> u32 {
    1
}

fn lockstep() -> String {
    "lockstep".into()
}
fn deadline() -> u64 {
    2000
}
fn one() -> u64 {
    1
}
fn router() -> String {
    "tcp/127.0.0.1:7447".into()
}

/// One agent entry: either `per_unit: true` with a `team` (one node per unit), or an `id`
/// with the unit `units` it owns (a role group).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawAgent {
    #[serde(default)]
    pub id: Option<String>,
    #[serde(default)]
    pub per_unit: bool,
    #[serde(default)]
    pub team: Option<u8>,
    #[serde(default)]
    pub units: Vec<u32>,
    /// A scripted agent's name, `marl:DIR` (a checkpoint of `avacraft train`; DIR relative
    /// to the launch file's directory, or absolute) or `dds`.
    pub policy: String,
    /// The host that runs it (default: the first). For `policy: dds`, the bridge's host.
    #[serde(default)]
    pub host: Option<String>,
    /// For `policy: ava`: this entry's settings instead of the launch file's `ava:` (in PvP,
    /// each team its own model).
    #[serde(default)]
    pub ava: Option<avacraft_ava::AvaSpec>,
    /// This entry is its `team`'s commander (policy `ava` or `rotate`): the team's units move
    /// between its role groups as the commander orders.
    #[serde(default)]
    pub commander: bool,
    /// Under a commander: this role group's role (attacker, defender, scout or support).
    #[serde(default)]
    pub role: Option<String>,
}

/// The clock of the simulator node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockMode {
    Lockstep,
    RealTime,
}

/// One agent node to start.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AgentPlan {
    pub id: AgentId,
    pub team: TeamNo,
    pub units: Vec<UnitTag>,
    /// Checked against the scenario and the node's team at parse time.
    pub policy: PolicySpec,
    pub host: String,
    /// Under a commander: the group's role (its `units` are those it starts with).
    pub role: Option<GroupRole>,
}

impl AgentPlan {
    /// Driven over DDS through the bridge rather than by an agent node of ours.
    pub fn is_dds(&self) -> bool {
        self.policy.is_dds()
    }
}

/// A validated launch file.
#[derive(Clone, Debug)]
pub struct Plan {
    pub file: String,
    pub scenario_arg: String,
    pub scenario: Arc<Scenario>,
    pub clock: ClockMode,
    pub deadline: Duration,
    pub seeds: Vec<u64>,
    pub opponent: Option<OpponentKind>,
    pub router: String,
    pub record: Option<PathBuf>,
    pub frames: Option<FramePlan>,
    pub agents: Vec<AgentPlan>,
    /// Teams under a commander (at most one per team).
    pub commanders: Vec<CommanderPlan>,
    /// Never empty; the first runs the router, the simulator and the recorder.
    pub hosts: Vec<String>,
    pub security: Option<Security>,
    pub bridge: Option<BridgePlan>,
}

/// Validated frame settings.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePlan {
    pub kinds: Vec<avacraft_nodes::FrameKind>,
    pub screen: (u32, u32),
    pub minimap: (u32, u32),
    pub vlm: (u32, u32),
    pub every: u32,
}

impl Plan {
    /// The environment the simulator node runs: the engine's default rules and the plan's
    /// opponent. In-process runs of the plan use the same, so their games are the deployment's.
    pub fn env_config(&self) -> EnvConfig {
        EnvConfig { opponent: self.opponent, ..EnvConfig::default() }
    }

    /// The plan's agent nodes as in-process agents: one agent per node, owning the node's
    /// units, with the node's policy and seed (see [`avacraft_engine::agent::agent_seed`]),
    /// so `episode --launch` plays the games the lockstep deployment plays. Agents driven from
    /// DDS have no in-process counterpart.
    pub fn controllers(&self) -> Result<Controllers, LaunchError> {
        self.controllers_and_runs().map(|(c, _)| c)
    }

    /// [`Plan::controllers`], and the run (calls, tokens, dollars) of each AVA node, in the
    /// file's order: what `avacraft episode --launch` reports.
    pub fn controllers_and_runs(&self) -> Result<(Controllers, NodeRuns), LaunchError> {
        let mut teams = Vec::new();
        let mut commanded = Vec::new();
        let mut runs = Vec::new();
        for c in &self.commanders {
            let (make, run) =
                c.policy.factory_run(c.id.as_str(), None).map_err(|e| Cx(&self.file).policy_err("agents", &c.policy.to_string(), e))?;
            runs.extend(run.map(|r| (c.id.clone(), r)));
            let mut groups = Vec::new();
            for (i, a) in self.agents.iter().enumerate().filter(|(_, a)| a.team == c.team) {
                let (make, run) = a
                    .policy
                    .factory_run(a.id.as_str(), None)
                    .map_err(|e| Cx(&self.file).policy_err(format!("agents[{i}].policy"), &a.policy.to_string(), e))?;
                runs.extend(run.map(|r| (a.id.clone(), r)));
                groups.push(RoleGroupSpec { role: a.role.unwrap_or_default(), initial: a.units.iter().map(|u| u.get()).collect(), make });
            }
            commanded.push(CommandedTeam::new(c.team.team(), make, groups));
        }
        for (i, a) in self.agents.iter().enumerate().filter(|(_, a)| !self.commanders.iter().any(|c| c.team == a.team)) {
            let (make, run) = a
                .policy
                .factory_run(a.id.as_str(), None)
                .map_err(|e| Cx(&self.file).policy_err(format!("agents[{i}].policy"), &a.policy.to_string(), e))?;
            runs.extend(run.map(|r| (a.id.clone(), r)));
            teams.push(AgentTeam::new(a.team.team(), Grouping::Groups(vec![a.units.iter().map(|u| u.get()).collect()]), make));
        }
        Ok((Controllers::new(&self.scenario, teams).with_commanded(&self.scenario, commanded), runs))
    }

    /// The host that runs the router, the simulator and the recorder.
    pub fn server(&self) -> &str {
        &self.hosts[0]
    }

    /// Unit tag to owning agent, for the simulator node.
    pub fn owners(&self) -> BTreeMap<UnitTag, AgentId> {
        self.agents.iter().flat_map(|a| a.units.iter().map(move |u| (*u, a.id.clone()))).collect()
    }
}

/// Each AVA node's run (its calls, tokens and dollars), by node.
pub type NodeRuns = Vec<(AgentId, Arc<AvaRun>)>;

/// Why a launch file was refused.
#[derive(Debug, Clone, thiserror::Error)]
pub enum LaunchError {
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    #[error("{file}: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: field `{field}` = {value}: {reason}")]
    Invalid { file: String, field: String, value: String, reason: String },
    /// A policy refused (a checkpoint missing, unreadable or trained for something else);
    /// the source says why.
    #[error("{file}: field `{field}` = {value}")]
    Policy {
        file: String,
        field: String,
        value: String,
        #[source]
        source: Arc<PolicyError>,
    },
}

pub(crate) struct Cx<'a>(&'a str);

impl Cx<'_> {
    pub(crate) fn err(&self, field: impl Into<String>, value: impl std::fmt::Display, reason: impl Into<String>) -> LaunchError {
        LaunchError::Invalid { file: self.0.to_owned(), field: field.into(), value: value.to_string(), reason: reason.into() }
    }
    pub(crate) fn policy_err(&self, field: impl Into<String>, value: &str, e: PolicyError) -> LaunchError {
        LaunchError::Policy { file: self.0.to_owned(), field: field.into(), value: format!("{value:?}"), source: Arc::new(e) }
    }
}

/// Reads and validates a launch file.
pub fn load(path: &Path) -> Result<Plan, LaunchError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| LaunchError::Io { file: file.clone(), message: e.to_string() })?;
    parse(&file, &text, path.parent())
}

/// Parses launch text; `base` resolves relative scenario paths.
pub fn parse(file: &str, text: &str, base: Option<&Path>) -> Result<Plan, LaunchError> {
    let raw: RawLaunch = serde_norway::from_str(text).map_err(|e| LaunchError::Syntax { file: file.to_owned(), message: e.to_string() })?;
    validate(file, raw, base)
}

fn validate(file: &str, raw: RawLaunch, base: Option<&Path>) -> Result<Plan, LaunchError> {
    let cx = Cx(file);
    let scenario_arg = match base.map(|b| b.join(&raw.scenario)) {
        Some(p) if p.exists() => p.display().to_string(),
        _ => raw.scenario.clone(),
    };
    let scenario = Scenario::load(&scenario_arg).map_err(|e| cx.err("scenario", format!("{:?}", raw.scenario), e.to_string()))?;
    let clock = match raw.clock.as_str() {
        "lockstep" => ClockMode::Lockstep,
        "realtime" => ClockMode::RealTime,
        other => return Err(cx.err("clock", format!("{other:?}"), "must be `lockstep` or `realtime`")),
    };
    if !(1..=600_000).contains(&raw.deadline_ms) {
        return Err(cx.err("deadline_ms", raw.deadline_ms, "must be 1 to 600000 milliseconds"));
    }
    if !(1..=1_000_000).contains(&raw.episodes) {
        return Err(cx.err("episodes", raw.episodes, "must be 1 to 1000000"));
    }
    let opponent = match &raw.opponent {
        None => None,
        Some(o) if scenario.mode == Mode::Pvp => {
            return Err(cx.err("opponent", format!("{o:?}"), "a PvP scenario has agent nodes on both teams"));
        }
        Some(o) => Some(o.parse::<OpponentKind>().map_err(|e| cx.err("opponent", format!("{o:?}"), e))?),
    };
    let hosts = if raw.hosts.is_empty() { vec!["local".to_owned()] } else { raw.hosts.clone() };
    for (i, h) in hosts.iter().enumerate() {
        if !deploy::valid_host(h) {
            return Err(cx.err(
                format!("hosts[{i}]"),
                format!("{h:?}"),
                "must be 1 to 32 lowercase letters, digits or '_', starting with a letter",
            ));
        }
        if hosts[..i].contains(h) {
            return Err(cx.err(format!("hosts[{i}]"), format!("{h:?}"), "named twice"));
        }
    }
    let security = raw.security.as_ref().map(|s| deploy::security(s, base));
    if hosts.len() > 1 && security.is_none() {
        return Err(cx.err("hosts", format!("{hosts:?}"), "a deployment across hosts needs `security:` (TLS and access control)"));
    }
    match (raw.router.split_once('/').map(|(p, _)| p), &security) {
        (Some("tcp"), None) | (Some("tls"), Some(_)) => {}
        (Some("tcp"), Some(_)) => {
            return Err(cx.err("router", format!("{:?}", raw.router), "with `security:` the router must be a tls/ endpoint"));
        }
        (Some("tls"), None) => {
            return Err(cx.err("router", format!("{:?}", raw.router), "a tls/ router needs a `security:` section with the certificates"));
        }
        _ => {
            return Err(cx.err(
                "router",
                format!("{:?}", raw.router),
                "must be a Zenoh endpoint such as tcp/127.0.0.1:7447 or tls/10.0.0.1:7447",
            ));
        }
    }
    let (addr, port) = raw
        .router
        .split_once('/')
        .and_then(|(_, rest)| rest.rsplit_once(':'))
        .map(|(a, p)| (a.trim_start_matches('[').trim_end_matches(']'), p.split('#').next().unwrap_or(p)))
        .unwrap_or(("", ""));
    if addr.is_empty() || port.parse::<u16>().is_err() {
        return Err(cx.err("router", format!("{:?}", raw.router), "must be <protocol>/<address>:<port>"));
    }
    if hosts.len() > 1 {
        let ip = addr.parse::<std::net::IpAddr>().ok();
        if addr == "localhost" || ip.is_some_and(|ip| ip.is_loopback() || ip.is_unspecified()) {
            return Err(cx.err(
                "router",
                format!("{:?}", raw.router),
                "other hosts connect here: it must be the first host's address on their network",
            ));
        }
    }
    let frames = match &raw.frames {
        None => None,
        Some(f) => {
            let mut kinds = Vec::new();
            for (i, k) in f.kinds.iter().enumerate() {
                kinds.push(match k.as_str() {
                    "screen" => avacraft_nodes::FrameKind::Screen,
                    "minimap" => avacraft_nodes::FrameKind::Minimap,
                    "vlm" => avacraft_nodes::FrameKind::Vlm,
                    other => return Err(cx.err(format!("frames.kinds[{i}]"), format!("{other:?}"), "must be screen, minimap or vlm")),
                });
            }
            for (name, [w, h]) in [("screen", f.screen), ("minimap", f.minimap), ("vlm", f.vlm)] {
                if !(1..=4096).contains(&w) || !(1..=4096).contains(&h) {
                    return Err(cx.err(format!("frames.{name}"), format!("[{w}, {h}]"), "width and height must be 1 to 4096"));
                }
            }
            if f.every == 0 {
                return Err(cx.err("frames.every", 0, "must be at least 1"));
            }
            let p = |s: [u32; 2]| (s[0], s[1]);
            Some(FramePlan { kinds, screen: p(f.screen), minimap: p(f.minimap), vlm: p(f.vlm), every: f.every })
        }
    };
    let scenario = Arc::new(scenario);
    let env = Env::new(Arc::clone(&scenario), EnvConfig::default(), 0);
    let agent_team = |t: Team| env.is_agent_team(t);
    let mut agents = Vec::new();
    let mut fields: Vec<String> = Vec::new();
    let mut commanders: Vec<CommanderPlan> = Vec::new();
    let mut owner: BTreeMap<u32, String> = BTreeMap::new();
    if raw.agents.is_empty() {
        return Err(cx.err("agents", "[]", "at least one agent node is needed"));
    }
    for (i, a) in raw.agents.iter().enumerate() {
        let f = |name: &str| format!("agents[{i}].{name}");
        // Agent nodes run the engine's agents (the same ones `episode` runs in-process); a
        // checkpoint is loaded once here for all the nodes of the entry.
        let policy = if a.commander && a.policy == ROTATE_POLICY {
            PolicySpec::Scripted(ROTATE_POLICY)
        } else if a.policy == AVA_POLICY {
            let mut spec = a
                .ava
                .clone()
                .or_else(|| raw.ava.clone())
                .ok_or_else(|| cx.policy_err(f("policy"), &a.policy, PolicyError::AvaWithoutSpec))?;
            if let Some(b) = base {
                spec.resolve(b);
            }
            let field = if a.ava.is_some() { f("ava") } else { "ava".to_owned() };
            PolicySpec::ava(spec).map_err(|e| cx.policy_err(field, &a.policy, e))?
        } else {
            if a.ava.is_some() {
                return Err(cx.err(f("ava"), "{..}", "AVA settings go with `policy: ava`"));
            }
            // A shipped baseline becomes this scenario's checkpoint here, so every child
            // process is handed the checkpoint itself.
            PolicySpec::parse(&a.policy, base).and_then(|p| p.on(&scenario)).map_err(|e| cx.policy_err(f("policy"), &a.policy, e))?
        };
        let first_new = agents.len();
        let host = a.host.clone().unwrap_or_else(|| hosts[0].clone());
        if !hosts.contains(&host) {
            return Err(cx.err(f("host"), format!("{host:?}"), format!("not one of the hosts {hosts:?}")));
        }
        if a.commander {
            if a.per_unit || !a.units.is_empty() || a.role.is_some() {
                return Err(cx.err(f("commander"), "true", "a commander takes an `id` and a `team`, not `units`, `per_unit` or `role`"));
            }
            let Some(id) = a.id.clone() else { return Err(cx.err(f("id"), "none", "a commander needs an `id`")) };
            let id = AgentId::parse(&id).map_err(|e| cx.err(f("id"), format!("{id:?}"), e.to_string()))?;
            let team = match a.team {
                Some(1) => Team::One,
                Some(2) => Team::Two,
                other => return Err(cx.err(f("team"), format!("{other:?}"), "must be 1 or 2")),
            };
            if !agent_team(team) {
                return Err(cx.err(f("team"), team.player(), "the opponent policy drives this team"));
            }
            let team = TeamNo::new(team.player()).map_err(|e| cx.err(f("team"), team.player(), e.to_string()))?;
            if commanders.iter().any(|c| c.team == team) {
                return Err(cx.err(f("team"), team.get(), "the team has a commander already"));
            }
            if commanders.iter().any(|c| c.id == id) || agents.iter().any(|x: &AgentPlan| x.id == id) {
                return Err(cx.err(f("id"), &id, "two agent nodes share this id"));
            }
            let policy = match policy {
                PolicySpec::Ava(spec) => CommanderPolicy::Ava(spec),
                PolicySpec::Scripted(ROTATE_POLICY) => CommanderPolicy::Rotate,
                _ => {
                    return Err(cx.err(
                        f("policy"),
                        format!("{:?}", a.policy),
                        format!("a commander's policy is {AVA_POLICY} or {ROTATE_POLICY}"),
                    ));
                }
            };
            commanders.push(CommanderPlan { id, team, policy, host, groups: Vec::new() });
            continue;
        }
        let role = a.role.as_deref().map(|r| command::role(&cx, f("role"), r)).transpose()?;
        if role.is_some() && a.per_unit {
            return Err(cx.err(
                f("role"),
                a.role.as_deref().unwrap_or_default(),
                "a role group names its `id` and `units`, not `per_unit`",
            ));
        }
        let mut add = |id: String, tags: Vec<u32>, field: String| -> Result<(), LaunchError> {
            let agent = AgentId::parse(&id).map_err(|e| cx.err(field.clone(), format!("{id:?}"), e.to_string()))?;
            let mut units = Vec::new();
            let mut team: Option<Team> = None;
            for t in tags {
                let u =
                    t.checked_sub(1).and_then(|i| u16::try_from(i).ok()).and_then(|i| env.world().unit(avacraft_engine::UnitId::new(i)));
                let Some(u) = u else {
                    return Err(cx.err(
                        f("units"),
                        t,
                        format!("no unit has this tag ({} has tags 1 to {})", scenario.name, scenario.units.len()),
                    ));
                };
                if !agent_team(u.team) {
                    return Err(cx.err(f("units"), t, format!("{} belongs to {}, which the opponent policy drives", u.name(), u.team)));
                }
                if team.is_some_and(|x| x != u.team) {
                    return Err(cx.err(f("units"), t, format!("{} belongs to {}; one agent node plays for one team", u.name(), u.team)));
                }
                team = Some(u.team);
                if let Some(prev) = owner.insert(t, id.clone()) {
                    return Err(cx.err(f("units"), t, format!("already owned by agent node `{prev}`")));
                }
                units.push(UnitTag::new(t).map_err(|e| cx.err(f("units"), t, e.to_string()))?);
            }
            if agents.iter().any(|x: &AgentPlan| x.id == agent) {
                return Err(cx.err(field, format!("{id:?}"), "two agent nodes share this id"));
            }
            let team = team
                .and_then(|t| TeamNo::new(t.player()).ok())
                .ok_or_else(|| cx.err(f("units"), "[]", "an agent node needs at least one unit"))?;
            if commanders.iter().any(|c| c.id == agent) {
                return Err(cx.err(field, format!("{id:?}"), "two agent nodes share this id"));
            }
            agents.push(AgentPlan { id: agent, team, units, policy: policy.clone(), host: host.clone(), role: None });
            Ok(())
        };
        if a.per_unit {
            if a.id.is_some() || !a.units.is_empty() {
                return Err(cx.err(f("per_unit"), "true", "takes a `team`, not an `id` or `units`"));
            }
            let team = match a.team {
                Some(1) => Team::One,
                Some(2) => Team::Two,
                other => return Err(cx.err(f("team"), format!("{other:?}"), "must be 1 or 2")),
            };
            for &id in env.agents(team) {
                let tag = id.tag();
                add(format!("unit_{tag}"), vec![tag], f("team"))?;
            }
        } else {
            let Some(id) = a.id.clone() else { return Err(cx.err(f("id"), "none", "an agent node needs an `id` (or `per_unit: true`)")) };
            if let Some(t) = a.team {
                return Err(cx.err(f("team"), t, "a role group names its `units`; `team` goes with `per_unit: true`"));
            }
            if a.units.is_empty() {
                return Err(cx.err(f("units"), "[]", "an agent node needs at least one unit"));
            }
            add(id, a.units.clone(), f("id"))?;
        }
        for ag in &mut agents[first_new..] {
            policy.check(&scenario, ag.team.team()).map_err(|e| cx.policy_err(f("policy"), &a.policy, e))?;
            ag.role = role;
            fields.push(format!("agents[{i}]"));
        }
    }
    command::link(&cx, &mut commanders, &agents, &fields)?;
    let bridge = match &raw.bridge {
        None => {
            if let Some(a) = agents.iter().position(|a| a.is_dds()) {
                return Err(cx.err(format!("agents[{a}].policy"), DDS_POLICY, "agents driven from DDS need a `bridge:` section"));
            }
            None
        }
        Some(b) => {
            let plan = deploy::bridge_plan(&cx, b, &hosts, &agents)?;
            if let Some(a) = agents.iter().find(|a| a.is_dds() && a.host != plan.host) {
                return Err(cx.err(
                    "bridge.host",
                    format!("{:?}", plan.host),
                    format!("agent `{}` (policy dds) is on host `{}`; DDS agents live on the bridge's host", a.id, a.host),
                ));
            }
            Some(plan)
        }
    };
    if raw.seed.checked_add(raw.episodes).is_none() {
        return Err(cx.err("seed", raw.seed, format!("seed + episodes ({}) overflows", raw.episodes)));
    }
    Ok(Plan {
        file: file.to_owned(),
        scenario_arg,
        scenario,
        clock,
        deadline: Duration::from_millis(raw.deadline_ms),
        seeds: (0..raw.episodes).map(|k| raw.seed + k).collect(),
        opponent,
        router: raw.router,
        record: raw.record,
        frames,
        agents,
        commanders,
        hosts,
        security,
        bridge,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_good_file_becomes_a_plan() {
        let p = parse("t.yaml", "scenario: 3m\nepisodes: 2\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n", None)
            .expect("plan");
        assert_eq!(p.agents.len(), 3);
        assert_eq!(p.seeds, vec![1, 2]);
        assert_eq!(p.owners().len(), 3);
        assert_eq!(p.agents[0].id.as_str(), "unit_3".replace('3', &p.agents[0].units[0].get().to_string()));
    }

    #[test]
    fn errors_name_file_field_and_value() {
        let cases = [
            ("scenario: nope\nagents: []\n", "scenario"),
            ("scenario: 3m\nclock: fast\nagents:\n  - {per_unit: true, team: 1, policy: noop}\n", "clock"),
            ("scenario: 3m\nagents:\n  - {id: a, units: [9], policy: noop}\n", "agents[0].units"),
            ("scenario: 3m\nagents:\n  - {id: a, units: [1], policy: dance}\n", "agents[0].policy"),
            ("scenario: 3m\nagents:\n  - {id: a, units: [1], policy: noop}\n  - {id: b, units: [1], policy: noop}\n", "agents[1].units"),
            ("scenario: 3m\nagents:\n  - {id: A, units: [1], policy: noop}\n", "agents[0].id"),
            ("scenario: 3m\ncolour: red\nagents: []\n", "colour"),
            ("scenario: 3m\nagents:\n  - {per_unit: true, team: 2, policy: noop}\n", "agents[0].units"),
            ("scenario: 3m\nagents:\n  - {id: a, team: 1, units: [1], policy: noop}\n", "agents[0].team"),
            ("scenario: 3m\nagents:\n  - {id: a, units: [1], policy: ava}\n", "agents[0].policy"),
            ("scenario: 3m\nagents:\n  - {id: a, units: [1], policy: noop, ava: {model: {kind: synthetic}}}\n", "agents[0].ava"),
            ("scenario: 3m\nava: {model: {kind: openai, url: ftp://x, model: m}}\nagents:\n  - {id: a, units: [1], policy: ava}\n", "ava"),
            (
                "scenario: 3m\nava: {model: {kind: synthetic}, config: {decide_every: 0}}\nagents:\n  - {id: a, units: [1], policy: ava}\n",
                "ava",
            ),
            (
                "scenario: 3m\nava: {model: {kind: synthetic}, config: {planer: false}}\nagents:\n  - {id: a, units: [1], policy: ava}\n",
                "planer",
            ),
            ("scenario: 3m\nava: {model: {kind: gpt}}\nagents:\n  - {id: a, units: [1], policy: ava}\n", "gpt"),
        ];
        for (text, field) in cases {
            let e = parse("bad.yaml", text, None).expect_err(text).to_string();
            assert!(e.starts_with("bad.yaml") && e.contains(field), "{text}: {e}");
        }
    }

    #[test]
    fn ava_settings_come_from_the_file_or_the_entry() {
        let text = "scenario: 8m3mr1mv1st_mirror_pvp\nava: {model: {kind: synthetic}, record: calls}\nagents:\n  - {id: blue, units: [1, 2], policy: ava}\n  - {id: red, units: [14], policy: ava, ava: {model: {kind: replay, dir: old}, config: {roles: false}}}\n";
        let p = parse("pvp.yaml", text, Some(Path::new("/base"))).expect("plan");
        let spec = |i: usize| match &p.agents[i].policy {
            PolicySpec::Ava(s) => s.clone(),
            other => panic!("{other:?}"),
        };
        assert_eq!(spec(0).model, avacraft_ava::ModelSpec::Synthetic);
        assert_eq!(spec(0).record.as_deref(), Some(Path::new("/base/calls")), "paths are resolved against the launch file");
        assert_eq!(spec(1).model, avacraft_ava::ModelSpec::Replay { dir: PathBuf::from("/base/old") });
        assert!(!spec(1).config.roles && spec(0).config.roles);
        assert_eq!(p.agents[1].policy.to_string(), "ava");
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_text_never_panics(s in "\\PC{0,200}") {
            let _ = parse("fuzz.yaml", &s, None);
        }
    }
}

#[cfg(test)]
mod deploy_tests {
    use super::*;

    fn pvp(extra: &str) -> String {
        format!(
            "scenario: MMM_vs_MMM\nrouter: tls/10.0.0.1:7447\nsecurity: {{certs: certs}}\nhosts: [server, blue, red]\nagents:\n  - {{id: blue_a, units: [1, 2], policy: hold, host: blue}}\n  - {{id: red_a, units: [13], policy: hold, host: red}}\n{extra}"
        )
    }

    #[test]
    fn the_shipped_launch_files_validate() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut n = 0;
        for entry in std::fs::read_dir(dir).expect("launch dir") {
            let p = entry.expect("entry").path();
            if p.extension().is_some_and(|e| e == "yaml") {
                load(&p).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
        assert!(n >= 5, "{n} launch files");
    }

    #[test]
    fn hosts_security_and_bridge_are_validated_with_file_field_and_value() {
        let ok = parse("p.yaml", &pvp(""), None).expect("plan");
        assert_eq!((ok.server(), ok.agents[0].host.as_str(), ok.agents[1].team.get()), ("server", "blue", 2));
        let cases = [
            (pvp("").replace("tls/", "tcp/"), "router"),
            (pvp("").replace("security: {certs: certs}\n", ""), "hosts"),
            (pvp("").replace("hosts: [server, blue, red]", "hosts: [server, Blue]"), "hosts[1]"),
            (pvp("").replace("hosts: [server, blue, red]", "hosts: [server, blue, blue]"), "hosts[2]"),
            (pvp("").replace("host: red", "host: green"), "agents[1].host"),
            (pvp("").replace("units: [1, 2]", "units: [1, 13]"), "agents[0].units"),
            (pvp("bridge: {topics: [everything]}\n"), "bridge.topics[0]"),
            (pvp("bridge: {host: nowhere}\n"), "bridge.host"),
            (pvp("bridge: {frame_size: [0, 10]}\n"), "bridge.frame_size"),
            (pvp("bridge: {dds_networks: [localhost]}\n"), "bridge.dds_networks[0]"),
            (pvp("bridge: {dds_domain: 300}\n"), "bridge.dds_domain"),
            (pvp("").replace("policy: hold, host: blue", "policy: dds, host: blue"), "agents[0].policy"),
            (pvp("bridge: {host: server, teams: [1]}\n").replace("policy: hold, host: blue", "policy: dds, host: blue"), "bridge.host"),
            ("scenario: 3m\nhosts: [a, b]\nagents:\n  - {id: x, units: [1], policy: hold}\n".to_owned(), "hosts"),
            (pvp("").replace("tls/10.0.0.1:7447", "tls/127.0.0.1:7447"), "router"),
            (pvp("").replace("tls/10.0.0.1:7447", "tls/0.0.0.0:7447"), "router"),
            (pvp("").replace("tls/10.0.0.1:7447", "tls/10.0.0.1"), "router"),
            // A bridge on blue may carry only blue's team, once, and not both teams' roles.
            (pvp("bridge: {host: blue, teams: [2]}\n"), "bridge.teams[0]"),
            (pvp("bridge: {teams: [1, 1]}\n"), "bridge.teams[1]"),
            (pvp("bridge: {host: red, topics: [roles]}\n"), "bridge.topics"),
            // DDS agents: one team per bridge, bridged, with observations.
            (pvp("bridge: {}\n").replace("policy: hold, host: blue", "policy: dds"), "bridge.teams"),
            (pvp("bridge: {teams: [2]}\n").replace("policy: hold, host: blue", "policy: dds"), "bridge.teams"),
            (pvp("bridge: {teams: [1], topics: [status]}\n").replace("policy: hold, host: blue", "policy: dds"), "bridge.topics"),
        ];
        for (text, field) in cases {
            let e = parse("bad.yaml", &text, None).expect_err(&text).to_string();
            assert!(e.starts_with("bad.yaml: field `") && e.contains(&format!("`{field}`")), "{field}: {e}");
        }
    }

    fn rule<'a>(acl: &'a serde_json::Value, id: &str) -> &'a serde_json::Value {
        acl["rules"].as_array().and_then(|r| r.iter().find(|r| r["id"] == id)).unwrap_or_else(|| panic!("no rule {id}: {acl}"))
    }

    #[test]
    fn access_control_gives_each_host_its_own_actions_and_its_teams_topics() {
        let plan = parse("p.yaml", &pvp("bridge: {host: red, topics: [status, team_obs]}\n"), None).expect("plan");
        assert_eq!(
            plan.bridge.as_ref().map(|b| b.teams.clone()),
            Some(vec![TeamNo::new(2).expect("team")]),
            "a team host's bridge defaults to its team"
        );
        assert_eq!(
            plan.bridge.as_ref().map(|b| b.dds_networks.clone()),
            Some(vec!["127.0.0.1".parse().expect("ip")]),
            "DDS stays on the machine by default"
        );
        let acl = access_control(&plan, &avacraft_nodes::Topics::default(), 0);
        assert_eq!(acl["default_permission"], "deny");
        assert_eq!(rule(&acl, "server_all")["key_exprs"], serde_json::json!(["**", "@ros2_lv/0/**"]));
        assert_eq!(rule(&acl, "blue_send")["key_exprs"], serde_json::json!(["0/avacraft/agents/blue_a/actions/**"]));
        assert_eq!(rule(&acl, "blue_receive")["key_exprs"], serde_json::json!(["0/avacraft/team_1/**", "0/avacraft/status/**"]));
        assert_eq!(rule(&acl, "blue_receive")["flows"], serde_json::json!(["egress"]));
        // The bridge on red carries only team 2.
        assert_eq!(rule(&acl, "red_receive")["key_exprs"], serde_json::json!(["0/avacraft/team_2/**", "0/avacraft/status/**"]));
        // The graph: blue announces only its own nodes and learns only of the simulator.
        assert_eq!(
            rule(&acl, "blue_announce")["key_exprs"],
            serde_json::json!([
                "@ros2_lv/0/*/*/*/*/*/%avacraft/agent_blue_a",
                "@ros2_lv/0/*/*/*/*/*/%avacraft/agent_blue_a/**",
                "@ros2_lv/0/*/*/*/*/*/%avacraft/launch_blue",
                "@ros2_lv/0/*/*/*/*/*/%avacraft/launch_blue/**"
            ])
        );
        assert_eq!(rule(&acl, "blue_sim_up")["key_exprs"], serde_json::json!(["@ros2_lv/0/*/*/*/*/*/%avacraft/sim"]));
        assert!(rule(&acl, "red_announce").to_string().contains("%avacraft/bridge"));
        let subjects = acl["subjects"].as_array().expect("subjects");
        assert_eq!(
            subjects.iter().map(|s| s["cert_common_names"][0].as_str().unwrap_or("")).collect::<Vec<_>>(),
            ["server", "blue", "red"]
        );
        // No rule of a team host names another team's prefix.
        let blue_rules: Vec<_> =
            acl["rules"].as_array().expect("rules").iter().filter(|r| r["id"].as_str().is_some_and(|i| i.starts_with("blue"))).collect();
        assert!(blue_rules.iter().all(|r| !r.to_string().contains("team_2")), "{blue_rules:?}");
        // And it is a configuration Zenoh accepts.
        let mut c = zenoh::Config::default();
        c.insert_json5("access_control", &acl.to_string()).expect("zenoh accepts the access control");
    }

    #[test]
    fn certificates_name_each_host_and_the_router_address() {
        let dir = std::env::temp_dir().join(format!("avacraft-certs-{}", std::process::id()));
        let plan = parse("p.yaml", &pvp("").replace("certs: certs", &format!("certs: {}", dir.display())), None).expect("plan");
        let files = write_certs(&plan).expect("certs");
        assert_eq!(files.len(), 1 + 2 * 3);
        let sec = plan.security.as_ref().expect("security");
        for h in ["server", "blue", "red"] {
            let pem = std::fs::read_to_string(sec.cert(h)).expect("cert");
            assert!(pem.starts_with("-----BEGIN CERTIFICATE-----"));
            assert!(std::fs::read_to_string(sec.key(h)).expect("key").contains("PRIVATE KEY"));
        }
        let without = parse("p.yaml", "scenario: 3m\nagents:\n  - {id: x, units: [1], policy: hold}\n", None).expect("plan");
        assert!(matches!(write_certs(&without), Err(CertError::NoSecurity)));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
