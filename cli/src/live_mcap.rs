//! The live view's channels in a recording: once a session's MCAP is closed, every
//! recorded episode is re-simulated from the file (as `replay` does) and the live view's
//! messages are added beside the ROS 2 topics, each at the log time of the step's recorded
//! status, so Foxglove or Lichtblick shows a recording with the same layout as a live run.
//!
//! The file is rewritten through a temporary file and renamed over the original only when
//! complete: whatever goes wrong, the recording as the recorder closed it stays.

use crate::replay::{read_recording, replay_episode};
use anyhow::{Context, Result, bail};
use avacraft_engine::Env;
use avacraft_live::{Framer, LiveChannel, ViewSize, Wire};
use avacraft_nodes::Qos;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

/// The images recordings carry: a quarter of the live view's pixels, as every step of
/// every episode is kept.
pub const RECORDED_VIEW: ViewSize = ViewSize { screen: (320, 240), minimap: 128 };

/// What was added.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Added {
    pub episodes: usize,
    pub messages: u64,
    /// Of the messages: AVA agent nodes' model calls, as log lines.
    pub calls: u64,
}

/// Adds the live view's channels to the recording at `path` (see the module's docs).
pub fn add_live_channels(path: &Path) -> Result<Added> {
    let shown = path.display();
    let bytes = std::fs::read(path).with_context(|| format!("reading {shown}"))?;
    if mcap::MessageStream::new(&bytes)?.filter_map(Result::ok).any(|m| LiveChannel::from_topic(&m.channel.topic).is_some()) {
        bail!("{shown} already has the live view's channels");
    }
    let rec = read_recording(&bytes).with_context(|| format!("{shown}: not a replayable session"))?;
    let tmp = path.with_extension("mcap.live-tmp");
    let result = write(&bytes, &rec, &tmp);
    match result {
        Ok(added) => {
            std::fs::rename(&tmp, path).with_context(|| format!("replacing {shown}"))?;
            Ok(added)
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

fn write(bytes: &[u8], rec: &crate::replay::Recording, out: &Path) -> Result<Added> {
    let file = std::fs::File::create(out).with_context(|| format!("creating {}", out.display()))?;
    let opts = mcap::WriteOptions::new().profile("ros2").compression(Some(mcap::Compression::Zstd)).chunk_size(Some(1 << 20));
    let mut w = opts.create(BufWriter::new(file))?;
    let mut calls = Vec::new();
    let mut agents: BTreeMap<u16, Option<String>> = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes)? {
        let m = m?;
        w.write(&m)?;
        let agent = agents.entry(m.channel.id).or_insert_with(|| model_calls_agent(&m.channel.topic));
        if let Some(agent) = agent {
            // A call that does not decode stays in the recording, only not in the log.
            if let Ok(c) = avacraft_msgs::decode::<avacraft_msgs::ModelCall>(&m.data) {
                calls.extend(crate::live::model_call_line(agent, &c).map(|line| (m.log_time, line)));
            }
        }
    }
    let mut ids = BTreeMap::new();
    for c in LiveChannel::ALL {
        // As ROS 2 topics, like the rest of the file: rosbag2's profile and QoS metadata.
        let (type_name, schema, hash) = avacraft_live::ros2_type(c);
        let schema = w.add_schema(type_name, "ros2msg", schema.as_bytes())?;
        let qos = if matches!(c, LiveChannel::Screen | LiveChannel::Minimap) {
            Qos::BestEffort { depth: 1 }
        } else {
            Qos::Reliable { depth: 10 }
        };
        let meta = BTreeMap::from([("offered_qos_profiles".to_owned(), qos.mcap_yaml()), ("topic_type_hash".to_owned(), hash.to_owned())]);
        ids.insert(c, w.add_channel(schema, c.topic().as_str(), "cdr", &meta)?);
    }
    let mut framer = Framer::with_wire(RECORDED_VIEW, Wire::Ros2);
    let mut added = Added::default();
    let mut seq = 0u32;
    for (&episode, ep) in &rec.episodes {
        let mut last_t = ep.status_times.values().next().copied().unwrap_or(0);
        let mut failed = None;
        let mut sink = |env: &Env| -> Result<()> {
            // A step's frames go where its status was recorded (or just after the last one).
            let t = ep.status_times.get(&env.steps()).copied().unwrap_or(last_t + 1).max(last_t);
            last_t = t;
            for (ch, _, data) in framer.frame(env, &|_| true) {
                seq = seq.wrapping_add(1);
                let header = mcap::records::MessageHeader { channel_id: ids[&ch], sequence: seq, log_time: t, publish_time: t };
                if let Err(e) = w.write_to_known_channel(&header, &data) {
                    failed.get_or_insert(e);
                }
                added.messages += 1;
            }
            Ok(())
        };
        replay_episode(episode, ep, Some(&mut sink))?;
        if let Some(e) = failed {
            return Err(e.into());
        }
        added.episodes += 1;
    }
    // AVA agent nodes' model calls, at the times they were recorded.
    for (t, (level, name, text)) in calls {
        seq = seq.wrapping_add(1);
        let header = mcap::records::MessageHeader { channel_id: ids[&LiveChannel::Log], sequence: seq, log_time: t, publish_time: t };
        w.write_to_known_channel(&header, &avacraft_live::log_bytes(Wire::Ros2, t, level, &name, &text))?;
        added.messages += 1;
        added.calls += 1;
    }
    w.finish()?;
    Ok(added)
}

/// The agent whose model calls a recorded topic carries, if it is such a topic.
fn model_calls_agent(topic: &str) -> Option<String> {
    let topic = avacraft_nodes::Topic::parse(topic).ok()?;
    match avacraft_nodes::Topics::find(&topic)?.1 {
        avacraft_nodes::TopicKind::ModelCalls(agent) => Some(agent.as_str().to_owned()),
        _ => None,
    }
}
