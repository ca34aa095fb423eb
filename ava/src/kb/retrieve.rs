//! Ranking passages for a query. BM25 (the `bm25` crate: English stemming and stop words) is
//! the default: the queries AVA asks are unit and ability names and a few words of
//! situation, which keyword scoring matches well and without a model.
//!
//! Results must not depend on hash-map order (a prompt built from them is recorded and
//! replayed), so equal scores are ordered by passage index.

use super::base::{KnowledgeBase, Passage};
use bm25::{Language, SearchEngine, SearchEngineBuilder};

/// A ranked passage.
#[derive(Clone, Debug, PartialEq)]
pub struct Hit<'a> {
    /// Index into [`KnowledgeBase::passages`].
    pub index: usize,
    pub passage: &'a Passage,
    pub score: f32,
}

/// Ranks a knowledge base's passages for a query.
pub trait Retriever: std::fmt::Debug {
    /// At most `k` passages with a positive score, best first; ties in passage order.
    fn search(&self, query: &str, k: usize) -> Vec<Hit<'_>>;
}

/// Okapi BM25 over the passages' titles and texts.
pub struct Bm25 {
    engine: SearchEngine<u32>,
    passages: Vec<Passage>,
}

impl std::fmt::Debug for Bm25 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bm25").field("passages", &self.passages.len()).finish_non_exhaustive()
    }
}

impl Bm25 {
    pub fn new(kb: &KnowledgeBase) -> Bm25 {
        let corpus: Vec<String> = kb.passages().iter().map(|p| format!("{}. {}", p.title, p.text)).collect();
        let engine = SearchEngineBuilder::<u32>::with_corpus(Language::English, corpus).build();
        Bm25 { engine, passages: kb.passages().to_vec() }
    }
}

impl Retriever for Bm25 {
    fn search(&self, query: &str, k: usize) -> Vec<Hit<'_>> {
        if k == 0 {
            return Vec::new();
        }
        let mut hits: Vec<(usize, f32)> = self
            .engine
            .search(query, None)
            .into_iter()
            .filter(|r| r.score.is_finite() && r.score > 0.0)
            .filter_map(|r| usize::try_from(r.document.id).ok().map(|i| (i, r.score)))
            .filter(|(i, _)| *i < self.passages.len())
            .collect();
        hits.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        hits.truncate(k);
        hits.into_iter().map(|(index, score)| Hit { index, passage: &self.passages[index], score }).collect()
    }
}
