//! The `RosMessage` trait and the table tying each Rust type to its `.msg` file.

use std::sync::OnceLock;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::registry::Registry;

/// A Rust type that is the wire image of one ROS 2 message type.
///
/// The names and hash are what rmw_zenoh puts in key expressions and
/// liveliness tokens, and what MCAP channels carry, so they are derived from
/// the `.msg` text rather than written by hand.
pub trait RosMessage: Serialize + DeserializeOwned + 'static {
    /// ROS package, e.g. `avacraft_msgs`.
    const PACKAGE: &'static str;
    /// Message name, e.g. `UnitAction`.
    const NAME: &'static str;
    /// Full ROS 2 name, e.g. `avacraft_msgs/msg/UnitAction` (also the MCAP schema name).
    const TYPE_NAME: &'static str;
    /// The `.msg` source, verbatim.
    const DEFINITION: &'static str;

    /// MCAP `ros2msg` schema data (definition plus all dependencies).
    fn schema() -> &'static str;
    /// REP-2016 hash, `RIHS01_<64 hex>`.
    fn type_hash() -> &'static str;
    /// DDS / rmw_zenoh type name, e.g. `avacraft_msgs::msg::dds_::UnitAction_`.
    fn dds_type_name() -> &'static str;
}

/// One `.msg` file compiled into the crate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EmbeddedType {
    pub package: &'static str,
    pub name: &'static str,
    pub definition: &'static str,
}

/// Builds the registry of every embedded `.msg` file once.
///
/// # Panics
/// If an embedded `.msg` file does not parse. They are compile-time constants
/// and the test suite parses each one, so this is a build defect, not input.
pub fn embedded_registry() -> &'static Registry {
    static REGISTRY: OnceLock<Registry> = OnceLock::new();
    REGISTRY.get_or_init(|| {
        let mut registry = Registry::new();
        for t in EMBEDDED_TYPES {
            if let Err(e) = registry.add(t.package, t.name, t.definition) {
                panic!("embedded definition does not parse: {e}");
            }
        }
        registry
    })
}

/// Computes a per-type string from the embedded registry; see [`embedded_registry`] for the panic.
fn derive_embedded<E: std::fmt::Display>(type_name: &str, f: impl FnOnce(&Registry, &str) -> Result<String, E>) -> String {
    match f(embedded_registry(), type_name) {
        Ok(s) => s,
        Err(e) => panic!("embedded type {type_name} cannot be described: {e}"),
    }
}

macro_rules! ros_messages {
    ($($ty:ty => $pkg:literal, $name:literal, $file:literal;)*) => {
        /// Every `.msg` file compiled into this crate, own and standard types alike.
        pub const EMBEDDED_TYPES: &[EmbeddedType] = &[
            $(EmbeddedType { package: $pkg, name: $name, definition: include_str!($file) },)*
        ];

        $(
            impl RosMessage for $ty {
                const PACKAGE: &'static str = $pkg;
                const NAME: &'static str = $name;
                const TYPE_NAME: &'static str = concat!($pkg, "/msg/", $name);
                const DEFINITION: &'static str = include_str!($file);

                fn schema() -> &'static str {
                    static SCHEMA: OnceLock<String> = OnceLock::new();
                    SCHEMA.get_or_init(|| derive_embedded(Self::TYPE_NAME, Registry::ros2msg_schema))
                }

                fn type_hash() -> &'static str {
                    static HASH: OnceLock<String> = OnceLock::new();
                    HASH.get_or_init(|| derive_embedded(Self::TYPE_NAME, Registry::type_hash))
                }

                fn dds_type_name() -> &'static str {
                    concat!($pkg, "::msg::dds_::", $name, "_")
                }
            }
        )*
    };
}

use crate::foxglove::*;
use crate::types::*;

ros_messages! {
    Time => "builtin_interfaces", "Time", "../std/builtin_interfaces/msg/Time.msg";
    Header => "std_msgs", "Header", "../std/std_msgs/msg/Header.msg";
    StdString => "std_msgs", "String", "../std/std_msgs/msg/String.msg";
    Image => "sensor_msgs", "Image", "../std/sensor_msgs/msg/Image.msg";
    Duration => "builtin_interfaces", "Duration", "../std/builtin_interfaces/msg/Duration.msg";
    Point => "geometry_msgs", "Point", "../std/geometry_msgs/msg/Point.msg";
    Vector3 => "geometry_msgs", "Vector3", "../std/geometry_msgs/msg/Vector3.msg";
    Quaternion => "geometry_msgs", "Quaternion", "../std/geometry_msgs/msg/Quaternion.msg";
    Pose => "geometry_msgs", "Pose", "../std/geometry_msgs/msg/Pose.msg";
    Color => "foxglove_msgs", "Color", "../std/foxglove_msgs/msg/Color.msg";
    KeyValuePair => "foxglove_msgs", "KeyValuePair", "../std/foxglove_msgs/msg/KeyValuePair.msg";
    Point2 => "foxglove_msgs", "Point2", "../std/foxglove_msgs/msg/Point2.msg";
    ArrowPrimitive => "foxglove_msgs", "ArrowPrimitive", "../std/foxglove_msgs/msg/ArrowPrimitive.msg";
    CubePrimitive => "foxglove_msgs", "CubePrimitive", "../std/foxglove_msgs/msg/CubePrimitive.msg";
    SpherePrimitive => "foxglove_msgs", "SpherePrimitive", "../std/foxglove_msgs/msg/SpherePrimitive.msg";
    CylinderPrimitive => "foxglove_msgs", "CylinderPrimitive", "../std/foxglove_msgs/msg/CylinderPrimitive.msg";
    LinePrimitive => "foxglove_msgs", "LinePrimitive", "../std/foxglove_msgs/msg/LinePrimitive.msg";
    TriangleListPrimitive => "foxglove_msgs", "TriangleListPrimitive", "../std/foxglove_msgs/msg/TriangleListPrimitive.msg";
    TextPrimitive => "foxglove_msgs", "TextPrimitive", "../std/foxglove_msgs/msg/TextPrimitive.msg";
    ModelPrimitive => "foxglove_msgs", "ModelPrimitive", "../std/foxglove_msgs/msg/ModelPrimitive.msg";
    SceneEntity => "foxglove_msgs", "SceneEntity", "../std/foxglove_msgs/msg/SceneEntity.msg";
    SceneEntityDeletion => "foxglove_msgs", "SceneEntityDeletion", "../std/foxglove_msgs/msg/SceneEntityDeletion.msg";
    SceneUpdate => "foxglove_msgs", "SceneUpdate", "../std/foxglove_msgs/msg/SceneUpdate.msg";
    CircleAnnotation => "foxglove_msgs", "CircleAnnotation", "../std/foxglove_msgs/msg/CircleAnnotation.msg";
    PointsAnnotation => "foxglove_msgs", "PointsAnnotation", "../std/foxglove_msgs/msg/PointsAnnotation.msg";
    TextAnnotation => "foxglove_msgs", "TextAnnotation", "../std/foxglove_msgs/msg/TextAnnotation.msg";
    ImageAnnotations => "foxglove_msgs", "ImageAnnotations", "../std/foxglove_msgs/msg/ImageAnnotations.msg";
    LogLine => "foxglove_msgs", "Log", "../std/foxglove_msgs/msg/Log.msg";
    UnitState => "avacraft_msgs", "UnitState", "../msg/UnitState.msg";
    AbilityState => "avacraft_msgs", "AbilityState", "../msg/AbilityState.msg";
    AreaEffect => "avacraft_msgs", "AreaEffect", "../msg/AreaEffect.msg";
    UnitObservation => "avacraft_msgs", "UnitObservation", "../msg/UnitObservation.msg";
    TeamObservation => "avacraft_msgs", "TeamObservation", "../msg/TeamObservation.msg";
    UnitAction => "avacraft_msgs", "UnitAction", "../msg/UnitAction.msg";
    ActionBatch => "avacraft_msgs", "ActionBatch", "../msg/ActionBatch.msg";
    EpisodeStatus => "avacraft_msgs", "EpisodeStatus", "../msg/EpisodeStatus.msg";
    RoleGroup => "avacraft_msgs", "RoleGroup", "../msg/RoleGroup.msg";
    RoleAssignment => "avacraft_msgs", "RoleAssignment", "../msg/RoleAssignment.msg";
    SessionInfo => "avacraft_msgs", "SessionInfo", "../msg/SessionInfo.msg";
    ModelCall => "avacraft_msgs", "ModelCall", "../msg/ModelCall.msg";
    TeamFeatures => "avacraft_msgs", "TeamFeatures", "../msg/TeamFeatures.msg";
}
