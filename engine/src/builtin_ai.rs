//! Emulation of StarCraft II's built-in AI for the opponent side: the scenario's opening
//! order (at its delay), then the engine's own acquisition and threat rules, healers
//! autocasting, and one response a VeryHard AI always has: idle army units go after enemies
//! the team has seen, and the abilities a competent player uses (the scripted agents' ability
//! use, on the team's observation: see `Env::step`).

use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::scenario::{Scenario, StartOrder};
use crate::world::{Order, World};
use rand::Rng;

#[derive(Debug, Clone, Default)]
pub(crate) struct BuiltinAi {
    start: Option<(Vec2, u32)>,
    issued: bool,
}

impl BuiltinAi {
    /// Its state for [`crate::Env::state_hash`]: the opening and whether it was issued.
    pub(crate) fn hash(&self, h: &mut crate::hash::Fnv) {
        let BuiltinAi { start, issued } = self;
        match start {
            None => h.u32(0),
            Some((to, delay)) => {
                h.u32(1);
                h.vec2(*to);
                h.u32(*delay);
            }
        }
        h.u32(*issued as u32);
    }

    /// Draws the opening (the random point of `attack_move_random`) from the world's RNG.
    pub(crate) fn new(scenario: &Scenario, world: &mut World) -> Self {
        let start = match scenario.start {
            StartOrder::None => None,
            StartOrder::AttackMove { to, delay_loops } => Some((to, delay_loops)),
            StartOrder::AttackMoveRandom { from, to, delay_loops } => {
                let t: f32 = world.rng().random_range(0.0..=1.0);
                Some((from + (to - from) * t, delay_loops))
            }
        };
        Self { start, issued: false }
    }

    /// Called before every game loop: issues the opening order once it is due.
    pub(crate) fn before_loop(&mut self, world: &mut World, units: &[UnitId]) {
        let Some((to, delay)) = self.start else { return };
        if self.issued || world.tick() < delay {
            return;
        }
        for &id in units {
            if world.unit(id).is_some_and(|u| u.alive && u.speed > 0.0) {
                world.set_order(id, Order::AttackMove { to });
            }
        }
        self.issued = true;
    }

    /// Whether the opening's delay is over: the AI answers nothing before.
    pub(crate) fn started(&self, tick: u32) -> bool {
        self.start.is_none_or(|(_, delay)| tick >= delay)
    }

    /// Called before every step, after the AI's casts: idle mobile units attack-move to the
    /// closest enemy the team sees (the AI answers contact with its whole army instead of
    /// waiting to be picked off).
    pub(crate) fn before_step(&mut self, world: &mut World, units: &[UnitId], team: Team) {
        if !self.started(world.tick()) {
            return;
        }
        let seen: Vec<Vec2> = world.alive(team.other()).filter(|e| world.visible_to(team, e.id)).map(|e| e.pos).collect();
        if seen.is_empty() {
            return;
        }
        for &id in units {
            let Some(u) = world.unit(id) else { continue };
            if !u.alive || u.speed <= 0.0 || u.order != Order::Idle || u.target.is_some() {
                continue;
            }
            let to = seen.iter().copied().min_by(|a, b| a.dist_sq(u.pos).total_cmp(&b.dist_sq(u.pos)));
            if let Some(to) = to {
                world.set_order(id, Order::AttackMove { to });
            }
        }
    }
}
