//! `avacraft agent-node`: one agent node (a unit's or a role group's policy, or a team's
//! commander), from its entry of a launch file (what `launch` starts) or from flags.

use anyhow::{Context, Result, bail};
use avacraft_ava::llm::{CallRecord, ChatRequest, Part, Stage};
use avacraft_engine::agent::GroupRole;
use avacraft_msgs::ModelCall;
use avacraft_nodes::{AgentId, Node, NodeArgs, NodeName, Shutdown, TeamNo, Topics, UnitTag};
use avacraft_policy::{Calls, CommanderPolicy, PolicySpec, Resolve, Weights};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Args, Debug, Clone)]
pub struct AgentNodeArgs {
    #[command(flatten)]
    pub node: NodeArgs,
    /// The launch file this node is part of (what `launch` passes): the node reads its own
    /// entry, `--node-id`, and only its own policy's weights. Without it, the flags below say
    /// what the node runs.
    #[arg(long, requires = "node_id", conflicts_with_all = ["id", "units", "role", "commander", "groups", "team", "policy", "ava_spec", "scenario"])]
    pub launch: Option<PathBuf>,
    /// With `--launch`: the id of this node's entry (an agent node or a commander).
    #[arg(long, requires = "launch")]
    pub node_id: Option<String>,
    /// This agent node's id (its action topic is `<namespace>/agents/<id>/actions`).
    #[arg(long, required_unless_present = "launch")]
    pub id: Option<String>,
    /// Tags of the units it owns, e.g. `--units 1,2` (with `--role`: those it starts with).
    #[arg(long, value_delimiter = ',', required_unless_present_any = ["commander", "launch"])]
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
    /// The agent's policy: a scripted agent (`avacraft episode --help` lists them),
    /// marl:DIR (a checkpoint of `avacraft train`, DIR relative to the working directory),
    /// baseline:NAME (the scenario's shipped policy) or ava (with --ava-spec).
    #[arg(long, default_value = "focus-fire")]
    pub policy: String,
    /// With `--policy ava`: its settings as JSON (what a launch file's `ava:` block holds).
    /// Calls are recorded under `record/<id>` when it names a folder.
    #[arg(long)]
    pub ava_spec: Option<String>,
    /// The scenario being played: a built-in name or a scenario file.
    #[arg(long, required_unless_present = "launch")]
    pub scenario: Option<String>,
}

/// What one agent node runs, from its launch file's entry or from its flags.
enum Job {
    /// `encoded`: the team's encoder node serves it (act on its encodings, not the frames).
    Agent {
        units: Vec<UnitTag>,
        role: Option<GroupRole>,
        policy: PolicySpec,
        encoded: bool,
    },
    Commander {
        groups: Vec<GroupRole>,
        policy: CommanderPolicy,
    },
    /// A team's encoder node: the network's image encoder on the team's frames, once a step.
    Encoder {
        policy: PolicySpec,
    },
}

/// The node's id, team, scenario and job.
struct NodeJob {
    id: AgentId,
    team: TeamNo,
    scenario: Arc<avacraft_engine::Scenario>,
    job: Job,
}

impl NodeJob {
    /// The entry `node` of the launch file, its policy's weights unread until it acts.
    fn from_launch(file: &Path, node: &str) -> Result<NodeJob> {
        let plan = avacraft_launch::load_with(file, Weights::Later)?;
        let id = AgentId::parse(node).with_context(|| format!("agent-node: --node-id {node}"))?;
        if let Some(c) = plan.commanders.iter().find(|c| c.id == id) {
            let groups = c.groups.iter().map(|(_, r)| *r).collect();
            return Ok(NodeJob { id, team: c.team, scenario: plan.scenario, job: Job::Commander { groups, policy: c.policy.clone() } });
        }
        if let Some(e) = plan.encoders.iter().find(|e| e.id == id) {
            e.policy.check_seeing(&plan.scenario, e.team.team()).with_context(|| format!("agent-node: {} encoder `{id}`", plan.file))?;
            return Ok(NodeJob { id, team: e.team, scenario: plan.scenario, job: Job::Encoder { policy: e.policy.clone() } });
        }
        let Some(a) = plan.agents.iter().find(|a| a.id == id) else {
            let ids: Vec<String> = plan
                .commanders
                .iter()
                .map(|c| c.id.to_string())
                .chain(plan.agents.iter().map(|a| a.id.to_string()))
                .chain(plan.encoders.iter().map(|e| e.id.to_string()))
                .collect();
            bail!("agent-node: --node-id {node}: {} has no such agent node (it has {})", plan.file, ids.join(", "));
        };
        // Only here, in the node that acts, are a checkpoint's weights read.
        a.policy
            .check_seeing(&plan.scenario, a.team.team())
            .with_context(|| format!("agent-node: {} agent `{id}`: policy {}", plan.file, a.policy))?;
        let job = Job::Agent { units: a.units.clone(), role: a.role, policy: a.policy.clone(), encoded: a.encoded };
        Ok(NodeJob { id, team: a.team, scenario: plan.scenario, job })
    }

    /// The node the flags describe.
    fn from_flags(a: &AgentNodeArgs) -> Result<NodeJob> {
        let (Some(id), Some(scenario)) = (&a.id, &a.scenario) else {
            bail!("agent-node: --id and --scenario (or --launch and --node-id) are needed")
        };
        let id = AgentId::parse(id)?;
        let scenario = Arc::new(avacraft_engine::Scenario::load(scenario).with_context(|| format!("agent-node: --scenario {scenario}"))?);
        let team = TeamNo::new(a.team)?;
        let role = |field: &str, name: &str| {
            GroupRole::from_name(name)
                .filter(|r| GroupRole::ASSIGNABLE.contains(r))
                .with_context(|| format!("agent-node: {field} {name}: a role is one of attacker, defender, scout, support"))
        };
        let ava = a.ava_spec.as_deref().map(serde_json::from_str::<avacraft_ava::AvaSpec>).transpose().context("agent-node: --ava-spec")?;
        let job = if a.commander {
            let groups = a.groups.iter().map(|g| role("--groups", g)).collect::<Result<Vec<_>>>()?;
            let policy = CommanderPolicy::resolve(&a.policy, ava, Resolve::default())
                .with_context(|| format!("agent-node: --commander --policy {}", a.policy))?;
            Job::Commander { groups, policy }
        } else {
            let units = a.units.iter().map(|&u| UnitTag::new(u)).collect::<Result<Vec<_>, _>>()?;
            let role = a.role.as_deref().map(|r| role("--role", r)).transpose()?;
            let policy = PolicySpec::resolve(&a.policy, ava, Resolve::default())
                .and_then(|p| p.on(&scenario))
                .and_then(|p| p.check_seeing(&scenario, team.team()).map(|()| p))
                .with_context(|| format!("agent-node: --policy {}", a.policy))?;
            if role.is_some() && policy.frames_need(&scenario)?.is_some() {
                bail!("agent-node: --policy {}: a role group reads no frames; this checkpoint does", a.policy);
            }
            Job::Agent { units, role, policy, encoded: false }
        };
        Ok(NodeJob { id, team, scenario, job })
    }
}

pub fn agent_node(a: &AgentNodeArgs) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    let NodeJob { id, team, scenario, job } = match (&a.launch, &a.node_id) {
        (Some(file), Some(node)) => NodeJob::from_launch(file, node)?,
        _ => NodeJob::from_flags(a)?,
    };
    let topics = Topics::new(&a.node.namespace)?;
    let node = Node::open(&a.node, &a.node.namespace, &NodeName::agent(&id)).context("agent-node: opening the Zenoh session")?;
    // AVA records under `record/<id>` and publishes each call; other policies make none.
    let calls = Calls::Under(id.to_string());
    match job {
        Job::Commander { groups, policy } => {
            let observer = policy.ava_spec().is_some().then(|| call_observer(&node, &topics, &id)).transpose()?;
            let mut commander = (policy.make(&calls, observer).with_context(|| format!("agent-node {id}: policy {policy}"))?.factory)();
            let cfg = avacraft_agent_nodes::CommandedConfig { id, team, initial: Vec::new(), groups, scenario };
            let stats = avacraft_agent_nodes::run_commander(&node, &topics, &cfg, commander.as_mut(), &shutdown, None)?;
            tracing::info!(orders = stats.batches, malformed = stats.malformed, "commander node stops");
        }
        Job::Encoder { policy } => {
            let agent = (policy.make(&calls, None).with_context(|| format!("agent-node {id}: policy {policy}"))?.factory)();
            let stats = avacraft_agent_nodes::run_encoder(&node, &topics, team, agent.as_ref(), &shutdown, None)
                .with_context(|| format!("agent-node {id}"))?;
            tracing::info!(encoded = stats.encoded, malformed = stats.malformed, "encoder node stops");
        }
        Job::Agent { units, role, policy, encoded } => {
            let observer = policy.ava_spec().is_some().then(|| call_observer(&node, &topics, &id)).transpose()?;
            let mut agent = (policy.make(&calls, observer).with_context(|| format!("agent-node {id}: policy {policy}"))?.factory)();
            let stats = match role {
                Some(_) => {
                    let cfg = avacraft_agent_nodes::CommandedConfig { id, team, initial: units, groups: Vec::new(), scenario };
                    avacraft_agent_nodes::run_role_group(&node, &topics, &cfg, agent.as_mut(), &shutdown, None)?
                }
                None => {
                    let cfg = avacraft_agent_nodes::AgentConfig { id, team, units, scenario, encoded };
                    avacraft_agent_nodes::run(&node, &topics, &cfg, agent.as_mut(), &shutdown, None)?
                }
            };
            tracing::info!(
                batches = stats.batches,
                malformed = stats.malformed,
                doomed = stats.doomed,
                encoded = stats.encoded,
                "agent node stops"
            );
        }
    }
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
fn model_call(r: &CallRecord, req: &ChatRequest, frame: &str) -> ModelCall {
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
