//! `avacraft bench --deploy`: the deployment's numbers on loopback, each against its goal.

use anyhow::{Context, Result, bail};
use avacraft_msgs::{ActionBatch, Header, Image};
use avacraft_nodes::{AgentId, FrameKind, Node, NodeArgs, Qos, SessionMode, TeamNo, Topics, now_ns};
use avacraft_sim_node::{EpisodeSummary, RoundTripParts};
use std::io::Write;
use std::process::Command;
use std::time::{Duration, Instant};

/// The namespace the deployment benchmarks' nodes and topics live in.
const BENCH: &str = "/bench";

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// What a launch measured: steps/s, the round trip's p50 and p99, and its legs (p50s, the
/// median over episodes).
struct Launched {
    steps_per_s: f64,
    round_trip: [u64; 2],
    parts: RoundTripParts,
}

/// Runs `avacraft launch` on a generated file: one focus-fire node per unit of team 1.
fn launch(scenario: &str, episodes: u32, record: bool) -> Result<Launched> {
    launch_with(scenario, episodes, record, "", "focus-fire")
}

/// [`launch`] with `extra` lines in the file and each node's `policy`.
fn launch_with(scenario: &str, episodes: u32, record: bool, extra: &str, policy: &str) -> Result<Launched> {
    let dir = std::env::temp_dir().join(format!("avacraft-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    // The launch file and its recording go when the run does, however it ends: a benchmark
    // run leaves nothing in the temporary folder.
    struct Gone(std::path::PathBuf);
    impl Drop for Gone {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
    let _gone = Gone(dir.clone());
    let port = free_port()?;
    let rec = if record { format!("record: {}\n", dir.join("bench.mcap").display()) } else { String::new() };
    let file = dir.join(format!("{scenario}.yaml"));
    std::fs::write(
        &file,
        format!(
            "scenario: {scenario}\nepisodes: {episodes}\nseed: 1\nrouter: tcp/127.0.0.1:{port}\n{rec}{extra}agents:\n  - per_unit: true\n    team: 1\n    policy: {policy}\n"
        ),
    )?;
    let exe = std::env::current_exe()?;
    let out = Command::new(exe).args(["launch", "--json"]).arg(&file).env("RUST_LOG", "warn").output().context("bench: running launch")?;
    if !out.status.success() {
        bail!("bench: launch of {scenario} failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    let eps: Vec<EpisodeSummary> = serde_json::from_slice(&out.stdout).context("bench: launch results")?;
    let steps: u32 = eps.iter().map(|e| e.steps).sum();
    let secs: f64 = eps.iter().map(|e| e.wall_seconds).sum();
    let mut p50: Vec<u64> = eps.iter().map(|e| e.round_trip_us[0]).collect();
    p50.sort_unstable();
    let p99 = eps.iter().map(|e| e.round_trip_us[1]).max().unwrap_or(0);
    let median = |f: fn(&RoundTripParts) -> u64| {
        let mut v: Vec<u64> = eps.iter().map(|e| f(&e.round_trip_parts_us)).collect();
        v.sort_unstable();
        v.get(v.len() / 2).copied().unwrap_or(0)
    };
    let parts = RoundTripParts { publish: median(|p| p.publish), to_agents: median(|p| p.to_agents), back: median(|p| p.back) };
    Ok(Launched { steps_per_s: steps as f64 / secs.max(1e-9), round_trip: [p50.get(p50.len() / 2).copied().unwrap_or(0), p99], parts })
}

/// How the two sessions of a ping-pong reach each other.
#[derive(Clone, Copy)]
enum Path {
    /// One listens, the other connects to it.
    Direct,
    /// Both are peers connected to a router, as a launch connects its nodes (they may then
    /// find each other and talk directly).
    PeersOfARouter,
    /// Both are clients of a router: every message goes through it.
    ThroughARouter,
}

/// Zenoh's own floor on this host: one small message there and one back between two
/// sessions (the size of a few units' actions), `n` times. Returns the round trip's p50 and
/// p99 (us).
fn ping_pong(path: Path, n: usize) -> Result<[u64; 2]> {
    let port = free_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let name = |n: &str| avacraft_nodes::NodeName::tool(n);
    let router = || -> Result<Node> {
        let args = NodeArgs { mode: SessionMode::Router, listen: vec![endpoint.clone()], ..NodeArgs::default() };
        Ok(Node::open(&args, BENCH, &name("router")?)?)
    };
    let (_router, a_args, b_args) = match path {
        Path::Direct => {
            let a = NodeArgs { listen: vec![endpoint.clone()], ..NodeArgs::default() };
            (None, a, NodeArgs { connect: vec![endpoint.clone()], ..NodeArgs::default() })
        }
        Path::PeersOfARouter => {
            let p = NodeArgs { connect: vec![endpoint.clone()], ..NodeArgs::default() };
            (Some(router()?), p.clone(), p)
        }
        Path::ThroughARouter => {
            let c = NodeArgs { mode: SessionMode::Client, connect: vec![endpoint.clone()], ..NodeArgs::default() };
            (Some(router()?), c.clone(), c)
        }
    };
    let (a, b) = (Node::open(&a_args, BENCH, &name("ping")?)?, Node::open(&b_args, BENCH, &name("pong")?)?);
    // The two directions as two agent nodes' action topics, the shape an episode's take.
    let topics = Topics::new(BENCH)?;
    let (ping, pong) = (topics.actions(&AgentId::parse("ping")?), topics.actions(&AgentId::parse("pong")?));
    let qos = Qos::Reliable { depth: 10 };
    let (mut tx, rx_b) = (a.publisher::<ActionBatch>(&ping, qos)?, b.subscriber::<ActionBatch>(&ping, qos)?);
    let (mut tx_b, rx) = (b.publisher::<ActionBatch>(&pong, qos)?, a.subscriber::<ActionBatch>(&pong, qos)?);
    std::thread::sleep(Duration::from_millis(500));
    let echo = std::thread::spawn(move || -> Result<()> {
        for _ in 0..n {
            match rx_b.recv_timeout(Duration::from_secs(2))? {
                Some(r) => tx_b.put(&r.msg?)?,
                None => bail!("bench: no ping arrived"),
            }
        }
        Ok(())
    });
    let msg = ActionBatch { agent_id: "bench".into(), actions: vec![Default::default(); 4], ..ActionBatch::default() };
    let mut lat = Vec::with_capacity(n);
    for _ in 0..n {
        let t0 = Instant::now();
        tx.put(&msg)?;
        if rx.recv_timeout(Duration::from_secs(2))?.is_none() {
            bail!("bench: no pong arrived");
        }
        lat.push(t0.elapsed().as_micros() as u64);
    }
    echo.join().map_err(|_| anyhow::anyhow!("bench: the echo thread panicked"))??;
    lat.sort_unstable();
    Ok([lat[lat.len() / 2], lat[(lat.len() - 1) * 99 / 100]])
}

/// Publishes `n` images of `w` x `h` through a router and returns the delivery latency
/// percentiles (microseconds) seen by a subscriber in another session.
fn frame_latency(w: u32, h: u32, n: usize) -> Result<[u64; 2]> {
    let port = free_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let _router = Node::open(
        &NodeArgs { mode: SessionMode::Router, connect: vec![], listen: vec![endpoint.clone()], ..NodeArgs::default() },
        BENCH,
        &avacraft_nodes::NodeName::tool("router")?,
    )?;
    let args = NodeArgs { connect: vec![endpoint], ..NodeArgs::default() };
    let (a, b) = (
        Node::open(&args, BENCH, &avacraft_nodes::NodeName::tool("camera")?)?,
        Node::open(&args, BENCH, &avacraft_nodes::NodeName::tool("viewer")?)?,
    );
    let topic = Topics::new(BENCH)?.frames(TeamNo::new(1)?, FrameKind::Screen);
    let sub = b.subscriber::<Image>(&topic, Qos::Reliable { depth: 10 })?;
    let mut p = a.publisher::<Image>(&topic, Qos::Reliable { depth: 10 })?;
    std::thread::sleep(Duration::from_millis(500));
    let img = Image {
        header: Header::default(),
        height: h,
        width: w,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: w * 3,
        data: vec![90; (w * h * 3) as usize],
    };
    let mut lat = Vec::with_capacity(n);
    for _ in 0..n {
        p.put(&img)?;
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(2) {
            if let Some(r) = sub.recv_timeout(Duration::from_millis(100))? {
                if let Some(att) = r.attachment {
                    lat.push(((now_ns() - att.source_ns).max(0) / 1000) as u64);
                }
                break;
            }
        }
    }
    lat.sort_unstable();
    if lat.is_empty() {
        bail!("bench: no frame arrived");
    }
    Ok([lat[lat.len() / 2], lat[(lat.len() - 1) * 99 / 100]])
}

/// The same through iceoryx2 shared memory, publisher and subscriber in two threads.
fn frame_latency_shm(w: u32, h: u32, n: usize) -> Result<[u64; 2]> {
    use avacraft_nodes::frames::{Encoding, FrameHeader, FramePublisher, FrameSubscriber};
    let topics = Topics::new(&format!("/bench_{}_{w}x{h}", std::process::id()))?;
    let service = topics.frame_service(TeamNo::new(1)?, FrameKind::Screen);
    let bytes = (w * h * 3) as usize;
    let mut p = FramePublisher::open(&service, FrameHeader::SIZE + bytes, 2)?;
    let mut s = FrameSubscriber::open(&service, 2)?;
    let pixels = vec![90u8; bytes];
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    let reader = std::thread::spawn(move || -> Result<Vec<u64>> {
        let mut lat = Vec::with_capacity(n);
        for _ in 0..n {
            if let Some(f) = s.recv_timeout(Duration::from_secs(2))? {
                lat.push(((now_ns() - f.header().source_timestamp_ns).max(0) / 1000) as u64);
            }
            tx.send(()).ok();
        }
        Ok(lat)
    });
    for k in 0..n {
        p.publish(FrameHeader::packed(k as u64, now_ns(), w, h, Encoding::Rgb8), &pixels)?;
        // One frame in flight at a time: latency, not throughput.
        if rx.recv_timeout(Duration::from_secs(3)).is_err() {
            break;
        }
    }
    let mut lat = reader.join().map_err(|_| anyhow::anyhow!("bench: the frame reader panicked"))??;
    lat.sort_unstable();
    if lat.is_empty() {
        bail!("bench: no frame arrived through iceoryx2");
    }
    Ok([lat[lat.len() / 2], lat[(lat.len() - 1) * 99 / 100]])
}

pub fn run(out: &mut dyn Write) -> Result<()> {
    let m3 = launch("3m_vlm", 30, false)?;
    let m3_rec = launch("3m_vlm", 30, true)?;
    let m3_sim_rec = launch_with("3m_vlm", 30, true, "record_by: simulator\n", "focus-fire")?;
    let pvz = launch("pvz_ht", 1, false)?;
    // The shipped rgb MAPPO on its own data, a node per Marine: the team's encoder node
    // encodes the frames once a step, or each node does.
    let rgb_shared = launch_with("3m_vlm", 10, false, "data: legacy\n", "baseline:mappo-rgb")?;
    let rgb_own = launch_with("3m_vlm", 10, false, "data: legacy\nshare_encoder: false\n", "baseline:mappo-rgb")?;
    let direct = ping_pong(Path::Direct, 2000)?;
    let peers = ping_pong(Path::PeersOfARouter, 2000)?;
    let routed = ping_pong(Path::ThroughARouter, 2000)?;
    let small = frame_latency(160, 120, 300)?;
    let large = frame_latency(1920, 1080, 40)?;
    let small_shm = frame_latency_shm(160, 120, 500)?;
    let large_shm = frame_latency_shm(1920, 1080, 50)?;
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(["measure", "value", "goal", "ratio to goal"]);
    let row = |t: &mut comfy_table::Table, m: &str, v: String, g: &str, r: f64| {
        t.add_row([m.to_owned(), v, g.to_owned(), if r.is_finite() { format!("{r:.2}") } else { "-".to_owned() }]);
    };
    let legs = |p: &RoundTripParts| format!("{} / {} / {}", p.publish, p.to_agents, p.back);
    row(&mut t, "3m_vlm lockstep steps/s (3 agent processes)", format!("{:.0}", m3.steps_per_s), "-", f64::NAN);
    row(&mut t, "pvz_ht lockstep steps/s (23 agent processes)", format!("{:.0}", pvz.steps_per_s), ">= 500", pvz.steps_per_s / 500.0);
    row(
        &mut t,
        "3m_vlm rgb MAPPO steps/s: one encoder node / one encoder per node",
        format!("{:.0} / {:.0}", rgb_shared.steps_per_s, rgb_own.steps_per_s),
        "-",
        f64::NAN,
    );
    row(&mut t, "  shared encoder, of one per node", format!("{:.2}", rgb_shared.steps_per_s / rgb_own.steps_per_s), "-", f64::NAN);
    let rt = m3.round_trip;
    row(&mut t, "3m_vlm round trip p50 / p99 (us)", format!("{} / {}", rt[0], rt[1]), "p50 <= 100", 100.0 / rt[0].max(1) as f64);
    row(&mut t, "  its legs: publish / to agents / back (p50, us)", legs(&m3.parts), "-", f64::NAN);
    row(&mut t, "pvz_ht round trip p50 / p99 (us)", format!("{} / {}", pvz.round_trip[0], pvz.round_trip[1]), "-", f64::NAN);
    row(&mut t, "  its legs: publish / to agents / back (p50, us)", legs(&pvz.parts), "-", f64::NAN);
    row(&mut t, "Zenoh ping-pong, two peers (p50 / p99, us)", format!("{} / {}", direct[0], direct[1]), "-", f64::NAN);
    row(&mut t, "Zenoh ping-pong, two peers of a router (p50 / p99, us)", format!("{} / {}", peers[0], peers[1]), "-", f64::NAN);
    row(&mut t, "Zenoh ping-pong through a router (p50 / p99, us)", format!("{} / {}", routed[0], routed[1]), "-", f64::NAN);
    row(
        &mut t,
        "160x120 frame via iceoryx2 p50 / p99 (us)",
        format!("{} / {}", small_shm[0], small_shm[1]),
        "p50 <= 20",
        20.0 / small_shm[0].max(1) as f64,
    );
    row(&mut t, "1920x1080 frame via iceoryx2 p50 / p99 (us)", format!("{} / {}", large_shm[0], large_shm[1]), "-", f64::NAN);
    row(&mut t, "160x120 frame via Zenoh p50 / p99 (us)", format!("{} / {}", small[0], small[1]), "-", f64::NAN);
    row(&mut t, "1920x1080 frame via Zenoh p50 / p99 (us)", format!("{} / {}", large[0], large[1]), "-", f64::NAN);
    let rec = m3_rec.steps_per_s / m3.steps_per_s;
    row(&mut t, "3m_vlm recorded by a recorder node, of unrecorded", format!("{rec:.2}"), ">= 0.95", rec / 0.95);
    let rec = m3_sim_rec.steps_per_s / m3.steps_per_s;
    row(&mut t, "3m_vlm recorded by the simulator, of unrecorded", format!("{rec:.2}"), ">= 0.95", rec / 0.95);
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "loopback, one router; ping-pong between two sessions of one process; iceoryx2 between two threads of one process, one frame in flight"
    )?;
    Ok(())
}
