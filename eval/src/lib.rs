//! The evaluation harness: an evaluation plan (TOML) names scenarios, agents, opponents,
//! seeds and head-to-head pairings; [`run`] plays its episodes in parallel, appending each
//! result as it ends (so runs resume and shards merge); [`Report`] turns a folder of results
//! into the paper's tables, CSV, JSON and plots; [`human`] runs the paper's human evaluation of
//! replays (blinded packing, a local rating server, the statistics).
#![forbid(unsafe_code)]

pub mod human;
mod plan;
mod plot;
mod report;
mod results;
mod run;
mod stats;
mod train_plan;

pub use plan::{AgentDef, AgentKind, Cell, CellKey, CurveDef, Job, Plan, PlanError, Shard, load, parse};
pub use plot::read_log;
pub use report::{META_FILE, Meta, Report};
#[cfg(test)]
mod shard_tests;
pub use results::{Appender, EpisodeResult, Loaded, ModelUse, RESULTS_FILE, ResultsError, merge, read};
pub use run::{Progress, RunOptions, RunStats, play_job, replay_job, run};
pub use stats::{CellStats, CostStats, MeanStd, wilson95};
pub use train_plan::{TrainJob, TrainPlan, TrainPlanError, load_train_plan, parse_train_plan};

use std::path::PathBuf;

/// Why an evaluation step failed.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Plan(#[from] Box<PlanError>),
    #[error(transparent)]
    Results(#[from] ResultsError),
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {why}", path.display())]
    Log { path: PathBuf, line: usize, why: String },
    #[error("{}: not an evaluation's plan.json", path.display())]
    Meta {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("plot: {message}")]
    Plot { message: String },
    #[error("eval merge: {} holds {what}", dir.display())]
    Shards { dir: PathBuf, what: String },
}

/// Checks the shards' folders of a merge (each with its `plan.json`): one plan, each shard
/// once, all of the same split. Returns the plan's metadata for the merged folder and the
/// shards that are missing (a merge of part of a plan is allowed, and said).
pub fn check_shards(shards: &[(PathBuf, Meta)]) -> Result<(Meta, Vec<Shard>), EvalError> {
    let Some((first_dir, first)) = shards.first() else {
        return Err(EvalError::Shards { dir: PathBuf::from("."), what: "no shard: name the shards' folders".into() });
    };
    let mut seen: Vec<(Shard, &PathBuf)> = Vec::new();
    let mut whole = false;
    for (dir, m) in shards {
        if m.cells != first.cells || m.seeds != first.seeds || m.name != first.name {
            return Err(EvalError::Shards {
                dir: dir.clone(),
                what: format!("the results of another plan (`{}`) than {} (`{}`)", m.name, first_dir.display(), first.name),
            });
        }
        match m.shard {
            None => {
                whole = true;
            }
            Some(s) => {
                if let Some((_, other)) = seen.iter().find(|(t, _)| *t == s) {
                    let how = if *other == dir { "is named twice".to_owned() } else { format!("as {} does", other.display()) };
                    return Err(EvalError::Shards { dir: dir.clone(), what: format!("shard {s}, {how}: each shard is merged once") });
                }
                if let Some((t, other)) = seen.iter().find(|(t, _)| t.count != s.count) {
                    return Err(EvalError::Shards {
                        dir: dir.clone(),
                        what: format!("shard {s}, but {} holds shard {t}: shards of one split have the same n", other.display()),
                    });
                }
                seen.push((s, dir));
            }
        }
    }
    if whole && shards.len() > 1 {
        let (dir, _) = shards.iter().find(|(_, m)| m.shard.is_none()).unwrap_or(&shards[0]);
        return Err(EvalError::Shards { dir: dir.clone(), what: "the whole plan's results: there is nothing to merge it with".into() });
    }
    let missing = match seen.first() {
        Some((s, _)) => (1..=s.count).map(|index| Shard { index, count: s.count }).filter(|s| !seen.iter().any(|(t, _)| t == s)).collect(),
        None => Vec::new(),
    };
    let mut meta = first.clone();
    meta.shard = None;
    Ok((meta, missing))
}

/// Reads an evaluation folder's `plan.json`.
pub fn read_meta(dir: &std::path::Path) -> Result<Meta, EvalError> {
    let path = dir.join(META_FILE);
    let text = std::fs::read_to_string(&path).map_err(|source| EvalError::Io { path: path.clone(), source })?;
    serde_json::from_str(&text).map_err(|source| EvalError::Meta { path, source })
}

/// Writes an evaluation folder's `plan.json` (the same plan may be written again; another
/// plan's results folder is refused, so results of two plans never mix).
pub fn write_meta(dir: &std::path::Path, meta: &Meta) -> Result<(), EvalError> {
    std::fs::create_dir_all(dir).map_err(|source| EvalError::Io { path: dir.to_path_buf(), source })?;
    let path = dir.join(META_FILE);
    if path.exists() {
        let old = read_meta(dir)?;
        if old.cells != meta.cells || old.seeds != meta.seeds {
            return Err(EvalError::Io {
                path,
                source: std::io::Error::other("this folder holds another plan's results; pick another --out (nothing is overwritten)"),
            });
        }
        if old.shard != meta.shard {
            let name = |s: Option<Shard>| s.map_or_else(|| "the whole plan".to_owned(), |s| format!("shard {s}"));
            return Err(EvalError::Io {
                path,
                source: std::io::Error::other(format!(
                    "this folder holds {}'s results, not {}'s; pick another --out (nothing is overwritten)",
                    name(old.shard),
                    name(meta.shard)
                )),
            });
        }
    }
    let text = serde_json::to_string_pretty(meta).map_err(|e| EvalError::Io { path: path.clone(), source: std::io::Error::other(e) })?;
    std::fs::write(&path, text).map_err(|source| EvalError::Io { path, source })
}
