//! Facts about units that scripted agents derive from observations alone: a [`UnitInfo`]
//! plus the unit type's data (`kind.spec()`), which a player knows. Nothing here reads the
//! world, so the same policy gives the same actions in-process and behind the wire.

use crate::ability::{Ability, AbilityInfo};
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::obs::{Buffs, OrderInfo, UnitFlags, UnitInfo};
use crate::terrain::Terrain;
use crate::time::LOOPS_PER_SECOND;
use crate::units::Weapon;

pub fn pos(u: &UnitInfo) -> Vec2 {
    Vec2::new(u.x, u.y)
}

/// Collision radius (a unit type's, in its current mode).
pub fn radius(u: &UnitInfo) -> f32 {
    u.spec().radius
}

/// Whether it can move now (0 while immobile, morphing, lifted or channelling).
pub fn mobile(u: &UnitInfo) -> bool {
    u.speed > 0.0
}

/// On the air layer now: a flying type, or a ground unit held up by a Graviton Beam (which
/// only anti-air weapons reach).
pub fn flying(u: &UnitInfo) -> bool {
    u.flags.contains(UnitFlags::FLYING) || u.buffs.contains(Buffs::LIFTED)
}

/// Morphing, lifted or channelling: any other order would be refused or cancel a channel.
pub fn busy(u: &UnitInfo) -> bool {
    u.buffs.contains(Buffs::MORPHING) || u.buffs.contains(Buffs::LIFTED) || u.buffs.contains(Buffs::CHANNELLING)
}

/// Heals instead of fighting, or has no weapon at all.
pub fn support(u: &UnitInfo) -> bool {
    u.flags.contains(UnitFlags::HEALER) || u.spec().weapons.is_empty()
}

/// The weapon of `u` that reaches `t`'s layer (the simulator's rule, `crate::rules`).
pub fn weapon_against(u: &UnitInfo, t: &UnitInfo) -> Option<&'static Weapon> {
    crate::rules::weapon_for(u, t).map(|(_, w)| w)
}

pub fn can_attack(u: &UnitInfo, t: &UnitInfo) -> bool {
    weapon_against(u, t).is_some()
}

/// Edge-to-edge distance.
pub fn edge(a: &UnitInfo, b: &UnitInfo) -> f32 {
    crate::rules::edge(a, b)
}

/// How far `t` is outside the range of `u`'s weapon against it (<= 0: in range).
pub fn range_gap(u: &UnitInfo, t: &UnitInfo) -> Option<f32> {
    weapon_against(u, t).map(|w| edge(u, t) - w.range)
}

pub fn max_range(u: &UnitInfo) -> f32 {
    u.spec().weapons.iter().map(|w| w.range).fold(0.0, f32::max)
}

/// Effective HP used to rank targets: what must be dealt to kill the unit.
pub fn ehp(u: &UnitInfo) -> f32 {
    u.hp + u.shield
}

pub fn hp_fraction(u: &UnitInfo) -> f32 {
    if u.max_hp > 0.0 { u.hp / u.max_hp } else { 0.0 }
}

/// Whether the weapon needs more than `loops` game loops to be ready again.
pub fn reloading_longer_than(u: &UnitInfo, loops: f32) -> bool {
    // Compared in seconds: dividing both sides by the same constant keeps their order.
    u.weapon_cooldown_s > loops / LOOPS_PER_SECOND
}

pub fn centroid<'a>(units: impl Iterator<Item = &'a UnitInfo>) -> Option<Vec2> {
    let (mut s, mut n) = (Vec2::ZERO, 0.0);
    for u in units {
        s += pos(u);
        n += 1.0;
    }
    (n > 0.0).then(|| s * (1.0 / n))
}

pub fn attacking(u: &UnitInfo, target: UnitId) -> bool {
    u.order == OrderInfo::Attack { target }
}

pub fn moving_to(u: &UnitInfo, to: Vec2) -> bool {
    u.order == OrderInfo::Move { x: to.x, y: to.y }
}

pub fn is_idle(u: &UnitInfo) -> bool {
    u.order == OrderInfo::Idle
}

/// One of the unit's abilities as its observation reports it (own units only).
pub fn ability(u: &UnitInfo, a: Ability) -> Option<&AbilityInfo> {
    u.abilities.iter().find(|i| i.ability == a)
}

/// Whether the unit could cast `a` now on some target: energy, cooldown, upgrade, mode and
/// state, as the observation says.
pub fn ready(u: &UnitInfo, a: Ability) -> bool {
    ability(u, a).is_some_and(|i| i.available)
}

/// Whether `team_units` see point `p`, by the engine's rule: within a unit's sight, and not
/// higher ground than a ground unit stands on. Full vision is not known from observations,
/// so this may say no where the engine would say yes, never the reverse.
pub fn sees_point<'a>(terrain: &Terrain, mut team_units: impl Iterator<Item = &'a UnitInfo>, p: Vec2) -> bool {
    let ph = terrain.height_at(p);
    team_units.any(|v| {
        let sight = v.spec().sight;
        pos(v).dist_sq(p) <= sight * sight && (flying(v) || ph < terrain.height_at(pos(v)) + 0.5)
    })
}

/// The unit's id for an [`Action`](crate::Action).
pub fn id(u: &UnitInfo) -> UnitId {
    u.tag
}
