//! The convolutional stream: convolutions with ReLU (a 4x4 stride-4 "patchify" stem, then
//! 3x3 stride 2 with padding 1), then adaptive average pooling to a fixed `pool x pool`
//! grid, so any frame size gives the same feature width (the paper's 160x120 screen and
//! this project's 80x60 default load the same weights).
//!
//! The stem is non-overlapping because the CPU cost of the usual overlapping 5x5 stride-2
//! first layer dominated training: measured on 256 80x60 frames (plus minimaps) on this
//! 2-core machine under load, 5x5/2 then 3x3/2 took 1.7 s forward and 3.3 s backward; the
//! 4x4/4 stem 0.3 s and 1.0 s.

use super::layers::{Conv2d, adaptive_avg_pool2d};
use crate::Error;
use crate::kernels::conv::geometry;
use crate::params::Params;
use candle_core::Tensor;
use rand_chacha::ChaCha8Rng;

#[derive(Debug, Clone)]
pub struct CnnStream {
    convs: Vec<Conv2d>,
    pool: usize,
    /// Width of the flattened output: last channels x pool x pool.
    pub out: usize,
}

impl CnnStream {
    pub fn new(p: &mut Params, name: &str, channels: &[usize], pool: usize, rng: &mut ChaCha8Rng) -> Result<CnnStream, Error> {
        let mut convs = Vec::with_capacity(channels.len());
        let mut inp = 3;
        for (i, &c) in channels.iter().enumerate() {
            let (k, stride, pad) = geometry(i);
            convs.push(Conv2d::new(p, &format!("{name}.conv{i}"), (inp, c, k), stride, pad, rng)?);
            inp = c;
        }
        Ok(CnnStream { convs, pool, out: inp * pool * pool })
    }

    /// Images `(N, 3, H, W)` in [0, 1] -> `(N, out)`.
    pub fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        let mut h = x.clone();
        for c in &self.convs {
            h = c.forward(&h)?.relu()?;
        }
        let n = h.dim(0)?;
        Ok(adaptive_avg_pool2d(&h, self.pool, self.pool)?.reshape((n, self.out))?)
    }
}
