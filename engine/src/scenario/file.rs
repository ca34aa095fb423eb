//! The scenario file format (TOML) exactly as written on disk. Everything here is raw:
//! [`super::validate`] turns it into a [`super::Scenario`] or an error naming the field.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawScenario {
    pub name: String,
    /// `pve` (an opponent policy drives team 2) or `pvp` (agents drive both teams).
    pub mode: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub objective: String,
    #[serde(default)]
    pub source: String,
    /// Fog of war (default on); SMAC's maps turn it and the black mask off at start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fog_of_war: Option<bool>,
    /// The unit data the map runs (`liberty`, `void`, `ladder`; `legacy` when absent: the
    /// engine's table from before it read the game's files, which files written then meant).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<String>,
    /// Map size in cells: [width, height].
    pub map_size: [u32; 2],
    /// Playable rectangle: [left, bottom, right, top]; defaults to the whole map.
    #[serde(default)]
    pub playable: Option<[f32; 4]>,
    /// Episode limit in seconds of game time (default 300).
    #[serde(default)]
    pub time_limit_s: Option<f32>,
    #[serde(default)]
    pub upgrades: Vec<RawUpgrade>,
    pub units: Vec<RawUnit>,
    #[serde(default)]
    pub opponent: RawOpponent,
    #[serde(default)]
    pub terrain: Option<RawTerrain>,
    /// Draws the units for every episode instead of listing them (`units` stays empty).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generate: Option<RawGenerate>,
}

/// SMACv2's team and start-position distributions (see `generate.rs`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawGenerate {
    /// Team 1's size.
    pub n_units: usize,
    /// Team 2's size.
    pub n_enemies: usize,
    /// Types each unit is drawn from, in the order of the observation's type bits.
    pub unit_types: Vec<String>,
    /// One probability per type, summing to 1.
    pub weights: Vec<f64>,
    /// Types a team may not consist of alone.
    #[serde(default)]
    pub exception_unit_types: Vec<String>,
    /// `surrounded_and_reflect` (default), `reflect` or `surrounded`.
    #[serde(default = "default_start")]
    pub start_positions: String,
    /// For `surrounded_and_reflect`: the probability of the reflected layout (SMACv2's `p`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p: Option<f64>,
}

fn default_start() -> String {
    "surrounded_and_reflect".to_owned()
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawUpgrade {
    pub team: i64,
    pub name: String,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawUnit {
    #[serde(rename = "type")]
    pub kind: String,
    pub team: i64,
    pub x: f32,
    pub y: f32,
    /// Radians, counter-clockwise from east.
    #[serde(default)]
    pub facing: f32,
    /// Starting energy for casters (default: the unit type's, e.g. 50 for a High Templar).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy: Option<f32>,
    /// Creates this many units at (x, y) as StarCraft II's triggers do: each goes to the
    /// nearest free spot around the point (SMAC's maps create armies so). Without it, the one
    /// unit stands exactly at (x, y).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u32>,
}

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawOpponent {
    /// Default opponent policy for PvE: builtin, aggressive, defensive, focus or random.
    #[serde(default)]
    pub policy: Option<String>,
    /// The built-in AI's opening order.
    #[serde(default)]
    pub start: Option<RawStart>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RawStart {
    /// Stand and defend.
    None,
    AttackMove {
        x: f32,
        y: f32,
        #[serde(default)]
        delay_s: f32,
    },
    /// Attack-move to a point drawn uniformly on the segment `from`-`to` each episode.
    AttackMoveRandom {
        from: [f32; 2],
        to: [f32; 2],
        #[serde(default)]
        delay_s: f32,
    },
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawTerrain {
    /// Character to height in cliff levels; a height that is not a whole number marks a ramp.
    /// `.` is reserved for cells with no ground.
    pub legend: BTreeMap<String, f32>,
    /// One string per row, the top row (highest y) first, one character per cell.
    pub rows: Vec<String>,
}
