//! The paper's 21 scenarios, compiled into the library so every tool works from any
//! directory. The files are generated from the reference map data by
//! `tools/gen_scenarios.py` and are meant to be read and copied by users.

use super::types::{Scenario, ScenarioError};
use std::path::Path;

macro_rules! scenarios {
    ($(#[$doc:meta])* $list:ident: $($name:literal),* $(,)?) => {
        $(#[$doc])*
        pub const $list: &[(&str, &str)] = &[$(($name, include_str!(concat!("../../scenarios/", $name, ".toml")))),*];
    };
}

scenarios!(
    /// Names and TOML text of the paper's 21 scenarios, in its table order.
    BUILTIN:
    "2c_vs_64zg",
    "2m_vs_1z",
    "2s_vs_1sc",
    "3s_vs_3z",
    "6r_vs_8z",
    "8m1mv_vs_2st",
    "8m2st_vs_35zg4b",
    "8m_vs_2pc1wp",
    "2s3z",
    "3m",
    "mixed_units",
    "8m3mr1mv1st_mirror",
    "8s_vs_8m3mr1mv1st",
    "8m3mr1mv1st_vs_5s2c",
    "pvz_ht",
    "MMM_vs_MMM",
    "mixed_units_pvp",
    "terran_mirror",
    "7s_vs_11m1mv1st",
    "8s_vs_8m3mr1mv1st_pvp",
    "8m3mr1mv1st_mirror_pvp",
);

scenarios!(
    /// Procedural scenarios with SMACv2's settings (its `sc2_gen_*` configs): teams and start
    /// positions drawn every episode, named `<race>_<n>_vs_<m>`.
    PROCEDURAL:
    "protoss_5_vs_5",
    "protoss_10_vs_10",
    "protoss_10_vs_11",
    "protoss_20_vs_20",
    "protoss_20_vs_23",
    "terran_5_vs_5",
    "terran_10_vs_10",
    "terran_10_vs_11",
    "terran_20_vs_20",
    "terran_20_vs_23",
    "zerg_5_vs_5",
    "zerg_10_vs_10",
    "zerg_10_vs_11",
    "zerg_20_vs_20",
    "zerg_20_vs_23",
);

/// Names of the procedural scenarios ([`PROCEDURAL`]).
pub fn procedural_names() -> impl Iterator<Item = &'static str> {
    PROCEDURAL.iter().map(|(n, _)| *n)
}

pub fn builtin_names() -> impl Iterator<Item = &'static str> {
    BUILTIN.iter().map(|(n, _)| *n)
}

/// A built-in scenario by name: one of the paper's, or a procedural one.
pub fn builtin(name: &str) -> Result<Scenario, ScenarioError> {
    let (_, text) = BUILTIN.iter().chain(PROCEDURAL).find(|(n, _)| *n == name).ok_or_else(|| ScenarioError::Unknown(name.to_owned()))?;
    Scenario::from_toml(&format!("<built-in>/{name}.toml"), text)
}

impl Scenario {
    /// Loads a scenario file, or a built-in scenario by name when no such file exists.
    pub fn load(name_or_path: &str) -> Result<Scenario, ScenarioError> {
        let p = Path::new(name_or_path);
        if p.extension().is_some_and(|e| e == "toml") || p.exists() {
            let text =
                std::fs::read_to_string(p).map_err(|e| ScenarioError::Io { file: name_or_path.to_owned(), message: e.to_string() })?;
            return Scenario::from_toml(name_or_path, &text);
        }
        builtin(name_or_path)
    }
}
