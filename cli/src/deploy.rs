//! The distributed deployment's commands: `sim-node`, `agent-node` and `launch`, which
//! hosts a Zenoh router and starts every node of a launch file as its own process.

use crate::record::{self, RecordArgs};
use anyhow::{Context, Result, bail};
use avacraft_engine::{EnvConfig, Rules};
use avacraft_launch::{ClockMode, Plan};
use avacraft_nodes::{AgentId, Node, NodeArgs, SessionMode, Shutdown, Topics, UnitTag};
use avacraft_sim_node::{Clock, EpisodeSummary, SimConfig};
use clap::Args;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

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
    /// Tags of the units it owns, e.g. `--units 1,2`.
    #[arg(long, value_delimiter = ',', required = true)]
    pub units: Vec<u32>,
    /// Policy: focus-fire, attack-move, hold or noop.
    #[arg(long, default_value = "focus-fire")]
    pub policy: String,
}

#[derive(Args, Debug, Clone)]
pub struct LaunchArgs {
    /// The launch file (YAML), e.g. launch/3m.yaml.
    pub file: PathBuf,
    /// Write the episode summaries as JSON here as well.
    #[arg(long)]
    pub json: bool,
}

fn sim_config(plan: &Plan, startup: Duration) -> SimConfig {
    let mut env = EnvConfig { rules: Rules::default(), ..EnvConfig::default() };
    env.opponent = plan.opponent;
    SimConfig {
        scenario: plan.scenario.clone(),
        env,
        clock: match plan.clock {
            ClockMode::Lockstep => Clock::Lockstep { deadline: plan.deadline },
            ClockMode::RealTime => Clock::RealTime,
        },
        seeds: plan.seeds.clone(),
        owners: plan.owners(),
        startup_timeout: startup,
        wait_for_recorder: plan.record.is_some(),
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
    let mut policy = avacraft_agent_nodes::by_name(&a.policy)?;
    let topics = Topics::new(&a.node.namespace)?;
    let node = Node::open(&a.node, &a.node.namespace, &format!("agent_{id}")).context("agent-node: opening the Zenoh session")?;
    let cfg = avacraft_agent_nodes::AgentConfig { id, units };
    let stats = avacraft_agent_nodes::run(&node, &topics, &cfg, policy.as_mut(), &shutdown, None)?;
    tracing::info!(batches = stats.batches, malformed = stats.malformed, "agent node stops");
    Ok(())
}

pub fn record(a: &RecordArgs) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    record::run(a, &shutdown)?;
    Ok(())
}

/// A child process with its name, its log lines prefixed on our stderr.
struct Proc {
    name: String,
    child: Child,
}

/// Every started node: whatever happens to the launcher (an error, a panic), they are
/// stopped when this goes out of scope, last started first.
struct Procs(Vec<Proc>);

impl Drop for Procs {
    fn drop(&mut self) {
        for p in self.0.iter_mut().rev() {
            stop(p, Duration::from_secs(5));
        }
    }
}

fn spawn(name: &str, args: &[String]) -> Result<Proc> {
    let exe = std::env::current_exe().context("launch: locating the avacraft executable")?;
    let mut child = Command::new(exe)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("launch: starting {name}"))?;
    if let Some(err) = child.stderr.take() {
        let prefix = name.to_owned();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(err).lines().map_while(Result::ok) {
                eprintln!("[{prefix}] {line}");
            }
        });
    }
    Ok(Proc { name: name.to_owned(), child })
}

/// Asks a child to stop (SIGTERM), then kills it if it has not after `grace`.
fn stop(p: &mut Proc, grace: Duration) {
    if let Ok(Some(_)) = p.child.try_wait() {
        return;
    }
    let pid = nix::unistd::Pid::from_raw(p.child.id() as i32);
    let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM);
    let t0 = Instant::now();
    while t0.elapsed() < grace {
        if let Ok(Some(_)) = p.child.try_wait() {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    tracing::warn!(node = %p.name, "did not stop on SIGTERM; killed");
    let _ = p.child.kill();
    let _ = p.child.wait();
}

pub fn launch(a: &LaunchArgs, out: &mut dyn Write) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    let plan = avacraft_launch::load(&a.file)?;
    // The embedded router: every node (and any ROS 2 tool) connects here.
    let router_args = NodeArgs { mode: SessionMode::Router, connect: Vec::new(), listen: vec![plan.router.clone()], ..NodeArgs::default() };
    let _router = Node::open(&router_args, &router_args.namespace, "launch")
        .with_context(|| format!("launch: hosting the router on {}", plan.router))?;
    let common = vec!["--connect".to_owned(), plan.router.clone()];
    let mut procs = Procs(Vec::new());
    if let Some(path) = &plan.record {
        let mut args = vec!["record".to_owned(), "--out".to_owned(), path.display().to_string()];
        args.extend(common.clone());
        procs.0.push(spawn("record", &args)?);
    }
    for ag in &plan.agents {
        let units: Vec<String> = ag.units.iter().map(|u| u.get().to_string()).collect();
        let mut args = vec![
            "agent-node".to_owned(),
            "--id".into(),
            ag.id.to_string(),
            "--units".into(),
            units.join(","),
            "--policy".into(),
            ag.policy.clone(),
        ];
        args.extend(common.clone());
        procs.0.push(spawn(&format!("agent {}", ag.id), &args)?);
    }
    let result = std::env::temp_dir().join(format!("avacraft-launch-{}.json", std::process::id()));
    let mut args =
        vec!["sim-node".to_owned(), "--launch".into(), a.file.display().to_string(), "--result-file".into(), result.display().to_string()];
    args.extend(common);
    let mut sim = Procs(vec![spawn("sim", &args)?]);
    let status = loop {
        if shutdown.requested() {
            drop(sim);
            break None;
        }
        if let Some(s) = sim.0[0].child.try_wait()? {
            break Some(s);
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    // Agents and recorder stop after the simulator; the recorder drains what is still on
    // its way and closes its file cleanly.
    std::thread::sleep(Duration::from_millis(300));
    drop(procs);
    let Some(status) = status else { bail!("launch: interrupted") };
    if !status.success() {
        bail!("launch: the simulator node failed ({status}); see its log lines above");
    }
    let text = std::fs::read_to_string(&result).with_context(|| format!("launch: reading the results {}", result.display()))?;
    let _ = std::fs::remove_file(&result);
    let summaries: Vec<EpisodeSummary> = serde_json::from_str(&text).context("launch: the simulator node's results")?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&summaries)?)?;
        return Ok(());
    }
    writeln!(out, "{} ({}): {} agent nodes, {} episodes", plan.scenario.name, plan.file, plan.agents.len(), summaries.len())?;
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "episode",
        "seed",
        "result",
        "steps",
        "missing",
        "foreign",
        "refused",
        "malformed",
    ]);
    for s in &summaries {
        t.add_row([
            s.episode.to_string(),
            s.seed.to_string(),
            format!("{:?}", s.result).to_lowercase(),
            s.steps.to_string(),
            format!("{:?}", s.missing_actions),
            format!("{:?}", s.foreign_actions),
            format!("{:?}", s.refused_actions),
            s.malformed_messages.to_string(),
        ]);
    }
    writeln!(out, "{t}")?;
    if let Some(p) = &plan.record {
        writeln!(out, "recorded to {}", p.display())?;
    }
    Ok(())
}
