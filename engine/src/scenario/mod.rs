//! Scenarios: the typed, validated description of a battle, loaded from the project's TOML
//! format. The paper's 21 scenarios are built in; users load their own files the same way.

mod builtin;
mod file;
mod types;
mod validate;

pub use builtin::{BUILTIN, builtin, builtin_names};
pub use file::{RawOpponent, RawScenario, RawStart, RawTerrain, RawUnit, RawUpgrade};
pub use types::{Mode, OpponentKind, Scenario, ScenarioError, ScenarioUnit, StartOrder, Upgrade};
