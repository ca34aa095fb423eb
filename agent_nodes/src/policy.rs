//! Policies that act on observation messages alone: an agent node knows only what its units'
//! observations say (their own state, what their team sees, their abilities), which is what
//! makes execution decentralised. The VLM and MARL policies implement the same trait.

use avacraft_engine::UnitKind;
use avacraft_msgs::{UnitAction, UnitObservation, UnitState};

/// A policy for the units of one agent node.
pub trait UnitPolicy: Send {
    fn name(&self) -> &str;
    /// One action per live unit in `obs` (units without a decision get a no-op).
    fn act(&mut self, obs: &[UnitObservation]) -> Vec<UnitAction>;
}

/// Names accepted by [`by_name`].
pub const POLICIES: &[&str] = &["focus-fire", "attack-move", "hold", "noop"];

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown agent policy `{0}` (known: focus-fire, attack-move, hold, noop)")]
pub struct UnknownPolicy(pub String);

pub fn by_name(name: &str) -> Result<Box<dyn UnitPolicy>, UnknownPolicy> {
    Ok(match name {
        "focus-fire" => Box::new(FocusFire),
        "attack-move" => Box::new(AttackMove),
        "hold" => Box::new(Fixed { name: "hold", kind: UnitAction::HOLD }),
        "noop" => Box::new(Fixed { name: "noop", kind: UnitAction::NOOP }),
        other => return Err(UnknownPolicy(other.to_owned())),
    })
}

fn action(unit: u32, kind: u8) -> UnitAction {
    UnitAction { unit_tag: unit, kind, ..UnitAction::default() }
}

/// Whether `me` has a weapon for `target`'s layer (from the unit table).
fn can_hit(me: &UnitState, target: &UnitState) -> bool {
    let flying = target.flags.iter().any(|f| f == "flying") || target.buffs.iter().any(|b| b == "lifted");
    me.unit_type.parse::<UnitKind>().is_ok_and(|k| k.spec().weapons.iter().any(|w| w.reach.hits(flying)))
}

fn dist(a: &UnitState, b: &UnitState) -> f32 {
    ((a.x - b.x).powi(2) + (a.y - b.y).powi(2)).sqrt()
}

/// Stimpack when an enemy is close and the unit is at full health (what a player does).
fn stim(o: &UnitObservation) -> Option<UnitAction> {
    let ready = o.abilities.iter().any(|a| a.ability == "stimpack" && a.available);
    let close = o.enemies.iter().any(|e| dist(&o.own, e) < 8.0 && can_hit(&o.own, e));
    (ready && close && o.own.hp >= o.own.max_hp && !o.own.buffs.iter().any(|b| b == "stimmed")).then(|| UnitAction {
        unit_tag: o.unit_tag,
        kind: UnitAction::ABILITY,
        ability: "stimpack".into(),
        ability_target: UnitAction::TARGET_NONE,
        ..UnitAction::default()
    })
}

/// With no enemy in sight, an idle unit heads for the middle of the map (grid cell 5, 5),
/// where two sides that cannot see each other meet; idle units engage on their own there.
fn seek(o: &UnitObservation) -> UnitAction {
    let centre = (5..=6).contains(&o.own.grid_x) && (5..=6).contains(&o.own.grid_y);
    let mobile = !o.own.flags.iter().any(|f| f == "immobile");
    if o.own.order == "idle" && !centre && mobile {
        UnitAction { grid_x: 5, grid_y: 5, ..action(o.unit_tag, UnitAction::MOVE_GRID) }
    } else {
        action(o.unit_tag, UnitAction::NOOP)
    }
}

/// Every unit attacks the visible enemy with the lowest HP + shields it can hit (ties: the
/// lower tag); with none in sight it heads for the middle of the map.
#[derive(Debug, Clone, Copy, Default)]
pub struct FocusFire;

impl UnitPolicy for FocusFire {
    fn name(&self) -> &str {
        "focus-fire"
    }
    fn act(&mut self, obs: &[UnitObservation]) -> Vec<UnitAction> {
        let mut out = Vec::new();
        for o in obs.iter().filter(|o| o.alive) {
            if let Some(s) = stim(o) {
                out.push(s);
            }
            let target = o
                .enemies
                .iter()
                .filter(|e| can_hit(&o.own, e))
                .min_by(|a, b| (a.hp + a.shield).total_cmp(&(b.hp + b.shield)).then(a.tag.cmp(&b.tag)));
            out.push(match target {
                Some(t) if o.own.target_tag != t.tag => UnitAction { target_tag: t.tag, ..action(o.unit_tag, UnitAction::ATTACK) },
                Some(_) => action(o.unit_tag, UnitAction::NOOP),
                None => seek(o),
            });
        }
        out
    }
}

/// Attack-move to the nearest visible enemy; the engine picks targets on the way.
#[derive(Debug, Clone, Copy, Default)]
pub struct AttackMove;

impl UnitPolicy for AttackMove {
    fn name(&self) -> &str {
        "attack-move"
    }
    fn act(&mut self, obs: &[UnitObservation]) -> Vec<UnitAction> {
        obs.iter()
            .filter(|o| o.alive)
            .map(|o| {
                let near = o.enemies.iter().min_by(|a, b| dist(&o.own, a).total_cmp(&dist(&o.own, b)).then(a.tag.cmp(&b.tag)));
                match near {
                    Some(e) if o.own.order == "idle" => UnitAction { x: e.x, y: e.y, ..action(o.unit_tag, UnitAction::ATTACK_MOVE_TO) },
                    Some(_) => action(o.unit_tag, UnitAction::NOOP),
                    None => seek(o),
                }
            })
            .collect()
    }
}

/// The same command for every unit, every step.
#[derive(Debug, Clone, Copy)]
pub struct Fixed {
    name: &'static str,
    kind: u8,
}

impl UnitPolicy for Fixed {
    fn name(&self) -> &str {
        self.name
    }
    fn act(&mut self, obs: &[UnitObservation]) -> Vec<UnitAction> {
        obs.iter().filter(|o| o.alive).map(|o| action(o.unit_tag, self.kind)).collect()
    }
}
