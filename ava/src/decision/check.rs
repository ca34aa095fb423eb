//! Checking items against the observation with the engine's own rules (its observation-side
//! check, [`check_action`]), so that what is accepted is executed, and what is refused says
//! why in words a model can act on.

use super::item::{Item, Verb};
use avacraft_engine::agent::{GroupObs, Stance, check_action, view};
use avacraft_engine::{
    Ability, AbilityTarget, Action, ActionError, Command, Direction, Inability, Refusal, TargetKind, TargetProblem, TargetRule, Terrain,
    UnitId, UnitInfo, Vec2,
};
use avacraft_render::Camera;
use serde::{Deserialize, Serialize};

/// An item that will not be executed, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Refused {
    /// Its index in the model's list.
    pub item: usize,
    pub unit: Option<u32>,
    pub reason: String,
}

/// What an accepted item orders: a command now, or a stance kept until the unit's next order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Order {
    Do(Command),
    Keep(Stance),
}

/// What a decision's items come to: orders for units, and refusals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Checked {
    /// (unit, order), in the model's order, at most one per unit.
    pub commands: Vec<(UnitId, Order)>,
    pub refused: Vec<Refused>,
}

/// What items are checked against: the group's observation, the camera its grid cells are
/// cells of, and the map (a player knows it: points off it or on ground a unit cannot reach
/// are refused by the engine).
#[derive(Clone, Copy, Debug)]
pub struct Situation<'a> {
    pub obs: &'a GroupObs,
    pub camera: &'a Camera,
    pub terrain: &'a Terrain,
    /// The micro action set's verbs are accepted (else they are refused as unknown).
    pub micro: bool,
}

impl Situation<'_> {
    fn unit(&self, tag: u32) -> Option<&UnitInfo> {
        self.obs.units.iter().find(|u| u.tag.tag() == tag)
    }
    fn controls(&self, tag: u32) -> bool {
        self.obs.controlled.iter().any(|c| c.unit.tag() == tag && c.alive)
    }
    fn mine(&self) -> String {
        let tags: Vec<String> = self.obs.controlled.iter().filter(|c| c.alive).map(|c| c.unit.tag().to_string()).collect();
        tags.join(", ")
    }
    fn point(&self, cell: [u8; 2]) -> Result<Vec2, String> {
        let p = self
            .camera
            .cell_center(cell[0], cell[1])
            .ok_or_else(|| format!("cell [{}, {}] is not on the 10x10 grid (columns and rows are 1 to 10)", cell[0], cell[1]))?;
        if !self.terrain.playable().contains(p) {
            return Err(format!("cell [{}, {}] is off the map", cell[0], cell[1]));
        }
        Ok(p)
    }
}

/// The tags an item's `target` may name: the enemies in sight, and the team's own units when
/// one of the group's units can act on them (a healer, an ability cast on allies). [`check`]
/// would refuse an attack on any other tag, so the schema leaves them out (an ability aimed
/// at the ground under an own unit takes a `cell` instead).
pub fn targets(obs: &GroupObs) -> Vec<UnitId> {
    let helps = obs.units.iter().filter(|u| u.own && obs.controlled.iter().any(|c| c.unit == u.tag && c.alive)).any(|u| {
        u.flags.contains(avacraft_engine::UnitFlags::HEALER) || u.abilities.iter().any(|a| a.ability.spec().rule == TargetRule::Ally)
    });
    let mut tags: Vec<UnitId> = obs.units.iter().filter(|u| helps || !u.own).map(|u| u.tag).collect();
    tags.sort_unstable();
    tags.dedup();
    tags
}

/// Checks `items` (with their indices in the model's list). Refusals of earlier stages (items
/// that did not parse) are passed in `refused` and kept.
pub fn check(s: &Situation<'_>, items: &[(usize, Item)], mut refused: Vec<Refused>) -> Checked {
    let mut commands: Vec<(UnitId, Order)> = Vec::new();
    for (i, item) in items {
        // The number the model wrote; a unit it names is one of the observation's.
        let tag = item.unit;
        let verdict = if !s.controls(tag) {
            Err(format!("unit {tag} is not one of yours that is alive (yours: {})", s.mine()))
        } else if commands.iter().any(|(t, _)| t.tag() == tag) {
            Err(format!("unit {tag} already has an action in this decision"))
        } else {
            match s.unit(tag) {
                Some(u) => command(s, u, item).map(|c| (u.tag, c)),
                None => Err(format!("unit {tag} is not in the observation")),
            }
        };
        match verdict {
            Ok(c) => commands.push(c),
            Err(reason) => refused.push(Refused { item: *i, unit: Some(tag), reason }),
        }
    }
    refused.sort_by_key(|r| r.item);
    Checked { commands, refused }
}

fn name(u: &UnitInfo) -> String {
    format!("{} {}", u.kind.base().name(), u.tag.tag())
}

/// The item as a command, checked by the engine's rules from the observation
/// ([`check_action`]); a refusal in words that name the units.
fn command(s: &Situation<'_>, u: &UnitInfo, item: &Item) -> Result<Order, String> {
    if item.action == Verb::Stance {
        if !s.micro {
            return Err("`stance` is not an action here (the paper's action set)".into());
        }
        return stance(s, u, item).map(Order::Keep);
    }
    let cmd = build(s, u, item)?;
    check_action(s.obs, s.terrain, &Action::new(view::id(u), cmd)).map_err(|e| words(s, u, item, &cmd, e))?;
    Ok(Order::Do(cmd))
}

/// A stance item: `focus` and `kite` need a unit with a weapon, and a target it can hit if
/// they name one.
fn stance(s: &Situation<'_>, u: &UnitInfo, item: &Item) -> Result<Stance, String> {
    let raw = item.stance.as_deref().ok_or("stance needs `stance`: focus, kite or hold")?;
    let named = |tag: u32| -> Result<UnitId, String> {
        let t = s.unit(tag).filter(|t| !t.own).ok_or_else(|| format!("target {tag} is not an enemy you can see"))?;
        if !view::can_attack(u, t) {
            return Err(format!("{} cannot hit {}", name(u), name(t)));
        }
        Ok(t.tag)
    };
    match raw {
        "focus" if u.spec().weapons.is_empty() => Err(format!("{} has no weapon to focus with", name(u))),
        "focus" => Ok(Stance::Focus { target: item.target.map(named).transpose()? }),
        "kite" if u.spec().weapons.is_empty() => Err(format!("{} has no weapon to kite with", name(u))),
        "kite" => Ok(Stance::Kite { target: item.target.map(named).transpose()? }),
        "hold" => Ok(Stance::Hold),
        other => Err(format!("unknown stance `{other}` (focus, kite or hold)")),
    }
}

/// A point the model wrote, on the map.
fn exact(s: &Situation<'_>, p: [f32; 2]) -> Result<Vec2, String> {
    let v = Vec2::new(p[0], p[1]);
    if !(v.x.is_finite() && v.y.is_finite() && s.terrain.playable().contains(v)) {
        let r = s.terrain.playable();
        return Err(format!(
            "point ({:.1}, {:.1}) is off the map (x {:.0} to {:.0}, y {:.0} to {:.0})",
            p[0], p[1], r.left, r.right, r.bottom, r.top
        ));
    }
    Ok(v)
}

/// What the item says, as a command: the camera's cells become points, names become types.
/// Refuses only what does not make a command at all.
fn build(s: &Situation<'_>, u: &UnitInfo, item: &Item) -> Result<Command, String> {
    Ok(match item.action {
        Verb::Hold => Command::Hold,
        Verb::Stop => Command::Stop,
        Verb::MoveGrid => Command::MoveTo { to: s.point(item.cell.ok_or("move_grid needs `cell`: [column, row]")?)? },
        Verb::MoveDir => {
            let d = item.direction.as_deref().ok_or("move_dir needs `direction`: north, south, east or west")?;
            let dir = match d.to_ascii_lowercase().as_str() {
                "north" | "up" => Direction::Up,
                "south" | "down" => Direction::Down,
                "east" | "right" => Direction::Right,
                "west" | "left" => Direction::Left,
                other => return Err(format!("unknown direction `{other}` (north, south, east or west)")),
            };
            Command::MoveDir { dir }
        }
        Verb::Attack => Command::Attack { target: seen_id(s, item.target.ok_or("attack needs `target`: the tag of a unit on screen")?)? },
        Verb::Ability => ability(s, u, item)?,
        _ if !s.micro => return Err(format!("`{}` is not an action here (the paper's action set)", item.action.name())),
        Verb::Move => Command::MoveTo { to: exact(s, item.point.ok_or("move needs `point`: [x, y] in world units")?)? },
        Verb::AttackMove => {
            let to = match (item.point, item.cell) {
                (Some(p), _) => exact(s, p)?,
                (None, Some(c)) => s.point(c)?,
                (None, None) => return Err("attack_move needs `point`: [x, y] (or `cell`)".into()),
            };
            Command::AttackMoveTo { to }
        }
        // Read by `stance` before a command is built.
        Verb::Stance => return Err("stance needs `stance`: focus, kite or hold".into()),
    })
}

/// The id of a unit the group sees.
fn seen_id(s: &Situation<'_>, tag: u32) -> Result<UnitId, String> {
    s.unit(tag).map(view::id).ok_or_else(|| format!("target {tag} is not a unit you can see"))
}

fn ability(s: &Situation<'_>, u: &UnitInfo, item: &Item) -> Result<Command, String> {
    let raw = item.ability.as_deref().ok_or("ability needs `ability`: the ability's name")?;
    let a: Ability = raw.parse().ok().filter(|&a| view::ability(u, a).is_some()).ok_or_else(|| no_such(u, raw))?;
    let target = match (a.spec().target, item.target, item.cell) {
        (TargetKind::None, _, _) => AbilityTarget::None,
        // The micro action set aims at exact points too.
        (TargetKind::Point | TargetKind::PointOrUnit, None, None) if s.micro && item.point.is_some() => {
            AbilityTarget::Point { to: exact(s, item.point.unwrap_or_default())? }
        }
        (TargetKind::Unit | TargetKind::PointOrUnit, Some(t), _) => AbilityTarget::Unit { unit: seen_id(s, t)? },
        (TargetKind::Point | TargetKind::PointOrUnit, _, Some(c)) => AbilityTarget::Point { to: s.point(c)? },
        (TargetKind::Unit, None, _) => return Err(format!("{} needs `target`: a unit tag", a.name())),
        (TargetKind::Point, Some(t), None) => {
            // A unit named where a point is wanted: its position, as a player would click it.
            let p = s.unit(t).ok_or_else(|| format!("target {t} is not a unit you can see"))?;
            AbilityTarget::Point { to: view::pos(p) }
        }
        (_, None, None) => return Err(format!("{} needs `cell` (or `target`)", a.name())),
    };
    Ok(Command::Ability { ability: a, target })
}

fn no_such(u: &UnitInfo, raw: &str) -> String {
    let own: Vec<&str> = u.abilities.iter().map(|a| a.ability.name()).collect();
    let list = if own.is_empty() { "none".to_owned() } else { own.join(", ") };
    format!("{} has no ability `{raw}` (its abilities: {list})", name(u))
}

/// The engine's refusal in words a model can act on, naming the units by type and tag.
fn words(s: &Situation<'_>, u: &UnitInfo, item: &Item, cmd: &Command, e: ActionError) -> String {
    let other = |id: UnitId| s.unit(id.tag()).map_or_else(|| format!("unit {}", id.tag()), name);
    match e {
        ActionError::UnknownTarget { target } | ActionError::TargetDead { target } | ActionError::TargetNotVisible { target, .. } => {
            format!("target {} is not a unit you can see", target.tag())
        }
        ActionError::InvalidTarget { target, why, .. } => match why {
            TargetProblem::HealerNeedsFriend => format!("{} heals: its target must be another of your units", name(u)),
            TargetProblem::NotBiological => format!("{} heals biological units only, and {} is not", name(u), other(target)),
            TargetProblem::Friendly => format!("target {} is your own unit", target.tag()),
            TargetProblem::NoAirWeapon | TargetProblem::NoGroundWeapon if u.spec().weapons.is_empty() => {
                format!("{} has no weapon", name(u))
            }
            TargetProblem::NoAirWeapon => format!("{} cannot hit air units such as {}", name(u), other(target)),
            TargetProblem::NoGroundWeapon => format!("{} cannot hit ground units such as {}", name(u), other(target)),
            TargetProblem::OutOfReach => format!("{} cannot move now, and {} is outside its weapon's range", name(u), other(target)),
        },
        ActionError::Unavailable { why: Inability::Morphing, .. } => {
            format!("{} is morphing: only `stop` (which cancels it) is possible now", name(u))
        }
        ActionError::Unavailable { why: Inability::Immobile { .. }, .. } => format!("{} cannot move now", name(u)),
        ActionError::Unavailable { why: Inability::NoGround, .. } => format!("{} has no ground path towards that point", name(u)),
        ActionError::AbilityRefused { ability: a, refusal, .. } => match refusal {
            Refusal::OutOfRange { distance, range } => {
                let what = match (cmd, item.cell) {
                    (Command::Ability { target: AbilityTarget::Unit { unit }, .. }, _) => format!("target {}", unit.tag()),
                    (_, Some(c)) => format!("cell [{}, {}]", c[0], c[1]),
                    _ => format!("unit {}", item.target.unwrap_or_default()),
                };
                format!("{} is out of range: {what} is {distance:.1} away, range {range:.1}", a.name())
            }
            Refusal::InvalidTarget { why } => format!("{} cannot be cast on that: {why}", a.name()),
            Refusal::WrongTargetKind { .. } => format!("{} cannot be cast on that kind of target", a.name()),
            other => format!("{} cannot cast {} now: {}", name(u), a.name(), other.code().text()),
        },
        other => other.to_string(),
    }
}
