//! `avacraft smac-report`: SMAC's 23 maps, our learners beside the real game's published
//! results. It reads the training runs of eval/plans/smac.toml (`<runs>/<map>/<run>-s1/log.csv`,
//! and `heldout.json`, an `avacraft episode --json` report on held-out seeds, where one was
//! played; without one, the folder's best-test checkpoint `best/` plays them, as its shipped
//! copy would, else its last) and the published numbers (eval/smac/published.toml), and writes the comparison
//! table (Markdown) and the learning curves of every map in one figure. A run whose training
//! folder is gone (another machine's, or removed) is read from its shipped copy under
//! `baselines/`, whose log it carries; its held-out games are played again from the shipped
//! checkpoint, as `avacraft episode` plays them (seeded: the same games).

use anyhow::{Context, Result, bail};
use avacraft_engine::smac_names;
use avacraft_marl::runlog::{LogRow, Panel, grid, read_log};
use clap::Args;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct SmacReportArgs {
    /// The plan's output folder (`<map>/<run>-s1/` under it).
    #[arg(long, default_value = "runs/smac")]
    runs: PathBuf,
    /// The published results (TOML: `[maps.<map>]` with `class` and `qmix_smac`, `qmix_tuned`,
    /// `mappo` = { value, check }).
    #[arg(long, default_value = "eval/smac/published.toml")]
    published: PathBuf,
    /// The shipped baselines (`<map>/<run>/`, `<run>-s<seed>` past seed 1): a run without a
    /// training folder under `--runs` is read from here.
    #[arg(long, default_value = "baselines")]
    baselines: PathBuf,
    /// Where the figure goes (`curves.png`) and the table (`table.md`).
    #[arg(long, default_value = "docs/smac")]
    out: PathBuf,
    /// Also write the table into this Markdown file, between the lines
    /// `<!-- smac-report:begin -->` and `<!-- smac-report:end -->`.
    #[arg(long)]
    doc: Option<PathBuf>,
}

/// The learners compared, as the plan names their runs.
const RUNS: [&str; 2] = ["qmix", "mappo"];
/// Runs of the plan with other settings than the compared learners' (seed 1, on the maps
/// where they ran), with what differs (eval/plans/smac.toml says why each ran): listed under
/// the table and drawn beside them; a finished one that does better is compared, and named.
const VARIANTS: [(&str, &str); 18] = [
    ("qmix-epymarl", "EPyMARL's QMIX settings with its recurrent agent (Adam at 5e-4, one-step targets), 300k steps"),
    ("qmix-pymarl", "PyMARL's QMIX, as the SMAC paper ran it (recurrent agent, RMSprop at 5e-4, one-step targets)"),
    ("mappo-ff", "feed-forward actor and critic, 5 PPO epochs (the MAPPO repository's script)"),
    ("mappo-ff-obs", "as mappo-ff, the critic also reading each agent's observation"),
    ("mappo-ln", "the MAPPO repository's network (layer norms, orthogonal initialisation)"),
    ("mappo-ln-10m", "as mappo-ln, at 10M steps"),
    ("mappo-ff-ln", "as mappo-ff, on the MAPPO repository's network"),
    ("qmix-pymarl2", "pymarl2's QMIX settings (recurrent agent, batches of 128 episodes)"),
    (
        "mappo-ff-ln-clip",
        "as mappo-ff-ln, 15 PPO epochs and the clip at 0.05 (the MAPPO repository's 3s_vs_5z script but for its stacked frames)",
    ),
    ("mappo-ff-ln-stack", "as mappo-ff-ln-clip, with 4 stacked frames: the MAPPO repository's 3s_vs_5z script"),
    ("mappo-clip", "the clip at 0.05 and 10 PPO epochs (the MAPPO repository's 5m_vs_6m script, on PyMARL's recurrent network)"),
    ("mappo-stack", "as mappo-ff-ln, 15 PPO epochs and 4 stacked frames: the MAPPO repository's 3s_vs_4z script"),
    ("mappo-clip15", "the clip at 0.05 (the MAPPO repository's 8m_vs_9m script, on PyMARL's recurrent network)"),
    (
        "qmix-signed",
        "SMAC's signed reward (reward_only_positive=False: the team's own losses taken off at 0.5), otherwise the shipped QMIX",
    ),
    (
        "mappo-signed",
        "SMAC's signed reward (reward_only_positive=False: the team's own losses taken off at 0.5), otherwise the plan's MAPPO",
    ),
    ("mappo-ff-ln-as", "as mappo-ff-ln, the critic on the MAPPO repository's agent-specific state (`state_agent`)"),
    ("mappo-ln-as", "as mappo-ln, the critic on the MAPPO repository's agent-specific state (`state_agent`)"),
    ("mappo-ff-ln-stack-as", "as mappo-ff-ln-stack, the critic on the MAPPO repository's agent-specific state (`state_agent`)"),
];
/// Runs of the plan on another game than the compared learners' (another data set than the
/// map's, or weapon periods counted from the shot), with what differs: listed under the
/// table, never compared with the real game's numbers nor drawn beside them.
const OTHER_GAMES: [(&str, &str); 3] =
    [("qmix-void", "the Void data set"), ("qmix-shot", "period from the shot"), ("mappo-shot", "period from the shot")];
/// Test rounds whose median is a run's final win rate (the MAPPO paper's rule).
const LAST_ROUNDS: usize = 10;
const BEGIN: &str = "<!-- smac-report:begin -->";
const END: &str = "<!-- smac-report:end -->";

#[derive(Deserialize)]
struct Published {
    maps: BTreeMap<String, PublishedMap>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PublishedMap {
    class: String,
    qmix_smac: Option<Cell>,
    qmix_tuned: Option<Cell>,
    mappo: Option<Cell>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct Cell {
    value: f64,
    check: Check,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
enum Check {
    #[serde(rename = "repo")]
    Repo,
    #[serde(rename = "2nd")]
    Second,
    #[serde(rename = "u")]
    Unverified,
}

impl Cell {
    fn show(self) -> String {
        let tag = match self.check {
            Check::Repo => "",
            Check::Second => " ²",
            Check::Unverified => " ᵘ",
        };
        format!("{:.0}{tag}", self.value)
    }
}

/// One learner's run on one map.
struct Ours {
    steps: u64,
    final_rate: f64,
    /// Held-out greedy win rate and its episodes.
    heldout: Option<(f64, usize)>,
    /// Not finished (no `done.json`): still training, or stopped short of its budget.
    running: bool,
    /// The steps it was planned for (its config's `t_max`), where its config says.
    budget: Option<u64>,
    /// Its resume state is here (`resume/` in its training folder): an unfinished run goes on
    /// from where it stopped; without it (a shipped copy) it trains again from the start.
    resumable: bool,
    rows: Vec<LogRow>,
}

impl Ours {
    /// An unfinished run's steps left to its budget and the hours they take at the pace it
    /// trained at: the median over its log's last rows of steps per wall-clock second, so
    /// that a stretch the run stood paused (its clock runs on) does not slow the estimate, and
    /// a run resumed on a faster build is timed at its new pace.
    fn left(&self) -> Option<Left> {
        let budget = self.budget.filter(|b| self.running && *b > self.steps)?;
        let recent = &self.rows[self.rows.len().saturating_sub(PACE_ROWS)..];
        let mut rates: Vec<f64> = recent
            .windows(2)
            .filter_map(|w| {
                let (steps, secs) = (w[1].t_env.saturating_sub(w[0].t_env), w[1].elapsed_s - w[0].elapsed_s);
                (steps > 0 && secs > 0.0).then(|| steps as f64 / secs)
            })
            .collect();
        rates.sort_by(f64::total_cmp);
        let pace = *rates.get(rates.len() / 2)?;
        let steps = if self.resumable { budget - self.steps } else { budget };
        (pace.is_finite() && pace > 0.0).then(|| Left { steps, hours: steps as f64 / pace / 3600.0, from_scratch: !self.resumable })
    }
}

/// The log rows (test rounds) whose pace times what a run has left.
const PACE_ROWS: usize = 50;

/// What an unfinished run has left to its budget.
struct Left {
    steps: u64,
    hours: f64,
    /// Its resume state is not on this machine: the whole budget again.
    from_scratch: bool,
}

/// A run's planned steps, from the `config.json` its folder holds (`None` without one).
fn budget_of(dir: &Path) -> Result<Option<u64>> {
    let path = dir.join("config.json");
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(None) };
    let meta: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("{}", path.display()))?;
    let t_max = meta["config"]["t_max"].as_u64().with_context(|| format!("{}: no config.t_max", path.display()))?;
    Ok(Some(t_max))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => (v[n / 2 - 1] + v[n / 2]) / 2.0,
    }
}

fn ours(dir: &Path) -> Result<Option<Ours>> {
    if !dir.join("log.csv").is_file() {
        return Ok(None);
    }
    let rows = read_log(dir)?;
    let Some(last) = rows.last() else { return Ok(None) };
    let tail: Vec<f64> = rows.iter().rev().take(LAST_ROUNDS).map(|r| r.test_win_rate).collect();
    let heldout = match std::fs::read_to_string(dir.join("heldout.json")) {
        Ok(text) => {
            let r: crate::Report = serde_json::from_str(&text).with_context(|| format!("{}/heldout.json", dir.display()))?;
            Some((r.summary.win.mean, r.episodes.len()))
        }
        Err(_) => None,
    };
    let budget = budget_of(dir)?;
    let (running, resumable) = (!dir.join("done.json").is_file(), dir.join("resume").is_dir());
    Ok(Some(Ours { steps: last.t_env, final_rate: median(tail), heldout, running, budget, resumable, rows }))
}

/// Held-out games: seeds 9000-9099, SMAC's passive allies, the checkpoint playing greedily.
const HELDOUT: [&str; 7] = ["--passive-agents", "--episodes", "100", "--seed", "9000", "--json", "--agent"];

/// Held-out results already played this report, by checkpoint folder: the seeds table asks for
/// seed 1's runs again, and 100 games a run is the report's longest work.
type Played = BTreeMap<PathBuf, (f64, usize)>;

/// A learner's run on `map` (`seed`): its training folder under `runs`, else its shipped copy
/// under `baselines`, with the held-out games played again from the checkpoint where no
/// report of them is kept (once a report: `played` keeps them).
fn find_run(runs: &Path, baselines: &Path, played: &mut Played, map: &str, run: &str, seed: u64) -> Result<Option<Ours>> {
    let dir = runs.join(map).join(format!("{run}-s{seed}"));
    if dir.join("log.csv").is_file() {
        let Some(mut o) = ours(&dir)? else { return Ok(None) };
        // A training folder without a held-out report plays them from its best-test
        // checkpoint, the one a shipped copy carries (so the table reads the same with the
        // folder or without it), else from its last test round's policy (a run too young to
        // have a best).
        let best = dir.join("best");
        let from = if best.join("agent.safetensors").is_file() { best } else { dir.clone() };
        if o.heldout.is_none() && from.join("agent.safetensors").is_file() {
            o.heldout = Some(heldout_of(played, &from, map)?);
        }
        return Ok(Some(o));
    }
    let shipped = baselines.join(map).join(if seed == 1 { run.to_owned() } else { format!("{run}-s{seed}") });
    if !shipped.join("log.csv").is_file() {
        return Ok(None);
    }
    let rows = read_log(&shipped)?;
    let Some(last) = rows.last() else { return Ok(None) };
    let t_max = budget_of(&shipped)?.with_context(|| format!("reading {}/config.json", shipped.display()))?;
    let heldout = heldout_of(played, &shipped, map)?;
    let tail: Vec<f64> = rows.iter().rev().take(LAST_ROUNDS).map(|r| r.test_win_rate).collect();
    Ok(Some(Ours {
        steps: last.t_env,
        final_rate: median(tail),
        heldout: Some(heldout),
        running: last.t_env < t_max,
        budget: Some(t_max),
        resumable: false,
        rows,
    }))
}

/// The held-out games of the checkpoint in `dir`, played once a report.
fn heldout_of(played: &mut Played, dir: &Path, map: &str) -> Result<(f64, usize)> {
    if let Some(h) = played.get(dir) {
        return Ok(*h);
    }
    let h = play_heldout(dir, map)?;
    played.insert(dir.to_path_buf(), h);
    Ok(h)
}

/// Plays the shipped checkpoint in `shipped` on `map`'s held-out seeds, as `avacraft episode`
/// does: its win rate and the number of games.
fn play_heldout(shipped: &Path, map: &str) -> Result<(f64, usize)> {
    #[derive(clap::Parser)]
    struct Episode {
        #[command(flatten)]
        args: crate::episode::EpisodeArgs,
    }
    let agent = format!("marl:{}", shipped.display());
    let game = learned_game(shipped)?;
    let argv = ["episode", "--scenario", map].into_iter().chain(game.iter().map(String::as_str)).chain(HELDOUT).chain([agent.as_str()]);
    let e = <Episode as clap::Parser>::try_parse_from(argv)?;
    let mut json = Vec::new();
    crate::episode::run(&e.args, &mut json).with_context(|| format!("playing {}'s held-out games", shipped.display()))?;
    let r: crate::Report = serde_json::from_slice(&json).with_context(|| format!("{}: the held-out report", shipped.display()))?;
    Ok((r.summary.win.mean, r.episodes.len()))
}

/// `avacraft episode`'s options for the game the checkpoint in `dir` learned: its unit data,
/// its reading of weapon periods and the surround experiment (not the map's defaults: a run on
/// the Void data, with the period from the shot or under the surround is played again on that
/// game).
fn learned_game(dir: &Path) -> Result<[String; 6]> {
    let data = avacraft_marl::Policy::data_in(dir).with_context(|| format!("{}: the unit data it learned on", dir.display()))?;
    let period = avacraft_marl::Policy::weapon_period_in(dir).with_context(|| format!("{}: its weapon periods", dir.display()))?;
    let surround = avacraft_marl::Policy::melee_surround_in(dir).with_context(|| format!("{}: the surround experiment", dir.display()))?;
    Ok(["--data".into(), data.to_string(), "--weapon-period".into(), period.to_string(), "--melee-surround".into(), surround.to_string()])
}

fn pct(x: f64) -> String {
    format!("{:.0}", 100.0 * x)
}

fn show_ours(o: Option<&Ours>) -> String {
    match o {
        None => "not run".into(),
        Some(o) => {
            let held = o.heldout.map_or_else(String::new, |(w, _)| format!(" / {}", pct(w)));
            let running = if o.running { " (unfinished)" } else { "" };
            format!("{}{held} @ {:.1}M{running}", pct(o.final_rate), o.steps as f64 / 1e6)
        }
    }
}

/// The compared runs stopped short: the steps each has left and the hours they take at its
/// own pace on the machine it trained on (where the run shares its cores, slower than alone).
fn left_table(left: &[(String, Left)]) -> String {
    if left.is_empty() {
        return String::new();
    }
    let rows: String = left
        .iter()
        .map(|(run, l)| {
            let from = if l.from_scratch { "step 0 (only its shipped copy is here)" } else { "where it stopped" };
            format!("| {run} | {:.2}M | {from} | {:.1} |\n", l.steps as f64 / 1e6, l.hours)
        })
        .collect();
    let total: f64 = left.iter().map(|(_, l)| l.hours).sum();
    format!(
        "\n**Left to SMAC's budget** ({total:.0} hours of one core in all, at the pace of each run's last {PACE_ROWS} test rounds):\n\n\
         | run | steps left | trains on from | hours |\n|---|---|---|---|\n{rows}"
    )
}

/// How soon each map's QMIX and MAPPO (seed 1, the table's runs) got there: the steps of
/// their first greedy test round at or above 50% and 90%, and of the rounds from that first 90%
/// on, the share at or above it (a run that touched 90% once and fell back reads low).
fn speed_table(panels: &[Panel]) -> String {
    let first = |rows: &[LogRow], rate: f64| rows.iter().position(|r| r.test_win_rate >= rate);
    let cells = |rows: &[LogRow]| -> [String; 3] {
        let at = |i: Option<usize>| i.map_or_else(|| "never".to_owned(), |i| avacraft_marl::plot::steps_label(rows[i].t_env as f64));
        let held = first(rows, 0.9).map_or_else(
            || "–".to_owned(),
            |i| {
                let after = &rows[i..];
                let kept = after.iter().filter(|r| r.test_win_rate >= 0.9).count();
                format!("{}%", pct(kept as f64 / after.len() as f64))
            },
        );
        [at(first(rows, 0.5)), at(first(rows, 0.9)), held]
    };
    let rows: String = panels
        .iter()
        .map(|p| {
            let of = |r: &str| {
                p.runs.iter().find(|(n, _)| n == r).map_or_else(|| ["–".to_owned(), "–".into(), "–".into()], |(_, rows)| cells(rows))
            };
            let ([q50, q90, qh], [m50, m90, mh]) = (of(RUNS[0]), of(RUNS[1]));
            format!(
                "| {} | {q50} | {q90} | {qh} | {m50} | {m90} | {mh} |
",
                p.title
            )
        })
        .collect();
    format!(
        "
**How soon.** Environment steps to the first greedy test round (32 episodes) at or above 50% and 90%, and the share of \
         the rounds from that first 90% on that stayed at or above it (seed 1, the table's runs):\n\n\
         | map | QMIX 50% at | QMIX 90% at | QMIX rounds ≥ 90% after | MAPPO 50% at | MAPPO 90% at | MAPPO rounds ≥ 90% after |\n\
         |---|---|---|---|---|---|---|\n{rows}"
    )
}

/// Maps where more than one seed of a learner ran: each seed's result, so a reader sees how far
/// one seed is from another.
fn seeds_table(a: &SmacReportArgs, played: &mut Played) -> Result<String> {
    let mut parts = Vec::new();
    for map in smac_names() {
        for r in RUNS.iter().chain(VARIANTS.iter().map(|(v, _)| v)) {
            let seeds: Vec<Option<Ours>> = (1..=3).map(|k| find_run(&a.runs, &a.baselines, played, map, r, k)).collect::<Result<_>>()?;
            if seeds.iter().filter(|o| o.is_some()).count() < 2 {
                continue;
            }
            let shown: Vec<String> = seeds.iter().map(|o| o.as_ref().map_or_else(|| "–".to_owned(), |o| show_ours(Some(o)))).collect();
            // The literature's summary over seeds: the median of each seed's final test rate.
            let finals: Vec<f64> = seeds.iter().flatten().map(|o| o.final_rate).collect();
            let partial = if seeds.iter().flatten().any(|o| o.running) { " (a seed unfinished)" } else { "" };
            parts.push(format!("| {map} | {r} | {} | {}{partial} |\n", shown.join(" | "), pct(median(finals))));
        }
    }
    Ok(if parts.is_empty() {
        String::new()
    } else {
        format!(
            "\n**Seeds.** Where more than one seed of a run trained (test / held-out @ steps, as in the table):\n\n\
             | map | run | seed 1 | seed 2 | seed 3 | median over seeds (test) |\n|---|---|---|---|---|---|\n{}",
            parts.concat()
        )
    })
}

/// The must-hold shortfall the median gap may reach (points below the best published result).
const MEDIAN_GAP_FLOOR: f64 = -10.0;

/// The page's first lines: how many runs reached their budget, and where the two
/// must-holds stand (easy maps won on at least 90% of held-out episodes; the median gap to
/// the best published result at most 10 points short).
fn glance(tally: &[[usize; 3]; RUNS.len()], easy: &[(&str, f64)], gaps: &[f64]) -> String {
    let runs: Vec<String> =
        RUNS.iter().zip(tally).map(|(r, [done, short, none])| format!("{r} on {done} ({short} stopped short, {none} not run)")).collect();
    let won = easy.iter().filter(|(_, h)| *h >= 0.9).count();
    let below: Vec<String> = easy.iter().filter(|(_, h)| *h < 0.9).map(|(m, h)| format!("{m} {}%", pct(*h))).collect();
    let unplayed = easy.iter().filter(|(_, h)| !h.is_finite()).count();
    let mut short = Vec::new();
    if !below.is_empty() {
        short.push(format!("below: {}", below.join(", ")));
    }
    if unplayed > 0 {
        short.push(format!("not played: {unplayed}"));
    }
    let short = if short.is_empty() { String::new() } else { format!(" ({})", short.join("; ")) };
    let med = median(gaps.to_vec());
    let gap = if med.is_finite() {
        let verdict = if med >= MEDIAN_GAP_FLOOR { "holds" } else { "falls short" };
        format!("{med:+.1} points over {} maps: the second must-hold (a median of at least {MEDIAN_GAP_FLOOR:.0}) {verdict}", gaps.len())
    } else {
        "no finished run with a published number yet".to_owned()
    };
    format!(
        "**At a glance.** Runs at SMAC's budget, of {} maps: {}. Easy maps won on at least 90% of held-out episodes (the issue's first must-hold: all of them): {won} of {}{short}. \
         Median gap between our best finished run and the best published result: {gap}.\n",
        smac_names().count(),
        runs.join("; "),
        easy.len()
    )
}

/// The lines under the table: how to read it, the median gap, the easy maps' held-out rates.
fn notes(gaps: &[f64], easy: &[(&str, f64)]) -> String {
    let med = median(gaps.to_vec());
    let easy_held: Vec<String> =
        easy.iter().map(|(m, h)| if h.is_finite() { format!("{m} {}", pct(*h)) } else { format!("{m} –") }).collect();
    format!(
        "\nOurs: the median greedy test win rate (%) of the run's last {LAST_ROUNDS} test rounds (32 episodes each) / the held-out win rate (%) of its best-test checkpoint on seeds 9000-9099 where played, @ the steps trained. \
         Where a finished run with other settings (listed under the table) does better, the last column compares it and names it. \
         Runs on another game (another data set than the map's, or `-shot`: weapon periods counted from the damage point) are listed with what differs and never compared. \
         Published: the SMAC paper's QMIX at 2M steps on every map, the super-hard ones included; pymarl2's tuned QMIX at 10M; the MAPPO paper's MAPPO at up to 10M; class: the MAPPO paper's difficulty class. \
         ² seen in a secondary copy, ᵘ unverified (the paper's table could not be read), unmarked read in the authors' repository. \
         Median gap over the {} maps with a finished run and a published number: {}.\n\
         Easy maps, best held-out win rate (%): {}.\n",
        gaps.len(),
        if med.is_finite() { format!("{med:+.1} points") } else { "none yet".into() },
        easy_held.join(", ")
    )
}

/// Writes `table` into the Markdown file `doc` between its `BEGIN` and `END` lines.
fn write_into(doc: &Path, table: &str) -> Result<()> {
    let text = std::fs::read_to_string(doc).with_context(|| format!("{}", doc.display()))?;
    let (Some(b), Some(e)) = (text.find(BEGIN), text.find(END)) else {
        bail!("{}: no `{BEGIN}` ... `{END}` section to write the table into", doc.display());
    };
    if e < b {
        bail!("{}: `{END}` comes before `{BEGIN}`", doc.display());
    }
    let new = format!("{}{BEGIN}\n{table}{}", &text[..b], &text[e..]);
    std::fs::write(doc, new).with_context(|| format!("{}", doc.display()))
}

pub fn run(a: &SmacReportArgs, out: &mut dyn Write) -> Result<()> {
    let text = std::fs::read_to_string(&a.published).with_context(|| format!("{}", a.published.display()))?;
    let published: Published = toml::from_str(&text).with_context(|| format!("{}", a.published.display()))?;
    for name in published.maps.keys() {
        if !smac_names().any(|n| n == name) {
            bail!("{}: `{name}` is not one of SMAC's maps", a.published.display());
        }
    }
    let mut table = String::new();
    table.push_str(
        "| map | class | our QMIX | our MAPPO | QMIX (SMAC paper) | QMIX (pymarl2 tuned) | MAPPO (paper) | ours best − published best |\n",
    );
    table.push_str("|---|---|---|---|---|---|---|---|\n");
    let mut panels = Vec::new();
    let mut gaps = Vec::new();
    let mut easy = Vec::new();
    let mut variants = Vec::new();
    let mut left = Vec::new();
    // Per learner: runs at their budget, stopped short, not run.
    let mut tally = [[0usize; 3]; RUNS.len()];
    let mut played = Played::new();
    for map in smac_names() {
        let p = published.maps.get(map).with_context(|| format!("{}: no entry for `{map}`", a.published.display()))?;
        let runs: Vec<(&str, Option<Ours>)> =
            RUNS.iter().map(|r| Ok((*r, find_run(&a.runs, &a.baselines, &mut played, map, r, 1)?))).collect::<Result<_>>()?;
        for (r, o) in &runs {
            if let Some(l) = o.as_ref().and_then(Ours::left) {
                left.push((format!("{map} {r}"), l));
            }
        }
        for (k, (_, o)) in runs.iter().enumerate() {
            tally[k][match o {
                Some(o) if !o.running => 0,
                Some(_) => 1,
                None => 2,
            }] += 1;
        }
        let mut others: Vec<(&str, Ours)> = Vec::new();
        for (v, what) in VARIANTS {
            if let Some(o) = find_run(&a.runs, &a.baselines, &mut played, map, v, 1)? {
                variants.push(format!("| {map} | {v} | {what} | {} |\n", show_ours(Some(&o))));
                others.push((v, o));
            }
        }
        for (v, game) in OTHER_GAMES {
            if let Some(o) = find_run(&a.runs, &a.baselines, &mut played, map, v, 1)? {
                variants.push(format!("| {map} | {v} | another game: {game}; never compared | {} |\n", show_ours(Some(&o))));
            }
        }
        // Our best finished run: the compared learners', or a finished run with other
        // settings (named in the cell). Runs still training are shown, not compared.
        let all = runs.iter().filter_map(|(r, o)| o.as_ref().map(|o| (*r, o))).chain(others.iter().map(|(r, o)| (*r, o)));
        // The first best: on a tie the compared learners' run, which come first.
        let best = all.clone().filter(|(_, o)| !o.running).fold(None, |b: Option<(&str, &Ours)>, (r, o)| match b {
            Some(b) if b.1.final_rate >= o.final_rate => Some(b),
            _ => Some((r, o)),
        });
        let best_pub = [p.qmix_smac, p.qmix_tuned, p.mappo].iter().flatten().map(|c| c.value).fold(f64::NAN, f64::max);
        let gap = match best {
            Some((r, o)) if best_pub.is_finite() => {
                let g = 100.0 * o.final_rate - best_pub;
                gaps.push(g);
                let by = if RUNS.contains(&r) { String::new() } else { format!(" ({r})") };
                format!("{g:+.0}{by}")
            }
            _ => "–".into(),
        };
        if p.class == "easy" {
            let held = all.filter_map(|(_, o)| o.heldout.map(|h| h.0)).fold(f64::NAN, f64::max);
            easy.push((map, held));
        }
        let cell = |c: Option<Cell>| c.map_or_else(|| "–".to_owned(), Cell::show);
        table.push_str(&format!(
            "| {map} | {} | {} | {} | {} | {} | {} | {gap} |\n",
            p.class,
            show_ours(runs[0].1.as_ref()),
            show_ours(runs[1].1.as_ref()),
            cell(p.qmix_smac),
            cell(p.qmix_tuned),
            cell(p.mappo),
        ));
        let best_pub_rate = best_pub.is_finite().then_some(best_pub / 100.0);
        let run_rows: Vec<(String, Vec<LogRow>)> = runs
            .into_iter()
            .filter_map(|(r, o)| o.map(|o| (r.to_owned(), o.rows)))
            .chain(others.into_iter().map(|(r, o)| (r.to_owned(), o.rows)))
            .collect();
        if !run_rows.is_empty() {
            let budget = if p.class == "super-hard" { 10_000_000 } else { 2_000_000 };
            panels.push(Panel { title: map.to_owned(), runs: run_rows, reference: best_pub_rate, budget });
        }
    }
    table.push_str(&notes(&gaps, &easy));
    table.push_str(&left_table(&left));
    table.push_str(&speed_table(&panels));
    table.push_str(&seeds_table(a, &mut played)?);
    if !variants.is_empty() {
        table.push_str(&format!(
            "\n**Other settings** (seed 1; test / held-out @ steps, as in the table):\n\n\
             | map | run | what differs | result |\n|---|---|---|---|\n{}",
            variants.concat()
        ));
    }
    // A blank line last: the page's end marker must not read as a row of the last table.
    let table = format!("{}\n{table}\n", glance(&tally, &easy, &gaps));
    std::fs::create_dir_all(&a.out).with_context(|| format!("{}", a.out.display()))?;
    std::fs::write(a.out.join("table.md"), &table).with_context(|| format!("{}/table.md", a.out.display()))?;
    let names: Vec<&str> = RUNS.iter().copied().chain(VARIANTS.iter().map(|(v, _)| *v)).collect();
    if !panels.is_empty() {
        grid(&a.out.join("curves.png"), "SMAC's maps: greedy test win rate against environment steps", &names, &panels, 5)?;
    }
    if let Some(doc) = &a.doc {
        write_into(doc, &table)?;
    }
    write!(out, "{table}")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run resumed on a faster build: what it has left is timed at its last rounds' pace.
    #[test]
    fn what_is_left_is_timed_at_the_recent_pace() {
        // 50 rounds at 10 steps a second, then 40 at 100.
        let mut rows = Vec::new();
        let (mut t, mut secs) = (0u64, 0.0);
        for k in 0..90 {
            t += 10_000;
            secs += if k < 50 { 1_000.0 } else { 100.0 };
            rows.push(LogRow {
                t_env: t,
                episodes: k,
                updates: k,
                train_win_rate: 0.5,
                test_win_rate: 1.0,
                test_return: 20.0,
                elapsed_s: secs,
            });
        }
        let ours = Ours { steps: t, final_rate: 1.0, heldout: None, running: true, budget: Some(1_900_000), resumable: true, rows };
        let left = ours.left().expect("unfinished");
        assert_eq!(left.steps, 1_000_000);
        assert!((left.hours - 1_000_000.0 / 100.0 / 3600.0).abs() < 1e-9, "{}", left.hours);
    }

    /// Shipped runs on another game than their map's default are played again on theirs.
    #[test]
    fn held_out_games_are_played_on_the_game_the_checkpoint_learned() -> Result<()> {
        let baselines = Path::new(env!("CARGO_MANIFEST_DIR")).join("../baselines/2s_vs_1sc");
        let game = |data: &'static str, period: &'static str, surround: &'static str| {
            ["--data", data, "--weapon-period", period, "--melee-surround", surround].map(String::from)
        };
        assert_eq!(learned_game(&baselines.join("qmix"))?, game("liberty", "attack", "false"));
        assert_eq!(learned_game(&baselines.join("qmix-void"))?, game("void", "attack", "false"));
        assert_eq!(learned_game(&baselines.join("qmix-shot"))?, game("liberty", "shot", "false"));
        // A run under the surround experiment (its config.json is all this reads).
        let surround = std::env::temp_dir().join(format!("avacraft-learned-surround-{}", std::process::id()));
        std::fs::create_dir_all(&surround)?;
        let mut meta: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(baselines.join("qmix/config.json"))?)?;
        meta["config"]["melee_surround"] = serde_json::Value::Bool(true);
        std::fs::write(surround.join("config.json"), meta.to_string())?;
        assert_eq!(learned_game(&surround)?, game("liberty", "attack", "true"));
        let _ = std::fs::remove_dir_all(&surround);
        let e = learned_game(&baselines.join("no-such-run")).expect_err("no checkpoint");
        assert!(format!("{e:#}").contains("no-such-run"), "{e:#}");
        Ok(())
    }
}
