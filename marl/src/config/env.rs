//! The environment's SMACv2, ability, weapon-period, surround and reward-sign options in a config table.

/// Puts the environment's SMACv2 and ability options, off unless set, into `table` where it
/// lacks them: keys every config has, which the built-in files and saved configs leave out at
/// their defaults.
pub(super) fn add_default_keys(table: &mut toml::Table) {
    table.entry("prob_obs_enemy").or_insert(toml::Value::Float(1.0));
    table.entry("action_mask").or_insert(toml::Value::Boolean(true));
    table.entry("conic_fov").or_insert(toml::Value::Boolean(false));
    table.entry("num_fov_actions").or_insert(toml::Value::Integer(12));
    table.entry("ability_actions").or_insert(toml::Value::Boolean(false));
    table.entry("weapon_period").or_insert(toml::Value::String(avacraft_engine::WeaponPeriod::Attack.name().to_owned()));
    table.entry("melee_surround").or_insert(toml::Value::Boolean(false));
    table.entry("reward_only_positive").or_insert(toml::Value::Boolean(true));
    table.entry("reward_negative_scale").or_insert(toml::Value::Float(0.5));
}
