//! The live view's messages as ROS 2 messages, for recordings: `sensor_msgs/Image` for the two
//! images, `foxglove_msgs` for the scene, the annotations and the log, `std_msgs/String` for
//! the status's JSON, all CDR through `avacraft_msgs`' one encoder. A recording then holds
//! ROS 2 messages only, which ROS 2 readers (rosbags, rosbag2) open and Foxglove shows with
//! the same panels as the live server's protobuf messages.

use crate::channels::LiveChannel;
use avacraft_msgs::builtin_interfaces::{Duration, Time};
use avacraft_msgs::foxglove_msgs as fm;
use avacraft_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3};
use avacraft_msgs::{Header, Image, RosMessage, StdString, encode};
use foxglove::messages as fx;

/// A channel's ROS 2 type: its name, `ros2msg` schema and REP-2016 hash.
pub fn ros2_type(c: LiveChannel) -> (&'static str, &'static str, &'static str) {
    fn of<T: RosMessage>() -> (&'static str, &'static str, &'static str) {
        (T::TYPE_NAME, T::schema(), T::type_hash())
    }
    match c {
        LiveChannel::Screen | LiveChannel::Minimap => of::<Image>(),
        LiveChannel::Scene => of::<fm::SceneUpdate>(),
        LiveChannel::Annotations => of::<fm::ImageAnnotations>(),
        LiveChannel::Log => of::<fm::Log>(),
        LiveChannel::Status => of::<StdString>(),
    }
}

fn time(t: Option<fx::Timestamp>) -> Time {
    t.map_or_else(Time::default, |t| Time { sec: t.sec() as i32, nanosec: t.nsec() })
}

fn color(c: Option<fx::Color>) -> fm::Color {
    c.map_or_else(fm::Color::default, |c| fm::Color { r: c.r, g: c.g, b: c.b, a: c.a })
}

fn vector(v: Option<fx::Vector3>) -> Vector3 {
    v.map_or_else(Vector3::default, |v| Vector3 { x: v.x, y: v.y, z: v.z })
}

fn pose(p: Option<fx::Pose>) -> Pose {
    let Some(p) = p else { return Pose::default() };
    let position = p.position.map_or_else(Point::default, |v| Point { x: v.x, y: v.y, z: v.z });
    let orientation = p.orientation.map_or_else(Quaternion::default, |q| Quaternion { x: q.x, y: q.y, z: q.z, w: q.w });
    Pose { position, orientation }
}

fn point2(p: Option<fx::Point2>) -> fm::Point2 {
    p.map_or_else(fm::Point2::default, |p| fm::Point2 { x: p.x, y: p.y })
}

/// `sensor_msgs/Image` of a live image (rgb8, rows top down as both have them).
pub fn image(m: &fx::RawImage) -> Image {
    Image {
        header: Header { stamp: time(m.timestamp), frame_id: m.frame_id.clone() },
        height: m.height,
        width: m.width,
        encoding: m.encoding.clone(),
        is_bigendian: 0,
        step: m.step,
        data: m.data.to_vec(),
    }
}

/// The scene, with the primitives the live view draws (cylinders and texts); it draws no
/// other kind, so the other lists stay empty.
pub fn scene(m: &fx::SceneUpdate) -> fm::SceneUpdate {
    let deletions = m
        .deletions
        .iter()
        .map(|d| fm::SceneEntityDeletion { timestamp: time(d.timestamp), r#type: d.r#type as u8, id: d.id.clone() })
        .collect();
    let entities = m
        .entities
        .iter()
        .map(|e| fm::SceneEntity {
            timestamp: time(e.timestamp),
            frame_id: e.frame_id.clone(),
            id: e.id.clone(),
            lifetime: e.lifetime.map_or_else(Duration::default, |d| Duration { sec: d.sec(), nanosec: d.nsec() }),
            frame_locked: e.frame_locked,
            metadata: e.metadata.iter().map(|k| fm::KeyValuePair { key: k.key.clone(), value: k.value.clone() }).collect(),
            cylinders: e
                .cylinders
                .iter()
                .map(|c| fm::CylinderPrimitive {
                    pose: pose(c.pose),
                    size: vector(c.size),
                    bottom_scale: c.bottom_scale,
                    top_scale: c.top_scale,
                    color: color(c.color),
                })
                .collect(),
            texts: e
                .texts
                .iter()
                .map(|t| fm::TextPrimitive {
                    pose: pose(t.pose),
                    billboard: t.billboard,
                    font_size: t.font_size,
                    scale_invariant: t.scale_invariant,
                    color: color(t.color),
                    text: t.text.clone(),
                })
                .collect(),
            ..fm::SceneEntity::default()
        })
        .collect();
    fm::SceneUpdate { deletions, entities }
}

/// The annotations the live view draws over the screen (circles and texts).
pub fn annotations(m: &fx::ImageAnnotations) -> fm::ImageAnnotations {
    fm::ImageAnnotations {
        circles: m
            .circles
            .iter()
            .map(|c| fm::CircleAnnotation {
                timestamp: time(c.timestamp),
                position: point2(c.position),
                diameter: c.diameter,
                thickness: c.thickness,
                fill_color: color(c.fill_color),
                outline_color: color(c.outline_color),
            })
            .collect(),
        points: Vec::new(),
        texts: m
            .texts
            .iter()
            .map(|t| fm::TextAnnotation {
                timestamp: time(t.timestamp),
                position: point2(t.position),
                text: t.text.clone(),
                font_size: t.font_size,
                text_color: color(t.text_color),
                background_color: color(t.background_color),
            })
            .collect(),
    }
}

/// A log line (Foxglove's levels are the `.msg`'s numbers).
pub fn log(m: &fx::Log) -> fm::Log {
    fm::Log {
        timestamp: time(m.timestamp),
        level: u8::try_from(m.level).unwrap_or(fm::Log::UNKNOWN),
        message: m.message.clone(),
        name: m.name.clone(),
        file: m.file.clone(),
        line: m.line,
    }
}

/// The status's JSON as `std_msgs/String`.
pub fn status(json: String) -> Vec<u8> {
    encode(&StdString { data: json })
}
