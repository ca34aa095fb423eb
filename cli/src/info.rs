//! `scenarios` and `env-info`.

use anyhow::{Context, Result};
use avacraft_engine::{Env, EnvConfig, Scenario, Team, builtin, builtin_names, loops_to_seconds};
use clap::Args;
use comfy_table::{Table, presets::UTF8_FULL_CONDENSED};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct ScenariosArgs {
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

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

#[derive(Serialize)]
struct Row {
    name: String,
    mode: String,
    team1: usize,
    team2: usize,
    team1_units: String,
    team2_units: String,
    map: String,
    time_limit_s: f32,
}

pub(crate) fn team_of(n: u8) -> Team {
    if n == 2 { Team::Two } else { Team::One }
}

fn composition(s: &Scenario, team: Team) -> String {
    let mut m: BTreeMap<&str, usize> = BTreeMap::new();
    for (_, u) in s.team_units(team) {
        *m.entry(u.kind.name()).or_default() += 1;
    }
    m.into_iter().map(|(k, n)| format!("{n} {k}")).collect::<Vec<_>>().join(", ")
}

pub fn scenarios(a: &ScenariosArgs, out: &mut dyn Write) -> Result<()> {
    let mut rows = Vec::new();
    for name in builtin_names() {
        let s = builtin(name).with_context(|| format!("built-in scenario {name}"))?;
        rows.push(Row {
            name: s.name.clone(),
            mode: s.mode.to_string(),
            team1: s.count(Team::One),
            team2: s.count(Team::Two),
            team1_units: composition(&s, Team::One),
            team2_units: composition(&s, Team::Two),
            map: format!("{}x{}", s.terrain.width(), s.terrain.height()),
            time_limit_s: loops_to_seconds(s.time_limit_loops),
        });
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let mut t = Table::new();
    t.load_preset(UTF8_FULL_CONDENSED).set_header(["scenario", "mode", "team 1", "team 2", "team 1 units", "team 2 units", "map"]);
    for r in rows {
        t.add_row([r.name, r.mode, r.team1.to_string(), r.team2.to_string(), r.team1_units, r.team2_units, r.map]);
    }
    writeln!(out, "{t}")?;
    Ok(())
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
