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

#[cfg(test)]
mod conv_tests;
#[cfg(test)]
mod tests;
