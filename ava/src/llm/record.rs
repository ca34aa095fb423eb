//! Every model call of a run, kept: `calls.jsonl` in the run folder (one line per call,
//! written and flushed before its answer is used, so a crash loses nothing already asked),
//! each image once as `images/<hash>.png` and each answer schema once as
//! `schemas/<hash>.json` (in the order the model was asked to write it). [`Replay`] answers
//! from that file, in order, and checks that each request is the one recorded: an AVA
//! episode then re-simulates exactly without calling any model.

use super::{ChatModel, ChatReply, ChatRequest, LlmError, Part, Role, Sampling, Stage};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

pub const CALLS_FILE: &str = "calls.jsonl";

/// A part of a recorded message: text verbatim, images by file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum StoredPart {
    Text { text: String },
    Image { file: String, width: u32, height: u32 },
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredMessage {
    pub role: Role,
    pub parts: Vec<StoredPart>,
}

/// One line of `calls.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CallRecord {
    /// Position in the run, from 0.
    pub seq: u64,
    pub episode: u64,
    pub seed: u64,
    pub team: u8,
    /// The environment step the decision was taken at.
    pub step: u32,
    /// The decision's number in its episode, from 0.
    pub decision: u32,
    pub stage: Stage,
    /// 0 for the first try of a stage; each repair round counts up.
    pub attempt: u32,
    /// 0 for the first call of an attempt; each retry after a transport error counts up.
    pub retry: u32,
    pub model: String,
    /// The prompt templates' version.
    pub prompts: String,
    pub request_hash: String,
    pub messages: Vec<StoredMessage>,
    /// The answer schema's name.
    pub schema: Option<String>,
    /// The schema itself, in the recording (`schemas/<hash>.json`): it changes from call to
    /// call (the tags and abilities there are), so what the model could answer is known.
    /// Absent in recordings made before it was kept, and for calls not recorded to disk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema_file: Option<String>,
    pub sampling: Sampling,
    pub reply: Option<ChatReply>,
    pub error: Option<LlmError>,
    /// Dollars, from the price table (`None`: the model is not in it or no usage was given).
    pub cost_usd: Option<f64>,
}

/// Why a recording could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{}: {what}", path.display())]
    Io {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("{} already holds a recording; pick another folder (nothing recorded is overwritten)", path.display())]
    Exists { path: PathBuf },
    #[error("{}:{line}: not a call record", path.display())]
    Line {
        path: PathBuf,
        line: usize,
        #[source]
        source: serde_json::Error,
    },
}

/// Writes calls as they happen.
#[derive(Debug)]
pub struct Recorder {
    dir: PathBuf,
    file: std::fs::File,
    images: BTreeSet<String>,
    schemas: BTreeSet<String>,
    seq: u64,
}

fn io<'a>(path: &'a Path, what: &'static str) -> impl FnOnce(std::io::Error) -> RecordError + 'a {
    move |source| RecordError::Io { path: path.to_path_buf(), what, source }
}

impl Recorder {
    /// Starts a recording in `dir` (created if missing); refused if it already holds one.
    pub fn create(dir: &Path) -> Result<Recorder, RecordError> {
        std::fs::create_dir_all(dir.join("images")).map_err(io(dir, "cannot create the folder"))?;
        std::fs::create_dir_all(dir.join("schemas")).map_err(io(dir, "cannot create the folder"))?;
        let path = dir.join(CALLS_FILE);
        let file = std::fs::OpenOptions::new().write(true).create_new(true).open(&path).map_err(|e| {
            if e.kind() == std::io::ErrorKind::AlreadyExists {
                RecordError::Exists { path: path.clone() }
            } else {
                io(&path, "cannot create")(e)
            }
        })?;
        Ok(Recorder { dir: dir.to_path_buf(), file, images: BTreeSet::new(), schemas: BTreeSet::new(), seq: 0 })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The stored form of a request's messages, writing images not yet written.
    pub fn store(&mut self, req: &ChatRequest) -> Result<Vec<StoredMessage>, RecordError> {
        let mut out = Vec::with_capacity(req.messages.len());
        for m in &req.messages {
            let mut parts = Vec::with_capacity(m.parts.len());
            for p in &m.parts {
                parts.push(match p {
                    Part::Text(t) => StoredPart::Text { text: t.clone() },
                    Part::Image(png) => {
                        let file = format!("images/{}.png", png.hash());
                        if self.images.insert(file.clone()) {
                            let path = self.dir.join(&file);
                            std::fs::write(&path, png.bytes.as_slice()).map_err(io(&path, "cannot write the image"))?;
                        }
                        StoredPart::Image { file, width: png.width, height: png.height }
                    }
                });
            }
            out.push(StoredMessage { role: m.role, parts });
        }
        Ok(out)
    }

    /// Where the request's schema is kept in the recording, writing it if not yet written.
    pub fn store_schema(&mut self, req: &ChatRequest) -> Result<Option<String>, RecordError> {
        let Some((_, schema)) = &req.schema else { return Ok(None) };
        let text = super::schema_text(schema);
        let file = format!("schemas/{:016x}.json", xxhash_rust::xxh3::xxh3_64(text.as_bytes()));
        if self.schemas.insert(file.clone()) {
            let path = self.dir.join(&file);
            std::fs::write(&path, text).map_err(io(&path, "cannot write the schema"))?;
        }
        Ok(Some(file))
    }

    /// Appends a record (its `seq` is set here) and flushes it to disk; returns it as written.
    pub fn write(&mut self, mut rec: CallRecord) -> Result<CallRecord, RecordError> {
        rec.seq = self.seq;
        self.seq += 1;
        let path = self.dir.join(CALLS_FILE);
        let mut line = serde_json::to_string(&rec).map_err(|e| io(&path, "cannot encode a record")(std::io::Error::other(e)))?;
        line.push('\n');
        self.file.write_all(line.as_bytes()).map_err(io(&path, "cannot append"))?;
        self.file.flush().map_err(io(&path, "cannot flush"))?;
        Ok(rec)
    }
}

/// A request's messages as a record holds them, without a recording to store images in
/// (images by size, no file).
pub fn unstored(req: &ChatRequest) -> Vec<StoredMessage> {
    req.messages
        .iter()
        .map(|m| StoredMessage {
            role: m.role,
            parts: m
                .parts
                .iter()
                .map(|p| match p {
                    Part::Text(t) => StoredPart::Text { text: t.clone() },
                    Part::Image(png) => StoredPart::Image { file: String::new(), width: png.width, height: png.height },
                })
                .collect(),
        })
        .collect()
}

/// Reads a recording's calls.
pub fn read_calls(dir: &Path) -> Result<Vec<CallRecord>, RecordError> {
    let path = dir.join(CALLS_FILE);
    let f = std::fs::File::open(&path).map_err(io(&path, "cannot open the recording"))?;
    let mut out = Vec::new();
    for (i, line) in std::io::BufReader::new(f).lines().enumerate() {
        let line = line.map_err(io(&path, "cannot read"))?;
        if line.trim().is_empty() {
            continue;
        }
        out.push(serde_json::from_str(&line).map_err(|source| RecordError::Line { path: path.clone(), line: i + 1, source })?);
    }
    Ok(out)
}

/// Answers from a recorded run, in order.
#[derive(Debug)]
pub struct Replay {
    name: String,
    calls: Vec<CallRecord>,
    next: usize,
}

impl Replay {
    pub fn open(dir: &Path) -> Result<Replay, RecordError> {
        Ok(Replay { name: format!("replay:{}", dir.display()), calls: read_calls(dir)?, next: 0 })
    }
    /// Calls not yet answered (0 once a replay went through the whole recording).
    pub fn remaining(&self) -> usize {
        self.calls.len() - self.next
    }
}

impl ChatModel for Replay {
    fn model(&self) -> &str {
        &self.name
    }
    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError> {
        let Some(rec) = self.calls.get(self.next) else {
            return Err(LlmError::Replay {
                why: format!("the recording ends after {} calls, and the run asks for more", self.calls.len()),
            });
        };
        let hash = req.hash();
        if rec.stage != req.stage || rec.request_hash != hash {
            return Err(LlmError::Replay {
                why: format!(
                    "call {} differs from the recording (recorded: {} at step {}, request {}; now: {}, request {hash})",
                    rec.seq,
                    rec.stage.name(),
                    rec.step,
                    rec.request_hash,
                    req.stage.name()
                ),
            });
        }
        self.next += 1;
        match (&rec.reply, &rec.error) {
            (Some(r), _) => Ok(r.clone()),
            (None, Some(e)) => Err(e.clone()),
            (None, None) => Err(LlmError::Replay { why: format!("call {} has neither an answer nor an error", rec.seq) }),
        }
    }
    fn waits(&self) -> bool {
        false
    }
}
