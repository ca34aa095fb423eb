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
mod error;
mod marl;
mod options;
mod vec;

use error::{AvacraftError, Error, PolicyError};
use options::load_scenario;
use pyo3::prelude::*;

/// The folder of the shipped baseline `name` (`qmix`, `mappo`, ...) of `scenario`: what
/// `baseline:NAME` names in `avacraft episode --agent` and the eval and launch files.
#[pyfunction]
#[pyo3(signature = (scenario, name="qmix"))]
fn baseline_dir(scenario: &str, name: &str) -> PyResult<String> {
    let scenario = load_scenario(scenario)?;
    let name = format!("{}{name}", avacraft_marl::baselines::BASELINE_PREFIX);
    let policy =
        avacraft_policy::PolicySpec::parse(&name, None).and_then(|p| p.on(&scenario)).map_err(PolicyError::from).map_err(Error::from)?;
    let avacraft_policy::PolicySpec::Marl(m) = policy else { unreachable!("a baseline resolves to its checkpoint") };
    Ok(m.dir().to_string_lossy().into_owned())
}

/// The built-in scenarios' names: the paper's 21, SMAC's 23 maps, then the procedural ones.
#[pyfunction]
fn scenario_names() -> Vec<&'static str> {
    avacraft_engine::all_names().collect()
}

/// The environment options both constructors take, in order, and their defaults (JSON): the
/// engine's `EnvOptions`, which the constructors' keyword arguments must match.
#[pyfunction]
fn env_options() -> (Vec<&'static str>, String) {
    let defaults = serde_json::to_string(&avacraft_engine::EnvOptions::default()).unwrap_or_default();
    (avacraft_engine::EnvOptions::NAMES.to_vec(), defaults)
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
    // Procedural scenarios: the unit types each unit is drawn from, in type-bit order.
    let drawn: Option<Vec<&str>> = s.generator.as_ref().map(|g| g.kinds().map(|k| k.name()).collect());
    d.set_item("drawn_types", drawn)?;
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
    m.add_function(wrap_pyfunction!(env_options, m)?)?;
    m.add_function(wrap_pyfunction!(baseline_dir, m)?)?;
    m.add_function(wrap_pyfunction!(vec::rust_loop_steps_per_s, m)?)?;
    Ok(())
}
