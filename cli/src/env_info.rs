//! `avacraft env-info`: SMAC's `get_env_info()` for a scenario and team.

use crate::flags::team_of;
use anyhow::Result;
use avacraft_engine::{Env, EnvConfig, Scenario};
use clap::Args;
use std::io::Write;
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct EnvInfoArgs {
    /// Built-in scenario name or path to a scenario file.
    #[arg(long)]
    scenario: String,
    /// Whose agents (2 only makes sense in PvP).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    team: u8,
    /// Print JSON (SMAC's get_env_info keys).
    #[arg(long)]
    json: bool,
    /// With the opt-in ability extension of the discrete actions (ability slots per unit
    /// type, their masks, and energy and slot features in the observations).
    #[arg(long)]
    ability_actions: bool,
}

pub fn env_info(a: &EnvInfoArgs, out: &mut dyn Write) -> Result<()> {
    let s = Scenario::load(&a.scenario)?;
    let env = Env::new(Arc::new(s), EnvConfig { ability_actions: a.ability_actions, ..EnvConfig::default() }, 0);
    let team = team_of(a.team);
    let info = env.env_info(team);
    let layout = env.smac_layout(team);
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&info)?)?;
    } else {
        writeln!(
            out,
            "n_agents {}\nn_actions {}\nobs_shape {}\nstate_shape {}\nepisode_limit {}",
            info.n_agents, info.n_actions, info.obs_shape, info.state_shape, info.episode_limit
        )?;
        if layout.abilities.slots > 0 {
            writeln!(
                out,
                "ability slots {} x {} actions from index {}",
                layout.abilities.slots,
                layout.abilities.width,
                layout.ability_base()
            )?;
            let mut seen = std::collections::BTreeSet::new();
            for (agent, list) in layout.abilities.per_agent.iter().enumerate() {
                let kind = env.world().unit(layout.agents[agent]).map(|u| u.kind.base());
                if let Some(k) = kind
                    && seen.insert(k)
                {
                    let names: Vec<&str> = list.iter().map(|a| a.name()).collect();
                    writeln!(out, "  {k}: {}", if names.is_empty() { "-".to_owned() } else { names.join(", ") })?;
                }
            }
        }
    }
    Ok(())
}
