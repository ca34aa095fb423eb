//! `avacraft sim-node`: the simulator node of a launch file (`launch` starts it as a process).

use anyhow::{Context, Result, bail};
use avacraft_launch::{ClockMode, Plan};
use avacraft_msgs::ModelCall;
use avacraft_nodes::{Node, NodeArgs, NodeName, Qos, Shutdown, TopicKind, Topics};
use avacraft_policy::Weights;
use avacraft_sim_node::{Clock, SimConfig};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
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
    /// Write the session's MCAP here from the simulator's own traffic (what it sends and
    /// receives, the agent nodes' model calls among it) instead of a recorder node's.
    #[arg(long)]
    pub record: Option<PathBuf>,
    #[command(flatten)]
    pub live: crate::live::LiveArgs,
}

fn sim_config(plan: &Plan, startup: Duration) -> SimConfig {
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
        wait_for_recorder: plan.record.is_some() && plan.record_by == avacraft_launch::RecordBy::Recorder,
        dds_agents: plan.agents.iter().filter(|a| a.is_dds()).map(|a| a.id.clone()).collect(),
        reads: plan.agents.iter().map(|a| (a.id.clone(), a.policy.reads())).collect(),
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
            for_agents: f.for_agents,
        }),
    }
}

pub fn sim_node(a: &SimNodeArgs, out: &mut dyn Write) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    // The simulator never acts: it names the policies without reading their weights.
    let plan = avacraft_launch::load_with(&a.launch, Weights::Later)?;
    if !(a.startup_timeout.is_finite() && a.startup_timeout > 0.0) {
        bail!("--startup-timeout {}: must be a positive number of seconds", a.startup_timeout);
    }
    let topics = Topics::new(&a.node.namespace)?;
    let node = Node::open(&a.node, &a.node.namespace, &NodeName::sim()).context("sim-node: opening the Zenoh session")?;
    // Recording its own traffic: every message its publishers and subscribers handle goes to
    // a writer thread, which closes the file once the node is gone.
    let (node, recorder) = match &a.record {
        None => (node, None),
        Some(path) => {
            let (tx, rx) = std::sync::mpsc::channel();
            let (path, ns) = (path.clone(), a.node.namespace.clone());
            let writer = std::thread::spawn(move || crate::record::record_tapped(&path, &ns, rx));
            (node.with_tap(tx), Some(writer))
        }
    };
    let mut live = a.live.start("launch")?;
    let forward =
        (live.is_some() || recorder.is_some()).then(|| forward_calls(&node, &topics, live.as_ref().map(|l| l.logger()))).transpose()?;
    let mut watch = |env: &avacraft_engine::Env| {
        if let Some(l) = live.as_mut() {
            l.step(env);
        }
    };
    let cfg = sim_config(&plan, Duration::from_secs_f64(a.startup_timeout));
    let summaries = avacraft_sim_node::run_watched(&node, &topics, &cfg, &shutdown, &mut watch)?;
    if let Some(f) = forward {
        f.stop();
    }
    drop(node);
    if let Some(r) = recorder {
        let stats = r.join().map_err(|_| anyhow::anyhow!("sim-node: the recording thread panicked"))??;
        tracing::info!(messages = stats.messages, channels = stats.channels, "the simulator's recording is closed");
    }
    if let Some(l) = &live {
        eprintln!("{}", l.summary());
    }
    let json = serde_json::to_string(&summaries)?;
    if let Some(p) = &a.result_file {
        std::fs::write(p, &json).with_context(|| format!("sim-node: writing {}", p.display()))?;
    }
    writeln!(out, "{json}")?;
    Ok(())
}

/// The thread that puts AVA agent nodes' model calls (their `model_calls` topics) into the
/// live view's log, as `episode` does with in-process calls (and, taking them, into the
/// simulator's own recording).
struct Forward {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<()>,
}

impl Forward {
    fn stop(self) {
        self.stop.store(true, Ordering::Relaxed);
        if self.thread.join().is_err() {
            tracing::warn!("the live view's model-call thread panicked");
        }
    }
}

fn forward_calls(node: &Node, topics: &Topics, log: Option<avacraft_live::LiveLog>) -> Result<Forward> {
    let sub = node
        .subscriber::<ModelCall>(topics.any_model_calls(), Qos::Reliable { depth: 64 })
        .context("sim-node: subscribing to the agent nodes' model calls")?;
    let (stop, topics) = (Arc::new(AtomicBool::new(false)), topics.clone());
    let flag = Arc::clone(&stop);
    let thread = std::thread::spawn(move || {
        while !flag.load(Ordering::Relaxed) {
            match sub.recv_timeout(Duration::from_millis(100)) {
                Ok(None) => {}
                Ok(Some(r)) => {
                    let Some(TopicKind::ModelCalls(agent)) = topics.classify(&r.topic) else { continue };
                    match r.msg {
                        Ok(c) => {
                            if let (Some(log), Some((level, name, text))) = (&log, crate::live::model_call_line(agent.as_str(), &c)) {
                                log.line(level, &name, &text);
                            }
                        }
                        Err(e) => tracing::warn!(topic = %r.topic, error = %e, "a model call that does not decode; not shown"),
                    }
                }
                Err(e) => {
                    tracing::warn!(error = %e, "the model-call subscription closed; the live view shows no more calls");
                    break;
                }
            }
        }
    });
    Ok(Forward { stop, thread })
}
