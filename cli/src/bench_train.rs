//! `bench --train`: training throughput, environment steps per second with learning, of
//! each MARL baseline, against the rate of the same vector environment (same scenario,
//! settings, environment count and threads) stepped with random actions in the same run.
//! The ratio is the share of the game in a training run's time: near 1 the game bounds
//! training, near 0 learning does (on this engine, learning does).

use anyhow::{Context, Result, bail};
use avacraft_engine::{Scenario, VecEnv};
use avacraft_marl::{Config, RunOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

#[derive(Serialize, Debug, Clone)]
pub struct TrainRow {
    pub algo: String,
    pub scenario: String,
    pub envs: usize,
    pub steps: u64,
    pub updates: u64,
    pub seconds: f64,
    /// Environment steps per second with acting, learning and the final greedy test.
    pub train_steps_per_sec: f64,
    /// The same vector environment with random available actions (the baseline).
    pub env_steps_per_sec: f64,
    /// train / env.
    pub ratio: f64,
}

/// What `bench --train` measures.
pub struct TrainBench<'a> {
    pub algos: &'a [String],
    pub scenario: &'a str,
    pub steps: u64,
    pub overrides: &'a [String],
    pub json: bool,
}

/// Steps per second of `cfg`'s vector environment with uniformly random available actions.
fn env_rate(cfg: &Config, scenario: &Arc<Scenario>, threads: usize, steps: u64) -> Result<f64> {
    let seeds: Vec<u64> = (1..=cfg.envs as u64).collect();
    let mut v = VecEnv::new(Arc::clone(scenario), cfg.env_config(), &seeds, threads.clamp(1, seeds.len()))?;
    let n_actions = v.shape().3.max(1);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut actions = vec![0i64; v.buffers.avail.len() / n_actions];
    let start = Instant::now();
    let mut done = 0u64;
    while done < steps {
        for (slot, mask) in actions.iter_mut().zip(v.buffers.avail.chunks(n_actions)) {
            let avail: Vec<usize> = mask.iter().enumerate().filter(|(_, m)| **m == 1).map(|(i, _)| i).collect();
            *slot = avail.get(rng.random_range(0..avail.len().max(1))).map_or(0, |&i| i as i64);
        }
        v.step(&actions).context("stepping the vector environment")?;
        done += cfg.envs as u64;
    }
    Ok(done as f64 / start.elapsed().as_secs_f64().max(1e-9))
}

pub fn run(b: &TrainBench<'_>, out: &mut dyn Write) -> Result<()> {
    if b.steps == 0 {
        bail!("--steps must be at least 1 for --train");
    }
    let scenario = Arc::new(Scenario::load(b.scenario)?);
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let mut rows = Vec::new();
    for algo in b.algos {
        // One greedy test at the end; SMAC's time limit unless overridden.
        let mut overrides = vec![format!("t_max={}", b.steps), format!("test_interval={}", b.steps), "test_nepisode=8".to_owned()];
        if scenario.name == "3m" {
            overrides.push("episode_limit=60".to_owned());
        }
        overrides.extend(b.overrides.iter().cloned());
        let cfg = Config::for_algo(algo, &overrides).with_context(|| format!("--algo {algo}"))?;
        let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 1, threads, out: None };
        let start = Instant::now();
        let (_, summary) = avacraft_marl::train(&cfg, &opts, &mut |_| {}).with_context(|| format!("training {algo}"))?;
        let seconds = start.elapsed().as_secs_f64();
        let train = summary.t_env as f64 / seconds.max(1e-9);
        let env = env_rate(&cfg, &scenario, threads, summary.t_env.max(20_000))?;
        rows.push(TrainRow {
            algo: algo.clone(),
            scenario: scenario.name.clone(),
            envs: cfg.envs,
            steps: summary.t_env,
            updates: summary.updates,
            seconds,
            train_steps_per_sec: train,
            env_steps_per_sec: env,
            ratio: train / env,
        });
    }
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "algo",
        "scenario",
        "envs",
        "steps",
        "updates",
        "seconds",
        "training: steps/s",
        "game alone: steps/s",
        "training / game",
    ]);
    for r in &rows {
        t.add_row([
            r.algo.clone(),
            r.scenario.clone(),
            r.envs.to_string(),
            r.steps.to_string(),
            r.updates.to_string(),
            format!("{:.1}", r.seconds),
            format!("{:.0}", r.train_steps_per_sec),
            format!("{:.0}", r.env_steps_per_sec),
            format!("{:.4}", r.ratio),
        ]);
    }
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "training: acting, learning and one greedy test of 8 episodes; game alone: the same vector environment with random available actions, in this run"
    )?;
    Ok(())
}
