//! Where a created unit stands: the nearest free spot to where it was asked for, as
//! StarCraft II places units a trigger creates (SMAC's armies, SMACv2's drawn teams).

use crate::geom::Vec2;
use crate::terrain::{Rect, Terrain};
use crate::units::UnitSpec;
use std::f32::consts::TAU;

/// The nearest free spot to `want` for a unit of `kind`: `want` itself if free, else the first
/// free point on rings around it. Ground bodies may not overlap ground bodies, air bodies air
/// bodies; a point must be on the unit's ground (or in the playable area, flying).
pub(super) fn place(terrain: &Terrain, placed: &[(Vec2, f32, bool)], spec: &UnitSpec, want: Vec2) -> Vec2 {
    let (r, fly) = (spec.radius, spec.flying);
    let p = terrain.playable();
    let inside = Rect { left: p.left + r, bottom: p.bottom + r, right: p.right - r, top: p.top - r };
    let want = Vec2::new(want.x.clamp(inside.left, inside.right), want.y.clamp(inside.bottom, inside.top));
    let free = |q: Vec2| {
        inside.contains(q) && (fly || terrain.walkable(q)) && placed.iter().all(|&(o, orad, ofly)| ofly != fly || o.dist(q) >= r + orad)
    };
    if free(want) {
        return want;
    }
    let step = r.max(0.25);
    let rings = ((p.width().max(p.height())) / step) as usize + 1;
    for ring in 1..=rings {
        let d = ring as f32 * step;
        let around = ((TAU * d / step).ceil() as usize).max(6);
        for k in 0..around {
            let q = want + Vec2::from_angle(TAU * k as f32 / around as f32) * d;
            if free(q) {
                return q;
            }
        }
    }
    // Validation keeps the teams small enough that a spot exists; if none did, overlapping
    // bodies are pushed apart by the simulation's collisions.
    want
}
