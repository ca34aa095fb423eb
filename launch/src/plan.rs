//! What a launch file says, checked: the plan every process of a deployment works from
//! (the launcher, the simulator, each agent node, the bridge), and the raw file it is read
//! from. The types only; `validate.rs` builds them.

use crate::error::{Cx, LaunchError};
use avacraft_ava::AvaRun;
use avacraft_engine::agent::{AgentTeam, CommandedTeam, GroupRole, Grouping, RoleGroupSpec};
use avacraft_engine::{Controllers, EnvConfig, OpponentKind, Scenario, UnitId};
use avacraft_nodes::{AgentId, TeamNo, UnitTag};
use avacraft_policy::{Calls, CommanderPolicy, PolicySpec};
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLaunch {
    pub scenario: String,
    /// The unit data to play on (`liberty`, `void`, `ladder`, `legacy`); default: the
    /// scenario's own.
    #[serde(default)]
    pub data: Option<String>,
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
    /// Environment options besides `opponent` and `data` (`step_mul`, `full_vision`,
    /// `time_limit_loops`, ...: the Python keyword names), over a deployment's defaults
    /// (sparse reward, no passive side).
    #[serde(default)]
    pub env: Option<serde_json::Value>,
    /// Agent nodes of one image network on a team share an encoder node, which runs the
    /// network's image encoder once a step for all of them (`false`: each runs it).
    #[serde(default = "yes")]
    pub share_encoder: bool,
    #[serde(default = "router")]
    pub router: String,
    #[serde(default)]
    pub record: Option<PathBuf>,
    /// Who writes `record`: `recorder`, a node of its own subscribed to every topic (what
    /// survives a killed simulator), or `simulator`, the simulator writing what it sends and
    /// receives (no second subscriber to each of its messages, so nearly free).
    #[serde(default)]
    pub record_by: RecordBy,
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

/// Who writes a launch's recording.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RecordBy {
    #[default]
    Recorder,
    Simulator,
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

fn yes() -> bool {
    true
}
fn screen_size() -> [u32; 2] {
    [160, 120]
}
fn minimap_size() -> [u32; 2] {
    [32, 32]
}
pub(crate) fn vlm_size() -> [u32; 2] {
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
    /// An image network served by its team's encoder node ([`EncoderPlan`]): it acts on the
    /// encoder's output instead of running the encoder on the frames itself.
    pub encoded: bool,
}

/// A team's encoder node: it runs an image network's encoder on the team's frames once a
/// step, for the team's agent nodes of that network, which would otherwise run it each.
#[derive(Clone, Debug)]
pub struct EncoderPlan {
    pub id: AgentId,
    pub team: TeamNo,
    pub policy: PolicySpec,
    pub host: String,
}

impl AgentPlan {
    /// Driven over DDS through the bridge rather than by an agent node of ours.
    pub fn is_dds(&self) -> bool {
        self.policy.is_dds()
    }

    /// The node's agents as the file makes them (AVA records under `record/<id>`), with
    /// AVA's run; a refusal names the entry `i`.
    fn make(&self, cx: &Cx<'_>, i: usize) -> Result<(avacraft_policy::AgentFactory, Option<Arc<AvaRun>>), LaunchError> {
        let made = self
            .policy
            .make(&Calls::Under(self.id.to_string()), None)
            .map_err(|e| cx.policy_err(format!("agents[{i}].policy"), &self.policy.to_string(), e))?;
        Ok((made.factory, made.run))
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
    /// The environment the simulator node runs: the engine's `EnvOptions` with the plan's
    /// opponent and the engine's default rules (sparse reward, no passive side), checked.
    pub env: EnvConfig,
    pub router: String,
    pub record: Option<PathBuf>,
    pub record_by: RecordBy,
    pub frames: Option<FramePlan>,
    pub agents: Vec<AgentPlan>,
    /// Teams under a commander (at most one per team).
    pub commanders: Vec<CommanderPlan>,
    /// Encoder nodes (`share_encoder`, on by default): one per team, network and host that
    /// has two or more agent nodes of an image network.
    pub encoders: Vec<EncoderPlan>,
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
    /// Agent nodes read them (an image-mode network): every frame is delivered, as the
    /// observations are, instead of the newest only.
    pub for_agents: bool,
}

impl Plan {
    /// The environment the simulator node runs: the engine's default rules and the plan's
    /// opponent. In-process runs of the plan use the same, so their games are the deployment's.
    pub fn env_config(&self) -> EnvConfig {
        self.env.clone()
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
        let cx = Cx(&self.file);
        for c in &self.commanders {
            let made =
                c.policy.make(&Calls::Under(c.id.to_string()), None).map_err(|e| cx.policy_err("agents", &c.policy.to_string(), e))?;
            runs.extend(made.run.map(|r| (c.id.clone(), r)));
            let mut groups = Vec::new();
            for (i, a) in self.agents.iter().enumerate().filter(|(_, a)| a.team == c.team) {
                let (make, run) = a.make(&cx, i)?;
                runs.extend(run.map(|r| (a.id.clone(), r)));
                groups.push(RoleGroupSpec {
                    role: a.role.unwrap_or_default(),
                    initial: a.units.iter().map(|&u| UnitId::from(u)).collect(),
                    make: Box::new(move || make()),
                });
            }
            commanded.push(CommandedTeam::new(c.team.team(), made.factory, groups));
        }
        for (i, a) in self.agents.iter().enumerate().filter(|(_, a)| !self.commanders.iter().any(|c| c.team == a.team)) {
            let (make, run) = a.make(&cx, i)?;
            runs.extend(run.map(|r| (a.id.clone(), r)));
            teams.push(AgentTeam::new(
                a.team.team(),
                Grouping::Groups(vec![a.units.iter().map(|&u| UnitId::from(u)).collect()]),
                move || make(),
            ));
        }
        let mut controllers = Controllers::new(&self.scenario, teams).with_commanded(&self.scenario, commanded);
        if self.frames.as_ref().is_some_and(|f| f.for_agents) {
            // Drawn as the simulator node draws its frame topics.
            controllers = controllers.with_frames(Box::new(avacraft_render::FramePainter::new()));
        }
        Ok((controllers, runs))
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

/// A team's commander node.
#[derive(Clone, Debug, PartialEq)]
pub struct CommanderPlan {
    pub id: AgentId,
    pub team: TeamNo,
    pub policy: CommanderPolicy,
    pub host: String,
    /// The team's role groups (agent nodes), in order, with their roles.
    pub groups: Vec<(AgentId, GroupRole)>,
}

/// `security:` in a launch file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSecurity {
    /// Directory (relative to the launch file) with `ca.pem` and `<host>.pem` / `<host>.key`,
    /// as `avacraft certs` writes them.
    pub certs: PathBuf,
}

/// `bridge:` in a launch file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBridge {
    /// The host that runs it (default: the first).
    #[serde(default)]
    pub host: Option<String>,
    /// DDS domain id on the ROS 2 side.
    #[serde(default)]
    pub dds_domain: u16,
    /// Which topics go to DDS: any of `status`, `team_obs`, `unit_obs`, `frames`, `roles`.
    #[serde(default = "bridge_topics")]
    pub topics: Vec<String>,
    /// Teams whose topics it carries (default: every agent team).
    #[serde(default)]
    pub teams: Vec<u8>,
    /// Frames are scaled to this size (width, height) before they go to DDS: RustDDS is slow
    /// for samples over 64 KB, and a 160x120 RGB frame is 57,600 bytes.
    #[serde(default = "bridge_frame_size")]
    pub frame_size: [u32; 2],
    /// Only every this many frames goes to DDS.
    #[serde(default = "one_u32")]
    pub frame_every: u32,
    /// Local addresses DDS may use. Default `[127.0.0.1]`: DDS has no access control here, so
    /// the bridged topics stay on this machine unless addresses are listed (`[]`: every
    /// interface).
    #[serde(default)]
    pub dds_networks: Option<Vec<String>>,
}

fn bridge_topics() -> Vec<String> {
    ["status", "team_obs", "unit_obs", "frames"].map(String::from).to_vec()
}
fn bridge_frame_size() -> [u32; 2] {
    [160, 120]
}
fn one_u32() -> u32 {
    1
}

/// The deployment's certificates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Security {
    pub certs: PathBuf,
}

impl Security {
    pub fn ca(&self) -> PathBuf {
        self.certs.join("ca.pem")
    }
    pub fn cert(&self, host: &str) -> PathBuf {
        self.certs.join(format!("{host}.pem"))
    }
    pub fn key(&self, host: &str) -> PathBuf {
        self.certs.join(format!("{host}.key"))
    }
}

/// What the bridge republishes onto DDS.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum BridgeTopic {
    Status,
    TeamObs,
    UnitObs,
    Frames,
    Roles,
}

/// A validated `bridge:` section.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BridgePlan {
    pub host: String,
    pub dds_domain: u16,
    pub topics: BTreeSet<BridgeTopic>,
    pub teams: Vec<TeamNo>,
    pub frame_size: (u32, u32),
    pub frame_every: u32,
    pub dds_networks: Vec<std::net::IpAddr>,
}
