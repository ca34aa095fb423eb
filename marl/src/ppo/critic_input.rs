//! What the PPO critic reads besides the agent id: the observation (IPPO), the global state
//! (MAPPO), or both (MAPPO with `critic_agent_obs`), or the agent's own row of the
//! agent-specific state (MAPPO with `state_agent`), and the rows it is fed.

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
    /// The agent's own row of the agent-specific state (MAPPO with `state_agent`: the
    /// environment's state is every agent's row, one after another), in each of `frames`
    /// stacked steps.
    AgentState { frames: usize },
}

impl CriticInput {
    pub fn of(cfg: &Config) -> CriticInput {
        match (cfg.algo.as_str(), cfg.critic_agent_obs, cfg.state_agent) {
            ("mappo", _, true) => CriticInput::AgentState { frames: cfg.stacked_frames.max(1) },
            ("mappo", false, false) => CriticInput::State,
            ("mappo", true, false) => CriticInput::StateObs,
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
            CriticInput::AgentState { .. } => shape.state / shape.n_agents.max(1),
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
            // One row per agent: its slice of each stacked step's state.
            CriticInput::AgentState { frames } => {
                let (step, w) = (shape.state / frames.max(1), shape.state / (frames.max(1) * a));
                debug_assert_eq!(step * frames.max(1), shape.state, "a stacked state is whole steps");
                debug_assert_eq!(w * a, step, "an agent-specific state is whole rows");
                let mut t = Vec::with_capacity(rows * w * frames);
                for r in 0..rows {
                    let env = &state[(r / a) * shape.state..(r / a + 1) * shape.state];
                    for f in 0..frames {
                        let from = f * step + (r % a) * w;
                        t.extend_from_slice(&env[from..from + w]);
                    }
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
