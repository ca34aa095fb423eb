//! `avacraft scenarios`: the built-in scenarios (the paper's, then the procedural ones) with
//! their teams, map, unit data set and time limit.

use anyhow::{Context, Result};
use avacraft_engine::{Scenario, Team, builtin, builtin_names, loops_to_seconds, procedural_names, smac_names};
use clap::Args;
use comfy_table::{Table, presets::UTF8_FULL_CONDENSED};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;

#[derive(Args, Debug)]
pub struct ScenariosArgs {
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Row {
    name: String,
    /// paper, smac or smacv2.
    family: String,
    mode: String,
    team1: usize,
    team2: usize,
    team1_units: String,
    team2_units: String,
    map: String,
    /// The unit data the scenario's map runs (`--data` plays another).
    data: String,
    time_limit_s: f32,
}

fn composition(s: &Scenario, team: Team) -> String {
    // Procedural: the types each unit is drawn from, with their weights.
    if let Some(g) = &s.generator {
        let w = g.types.iter().map(|(k, w)| format!("{k} {w}")).collect::<Vec<_>>().join(" / ");
        return format!("drawn: {w}");
    }
    let mut m: BTreeMap<&str, usize> = BTreeMap::new();
    for (_, u) in s.team_units(team) {
        *m.entry(u.kind.name()).or_default() += 1;
    }
    m.into_iter().map(|(k, n)| format!("{n} {k}")).collect::<Vec<_>>().join(", ")
}

pub fn scenarios(a: &ScenariosArgs, out: &mut dyn Write) -> Result<()> {
    let mut rows = Vec::new();
    let families =
        builtin_names().map(|n| (n, "paper")).chain(smac_names().map(|n| (n, "smac"))).chain(procedural_names().map(|n| (n, "smacv2")));
    for (name, family) in families {
        let s = builtin(name).with_context(|| format!("built-in scenario {name}"))?;
        rows.push(Row {
            name: s.name.clone(),
            family: family.to_owned(),
            mode: s.mode.to_string(),
            team1: s.count(Team::One),
            team2: s.count(Team::Two),
            team1_units: composition(&s, Team::One),
            team2_units: composition(&s, Team::Two),
            map: format!("{}x{}", s.terrain.width(), s.terrain.height()),
            data: s.data.to_string(),
            time_limit_s: loops_to_seconds(s.time_limit_loops),
        });
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let mut t = Table::new();
    t.load_preset(UTF8_FULL_CONDENSED).set_header([
        "scenario",
        "from",
        "mode",
        "team 1",
        "team 2",
        "team 1 units",
        "team 2 units",
        "map",
        "data",
    ]);
    for r in rows {
        t.add_row([r.name, r.family, r.mode, r.team1.to_string(), r.team2.to_string(), r.team1_units, r.team2_units, r.map, r.data]);
    }
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "From: paper = the AVACraft paper's 21 scenarios; smac = SMAC's 23 maps, under SMAC's names; smacv2 = procedural, SMACv2's settings."
    )?;
    let renamed: Vec<String> = avacraft_engine::RENAMED.iter().map(|(o, n)| format!("{o} -> {n}")).collect();
    writeln!(out, "Renamed: SMAC's names mean SMAC's maps; the paper's scenarios that had them are {}.", renamed.join(", "))?;
    writeln!(out, "Unit data sets (a scenario's is its map's; `--data` plays another):")?;
    for d in avacraft_engine::DataSet::ALL {
        writeln!(out, "  {:<8} {}", d.name(), d.describe())?;
    }
    Ok(())
}
