//! Optimal Reciprocal Collision Avoidance (van den Berg et al., 2011) for ground units.
//!
//! Each moving unit picks the velocity closest to its preferred one that keeps it out of
//! every neighbour's velocity obstacle for `tau` loops. Moving neighbours share the effort
//! (responsibility 1/2); standing ones (attacking, holding, structures) take none of it.
//! The 2-D linear programs follow the paper's incremental algorithm.

use crate::geom::Vec2;

const EPS: f32 = 1e-5;

#[derive(Clone, Copy, Debug)]
struct Line {
    point: Vec2,
    dir: Vec2,
}

/// A neighbour as seen by the avoiding unit.
#[derive(Clone, Copy, Debug)]
pub struct Neighbour {
    pub pos: Vec2,
    pub vel: Vec2,
    pub radius: f32,
    /// Share of the avoidance this unit takes on: 0.5 against movers, 1 against standers.
    pub responsibility: f32,
}

/// The avoiding unit itself.
#[derive(Clone, Copy, Debug)]
pub struct Agent {
    pub pos: Vec2,
    pub vel: Vec2,
    pub radius: f32,
    pub max_speed: f32,
}

/// Reusable buffers so the hot loop does not allocate.
#[derive(Clone, Debug, Default)]
pub struct Orca {
    lines: Vec<Line>,
    proj: Vec<Line>,
}

impl Orca {
    /// The new velocity (map units per loop) for a unit at `pos` with current velocity `vel`.
    pub fn solve(&mut self, me: &Agent, pref: Vec2, tau: f32, neighbours: &[Neighbour]) -> Vec2 {
        let Agent { pos, vel, radius, max_speed } = *me;
        self.lines.clear();
        let inv_tau = 1.0 / tau;
        for n in neighbours {
            let rel_pos = n.pos - pos;
            let rel_vel = vel - n.vel;
            let dist_sq = rel_pos.len_sq();
            let r = radius + n.radius;
            let r_sq = r * r;
            let (dir, u);
            if dist_sq > r_sq {
                let w = rel_vel - rel_pos * inv_tau;
                let w_len_sq = w.len_sq();
                let dot1 = w.dot(rel_pos);
                if dot1 < 0.0 && dot1 * dot1 > r_sq * w_len_sq {
                    let w_len = w_len_sq.sqrt();
                    let unit_w = w * (1.0 / w_len);
                    dir = Vec2::new(unit_w.y, -unit_w.x);
                    u = unit_w * (r * inv_tau - w_len);
                } else {
                    let leg = (dist_sq - r_sq).sqrt();
                    dir = if rel_pos.det(w) > 0.0 {
                        Vec2::new(rel_pos.x * leg - rel_pos.y * r, rel_pos.x * r + rel_pos.y * leg) * (1.0 / dist_sq)
                    } else {
                        -Vec2::new(rel_pos.x * leg + rel_pos.y * r, -rel_pos.x * r + rel_pos.y * leg) * (1.0 / dist_sq)
                    };
                    u = dir * rel_vel.dot(dir) - rel_vel;
                }
            } else {
                // Already overlapping: resolve within one loop.
                let w = rel_vel - rel_pos;
                let w_len = w.len();
                if w_len < EPS {
                    continue;
                }
                let unit_w = w * (1.0 / w_len);
                dir = Vec2::new(unit_w.y, -unit_w.x);
                u = unit_w * (r - w_len);
            }
            self.lines.push(Line { point: vel + u * n.responsibility, dir });
        }
        let mut result = Vec2::ZERO;
        let fail = lp2(&self.lines, max_speed, pref, false, &mut result);
        if fail < self.lines.len() {
            lp3(&self.lines, &mut self.proj, fail, max_speed, &mut result);
        }
        if result.is_finite() { result } else { Vec2::ZERO }
    }
}

fn lp1(lines: &[Line], no: usize, radius: f32, opt: Vec2, dir_opt: bool, result: &mut Vec2) -> bool {
    let l = lines[no];
    let dot = l.point.dot(l.dir);
    let disc = dot * dot + radius * radius - l.point.len_sq();
    if disc < 0.0 {
        return false;
    }
    let sq = disc.sqrt();
    let mut t_left = -dot - sq;
    let mut t_right = -dot + sq;
    for other in &lines[..no] {
        let denom = l.dir.det(other.dir);
        let numer = other.dir.det(l.point - other.point);
        if denom.abs() <= EPS {
            if numer < 0.0 {
                return false;
            }
            continue;
        }
        let t = numer / denom;
        if denom >= 0.0 {
            t_right = t_right.min(t);
        } else {
            t_left = t_left.max(t);
        }
        if t_left > t_right {
            return false;
        }
    }
    *result = if dir_opt {
        if opt.dot(l.dir) > 0.0 { l.point + l.dir * t_right } else { l.point + l.dir * t_left }
    } else {
        let t = l.dir.dot(opt - l.point);
        l.point + l.dir * t.clamp(t_left, t_right)
    };
    true
}

fn lp2(lines: &[Line], radius: f32, opt: Vec2, dir_opt: bool, result: &mut Vec2) -> usize {
    *result = if dir_opt {
        opt * radius
    } else if opt.len_sq() > radius * radius {
        opt.normalized() * radius
    } else {
        opt
    };
    for i in 0..lines.len() {
        if lines[i].dir.det(lines[i].point - *result) > 0.0 {
            let keep = *result;
            if !lp1(lines, i, radius, opt, dir_opt, result) {
                *result = keep;
                return i;
            }
        }
    }
    lines.len()
}

fn lp3(lines: &[Line], proj: &mut Vec<Line>, begin: usize, radius: f32, result: &mut Vec2) {
    let mut distance = 0.0;
    for i in begin..lines.len() {
        if lines[i].dir.det(lines[i].point - *result) <= distance {
            continue;
        }
        proj.clear();
        for j in 0..i {
            let det = lines[i].dir.det(lines[j].dir);
            let point = if det.abs() <= EPS {
                if lines[i].dir.dot(lines[j].dir) > 0.0 {
                    continue;
                }
                (lines[i].point + lines[j].point) * 0.5
            } else {
                lines[i].point + lines[i].dir * (lines[j].dir.det(lines[i].point - lines[j].point) / det)
            };
            proj.push(Line { point, dir: (lines[j].dir - lines[i].dir).normalized() });
        }
        let keep = *result;
        if lp2(proj, radius, Vec2::new(-lines[i].dir.y, lines[i].dir.x), true, result) < proj.len() {
            *result = keep;
        }
        distance = lines[i].dir.det(lines[i].point - *result);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_space_keeps_preferred_velocity() {
        let mut o = Orca::default();
        let v = o.solve(&Agent { pos: Vec2::ZERO, vel: Vec2::ZERO, radius: 0.5, max_speed: 0.2 }, Vec2::new(0.1, 0.0), 10.0, &[]);
        assert!((v - Vec2::new(0.1, 0.0)).len() < 1e-6);
    }

    #[test]
    fn head_on_units_swerve() {
        let mut o = Orca::default();
        let n = Neighbour { pos: Vec2::new(2.0, 0.0), vel: Vec2::new(-0.1, 0.0), radius: 0.5, responsibility: 0.5 };
        let v =
            o.solve(&Agent { pos: Vec2::ZERO, vel: Vec2::new(0.1, 0.0), radius: 0.5, max_speed: 0.15 }, Vec2::new(0.1, 0.0), 10.0, &[n]);
        assert!(v.y.abs() > 1e-3, "expected a sideways component, got {v:?}");
        assert!(v.len() <= 0.15 + 1e-5);
    }

    #[test]
    fn does_not_walk_into_a_standing_unit() {
        let mut o = Orca::default();
        let n = Neighbour { pos: Vec2::new(1.05, 0.0), vel: Vec2::ZERO, radius: 0.5, responsibility: 1.0 };
        let v = o.solve(&Agent { pos: Vec2::ZERO, vel: Vec2::ZERO, radius: 0.5, max_speed: 0.14 }, Vec2::new(0.14, 0.0), 10.0, &[n]);
        assert!(v.x < 0.05 + 1e-4, "closing speed too high: {v:?}");
    }
}
