//! SMAC's own heuristic agent (`StarCraft2Env(heuristic_ai=True)`), the "Heuristic" column
//! of the SMAC paper's results: a policy fully specified by SMAC's code, so the win rate it
//! gets on this engine can be set beside the real game's map by map with no learner in
//! between.
//!
//! As SMAC's `get_agent_action_heuristic` does, every step: each unit keeps one target until
//! it dies. A unit without one takes the nearest living enemy (centre to centre; first in
//! SMAC's enemy order on a tie), a healer the nearest other ally that has lost life (life
//! alone, not shields; not a healer) and drops it once whole. The order (attack or heal) is
//! given again every step, as SMAC sends it. With `rest` (SMAC's `heuristic_rest`) a unit
//! whose attack action SMAC would not offer (target beyond its shoot range) steps towards
//! the target along the longer axis instead.
//!
//! SMAC skips Medivacs as Marauders' targets (they cannot hit air); here any enemy the unit
//! cannot hit is skipped, the same rule on SMAC's maps.

use super::view::{can_attack, id, pos};
use super::{Agent, AgentCtx};
use crate::action::{Action, Command, Direction};
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::obs::{GroupObs, Reads, SHOOT_RANGE, UnitInfo};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Default)]
pub struct SmacHeuristic {
    /// SMAC's `heuristic_rest`.
    rest: bool,
    /// Each unit's target (an enemy, or an ally for a healer), kept until it dies.
    targets: BTreeMap<UnitId, UnitId>,
}

impl SmacHeuristic {
    pub fn new(rest: bool) -> Self {
        Self { rest, targets: BTreeMap::new() }
    }

    /// Today's target of `u`: the kept one while it qualifies, else a new pick (kept).
    fn target<'a>(&mut self, g: &'a GroupObs, u: &UnitInfo) -> Option<&'a UnitInfo> {
        let heals = u.spec().heal.is_some();
        let kept = self
            .targets
            .get(&u.tag)
            .and_then(|t| if heals { g.own().find(|a| a.tag == *t && a.hp < a.max_hp) } else { g.enemies().find(|e| e.tag == *t) });
        let picked = kept.or_else(|| {
            let here = pos(u);
            let nearest = |best: Option<&'a UnitInfo>, c: &'a UnitInfo| match best {
                Some(b) if pos(b).dist(here) <= pos(c).dist(here) => Some(b),
                _ => Some(c),
            };
            if heals {
                g.own().filter(|a| a.spec().heal.is_none() && a.hp > 0.0 && a.hp < a.max_hp).fold(None, nearest)
            } else {
                g.enemies().filter(|e| can_attack(u, e)).fold(None, nearest)
            }
        });
        match picked {
            Some(t) => self.targets.insert(u.tag, t.tag),
            None => self.targets.remove(&u.tag),
        };
        picked
    }
}

/// SMAC's step towards a point along the longer axis (east or west on a tie goes north or
/// south, as SMAC's `abs(dx) > abs(dy)`).
fn step_towards(from: Vec2, to: Vec2) -> Direction {
    let d = to - from;
    match (d.x.abs() > d.y.abs(), d.x > 0.0, d.y > 0.0) {
        (true, true, _) => Direction::Right,
        (true, false, _) => Direction::Left,
        (false, _, true) => Direction::Up,
        (false, _, false) => Direction::Down,
    }
}

impl Agent for SmacHeuristic {
    fn reads(&self) -> Reads {
        Reads::UNITS
    }
    fn name(&self) -> &str {
        if self.rest { "smac-heuristic-rest" } else { "smac-heuristic" }
    }
    fn reset(&mut self, _ctx: &AgentCtx) {
        self.targets.clear();
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        let mut out = Vec::new();
        for u in g.mine() {
            let Some(t) = self.target(g, u) else { continue };
            // SMAC offers the attack (or heal) within its shoot range, centre to centre.
            let offered = pos(u).dist(pos(t)) <= SHOOT_RANGE;
            let cmd = if self.rest && !offered {
                Command::MoveDir { dir: step_towards(pos(u), pos(t)) }
            } else {
                Command::Attack { target: id(t) }
            };
            out.push(Action::new(id(u), cmd));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_step_follows_the_longer_axis_as_smac_does() {
        let o = Vec2::new(10.0, 10.0);
        assert_eq!(step_towards(o, Vec2::new(14.0, 11.0)), Direction::Right);
        assert_eq!(step_towards(o, Vec2::new(6.0, 9.0)), Direction::Left);
        assert_eq!(step_towards(o, Vec2::new(11.0, 14.0)), Direction::Up);
        assert_eq!(step_towards(o, Vec2::new(9.0, 6.0)), Direction::Down);
        // A tie is north or south, as SMAC's strict comparison.
        assert_eq!(step_towards(o, Vec2::new(13.0, 13.0)), Direction::Up);
        assert_eq!(step_towards(o, Vec2::new(7.0, 7.0)), Direction::Down);
    }
}
