//! Clause embeddings kept on disk between runs, so that a second run (or the benchmark)
//! does not pay MiniLM's warm-up again.
//!
//! The file is trusted only when everything about it checks out: it must start with the
//! format's magic and version, name the model it was computed with (a hash of the model's
//! files, the token limit and the pooling, [`crate::encoders::text::MiniLm::hash`]), hold
//! records of the right width whose texts are UTF-8, and end with a checksum of everything
//! before it. Anything else (a file cut short by a crash, another model's file, a stray
//! file) is refused with a warning and the run embeds from scratch: a wrong embedding would
//! silently change the observation. Because a clause's embedding does not depend on the
//! cache or on the batch it was computed in, a run reads the same features with the file as
//! without it.
//!
//! Layout (little-endian): magic, `u32` version, `u64` model hash, `u32` width, `u64`
//! record count, then per record `u32` text length, the text, `u32` tokens, `width` x `f32`;
//! last the `u64` FNV-1a of all preceding bytes. Files are written to a temporary name and
//! renamed, so a reader never sees a half-written file.

use avacraft_engine::Fnv;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 28] = b"AVACRAFT clause embeddings\n\0";
const VERSION: u32 = 1;
/// Longest clause text accepted from a file (clauses are a few dozen bytes).
const MAX_TEXT: usize = 1 << 16;

/// Why a file of clause embeddings was not used or not written.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: not a valid clause-embedding file ({why})", path.display())]
    Corrupt { path: PathBuf, why: String },
    #[error("{}: computed with another model (hash {found:016x}, this model's is {want:016x})", path.display())]
    OtherModel { path: PathBuf, found: u64, want: u64 },
}

/// One stored clause: its text, token count (its weight in a line) and embedding.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    pub text: String,
    pub tokens: u32,
    pub embedding: Vec<f32>,
}

fn checksum(bytes: &[u8]) -> u64 {
    let mut h = Fnv::default();
    h.bytes(bytes);
    h.finish()
}

/// The file for `model_hash` in `dir`.
pub fn file_in(dir: &Path, model_hash: u64) -> PathBuf {
    dir.join(format!("minilm-clauses-{model_hash:016x}.bin"))
}

/// The records of `path`, written for `model_hash` with embeddings `width` wide; a missing
/// file is empty.
pub fn load(path: &Path, model_hash: u64, width: usize) -> Result<Vec<Record>, StoreError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => return Err(StoreError::Io { path: path.to_path_buf(), source }),
    };
    let corrupt = |why: &str| StoreError::Corrupt { path: path.to_path_buf(), why: why.to_owned() };
    let head = MAGIC.len() + 4 + 8 + 4 + 8;
    if bytes.len() < head + 8 || !bytes.starts_with(MAGIC) {
        return Err(corrupt("no header"));
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    if checksum(body) != u64::from_le_bytes(sum.try_into().map_err(|_| corrupt("no checksum"))?) {
        return Err(corrupt("checksum mismatch: cut short or altered"));
    }
    let mut r = Reader { bytes: body, at: MAGIC.len() };
    let version = r.u32().ok_or_else(|| corrupt("no version"))?;
    if version != VERSION {
        return Err(corrupt(&format!("format version {version}, expected {VERSION}")));
    }
    let found = r.u64().ok_or_else(|| corrupt("no model hash"))?;
    if found != model_hash {
        return Err(StoreError::OtherModel { path: path.to_path_buf(), found, want: model_hash });
    }
    if r.u32().map(|w| w as usize) != Some(width) {
        return Err(corrupt(&format!("embeddings are not {width} wide")));
    }
    let count = r.u64().ok_or_else(|| corrupt("no record count"))?;
    let mut out = Vec::new();
    for i in 0..count {
        let bad = || corrupt(&format!("record {i} of {count} is truncated or malformed"));
        let len = r.u32().ok_or_else(bad)? as usize;
        if len > MAX_TEXT {
            return Err(bad());
        }
        let text = std::str::from_utf8(r.take(len).ok_or_else(bad)?).map_err(|_| bad())?.to_owned();
        let tokens = r.u32().ok_or_else(bad)?;
        let raw = r.take(width * 4).ok_or_else(bad)?;
        let embedding: Vec<f32> = raw.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        if tokens == 0 || embedding.iter().any(|x| !x.is_finite()) {
            return Err(bad());
        }
        out.push(Record { text, tokens, embedding });
    }
    if r.at != body.len() {
        return Err(corrupt("bytes after the last record"));
    }
    Ok(out)
}

/// Writes `records` (each `width` wide) for `model_hash` to `path`, replacing it whole.
pub fn save<'a>(
    path: &Path,
    model_hash: u64,
    width: usize,
    records: impl Iterator<Item = (&'a str, u32, &'a [f32])>,
) -> Result<(), StoreError> {
    let mut body = MAGIC.to_vec();
    body.extend_from_slice(&VERSION.to_le_bytes());
    body.extend_from_slice(&model_hash.to_le_bytes());
    body.extend_from_slice(&(width as u32).to_le_bytes());
    let count_at = body.len();
    body.extend_from_slice(&0u64.to_le_bytes());
    let mut count = 0u64;
    for (text, tokens, embedding) in records {
        if embedding.len() != width || text.len() > MAX_TEXT {
            continue;
        }
        body.extend_from_slice(&(text.len() as u32).to_le_bytes());
        body.extend_from_slice(text.as_bytes());
        body.extend_from_slice(&tokens.to_le_bytes());
        for x in embedding {
            body.extend_from_slice(&x.to_le_bytes());
        }
        count += 1;
    }
    body[count_at..count_at + 8].copy_from_slice(&count.to_le_bytes());
    let sum = checksum(&body);
    body.extend_from_slice(&sum.to_le_bytes());
    let io = |source| StoreError::Io { path: path.to_path_buf(), source };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    // A name of this process's own: concurrent runs each rename a whole file.
    let tmp = path.with_extension(format!("tmp.{}", std::process::id()));
    std::fs::write(&tmp, &body).map_err(|source| StoreError::Io { path: tmp.clone(), source })?;
    std::fs::rename(&tmp, path).map_err(io)
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("avacraft-clause-store-{}-{name}.bin", std::process::id()))
    }

    #[test]
    fn a_file_round_trips_and_a_damaged_or_foreign_one_is_refused() -> Result<(), StoreError> {
        let path = tmp("roundtrip");
        let recs = [("HP 45/45", 5u32, vec![0.5f32, -0.25, 1.0]), ("at grid (3, 4)", 7, vec![0.0, 1.0, 0.0])];
        save(&path, 42, 3, recs.iter().map(|(t, n, e)| (*t, *n, e.as_slice())))?;
        let back = load(&path, 42, 3)?;
        assert_eq!(back.len(), 2);
        assert_eq!((back[1].text.as_str(), back[1].tokens, back[1].embedding.as_slice()), ("at grid (3, 4)", 7, &[0.0, 1.0, 0.0][..]));
        assert!(matches!(load(&path, 43, 3), Err(StoreError::OtherModel { found: 42, want: 43, .. })));
        assert!(matches!(load(&path, 42, 4), Err(StoreError::Corrupt { .. })));
        let good = std::fs::read(&path).map_err(|source| StoreError::Io { path: path.clone(), source })?;
        // One flipped bit anywhere, or a file cut short, is caught.
        for at in [0, MAGIC.len() + 5, good.len() / 2, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            std::fs::write(&path, &bad).map_err(|source| StoreError::Io { path: path.clone(), source })?;
            assert!(load(&path, 42, 3).is_err(), "flipped byte {at}");
        }
        std::fs::write(&path, &good[..good.len() - 3]).map_err(|source| StoreError::Io { path: path.clone(), source })?;
        assert!(matches!(load(&path, 42, 3), Err(StoreError::Corrupt { .. })));
        let _ = std::fs::remove_file(&path);
        assert!(load(&path, 42, 3)?.is_empty(), "a missing file is empty");
        Ok(())
    }
}
