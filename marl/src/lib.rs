//! MARL baselines on the engine's vector environment: IQL, VDN, QMIX and QTRAN with PyMARL's
//! conventions (one GRU agent network shared by all agents, agent id and last action in its
//! input, action masking, an episode replay buffer, target networks, epsilon-greedy,
//! RMSprop with global-norm gradient clipping), IPPO and MAPPO with the MAPPO repository's
//! (the same agent network as the policy, a recurrent critic, GAE, value normalisation; see
//! [`ppo`]), and trained policies as engine [`Agent`]s.
//!
//! Tensors and automatic differentiation come from candle (CPU), because:
//! - its tensors are stepped one timestep at a time, so the GRU agent carries its hidden
//!   state across environment steps while acting and unrolls over stored episodes while
//!   learning, as PyMARL's RNN agents do;
//! - it reads and writes safetensors itself (the checkpoints);
//! - it builds offline here without libtorch (tch needs a multi-GB libtorch);
//! - burn's gradient clipping is per tensor, not PyMARL's global norm, and it needs a newer
//!   rustc. candle has neither RMSprop nor clipping, so [`optim`] adds both (a few lines over
//!   its gradient store).
//!
//! Training runs the agent networks, the CNN image encoder (and PPO's loss and optimiser)
//! through hand-written kernels ([`kernels`]) checked against candle's autograd, which the
//! networks here keep as the reference: see `marl/README.md` for where the time went and
//! why.
//!
//! Four observation modes (the paper's, config key `obs`): SMAC's feature vectors, or an
//! image encoder ([`encoders`]: a two-stream CNN or Swin Transformer over the renderer's
//! screen and minimap, trained from scratch) in front of the agent network, with the
//! SMAC features (`hybrid`) or per-unit slot embeddings of the team's text, built from its
//! clauses embedded once each by a frozen all-MiniLM-L6-v2 (`vision-text`); [`observe`]
//! renders the frames while training.
//!
//! The weights are initialised from a seeded ChaCha stream and every random choice (actions,
//! replay samples) draws from seeded streams, so a run is a function of its config and seed.
//!
//! [`Agent`]: avacraft_engine::Agent

// Denied (not forbidden) so that `kernels::gemm`, the one call into a matrix-product kernel
// by pointer, can allow it behind a bounds-checked safe function.
#![deny(unsafe_code)]

pub mod baselines;
pub mod buffer;
mod carry;
pub mod config;
pub mod encoders;
pub mod frames;
mod journal;
pub mod kernels;
pub mod learner;
pub mod monitor;
pub mod nets;
pub mod observe;
mod opponent;
pub mod optim;
pub mod params;
pub mod plot;
pub mod policy;
pub mod ppo;
pub mod qtran;
pub mod resume;
pub mod runlog;
pub mod selfplay;
pub mod ship;
pub mod td;
pub mod tensorboard;
pub mod train;

pub use buffer::{Batch, Episode, ReplayBuffer, Shape};
pub use config::{ALGOS, Config, MixerKind, Opponent};
pub use encoders::{Backbone, ObsEncoder, ObsKind};
pub use learner::{Learner, UpdateStats};
pub use monitor::{Progress, RunOptions, Summary};
pub use nets::Nets;
pub use observe::ObsSource;
pub use optim::{Optimizer, OptimizerKind};
pub use policy::{FramesActor, MarlAgent, Policy, TestResult, select_actions};
pub use ppo::PpoLearner;
pub use td::QGrads;
pub use train::{Trained, train, train_from};

/// A config value refused: its key, the value, the rule it breaks and the nearest valid value
/// (boxed in [`Error`] to keep the error small).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{key} = {value}`: {rule}; nearest valid value: {nearest}")]
pub struct Refused {
    pub key: String,
    pub value: String,
    pub rule: String,
    pub nearest: String,
}

/// What can go wrong configuring, training, saving or loading.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("unknown algorithm `{algo}` (known: {known})")]
    UnknownAlgo { algo: String, known: String },
    #[error("unknown config key `{key}` (known: {known})")]
    UnknownKey { key: String, known: String },
    #[error("override `{text}`: {message}")]
    Override { text: String, message: String },
    #[error("{what}: {message}")]
    ConfigParse { what: String, message: String },
    #[error("{0}")]
    BadValue(Box<Refused>),
    #[error("tensor operation failed")]
    Tensor(#[from] candle_core::Error),
    #[error("environment")]
    Env(#[from] avacraft_engine::VecEnvError),
    #[error("{}", path.display())]
    Io {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}", path.display())]
    Json {
        path: std::path::PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("learning-curve plot: {message}")]
    Plot { message: String },
    #[error("checkpoint: {message}")]
    Checkpoint { message: String },
    #[error("training diverged at update {update}: loss {loss}")]
    Diverged { update: u64, loss: f64 },
    #[error("training diverged: the gradients' norm is {norm}")]
    NonFiniteGradient { norm: f64 },
    #[error("observation: {message}")]
    Observation { message: String },
    #[error("text model all-MiniLM-L6-v2: {message}")]
    TextModel { message: String },
    /// all-MiniLM-L6-v2, the vision-text mode's text model.
    #[error(transparent)]
    Text(#[from] avacraft_minilm::Error),
}
