//! What an environment is made from: the scenario and the engine's [`EnvOptions`], which both
//! constructors (the single and the vector environment) take as keyword arguments named as its
//! fields (`env_option_names()`; a Python test holds both signatures to it).

use crate::error::Error;
use avacraft_engine::{BadOption, EnvConfig, EnvOptions, Scenario, ScenarioError, all_names};
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

/// The keyword arguments of both constructors, as Python passes them (names, strings and plain
/// numbers), before they are checked into [`EnvOptions`].
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
    pub fov_actions: i64,
    pub data: Option<String>,
}

impl From<BadOption> for Error {
    fn from(b: BadOption) -> Error {
        Error::Option { option: b.option, value: b.value, supported: b.supported }
    }
}

impl Options {
    /// The engine's options, the names parsed (each refusal names its option).
    pub(crate) fn env_options(&self) -> Result<EnvOptions, Error> {
        Ok(EnvOptions {
            step_mul: self.step_mul,
            reward: EnvOptions::reward_named(&self.reward)?,
            opponent: self.opponent.as_deref().map(EnvOptions::opponent_named).transpose()?,
            full_vision: self.full_vision,
            passive_allies: self.passive_allies,
            cooldown_jitter: self.cooldown_jitter,
            abilities: self.abilities,
            ability_actions: self.ability_actions,
            time_limit_loops: self.time_limit_loops,
            prob_obs_enemy: self.prob_obs_enemy,
            action_mask: self.action_mask,
            fov_actions: self.fov_actions,
            data: self.data.as_deref().map(EnvOptions::data_named).transpose()?,
        })
    }

    /// The scenario, on the data set asked for, and the engine's configuration.
    pub(crate) fn build(&self, scenario: &str) -> Result<(Arc<Scenario>, EnvConfig), Error> {
        let o = self.env_options()?;
        Ok((o.scenario(load_scenario(scenario)?)?, o.config()?))
    }
}
