//! The self-play league's keys of the config: their defaults, how scripts are drawn, and the
//! keys a config file or a saved config may leave out but `--set` may still name.

/// Updates between snapshots of the learner joining team 2's pool.
pub(super) fn default_self_play_every() -> u64 {
    20
}

/// Snapshots kept in the pool.
pub(super) fn default_self_play_pool() -> usize {
    5
}

/// The share of episodes in which team 2 plays a script instead of a snapshot.
pub(super) fn default_script_share() -> f64 {
    0.5
}

pub(super) fn is_default_script_share(v: &f64) -> bool {
    *v == default_script_share()
}

/// How a self-play league draws its scripted opponents ([`super::Config::self_play_script_draw`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScriptDraw {
    /// Every script equally often.
    #[default]
    Uniform,
    /// Weighted by `(1 - w)^2 + 0.05`, `w` the learner's win rate against the script in its
    /// last greedy test round (scripts not tested yet weigh 1).
    Pfsp,
}

impl ScriptDraw {
    pub(super) fn is_uniform(&self) -> bool {
        *self == ScriptDraw::Uniform
    }
}

/// Puts the league's keys, off unless set, into `table` where it lacks them: the built-in
/// config files leave them out, and a saved config omits those at their defaults.
pub(super) fn add_default_keys(table: &mut toml::Table) {
    table.entry("self_play_scripts").or_insert(toml::Value::Array(Vec::new()));
    table.entry("self_play_script_share").or_insert(toml::Value::Float(default_script_share()));
    table.entry("self_play_script_draw").or_insert(toml::Value::String("uniform".to_owned()));
}
