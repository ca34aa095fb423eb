//! AVA from Python: `avacraft.Ava(...)` builds the same [`AvaSpec`] a launch file's `ava:`
//! block or `avacraft episode --agent ava` builds, and plays episodes with the Rust agent,
//! so a Python run asks the model exactly what the command line asks and records the same
//! calls (replayable with `model={"kind": "replay", ...}`).

use crate::env::PyEnv;
use crate::error::AvacraftError;
use avacraft_ava::{AvaRun, AvaSpec};
use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Mode, Team};
use avacraft_policy::{AVA_POLICY, AgentFactory, Calls, PolicySpec, Resolve};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// The AVA agent with its settings and its run (model, recording, accounting).
#[pyclass(module = "avacraft._avacraft", name = "Ava", subclass)]
pub struct PyAva {
    spec: AvaSpec,
    /// Made by the policy registry, as `--agent ava` and launch files make it.
    make: AgentFactory,
    run: Arc<AvaRun>,
}

impl std::fmt::Debug for PyAva {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PyAva").field("model", &self.spec.model.label()).finish_non_exhaustive()
    }
}

fn err(e: impl std::fmt::Display) -> PyErr {
    AvacraftError::new_err(e.to_string())
}

#[pymethods]
impl PyAva {
    /// `spec_json`: an AVA spec as JSON (`{"model": {...}, "config": {...}, "record": ...}`,
    /// the launch file's `ava:` block); `record` overrides its recording folder.
    #[new]
    #[pyo3(signature = (spec_json, record=None))]
    fn new(spec_json: &str, record: Option<PathBuf>) -> PyResult<Self> {
        let mut spec: AvaSpec = serde_json::from_str(spec_json).map_err(|e| err(format!("AVA settings: {e}")))?;
        if record.is_some() {
            spec.record = record;
        }
        let made = PolicySpec::resolve(AVA_POLICY, Some(spec.clone()), Resolve::default())
            .and_then(|p| p.make(&Calls::Own, None))
            .map_err(|e| {
                let mut msg = e.to_string();
                let mut src = std::error::Error::source(&e);
                while let Some(s) = src {
                    msg.push_str(&format!(": {s}"));
                    src = s.source();
                }
                err(msg)
            })?;
        let run = made.run.ok_or_else(|| err("an AVA policy is made with its run"))?;
        Ok(Self { spec, make: made.factory, run })
    }

    /// The settings as JSON (the key is never part of them).
    fn spec_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.spec).map_err(err)
    }

    /// Plays one episode of `env` from `seed` with AVA as `team` (team 1 in PvE; in PvP the
    /// other team holds still unless another agent drives it), leaving `env` at its end.
    /// Returns `{"result", "steps", "trajectory_hash", "cost"}`, `cost` being this episode's
    /// accounting as JSON. Raises when a replay no longer matches its recording or the
    /// recording cannot be written.
    #[pyo3(signature = (env, seed, team=1))]
    fn play<'py>(&self, py: Python<'py>, env: &Bound<'py, PyEnv>, seed: u64, team: u8) -> PyResult<Bound<'py, PyDict>> {
        let team = crate::env::team(team)?;
        let mut e = env.borrow_mut();
        let env = e.engine();
        if env.scenario().mode == Mode::Pve && team == Team::Two {
            return Err(err("team 2 of a PvE scenario is the opponent's"));
        }
        let make = Arc::clone(&self.make);
        let mut side = AgentTeam::new(team, Grouping::Team, move || make());
        // The agent opens its episode's accounting at reset.
        let before = self.run.episodes().len();
        env.reset(seed);
        side.reset(env);
        let run = &self.run;
        // Without the GIL while the model thinks: other Python threads (a server answering
        // on loopback, a progress display) keep running.
        let fatal = py.detach(|| {
            while !env.done() {
                let actions = side.act(env, 0);
                env.submit(team, &actions);
                env.step();
                if let Some(why) = run.fatal() {
                    return Some(why);
                }
            }
            None
        });
        if let Some(why) = fatal {
            return Err(err(format!("AVA stopped: {why}")));
        }
        let d = crate::marl::episode_result(py, env, team)?;
        let cost = self.run.episodes().get(before).cloned().unwrap_or_default();
        d.set_item("cost", serde_json::to_string(&cost).map_err(err)?)?;
        Ok(d)
    }

    /// Every episode's accounting so far, as JSON.
    fn costs_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.run.episodes()).map_err(err)
    }

    fn __repr__(&self) -> String {
        format!("Ava(model={:?})", self.spec.model.label())
    }
}
