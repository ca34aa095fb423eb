//! The typed action interface shared by every agent kind, the reasons an action is refused,
//! and the 10x10 movement grid that screenshots label. Checking an action and applying it
//! are [`crate::rules`]' (`World::validate`, `World::apply`).

use crate::ability::{Ability, AbilityTarget, Refusal};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::terrain::Rect;
use crate::units::UnitKind;
use serde::{Deserialize, Serialize};

/// Cells per side of the movement grid.
pub const GRID: u8 = 10;
/// SMAC's `move_amount`: distance of a directional move.
pub const MOVE_AMOUNT: f32 = 2.0;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    Up,
    Down,
    Left,
    Right,
}

impl Direction {
    pub const ALL: [Direction; 4] = [Direction::Up, Direction::Down, Direction::Left, Direction::Right];
    /// Unit vector on the map: up is north (+y), as the screen shows it.
    pub fn vector(self) -> Vec2 {
        match self {
            Direction::Up => Vec2::new(0.0, 1.0),
            Direction::Down => Vec2::new(0.0, -1.0),
            Direction::Left => Vec2::new(-1.0, 0.0),
            Direction::Right => Vec2::new(1.0, 0.0),
        }
    }
}

/// What a unit is told to do.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Command {
    /// Keep the current order.
    NoOp,
    Stop,
    Hold,
    /// Attack an enemy; for a healer (Medivac), heal an ally.
    Attack {
        target: UnitId,
    },
    /// Move to the centre of grid cell (x, y), both in 1..=10, (1, 1) top left.
    MoveGrid {
        x: u8,
        y: u8,
    },
    /// Move `MOVE_AMOUNT` in a direction.
    MoveDir {
        dir: Direction,
    },
    MoveTo {
        to: Vec2,
    },
    AttackMoveTo {
        to: Vec2,
    },
    /// Use an ability; it resolves at the start of the next game loop.
    Ability {
        ability: Ability,
        target: AbilityTarget,
    },
    /// Turn the unit's field of view (SMACv2's `conic_fov`) to sector `sector` of `sectors`,
    /// counter-clockwise from east: the direction at angle 2π·sector/sectors. The unit keeps
    /// its order; only what its SMAC features see and may attack changes.
    Look {
        sector: u8,
        sectors: u8,
    },
}

impl Command {
    /// The unit vector of a [`Command::Look`] direction.
    pub fn look_direction(sector: u8, sectors: u8) -> Vec2 {
        Vec2::from_angle(std::f32::consts::TAU * f32::from(sector) / f32::from(sectors.max(1)))
    }
}

/// A command for one unit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Action {
    pub unit: UnitId,
    pub command: Command,
}

impl Action {
    pub fn new(unit: UnitId, command: Command) -> Self {
        Self { unit, command }
    }
}

/// Why an action was refused. The unit keeps its current order.
#[derive(Clone, Debug, PartialEq, thiserror::Error, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum ActionError {
    #[error("unit #{} does not exist", unit.tag())]
    UnknownUnit { unit: UnitId },
    #[error("unit #{} belongs to {owner}, not to {team}", unit.tag())]
    NotYourUnit { unit: UnitId, owner: Team, team: Team },
    #[error("unit #{} is dead", unit.tag())]
    DeadUnit { unit: UnitId },
    #[error("target #{} does not exist", target.tag())]
    UnknownTarget { target: UnitId },
    #[error("target #{} is dead", target.tag())]
    TargetDead { target: UnitId },
    #[error("target #{} is not visible to {team}", target.tag())]
    TargetNotVisible { target: UnitId, team: Team },
    #[error("unit #{} cannot attack target #{} ({why})", unit.tag(), target.tag())]
    InvalidTarget { unit: UnitId, target: UnitId, why: TargetProblem },
    #[error("grid cell ({x}, {y}) is off the 1..=10 grid")]
    OffGrid { x: u8, y: u8 },
    #[error("point ({x}, {y}) is outside the playable area")]
    OffMap { x: f32, y: f32 },
    #[error("unit #{} cannot do that: {why}", unit.tag())]
    Unavailable { unit: UnitId, why: Inability },
    #[error("unit #{} cannot use {ability}: {refusal}", unit.tag())]
    AbilityRefused { unit: UnitId, ability: Ability, refusal: Refusal },
    #[error("look sector {sector} of {sectors}: the sector must be below the number of sectors, which must be 1 or more")]
    BadLook { sector: u8, sectors: u8 },
}

/// Centre of grid cell (x, y) in map coordinates; (1, 1) is the top-left cell.
pub fn grid_cell_center(playable: Rect, x: u8, y: u8) -> Vec2 {
    let cw = playable.width() / GRID as f32;
    let ch = playable.height() / GRID as f32;
    Vec2::new(playable.left + (x as f32 - 0.5) * cw, playable.top - (y as f32 - 0.5) * ch)
}

/// The grid cell (x, y) containing a point, clamped to the grid.
pub fn grid_cell_of(playable: Rect, p: Vec2) -> (u8, u8) {
    let fx = (p.x - playable.left) / playable.width() * GRID as f32;
    let fy = (playable.top - p.y) / playable.height() * GRID as f32;
    let c = |f: f32| (f.floor().clamp(0.0, GRID as f32 - 1.0) as u8) + 1;
    (c(fx), c(fy))
}

/// Why a unit may not attack (or, a healer, heal) a target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TargetProblem {
    #[error("a healer targets other friendly units")]
    HealerNeedsFriend,
    #[error("heal needs a biological target")]
    NotBiological,
    #[error("friendly unit")]
    Friendly,
    #[error("no weapon hits air units")]
    NoAirWeapon,
    #[error("no weapon hits ground units")]
    NoGroundWeapon,
    #[error("out of range of an immobile unit")]
    OutOfReach,
}

/// Why a unit cannot take an order now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error, Serialize, Deserialize)]
#[serde(tag = "state", rename_all = "snake_case")]
pub enum Inability {
    #[error("it is morphing: only stop (which cancels it) is possible")]
    Morphing,
    #[error("a {kind} cannot move now")]
    Immobile { kind: UnitKind },
    #[error("there is no ground it can reach")]
    NoGround,
    #[error("{team} is driven by the opponent policy in PvE")]
    OpponentDriven { team: Team },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_round_trip() {
        let r = Rect { left: 10.0, bottom: 8.0, right: 54.0, top: 44.0 };
        for x in 1..=GRID {
            for y in 1..=GRID {
                assert_eq!(grid_cell_of(r, grid_cell_center(r, x, y)), (x, y));
            }
        }
        assert_eq!(grid_cell_of(r, Vec2::new(10.1, 43.9)), (1, 1));
        assert_eq!(grid_cell_of(r, Vec2::new(53.9, 8.1)), (10, 10));
    }
}
