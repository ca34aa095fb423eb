//! The environment a config's runs play: its options as the engine's `EnvOptions` and
//! `EnvConfig`, and the SMACv2, ability, weapon-period, surround and reward-sign keys every
//! config table has.

use super::{Config, bad};
use crate::Error;
use avacraft_engine::{EnvConfig, EnvOptions};

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
    table.entry("state_agent").or_insert(toml::Value::Boolean(false));
}

impl Config {
    /// The environment options the runs use: the config's PyMARL keys as the engine's
    /// [`EnvOptions`], the same options Python and the command line give.
    pub fn env_options(&self) -> EnvOptions {
        let step_mul = EnvOptions::default().step_mul;
        EnvOptions {
            passive_allies: self.passive_agents,
            reward: self.reward,
            time_limit_loops: (self.episode_limit > 0).then(|| self.episode_limit.saturating_mul(step_mul)),
            prob_obs_enemy: self.prob_obs_enemy,
            action_mask: self.action_mask,
            fov_actions: if self.conic_fov { self.num_fov_actions } else { 0 },
            ability_actions: self.ability_actions,
            weapon_period: self.weapon_period,
            melee_surround: self.melee_surround,
            reward_only_positive: self.reward_only_positive,
            reward_negative_scale: self.reward_negative_scale,
            state_agent: self.state_agent,
            ..EnvOptions::default()
        }
    }

    /// Whether a run under `other` plays the same games as under `self`: the same environment
    /// options, unit data and opponent. A resumed run's episodes under way and its replay
    /// buffer go on only then (replayed under another game, they would be another game's).
    pub fn same_game(&self, other: &Config) -> bool {
        self.env_options() == other.env_options() && self.data == other.data && self.opponent == other.opponent
    }

    /// The engine settings the runs use, checked by [`EnvOptions::config`] (`validate` refuses
    /// every value it would, so only a config built around `validate` gets the error).
    pub fn env_config(&self) -> Result<EnvConfig, Error> {
        self.env_options().config().map_err(|b| bad(b.option, b.value, &b.supported, "see the rule"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use avacraft_engine::WeaponPeriod;

    #[test]
    fn environment_keys_reach_the_game_and_survive_a_save() -> Result<(), Error> {
        let c = Config::for_algo("qmix", &[])?;
        assert_eq!(c.env_config()?.time_limit_loops, None);
        let c = Config::for_algo("qmix", &["episode_limit=60".into()])?;
        assert_eq!(c.env_config()?.time_limit_loops.map(|l| l.get()), Some(60 * c.env_config()?.step_mul.get()));
        // SMACv2's EPO options: off by default, settable, kept out of the saved config when off.
        let c = Config::for_algo("mappo", &[])?;
        assert!(!c.env_config()?.epo() && c.env_config()?.action_mask);
        assert!(
            !toml::to_string(&c)
                .map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?
                .contains("prob_obs_enemy")
        );
        let c = Config::for_algo("mappo", &["prob_obs_enemy=0".into(), "action_mask=false".into()])?;
        assert!(c.env_config()?.epo() && !c.env_config()?.action_mask && c.env_config()?.prob_obs_enemy == 0.0);
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert_eq!(Config::from_toml(&text, &[])?.env_config()?, c.env_config()?);
        // SMACv2's conic fields of view: off by default, 12 look actions when on.
        assert_eq!(Config::for_algo("qmix", &[])?.env_config()?.fov_actions, 0);
        let c = Config::for_algo("qmix", &["conic_fov=true".into()])?;
        assert_eq!(c.env_config()?.fov_actions, 12);
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert_eq!(Config::from_toml(&text, &[])?.env_config()?.fov_actions, 12);
        // The weapon period's reading: the engine's by default and left out of a saved
        // config; the other one reaches the game and survives a save.
        let c = Config::for_algo("qmix", &[])?;
        assert_eq!(c.env_config()?.rules.weapon_period, WeaponPeriod::Attack);
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert!(!text.contains("weapon_period"), "{text}");
        let c = Config::for_algo("qmix", &["weapon_period=\"shot\"".into()])?;
        assert_eq!(c.env_config()?.rules.weapon_period, WeaponPeriod::Shot);
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert_eq!(Config::from_toml(&text, &[])?.env_config()?.rules.weapon_period, WeaponPeriod::Shot);
        // The surround experiment likewise: off and unsaved by default, on when set.
        let c = Config::for_algo("qmix", &[])?;
        assert!(!c.env_config()?.rules.melee_surround);
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert!(!text.contains("melee_surround"), "{text}");
        let c = Config::for_algo("qmix", &["melee_surround=true".into()])?;
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert!(Config::from_toml(&text, &[])?.env_config()?.rules.melee_surround);
        // SMAC's signed reward: off and unsaved by default; on, it reaches the game's reward
        // settings and survives a save; refused with the sparse reward.
        let text = toml::to_string(&Config::for_algo("qmix", &[])?)
            .map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert!(!text.contains("reward_only_positive") && !text.contains("reward_negative_scale"), "{text}");
        let c = Config::for_algo("qmix", &["reward_only_positive=false".into(), "reward_negative_scale=0.25".into()])?;
        assert_eq!(c.env_config()?.dense_reward.negative_scale, Some(0.25));
        let text = toml::to_string(&c).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        assert_eq!(Config::from_toml(&text, &[])?.env_config()?.dense_reward.negative_scale, Some(0.25));
        let e = Config::for_algo("qmix", &["reward=\"sparse\"".into(), "reward_only_positive=false".into()]).err().map(|e| e.to_string());
        assert!(e.as_deref().is_some_and(|e| e.contains("reward_only_positive")), "{e:?}");
        Ok(())
    }
}
