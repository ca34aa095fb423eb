//! The crate's errors and the one Python exception they become. A leaf: every class
//! raises them, and the crate root registers the exception.

use avacraft_engine::ScenarioError;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    _avacraft,
    AvacraftError,
    PyValueError,
    "Bad input to an AVACraft environment (an unknown scenario or option, an action that cannot be taken, an array of the wrong shape). A subclass of ValueError."
);

/// An error of this crate; every one becomes an [`AvacraftError`] with its message.
#[derive(Debug, thiserror::Error)]
pub(crate) enum Error {
    #[error("unknown scenario `{name}`: not a scenario file, and not one of the built-in scenarios: {known}")]
    UnknownScenario { name: String, known: String },
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error(transparent)]
    Learn(#[from] avacraft_engine::LearnError),
    #[error(transparent)]
    Vec(#[from] avacraft_engine::VecEnvError),
    #[error("{option} = {value:?}: {supported}")]
    Option { option: &'static str, value: String, supported: String },
    #[error(transparent)]
    Video(#[from] avacraft_render::VideoError),
    #[error(transparent)]
    Policy(#[from] PolicyError),
}

impl From<Error> for PyErr {
    fn from(e: Error) -> PyErr {
        // The whole chain of sources, so nothing said by an inner error is lost.
        let mut msg = e.to_string();
        let mut src = std::error::Error::source(&e);
        while let Some(s) = src {
            let s_msg = s.to_string();
            if !msg.contains(&s_msg) {
                msg.push_str(": ");
                msg.push_str(&s_msg);
            }
            src = s.source();
        }
        AvacraftError::new_err(msg)
    }
}

/// Why a checkpoint cannot act here: the policy registry's refusals (the same words as
/// `episode --agent marl:DIR` and launch files), and the arrays Python hands it.
#[derive(Debug, thiserror::Error)]
pub(crate) enum PolicyError {
    #[error(transparent)]
    Registry(Box<avacraft_policy::PolicyError>),
    #[error("{what}: shape {given:?} given, {needed:?} needed (n_agents x {what_size})")]
    Shape { what: &'static str, given: Vec<usize>, needed: [usize; 2], what_size: &'static str },
    #[error("avail[{agent}]: no action is available (a dead agent has the no-op, 0)")]
    NoAction { agent: usize },
    #[error("the network")]
    Network(#[source] Box<avacraft_marl::Error>),
    #[error(
        "{dir}: trained on `{obs}` observations, which {method} is not handed: the network reads frames \
         rendered from the game; act_env(env) renders them and plays team 1"
    )]
    NeedsFrames { dir: String, obs: &'static str, method: &'static str },
    #[error("{dir}: an `{obs}` checkpoint plays team 1 of a PvE scenario from rendered frames; {scenario} is PvP")]
    FramesPvp { dir: String, obs: &'static str, scenario: String },
}

impl From<avacraft_policy::PolicyError> for PolicyError {
    fn from(e: avacraft_policy::PolicyError) -> PolicyError {
        PolicyError::Registry(Box::new(e))
    }
}

impl From<PolicyError> for PyErr {
    fn from(e: PolicyError) -> PyErr {
        Error::Policy(e).into()
    }
}
