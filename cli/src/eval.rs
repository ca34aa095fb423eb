//! `avacraft eval PLAN.toml`: plays an evaluation plan (resuming what a previous run
//! finished), then writes its report; `eval merge` combines shards' folders; `eval report`
//! rewrites a folder's report.

use anyhow::{Context, Result, bail};
use avacraft_eval::{CellKey, EpisodeResult, Meta, Progress, Report, RunOptions, Shard};
use clap::{Args, Subcommand};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct EvalArgs {
    #[command(subcommand)]
    cmd: Option<EvalCmd>,
    /// The evaluation plan (TOML; see the README).
    plan: Option<PathBuf>,
    /// The evaluation's folder (results.jsonl, AVA recordings, the report). Default:
    /// runs/eval-<plan name>. Run again with the same folder to resume.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Play only this machine's share of the plan: i/n plays every n-th episode from the
    /// i-th (e.g. a cluster array job's index); merge the folders with `eval merge`.
    #[arg(long)]
    shard: Option<Shard>,
    /// Worker threads playing episodes, and the threads trained policies' networks run on
    /// (0: one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Print the report's Markdown when done (default: only where it was written).
    #[arg(long)]
    print: bool,
}

#[derive(Subcommand, Debug)]
enum EvalCmd {
    /// Combine shards' evaluation folders into one and write its report.
    Merge {
        /// The merged folder (must not hold results yet).
        #[arg(long)]
        out: PathBuf,
        /// The shards' folders.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
    },
    /// Write the report of an evaluation folder again (e.g. while a run is going on); given
    /// a published `report.json` instead (its folder gone), write its document again.
    Report { dir: PathBuf },
}

/// Per-cell progress under one bar of episodes; without a terminal (a log file, a cluster
/// job), plain lines instead: failures at once, and where the run stands once a minute.
struct Bars {
    bar: ProgressBar,
    cell: ProgressBar,
    shown: bool,
    /// Episodes each cell plays in this run's plan (an agent may play fewer seeds).
    per_cell: BTreeMap<CellKey, usize>,
    tally: Mutex<BTreeMap<CellKey, (usize, usize, usize)>>,
    /// When the last plain progress line was written.
    said: Mutex<Option<Instant>>,
}

impl Bars {
    fn say(&self, line: String) {
        if self.shown {
            self.bar.println(line);
        } else {
            eprintln!("{line}");
        }
    }
}

/// How often a run without a terminal says where it stands.
const PLAIN_EVERY: Duration = Duration::from_secs(60);

impl Progress for Bars {
    fn start(&self, total: usize, skipped: usize) {
        self.bar.set_length(total as u64);
        self.bar.set_position(skipped as u64);
        if skipped > 0 {
            self.say(format!("resuming: {skipped} of {total} episodes are done already"));
        }
    }
    fn done(&self, r: &EpisodeResult) {
        self.bar.inc(1);
        let mut t = self.tally.lock().unwrap_or_else(|p| p.into_inner());
        let e = t.entry(r.cell.clone()).or_default();
        e.0 += 1;
        if r.result == Some(avacraft_engine::Outcome::Win) {
            e.1 += 1;
        }
        if let Some(why) = &r.error {
            e.2 += 1;
            self.say(format!("FAILED {} seed {}: {why}", r.cell, r.seed));
        }
        let failed = if e.2 > 0 { format!(", {} failed", e.2) } else { String::new() };
        let of = self.per_cell.get(&r.cell).copied().unwrap_or_default();
        let line = format!("{}: {}/{of} played, {} won{failed}", r.cell, e.0, e.1);
        if self.shown {
            self.cell.set_message(line);
            return;
        }
        let mut said = self.said.lock().unwrap_or_else(|p| p.into_inner());
        let now = Instant::now();
        let finished = self.bar.length().is_some_and(|n| self.bar.position() >= n);
        if finished || said.is_none_or(|t| now.duration_since(t) >= PLAIN_EVERY) {
            *said = Some(now);
            eprintln!("{}/{} episodes; {line}", self.bar.position(), self.bar.length().unwrap_or_default());
        }
    }
}

pub fn run(a: &EvalArgs, out: &mut dyn Write) -> Result<()> {
    match &a.cmd {
        Some(EvalCmd::Merge { out: dir, shards }) => return merge(dir, shards, out),
        Some(EvalCmd::Report { dir }) => return report(dir, out, a.print),
        None => {}
    }
    let Some(path) = &a.plan else { bail!("eval: name a plan file (or `eval merge`, `eval report`)") };
    let plan = avacraft_eval::load(path)?;
    for (agent, scenario, what) in &plan.off_rules {
        eprintln!("warning: {agent} on {scenario} plays under other rules than it learned: {what} (the plan's env sets them)");
    }
    let dir = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("eval-{}", plan.name)));
    avacraft_eval::write_meta(&dir, &Meta { shard: a.shard, fingerprints: avacraft_eval::fingerprints(&plan)?, ..Meta::of(&plan) })?;
    let shown = std::io::stderr().is_terminal();
    let multi = MultiProgress::new();
    let (bar, cell) = if shown {
        (multi.add(ProgressBar::new(0)), multi.add(ProgressBar::new_spinner()))
    } else {
        (ProgressBar::hidden(), ProgressBar::hidden())
    };
    bar.set_style(ProgressStyle::with_template("[{bar:40}] {pos}/{len} episodes ({eta})")?.progress_chars("=> "));
    cell.set_style(ProgressStyle::with_template("{msg}")?);
    let mut per_cell = BTreeMap::new();
    for job in plan.jobs_in(a.shard) {
        *per_cell.entry(plan.cells[job.cell].key.clone()).or_insert(0) += 1;
    }
    let bars = Bars { bar, cell, shown, per_cell, tally: Mutex::new(BTreeMap::new()), said: Mutex::new(None) };
    if a.threads > 0 {
        avacraft_marl::kernels::use_threads(a.threads);
    }
    let opts = RunOptions { out: dir.clone(), shard: a.shard, threads: a.threads };
    let stats = avacraft_eval::run(&plan, &opts, &bars).with_context(|| format!("eval: {}", plan.file))?;
    bars.bar.finish_and_clear();
    bars.cell.finish_and_clear();
    writeln!(
        out,
        "{}: {} episodes in this {}: {} played now, {} done before, {} failed",
        plan.name,
        stats.planned,
        if a.shard.is_some() { "shard" } else { "plan" },
        stats.played,
        stats.skipped,
        stats.failed
    )?;
    report(&dir, out, a.print)?;
    if stats.failed > 0 {
        bail!("{} episodes failed (see above; run again to retry them)", stats.failed);
    }
    Ok(())
}

fn report(dir: &Path, out: &mut dyn Write, print: bool) -> Result<()> {
    if dir.is_file() {
        return report_from_json(dir, out, print);
    }
    let meta = avacraft_eval::read_meta(dir)?;
    let loaded = avacraft_eval::read(&dir.join(avacraft_eval::RESULTS_FILE))?;
    for why in &loaded.unreadable {
        writeln!(out, "skipped an unreadable result line: {why}")?;
    }
    let r = Report::build(meta, &loaded);
    let mut files = r.write(dir)?;
    // The episodes in marl-eval's raw-data format, for its aggregation and plots.
    let me = dir.join("marl_eval.json");
    std::fs::write(&me, serde_json::to_string_pretty(&avacraft_eval::marl_eval_json(&loaded))?)
        .with_context(|| format!("writing {}", me.display()))?;
    files.push(me);
    if print {
        writeln!(out, "{}", r.markdown())?;
    }
    for f in files {
        writeln!(out, "wrote {}", f.display())?;
    }
    Ok(())
}

/// The document of a published `report.json` written again (the tables and plots from its
/// numbers; the plots drawn in a scratch folder first).
fn report_from_json(path: &Path, out: &mut dyn Write, print: bool) -> Result<()> {
    let text = std::fs::read_to_string(path).with_context(|| format!("eval report: reading {}", path.display()))?;
    let r: Report = serde_json::from_str(&text).with_context(|| format!("eval report: {} is not a report.json", path.display()))?;
    if r.meta.document.is_none() {
        bail!("eval report: {} names no document to write (its plan had no `document`)", path.display());
    }
    let scratch = std::env::temp_dir().join(format!("avacraft-report-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| format!("eval report: creating {}", scratch.display()))?;
    let files = r.write(&scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    if print {
        writeln!(out, "{}", r.markdown())?;
    }
    for f in files?.iter().filter(|f| !f.starts_with(&scratch)) {
        writeln!(out, "wrote {}", f.display())?;
    }
    Ok(())
}

fn merge(dir: &Path, shards: &[PathBuf], out: &mut dyn Write) -> Result<()> {
    let mut metas = Vec::new();
    for s in shards {
        // The same folder under two spellings is the same shard.
        let canon = std::fs::canonicalize(s).with_context(|| format!("eval merge: {}", s.display()))?;
        metas.push((canon, avacraft_eval::read_meta(s)?));
    }
    let (meta, missing) = avacraft_eval::check_shards(&metas)?;
    if !missing.is_empty() {
        let names: Vec<String> = missing.iter().map(ToString::to_string).collect();
        writeln!(out, "note: shards {} are missing; the merged report covers only the shards given", names.join(", "))?;
    }
    avacraft_eval::write_meta(dir, &meta)?;
    let parts: Vec<PathBuf> = shards.iter().map(|s| s.join(avacraft_eval::RESULTS_FILE)).collect();
    let merged = avacraft_eval::merge(&parts, &dir.join(avacraft_eval::RESULTS_FILE))?;
    writeln!(out, "merged {} episodes from {} shards into {}", merged.done.len(), shards.len(), dir.display())?;
    report(dir, out, false)
}
