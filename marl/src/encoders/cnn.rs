//! The convolutional stream: convolutions with ReLU (5x5 stride 2 first, 3x3 stride 2
//! after, "same" padding), then adaptive average pooling to a fixed `pool x pool` grid, so
//! any frame size gives the same feature width (the paper's 160x120 screen and this
//! project's 80x60 default load the same weights).

use super::layers::{Conv2d, adaptive_avg_pool2d};
use crate::Error;
use crate::nets::Params;
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
            let (k, pad) = if i == 0 { (5, 2) } else { (3, 1) };
            convs.push(Conv2d::new(p, &format!("{name}.conv{i}"), (inp, c, k), 2, pad, rng)?);
            inp = c;
        }
        Ok(CnnStream { convs, pool, out: inp * pool * pool })
    }

    /// Images `(N, 3, H, W)` in [0, 1] -> `(N, out)`.
    pub fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        let mut h = x.clone();
        for c in &self.convs {
            // Even sizes (one zero row or column at most): candle 0.11's conv2d backward
            // applies the height's output padding to the width too, which gives the input
            // gradient a wrong width when the two sizes differ in parity.
            let (_, _, ih, iw) = h.dims4()?;
            h = c.forward(&h.pad_with_zeros(2, 0, ih % 2)?.pad_with_zeros(3, 0, iw % 2)?)?.relu()?;
        }
        let n = h.dim(0)?;
        Ok(adaptive_avg_pool2d(&h, self.pool, self.pool)?.reshape((n, self.out))?)
    }
}
