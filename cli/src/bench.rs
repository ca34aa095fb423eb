//! `bench`: environment steps per second (one step = `step_mul` game loops plus every
//! agent's observation, the state and the available actions, as a MARL training loop
//! consumes them), single thread, with random available actions; and bytes per env.

use anyhow::Result;
use avacraft_engine::{Env, EnvConfig, Scenario, Team, builtin_names};
use clap::Args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use stats_alloc::{Region, StatsAlloc};
use std::alloc::System;
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

/// The goal for 2s3z_vlm on one core.
const GOAL_STEPS_PER_SEC: f64 = 100_000.0;

impl BenchArgs {
    const DEFAULT_SCENARIOS: [&str; 5] = ["3m_vlm", "2s3z_vlm", "2c_vs_64zg_vlm", "8m3mr1mv1st_mirror", "pvz_ht"];
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scenario names or files; `all` for every built-in scenario.
    #[arg(long, num_args = 1.., default_values_t = ["3m_vlm".to_owned(), "2s3z_vlm".to_owned(), "2c_vs_64zg_vlm".to_owned(), "8m3mr1mv1st_mirror".to_owned(), "pvz_ht".to_owned()])]
    scenario: Vec<String>,
    /// Seconds of measurement per scenario and configuration.
    #[arg(long, default_value_t = 2.0)]
    seconds: f64,
    /// Run exactly this many steps per configuration instead of a time budget (for
    /// instruction counts under callgrind, which do not depend on machine load); with
    /// --train, the steps each algorithm trains for.
    #[arg(long)]
    steps: Option<u64>,
    #[arg(long)]
    json: bool,
    /// Instead: measure how the cost per unit grows with army size (N Marines against N
    /// Marines, N = 4 .. 256, on a flat 96x96 map), to check near-linear scaling.
    #[arg(long, conflicts_with = "render")]
    scaling: bool,
    /// Instead: measure rendering (screen + minimap pairs per second at 160x120 and 32x32,
    /// milliseconds per 1920x1080 VLM screenshot) on each available back end.
    #[arg(long, conflicts_with = "steps")]
    render: bool,
    /// Instead: measure the distributed deployment (lockstep steps/s with one agent process
    /// per unit for 3m_vlm and pvz_ht, observation-to-action round trip, frame latency through
    /// Zenoh, the cost of recording), each against its goal.
    #[arg(long)]
    deploy: bool,
    /// Instead: measure the ROS 2 DDS bridge (latency and throughput of a unit observation
    /// and a 160x120 frame onto DDS, against the direct Zenoh path in the same run).
    #[arg(long, conflicts_with = "deploy")]
    bridge: bool,
    /// Instead: a vector environment of `--envs` episodes on all cores against one
    /// environment on one core (default scenarios: 3m_vlm and 2s3z_vlm), and the per-core rate
    /// against 150,000 steps/s.
    #[arg(long, conflicts_with_all = ["deploy", "bridge", "render", "scaling", "steps"])]
    vec: bool,
    /// Environments of the vector benchmark.
    #[arg(long, default_value_t = 64, requires = "vec")]
    envs: usize,
    /// Instead: training throughput (environment steps per second with learning) of each
    /// `--algo` on `--scenario` (default 3m_vlm) for `--steps` steps (default 10000), against the
    /// same vector environment stepped with random actions in the same run.
    #[arg(long, conflicts_with_all = ["deploy", "bridge", "render", "scaling", "vec"])]
    train: bool,
    /// With --train: the learners' goal rows (IPPO and MAPPO with JaxMARL's settings on 3m_vlm
    /// and 2s3z_vlm, QMIX with PyMARL's defaults and feed-forward, MAPPO rgb and vision-text),
    /// each against its goal, `--steps` steps each (default 153600; the image modes one or two
    /// rollouts of their config).
    #[arg(long, requires = "train", conflicts_with = "algo")]
    goals: bool,
    /// With --goals: only the goal rows whose label, algorithm or scenario contains this
    /// (repeatable), e.g. --only QMIX --only 2s3z_vlm.
    #[arg(long, requires = "goals")]
    only: Vec<String>,
    /// With --goals: a JaxMARL checkout (github.com/FLAIROx/JaxMARL) whose IPPO and MAPPO SMAX
    /// baselines run in this run with the same settings, beside the rows they compare with;
    /// the 3m_vlm goals become 1.2x its IPPO. Needs a Python with jax and JaxMARL's dependencies
    /// (--jaxmarl-python).
    #[arg(long, requires = "goals", value_name = "DIR")]
    jaxmarl: Option<std::path::PathBuf>,
    /// The Python that runs JaxMARL.
    #[arg(long, requires = "jaxmarl", default_value = "python3", value_name = "PATH")]
    jaxmarl_python: std::path::PathBuf,
    /// Algorithms of the training benchmark (default: all six).
    #[arg(long, num_args = 1.., requires = "train")]
    algo: Vec<String>,
    /// Instead: AVA's pipeline time per decision beyond the model's (default scenarios: 3m_vlm
    /// and pvz_ht; `--steps` decisions per variant, default 60), against its goals and an
    /// environment step.
    #[arg(long, conflicts_with_all = ["deploy", "bridge", "render", "scaling", "vec", "train"])]
    ava: bool,
    /// Config overrides of the training benchmark, e.g. --set use_rnn=false (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE", requires = "train")]
    set: Vec<String>,
}

impl BenchArgs {
    /// Whether this run trains (and so wants `train`'s process environment).
    pub fn trains(&self) -> bool {
        self.train
    }
}

/// One back end's rendering speed on one scenario.
#[derive(Serialize, Debug, Clone)]
pub struct RenderRow {
    pub backend: String,
    pub scenario: String,
    pub screen_minimap_pairs_per_sec: f64,
    pub ms_per_vlm_1080p: f64,
    /// pairs per second / 5,000 (the goal on one core).
    pub pairs_ratio_to_goal: f64,
    /// 20 ms / ms per screenshot (above 1 meets the goal).
    pub vlm_ratio_to_goal: f64,
}

fn render_row(backend: &str, scenario: &str, pps: f64, ms: f64) -> RenderRow {
    RenderRow {
        backend: backend.to_owned(),
        scenario: scenario.to_owned(),
        screen_minimap_pairs_per_sec: pps,
        ms_per_vlm_1080p: ms,
        pairs_ratio_to_goal: pps / 5000.0,
        vlm_ratio_to_goal: 20.0 / ms,
    }
}

/// Runs a closure for at least `budget` seconds and `min` times: (runs, seconds).
type Timed<'a> = &'a dyn Fn(f64, u64, &mut dyn FnMut()) -> (u64, f64);

/// The wgpu back end's row, where the program has it (`--features gpu`).
#[cfg(feature = "gpu")]
fn wgpu_row(
    rows: &mut Vec<RenderRow>,
    a: &BenchArgs,
    scenario: &str,
    env: &Env,
    frames: &mut avacraft_render::FrameBuilder,
    timed: Timed<'_>,
) -> Result<()> {
    use avacraft_render::VlmOptions;
    match avacraft_render::WgpuBackend::new() {
        Ok(mut gpu) => {
            let mut ok = true;
            // Batches of 64, as a vectorised MARL loop would hand them over.
            const BATCH: usize = 64;
            let (batches, secs) = timed(a.seconds / 4.0, 1, &mut || {
                // Scenes are built inside the timing, as for the CPU.
                let screens: Vec<_> = (0..BATCH).map(|_| frames.screen(env.world(), Team::One, 160, 120)).collect();
                let minis: Vec<_> = (0..BATCH).map(|_| frames.minimap(env.world(), Team::One, 32, 32)).collect();
                ok &= gpu.render_batch(&screens).is_ok();
                ok &= gpu.render_batch(&minis).is_ok();
            });
            let pairs = batches * BATCH as u64;
            let (shots, shot_secs) = timed(a.seconds / 4.0, 3, &mut || {
                ok &= gpu.render(&frames.vlm(env.world(), Team::One, 1920, 1080, &VlmOptions::default())).is_ok();
            });
            if !ok {
                anyhow::bail!("the wgpu back end failed to render a frame");
            }
            rows.push(render_row(&format!("wgpu: {}", gpu.adapter()), scenario, pairs as f64 / secs, shot_secs * 1000.0 / shots as f64));
        }
        Err(e) => eprintln!("wgpu back end not measured: {e}"),
    }
    Ok(())
}

#[cfg(not(feature = "gpu"))]
fn wgpu_row(_: &mut Vec<RenderRow>, _: &BenchArgs, _: &str, _: &Env, _: &mut avacraft_render::FrameBuilder, _: Timed<'_>) -> Result<()> {
    eprintln!(
        "wgpu back end not measured: this program was built without its `gpu` feature (cargo run --release -p avacraft-cli --features gpu -- bench --render)"
    );
    Ok(())
}

fn run_render(a: &BenchArgs, out: &mut dyn Write) -> Result<()> {
    use avacraft_render::{CpuBackend, FrameBuilder, VlmOptions};
    let mut rows = Vec::new();
    for name in &scenario_names(a) {
        let scenario = Arc::new(Scenario::load(name)?);
        let mut env = Env::new(Arc::clone(&scenario), EnvConfig::default(), 1);
        for _ in 0..20 {
            env.step();
        }
        let mut frames = FrameBuilder::new();
        let mut cpu = CpuBackend::new();
        let (mut screen, mut mini) = (avacraft_render::RgbImage::new(160, 120), avacraft_render::RgbImage::new(32, 32));
        let timed = |budget: f64, min: u64, f: &mut dyn FnMut()| {
            let start = Instant::now();
            let mut n = 0u64;
            while start.elapsed().as_secs_f64() < budget || n < min {
                f();
                n += 1;
            }
            (n, start.elapsed().as_secs_f64())
        };
        let (pairs, secs) = timed(a.seconds / 4.0, 1, &mut || {
            cpu.render_into(&frames.screen(env.world(), Team::One, 160, 120), &mut screen);
            cpu.render_into(&frames.minimap(env.world(), Team::One, 32, 32), &mut mini);
        });
        let mut shot = avacraft_render::RgbImage::new(1920, 1080);
        let (shots, shot_secs) = timed(a.seconds / 4.0, 3, &mut || {
            cpu.render_into(&frames.vlm(env.world(), Team::One, 1920, 1080, &VlmOptions::default()), &mut shot);
        });
        std::hint::black_box((&screen, &mini, &shot));
        rows.push(render_row("cpu", &scenario.name, pairs as f64 / secs, shot_secs * 1000.0 / shots as f64));
        wgpu_row(&mut rows, a, &scenario.name, &env, &mut frames, &timed)?;
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let t = table(
        &["back end", "scenario", "screen+minimap/s", "ratio to 5k goal", "ms per 1080p VLM", "ratio to 20 ms goal"],
        rows.iter().map(|r| {
            vec![
                r.backend.clone(),
                r.scenario.clone(),
                format!("{:.0}", r.screen_minimap_pairs_per_sec),
                format!("{:.2}", r.pairs_ratio_to_goal),
                format!("{:.2}", r.ms_per_vlm_1080p),
                format!("{:.2}", r.vlm_ratio_to_goal),
            ]
        }),
    );
    writeln!(out, "{t}")?;
    Ok(())
}

/// One army size of the scaling measurement.
#[derive(Serialize, Debug, Clone)]
pub struct ScalingRow {
    pub units: usize,
    pub game_loops_per_sec: f64,
    /// Nanoseconds per unit per game loop; flat when cost grows linearly with units.
    pub ns_per_unit_loop: f64,
    /// ns_per_unit_loop relative to the smallest army, measured in the same run.
    pub ratio_to_smallest: f64,
}

fn scaling_scenario(n: usize) -> Result<Scenario> {
    let side = (n as f32).sqrt().ceil() as usize;
    let mut units = String::new();
    for team in [1, 2] {
        for k in 0..n {
            let (row, col) = (k / side, k % side);
            let x = if team == 1 { 30.0 - col as f32 * 1.0 } else { 66.0 + col as f32 * 1.0 };
            let y = 48.0 - side as f32 * 0.5 + row as f32 * 1.0;
            units.push_str(&format!("  {{ type = \"Marine\", team = {team}, x = {x}, y = {y} }},\n"));
        }
    }
    let text = format!(
        "name = \"scaling_{n}\"\nmode = \"pve\"\nmap_size = [96, 96]\nunits = [\n{units}]\n[opponent]\nstart = {{ kind = \"attack_move\", x = 30.0, y = 48.0 }}\n"
    );
    Ok(Scenario::from_toml(&format!("<scaling {n}>"), &text)?)
}

fn run_scaling(a: &BenchArgs, out: &mut dyn Write) -> Result<()> {
    let mut rows: Vec<ScalingRow> = Vec::new();
    for n in [4usize, 8, 16, 32, 64, 128, 256] {
        let scenario = Arc::new(scaling_scenario(n)?);
        let (_, _, loops, secs) =
            measure(&scenario, a.seconds / 2.0, a.steps, Config { with_obs: false, random_actions: true, abilities: true });
        let lps = loops as f64 / secs;
        let ns = 1e9 / lps / (2 * n) as f64;
        let base = rows.first().map_or(ns, |r| r.ns_per_unit_loop);
        rows.push(ScalingRow { units: 2 * n, game_loops_per_sec: lps, ns_per_unit_loop: ns, ratio_to_smallest: ns / base });
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let t = table(
        &["units", "game loops/s", "ns per unit-loop", "ratio to smallest"],
        rows.iter().map(|r| {
            vec![
                r.units.to_string(),
                format!("{:.0}", r.game_loops_per_sec),
                format!("{:.0}", r.ns_per_unit_loop),
                format!("{:.2}", r.ratio_to_smallest),
            ]
        }),
    );
    writeln!(out, "{t}")?;
    Ok(())
}

/// One scenario's measurement.
#[derive(Serialize, Debug, Clone)]
pub struct BenchRow {
    scenario: String,
    /// The unit data the scenario plays (its map's).
    data: String,
    units: usize,
    steps: u64,
    episodes: u64,
    steps_per_sec: f64,
    /// Baseline measured in the same run: the same stepping without observations.
    sim_only_steps_per_sec: f64,
    /// steps_per_sec / sim_only_steps_per_sec: what observations cost.
    ratio_to_sim_only: f64,
    /// steps_per_sec / 100,000 (the 2s3z_vlm goal).
    ratio_to_goal: f64,
    /// Baseline measured in the same run: abilities switched off (no casts, no scripted
    /// ability use, SMAC's plain action set).
    no_abilities_steps_per_sec: f64,
    /// steps_per_sec / no_abilities_steps_per_sec (goal: at least 0.5).
    ratio_to_no_abilities: f64,
    game_loops_per_sec: f64,
    /// Baseline measured in the same run: the scenario on the legacy data set (no weapon
    /// timing: attacks land at once, no missiles in flight), the engine's game before it read
    /// StarCraft II's data files.
    legacy_steps_per_sec: f64,
    /// steps_per_sec / legacy_steps_per_sec: what the maps' own data and weapon timing cost
    /// (goal: at least 0.9). The battles differ too, so it measures the game, not only code.
    ratio_to_legacy: f64,
    /// Heap and inline bytes of one environment (needs the binary's counting allocator).
    bytes_per_env: Option<usize>,
}

/// What a measurement includes.
#[derive(Clone, Copy)]
struct Config {
    with_obs: bool,
    random_actions: bool,
    /// Abilities on, and the random actions drawn from SMAC's actions plus the ability slots.
    abilities: bool,
}

fn measure(scenario: &Arc<Scenario>, seconds: f64, max_steps: Option<u64>, c: Config) -> (u64, u64, u64, f64) {
    let Config { with_obs, random_actions, abilities } = c;
    let mut cfg = EnvConfig { ability_actions: abilities, ..EnvConfig::default() };
    cfg.rules.abilities = abilities;
    let mut env = Env::new(Arc::clone(scenario), cfg, 1);
    let layout = env.smac_layout(Team::One).clone();
    let mut obs = vec![0f32; layout.obs_size];
    let mut state = vec![0f32; layout.state_size];
    let mut avail = vec![0u8; layout.n_actions];
    let mut actions = vec![0usize; layout.n_agents];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut steps, mut episodes, mut loops) = (0u64, 0u64, 0u64);
    let start = Instant::now();
    let mut sink = 0f32;
    loop {
        for (agent, slot) in actions.iter_mut().enumerate().filter(|_| random_actions) {
            env.avail_agent(Team::One, agent, &mut avail);
            let n = avail.iter().filter(|&&a| a == 1).count();
            let mut k = rng.random_range(0..n.max(1));
            *slot = avail
                .iter()
                .position(|&a| {
                    a == 1 && {
                        let hit = k == 0;
                        k = k.saturating_sub(1);
                        hit
                    }
                })
                .unwrap_or(0);
        }
        if random_actions {
            env.submit_indices(Team::One, &actions);
        }
        let before = env.world().tick();
        let r = env.step();
        loops += (env.world().tick() - before) as u64;
        if with_obs {
            for agent in 0..layout.n_agents {
                env.obs_agent(Team::One, agent, &mut obs);
                env.avail_agent(Team::One, agent, &mut avail);
                sink += obs[0];
            }
            env.state(Team::One, &mut state);
            sink += state[0];
        }
        steps += 1;
        if r.done {
            episodes += 1;
            env.reset(steps);
        }
        let done = match max_steps {
            Some(n) => steps >= n,
            None => steps % 256 == 0 && start.elapsed().as_secs_f64() >= seconds,
        };
        if done {
            break;
        }
    }
    std::hint::black_box(sink);
    (steps, episodes, loops, start.elapsed().as_secs_f64())
}

fn bytes_per_env(scenario: &Arc<Scenario>, alloc: &'static StatsAlloc<System>) -> usize {
    const N: usize = 32;
    let region = Region::new(alloc);
    let mut envs = Vec::with_capacity(N);
    let base = region.change();
    for i in 0..N {
        let mut e = Env::new(Arc::clone(scenario), EnvConfig::default(), i as u64);
        e.step();
        envs.push(e);
    }
    let c = region.change();
    let heap = (c.bytes_allocated - c.bytes_deallocated).saturating_sub(base.bytes_allocated - base.bytes_deallocated);
    std::hint::black_box(&envs);
    heap / N + size_of::<Env>()
}

fn scenario_names(a: &BenchArgs) -> Vec<String> {
    if a.scenario.iter().any(|s| s == "all") { builtin_names().map(str::to_owned).collect() } else { a.scenario.clone() }
}

/// The benchmark asked for; by default the simulator's table, each row measured against its
/// baselines in the same run (the other benchmarks live in the bench_* modules).
pub fn run(a: &BenchArgs, out: &mut dyn Write, alloc: Option<&'static StatsAlloc<System>>) -> Result<()> {
    if !(a.seconds.is_finite() && a.seconds > 0.0 && a.seconds <= 3600.0) {
        anyhow::bail!("--seconds {}: must be a number of seconds in (0, 3600]", a.seconds);
    }
    if a.scaling {
        return run_scaling(a, out);
    }
    if a.render {
        return run_render(a, out);
    }
    if a.bridge {
        return crate::bench_bridge::run(out);
    }
    if a.deploy {
        return crate::bench_deploy::run(out);
    }
    if a.train {
        return run_train(a, out);
    }
    if a.ava {
        let explicit = a.scenario != BenchArgs::DEFAULT_SCENARIOS;
        let names = if explicit { scenario_names(a) } else { vec!["3m_vlm".to_owned(), "pvz_ht".to_owned()] };
        return crate::bench_ava::run(&names, a.steps.unwrap_or(60).max(1), a.json, out);
    }
    if a.vec {
        if a.envs == 0 {
            anyhow::bail!("--envs must be at least 1");
        }
        let explicit = a.scenario != BenchArgs::DEFAULT_SCENARIOS;
        let names = if explicit { scenario_names(a) } else { vec!["3m_vlm".to_owned(), "2s3z_vlm".to_owned()] };
        return crate::bench_vec::run(&names, a.envs, a.seconds, a.json, out);
    }
    let rows = simulator_rows(a, alloc)?;
    if a.json {
        if rows.len() == 1 {
            writeln!(out, "{}", serde_json::to_string_pretty(&rows[0])?)?;
        } else {
            writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        }
        return Ok(());
    }
    let t = table(
        &[
            "scenario",
            "data",
            "units",
            "steps/s",
            "sim-only steps/s",
            "ratio to sim-only",
            "ratio to 100k goal",
            "no-abilities steps/s",
            "ratio to no abilities",
            "legacy data steps/s",
            "ratio to legacy (goal 0.9)",
            "game loops/s",
            "bytes/env",
        ],
        rows.iter().map(|r| {
            vec![
                r.scenario.clone(),
                r.data.clone(),
                r.units.to_string(),
                format!("{:.0}", r.steps_per_sec),
                format!("{:.0}", r.sim_only_steps_per_sec),
                format!("{:.2}", r.ratio_to_sim_only),
                format!("{:.2}", r.ratio_to_goal),
                format!("{:.0}", r.no_abilities_steps_per_sec),
                format!("{:.2}", r.ratio_to_no_abilities),
                format!("{:.0}", r.legacy_steps_per_sec),
                format!("{:.2}", r.ratio_to_legacy),
                format!("{:.0}", r.game_loops_per_sec),
                r.bytes_per_env.map_or("-".to_owned(), |b| b.to_string()),
            ]
        }),
    );
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "one step = 8 game loops + every agent's observation and available actions + the state; single thread, random available actions (with the ability slots; the no-abilities baseline has abilities off and SMAC's plain actions)"
    )?;
    Ok(())
}

/// `--train`: the learners' training speed on one scenario.
fn run_train(a: &BenchArgs, out: &mut dyn Write) -> Result<()> {
    let explicit = a.scenario != BenchArgs::DEFAULT_SCENARIOS;
    let scenario = match (explicit, a.scenario.as_slice()) {
        (false, _) => "3m_vlm",
        (true, [one]) => one.as_str(),
        (true, _) => anyhow::bail!("--train measures one scenario at a time"),
    };
    let algos: Vec<String> =
        if a.algo.is_empty() { avacraft_marl::ALGOS.iter().map(|s| (*s).to_owned()).collect() } else { a.algo.clone() };
    let b = crate::bench_train::TrainBench {
        algos: &algos,
        scenario,
        steps: a.steps.unwrap_or(if a.goals { 153_600 } else { 10_000 }),
        overrides: &a.set,
        json: a.json,
        goals: a.goals,
        only: &a.only,
        peer: a.jaxmarl.clone().map(|dir| crate::bench_train::Peer { dir, python: a.jaxmarl_python.clone() }),
    };
    crate::bench_train::run(&b, out)
}

/// The simulator's rows: each scenario with observations and abilities, and its baselines
/// (no observations, no abilities, the legacy data) measured in the same run.
fn simulator_rows(a: &BenchArgs, alloc: Option<&'static StatsAlloc<System>>) -> Result<Vec<BenchRow>> {
    let names = scenario_names(a);
    let mut rows = Vec::new();
    for name in &names {
        let scenario = Arc::new(Scenario::load(name)?);
        let full = Config { with_obs: true, random_actions: true, abilities: true };
        let (steps, episodes, loops, secs) = measure(&scenario, a.seconds, a.steps, full);
        let (base_steps, _, _, base_secs) = measure(&scenario, a.seconds / 2.0, a.steps, Config { with_obs: false, ..full });
        let (plain_steps, _, _, plain_secs) = measure(&scenario, a.seconds / 2.0, a.steps, Config { abilities: false, ..full });
        let legacy = Arc::new(scenario.with_data(avacraft_engine::DataSet::Legacy)?);
        let (legacy_steps, _, _, legacy_secs) = measure(&legacy, a.seconds / 2.0, a.steps, full);
        let legacy_sps = legacy_steps as f64 / legacy_secs;
        let sps = steps as f64 / secs;
        let base = base_steps as f64 / base_secs;
        let plain = plain_steps as f64 / plain_secs;
        rows.push(BenchRow {
            scenario: scenario.name.clone(),
            data: scenario.data.to_string(),
            units: scenario.units.len(),
            steps,
            episodes,
            steps_per_sec: sps,
            sim_only_steps_per_sec: base,
            ratio_to_sim_only: sps / base,
            ratio_to_goal: sps / GOAL_STEPS_PER_SEC,
            no_abilities_steps_per_sec: plain,
            ratio_to_no_abilities: sps / plain,
            game_loops_per_sec: loops as f64 / secs,
            legacy_steps_per_sec: legacy_sps,
            ratio_to_legacy: sps / legacy_sps,
            bytes_per_env: alloc.map(|a| bytes_per_env(&scenario, a)),
        });
        if !a.json {
            eprintln!("measured {name}");
        }
    }
    Ok(rows)
}

/// A condensed table with a header row, as every bench report prints.
fn table(header: &[&str], rows: impl Iterator<Item = Vec<String>>) -> comfy_table::Table {
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(header.to_vec());
    for r in rows {
        t.add_row(r);
    }
    t
}
