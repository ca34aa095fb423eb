//! Why a policy was refused: one error type for every place that names a policy, so a
//! launch file, an eval plan, `episode --agent` and Python say the same thing.

use crate::names::{AVA_POLICY, DDS_POLICY, MARL_PREFIX, ROTATE_POLICY};
use avacraft_engine::Team;
use avacraft_marl::baselines::{BASELINE_PREFIX, BaselineError};
use std::path::PathBuf;
use std::sync::Arc;

/// Why a policy was refused.
#[derive(Debug, thiserror::Error)]
pub enum PolicyError {
    #[error("unknown policy `{name}` (known: {known}, {MARL_PREFIX}DIR, {BASELINE_PREFIX}NAME, {AVA_POLICY}, {DDS_POLICY})")]
    Unknown { name: String, known: String },
    #[error("`{MARL_PREFIX}` needs the directory of a checkpoint written by `avacraft train`, e.g. {MARL_PREFIX}runs/qmix-3m")]
    NoDir,
    #[error("checkpoint directory {} does not exist", dir.display())]
    MissingDir {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("checkpoint directory {} cannot be opened", dir.display())]
    Unreadable {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("checkpoint {} is not a directory", dir.display())]
    NotADir { dir: PathBuf },
    #[error("cannot load the checkpoint in {}", dir.display())]
    Checkpoint {
        dir: PathBuf,
        #[source]
        source: avacraft_marl::Error,
    },
    #[error("checkpoint {}: {why}", dir.display())]
    NotAnAgent { dir: PathBuf, why: String },
    #[error("checkpoint {} was trained on scenario `{trained}`, not `{scenario}`", dir.display())]
    OtherScenario { dir: PathBuf, trained: String, scenario: String },
    #[error(
        "checkpoint {} was trained for {} agents, {} features and {} actions; {team} of {scenario} has {} agents, {} features and {} actions",
        dir.display(), trained.0, trained.1, trained.2, here.0, here.1, here.2
    )]
    OtherShape { dir: PathBuf, trained: (usize, usize, usize), team: Team, scenario: String, here: (usize, usize, usize) },
    #[error("shipped baseline")]
    Baseline(#[source] BaselineError),
    #[error("policy `{BASELINE_PREFIX}{name}` names each scenario's shipped policy: it is resolved for a scenario first")]
    BaselineUnresolved { name: String },
    #[error("policy `{DDS_POLICY}` is an agent outside, driven over DDS through the bridge: it cannot run here")]
    Dds,
    #[error(
        "policy `{AVA_POLICY}` needs its settings (at least a `model`): a launch file's `ava:` block, an eval plan's `ava` table, or `episode`'s --llm-* options"
    )]
    AvaWithoutSpec,
    #[error("AVA settings go with policy `{AVA_POLICY}`, not `{policy}`")]
    SpecWithoutAva { policy: String },
    #[error("policy `{AVA_POLICY}`")]
    Ava(#[source] Arc<avacraft_ava::SpecError>),
    #[error("a commander's policy is `{AVA_POLICY}` or `{ROTATE_POLICY}`, not `{policy}`")]
    NotACommander { policy: String },
}
