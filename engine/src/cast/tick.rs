//! The per-loop side of abilities: timers, morphs, channels, cloak drain, heal over time,
//! and the area effects on the ground (storms, force fields, shields, charges).

use crate::ability::*;
use crate::combat::edge_dist;
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::units::Attrs;
use crate::units::UnitKind;
use crate::world::{Body, Order, World};

impl World {
    /// Runs before units decide: pending casts, then every timer of this loop.
    pub(crate) fn tick_abilities(&mut self) {
        self.run_casts();
        let tick = self.tick;
        let data = self.data;
        let mut channels = false;
        for i in 0..self.units.len() {
            let u = &mut self.units[i];
            if !u.alive {
                if u.status.channel.is_some() {
                    self.cancel_channel(i);
                }
                continue;
            }
            if u.status.quiet(tick) {
                continue;
            }
            channels |= u.status.channel.is_some();
            if let Some((into, done)) = u.status.morph
                && tick >= done
            {
                let s = data.spec(into);
                u.kind = into;
                u.spec = s;
                u.body = Body::of(s);
                u.radius = s.radius;
                u.base_speed = s.speed;
                u.status.morph = None;
                u.order = Order::Idle;
                u.target = None;
            }
            if u.body == Body::Air && !u.spec().flying && !u.status.lifted(tick) {
                u.body = Body::of(u.spec);
            }
            if u.status.cloaked {
                u.energy -= CLOAK_DRAIN;
                if u.energy <= 0.0 {
                    u.energy = 0.0;
                    u.status.cloaked = false;
                }
            }
            if tick < u.status.hot_until {
                u.hp = (u.hp + u.status.hot_per_loop).min(u.max_hp);
            }
            if tick >= u.status.barrier_until {
                u.status.barrier_hp = 0.0;
            }
            u.speed = u.status.speed(tick, u.base_speed);
        }
        if channels {
            self.tick_channels();
        }
        if !self.effects.is_empty() || self.any_guarded {
            self.tick_effects();
        }
        // Units killed by spells are dead before anyone decides this loop.
        if self.deaths_pending {
            let _ = self.resolve_hits(Vec::new());
        }
    }

    fn tick_channels(&mut self) {
        let tick = self.tick;
        for i in 0..self.units.len() {
            let Some(ch) = self.units[i].status.channel else { continue };
            let (team, caster) = (self.units[i].team, self.units[i].id);
            match ch {
                Channel::Snipe { target, done } => {
                    let t = &self.units[target.index()];
                    let lost = !t.alive || !self.visible_to(team, target) || edge_dist(&self.units[i], t) > SNIPE_LEASH;
                    if lost {
                        self.cancel_channel(i);
                    } else if tick >= done {
                        let psi = t.spec().attrs.has(Attrs::PSIONIC);
                        self.units[i].status.channel = None;
                        self.spell_damage(target.index(), SNIPE_DAMAGE + if psi { SNIPE_PSIONIC_BONUS } else { 0.0 }, caster);
                    }
                }
                Channel::Graviton { target } => {
                    let t = &self.units[target.index()];
                    if !t.alive || !t.status.lifted(tick) {
                        self.units[i].status.channel = None;
                    }
                }
            }
        }
    }

    fn tick_effects(&mut self) {
        let tick = self.tick;
        // Guardian Shields follow their Sentry and end with it.
        for e in self.effects.iter_mut().filter(|e| e.kind == EffectKind::GuardianShield) {
            let s = &self.units[e.owner.index()];
            if s.alive {
                e.pos = s.pos;
            } else {
                e.until = e.until.min(tick);
            }
        }
        let due: Vec<AreaEffect> = self.effects.iter().filter(|e| e.kind == EffectKind::Kd8Charge && !e.active(tick)).copied().collect();
        for e in due {
            self.detonate_kd8(&e);
        }
        self.effects.retain(|e| e.active(tick));
        for u in self.units.iter_mut() {
            u.status.guarded = false;
        }
        self.any_guarded = false;
        let mut storm_hits = Vec::new();
        for e in &self.effects {
            match e.kind {
                EffectKind::GuardianShield => {
                    let (team, pos) = (e.team, e.pos);
                    self.team_grid[team.index()].for_each_near(pos, GUARDIAN_RADIUS + 1.25, |j| {
                        storm_hits.push((j, -1.0));
                    });
                    for (j, _) in storm_hits.drain(..) {
                        let u = &mut self.units[j];
                        if u.alive && u.pos.dist(pos) <= GUARDIAN_RADIUS + u.radius {
                            u.status.guarded = true;
                            self.any_guarded = true;
                        }
                    }
                }
                EffectKind::PsionicStorm => {
                    self.grid.for_each_near(e.pos, e.radius + 1.25, |j| storm_hits.push((j, e.owner.index() as f32)));
                    for (j, owner) in storm_hits.drain(..) {
                        let u = &mut self.units[j];
                        if u.alive && !u.spec().attrs.has(Attrs::STRUCTURE) && e.touches(u.pos, u.radius) && tick >= u.status.storm_next {
                            u.status.storm_next = tick + STORM_TICK_LOOPS;
                            self.scratch_damage.push((j, STORM_TICK_DAMAGE, UnitId::new(owner as u16)));
                        }
                    }
                }
                EffectKind::ForceField | EffectKind::Kd8Charge => {}
            }
        }
        let mut hurt = std::mem::take(&mut self.scratch_damage);
        for &(j, amount, from) in &hurt {
            self.spell_damage(j, amount, from);
        }
        hurt.clear();
        self.scratch_damage = hurt;
    }

    fn detonate_kd8(&mut self, e: &AreaEffect) {
        let mut hit = Vec::new();
        self.grid.for_each_near(e.pos, e.radius + 1.25, |j| hit.push(j));
        hit.sort_unstable();
        for j in hit {
            let u = &self.units[j];
            if !u.alive || u.flying() || u.pos.dist(e.pos) - u.radius > e.radius {
                continue;
            }
            let attrs = u.spec().attrs;
            if !attrs.has(Attrs::MASSIVE) && !attrs.has(Attrs::STRUCTURE) && u.speed > 0.0 {
                // Away from the blast; a unit at its very centre flies away from the Reaper.
                let d = u.pos - e.pos;
                let d = if d.len_sq() > 1e-6 { d } else { u.pos - self.units[e.owner.index()].pos };
                let away = if d.len_sq() > 1e-6 { d.normalized() } else { Vec2::from_angle(j as f32) };
                let (from, r, cw) = (u.pos, u.radius, u.spec().cliff_walk);
                let to = self.constrain(from, from + away * KD8_KNOCKBACK, r, false, cw);
                let u = &mut self.units[j];
                u.pos = to;
                u.vel = Vec2::ZERO;
                u.waypoint = None;
                self.dirty[j] = true;
            }
            self.spell_damage(j, KD8_DAMAGE, e.owner);
        }
        self.refresh();
    }

    /// Damage from a spell: shields first, no armour, Barrier absorbs it.
    pub(crate) fn spell_damage(&mut self, j: usize, amount: f32, from: UnitId) {
        if amount <= 0.0 || !self.units[j].alive {
            return;
        }
        let src_team = self.units[from.index()].team;
        let dealt = self.hurt(j, amount, 1, 0.0);
        let u = &mut self.units[j];
        if u.team != src_team {
            u.last_attacker = Some(from);
            self.stats[src_team.index()].damage_dealt += dealt.total();
        }
    }

    /// Applies damage to unit `j`: raises an Immortal's Barrier on the first hit, lets the
    /// Barrier absorb, interrupts a Ghost's channel, then shields and hull.
    pub(crate) fn hurt(&mut self, j: usize, per_hit: f32, hits: u8, armor: f32) -> crate::damage::Dealt {
        let tick = self.tick;
        if self.units[j].kind == UnitKind::Immortal && self.rules.abilities && self.units[j].status.ready_at(Ability::Barrier) <= tick {
            self.raise_barrier(j);
            let team = self.units[j].team;
            self.count_ability(team, Ability::Barrier);
        }
        if matches!(self.units[j].status.channel, Some(Channel::Snipe { .. })) {
            self.cancel_channel(j);
        }
        let u = &mut self.units[j];
        u.last_damaged = tick;
        let barrier = if u.status.barrier_up(tick) { Some(&mut u.status.barrier_hp) } else { None };
        let dealt = crate::damage::apply_hits_absorbed(per_hit, hits, armor, barrier, &mut u.shield, &mut u.hp);
        self.deaths_pending |= u.hp <= 0.0;
        dealt
    }

    /// Keeps ground units out of force fields; a Massive ground unit touching one breaks it.
    pub(crate) fn enforce_force_fields(&mut self) {
        let tick = self.tick;
        if !self.effects.iter().any(|e| e.kind == EffectKind::ForceField && e.active(tick)) {
            return;
        }
        let mut near = Vec::new();
        for k in 0..self.effects.len() {
            let e = self.effects[k];
            if e.kind != EffectKind::ForceField || !e.active(tick) {
                continue;
            }
            near.clear();
            self.grid.for_each_near(e.pos, e.radius + 1.25, |j| near.push(j));
            near.sort_unstable();
            for &j in &near {
                let u = &self.units[j];
                // Air units pass over; structures and immobile units are not pushed.
                if !u.alive || u.body == Body::Air || u.base_speed <= 0.0 || !e.touches(u.pos, u.radius) {
                    continue;
                }
                if matches!(u.body, Body::Massive | Body::Tall) {
                    self.effects[k].until = tick;
                    break;
                }
                let d = u.pos - e.pos;
                let dir = if d.len_sq() > 1e-8 { d.normalized() } else { Vec2::from_angle(j as f32 * 2.39996) };
                let (from, r) = (u.pos, u.radius);
                let to = self.constrain(from, e.pos + dir * (e.radius + r + 0.01), r, false, false);
                let u = &mut self.units[j];
                u.pos = to;
                self.dirty[j] = true;
            }
        }
        self.effects.retain(|e| e.active(tick));
    }

    /// Active force fields, for movement's obstacle avoidance.
    pub(crate) fn force_fields(&self) -> impl Iterator<Item = &AreaEffect> {
        let tick = self.tick;
        self.effects.iter().filter(move |e| e.kind == EffectKind::ForceField && e.active(tick))
    }

    /// Area effects on the ground now.
    pub fn area_effects(&self) -> &[AreaEffect] {
        &self.effects
    }
}
