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

/// A number that is not a unit's tag: tags start at 1 and fit a unit index (16 bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unit tag {0} is not a tag (tags run from 1 to 65536)")]
pub struct BadTag(pub u32);

/// The one conversion from a unit's tag (1-based, as on screen, in text and on the wire) to
/// its id: every place that reads a tag from outside goes through it.
impl TryFrom<u32> for UnitId {
    type Error = BadTag;
    fn try_from(tag: u32) -> Result<UnitId, BadTag> {
        tag.checked_sub(1).and_then(|i| u16::try_from(i).ok()).map(UnitId::new).ok_or(BadTag(tag))
    }
}

// No `Display`: text shows a unit by its tag (`id.tag()`), and a formatted id that
// compiled silently could print something else.

/// Serde forms for the numbers people and programs read: a unit as its tag (1-based, as on
/// screen and on the wire) and a team as its player number, so typed fields serialise as the
/// plain numbers JSON, prompts and recordings have always carried.
pub mod serde_as {
    /// A unit as its tag.
    pub mod tag {
        use crate::ids::UnitId;
        use serde::{Deserialize, Deserializer, Serializer, de::Error};

        pub fn serialize<S: Serializer>(id: &UnitId, s: S) -> Result<S::Ok, S::Error> {
            s.serialize_u32(id.tag())
        }
        pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<UnitId, D::Error> {
            UnitId::try_from(u32::deserialize(d)?).map_err(D::Error::custom)
        }
    }
    /// An optional unit as its tag or null.
    pub mod tag_opt {
        use crate::ids::UnitId;
        use serde::{Deserialize, Deserializer, Serializer, de::Error};

        pub fn serialize<S: Serializer>(id: &Option<UnitId>, s: S) -> Result<S::Ok, S::Error> {
            match id {
                Some(id) => s.serialize_some(&id.tag()),
                None => s.serialize_none(),
            }
        }
        pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<UnitId>, D::Error> {
            Option::<u32>::deserialize(d)?.map(|t| UnitId::try_from(t).map_err(D::Error::custom)).transpose()
        }
    }
    /// A team as its player number.
    pub mod player {
        use crate::ids::Team;
        use serde::Serializer;

        pub fn serialize<S: Serializer>(team: &Team, s: S) -> Result<S::Ok, S::Error> {
            s.serialize_u8(team.player())
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_convert_to_ids_in_one_place_and_zero_is_refused() {
        assert_eq!(UnitId::try_from(1), Ok(UnitId::new(0)));
        assert_eq!(UnitId::try_from(65_536), Ok(UnitId::new(u16::MAX)));
        assert_eq!(UnitId::try_from(0), Err(BadTag(0)));
        assert_eq!(UnitId::try_from(65_537), Err(BadTag(65_537)));
        for tag in [1u32, 2, 300, 65_536] {
            assert_eq!(UnitId::try_from(tag).map(UnitId::tag), Ok(tag), "round trip");
        }
    }
}
