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

pub use plan::{AgentDef, AgentKind, Cell, CellKey, CurveDef, Job, Plan, PlanError, Shard, load, parse};
pub use plot::read_log;
pub use report::{META_FILE, Meta, Report};
pub use results::{Appender, EpisodeResult, Loaded, ModelUse, RESULTS_FILE, ResultsError, merge, read};
pub use run::{Progress, RunOptions, RunStats, play_job, replay_job, run};
pub use stats::{CellStats, CostStats, MeanStd, wilson95};

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
    }
    let text = serde_json::to_string_pretty(meta).map_err(|e| EvalError::Io { path: path.clone(), source: std::io::Error::other(e) })?;
    std::fs::write(&path, text).map_err(|source| EvalError::Io { path, source })
}
