//! What learners need from one environment: every agent's observation, mask and the state
//! written into contiguous buffers the caller owns (no allocation per step), SMAC's step
//! info, and SMAC-index steps that report what was wrong with an action before anything is
//! applied.

use crate::env::{Env, StepResult};
use crate::ids::Team;
use serde::Serialize;

/// SMAC's `info` for one step, from one team's side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct StepInfo {
    pub battle_won: bool,
    /// The team's agents that have died this episode.
    pub dead_allies: u32,
    /// The other team's units that have died this episode.
    pub dead_enemies: u32,
    /// The episode ended at its time limit (SMAC sets this key only then).
    pub episode_limit: bool,
}

/// An action a learner gave that cannot be applied: nothing of the step was applied.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LearnError {
    #[error("{given} actions given for {agents} agents")]
    Count { given: usize, agents: usize },
    #[error("agent {agent}: action {index} is out of range (0..{n_actions})")]
    OutOfRange { agent: usize, index: i64, n_actions: usize },
    #[error("agent {agent}: action {index} is not available now (available: {available:?})")]
    Unavailable { agent: usize, index: usize, available: Vec<usize> },
    #[error("buffer `{name}` has {len} elements, {needed} needed")]
    Buffer { name: &'static str, len: usize, needed: usize },
}

fn check(name: &'static str, len: usize, needed: usize) -> Result<(), LearnError> {
    if len == needed { Ok(()) } else { Err(LearnError::Buffer { name, len, needed }) }
}

/// Checks one SMAC index per agent against flat masks (`n_agents * n_actions`): the masks a
/// learner was handed, so a vector environment checks without recomputing them.
pub(crate) fn check_against_masks(indices: &[i64], masks: &[u8], n_agents: usize, n_actions: usize) -> Result<(), LearnError> {
    if indices.len() != n_agents {
        return Err(LearnError::Count { given: indices.len(), agents: n_agents });
    }
    for (agent, &index) in indices.iter().enumerate() {
        let Some(i) = usize::try_from(index).ok().filter(|&i| i < n_actions) else {
            return Err(LearnError::OutOfRange { agent, index, n_actions });
        };
        let mask = &masks[agent * n_actions..(agent + 1) * n_actions];
        if mask[i] == 0 {
            let available = mask.iter().enumerate().filter(|(_, m)| **m == 1).map(|(k, _)| k).collect();
            return Err(LearnError::Unavailable { agent, index: i, available });
        }
    }
    Ok(())
}

impl Env {
    /// SMAC's info for `team` now.
    pub fn info(&self, team: Team) -> StepInfo {
        let w = self.world();
        let dead = |t: Team| w.units().iter().filter(|u| u.team == t && !u.alive).count() as u32;
        let dead_allies = self.agents(team).iter().filter(|id| w.unit(**id).is_none_or(|u| !u.alive)).count() as u32;
        StepInfo {
            battle_won: self.outcome().is_some_and(|o| o.for_team(team) == crate::env::Outcome::Win),
            dead_allies,
            dead_enemies: dead(team.other()),
            episode_limit: self.truncated(),
        }
    }

    /// Every agent's feature vector, agent after agent (`n_agents * obs_shape`).
    pub fn obs_all(&self, team: Team, out: &mut [f32]) -> Result<(), LearnError> {
        let l = self.smac_layout(team);
        check("obs", out.len(), l.n_agents * l.obs_size)?;
        for (agent, o) in out.chunks_exact_mut(l.obs_size.max(1)).enumerate().take(l.n_agents) {
            self.obs_agent(team, agent, o);
        }
        Ok(())
    }

    /// Every agent's action mask, agent after agent (`n_agents * n_actions`).
    pub fn avail_all(&self, team: Team, out: &mut [u8]) -> Result<(), LearnError> {
        let l = self.smac_layout(team);
        check("avail_actions", out.len(), l.n_agents * l.n_actions)?;
        for (agent, o) in out.chunks_exact_mut(l.n_actions.max(1)).enumerate().take(l.n_agents) {
            self.avail_agent(team, agent, o);
        }
        Ok(())
    }

    /// The global state (`state_shape`), checked for size.
    pub fn state_into(&self, team: Team, out: &mut [f32]) -> Result<(), LearnError> {
        check("state", out.len(), self.smac_layout(team).state_size)?;
        self.state(team, out);
        Ok(())
    }

    /// Checks one SMAC index per agent of `team` against the masks, applying nothing.
    pub fn check_indices(&self, team: Team, indices: &[i64]) -> Result<(), LearnError> {
        let l = self.smac_layout(team);
        let mut masks = vec![0u8; l.n_agents * l.n_actions];
        self.avail_all(team, &mut masks)?;
        check_against_masks(indices, &masks, l.n_agents, l.n_actions)
    }
    /// SMAC's `step(actions)` for team 1 (team 2 too in PvP with `team2`): every index is
    /// checked first, so a bad one leaves the episode untouched.
    pub fn step_indices(&mut self, team1: &[i64], team2: Option<&[i64]>) -> Result<StepResult, LearnError> {
        self.check_indices(Team::One, team1)?;
        if let Some(t2) = team2 {
            self.check_indices(Team::Two, t2)?;
        }
        let as_usize = |v: &[i64]| v.iter().map(|&i| i as usize).collect::<Vec<_>>();
        self.submit_indices(Team::One, &as_usize(team1));
        if let Some(t2) = team2 {
            self.submit_indices(Team::Two, &as_usize(t2));
        }
        Ok(self.step())
    }
}
