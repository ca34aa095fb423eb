//! The simulator node. It owns the one `Env` of a deployment, publishes each agent-team
//! unit's observation, each team's view and the episode status every step, and takes
//! actions from the agent nodes: a unit accepts actions only from the agent node that owns
//! it, so decentralised execution is physical. Lockstep clock: a step advances when every
//! live owned unit's action for it has arrived, or at the deadline (a missing action is a
//! no-op, counted). Real-time clock: 22.4 game loops per wall second, actions applied as
//! they arrive.
#![forbid(unsafe_code)]

mod command;
mod config;
mod convert;
mod node;
mod session;

pub use config::{Clock, FrameSpec, SimConfig, TeamCommand};
pub use convert::{BadAction, action_from_msg, header, unit_state};
pub use node::{EpisodeSummary, RoundTripParts, SimError, result_code, run, run_watched};
pub use session::{SessionError, env_config, scenario, session_info};
