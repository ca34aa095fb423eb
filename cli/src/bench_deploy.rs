//! `avacraft bench --deploy`: the deployment's numbers on loopback, each against its goal.

use anyhow::{Context, Result, bail};
use avacraft_msgs::{Header, Image};
use avacraft_nodes::{Node, NodeArgs, Qos, SessionMode, Topic, now_ns};
use avacraft_sim_node::EpisodeSummary;
use std::io::Write;
use std::process::Command;
use std::time::{Duration, Instant};

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// Runs `avacraft launch` on a generated file; returns steps/s and round-trip percentiles.
fn launch(scenario: &str, episodes: u32, record: bool) -> Result<(f64, [u64; 2], u32)> {
    let dir = std::env::temp_dir().join(format!("avacraft-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let port = free_port()?;
    let rec = if record { format!("record: {}\n", dir.join("bench.mcap").display()) } else { String::new() };
    let file = dir.join(format!("{scenario}.yaml"));
    std::fs::write(
        &file,
        format!(
            "scenario: {scenario}\nepisodes: {episodes}\nseed: 1\nrouter: tcp/127.0.0.1:{port}\n{rec}agents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n"
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
    Ok((steps as f64 / secs.max(1e-9), [p50.get(p50.len() / 2).copied().unwrap_or(0), p99], steps))
}

/// Publishes `n` images of `w` x `h` through a router and returns the delivery latency
/// percentiles (microseconds) seen by a subscriber in another session.
fn frame_latency(w: u32, h: u32, n: usize) -> Result<[u64; 2]> {
    let port = free_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let _router = Node::open(
        &NodeArgs { mode: SessionMode::Router, connect: vec![], listen: vec![endpoint.clone()], ..NodeArgs::default() },
        "/bench",
        &avacraft_nodes::NodeName::tool("router")?,
    )?;
    let args = NodeArgs { connect: vec![endpoint], ..NodeArgs::default() };
    let (a, b) = (
        Node::open(&args, "/bench", &avacraft_nodes::NodeName::tool("camera")?)?,
        Node::open(&args, "/bench", &avacraft_nodes::NodeName::tool("viewer")?)?,
    );
    let topic = Topic::parse("/bench/frames")?;
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
    let topics = avacraft_nodes::Topics::new(&format!("/bench_{}_{w}x{h}", std::process::id()))?;
    let service = topics.frame_service(avacraft_nodes::TeamNo::new(1)?, avacraft_nodes::FrameKind::Screen);
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
    let (m3, rt, _) = launch("3m_vlm", 30, false)?;
    let (m3_rec, _, _) = launch("3m_vlm", 30, true)?;
    let (pvz, pvz_rt, _) = launch("pvz_ht", 1, false)?;
    let small = frame_latency(160, 120, 300)?;
    let large = frame_latency(1920, 1080, 40)?;
    let small_shm = frame_latency_shm(160, 120, 500)?;
    let large_shm = frame_latency_shm(1920, 1080, 50)?;
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(["measure", "value", "goal", "ratio to goal"]);
    let row = |t: &mut comfy_table::Table, m: &str, v: String, g: &str, r: f64| {
        t.add_row([m.to_owned(), v, g.to_owned(), if r.is_finite() { format!("{r:.2}") } else { "-".to_owned() }]);
    };
    row(&mut t, "3m_vlm lockstep steps/s (3 agent processes)", format!("{m3:.0}"), ">= 2000", m3 / 2000.0);
    row(&mut t, "pvz_ht lockstep steps/s (23 agent processes)", format!("{pvz:.0}"), "-", f64::NAN);
    row(&mut t, "3m_vlm round trip p50 / p99 (us)", format!("{} / {}", rt[0], rt[1]), "p50 <= 200", 200.0 / rt[0].max(1) as f64);
    row(&mut t, "pvz_ht round trip p50 / p99 (us)", format!("{} / {}", pvz_rt[0], pvz_rt[1]), "-", f64::NAN);
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
    row(&mut t, "3m_vlm steps/s while recording everything", format!("{m3_rec:.0}"), ">= 0.9 of unrecorded", m3_rec / m3 / 0.9);
    writeln!(out, "{t}")?;
    writeln!(out, "loopback, one router; iceoryx2 between two threads of one process, one frame in flight")?;
    Ok(())
}
