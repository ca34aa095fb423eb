//! AVA, the paper's VLM agent, built as the paper describes it and with its released code's
//! faults fixed: the executed actions are the model's own (checked, repaired, or a counted
//! fallback), retrieval covers every unit type, positions in the prompt are cells of the
//! grid drawn on the screenshot, energy and cooldowns are checked, own units are blue, and
//! every model call is recorded, costed and replayable.
//!
//! - [`kb`]: the unit knowledge base and its retrieval;
//! - [`decision`]: the action schema, parsing and checking;
//! - [`llm`]: model back ends (OpenAI-compatible, a local GGUF model with the `local` feature,
//!   replay, scripted) and the recorder;
//! - [`AvaAgent`]: the pipeline behind the engine's agent contract;
//! - [`AvaConfig`]: switches (the paper's ablations), timing, view and sampling;
//! - [`cost`]: tokens, latency and dollars per call, decision and episode.

#![forbid(unsafe_code)]

mod agent;
mod config;
pub mod cost;
pub mod decision;
pub mod kb;
pub mod llm;
mod prompt;
mod spec;

pub use agent::{
    AvaAgent, AvaCommander, AvaRun, AvaSetup, CallObserver, Plan, Priority, ROLES, RoleOf, Skill, Tally, describe, describe_rich, place,
};
pub use config::{ActionSet, AvaConfig, ConfigError, Fallback, PromptStyle, RetrieverKind, Timing};
pub use kb::{Bm25, Hit, KbError, KnowledgeBase, Passage, Retriever, Topic, UnitDoc};
pub use prompt::{PromptError, Prompts, TEMPLATES};
pub use spec::{AvaSpec, ModelSpec, SpecError};
