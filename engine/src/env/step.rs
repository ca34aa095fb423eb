//! Stepping an episode: the opponent acts on its observation, the loops run, the step is
//! scored. Above the observations, which are built from an `Env` and for its opponent here.

use super::episode::{Env, Outcome, RewardMode, StepResult};
use crate::ids::Team;
use crate::obs::{GroupObs, Reads};
use crate::policy;

impl Env {
    /// Runs the opponent (PvE), then `step_mul` game loops, and scores the step. Stepping a
    /// finished episode does nothing and returns its outcome again.
    pub fn step(&mut self) -> StepResult {
        if let Some(o) = self.outcome {
            let truncated = self.truncated();
            return StepResult { reward: [0.0, 0.0], done: true, terminated: !truncated, truncated, outcome: Some(o) };
        }
        // The opponent sees what team 2's units observe, as any agent does.
        let mut actions = Vec::new();
        if let Some(mut p) = self.opponent.take() {
            actions = p.act(&GroupObs::team(self, Team::Two, 0, p.reads()));
            self.opponent = Some(p);
        }
        if self.builtin.as_ref().is_some_and(|ai| ai.started(self.world.tick())) && self.builtin_may_cast() {
            // The built-in AI's abilities, as the scripted agents use them.
            actions = policy::micro::ability_actions(&GroupObs::team(self, Team::Two, 0, Reads::UNITS), &self.scenario.terrain).0;
        }
        for a in &actions {
            // A scripted opponent's invalid action is its own bug, not the agent's: it is
            // dropped without counting against anyone.
            let _ = self.world.apply(Team::Two, a);
        }
        if let Some(ai) = self.builtin.as_mut() {
            ai.before_step(&mut self.world, &self.agents[Team::Two.index()], Team::Two);
        }
        let limit = self.time_limit_loops();
        for _ in 0..self.cfg.step_mul.get() {
            if let Some(ai) = self.builtin.as_mut() {
                ai.before_loop(&mut self.world, &self.agents[Team::Two.index()]);
            }
            self.world.step_loop();
            if self.terminal().is_some() || self.world.tick() >= limit {
                break;
            }
        }
        for team in Team::BOTH {
            let t = team.index();
            std::mem::swap(&mut self.last_actions[t], &mut self.pending_actions[t]);
            self.pending_actions[t].iter_mut().for_each(|a| *a = None);
        }
        self.steps += 1;
        let outcome = self.terminal().or_else(|| (self.world.tick() >= limit).then_some(Outcome::Draw));
        self.outcome = outcome;
        self.update_epo();
        self.trajectory.u64(self.state_hash());
        let reward = match self.cfg.reward {
            RewardMode::Sparse => outcome.map_or([0.0, 0.0], |o| [o.sparse_reward(), o.for_team(Team::Two).sparse_reward()]),
            RewardMode::Dense => self.dense_reward(outcome),
        };
        let truncated = self.truncated();
        StepResult { reward, done: outcome.is_some(), terminated: outcome.is_some() && !truncated, truncated, outcome }
    }

    /// Whether some unit of the built-in AI could cast now. Its ability use never acts
    /// otherwise, so the team's observation is built only when this holds: most steps of
    /// most scenarios, where no unit has a castable ability, stay as cheap as without it.
    fn builtin_may_cast(&self) -> bool {
        let w = &self.world;
        w.rules().abilities && w.alive(Team::Two).any(|u| u.kind.mode_abilities().any(|a| w.can_cast(u, a).is_ok()))
    }
}

impl Env {
    /// The most this episode's dense reward can pay `team` before scaling (SMAC's
    /// `max_reward`, which `reward_scale` divides by over its rate).
    pub fn max_reward(&self, team: Team) -> f32 {
        self.max_reward[team.index()]
    }

    /// SMAC's `max_reward` for `team`: `death_value` per enemy, their full life and
    /// shields, and `win`.
    pub(super) fn max_reward_of(&self, team: Team) -> f32 {
        let r = &self.cfg.dense_reward;
        let enemies = self.world.units().iter().filter(|u| u.team == team.other());
        enemies.map(|u| r.death_value + u.max_hp + u.max_shield).sum::<f32>() + r.win
    }

    /// One step's dense reward per team, and the bookkeeping moved on.
    pub(super) fn dense_reward(&mut self, outcome: Option<Outcome>) -> [f32; 2] {
        let r = self.cfg.dense_reward;
        // Per team: damage and kills dealt (SMAC's delta_enemy + delta_deaths), and its own
        // losses already scaled (its delta_ally, and the death penalty it takes out of
        // delta_deaths; only without reward_only_positive).
        let mut dealt = [0.0f32; 2];
        let mut lost = [0.0f32; 2];
        let neg = r.negative_scale.unwrap_or(0.0);
        for (i, u) in self.world.units().iter().enumerate() {
            if self.dense.dead[i] {
                continue;
            }
            let (owner, scorer) = (u.team.index(), u.team.other().index());
            let now = u.hp.max(0.0) + u.shield.max(0.0);
            let prev = self.dense.prev[i];
            if !u.alive {
                self.dense.dead[i] = true;
                dealt[scorer] += prev + r.death_value;
                lost[owner] += neg * (prev + r.death_value);
            } else {
                dealt[scorer] += prev - now;
                lost[owner] += neg * (prev - now);
            }
            self.dense.prev[i] = now;
        }
        let mut out = [0.0; 2];
        for team in Team::BOTH {
            let t = team.index();
            // Only positive: the absolute value, as SMAC takes it (shields coming back on the
            // enemy count as damage: oxwhirl/smac#72).
            let mut v = if r.negative_scale.is_none() { dealt[t].abs() } else { dealt[t] - lost[t] };
            match outcome.map(|o| o.for_team(team)) {
                Some(Outcome::Win) => v += r.win,
                Some(Outcome::Loss) => v += r.defeat,
                _ => {}
            }
            out[t] = match r.scale_rate {
                Some(rate) => v / (self.max_reward[t] / rate),
                None => v,
            };
        }
        out
    }
}
