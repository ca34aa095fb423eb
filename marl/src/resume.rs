//! Resuming a run from its output directory. At every test round the trainer writes, next to
//! the checkpoint, `resume/state.json` (step and episode counters, the test history, the
//! positions of its random streams, the elapsed time; for PPO the value normaliser's
//! statistics) and, for the Q-learners, the target networks' weights. A resumed run loads
//! those and the checkpoint's weights (PPO: actor and critic) and goes on from that test
//! round: the log and the curves continue, epsilon and the target copies keep their schedule,
//! and the environments start fresh episodes (from seeds past the ones already played).
//!
//! A test round's resume files (the online networks' weights as the checkpoint then held them,
//! the `best/` checkpoint as the round left it, the targets, the optimisers, the carry) go
//! into a folder of their own,
//! `resume/round-NNNNNN/`, and `state.json`, written last and renamed into place, names it; the
//! folder of the round before is removed only after. A run killed anywhere in a checkpoint
//! therefore resumes from one round's files, all of them: before, the checkpoint's weights
//! could be a round newer than the state (a kill between the two), and the resumed run was
//! no longer the uninterrupted one. States written before keep their files in `resume/` and
//! the weights in the checkpoint, and are read as they were.
//!
//! The optimisers' running states (Adam's moments and step count, RMSprop's averages) are
//! kept too, in the round's `optim.safetensors`: a fresh Adam's bias correction makes its first
//! steps full-size, which jolted a resumed policy. A run saved before they were kept resumes
//! with fresh optimisers, as it did then.
//!
//! In `features` mode the run also keeps what it carries between steps ([`crate::carry`]:
//! where each environment's episode stands, the episodes or the rollout under way, the
//! hidden states) and the Q-learners' replay buffer ([`crate::journal`]), so a resumed run
//! goes on exactly as the uninterrupted one: the same log, row for row. Not kept, so a
//! resumed run in an image mode is not identical to an uninterrupted one: the stored frames
//! (the buffer refills, the episodes under way start afresh), and the optimisers of QTRAN and
//! of PPO's Swin encoder (candle's).

use crate::evaluation::TestResult;
use crate::kernels::Moments;
use crate::learner::Learner;
use crate::nets::Nets;
use crate::plot::CurvePoint;
use crate::value_norm::ValueNorm;
use crate::{Config, Error};
use candle_core::Device;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// 2 since a state names its round's folder (`files`): a build that reads 1 would look for
/// the files where states of format 1 kept them, gone, and miss the optimisers' quietly.
const FORMAT: u32 = 2;
/// States of format 1, still read.
const FORMAT_FLAT: u32 = 1;

/// The optimisers' states, in a round's folder.
pub(crate) const OPTIM_FILE: &str = "optim.safetensors";

/// The checkpoint's files a round's resume folder keeps (hard links: the next checkpoint
/// renames new files over the checkpoint's, and the round keeps its own). The config too: a
/// resume under another game (`--set`) rewrites the checkpoint's at its first round, and
/// whether the round's episodes may be replayed is a question about the game they were
/// played in.
const KEPT: [&str; 4] = ["agent.safetensors", "mixer.safetensors", "critic.safetensors", "config.json"];

const ROUND_PREFIX: &str = "round-";

/// A fresh folder for test round `round`'s resume files in `dir/resume`, holding the
/// checkpoint's weights as they are now (the round's): what [`RunState::save`] then names.
pub(crate) fn begin_round(dir: &Path, round: u64) -> Result<std::path::PathBuf, Error> {
    let files = dir.join("resume").join(format!("{ROUND_PREFIX}{round:06}"));
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    // Left by a kill before its state was written: never named, so nothing reads it.
    if files.exists() {
        std::fs::remove_dir_all(&files).map_err(io(&files))?;
    }
    std::fs::create_dir_all(&files).map_err(io(&files))?;
    link_kept(dir, &files)?;
    // The monitor has just picked `best/` for this round: kept with it, so a resume from this
    // round finds the pick the round made (see `restore_best`).
    let best = dir.join(BEST);
    if best.join("config.json").is_file() {
        let kept = files.join(BEST);
        std::fs::create_dir_all(&kept).map_err(io(&kept))?;
        link_kept(&best, &kept)?;
    }
    Ok(files)
}

/// A checkpoint's best-test copy, beside it.
const BEST: &str = "best";

/// Hard-links (copies where links fail) the checkpoint files [`KEPT`] in `from` into `to`.
fn link_kept(from: &Path, to: &Path) -> Result<(), Error> {
    for name in KEPT {
        let (src, dst) = (from.join(name), to.join(name));
        if src.is_file() && std::fs::hard_link(&src, &dst).is_err() {
            std::fs::copy(&src, &dst).map_err(|source| Error::Io { path: dst.clone(), source })?;
        }
    }
    Ok(())
}

/// Puts back the `best/` checkpoint that the round `state` names kept. The monitor rewrites
/// `best/` before the round's state is written: a run killed in between has a `best/` from a
/// round its state does not have (or half written), which a resume in a mode that does not
/// replay exactly (images, self-play) would keep, though its log never showed that round.
/// Rounds written before they kept `best/` leave it as it is.
pub(crate) fn restore_best(dir: &Path, state: &RunState) -> Result<(), Error> {
    let kept = state.files(dir).join(BEST);
    if state.files.is_none() || !kept.join("config.json").is_file() {
        return Ok(());
    }
    let best = dir.join(BEST);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    std::fs::create_dir_all(&best).map_err(io(&best))?;
    for name in KEPT {
        let (from, to) = (kept.join(name), best.join(name));
        if !from.is_file() {
            match std::fs::remove_file(&to) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(Error::Io { path: to, source: e }),
                _ => continue,
            }
        }
        // Beside, then renamed over: a kill here leaves either file whole.
        let tmp = crate::aside::aside(&to);
        let _ = std::fs::remove_file(&tmp);
        if std::fs::hard_link(&from, &tmp).is_err() {
            std::fs::copy(&from, &tmp).map_err(io(&tmp))?;
        }
        std::fs::rename(&tmp, &to).map_err(io(&to))?;
        // Left where `to` already was the kept file (a rename between two links of one file
        // does nothing).
        let _ = std::fs::remove_file(&tmp);
    }
    Ok(())
}

/// Writes named optimiser states into `files`, a round's resume folder (aside, then renamed).
pub(crate) fn save_moments(files: &Path, moments: &[(&str, Moments)]) -> Result<(), Error> {
    std::fs::create_dir_all(files).map_err(|source| Error::Io { path: files.to_path_buf(), source })?;
    let mut map = std::collections::HashMap::new();
    for (name, m) in moments {
        for (i, v) in m.vectors.iter().enumerate() {
            map.insert(format!("{name}.{i}"), candle_core::Tensor::from_slice(v, v.len(), &Device::Cpu)?);
        }
        map.insert(format!("{name}.steps"), candle_core::Tensor::new(&[f64::from(m.steps)], &Device::Cpu)?);
    }
    crate::aside::tensors(&map, &files.join(OPTIM_FILE))
}

/// The optimiser states saved in `files` (a state's [`RunState::files`]), by name, shaped like
/// `like`'s; `None` for a run saved before they were kept.
pub(crate) fn load_moments(files: &Path, like: &[(&str, Moments)]) -> Result<Option<Vec<Moments>>, Error> {
    let path = files.join(OPTIM_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let map = load_tensors(&path)?;
    let bad = |what: String| Error::Checkpoint { message: format!("{}: {what}", path.display()) };
    let mut out = Vec::new();
    for (name, m) in like {
        let get = |key: String| map.get(&key).ok_or_else(|| bad(format!("no tensor `{key}`")));
        let vectors = (0..m.vectors.len())
            .map(|i| get(format!("{name}.{i}"))?.flatten_all()?.to_vec1::<f32>().map_err(Error::from))
            .collect::<Result<Vec<_>, _>>()?;
        let steps = get(format!("{name}.steps"))?.to_vec1::<f64>()?;
        let steps = match steps.as_slice() {
            [s] if s.fract() == 0.0 && (0.0..=f64::from(i32::MAX)).contains(s) => *s as i32,
            other => return Err(bad(format!("`{name}.steps` = {other:?}, not a step count"))),
        };
        out.push(Moments { vectors, steps });
    }
    Ok(Some(out))
}

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
    /// How far past the run's base seeds its environments were seeded (a resume that started
    /// fresh episodes seeds them past the episodes already played): what a later resume
    /// replays the kept episodes from. 0 in states written before it was kept.
    #[serde(default)]
    pub seed_offset: u64,
    /// The folder in `resume/` holding this state's files (its round's); absent in states
    /// written before rounds had one, whose files are in `resume/` itself.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub files: Option<String>,
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
            format: FORMAT_FLAT,
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
            seed_offset: 0,
            files: None,
        }
    }

    pub(crate) fn rng_positions(&self) -> Result<(u128, u128), Error> {
        let parse = |s: &str| {
            s.parse::<u128>().map_err(|e| Error::Checkpoint { message: format!("resume/state.json: stream position `{s}`: {e}") })
        };
        Ok((parse(&self.act_rng)?, parse(&self.sample_rng)?))
    }

    /// The folder holding this state's resume files (the carry, the optimisers, the targets).
    pub fn files(&self, dir: &Path) -> std::path::PathBuf {
        let resume = dir.join("resume");
        match &self.files {
            Some(name) => resume.join(name),
            None => resume,
        }
    }

    /// The folder holding the online networks' weights this state goes on from: its round's
    /// copy, or for a state written before rounds had one, the checkpoint itself.
    pub(crate) fn weights(&self, dir: &Path) -> std::path::PathBuf {
        if self.files.is_some() { self.files(dir) } else { dir.to_path_buf() }
    }

    /// The config of the game this state's round was played in: its round's copy of the
    /// checkpoint's (a state written before rounds had folders: the checkpoint's).
    pub(crate) fn played_config(&self, dir: &Path) -> Result<Config, Error> {
        let round = self.weights(dir);
        let from = if round.join("config.json").is_file() { round } else { dir.to_path_buf() };
        crate::Policy::config_in(&from)
    }

    /// Writes the target networks, if any, into `files` (the round's folder from
    /// [`begin_round`], which holds the round's other files by now), then the state naming
    /// it, then removes what earlier rounds left in `dir/resume` (the journal stays).
    pub(crate) fn save(&mut self, dir: &Path, target: Option<&Nets>, files: &Path) -> Result<(), Error> {
        if let Some(target) = target {
            crate::aside::tensors(&target.agent_params.to_map(), &files.join("target_agent.safetensors"))?;
            let mixer = target.mixer_params.to_map();
            if !mixer.is_empty() {
                crate::aside::tensors(&mixer, &files.join("target_mixer.safetensors"))?;
            }
        }
        let name = files.file_name().map(|n| n.to_string_lossy().into_owned());
        self.files = name.clone();
        self.format = FORMAT;
        let d = dir.join("resume");
        let path = d.join("state.json");
        let text = serde_json::to_string_pretty(self).map_err(|source| Error::Json { path: path.clone(), source })?;
        crate::aside::write(&path, text)?;
        prune(&d, name.as_deref())
    }
}

/// Removes from `resume` every round's folder but `keep`, and the files states written before
/// rounds had folders kept there.
fn prune(resume: &Path, keep: Option<&str>) -> Result<(), Error> {
    let entries = std::fs::read_dir(resume).map_err(|source| Error::Io { path: resume.to_path_buf(), source })?;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        let r = if name.starts_with(ROUND_PREFIX) && Some(name.as_str()) != keep {
            std::fs::remove_dir_all(&path)
        } else if [OPTIM_FILE, crate::carry::FILE, "target_agent.safetensors", "target_mixer.safetensors"].contains(&name.as_str()) {
            std::fs::remove_file(&path)
        } else {
            continue;
        };
        match r {
            Err(source) if source.kind() != std::io::ErrorKind::NotFound => return Err(Error::Io { path, source }),
            _ => {}
        }
    }
    Ok(())
}

/// The config and state of the run in `dir`, to go on with [`crate::train::train_from`].
pub fn load(dir: &Path) -> Result<(Config, RunState), Error> {
    let policy = crate::Policy::load(dir)?;
    let state = load_state(dir)?;
    if policy.cfg.is_ppo() && state.value_norm.is_none() {
        let path = dir.join("resume").join("state.json");
        return Err(Error::Checkpoint {
            message: format!("{}: a {} run's state has no value statistics", path.display(), policy.cfg.algo),
        });
    }
    Ok((policy.cfg, state))
}

/// The state in `dir/resume` alone, checked on its own (not against the checkpoint).
pub(crate) fn load_state(dir: &Path) -> Result<RunState, Error> {
    let path = dir.join("resume").join("state.json");
    let text = std::fs::read_to_string(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
    let state: RunState = serde_json::from_str(&text).map_err(|source| Error::Json { path: path.clone(), source })?;
    if state.format != FORMAT && state.format != FORMAT_FLAT {
        return Err(Error::Checkpoint {
            message: format!("{}: format {} (this build reads {FORMAT_FLAT} and {FORMAT})", path.display(), state.format),
        });
    }
    if (state.format == FORMAT) != state.files.is_some() {
        return Err(Error::Checkpoint {
            message: format!(
                "{}: format {} names {} round's folder (`files`)",
                path.display(),
                state.format,
                if state.files.is_some() { "a" } else { "no" }
            ),
        });
    }
    if let Some(name) = &state.files
        && !name.strip_prefix(ROUND_PREFIX).is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
    {
        return Err(Error::Checkpoint {
            message: format!("{}: `files` = {name:?} is not a round's folder (`{ROUND_PREFIX}` and its number)", path.display()),
        });
    }
    Ok(state)
}

pub(crate) fn load_tensors(path: &Path) -> Result<std::collections::HashMap<String, candle_core::Tensor>, Error> {
    if !path.is_file() {
        return Err(Error::Checkpoint { message: format!("{} is missing", path.display()) });
    }
    Ok(candle_core::safetensors::load(path, &Device::Cpu)?)
}

pub(crate) fn optim_mismatch(files: &Path, name: &str, why: &str) -> Error {
    Error::Checkpoint { message: format!("{}: the `{name}` optimiser's state: {why}", files.join(OPTIM_FILE).display()) }
}

/// Loads the state's online and target networks' weights into `learner`.
pub(crate) fn restore(dir: &Path, learner: &mut Learner, state: &RunState) -> Result<(), Error> {
    let weights = state.weights(dir);
    let policy = crate::Policy::load_from(dir, &weights)?;
    if learner.nets.mixer_params.vars().next().is_some() && !weights.join("mixer.safetensors").is_file() {
        return Err(Error::Checkpoint {
            message: format!("{}: no mixer.safetensors to resume from (a shipped policy only acts)", weights.display()),
        });
    }
    learner.nets.agent_params.copy_from(&policy.nets.agent_params)?;
    learner.nets.mixer_params.copy_from(&policy.nets.mixer_params)?;
    let d = state.files(dir);
    let load = |name: &str| load_tensors(&d.join(name));
    learner.target.agent_params.load_map(&load("target_agent.safetensors")?, "target_agent.safetensors")?;
    if learner.target.mixer_params.vars().next().is_some() {
        learner.target.mixer_params.load_map(&load("target_mixer.safetensors")?, "target_mixer.safetensors")?;
    }
    learner.updates = state.updates;
    learner.last_target_update = state.last_target_update;
    learner.reload()?;
    if let Some(like) = learner.moments()
        && let Some(saved) = load_moments(&d, &[("q", like)])?.and_then(|v| v.into_iter().next())
    {
        learner.set_moments(saved).map_err(|e| optim_mismatch(&d, "q", &e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::{Adam, RmsProp};

    fn scratch(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("avacraft-resume-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// A resumed Adam takes the steps the uninterrupted one takes; RMSprop's averages come
    /// back too; a state of another shape, or a broken step count, is refused by name.
    #[test]
    fn optimiser_states_come_back_and_mismatches_are_named() -> Result<(), Error> {
        let dir = scratch("optim");
        let grads = [[0.5f32, -1.0, 2.0], [0.25, 0.75, -0.5], [1.0, 1.0, 1.0]];
        let (mut theta, mut adam) = (vec![0.1f32, 0.2, 0.3], Adam::new(3, 0.01, 1e-5));
        let mut rms = RmsProp::new(3, 0.01, 0.99, 1e-5);
        let mut rms_theta = theta.clone();
        for g in &grads[..2] {
            adam.step(&mut theta, g);
            rms.step(&mut rms_theta, g);
        }
        assert!(load_moments(&dir, &[("q", adam.moments())])?.is_none(), "no file: a fresh optimiser, as before");
        save_moments(&dir, &[("actor", adam.moments()), ("critic", rms.moments())])?;
        let (mut fresh, mut fresh_rms) = (Adam::new(3, 0.01, 1e-5), RmsProp::new(3, 0.01, 0.99, 1e-5));
        let back = load_moments(&dir, &[("actor", fresh.moments()), ("critic", fresh_rms.moments())])?.unwrap_or_default();
        assert_eq!(back, [adam.moments(), rms.moments()]);
        let mut it = back.into_iter();
        fresh.set_moments(it.next().unwrap_or_else(|| fresh.moments())).map_err(|m| Error::Checkpoint { message: m })?;
        fresh_rms.set_moments(it.next().unwrap_or_else(|| fresh_rms.moments())).map_err(|m| Error::Checkpoint { message: m })?;
        let (mut resumed, mut resumed_rms) = (theta.clone(), rms_theta.clone());
        adam.step(&mut theta, &grads[2]);
        fresh.step(&mut resumed, &grads[2]);
        rms.step(&mut rms_theta, &grads[2]);
        fresh_rms.step(&mut resumed_rms, &grads[2]);
        assert_eq!((resumed, resumed_rms), (theta, rms_theta));

        let e = Adam::new(4, 0.01, 1e-5).set_moments(adam.moments()).err().unwrap_or_default();
        assert!(e.contains("[3, 3]") && e.contains("[4, 4]"), "{e}");
        assert!(load_moments(&dir, &[("q", adam.moments())]).err().is_some_and(|e| e.to_string().contains("no tensor `q.0`")));
        let mut map = std::collections::HashMap::new();
        map.insert("q.0".to_owned(), candle_core::Tensor::new(&[1f32, 2.0, 3.0], &Device::Cpu)?);
        map.insert("q.steps".to_owned(), candle_core::Tensor::new(&[2.5f64], &Device::Cpu)?);
        candle_core::safetensors::save(&map, dir.join(OPTIM_FILE))?;
        let e = load_moments(&dir, &[("q", rms.moments())]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("`q.steps` = [2.5], not a step count") && e.contains(OPTIM_FILE), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }
}
