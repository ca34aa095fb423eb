//! The live view's channels: the one place their topic names, message encodings and schemas
//! are written down, for the WebSocket server's advertisement and for recordings (MCAP
//! channels beside the ROS 2 topics), so that a layout made for one opens the other.

use avacraft_nodes::{LiveTopic, Topic, TopicKind, Topics};
use foxglove::Encode;
use foxglove::schemas::{ImageAnnotations, Log, RawImage, SceneUpdate};

/// A channel of the live view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LiveChannel {
    /// Team 1's screen (the MARL screen, fog of war included), `foxglove.RawImage` rgb8.
    Screen,
    /// The whole map as team 1 sees it, `foxglove.RawImage` rgb8.
    Minimap,
    /// Every visible unit as a 3D entity, `foxglove.SceneUpdate`.
    Scene,
    /// Unit rings, health and tags over the screen, `foxglove.ImageAnnotations`.
    Annotations,
    /// Agents' orders, AVA's reasoning and model calls, `foxglove.Log`.
    Log,
    /// The episode's status (scenario, seed, step, game time, units left, result), JSON.
    Status,
}

impl LiveChannel {
    pub const ALL: [LiveChannel; 6] =
        [LiveChannel::Screen, LiveChannel::Minimap, LiveChannel::Scene, LiveChannel::Annotations, LiveChannel::Log, LiveChannel::Status];

    /// The channel's topic name (also its MCAP topic), from the deployment's topic module
    /// under the default namespace.
    pub fn topic(self) -> Topic {
        Topics::default().live(self.live_topic())
    }

    fn live_topic(self) -> LiveTopic {
        match self {
            LiveChannel::Screen => LiveTopic::ScreenImage,
            LiveChannel::Minimap => LiveTopic::MinimapImage,
            LiveChannel::Scene => LiveTopic::SceneUpdate,
            LiveChannel::Annotations => LiveTopic::ScreenAnnotations,
            LiveChannel::Log => LiveTopic::LogLines,
            LiveChannel::Status => LiveTopic::EpisodeStatus,
        }
    }

    /// The channel with this topic name.
    pub fn from_topic(topic: &str) -> Option<LiveChannel> {
        let kind = Topics::default().classify(&Topic::parse(topic).ok()?)?;
        LiveChannel::ALL.into_iter().find(|c| kind == TopicKind::Live(c.live_topic()))
    }

    /// Its id on the WebSocket server (stable: a layout or a client may keep it).
    pub fn id(self) -> u64 {
        match self {
            LiveChannel::Screen => 1,
            LiveChannel::Minimap => 2,
            LiveChannel::Scene => 3,
            LiveChannel::Annotations => 4,
            LiveChannel::Log => 5,
            LiveChannel::Status => 6,
        }
    }

    pub fn from_id(id: u64) -> Option<LiveChannel> {
        LiveChannel::ALL.into_iter().find(|c| c.id() == id)
    }

    /// The message encoding (`protobuf` for Foxglove's schemas, `json` for the status).
    pub fn encoding(self) -> String {
        match self {
            LiveChannel::Screen | LiveChannel::Minimap => RawImage::get_message_encoding(),
            LiveChannel::Scene => SceneUpdate::get_message_encoding(),
            LiveChannel::Annotations => ImageAnnotations::get_message_encoding(),
            LiveChannel::Log => Log::get_message_encoding(),
            LiveChannel::Status => "json".into(),
        }
    }

    /// The schema: its name, encoding and data (a protobuf FileDescriptorSet, or a JSON
    /// Schema for the status).
    pub fn schema(self) -> (String, String, Vec<u8>) {
        let of = |s: Option<foxglove::Schema>| s.map(|s| (s.name, s.encoding, s.data.into_owned()));
        let s = match self {
            LiveChannel::Screen | LiveChannel::Minimap => of(RawImage::get_schema()),
            LiveChannel::Scene => of(SceneUpdate::get_schema()),
            LiveChannel::Annotations => of(ImageAnnotations::get_schema()),
            LiveChannel::Log => of(Log::get_schema()),
            LiveChannel::Status => None,
        };
        s.unwrap_or_else(|| ("avacraft.EpisodeStatus".into(), "jsonschema".into(), STATUS_SCHEMA.as_bytes().to_vec()))
    }
}

/// The status channel's JSON Schema.
const STATUS_SCHEMA: &str = r#"{"type":"object","properties":{"scenario":{"type":"string"},"seed":{"type":"integer"},"episode":{"type":"integer"},"step":{"type":"integer"},"game_loop":{"type":"integer"},"game_seconds":{"type":"number"},"units_left":{"type":"array","items":{"type":"integer"}},"result":{"type":"string"}}}"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_ids_and_schemas_are_distinct_and_round_trip() {
        let mut topics = std::collections::BTreeSet::new();
        for c in LiveChannel::ALL {
            assert_eq!(LiveChannel::from_topic(c.topic().as_str()), Some(c));
            assert_eq!(LiveChannel::from_id(c.id()), Some(c));
            assert!(topics.insert(c.topic().as_str().to_owned()));
            let (name, enc, data) = c.schema();
            assert!(!data.is_empty(), "{c:?}");
            match c {
                LiveChannel::Status => assert_eq!((enc.as_str(), c.encoding().as_str()), ("jsonschema", "json")),
                _ => assert!(name.starts_with("foxglove.") && enc == "protobuf" && c.encoding() == "protobuf", "{c:?}: {name} {enc}"),
            }
        }
        assert!(serde_json::from_str::<serde_json::Value>(STATUS_SCHEMA).is_ok());
    }
}
