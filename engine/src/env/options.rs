//! The environment's options as people and files write them: one serde struct that the Python
//! constructors, the command line and configuration files all fill, checked into an
//! [`EnvConfig`] in one place, so an option means the same and is refused with the same words
//! wherever it is given.

use super::episode::{EnvConfig, RewardMode, check_fov_actions};
use super::reward::DenseReward;
use crate::scenario::{OpponentKind, Scenario, ScenarioError};
use crate::units::DataSet;
use crate::world::WeaponPeriod;
use serde::{Deserialize, Serialize};
use std::num::NonZeroU32;
use std::sync::Arc;

/// Every environment option, with the defaults of `avacraft.Env` (SMAC's passive allies, dense
/// reward, 8 loops a step). Field names are the Python keyword names.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnvOptions {
    /// Game loops per environment step.
    pub step_mul: u32,
    pub reward: RewardMode,
    /// The PvE opponent; `None`: the scenario's own.
    pub opponent: Option<OpponentKind>,
    pub full_vision: bool,
    /// SMAC's agents: team 1's units fire only when told (no auto-acquire).
    pub passive_allies: bool,
    /// StarCraft II's random delay after each attack.
    pub cooldown_jitter: bool,
    pub abilities: bool,
    /// Ability slots appended to SMAC's discrete actions.
    pub ability_actions: bool,
    /// Overrides the scenario's time limit (game loops).
    pub time_limit_loops: Option<u32>,
    /// SMACv2's extended partial observability (1: off).
    pub prob_obs_enemy: f64,
    /// SMAC's range mask on attack actions.
    pub action_mask: bool,
    /// SMACv2's conic fields of view: the number of look actions (0: off).
    pub fov_actions: i64,
    /// The unit data to play on; `None`: the scenario's own.
    pub data: Option<DataSet>,
    /// Where a weapon's period is counted from: `attack` (the engine's reading) or `shot`
    /// (an experiment; see [`WeaponPeriod`]).
    pub weapon_period: WeaponPeriod,
    /// The surround experiment (off): melee units walk round those already at their target
    /// to a free place beside it (see [`crate::Rules`]'s `melee_surround`).
    pub melee_surround: bool,
    /// SMAC's shaped-reward settings under SMAC's keywords and defaults, read with `reward:
    /// dense` (see [`DenseReward`]): the team's own losses are left out
    /// (`reward_only_positive`) or taken off at `reward_negative_scale`; paid per kill, on a
    /// win, on a defeat; scaled (`reward_scale`) so that an episode pays
    /// `reward_scale_rate` at most.
    pub reward_only_positive: bool,
    pub reward_negative_scale: f64,
    pub reward_death_value: f64,
    pub reward_win: f64,
    pub reward_defeat: f64,
    pub reward_scale: bool,
    pub reward_scale_rate: f64,
    /// The MAPPO repository's agent-specific state in place of SMAC's global state (see
    /// [`EnvConfig`]'s `state_agent`).
    pub state_agent: bool,
}

impl Default for EnvOptions {
    fn default() -> Self {
        EnvOptions {
            step_mul: 8,
            reward: RewardMode::Dense,
            opponent: None,
            full_vision: false,
            passive_allies: true,
            cooldown_jitter: true,
            abilities: true,
            ability_actions: false,
            time_limit_loops: None,
            prob_obs_enemy: 1.0,
            action_mask: true,
            fov_actions: 0,
            data: None,
            weapon_period: WeaponPeriod::Attack,
            melee_surround: false,
            reward_only_positive: true,
            reward_negative_scale: 0.5,
            reward_death_value: 10.0,
            reward_win: 200.0,
            reward_defeat: 0.0,
            reward_scale: true,
            reward_scale_rate: 20.0,
            state_agent: false,
        }
    }
}

/// An option refused: its name, the value given and what is accepted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{option}={value}: {supported}")]
pub struct BadOption {
    pub option: &'static str,
    pub value: String,
    pub supported: String,
}

impl EnvOptions {
    /// The options' names, in the order of the Python constructors' keyword arguments (a test
    /// holds both constructors' signatures to it).
    pub const NAMES: [&'static str; 23] = [
        "step_mul",
        "reward",
        "opponent",
        "full_vision",
        "passive_allies",
        "cooldown_jitter",
        "abilities",
        "ability_actions",
        "time_limit_loops",
        "prob_obs_enemy",
        "action_mask",
        "fov_actions",
        "data",
        "weapon_period",
        "melee_surround",
        "reward_only_positive",
        "reward_negative_scale",
        "reward_death_value",
        "reward_win",
        "reward_defeat",
        "reward_scale",
        "reward_scale_rate",
        "state_agent",
    ];

    /// The engine's configuration, every option checked.
    pub fn config(&self) -> Result<EnvConfig, BadOption> {
        let bad = |option, value: String, supported: &str| BadOption { option, value, supported: supported.to_owned() };
        let mut cfg = if self.passive_allies { EnvConfig::smac() } else { EnvConfig::default() };
        cfg.step_mul =
            NonZeroU32::new(self.step_mul).ok_or_else(|| bad("step_mul", self.step_mul.to_string(), "game loops per step: 1 or more"))?;
        cfg.reward = self.reward;
        cfg.opponent = self.opponent;
        cfg.rules.full_vision = self.full_vision;
        cfg.rules.cooldown_jitter = self.cooldown_jitter;
        cfg.rules.abilities = self.abilities;
        cfg.rules.weapon_period = self.weapon_period;
        cfg.rules.melee_surround = self.melee_surround;
        cfg.ability_actions = self.ability_actions;
        cfg.time_limit_loops = match self.time_limit_loops {
            None => None,
            Some(t) => {
                Some(NonZeroU32::new(t).ok_or_else(|| bad("time_limit_loops", t.to_string(), "a time limit of 1 game loop or more"))?)
            }
        };
        if !(0.0..=1.0).contains(&self.prob_obs_enemy) {
            let why = "a probability in [0, 1] (1: extended partial observability off)";
            return Err(bad("prob_obs_enemy", self.prob_obs_enemy.to_string(), why));
        }
        cfg.prob_obs_enemy = self.prob_obs_enemy as f32;
        cfg.action_mask = self.action_mask;
        cfg.fov_actions = check_fov_actions(self.fov_actions)
            .map_err(|why| bad("num_fov_actions", self.fov_actions.to_string(), &format!("with conic_fov, {why}")))?;
        cfg.dense_reward = self.dense_reward()?;
        cfg.state_agent = self.state_agent;
        if let (RewardMode::Sparse, Some((option, value))) = (cfg.reward, cfg.dense_reward.first_change()) {
            return Err(bad(option, value, "SMAC's default with `reward: sparse` (these settings shape the dense reward)"));
        }
        Ok(cfg)
    }

    /// The dense reward's settings, checked. As in SMAC, `reward_negative_scale` is read only
    /// without `reward_only_positive` and `reward_scale_rate` only with `reward_scale`.
    fn dense_reward(&self) -> Result<DenseReward, BadOption> {
        let r = DenseReward {
            death_value: self.reward_death_value as f32,
            win: self.reward_win as f32,
            defeat: self.reward_defeat as f32,
            negative_scale: (!self.reward_only_positive).then_some(self.reward_negative_scale as f32),
            scale_rate: self.reward_scale.then_some(self.reward_scale_rate as f32),
        };
        r.check().map_err(|(option, v, why)| BadOption { option, value: v.to_string(), supported: why.to_owned() })?;
        Ok(r)
    }

    /// These options with a file's section put over them: `over` names options by their
    /// names, in their serde forms (`{step_mul: 4, full_vision: true}`); an unknown name or a
    /// value of the wrong form is refused with the name. `fixed` are options the file sets
    /// elsewhere (a launch file's top-level `opponent` and `data`), refused here.
    pub fn overlay(&self, over: &serde_json::Value, fixed: &[&str]) -> Result<EnvOptions, String> {
        let Some(over) = over.as_object() else { return Err(format!("{over}: a mapping of option names to values")) };
        let serde_json::Value::Object(mut merged) = serde_json::to_value(self).map_err(|e| e.to_string())? else {
            return Err("options that are not a mapping".into());
        };
        for (k, v) in over {
            if fixed.contains(&k.as_str()) {
                return Err(format!("`{k}` is set on its own here, not among the environment options"));
            }
            merged.insert(k.clone(), v.clone());
        }
        serde_json::from_value(serde_json::Value::Object(merged)).map_err(|e| e.to_string())
    }

    /// `s` on the unit data asked for (itself when none is).
    pub fn scenario(&self, s: Arc<Scenario>) -> Result<Arc<Scenario>, ScenarioError> {
        match self.data {
            None => Ok(s),
            Some(d) => Ok(Arc::new(s.with_data(d)?)),
        }
    }

    /// Parses the options' text forms (what Python and command lines pass): the reward mode,
    /// the opponent and the data set by name.
    pub fn reward_named(name: &str) -> Result<RewardMode, BadOption> {
        match name {
            "dense" => Ok(RewardMode::Dense),
            "sparse" => Ok(RewardMode::Sparse),
            other => Err(BadOption { option: "reward", value: other.into(), supported: "one of: dense, sparse".into() }),
        }
    }
    pub fn opponent_named(name: &str) -> Result<OpponentKind, BadOption> {
        name.parse::<OpponentKind>().map_err(|why| BadOption { option: "opponent", value: name.into(), supported: why })
    }
    pub fn data_named(name: &str) -> Result<DataSet, BadOption> {
        name.parse::<DataSet>().map_err(|_| BadOption {
            option: "data",
            value: name.into(),
            supported: "one of liberty, void, ladder, legacy (or None: the scenario's own)".into(),
        })
    }
    pub fn weapon_period_named(name: &str) -> Result<WeaponPeriod, BadOption> {
        name.parse::<WeaponPeriod>().map_err(|_| BadOption {
            option: "weapon_period",
            value: name.into(),
            supported: "one of attack (the engine's reading), shot (an experiment)".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_serde_fields_in_order() {
        let v = serde_json::to_value(EnvOptions::default()).expect("json");
        let keys: Vec<&str> = v.as_object().expect("an object").keys().map(String::as_str).collect();
        let mut names = EnvOptions::NAMES.to_vec();
        names.sort_unstable();
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, names);
        // The order: a `Value`'s map sorts its keys, the serialised text keeps the fields'.
        let text = serde_json::to_string(&EnvOptions::default()).expect("json");
        let at: Vec<usize> = EnvOptions::NAMES.iter().map(|n| text.find(&format!("\"{n}\":")).expect("each name")).collect();
        assert!(at.windows(2).all(|w| w[0] < w[1]), "NAMES out of the fields' order: {text}");
    }

    #[test]
    fn defaults_give_the_smac_config_and_bad_values_name_the_option() {
        let d = EnvOptions::default().config().expect("defaults");
        assert_eq!(d, EnvConfig { reward: RewardMode::Dense, ..EnvConfig::smac() });
        let e = EnvOptions { step_mul: 0, ..EnvOptions::default() }.config().expect_err("0 loops");
        assert_eq!(e.option, "step_mul");
        let e = EnvOptions { prob_obs_enemy: 1.5, ..EnvOptions::default() }.config().expect_err("p > 1");
        assert_eq!(e.option, "prob_obs_enemy");
        let e = EnvOptions { fov_actions: 3, ..EnvOptions::default() }.config().expect_err("odd");
        assert_eq!(e.option, "num_fov_actions");
        assert_eq!(EnvOptions::reward_named("shaped").expect_err("no such").option, "reward");
        // SMAC's reward settings: checked by their SMAC names, refused under the sparse reward.
        let signed = EnvOptions { reward_only_positive: false, reward_scale: false, ..EnvOptions::default() };
        let want = DenseReward { negative_scale: Some(0.5), scale_rate: None, ..DenseReward::default() };
        assert_eq!(signed.config().expect("signed, unscaled").dense_reward, want);
        // Settings SMAC does not read are not checked either.
        let unread = EnvOptions { reward_negative_scale: f64::NAN, reward_scale_rate: -1.0, ..signed.clone() };
        assert!(EnvOptions { reward_scale: false, ..unread }.config().is_err(), "read: the negative scale");
        assert!(EnvOptions { reward_only_positive: true, reward_scale: false, ..unread.clone() }.config().is_ok());
        for (o, name) in [
            (EnvOptions { reward_scale_rate: 0.0, ..EnvOptions::default() }, "reward_scale_rate"),
            (EnvOptions { reward_win: f64::NAN, ..EnvOptions::default() }, "reward_win"),
            (EnvOptions { reward_death_value: -1.0, ..EnvOptions::default() }, "reward_death_value"),
            (EnvOptions { reward_negative_scale: f64::INFINITY, ..signed.clone() }, "reward_negative_scale"),
            (EnvOptions { reward_defeat: 1e300, ..EnvOptions::default() }, "reward_defeat"),
            (EnvOptions { reward: RewardMode::Sparse, reward_only_positive: false, ..EnvOptions::default() }, "reward_only_positive"),
            (EnvOptions { reward: RewardMode::Sparse, reward_scale: false, ..EnvOptions::default() }, "reward_scale"),
        ] {
            assert_eq!(o.config().expect_err(name).option, name);
        }
        assert!(EnvOptions { reward_defeat: -5.0, ..EnvOptions::default() }.config().is_ok(), "a defeat may cost");
        assert_eq!(EnvOptions::data_named("brood_war").expect_err("no such").option, "data");
        // A file naming an unknown option is refused with the name.
        let err = serde_json::from_str::<EnvOptions>(r#"{"step_mull": 8}"#).expect_err("unknown key");
        assert!(err.to_string().contains("step_mull"), "{err}");
    }

    #[test]
    fn a_section_overlays_the_options_it_names_and_refuses_the_rest() {
        let base = EnvOptions { passive_allies: false, reward: RewardMode::Sparse, ..EnvOptions::default() };
        let o = base.overlay(&serde_json::json!({"step_mul": 4, "full_vision": true}), &[]).expect("two options");
        assert_eq!(o, EnvOptions { step_mul: 4, full_vision: true, ..base.clone() });
        assert_eq!(base.overlay(&serde_json::json!({}), &[]).expect("nothing"), base);
        let e = base.overlay(&serde_json::json!({"step_mull": 4}), &[]).expect_err("unknown");
        assert!(e.contains("step_mull"), "{e}");
        let e = base.overlay(&serde_json::json!({"step_mul": "fast"}), &[]).expect_err("a word");
        assert!(e.contains("fast"), "{e}");
        let e = base.overlay(&serde_json::json!({"opponent": "kite"}), &["opponent", "data"]).expect_err("fixed");
        assert!(e.contains("`opponent`"), "{e}");
        assert!(base.overlay(&serde_json::json!([1, 2]), &[]).is_err(), "not a mapping");
    }
}
