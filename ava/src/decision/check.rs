//! Checking items against the observation with the engine's own rules, so that what is
//! accepted is executed, and what is refused says why in words a model can act on.

use super::item::{Item, Verb};
use avacraft_engine::agent::GroupObs;
use avacraft_engine::agent::view;
use avacraft_engine::{
    Ability, AbilityTarget, Attrs, Buffs, Command, Direction, MOVE_AMOUNT, TargetKind, TargetRule, Terrain, UnitId, UnitInfo, Vec2,
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

/// What a decision's items come to: commands for units, and refusals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Checked {
    /// (unit tag, command), in the model's order, at most one per unit.
    pub commands: Vec<(u32, Command)>,
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
}

impl Situation<'_> {
    fn unit(&self, tag: u32) -> Option<&UnitInfo> {
        self.obs.units.iter().find(|u| u.tag == tag)
    }
    fn controls(&self, tag: u32) -> bool {
        self.obs.controlled.iter().any(|c| c.unit == tag && c.alive)
    }
    fn mine(&self) -> String {
        let tags: Vec<String> = self.obs.controlled.iter().filter(|c| c.alive).map(|c| c.unit.to_string()).collect();
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
pub fn targets(obs: &GroupObs) -> Vec<u32> {
    let helps = obs.units.iter().filter(|u| u.own && obs.controlled.iter().any(|c| c.unit == u.tag && c.alive)).any(|u| {
        u.flags.contains(avacraft_engine::UnitFlags::HEALER) || u.abilities.iter().any(|a| a.ability.spec().rule == TargetRule::Ally)
    });
    let mut tags: Vec<u32> = obs.units.iter().filter(|u| helps || !u.own).map(|u| u.tag).collect();
    tags.sort_unstable();
    tags.dedup();
    tags
}

/// Checks `items` (with their indices in the model's list). Refusals of earlier stages (items
/// that did not parse) are passed in `refused` and kept.
pub fn check(s: &Situation<'_>, items: &[(usize, Item)], mut refused: Vec<Refused>) -> Checked {
    let mut commands: Vec<(u32, Command)> = Vec::new();
    for (i, item) in items {
        let tag = item.unit;
        let verdict = if !s.controls(tag) {
            Err(format!("unit {tag} is not one of yours that is alive (yours: {})", s.mine()))
        } else if commands.iter().any(|(t, _)| *t == tag) {
            Err(format!("unit {tag} already has an action in this decision"))
        } else {
            match s.unit(tag) {
                Some(u) => command(s, u, item),
                None => Err(format!("unit {tag} is not in the observation")),
            }
        };
        match verdict {
            Ok(c) => commands.push((tag, c)),
            Err(reason) => refused.push(Refused { item: *i, unit: Some(tag), reason }),
        }
    }
    refused.sort_by_key(|r| r.item);
    Checked { commands, refused }
}

fn name(u: &UnitInfo) -> String {
    format!("{} {}", u.kind.base().name(), u.tag)
}

fn command(s: &Situation<'_>, u: &UnitInfo, item: &Item) -> Result<Command, String> {
    let needs_move = || if view::mobile(u) { Ok(()) } else { Err(format!("{} cannot move now", name(u))) };
    // Ground units go as near as they can get; with no ground they can reach, the engine
    // refuses the move.
    let reach = |to: Vec2| {
        if view::flying(u) || s.terrain.reachable_point(view::pos(u), to, u.kind.spec().cliff_walk).is_some() {
            Ok(())
        } else {
            Err(format!("{} has no ground path towards that point", name(u)))
        }
    };
    if u.buffs.contains(Buffs::MORPHING) && !matches!(item.action, Verb::Stop | Verb::Ability) {
        return Err(format!("{} is morphing: only `stop` (which cancels it) is possible now", name(u)));
    }
    match item.action {
        Verb::Hold => Ok(Command::Hold),
        Verb::Stop => Ok(Command::Stop),
        Verb::MoveGrid => {
            let cell = item.cell.ok_or("move_grid needs `cell`: [column, row]")?;
            needs_move()?;
            let to = s.point(cell)?;
            reach(to)?;
            Ok(Command::MoveTo { to })
        }
        Verb::MoveDir => {
            let d = item.direction.as_deref().ok_or("move_dir needs `direction`: north, south, east or west")?;
            let dir = match d.to_ascii_lowercase().as_str() {
                "north" | "up" => Direction::Up,
                "south" | "down" => Direction::Down,
                "east" | "right" => Direction::Right,
                "west" | "left" => Direction::Left,
                other => return Err(format!("unknown direction `{other}` (north, south, east or west)")),
            };
            needs_move()?;
            reach(s.terrain.playable().clamp(view::pos(u) + dir.vector() * MOVE_AMOUNT, 0.0))?;
            Ok(Command::MoveDir { dir })
        }
        Verb::Attack => attack(s, u, item.target.ok_or("attack needs `target`: the tag of a unit on screen")?),
        Verb::Ability => ability(s, u, item),
    }
}

fn attack(s: &Situation<'_>, u: &UnitInfo, tag: u32) -> Result<Command, String> {
    let t = s.unit(tag).ok_or_else(|| format!("target {tag} is not a unit you can see"))?;
    let target = UnitId::new((tag - 1) as u16);
    if u.flags.contains(avacraft_engine::UnitFlags::HEALER) {
        if !t.own || t.tag == u.tag {
            return Err(format!("{} heals: its target must be another of your units", name(u)));
        }
        if !t.kind.spec().attrs.has(Attrs::BIOLOGICAL) {
            return Err(format!("{} heals biological units only, and {} is not", name(u), name(t)));
        }
        return Ok(Command::Attack { target });
    }
    if u.kind.spec().weapons.is_empty() {
        return Err(format!("{} has no weapon", name(u)));
    }
    if t.own {
        return Err(format!("target {tag} is your own unit"));
    }
    if !view::can_attack(u, t) {
        let layer = if view::flying(t) { "air" } else { "ground" };
        return Err(format!("{} cannot hit {} units such as {}", name(u), layer, name(t)));
    }
    if !view::mobile(u) && view::weapon_against(u, t).is_some_and(|w| view::edge(u, t) > w.range || view::edge(u, t) < w.min_range) {
        return Err(format!("{} cannot move now, and {} is outside its weapon's range", name(u), name(t)));
    }
    Ok(Command::Attack { target })
}

fn ability(s: &Situation<'_>, u: &UnitInfo, item: &Item) -> Result<Command, String> {
    let raw = item.ability.as_deref().ok_or("ability needs `ability`: the ability's name")?;
    let own: Vec<&str> = u.abilities.iter().map(|a| a.ability.name()).collect();
    let no_such = || {
        let list = if own.is_empty() { "none".to_owned() } else { own.join(", ") };
        format!("{} has no ability `{raw}` (its abilities: {list})", name(u))
    };
    let a: Ability = raw.parse().map_err(|_| no_such())?;
    let info = view::ability(u, a).ok_or_else(no_such)?;
    if !info.available {
        let why = info.why_not.map_or("not castable now", |c| c.text());
        return Err(format!("{} cannot cast {} now: {why}", name(u), a.name()));
    }
    let spec = a.spec();
    let unit_target = |tag: u32| -> Result<AbilityTarget, String> {
        let t = s.unit(tag).ok_or_else(|| format!("target {tag} is not a unit you can see"))?;
        match spec.rule {
            TargetRule::Enemy if t.own => return Err(format!("{} needs an enemy target", a.name())),
            TargetRule::Ally if !t.own || t.tag == u.tag => return Err(format!("{} needs another of your units as target", a.name())),
            _ => {}
        }
        let d = view::edge(u, t);
        if d > info.range {
            return Err(format!("{} is out of range: target {tag} is {d:.1} away, range {:.1}", a.name(), info.range));
        }
        Ok(AbilityTarget::Unit { unit: UnitId::new((tag - 1) as u16) })
    };
    let point_target = |to: Vec2, what: String| -> Result<AbilityTarget, String> {
        let d = view::pos(u).dist(to) - view::radius(u);
        if d > info.range {
            return Err(format!("{} is out of range: {what} is {d:.1} away, range {:.1}", a.name(), info.range));
        }
        Ok(AbilityTarget::Point { to })
    };
    let target = match (spec.target, item.target, item.cell) {
        (TargetKind::None, _, _) => AbilityTarget::None,
        (TargetKind::Unit | TargetKind::PointOrUnit, Some(t), _) => unit_target(t)?,
        (TargetKind::Point | TargetKind::PointOrUnit, _, Some(c)) => point_target(s.point(c)?, format!("cell [{}, {}]", c[0], c[1]))?,
        (TargetKind::Unit, None, _) => return Err(format!("{} needs `target`: a unit tag", a.name())),
        (TargetKind::Point, Some(t), None) => {
            // A unit named where a point is wanted: its position, as a player would click it.
            let p = s.unit(t).ok_or_else(|| format!("target {t} is not a unit you can see"))?;
            point_target(view::pos(p), format!("unit {t}"))?
        }
        (_, None, None) => return Err(format!("{} needs `cell` (or `target`)", a.name())),
    };
    Ok(Command::Ability { ability: a, target })
}
