//! What the PPO critic reads besides the agent id: the observation (IPPO), the global state
//! (MAPPO), or both (MAPPO with `critic_agent_obs`), and the rows it is fed.

use super::rollout::CriticRows;
use crate::Config;
use crate::buffer::Shape;

/// What the critic sees besides the agent id one-hot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CriticInput {
    /// The agent's own observation (IPPO: decentralised).
    Obs,
    /// The global state (MAPPO: centralised).
    State,
    /// The global state, then the agent's own observation (MAPPO with `critic_agent_obs`).
    StateObs,
}

impl CriticInput {
    pub fn of(cfg: &Config) -> CriticInput {
        match (cfg.algo.as_str(), cfg.critic_agent_obs) {
            ("mappo", false) => CriticInput::State,
            ("mappo", true) => CriticInput::StateObs,
            _ => CriticInput::Obs,
        }
    }
    /// The input's width: the observation or state, then the agent id's one-hot.
    pub fn width(self, shape: &Shape) -> usize {
        shape.n_agents + self.seen(shape)
    }
    /// The width of what the critic sees besides the id.
    fn seen(self, shape: &Shape) -> usize {
        match self {
            CriticInput::Obs => shape.obs,
            CriticInput::State => shape.state,
            CriticInput::StateObs => shape.state + shape.obs,
        }
    }
    /// The critic's input rows (`envs x agents`) of a vector step's observations and states,
    /// factored: the states (one per environment) or observations (one per row), and each
    /// row's index among them and agent id.
    pub fn rows(self, shape: &Shape, obs: &[f32], state: &[f32], envs: usize) -> CriticRows {
        let a = shape.n_agents.max(1);
        let rows = envs * shape.n_agents;
        let (table, idx) = match self {
            CriticInput::Obs => (obs[..rows * shape.obs].to_vec(), (0..rows as u32).collect()),
            CriticInput::State => (state[..envs * shape.state].to_vec(), (0..rows).map(|r| (r / a) as u32).collect()),
            // One row per agent: its environment's state, then its observation.
            CriticInput::StateObs => {
                let mut t = Vec::with_capacity(rows * (shape.state + shape.obs));
                for r in 0..rows {
                    t.extend_from_slice(&state[(r / a) * shape.state..(r / a + 1) * shape.state]);
                    t.extend_from_slice(&obs[r * shape.obs..(r + 1) * shape.obs]);
                }
                (t, (0..rows as u32).collect())
            }
        };
        CriticRows {
            table: std::sync::Arc::new(table),
            width: self.seen(shape),
            n_ids: shape.n_agents,
            idx,
            ids: (0..rows).map(|r| (r % a) as u32).collect(),
        }
    }
}
