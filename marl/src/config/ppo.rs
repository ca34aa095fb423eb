//! The PPO learners' checks of a config (IPPO's and MAPPO's keys), apart from the
//! Q-learners' in `mod.rs`.

use super::{Config, ObsKind, at_least, bad, positive, unit, validate_obs};
use crate::Error;

/// The most steps `stacked_frames` stacks (the MAPPO repository's scripts use 4).
const MAX_STACKED: usize = 16;

impl Config {
    pub(super) fn validate_ppo(&self, def: &dyn Fn(fn(&Config) -> f64, f64) -> f64) -> Result<(), Error> {
        positive("critic_lr", self.critic_lr, def(|c| c.critic_lr, 5e-4))?;
        at_least("data_chunk_length", self.data_chunk_length, 1)?;
        at_least("rollout_len", self.rollout_len, self.data_chunk_length)?;
        if !self.rollout_len.is_multiple_of(self.data_chunk_length) {
            let c = self.data_chunk_length;
            let down = self.rollout_len / c * c;
            let nearest = if self.rollout_len - down <= c / 2 { down } else { down + c };
            return Err(bad(
                "rollout_len",
                self.rollout_len,
                &format!("must be a multiple of data_chunk_length ({c})"),
                format!("{nearest} (or data_chunk_length = a divisor of {})", self.rollout_len),
            ));
        }
        at_least("ppo_epochs", self.ppo_epochs, 1)?;
        at_least("num_mini_batch", self.num_mini_batch, 1)?;
        let chunks = self.envs * self.rollout_len / self.data_chunk_length;
        if self.num_mini_batch > chunks {
            return Err(bad(
                "num_mini_batch",
                self.num_mini_batch,
                &format!("at most the number of chunks, envs x rollout_len / data_chunk_length = {chunks}"),
                chunks,
            ));
        }
        positive("clip_param", self.clip_param, def(|c| c.clip_param, 0.2))?;
        // Critic options that one of the two algorithms alone has.
        let only = [
            (
                "shared_trunk",
                self.shared_trunk,
                "ippo",
                "only IPPO's critic can share the actor's trunk: MAPPO's critic reads the global state, which the actor never sees",
            ),
            (
                "critic_agent_obs",
                self.critic_agent_obs,
                "mappo",
                "only MAPPO's critic reads the global state; IPPO's reads the observation alone",
            ),
        ];
        if let Some((key, _, _, why)) = only.into_iter().find(|(_, on, algo, _)| *on && self.algo != *algo) {
            return Err(bad(key, true, why, false));
        }
        if self.critic_agent_obs && self.state_agent {
            let why = "the agent-specific state (`state_agent`) already holds what the agent sees: set one of the two";
            return Err(bad("critic_agent_obs", true, why, false));
        }
        if self.shared_trunk && self.obs != ObsKind::Features {
            return Err(bad(
                "shared_trunk",
                true,
                &format!(
                    "a shared trunk reads SMAC's features only (obs = \"{}\" has an image encoder in front of the actor)",
                    self.obs.name()
                ),
                false,
            ));
        }
        if !(1..=MAX_STACKED).contains(&self.stacked_frames) {
            return Err(bad("stacked_frames", self.stacked_frames, &format!("1 (no stacking) to {MAX_STACKED} steps"), 1));
        }
        if self.stacked_frames > 1 && (self.obs != ObsKind::Features || self.self_play()) {
            let why = "stacking reads SMAC's features under a fixed opponent (not an image mode, not self-play, whose snapshots act without the history)";
            return Err(bad("stacked_frames", self.stacked_frames, why, 1));
        }
        unit("gae_lambda", self.gae_lambda)?;
        for (key, v) in [
            ("huber_delta", self.huber_delta),
            ("entropy_coef", self.entropy_coef),
            ("value_loss_coef", self.value_loss_coef),
            ("actor_out_gain", self.actor_out_gain),
        ] {
            if v.is_nan() || v < 0.0 {
                return Err(bad(key, v, "must not be negative", 0.0));
            }
        }
        validate_obs(self)?;
        Ok(())
    }
}
