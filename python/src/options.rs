//! What an environment is made from: the scenario and the engine's [`EnvOptions`], which both
//! constructors (the single and the vector environment) take as keyword arguments named as its
//! fields (`env_option_names()`; a Python test holds both signatures to it).

use crate::error::Error;
use avacraft_engine::{
    BadOption, DataSet, EnvConfig, EnvOptions, OpponentKind, RewardMode, Scenario, ScenarioError, WeaponPeriod, all_names,
};
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

impl From<BadOption> for Error {
    fn from(b: BadOption) -> Error {
        Error::Option { option: b.option, value: b.value, supported: b.supported }
    }
}

/// The options Python names by strings, parsed (each refusal names its option): the reward
/// mode, the opponent and the unit data.
pub(crate) fn named(reward: &str, opponent: Option<&str>, data: Option<&str>, weapon_period: &str) -> Result<Named, Error> {
    Ok((
        EnvOptions::reward_named(reward)?,
        opponent.map(EnvOptions::opponent_named).transpose()?,
        data.map(EnvOptions::data_named).transpose()?,
        EnvOptions::weapon_period_named(weapon_period)?,
    ))
}

pub(crate) type Named = (RewardMode, Option<OpponentKind>, Option<DataSet>, WeaponPeriod);

/// The scenario, on the data set `o` asks for, and the engine's configuration.
pub(crate) fn build(scenario: &str, o: &EnvOptions) -> Result<(Arc<Scenario>, EnvConfig), Error> {
    Ok((o.scenario(load_scenario(scenario)?)?, o.config()?))
}
