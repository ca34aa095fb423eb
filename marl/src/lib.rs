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
//!
//! # Layers
//!
//! Each module uses only modules of its own layer or a lower one, and no two modules use each
//! other, directly or around a circle (`tests/it/structure.rs` checks both, from this list):
//!
//! 1. foundations: `error`, `aside`, `params`, `optim`, `opponent`, `value_norm`, `plot`, `tensorboard`, `runlog`, `baselines`, `lock`
//! 2. configuration: `config`
//! 3. data: `kernels`, `frames`, `buffer`, `journal`, `td`, `stack`
//! 4. networks: `encoders`, `nets`, `qtran`, `observe`
//! 5. acting: `acting`, `checkpoint`, `evaluation`, `selfplay`
//! 6. learning: `learner`, `carry`, `resume`, `monitor`, `ppo`
//! 7. training: `train`, `ship`, `continuation`

// Denied (not forbidden) so that `kernels::gemm`, the one call into a matrix-product kernel
// by pointer, can allow it behind a bounds-checked safe function.
#![deny(unsafe_code)]

pub mod acting;
pub mod aside;
pub mod baselines;
pub mod buffer;
mod carry;
pub mod checkpoint;
pub mod config;
pub mod continuation;
pub mod encoders;
mod error;
pub mod evaluation;
pub mod frames;
mod journal;
pub mod kernels;
pub mod learner;
pub mod lock;
pub mod monitor;
pub mod nets;
pub mod observe;
mod opponent;
pub mod optim;
pub mod params;
pub mod plot;
pub mod ppo;
pub mod qtran;
pub mod resume;
pub mod runlog;
pub mod selfplay;
pub mod ship;
mod stack;
pub mod td;
pub mod tensorboard;
pub mod train;
mod value_norm;

pub use acting::select_actions;
pub use buffer::{Batch, Episode, ReplayBuffer, Shape};
pub use checkpoint::{MarlAgent, Policy, Seen};
pub use config::{ALGOS, Config, MixerKind, Opponent, ScriptDraw};
pub use encoders::{Backbone, ObsEncoder, ObsKind};
pub use error::{Error, Refused};
pub use evaluation::{FramesActor, TestResult};
pub use learner::{Learner, UpdateStats};
pub use monitor::{Progress, RunOptions, Summary};
pub use nets::Nets;
pub use observe::ObsSource;
pub use optim::{Optimizer, OptimizerKind};
pub use ppo::PpoLearner;
pub use stack::Stack;
pub use td::QGrads;
pub use train::{Trained, train, train_from};
