//! Procedural scenarios in SMACv2's manner: a scenario file's `[generate]` table draws both
//! teams and their start positions for every episode from the episode's seed. SMACv2 draws
//! from unseeded generators; here the draw is a function of the seed alone, so an episode
//! replays in-process, deployed and in Python from its seed.
//!
//! What is drawn, as SMACv2 does (`distributions.py`, `weighted_teams` and
//! `surrounded_and_reflect`):
//! - team 1: `n_units` types drawn one by one from `weights`, redrawn while every unit is an
//!   `exception_unit_types` type (a team of Medivacs alone cannot fight);
//! - team 2: a copy of team 1's first `n_enemies` units, plus an extra block drawn the same
//!   way when `n_enemies > n_units`;
//! - positions: with probability `p` *reflect* (team 1 uniform over the left half but a
//!   one-cell buffer, team 2 its mirror image in the vertical centre line, extra enemies
//!   uniform over the right half), otherwise *surrounded* (team 1 at the centre, team 2 in
//!   one to four groups on distinct diagonals between the centre and the corners).
//!
//! SMACv2 spawns every unit of a group on one point and lets the game push them apart; here
//! each unit takes the nearest free spot to its drawn point (a deterministic spiral), so
//! episodes start without overlapping bodies.

use super::file::RawGenerate;
use super::place::place;
use super::types::ScenarioUnit;
use crate::geom::Vec2;
use crate::ids::Team;
use crate::terrain::{Rect, Terrain};
use crate::units::{DataSet, UnitKind};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Keeps the scenario draw's stream apart from the world's and the policies', which are
/// seeded from the same episode seed.
const DRAW_SALT: u64 = 0x5eed_5ca1_ab1e_0002;

/// How the start positions are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StartDist {
    /// Team 2 mirrors team 1 across the vertical centre line.
    Reflect,
    /// Team 1 at the centre, team 2 in groups towards the corners.
    Surrounded,
    /// Reflect with probability `p`, surrounded otherwise (SMACv2's `surrounded_and_reflect`).
    SurroundedAndReflect { p: f64 },
}

/// A validated `[generate]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct Generator {
    /// Team sizes: team 1 (`n_units`) and team 2 (`n_enemies`), the same every episode.
    pub n: [usize; 2],
    /// Unit types in the order of the observation's type bits, with their weights (sum 1).
    pub types: Vec<(UnitKind, f64)>,
    /// Types a team may not consist of alone.
    pub exceptions: Vec<UnitKind>,
    pub start: StartDist,
}

/// Why a `[generate]` table was refused: the field and the reason (the caller adds the file).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct GenerateProblem {
    pub field: String,
    pub value: String,
    pub reason: String,
}

fn problem(field: &str, value: impl std::fmt::Display, reason: impl Into<String>) -> GenerateProblem {
    GenerateProblem { field: format!("generate.{field}"), value: value.to_string(), reason: reason.into() }
}

/// Fraction of a start area that units' bodies may cover: beyond it the spiral placement
/// would push units far from their drawn points (random circle packing jams near 0.55).
const PACKING: f32 = 0.5;

impl Generator {
    /// Checks a raw table against the map it will place units on.
    pub(super) fn from_raw(raw: &RawGenerate, playable: Rect, data: DataSet) -> Result<Generator, GenerateProblem> {
        let n = [raw.n_units, raw.n_enemies];
        for (name, v) in [("n_units", n[0]), ("n_enemies", n[1])] {
            if !(1..=super::validate::MAX_UNITS / 2).contains(&v) {
                return Err(problem(name, v, format!("must be between 1 and {}", super::validate::MAX_UNITS / 2)));
            }
        }
        if raw.unit_types.is_empty() {
            return Err(problem("unit_types", "[]", "needs at least one unit type"));
        }
        if raw.weights.len() != raw.unit_types.len() {
            return Err(problem(
                "weights",
                format!("{} weights", raw.weights.len()),
                format!("needs one weight per unit type ({})", raw.unit_types.len()),
            ));
        }
        let mut types = Vec::with_capacity(raw.unit_types.len());
        for (i, (name, &w)) in raw.unit_types.iter().zip(&raw.weights).enumerate() {
            let kind: UnitKind = name
                .parse()
                .map_err(|e: crate::units::UnknownUnitKind| problem(&format!("unit_types[{i}]"), format!("{name:?}"), e.to_string()))?;
            if types.iter().any(|(k, _)| *k == kind) {
                return Err(problem(&format!("unit_types[{i}]"), format!("{name:?}"), "listed twice"));
            }
            if !data.has(kind) {
                return Err(problem(&format!("unit_types[{i}]"), format!("{name:?}"), format!("not in the {data} data set")));
            }
            if !(w.is_finite() && (0.0..=1.0).contains(&w)) {
                return Err(problem(&format!("weights[{i}]"), w, "must be a probability in [0, 1]"));
            }
            types.push((kind, w));
        }
        let sum: f64 = raw.weights.iter().sum();
        if (sum - 1.0).abs() > 1e-6 {
            return Err(problem("weights", format!("{:?} (sum {sum})", raw.weights), "must sum to 1"));
        }
        let mut exceptions = Vec::new();
        for (i, name) in raw.exception_unit_types.iter().enumerate() {
            let kind: UnitKind = name.parse().map_err(|e: crate::units::UnknownUnitKind| {
                problem(&format!("exception_unit_types[{i}]"), format!("{name:?}"), e.to_string())
            })?;
            if !types.iter().any(|(k, _)| *k == kind) {
                return Err(problem(&format!("exception_unit_types[{i}]"), format!("{name:?}"), "not one of unit_types"));
            }
            exceptions.push(kind);
        }
        if types.iter().all(|(k, w)| *w == 0.0 || exceptions.contains(k)) {
            return Err(problem(
                "exception_unit_types",
                format!("{:?}", raw.exception_unit_types),
                "leaves no type a team could be drawn from",
            ));
        }
        let start = match raw.start_positions.as_str() {
            "reflect" | "reflect_position" => StartDist::Reflect,
            "surrounded" => StartDist::Surrounded,
            "surrounded_and_reflect" => {
                let p = raw.p.unwrap_or(0.5);
                if !(p.is_finite() && (0.0..=1.0).contains(&p)) {
                    return Err(problem("p", p, "must be a probability in [0, 1]"));
                }
                StartDist::SurroundedAndReflect { p }
            }
            other => {
                return Err(problem(
                    "start_positions",
                    format!("{other:?}"),
                    "must be \"surrounded_and_reflect\", \"reflect\" or \"surrounded\"",
                ));
            }
        };
        if raw.p.is_some() && !matches!(start, StartDist::SurroundedAndReflect { .. }) {
            return Err(problem("p", raw.p.unwrap_or_default(), "only surrounded_and_reflect takes a probability"));
        }
        let g = Generator { n, types, exceptions, start };
        // Room: each team's largest possible bodies must fit their start area (the left half
        // but a buffer for team 1 when reflected; team 2's is as large).
        let r = g.types.iter().filter(|(_, w)| *w > 0.0).map(|(k, _)| data.spec(*k).radius).fold(0.0, f32::max);
        let area = (playable.width() / 2.0 - 1.0).max(0.0) * playable.height();
        for (i, name) in ["n_units", "n_enemies"].into_iter().enumerate() {
            let need = g.n[i] as f32 * std::f32::consts::PI * r * r / PACKING;
            if need > area {
                return Err(problem(
                    name,
                    g.n[i],
                    format!("more units than the map's start area holds ({need:.0} of {area:.0} square cells at the largest radius {r})"),
                ));
            }
        }
        Ok(g)
    }

    /// The type-bit order of the observation: the listed types.
    pub fn kinds(&self) -> impl Iterator<Item = UnitKind> + '_ {
        self.types.iter().map(|(k, _)| *k)
    }

    /// Both teams for the episode of `seed`: team 1 first, each team sorted as SMAC orders
    /// agents (type name, x, y), so a team's `i`-th unit is its `i`-th agent in every episode.
    pub(super) fn draw(&self, seed: u64, terrain: &Terrain, data: DataSet) -> Vec<ScenarioUnit> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ DRAW_SALT);
        let allies = self.team(&mut rng, self.n[0]);
        let mut enemies: Vec<UnitKind> = allies.iter().copied().take(self.n[1]).collect();
        if self.n[1] > self.n[0] {
            enemies.extend(self.team(&mut rng, self.n[1] - self.n[0]));
        }
        let p = terrain.playable();
        let reflect = match self.start {
            StartDist::Reflect => true,
            StartDist::Surrounded => false,
            // SMACv2 takes surrounded when u > p.
            StartDist::SurroundedAndReflect { p } => rng.random::<f64>() <= p,
        };
        let (a, e) = if reflect { self.reflect(&mut rng, p) } else { self.surrounded(&mut rng, p) };
        let mut placed: Vec<(Vec2, f32, bool)> = Vec::new();
        let mut out = Vec::with_capacity(self.n[0] + self.n[1]);
        let (ca, ce) = (centroid(&a), centroid(&e));
        for (team, kinds, points, facing) in [(Team::One, &allies, &a, ce - ca), (Team::Two, &enemies, &e, ca - ce)] {
            let mut team_units: Vec<ScenarioUnit> = kinds
                .iter()
                .zip(points)
                .map(|(&kind, &want)| {
                    let s = data.spec(kind);
                    let pos = place(terrain, &placed, s, want);
                    placed.push((pos, s.radius, s.flying));
                    ScenarioUnit { kind, team, pos, facing: facing.y.atan2(facing.x), energy: s.energy_start }
                })
                .collect();
            team_units.sort_by(|a, b| {
                a.kind.base().name().cmp(b.kind.base().name()).then(a.pos.x.total_cmp(&b.pos.x)).then(a.pos.y.total_cmp(&b.pos.y))
            });
            out.extend(team_units);
        }
        out
    }

    /// One team of `n` types drawn by weight, redrawn while it is made of exceptions alone.
    fn team(&self, rng: &mut ChaCha8Rng, n: usize) -> Vec<UnitKind> {
        loop {
            let team: Vec<UnitKind> = (0..n).map(|_| self.one(rng)).collect();
            if !team.iter().all(|k| self.exceptions.contains(k)) {
                return team;
            }
        }
    }

    fn one(&self, rng: &mut ChaCha8Rng) -> UnitKind {
        let u: f64 = rng.random();
        let mut acc = 0.0;
        for &(k, w) in &self.types {
            acc += w;
            if u < acc {
                return k;
            }
        }
        // Rounding left the last sliver of [0, 1): the last type with weight.
        self.types.iter().rev().find(|(_, w)| *w > 0.0).map_or(self.types[0].0, |(k, _)| *k)
    }

    fn reflect(&self, rng: &mut ChaCha8Rng, p: Rect) -> (Vec<Vec2>, Vec<Vec2>) {
        let half = p.width() / 2.0;
        let a: Vec<Vec2> = (0..self.n[0])
            .map(|_| Vec2::new(p.left + rng.random::<f32>() * (half - 1.0), p.bottom + rng.random::<f32>() * p.height()))
            .collect();
        let mut e: Vec<Vec2> = a.iter().take(self.n[1]).map(|v| Vec2::new(p.left + p.right - v.x, v.y)).collect();
        for _ in self.n[0]..self.n[1] {
            e.push(Vec2::new(p.left + half + rng.random::<f32>() * half, p.bottom + rng.random::<f32>() * p.height()));
        }
        (a, e)
    }

    fn surrounded(&self, rng: &mut ChaCha8Rng, p: Rect) -> (Vec<Vec2>, Vec<Vec2>) {
        let c = p.center();
        let a = vec![c; self.n[0]];
        let groups = rng.random_range(1..=4usize);
        // Group sizes: each enemy joins a group uniformly (a multinomial draw).
        let mut sizes = vec![0usize; groups];
        for _ in 0..self.n[1] {
            sizes[rng.random_range(0..groups)] += 1;
        }
        let t: Vec<f32> = (0..groups).map(|_| rng.random::<f32>()).collect();
        let mut diagonals = [0usize, 1, 2, 3];
        for i in 0..groups {
            let j = rng.random_range(i..4);
            diagonals.swap(i, j);
        }
        let corners = [Vec2::new(p.left, p.bottom), Vec2::new(p.left, p.top), Vec2::new(p.right, p.top), Vec2::new(p.right, p.bottom)];
        let signs = [(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)];
        let mut e = Vec::with_capacity(self.n[1]);
        for g in 0..groups {
            let d = diagonals[g];
            let inner = c + Vec2::new(signs[d].0, signs[d].1) * 2.0;
            let at = inner * t[g] + corners[d] * (1.0 - t[g]);
            e.extend(std::iter::repeat_n(at, sizes[g]));
        }
        (a, e)
    }
}

fn centroid(v: &[Vec2]) -> Vec2 {
    let s = v.iter().fold(Vec2::ZERO, |s, &p| s + p);
    s * (1.0 / v.len().max(1) as f32)
}
