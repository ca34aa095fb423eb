//! Human evaluation, as the paper does it: raters watch blinded replays of episodes played by
//! agents of two or more kinds (scripted, MARL, VLM) and rate each on three 1-to-5 scales
//! (game-bug exploitation, reasoning coherence, human similarity).
//!
//! - [`pack`] picks finished episodes of an evaluation folder, re-plays them and draws each
//!   step's annotated view into a study folder under anonymous ids, in random order; which
//!   agent played which replay is written to a separate key file that is never served.
//! - [`Server`] serves the rating page (embedded, no internet needed), the frames and a JSON
//!   API; ratings go into SQLite (`ratings.db`), one per rater and replay.
//! - [`analyze`] un-blinds the ratings with the key and compares the kinds per metric
//!   (Mann-Whitney U with a two-sided p-value, rank-biserial correlation), as Markdown and a
//!   plot.
//!
//! A study folder:
//!
//! ```text
//! STUDY/study.json               the replays' ids in the blinded order (what the server reads)
//! STUDY/key.json                 anon id -> agent, kind, scenario, seed (never served)
//! STUDY/replays/<id>/manifest.json, 000000.png, 000001.png, ...   (served)
//! STUDY/ratings.db               the ratings (SQLite, WAL)
//! STUDY/analysis.md, analysis.png
//! ```

mod analyze;
mod db;
mod pack;
mod serve;

pub use analyze::{Analysis, Comparison, KindSummary, MannWhitney, analyze, mann_whitney};
pub use db::{Db, Rating};
pub use pack::{PackOptions, PackSummary, pack};
pub use serve::Server;

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The study's public description (the server reads it; it names no agent).
pub const STUDY_FILE: &str = "study.json";
/// The un-blinding key: kept apart from the replays and never served.
pub const KEY_FILE: &str = "key.json";
/// The folder of the replays' frames and manifests, the only files the server sends.
pub const REPLAYS_DIR: &str = "replays";
/// The ratings database.
pub const DB_FILE: &str = "ratings.db";
/// A replay folder's description of its frames.
pub const MANIFEST_FILE: &str = "manifest.json";
/// The longest comment kept, in characters (a bound so one request cannot fill the disk).
pub const MAX_COMMENT_CHARS: usize = 2000;

/// One of the paper's three rating scales.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Metric {
    /// The database column and the API's field.
    pub key: &'static str,
    pub name: &'static str,
    /// What the rater is asked.
    pub question: &'static str,
    /// What 1 and 5 mean.
    pub low: &'static str,
    pub high: &'static str,
}

/// The paper's metrics, in its order.
pub const METRICS: [Metric; 3] = [
    Metric {
        key: "exploitation",
        name: "Game-bug exploitation",
        question: "How much does the team's play rely on quirks or bugs of the game rather than sound tactics?",
        low: "not at all",
        high: "throughout",
    },
    Metric {
        key: "coherence",
        name: "Reasoning coherence",
        question: "How coherent and purposeful are the team's decisions over the episode?",
        low: "incoherent",
        high: "fully coherent",
    },
    Metric {
        key: "similarity",
        name: "Human similarity",
        question: "How much does the team play like a human player would?",
        low: "not at all",
        high: "like a human",
    },
];

/// A replay's frames, as written by [`pack`] (`replays/<id>/manifest.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub id: String,
    /// Frames `000000.png` ..: one before each step and one after the last.
    pub frames: u32,
    pub width: u32,
    pub height: u32,
    /// Game time between two frames at normal speed, in seconds.
    pub step_seconds: f64,
}

/// `study.json`: the replays in the blinded order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Study {
    pub version: u32,
    pub replays: Vec<String>,
}

/// What one anonymous replay is (`key.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KeyEntry {
    pub agent: String,
    pub kind: crate::AgentKind,
    pub scenario: String,
    pub against: String,
    pub seed: u64,
    pub result: String,
    pub trajectory_hash: String,
}

/// `key.json`: anonymous id -> episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Key {
    pub version: u32,
    /// The evaluation folder the episodes come from.
    pub eval: PathBuf,
    pub replays: BTreeMap<String, KeyEntry>,
}

/// Why a human-evaluation step failed.
#[derive(Debug, thiserror::Error)]
pub enum HumanError {
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: unreadable", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error(transparent)]
    Plan(#[from] Box<crate::PlanError>),
    #[error(transparent)]
    Results(#[from] crate::ResultsError),
    #[error(transparent)]
    Eval(#[from] Box<crate::EvalError>),
    #[error("{}: holds results of another plan than {plan}", eval.display())]
    OtherPlan { eval: PathBuf, plan: String },
    #[error("a study compares two or more agent kinds; the finished episodes are all of {found}")]
    OneKind { found: String },
    #[error("{kind}: {have} finished episodes, {want} asked for (--per-kind)")]
    TooFew { kind: String, have: usize, want: usize },
    #[error("{episode}: cannot be re-played")]
    Replay {
        episode: String,
        #[source]
        source: Box<crate::EpisodeError>,
    },
    #[error("{episode}: the re-play diverged (trajectory {replayed}, the result says {recorded}); refusing to show it")]
    Diverged { episode: String, recorded: String, replayed: String },
    #[error("{}: cannot write a frame", path.display())]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{}: exists and is not empty (a study is never overwritten); pick another folder", path.display())]
    StudyExists { path: PathBuf },
    #[error("{}: not a study folder ({why})", path.display())]
    NotAStudy { path: PathBuf, why: String },
    #[error("{}: database", path.display())]
    Db {
        path: PathBuf,
        #[source]
        source: rusqlite::Error,
    },
    #[error("{}: made by a newer version (schema {found}, this one knows {known})", path.display())]
    Schema { path: PathBuf, found: i64, known: i64 },
    #[error("rater name {0:?}: use 1 to 32 letters, digits, `_` or `-`")]
    BadRater(String),
    #[error("replay {0:?} is not one of this study's")]
    UnknownReplay(String),
    #[error("{metric}: {value} is not a rating (1 to 5)")]
    BadScore { metric: &'static str, value: i64 },
    #[error("the comment has {chars} characters; at most {MAX_COMMENT_CHARS} are kept")]
    CommentTooLong { chars: usize },
    #[error("{rater} has rated replay {replay} already (each rater rates each replay once)")]
    AlreadyRated { rater: String, replay: String },
    #[error("{}: no ratings yet", path.display())]
    NoRatings { path: PathBuf },
    #[error("rated replay {0} is not in the key")]
    NotInKey(String),
    #[error("cannot serve on {addr}")]
    Serve {
        addr: String,
        #[source]
        source: std::io::Error,
    },
    #[error("plot: {message}")]
    Plot { message: String },
}

/// Checks a rater's name: 1 to 32 of `[A-Za-z0-9_-]` (so it is safe in URLs, logs and files).
pub fn check_rater(name: &str) -> Result<(), HumanError> {
    if (1..=32).contains(&name.len()) && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-') {
        Ok(())
    } else {
        Err(HumanError::BadRater(name.chars().take(40).collect()))
    }
}

/// Whether `id` has the shape of an anonymous id (`pack` makes `r` and 8 hex digits): checked
/// before an id is looked up or joined to a path.
pub fn valid_id_shape(id: &str) -> bool {
    (1..=16).contains(&id.len()) && id.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit())
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> HumanError + '_ {
    move |source| HumanError::Io { path: path.to_path_buf(), source }
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, HumanError> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    serde_json::from_str(&text).map_err(|source| HumanError::Json { path: path.to_path_buf(), source })
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), HumanError> {
    let text = serde_json::to_string_pretty(value).map_err(|source| HumanError::Json { path: path.to_path_buf(), source })?;
    std::fs::write(path, text).map_err(io(path))
}

/// Reads a study folder's `study.json` and checks every replay has its manifest.
pub fn read_study(dir: &Path) -> Result<(Study, Vec<Manifest>), HumanError> {
    let path = dir.join(STUDY_FILE);
    if !path.is_file() {
        return Err(HumanError::NotAStudy { path: dir.to_path_buf(), why: format!("no {STUDY_FILE}; make one with `human-eval pack`") });
    }
    let study: Study = read_json(&path)?;
    let mut manifests = Vec::new();
    for id in &study.replays {
        if !valid_id_shape(id) {
            return Err(HumanError::NotAStudy { path: path.clone(), why: format!("bad replay id {id:?}") });
        }
        let m: Manifest = read_json(&dir.join(REPLAYS_DIR).join(id).join(MANIFEST_FILE))?;
        manifests.push(m);
    }
    Ok((study, manifests))
}

/// Reads a study folder's key.
pub fn read_key(dir: &Path) -> Result<Key, HumanError> {
    read_json(&dir.join(KEY_FILE))
}
