//! What a training loop carries from one vector step to the next, kept at each test round in
//! the round's resume folder (`resume/round-NNNNNN/carry.safetensors`) so that a resumed run goes on exactly as the uninterrupted one
//! would have (its log row for row, elapsed time aside):
//!
//! - each environment's episode number and team 1's actions since that episode began: the
//!   environments are made again from the run's seeds and replayed to where they were
//!   ([`VecEnv::restore`]), instead of starting fresh episodes;
//! - the loop's own state: hidden states and last actions, the rollout under way (PPO), the
//!   returns so far, the last update's statistics (the log's loss columns until the next
//!   update). A Q-learner's episodes under way are not kept: they are played again from
//!   their lanes' actions (carries written before that kept them whole, and are still read).
//!
//! The Q-learners' replay buffer is kept apart, episode by episode, in [`crate::journal`].
//! Neither is used by a resume under another game ([`crate::Config::same_game`]: `--set`
//! changed a rule, the unit data or the opponent), whose episodes would be replayed into games
//! they were not played in.
//!
//! The carry names the step it was taken at, and a resume checks it: the state names its
//! round's folder, so the carry a resume reads is that round's, but a state written before
//! rounds had folders shares `resume/` with a carry perhaps newer (a kill between the two),
//! which is not used: that run resumes with fresh episodes as runs saved before carries
//! existed do.

use crate::learner::UpdateStats;
use crate::{Episode, Error};
use avacraft_engine::VecEnv;
use candle_core::{DType, Device, Tensor};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

pub(crate) const FILE: &str = "carry.safetensors";

/// Named arrays, written and read as one safetensors file.
#[derive(Debug, Default)]
pub(crate) struct Carry {
    map: HashMap<String, Tensor>,
    path: PathBuf,
}

impl Carry {
    /// An empty carry for the state at step `t_env`.
    pub(crate) fn new(t_env: u64) -> Result<Carry, Error> {
        let mut c = Carry::default();
        c.u64s("t_env", &[t_env])?;
        Ok(c)
    }

    pub(crate) fn f32s(&mut self, name: &str, v: &[f32]) -> Result<(), Error> {
        self.map.insert(name.to_owned(), Tensor::from_slice(v, v.len(), &Device::Cpu)?);
        Ok(())
    }

    pub(crate) fn u32s(&mut self, name: &str, v: &[u32]) -> Result<(), Error> {
        self.map.insert(name.to_owned(), Tensor::from_slice(v, v.len(), &Device::Cpu)?);
        Ok(())
    }

    #[cfg(test)]
    pub(crate) fn u8s(&mut self, name: &str, v: &[u8]) -> Result<(), Error> {
        self.map.insert(name.to_owned(), Tensor::from_slice(v, v.len(), &Device::Cpu)?);
        Ok(())
    }

    pub(crate) fn u64s(&mut self, name: &str, v: &[u64]) -> Result<(), Error> {
        let v: Vec<i64> = v.iter().map(|&x| x as i64).collect();
        self.map.insert(name.to_owned(), Tensor::from_slice(&v, v.len(), &Device::Cpu)?);
        Ok(())
    }

    /// Last actions, `None` (no action yet this episode) as -1.
    pub(crate) fn actions(&mut self, name: &str, v: &[Option<u32>]) -> Result<(), Error> {
        let v: Vec<i64> = v.iter().map(|x| x.map_or(-1, i64::from)).collect();
        self.map.insert(name.to_owned(), Tensor::from_slice(&v, v.len(), &Device::Cpu)?);
        Ok(())
    }

    pub(crate) fn stats(&mut self, name: &str, s: &UpdateStats) -> Result<(), Error> {
        let opt = |x: Option<f64>| x.unwrap_or(f64::NAN);
        let v = [s.loss, s.grad_norm, s.td_abs, s.q_taken, opt(s.entropy), opt(s.policy_loss), opt(s.critic_grad_norm)];
        self.map.insert(name.to_owned(), Tensor::from_slice(&v, v.len(), &Device::Cpu)?);
        Ok(())
    }

    /// Episodes so far (all but their frames): each field concatenated, with the lengths.
    /// What carries written before episodes were replayed kept; now only their tests write it.
    #[cfg(test)]
    pub(crate) fn episodes(&mut self, name: &str, eps: &[Episode]) -> Result<(), Error> {
        let cat = |f: &dyn Fn(&Episode) -> &[f32]| eps.iter().flat_map(|e| f(e).iter().copied()).collect::<Vec<f32>>();
        self.u64s(&format!("{name}.len"), &eps.iter().map(|e| e.len as u64).collect::<Vec<_>>())?;
        self.u64s(&format!("{name}.outcomes"), &eps.iter().map(|e| e.reward.len() as u64).collect::<Vec<_>>())?;
        self.f32s(&format!("{name}.obs"), &cat(&|e| &e.obs))?;
        self.f32s(&format!("{name}.state"), &cat(&|e| &e.state))?;
        self.f32s(&format!("{name}.reward"), &cat(&|e| &e.reward))?;
        self.f32s(&format!("{name}.terminated"), &cat(&|e| &e.terminated))?;
        self.u8s(&format!("{name}.avail"), &eps.iter().flat_map(|e| e.avail.iter().copied()).collect::<Vec<u8>>())?;
        self.u32s(&format!("{name}.actions"), &eps.iter().flat_map(|e| e.actions.iter().copied()).collect::<Vec<u32>>())
    }

    /// Each environment's episode number, and team 1's actions since it began (`A` a step).
    pub(crate) fn lanes(&mut self, env: &VecEnv, since: &[Vec<u32>]) -> Result<(), Error> {
        self.u64s("lanes.episode", env.episode_numbers())?;
        self.u64s("lanes.len", &since.iter().map(|s| s.len() as u64).collect::<Vec<_>>())?;
        self.u32s("lanes.actions", &since.concat())
    }

    /// Written aside and renamed into `files`, a round's resume folder.
    pub(crate) fn save(&self, files: &Path) -> Result<(), Error> {
        std::fs::create_dir_all(files).map_err(|source| Error::Io { path: files.to_path_buf(), source })?;
        crate::aside::tensors(&self.map, &files.join(FILE))
    }

    /// The carry in `files` (a state's [`crate::resume::RunState::files`]) if there is one
    /// taken at step `t_env`.
    pub(crate) fn load(files: &Path, t_env: u64) -> Result<Option<Carry>, Error> {
        let path = files.join(FILE);
        if !path.is_file() {
            return Ok(None);
        }
        let map = candle_core::safetensors::load(&path, &Device::Cpu)?;
        let c = Carry { map, path };
        Ok((c.get_u64s("t_env")? == [t_env]).then_some(c))
    }

    /// Whether the carry holds an array `name` (carries of older runs hold others).
    pub(crate) fn has(&self, name: &str) -> bool {
        self.map.contains_key(name)
    }

    /// An error about the carry, naming its file.
    pub(crate) fn bad(&self, what: String) -> Error {
        Error::Checkpoint { message: format!("{}: {what}", self.path.display()) }
    }

    fn get(&self, name: &str, dtype: DType) -> Result<&Tensor, Error> {
        let t = self.map.get(name).ok_or_else(|| self.bad(format!("no array `{name}`")))?;
        if t.dtype() != dtype {
            return Err(self.bad(format!("`{name}` is {:?}, not {dtype:?}", t.dtype())));
        }
        Ok(t)
    }

    pub(crate) fn get_f32s(&self, name: &str) -> Result<Vec<f32>, Error> {
        Ok(self.get(name, DType::F32)?.to_vec1()?)
    }

    pub(crate) fn get_u32s(&self, name: &str) -> Result<Vec<u32>, Error> {
        Ok(self.get(name, DType::U32)?.to_vec1()?)
    }

    pub(crate) fn get_u8s(&self, name: &str) -> Result<Vec<u8>, Error> {
        Ok(self.get(name, DType::U8)?.to_vec1()?)
    }

    pub(crate) fn get_u64s(&self, name: &str) -> Result<Vec<u64>, Error> {
        let v: Vec<i64> = self.get(name, DType::I64)?.to_vec1()?;
        v.into_iter().map(|x| u64::try_from(x).map_err(|_| self.bad(format!("`{name}` holds {x}, not a count")))).collect()
    }

    /// Each row's last action (`None`: none yet), every one below `n_actions`.
    pub(crate) fn get_actions(&self, name: &str, n_actions: usize) -> Result<Vec<Option<u32>>, Error> {
        let v: Vec<i64> = self.get(name, DType::I64)?.to_vec1()?;
        v.into_iter()
            .map(|x| match x {
                -1 => Ok(None),
                x => u32::try_from(x)
                    .ok()
                    .filter(|&a| (a as usize) < n_actions)
                    .map(Some)
                    .ok_or_else(|| self.bad(format!("`{name}` holds {x}, not one of the team's {n_actions} actions"))),
            })
            .collect()
    }

    pub(crate) fn get_stats(&self, name: &str) -> Result<UpdateStats, Error> {
        let v: Vec<f64> = self.get(name, DType::F64)?.to_vec1()?;
        let [loss, grad_norm, td_abs, q_taken, entropy, policy_loss, critic] = v[..] else {
            return Err(self.bad(format!("`{name}` has {} numbers, not 7", v.len())));
        };
        let opt = |x: f64| (!x.is_nan()).then_some(x);
        Ok(UpdateStats {
            loss,
            grad_norm,
            td_abs,
            q_taken,
            entropy: opt(entropy),
            policy_loss: opt(policy_loss),
            critic_grad_norm: opt(critic),
        })
    }

    /// Splits `data` into pieces of `lens[i] * per` items, checking the total.
    fn split<T: Clone>(&self, name: &str, data: Vec<T>, lens: &[u64], per: usize) -> Result<Vec<Vec<T>>, Error> {
        let total = lens.iter().try_fold(0u64, |acc, &l| acc.checked_add(l)).and_then(|n| n.checked_mul(per as u64));
        if total != Some(data.len() as u64) {
            let said = total.map_or("more than a count holds".to_string(), |t| t.to_string());
            return Err(self.bad(format!("`{name}` holds {} items, its lengths say {said}", data.len())));
        }
        let mut out = Vec::with_capacity(lens.len());
        let mut at = 0usize;
        for &l in lens {
            let n = l as usize * per;
            out.push(data[at..at + n].to_vec());
            at += n;
        }
        Ok(out)
    }

    /// The episodes `Carry::episodes` wrote (carries written before episodes under way were
    /// replayed), shaped by `shape` (per step: `A x obs`
    /// observations, the state, `A x n_actions` masks, `A` actions).
    pub(crate) fn get_episodes(&self, name: &str, shape: &crate::Shape) -> Result<Vec<Episode>, Error> {
        let (a, o, s, na) = (shape.n_agents, shape.obs, shape.state, shape.n_actions);
        let lens = self.get_u64s(&format!("{name}.len"))?;
        let outs = self.get_u64s(&format!("{name}.outcomes"))?;
        if outs.len() != lens.len() {
            return Err(self.bad(format!("`{name}`: {} lengths, {} outcome counts", lens.len(), outs.len())));
        }
        let obs = self.split(name, self.get_f32s(&format!("{name}.obs"))?, &lens, a * o)?;
        let state = self.split(name, self.get_f32s(&format!("{name}.state"))?, &lens, s)?;
        let avail = self.split(name, self.get_u8s(&format!("{name}.avail"))?, &lens, a * na)?;
        let actions = self.split(name, self.get_u32s(&format!("{name}.actions"))?, &lens, a)?;
        let reward = self.split(name, self.get_f32s(&format!("{name}.reward"))?, &outs, 1)?;
        let terminated = self.split(name, self.get_f32s(&format!("{name}.terminated"))?, &outs, 1)?;
        let mut eps = Vec::with_capacity(lens.len());
        for (i, &len) in lens.iter().enumerate() {
            eps.push(Episode {
                len: len as usize,
                obs: obs[i].clone(),
                state: state[i].clone(),
                avail: avail[i].clone(),
                actions: actions[i].clone(),
                reward: reward[i].clone(),
                terminated: terminated[i].clone(),
                frames: Default::default(),
            });
        }
        Ok(eps)
    }

    /// Whether the carry kept `envs` environments, as the run steps.
    pub(crate) fn check_lanes(&self, envs: usize) -> Result<(), Error> {
        let kept = self.get_u64s("lanes.episode")?.len();
        if kept != envs {
            return Err(self.bad(format!("{kept} environments kept, the run has {envs}")));
        }
        Ok(())
    }

    /// Puts each environment of `env` back where [`Carry::lanes`] found it; returns the
    /// actions since each episode began.
    pub(crate) fn restore_lanes(&self, env: &mut VecEnv) -> Result<Vec<Vec<u32>>, Error> {
        let episode = self.get_u64s("lanes.episode")?;
        let lens = self.get_u64s("lanes.len")?;
        if episode.len() != env.len() || lens.len() != env.len() {
            return Err(self.bad(format!("{} environments kept, the run has {}", episode.len(), env.len())));
        }
        let since = self.split("lanes.actions", self.get_u32s("lanes.actions")?, &lens, 1)?;
        for (i, (k, acts)) in episode.iter().zip(&since).enumerate() {
            let acts: Vec<i64> = acts.iter().map(|&x| i64::from(x)).collect();
            env.restore(i, *k, &acts).map_err(|e| self.bad(e.to_string()))?;
        }
        Ok(since)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Carries written before episodes under way were replayed kept them whole: they read back.
    #[test]
    fn episodes_kept_whole_read_back() -> Result<(), Error> {
        let shape = crate::Shape { n_agents: 2, obs: 3, state: 4, n_actions: 5, n_enemies: 1 };
        let ep = |len: usize, k: f32| Episode {
            len,
            obs: vec![k; len * 6],
            state: vec![k + 1.0; len * 4],
            avail: vec![1; len * 10],
            actions: vec![4; len * 2],
            reward: vec![k; len],
            terminated: vec![0.0; len],
            frames: Default::default(),
        };
        let eps = vec![ep(3, 0.5), ep(0, 1.0), ep(7, 2.0)];
        let dir = std::env::temp_dir().join(format!("avacraft-carry-{}", std::process::id()));
        let mut c = Carry::new(40)?;
        c.episodes("running", &eps)?;
        assert!(c.has("running.len") && !c.has("running.nothing"));
        c.save(&dir)?;
        assert!(Carry::load(&dir, 39)?.is_none(), "a carry of another step is not used");
        let back = Carry::load(&dir, 40)?.expect("kept").get_episodes("running", &shape)?;
        assert_eq!(back, eps);
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }
}
