//! Hand-written training kernels where candle's per-operation costs dominate: the agent
//! network's forward and backward passes over sequences ([`net`]), QMIX's mixer ([`mixer`]),
//! the CNN image encoder's over frames ([`conv`]), PPO's loss and its gradient
//! ([`ppo_loss`]), and Adam and RMSprop on flat parameter vectors ([`adam`]). Each is checked
//! against candle's autograd on the crate's reference implementations by gradient tests.

mod act;
pub mod adam;
mod chunk_in;
pub mod conv;
mod gemm;
pub mod mixer;
pub mod net;
mod norm;
mod pack;
pub mod ppo_loss;

pub use adam::{Adam, Moments, RmsProp, clip_global_norm};
pub use conv::{EncoderForward, EncoderLayout, Pixels};
pub use mixer::{MixerForward, MixerLayout};
pub use net::{Forward, Input, NetLayout};
pub use pack::Want;

/// Sizes the pool the kernels run their chunks on (rayon's global pool) to `threads`, so a
/// run told to use one core does not keep a second busy with its learner. The chunks and the
/// order their gradients are summed in do not depend on the pool, so neither do the results.
/// The pool can be sized once per process: later calls leave it as it is. Returns the
/// threads the kernels use from then on.
pub fn use_threads(threads: usize) -> usize {
    // An error means the pool is already running (sized by an earlier call or first use);
    // its size is then what the caller gets back.
    let _ = rayon::ThreadPoolBuilder::new().num_threads(threads.max(1)).build_global();
    rayon::current_num_threads()
}

#[cfg(test)]
mod conv_tests;
#[cfg(test)]
mod tests;
