//! The paper's 21 scenarios, SMAC's 23 maps and the procedural ones, compiled into the library so every tool works from any
//! directory. The files are generated from the reference map data by
//! `tools/gen_scenarios.py` and are meant to be read and copied by users.

use super::types::{Scenario, ScenarioError};
use std::path::Path;

macro_rules! scenarios {
    ($(#[$doc:meta])* $list:ident: $($name:literal),* $(,)?) => {
        scenarios!($(#[$doc])* $list in "": $($name),*);
    };
    ($(#[$doc:meta])* $list:ident in $dir:literal: $($name:literal),* $(,)?) => {
        $(#[$doc])*
        pub const $list: &[(&str, &str)] = &[$(($name, include_str!(concat!("../../scenarios/", $dir, $name, ".toml")))),*];
    };
}

scenarios!(
    /// Names and TOML text of the paper's 21 scenarios, in its table order.
    BUILTIN:
    "2c_vs_64zg_vlm",
    "2m_vs_1z_vlm",
    "2s_vs_1sc_vlm",
    "3s_vs_3z_vlm",
    "6r_vs_8z",
    "8m1mv_vs_2st",
    "8m2st_vs_35zg4b",
    "8m_vs_2pc1wp",
    "2s3z_vlm",
    "3m_vlm",
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

scenarios!(
    /// SMAC's 23 maps under SMAC's names (`tools/gen_smac.py`), in SMAC's registry order.
    SMAC in "smac/":
    "3m",
    "8m",
    "25m",
    "5m_vs_6m",
    "8m_vs_9m",
    "10m_vs_11m",
    "27m_vs_30m",
    "MMM",
    "MMM2",
    "2s3z",
    "3s5z",
    "3s5z_vs_3s6z",
    "3s_vs_3z",
    "3s_vs_4z",
    "3s_vs_5z",
    "1c3s5z",
    "2m_vs_1z",
    "corridor",
    "6h_vs_8z",
    "2s_vs_1sc",
    "so_many_baneling",
    "bane_vs_bane",
    "2c_vs_64zg",
);

/// Names that meant one of the paper's scenarios before SMAC's maps took them, and the
/// paper's scenario's name now: (old name, new name). The old names now mean SMAC's maps;
/// anything recorded under the old meaning (a checkpoint, an evaluation folder) is read with
/// the new name or refused with it.
pub const RENAMED: &[(&str, &str)] = &[
    ("2c_vs_64zg", "2c_vs_64zg_vlm"),
    ("2m_vs_1z", "2m_vs_1z_vlm"),
    ("2s3z", "2s3z_vlm"),
    ("2s_vs_1sc", "2s_vs_1sc_vlm"),
    ("3m", "3m_vlm"),
    ("3s_vs_3z", "3s_vs_3z_vlm"),
];

/// The paper's scenario a name meant before SMAC's maps took it ([`RENAMED`]).
pub fn renamed(old: &str) -> Option<&'static str> {
    RENAMED.iter().find(|(o, _)| *o == old).map(|(_, n)| *n)
}

/// Names of SMAC's maps ([`SMAC`]).
pub fn smac_names() -> impl Iterator<Item = &'static str> {
    SMAC.iter().map(|(n, _)| *n)
}

/// Names of the procedural scenarios ([`PROCEDURAL`]).
pub fn procedural_names() -> impl Iterator<Item = &'static str> {
    PROCEDURAL.iter().map(|(n, _)| *n)
}

/// Names of the paper's 21 scenarios ([`BUILTIN`]).
pub fn builtin_names() -> impl Iterator<Item = &'static str> {
    BUILTIN.iter().map(|(n, _)| *n)
}

/// Every built-in name: the paper's scenarios, SMAC's maps, then the procedural ones.
pub fn all_names() -> impl Iterator<Item = &'static str> {
    builtin_names().chain(smac_names()).chain(procedural_names())
}

/// A built-in scenario by name: one of the paper's, one of SMAC's maps, or a procedural one.
pub fn builtin(name: &str) -> Result<Scenario, ScenarioError> {
    let (_, text) =
        BUILTIN.iter().chain(SMAC).chain(PROCEDURAL).find(|(n, _)| *n == name).ok_or_else(|| ScenarioError::Unknown(name.to_owned()))?;
    Scenario::from_toml(&format!("<built-in>/{name}.toml"), text)
}

impl Scenario {
    /// Loads a scenario file, or a built-in scenario by name when no such file exists.
    pub fn load(name_or_path: &str) -> Result<Scenario, ScenarioError> {
        let p = Path::new(name_or_path);
        // A file by that name, not a folder: runs are kept in folders named after their
        // scenarios (`runs/<plan>/<scenario>/...`), and a built-in name must still mean
        // the built-in from inside such a tree.
        if p.extension().is_some_and(|e| e == "toml") || p.is_file() {
            let text =
                std::fs::read_to_string(p).map_err(|e| ScenarioError::Io { file: name_or_path.to_owned(), message: e.to_string() })?;
            return Scenario::from_toml(name_or_path, &text);
        }
        builtin(name_or_path)
    }
}
