//! `avacraft._avacraft`: the compiled half of the Python package. It holds AVACraft's engine
//! (one environment, a threaded vector environment), hands observations out as numpy arrays
//! and checks every input, so a mistake in Python becomes a Python exception naming what is
//! wrong, never a Rust panic. The SMAC, PettingZoo and vector-environment interfaces users
//! see are thin pure-Python wrappers over it (`python/avacraft/`). Trained MARL policies
//! (`avacraft train`'s checkpoints) act from Python through `marl.rs`.
//!
//! pyo3's `#[pyclass]`, `#[pymethods]` and `#[pymodule]` macros expand to `unsafe` FFI glue,
//! so this crate alone allows `unsafe_code` (the workspace denies it; every other crate
//! forbids it). None is written by hand here.
#![allow(unsafe_code)]

mod ava;
mod convert;
mod env;
mod marl;
mod vec;

use avacraft_engine::{EnvConfig, OpponentKind, RewardMode, Scenario, ScenarioError, builtin_names};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::num::NonZeroU32;
use std::sync::Arc;

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
    Policy(#[from] marl::PolicyError),
    #[error(transparent)]
    Baseline(#[from] avacraft_marl::baselines::BaselineError),
}

/// The folder of the shipped baseline `name` (`qmix`, `mappo`, ...) of `scenario`: what
/// `baseline:NAME` names in `avacraft episode --agent` and the eval and launch files.
#[pyfunction]
#[pyo3(signature = (scenario, name="qmix"))]
fn baseline_dir(scenario: &str, name: &str) -> PyResult<String> {
    let scenario = load_scenario(scenario)?;
    let dir = avacraft_marl::baselines::dir(&avacraft_marl::baselines::root(), &scenario.name, name).map_err(Error::from)?;
    Ok(dir.to_string_lossy().into_owned())
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

/// A built-in scenario by name or a scenario TOML file by path.
pub(crate) fn load_scenario(name: &str) -> Result<Arc<Scenario>, Error> {
    match Scenario::load(name) {
        Ok(s) => Ok(Arc::new(s)),
        Err(ScenarioError::Unknown(name)) => Err(Error::UnknownScenario { name, known: builtin_names().collect::<Vec<_>>().join(", ") }),
        Err(e) => Err(e.into()),
    }
}

/// The engine options Python passes (already named and checked by the wrapper; checked
/// again here, since `_avacraft` can be used directly).
#[derive(Clone, Debug)]
pub(crate) struct Options {
    pub step_mul: u32,
    pub reward: String,
    pub opponent: Option<String>,
    pub full_vision: bool,
    pub passive_allies: bool,
    pub cooldown_jitter: bool,
    pub abilities: bool,
    pub ability_actions: bool,
    pub time_limit_loops: Option<u32>,
}

impl Options {
    pub fn config(&self) -> Result<EnvConfig, Error> {
        let mut cfg = if self.passive_allies { EnvConfig::smac() } else { EnvConfig::default() };
        cfg.step_mul = NonZeroU32::new(self.step_mul).ok_or_else(|| Error::Option {
            option: "step_mul",
            value: self.step_mul.to_string(),
            supported: "game loops per step: 1 or more".into(),
        })?;
        cfg.reward = match self.reward.as_str() {
            "dense" => RewardMode::Dense,
            "sparse" => RewardMode::Sparse,
            other => {
                return Err(Error::Option { option: "reward", value: other.into(), supported: "one of: dense, sparse".into() });
            }
        };
        cfg.opponent = match self.opponent.as_deref() {
            None => None,
            Some(o) => {
                Some(o.parse::<OpponentKind>().map_err(|why| Error::Option { option: "opponent", value: o.into(), supported: why })?)
            }
        };
        cfg.rules.full_vision = self.full_vision;
        cfg.rules.cooldown_jitter = self.cooldown_jitter;
        cfg.rules.abilities = self.abilities;
        cfg.ability_actions = self.ability_actions;
        cfg.time_limit_loops = match self.time_limit_loops {
            None => None,
            Some(t) => Some(NonZeroU32::new(t).ok_or_else(|| Error::Option {
                option: "time_limit_loops",
                value: t.to_string(),
                supported: "a time limit of 1 game loop or more".into(),
            })?),
        };
        Ok(cfg)
    }
}

/// The built-in scenarios' names.
#[pyfunction]
fn scenario_names() -> Vec<&'static str> {
    builtin_names().collect()
}

/// A scenario's summary: name, mode ("pve"/"pvp"), units per team, time limit in loops.
#[pyfunction]
fn scenario_info(py: Python<'_>, scenario: &str) -> PyResult<Py<PyAny>> {
    let s = load_scenario(scenario)?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("name", &s.name)?;
    d.set_item("mode", if s.mode == avacraft_engine::Mode::Pvp { "pvp" } else { "pve" })?;
    d.set_item("units", (s.count(avacraft_engine::Team::One), s.count(avacraft_engine::Team::Two)))?;
    d.set_item("time_limit_loops", s.time_limit_loops)?;
    Ok(d.into_any().unbind())
}

#[pymodule]
fn _avacraft(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("AvacraftError", m.py().get_type::<AvacraftError>())?;
    m.add_class::<env::PyEnv>()?;
    m.add_class::<env::PySnapshot>()?;
    m.add_class::<vec::PyVecEnv>()?;
    m.add_class::<marl::PyMarlPolicy>()?;
    m.add_class::<ava::PyAva>()?;
    m.add_function(wrap_pyfunction!(scenario_names, m)?)?;
    m.add_function(wrap_pyfunction!(scenario_info, m)?)?;
    m.add_function(wrap_pyfunction!(baseline_dir, m)?)?;
    m.add_function(wrap_pyfunction!(vec::rust_loop_steps_per_s, m)?)?;
    Ok(())
}
