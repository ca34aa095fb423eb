//! Rust images of the `.msg` files. CDR has no field names or tags, so the
//! field order here IS the wire format: it must follow the `.msg` exactly
//! (checked by `tests/struct_matches_msg.rs`).

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `std_msgs/msg/String` (named `StdString` in Rust to keep `String` unambiguous).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StdString {
    pub data: String,
}

/// `sensor_msgs/msg/Image`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Image {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub encoding: String,
    pub is_bigendian: u8,
    pub step: u32,
    /// `serde_bytes` makes this one memcpy instead of one call per pixel byte.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `avacraft_msgs/msg/UnitState`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct UnitState {
    pub tag: u32,
    pub name: String,
    pub unit_type: String,
    pub team: u8,
    pub x: f32,
    pub y: f32,
    pub hp: f32,
    pub max_hp: f32,
    pub shield: f32,
    pub max_shield: f32,
    pub energy: f32,
    pub max_energy: f32,
    pub weapon_cooldown_s: f32,
    pub grid_x: u8,
    pub grid_y: u8,
    pub order: String,
    /// 0 = none.
    pub target_tag: u32,
    pub flags: Vec<String>,
    pub buffs: Vec<String>,
}

/// `avacraft_msgs/msg/AbilityState`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AbilityState {
    pub ability: String,
    pub available: bool,
    pub cooldown_s: f32,
    pub energy_cost: f32,
    pub target_kind: String,
}

/// `avacraft_msgs/msg/AreaEffect`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AreaEffect {
    pub kind: String,
    pub team: u8,
    pub x: f32,
    pub y: f32,
    pub radius: f32,
    pub remaining_s: f32,
}

/// `avacraft_msgs/msg/UnitObservation`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct UnitObservation {
    pub header: Header,
    pub episode: u64,
    pub step: u32,
    pub game_loop: u32,
    pub unit_tag: u32,
    pub alive: bool,
    pub own: UnitState,
    pub allies: Vec<UnitState>,
    pub enemies: Vec<UnitState>,
    pub abilities: Vec<AbilityState>,
    pub effects: Vec<AreaEffect>,
    #[serde(with = "serde_bytes")]
    pub avail_actions: Vec<u8>,
    pub features: Vec<f32>,
    pub text: String,
}

/// `avacraft_msgs/msg/TeamObservation`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TeamObservation {
    pub header: Header,
    pub episode: u64,
    pub step: u32,
    pub game_loop: u32,
    pub team: u8,
    pub units: Vec<UnitState>,
    pub effects: Vec<AreaEffect>,
    pub text: String,
}

/// `avacraft_msgs/msg/UnitAction`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct UnitAction {
    pub unit_tag: u32,
    pub kind: u8,
    pub target_tag: u32,
    pub x: f32,
    pub y: f32,
    pub grid_x: u8,
    pub grid_y: u8,
    pub direction: u8,
    pub ability: String,
    pub ability_target: u8,
}

/// Constants of `UnitAction.msg`, mirrored here (a test checks they agree).
impl UnitAction {
    pub const NOOP: u8 = 0;
    pub const STOP: u8 = 1;
    pub const HOLD: u8 = 2;
    pub const ATTACK: u8 = 3;
    pub const MOVE_GRID: u8 = 4;
    pub const MOVE_DIR: u8 = 5;
    pub const MOVE_TO: u8 = 6;
    pub const ATTACK_MOVE_TO: u8 = 7;
    pub const ABILITY: u8 = 8;
    pub const UP: u8 = 0;
    pub const DOWN: u8 = 1;
    pub const LEFT: u8 = 2;
    pub const RIGHT: u8 = 3;
    pub const TARGET_NONE: u8 = 0;
    pub const TARGET_POINT: u8 = 1;
    pub const TARGET_UNIT: u8 = 2;

    /// Name/value pairs of all constants, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("NOOP", Self::NOOP),
        ("STOP", Self::STOP),
        ("HOLD", Self::HOLD),
        ("ATTACK", Self::ATTACK),
        ("MOVE_GRID", Self::MOVE_GRID),
        ("MOVE_DIR", Self::MOVE_DIR),
        ("MOVE_TO", Self::MOVE_TO),
        ("ATTACK_MOVE_TO", Self::ATTACK_MOVE_TO),
        ("ABILITY", Self::ABILITY),
        ("UP", Self::UP),
        ("DOWN", Self::DOWN),
        ("LEFT", Self::LEFT),
        ("RIGHT", Self::RIGHT),
        ("TARGET_NONE", Self::TARGET_NONE),
        ("TARGET_POINT", Self::TARGET_POINT),
        ("TARGET_UNIT", Self::TARGET_UNIT),
    ];
}

/// `avacraft_msgs/msg/ActionBatch`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ActionBatch {
    pub header: Header,
    pub episode: u64,
    pub step: u32,
    pub agent_id: String,
    pub actions: Vec<UnitAction>,
}

/// `avacraft_msgs/msg/EpisodeStatus`. Two-element arrays are indexed by team.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EpisodeStatus {
    pub header: Header,
    pub episode: u64,
    pub seed: u64,
    pub scenario: String,
    pub step: u32,
    pub game_loop: u32,
    pub result: u8,
    pub reward: [f32; 2],
    pub refused_actions: [u32; 2],
    pub missing_actions: [u32; 2],
    pub foreign_actions: [u32; 2],
    pub malformed_messages: u32,
}

/// Constants of `EpisodeStatus.msg`, mirrored here (a test checks they agree).
impl EpisodeStatus {
    pub const RUNNING: u8 = 0;
    pub const WIN: u8 = 1;
    pub const LOSS: u8 = 2;
    pub const DRAW: u8 = 3;

    /// Name/value pairs of all constants, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] =
        &[("RUNNING", Self::RUNNING), ("WIN", Self::WIN), ("LOSS", Self::LOSS), ("DRAW", Self::DRAW)];
}

/// `avacraft_msgs/msg/RoleGroup`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RoleGroup {
    pub role: String,
    pub agent_id: String,
    pub unit_tags: Vec<u32>,
}

/// `avacraft_msgs/msg/RoleAssignment`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RoleAssignment {
    pub header: Header,
    pub episode: u64,
    pub step: u32,
    pub groups: Vec<RoleGroup>,
}
