//! Rust images of the standard geometry types and the `foxglove_msgs` the live view records
//! (a 3D scene, image annotations, log lines), so that recordings carry them as ROS 2 CDR
//! like every other topic. Field order is the wire format, as in `types`.

use crate::types::Time;
use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    pub sec: i32,
    pub nanosec: u32,
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Default for Quaternion {
    /// No rotation, as the `.msg`'s defaults say.
    fn default() -> Self {
        Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

/// `foxglove_msgs/msg/Color`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

/// `foxglove_msgs/msg/KeyValuePair`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyValuePair {
    pub key: String,
    pub value: String,
}

/// `foxglove_msgs/msg/Point2`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point2 {
    pub x: f64,
    pub y: f64,
}

/// `foxglove_msgs/msg/ArrowPrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ArrowPrimitive {
    pub pose: Pose,
    pub shaft_length: f64,
    pub shaft_diameter: f64,
    pub head_length: f64,
    pub head_diameter: f64,
    pub color: Color,
}

/// `foxglove_msgs/msg/CubePrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CubePrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove_msgs/msg/SpherePrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SpherePrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove_msgs/msg/CylinderPrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CylinderPrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub bottom_scale: f64,
    pub top_scale: f64,
    pub color: Color,
}

/// `foxglove_msgs/msg/LinePrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LinePrimitive {
    pub r#type: u8,
    pub pose: Pose,
    pub thickness: f64,
    pub scale_invariant: bool,
    pub points: Vec<Point>,
    pub color: Color,
    pub colors: Vec<Color>,
    pub indices: Vec<u32>,
}

/// `foxglove_msgs/msg/TriangleListPrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TriangleListPrimitive {
    pub pose: Pose,
    pub points: Vec<Point>,
    pub color: Color,
    pub colors: Vec<Color>,
    pub indices: Vec<u32>,
}

/// `foxglove_msgs/msg/TextPrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TextPrimitive {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

/// `foxglove_msgs/msg/ModelPrimitive`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelPrimitive {
    pub pose: Pose,
    pub scale: Vector3,
    pub color: Color,
    pub override_color: bool,
    pub url: String,
    pub media_type: String,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `foxglove_msgs/msg/SceneEntity`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: String,
    pub id: String,
    pub lifetime: Duration,
    pub frame_locked: bool,
    pub metadata: Vec<KeyValuePair>,
    pub arrows: Vec<ArrowPrimitive>,
    pub cubes: Vec<CubePrimitive>,
    pub spheres: Vec<SpherePrimitive>,
    pub cylinders: Vec<CylinderPrimitive>,
    pub lines: Vec<LinePrimitive>,
    pub triangles: Vec<TriangleListPrimitive>,
    pub texts: Vec<TextPrimitive>,
    pub models: Vec<ModelPrimitive>,
}

/// `foxglove_msgs/msg/SceneEntityDeletion`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SceneEntityDeletion {
    pub timestamp: Time,
    pub r#type: u8,
    pub id: String,
}

impl SceneEntityDeletion {
    pub const MATCHING_ID: u8 = 0;
    pub const ALL: u8 = 1;
}

/// `foxglove_msgs/msg/SceneUpdate`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneUpdate {
    pub deletions: Vec<SceneEntityDeletion>,
    pub entities: Vec<SceneEntity>,
}

/// `foxglove_msgs/msg/CircleAnnotation`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CircleAnnotation {
    pub timestamp: Time,
    pub position: Point2,
    pub diameter: f64,
    pub thickness: f64,
    pub fill_color: Color,
    pub outline_color: Color,
}

/// `foxglove_msgs/msg/PointsAnnotation`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PointsAnnotation {
    pub timestamp: Time,
    pub r#type: u8,
    pub points: Vec<Point2>,
    pub outline_color: Color,
    pub outline_colors: Vec<Color>,
    pub fill_color: Color,
    pub thickness: f64,
}

/// `foxglove_msgs/msg/TextAnnotation`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TextAnnotation {
    pub timestamp: Time,
    pub position: Point2,
    pub text: String,
    pub font_size: f64,
    pub text_color: Color,
    pub background_color: Color,
}

/// `foxglove_msgs/msg/ImageAnnotations`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImageAnnotations {
    pub circles: Vec<CircleAnnotation>,
    pub points: Vec<PointsAnnotation>,
    pub texts: Vec<TextAnnotation>,
}

/// `foxglove_msgs/msg/Log` (named `LogLine` in Rust: `log` is a crate's name).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LogLine {
    pub timestamp: Time,
    pub level: u8,
    pub message: String,
    pub name: String,
    pub file: String,
    pub line: u32,
}

impl LogLine {
    pub const UNKNOWN: u8 = 0;
    pub const DEBUG: u8 = 1;
    pub const INFO: u8 = 2;
    pub const WARNING: u8 = 3;
    pub const ERROR: u8 = 4;
    pub const FATAL: u8 = 5;
}
