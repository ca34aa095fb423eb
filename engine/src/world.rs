//! The world state: units, terrain, the loop counter and the seeded RNG. `sim.rs` advances
//! it one game loop at a time.

use crate::ability::{AreaEffect, PendingCast, Status};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::orca::{Neighbour, Orca};
use crate::pathing::PathCache;
use crate::scenario::{Scenario, Upgrade};
use crate::spatial::SpatialGrid;
use crate::terrain::Terrain;
use crate::time::per_normal_s;
use crate::units::{DataSet, UnitKind, UnitSpec, Weapon};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// What a unit has been told to do.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Order {
    /// No order: stands, and (if auto-acquisition is on for its team) engages what comes in range.
    Idle,
    /// Never moves; fires at enemies in weapon range.
    Hold,
    /// Moves to a point ignoring enemies.
    Move { to: Vec2 },
    /// Moves to a point, engaging enemies met on the way.
    AttackMove { to: Vec2 },
    /// Attacks one unit (for a healer: heals one ally) until it dies or is lost from sight.
    Attack { target: UnitId },
}

/// What a unit did in the last loop, for observations and text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Activity {
    Idle,
    Moving,
    Attacking,
    Healing,
    Dead,
}

/// How a unit takes up space, cached from its type (hot in collision queries).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Body {
    Air,
    Ground,
    /// Massive ground units (a Colossus does not stride over them).
    Massive,
    /// Strides over smaller ground units (Colossus).
    Tall,
}

impl Body {
    /// Whether two bodies push each other.
    pub fn collide(a: Body, b: Body) -> bool {
        match (a, b) {
            (Body::Air, _) | (_, Body::Air) => false,
            (Body::Tall, o) | (o, Body::Tall) => o == Body::Massive || o == Body::Tall,
            _ => true,
        }
    }

    pub fn of(s: &UnitSpec) -> Body {
        if s.flying {
            Body::Air
        } else if s.tall {
            Body::Tall
        } else if s.attrs.has(crate::units::Attrs::MASSIVE) {
            Body::Massive
        } else {
            Body::Ground
        }
    }
}

/// One unit's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    pub id: UnitId,
    pub team: Team,
    pub kind: UnitKind,
    /// The kind's row in the world's data set (changes with it on a morph).
    pub(crate) spec: &'static UnitSpec,
    pub(crate) body: Body,
    pub(crate) radius: f32,
    /// 1-based number among the units of the same team and base type (`Marine_3`).
    pub ordinal: u16,
    pub pos: Vec2,
    pub vel: Vec2,
    /// Unit vector the unit faces (kept as a vector: the angle is only needed for display).
    pub heading: Vec2,
    /// Where its field of view points under SMACv2's `conic_fov` ([`crate::Command::Look`]):
    /// a unit vector, east until told otherwise (SMACv2's start). Other rules ignore it.
    pub look: Vec2,
    pub hp: f32,
    pub max_hp: f32,
    pub shield: f32,
    pub max_shield: f32,
    pub energy: f32,
    /// Loops until the weapon may fire again (at most 0 when ready).
    pub cooldown: f32,
    pub speed: f32,
    pub order: Order,
    /// The unit currently engaged (ordered or auto-acquired).
    pub target: Option<UnitId>,
    pub last_damaged: u32,
    pub alive: bool,
    pub activity: Activity,
    pub(crate) was_healing: bool,
    /// The last enemy that damaged this unit, so an idle unit can answer it.
    pub last_attacker: Option<UnitId>,
    /// Consecutive loops in which it wanted to move but hardly could (blocked).
    pub(crate) blocked_loops: u16,
    pub(crate) waypoint: Option<(Vec2, Vec2, u32)>,
    /// Speed before buffs and debuffs (upgrades included).
    pub(crate) base_speed: f32,
    /// Buffs, modes, timers and cooldowns from abilities.
    pub status: Status,
    /// An attack started and not yet over (wind-up or backswing).
    pub(crate) swing: Option<Swing>,
    /// Where its weapon's turret points (radians, counter-clockwise from east), for
    /// weapons with a turret ([`crate::units::Timing::turn`]); the unit's facing at the start.
    pub(crate) aim: f32,
}

/// An attack in progress: it started at `start`, its effect fires at `fire_at` (the
/// weapon's damage point later) and the unit stands until `done_at` (the backswing after).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Swing {
    pub target: UnitId,
    pub weapon: u8,
    pub fire_at: u32,
    pub done_at: u32,
    pub fired: bool,
    /// The weapon's cooldown before the attack began, restored if it is cancelled before its
    /// effect (a cancelled attack costs no cooldown).
    pub cooldown_before: f32,
}

/// A weapon's missile on its way to its target (it homes, as the game's guided movers do).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Missile {
    pub attacker: UnitId,
    pub target: UnitId,
    pub weapon: &'static Weapon,
    pub pos: Vec2,
}

/// A unit's field of view before any [`crate::Command::Look`]: east, as SMACv2 starts.
pub const LOOK_EAST: Vec2 = Vec2 { x: 1.0, y: 0.0 };

impl Unit {
    pub fn spec(&self) -> &'static UnitSpec {
        self.spec
    }
    /// The name shown in observations: base type and ordinal, e.g. `Marine_1`.
    pub fn name(&self) -> String {
        format!("{}_{}", self.kind.base().name(), self.ordinal)
    }
    pub fn flying(&self) -> bool {
        self.body == Body::Air
    }
    /// Collision radius.
    pub fn radius(&self) -> f32 {
        self.radius
    }
    /// How far a collision query around this unit must reach beyond its own radius.
    pub(crate) fn collision_reach(&self, w: &World) -> f32 {
        w.reach_radius[(self.body == Body::Tall) as usize] + w.max_step
    }
    /// Whether two units push each other. Air units never collide; a Colossus strides over
    /// ground units that are not massive (and they walk under it), as in StarCraft II.
    pub fn collides_with(&self, other: &Unit) -> bool {
        Body::collide(self.body, other.body)
    }

    /// Ends an attack in progress; one cancelled in its wind-up gives its cooldown back.
    pub(crate) fn cancel_swing(&mut self) {
        if let Some(sw) = self.swing.take()
            && !sw.fired
        {
            self.cooldown = sw.cooldown_before;
        }
    }

    /// Turns the turret of a weapon with `timing` towards `to`, by at most its yaw rate this
    /// loop, and tells whether it now points within the weapon's `ArcSlop` of it (always true
    /// for a weapon without a turret: it fires whichever way).
    pub(crate) fn aim_at(&mut self, to: Vec2, timing: &crate::units::Timing) -> bool {
        if timing.turn <= 0.0 {
            return true;
        }
        let want = (to - self.pos).angle();
        let off = wrap_angle(want - self.aim);
        self.aim = if off.abs() <= timing.turn { want } else { wrap_angle(self.aim + timing.turn.copysign(off)) };
        wrap_angle(want - self.aim).abs() <= timing.arc_slop
    }

    /// Facing in radians, counter-clockwise from east.
    pub fn facing(&self) -> f32 {
        self.heading.angle()
    }
    pub fn hp_fraction(&self) -> f32 {
        if self.max_hp > 0.0 { self.hp / self.max_hp } else { 0.0 }
    }
}

/// Switches that change the rules of a world.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rules {
    /// Everyone sees everything (fog of war off).
    pub full_vision: bool,
    /// StarCraft II's random attack delay (-1 to +2 loops after each attack).
    pub cooldown_jitter: bool,
    /// Whether idle units of each team acquire targets on their own. SMAC's allied units
    /// are "passive" editor copies; StarCraft II units are not.
    pub auto_acquire: [bool; 2],
    /// Unit abilities (casts, autocast Barrier, scripted ability use). Off gives SMAC's
    /// ability-less units, and the baseline the benchmark compares against.
    #[serde(default = "yes")]
    pub abilities: bool,
    /// Where a weapon's `Period` is counted from (the game's data does not say: docs/smac.md).
    #[serde(default)]
    pub weapon_period: WeaponPeriod,
    /// Melee units near their target walk round the units already at it to a free place
    /// beside it instead of waiting behind them: an experiment on StarCraft II's surround,
    /// off by default (docs/smac.md, "The learner or the game?", gives what it changed).
    #[serde(default)]
    pub melee_surround: bool,
}

fn yes() -> bool {
    true
}

impl Default for Rules {
    fn default() -> Self {
        Self {
            full_vision: false,
            cooldown_jitter: true,
            auto_acquire: [true, true],
            abilities: true,
            weapon_period: WeaponPeriod::Attack,
            melee_surround: false,
        }
    }
}

/// Where a weapon's period (its `Period`, the time between attacks) is counted from. The
/// game's data files give the period and the damage point but not which event starts the
/// period; the engine's reading is the start of the attack (Liquipedia's "time between
/// damage-dealing actions"; SMAC's largest observed cooldowns lean the same way). `Shot`
/// counts it from the damage point instead, so every cycle is longer by the wind-up: an
/// experiment, kept off the deployment's wire (a launch file asking for it is refused).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WeaponPeriod {
    /// From the start of the attack: wind-up and backswing lie inside the period.
    #[default]
    Attack,
    /// From the shot (the damage point): the cycle is the period plus the wind-up.
    Shot,
}

impl WeaponPeriod {
    pub const ALL: [WeaponPeriod; 2] = [WeaponPeriod::Attack, WeaponPeriod::Shot];

    /// The engine's reading (a saved config leaves it out).
    pub fn is_attack(&self) -> bool {
        *self == WeaponPeriod::Attack
    }

    pub const fn name(self) -> &'static str {
        match self {
            WeaponPeriod::Attack => "attack",
            WeaponPeriod::Shot => "shot",
        }
    }
}

impl std::fmt::Display for WeaponPeriod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A weapon period reading that is not one of the two.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown weapon period `{0}` (known: attack, shot)")]
pub struct UnknownWeaponPeriod(pub String);

impl std::str::FromStr for WeaponPeriod {
    type Err = UnknownWeaponPeriod;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        WeaponPeriod::ALL.into_iter().find(|w| w.name() == s).ok_or_else(|| UnknownWeaponPeriod(s.to_owned()))
    }
}

/// Counters kept over an episode.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TeamStats {
    pub damage_dealt: f32,
    pub healing_done: f32,
    pub kills: u32,
    pub attacks: u32,
    /// Casts per ability (autocasts included: Barrier, and each new Medivac heal target).
    pub abilities: std::collections::BTreeMap<crate::ability::Ability, u32>,
}

/// An attack or heal made in the last loop (drawn as lines by renderers, counted by stats).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shot {
    pub from: UnitId,
    pub to: UnitId,
    pub impact: Vec2,
}

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Intent {
    /// Where to go and how close (centre to centre) is close enough.
    pub goal: Option<(Vec2, f32)>,
    /// Start an attack on a target with a weapon (its effect fires at the damage point).
    pub fire: Option<(UnitId, usize)>,
    /// The damage point of an attack started earlier is reached: its effect fires.
    pub release: Option<(UnitId, usize)>,
    pub heal: Option<UnitId>,
    /// Unit to ignore in collision avoidance (the one it is closing on).
    pub closing_on: Option<UnitId>,
    /// A melee unit near the target it closes on, under `Rules::melee_surround`: its weapon's
    /// range, so that movement looks for a free place beside the target.
    pub surround: Option<f32>,
}

/// A unit as movement sees it at the start of a loop: compact, so neighbour scans stay cheap.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Snap {
    pub pos: Vec2,
    pub vel: Vec2,
    pub radius: f32,
    pub body: Body,
    pub alive: bool,
    /// Has a goal this loop (ORCA shares the avoidance with it).
    pub moving: bool,
    /// Share of an overlap push it takes (0: immobile).
    pub weight: f32,
    pub cliff_walk: bool,
}

impl Snap {
    pub fn collides_with(&self, o: &Snap) -> bool {
        Body::collide(self.body, o.body)
    }
}

/// A loop's reusable buffers (filled by `sim` and `movement`), held by the world so that
/// stepping allocates nothing.
#[derive(Clone, Debug, Default)]
pub(crate) struct Scratch {
    pub intents: Vec<Intent>,
    pub neighbours: Vec<Neighbour>,
    pub snaps: Vec<Snap>,
    pub moves: Vec<(usize, Vec2)>,
}

/// The simulated world.
#[derive(Clone, Debug)]
pub struct World {
    pub(crate) terrain: Arc<Terrain>,
    pub(crate) units: Vec<Unit>,
    pub(crate) tick: u32,
    pub(crate) rng: ChaCha8Rng,
    pub(crate) rules: Rules,
    pub(crate) upgrades: [Vec<Upgrade>; 2],
    pub(crate) vis: [Vec<bool>; 2],
    /// Ground height under each unit, refreshed every loop.
    pub(crate) heights: Vec<f32>,
    /// The longest sight range of any unit type in the scenario.
    pub(crate) max_sight: f32,
    /// Units that may overlap another (moved, or pushed last pass); see `separate`.
    pub(crate) dirty: Vec<bool>,
    pub(crate) dirty_next: Vec<bool>,
    /// The largest radius of a unit each body kind can collide with (bounds collision
    /// queries): Colossi stride over small units, so a Zergling never needs to look as far
    /// as a Colossus's radius.
    pub(crate) reach_radius: [f32; 2],
    /// The fastest unit's speed per loop: how stale grid positions can be within a loop.
    pub(crate) max_step: f32,
    /// Every living unit.
    pub(crate) grid: SpatialGrid,
    /// Living units of each team, for queries that only want one side (vision, targets).
    pub(crate) team_grid: [SpatialGrid; 2],
    pub(crate) paths: PathCache,
    pub(crate) orca: Orca,
    pub(crate) stats: [TeamStats; 2],
    pub(crate) shots: Vec<Shot>,
    pub(crate) scratch: Scratch,
    /// Area effects on the ground (storms, force fields, shields, charges).
    pub(crate) effects: Vec<AreaEffect>,
    /// Casts accepted since the last loop.
    pub(crate) pending_casts: Vec<PendingCast>,
    /// Weapon missiles in flight.
    pub(crate) missiles: Vec<Missile>,
    /// The unit data every unit's row comes from.
    pub(crate) data: DataSet,
    /// Whether some unit was marked as under a Guardian Shield (flags need clearing).
    pub(crate) any_guarded: bool,
    pub(crate) scratch_damage: Vec<(usize, f32, UnitId)>,
    /// Some unit's HP reached zero outside an attack (spells): deaths need settling.
    pub(crate) deaths_pending: bool,
    /// Whether any unit may cloak (the detection check is skipped otherwise).
    pub(crate) cloak_possible: bool,
}

impl World {
    /// Instantiates a scenario with a seed. Everything random downstream draws from `rng`.
    pub fn new(scenario: &Scenario, rules: Rules, seed: u64) -> Self {
        let terrain = Arc::clone(&scenario.terrain);
        let data = scenario.data;
        // A map without fog of war shows everything, whatever the rules ask.
        let rules = Rules { full_vision: rules.full_vision || !scenario.fog_of_war, ..rules };
        let mut units = Vec::with_capacity(scenario.units.len());
        let mut ordinals: Vec<(Team, UnitKind, u16)> = Vec::new();
        for (i, su) in scenario.units.iter().enumerate() {
            let base = su.kind.base();
            let ord = match ordinals.iter_mut().find(|(t, k, _)| *t == su.team && *k == base) {
                Some(e) => {
                    e.2 += 1;
                    e.2
                }
                None => {
                    ordinals.push((su.team, base, 1));
                    1
                }
            };
            let s = data.spec(su.kind);
            let ups = &scenario.upgrades[su.team.index()];
            let mut max_hp = s.hp;
            if su.kind == UnitKind::Marine && ups.contains(&Upgrade::CombatShield) {
                max_hp += 10.0;
            }
            let mut speed = s.speed;
            if su.kind == UnitKind::Zergling && ups.contains(&Upgrade::MetabolicBoost) {
                // The data's zerglingmovementspeed adds 1.746 per Normal second in every mod;
                // the legacy table multiplied by 1.6.
                speed = if data == DataSet::Legacy { speed * 1.6 } else { speed + per_normal_s(1.746) };
            }
            units.push(Unit {
                id: UnitId::new(i as u16),
                team: su.team,
                kind: su.kind,
                spec: s,
                body: Body::of(s),
                radius: s.radius,
                ordinal: ord,
                pos: su.pos,
                vel: Vec2::ZERO,
                heading: Vec2::from_angle(su.facing),
                look: LOOK_EAST,
                hp: max_hp,
                max_hp,
                shield: s.shield,
                max_shield: s.shield,
                energy: su.energy,
                cooldown: 0.0,
                speed,
                order: Order::Idle,
                target: None,
                last_damaged: 0,
                alive: true,
                activity: Activity::Idle,
                was_healing: false,
                last_attacker: None,
                blocked_loops: 0,
                waypoint: None,
                base_speed: speed,
                status: Status::default(),
                swing: None,
                aim: su.facing,
            });
        }
        let n = units.len();
        let grid = SpatialGrid::new(terrain.width(), terrain.height(), n);
        let mut w = Self {
            terrain,
            units,
            tick: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
            rules,
            upgrades: scenario.upgrades.clone(),
            vis: [vec![false; n], vec![false; n]],
            heights: vec![0.0; n],
            dirty: vec![true; n],
            dirty_next: vec![false; n],
            max_sight: scenario.units.iter().map(|u| data.spec(u.kind).sight).fold(0.0, f32::max),
            reach_radius: {
                let r = |f: &dyn Fn(Body) -> bool| {
                    scenario.units.iter().map(|u| data.spec(u.kind)).filter(|s| f(Body::of(s))).map(|s| s.radius).fold(0.0, f32::max)
                };
                [r(&|b| b != Body::Air && b != Body::Tall), r(&|b| b == Body::Massive || b == Body::Tall)]
            },
            // Metabolic Boost x1.6, Stimpack x1.5, Afterburners x1.7: no unit outruns this.
            max_step: scenario.units.iter().map(|u| data.spec(u.kind).speed * 1.7).fold(0.0, f32::max),
            team_grid: [grid.clone(), grid.clone()],
            grid,
            paths: PathCache::default(),
            orca: Orca::default(),
            stats: Default::default(),
            shots: Vec::new(),
            scratch: Default::default(),
            effects: Vec::new(),
            pending_casts: Vec::new(),
            missiles: Vec::new(),
            data,
            any_guarded: false,
            scratch_damage: Vec::new(),
            deaths_pending: false,
            cloak_possible: scenario.units.iter().any(|u| matches!(u.kind, UnitKind::Ghost | UnitKind::Banshee)),
        };
        w.refresh();
        w
    }

    pub fn terrain(&self) -> &Terrain {
        &self.terrain
    }
    /// The shared terrain, for caches that must know when it changes.
    pub fn terrain_arc(&self) -> &Arc<Terrain> {
        &self.terrain
    }
    pub fn units(&self) -> &[Unit] {
        &self.units
    }
    pub fn unit(&self, id: UnitId) -> Option<&Unit> {
        self.units.get(id.index())
    }
    pub fn tick(&self) -> u32 {
        self.tick
    }
    pub fn rules(&self) -> &Rules {
        &self.rules
    }
    /// The unit data this game runs.
    pub fn data(&self) -> DataSet {
        self.data
    }
    pub fn stats(&self, team: Team) -> &TeamStats {
        &self.stats[team.index()]
    }
    pub fn has_upgrade(&self, team: Team, up: Upgrade) -> bool {
        self.upgrades[team.index()].contains(&up)
    }
    /// Attacks and heals made in the last loop.
    pub fn shots(&self) -> &[Shot] {
        &self.shots
    }
    pub(crate) fn rng(&mut self) -> &mut ChaCha8Rng {
        &mut self.rng
    }

    /// Whether `team` currently sees unit `id` (its own units always).
    pub fn visible_to(&self, team: Team, id: UnitId) -> bool {
        self.vis[team.index()].get(id.index()).copied().unwrap_or(false)
    }

    pub fn alive(&self, team: Team) -> impl Iterator<Item = &Unit> {
        self.units.iter().filter(move |u| u.alive && u.team == team)
    }

    /// Whether a unit that needs power (Photon Cannon) stands in a friendly power field.
    pub fn powered(&self, u: &Unit) -> bool {
        !u.spec().needs_power
            || self.alive(u.team).any(|p| {
                let r = p.spec().power_radius;
                r > 0.0 && p.pos.dist_sq(u.pos) <= r * r
            })
    }

    /// Fog of war per terrain cell for `team` (row 0 at y = 0): a cell is visible when one of
    /// the team's units sees its centre, with the same cliff rule as for units. Renderers
    /// darken the rest. `out` is resized to the cell count.
    pub fn cell_visibility(&self, team: Team, out: &mut Vec<bool>) {
        let t = &self.terrain;
        out.clear();
        out.resize(t.cell_count(), self.rules.full_vision);
        if self.rules.full_vision {
            return;
        }
        let (w, h) = (t.width() as i64, t.height() as i64);
        for (i, v) in self.units.iter().enumerate() {
            if !v.alive || v.team != team {
                continue;
            }
            let sight = v.spec().sight;
            let (vh, vf) = (self.heights[i], v.flying());
            let (x0, x1) = (((v.pos.x - sight).floor() as i64).max(0), ((v.pos.x + sight).ceil() as i64).min(w - 1));
            let (y0, y1) = (((v.pos.y - sight).floor() as i64).max(0), ((v.pos.y + sight).ceil() as i64).min(h - 1));
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    let c = (cy * w + cx) as usize;
                    if out[c] {
                        continue;
                    }
                    let centre = Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5);
                    let ch = t.cell_height(c).unwrap_or(0.0);
                    out[c] = centre.dist_sq(v.pos) <= sq(sight) && (vf || ch < vh + 0.5);
                }
            }
        }
    }

    /// Whether a side still has a unit that can deal damage.
    pub fn can_fight(&self, team: Team) -> bool {
        self.alive(team).any(|u| u.kind.can_fight())
    }

    pub(crate) fn set_order(&mut self, id: UnitId, order: Order) {
        if let Some(u) = self.units.get_mut(id.index()) {
            // A new order cancels an attack in progress (a cancelled wind-up gives its
            // cooldown back); the same order again, as agents send every step, does not.
            if u.order != order {
                u.cancel_swing();
            }
            u.order = order;
            u.target = match order {
                Order::Attack { target } => Some(target),
                _ => None,
            };
            u.waypoint = None;
            u.blocked_loops = 0;
        }
    }

    /// Recomputes the spatial grid and both teams' vision from current positions.
    pub(crate) fn refresh(&mut self) {
        self.grid.rebuild(self.units.iter().map(|u| (u.pos, u.alive)));
        for team in Team::BOTH {
            self.team_grid[team.index()].rebuild(self.units.iter().map(|u| (u.pos, u.alive && u.team == team)));
        }
        for (i, u) in self.units.iter().enumerate() {
            self.heights[i] = self.terrain.height_at(u.pos);
        }
        for team in Team::BOTH {
            let ti = team.index();
            for i in 0..self.units.len() {
                let t = &self.units[i];
                let seen = t.alive
                    && (t.team == team || ((self.rules.full_vision || self.sees(team, i)) && (!t.status.cloaked || self.detects(team, i))));
                self.vis[ti][i] = seen;
            }
        }
        if self.cloak_possible {
            for i in 0..self.units.len() {
                let enemy = self.units[i].team.other().index();
                let detected = self.units[i].status.cloaked && self.vis[enemy][i];
                self.units[i].status.detected = detected;
            }
        }
    }

    /// Whether `team` may target cloaked unit `target`: a powered detector of the team has it
    /// in range, or an EMP revealed it.
    fn detects(&self, team: Team, target: usize) -> bool {
        let t = &self.units[target];
        if self.tick < t.status.revealed_until {
            return true;
        }
        let r = crate::ability::DETECTION_RADIUS + t.radius;
        self.alive(team).any(|d| d.spec().detector && d.pos.dist_sq(t.pos) <= r * r && self.powered(d))
    }

    /// Whether any unit of `team` sees unit `target`, with StarCraft II's cliff rule: a
    /// ground viewer does not see ground units on higher ground (half a level or more above).
    /// Only units within the longest sight range are visited, so the cost is local.
    fn sees(&self, team: Team, target: usize) -> bool {
        let t = &self.units[target];
        let (tflying, tr, th) = (t.flying(), t.radius, self.heights[target]);
        self.team_grid[team.index()].any_near(t.pos, self.max_sight + tr, |j| {
            let v = &self.units[j];
            v.pos.dist_sq(t.pos) <= sq(v.spec().sight + tr) && (tflying || v.flying() || th < self.heights[j] + 0.5)
        })
    }
}

pub(crate) fn sq(x: f32) -> f32 {
    x * x
}

/// An angle brought into [-pi, pi].
fn wrap_angle(a: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    let a = a.rem_euclid(tau);
    if a > std::f32::consts::PI { a - tau } else { a }
}
