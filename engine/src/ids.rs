//! Validated identifiers. A raw integer never stands for a unit or team in the public API.

use serde::{Deserialize, Serialize};
use std::fmt;

/// A unit's permanent index in an episode (its position in the scenario's unit list).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct UnitId(u16);

impl UnitId {
    pub const fn new(index: u16) -> Self {
        Self(index)
    }
    pub const fn index(self) -> usize {
        self.0 as usize
    }
    /// The numeric tag shown on screen and in text (1-based, stable for the episode).
    pub const fn tag(self) -> u32 {
        self.0 as u32 + 1
    }
}

impl fmt::Display for UnitId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{}", self.tag())
    }
}

/// One of the two sides. `One` is the agent side in PvE (player 1 of the source maps).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Team {
    #[serde(rename = "1")]
    One,
    #[serde(rename = "2")]
    Two,
}

impl Team {
    pub const BOTH: [Team; 2] = [Team::One, Team::Two];

    pub const fn index(self) -> usize {
        match self {
            Team::One => 0,
            Team::Two => 1,
        }
    }
    pub const fn other(self) -> Team {
        match self {
            Team::One => Team::Two,
            Team::Two => Team::One,
        }
    }
    /// Player number as in the source maps (1 or 2).
    pub const fn player(self) -> u8 {
        self.index() as u8 + 1
    }
    pub fn from_player(p: i64) -> Option<Team> {
        match p {
            1 => Some(Team::One),
            2 => Some(Team::Two),
            _ => None,
        }
    }
}

impl fmt::Display for Team {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "team {}", self.player())
    }
}

/// A game loop counter within an episode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Tick(pub u32);

impl fmt::Display for Tick {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "loop {}", self.0)
    }
}
