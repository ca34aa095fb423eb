//! Standing orders a slow decision-maker gives a unit, executed every step until its next
//! decision: what a player's unit does between clicks. A VLM answers in seconds while units
//! fight in fractions of one, so an order such as "attack 31" goes stale within a step or two
//! (the target dies, a Zealot closes in while the weapon reloads); a stance says what to keep
//! doing instead. Each step's command comes from the group's observation alone, by the same
//! rules as the scripted agents' ([`FocusFire`](super::FocusFire)).

use super::scripted::{kite_step, own_target, weakest_in_sight};
use super::view::{attacking, busy, id, mobile, radius, range_gap};
use crate::action::{Action, Command};
use crate::ids::{UnitId, serde_as};
use crate::obs::GroupObs;
use crate::obs::{OrderInfo, UnitInfo};
use crate::terrain::Terrain;
use serde::{Deserialize, Serialize};

/// What a unit keeps doing between decisions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "stance", rename_all = "snake_case")]
pub enum Stance {
    /// Attack `target` while it lives and is seen. When none is named or it is gone: the
    /// group's weakest enemy in sight (lowest HP + shields, the focus-fire script's pick)
    /// when the unit can hit it, else the weakest in its range, else the nearest it can hit.
    /// With no enemy in sight the unit keeps its current order (an attack-move goes on), so a
    /// stance given before contact engages at the first step the enemy is seen.
    Focus {
        #[serde(default, with = "serde_as::tag_opt")]
        target: Option<UnitId>,
    },
    /// As `Focus`, stepping back from slower melee units while the weapon reloads.
    Kite {
        #[serde(default, with = "serde_as::tag_opt")]
        target: Option<UnitId>,
    },
    /// Stand still and fire at what comes in range.
    Hold,
}

impl Stance {
    /// The names a decision writes.
    pub const NAMES: [&'static str; 3] = ["focus", "kite", "hold"];

    pub fn name(&self) -> &'static str {
        match self {
            Stance::Focus { .. } => "focus",
            Stance::Kite { .. } => "kite",
            Stance::Hold => "hold",
        }
    }

    /// This step's action for unit `u` under the stance, `None` when its current order
    /// already does what the stance wants or the unit is busy (morphing, lifted or
    /// channelling: the engine refuses other orders then, or they would end the channel).
    pub fn act(&self, g: &GroupObs, terrain: &Terrain, u: &UnitInfo) -> Option<Action> {
        if busy(u) {
            return None;
        }
        let cmd = match *self {
            Stance::Hold => (u.order != OrderInfo::Hold).then_some(Command::Hold)?,
            Stance::Focus { target } => attack(u, pick(g, u, target)?)?,
            Stance::Kite { target } => {
                if let Some(p) = kite_step(g, u) {
                    let to = terrain.playable().clamp(p, radius(u));
                    if terrain.walkable(to) || super::view::flying(u) {
                        return Some(Action::new(id(u), Command::MoveTo { to }));
                    }
                }
                attack(u, pick(g, u, target)?)?
            }
        };
        Some(Action::new(id(u), cmd))
    }
}

/// The named enemy while it is seen and `u` can hit it; else the focus-fire script's pick.
fn pick<'a>(g: &'a GroupObs, u: &UnitInfo, named: Option<UnitId>) -> Option<&'a UnitInfo> {
    let named = named.and_then(|id| g.enemies().find(|e| e.tag == id)).or_else(|| weakest_in_sight(g));
    own_target(g, u, named)
}

/// An attack order on `t`, unless `u` is on it already or cannot reach it.
fn attack(u: &UnitInfo, t: &UnitInfo) -> Option<Command> {
    let reachable = mobile(u) || range_gap(u, t).is_some_and(|gap| gap <= 0.0);
    (!attacking(u, t.tag) && reachable).then_some(Command::Attack { target: id(t) })
}
