//! The vision-text features: slot embeddings built from cached clause embeddings.
//!
//! A slot's embedding (see [`super::clauses`] for the slots) is the token-weighted mean of
//! its clauses' MiniLM embeddings, L2-normalised, or zeros when the slot has no line (a dead
//! agent, an enemy out of sight). Weighting by tokens makes a line's embedding the mean over
//! its clauses' tokens, as mean pooling over the whole line would be, except that each
//! token attends only within its clause.
//!
//! Each distinct clause is embedded once ([`ClauseCache`]): after a warm-up of a few
//! thousand clauses a step is lookups and a few additions. The clauses a step misses are
//! embedded together ([`MiniLm::embed_many`]); a clause's embedding does not depend on the
//! batch, the thread count or the cache (it is a function of its text), so whether a clause
//! was cached changes nothing and eviction only costs time. The cache is bounded (config
//! `text_cache`) and evicts with the clock rule (second chance: a clause read since the last
//! sweep stays), deterministically; its map is only looked up, never iterated.

use super::clause_store::{self, Record};
use super::clauses::Clause;
use super::text::{Embedding, MiniLm, TEXT_DIM};
use crate::Error;
use std::collections::{HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock, Weak};

/// Counters of a [`ClauseCache`]'s use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextStats {
    /// Clauses read (one per clause of every description).
    pub lookups: u64,
    /// Of those, found in the cache.
    pub hits: u64,
    /// Clauses embedded by MiniLM (distinct misses).
    pub computed: u64,
    /// Clauses read from the on-disk cache at start.
    pub loaded: u64,
}

/// Embeddings of distinct clauses, at most `capacity` of them.
#[derive(Debug)]
pub struct ClauseCache {
    map: HashMap<Box<str>, u32>,
    keys: Vec<Box<str>>,
    tokens: Vec<u32>,
    vecs: Vec<f32>,
    referenced: Vec<bool>,
    /// Entries in clock order.
    clock: VecDeque<u32>,
    free: Vec<u32>,
    capacity: usize,
}

impl ClauseCache {
    pub fn new(capacity: usize) -> ClauseCache {
        ClauseCache {
            map: HashMap::new(),
            keys: Vec::new(),
            tokens: Vec::new(),
            vecs: Vec::new(),
            referenced: Vec::new(),
            clock: VecDeque::new(),
            free: Vec::new(),
            capacity: capacity.max(1),
        }
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// The entry of `text`, marked as read.
    fn get(&mut self, text: &str) -> Option<u32> {
        let i = *self.map.get(text)?;
        self.referenced[i as usize] = true;
        Some(i)
    }

    fn entry(&self, i: u32) -> (u32, &[f32]) {
        let i = i as usize;
        (self.tokens[i], &self.vecs[i * TEXT_DIM..(i + 1) * TEXT_DIM])
    }

    /// Adds `text` (unless present), evicting one entry when full.
    fn insert(&mut self, text: &str, tokens: u32, vec: &[f32]) {
        if vec.len() != TEXT_DIM || self.map.contains_key(text) {
            return;
        }
        if self.map.len() >= self.capacity {
            self.evict();
        }
        let i = match self.free.pop() {
            Some(i) => i,
            None => {
                self.keys.push(Box::from(""));
                self.tokens.push(0);
                self.vecs.resize(self.vecs.len() + TEXT_DIM, 0.0);
                self.referenced.push(false);
                (self.keys.len() - 1) as u32
            }
        };
        let u = i as usize;
        self.keys[u] = Box::from(text);
        self.tokens[u] = tokens;
        self.vecs[u * TEXT_DIM..(u + 1) * TEXT_DIM].copy_from_slice(vec);
        self.referenced[u] = false;
        self.map.insert(Box::from(text), i);
        self.clock.push_back(i);
    }

    fn evict(&mut self) {
        while let Some(i) = self.clock.pop_front() {
            let u = i as usize;
            if std::mem::take(&mut self.referenced[u]) {
                self.clock.push_back(i);
                continue;
            }
            self.map.remove(&self.keys[u]);
            self.keys[u] = Box::from("");
            self.free.push(i);
            return;
        }
    }

    /// Entries in clock order: `(text, tokens, embedding)`.
    fn entries(&self) -> impl Iterator<Item = (&str, u32, &[f32])> {
        self.clock.iter().map(|&i| {
            let (t, v) = self.entry(i);
            (&*self.keys[i as usize], t, v)
        })
    }
}

/// MiniLM, its clause cache and its optional file: what turns descriptions into features.
#[derive(Debug)]
pub struct TextEmbedder {
    model: Arc<MiniLm>,
    cache: ClauseCache,
    file: Option<PathBuf>,
    /// Clauses embedded since the file was last written.
    unsaved: usize,
    stats: TextStats,
}

/// Write the file again once this many new clauses have been embedded (and when dropped).
const SAVE_EVERY: usize = 2048;

/// Where one entry of a step's clauses is: in the cache or among the step's misses.
#[derive(Clone, Copy)]
enum At {
    Cached(u32),
    Fresh(usize),
}

impl TextEmbedder {
    /// An embedder with a cache of `capacity` clauses; with `file`, the clauses stored there
    /// for this model are loaded (a file that does not check out is ignored with a warning)
    /// and new ones are written back.
    pub fn new(model: Arc<MiniLm>, capacity: usize, file: Option<PathBuf>) -> TextEmbedder {
        let mut cache = ClauseCache::new(capacity);
        let mut loaded = 0;
        if let Some(path) = &file {
            match clause_store::load(path, model.hash(), TEXT_DIM) {
                Ok(records) => {
                    for Record { text, tokens, embedding } in records.iter().take(cache.capacity) {
                        cache.insert(text, *tokens, embedding);
                    }
                    loaded = cache.len() as u64;
                }
                Err(e) => eprintln!("warning: ignoring the clause-embedding cache: {e}"),
            }
        }
        TextEmbedder { model, cache, file, unsaved: 0, stats: TextStats { loaded, ..TextStats::default() } }
    }

    pub fn stats(&self) -> TextStats {
        self.stats
    }
    pub fn cache(&self) -> &ClauseCache {
        &self.cache
    }
    pub fn model(&self) -> &MiniLm {
        &self.model
    }

    /// The features of `docs` (each a description's clauses), `slots` x 384 per description,
    /// appended to `out`.
    pub fn features(&mut self, docs: &[Vec<Clause<'_>>], slots: usize, out: &mut Vec<f32>) -> Result<(), Error> {
        // Resolve every clause; the step's misses, each once, in first-seen order.
        let mut misses: Vec<&str> = Vec::new();
        let mut miss_at: HashMap<&str, usize> = HashMap::new();
        let mut at = Vec::with_capacity(docs.iter().map(Vec::len).sum());
        for c in docs.iter().flatten() {
            if c.slot >= slots {
                return Err(Error::Observation { message: format!("a clause for slot {} of {slots}", c.slot) });
            }
            self.stats.lookups += 1;
            match self.cache.get(&c.text) {
                Some(i) => {
                    self.stats.hits += 1;
                    at.push(At::Cached(i));
                }
                None => {
                    let j = *miss_at.entry(&c.text).or_insert_with(|| {
                        misses.push(&c.text);
                        misses.len() - 1
                    });
                    at.push(At::Fresh(j));
                }
            }
        }
        let fresh: Vec<Embedding> = self.model.embed_many(&misses)?;
        let mut k = 0;
        for doc in docs {
            let base = out.len();
            out.resize(base + slots * TEXT_DIM, 0.0);
            let acc = &mut out[base..];
            for c in doc {
                let (tokens, vec) = match at[k] {
                    At::Cached(i) => self.cache.entry(i),
                    At::Fresh(j) => (fresh[j].tokens, fresh[j].vec.as_slice()),
                };
                k += 1;
                let w = tokens as f32;
                for (a, v) in acc[c.slot * TEXT_DIM..(c.slot + 1) * TEXT_DIM].iter_mut().zip(vec) {
                    *a += w * v;
                }
            }
            for slot in acc.chunks_exact_mut(TEXT_DIM) {
                let norm = slot.iter().map(|x| x * x).sum::<f32>().sqrt();
                if norm > 0.0 {
                    slot.iter_mut().for_each(|x| *x /= norm);
                }
            }
        }
        // Inserted after use: an eviction cannot take what this step reads.
        for (text, e) in misses.iter().zip(&fresh) {
            self.cache.insert(text, e.tokens, &e.vec);
        }
        self.stats.computed += misses.len() as u64;
        self.unsaved += misses.len();
        if self.unsaved >= SAVE_EVERY {
            self.save();
        }
        Ok(())
    }

    /// Writes the cache to its file (if it has one); a failure is a warning, not an error:
    /// the file only saves time.
    pub fn save(&mut self) {
        let Some(path) = &self.file else { return };
        self.unsaved = 0;
        if let Err(e) = clause_store::save(path, self.model.hash(), TEXT_DIM, self.cache.entries()) {
            eprintln!("warning: could not write the clause-embedding cache: {e}");
        }
    }
}

impl Drop for TextEmbedder {
    fn drop(&mut self) {
        if self.unsaved > 0 {
            self.save();
        }
    }
}

/// What makes two embedders interchangeable.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Key {
    model: PathBuf,
    max_tokens: usize,
    capacity: usize,
    file_dir: Option<PathBuf>,
}

type Shared = Arc<Mutex<TextEmbedder>>;
type Live = Weak<Mutex<TextEmbedder>>;

/// The embedder for a model, cache size and file, shared by every source in the process
/// that is alive at the same time (the training run's and its greedy tests'), so that the
/// model is loaded and warmed up once. Sharing cannot change a result: embeddings do not
/// depend on the cache.
pub fn shared(model: PathBuf, max_tokens: usize, capacity: usize, file_dir: Option<PathBuf>) -> Result<Shared, Error> {
    static LIVE: OnceLock<Mutex<Vec<(Key, Live)>>> = OnceLock::new();
    let key = Key { model, max_tokens, capacity, file_dir };
    let live = LIVE.get_or_init(|| Mutex::new(Vec::new()));
    let mut live = live.lock().map_err(|_| Error::TextModel { message: "a thread panicked holding the embedder list".into() })?;
    live.retain(|(_, w)| w.strong_count() > 0);
    if let Some(e) = live.iter().find(|(k, _)| *k == key).and_then(|(_, w)| w.upgrade()) {
        return Ok(e);
    }
    let model = MiniLm::load_from(&key.model, key.max_tokens)?;
    let file = key.file_dir.as_deref().map(|d| clause_store::file_in(d, model.hash()));
    let e = Arc::new(Mutex::new(TextEmbedder::new(Arc::new(model), capacity, file)));
    live.push((key, Arc::downgrade(&e)));
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(i: usize) -> Vec<f32> {
        (0..TEXT_DIM).map(|k| if k == i { 1.0 } else { 0.0 }).collect()
    }

    #[test]
    fn the_clock_keeps_what_was_read_since_the_last_sweep() {
        let mut c = ClauseCache::new(2);
        c.insert("a", 1, &unit(0));
        c.insert("b", 1, &unit(1));
        assert!(c.get("a").is_some());
        c.insert("c", 1, &unit(2)); // b goes: a was read
        assert!(c.get("b").is_none() && c.get("a").is_some() && c.get("c").is_some());
        assert_eq!(c.len(), 2);
        let i = c.get("c").unwrap_or(0);
        let (_, v) = c.entry(i);
        assert_eq!(v, unit(2).as_slice());
        let order: Vec<&str> = c.entries().map(|(t, ..)| t).collect();
        assert_eq!(order, ["a", "c"]);
    }
}
