//! `train`: a MARL baseline (IQL, VDN, QMIX, QTRAN, IPPO, MAPPO) on a scenario in one of the
//! observation modes (SMAC features, images, images and features, images and text), with a
//! progress bar, a CSV log, greedy test episodes and checkpoints in `--out` (see `avacraft-marl`).

use anyhow::{Context, Result, bail};
use avacraft_engine::Scenario;
use avacraft_marl::{Config, RunOptions};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct TrainArgs {
    /// Algorithm: iql, vdn, qmix, qtran (PyMARL's defaults), ippo or mappo (the MAPPO repository's),
    /// from marl/configs/ALGO.toml.
    #[arg(long, default_value = "qmix")]
    pub algo: String,
    /// Built-in scenario name or path to a scenario file (with --resume: the run's own, kept
    /// in its directory, unless given).
    #[arg(long, required_unless_present = "resume")]
    pub scenario: Option<String>,
    /// Observation mode: features (SMAC's vectors), rgb (screen and minimap images), hybrid
    /// (both) or vision-text (images and the text description's MiniLM embedding); the
    /// config's `obs` key, `features` unless the config says otherwise. Encoder keys
    /// (encoder=cnn|swin|swin-tiny, screen_size, ...) are set with --set.
    #[arg(long)]
    pub obs: Option<String>,
    /// Environment steps to train for (the config's t_max).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Seed of every random stream of the run (default 1; with --resume, the run's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Environments stepped in parallel (the config's envs).
    #[arg(long)]
    pub envs: Option<usize>,
    /// Threads stepping environments (default: all cores; results do not depend on it).
    #[arg(long)]
    pub threads: Option<usize>,
    /// A config file to start from instead of the algorithm's built-in one.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override a config key, e.g. --set lr=0.001 (repeatable; values in TOML syntax).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Directory for log.csv, curves.png and the checkpoint (agent.safetensors,
    /// mixer.safetensors for QMIX and QTRAN, critic.safetensors for PPO, config.json), which `avacraft episode --agent marl:DIR` plays.
    #[arg(long, required_unless_present = "resume", conflicts_with = "resume")]
    pub out: Option<PathBuf>,
    /// Go on with the run in DIR from its last test round, with its config (`--steps` and
    /// `--set` still apply, e.g. to train longer). The replay buffer and the optimiser's
    /// moments start afresh.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["config", "algo"])]
    pub resume: Option<PathBuf>,
}

pub fn run(a: &TrainArgs, out: &mut dyn Write) -> Result<()> {
    let mut overrides = a.set.clone();
    if let Some(obs) = &a.obs {
        if !avacraft_marl::ObsKind::NAMES.contains(&obs.as_str()) {
            bail!("--obs {obs}: expected one of {}", avacraft_marl::ObsKind::NAMES.join(", "));
        }
        overrides.push(format!("obs=\"{obs}\""));
    }
    if let Some(s) = a.steps {
        overrides.push(format!("t_max={s}"));
    }
    if let Some(e) = a.envs {
        overrides.push(format!("envs={e}"));
    }
    let mut start = None;
    let cfg = match (&a.config, &a.resume) {
        (_, Some(dir)) => {
            let (cfg, state) = avacraft_marl::resume::load(dir).with_context(|| format!("--resume {}", dir.display()))?;
            start = Some(state);
            let text = toml::to_string(&cfg).context("the resumed run's config")?;
            Config::from_toml(&text, &overrides).with_context(|| format!("--resume {}", dir.display()))?
        }
        (Some(path), None) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("--config {}", path.display()))?;
            Config::from_toml(&text, &overrides).with_context(|| format!("--config {}", path.display()))?
        }
        (None, None) => Config::for_algo(&a.algo, &overrides)?,
    };
    let Some(out_dir) = a.out.as_ref().or(a.resume.as_ref()) else { bail!("--out DIR is needed") };
    let scenario = Arc::new(scenario_of_run(a, out_dir)?);
    let seed = match (&start, a.seed) {
        (Some(st), Some(s)) if s != st.seed => bail!("--seed {s}: the run in {} has seed {}", out_dir.display(), st.seed),
        (Some(st), _) => st.seed,
        (None, s) => s.unwrap_or(1),
    };
    let threads = a.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed, threads, out: Some(out_dir.clone()) };
    let bar = if std::io::stderr().is_terminal() { ProgressBar::new(cfg.t_max) } else { ProgressBar::hidden() };
    bar.set_style(ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} steps, {per_sec} ({eta})")?.progress_chars("=> "));
    let name = format!("{} ({}) on {}", cfg.algo, cfg.obs.name(), scenario.name);
    bar.set_message(name.clone());
    let started = std::time::Instant::now();
    let (_, summary) = avacraft_marl::train_from(&cfg, &opts, start, &mut |p| {
        bar.set_position(p.t_env);
        let test = p.last_test.map_or_else(|| "-".to_owned(), |t| format!("{:.0}%", 100.0 * t.win_rate));
        bar.set_message(format!("{name}: test win {test}, eps {:.2}, loss {:.3}, updates {}", p.epsilon, p.loss, p.updates));
    })?;
    bar.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    writeln!(
        out,
        "{name}: {} steps, {} episodes, {} updates in {secs:.0} s ({:.0} steps/s)",
        summary.t_env,
        summary.episodes,
        summary.updates,
        summary.t_env as f64 / secs.max(1e-9)
    )?;
    if !summary.phases.is_empty() {
        let phases: Vec<String> = summary.phases.iter().map(|(n, s)| format!("{n} {s:.1} s")).collect();
        writeln!(out, "  time: {}", phases.join(", "))?;
    }
    for t in &summary.tests {
        writeln!(
            out,
            "  step {:>9}: greedy win rate {:5.1}% over {} episodes, return {:.2}",
            t.t_env,
            100.0 * t.win_rate,
            t.episodes,
            t.mean_return
        )?;
    }
    writeln!(out, "log, curves and checkpoint in {}", out_dir.display())?;
    Ok(())
}

/// A copy of a scenario file a run trains on, in the run's directory, so `--resume` finds it.
const SCENARIO_COPY: &str = "scenario.toml";

/// The scenario to train on: `--scenario`, or when resuming without it the run's own (its
/// copied file, else the built-in scenario its checkpoint names). A new run over a scenario
/// file keeps a copy of the file in its directory.
fn scenario_of_run(a: &TrainArgs, out_dir: &std::path::Path) -> Result<Scenario> {
    let copy = out_dir.join(SCENARIO_COPY);
    let Some(name) = &a.scenario else {
        if copy.is_file() {
            return Ok(Scenario::load(&copy.to_string_lossy())?);
        }
        let policy = avacraft_marl::Policy::load(out_dir).with_context(|| format!("--resume {}", out_dir.display()))?;
        return Scenario::load(&policy.scenario)
            .with_context(|| format!("--resume {}: its scenario `{}` (give it with --scenario)", out_dir.display(), policy.scenario));
    };
    let scenario = Scenario::load(name)?;
    let path = std::path::Path::new(name);
    if a.resume.is_none() {
        if path.is_file() {
            std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
            std::fs::copy(path, &copy).with_context(|| format!("copying {name} to {}", copy.display()))?;
        } else if copy.is_file() {
            // an earlier run's file in a reused directory is not this run's scenario
            std::fs::remove_file(&copy).with_context(|| format!("removing {}", copy.display()))?;
        }
    }
    Ok(scenario)
}
