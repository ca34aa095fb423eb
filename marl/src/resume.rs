//! Resuming a run from its output directory. At every test round the trainer writes, next to
//! the checkpoint, `resume/state.json` (step and episode counters, the test history, the
//! positions of its random streams, the elapsed time; for PPO the value normaliser's
//! statistics) and, for the Q-learners, the target networks' weights. A resumed run loads
//! those and the checkpoint's weights (PPO: actor and critic) and goes on from that test
//! round: the log and the curves continue, epsilon and the target copies keep their schedule,
//! and the environments start fresh episodes (from seeds past the ones already played).
//!
//! Not kept, so a resumed run is not bit-identical to an uninterrupted one: the replay
//! buffer (it refills; up to `buffer_size` episodes of tens of MB), the optimiser's moment
//! estimates, the episodes that were running at the checkpoint and, for PPO, the unfinished
//! rollout.

use crate::learner::Learner;
use crate::nets::Nets;
use crate::plot::CurvePoint;
use crate::policy::TestResult;
use crate::ppo::{PpoLearner, ValueNorm};
use crate::{Config, Error};
use candle_core::Device;
use serde::{Deserialize, Serialize};
use std::path::Path;

const FORMAT: u32 = 1;

/// Where a run was at its last test round.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunState {
    format: u32,
    pub seed: u64,
    pub t_env: u64,
    pub episodes: u64,
    pub updates: u64,
    pub test_round: u64,
    pub last_target_update: u64,
    /// Word positions of the acting and sampling streams (decimal: JSON numbers are f64 to
    /// many readers).
    pub act_rng: String,
    pub sample_rng: String,
    pub elapsed_s: f64,
    pub tests: Vec<TestResult>,
    pub curve: Vec<CurvePoint>,
    /// PPO's return statistics (absent for the Q-learners).
    #[serde(default)]
    pub value_norm: Option<ValueNorm>,
}

impl RunState {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        seed: u64,
        t_env: u64,
        episodes: u64,
        test_round: u64,
        updates: (u64, u64),
        rngs: (u128, u128),
        elapsed_s: f64,
        tests: &[TestResult],
        curve: &[CurvePoint],
    ) -> RunState {
        RunState {
            format: FORMAT,
            seed,
            t_env,
            episodes,
            updates: updates.0,
            test_round,
            last_target_update: updates.1,
            act_rng: rngs.0.to_string(),
            sample_rng: rngs.1.to_string(),
            elapsed_s,
            tests: tests.to_vec(),
            curve: curve.to_vec(),
            value_norm: None,
        }
    }

    pub(crate) fn rng_positions(&self) -> Result<(u128, u128), Error> {
        let parse = |s: &str| {
            s.parse::<u128>().map_err(|e| Error::Checkpoint { message: format!("resume/state.json: stream position `{s}`: {e}") })
        };
        Ok((parse(&self.act_rng)?, parse(&self.sample_rng)?))
    }

    /// Writes the state and the target networks, if any, into `dir/resume` (the online
    /// networks are the checkpoint in `dir`).
    pub(crate) fn save(&self, dir: &Path, target: Option<&Nets>) -> Result<(), Error> {
        let d = dir.join("resume");
        std::fs::create_dir_all(&d).map_err(|source| Error::Io { path: d.clone(), source })?;
        if let Some(target) = target {
            candle_core::safetensors::save(&target.agent_params.to_map(), d.join("target_agent.safetensors"))?;
            let mixer = target.mixer_params.to_map();
            if !mixer.is_empty() {
                candle_core::safetensors::save(&mixer, d.join("target_mixer.safetensors"))?;
            }
        }
        let path = d.join("state.json");
        let text = serde_json::to_string_pretty(self).map_err(|source| Error::Json { path: path.clone(), source })?;
        // Written aside and renamed, so an interrupted write never leaves half a state.
        let tmp = d.join("state.json.tmp");
        std::fs::write(&tmp, text).map_err(|source| Error::Io { path: tmp.clone(), source })?;
        std::fs::rename(&tmp, &path).map_err(|source| Error::Io { path, source })
    }
}

/// The config and state of the run in `dir`, to go on with [`crate::train::train_from`].
pub fn load(dir: &Path) -> Result<(Config, RunState), Error> {
    let policy = crate::Policy::load(dir)?;
    let path = dir.join("resume").join("state.json");
    let text = std::fs::read_to_string(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
    let state: RunState = serde_json::from_str(&text).map_err(|source| Error::Json { path: path.clone(), source })?;
    if state.format != FORMAT {
        return Err(Error::Checkpoint { message: format!("{}: format {} (this build reads {FORMAT})", path.display(), state.format) });
    }
    if policy.cfg.is_ppo() && state.value_norm.is_none() {
        return Err(Error::Checkpoint {
            message: format!("{}: a {} run's state has no value statistics", path.display(), policy.cfg.algo),
        });
    }
    Ok((policy.cfg, state))
}

fn load_tensors(path: &Path) -> Result<std::collections::HashMap<String, candle_core::Tensor>, Error> {
    if !path.is_file() {
        return Err(Error::Checkpoint { message: format!("{} is missing", path.display()) });
    }
    Ok(candle_core::safetensors::load(path, &Device::Cpu)?)
}

/// Loads the checkpoint's actor and critic and the state's value statistics into `learner`.
pub(crate) fn restore_ppo(dir: &Path, learner: &mut PpoLearner, state: &RunState) -> Result<(), Error> {
    let policy = crate::Policy::load(dir)?;
    learner.actor.agent_params.copy_from(&policy.nets.agent_params)?;
    learner.critic_params.load_map(&load_tensors(&dir.join("critic.safetensors"))?, "critic.safetensors")?;
    learner.value_norm = state
        .value_norm
        .clone()
        .ok_or_else(|| Error::Checkpoint { message: format!("{}: no value statistics to resume from", dir.display()) })?;
    learner.updates = state.updates;
    learner.load_weights()
}

/// Loads the checkpoint's and the saved targets' weights into `learner`.
pub(crate) fn restore(dir: &Path, learner: &mut Learner, state: &RunState) -> Result<(), Error> {
    let policy = crate::Policy::load(dir)?;
    if learner.nets.mixer_params.vars().next().is_some() && !dir.join("mixer.safetensors").is_file() {
        return Err(Error::Checkpoint {
            message: format!("{}: no mixer.safetensors to resume from (a shipped policy only acts)", dir.display()),
        });
    }
    learner.nets.agent_params.copy_from(&policy.nets.agent_params)?;
    learner.nets.mixer_params.copy_from(&policy.nets.mixer_params)?;
    let d = dir.join("resume");
    let load = |name: &str| load_tensors(&d.join(name));
    learner.target.agent_params.load_map(&load("target_agent.safetensors")?, "target_agent.safetensors")?;
    if learner.target.mixer_params.vars().next().is_some() {
        learner.target.mixer_params.load_map(&load("target_mixer.safetensors")?, "target_mixer.safetensors")?;
    }
    learner.updates = state.updates;
    learner.last_target_update = state.last_target_update;
    learner.reload()
}
