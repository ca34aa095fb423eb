//! AVACraft's policy registry. Every place that names a policy — launch files, eval plans,
//! `avacraft episode --agent`, agent nodes, Python — resolves the name here
//! ([`PolicySpec::resolve`]) and makes agents from it here ([`PolicySpec::make`]): one parser,
//! one set of error messages, one factory, with AVA one policy among the others rather than a
//! special case at each call site.
//!
//! A checkpoint is read where it is named by default ([`Weights::Load`]), so a missing or
//! corrupt one is refused there instead of surfacing as a silent no-op agent once episodes
//! run; processes that never act (the simulator node, the bridge) name it with
//! [`Weights::Later`] and never read it.

mod checkpoint;
mod error;
mod make;
mod names;
mod spec;
#[cfg(test)]
mod tests;

pub use checkpoint::{BaselineSet, MarlCheckpoint, Weights};
pub use error::PolicyError;
pub use make::{AgentFactory, Calls, Made, ROTATE_EVERY};
pub use names::{AVA_POLICY, DDS_POLICY, MARL_PREFIX, ROTATE_POLICY};
pub use spec::{CommanderPolicy, PolicySpec, Resolve};
