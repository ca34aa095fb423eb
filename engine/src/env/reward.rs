//! The settings of SMAC's shaped reward (paid by `Env::dense_reward`, beside the step): its
//! `reward_battle` (damage and kills dealt, and without `reward_only_positive` the team's own
//! losses) and the end-of-episode terms of its `step` (`reward_win`, `reward_defeat`, then
//! `reward_scale`).

use serde::{Deserialize, Serialize};

/// SMAC's dense-reward settings under their SMAC meanings; the default is SMAC's default.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DenseReward {
    /// Paid per enemy killed (`reward_death_value`).
    pub death_value: f32,
    /// Paid on a win (`reward_win`).
    pub win: f32,
    /// Paid on a defeat (`reward_defeat`; SMAC adds it with or without
    /// `reward_only_positive`).
    pub defeat: f32,
    /// `None`: SMAC's `reward_only_positive` (the default): the absolute value of the damage
    /// and kills dealt in a step. `Some(s)`: the signed reward, less `s` times the team's own
    /// life and shields lost and `s` times `death_value` per unit of its own killed
    /// (`reward_negative_scale`).
    pub negative_scale: Option<f32>,
    /// `Some(rate)`: divided by the most an episode can pay over `rate` (`reward_scale` with
    /// `reward_scale_rate`); `None`: unscaled.
    pub scale_rate: Option<f32>,
}

impl Default for DenseReward {
    fn default() -> Self {
        Self { death_value: 10.0, win: 200.0, defeat: 0.0, negative_scale: None, scale_rate: Some(20.0) }
    }
}

impl DenseReward {
    /// Whether these are SMAC's defaults (what the deployment's session description can say).
    pub fn is_smac_default(&self) -> bool {
        *self == Self::default()
    }

    /// The first setting that is not SMAC's default, by SMAC's keyword name, with its value.
    pub fn first_change(&self) -> Option<(&'static str, String)> {
        let d = Self::default();
        let changed = |a: f32, b: f32| (a != b).then(|| a.to_string());
        changed(self.death_value, d.death_value)
            .map(|v| ("reward_death_value", v))
            .or_else(|| changed(self.win, d.win).map(|v| ("reward_win", v)))
            .or_else(|| changed(self.defeat, d.defeat).map(|v| ("reward_defeat", v)))
            .or_else(|| self.negative_scale.is_some().then(|| ("reward_only_positive", "false".to_owned())))
            .or_else(|| match (self.scale_rate, d.scale_rate) {
                (None, _) => Some(("reward_scale", "false".to_owned())),
                (Some(r), Some(dr)) => changed(r, dr).map(|v| ("reward_scale_rate", v)),
                (Some(_), None) => None,
            })
    }

    /// The first setting that is not accepted, by SMAC's keyword name, with its value and
    /// what is accepted. Kills and wins must not cost, so that the most an episode can pay
    /// (what `reward_scale` divides by) stays positive.
    pub fn check(&self) -> Result<(), (&'static str, f32, &'static str)> {
        let finite = "a finite number";
        let at_least_0 = "a finite number of 0 or more";
        let fields = [
            ("reward_death_value", Some(self.death_value), at_least_0),
            ("reward_win", Some(self.win), at_least_0),
            ("reward_defeat", Some(self.defeat), finite),
            ("reward_negative_scale", self.negative_scale, at_least_0),
            ("reward_scale_rate", self.scale_rate, "a finite number above 0"),
        ];
        for (name, v, why) in fields {
            let Some(v) = v else { continue };
            let ok = v.is_finite()
                && match name {
                    "reward_defeat" => true,
                    "reward_scale_rate" => v > 0.0,
                    _ => v >= 0.0,
                };
            if !ok {
                return Err((name, v, why));
            }
        }
        Ok(())
    }
}
