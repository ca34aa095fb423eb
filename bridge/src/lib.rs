//! The ROS 2 DDS bridge. ROS 2 Jazzy users on the default DDS middleware see the
//! deployment's topics (`rt/avacraft/...`, types `avacraft_msgs::msg::dds_::X_`) without
//! a Zenoh router, and agents written against DDS drive their units: their actions come
//! back onto the agent's Zenoh action topic, where the simulator checks ownership as for
//! any agent node. Only the action topics of agents the launch file marks `policy: dds`
//! are carried back, so a DDS participant cannot speak for a Zenoh agent node.
//!
//! Each Zenoh topic has a thread that decodes and republishes with ros2-client (RustDDS).
//! Frames are scaled down and thinned first: RustDDS fragments samples over 64 KB and
//! slows down sharply with them.
#![forbid(unsafe_code)]

mod scale;

pub use scale::scale_rgb8;

use avacraft_msgs::{ActionBatch, EpisodeStatus, Image, RosMessage, TeamObservation, UnitObservation};
use avacraft_nodes::{AgentId, FrameKind, Node, NodeError, Qos, Shutdown, TeamNo, Topic, Topics, UnitTag};
use ros2_client::{Context, MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use std::collections::BTreeMap;
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What to bridge.
#[derive(Clone, Debug, Default)]
pub struct BridgeConfig {
    pub dds_domain: u16,
    /// Restrict DDS to these local addresses (empty: every interface).
    pub dds_networks: Vec<IpAddr>,
    pub status: bool,
    pub roles: bool,
    /// Team observations of these teams.
    pub team_obs: Vec<TeamNo>,
    /// Unit observations of these units.
    pub unit_obs: Vec<(TeamNo, UnitTag)>,
    /// Frames of these teams and kinds.
    pub frames: Vec<(TeamNo, FrameKind)>,
    /// Frames go to DDS at this size (width, height) ...
    pub frame_size: (u32, u32),
    /// ... and only one in this many.
    pub frame_every: u32,
    /// Agents whose actions come from DDS, with their team.
    pub dds_agents: Vec<(AgentId, TeamNo)>,
    /// Before announcing the DDS agents' action topics on Zenoh (which lets a lockstep
    /// simulator start), wait up to this long for a DDS writer on each and a DDS reader on
    /// every bridged observation topic of its team.
    pub wait_for_dds: Duration,
}

/// Why the bridge stopped.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    #[error(transparent)]
    Node(#[from] NodeError),
    #[error("DDS: {what}: {message}")]
    Dds { what: String, message: String },
    #[error("DDS agents {missing:?} did not appear within {seconds:.1} s")]
    DdsMissing { missing: Vec<String>, seconds: f64 },
}

fn dds_err(what: impl Into<String>, e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Dds { what: what.into(), message: e.to_string() }
}

/// What crossed the bridge.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BridgeStats {
    /// Samples republished onto DDS, per ROS topic.
    pub to_dds: BTreeMap<String, u64>,
    /// Frames left out by `frame_every`.
    pub frames_thinned: u64,
    /// Action batches carried from DDS to Zenoh.
    pub actions_to_zenoh: u64,
    /// Zenoh samples that did not decode (not forwarded).
    pub malformed: u64,
    /// Samples DDS refused to take (its queue stayed full): lost, and counted here.
    pub dds_refused: u64,
}

#[derive(Debug, Default)]
struct Counters {
    to_dds: Mutex<BTreeMap<String, u64>>,
    thinned: AtomicU64,
    actions: AtomicU64,
    malformed: AtomicU64,
    refused: AtomicU64,
}

/// The ROS name of a topic for ros2-client: namespace and base name.
fn ros_name(topic: &Topic) -> Result<Name, BridgeError> {
    let (ns, base) = topic.namespace_and_base();
    Name::new(ns, base).map_err(|e| dds_err(format!("topic name {topic}"), format!("{e:?}")))
}

fn type_name<T: RosMessage>() -> MessageTypeName {
    MessageTypeName::new(T::PACKAGE, T::NAME)
}

/// Reliable with a deep history (1,000 samples): a burst of observations waits up to
/// 500 ms for slow readers before a publish fails (and is counted). RustDDS's KEEP_ALL lost
/// more under bursts in `bench --bridge`.
fn reliable() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(ros2_client::qos::WhenFull::Wait(Duration::from_millis(500)))
        .history(ros2_client::qos::History::KeepLast { depth: 1000 })
}

fn best_effort() -> QosProfile {
    QosProfile::subscription_default().reliability_best_effort().history(ros2_client::qos::History::KeepLast { depth: 1 })
}

/// The DDS side: context, node, and its spinner on a thread of its own.
struct Dds {
    node: ros2_client::Node,
}

impl Dds {
    fn open(cfg: &BridgeConfig, topics: &Topics) -> Result<Dds, BridgeError> {
        let mut b = ros2_client::dds::rustdds::DomainParticipantBuilder::new(cfg.dds_domain);
        if !cfg.dds_networks.is_empty() {
            b = b.with_only_networks(cfg.dds_networks.iter().copied());
        }
        let dp = b.build().map_err(|e| dds_err("creating the domain participant", e))?;
        let ctx = Context::from_domain_participant(dp).map_err(|e| dds_err("creating the ROS 2 context", e))?;
        let name = NodeName::new(topics.namespace(), "bridge").map_err(|e| dds_err("node name", format!("{e:?}")))?;
        let mut node = ctx.new_node(name, NodeOptions::new().enable_rosout(false)).map_err(|e| dds_err("creating the ROS 2 node", e))?;
        let spinner = node.spinner().map_err(|e| dds_err("starting the ROS 2 spinner", e))?;
        std::thread::Builder::new()
            .name("dds-spinner".into())
            .spawn(move || {
                if let Err(e) = smol::block_on(spinner.spin()) {
                    tracing::warn!(error = %e, "the ROS 2 spinner stopped");
                }
            })
            .map_err(|e| dds_err("spawning the spinner thread", e))?;
        Ok(Dds { node })
    }

    fn publisher<T: RosMessage>(&mut self, topic: &Topic, qos: QosProfile) -> Result<ros2_client::Publisher<T>, BridgeError> {
        let t = self.node.create_topic(&ros_name(topic)?, type_name::<T>(), &qos).map_err(|e| dds_err(format!("topic {topic}"), e))?;
        self.node.create_publisher::<T>(&t, None).map_err(|e| dds_err(format!("publisher {topic}"), e))
    }

    fn subscription<T: RosMessage>(&mut self, topic: &Topic, qos: QosProfile) -> Result<ros2_client::Subscription<T>, BridgeError> {
        let t = self.node.create_topic(&ros_name(topic)?, type_name::<T>(), &qos).map_err(|e| dds_err(format!("topic {topic}"), e))?;
        self.node.create_subscription::<T>(&t, None).map_err(|e| dds_err(format!("subscription {topic}"), e))
    }
}

/// One direction Zenoh → DDS for one topic, on its own thread.
fn forward<T, F>(
    node: &Node,
    dds: &mut Dds,
    topic: &Topic,
    qos: Qos,
    counters: &Arc<Counters>,
    shutdown: &Shutdown,
    mut map: F,
) -> Result<std::thread::JoinHandle<()>, BridgeError>
where
    T: RosMessage + Send + std::fmt::Debug,
    F: FnMut(T) -> Option<T> + Send + 'static,
{
    let sub = node.subscriber::<T>(topic, qos)?;
    let dds_qos = if matches!(qos, Qos::BestEffort { .. }) { best_effort() } else { reliable() };
    let publisher = dds.publisher::<T>(topic, dds_qos)?;
    let (counters, shutdown, name) = (Arc::clone(counters), shutdown.clone(), topic.to_string());
    counters.to_dds.lock().unwrap_or_else(|e| e.into_inner()).insert(name.clone(), 0);
    std::thread::Builder::new()
        .name(format!("bridge {name}"))
        .spawn(move || {
            while !shutdown.requested() {
                let r = match sub.recv_timeout(Duration::from_millis(100)) {
                    Ok(Some(r)) => r,
                    Ok(None) => continue,
                    Err(_) => break,
                };
                let Ok(msg) = r.msg else {
                    counters.malformed.fetch_add(1, Ordering::Relaxed);
                    continue;
                };
                let Some(msg) = map(msg) else { continue };
                match publisher.publish(msg) {
                    Ok(()) => *counters.to_dds.lock().unwrap_or_else(|e| e.into_inner()).entry(name.clone()).or_default() += 1,
                    Err(e) => {
                        counters.refused.fetch_add(1, Ordering::Relaxed);
                        tracing::warn!(topic = %name, error = ?e, "DDS publish failed");
                    }
                }
            }
        })
        .map_err(|e| dds_err("spawning a bridge thread", e))
}

/// Runs until `shutdown`; returns what crossed.
pub fn run(node: &Node, topics: &Topics, cfg: &BridgeConfig, shutdown: &Shutdown) -> Result<BridgeStats, BridgeError> {
    let mut dds = Dds::open(cfg, topics)?;
    let counters = Arc::new(Counters::default());
    let reliable_z = Qos::Reliable { depth: 10 };
    let mut threads = Vec::new();
    // Readers the DDS agents of a team must have before the bridge announces them.
    let dds_teams: Vec<TeamNo> = cfg.dds_agents.iter().map(|(_, t)| *t).collect();
    let mut needed_readers: BTreeMap<TeamNo, Vec<Topic>> = BTreeMap::new();
    if cfg.status {
        threads.push(forward::<EpisodeStatus, _>(node, &mut dds, &topics.status(), reliable_z, &counters, shutdown, Some)?);
    }
    if cfg.roles {
        threads.push(forward::<avacraft_msgs::RoleAssignment, _>(node, &mut dds, &topics.roles(), reliable_z, &counters, shutdown, Some)?);
    }
    for &team in &cfg.team_obs {
        let t = topics.team_obs(team);
        threads.push(forward::<TeamObservation, _>(node, &mut dds, &t, reliable_z, &counters, shutdown, Some)?);
        if dds_teams.contains(&team) {
            needed_readers.entry(team).or_default().push(t);
        }
    }
    for &(team, unit) in &cfg.unit_obs {
        let t = topics.unit_obs(team, unit);
        threads.push(forward::<UnitObservation, _>(node, &mut dds, &t, reliable_z, &counters, shutdown, Some)?);
    }
    for &(team, kind) in &cfg.frames {
        let (size, every) = (cfg.frame_size, cfg.frame_every.max(1) as u64);
        let c = Arc::clone(&counters);
        let mut n = 0u64;
        let thin = move |img: Image| {
            n += 1;
            if !(n - 1).is_multiple_of(every) {
                c.thinned.fetch_add(1, Ordering::Relaxed);
                return None;
            }
            Some(scale_rgb8(img, size))
        };
        threads.push(forward::<Image, _>(
            node,
            &mut dds,
            &topics.frames(team, kind),
            Qos::BestEffort { depth: 1 },
            &counters,
            shutdown,
            thin,
        )?);
    }
    // DDS → Zenoh: the DDS agents' actions.
    let mut subs = Vec::new();
    for (agent, _) in &cfg.dds_agents {
        let topic = topics.actions(agent);
        subs.push((agent.clone(), topic.clone(), dds.subscription::<ActionBatch>(&topic, reliable())?));
    }
    wait_for_dds(&dds, cfg, &subs, &needed_readers, shutdown)?;
    for (agent, topic, sub) in subs {
        // Declared only now: the simulator waits for this publisher's token.
        let mut out = node.publisher::<ActionBatch>(&topic, reliable_z)?;
        let (counters, shutdown) = (Arc::clone(&counters), shutdown.clone());
        threads.push(
            std::thread::Builder::new()
                .name(format!("bridge {agent} actions"))
                .spawn(move || {
                    use futures::StreamExt;
                    let stream = sub.async_stream();
                    futures::pin_mut!(stream);
                    while !shutdown.requested() {
                        let next = smol::block_on(async {
                            futures::select! {
                                r = stream.select_next_some() => Some(r),
                                _ = futures::FutureExt::fuse(smol::Timer::after(Duration::from_millis(100))) => None,
                            }
                        });
                        match next {
                            Some(Ok((batch, _info))) => match out.put(&batch) {
                                Ok(()) => {
                                    counters.actions.fetch_add(1, Ordering::Relaxed);
                                }
                                Err(e) => tracing::warn!(%agent, error = %e, "actions not forwarded"),
                            },
                            Some(Err(e)) => {
                                counters.malformed.fetch_add(1, Ordering::Relaxed);
                                tracing::warn!(%agent, error = ?e, "undecodable DDS action batch");
                            }
                            None => {}
                        }
                    }
                })
                .map_err(|e| dds_err("spawning a bridge thread", e))?,
        );
    }
    tracing::info!(threads = threads.len(), dds_domain = cfg.dds_domain, "bridge up");
    let mut panicked = 0;
    for t in threads {
        if t.join().is_err() {
            panicked += 1;
        }
    }
    if panicked > 0 {
        return Err(BridgeError::Dds { what: format!("{panicked} bridge threads"), message: "panicked".into() });
    }
    Ok(BridgeStats {
        to_dds: counters.to_dds.lock().unwrap_or_else(|e| e.into_inner()).clone(),
        frames_thinned: counters.thinned.load(Ordering::Relaxed),
        actions_to_zenoh: counters.actions.load(Ordering::Relaxed),
        malformed: counters.malformed.load(Ordering::Relaxed),
        dds_refused: counters.refused.load(Ordering::Relaxed),
    })
}

/// Waits for every DDS agent's writer, and for readers on its team's bridged topics.
fn wait_for_dds(
    dds: &Dds,
    cfg: &BridgeConfig,
    subs: &[(AgentId, Topic, ros2_client::Subscription<ActionBatch>)],
    readers: &BTreeMap<TeamNo, Vec<Topic>>,
    shutdown: &Shutdown,
) -> Result<(), BridgeError> {
    if subs.is_empty() {
        return Ok(());
    }
    let start = Instant::now();
    loop {
        let mut missing = Vec::new();
        for (agent, topic, _) in subs {
            if dds.node.publisher_count(topic.as_str()) == 0 {
                missing.push(format!("{agent}: a DDS writer on {topic}"));
            }
        }
        for ts in readers.values() {
            for t in ts {
                if dds.node.subscription_count(t.as_str()) == 0 {
                    missing.push(format!("a DDS reader on {t}"));
                }
            }
        }
        if missing.is_empty() {
            tracing::info!(agents = subs.len(), "every DDS agent is up");
            return Ok(());
        }
        if shutdown.requested() || start.elapsed() > cfg.wait_for_dds {
            return Err(BridgeError::DdsMissing { missing, seconds: start.elapsed().as_secs_f64() });
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}
