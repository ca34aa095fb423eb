//! IPPO and MAPPO (the MAPPO repository's recurrent PPO for SMAC): a shared GRU actor, the
//! Q-learners' agent network read as logits so its checkpoints play through
//! [`crate::MarlAgent`] unchanged, and a recurrent critic of the same architecture with one
//! output, fed each agent's observation (IPPO) or the global state (MAPPO) with the agent id.
//!
//! - [`rollout`]: on-policy rollouts, GAE, the chunks the recurrent nets learn on;
//! - [`learner`]: losses, Adam with global-norm clipping, the update, masked sampling;
//! - [`value_norm`]: MAPPO's running normalisation of the value targets;
//! - [`train`](train()): the loop.
//!
//! Speed: the update is one forward and backward pass over all chunks per epoch, with
//! the GRU unrolled `data_chunk_length` steps. On a small shared machine it runs
//! several times faster with `CANDLE_NUM_THREADS=1` (candle's elementwise pool spins) and
//! glibc's malloc kept from unmapping freed tensors
//! (`GLIBC_TUNABLES=glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=536870912`);
//! `avacraft train` sets both unless they are set (see its `main.rs`). The example
//! `ppo_update_bench` times the update's parts.

pub mod learner;
pub mod rollout;
mod train;
pub mod value_norm;

pub use learner::{CriticInput, Gradients, Losses, PpoLearner, PpoStats, StepReport, masked_log_softmax, sample_actions};
pub use rollout::{FlatBatch, MASKED, PpoBatch, Rollout, gae, to_chunks};
pub use train::{train, train_from};
pub use value_norm::ValueNorm;
