//! The unit knowledge base AVA retrieves from: for every unit type of the engine, authored
//! prose (what it is, strengths and weaknesses, matchups, abilities, micro tactics; in
//! `ava/kb/units.toml`) joined with the numbers of the engine's own unit and ability tables,
//! so the figures a model reads are the ones the simulator plays by and never drift from it.
//!
//! The base is cut into passages (a unit's profile, each of its abilities, its tactics), the
//! units retrieval ranks. The paper's released code looked units up by exact name in a YAML
//! index that missed several scenario units; here every unit type has its passages and a
//! test holds the base to the engine's table.

mod base;
mod dense;
mod retrieve;
mod shared;

pub use base::{KbError, KnowledgeBase, Passage, Topic, UnitDoc, stats_line};
pub use dense::{Dense, DenseError};
pub use retrieve::{Bm25, Hit, Retriever};
pub use shared::{RetrieverError, SharedRetriever, retriever};
