//! Scripted policies: agent baselines and the opponent styles. They see only a
//! [`TeamView`] and act only through [`Action`]s, like any other agent.

use super::{Policy, TeamView, micro::ability_actions};
use crate::action::{Action, Command};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::scenario::Scenario;
use crate::world::{Order, Unit};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Effective HP used to rank targets: what must be dealt to kill the unit.
fn ehp(u: &Unit) -> f32 {
    u.hp + u.shield
}

fn max_range(u: &Unit) -> f32 {
    u.spec().weapons.iter().map(|w| w.range).fold(0.0, f32::max)
}

fn centroid<'a>(units: impl Iterator<Item = &'a Unit>) -> Option<Vec2> {
    let (mut s, mut n) = (Vec2::ZERO, 0.0);
    for u in units {
        s += u.pos;
        n += 1.0;
    }
    (n > 0.0).then(|| s * (1.0 / n))
}

/// Attack-move towards the nearest seen enemy, or the enemy start; idle units only, so
/// the engine's own acquisition does the rest.
#[derive(Debug, Clone, Copy, Default)]
pub struct AttackMove;

impl Policy for AttackMove {
    fn name(&self) -> &str {
        "attack-move"
    }
    fn act(&mut self, view: &TeamView<'_>, _rng: &mut ChaCha8Rng) -> Vec<Action> {
        let centre = centroid(view.own()).unwrap_or_default();
        let goal =
            view.enemies().min_by(|a, b| a.pos.dist_sq(centre).total_cmp(&b.pos.dist_sq(centre))).map_or(view.enemy_spawn(), |e| e.pos);
        let (mut out, handled) = ability_actions(view);
        out.extend(
            view.own()
                .filter(|u| !handled.contains(&u.id) && u.order == Order::Idle && u.target.is_none() && u.speed > 0.0)
                .map(|u| Action::new(u.id, Command::AttackMoveTo { to: goal })),
        );
        out
    }
}

#[derive(Debug, Clone, Copy, Default)]
pub struct NoOp;

impl Policy for NoOp {
    fn name(&self) -> &str {
        "noop"
    }
    fn act(&mut self, _view: &TeamView<'_>, _rng: &mut ChaCha8Rng) -> Vec<Action> {
        Vec::new()
    }
}

/// A uniformly random available SMAC action per living unit: the MARL "random agent".
#[derive(Debug, Clone, Copy, Default)]
pub struct RandomActions;

impl Policy for RandomActions {
    fn name(&self) -> &str {
        "random"
    }
    fn act(&mut self, view: &TeamView<'_>, rng: &mut ChaCha8Rng) -> Vec<Action> {
        let layout = crate::obs::SmacLayout::new(view.scenario(), view.team());
        let mut avail = vec![0u8; layout.n_actions];
        let mut out = Vec::new();
        for agent in 0..layout.n_agents {
            layout.avail_actions_view(view, agent, &mut avail);
            let choices: Vec<usize> = avail.iter().enumerate().filter(|(_, a)| **a == 1).map(|(i, _)| i).collect();
            if choices.is_empty() {
                continue;
            }
            let idx = choices[rng.random_range(0..choices.len())];
            if let Some(a) = layout.action_from_index(view, agent, idx) {
                out.push(a);
            }
        }
        out
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pick {
    /// The whole team on the seen enemy with the lowest effective HP.
    TeamLowest,
    /// The whole team on the seen enemy closest to the army's centre.
    TeamClosest,
    /// Each unit on the lowest effective HP enemy in its range, else the nearest.
    LowestInRange,
}

/// Focus fire in one of three flavours, with optional kiting.
#[derive(Debug, Clone)]
pub struct FocusFire {
    name: &'static str,
    pick: Pick,
    kite: bool,
}

/// The scripted opponent styles are focus-fire flavours too.
pub type Style = FocusFire;

impl FocusFire {
    pub fn team_focus() -> Self {
        Self { name: "focus-fire", pick: Pick::TeamLowest, kite: false }
    }
    pub fn kiting() -> Self {
        Self { name: "kite", pick: Pick::TeamLowest, kite: true }
    }
    pub fn aggressive() -> Self {
        Self { name: "aggressive", pick: Pick::TeamClosest, kite: false }
    }
    pub fn focus() -> Self {
        Self { name: "focus", pick: Pick::LowestInRange, kite: true }
    }

    fn team_target(&self, view: &TeamView<'_>) -> Option<UnitId> {
        let centre = centroid(view.own())?;
        match self.pick {
            Pick::TeamLowest => {
                view.enemies().min_by(|a, b| ehp(a).total_cmp(&ehp(b)).then(a.pos.dist_sq(centre).total_cmp(&b.pos.dist_sq(centre))))
            }
            Pick::TeamClosest => {
                view.enemies().min_by(|a, b| a.pos.dist_sq(centre).total_cmp(&b.pos.dist_sq(centre)).then(a.id.cmp(&b.id)))
            }
            Pick::LowestInRange => None,
        }
        .map(|u| u.id)
    }

    fn own_target(&self, view: &TeamView<'_>, u: &Unit, team_target: Option<UnitId>) -> Option<UnitId> {
        if let Some(t) = team_target
            && view.unit(t).is_some_and(|t| view.can_attack(u, t))
        {
            return Some(t);
        }
        let hittable: Vec<&Unit> = view.enemies().filter(|e| view.can_attack(u, e)).collect();
        let in_range = hittable.iter().filter(|e| view.range_gap(u.id, e.id).is_some_and(|g| g <= 0.0));
        if let Some(t) = in_range.min_by(|a, b| ehp(a).total_cmp(&ehp(b)).then(a.id.cmp(&b.id))) {
            return Some(t.id);
        }
        hittable.into_iter().min_by(|a, b| a.pos.dist_sq(u.pos).total_cmp(&b.pos.dist_sq(u.pos)).then(a.id.cmp(&b.id))).map(|e| e.id)
    }

    /// A melee enemy that is slower than `u` and about to reach it while `u` reloads.
    fn kite_from(&self, view: &TeamView<'_>, u: &Unit) -> Option<Vec2> {
        if !self.kite || max_range(u) < 3.0 || u.cooldown <= 2.0 || u.speed <= 0.0 {
            return None;
        }
        let threats: Vec<&Unit> = view
            .enemies()
            .filter(|e| max_range(e) < 1.5 && e.speed < u.speed && e.speed > 0.0 && view.can_attack(e, u))
            .filter(|e| e.pos.dist(u.pos) - e.spec().radius - u.spec().radius < max_range(e) + 1.5)
            .collect();
        let away = threats.iter().fold(Vec2::ZERO, |acc, e| acc + (u.pos - e.pos).normalized());
        (!threats.is_empty() && away.len() > 1e-3).then(|| u.pos + away.normalized() * 2.0)
    }
}

impl Policy for FocusFire {
    fn name(&self) -> &str {
        self.name
    }
    fn act(&mut self, view: &TeamView<'_>, _rng: &mut ChaCha8Rng) -> Vec<Action> {
        let team_target = self.team_target(view);
        let spawn = view.enemy_spawn();
        let playable = view.terrain().playable();
        let (mut out, handled) = ability_actions(view);
        for u in view.own() {
            if handled.contains(&u.id) {
                continue;
            }
            if u.spec().heal.is_some() || u.spec().weapons.is_empty() {
                // Healers autocast; keep them with the army.
                if u.order == Order::Idle
                    && u.speed > 0.0
                    && let Some(c) = centroid(view.own().filter(|o| o.kind.can_fight()))
                {
                    out.push(Action::new(u.id, Command::AttackMoveTo { to: playable.clamp(c, 0.5) }));
                }
                continue;
            }
            if let Some(p) = self.kite_from(view, u) {
                let to = playable.clamp(p, u.spec().radius);
                if view.terrain().walkable(to) || u.flying() {
                    out.push(Action::new(u.id, Command::MoveTo { to }));
                    continue;
                }
            }
            match self.own_target(view, u, team_target) {
                Some(t) => {
                    if u.order != (Order::Attack { target: t }) && (u.speed > 0.0 || view.range_gap(u.id, t).is_some_and(|g| g <= 0.0)) {
                        out.push(Action::new(u.id, Command::Attack { target: t }));
                    }
                }
                None => {
                    if u.speed > 0.0 && !matches!(u.order, Order::AttackMove { .. }) {
                        out.push(Action::new(u.id, Command::AttackMoveTo { to: spawn }));
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

impl Policy for Defensive {
    fn name(&self) -> &str {
        "defensive"
    }
    fn reset(&mut self, scenario: &Scenario, team: Team) {
        self.anchor = Self::pick_anchor(scenario, team);
    }
    fn act(&mut self, view: &TeamView<'_>, _rng: &mut ChaCha8Rng) -> Vec<Action> {
        let enemy_centre = centroid(view.enemies());
        let playable = view.terrain().playable();
        let (mut out, handled) = ability_actions(view);
        for u in view.own() {
            if handled.contains(&u.id) {
                continue;
            }
            if u.speed <= 0.0 {
                if u.order != Order::Hold {
                    out.push(Action::new(u.id, Command::Hold));
                }
                continue;
            }
            let near_enemy = view.enemies().any(|e| e.pos.dist(u.pos) < 8.0);
            if u.hp_fraction() < 0.3
                && near_enemy
                && let Some(ec) = enemy_centre
            {
                let to = playable.clamp(self.anchor + (self.anchor - ec).normalized() * 3.0, u.spec().radius);
                if !matches!(u.order, Order::Move { .. }) {
                    out.push(Action::new(u.id, Command::MoveTo { to }));
                }
                continue;
            }
            let engage = if max_range(u) < 1.5 { 3.0 } else { 0.5 };
            let target = view
                .enemies()
                .filter(|e| view.can_attack(u, e) && view.range_gap(u.id, e.id).is_some_and(|g| g <= engage))
                .min_by(|a, b| ehp(a).total_cmp(&ehp(b)).then(a.id.cmp(&b.id)));
            if let Some(t) = target {
                if u.order != (Order::Attack { target: t.id }) {
                    out.push(Action::new(u.id, Command::Attack { target: t.id }));
                }
                continue;
            }
            if u.pos.dist(self.anchor) > 3.0 {
                if u.order != (Order::Move { to: self.anchor }) {
                    out.push(Action::new(u.id, Command::MoveTo { to: self.anchor }));
                }
            } else if u.order != Order::Hold && !matches!(u.order, Order::Move { .. }) {
                out.push(Action::new(u.id, Command::Hold));
            }
        }
        out
    }
}
