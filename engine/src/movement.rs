//! Movement: preferred velocity from the path, ORCA among ground units, terrain and map
//! bounds, then a positional pass that pushes apart any ground units still overlapping.

use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::orca::{Agent, Neighbour};
use crate::world::{Activity, Body, Intent, Order, Snap, World};

/// ORCA's time horizon in loops.
const TAU: f32 = 6.0;
/// Neighbours each unit avoids at most.
const MAX_NEIGHBOURS: usize = 10;
/// Overlap small enough that resolving it in the next loop is as good as now.
const SLIVER: f32 = 0.02;
/// Relaxation passes of the overlap resolution per loop.
const SEPARATION_PASSES: usize = 2;
/// Places on the ring around a melee unit's target it considers.
const SLOTS: usize = 16;
/// Loops a computed waypoint is reused while the goal stays in place.
const WAYPOINT_TTL: u32 = 8;

impl World {
    /// Moves every unit with a goal. Velocities are chosen from one snapshot of where
    /// everyone is and how they move at the start of the loop (as RVO2 does), then applied,
    /// so the result does not depend on the order units are processed in.
    pub(crate) fn move_units(&mut self, intents: &[Intent]) {
        let mut neighbours = std::mem::take(&mut self.scratch.neighbours);
        let mut snaps = std::mem::take(&mut self.scratch.snaps);
        snaps.clear();
        snaps.extend(self.units.iter().zip(intents).map(|(u, it)| Snap {
            pos: u.pos,
            vel: u.vel,
            radius: u.radius,
            body: u.body,
            alive: u.alive,
            moving: it.goal.is_some() && u.speed > 0.0,
            weight: weight(u.speed, it.goal.is_some()),
            cliff_walk: u.spec().cliff_walk,
        }));
        let mut moves = std::mem::take(&mut self.scratch.moves);
        moves.clear();
        for i in 0..self.units.len() {
            let Some((goal, stop)) = intents[i].goal else {
                if self.units[i].alive {
                    self.units[i].vel = Vec2::ZERO;
                }
                continue;
            };
            let u = &self.units[i];
            if !u.alive || u.speed <= 0.0 {
                continue;
            }
            let (pos, speed, flying, cliff_walk) = (u.pos, u.speed, u.flying(), u.spec().cliff_walk);
            let remaining = pos.dist(goal) - stop;
            if remaining <= 0.0 {
                self.units[i].vel = Vec2::ZERO;
                continue;
            }
            // A melee unit close to its target heads for a free place beside it, around
            // the others already there, instead of queueing behind them.
            let (goal, remaining) = match (intents[i].closing_on, intents[i].surround) {
                (Some(t), Some(range)) if !flying => match self.surround_goal(i, t, range) {
                    Some(g) => (g, pos.dist(g)),
                    None => (goal, remaining),
                },
                _ => (goal, remaining),
            };
            let waypoint = if flying { Some(goal) } else { self.waypoint_for(i, goal, cliff_walk) };
            let Some(wp) = waypoint else {
                // No path to the goal at all: the order cannot be carried out.
                let u = &mut self.units[i];
                u.vel = Vec2::ZERO;
                if matches!(u.order, Order::Move { .. } | Order::AttackMove { .. }) {
                    u.order = Order::Idle;
                }
                continue;
            };
            let pref = (wp - pos).normalized() * speed.min(remaining);
            let vel = if flying { pref } else { self.ground_velocity(i, pref, &snaps, intents, &mut neighbours) };
            moves.push((i, vel));
        }
        for &(i, vel) in &moves {
            let u = &self.units[i];
            let (pos, speed, radius, flying, cliff_walk) = (u.pos, u.speed, u.radius, u.flying(), u.spec().cliff_walk);
            let new = self.constrain(pos, pos + vel, radius, flying, cliff_walk);
            snaps[i].pos = new;
            let u = &mut self.units[i];
            u.vel = new - pos;
            u.pos = new;
            u.blocked_loops = if u.vel.len_sq() < 0.01 * speed * speed { u.blocked_loops.saturating_add(1) } else { 0 };
            if u.vel.len_sq() > 0.0 {
                self.dirty[i] = true;
            }
            if u.vel.len_sq() > 1e-8 {
                u.heading = u.vel.normalized();
                if u.activity == Activity::Idle {
                    u.activity = Activity::Moving;
                }
            }
        }
        self.scratch.neighbours = neighbours;
        self.scratch.snaps = snaps;
        self.scratch.moves = moves;
    }

    /// A ground unit's velocity this loop: ORCA against its closest neighbours (and force
    /// fields) from the loop's snapshot, veering out of a head-on deadlock.
    fn ground_velocity(&mut self, i: usize, pref: Vec2, snaps: &[Snap], intents: &[Intent], neighbours: &mut Vec<Neighbour>) -> Vec2 {
        let u = &self.units[i];
        let (pos, speed, radius) = (u.pos, u.speed, u.radius);
        neighbours.clear();
        let me = snaps[i];
        let query = radius + self.units[i].collision_reach(self) + speed * TAU;
        let closing = intents[i].closing_on.map_or(usize::MAX, |t| t.index());
        self.grid.for_each_near(pos, query, |j| {
            let o = &snaps[j];
            if j == i || j == closing || !o.alive || !me.collides_with(o) {
                return;
            }
            let r = radius + o.radius + speed * TAU;
            if o.pos.dist_sq(pos) > r * r {
                return;
            }
            let n = Neighbour { pos: o.pos, vel: o.vel, radius: o.radius, responsibility: if o.moving { 0.5 } else { 1.0 } };
            // Keep the MAX_NEIGHBOURS closest (RVO2's maxNeighbors), replacing the
            // farthest kept one; ties keep the earlier, so the set is deterministic.
            if neighbours.len() < MAX_NEIGHBOURS {
                neighbours.push(n);
            } else {
                let d = n.pos.dist_sq(pos);
                let (far, fd) = neighbours.iter().enumerate().fold((0, f32::MIN), |acc, (k, m)| {
                    let md = m.pos.dist_sq(pos);
                    if md > acc.1 { (k, md) } else { acc }
                });
                if d < fd {
                    neighbours[far] = n;
                }
            }
        });
        if me.body == Body::Ground {
            // Force fields are walls to ground units that are not massive.
            for f in self.force_fields() {
                if f.pos.dist(pos) <= f.radius + query {
                    neighbours.push(Neighbour { pos: f.pos, vel: Vec2::ZERO, radius: f.radius, responsibility: 1.0 });
                }
            }
        }
        let agent = Agent { pos, vel: me.vel, radius, max_speed: speed };
        let v = self.orca.solve(&agent, pref, TAU, neighbours);
        if v.len_sq() < 0.25 * pref.len_sq() && neighbours.len() <= 3 {
            // Blocked head-on by a few units (ORCA's symmetric deadlock): try veering
            // either way and keep whichever makes more progress; left wins ties, so it
            // is deterministic. In a crowd, waiting is what StarCraft II units do too.
            let (c, s) = (std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2);
            let left = Vec2::new(pref.x * c - pref.y * s, pref.x * s + pref.y * c);
            let right = Vec2::new(pref.x * c + pref.y * s, -pref.x * s + pref.y * c);
            let vl = self.orca.solve(&agent, left, TAU, neighbours);
            let vr = self.orca.solve(&agent, right, TAU, neighbours);
            let best = if vr.dot(pref) > vl.dot(pref) { vr } else { vl };
            if best.len_sq() > v.len_sq() && best.dot(pref) > 0.0 { best } else { v }
        } else {
            v
        }
    }

    /// Where melee unit `i` closing on `t` with a weapon of `range` heads: the free place on
    /// the ring of attack positions around `t` nearest its side, straight there when that is
    /// at most 45 degrees around, else a point further out a quarter turn round (it walks
    /// round the units already there). `None` (go straight at the target, or wait behind)
    /// when no place is free.
    fn surround_goal(&self, i: usize, t: UnitId, range: f32) -> Option<Vec2> {
        let dev = self.free_place(i, t, range)?;
        let (u, tu) = (&self.units[i], &self.units[t.index()]);
        let (c, ru) = (tu.pos, u.radius);
        let ring = tu.radius + ru + range * 0.5;
        let base = (u.pos - c).angle();
        if dev.abs() <= std::f32::consts::FRAC_PI_4 {
            return Some(c + Vec2::from_angle(base + dev) * ring);
        }
        let round = base + std::f32::consts::FRAC_PI_4 * dev.signum();
        Some(c + Vec2::from_angle(round) * (ring + 2.0 * ru))
    }

    /// The turn (radians, signed) from `i`'s side of `t` to the nearest free place on the ring
    /// where `i`'s melee weapon of `range` reaches `t`, or `None` if every place is taken (by
    /// any ground unit, or unwalkable). Positions as at the start of the loop: nobody has
    /// moved yet when units decide or choose their velocities.
    fn free_place(&self, i: usize, t: UnitId, range: f32) -> Option<f32> {
        let (u, tu) = (&self.units[i], self.units.get(t.index())?);
        let (c, ru) = (tu.pos, u.radius);
        let ring = tu.radius + ru + range * 0.5;
        let base = (u.pos - c).angle();
        let free = |p: Vec2| {
            let mut ok = self.terrain.walkable(p);
            self.grid.for_each_near(p, ru + 1.0, |j| {
                let o = &self.units[j];
                if ok && j != i && j != t.index() && o.alive && !o.flying() && o.pos.dist(p) < (ru + o.radius) * 0.9 {
                    ok = false;
                }
            });
            ok
        };
        let step = std::f32::consts::PI / (SLOTS / 2) as f32;
        (0..SLOTS)
            .map(|k| k.div_ceil(2) as f32 * step * if k % 2 == 1 { 1.0 } else { -1.0 })
            .find(|&d| free(c + Vec2::from_angle(base + d) * ring))
    }

    fn waypoint_for(&mut self, i: usize, goal: Vec2, cliff_walk: bool) -> Option<Vec2> {
        let u = &self.units[i];
        if let Some((g, wp, at)) = u.waypoint
            && g.dist_sq(goal) < 1.0
            && self.tick.saturating_sub(at) < WAYPOINT_TTL
            && wp.dist_sq(u.pos) > 0.04
        {
            return Some(wp);
        }
        let from = u.pos;
        let wp = self.paths.waypoint(&self.terrain, from, goal, cliff_walk);
        let tick = self.tick;
        self.units[i].waypoint = wp.map(|wp| (goal, wp, tick));
        wp
    }

    /// Where a unit moving from `from` towards `to` may end up: inside the playable area,
    /// and for ground units on ground it can step onto, sliding along walls.
    pub(crate) fn constrain(&self, from: Vec2, to: Vec2, radius: f32, flying: bool, cliff_walk: bool) -> Vec2 {
        let to = self.terrain.playable().clamp(to, radius);
        if flying {
            return to;
        }
        let t = &self.terrain;
        let ok = |p: Vec2| t.walkable(p) && t.segment_clear(from, p, cliff_walk);
        if ok(to) {
            return to;
        }
        let sx = Vec2::new(to.x, from.y);
        if ok(sx) {
            return sx;
        }
        let sy = Vec2::new(from.x, to.y);
        if ok(sy) {
            return sy;
        }
        from
    }

    /// Pushes overlapping ground units apart. Immobile units do not move; moving units give
    /// way to standing ones twice as readily as the reverse.
    pub(crate) fn separate(&mut self) {
        // The grid is from the start of this loop; nobody moved more than a third of a cell
        // since, which the query margin covers. Only a unit that moved this loop, or was left
        // overlapping by the last pass, can be part of an overlap: the rest are skipped.
        // `snaps` (from `move_units`) hold current positions and are kept in step with pushes.
        let n = self.units.len();
        let mut snaps = std::mem::take(&mut self.scratch.snaps);
        let mut dirty = std::mem::take(&mut self.dirty);
        let mut next = std::mem::take(&mut self.dirty_next);
        for _ in 0..SEPARATION_PASSES {
            next.clear();
            next.resize(n, false);
            let mut worst = 0.0f32;
            for i in 0..n {
                let a = snaps[i];
                if !dirty[i] || !a.alive || a.body == Body::Air {
                    continue;
                }
                let mut pushes: [(usize, Vec2); 16] = [(usize::MAX, Vec2::ZERO); 16];
                let mut np = 0;
                self.grid.for_each_near(a.pos, a.radius + self.units[i].collision_reach(self), |j| {
                    // A pair of dirty units is handled once, from its lower index.
                    if j == i || (dirty[j] && j < i) || np == pushes.len() {
                        return;
                    }
                    let b = &snaps[j];
                    if !b.alive || !a.collides_with(b) || a.weight + b.weight <= 0.0 {
                        return;
                    }
                    let min = a.radius + b.radius;
                    let d2 = b.pos.dist_sq(a.pos);
                    if d2 >= min * min {
                        return;
                    }
                    let d = d2.sqrt();
                    let n = if d > 1e-4 {
                        (b.pos - a.pos) * (1.0 / d)
                    } else {
                        // Coincident centres: a fixed direction from the id pair.
                        Vec2::from_angle((i * 7 + j * 13) as f32)
                    };
                    pushes[np] = (j, n * (min - d));
                    worst = worst.max(min - d);
                    np += 1;
                });
                for &(j, push) in &pushes[..np] {
                    next[i] = true;
                    next[j] = true;
                    let (sa, sb) = (snaps[i], snaps[j]);
                    let sum = sa.weight + sb.weight;
                    // Whatever one side cannot take (a wall, a cliff) the other takes.
                    let mut left = push;
                    if sa.weight > 0.0 {
                        let moved = self.constrain(sa.pos, sa.pos - push * (sa.weight / sum), sa.radius, false, sa.cliff_walk) - sa.pos;
                        snaps[i].pos = sa.pos + moved;
                        self.units[i].pos = snaps[i].pos;
                        left = push + moved;
                    }
                    if sb.weight > 0.0 {
                        snaps[j].pos = self.constrain(sb.pos, sb.pos + left, sb.radius, false, sb.cliff_walk);
                        self.units[j].pos = snaps[j].pos;
                    }
                }
            }
            std::mem::swap(&mut dirty, &mut next);
            // Another pass only when this one had to undo more than a sliver of overlap.
            if worst < SLIVER {
                break;
            }
        }
        // Units pushed in the last pass may still overlap: they are checked again next loop.
        self.dirty = dirty;
        self.dirty_next = next;
        self.scratch.snaps = snaps;
    }
}

/// Share of a push a unit takes: none if it cannot move, more if it is moving anyway.
fn weight(speed: f32, moving: bool) -> f32 {
    if speed <= 0.0 {
        0.0
    } else if moving {
        1.0
    } else {
        0.5
    }
}
