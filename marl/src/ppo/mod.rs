//! IPPO and MAPPO (the MAPPO repository's recurrent PPO for SMAC): a shared GRU actor, the
//! Q-learners' agent network read as logits so its checkpoints play through
//! [`crate::MarlAgent`] unchanged, and a recurrent critic of the same architecture with one
//! output, fed each agent's observation (IPPO) or the global state (MAPPO) with the agent id.
//!
//! - [`rollout`]: on-policy rollouts, GAE, the chunks the recurrent nets learn on;
//! - [`learner`]: losses, Adam with global-norm clipping, the update, masked sampling;
//! - `crate::value_norm`: MAPPO's running normalisation of the value targets (below the
//!   run state, which saves it);
//! - [`train`](train()): the loop.
//!
//! Speed: the actor and critic train through the fused kernels ([`crate::kernels`]: the
//! networks' forward and backward passes, the loss's gradient and Adam by hand, on both
//! cores), each mini-batch one pass over its chunks with the GRU unrolled
//! `data_chunk_length` steps; candle runs only the image encoders. `avacraft train` still
//! sets `CANDLE_NUM_THREADS=1` (candle's elementwise pool spins) and a glibc malloc tuning
//! (see its `main.rs`) for those. The example `ppo_update_bench` times candle's update against
//! the fused one.

mod critic_input;
pub mod learner;
pub mod rollout;
mod train;

pub use crate::value_norm::ValueNorm;
pub use critic_input::CriticInput;
pub use learner::{Gradients, Losses, PpoLearner, PpoStats, StepReport, masked_log_softmax, sample_actions};
pub use rollout::{CriticRows, FlatBatch, MASKED, PpoBatch, Rollout, gae, to_chunks};
pub(crate) use train::restore;
pub(crate) use train::train_from;
