//! `episode`: run episodes in-process with scripted or trained policies and summarise the results.

use crate::flags::team_of;
use anyhow::{Context, Result, bail};
use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{
    Ability, Controllers, Env, EnvConfig, EnvOptions, Mode, OpponentKind, Outcome, RewardMode, Scenario, Team, loops_to_seconds,
};
use avacraft_policy::{AVA_POLICY, PolicySpec};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::io::IsTerminal;
use std::io::Write;
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct EpisodeArgs {
    /// Built-in scenario name or path to a scenario file.
    #[arg(long, required_unless_present = "launch")]
    pub scenario: Option<String>,
    /// The unit data to play on: liberty, void, ladder or legacy (default: the scenario's
    /// own, its map's; `avacraft scenarios` lists them).
    #[arg(long, value_parser = parse_data)]
    pub data: Option<avacraft_engine::DataSet>,
    /// Play a launch file's games in-process: its scenario, seeds, opponent and agent nodes
    /// (each node's units, policy and seed; `policy: marl:DIR` loads the checkpoint once and
    /// runs one network per node), exactly as `avacraft launch` deploys them, so the
    /// trajectory hashes can be compared with the deployment's.
    #[arg(long, conflicts_with_all = ["scenario", "data", "agent", "agent2", "opponent", "episodes", "seed", "full_vision", "passive_agents", "no_jitter", "no_abilities", "weapon_period", "melee_surround"])]
    pub launch: Option<std::path::PathBuf>,
    /// Policy for team 1: focus-fire, kite, attack-move, builtin, aggressive, defensive, focus, smac-heuristic,
    /// smac-heuristic-rest, random, hold, noop,
    /// marl:DIR, a checkpoint written by `avacraft train --out DIR` (refused if trained on another
    /// scenario or team size), or ava, the VLM agent (see the --llm-* options).
    #[arg(long, default_value = "kite")]
    pub agent: String,
    /// Policy for team 2 in PvP scenarios, as --agent (default: the same as --agent).
    #[arg(long)]
    pub agent2: Option<String>,
    /// Opponent in PvE: builtin, aggressive, defensive, focus or random (default: the scenario's).
    #[arg(long)]
    pub opponent: Option<String>,
    #[arg(long, default_value_t = 10)]
    pub episodes: u32,
    /// Seed of the first episode; episode k uses seed + k.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Turn fog of war off.
    #[arg(long)]
    pub full_vision: bool,
    /// Team 1's idle units do not acquire targets on their own (SMAC's passive allies).
    #[arg(long)]
    pub passive_agents: bool,
    /// Turn off StarCraft II's random attack delay.
    #[arg(long)]
    pub no_jitter: bool,
    /// Switch unit abilities off (SMAC's ability-less units).
    #[arg(long)]
    pub no_abilities: bool,
    /// Where weapons' periods are counted from: attack (the engine's reading) or shot (an
    /// experiment: the period from the damage point; docs/smac.md).
    #[arg(long, default_value = "attack")]
    pub weapon_period: avacraft_engine::WeaponPeriod,
    /// An experiment: melee units walk round those already at their target to a free place
    /// beside it instead of waiting behind them (the engine's rule is false; docs/smac.md).
    #[arg(long)]
    pub melee_surround: Option<bool>,
    /// Print team 1's text observation to stderr every N steps (0: never).
    #[arg(long, default_value_t = 0)]
    pub trace_every: u32,
    /// Record the first episode as an animated GIF (team 1's annotated view), e.g. out.gif.
    #[arg(long)]
    pub video: Option<std::path::PathBuf>,
    /// Frame size of the video, WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540")]
    pub video_size: String,
    /// Print a JSON result instead of a table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub ava: crate::ava::AvaArgs,
    #[command(flatten)]
    pub live: crate::live::LiveArgs,
}

/// One episode's result.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct EpisodeRecord {
    pub seed: u64,
    pub result: Outcome,
    pub opponent: Option<OpponentKind>,
    pub game_loops: u32,
    pub game_seconds: f32,
    pub steps: u32,
    pub units_left: [usize; 2],
    pub refused_actions: [u32; 2],
    /// Casts per ability, per team (team 1 first).
    pub abilities: [std::collections::BTreeMap<Ability, u32>; 2],
    pub trajectory_hash: String,
}

/// Mean and sample standard deviation.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Rate {
    pub mean: f64,
    pub std: f64,
}

/// Rates over all episodes.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Summary {
    pub scenario: String,
    pub mode: String,
    pub agent: String,
    pub agent2: Option<String>,
    pub opponent: Option<String>,
    pub episodes: usize,
    pub win: Rate,
    pub draw: Rate,
    pub loss: Rate,
    pub game_seconds: Rate,
}

/// What `episode --json` prints.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Report {
    pub summary: Summary,
    pub episodes: Vec<EpisodeRecord>,
    /// AVA's accounting per episode and team, when AVA played.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ava: Vec<avacraft_ava::cost::EpisodeCost>,
    /// With `--launch`: each AVA node's accounting (agent node or commander id to its
    /// episodes), as each node's `costs.json` holds it when deployed.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub ava_nodes: std::collections::BTreeMap<String, Vec<avacraft_ava::cost::EpisodeCost>>,
}

fn rate(xs: impl Iterator<Item = f64>) -> Rate {
    let v: Vec<f64> = xs.collect();
    let n = v.len().max(1) as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 { v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) } else { 0.0 };
    Rate { mean, std: var.sqrt() }
}

/// What is played: the scenario, the environment, who plays, and the seeds.
struct Setup {
    scenario: Arc<Scenario>,
    cfg: EnvConfig,
    controllers: Controllers,
    seeds: Vec<u64>,
    agent: String,
    agent2: Option<String>,
    opponent: Option<OpponentKind>,
    /// AVA's shared run and its recording folder, when AVA plays a side.
    ava: Option<(Arc<avacraft_ava::AvaRun>, Option<std::path::PathBuf>)>,
    /// With `--launch`: each AVA node's run, in the file's order.
    nodes: Vec<(String, Arc<avacraft_ava::AvaRun>)>,
    /// An image-mode checkpoint on team 1 (PvE): it acts on frames rendered from the game.
    frames: Option<Arc<avacraft_marl::Policy>>,
}

fn setup(a: &EpisodeArgs) -> Result<Setup> {
    if let Some(path) = &a.launch {
        let plan = avacraft_launch::load(path)?;
        let (controllers, runs) = plan.controllers_and_runs()?;
        let names = controllers.names();
        return Ok(Setup {
            cfg: plan.env_config(),
            scenario: Arc::clone(&plan.scenario),
            seeds: plan.seeds.clone(),
            agent: format!("{} ({} agent nodes)", names.first().cloned().unwrap_or_default(), names.len()),
            agent2: None,
            opponent: plan.opponent,
            controllers,
            ava: None,
            nodes: runs.into_iter().map(|(id, run)| (id.to_string(), run)).collect(),
            frames: None,
        });
    }
    if a.episodes == 0 {
        bail!("--episodes must be at least 1");
    }
    let Some(name) = &a.scenario else { bail!("--scenario or --launch is needed") };
    let scenario = Scenario::load(name)?;
    let scenario = Arc::new(match a.data {
        Some(d) => scenario.with_data(d).with_context(|| format!("--data {d}"))?,
        None => scenario,
    });
    let opponent = a.opponent.as_deref().map(str::parse::<OpponentKind>).transpose().map_err(anyhow::Error::msg).context("--opponent")?;
    if scenario.mode == Mode::Pvp && opponent.is_some() {
        bail!("--opponent applies to PvE scenarios; {} is PvP: pick team 2's policy with --agent2", scenario.name);
    }
    let agent2 = a.agent2.clone().unwrap_or_else(|| a.agent.clone());
    let pvp = scenario.mode == Mode::Pvp;
    // AVA's sides share one model, recording and accounting (each call records its team).
    let uses_ava = a.agent == AVA_POLICY || (pvp && agent2 == AVA_POLICY);
    let ava = if uses_ava { Some(a.ava.made(&scenario.name, a.seed)?) } else { None };
    if a.ava.dry_run && !uses_ava {
        bail!("--dry-run shows what AVA's model would see; it needs --agent ava");
    }
    let side = |team: Team, name: &str, flag: &str| -> Result<AgentTeam> {
        match (&ava, name == AVA_POLICY) {
            (Some((made, _)), true) => {
                let make = Arc::clone(&made.factory);
                Ok(AgentTeam::new(team, Grouping::Team, move || make()))
            }
            _ => team_agent(&scenario, (a.weapon_period, a.melee_surround.unwrap_or(false)), team, name, flag),
        }
    };
    // An image-mode checkpoint is not an engine agent: it plays PvE from rendered frames.
    let frames = if pvp || a.agent == AVA_POLICY {
        None
    } else {
        PolicySpec::parse(&a.agent, None)
            .and_then(|p| p.on(&scenario))
            .and_then(|p| p.frames_policy(&scenario))
            .with_context(|| format!("--agent {}", a.agent))?
    };
    // One agent per team, each acting for its units on their own observations.
    let mut teams = if frames.is_some() { Vec::new() } else { vec![side(Team::One, &a.agent, "--agent")?] };
    if pvp {
        teams.push(side(Team::Two, &agent2, if a.agent2.is_some() { "--agent2" } else { "--agent (for team 2)" })?);
    }
    let controllers = Controllers::new(&scenario, teams);
    // A network trained with the ability slots needs them in the game; every other agent
    // plays the same with or without them.
    let mut ability_actions = false;
    for (name, flag) in std::iter::once((&a.agent, "--agent")).chain(pvp.then_some((&agent2, "--agent2"))) {
        if name != AVA_POLICY {
            let spec = PolicySpec::parse(name, None).and_then(|p| p.on(&scenario)).with_context(|| format!("{flag} {name}"))?;
            ability_actions |= spec.ability_actions(&scenario).with_context(|| format!("{flag} {name}"))?;
        }
    }
    let cfg = EnvOptions {
        ability_actions,
        full_vision: a.full_vision,
        cooldown_jitter: !a.no_jitter,
        passive_allies: a.passive_agents,
        abilities: !a.no_abilities,
        weapon_period: a.weapon_period,
        melee_surround: a.melee_surround.unwrap_or(false),
        reward: RewardMode::Sparse,
        opponent,
        ..EnvOptions::default()
    }
    .config()
    .context("the episode's options")?;
    let seeds = (0..a.episodes as u64).map(|k| a.seed.wrapping_add(k)).collect();
    let ava = ava.map(|(made, dir)| (made.run.unwrap_or_else(|| unreachable!("an AVA policy is made with its run")), dir));
    Ok(Setup {
        scenario,
        cfg,
        controllers,
        seeds,
        agent: a.agent.clone(),
        agent2: pvp.then_some(agent2),
        opponent,
        ava,
        nodes: Vec::new(),
        frames,
    })
}

/// `team` played by one agent of the policy `name` (a scripted agent, `marl:DIR` or
/// `baseline:NAME`), checked
/// against the scenario.
fn team_agent(scenario: &Scenario, rules: (avacraft_engine::WeaponPeriod, bool), team: Team, name: &str, flag: &str) -> Result<AgentTeam> {
    let (period, surround) = rules;
    let spec = PolicySpec::parse(name, None).and_then(|p| p.on(scenario)).with_context(|| format!("{flag} {name}"))?;
    spec.check(scenario, team).with_context(|| format!("{flag} {name}"))?;
    if let Some(trained) = spec.trained_data(scenario).with_context(|| format!("{flag} {name}"))?
        && trained != scenario.data
    {
        eprintln!(
            "warning: {flag} {name} trained on the {trained} unit data; {} plays on {} here (--data {trained} plays the game it learned)",
            scenario.name, scenario.data
        );
    }
    if let Some(trained) = spec.trained_weapon_period(scenario).with_context(|| format!("{flag} {name}"))?
        && trained != period
    {
        eprintln!(
            "warning: {flag} {name} learned with weapon periods counted from the {trained}; from the {period} here (--weapon-period {trained} plays the game it learned)"
        );
    }
    // A melee policy leans on how its units find room round a target: trained under the
    // surround experiment, corridor's QMIX wins 94 of 100 held out with it and 18 without.
    if let Some(trained) = spec.trained_melee_surround(scenario).with_context(|| format!("{flag} {name}"))?
        && trained != surround
        && scenario.has_melee()
    {
        let (was, is) = if trained { ("under", "without") } else { ("without", "under") };
        eprintln!(
            "warning: {flag} {name} learned {was} the surround experiment and plays {is} it here (--melee-surround {trained} plays the game it learned)"
        );
    }
    let make = spec.factory().with_context(|| format!("{flag} {name}"))?;
    Ok(AgentTeam::new(team, Grouping::Team, move || make()))
}

/// The episodes, then their report (a table, or JSON) with AVA's costs.
pub fn run(a: &EpisodeArgs, out: &mut dyn Write) -> Result<()> {
    let Setup { scenario, cfg, mut controllers, seeds, agent, agent2, opponent, ava, nodes, frames } = setup(a)?;
    let mut frames = frames.map(|p| avacraft_marl::FramesActor::new(p, &scenario)).transpose()?;
    let bar = if a.json || !std::io::stderr().is_terminal() { ProgressBar::hidden() } else { ProgressBar::new(seeds.len() as u64) };
    bar.set_style(ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} episodes ({eta})")?.progress_chars("=> "));
    bar.set_message(scenario.name.clone());
    let mut env = Env::new(Arc::clone(&scenario), cfg, seeds[0]);
    let mut live = a.live.start("episode")?;
    if let (Some(l), Some((run, _))) = (&live, &ava) {
        // AVA's model calls go to the live log as they happen.
        let log = l.logger();
        run.observe(Box::new(move |rec, _| {
            let error = rec.error.as_ref().map(ToString::to_string);
            let reply = rec.reply.as_ref().map(|r| r.text.as_str());
            if let Some((level, name, text)) =
                crate::live::call_line(&format!("team{}", rec.team), rec.stage, rec.step, reply, error.as_deref())
            {
                log.line(level, &name, &text);
            }
        }));
    }
    let mut records = Vec::new();
    let mut video = video(a)?;
    for (k, &seed) in seeds.iter().enumerate() {
        env.reset(seed);
        controllers.reset(&env);
        if let Some(f) = frames.as_mut() {
            f.reset();
        }
        if let Some(l) = live.as_mut() {
            l.step(&env);
        }
        while !env.done() {
            if k == 0
                && let Some((writer, frames, cpu, w, h)) = video.as_mut()
            {
                let scene = frames.vlm(env.world(), Team::One, *w, *h, &avacraft_render::VlmOptions::default());
                writer.push(&cpu.render(&scene))?;
            }
            if a.trace_every > 0 && env.steps().is_multiple_of(a.trace_every) {
                eprintln!("--- seed {seed}, step {}\n{}", env.steps(), avacraft_engine::describe(&env, Team::One));
            }
            match frames.as_mut() {
                Some(f) => f.act(&mut env)?,
                None => controllers.act(&mut env),
            }
            if a.ava.dry_run {
                // What the model would have seen at the first decision is printed.
                return Ok(());
            }
            env.step();
            if let Some(l) = live.as_mut() {
                l.step(&env);
            }
        }
        if let Some(why) = ava.as_ref().and_then(|(run, _)| run.fatal()) {
            bail!("AVA stopped at episode seed {seed}: {why}");
        }
        if k == 0
            && let Some((writer, frames, cpu, w, h)) = video.as_mut()
        {
            let scene = frames.vlm(env.world(), Team::One, *w, *h, &avacraft_render::VlmOptions::default());
            writer.push(&cpu.render(&scene))?;
        }
        records.push(record(&env, seed));
        bar.inc(1);
    }
    bar.finish_and_clear();
    if let Some(l) = &live {
        eprintln!("{}", l.summary());
    }
    if let (Some((writer, ..)), Some(path)) = (video, &a.video) {
        let frames = writer.finish()?;
        eprintln!("{}: {} frames of the first episode", path.display(), frames);
    }
    let is = |o: Outcome| move |r: &EpisodeRecord| if r.result == o { 1.0 } else { 0.0 };
    let summary = Summary {
        scenario: scenario.name.clone(),
        mode: scenario.mode.to_string(),
        agent,
        agent2,
        opponent: (scenario.mode == Mode::Pve).then(|| opponent.unwrap_or(scenario.opponent).to_string()),
        episodes: records.len(),
        win: rate(records.iter().map(is(Outcome::Win))),
        draw: rate(records.iter().map(is(Outcome::Draw))),
        loss: rate(records.iter().map(is(Outcome::Loss))),
        game_seconds: rate(records.iter().map(|r| r.game_seconds as f64)),
    };
    let ava_costs = match &ava {
        Some((run, dir)) => crate::ava::report(run, dir.as_deref(), &mut std::io::sink(), true)?,
        None => Vec::new(),
    };
    if a.json {
        let ava_nodes = nodes.iter().map(|(id, run)| (id.clone(), run.episodes())).collect();
        writeln!(out, "{}", serde_json::to_string_pretty(&Report { summary, episodes: records, ava: ava_costs, ava_nodes })?)?;
        return Ok(());
    }
    table(&summary, &records, seeds[0], out)?;
    if let Some((run, dir)) = &ava {
        crate::ava::report(run, dir.as_deref(), out, false)?;
    }
    // Each node's costs.json is written by the node's run itself when it records.
    for (id, run) in &nodes {
        writeln!(out, "AVA node {id}:")?;
        crate::ava::report(run, None, out, false)?;
    }
    let _ = team_of;
    Ok(())
}

/// What a finished episode leaves.
fn record(env: &Env, seed: u64) -> EpisodeRecord {
    let w = env.world();
    EpisodeRecord {
        seed,
        result: env.outcome().unwrap_or(Outcome::Draw),
        opponent: env.opponent(),
        game_loops: w.tick(),
        game_seconds: loops_to_seconds(w.tick()),
        steps: env.steps(),
        units_left: [w.alive(Team::One).count(), w.alive(Team::Two).count()],
        refused_actions: env.refused(),
        abilities: Team::BOTH.map(|t| w.stats(t).abilities.clone()),
        trajectory_hash: format!("{:016x}", env.trajectory_hash()),
    }
}

/// The text report: the rates, then the abilities each side cast.
fn table(summary: &Summary, records: &[EpisodeRecord], first_seed: u64, out: &mut dyn Write) -> Result<()> {
    let who = match (&summary.opponent, &summary.agent2) {
        (Some(o), _) => format!("{} vs opponent {}", summary.agent, o),
        (None, Some(b)) => format!("{} (team 1) vs {} (team 2)", summary.agent, b),
        _ => summary.agent.clone(),
    };
    writeln!(out, "{} ({}), {}: {} episodes from seed {}", summary.scenario, summary.mode, who, summary.episodes, first_seed)?;
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(["", "mean", "std"]);
    for (name, r) in [("win rate", &summary.win), ("draw rate", &summary.draw), ("loss rate", &summary.loss)] {
        t.add_row([name.to_owned(), format!("{:.3}", r.mean), format!("{:.3}", r.std)]);
    }
    t.add_row(["game seconds".to_owned(), format!("{:.1}", summary.game_seconds.mean), format!("{:.1}", summary.game_seconds.std)]);
    writeln!(out, "{t}")?;
    let mut casts: std::collections::BTreeMap<Ability, [u32; 2]> = Default::default();
    for r in records {
        for (side, m) in r.abilities.iter().enumerate() {
            for (a, n) in m {
                casts.entry(*a).or_default()[side] += n;
            }
        }
    }
    if !casts.is_empty() {
        let mut t = comfy_table::Table::new();
        t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(["ability", "team 1 casts", "team 2 casts"]);
        for (a, [x, y]) in casts {
            t.add_row([a.name().to_owned(), x.to_string(), y.to_string()]);
        }
        writeln!(out, "{t}")?;
    }
    Ok(())
}

/// The first episode's video writer, frame builder, renderer and size, when asked for.
type Video = (avacraft_render::VideoWriter, avacraft_render::FrameBuilder, avacraft_render::CpuBackend, u32, u32);

fn video(a: &EpisodeArgs) -> Result<Option<Video>> {
    let Some(path) = &a.video else { return Ok(None) };
    let (w, h) = crate::render::parse_size(&a.video_size)?;
    // One step (8 loops, 0.36 s of game time) per frame, played at about 2x.
    Ok(Some((
        avacraft_render::VideoWriter::create(path, 180)?,
        avacraft_render::FrameBuilder::new(),
        avacraft_render::CpuBackend::new(),
        w,
        h,
    )))
}

/// `--data`'s parser: one of the data sets, with their list in the error.
pub(crate) fn parse_data(s: &str) -> Result<avacraft_engine::DataSet, String> {
    s.parse().map_err(|e: avacraft_engine::UnknownDataSet| e.to_string())
}
