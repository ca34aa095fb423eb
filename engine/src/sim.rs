//! One game loop: every unit decides (targets, orders), attacks resolve simultaneously,
//! units move, overlaps are resolved, then regeneration and cooldowns tick.

use crate::combat::{LEASH, PendingHit, edge_dist, in_heal_range, weapon_for};
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::units::Attrs;
use crate::world::{Activity, Intent, Missile, Order, Swing, Unit, WeaponPeriod, World};
use rand::Rng;

/// Distance within which a move order counts as arrived.
const ARRIVE: f32 = 0.05;
/// Edge distance to its target within which a melee unit looks for a free place beside it
/// (`Rules::melee_surround`).
const SURROUND_FROM: f32 = 3.0;
/// Loops of being blocked near its goal after which a move order ends.
const BLOCKED_GIVE_UP: u16 = 16;

impl World {
    /// Advances the world by one game loop.
    pub fn step_loop(&mut self) {
        self.shots.clear();
        self.tick_abilities();
        let mut intents = std::mem::take(&mut self.scratch.intents);
        intents.clear();
        for u in self.units.iter_mut().filter(|u| u.alive) {
            u.was_healing = u.activity == Activity::Healing;
            u.activity = Activity::Idle;
        }
        for i in 0..self.units.len() {
            let it = if self.units[i].alive { self.decide(i) } else { Intent::default() };
            intents.push(it);
        }
        self.attack(&intents);
        self.move_units(&intents);
        self.separate();
        self.enforce_force_fields();
        self.regen();
        self.scratch.intents = intents;
        self.tick += 1;
        self.refresh();
    }

    fn decide(&mut self, i: usize) -> Intent {
        let u = &self.units[i];
        if u.status.busy(self.tick) {
            // Morphing, lifted or channelling: nothing else this loop.
            return Intent::default();
        }
        if let Some(sw) = u.swing
            && let Some(it) = self.swing_on(i, sw)
        {
            return it;
        }
        let u = &self.units[i];
        if u.spec().heal.is_some() {
            return self.decide_healer(i);
        }
        if !self.powered(u) {
            // An unpowered cannon does nothing at all.
            self.units[i].target = None;
            return Intent::default();
        }
        if u.spec().weapons.is_empty() {
            return match u.order {
                Order::Move { to } | Order::AttackMove { to } => self.go(i, to),
                _ => Intent::default(),
            };
        }
        let auto = self.rules.auto_acquire[u.team.index()];
        match u.order {
            Order::Attack { target } => {
                if self.valid_enemy(u, target) {
                    return self.engage(i, target, true);
                }
                self.set_order(u.id, Order::Idle);
                self.decide(i)
            }
            Order::Hold => match self.keep_or_acquire(u, true) {
                Some(t) => self.engage(i, t, false),
                None => {
                    self.units[i].target = None;
                    Intent::default()
                }
            },
            Order::Idle => {
                let t = if auto { self.keep_or_acquire(u, false) } else { None };
                match t {
                    Some(t) => self.engage(i, t, true),
                    None => {
                        self.units[i].target = None;
                        Intent::default()
                    }
                }
            }
            Order::AttackMove { to } => match self.keep_or_acquire(u, false) {
                Some(t) => self.engage(i, t, true),
                None => {
                    self.units[i].target = None;
                    self.go(i, to)
                }
            },
            Order::Move { to } => self.go(i, to),
        }
    }

    /// An attack in progress: during the wind-up the unit stands facing its target until the
    /// damage point, unless the target dies, hides or gets beyond range plus `RangeSlop`
    /// (then the attack is cancelled and its cooldown given back); during the backswing it
    /// stands. `None` once the attack is over or cancelled: the unit decides as usual.
    fn swing_on(&mut self, i: usize, sw: Swing) -> Option<Intent> {
        let tick = self.tick;
        let u = &self.units[i];
        if sw.fired {
            if tick < sw.done_at {
                self.units[i].activity = Activity::Attacking;
                return Some(Intent::default());
            }
            self.units[i].swing = None;
            return None;
        }
        let w = &u.spec().weapons[sw.weapon as usize];
        let keep = self.valid_enemy(u, sw.target) && edge_dist(u, &self.units[sw.target.index()]) <= w.range + w.timing.range_slop;
        let tpos = self.units[sw.target.index()].pos;
        let u = &mut self.units[i];
        if !keep {
            u.cancel_swing();
            return None;
        }
        u.heading = (tpos - u.pos).normalized();
        u.aim_at(tpos, &w.timing);
        u.activity = Activity::Attacking;
        u.target = Some(sw.target);
        let release = (tick >= sw.fire_at).then_some((sw.target, sw.weapon as usize));
        Some(Intent { release, closing_on: Some(sw.target), ..Intent::default() })
    }

    /// Move towards `to`; the order completes on arrival.
    fn go(&mut self, i: usize, to: Vec2) -> Intent {
        let u = &mut self.units[i];
        let d = u.pos.dist(to);
        // Arrived, or pressed against others short of the point for a while (StarCraft II
        // gives up the same way instead of pushing forever).
        if d <= ARRIVE || (u.blocked_loops >= BLOCKED_GIVE_UP && d <= 2.0 + u.radius) {
            u.order = Order::Idle;
            u.blocked_loops = 0;
            return Intent::default();
        }
        Intent { goal: Some((to, 0.0)), ..Intent::default() }
    }

    fn engage(&mut self, i: usize, t: UnitId, chase: bool) -> Intent {
        let (u, tu) = (&self.units[i], &self.units[t.index()]);
        let Some((wi, w)) = weapon_for(u, tu) else { return Intent::default() };
        let d = edge_dist(u, tu);
        let (tpos, ready) = (tu.pos, u.cooldown <= 0.0);
        let stop = w.range + u.radius + tu.radius - 0.05;
        let u = &mut self.units[i];
        u.target = Some(t);
        // A turret tracks its target while the unit engages it, in range or closing in.
        let aimed = u.aim_at(tpos, &w.timing);
        if d <= w.range && d >= w.min_range {
            u.heading = (tpos - u.pos).normalized();
            u.activity = Activity::Attacking;
            return Intent { fire: (ready && aimed).then_some((t, wi)), closing_on: Some(t), ..Intent::default() };
        }
        if chase && u.speed > 0.0 && d > w.range {
            let surround =
                (self.rules.melee_surround && w.is_melee() && d <= SURROUND_FROM && !self.units[t.index()].flying()).then_some(w.range);
            return Intent { goal: Some((tpos, stop)), closing_on: Some(t), surround, ..Intent::default() };
        }
        Intent::default()
    }

    fn decide_healer(&mut self, i: usize) -> Intent {
        let u = &self.units[i];
        let heal = u.spec().heal.unwrap_or_else(|| unreachable!("healer without heal"));
        let healing = u.was_healing;
        let chase = !matches!(u.order, Order::Hold);
        let target = match u.order {
            Order::Move { to } => return self.go(i, to),
            Order::Attack { target } => {
                let ok = self.unit(target).is_some_and(|t| heal_ok(u, t));
                if !ok {
                    self.set_order(u.id, Order::Idle);
                    return Intent::default();
                }
                Some(target)
            }
            // Passive teams (SMAC's allies) autocast nothing while idle.
            Order::Idle if !self.rules.auto_acquire[u.team.index()] => None,
            _ => {
                let reach = heal.range + if chase { LEASH + 2.0 } else { 0.0 };
                self.heal_target(u, reach)
            }
        };
        let u = &self.units[i];
        if let Some(t) = target {
            let tu = &self.units[t.index()];
            let can = u.energy >= heal.min_energy_to_start || (healing && u.energy > 0.0);
            if in_heal_range(u, tu, heal.range) {
                self.units[i].target = Some(t);
                return Intent { heal: can.then_some(t), ..Intent::default() };
            }
            if chase {
                let stop = heal.range + u.radius + tu.radius - 0.1;
                return Intent { goal: Some((tu.pos, stop)), ..Intent::default() };
            }
        }
        let (order, team) = (u.order, u.team);
        self.units[i].target = None;
        if let Order::AttackMove { to } = order {
            // A healer on attack-move stays with its army instead of flying ahead of it.
            let (mut sum, mut n) = (Vec2::ZERO, 0);
            for o in self.units.iter().filter(|o| o.alive && o.team == team && o.spec().heal.is_none() && o.kind.can_fight()) {
                sum += o.pos;
                n += 1;
            }
            return if n > 0 { Intent { goal: Some((sum * (1.0 / n as f32), 2.0)), ..Intent::default() } } else { self.go(i, to) };
        }
        Intent::default()
    }

    /// The damaged biological ally with the most HP missing within `reach` (edge to edge).
    fn heal_target(&self, h: &Unit, reach: f32) -> Option<UnitId> {
        let mut best: Option<(f32, f32, UnitId)> = None;
        self.team_grid[h.team.index()].for_each_near(h.pos, reach + h.radius + 1.25, |j| {
            let t = &self.units[j];
            if !heal_ok(h, t) {
                return;
            }
            let d = edge_dist(h, t);
            if d > reach {
                return;
            }
            let missing = t.max_hp - t.hp;
            if best.is_none_or(|(bm, bd, _)| missing > bm || (missing == bm && d < bd)) {
                best = Some((missing, d, t.id));
            }
        });
        best.map(|b| b.2)
    }

    fn attack(&mut self, intents: &[Intent]) {
        let mut pending = Vec::new();
        self.fly_missiles(&mut pending);
        for (i, it) in intents.iter().enumerate() {
            if let Some((t, wi)) = it.fire {
                let w = &self.units[i].spec().weapons[wi];
                // RandomDelayMin/Max: drawn at every attack and added to the period.
                let jitter = if self.rules.cooldown_jitter { self.rng().random_range(w.timing.delay[0]..=w.timing.delay[1]) } else { 0.0 };
                let tick = self.tick;
                let u = &mut self.units[i];
                let before = u.cooldown;
                // The game acts on loop boundaries: the effect fires on the first loop by which
                // the damage point has passed (the Spine Crawler's 5.33 loops: on the 6th).
                let windup = w.timing.damage_point.ceil() as u32;
                // The engine's reading: the period runs from the start of the attack, the
                // wind-up and the backswing inside it. Counted from the shot, it starts when
                // the effect fires (a cancelled swing gives the whole cooldown back either way).
                let from_shot = match self.rules.weapon_period {
                    WeaponPeriod::Attack => 0.0,
                    WeaponPeriod::Shot => windup as f32,
                };
                u.cooldown = w.cooldown / u.status.attack_rate(tick) + from_shot + jitter + u.cooldown.clamp(-1.0, 0.0);
                u.activity = Activity::Attacking;
                if windup > 0 {
                    u.swing = Some(Swing {
                        target: t,
                        weapon: wi as u8,
                        fire_at: tick + windup,
                        done_at: 0,
                        fired: false,
                        cooldown_before: before,
                    });
                    continue;
                }
                self.release(i, t, wi, &mut pending);
            } else if let Some((t, wi)) = it.release {
                self.release(i, t, wi, &mut pending);
            }
        }
        for (i, it) in intents.iter().enumerate() {
            let Some(t) = it.heal else { continue };
            let heal = self.units[i].spec().heal.unwrap_or_else(|| unreachable!("heal intent without heal"));
            let energy = self.units[i].energy;
            let tu = &mut self.units[t.index()];
            let amount = heal.hp_per_loop.min(tu.max_hp - tu.hp).min(energy / heal.energy_per_hp).max(0.0);
            tu.hp += amount;
            let (tid, tpos) = (tu.id, tu.pos);
            let h = &mut self.units[i];
            h.energy -= amount * heal.energy_per_hp;
            h.activity = Activity::Healing;
            let (team, new_heal) = (h.team, !h.was_healing);
            if new_heal {
                self.count_ability(team, crate::ability::Ability::Heal);
            }
            self.stats[team.index()].healing_done += amount;
            let hid = self.units[i].id;
            self.record_shot(hid, tid, tpos);
        }
        self.resolve_hits(pending);
    }

    /// The effect of an attack at its damage point: the hit now, or a missile on its way.
    /// The unit then stands through its backswing.
    fn release(&mut self, i: usize, t: UnitId, wi: usize, pending: &mut Vec<PendingHit>) {
        let w = &self.units[i].spec().weapons[wi];
        let tpos = self.units[t.index()].pos;
        let tick = self.tick;
        let u = &mut self.units[i];
        u.activity = Activity::Attacking;
        let dir = (tpos - u.pos).normalized();
        let (id, team, pos) = (u.id, u.team, u.pos);
        let backswing = w.timing.backswing.ceil() as u32;
        u.swing = (backswing > 0 && !w.suicide).then_some(Swing {
            target: t,
            weapon: wi as u8,
            fire_at: tick,
            done_at: tick + backswing,
            fired: true,
            cooldown_before: 0.0,
        });
        if w.suicide {
            u.alive = false;
            u.hp = 0.0;
            u.activity = Activity::Dead;
            pending.push(PendingHit { attacker: id, target: None, weapon: w, impact: pos, dir });
        } else if w.timing.missile_speed > 0.0 {
            self.missiles.push(Missile { attacker: id, target: t, weapon: w, pos });
        } else {
            pending.push(PendingHit { attacker: id, target: Some(t), weapon: w, impact: tpos, dir });
        }
        self.stats[team.index()].attacks += 1;
        self.record_shot(id, t, tpos);
    }

    /// Moves every missile towards its target's current position at the weapon's missile
    /// speed; one that reaches it hits this loop, one whose target died is lost.
    fn fly_missiles(&mut self, pending: &mut Vec<PendingHit>) {
        if self.missiles.is_empty() {
            return;
        }
        let mut missiles = std::mem::take(&mut self.missiles);
        missiles.retain_mut(|m| {
            let t = &self.units[m.target.index()];
            if !t.alive {
                return false;
            }
            let to = t.pos - m.pos;
            let d = to.len();
            let step = m.weapon.timing.missile_speed;
            if d - t.radius <= step {
                pending.push(PendingHit {
                    attacker: m.attacker,
                    target: Some(m.target),
                    weapon: m.weapon,
                    impact: t.pos,
                    dir: to.normalized(),
                });
                return false;
            }
            m.pos += to * (step / d);
            true
        });
        self.missiles = missiles;
    }

    fn regen(&mut self) {
        let tick = self.tick;
        for u in self.units.iter_mut().filter(|u| u.alive) {
            u.cooldown = (u.cooldown - 1.0).max(-1.0);
            let s = u.spec();
            let quiet = tick.saturating_sub(u.last_damaged) as f32;
            if u.shield < u.max_shield && s.regen.shield > 0.0 && quiet >= s.regen.shield_delay {
                u.shield = (u.shield + s.regen.shield).min(u.max_shield);
            }
            if s.regen.life > 0.0 && u.hp < u.max_hp && quiet >= s.regen.life_delay {
                u.hp = (u.hp + s.regen.life).min(u.max_hp);
            }
            if s.energy_max > 0.0 {
                u.energy = (u.energy + s.regen.energy).min(s.energy_max);
            }
        }
    }

    /// Euclidean distance from `u` to its engagement range of `t`, for scripted policies.
    pub fn range_gap(&self, u: UnitId, t: UnitId) -> Option<f32> {
        let (a, b) = (self.unit(u)?, self.unit(t)?);
        let (_, w) = weapon_for(a, b)?;
        Some(edge_dist(a, b) - w.range)
    }
}

fn heal_ok(h: &Unit, t: &Unit) -> bool {
    t.alive && t.team == h.team && t.id != h.id && t.spec().attrs.has(Attrs::BIOLOGICAL) && t.hp < t.max_hp
}
