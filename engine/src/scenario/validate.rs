//! Raw scenario file to validated [`Scenario`], with errors naming file, field and value.

use super::file::{RawScenario, RawStart, RawTerrain};
use super::types::{Mode, OpponentKind, Scenario, ScenarioError, ScenarioUnit, StartOrder, Upgrade};
use crate::geom::Vec2;
use crate::ids::Team;
use crate::terrain::{Rect, Terrain};
use crate::time::{DEFAULT_TIME_LIMIT_S, seconds_to_loops};
use crate::units::{DataSet, UnitKind};
use std::sync::Arc;

/// Units per scenario at most (ids are 16-bit; the game caps armies far lower).
pub const MAX_UNITS: usize = 1024;

struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    fn err(&self, field: impl Into<String>, value: impl std::fmt::Display, reason: impl Into<String>) -> ScenarioError {
        ScenarioError::Invalid { file: self.file.to_owned(), field: field.into(), value: value.to_string(), reason: reason.into() }
    }
}

impl Scenario {
    /// Parses and validates TOML text; `file` names the source in errors.
    pub fn from_toml(file: &str, text: &str) -> Result<Scenario, ScenarioError> {
        let raw: RawScenario = toml::from_str(text)
            .map_err(|e| ScenarioError::Syntax { file: file.to_owned(), message: e.to_string().trim_end().to_owned() })?;
        validate(file, raw, text)
    }
}

pub(crate) fn default_time_limit() -> u32 {
    seconds_to_loops(DEFAULT_TIME_LIMIT_S)
}

pub(crate) fn rect(p: [f32; 4]) -> Rect {
    Rect { left: p[0], bottom: p[1], right: p[2], top: p[3] }
}

/// The file's checks in its order, each refusal naming its field.
pub(super) fn validate(file: &str, raw: RawScenario, text: &str) -> Result<Scenario, ScenarioError> {
    let cx = Ctx { file };
    if raw.name.is_empty() || !raw.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        return Err(cx.err("name", format!("{:?}", raw.name), "must be non-empty ASCII letters, digits, '_' or '-'"));
    }
    let mode = match raw.mode.as_str() {
        "pve" => Mode::Pve,
        "pvp" => Mode::Pvp,
        other => return Err(cx.err("mode", format!("{other:?}"), "must be \"pve\" or \"pvp\"")),
    };
    let data = match &raw.data {
        None => DataSet::Legacy,
        Some(d) => d.parse::<DataSet>().map_err(|e| cx.err("data", format!("{d:?}"), e.to_string()))?,
    };
    let [w, h] = raw.map_size;
    for (i, v) in [w, h].into_iter().enumerate() {
        if !(8..=512).contains(&v) {
            return Err(cx.err(format!("map_size[{i}]"), v, "must be between 8 and 512 cells"));
        }
    }
    let playable = playable_area(&cx, raw.playable, w, h)?;
    let time_limit_loops = match raw.time_limit_s {
        None => default_time_limit(),
        Some(t) if t.is_finite() && t > 0.0 && t <= 3600.0 => seconds_to_loops(t).max(1),
        Some(t) => return Err(cx.err("time_limit_s", t, "must be a number of game seconds in (0, 3600]")),
    };
    let terrain = match &raw.terrain {
        None => Terrain::flat(w, h, playable),
        Some(t) => terrain(&cx, t, w, h, playable)?,
    };
    let upgrades = upgrades(&cx, &raw)?;
    let mut units = units(&cx, &raw, data, &terrain, playable)?;
    let generator = match &raw.generate {
        None => None,
        Some(_) if !units.is_empty() => {
            return Err(cx.err("units", format!("{} units", units.len()), "a scenario with [generate] draws its units: leave units empty"));
        }
        Some(g) => Some(Arc::new(super::Generator::from_raw(g, playable, data).map_err(|p| ScenarioError::Invalid {
            file: file.to_owned(),
            field: p.field,
            value: p.value,
            reason: p.reason,
        })?)),
    };
    let terrain = Arc::new(terrain);
    if let Some(g) = &generator {
        units = g.draw(0, &terrain, data);
    }
    for team in Team::BOTH {
        if !units.iter().any(|u| u.team == team) {
            return Err(cx.err("units", format!("{} units", units.len()), format!("{team} has no units")));
        }
    }
    let opponent = match &raw.opponent.policy {
        None => OpponentKind::Builtin,
        Some(p) => p.parse().map_err(|e: String| cx.err("opponent.policy", format!("{p:?}"), e))?,
    };
    let start = start_order(&cx, raw.opponent.start.as_ref(), playable)?;
    let s = Scenario {
        name: raw.name,
        mode,
        description: raw.description,
        objective: if raw.objective.is_empty() { "Destroy every enemy unit before time runs out.".into() } else { raw.objective },
        source: raw.source,
        fog_of_war: raw.fog_of_war.unwrap_or(true),
        data,
        terrain,
        units,
        upgrades,
        opponent,
        start,
        time_limit_loops,
        text: Arc::from(text),
        generator,
    };
    Ok(match s.generator.clone() {
        Some(g) => s.drawn(&g, 0),
        None => s,
    })
}

/// `playable`: inside the map, at least 4 cells each way (the whole map when absent).
fn playable_area(cx: &Ctx, raw: Option<[f32; 4]>, w: u32, h: u32) -> Result<Rect, ScenarioError> {
    let Some(p) = raw else { return Ok(Rect { left: 0.0, bottom: 0.0, right: w as f32, top: h as f32 }) };
    let r = rect(p);
    let ok = p.iter().all(|v| v.is_finite())
        && r.left >= 0.0
        && r.bottom >= 0.0
        && r.right <= w as f32
        && r.top <= h as f32
        && r.right - r.left >= 4.0
        && r.top - r.bottom >= 4.0;
    if !ok {
        return Err(cx.err(
            "playable",
            format!("{p:?}"),
            format!("must be [left, bottom, right, top] inside the {w}x{h} map, at least 4 wide and high"),
        ));
    }
    Ok(r)
}

/// Each team's upgrades, once each, sorted.
fn upgrades(cx: &Ctx, raw: &RawScenario) -> Result<[Vec<Upgrade>; 2], ScenarioError> {
    let mut upgrades: [Vec<Upgrade>; 2] = Default::default();
    for (i, u) in raw.upgrades.iter().enumerate() {
        let team = Team::from_player(u.team).ok_or_else(|| cx.err(format!("upgrades[{i}].team"), u.team, "must be 1 or 2"))?;
        let up: Upgrade = u.name.parse().map_err(|e: String| cx.err(format!("upgrades[{i}].name"), format!("{:?}", u.name), e))?;
        if !upgrades[team.index()].contains(&up) {
            upgrades[team.index()].push(up);
        }
    }
    for list in &mut upgrades {
        list.sort();
    }
    Ok(upgrades)
}

/// The listed units, each on ground it can stand on; a `count` group is placed around its
/// point, clear of the units already standing.
fn units(cx: &Ctx, raw: &RawScenario, data: DataSet, terrain: &Terrain, playable: Rect) -> Result<Vec<ScenarioUnit>, ScenarioError> {
    if raw.units.len() > MAX_UNITS {
        return Err(cx.err("units", raw.units.len(), format!("at most {MAX_UNITS} units")));
    }
    let total: u64 = raw.units.iter().map(|u| u64::from(u.count.unwrap_or(1))).sum();
    if total > MAX_UNITS as u64 {
        return Err(cx.err("units", total, format!("at most {MAX_UNITS} units (counts included)")));
    }
    let mut units = Vec::with_capacity(total as usize);
    let mut placed: Vec<(Vec2, f32, bool)> = Vec::new();
    for (i, u) in raw.units.iter().enumerate() {
        let f = |name: &str| format!("units[{i}].{name}");
        let kind: UnitKind =
            u.kind.parse().map_err(|e: crate::units::UnknownUnitKind| cx.err(f("type"), format!("{:?}", u.kind), e.to_string()))?;
        let team = Team::from_player(u.team).ok_or_else(|| cx.err(f("team"), u.team, "must be 1 or 2"))?;
        let spec = data.spec(kind);
        if !spec.present {
            return Err(cx.err(f("type"), kind, format!("not in the {data} data set ({})", data.describe())));
        }
        let pos = Vec2::new(u.x, u.y);
        if !pos.is_finite() || !playable.contains(pos) {
            return Err(cx.err(
                format!("units[{i}].x/y"),
                format!("({}, {})", u.x, u.y),
                format!("outside the playable area {playable:?}"),
            ));
        }
        if !spec.flying && !terrain.walkable(pos) {
            return Err(cx.err(
                format!("units[{i}].x/y"),
                format!("({}, {})", u.x, u.y),
                format!("a ground unit ({kind}) placed where there is no ground"),
            ));
        }
        if !u.facing.is_finite() {
            return Err(cx.err(f("facing"), u.facing, "must be a finite angle in radians"));
        }
        let emax = spec.energy_max;
        let energy = match u.energy {
            None => spec.energy_start,
            Some(e) if emax > 0.0 && e.is_finite() && (0.0..=emax).contains(&e) => e,
            Some(e) if emax == 0.0 => return Err(cx.err(f("energy"), e, format!("{kind} has no energy"))),
            Some(e) => return Err(cx.err(f("energy"), e, format!("must be between 0 and {emax} for {kind}"))),
        };
        match u.count {
            None => {
                placed.push((pos, spec.radius, spec.flying));
                units.push(ScenarioUnit { kind, team, pos, facing: u.facing, energy });
            }
            Some(0) => return Err(cx.err(f("count"), 0, "at least 1 unit")),
            Some(n) => {
                for _ in 0..n {
                    let at = super::place::place(terrain, &placed, spec, pos);
                    placed.push((at, spec.radius, spec.flying));
                    units.push(ScenarioUnit { kind, team, pos: at, facing: u.facing, energy });
                }
            }
        }
    }
    Ok(units)
}

/// The opponent's order at the start, its points on the map.
fn start_order(cx: &Ctx, raw: Option<&RawStart>, playable: Rect) -> Result<StartOrder, ScenarioError> {
    Ok(match raw {
        None | Some(RawStart::None) => StartOrder::None,
        Some(RawStart::AttackMove { x, y, delay_s }) => {
            let to = point(cx, "opponent.start", [*x, *y], playable)?;
            StartOrder::AttackMove { to, delay_loops: delay(cx, *delay_s)? }
        }
        Some(RawStart::AttackMoveRandom { from, to, delay_s }) => StartOrder::AttackMoveRandom {
            from: point(cx, "opponent.start.from", *from, playable)?,
            to: point(cx, "opponent.start.to", *to, playable)?,
            delay_loops: delay(cx, *delay_s)?,
        },
    })
}

fn point(cx: &Ctx, field: &str, p: [f32; 2], playable: Rect) -> Result<Vec2, ScenarioError> {
    let v = Vec2::new(p[0], p[1]);
    if !v.is_finite() || !playable.contains(v) {
        return Err(cx.err(field, format!("({}, {})", p[0], p[1]), "outside the playable area"));
    }
    Ok(v)
}

fn delay(cx: &Ctx, s: f32) -> Result<u32, ScenarioError> {
    if !(s.is_finite() && (0.0..=3600.0).contains(&s)) {
        return Err(cx.err("opponent.start.delay_s", s, "must be between 0 and 3600 seconds"));
    }
    Ok(seconds_to_loops(s))
}

fn terrain(cx: &Ctx, t: &RawTerrain, w: u32, h: u32, playable: Rect) -> Result<Terrain, ScenarioError> {
    let mut legend: Vec<(char, f32)> = Vec::new();
    for (k, &v) in &t.legend {
        let mut chars = k.chars();
        let (Some(c), None) = (chars.next(), chars.next()) else {
            return Err(cx.err(format!("terrain.legend.{k:?}"), v, "keys must be single characters"));
        };
        if c == '.' {
            return Err(cx.err("terrain.legend.\".\"", v, "'.' is reserved for cells with no ground"));
        }
        if !(v.is_finite() && (0.0..=8.0).contains(&v)) {
            return Err(cx.err(format!("terrain.legend.{k:?}"), v, "heights are cliff levels between 0 and 8"));
        }
        legend.push((c, v));
    }
    if t.rows.len() != h as usize {
        return Err(cx.err("terrain.rows", format!("{} rows", t.rows.len()), format!("the map is {h} cells high")));
    }
    let mut cells = vec![None; (w * h) as usize];
    for (r, row) in t.rows.iter().enumerate() {
        let y = h as usize - 1 - r;
        let n = row.chars().count();
        if n != w as usize {
            return Err(cx.err(format!("terrain.rows[{r}]"), format!("{n} characters"), format!("the map is {w} cells wide")));
        }
        for (x, c) in row.chars().enumerate() {
            cells[y * w as usize + x] = match c {
                '.' => None,
                c => match legend.iter().find(|(k, _)| *k == c) {
                    Some((_, v)) => Some(*v),
                    None => return Err(cx.err(format!("terrain.rows[{r}][{x}]"), format!("{c:?}"), "character not in terrain.legend")),
                },
            };
        }
    }
    Ok(Terrain::new(w, h, cells, playable))
}
