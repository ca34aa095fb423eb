//! Scenarios: the typed, validated description of a battle, loaded from the project's TOML
//! format. The paper's 21 scenarios are built in; users load their own files the same way.

mod builtin;
mod file;
mod generate;
mod place;
mod types;
mod validate;

pub use builtin::{BUILTIN, PROCEDURAL, RENAMED, SMAC, all_names, builtin, builtin_names, procedural_names, renamed, smac_names};
pub use file::{RawGenerate, RawOpponent, RawScenario, RawStart, RawTerrain, RawUnit, RawUpgrade};
pub use generate::{Generator, StartDist};
pub use types::{Mode, OpponentKind, Scenario, ScenarioError, ScenarioUnit, StartOrder, Upgrade};
