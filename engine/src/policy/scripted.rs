//! Scripted agents: baselines, the PvE opponent styles, and the built-in AI's ability use.
//! They read a [`GroupObs`] and the scenario (a player knows the map) and nothing else, give
//! actions only for the units their group controls, and may read every unit their team sees.

use super::micro::ability_actions;
use super::view::{
    attacking, busy, can_attack, centroid, edge, ehp, flying, hp_fraction, id, is_idle, max_range, mobile, moving_to, pos, radius,
    range_gap, reloading_longer_than, support,
};
use super::{Agent, AgentCtx};
use crate::action::{Action, Command};
use crate::geom::Vec2;
use crate::ids::Team;
use crate::obs::{Buffs, OrderInfo, SmacLayout, UnitInfo};
use crate::obs::{GroupObs, Reads};
use crate::scenario::{OpponentKind, Scenario};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

/// What makes a fresh scripted agent.
pub type MakeAgent = fn() -> Box<dyn Agent>;

/// The scripted agents, written once: the names [`by_name`] accepts (the CLI's `--agent` and
/// launch files' `policy:` values), a line each for `--help` and error messages, and what
/// makes one.
pub const SCRIPTED: &[(&str, &str, MakeAgent)] = &[
    ("focus-fire", "every unit attacks the visible enemy with the lowest HP + shields it can hit", || Box::new(FocusFire::team_focus())),
    ("kite", "focus fire; ranged units step back from slower melee units while reloading", || Box::new(FocusFire::kiting())),
    ("attack-move", "attack-move to the enemy start and let the engine pick targets", || Box::new(AttackMove::default())),
    ("builtin", "the built-in AI's behaviour: attack-move towards the enemy", || Box::new(AttackMove::default())),
    ("aggressive", "scripted style: attack-move, everyone on the enemy closest to the army", || Box::new(FocusFire::aggressive())),
    ("defensive", "scripted style: hold ground or high ground, pull back badly hurt units", || Box::new(Defensive::default())),
    ("focus", "scripted style: lowest effective HP in range, ranged units kite slower melee", || Box::new(FocusFire::focus())),
    ("smac-heuristic", "SMAC's heuristic_ai: each unit on the nearest enemy until it dies, order re-sent each step", || {
        Box::new(super::SmacHeuristic::new(false))
    }),
    ("smac-heuristic-rest", "as smac-heuristic, stepping towards a target beyond SMAC's shoot range (heuristic_rest)", || {
        Box::new(super::SmacHeuristic::new(true))
    }),
    ("random", "uniformly random available SMAC action per unit", || Box::new(RandomActions::default())),
    ("hold", "every unit holds its position and fires at what comes in range", || Box::new(Hold)),
    ("noop", "never gives an order", || Box::new(NoOp)),
];

/// The scripted agents' names and lines ([`SCRIPTED`] without the makers).
pub const AGENTS: [(&str, &str); SCRIPTED.len()] = {
    let mut out = [("", ""); SCRIPTED.len()];
    let mut i = 0;
    while i < SCRIPTED.len() {
        out[i] = (SCRIPTED[i].0, SCRIPTED[i].1);
        i += 1;
    }
    out
};

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown agent `{0}` (known: {known})", known = AGENTS.map(|a| a.0).join(", "))]
pub struct UnknownAgent(pub String);

/// A scripted agent by its CLI name (see [`AGENTS`]).
pub fn by_name(name: &str) -> Result<Box<dyn Agent>, UnknownAgent> {
    factory(name).map(|make| make())
}

/// What makes a fresh agent of a named policy (for `crate::agent::AgentTeam`s, which
/// make one per group).
pub fn factory(name: &str) -> Result<MakeAgent, UnknownAgent> {
    SCRIPTED.iter().find(|(n, _, _)| *n == name).map(|(_, _, make)| *make).ok_or_else(|| UnknownAgent(name.to_owned()))
}

/// The scripted opponent for a style (not `builtin`, which is the engine's own AI).
pub(crate) fn opponent(kind: OpponentKind) -> Box<dyn super::ForkAgent> {
    match kind {
        OpponentKind::Aggressive => Box::new(FocusFire::aggressive()),
        OpponentKind::Defensive => Box::new(Defensive::default()),
        OpponentKind::Focus | OpponentKind::Builtin | OpponentKind::Random => Box::new(FocusFire::focus()),
    }
}

/// What an agent keeps from [`AgentCtx`]: the map and its side.
#[derive(Clone, Debug)]
struct Known {
    scenario: Arc<Scenario>,
    team: Team,
}

impl Known {
    fn of(ctx: &AgentCtx) -> Self {
        Self { scenario: Arc::clone(&ctx.scenario), team: ctx.team }
    }
    /// Where the enemy started (known from the scenario, as a player knows the map).
    fn enemy_spawn(&self) -> Vec2 {
        self.scenario.spawn(self.team.other())
    }
}

/// Attack-move towards the nearest seen enemy, or the enemy start; idle units only, so the
/// engine's own acquisition does the rest.
#[derive(Debug, Clone, Default)]
pub struct AttackMove {
    known: Option<Known>,
}

impl Agent for AttackMove {
    fn reads(&self) -> Reads {
        Reads::UNITS
    }
    fn name(&self) -> &str {
        "attack-move"
    }
    fn reset(&mut self, ctx: &AgentCtx) {
        self.known = Some(Known::of(ctx));
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        let Some(k) = &self.known else { return Vec::new() };
        let centre = centroid(g.own()).unwrap_or_default();
        let goal = g.enemies().min_by(|a, b| pos(a).dist_sq(centre).total_cmp(&pos(b).dist_sq(centre))).map_or(k.enemy_spawn(), pos);
        let (mut out, handled) = ability_actions(g, &k.scenario.terrain);
        out.extend(
            g.mine()
                .filter(|u| !handled.contains(&u.tag) && is_idle(u) && u.target.is_none() && mobile(u))
                .map(|u| Action::new(id(u), Command::AttackMoveTo { to: goal })),
        );
        out
    }
}

/// Never gives an order.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoOp;

impl Agent for NoOp {
    fn reads(&self) -> Reads {
        Reads::UNITS
    }
    fn name(&self) -> &str {
        "noop"
    }
    fn reset(&mut self, _ctx: &AgentCtx) {}
    fn act(&mut self, _g: &GroupObs) -> Vec<Action> {
        Vec::new()
    }
}

/// Every unit holds its position (firing at what comes in range). Units already holding,
/// and busy ones (a new order would cancel a channel), are left alone.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hold;

impl Agent for Hold {
    fn reads(&self) -> Reads {
        Reads::UNITS
    }
    fn name(&self) -> &str {
        "hold"
    }
    fn reset(&mut self, _ctx: &AgentCtx) {}
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        g.mine().filter(|u| u.order != OrderInfo::Hold && !busy(u)).map(|u| Action::new(id(u), Command::Hold)).collect()
    }
}

/// A uniformly random available SMAC action per controlled living unit: the MARL "random
/// agent". Its draws come from the agent's own seed, so they do not depend on where it runs.
#[derive(Debug, Clone)]
pub struct RandomActions {
    rng: ChaCha8Rng,
    known: Option<Known>,
    layout: Option<SmacLayout>,
}

impl Default for RandomActions {
    fn default() -> Self {
        Self { rng: ChaCha8Rng::seed_from_u64(0), known: None, layout: None }
    }
}

impl Agent for RandomActions {
    fn reads(&self) -> Reads {
        Reads { smac: true, text: false }
    }
    fn name(&self) -> &str {
        "random"
    }
    fn reset(&mut self, ctx: &AgentCtx) {
        self.rng = ChaCha8Rng::seed_from_u64(ctx.seed);
        self.known = Some(Known::of(ctx));
        self.layout = None;
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        let Some(k) = &self.known else { return Vec::new() };
        let mut out = Vec::new();
        for c in g.controlled.iter().filter(|c| c.alive) {
            // The masks tell whether the environment appends the ability slots: the layout
            // must match them for the indices to mean the same actions.
            if self.layout.as_ref().is_none_or(|l| l.n_actions != c.avail_actions.len()) {
                let plain = SmacLayout::new(&k.scenario, k.team);
                self.layout = Some(if plain.n_actions == c.avail_actions.len() {
                    plain
                } else {
                    SmacLayout::with_abilities(&k.scenario, k.team, true)
                });
            }
            let Some(layout) = &self.layout else { continue };
            let choices: Vec<usize> = c.avail_actions.iter().enumerate().filter(|(_, a)| **a == 1).map(|(i, _)| i).collect();
            if choices.is_empty() {
                continue;
            }
            let idx = choices[self.rng.random_range(0..choices.len())];
            if let Some(command) = layout.command_for_obs(g, c.agent, idx) {
                out.push(Action::new(c.unit, command));
            }
        }
        out
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pick {
    /// The whole group on the seen enemy with the lowest effective HP.
    TeamLowest,
    /// The whole group on the seen enemy closest to the army's centre.
    TeamClosest,
    /// Each unit on the lowest effective HP enemy in its range, else the nearest.
    LowestInRange,
}

/// Focus fire in one of three flavours, with optional kiting. The scripted opponent styles
/// `aggressive` and `focus` are flavours too. The shared target is chosen from the whole
/// team's view, so a unit acting alone picks what its team acting together would.
#[derive(Debug, Clone)]
pub struct FocusFire {
    name: &'static str,
    pick: Pick,
    kite: bool,
    known: Option<Known>,
}

impl FocusFire {
    pub fn team_focus() -> Self {
        Self { name: "focus-fire", pick: Pick::TeamLowest, kite: false, known: None }
    }
    pub fn kiting() -> Self {
        Self { name: "kite", pick: Pick::TeamLowest, kite: true, known: None }
    }
    pub fn aggressive() -> Self {
        Self { name: "aggressive", pick: Pick::TeamClosest, kite: false, known: None }
    }
    pub fn focus() -> Self {
        Self { name: "focus", pick: Pick::LowestInRange, kite: true, known: None }
    }

    fn team_target<'a>(&self, g: &'a GroupObs) -> Option<&'a UnitInfo> {
        let centre = centroid(g.own())?;
        let d = |u: &UnitInfo| pos(u).dist_sq(centre);
        match self.pick {
            Pick::TeamLowest => weakest_in_sight(g),
            Pick::TeamClosest => g.enemies().min_by(|a, b| d(a).total_cmp(&d(b)).then(a.tag.cmp(&b.tag))),
            Pick::LowestInRange => None,
        }
    }

    fn kite_from(&self, g: &GroupObs, u: &UnitInfo) -> Option<Vec2> {
        if self.kite { kite_step(g, u) } else { None }
    }
}

/// The group's weakest enemy in sight: lowest HP + shields, ties to the one nearest the
/// group's centre (the focus-fire script's shared target).
pub(super) fn weakest_in_sight(g: &GroupObs) -> Option<&UnitInfo> {
    let centre = centroid(g.own())?;
    let d = |u: &UnitInfo| pos(u).dist_sq(centre);
    g.enemies().min_by(|a, b| ehp(a).total_cmp(&ehp(b)).then(d(a).total_cmp(&d(b))))
}

/// The target `u` takes: the team's target when it can hit it, else the lowest HP + shields
/// enemy in range, else the nearest enemy it can hit.
pub(super) fn own_target<'a>(g: &'a GroupObs, u: &UnitInfo, team_target: Option<&'a UnitInfo>) -> Option<&'a UnitInfo> {
    if let Some(t) = team_target
        && can_attack(u, t)
    {
        return Some(t);
    }
    let hittable: Vec<&UnitInfo> = g.enemies().filter(|e| can_attack(u, e)).collect();
    let in_range = hittable.iter().filter(|e| range_gap(u, e).is_some_and(|gap| gap <= 0.0));
    if let Some(t) = in_range.min_by(|a, b| ehp(a).total_cmp(&ehp(b)).then(a.tag.cmp(&b.tag))) {
        return Some(t);
    }
    hittable.into_iter().min_by(|a, b| pos(a).dist_sq(pos(u)).total_cmp(&pos(b).dist_sq(pos(u))).then(a.tag.cmp(&b.tag)))
}

/// Where `u` steps to get away from a melee enemy that is slower than it and about to reach
/// it while it reloads; `None` when it should not step back.
pub(super) fn kite_step(g: &GroupObs, u: &UnitInfo) -> Option<Vec2> {
    // An attack in its wind-up is left to fire: stepping away would cancel it.
    if max_range(u) < 3.0 || !reloading_longer_than(u, 2.0) || !mobile(u) || u.buffs.contains(Buffs::WINDING_UP) {
        return None;
    }
    let threats: Vec<&UnitInfo> = g
        .enemies()
        .filter(|e| max_range(e) < 1.5 && e.speed < u.speed && mobile(e) && can_attack(e, u))
        .filter(|e| edge(e, u) < max_range(e) + 1.5)
        .collect();
    let away = threats.iter().fold(Vec2::ZERO, |acc, e| acc + (pos(u) - pos(e)).normalized());
    (!threats.is_empty() && away.len() > 1e-3).then(|| pos(u) + away.normalized() * 2.0)
}

impl Agent for FocusFire {
    fn reads(&self) -> Reads {
        Reads::UNITS
    }
    fn name(&self) -> &str {
        self.name
    }
    fn reset(&mut self, ctx: &AgentCtx) {
        self.known = Some(Known::of(ctx));
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        let Some(k) = &self.known else { return Vec::new() };
        let terrain = &k.scenario.terrain;
        let team_target = self.team_target(g);
        let spawn = k.enemy_spawn();
        let playable = terrain.playable();
        let (mut out, handled) = ability_actions(g, terrain);
        for u in g.mine() {
            if handled.contains(&u.tag) {
                continue;
            }
            if support(u) {
                // Healers autocast; keep them with the army.
                if is_idle(u)
                    && mobile(u)
                    && let Some(c) = centroid(g.own().filter(|o| o.kind.can_fight()))
                {
                    out.push(Action::new(id(u), Command::AttackMoveTo { to: playable.clamp(c, 0.5) }));
                }
                continue;
            }
            if let Some(p) = self.kite_from(g, u) {
                let to = playable.clamp(p, radius(u));
                if terrain.walkable(to) || flying(u) {
                    out.push(Action::new(id(u), Command::MoveTo { to }));
                    continue;
                }
            }
            match own_target(g, u, team_target) {
                Some(t) => {
                    if !attacking(u, t.tag) && (mobile(u) || range_gap(u, t).is_some_and(|gap| gap <= 0.0)) {
                        out.push(Action::new(id(u), Command::Attack { target: id(t) }));
                    }
                }
                None => {
                    if mobile(u) && !matches!(u.order, OrderInfo::AttackMove { .. }) {
                        out.push(Action::new(id(u), Command::AttackMoveTo { to: spawn }));
                    }
                }
            }
        }
        out
    }
}

/// Hold ground (or nearby high ground), engage what comes in range, pull back units that
/// are badly hurt.
#[derive(Debug, Clone, Default)]
pub struct Defensive {
    anchor: Vec2,
    known: Option<Known>,
}

impl Defensive {
    fn pick_anchor(scenario: &Scenario, team: Team) -> Vec2 {
        let t = &scenario.terrain;
        let spawn = scenario.spawn(team);
        let enemy = scenario.spawn(team.other());
        let base = t.height_at(spawn);
        let mut best = (base, f32::MAX, spawn);
        for idx in 0..t.cell_count() {
            let c = t.cell_center(idx);
            let d = c.dist(spawn);
            // High ground on our side of the map only: never walk into the enemy to find it.
            if d > 8.0 || !t.walkable(c) || t.is_ramp(idx) || c.dist(enemy) < d {
                continue;
            }
            let h = t.height_at(c);
            if h > best.0 + 0.25 || (h >= best.0 - 0.25 && h > base + 0.25 && d < best.1) {
                best = (h, d, c);
            }
        }
        best.2
    }
}

impl Agent for Defensive {
    fn reads(&self) -> Reads {
        Reads::UNITS
    }
    fn name(&self) -> &str {
        "defensive"
    }
    fn reset(&mut self, ctx: &AgentCtx) {
        self.anchor = Self::pick_anchor(&ctx.scenario, ctx.team);
        self.known = Some(Known::of(ctx));
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        let Some(k) = &self.known else { return Vec::new() };
        let anchor = self.anchor;
        let enemy_centre = centroid(g.enemies());
        let playable = k.scenario.terrain.playable();
        let (mut out, handled) = ability_actions(g, &k.scenario.terrain);
        for u in g.mine() {
            if handled.contains(&u.tag) {
                continue;
            }
            if !mobile(u) {
                if u.order != OrderInfo::Hold {
                    out.push(Action::new(id(u), Command::Hold));
                }
                continue;
            }
            let near_enemy = g.enemies().any(|e| pos(e).dist(pos(u)) < 8.0);
            if hp_fraction(u) < 0.3
                && near_enemy
                && let Some(ec) = enemy_centre
            {
                let to = playable.clamp(anchor + (anchor - ec).normalized() * 3.0, radius(u));
                if !matches!(u.order, OrderInfo::Move { .. }) {
                    out.push(Action::new(id(u), Command::MoveTo { to }));
                }
                continue;
            }
            let engage = if max_range(u) < 1.5 { 3.0 } else { 0.5 };
            let target = g
                .enemies()
                .filter(|e| range_gap(u, e).is_some_and(|gap| gap <= engage))
                .min_by(|a, b| ehp(a).total_cmp(&ehp(b)).then(a.tag.cmp(&b.tag)));
            if let Some(t) = target {
                if !attacking(u, t.tag) {
                    out.push(Action::new(id(u), Command::Attack { target: id(t) }));
                }
                continue;
            }
            if pos(u).dist(anchor) > 3.0 {
                if !moving_to(u, anchor) {
                    out.push(Action::new(id(u), Command::MoveTo { to: anchor }));
                }
            } else if u.order != OrderInfo::Hold && !matches!(u.order, OrderInfo::Move { .. }) {
                out.push(Action::new(id(u), Command::Hold));
            }
        }
        out
    }
}
