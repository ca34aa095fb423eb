//! Targeting and attacks: acquisition as StarCraft II does it (threats before harmless
//! units, then distance; keep a target while it stays valid and in range), simultaneous
//! resolution of every attack made in a loop, and each splash shape.

use crate::ability::{GUARDIAN_REDUCTION, RANGED_MIN, SLOW_LOOPS};
use crate::damage::{Dealt, hit_damage};
use crate::geom::{Vec2, point_segment_dist};
use crate::ids::UnitId;
use crate::units::{Attrs, Splash, Weapon};
use crate::world::{Shot, Unit, World, sq};

/// How far past its acquisition range a unit keeps chasing an auto-acquired target.
pub(crate) const LEASH: f32 = 2.0;
/// A Colossus lance hits units within this distance of its line (game data 5.0.13).
const LANCE_WIDTH: f32 = 0.15;
/// Loops between target re-evaluations while chasing a valid target.
const RESCAN_EVERY: u32 = 4;

/// An attack made this loop, applied after every unit has decided.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PendingHit {
    pub attacker: UnitId,
    pub target: Option<UnitId>,
    pub weapon: &'static Weapon,
    pub impact: Vec2,
    pub dir: Vec2,
}

// One definition of reach for the simulation and for the checks of actions (`crate::rules`).
pub(crate) use crate::rules::{edge as edge_dist, in_weapon_range, weapon_for};

/// Acquisition range: the longest weapon or the unit's minimum scan range.
pub(crate) fn acquire_range(u: &Unit) -> f32 {
    let s = u.spec();
    s.weapons.iter().map(|w| w.range).fold(s.scan_range, f32::max)
}

impl World {
    /// Whether `t` is an enemy of `u` that `u` may attack now (alive, seen, reachable layer).
    pub(crate) fn valid_enemy(&self, u: &Unit, t: UnitId) -> bool {
        self.unit(t).is_some_and(|t| t.alive && t.team != u.team && self.visible_to(u.team, t.id) && weapon_for(u, t).is_some())
    }

    /// One pass over the enemies near `u` within `max_edge` (edge to edge): the best one its
    /// weapons reach now, and the best one overall. Best means units that can hit back
    /// first, then structures last, then the closest, ties by id.
    pub(crate) fn scan(&self, u: &Unit, max_edge: f32) -> (Option<UnitId>, Option<UnitId>) {
        type Best = Option<(u8, f32, UnitId)>;
        let better = |b: &Best, tier: u8, d: f32, id: UnitId| match *b {
            None => true,
            Some((bt, bd, bid)) => tier > bt || (tier == bt && (d < bd || (d == bd && id < bid))),
        };
        let (mut in_range, mut any): (Best, Best) = (None, None);
        let reach = max_edge + u.radius + 1.25;
        let vis = &self.vis[u.team.index()];
        let u_flying = u.flying();
        self.team_grid[u.team.other().index()].for_each_near(u.pos, reach, |j| {
            let t = &self.units[j];
            if !t.alive || !vis[j] {
                return;
            }
            let Some((_, w)) = weapon_for(u, t) else { return };
            let d = edge_dist(u, t);
            if d > max_edge || d < w.min_range {
                return;
            }
            let ts = t.spec();
            let threat = ts.weapons.iter().any(|tw| tw.reach.hits(u_flying));
            let tier = if threat {
                2
            } else if ts.attrs.has(Attrs::STRUCTURE) {
                0
            } else {
                1
            };
            if d <= w.range && better(&in_range, tier, d, t.id) {
                in_range = Some((tier, d, t.id));
            }
            if better(&any, tier, d, t.id) {
                any = Some((tier, d, t.id));
            }
        });
        (in_range.map(|b| b.2), any.map(|b| b.2))
    }

    /// Keeps the current target while it is valid and in range; otherwise prefers any enemy
    /// already in range, then keeps chasing the current one within the leash, then acquires.
    pub(crate) fn keep_or_acquire(&self, u: &Unit, in_range_only: bool) -> Option<UnitId> {
        let cur = u.target.filter(|&t| self.valid_enemy(u, t));
        if let Some(t) = cur
            && in_weapon_range(u, &self.units[t.index()])
        {
            return Some(t);
        }
        let range = acquire_range(u);
        let chasing = cur.filter(|t| edge_dist(u, &self.units[t.index()]) <= range + LEASH);
        // A unit closing on a valid target looks for a better one every few loops, not every
        // loop (staggered by id so the work spreads evenly and stays deterministic).
        if !in_range_only && chasing.is_some() && !(self.tick + u.id.index() as u32).is_multiple_of(RESCAN_EVERY) {
            return chasing;
        }
        let (in_range, any) = self.scan(u, range);
        if in_range.is_some() || in_range_only {
            return in_range;
        }
        // Answer whoever is shooting at it from beyond its acquisition range.
        let attacker = u.last_attacker.filter(|&a| self.valid_enemy(u, a));
        chasing.or(any).or(attacker)
    }

    /// Applies every attack made this loop, then splash, then deaths; Banelings killed this
    /// way detonate in turn (they do in StarCraft II). A unit that attacks with a suicide
    /// weapon is already marked dead by the caller. Also called with no hits to settle
    /// deaths from spells.
    pub(crate) fn resolve_hits(&mut self, mut pending: Vec<PendingHit>) -> Vec<PendingHit> {
        while !pending.is_empty() || self.deaths_pending {
            self.deaths_pending = false;
            for h in pending.drain(..) {
                self.apply_hit(&h);
            }
            for i in 0..self.units.len() {
                let u = &self.units[i];
                if u.alive && u.hp <= 0.0 {
                    let (team, pos, spec) = (u.team, u.pos, u.spec);
                    let u = &mut self.units[i];
                    u.alive = false;
                    u.hp = 0.0;
                    u.activity = crate::world::Activity::Dead;
                    u.vel = Vec2::ZERO;
                    self.stats[team.other().index()].kills += 1;
                    if let Some(w) = spec.weapons.first().filter(|w| w.suicide) {
                        pending.push(PendingHit { attacker: UnitId::new(i as u16), target: None, weapon: w, impact: pos, dir: Vec2::ZERO });
                    }
                }
            }
        }
        pending
    }

    fn apply_hit(&mut self, h: &PendingHit) {
        let (a_team, a_pos) = {
            let a = &self.units[h.attacker.index()];
            (a.team, a.pos)
        };
        let w = h.weapon;
        let mut primary_layer_flying = false;
        if let Some(t) = h.target {
            let tu = &mut self.units[t.index()];
            primary_layer_flying = tu.flying();
            if tu.alive && !w.suicide {
                tu.last_attacker = Some(h.attacker);
                let dealt = self.weapon_damage(t.index(), w, 1.0, true);
                self.stats[a_team.index()].damage_dealt += dealt.total();
                self.on_hit(h.attacker, t.index());
            }
        }
        if matches!(w.splash, Splash::None) {
            return;
        }
        let centre = if matches!(w.splash, Splash::Cone { .. }) { a_pos } else { h.impact };
        let mut victims: Vec<(usize, f32)> = Vec::new();
        self.grid.for_each_near(centre, 4.0, |j| {
            let v = &self.units[j];
            if !v.alive || Some(v.id) == h.target || v.id == h.attacker || v.flying() != primary_layer_flying {
                return;
            }
            let r = v.radius;
            let frac = match w.splash {
                Splash::None => 0.0,
                Splash::Radial { zones, friendly_fire } => {
                    if !friendly_fire && v.team == a_team {
                        return;
                    }
                    let d = v.pos.dist(h.impact) - r;
                    zones.iter().find(|(rad, _)| d <= *rad).map_or(0.0, |z| z.1)
                }
                Splash::Line { half_length, fraction } => {
                    if v.team == a_team {
                        return;
                    }
                    let across = h.dir.perp() * half_length;
                    if point_segment_dist(v.pos, h.impact - across, h.impact + across) <= r + LANCE_WIDTH { fraction } else { 0.0 }
                }
                Splash::Cone { length, half_angle, fraction } => {
                    if v.team == a_team {
                        return;
                    }
                    let to = v.pos - a_pos;
                    let d = to.len();
                    let ang = if d > 1e-4 { (to.dot(h.dir) / d).clamp(-1.0, 1.0).acos() } else { 0.0 };
                    if d - r <= length && ang <= half_angle { fraction } else { 0.0 }
                }
            };
            if frac > 0.0 {
                victims.push((j, frac));
            }
        });
        for (j, frac) in victims {
            if self.units[j].team != a_team {
                self.units[j].last_attacker = Some(h.attacker);
            }
            let dealt = self.weapon_damage(j, w, frac, false);
            let friendly = self.units[j].team == a_team;
            if !friendly {
                self.stats[a_team.index()].damage_dealt += dealt.total();
            }
        }
    }

    pub(crate) fn record_shot(&mut self, from: UnitId, to: UnitId, impact: Vec2) {
        self.shots.push(Shot { from, to, impact });
    }
}

impl World {
    /// A weapon's damage to unit `j`. Guardian Shield takes 2 off each ranged primary hit
    /// (not melee, not splash).
    fn weapon_damage(&mut self, j: usize, w: &Weapon, fraction: f32, primary: bool) -> Dealt {
        let t = &self.units[j];
        let mut per_hit = hit_damage(w, t.spec().attrs) * fraction;
        if primary && t.status.guarded && w.range >= RANGED_MIN {
            per_hit = (per_hit - GUARDIAN_REDUCTION).max(0.0);
        }
        let armor = t.spec().armor;
        self.hurt(j, per_hit, w.hits, armor)
    }

    /// On-hit effects of the attacker's weapon: Concussive Shells.
    fn on_hit(&mut self, attacker: UnitId, j: usize) {
        let a = &self.units[attacker.index()];
        if a.kind == crate::units::UnitKind::Marauder && self.has_upgrade(a.team, crate::scenario::Upgrade::ConcussiveShells) {
            let tick = self.tick;
            let t = &mut self.units[j];
            let attrs = t.spec().attrs;
            if !attrs.has(Attrs::MASSIVE) && !attrs.has(Attrs::STRUCTURE) {
                t.status.slow_until = tick + SLOW_LOOPS;
                t.status.hold(tick + SLOW_LOOPS);
            }
        }
    }
}

pub(crate) fn in_heal_range(h: &Unit, t: &Unit, range: f32) -> bool {
    h.pos.dist_sq(t.pos) <= sq(range + h.radius + t.radius)
}
