//! AVA, the paper's VLM agent. This crate grows with issue #14; it holds so far the unit
//! knowledge base and its retrieval ([`kb`]), which the agent's prompts draw on.

#![forbid(unsafe_code)]

pub mod kb;

pub use kb::{Bm25, Hit, KbError, KnowledgeBase, Passage, Retriever, Topic, UnitDoc};
