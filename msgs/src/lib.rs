//! `avacraft_msgs`: the ROS 2 interface package of AVACraft, in Rust.
//!
//! The `.msg` files under `msg/` are the source of truth. From them this crate
//! derives everything a ROS 2 tool checks without a ROS installation: the
//! REP-2016 type hash (rmw_zenoh key expressions), the DDS type name, and the
//! MCAP `ros2msg` schema. [`encode`] / [`decode`] are the only way payloads are
//! produced and read, so every transport agrees on the bytes.
#![forbid(unsafe_code)]

mod cdr;
mod foxglove;
mod message;
mod parser;
mod registry;
mod types;

pub use cdr::{CDR_LE_HEADER, DecodeError, EncodeError, decode, encode, try_encode};
pub use message::{EMBEDDED_TYPES, EmbeddedType, RosMessage, embedded_registry};
pub use parser::{
    BaseType, Collection, Constant, Field, FieldType, MsgSpec, ParseError, ParseErrorKind, PrimitiveType, TypeRef, field_type_text,
    parse_field_type, parse_msg,
};
pub use registry::{Registry, RegistryError};
pub use types::{
    AbilityState, ActionBatch, AreaEffect, EpisodeStatus, Header, Image, ModelCall, RoleAssignment, RoleGroup, SessionInfo, StdString,
    TeamFeatures, TeamObservation, Time, UnitAction, UnitObservation, UnitState,
};

/// `builtin_interfaces` types, under their ROS names.
pub mod builtin_interfaces {
    pub use crate::foxglove::Duration;
    pub use crate::types::Time;
}

/// `geometry_msgs` types, under their ROS names.
pub mod geometry_msgs {
    pub use crate::foxglove::{Point, Pose, Quaternion, Vector3};
}

/// `foxglove_msgs` types (the live view's, recorded as ROS 2 messages), under their ROS names
/// (`Log` is [`crate::foxglove_msgs::Log`]).
pub mod foxglove_msgs {
    pub use crate::foxglove::{
        ArrowPrimitive, CircleAnnotation, Color, CubePrimitive, CylinderPrimitive, ImageAnnotations, KeyValuePair, LinePrimitive,
        LogLine as Log, ModelPrimitive, Point2, PointsAnnotation, SceneEntity, SceneEntityDeletion, SceneUpdate, SpherePrimitive,
        TextAnnotation, TextPrimitive, TriangleListPrimitive,
    };
}

/// `std_msgs` types, under their ROS names.
pub mod std_msgs {
    pub use crate::types::{Header, StdString as String};
}

/// `sensor_msgs` types, under their ROS names.
pub mod sensor_msgs {
    pub use crate::types::Image;
}
