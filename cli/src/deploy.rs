//! The node commands of the distributed deployment: `sim-node`, `agent-node` and `record`
//! (`launch` starts them as processes).

use crate::record::{self, RecordArgs};
use anyhow::{Context, Result, bail};
use avacraft_ava::llm::{CallRecord, ChatRequest, Part, Stage};
use avacraft_engine::agent::GroupRole;
use avacraft_launch::{ClockMode, CommanderPolicy, Plan, PolicySpec};
use avacraft_msgs::ModelCall;
use avacraft_nodes::{AgentId, Node, NodeArgs, Shutdown, Topics, UnitTag};
use avacraft_sim_node::{Clock, SimConfig};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

#[derive(Args, Debug, Clone)]
pub struct SimNodeArgs {
    #[command(flatten)]
    pub node: NodeArgs,
    /// The launch file whose scenario, clock, seeds and unit owners to use.
    #[arg(long)]
    pub launch: PathBuf,
    /// Write the episode summaries as JSON here.
    #[arg(long)]
    pub result_file: Option<PathBuf>,
    /// Seconds to wait for every agent node to appear.
    #[arg(long, default_value_t = 30.0)]
    pub startup_timeout: f64,
}

#[derive(Args, Debug, Clone)]
pub struct AgentNodeArgs {
    #[command(flatten)]
    pub node: NodeArgs,
    /// This agent node's id (its action topic is `<namespace>/agents/<id>/actions`).
    #[arg(long)]
    pub id: String,
    /// Tags of the units it owns, e.g. `--units 1,2` (with `--role`: those it starts with).
    #[arg(long, value_delimiter = ',', required_unless_present = "commander")]
    pub units: Vec<u32>,
    /// A role group under its team's commander (attacker, defender, scout or support): it
    /// acts each step for the units the simulator's `team_<n>/roles` give it.
    #[arg(long, conflicts_with = "commander")]
    pub role: Option<String>,
    /// The team's commander (`--policy ava` or `rotate`): it orders units between the role
    /// groups `--groups` names, and drives no unit itself.
    #[arg(long, requires = "groups")]
    pub commander: bool,
    /// With `--commander`: the roles of the team's role groups, in the launch file's order.
    #[arg(long, value_delimiter = ',')]
    pub groups: Vec<String>,
    /// The team of its units (1 or 2).
    #[arg(long, default_value_t = 1)]
    pub team: u8,
    /// The agent's policy: a scripted agent (`avacraft episode --help` lists them) or
    /// marl:DIR, a checkpoint of `avacraft train` (DIR relative to the working directory),
    /// whose network acts for each unit on the unit's own observation.
    #[arg(long, default_value = "focus-fire")]
    pub policy: String,
    /// With `--policy ava`: its settings as JSON (what a launch file's `ava:` block holds;
    /// `launch` passes it). Calls are recorded under `record/<id>` when it names a folder.
    #[arg(long)]
    pub ava_spec: Option<String>,
    /// The scenario being played: a built-in name or a scenario file.
    #[arg(long)]
    pub scenario: String,
}

pub(crate) fn sim_config(plan: &Plan, startup: Duration) -> SimConfig {
    SimConfig {
        scenario: plan.scenario.clone(),
        env: plan.env_config(),
        clock: match plan.clock {
            ClockMode::Lockstep => Clock::Lockstep { deadline: plan.deadline },
            ClockMode::RealTime => Clock::RealTime,
        },
        seeds: plan.seeds.clone(),
        owners: plan.owners(),
        startup_timeout: startup,
        wait_for_recorder: plan.record.is_some(),
        dds_agents: plan.agents.iter().filter(|a| a.is_dds()).map(|a| a.id.clone()).collect(),
        launch_file: plan.file.clone(),
        commands: plan
            .commanders
            .iter()
            .map(|c| avacraft_sim_node::TeamCommand { team: c.team, commander: c.id.clone(), groups: c.groups.clone() })
            .collect(),
        frames: plan.frames.as_ref().map(|f| avacraft_sim_node::FrameSpec {
            kinds: f.kinds.clone(),
            screen: f.screen,
            minimap: f.minimap,
            vlm: f.vlm,
            every: f.every,
        }),
    }
}

pub fn sim_node(a: &SimNodeArgs, out: &mut dyn Write) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    let plan = avacraft_launch::load(&a.launch)?;
    if !(a.startup_timeout.is_finite() && a.startup_timeout > 0.0) {
        bail!("--startup-timeout {}: must be a positive number of seconds", a.startup_timeout);
    }
    let topics = Topics::new(&a.node.namespace)?;
    let node = Node::open(&a.node, &a.node.namespace, "sim").context("sim-node: opening the Zenoh session")?;
    let summaries = avacraft_sim_node::run(&node, &topics, &sim_config(&plan, Duration::from_secs_f64(a.startup_timeout)), &shutdown)?;
    let json = serde_json::to_string(&summaries)?;
    if let Some(p) = &a.result_file {
        std::fs::write(p, &json).with_context(|| format!("sim-node: writing {}", p.display()))?;
    }
    writeln!(out, "{json}")?;
    Ok(())
}

pub fn agent_node(a: &AgentNodeArgs) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    let id = AgentId::parse(&a.id)?;
    let units = a.units.iter().map(|&u| UnitTag::new(u)).collect::<Result<Vec<_>, _>>()?;
    let scenario =
        Arc::new(avacraft_engine::Scenario::load(&a.scenario).with_context(|| format!("agent-node: --scenario {}", a.scenario))?);
    let team = avacraft_nodes::TeamNo::new(a.team)?;
    let role = |field: &str, name: &str| {
        GroupRole::from_name(name)
            .filter(|r| GroupRole::ASSIGNABLE.contains(r))
            .with_context(|| format!("agent-node: {field} {name}: a role is one of attacker, defender, scout, support"))
    };
    if a.commander {
        let groups = a.groups.iter().map(|g| role("--groups", g)).collect::<Result<Vec<_>>>()?;
        let ava = match &a.ava_spec {
            Some(json) => Some(serde_json::from_str::<avacraft_ava::AvaSpec>(json).context("agent-node: --ava-spec")?),
            None => None,
        };
        let policy = match (a.policy.as_str(), ava) {
            (avacraft_launch::AVA_POLICY, Some(spec)) => {
                spec.validate().context("agent-node: --ava-spec")?;
                CommanderPolicy::Ava(Arc::new(spec))
            }
            (avacraft_launch::ROTATE_POLICY, None) => CommanderPolicy::Rotate,
            (p, _) => bail!("agent-node: --commander --policy {p}: a commander's policy is ava (with --ava-spec) or rotate"),
        };
        let topics = Topics::new(&a.node.namespace)?;
        let node = Node::open(&a.node, &a.node.namespace, &format!("agent_{id}")).context("agent-node: opening the Zenoh session")?;
        let observer = matches!(policy, CommanderPolicy::Ava(_)).then(|| call_observer(&node, &topics, &id)).transpose()?;
        let mut commander = policy.factory_observed(id.as_str(), observer).context("agent-node: --policy")?();
        let cfg = avacraft_agent_nodes::CommandedConfig { id, team, initial: Vec::new(), groups, scenario };
        let stats = avacraft_agent_nodes::run_commander(&node, &topics, &cfg, commander.as_mut(), &shutdown, None)?;
        tracing::info!(orders = stats.batches, malformed = stats.malformed, "commander node stops");
        return Ok(());
    }
    let group_role = a.role.as_deref().map(|r| role("--role", r)).transpose()?;
    let policy = match (a.policy.as_str(), &a.ava_spec) {
        (avacraft_launch::AVA_POLICY, Some(json)) => {
            let spec: avacraft_ava::AvaSpec = serde_json::from_str(json).context("agent-node: --ava-spec")?;
            PolicySpec::ava(spec).context("agent-node: --ava-spec")?
        }
        (_, Some(_)) => bail!("agent-node: --ava-spec goes with --policy ava"),
        (p, None) => {
            PolicySpec::parse(p, None).and_then(|p| p.on(&scenario)).with_context(|| format!("agent-node: --policy {}", a.policy))?
        }
    };
    policy.check(&scenario, team.team()).with_context(|| format!("agent-node: --policy {}", a.policy))?;
    let topics = Topics::new(&a.node.namespace)?;
    let node = Node::open(&a.node, &a.node.namespace, &format!("agent_{id}")).context("agent-node: opening the Zenoh session")?;
    let observer = matches!(policy, PolicySpec::Ava(_)).then(|| call_observer(&node, &topics, &id)).transpose()?;
    let mut agent = policy.factory_observed(id.as_str(), observer).with_context(|| format!("agent-node: --policy {}", a.policy))?();
    let stats = match group_role {
        Some(_) => {
            let cfg = avacraft_agent_nodes::CommandedConfig { id, team, initial: units, groups: Vec::new(), scenario };
            avacraft_agent_nodes::run_role_group(&node, &topics, &cfg, agent.as_mut(), &shutdown, None)?
        }
        None => {
            let cfg = avacraft_agent_nodes::AgentConfig { id, team, units, scenario };
            avacraft_agent_nodes::run(&node, &topics, &cfg, agent.as_mut(), &shutdown, None)?
        }
    };
    tracing::info!(batches = stats.batches, malformed = stats.malformed, "agent node stops");
    Ok(())
}

/// Publishes each of the node's model calls on `agents/<id>/model_calls`, so the session's
/// MCAP holds them next to the game (the run folder's `calls.jsonl` stays what replays).
fn call_observer(node: &Node, topics: &Topics, id: &AgentId) -> Result<avacraft_ava::CallObserver> {
    let mut publisher = node.publisher::<ModelCall>(&topics.model_calls(id), avacraft_nodes::Qos::Reliable { depth: 10 })?;
    let frame = id.to_string();
    Ok(Box::new(move |r, req| {
        if let Err(e) = publisher.put(&model_call(r, req, &frame)) {
            tracing::warn!(error = %e, "a model call could not be published (the run folder has it)");
        }
    }))
}

/// A call record as the `ModelCall` message.
pub(crate) fn model_call(r: &CallRecord, req: &ChatRequest, frame: &str) -> ModelCall {
    let stage = match r.stage {
        Stage::Planner => ModelCall::STAGE_PLANNER,
        Stage::Priority => ModelCall::STAGE_PRIORITY,
        Stage::Roles => ModelCall::STAGE_ROLES,
        Stage::Decision => ModelCall::STAGE_DECISION,
    };
    let images: Vec<&avacraft_ava::llm::Png> = req
        .messages
        .iter()
        .flat_map(|m| m.parts.iter())
        .filter_map(|p| match p {
            Part::Image(png) => Some(png),
            Part::Text(_) => None,
        })
        .collect();
    let usage = r.reply.as_ref().and_then(|x| x.usage);
    let tokens = |n: u64| u32::try_from(n).unwrap_or(u32::MAX);
    ModelCall {
        header: avacraft_msgs::Header { frame_id: frame.to_owned(), ..Default::default() },
        episode: r.episode,
        step: r.step,
        team: r.team,
        decision: r.decision,
        stage,
        attempt: r.attempt,
        retry: r.retry,
        model: r.model.clone(),
        prompts_version: r.prompts.clone(),
        request_hash: r.request_hash.clone(),
        request_json: serde_json::json!({"messages": r.messages, "schema": r.schema, "sampling": r.sampling}).to_string(),
        response: r.reply.as_ref().map(|x| x.text.clone()).unwrap_or_default(),
        error: r.error.as_ref().map(|e| e.to_string()).unwrap_or_default(),
        prompt_tokens: usage.map_or(0, |u| tokens(u.prompt_tokens)),
        completion_tokens: usage.map_or(0, |u| tokens(u.completion_tokens)),
        latency_ms: r.reply.as_ref().map_or(0.0, |x| x.latency_ms),
        cost_usd: r.cost_usd.unwrap_or(f64::NAN),
        images: images.len() as u32,
        first_image_png: images.first().map(|p| p.bytes.as_ref().clone()).unwrap_or_default(),
    }
}

pub fn record(a: &RecordArgs) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    record::run(a, &shutdown)?;
    Ok(())
}
