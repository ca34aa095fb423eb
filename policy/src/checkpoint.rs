//! Trained checkpoints, loaded when first needed: a process that only routes or simulates
//! (the simulator node, the bridge) names them without reading their weights.

use crate::PolicyError;
use avacraft_engine::agent::FrameNeed;
use avacraft_engine::{Scenario, Team};
use avacraft_marl::Policy;
use avacraft_marl::baselines;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use xxhash_rust::xxh3::Xxh3;

/// When a checkpoint's weights are read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Weights {
    /// Where the policy is named, so a missing or corrupt checkpoint is refused there.
    #[default]
    Load,
    /// On first use (a process that never acts never reads them); only the folder is checked.
    Later,
}

/// A trained policy's checkpoint directory and, once read, its network.
#[derive(Clone)]
pub struct MarlCheckpoint {
    /// As resolved (absolute), so another process started from elsewhere finds it.
    dir: PathBuf,
    policy: Arc<OnceLock<Arc<Policy>>>,
}

impl MarlCheckpoint {
    /// The checkpoint in `dir` (resolved to an absolute path first), read now or later.
    pub fn open(dir: &Path, weights: Weights) -> Result<MarlCheckpoint, PolicyError> {
        let abs = std::fs::canonicalize(dir).map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound => PolicyError::MissingDir { dir: dir.to_path_buf(), source },
            _ => PolicyError::Unreadable { dir: dir.to_path_buf(), source },
        })?;
        if !abs.is_dir() {
            return Err(PolicyError::NotADir { dir: abs });
        }
        let m = MarlCheckpoint { dir: abs, policy: Arc::new(OnceLock::new()) };
        if weights == Weights::Load {
            m.policy()?;
        }
        Ok(m)
    }

    /// The unit data it trained on ([`Policy::data_in`]).
    pub fn trained_data(&self) -> Result<avacraft_engine::DataSet, PolicyError> {
        Policy::data_in(&self.dir).map_err(|source| PolicyError::Checkpoint { dir: self.dir.clone(), source })
    }

    /// Where weapons' periods were counted from in the games it learned ([`Policy::weapon_period_in`]).
    pub fn trained_weapon_period(&self) -> Result<avacraft_engine::WeaponPeriod, PolicyError> {
        Policy::weapon_period_in(&self.dir).map_err(|source| PolicyError::Checkpoint { dir: self.dir.clone(), source })
    }

    /// Whether it learned under the surround experiment ([`Policy::melee_surround_in`]).
    pub fn trained_melee_surround(&self) -> Result<bool, PolicyError> {
        Policy::melee_surround_in(&self.dir).map_err(|source| PolicyError::Checkpoint { dir: self.dir.clone(), source })
    }

    /// Whether the network reads the ability slots ([`Policy::ability_actions_in`]).
    pub fn ability_actions(&self) -> Result<bool, PolicyError> {
        Policy::ability_actions_in(&self.dir).map_err(|source| PolicyError::Checkpoint { dir: self.dir.clone(), source })
    }

    /// Loads the checkpoint in `dir` now.
    pub fn load(dir: &Path) -> Result<MarlCheckpoint, PolicyError> {
        Self::open(dir, Weights::Load)
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The network, read on first call and shared by every agent made from it (the per-unit
    /// agents of one launch entry read the file once).
    pub fn policy(&self) -> Result<&Arc<Policy>, PolicyError> {
        if let Some(p) = self.policy.get() {
            return Ok(p);
        }
        let p = Policy::load(&self.dir).map_err(|source| PolicyError::Checkpoint { dir: self.dir.clone(), source })?;
        // A racing first use read the same file: either copy is the network.
        Ok(self.policy.get_or_init(|| Arc::new(p)))
    }

    /// Refuses a checkpoint trained on another scenario, or whose network does not fit
    /// `team`'s agents there (team size, feature and action counts): it would read other
    /// features, and the MARL agent gives no orders at all then. An image-mode checkpoint is
    /// refused too: an agent is handed units, not the frames its encoder reads.
    pub fn check(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        if let Some(why) = self.policy()?.agent_refusal() {
            return Err(PolicyError::NotAnAgent { dir: self.dir.clone(), why });
        }
        self.check_fit(scenario, team)
    }

    /// [`MarlCheckpoint::check`] for an agent shown its team's frames before each step: an
    /// `rgb` or `hybrid` checkpoint plays team 1 then ([`Policy::seeing_refusal`]).
    pub fn check_seeing(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        let policy = self.policy()?;
        if policy.agent_refusal().is_some()
            && let Some(why) = policy.seeing_refusal(team)
        {
            return Err(PolicyError::NotAnAgent { dir: self.dir.clone(), why });
        }
        self.check_fit(scenario, team)
    }

    /// The frames the network reads, from `config.json` (the weights stay unread when
    /// they are not read yet).
    pub fn frames_need(&self) -> Result<Option<FrameNeed>, PolicyError> {
        match self.policy.get() {
            Some(p) => Ok(p.frames_need()),
            None => Policy::frames_need_in(&self.dir).map_err(|source| PolicyError::Checkpoint { dir: self.dir.clone(), source }),
        }
    }

    /// The network when it plays from rendered frames (an image mode), checked to fit team 1
    /// of `scenario`: an evaluation plays it with [`Policy::play_out`]. `None` for a
    /// `features` checkpoint, which plays as an engine agent.
    pub fn frames_policy(&self, scenario: &Scenario) -> Result<Option<Arc<Policy>>, PolicyError> {
        if self.policy()?.agent_refusal().is_none() {
            return Ok(None);
        }
        self.check_fit(scenario, Team::One)?;
        Ok(Some(Arc::clone(self.policy()?)))
    }

    /// Refuses a network trained on another scenario or for other sizes.
    fn check_fit(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        let policy = self.policy()?;
        if policy.scenario != scenario.name {
            return Err(PolicyError::OtherScenario {
                dir: self.dir.clone(),
                trained: policy.scenario.clone(),
                scenario: scenario.name.clone(),
            });
        }
        let l = policy.layout(scenario, team);
        let s = policy.shape;
        let (trained, here) = ((s.n_agents, s.obs, s.n_actions), (l.n_agents, l.obs_size, l.n_actions));
        if trained != here || policy.check_scenario(scenario, team).is_err() {
            return Err(PolicyError::OtherShape { dir: self.dir.clone(), trained, team, scenario: scenario.name.clone(), here });
        }
        Ok(())
    }

    /// What identifies the trained network: a hash of the files acting reads
    /// (`config.json`, `agent.safetensors`). An evaluation records it with its results, so a
    /// checkpoint trained again or shipped anew is not mixed with the old one's episodes.
    pub fn fingerprint(&self) -> Result<String, PolicyError> {
        let mut h = Xxh3::new();
        for name in ["config.json", "agent.safetensors"] {
            let path = self.dir.join(name);
            let bytes = std::fs::read(&path).map_err(|source| PolicyError::Unreadable { dir: path, source })?;
            h.update(&(bytes.len() as u64).to_le_bytes());
            h.update(&bytes);
        }
        Ok(format!("xxh3:{:016x}", h.digest()))
    }

    /// The agent's name: `marl:DIR`.
    pub fn name(&self) -> String {
        format!("{}{}", crate::names::MARL_PREFIX, self.dir.display())
    }
}

impl std::fmt::Debug for MarlCheckpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Not the weights.
        let mut d = f.debug_struct("MarlCheckpoint");
        d.field("dir", &self.dir);
        if let Some(p) = self.policy.get() {
            d.field("scenario", &p.scenario).field("algo", &p.cfg.algo).field("shape", &p.shape);
        }
        d.finish()
    }
}

/// `baseline:NAME`: the shipped checkpoints of one run name, opened per scenario on first use.
#[derive(Clone)]
pub struct BaselineSet {
    pub(crate) name: String,
    pub(crate) root: PathBuf,
    pub(crate) weights: Weights,
    loaded: Arc<Mutex<BTreeMap<String, MarlCheckpoint>>>,
}

impl std::fmt::Debug for BaselineSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BaselineSet").field("name", &self.name).field("root", &self.root).finish_non_exhaustive()
    }
}

impl BaselineSet {
    pub(crate) fn new(name: &str, weights: Weights) -> Result<BaselineSet, PolicyError> {
        baselines::check_name(name).map_err(PolicyError::Baseline)?;
        Ok(BaselineSet { name: name.to_owned(), root: baselines::root(), weights, loaded: Arc::default() })
    }

    /// The run name (`qmix` of `baseline:qmix`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The checkpoint shipped for `scenario`, opened once.
    pub fn for_scenario(&self, scenario: &str) -> Result<MarlCheckpoint, PolicyError> {
        let mut loaded = self.loaded.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(m) = loaded.get(scenario) {
            return Ok(m.clone());
        }
        let dir = baselines::dir(&self.root, scenario, &self.name).map_err(PolicyError::Baseline)?;
        let m = MarlCheckpoint::open(&dir, self.weights)?;
        loaded.insert(scenario.to_owned(), m.clone());
        Ok(m)
    }
}
