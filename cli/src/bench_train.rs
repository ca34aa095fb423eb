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
    /// What the row measures (the algorithm, or a goal row's name).
    pub label: String,
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
    /// Goal rows (`--goals`): the goal in training steps per second, and measured / goal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub goal: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub goal_ratio: Option<f64>,
}

/// JaxMARL's IPPO settings (`baselines/IPPO/ippo_rnn_smax.py`): 64 environments, rollouts of
/// 128 steps (120 here: a multiple of the 10-step chunks the recurrent nets learn on), 4
/// epochs of 4 mini-batches, GRU and fully connected layers 128 wide.
pub const JAXMARL: [&str; 5] = ["envs=64", "rollout_len=120", "ppo_epochs=4", "num_mini_batch=4", "rnn_hidden_dim=128"];

/// The README's `$FAST` QMIX settings.
pub const FAST: [&str; 4] = ["use_rnn=false", "optimizer=adam", "lr=0.001", "td_lambda=0.6"];

/// One row of the goal set: a name, an algorithm, a scenario, overrides and the goal.
pub struct GoalRow {
    pub label: &'static str,
    pub algo: &'static str,
    pub scenario: &'static str,
    pub overrides: Vec<&'static str>,
    /// Training environment steps per second on the 2-core machine, release build.
    pub goal: f64,
    /// Steps to train, where not `--steps` (the image modes: whole rollouts of their
    /// config, 8 environments x 400 steps, so that updates are measured).
    pub steps: Option<u64>,
}

/// The learners issue's row set. The first two goals are 1.2x JaxMARL's IPPO on SMAX 3m as
/// measured on the same 2-core machine (12,700 env steps/s, JIT excluded); the others the
/// issue's own figures.
pub fn goal_rows() -> Vec<GoalRow> {
    let with = |extra: &[&'static str]| -> Vec<&'static str> { JAXMARL.iter().chain(extra).copied().collect() };
    vec![
        GoalRow { label: "IPPO, JaxMARL's settings", algo: "ippo", scenario: "3m", overrides: with(&[]), goal: 15_000.0, steps: None },
        GoalRow { label: "MAPPO, JaxMARL's settings", algo: "mappo", scenario: "3m", overrides: with(&[]), goal: 15_000.0, steps: None },
        GoalRow {
            label: "IPPO, JaxMARL's settings",
            algo: "ippo",
            scenario: "2s3z",
            overrides: with(&["episode_limit=120"]),
            goal: 10_000.0,
            steps: None,
        },
        GoalRow {
            label: "MAPPO, JaxMARL's settings",
            algo: "mappo",
            scenario: "2s3z",
            overrides: with(&["episode_limit=120"]),
            goal: 10_000.0,
            steps: None,
        },
        GoalRow { label: "QMIX, PyMARL's defaults", algo: "qmix", scenario: "3m", overrides: vec![], goal: 3_000.0, steps: None },
        GoalRow { label: "QMIX feed-forward ($FAST)", algo: "qmix", scenario: "3m", overrides: FAST.to_vec(), goal: 6_000.0, steps: None },
        GoalRow {
            label: "MAPPO rgb (80x60 + 32x32)",
            algo: "mappo",
            scenario: "3m",
            overrides: vec!["obs=rgb"],
            goal: 1_500.0,
            steps: Some(6_400),
        },
        GoalRow {
            label: "MAPPO vision-text",
            algo: "mappo",
            scenario: "3m",
            overrides: vec!["obs=\"vision-text\""],
            goal: 400.0,
            steps: Some(3_200),
        },
    ]
}

/// What `bench --train` measures.
pub struct TrainBench<'a> {
    pub algos: &'a [String],
    pub scenario: &'a str,
    pub steps: u64,
    pub overrides: &'a [String],
    pub json: bool,
    /// The learners issue's goal rows instead of `algos` on `scenario`.
    pub goals: bool,
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

/// Trains `algo` on `scenario` for `steps` steps with `extra` overrides and measures it.
fn measure(label: &str, algo: &str, scenario: &Arc<Scenario>, steps: u64, extra: &[String], goal: Option<f64>) -> Result<TrainRow> {
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    // One greedy test at the end; SMAC's time limit unless overridden.
    let mut overrides = vec![format!("t_max={steps}"), format!("test_interval={steps}"), "test_nepisode=8".to_owned()];
    if scenario.name == "3m" {
        overrides.push("episode_limit=60".to_owned());
    }
    overrides.extend(extra.iter().cloned());
    let cfg = Config::for_algo(algo, &overrides)?;
    let opts = RunOptions { scenario: Arc::clone(scenario), seed: 1, threads, out: None };
    let start = Instant::now();
    let (_, summary) = avacraft_marl::train(&cfg, &opts, &mut |_| {}).with_context(|| format!("training {algo}"))?;
    let seconds = start.elapsed().as_secs_f64();
    let train = summary.t_env as f64 / seconds.max(1e-9);
    let env = env_rate(&cfg, scenario, threads, summary.t_env.max(20_000))?;
    Ok(TrainRow {
        label: label.to_owned(),
        algo: algo.to_owned(),
        scenario: scenario.name.clone(),
        envs: cfg.envs,
        steps: summary.t_env,
        updates: summary.updates,
        seconds,
        train_steps_per_sec: train,
        env_steps_per_sec: env,
        ratio: train / env,
        goal,
        goal_ratio: goal.map(|g| train / g),
    })
}

pub fn run(b: &TrainBench<'_>, out: &mut dyn Write) -> Result<()> {
    if b.steps == 0 {
        bail!("--steps must be at least 1 for --train");
    }
    let mut rows = Vec::new();
    if b.goals {
        for g in goal_rows() {
            let scenario = Arc::new(Scenario::load(g.scenario)?);
            let mut extra: Vec<String> = g.overrides.iter().map(|s| (*s).to_owned()).collect();
            extra.extend(b.overrides.iter().cloned());
            let steps = g.steps.unwrap_or(b.steps);
            rows.push(
                measure(g.label, g.algo, &scenario, steps, &extra, Some(g.goal))
                    .with_context(|| format!("goal row `{}` on {}", g.label, g.scenario))?,
            );
        }
    } else {
        let scenario = Arc::new(Scenario::load(b.scenario)?);
        for algo in b.algos {
            rows.push(measure(algo, algo, &scenario, b.steps, b.overrides, None)?);
        }
    }
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "row",
        "scenario",
        "envs",
        "steps",
        "updates",
        "seconds",
        "training: steps/s",
        "game alone: steps/s",
        "training / game",
        "goal: steps/s",
        "training / goal",
    ]);
    for r in &rows {
        t.add_row([
            r.label.clone(),
            r.scenario.clone(),
            r.envs.to_string(),
            r.steps.to_string(),
            r.updates.to_string(),
            format!("{:.1}", r.seconds),
            format!("{:.0}", r.train_steps_per_sec),
            format!("{:.0}", r.env_steps_per_sec),
            format!("{:.4}", r.ratio),
            r.goal.map_or_else(|| "-".to_owned(), |g| format!("{g:.0}")),
            r.goal_ratio.map_or_else(|| "-".to_owned(), |g| format!("{g:.2}")),
        ]);
    }
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "training: acting, learning and one greedy test of 8 episodes; game alone: the same vector environment with random available actions, in this run"
    )?;
    if b.goals {
        writeln!(
            out,
            "goals: the learners issue's (release build, 2 cores); JaxMARL's settings: {}; $FAST: {}",
            JAXMARL.join(" "),
            FAST.join(" ")
        )?;
    }
    Ok(())
}
