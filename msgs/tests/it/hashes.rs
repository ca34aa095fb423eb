//! REP-2016 hashes against values published by ROS itself, and the derived names.

use avacraft_msgs::{
    AbilityState, ActionBatch, AreaEffect, EpisodeStatus, Header, Image, Registry, RoleAssignment, RoleGroup, RosMessage, SessionInfo,
    StdString, TeamObservation, Time, UnitAction, UnitObservation, UnitState, embedded_registry,
};

/// From the rmw_zenoh design doc (`0/chatter/std_msgs::msg::dds_::String_/RIHS01_df66...`).
const STRING_HASH: &str = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";
/// From /work/shared/reference/ros2_interop.md (rmw_zenoh, Jazzy).
const IMAGE_HASH: &str = "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47";
/// From rosidl-generated `*__description.c` files (`std_msgs__msg__Header__EXPECTED_HASH`).
const HEADER_HASH: &str = "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01";
/// From rosidl-generated `*__description.c` files (`builtin_interfaces__msg__Time__EXPECTED_HASH`).
const TIME_HASH: &str = "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197";

/// The geometry types the live view's recordings carry, as rosbags' ROS 2 Jazzy type store
/// hashes them (`Typestore.hash_rihs01`, rosbags 0.11); Pose's is also in rosidl's
/// `geometry_msgs__msg__Pose__EXPECTED_HASH`.
#[test]
fn geometry_types_match_jazzy_hashes() {
    use avacraft_msgs::builtin_interfaces::Duration;
    use avacraft_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3};
    assert_eq!(Pose::type_hash(), "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa");
    assert_eq!(Point::type_hash(), "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881");
    assert_eq!(Quaternion::type_hash(), "RIHS01_8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684");
    assert_eq!(Vector3::type_hash(), "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d");
    assert_eq!(Duration::type_hash(), "RIHS01_e8d009f659816f758b75334ee1a9ca5b5c0b859843261f14c7f937349599d93b");
}

#[test]
fn standard_types_match_published_hashes() {
    assert_eq!(StdString::type_hash(), STRING_HASH);
    assert_eq!(Image::type_hash(), IMAGE_HASH);
    assert_eq!(Header::type_hash(), HEADER_HASH);
    assert_eq!(Time::type_hash(), TIME_HASH);
}

/// Published by ros2_pyterfaces' tests for `diagnostic_msgs/msg/KeyValue`, a type
/// outside this crate: checks the registry works for arbitrary definitions.
#[test]
fn registry_hashes_foreign_definitions() {
    let mut reg = Registry::new();
    reg.add("diagnostic_msgs", "KeyValue", "string key # what\nstring value\n").expect("valid");
    assert_eq!(
        reg.type_hash("diagnostic_msgs/msg/KeyValue").expect("registered"),
        "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42"
    );
}

/// Published in rosidl-generated `*__description.c` files
/// (`geometry_msgs__msg__PoseWithCovariance__EXPECTED_HASH`): covers fixed
/// arrays (`float64[36]`), default values (Quaternion's `w 1`) and a
/// two-level reference graph.
#[test]
fn fixed_arrays_and_defaults_match_published_hash() {
    let mut reg = Registry::new();
    reg.add("geometry_msgs", "Point", "float64 x\nfloat64 y\nfloat64 z\n").expect("valid");
    reg.add("geometry_msgs", "Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n").expect("valid");
    reg.add("geometry_msgs", "Pose", "Point position\nQuaternion orientation\n").expect("valid");
    reg.add("geometry_msgs", "PoseWithCovariance", "Pose pose\nfloat64[36] covariance\n").expect("valid");
    assert_eq!(
        reg.type_hash("geometry_msgs/msg/PoseWithCovariance").expect("registered"),
        "RIHS01_9a7c0fd234b7f45c6098745ecccd773ca1085670e64107135397aee31c02e1bb"
    );
    assert_eq!(
        reg.type_hash("geometry_msgs/msg/Pose").expect("registered"),
        "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa"
    );
}

/// Published by ros2_pyterfaces' tests for `sensor_msgs/msg/JointState`:
/// unbounded sequences of strings and doubles next to a nested Header.
#[test]
fn sequences_match_published_hash() {
    let mut reg = embedded_registry().clone();
    reg.add(
        "sensor_msgs",
        "JointState",
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    )
    .expect("valid");
    assert_eq!(
        reg.type_hash("sensor_msgs/msg/JointState").expect("registered"),
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
    );
}

#[test]
fn comments_and_defaults_do_not_change_the_hash() {
    let mut reg = Registry::new();
    reg.add("std_msgs", "String", "string data 'x' # a default and a comment\n").expect("valid");
    assert_eq!(reg.type_hash("std_msgs/msg/String").expect("registered"), STRING_HASH);
    reg.add("std_msgs", "String", "string other\n").expect("valid");
    assert_ne!(reg.type_hash("std_msgs/msg/String").expect("registered"), STRING_HASH);
}

#[test]
fn hashable_json_has_rosidl_shape() {
    let json = embedded_registry().hashable_description("std_msgs/msg/Header").expect("registered");
    let expected = concat!(
        r#"{"type_description": {"type_name": "std_msgs/msg/Header", "fields": ["#,
        r#"{"name": "stamp", "type": {"type_id": 1, "capacity": 0, "string_capacity": 0, "nested_type_name": "builtin_interfaces/msg/Time"}}, "#,
        r#"{"name": "frame_id", "type": {"type_id": 17, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}, "#,
        r#""referenced_type_descriptions": [{"type_name": "builtin_interfaces/msg/Time", "fields": ["#,
        r#"{"name": "sec", "type": {"type_id": 6, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}, "#,
        r#"{"name": "nanosec", "type": {"type_id": 7, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}]}"#
    );
    assert_eq!(json, expected);
}

fn check_names<T: RosMessage>(package: &str, name: &str) {
    assert_eq!(T::TYPE_NAME, format!("{package}/msg/{name}"));
    assert_eq!(T::dds_type_name(), format!("{package}::msg::dds_::{name}_"));
    let hash = T::type_hash();
    assert_eq!(hash.len(), 7 + 64, "{hash}");
    assert!(hash.starts_with("RIHS01_"));
    assert!(hash[7..].bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)), "{hash}");
    // Computed once, then the same string every time.
    assert!(std::ptr::eq(hash, T::type_hash()));
}

#[test]
fn every_type_has_consistent_names_and_distinct_hashes() {
    check_names::<UnitState>("avacraft_msgs", "UnitState");
    check_names::<AbilityState>("avacraft_msgs", "AbilityState");
    check_names::<AreaEffect>("avacraft_msgs", "AreaEffect");
    check_names::<UnitObservation>("avacraft_msgs", "UnitObservation");
    check_names::<TeamObservation>("avacraft_msgs", "TeamObservation");
    check_names::<UnitAction>("avacraft_msgs", "UnitAction");
    check_names::<ActionBatch>("avacraft_msgs", "ActionBatch");
    check_names::<EpisodeStatus>("avacraft_msgs", "EpisodeStatus");
    check_names::<RoleGroup>("avacraft_msgs", "RoleGroup");
    check_names::<RoleAssignment>("avacraft_msgs", "RoleAssignment");
    check_names::<SessionInfo>("avacraft_msgs", "SessionInfo");
    check_names::<avacraft_msgs::ModelCall>("avacraft_msgs", "ModelCall");
    check_names::<avacraft_msgs::TeamFeatures>("avacraft_msgs", "TeamFeatures");
    check_names::<Image>("sensor_msgs", "Image");
    let mut hashes: Vec<String> = avacraft_msgs::EMBEDDED_TYPES
        .iter()
        .map(|t| embedded_registry().type_hash(&format!("{}/msg/{}", t.package, t.name)).expect("registered"))
        .collect();
    let n = hashes.len();
    hashes.sort();
    hashes.dedup();
    assert_eq!(hashes.len(), n, "two embedded types share a hash");
}
