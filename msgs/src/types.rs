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

/// `avacraft_msgs/msg/UnitState`. The `TYPE_*`, `FLAG_*` and `BUFF_*` values are the
/// engine's (the conversion in `avacraft-nodes` checks them against the `.msg`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct UnitState {
    pub tag: u32,
    pub name: String,
    pub unit_type: u8,
    pub team: u8,
    pub own: bool,
    pub x: f32,
    pub y: f32,
    pub hp: f32,
    pub max_hp: f32,
    pub shield: f32,
    pub max_shield: f32,
    pub energy: f32,
    pub max_energy: f32,
    pub speed: f32,
    pub weapon_cooldown_s: f32,
    pub grid_x: u8,
    pub grid_y: u8,
    pub order: u8,
    pub order_x: f32,
    pub order_y: f32,
    pub order_target: u32,
    pub activity: u8,
    /// 0 = none.
    pub target_tag: u32,
    pub flags: u32,
    pub buffs: u32,
    pub data_set: u8,
}

impl UnitState {
    pub const DATA_LIBERTY: u8 = 0;
    pub const DATA_VOID: u8 = 1;
    pub const DATA_LADDER: u8 = 2;
    pub const DATA_LEGACY: u8 = 3;
    pub const ORDER_IDLE: u8 = 0;
    pub const ORDER_HOLD: u8 = 1;
    pub const ORDER_MOVE: u8 = 2;
    pub const ORDER_ATTACK_MOVE: u8 = 3;
    pub const ORDER_ATTACK: u8 = 4;
    pub const ACTIVITY_IDLE: u8 = 0;
    pub const ACTIVITY_MOVING: u8 = 1;
    pub const ACTIVITY_ATTACKING: u8 = 2;
    pub const ACTIVITY_HEALING: u8 = 3;
    pub const ACTIVITY_DEAD: u8 = 4;

    /// The `ORDER_*` and `ACTIVITY_*` constants, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("ORDER_IDLE", Self::ORDER_IDLE),
        ("ORDER_HOLD", Self::ORDER_HOLD),
        ("ORDER_MOVE", Self::ORDER_MOVE),
        ("ORDER_ATTACK_MOVE", Self::ORDER_ATTACK_MOVE),
        ("ORDER_ATTACK", Self::ORDER_ATTACK),
        ("ACTIVITY_IDLE", Self::ACTIVITY_IDLE),
        ("ACTIVITY_MOVING", Self::ACTIVITY_MOVING),
        ("ACTIVITY_ATTACKING", Self::ACTIVITY_ATTACKING),
        ("ACTIVITY_HEALING", Self::ACTIVITY_HEALING),
        ("ACTIVITY_DEAD", Self::ACTIVITY_DEAD),
    ];
}

/// `avacraft_msgs/msg/AbilityState`. `ABILITY_*` and `UNAVAILABLE_*` values are the engine's.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AbilityState {
    pub ability: u8,
    pub available: bool,
    pub unavailable: u8,
    pub cooldown_s: f32,
    pub energy_cost: f32,
    pub range: f32,
    pub target_kind: u8,
}

impl AbilityState {
    pub const TARGET_NONE: u8 = 0;
    pub const TARGET_POINT: u8 = 1;
    pub const TARGET_UNIT: u8 = 2;
    pub const TARGET_POINT_OR_UNIT: u8 = 3;
    pub const UNAVAILABLE_NONE: u8 = 0;

    /// The `TARGET_*` constants and `UNAVAILABLE_NONE`, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("TARGET_NONE", Self::TARGET_NONE),
        ("TARGET_POINT", Self::TARGET_POINT),
        ("TARGET_UNIT", Self::TARGET_UNIT),
        ("TARGET_POINT_OR_UNIT", Self::TARGET_POINT_OR_UNIT),
        ("UNAVAILABLE_NONE", Self::UNAVAILABLE_NONE),
    ];
}

/// `avacraft_msgs/msg/AreaEffect`. `KIND_*` values are the engine's.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AreaEffect {
    pub kind: u8,
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
    pub seed: u64,
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
    /// `AbilityState`'s `ABILITY_*`.
    pub ability: u8,
    pub ability_target: u8,
    /// `LOOK`: sector `look_sector` of `look_sectors`, counter-clockwise from east.
    pub look_sector: u8,
    pub look_sectors: u8,
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
    pub const LOOK: u8 = 9;
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
        ("LOOK", Self::LOOK),
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
    /// The simulator's full-state hash at this step, before its actions.
    pub state_hash: u64,
    /// The seed and every state so far, chained (the episode's trajectory hash at its end).
    pub trajectory_hash: u64,
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
    pub role: u8,
    pub agent_id: String,
    pub unit_tags: Vec<u32>,
}

impl RoleGroup {
    pub const ROLE_NONE: u8 = 0;
    pub const ROLE_ATTACKER: u8 = 1;
    pub const ROLE_DEFENDER: u8 = 2;
    pub const ROLE_SCOUT: u8 = 3;
    pub const ROLE_SUPPORT: u8 = 4;

    /// Name/value pairs of all constants, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("ROLE_NONE", Self::ROLE_NONE),
        ("ROLE_ATTACKER", Self::ROLE_ATTACKER),
        ("ROLE_DEFENDER", Self::ROLE_DEFENDER),
        ("ROLE_SCOUT", Self::ROLE_SCOUT),
        ("ROLE_SUPPORT", Self::ROLE_SUPPORT),
    ];
}

/// `avacraft_msgs/msg/RoleAssignment`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RoleAssignment {
    pub header: Header,
    pub episode: u64,
    pub step: u32,
    pub team: u8,
    pub groups: Vec<RoleGroup>,
    pub plan: String,
    pub priority_tags: Vec<u32>,
}

/// `avacraft_msgs/msg/SessionInfo`: what a replay needs besides seeds and applied actions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionInfo {
    pub header: Header,
    pub scenario_name: String,
    pub scenario_toml: String,
    pub step_mul: u32,
    pub reward: u8,
    pub opponent: u8,
    pub time_limit_loops: u32,
    pub ability_actions: bool,
    pub full_vision: bool,
    pub cooldown_jitter: bool,
    pub auto_acquire: [bool; 2],
    pub abilities: bool,
    pub prob_obs_enemy: f32,
    pub action_mask: bool,
    pub fov_actions: u8,
    pub clock: u8,
    pub deadline_ms: u32,
    pub launch_file: String,
    pub episode: u64,
    pub seeds: Vec<u64>,
}

/// Constants of `SessionInfo.msg`, mirrored here (a test checks they agree).
impl SessionInfo {
    pub const REWARD_SPARSE: u8 = 0;
    pub const REWARD_DENSE: u8 = 1;
    pub const OPPONENT_SCENARIO: u8 = 0;
    pub const OPPONENT_BUILTIN: u8 = 1;
    pub const OPPONENT_AGGRESSIVE: u8 = 2;
    pub const OPPONENT_DEFENSIVE: u8 = 3;
    pub const OPPONENT_FOCUS: u8 = 4;
    pub const OPPONENT_RANDOM: u8 = 5;
    pub const CLOCK_LOCKSTEP: u8 = 0;
    pub const CLOCK_REALTIME: u8 = 1;

    /// Name/value pairs of all constants, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("REWARD_SPARSE", Self::REWARD_SPARSE),
        ("REWARD_DENSE", Self::REWARD_DENSE),
        ("OPPONENT_SCENARIO", Self::OPPONENT_SCENARIO),
        ("OPPONENT_BUILTIN", Self::OPPONENT_BUILTIN),
        ("OPPONENT_AGGRESSIVE", Self::OPPONENT_AGGRESSIVE),
        ("OPPONENT_DEFENSIVE", Self::OPPONENT_DEFENSIVE),
        ("OPPONENT_FOCUS", Self::OPPONENT_FOCUS),
        ("OPPONENT_RANDOM", Self::OPPONENT_RANDOM),
        ("CLOCK_LOCKSTEP", Self::CLOCK_LOCKSTEP),
        ("CLOCK_REALTIME", Self::CLOCK_REALTIME),
    ];
}

/// `avacraft_msgs/msg/TeamFeatures`: an image-mode network's encoding of its team's frames of
/// one step.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TeamFeatures {
    pub header: Header,
    pub team: u8,
    pub encoder: String,
    pub data: Vec<f32>,
}

/// `avacraft_msgs/msg/ModelCall`: one model call of an AVA agent node.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelCall {
    pub header: Header,
    pub episode: u64,
    pub step: u32,
    pub team: u8,
    pub decision: u32,
    pub stage: u8,
    pub attempt: u32,
    pub retry: u32,
    pub model: String,
    pub prompts_version: String,
    pub request_hash: String,
    pub request_json: String,
    pub response: String,
    pub error: String,
    pub prompt_tokens: u32,
    pub completion_tokens: u32,
    pub latency_ms: f64,
    pub cost_usd: f64,
    pub images: u32,
    #[serde(with = "serde_bytes")]
    pub first_image_png: Vec<u8>,
}

impl ModelCall {
    pub const STAGE_PLANNER: u8 = 0;
    pub const STAGE_PRIORITY: u8 = 1;
    pub const STAGE_ROLES: u8 = 2;
    pub const STAGE_DECISION: u8 = 3;

    /// Name/value pairs of all constants, for checking against the `.msg`.
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("STAGE_PLANNER", Self::STAGE_PLANNER),
        ("STAGE_PRIORITY", Self::STAGE_PRIORITY),
        ("STAGE_ROLES", Self::STAGE_ROLES),
        ("STAGE_DECISION", Self::STAGE_DECISION),
    ];
}
