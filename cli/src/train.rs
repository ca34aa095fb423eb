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
    #[arg(long, required_unless_present_any = ["resume", "plan"])]
    pub scenario: Option<String>,
    /// Instead: every run of a training plan (TOML: scenarios x algorithms x seeds x
    /// observation mode x budget; see eval/plans/baselines.toml), each in its folder under the
    /// plan's `out`. Runs already done are skipped and interrupted ones resume, so the plan
    /// can be started again after a kill; a run's `steps` raised in the plan takes it on to the
    /// new budget, finished or not.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scenario", "resume", "config", "out", "obs", "steps", "seed", "envs", "set", "opponent"])]
    pub plan: Option<PathBuf>,
    /// With --plan: only the runs of shard i of n (run k goes to shard k mod n + 1), for a
    /// cluster's array jobs.
    #[arg(long, value_name = "i/n", requires = "plan")]
    pub shard: Option<avacraft_eval::Shard>,
    /// With --plan: only these runs (plan ids such as `27m_vs_30m/qmix-s1`), e.g. to go on
    /// with one unfinished run whose folder came with the repository; with --ship, ship these
    /// alone and leave every other shipped run as it is.
    #[arg(long, value_name = "RUN", num_args = 1.., requires = "plan")]
    pub only: Vec<String>,
    /// With --plan: train nothing; copy the plan's finished runs' policies into
    /// DIR/<scenario>/<run> (seed 1; other seeds <run>-s<seed>): each one's best checkpoint's
    /// agent network, config, log and curves, at most 300 kB each without the curves.
    #[arg(long, value_name = "DIR", requires = "plan")]
    pub ship: Option<PathBuf>,
    /// With --ship: also ship these runs (plan ids such as `bane_vs_bane/qmix-s1`), stopped
    /// short of their budget (a checkpoint, no done.json); the table names each with the steps
    /// it trained, and its shipped log shows them too.
    #[arg(long, value_name = "RUN", num_args = 1.., requires = "ship")]
    pub unfinished: Vec<String>,
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
    /// Threads the run uses, stepping environments and in the learner's kernels (default: all
    /// cores; results do not depend on it).
    #[arg(long)]
    pub threads: Option<usize>,
    /// PvP scenarios: who plays team 2 while team 1 learns: scripted:NAME (or NAME: a
    /// scripted agent), marl:DIR (a checkpoint), or self (the learner's own snapshots,
    /// refreshed every `self_play_every` updates, the last `self_play_pool` kept, one drawn
    /// per episode). The config's `opponent`.
    #[arg(long, value_name = "SPEC")]
    pub opponent: Option<String>,
    /// A config file to start from instead of the algorithm's built-in one.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override a config key, e.g. --set lr=0.001 (repeatable; values in TOML syntax).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Directory for log.csv, curves.png and the checkpoint (agent.safetensors,
    /// mixer.safetensors for QMIX and QTRAN, critic.safetensors for PPO, config.json), which `avacraft episode --agent marl:DIR` plays.
    #[arg(long, required_unless_present_any = ["resume", "plan"], conflicts_with = "resume")]
    pub out: Option<PathBuf>,
    /// Go on with the run in DIR from its last test round, with its config (`--steps` and
    /// `--set` still apply, e.g. to train longer), its optimisers' state and its random
    /// streams. With feature observations and no self-play, the episodes under way (and a
    /// Q-learner's replay buffer, journalled in DIR/resume) go on as they were, so the run
    /// goes on as if uninterrupted; otherwise, where those files are gone, or where `--set`
    /// changes the game (a rule, the unit data, the opponent), they start afresh.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["config", "algo"])]
    pub resume: Option<PathBuf>,
}

pub fn run(a: &TrainArgs, out: &mut dyn Write) -> Result<()> {
    if let (Some(plan), Some(to)) = (&a.plan, &a.ship) {
        return ship_plan(plan, (a.shard, &a.only), to, &a.unfinished, out);
    }
    if let Some(n) = a.threads {
        if n == 0 {
            bail!("--threads 0: a run needs at least one thread");
        }
        let learner = avacraft_marl::kernels::use_threads(n);
        writeln!(out, "threads: {n} stepping environments, {learner} in the learner")?;
    }
    if let Some(plan) = &a.plan {
        return run_plan(plan, (a.shard, &a.only), a.threads, out);
    }
    let overrides = &a.set;
    let mut start = None;
    let mut cfg = match (&a.config, &a.resume) {
        (_, Some(dir)) => {
            let (saved, state) = avacraft_marl::resume::load(dir).with_context(|| format!("--resume {}", dir.display()))?;
            start = Some(state);
            let cfg = saved.overridden(overrides).with_context(|| format!("--resume {}", dir.display()))?;
            if !saved.same_game(&cfg) {
                writeln!(
                    out,
                    "note: --set changes the game the run in {} plays (a rule, the unit data or the opponent): it goes on with fresh episodes and a new replay buffer",
                    dir.display()
                )?;
            }
            cfg
        }
        (Some(path), None) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("--config {}", path.display()))?;
            Config::from_toml(&text, overrides).with_context(|| format!("--config {}", path.display()))?
        }
        (None, None) => Config::for_algo(&a.algo, overrides)?,
    };
    // The flags set their fields directly, after `--set`, so they win over it.
    if let Some(obs) = &a.obs {
        cfg.obs = match avacraft_marl::ObsKind::from_name(obs) {
            Some(k) => k,
            None => bail!("--obs {obs}: expected one of {}", avacraft_marl::ObsKind::NAMES.join(", ")),
        };
    }
    if let Some(s) = a.steps {
        cfg.t_max = s;
    }
    if let Some(e) = a.envs {
        cfg.envs = e;
    }
    if let Some(o) = &a.opponent {
        cfg.opponent = avacraft_marl::Opponent::parse(o).with_context(|| format!("--opponent {o}"))?;
    }
    cfg.validate().context("the settings the flags give")?;
    let Some(out_dir) = a.out.as_ref().or(a.resume.as_ref()) else { bail!("--out DIR is needed") };
    let scenario = Arc::new(scenario_of_run(a, out_dir)?);
    let seed = match (&start, a.seed) {
        (Some(st), Some(s)) if s != st.seed => bail!("--seed {s}: the run in {} has seed {}", out_dir.display(), st.seed),
        (Some(st), _) => st.seed,
        (None, s) => s.unwrap_or(1),
    };
    let threads = a.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    execute(&cfg, scenario, seed, threads, out_dir, start, "", out).map(|_| ())
}

/// Trains `cfg` on `scenario` into `out_dir` (going on from `start` when resuming), with a
/// progress bar (`label` before the run's name) and a report to `out`.
#[allow(clippy::too_many_arguments)]
fn execute(
    cfg: &Config,
    scenario: Arc<Scenario>,
    seed: u64,
    threads: usize,
    out_dir: &std::path::Path,
    start: Option<avacraft_marl::resume::RunState>,
    label: &str,
    out: &mut dyn Write,
) -> Result<avacraft_marl::Summary> {
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed, threads, out: Some(out_dir.to_path_buf()) };
    let bar = if std::io::stderr().is_terminal() { ProgressBar::new(cfg.t_max) } else { ProgressBar::hidden() };
    bar.set_style(ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} steps, {per_sec} ({eta})")?.progress_chars("=> "));
    let name = format!("{label}{} ({}) on {}", cfg.algo, cfg.obs.name(), scenario.name);
    bar.set_message(name.clone());
    let started = std::time::Instant::now();
    let (_, summary) = avacraft_marl::train_from(cfg, &opts, start, &mut |p| {
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
    Ok(summary)
}

/// The file a finished run of a plan leaves in its folder (its summary): the plan skips it.
pub const DONE_FILE: &str = "done.json";

#[derive(serde::Serialize, serde::Deserialize)]
struct Done {
    t_env: u64,
    episodes: u64,
    updates: u64,
    final_test_win_rate: Option<f64>,
}

/// A shipped run's size budget without its curves, and all shipped runs' together (a guard on
/// the repository's size: some 175 policies of the paper's, SMAC's and the PvP leagues' runs
/// take about 47 MB, a third of it their curves, with room for about ten more runs).
const SHIP_RUN_BYTES: u64 = 300 * 1024;
const SHIP_TOTAL_BYTES: u64 = 48 * 1024 * 1024;

/// The plan's runs of one shard, and of those only the ones named (all when none is), a name
/// the shard lacks refused with the shard's.
fn select<'p>(
    plan: &'p avacraft_eval::TrainPlan,
    shard: Option<avacraft_eval::Shard>,
    only: &[String],
) -> Result<Vec<&'p avacraft_eval::TrainJob>> {
    let mut jobs = plan.shard(shard);
    if let Some(bad) = only.iter().find(|u| !jobs.iter().any(|j| &j.id == *u)) {
        let ids: Vec<&str> = jobs.iter().map(|j| j.id.as_str()).collect();
        let of = shard.map_or_else(String::new, |s| format!(" in shard {}/{}", s.index, s.count));
        bail!("--only {bad}: not one of the plan's runs{of} ({})", ids.join(", "));
    }
    if !only.is_empty() {
        jobs.retain(|j| only.contains(&j.id));
    }
    Ok(jobs)
}

/// `train --plan FILE --ship DIR`: the plan's finished runs' policies into `DIR` (with
/// `--only`, those named alone: no other shipped run is touched, nor its figure redrawn).
fn ship_plan(
    path: &std::path::Path,
    (shard, only): (Option<avacraft_eval::Shard>, &[String]),
    to: &std::path::Path,
    unfinished: &[String],
    out: &mut dyn Write,
) -> Result<()> {
    let plan = avacraft_eval::load_train_plan(path)?;
    let jobs = select(&plan, shard, only)?;
    if let Some(bad) = unfinished.iter().find(|u| !jobs.iter().any(|j| &j.id == *u)) {
        let ids: Vec<&str> = jobs.iter().map(|j| j.id.as_str()).collect();
        let what = if only.is_empty() { "the plan's runs" } else { "the runs --only names" };
        bail!("--unfinished {bad}: not one of {what} ({})", ids.join(", "));
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(["run", "shipped to", "kB without curves", "weights", "trained"]);
    let (mut shipped, mut redrawn, mut waiting) = (0, 0, Vec::new());
    for job in jobs {
        // Finished: through the plan (its summary written), or resumed by hand to the plan's
        // budget (`train --resume DIR --steps N`).
        let done = job.dir.join(DONE_FILE).is_file() || reached_budget(&job.dir, job.steps);
        let started = job.dir.join("config.json").is_file();
        let ship = done || (unfinished.contains(&job.id) && started);
        let name = if job.seed == 1 { job.run.clone() } else { format!("{}-s{}", job.run, job.seed) };
        let dest = to.join(&job.scenario).join(&name);
        if !ship {
            // A copy shipped from another machine keeps its log: its figure is drawn again
            // with this build's plotting, as a copy shipped from here is.
            if !started && avacraft_marl::ship::redraw(&dest, job.seed).with_context(|| format!("redrawing {}", dest.display()))? {
                redrawn += 1;
            } else {
                waiting.push(job.id.clone());
            }
            continue;
        }
        let trained = if done { "to its budget".to_owned() } else { format!("unfinished: {} steps", last_t_env(&job.dir)?) };
        let total = avacraft_marl::ship::Total { root: to, max_bytes: SHIP_TOTAL_BYTES };
        let r = avacraft_marl::ship::ship_under(&job.dir, &dest, SHIP_RUN_BYTES, Some(total))
            .with_context(|| format!("shipping {}", job.id))?;
        t.add_row([
            job.id.clone(),
            dest.display().to_string(),
            format!("{:.0}", r.bytes as f64 / 1024.0),
            match (r.half, r.last_half) {
                (true, _) => "f16",
                (false, true) => "f32 (last/ f16)",
                (false, false) => "f32",
            }
            .into(),
            trained,
        ]);
        shipped += 1;
    }
    writeln!(out, "{t}")?;
    let total = avacraft_marl::ship::dir_bytes(to)?;
    writeln!(
        out,
        "{shipped} runs shipped into {} ({:.1} MB in all); {redrawn} shipped before, their runs not here, had their figures drawn again; not finished yet: {}",
        to.display(),
        total as f64 / 1e6,
        if waiting.is_empty() { "none".to_owned() } else { waiting.join(", ") }
    )?;
    Ok(())
}

/// Whether the run in `dir` saved its state at `steps` environment steps or later.
fn reached_budget(dir: &std::path::Path, steps: u64) -> bool {
    dir.join("resume").join("state.json").is_file() && avacraft_marl::resume::load(dir).is_ok_and(|(_, state)| state.t_env >= steps)
}

/// The environment steps of a run's last logged row.
fn last_t_env(dir: &std::path::Path) -> Result<u64> {
    let path = dir.join("log.csv");
    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let last = text.lines().skip(1).filter(|l| !l.trim().is_empty()).last();
    let steps = last.and_then(|l| l.split(',').next()).and_then(|f| f.trim().parse().ok());
    steps.with_context(|| format!("{}: no logged row with a step count", path.display()))
}

/// `train --plan`: the plan's runs (of one shard) one after another, each using every core.
fn run_plan(
    path: &std::path::Path,
    (shard, only): (Option<avacraft_eval::Shard>, &[String]),
    threads: Option<usize>,
    out: &mut dyn Write,
) -> Result<()> {
    let plan = avacraft_eval::load_train_plan(path)?;
    let jobs = select(&plan, shard, only)?;
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    writeln!(
        out,
        "plan {} ({}): {} runs{}, into {}",
        plan.name,
        plan.file,
        jobs.len(),
        shard.map_or_else(String::new, |s| format!(" of shard {}/{}", s.index, s.count)),
        plan.out.display()
    )?;
    let mut rows = Vec::new();
    for (k, job) in jobs.iter().enumerate() {
        let done_path = job.dir.join(DONE_FILE);
        if done_path.is_file() {
            let text = std::fs::read_to_string(&done_path).with_context(|| format!("reading {}", done_path.display()))?;
            let d: Done = serde_json::from_str(&text)
                .with_context(|| format!("{}: not a finished run's summary (remove it to run again)", done_path.display()))?;
            // A budget raised after the run finished: it goes on from its last state.
            if d.t_env >= job.steps || !job.dir.join("resume").join("state.json").is_file() {
                rows.push((job.id.clone(), "done before".to_owned(), d.t_env, d.final_test_win_rate));
                continue;
            }
        }
        let cfg = Config::for_algo(&job.algo, &job.overrides).with_context(|| format!("run {}", job.id))?;
        // Resolved before comparing with a saved run, which names the set it played.
        let (cfg, scenario) = cfg.resolved(Arc::new(Scenario::load(&job.scenario)?)).with_context(|| format!("run {}", job.id))?;
        if let Some(src) = &job.from
            && !job.dir.join("resume").join("state.json").is_file()
        {
            if !(src.dir.join(DONE_FILE).is_file() || reached_budget(&src.dir, src.steps)) {
                rows.push((job.id.clone(), format!("waiting for {}", src.id), 0, None));
                continue;
            }
            continue_from(&src.dir, &job.dir, &cfg, &scenario).with_context(|| format!("run {}: going on from {}", job.id, src.id))?;
        }
        let start = if job.dir.join("resume").join("state.json").is_file() {
            let (saved, state) = avacraft_marl::resume::load(&job.dir).with_context(|| format!("resuming run {}", job.id))?;
            // The budget may change (the run goes on to the plan's, as `--resume --steps`
            // does); every other setting must be the saved run's.
            let mut budgeted = saved.clone();
            budgeted.t_max = cfg.t_max;
            if budgeted != cfg {
                bail!(
                    "run {}: {} holds a run of another config than the plan's (move it away to start afresh, or restore the plan)",
                    job.id,
                    job.dir.display()
                );
            }
            if state.t_env > cfg.t_max {
                bail!(
                    "run {}: {} has trained {} steps, past the plan's budget of {} (raise the plan's `steps`, or move the run away)",
                    job.id,
                    job.dir.display(),
                    state.t_env,
                    cfg.t_max
                );
            }
            Some(state)
        } else {
            None
        };
        let status = if start.is_some() { "resumed" } else { "ran" };
        let label = format!("[{}/{}] {} ", k + 1, jobs.len(), job.id);
        let summary =
            execute(&cfg, scenario, job.seed, threads, &job.dir, start, &label, out).with_context(|| format!("run {}", job.id))?;
        let done = Done {
            t_env: summary.t_env,
            episodes: summary.episodes,
            updates: summary.updates,
            final_test_win_rate: summary.tests.last().map(|t| t.win_rate),
        };
        avacraft_marl::aside::write_file(&done_path, serde_json::to_string_pretty(&done)?)
            .with_context(|| format!("writing {}", done_path.display()))?;
        rows.push((job.id.clone(), status.to_owned(), summary.t_env, done.final_test_win_rate));
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header(["run", "status", "steps", "last greedy win rate"]);
    for (id, status, steps, wr) in rows {
        t.add_row([id, status, steps.to_string(), wr.map_or_else(|| "-".to_owned(), |w| format!("{w:.2}"))]);
    }
    writeln!(out, "{t}")?;
    Ok(())
}

/// A plan's run that goes on from another (`from`): the other's folder copied into `dir` (all
/// but its summary; aside first, so a kill never leaves half a copy that looks like a run),
/// made ready to resume under this run's settings (`continuation::continue_as`).
fn continue_from(src: &std::path::Path, dir: &std::path::Path, cfg: &Config, scenario: &Arc<Scenario>) -> Result<()> {
    if !src.join("resume").join("state.json").is_file() {
        bail!("{} has no resume/state.json to go on from", src.display());
    }
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.with_file_name(format!("{name}.copy"));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).with_context(|| format!("removing {}", tmp.display()))?;
    }
    copy_dir(src, &tmp)?;
    avacraft_marl::continuation::continue_as(&tmp, cfg, scenario)
        .with_context(|| format!("{}: its networks under this run's settings", src.display()))?;
    if dir.exists() {
        // A folder without a saved state holds nothing a resume could use.
        std::fs::remove_dir_all(dir).with_context(|| format!("removing {}", dir.display()))?;
    }
    std::fs::rename(&tmp, dir).with_context(|| format!("renaming {} to {}", tmp.display(), dir.display()))
}

fn copy_dir(from: &std::path::Path, to: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(to).with_context(|| format!("creating {}", to.display()))?;
    for e in std::fs::read_dir(from).with_context(|| format!("reading {}", from.display()))? {
        let e = e?;
        // A summary is the source run's own; a file left aside by a killed write is no part
        // of it.
        if e.file_name() == DONE_FILE || avacraft_marl::aside::is_aside(&e.path()) {
            continue;
        }
        let (a, b) = (e.path(), to.join(e.file_name()));
        if e.file_type()?.is_dir() {
            copy_dir(&a, &b)?;
        } else {
            std::fs::copy(&a, &b).with_context(|| format!("copying {} to {}", a.display(), b.display()))?;
        }
    }
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
