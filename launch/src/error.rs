//! Why a launch file was refused: every refusal names the file, the field and the value.

use avacraft_policy::PolicyError;
use std::sync::Arc;

/// Why a launch file was refused.
#[derive(Debug, Clone, thiserror::Error)]
pub enum LaunchError {
    #[error("{file}: cannot read the launch file")]
    Io {
        file: String,
        #[source]
        source: Arc<std::io::Error>,
    },
    #[error("{file}: not a valid launch file")]
    Syntax {
        file: String,
        #[source]
        source: Arc<serde_norway::Error>,
    },
    #[error("{file}: field `{field}` = {value}: {reason}")]
    Invalid { file: String, field: String, value: String, reason: String },
    /// A policy refused (a checkpoint missing, unreadable or trained for something else);
    /// the source says why.
    #[error("{file}: field `{field}` = {value}")]
    Policy {
        file: String,
        field: String,
        value: String,
        #[source]
        source: Arc<PolicyError>,
    },
}

pub(crate) struct Cx<'a>(pub(crate) &'a str);

impl Cx<'_> {
    pub(crate) fn err(&self, field: impl Into<String>, value: impl std::fmt::Display, reason: impl Into<String>) -> LaunchError {
        LaunchError::Invalid { file: self.0.to_owned(), field: field.into(), value: value.to_string(), reason: reason.into() }
    }
    pub(crate) fn policy_err(&self, field: impl Into<String>, value: &str, e: PolicyError) -> LaunchError {
        LaunchError::Policy { file: self.0.to_owned(), field: field.into(), value: format!("{value:?}"), source: Arc::new(e) }
    }
}
