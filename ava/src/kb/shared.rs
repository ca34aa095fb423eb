//! The retriever a run's agents share, built once per kind. Kept out of the retrievers' own
//! files: it names both of them, while each of them needs only the base.

use super::base::{KbError, KnowledgeBase};
use super::dense::{Dense, DenseError};
use super::retrieve::{Bm25, Retriever};
use std::sync::{Arc, Mutex};

/// A retriever shared by the agents of a run (and across runs: the dense one embeds the base
/// once per process, which an evaluation of many episodes would otherwise redo each time).
pub type SharedRetriever = Arc<dyn Retriever + Send + Sync>;

/// The built-in base's retriever of `kind`.
pub fn retriever(kind: crate::config::RetrieverKind) -> Result<SharedRetriever, RetrieverError> {
    static DENSE: Mutex<Option<Arc<Dense>>> = Mutex::new(None);
    let kb = KnowledgeBase::builtin()?;
    Ok(match kind {
        crate::config::RetrieverKind::Bm25 => Arc::new(Bm25::new(&kb)),
        crate::config::RetrieverKind::Dense => {
            let mut g = DENSE.lock().unwrap_or_else(|p| p.into_inner());
            match g.as_ref() {
                Some(d) => Arc::clone(d) as SharedRetriever,
                None => {
                    let d = Arc::new(Dense::load(&kb)?);
                    *g = Some(Arc::clone(&d));
                    d
                }
            }
        }
    })
}

/// Why a retriever could not be built.
#[derive(Debug, thiserror::Error)]
pub enum RetrieverError {
    #[error(transparent)]
    Kb(#[from] KbError),
    #[error(transparent)]
    Dense(#[from] DenseError),
}
