//! What an environment is made from: the scenario and the engine options Python passes,
//! shared by the single and the vector environment.

use crate::error::Error;
use avacraft_engine::{DataSet, EnvConfig, OpponentKind, RewardMode, Scenario, ScenarioError, all_names};
use std::num::NonZeroU32;
use std::sync::Arc;

/// A built-in scenario by name, a scenario TOML file by path, or a scenario's TOML text (what
/// `StarCraftCapabilityEnvWrapper` builds from SMACv2's config; names and paths have no
/// line breaks, a file's text always has).
pub(crate) fn load_scenario(name: &str) -> Result<Arc<Scenario>, Error> {
    if name.contains('\n') {
        return Ok(Arc::new(Scenario::from_toml("<scenario text>", name)?));
    }
    match Scenario::load(name) {
        Ok(s) => Ok(Arc::new(s)),
        Err(ScenarioError::Unknown(name)) => Err(Error::UnknownScenario { name, known: all_names().collect::<Vec<_>>().join(", ") }),
        Err(e) => Err(e.into()),
    }
}

impl Options {
    /// The scenario on the data set asked for.
    pub(crate) fn scenario(&self, s: Arc<Scenario>) -> Result<Arc<Scenario>, Error> {
        let Some(name) = &self.data else { return Ok(s) };
        let d: DataSet = name.parse().map_err(|_| Error::Option {
            option: "data",
            value: name.clone(),
            supported: "one of liberty, void, ladder, legacy (or None: the scenario's own)".into(),
        })?;
        Ok(Arc::new(s.with_data(d)?))
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
    pub prob_obs_enemy: f64,
    pub action_mask: bool,
    /// SMACv2's conic fields of view: the number of look actions (0: off).
    pub fov_actions: i64,
    /// The unit data to play on (`liberty`, `void`, `ladder`, `legacy`); `None`: the
    /// scenario's own.
    pub data: Option<String>,
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
        if !(0.0..=1.0).contains(&self.prob_obs_enemy) {
            return Err(Error::Option {
                option: "prob_obs_enemy",
                value: self.prob_obs_enemy.to_string(),
                supported: "a probability in [0, 1] (1: extended partial observability off)".into(),
            });
        }
        cfg.prob_obs_enemy = self.prob_obs_enemy as f32;
        cfg.action_mask = self.action_mask;
        cfg.fov_actions = avacraft_engine::check_fov_actions(self.fov_actions).map_err(|why| Error::Option {
            option: "num_fov_actions",
            value: self.fov_actions.to_string(),
            supported: format!("with conic_fov, {why}"),
        })?;
        Ok(cfg)
    }
}
