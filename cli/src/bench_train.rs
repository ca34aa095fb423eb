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
    /// JaxMARL's same algorithm and settings on SMAX's same scenario, in this run
    /// (`--jaxmarl`), and training / that.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jaxmarl_steps_per_sec: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jaxmarl_ratio: Option<f64>,
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

/// JaxMARL's IPPO network: one GRU trunk under both the policy and the value head
/// (`ActorCriticRNN`); MAPPO's critic reads the state and keeps a network of its own, in
/// JaxMARL as here.
pub const JAXMARL_IPPO_NET: &str = "shared_trunk=true";

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
    /// The JaxMARL baseline this row compares with (its algorithm), and whether the goal is
    /// 1.2x JaxMARL's IPPO on the row's scenario measured in the same run.
    pub peer: Option<&'static str>,
    pub goal_from_peer: bool,
    /// Timed after an untimed run of one rollout that fills the caches a first run on a
    /// machine pays for once (the vision-text clause embeddings, kept on disk).
    pub warm: bool,
}

/// A JaxMARL checkout and the Python (with jax) that runs its SMAX baselines.
#[derive(Clone, Debug)]
pub struct Peer {
    pub dir: std::path::PathBuf,
    pub python: std::path::PathBuf,
}

/// Our wrapper around JaxMARL's unchanged baseline scripts (see its docstring), carried in
/// the binary so the benchmark runs from anywhere.
const PEER_SCRIPT: &str = include_str!("../../tools/peer/jaxmarl_train_bench.py");

/// JaxMARL's `algo` (ippo or mappo) on SMAX `map` with JaxMARL's settings (64 environments,
/// the script's own 128-step rollouts, epochs, mini-batches and widths), for about `steps`
/// environment steps, JIT compilation excluded: its environment steps per second.
pub fn jaxmarl_rate(peer: &Peer, algo: &str, map: &str, steps: u64) -> Result<f64> {
    let script = std::env::temp_dir().join(format!("avacraft-jaxmarl-bench-{}.py", std::process::id()));
    std::fs::write(&script, PEER_SCRIPT).with_context(|| format!("writing {}", script.display()))?;
    // Whole updates of 64 environments x 128 steps.
    let per_update = 64 * 128;
    let total = steps.div_ceil(per_update).max(1) * per_update;
    let out = std::process::Command::new(&peer.python)
        .arg(&script)
        .args(["--jaxmarl"])
        .arg(&peer.dir)
        .args(["--algo", algo, "--map", map, "--total-timesteps", &total.to_string(), "--set", "NUM_ENVS=64"])
        .env("WANDB_MODE", "disabled")
        .output()
        .with_context(|| format!("running JaxMARL with {} (--jaxmarl-python)", peer.python.display()))?;
    let _ = std::fs::remove_file(&script);
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(6).collect::<Vec<_>>().into_iter().rev().collect();
        bail!("JaxMARL's {algo} on {map} failed ({}): {}", out.status, tail.join("\n"));
    }
    let line = stdout.lines().rev().find(|l| l.trim_start().starts_with('{')).context("JaxMARL printed no result line")?;
    let v: serde_json::Value = serde_json::from_str(line).with_context(|| format!("JaxMARL's result line `{line}`"))?;
    v.get("steps_per_s").and_then(serde_json::Value::as_f64).with_context(|| format!("no steps_per_s in `{line}`"))
}

/// The learners issue's row set. The first two goals are 1.2x JaxMARL's IPPO on SMAX 3m_vlm as
/// measured on the same 2-core machine (12,700 env steps/s, JIT excluded); the others the
/// issue's own figures.
pub fn goal_rows() -> Vec<GoalRow> {
    let with = |extra: &[&'static str]| -> Vec<&'static str> { JAXMARL.iter().chain(extra).copied().collect() };
    vec![
        GoalRow {
            label: "IPPO, JaxMARL's settings",
            algo: "ippo",
            scenario: "3m_vlm",
            overrides: with(&[JAXMARL_IPPO_NET]),
            goal: 15_000.0,
            steps: None,
            peer: Some("ippo"),
            goal_from_peer: true,
            warm: false,
        },
        GoalRow {
            label: "MAPPO, JaxMARL's settings",
            algo: "mappo",
            scenario: "3m_vlm",
            overrides: with(&[]),
            goal: 15_000.0,
            steps: None,
            peer: Some("mappo"),
            goal_from_peer: true,
            warm: false,
        },
        GoalRow {
            label: "IPPO, JaxMARL's settings",
            algo: "ippo",
            scenario: "2s3z_vlm",
            overrides: with(&[JAXMARL_IPPO_NET, "episode_limit=120"]),
            goal: 10_000.0,
            steps: None,
            peer: Some("ippo"),
            goal_from_peer: false,
            warm: false,
        },
        GoalRow {
            label: "MAPPO, JaxMARL's settings",
            algo: "mappo",
            scenario: "2s3z_vlm",
            overrides: with(&["episode_limit=120"]),
            goal: 10_000.0,
            steps: None,
            peer: Some("mappo"),
            goal_from_peer: false,
            warm: false,
        },
        GoalRow {
            label: "QMIX, PyMARL's defaults",
            algo: "qmix",
            scenario: "3m_vlm",
            overrides: vec![],
            goal: 3_000.0,
            steps: None,
            peer: None,
            goal_from_peer: false,
            warm: false,
        },
        GoalRow {
            label: "QMIX feed-forward ($FAST)",
            algo: "qmix",
            scenario: "3m_vlm",
            overrides: FAST.to_vec(),
            goal: 6_000.0,
            steps: None,
            peer: None,
            goal_from_peer: false,
            warm: false,
        },
        GoalRow {
            label: "MAPPO rgb (80x60 + 32x32)",
            algo: "mappo",
            scenario: "3m_vlm",
            overrides: vec!["obs=rgb"],
            goal: 1_500.0,
            steps: Some(6_400),
            peer: None,
            goal_from_peer: false,
            warm: false,
        },
        GoalRow {
            label: "MAPPO vision-text",
            algo: "mappo",
            scenario: "3m_vlm",
            overrides: vec!["obs=\"vision-text\""],
            goal: 400.0,
            steps: Some(6_400),
            peer: None,
            goal_from_peer: false,
            warm: true,
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
    /// Goal rows whose label, algorithm or scenario contains one of these (all if empty).
    pub only: &'a [String],
    /// JaxMARL, run beside the rows it compares with.
    pub peer: Option<Peer>,
}

/// Steps per second of `cfg`'s vector environment with uniformly random available actions.
fn env_rate(cfg: &Config, scenario: &Arc<Scenario>, threads: usize, steps: u64) -> Result<f64> {
    let seeds: Vec<u64> = (1..=cfg.envs as u64).collect();
    let mut v = VecEnv::new(Arc::clone(scenario), cfg.env_config()?, &seeds, threads.clamp(1, seeds.len()))?;
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
fn measure(
    label: &str,
    algo: &str,
    scenario: &Arc<Scenario>,
    steps: u64,
    extra: &[String],
    goal: Option<f64>,
    jaxmarl: Option<f64>,
) -> Result<TrainRow> {
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    // One greedy test at the end; SMAC's time limit unless overridden.
    let mut overrides = vec![format!("t_max={steps}"), format!("test_interval={steps}"), "test_nepisode=8".to_owned()];
    if scenario.name == "3m_vlm" {
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
        jaxmarl_steps_per_sec: jaxmarl,
        jaxmarl_ratio: jaxmarl.map(|j| train / j),
        goal,
        goal_ratio: goal.map(|g| train / g),
    })
}

/// The training benchmark: its rows measured, then printed with their goals.
pub fn run(b: &TrainBench<'_>, out: &mut dyn Write) -> Result<()> {
    if b.steps == 0 {
        bail!("--steps must be at least 1 for --train");
    }
    let mut rows = Vec::new();
    let mut warmed = Vec::new();
    if b.goals {
        let picked: Vec<GoalRow> = goal_rows()
            .into_iter()
            .filter(|g| b.only.is_empty() || b.only.iter().any(|o| g.label.contains(o.as_str()) || g.algo == o || g.scenario == o))
            .collect();
        if picked.is_empty() {
            bail!("--only {:?} matches no goal row", b.only);
        }
        // JaxMARL's runs, each once (the IPPO ones set the goals of the rows that follow it).
        let mut peer_rates: Vec<((&str, &str), f64)> = Vec::new();
        if let Some(peer) = &b.peer {
            for g in &picked {
                let needed: Vec<&str> = g.peer.into_iter().chain(g.goal_from_peer.then_some("ippo")).collect();
                for algo in needed {
                    if !peer_rates.iter().any(|(k, _)| *k == (algo, g.scenario)) {
                        let rate = jaxmarl_rate(peer, algo, g.scenario, g.steps.unwrap_or(b.steps))?;
                        peer_rates.push(((algo, g.scenario), rate));
                    }
                }
            }
        }
        let rate_of = |algo: &str, map: &str| peer_rates.iter().find(|(k, _)| *k == (algo, map)).map(|(_, r)| *r);
        for g in &picked {
            let scenario = Arc::new(Scenario::load(g.scenario)?);
            let mut extra: Vec<String> = g.overrides.iter().map(|s| (*s).to_owned()).collect();
            extra.extend(b.overrides.iter().cloned());
            let steps = g.steps.unwrap_or(b.steps);
            let goal = match (g.goal_from_peer, rate_of("ippo", g.scenario)) {
                (true, Some(ippo)) => 1.2 * ippo,
                _ => g.goal,
            };
            let peer = g.peer.and_then(|p| rate_of(p, g.scenario));
            if g.warm {
                let cold = measure(g.label, g.algo, &scenario, 3_200, &extra, None, None)
                    .with_context(|| format!("goal row `{}`'s warm-up run", g.label))?;
                warmed.push(cold);
            }
            rows.push(
                measure(g.label, g.algo, &scenario, steps, &extra, Some(goal), peer)
                    .with_context(|| format!("goal row `{}` on {}", g.label, g.scenario))?,
            );
        }
    } else {
        let scenario = Arc::new(Scenario::load(b.scenario)?);
        for algo in b.algos {
            rows.push(measure(algo, algo, &scenario, b.steps, b.overrides, None, None)?);
        }
    }
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    table(b, &rows, &warmed, out)
}

/// The measured rows as a table, with what the goal rows were measured against.
fn table(b: &TrainBench<'_>, rows: &[TrainRow], warmed: &[TrainRow], out: &mut dyn Write) -> Result<()> {
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
        "JaxMARL: steps/s",
        "training / JaxMARL",
        "goal: steps/s",
        "training / goal",
    ]);
    for r in rows {
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
            r.jaxmarl_steps_per_sec.map_or_else(|| "-".to_owned(), |g| format!("{g:.0}")),
            r.jaxmarl_ratio.map_or_else(|| "-".to_owned(), |g| format!("{g:.2}")),
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
            "goals: the learners issue's (release build, 2 cores); JaxMARL's settings: {} (IPPO also {JAXMARL_IPPO_NET}: JaxMARL's one-GRU network); $FAST: {}",
            JAXMARL.join(" "),
            FAST.join(" ")
        )?;
        for w in warmed {
            writeln!(
                out,
                "{}: timed after an untimed run of {} steps that fills the clause-embedding cache (kept on disk, so only a machine's first run pays it): that run {:.1} s, {:.0} steps/s",
                w.label, w.steps, w.seconds, w.train_steps_per_sec
            )?;
        }
        match &b.peer {
            Some(p) => writeln!(
                out,
                "JaxMARL ({}): its baselines/{{IPPO,MAPPO}}/*_rnn_smax.py unchanged on SMAX, NUM_ENVS=64 and the scripts' own settings, JIT compile excluded, run before the rows; the 3m_vlm goals are 1.2x its IPPO",
                p.dir.display()
            )?,
            None => writeln!(out, "JaxMARL not run (--jaxmarl DIR): the 3m_vlm goals are the issue's 15,000 (1.2x the 12,700 it reports)")?,
        }
    }
    Ok(())
}
