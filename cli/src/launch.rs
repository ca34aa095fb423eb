//! `avacraft launch`: starts the nodes of a launch file that belong on this host, each as
//! its own process. The first host hosts the Zenoh router (with TLS and access control when
//! the file has `security:`), the simulator and the recorder; any other host runs only its
//! agent nodes (and the bridge, if it is placed there) and stops them when the simulator
//! is gone. `avacraft certs` makes the deployment's certificates.

use anyhow::{Context, Result, bail};
use avacraft_launch::Plan;
use avacraft_nodes::{Node, NodeArgs, SessionMode, Shutdown, Topics};
use avacraft_sim_node::EpisodeSummary;
use clap::Args;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[derive(Args, Debug, Clone)]
pub struct LaunchArgs {
    /// The launch file (YAML), e.g. launch/3m.yaml. An agent entry's `policy` is a scripted
    /// agent (`avacraft episode --help` lists them), `dds`, or `marl:DIR`: a checkpoint of
    /// `avacraft train`, DIR relative to the launch file's directory or absolute; each of its
    /// agent nodes loads it and acts for its own units on their own observations
    /// (launch/3m_marl.yaml). A checkpoint missing, unreadable or trained for another
    /// scenario or team size is refused before anything starts.
    pub file: PathBuf,
    /// Print the episode summaries as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Which of the launch file's hosts this machine is (default: the first, which runs the
    /// router, the simulator and the recorder).
    #[arg(long)]
    pub host: Option<String>,
    /// Seconds to wait for every node to appear (and, on other hosts, for the simulator).
    #[arg(long, default_value_t = 60.0)]
    pub startup_timeout: f64,
    /// `--foxglove`: the simulator node serves the live view (it holds the one game).
    #[command(flatten)]
    pub live: crate::live::LiveArgs,
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

/// The Zenoh settings of `host`'s processes: clients of the router, with the host's TLS
/// identity when the deployment is secured.
fn host_args(plan: &Plan, host: &str) -> Result<NodeArgs> {
    let mut args = NodeArgs { connect: vec![plan.router.clone()], ..NodeArgs::default() };
    if let Some(sec) = &plan.security {
        // Only through the router, where access control is enforced: peers would also
        // talk to each other directly.
        args.mode = SessionMode::Client;
        for p in [sec.ca(), sec.cert(host), sec.key(host)] {
            if !p.is_file() {
                bail!(
                    "{}: host `{host}` needs {} (make the deployment's certificates with `avacraft certs {}` and copy the authority and each host's pair to it)",
                    plan.file,
                    p.display(),
                    plan.file
                );
            }
        }
        args.tls_ca = Some(sec.ca());
        args.tls_cert = Some(sec.cert(host));
        args.tls_key = Some(sec.key(host));
    }
    Ok(args)
}

/// The flags that give a child process `args`' connection.
fn child_flags(args: &NodeArgs) -> Vec<String> {
    let mut v = vec!["--mode".to_owned(), args.mode.name().to_owned(), "--connect-timeout-ms".into(), args.connect_timeout_ms.to_string()];
    for c in &args.connect {
        v.push("--connect".into());
        v.push(c.clone());
    }
    v.extend(args.tls_flags());
    v
}

/// Starts the agent nodes (and the bridge) that `host` runs.
fn spawn_host_nodes(a: &LaunchArgs, plan: &Plan, host: &str, common: &[String], procs: &mut Procs) -> Result<usize> {
    let mut n = 0;
    // Each node reads its own entry of the launch file (by absolute path: the node may run
    // from elsewhere), and only the nodes that act read weights.
    let file = std::fs::canonicalize(&a.file).with_context(|| format!("launch: {}", a.file.display()))?;
    let agents = plan.agents.iter().filter(|ag| ag.host == host && !ag.is_dds()).map(|ag| (format!("agent {}", ag.id), &ag.id));
    let commanders = plan.commanders.iter().filter(|c| c.host == host).map(|c| (format!("commander {}", c.id), &c.id));
    let encoders = plan.encoders.iter().filter(|e| e.host == host).map(|e| (format!("encoder {}", e.id), &e.id));
    for (what, id) in encoders.chain(agents).chain(commanders) {
        let mut args = vec!["agent-node".to_owned(), "--launch".into(), file.display().to_string(), "--node-id".into(), id.to_string()];
        args.extend(common.iter().cloned());
        procs.0.push(spawn(&what, &args)?);
        n += 1;
    }
    if plan.bridge.as_ref().is_some_and(|b| b.host == host) {
        let mut args = vec!["bridge".to_owned(), "--launch".into(), a.file.display().to_string()];
        args.extend(common.iter().cloned());
        procs.0.push(spawn("bridge", &args)?);
    }
    Ok(n)
}

pub fn launch(a: &LaunchArgs, out: &mut dyn Write) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    let plan = avacraft_launch::load(&a.file)?;
    if !(a.startup_timeout.is_finite() && a.startup_timeout > 0.0) {
        bail!("--startup-timeout {}: must be a positive number of seconds", a.startup_timeout);
    }
    let host = a.host.clone().unwrap_or_else(|| plan.server().to_owned());
    if !plan.hosts.contains(&host) {
        bail!("--host {host}: {} names the hosts {:?}", plan.file, plan.hosts);
    }
    let mut args = host_args(&plan, &host)?;
    if host != plan.server() {
        // Another host may start before the router: keep trying for the startup time.
        args.connect_timeout_ms = (a.startup_timeout * 1000.0) as i64;
    }
    let common = child_flags(&args);
    if host != plan.server() {
        return remote_host(a, &plan, &host, &args, &common, &shutdown, out);
    }
    // The embedded router: every node (and any ROS 2 tool) connects here.
    let mut router_args = NodeArgs { mode: SessionMode::Router, connect: Vec::new(), listen: vec![plan.router.clone()], ..args.clone() };
    if plan.security.is_some() {
        let topics = Topics::new(&router_args.namespace)?;
        router_args.access_control = Some(avacraft_launch::access_control(&plan, &topics, router_args.domain).to_string());
    }
    let _router = Node::open(&router_args, &router_args.namespace, &avacraft_nodes::NodeName::launch())
        .with_context(|| format!("launch: hosting the router on {}", plan.router))?;
    let mut procs = Procs(Vec::new());
    if let Some(path) = plan.record.as_ref().filter(|_| plan.record_by == avacraft_launch::RecordBy::Recorder) {
        let mut rec = vec!["record".to_owned(), "--out".to_owned(), path.display().to_string()];
        rec.extend(common.clone());
        procs.0.push(spawn("record", &rec)?);
    }
    spawn_host_nodes(a, &plan, &host, &common, &mut procs)?;
    let result = std::env::temp_dir().join(format!("avacraft-launch-{}.json", std::process::id()));
    let mut sim_args = vec![
        "sim-node".to_owned(),
        "--launch".into(),
        a.file.display().to_string(),
        "--result-file".into(),
        result.display().to_string(),
        "--startup-timeout".into(),
        a.startup_timeout.to_string(),
    ];
    if let Some(path) = plan.record.as_ref().filter(|_| plan.record_by == avacraft_launch::RecordBy::Simulator) {
        sim_args.extend(["--record".to_owned(), path.display().to_string()]);
    }
    sim_args.extend(common);
    sim_args.extend(a.live.args());
    let mut sim = Procs(vec![spawn("sim", &sim_args)?]);
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
    if let Some(path) = &plan.record {
        // The live view's channels beside the ROS 2 topics; the recording as closed stays
        // if this fails.
        match crate::live_mcap::add_live_channels(path) {
            Ok(n) => tracing::info!(
                episodes = n.episodes,
                messages = n.messages,
                model_calls = n.calls,
                "{}: Foxglove channels added",
                path.display()
            ),
            Err(e) => tracing::warn!("{}: the Foxglove channels were not added: {e:#}", path.display()),
        }
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&summaries)?)?;
        return Ok(());
    }
    report(&plan, &summaries, out)
}

/// Another host: runs its nodes until the simulator, once seen, is gone.
fn remote_host(
    a: &LaunchArgs,
    plan: &Plan,
    host: &str,
    args: &NodeArgs,
    common: &[String],
    shutdown: &Shutdown,
    out: &mut dyn Write,
) -> Result<()> {
    let watch = Node::open(args, &args.namespace, &avacraft_nodes::NodeName::launch_on(host))
        .with_context(|| format!("launch --host {host}: connecting to the router {}", plan.router))?;
    let mut procs = Procs(Vec::new());
    let n = spawn_host_nodes(a, plan, host, common, &mut procs)?;
    let start = Instant::now();
    let mut seen = false;
    // Gone means absent from three queries in a row: one late reply must not stop a team.
    let mut misses = 0;
    loop {
        if shutdown.requested() {
            bail!("launch --host {host}: interrupted");
        }
        let sim_up = watch.alive_nodes(Duration::from_millis(500))?.contains("sim");
        if sim_up && !seen {
            tracing::info!(host, "the simulator is up");
        }
        seen |= sim_up;
        misses = if sim_up { 0 } else { misses + 1 };
        if seen && misses >= 3 {
            break;
        }
        if !seen && start.elapsed().as_secs_f64() > a.startup_timeout {
            bail!("launch --host {host}: the simulator did not appear on {} within {} s", plan.router, a.startup_timeout);
        }
        for p in &mut procs.0 {
            if let Some(s) = p.child.try_wait()? {
                bail!("launch --host {host}: {} stopped early ({s}); see its log lines above", p.name);
            }
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    drop(procs);
    writeln!(out, "{host}: {n} agent nodes ran until the simulator on {} finished", plan.router)?;
    Ok(())
}

fn report(plan: &Plan, summaries: &[EpisodeSummary], out: &mut dyn Write) -> Result<()> {
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
        "trajectory hash",
    ]);
    for s in summaries {
        t.add_row([
            s.episode.to_string(),
            s.seed.to_string(),
            format!("{:?}", s.result).to_lowercase(),
            s.steps.to_string(),
            format!("{:?}", s.missing_actions),
            format!("{:?}", s.foreign_actions),
            format!("{:?}", s.refused_actions),
            s.malformed_messages.to_string(),
            s.trajectory_hash.clone(),
        ]);
    }
    writeln!(out, "{t}")?;
    if let Some(p) = &plan.record {
        writeln!(out, "recorded to {}", p.display())?;
    }
    Ok(())
}
