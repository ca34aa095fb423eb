//! `avacraft curves`: training runs compared. Each `--group NAME=DIR[,DIR...]` is a set of
//! runs (their `log.csv`), e.g. one config over seeds, or old code against new on the same
//! seeds; the figure shows every run and each group's mean against environment steps and
//! wall-clock seconds, and the table when each run first reached the win rates asked for.

use anyhow::{Context, Result, bail};
use avacraft_marl::runlog::{Group, first_reaching, read_log};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct CurvesArgs {
    /// A group of runs: NAME=DIR[,DIR...] (each DIR a training run's output directory or its
    /// log.csv); repeatable.
    #[arg(long = "group", value_name = "NAME=DIR,...", required = true)]
    groups: Vec<String>,
    /// The figure (PNG).
    #[arg(long, default_value = "curves.png")]
    out: PathBuf,
    /// The figure's title.
    #[arg(long, default_value = "training runs")]
    title: String,
    /// The greedy test win rate a run must reach (with --train-win-rate on the same row).
    #[arg(long, default_value_t = 0.95)]
    test_win_rate: f64,
    /// The training win rate a run must reach.
    #[arg(long, default_value_t = 0.8)]
    train_win_rate: f64,
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct Reached {
    group: String,
    run: String,
    steps: Option<u64>,
    seconds: Option<f64>,
    final_test_win_rate: Option<f64>,
}

fn parse_group(text: &str) -> Result<Group> {
    let Some((name, dirs)) = text.split_once('=') else { bail!("--group `{text}`: expected NAME=DIR[,DIR...]") };
    let name = name.trim();
    if name.is_empty() {
        bail!("--group `{text}`: the name is empty");
    }
    let mut runs = Vec::new();
    for d in dirs.split(',').map(str::trim).filter(|d| !d.is_empty()) {
        let path = PathBuf::from(d);
        let rows = read_log(&path).with_context(|| format!("--group {name}"))?;
        if rows.is_empty() {
            bail!("--group {name}: {} has no test rounds yet", path.display());
        }
        runs.push((path, rows));
    }
    if runs.is_empty() {
        bail!("--group `{text}`: no run directories");
    }
    Ok(Group { name: name.to_owned(), runs })
}

pub fn run(a: &CurvesArgs, out: &mut dyn Write) -> Result<()> {
    for (flag, v) in [("--test-win-rate", a.test_win_rate), ("--train-win-rate", a.train_win_rate)] {
        if !(0.0..=1.0).contains(&v) {
            bail!("{flag} {v}: a win rate lies in [0, 1]");
        }
    }
    let groups: Vec<Group> = a.groups.iter().map(|g| parse_group(g)).collect::<Result<_>>()?;
    avacraft_marl::runlog::compare(&a.out, &a.title, &groups).with_context(|| format!("drawing {}", a.out.display()))?;
    let mut reached = Vec::new();
    for g in &groups {
        for (path, rows) in &g.runs {
            let first = first_reaching(rows, a.test_win_rate, a.train_win_rate);
            reached.push(Reached {
                group: g.name.clone(),
                run: path.display().to_string(),
                steps: first.map(|r| r.t_env),
                seconds: first.map(|r| r.elapsed_s),
                final_test_win_rate: rows.last().map(|r| r.test_win_rate),
            });
        }
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&reached)?)?;
        return Ok(());
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "group".to_owned(),
        "run".to_owned(),
        format!("steps to test >= {} and training >= {}", a.test_win_rate, a.train_win_rate),
        "seconds".to_owned(),
        "last test win rate".to_owned(),
    ]);
    for r in &reached {
        t.add_row([
            r.group.clone(),
            r.run.clone(),
            r.steps.map_or_else(|| "not reached".to_owned(), |s| s.to_string()),
            r.seconds.map_or_else(|| "-".to_owned(), |s| format!("{s:.0}")),
            r.final_test_win_rate.map_or_else(|| "-".to_owned(), |w| format!("{w:.2}")),
        ]);
    }
    writeln!(out, "{t}")?;
    writeln!(out, "figure: {}", a.out.display())?;
    Ok(())
}
