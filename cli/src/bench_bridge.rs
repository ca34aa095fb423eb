//! `avacraft bench --bridge`: what the DDS bridge costs. A unit observation (3m_vlm, as the
//! simulator publishes it) and a 160x120 frame go from a Zenoh publisher through a router
//! to (a) a Zenoh subscriber directly and (b) the bridge and on to a ros2-client DDS
//! reader; latency one message at a time, then throughput in a burst. The direct path,
//! measured in the same run, is the baseline of every ratio.

use anyhow::{Context, Result, anyhow, bail};
use avacraft_bridge::BridgeConfig;
use avacraft_msgs::{Header, Image, RosMessage, Time, UnitObservation};
use avacraft_nodes::{FrameKind, Node, NodeArgs, Qos, SessionMode, Shutdown, TeamNo, Topic, Topics, UnitTag, now_ns};
use futures::StreamExt;
use std::io::Write;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn stamp() -> Header {
    let ns = now_ns();
    Header { stamp: Time { sec: (ns / 1_000_000_000) as i32, nanosec: (ns % 1_000_000_000) as u32 }, frame_id: "bench".into() }
}

fn age_us(h: &Header) -> u64 {
    let sent = h.stamp.sec as i64 * 1_000_000_000 + h.stamp.nanosec as i64;
    ((now_ns() - sent).max(0) / 1000) as u64
}

/// A message whose header can be stamped.
trait Stamped: RosMessage + Clone + Send + std::fmt::Debug {
    fn header_mut(&mut self) -> &mut Header;
    fn header(&self) -> &Header;
}

impl Stamped for UnitObservation {
    fn header_mut(&mut self) -> &mut Header {
        &mut self.header
    }
    fn header(&self) -> &Header {
        &self.header
    }
}

impl Stamped for Image {
    fn header_mut(&mut self) -> &mut Header {
        &mut self.header
    }
    fn header(&self) -> &Header {
        &self.header
    }
}

/// The DDS reader side: its own participant, as a ROS 2 tool on DDS would have.
struct DdsReader {
    node: ros2_client::Node,
}

impl DdsReader {
    fn open(domain: u16) -> Result<DdsReader> {
        let dp = ros2_client::dds::rustdds::DomainParticipantBuilder::new(domain)
            .with_only_networks([std::net::Ipv4Addr::LOCALHOST])
            .build()
            .map_err(|e| anyhow!("bench: DDS participant: {e}"))?;
        let ctx = ros2_client::Context::from_domain_participant(dp).map_err(|e| anyhow!("bench: ROS 2 context: {e}"))?;
        let name = ros2_client::NodeName::new("/bench", "dds_reader").map_err(|e| anyhow!("bench: {e:?}"))?;
        let mut node =
            ctx.new_node(name, ros2_client::NodeOptions::new().enable_rosout(false)).map_err(|e| anyhow!("bench: ROS 2 node: {e}"))?;
        let spinner = node.spinner().map_err(|e| anyhow!("bench: spinner: {e}"))?;
        std::thread::spawn(move || smol::block_on(spinner.spin()));
        Ok(DdsReader { node })
    }

    fn subscription<T: RosMessage>(&mut self, topic: &Topic, reliable: bool) -> Result<ros2_client::Subscription<T>> {
        let (ns, base) = topic.as_str().rsplit_once('/').unwrap_or(("/", topic.as_str()));
        let name = ros2_client::Name::new(ns, base).map_err(|e| anyhow!("bench: {e:?}"))?;
        let qos = if reliable {
            ros2_client::QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth: 1000 })
        } else {
            ros2_client::QosProfile::subscription_default().history(ros2_client::qos::History::KeepLast { depth: 1000 })
        };
        let t = self
            .node
            .create_topic(&name, ros2_client::MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
            .map_err(|e| anyhow!("bench: DDS topic: {e}"))?;
        self.node.create_subscription::<T>(&t, None).map_err(|e| anyhow!("bench: DDS reader: {e}"))
    }
}

/// Takes the next DDS sample within `timeout`.
fn dds_next<T: RosMessage>(sub: &ros2_client::Subscription<T>, timeout: Duration) -> Option<T> {
    let stream = sub.async_stream();
    futures::pin_mut!(stream);
    smol::block_on(async {
        futures::select! {
            r = stream.select_next_some() => r.ok().map(|(m, _)| m),
            _ = futures::FutureExt::fuse(smol::Timer::after(timeout)) => None,
        }
    })
}

/// One payload's numbers, direct and bridged: latency percentiles (us), burst throughput
/// (msgs/s) and the fraction of the burst delivered.
struct Measured {
    direct: ([u64; 2], f64, f64),
    bridged: ([u64; 2], f64, f64),
}

fn pct(mut v: Vec<u64>) -> [u64; 2] {
    v.sort_unstable();
    if v.is_empty() { [0, 0] } else { [v[v.len() / 2], v[(v.len() - 1) * 99 / 100]] }
}

fn measure<T: Stamped>(
    publisher: &mut avacraft_nodes::Publisher<T>,
    direct: &avacraft_nodes::Subscriber<T>,
    dds: &ros2_client::Subscription<T>,
    msg: &T,
    pings: usize,
    burst: usize,
    rate: f64,
) -> Result<Measured> {
    // Warm up until a sample crosses the bridge (discovery and matching take a moment).
    let t0 = Instant::now();
    loop {
        let mut m = msg.clone();
        *m.header_mut() = stamp();
        publisher.put(&m)?;
        if dds_next(dds, Duration::from_millis(200)).is_some() {
            break;
        }
        if t0.elapsed() > Duration::from_secs(20) {
            bail!("bench: nothing crossed the bridge to DDS in 20 s");
        }
    }
    while direct.try_recv()?.is_some() {}
    while dds.take().ok().flatten().is_some() {}
    let (mut lat_direct, mut lat_dds) = (Vec::new(), Vec::new());
    for _ in 0..pings {
        let mut m = msg.clone();
        *m.header_mut() = stamp();
        publisher.put(&m)?;
        if let Some(Ok(r)) = direct.recv_timeout(Duration::from_secs(1))?.map(|r| r.msg) {
            lat_direct.push(age_us(r.header()));
        }
        if let Some(r) = dds_next(dds, Duration::from_secs(1)) {
            lat_dds.push(age_us(r.header()));
        }
    }
    // A stream at `rate` per second (0: as fast as possible): how many arrive, how fast.
    let start = Instant::now();
    for k in 0..burst {
        if rate > 0.0 {
            // Sleeping, not spinning: on two cores a spinning sender starves the bridge.
            let due = start + Duration::from_secs_f64(k as f64 / rate);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
        let mut m = msg.clone();
        *m.header_mut() = stamp();
        publisher.put(&m)?;
    }
    let (mut n_direct, mut n_dds) = (0usize, 0usize);
    let (mut last_direct, mut last_dds) = (start, start);
    let quiet = Duration::from_millis(3000);
    let mut idle = Instant::now();
    while idle.elapsed() < quiet {
        let mut got = false;
        while direct.try_recv()?.is_some() {
            n_direct += 1;
            last_direct = Instant::now();
            got = true;
        }
        while dds.take().ok().flatten().is_some() {
            n_dds += 1;
            last_dds = Instant::now();
            got = true;
        }
        if got {
            idle = Instant::now();
        } else {
            std::thread::sleep(Duration::from_micros(200));
        }
    }
    let rate = |n: usize, last: Instant| n as f64 / last.duration_since(start).as_secs_f64().max(1e-6);
    let part = |n: usize| n as f64 / burst.max(1) as f64;
    Ok(Measured {
        direct: (pct(lat_direct), rate(n_direct, last_direct), part(n_direct)),
        bridged: (pct(lat_dds), rate(n_dds, last_dds), part(n_dds)),
    })
}

pub fn run(out: &mut dyn Write) -> Result<()> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let topics = Topics::default();
    let _router = Node::open(
        &NodeArgs { mode: SessionMode::Router, connect: vec![], listen: vec![endpoint.clone()], ..NodeArgs::default() },
        topics.namespace(),
        &avacraft_nodes::NodeName::tool("router")?,
    )?;
    let args = NodeArgs { mode: SessionMode::Client, connect: vec![endpoint], ..NodeArgs::default() };
    let (team, unit) = (TeamNo::new(1)?, UnitTag::new(1)?);
    let domain = 100 + (std::process::id() % 100) as u16;
    let cfg = BridgeConfig {
        dds_domain: domain,
        dds_networks: vec![std::net::Ipv4Addr::LOCALHOST.into()],
        unit_obs: vec![(team, unit)],
        frames: vec![(team, FrameKind::Screen)],
        frame_size: (160, 120),
        frame_every: 1,
        ..BridgeConfig::default()
    };
    let shutdown = Shutdown::default();
    let bridge_node = Arc::new(Node::open(&args, topics.namespace(), &avacraft_nodes::NodeName::bridge())?);
    let bridge = {
        let (node, topics, shutdown) = (Arc::clone(&bridge_node), topics.clone(), shutdown.clone());
        std::thread::spawn(move || avacraft_bridge::run(&node, &topics, &cfg, &shutdown))
    };
    let node = Node::open(&args, topics.namespace(), &avacraft_nodes::NodeName::tool("bench")?)?;
    let viewer = Node::open(&args, topics.namespace(), &avacraft_nodes::NodeName::tool("viewer")?)?;
    let mut dds = DdsReader::open(domain)?;

    // A real 3m_vlm unit observation, as the simulator publishes it.
    let scenario = Arc::new(avacraft_engine::Scenario::load("3m_vlm").context("bench: 3m_vlm")?);
    let env = avacraft_engine::Env::new(scenario, avacraft_engine::EnvConfig::default(), 1);
    let obs = avacraft_nodes::wire::unit_observation(&env.agent_obs(avacraft_engine::Team::One, 0, 0), Header::default());
    let obs_bytes = avacraft_msgs::encode(&obs).len();
    let obs_topic = topics.unit_obs(team, unit);
    let mut obs_pub = node.publisher::<UnitObservation>(&obs_topic, Qos::Reliable { depth: 10 })?;
    let obs_direct = viewer.subscriber::<UnitObservation>(&obs_topic, Qos::Reliable { depth: 10 })?;
    let obs_dds = dds.subscription::<UnitObservation>(&obs_topic, true)?;

    let frame_topic = topics.frames(team, FrameKind::Screen);
    let frame = Image {
        height: 120,
        width: 160,
        encoding: "rgb8".into(),
        step: 480,
        data: (0..160 * 120 * 3).map(|i| (i % 251) as u8).collect(),
        ..Image::default()
    };
    let mut frame_pub = node.publisher::<Image>(&frame_topic, Qos::BestEffort { depth: 1 })?;
    let frame_direct = viewer.subscriber::<Image>(&frame_topic, Qos::BestEffort { depth: 1000 })?;
    let frame_dds = dds.subscription::<Image>(&frame_topic, false)?;

    // Each payload as fast as the publisher can, then paced: what arrives, and how fast.
    let mut rows = Vec::new();
    for (rate, n) in [(0.0, 3000), (2000.0, 2000), (500.0, 500)] {
        rows.push((
            format!("unit observation (3m_vlm), {obs_bytes} B"),
            rate,
            measure(&mut obs_pub, &obs_direct, &obs_dds, &obs, 200, n, rate)?,
        ));
    }
    // Frames are best effort, as the simulator sends them.
    for (rate, n) in [(0.0, 1000), (200.0, 400)] {
        let name = format!("160x120 rgb8 frame, {} B", frame.data.len());
        rows.push((name, rate, measure(&mut frame_pub, &frame_direct, &frame_dds, &frame, 100, n, rate)?));
    }
    shutdown.request();
    let stats = bridge.join().map_err(|_| anyhow!("bench: the bridge panicked"))??;
    drop(dds.node);

    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "payload",
        "path",
        "sent at (msgs/s)",
        "latency p50 / p99 (us)",
        "arrived msgs/s",
        "MB/s",
        "delivered",
        "latency ratio to direct",
        "rate ratio to direct",
    ]);
    for (name, sent, m) in &rows {
        let bytes: usize = name.split(", ").nth(1).and_then(|b| b.trim_end_matches(" B").parse().ok()).unwrap_or(0);
        for (path, (lat, rate, part), base) in [("Zenoh direct", m.direct, None), ("bridged to DDS", m.bridged, Some(m.direct))] {
            let ratio = |a: f64, b: f64| if b > 0.0 { format!("{:.2}", a / b) } else { "-".into() };
            t.add_row([
                name.clone(),
                path.to_owned(),
                if *sent > 0.0 { format!("{sent:.0}") } else { "max".to_owned() },
                format!("{} / {}", lat[0], lat[1]),
                format!("{rate:.0}"),
                format!("{:.1}", rate * bytes as f64 / 1e6),
                format!("{:.0}%", part * 100.0),
                base.map_or("1.00".into(), |b| ratio(lat[0] as f64, b.0[0] as f64)),
                base.map_or("1.00".into(), |b| ratio(rate, b.1)),
            ]);
        }
    }
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "loopback, one router; the bridge republished {} samples ({} malformed); DDS reader: ros2-client (RustDDS) in this process",
        stats.to_dds.values().sum::<u64>(),
        stats.malformed
    )?;
    Ok(())
}
