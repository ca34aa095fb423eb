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
