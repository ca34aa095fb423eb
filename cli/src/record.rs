//! The recorder node: every topic under the namespace to MCAP with the ros2 profile
//! (ros2msg schemas, cdr encoding, QoS metadata, zstd chunks, summary and statistics), so
//! rosbag2's MCAP storage and Foxglove read it. Chunks are closed often, so a file whose
//! writer was killed still yields every message written before. The simulator's session
//! description (`<namespace>/session`: scenario text, configuration, seeds) is one of those
//! topics, so a recording replays with nothing else.

use anyhow::{Context, Result};
use avacraft_msgs::{EMBEDDED_TYPES, RosMessage, embedded_registry};
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

pub fn run(a: &RecordArgs, shutdown: &Shutdown) -> Result<RecordStats> {
    let node =
        Node::open(&a.node, &a.node.namespace, &avacraft_nodes::NodeName::recorder()).context("recorder: opening the Zenoh session")?;
    let file = std::fs::File::create(&a.out).with_context(|| format!("recorder: creating {}", a.out.display()))?;
    let opts = mcap::WriteOptions::new().profile("ros2").compression(Some(mcap::Compression::Zstd)).chunk_size(Some(64 * 1024));
    let mut w = opts.create(BufWriter::new(file)).with_context(|| format!("recorder: starting {}", a.out.display()))?;
    let pattern = format!("{}/{}/**", a.node.domain, a.node.namespace.trim_matches('/'));
    let sub = node
        .session()
        .declare_subscriber(pattern.clone())
        .with(zenoh::handlers::FifoChannel::new(16384))
        .wait()
        .map_err(|e| anyhow::anyhow!("recorder: subscribing to {pattern}: {e}"))?;
    let types = known_types()?;
    // Announced after subscribing, so a simulator waiting for it misses nothing.
    let topics = Topics::new(&a.node.namespace)?;
    let status = topics.status();
    let _token =
        node.announce_subscription(&status, "avacraft_msgs::msg::dds_::EpisodeStatus_", avacraft_msgs::EpisodeStatus::type_hash())?;
    let mut channels: BTreeMap<String, u16> = BTreeMap::new();
    let mut schemas: BTreeMap<String, u16> = BTreeMap::new();
    let mut stats = RecordStats::default();
    let mut seq = 0u32;
    tracing::info!(out = %a.out.display(), %pattern, "recording");
    // After a stop request, keep taking what is already on its way until 200 ms pass quietly.
    let mut quiet_since: Option<std::time::Instant> = None;
    // Whether the last pass took a message: then the next empty queue means a batch ended.
    let mut drained = false;
    while a.max_messages == 0 || stats.messages < a.max_messages {
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
        let key = sample.key_expr().as_str().to_owned();
        let Some((topic, ty)) = split_key(&types, &key) else {
            stats.skipped += 1;
            continue;
        };
        let channel = match channels.get(&key) {
            Some(&c) => c,
            None if channels.len() >= MAX_CHANNELS => {
                stats.skipped += 1;
                continue;
            }
            None => {
                let schema = match schemas.get(&ty.type_name) {
                    Some(&s) => s,
                    None => {
                        let s = w.add_schema(&ty.type_name, "ros2msg", ty.schema.as_bytes())?;
                        schemas.insert(ty.type_name.clone(), s);
                        s
                    }
                };
                // As the simulator offers them: frames best effort, everything else reliable.
                let qos = match topics.classify(&topic) {
                    Some(TopicKind::Frames(..)) => Qos::BestEffort { depth: 1 },
                    _ => Qos::Reliable { depth: 10 },
                };
                let meta =
                    BTreeMap::from([("offered_qos_profiles".to_owned(), qos.mcap_yaml()), ("topic_type_hash".to_owned(), ty.hash.clone())]);
                let c = w.add_channel(schema, topic.as_str(), "cdr", &meta)?;
                channels.insert(key.clone(), c);
                c
            }
        };
        let t = now_ns().max(0) as u64;
        // rosbag2's publish time is the sender's timestamp, from rmw_zenoh's attachment.
        let sent = sample
            .attachment()
            .and_then(|b| avacraft_nodes::ros::parse_attachment(&b.to_bytes()))
            .map_or(t, |att| att.source_ns.max(0) as u64);
        seq = seq.wrapping_add(1);
        let payload = sample.payload().to_bytes();
        w.write_to_known_channel(
            &mcap::records::MessageHeader { channel_id: channel, sequence: seq, log_time: t, publish_time: sent },
            &payload,
        )?;
        stats.messages += 1;
    }
    stats.channels = channels.len();
    w.finish().with_context(|| format!("recorder: finishing {}", a.out.display()))?;
    tracing::info!(messages = stats.messages, channels = stats.channels, "recording closed");
    Ok(stats)
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
