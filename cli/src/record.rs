//! The recorder node: every topic under the namespace to MCAP with the ros2 profile
//! (ros2msg schemas, cdr encoding, QoS metadata, zstd chunks, summary and statistics), so
//! rosbag2's MCAP storage and Foxglove read it. Chunks are closed often, so a file whose
//! writer was killed still yields every message written before. The simulator's session
//! description (`<namespace>/session`: scenario text, configuration, seeds) is one of those
//! topics, so a recording replays with nothing else.

use anyhow::{Context, Result};
use avacraft_msgs::{EMBEDDED_TYPES, EpisodeStatus, RosMessage, embedded_registry};
use avacraft_nodes::{Node, NodeArgs, Qos, Shutdown, Topic, TopicKind, Topics, now_ns};
use clap::Args;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::PathBuf;
use std::time::Duration;
use zenoh::Wait;

#[derive(Args, Debug, Clone)]
pub struct RecordArgs {
    #[command(flatten)]
    pub node: NodeArgs,
    /// MCAP file to write.
    #[arg(long, default_value = "session.mcap")]
    pub out: PathBuf,
    /// Stop after this many messages (0: until SIGINT/SIGTERM).
    #[arg(long, default_value_t = 0)]
    pub max_messages: u64,
}

/// Channels the recorder opens at most (a hostile publisher cannot exhaust the file's ids).
const MAX_CHANNELS: usize = 4096;

/// How long the recorder lets messages gather between passes while they keep coming.
const BATCH: Duration = Duration::from_millis(5);

/// What the recorder wrote.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RecordStats {
    pub messages: u64,
    pub channels: usize,
    pub skipped: u64,
}

/// A message type the recorder knows: names, hash and MCAP schema.
#[derive(Debug)]
struct TypeInfo {
    type_name: String,
    dds: String,
    hash: String,
    schema: String,
}

fn known_types() -> Result<Vec<TypeInfo>> {
    let reg = embedded_registry();
    EMBEDDED_TYPES
        .iter()
        .map(|t| {
            let type_name = format!("{}/msg/{}", t.package, t.name);
            Ok(TypeInfo {
                dds: format!("{}::msg::dds_::{}_", t.package, t.name),
                hash: reg.type_hash(&type_name)?,
                schema: reg.ros2msg_schema(&type_name)?,
                type_name,
            })
        })
        .collect()
}

/// The ROS topic and type of a data key `<domain>/<topic...>/<dds type>/<hash>`; `None` for
/// keys of unknown types or invalid topic names.
fn split_key<'a>(types: &'a [TypeInfo], key: &str) -> Option<(Topic, &'a TypeInfo)> {
    let k = avacraft_nodes::ros::parse_data_key(key)?;
    let ty = types.iter().find(|t| t.dds == k.dds_type && t.hash == k.type_hash)?;
    Some((k.topic, ty))
}

/// An MCAP file being written with the ros2 profile: channels opened as their topics first
/// appear, from the messages' data keys. The recorder node and a simulator recording its
/// own traffic ([`record_tapped`]) write through it, so their files are alike.
pub struct McapSink {
    w: mcap::Writer<BufWriter<std::fs::File>>,
    path: PathBuf,
    types: Vec<TypeInfo>,
    topics: Topics,
    channels: BTreeMap<String, u16>,
    schemas: BTreeMap<String, u16>,
    seq: u32,
    stats: RecordStats,
}

impl McapSink {
    pub fn create(path: &std::path::Path, namespace: &str) -> Result<McapSink> {
        let file = std::fs::File::create(path).with_context(|| format!("recorder: creating {}", path.display()))?;
        let opts = mcap::WriteOptions::new().profile("ros2").compression(Some(mcap::Compression::Zstd)).chunk_size(Some(64 * 1024));
        let w = opts.create(BufWriter::new(file)).with_context(|| format!("recorder: starting {}", path.display()))?;
        Ok(McapSink {
            w,
            path: path.to_path_buf(),
            types: known_types()?,
            topics: Topics::new(namespace)?,
            channels: BTreeMap::new(),
            schemas: BTreeMap::new(),
            seq: 0,
            stats: RecordStats::default(),
        })
    }

    /// Writes one message by its data key (skipped, and counted, when the key names no
    /// topic and type of ours or the file has all the channels it may open).
    pub fn write(&mut self, key: &str, payload: &[u8], sent_ns: Option<i64>) -> Result<()> {
        let Some((topic, ty)) = split_key(&self.types, key) else {
            self.stats.skipped += 1;
            return Ok(());
        };
        let channel = match self.channels.get(key) {
            Some(&c) => c,
            None if self.channels.len() >= MAX_CHANNELS => {
                self.stats.skipped += 1;
                return Ok(());
            }
            None => {
                let schema = match self.schemas.get(&ty.type_name) {
                    Some(&s) => s,
                    None => {
                        let s = self.w.add_schema(&ty.type_name, "ros2msg", ty.schema.as_bytes())?;
                        self.schemas.insert(ty.type_name.clone(), s);
                        s
                    }
                };
                // As the simulator offers them: frames best effort, everything else reliable.
                let qos = match self.topics.classify(&topic) {
                    Some(TopicKind::Frames(..)) => Qos::BestEffort { depth: 1 },
                    _ => Qos::Reliable { depth: 10 },
                };
                let meta =
                    BTreeMap::from([("offered_qos_profiles".to_owned(), qos.mcap_yaml()), ("topic_type_hash".to_owned(), ty.hash.clone())]);
                let c = self.w.add_channel(schema, topic.as_str(), "cdr", &meta)?;
                self.channels.insert(key.to_owned(), c);
                c
            }
        };
        let t = now_ns().max(0) as u64;
        // rosbag2's publish time is the sender's timestamp, from rmw_zenoh's attachment.
        let sent = sent_ns.map_or(t, |s| s.max(0) as u64);
        self.seq = self.seq.wrapping_add(1);
        self.w.write_to_known_channel(
            &mcap::records::MessageHeader { channel_id: channel, sequence: self.seq, log_time: t, publish_time: sent },
            payload,
        )?;
        self.stats.messages += 1;
        Ok(())
    }

    pub fn messages(&self) -> u64 {
        self.stats.messages
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<RecordStats> {
        self.stats.channels = self.channels.len();
        self.w.finish().with_context(|| format!("recorder: finishing {}", self.path.display()))?;
        tracing::info!(messages = self.stats.messages, channels = self.stats.channels, "recording closed");
        Ok(self.stats)
    }
}

/// Writes what a node's tap hands over ([`avacraft_nodes::Node::with_tap`]) until every
/// sender is gone, then closes the file: the simulator recording its own traffic.
pub fn record_tapped(
    path: &std::path::Path,
    namespace: &str,
    taps: std::sync::mpsc::Receiver<avacraft_nodes::Tapped>,
) -> Result<RecordStats> {
    let mut sink = McapSink::create(path, namespace)?;
    // Drained in batches: a writer blocked on the channel would be woken by every send, a
    // wake-up per message on the simulator's cores.
    loop {
        match taps.try_recv() {
            Ok(t) => sink.write(&t.key, &t.payload, Some(t.sent_ns))?,
            Err(std::sync::mpsc::TryRecvError::Empty) => std::thread::sleep(BATCH),
            Err(std::sync::mpsc::TryRecvError::Disconnected) => break,
        }
    }
    sink.finish()
}

pub fn run(a: &RecordArgs, shutdown: &Shutdown) -> Result<RecordStats> {
    let node =
        Node::open(&a.node, &a.node.namespace, &avacraft_nodes::NodeName::recorder()).context("recorder: opening the Zenoh session")?;
    let mut sink = McapSink::create(&a.out, &a.node.namespace)?;
    let topics = Topics::new(&a.node.namespace)?;
    let pattern = avacraft_nodes::ros::pattern_space(a.node.domain, &topics.all());
    let sub = node
        .session()
        .declare_subscriber(pattern.clone())
        .with(zenoh::handlers::FifoChannel::new(16384))
        .wait()
        .map_err(|e| anyhow::anyhow!("recorder: subscribing to {pattern}: {e}"))?;
    // Announced after subscribing, so a simulator waiting for it misses nothing.
    let status = topics.status();
    let _token = node.announce_subscription(&status, EpisodeStatus::dds_type_name(), EpisodeStatus::type_hash())?;
    tracing::info!(out = %a.out.display(), %pattern, "recording");
    // After a stop request, keep taking what is already on its way until 200 ms pass quietly.
    let mut quiet_since: Option<std::time::Instant> = None;
    // Whether the last pass took a message: then the next empty queue means a batch ended.
    let mut drained = false;
    while a.max_messages == 0 || sink.messages() < a.max_messages {
        if shutdown.requested() && quiet_since.is_none() {
            quiet_since = Some(std::time::Instant::now());
        }
        if quiet_since.is_some_and(|t| t.elapsed() > Duration::from_millis(200)) {
            break;
        }
        // One wake-up per batch, not per message: under lockstep the simulator sends tens of
        // thousands of messages a second, and a recorder woken for each took a core's share
        // from the processes it records. The first message of a lull is taken at once.
        let sample = match sub.try_recv() {
            Ok(Some(s)) => s,
            Ok(None) if drained => {
                drained = false;
                std::thread::sleep(BATCH);
                continue;
            }
            Ok(None) => match sub.recv_timeout(Duration::from_millis(50)) {
                Ok(Some(s)) => s,
                Ok(None) => continue,
                Err(_) => break,
            },
            Err(_) => break,
        };
        drained = true;
        if quiet_since.is_some() {
            quiet_since = Some(std::time::Instant::now());
        }
        let sent = sample.attachment().and_then(|b| avacraft_nodes::ros::parse_attachment(&b.to_bytes())).map(|att| att.source_ns);
        sink.write(sample.key_expr().as_str(), &sample.payload().to_bytes(), sent)?;
    }
    sink.finish()
}

/// `avacraft record`: records until stopped (SIGINT, SIGTERM).
pub fn command(a: &RecordArgs) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    run(a, &shutdown)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_keys_split_into_topic_and_type() {
        let types = known_types().expect("types");
        let ty = types.iter().find(|t| t.type_name == "avacraft_msgs/msg/ActionBatch").expect("type");
        let key = format!("0/avacraft/agents/a/actions/{}/{}", ty.dds, ty.hash);
        let (topic, got) = split_key(&types, &key).expect("split");
        assert_eq!(topic.as_str(), "/avacraft/agents/a/actions");
        assert_eq!(got.type_name, ty.type_name);
        assert!(split_key(&types, "0/avacraft/x/unknown_::msg::dds_::X_/RIHS01_00").is_none());
    }
}
