//! The results file: one JSON line per finished episode, appended and flushed as it ends, so
//! an interrupted evaluation resumes where it stopped and shards from several machines merge
//! by concatenation. A line that cannot be read (a torn last line after a crash) is reported
//! and skipped, never silently dropped from a merge.

use crate::plan::CellKey;
use avacraft_engine::Outcome;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// The results file's name in an evaluation's folder.
pub const RESULTS_FILE: &str = "results.jsonl";

/// What AVA spent in an episode (team 1's side).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelUse {
    pub decisions: u64,
    pub calls: u64,
    pub prompt_tokens: u64,
    pub completion_tokens: u64,
    pub cost_usd: f64,
    /// Calls of a model missing from the price table (their dollars are unknown).
    pub unpriced_calls: u64,
    pub model_ms: f64,
    pub failed_calls: u64,
    pub fallbacks: u64,
}

/// One finished (or failed) episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeResult {
    pub cell: CellKey,
    pub seed: u64,
    /// `win`, `draw` or `loss` for team 1; `None` when the episode failed.
    pub result: Option<Outcome>,
    /// Why the episode could not be played (an endpoint down, a replay that diverged).
    #[serde(default)]
    pub error: Option<String>,
    pub steps: u32,
    pub game_seconds: f64,
    /// Per team (team 1 first).
    pub damage_dealt: [f64; 2],
    pub kills: [u32; 2],
    pub units_left: [u32; 2],
    pub refused_actions: [u32; 2],
    pub trajectory_hash: String,
    #[serde(default)]
    pub model: Option<ModelUse>,
    /// PvP: what team 2's AVA spent.
    #[serde(default)]
    pub model2: Option<ModelUse>,
}

impl EpisodeResult {
    /// An episode of `cell` on `seed` with nothing recorded yet: no result, no error.
    pub fn blank(cell: CellKey, seed: u64) -> EpisodeResult {
        EpisodeResult {
            cell,
            seed,
            result: None,
            error: None,
            steps: 0,
            game_seconds: 0.0,
            damage_dealt: [0.0; 2],
            kills: [0; 2],
            units_left: [0; 2],
            refused_actions: [0; 2],
            trajectory_hash: String::new(),
            model: None,
            model2: None,
        }
    }

    pub fn ok(&self) -> bool {
        self.error.is_none() && self.result.is_some()
    }
}

/// Why results could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    #[error("{}: {what}", path.display())]
    Io {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: episode {} seed {} has two different results (trajectory {} and {}); the shards played different games", .0.path.display(), .0.cell, .0.seed, .0.a, .0.b)]
    Conflict(Box<Conflict>),
}

/// Two results of one episode that disagree.
#[derive(Debug)]
pub struct Conflict {
    pub path: PathBuf,
    pub cell: CellKey,
    pub seed: u64,
    pub a: String,
    pub b: String,
}

/// A results file read back: the finished episodes by (cell, seed), and what was skipped.
#[derive(Debug, Default)]
pub struct Loaded {
    pub done: BTreeMap<(CellKey, u64), EpisodeResult>,
    /// Failed episodes (they are played again on resume).
    pub failed: Vec<EpisodeResult>,
    /// `line: why` of lines that could not be read.
    pub unreadable: Vec<String>,
}

/// Reads a results file (a missing file is an empty one).
pub fn read(path: &Path) -> Result<Loaded, ResultsError> {
    let mut out = Loaded::default();
    let f = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(out),
        Err(source) => return Err(ResultsError::Io { path: path.to_path_buf(), what: "cannot open", source }),
    };
    for (i, line) in std::io::BufReader::new(f).lines().enumerate() {
        let line = line.map_err(|source| ResultsError::Io { path: path.to_path_buf(), what: "cannot read", source })?;
        if line.trim().is_empty() {
            continue;
        }
        match serde_json::from_str::<EpisodeResult>(&line) {
            Ok(r) if r.ok() => add(&mut out, r, path)?,
            Ok(r) => out.failed.push(r),
            Err(e) => out.unreadable.push(format!("{}:{}: {e}", path.display(), i + 1)),
        }
    }
    Ok(out)
}

fn add(out: &mut Loaded, r: EpisodeResult, path: &Path) -> Result<(), ResultsError> {
    let key = (r.cell.clone(), r.seed);
    match out.done.get(&key) {
        Some(prev) if prev.trajectory_hash != r.trajectory_hash => Err(ResultsError::Conflict(Box::new(Conflict {
            path: path.to_path_buf(),
            cell: r.cell,
            seed: r.seed,
            a: prev.trajectory_hash.clone(),
            b: r.trajectory_hash,
        }))),
        Some(_) => Ok(()),
        None => {
            out.done.insert(key, r);
            Ok(())
        }
    }
}

/// Merges results files (shards) into `into`: every finished episode once, in (cell, seed)
/// order; two different games for one episode are refused. Returns the merged results.
pub fn merge(parts: &[PathBuf], into: &Path) -> Result<Loaded, ResultsError> {
    let mut all = Loaded::default();
    for p in parts {
        if !p.is_file() {
            return Err(ResultsError::Io {
                path: p.clone(),
                what: "is not a results file",
                source: std::io::Error::from(std::io::ErrorKind::NotFound),
            });
        }
        let l = read(p)?;
        for (_, r) in l.done {
            add(&mut all, r, p)?;
        }
        all.failed.extend(l.failed);
        all.unreadable.extend(l.unreadable);
    }
    if into.exists() {
        return Err(ResultsError::Io {
            path: into.to_path_buf(),
            what: "exists already (nothing is overwritten); merge into a new file",
            source: std::io::Error::from(std::io::ErrorKind::AlreadyExists),
        });
    }
    let mut w = Appender::open(into)?;
    for r in all.done.values() {
        w.append(r)?;
    }
    Ok(all)
}

/// Appends results, one flushed line each.
#[derive(Debug)]
pub struct Appender {
    path: PathBuf,
    file: std::fs::File,
}

impl Appender {
    pub fn open(path: &Path) -> Result<Appender, ResultsError> {
        if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(d).map_err(|source| ResultsError::Io { path: d.to_path_buf(), what: "cannot create", source })?;
        }
        let file = std::fs::OpenOptions::new().create(true).append(true).open(path).map_err(|source| ResultsError::Io {
            path: path.to_path_buf(),
            what: "cannot open for appending",
            source,
        })?;
        let mut a = Appender { path: path.to_path_buf(), file };
        // A line torn by a crash stays a line of its own: what is appended after it must not
        // be glued to it (and be lost with it).
        let torn = std::fs::read(path).map(|b| b.last().is_some_and(|&c| c != b'\n')).unwrap_or(false);
        if torn {
            a.file.write_all(b"\n").map_err(|source| ResultsError::Io { path: path.to_path_buf(), what: "cannot append", source })?;
        }
        Ok(a)
    }

    pub fn append(&mut self, r: &EpisodeResult) -> Result<(), ResultsError> {
        let mut line = serde_json::to_string(r).map_err(|e| ResultsError::Io {
            path: self.path.clone(),
            what: "cannot encode a result",
            source: std::io::Error::other(e),
        })?;
        line.push('\n');
        let io = |source| ResultsError::Io { path: self.path.clone(), what: "cannot append", source };
        self.file.write_all(line.as_bytes()).map_err(io)?;
        self.file.flush().map_err(|source| ResultsError::Io { path: self.path.clone(), what: "cannot flush", source })
    }
}
