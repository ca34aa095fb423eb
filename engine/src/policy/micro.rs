//! Ability use as a competent player does it, shared by the scripted agents, the three
//! opponent styles and the built-in AI emulation: stim when engaging at full health, siege
//! when enemies approach and unsiege to chase, storm on clumps, feedback on casters, blink
//! damaged Stalkers back, Guardian Shield against ranged units, Banelings at clumps of
//! light units, Queens transfuse the most valuable damaged unit, and the rest of the
//! table's abilities where they pay.
//!
//! It reads observations only: each ability's availability as the unit's observation
//! reports it (energy, cooldown, upgrade, mode, state), then the target rules and the cast
//! range from what the team sees, so a scripted side does not have casts refused. The engine
//! still validates every cast it is given.

use super::view::{attacking, busy, can_attack, edge, flying, id, max_range, mobile, pos, radius, ready, sees_point};
use crate::ability::{Ability, AbilityTarget, DETECTION_RADIUS, EMP_RADIUS, EffectKind, STORM_RADIUS, TargetKind, TargetRule};
use crate::action::{Action, Command};
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::obs::GroupObs;
use crate::obs::{Buffs, UnitFlags, UnitInfo};
use crate::terrain::Terrain;
use crate::units::UnitKind;

/// Ability actions for the units the group controls this step, and the tags of the units
/// they leave alone otherwise (casting, channelling, morphing, or running at a clump): the
/// caller gives those no other order.
pub(crate) fn ability_actions(g: &GroupObs, terrain: &Terrain) -> (Vec<Action>, Vec<UnitId>) {
    // Storms already on the ground (ours) and cast this step: a new one must not overlap
    // them, as storms do not stack.
    let storms = g.effects.iter().filter(|e| e.kind == EffectKind::PsionicStorm && e.team == g.team).map(|e| Vec2::new(e.x, e.y)).collect();
    let mut s = Step { g, terrain, out: Vec::new(), handled: Vec::new(), storms, feedbacks: Vec::new() };
    for u in g.mine() {
        if busy(u) {
            s.handled.push(u.tag);
            continue;
        }
        terran(&mut s, u);
        protoss(&mut s, u);
        zerg(&mut s, u);
    }
    (s.out, s.handled)
}

/// One step's casts so far, shared by every caster's rules: the actions, the units they
/// claim, the storms down or cast and the casters already fed back.
struct Step<'a> {
    g: &'a GroupObs,
    terrain: &'a Terrain,
    out: Vec<Action>,
    handled: Vec<UnitId>,
    storms: Vec<Vec2>,
    feedbacks: Vec<UnitId>,
}

impl Step<'_> {
    /// `u` casting `ability` on `target`, when the engine would take it.
    fn cast(&self, u: &UnitInfo, ability: Ability, target: AbilityTarget) -> Option<Action> {
        cast_ok(self.g, self.terrain, u, ability, target).then(|| Action::new(id(u), Command::Ability { ability, target }))
    }

    /// Keeps a cast; an exclusive one leaves the unit no other order this step.
    fn take(&mut self, u: &UnitInfo, a: Option<Action>, exclusive: bool) -> bool {
        let Some(a) = a else { return false };
        self.out.push(a);
        if exclusive {
            self.handled.push(u.tag);
        }
        true
    }
}

/// Terran casters: Stimpack, Afterburners, Siege Mode and back, KD8 Charge, EMP, Steady
/// Targeting, cloaking, and the Viking's two modes.
fn terran(s: &mut Step<'_>, u: &UnitInfo) {
    let (g, terrain) = (s.g, s.terrain);
    match u.kind {
        UnitKind::Marine | UnitKind::Marauder => {
            let engaging = nearest_enemy(g, u, |e| can_attack(u, e)).is_some_and(|(_, d)| d <= max_range(u) + 2.0);
            if engaging && !u.buffs.contains(Buffs::STIMMED) && u.hp >= u.max_hp {
                s.take(u, s.cast(u, Ability::Stimpack, AbilityTarget::None), false);
            }
        }
        UnitKind::Medivac if u.hp < 0.5 * u.max_hp && nearest_enemy(g, u, |_| true).is_some_and(|(_, d)| d < 8.0) => {
            s.take(u, s.cast(u, Ability::Afterburners, AbilityTarget::None), false);
        }
        UnitKind::SiegeTank => {
            let near = nearest_enemy(g, u, |e| !flying(e)).map(|(_, d)| d);
            if near.is_some_and(|d| (3.0..=13.0).contains(&d)) {
                s.take(u, s.cast(u, Ability::SiegeMode, AbilityTarget::None), true);
            }
        }
        UnitKind::SiegeTankSieged => {
            // Unsiege to chase when nothing is close (with a margin over the siege
            // rule, so a unit hovering at the edge does not toggle it), or when every
            // enemy in reach is inside the minimum range.
            let ground: Vec<f32> = g.enemies().filter(|e| !flying(e)).map(|e| edge(u, e)).collect();
            let in_reach = ground.iter().any(|&d| (2.0..=13.0).contains(&d));
            let near = ground.iter().any(|&d| d <= 15.0);
            let hugged = ground.iter().any(|&d| d < 2.0);
            if !in_reach && (!near || hugged) {
                s.take(u, s.cast(u, Ability::Unsiege, AbilityTarget::None), true);
            }
        }
        UnitKind::Reaper => {
            // Knock back a melee unit closing in.
            if let Some((e, d)) = nearest_enemy(g, u, |e| !flying(e) && max_range(e) < 1.5 && mobile(e))
                && d < 3.0
            {
                s.take(u, s.cast(u, Ability::Kd8Charge, AbilityTarget::Unit { unit: id(e) }), false);
            }
        }
        UnitKind::Ghost => {
            let emp = best_clump(g, u, EMP_RADIUS, |e| e.shield + e.energy.min(100.0))
                .filter(|(_, v)| *v >= 100.0)
                .and_then(|(p, _)| s.cast(u, Ability::Emp, AbilityTarget::Point { to: p }));
            if s.take(u, emp, true) {
                return;
            }
            let snipe = g
                .enemies()
                .filter(|e| e.flags.contains(UnitFlags::BIOLOGICAL) && e.hp >= 80.0)
                .max_by(|a, b| a.hp.total_cmp(&b.hp).then(b.tag.cmp(&a.tag)))
                .and_then(|e| s.cast(u, Ability::SteadyTargeting, AbilityTarget::Unit { unit: id(e) }));
            if nearest_enemy(g, u, |e| can_attack(e, u)).is_none_or(|(_, d)| d > 4.0) && s.take(u, snipe, true) {
                return;
            }
            cloak_if_engaged(g, terrain, u, &mut s.out);
        }
        UnitKind::Banshee => cloak_if_engaged(g, terrain, u, &mut s.out),
        UnitKind::VikingAssault if g.enemies().any(|e| flying(e) && e.kind.can_fight()) => {
            s.take(u, s.cast(u, Ability::FighterMode, AbilityTarget::None), true);
        }
        UnitKind::VikingFighter if !g.enemies().any(flying) && g.enemies().any(|e| !flying(e)) => {
            s.take(u, s.cast(u, Ability::AssaultMode, AbilityTarget::None), true);
        }
        _ => {}
    }
}

/// Protoss casters: Blink, Guardian Shield, Feedback and Psionic Storm, Graviton Beam.
fn protoss(s: &mut Step<'_>, u: &UnitInfo) {
    let (g, terrain) = (s.g, s.terrain);
    match u.kind {
        UnitKind::Stalker => {
            // Blink a damaged Stalker back, away from the enemies close to it.
            let threats: Vec<&UnitInfo> = g.enemies().filter(|e| can_attack(e, u) && edge(u, e) < 6.0).collect();
            if u.shield < 0.1 * u.max_shield && u.hp < 0.6 * u.max_hp && !threats.is_empty() {
                let away = threats.iter().fold(Vec2::ZERO, |acc, e| acc + (pos(u) - pos(e)).normalized());
                let to = terrain.playable().clamp(pos(u) + away.normalized() * 7.5, radius(u));
                s.take(u, s.cast(u, Ability::Blink, AbilityTarget::Point { to }), true);
            }
        }
        UnitKind::Sentry => {
            let ranged = g.enemies().filter(|e| max_range(e) >= 2.0 && pos(e).dist(pos(u)) < 9.0).count();
            let friends = g.own().filter(|o| pos(o).dist(pos(u)) < 4.5).count();
            if ranged >= 2 && friends >= 3 {
                s.take(u, s.cast(u, Ability::GuardianShield, AbilityTarget::None), false);
            }
        }
        UnitKind::HighTemplar => {
            let caster = g
                .enemies()
                .filter(|e| e.energy >= 50.0 && !s.feedbacks.contains(&e.tag))
                .max_by(|a, b| a.energy.total_cmp(&b.energy).then(b.tag.cmp(&a.tag)));
            if let Some(e) = caster
                && s.take(u, s.cast(u, Ability::Feedback, AbilityTarget::Unit { unit: id(e) }), true)
            {
                s.feedbacks.push(e.tag);
                return;
            }
            // Storm a clump of at least three enemies, clear of our own units and of
            // our storms (on the ground or cast this step).
            let clump = best_clump(g, u, STORM_RADIUS, |_| 1.0)
                .filter(|(p, n)| *n >= 3.0 && !g.own().any(|o| pos(o).dist(*p) < STORM_RADIUS + radius(o) + 0.5))
                .filter(|(p, _)| s.storms.iter().all(|s| s.dist(*p) > 2.0 * STORM_RADIUS));
            if let Some((p, _)) = clump
                && s.take(u, s.cast(u, Ability::PsionicStorm, AbilityTarget::Point { to: p }), true)
            {
                s.storms.push(p);
            }
        }
        UnitKind::Phoenix => {
            let lift = g
                .enemies()
                .filter(|e| !flying(e) && !e.flags.contains(UnitFlags::MASSIVE) && edge(u, e) <= 4.0)
                .max_by(|a, b| (a.max_hp + a.max_shield).total_cmp(&(b.max_hp + b.max_shield)).then(b.tag.cmp(&a.tag)));
            if let Some(e) = lift {
                s.take(u, s.cast(u, Ability::GravitonBeam, AbilityTarget::Unit { unit: id(e) }), true);
            }
        }
        _ => {}
    }
}

/// Zerg casters: the Baneling's Explode (and its run at a clump), the Queen's Transfusion.
fn zerg(s: &mut Step<'_>, u: &UnitInfo) {
    let g = s.g;
    match u.kind {
        // Running at a clump is part of the Baneling's ability use: with abilities off
        // (Explode unavailable) it fights as the engine's own rules make it.
        UnitKind::Baneling if ready(u, Ability::Explode) => {
            let light = |e: &UnitInfo| e.flags.contains(UnitFlags::LIGHT) && !flying(e);
            let around = |p: Vec2| g.enemies().filter(|e| light(e) && pos(e).dist(p) <= 2.2 + radius(e)).count();
            if around(pos(u)) >= 3 {
                s.take(u, s.cast(u, Ability::Explode, AbilityTarget::None), true);
            } else if let Some(t) = g.enemies().filter(|e| light(e)).max_by(|a, b| {
                around(pos(a)).cmp(&around(pos(b))).then(pos(b).dist_sq(pos(u)).total_cmp(&pos(a).dist_sq(pos(u)))).then(b.tag.cmp(&a.tag))
            }) && around(pos(t)) >= 2
            {
                if !attacking(u, t.tag) {
                    s.out.push(Action::new(id(u), Command::Attack { target: id(t) }));
                }
                s.handled.push(u.tag);
            }
        }
        UnitKind::Queen => {
            let patient = g
                .own()
                .filter(|o| o.tag != u.tag && o.flags.contains(UnitFlags::BIOLOGICAL) && o.hp < 0.5 * o.max_hp && o.max_hp - o.hp >= 50.0)
                .filter(|o| edge(u, o) <= Ability::Transfusion.spec().range)
                .max_by(|a, b| a.max_hp.total_cmp(&b.max_hp).then(b.tag.cmp(&a.tag)));
            if let Some(p) = patient {
                s.take(u, s.cast(u, Ability::Transfusion, AbilityTarget::Unit { unit: id(p) }), false);
            }
        }
        _ => {}
    }
}

/// Whether the engine would accept `u` casting `ability` on `target`, judged from the
/// observation: the ability's availability, then the target rules and the cast range.
fn cast_ok(g: &GroupObs, terrain: &Terrain, u: &UnitInfo, ability: Ability, target: AbilityTarget) -> bool {
    if !ready(u, ability) {
        return false;
    }
    let spec = ability.spec();
    match (spec.target, target) {
        (TargetKind::None, AbilityTarget::None) => true,
        (TargetKind::Point | TargetKind::PointOrUnit, AbilityTarget::Point { to }) => {
            if !to.is_finite() || !terrain.playable().contains(to) || pos(u).dist(to) - radius(u) > spec.range {
                return false;
            }
            // Blink needs ground to stand on, and vision of higher ground.
            ability != Ability::Blink
                || (terrain.walkable(to) && (terrain.height_at(to) <= terrain.height_at(pos(u)) + 0.5 || sees_point(terrain, g.own(), to)))
        }
        (TargetKind::Unit | TargetKind::PointOrUnit, AbilityTarget::Unit { unit }) => {
            // The group's observation lists exactly the living units its team sees.
            let Some(t) = g.unit(unit) else { return false };
            let rule_ok = match spec.rule {
                TargetRule::Enemy => !t.own,
                TargetRule::Ally => t.own && t.tag != u.tag,
                TargetRule::NoUnit => true,
            };
            if !rule_ok || edge(u, t) > spec.range {
                return false;
            }
            let bio = t.flags.contains(UnitFlags::BIOLOGICAL);
            match ability {
                Ability::SteadyTargeting => bio,
                Ability::Feedback => t.energy > 0.0,
                Ability::GravitonBeam => {
                    !flying(t)
                        && !t.flags.contains(UnitFlags::MASSIVE)
                        && !t.flags.contains(UnitFlags::STRUCTURE)
                        && !t.buffs.contains(Buffs::MORPHING)
                }
                Ability::Kd8Charge => !flying(t),
                Ability::Transfusion | Ability::Heal => bio && t.hp < t.max_hp,
                _ => true,
            }
        }
        _ => false,
    }
}

fn cloak_if_engaged(g: &GroupObs, terrain: &Terrain, u: &UnitInfo, out: &mut Vec<Action>) {
    let detected = g.enemies().any(|e| e.flags.contains(UnitFlags::DETECTOR) && pos(e).dist(pos(u)) < DETECTION_RADIUS + 2.0);
    let engaged = g.enemies().any(|e| can_attack(e, u) && edge(u, e) < 8.0);
    if engaged && !detected && !u.buffs.contains(Buffs::CLOAKED) && u.energy >= 50.0 {
        let (ability, target) = (Ability::Cloak, AbilityTarget::None);
        if cast_ok(g, terrain, u, ability, target) {
            out.push(Action::new(id(u), Command::Ability { ability, target }));
        }
    }
}

/// The closest seen enemy passing `keep`, with its edge distance; ties to the lower tag.
fn nearest_enemy<'a>(g: &'a GroupObs, u: &UnitInfo, keep: impl Fn(&UnitInfo) -> bool) -> Option<(&'a UnitInfo, f32)> {
    g.enemies().filter(|e| keep(e)).map(|e| (e, edge(u, e))).min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.tag.cmp(&b.0.tag)))
}

/// The seen enemy position within the caster's reach (its cast range of 9 to 10) whose
/// surroundings within `radius` hold the most `value`; ties to the lower tag.
fn best_clump(g: &GroupObs, u: &UnitInfo, r: f32, value: impl Fn(&UnitInfo) -> f32) -> Option<(Vec2, f32)> {
    let enemies: Vec<&UnitInfo> = g.enemies().collect();
    let mut best: Option<(Vec2, f32, UnitId)> = None;
    for c in enemies.iter().filter(|c| pos(c).dist(pos(u)) - radius(u) <= 9.0) {
        let v: f32 = enemies.iter().filter(|e| pos(e).dist(pos(c)) <= r + radius(e)).map(|e| value(e)).sum();
        if best.is_none_or(|(_, bv, bt)| v > bv || (v == bv && c.tag < bt)) {
            best = Some((pos(c), v, c.tag));
        }
    }
    best.map(|(p, v, _)| (p, v))
}
