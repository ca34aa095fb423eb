//! Ability use as a competent player does it, shared by the scripted agents, the three
//! opponent styles and the built-in AI emulation: stim when engaging at full health, siege
//! when enemies approach and unsiege to chase, storm on clumps, feedback on casters, blink
//! damaged Stalkers back, Guardian Shield against ranged units, Banelings at clumps of
//! light units, Queens transfuse the most valuable damaged unit, and the rest of the
//! table's abilities where they pay. Every cast is checked before it is issued, so a
//! scripted side never has a cast refused.

use super::TeamView;
use crate::ability::{Ability, AbilityTarget, STORM_RADIUS};
use crate::action::{Action, Command};
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::units::{Attrs, UnitKind};
use crate::world::{Order, Unit};

/// Ability actions for this step, and the units they leave alone otherwise (casting,
/// channelling, morphing, or running at a clump): the caller gives those no other order.
pub fn ability_actions(view: &TeamView<'_>) -> (Vec<Action>, Vec<UnitId>) {
    let mut out = Vec::new();
    let mut handled = Vec::new();
    if !view.world().rules().abilities {
        return (out, handled);
    }
    let tick = view.tick();
    let mut storms: Vec<Vec2> = Vec::new();
    let mut feedbacks: Vec<UnitId> = Vec::new();
    for u in view.own() {
        if u.status.busy(tick) {
            handled.push(u.id);
            continue;
        }
        let cast = |ability: Ability, target: AbilityTarget| -> Option<Action> {
            view.world().check_cast(view.team(), u, ability, target).ok().map(|_| Action::new(u.id, Command::Ability { ability, target }))
        };
        let mut take = |a: Option<Action>, exclusive: bool| -> bool {
            match a {
                Some(a) => {
                    out.push(a);
                    if exclusive {
                        handled.push(u.id);
                    }
                    true
                }
                None => false,
            }
        };
        match u.kind {
            UnitKind::Marine | UnitKind::Marauder => {
                let engaging = nearest_enemy(view, u, |e| view.can_attack(u, e)).is_some_and(|(_, d)| d <= max_range(u) + 2.0);
                if engaging && !u.status.stimmed(tick) && u.hp >= u.max_hp {
                    take(cast(Ability::Stimpack, AbilityTarget::None), false);
                }
            }
            UnitKind::Medivac if u.hp < 0.5 * u.max_hp && nearest_enemy(view, u, |_| true).is_some_and(|(_, d)| d < 8.0) => {
                take(cast(Ability::Afterburners, AbilityTarget::None), false);
            }
            UnitKind::SiegeTank => {
                let near = nearest_enemy(view, u, |e| !e.flying()).map(|(_, d)| d);
                if near.is_some_and(|d| (3.0..=13.0).contains(&d)) {
                    take(cast(Ability::SiegeMode, AbilityTarget::None), true);
                }
            }
            UnitKind::SiegeTankSieged => {
                // Unsiege to chase when nothing is close (with a margin over the siege
                // rule, so a unit hovering at the edge does not toggle it), or when every
                // enemy in reach is inside the minimum range.
                let ground: Vec<f32> = view.enemies().filter(|e| !e.flying()).map(|e| edge(u, e)).collect();
                let in_reach = ground.iter().any(|&d| (2.0..=13.0).contains(&d));
                let near = ground.iter().any(|&d| d <= 15.0);
                let hugged = ground.iter().any(|&d| d < 2.0);
                if !in_reach && (!near || hugged) {
                    take(cast(Ability::Unsiege, AbilityTarget::None), true);
                }
            }
            UnitKind::Reaper => {
                // Knock back a melee unit closing in.
                if let Some((e, d)) = nearest_enemy(view, u, |e| !e.flying() && max_range(e) < 1.5 && e.speed > 0.0)
                    && d < 3.0
                {
                    take(cast(Ability::Kd8Charge, AbilityTarget::Unit { unit: e }), false);
                }
            }
            UnitKind::Ghost => {
                let emp = best_clump(view, u, crate::ability::EMP_RADIUS, |e| e.shield + e.energy.min(100.0))
                    .filter(|(_, v)| *v >= 100.0)
                    .and_then(|(p, _)| cast(Ability::Emp, AbilityTarget::Point { to: p }));
                if take(emp, true) {
                    continue;
                }
                let snipe = view
                    .enemies()
                    .filter(|e| e.spec().attrs.has(Attrs::BIOLOGICAL) && e.hp >= 80.0)
                    .max_by(|a, b| a.hp.total_cmp(&b.hp).then(b.id.cmp(&a.id)))
                    .and_then(|e| cast(Ability::SteadyTargeting, AbilityTarget::Unit { unit: e.id }));
                if nearest_enemy(view, u, |e| view.can_attack(e, u)).is_none_or(|(_, d)| d > 4.0) && take(snipe, true) {
                    continue;
                }
                cloak_if_engaged(view, u, &mut out);
            }
            UnitKind::Banshee => cloak_if_engaged(view, u, &mut out),
            UnitKind::VikingAssault if view.enemies().any(|e| e.flying() && e.kind.can_fight()) => {
                take(cast(Ability::FighterMode, AbilityTarget::None), true);
            }
            UnitKind::VikingFighter if !view.enemies().any(|e| e.flying()) && view.enemies().any(|e| !e.flying()) => {
                take(cast(Ability::AssaultMode, AbilityTarget::None), true);
            }
            UnitKind::Stalker => {
                // Blink a damaged Stalker back, away from the enemies close to it.
                let threats: Vec<&Unit> = view.enemies().filter(|e| view.can_attack(e, u) && edge(u, e) < 6.0).collect();
                if u.shield < 0.1 * u.max_shield && u.hp < 0.6 * u.max_hp && !threats.is_empty() {
                    let away = threats.iter().fold(Vec2::ZERO, |acc, e| acc + (u.pos - e.pos).normalized());
                    let to = view.terrain().playable().clamp(u.pos + away.normalized() * 7.5, u.radius);
                    take(cast(Ability::Blink, AbilityTarget::Point { to }), true);
                }
            }
            UnitKind::Sentry => {
                let ranged = view.enemies().filter(|e| max_range(e) >= 2.0 && e.pos.dist(u.pos) < 9.0).count();
                let friends = view.own().filter(|o| o.pos.dist(u.pos) < 4.5).count();
                if ranged >= 2 && friends >= 3 {
                    take(cast(Ability::GuardianShield, AbilityTarget::None), false);
                }
            }
            UnitKind::HighTemplar => {
                let caster = view
                    .enemies()
                    .filter(|e| e.energy >= 50.0 && !feedbacks.contains(&e.id))
                    .max_by(|a, b| a.energy.total_cmp(&b.energy).then(b.id.cmp(&a.id)));
                if let Some(e) = caster
                    && take(cast(Ability::Feedback, AbilityTarget::Unit { unit: e.id }), true)
                {
                    feedbacks.push(e.id);
                    continue;
                }
                // Storm a clump of at least three enemies, clear of our own units and of
                // storms already cast this step.
                let clump = best_clump(view, u, STORM_RADIUS, |_| 1.0)
                    .filter(|(p, n)| *n >= 3.0 && !view.own().any(|o| o.pos.dist(*p) < STORM_RADIUS + o.radius + 0.5))
                    .filter(|(p, _)| storms.iter().all(|s| s.dist(*p) > 2.0 * STORM_RADIUS));
                if let Some((p, _)) = clump
                    && take(cast(Ability::PsionicStorm, AbilityTarget::Point { to: p }), true)
                {
                    storms.push(p);
                }
            }
            UnitKind::Phoenix => {
                let lift = view
                    .enemies()
                    .filter(|e| !e.flying() && !e.spec().attrs.has(Attrs::MASSIVE) && edge(u, e) <= 4.0)
                    .max_by(|a, b| (a.max_hp + a.max_shield).total_cmp(&(b.max_hp + b.max_shield)).then(b.id.cmp(&a.id)));
                if let Some(e) = lift {
                    take(cast(Ability::GravitonBeam, AbilityTarget::Unit { unit: e.id }), true);
                }
            }
            UnitKind::Baneling => {
                let light = |e: &Unit| e.spec().attrs.has(Attrs::LIGHT) && !e.flying();
                let around = |p: Vec2| view.enemies().filter(|e| light(e) && e.pos.dist(p) <= 2.2 + e.radius).count();
                if around(u.pos) >= 3 {
                    take(cast(Ability::Explode, AbilityTarget::None), true);
                } else if let Some(t) = view.enemies().filter(|e| light(e)).max_by(|a, b| {
                    around(a.pos).cmp(&around(b.pos)).then(b.pos.dist_sq(u.pos).total_cmp(&a.pos.dist_sq(u.pos))).then(b.id.cmp(&a.id))
                }) && around(t.pos) >= 2
                {
                    if u.order != (Order::Attack { target: t.id }) {
                        out.push(Action::new(u.id, Command::Attack { target: t.id }));
                    }
                    handled.push(u.id);
                }
            }
            UnitKind::Queen => {
                let patient = view
                    .own()
                    .filter(|o| o.id != u.id && o.spec().attrs.has(Attrs::BIOLOGICAL) && o.hp < 0.5 * o.max_hp && o.max_hp - o.hp >= 50.0)
                    .filter(|o| edge(u, o) <= Ability::Transfusion.spec().range)
                    .max_by(|a, b| a.max_hp.total_cmp(&b.max_hp).then(b.id.cmp(&a.id)));
                if let Some(p) = patient {
                    take(cast(Ability::Transfusion, AbilityTarget::Unit { unit: p.id }), false);
                }
            }
            _ => {}
        }
    }
    (out, handled)
}

fn cloak_if_engaged(view: &TeamView<'_>, u: &Unit, out: &mut Vec<Action>) {
    let detected = view.enemies().any(|e| e.spec().detector && e.pos.dist(u.pos) < crate::ability::DETECTION_RADIUS + 2.0);
    let engaged = view.enemies().any(|e| view.can_attack(e, u) && edge(u, e) < 8.0);
    if engaged && !detected && !u.status.cloaked && u.energy >= 50.0 {
        let (ability, target) = (Ability::Cloak, AbilityTarget::None);
        if view.world().check_cast(view.team(), u, ability, target).is_ok() {
            out.push(Action::new(u.id, Command::Ability { ability, target }));
        }
    }
}

fn edge(a: &Unit, b: &Unit) -> f32 {
    a.pos.dist(b.pos) - a.radius - b.radius
}

fn max_range(u: &Unit) -> f32 {
    u.spec().weapons.iter().map(|w| w.range).fold(0.0, f32::max)
}

/// The closest seen enemy passing `keep`, with its edge distance.
fn nearest_enemy(view: &TeamView<'_>, u: &Unit, keep: impl Fn(&Unit) -> bool) -> Option<(UnitId, f32)> {
    view.enemies().filter(|e| keep(e)).map(|e| (e.id, edge(u, e))).min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
}

/// The seen enemy position within the caster's reach (its cast range of 9 to 10) whose
/// surroundings within `radius` hold the most `value`; ties to the lower id.
fn best_clump(view: &TeamView<'_>, u: &Unit, radius: f32, value: impl Fn(&Unit) -> f32) -> Option<(Vec2, f32)> {
    let enemies: Vec<&Unit> = view.enemies().collect();
    let mut best: Option<(Vec2, f32, UnitId)> = None;
    for c in enemies.iter().filter(|c| c.pos.dist(u.pos) - u.radius <= 9.0) {
        let v: f32 = enemies.iter().filter(|e| e.pos.dist(c.pos) <= radius + e.radius).map(|e| value(e)).sum();
        if best.is_none_or(|(_, bv, bid)| v > bv || (v == bv && c.id < bid)) {
            best = Some((c.pos, v, c.id));
        }
    }
    best.map(|(p, v, _)| (p, v))
}
