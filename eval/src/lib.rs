//! The evaluation harness: an evaluation plan (TOML) names scenarios, agents, opponents,
//! seeds and head-to-head pairings; [`run`] plays its episodes in parallel, appending each
//! result as it ends (so runs resume and shards merge); [`Report`] turns a folder of results
//! into the paper's tables, CSV, JSON and plots; [`human`] runs the paper's human evaluation of
//! replays (blinded packing, a local rating server, the statistics).
#![forbid(unsafe_code)]

pub mod human;
mod links;
mod marl_eval;
mod meta;
mod plan;
mod plan_file;
mod plot;
mod report;
mod results;
mod run;
mod stats;
mod summary;
mod train_plan;

pub use marl_eval::{MARL_EVAL_METRICS, marl_eval_json};
pub use meta::{META_FILE, Meta, cannot_extend, check_shards, fingerprints, read_meta, write_meta};
pub use plan::{AgentDef, AgentKind, Cell, CellKey, CurveDef, Job, Plan, PlanError, Shard};
pub use plan_file::{load, parse};
pub use plot::read_log;
pub use report::Report;
#[cfg(test)]
mod report_tests;
#[cfg(test)]
mod resume_tests;
#[cfg(test)]
mod shard_tests;
pub use results::{Appender, EpisodeResult, Loaded, ModelUse, RESULTS_FILE, ResultsError, merge, read};
pub use run::{EpisodeError, Progress, RunOptions, RunStats, play_job, replay_job, run};
pub use stats::{CellStats, CostStats, MeanStd, wilson95};
pub use train_plan::{Source, TrainJob, TrainPlan, TrainPlanError, load_train_plan, parse_train_plan};

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
    #[error("{}: this evaluation folder cannot be resumed with this plan: {why}; pick another --out (nothing is overwritten)", path.display())]
    Folder { path: PathBuf, why: String },
    #[error("agent `{agent}` on {scenario}: its policy cannot be fingerprinted")]
    Policy {
        agent: String,
        scenario: String,
        #[source]
        source: Box<avacraft_policy::PolicyError>,
    },
}
