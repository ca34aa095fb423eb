//! Layers of the image encoders, their weights drawn from the seeded [`Params`] stream like
//! every other network here (PyTorch's default initialisation, uniform in +-1/sqrt(fan_in);
//! layer norms start at scale 1, shift 0). Everything is built from candle operations that
//! have gradients (conv2d, matmul, basic arithmetic); candle's fused layer norm and
//! last-dimension softmax kernels have none, so they are not used.

use crate::Error;
use crate::params::{Linear, Params};
use candle_core::{D, Device, Tensor};
use rand_chacha::ChaCha8Rng;

impl Params {
    /// A convolution kernel `(out, inp, k, k)` and bias `(out)`.
    pub(crate) fn conv2d(&mut self, name: &str, inp: usize, out: usize, k: usize, rng: &mut ChaCha8Rng) -> Result<(Tensor, Tensor), Error> {
        let fan_in = inp * k * k;
        Ok((
            self.uniform(format!("{name}.weight"), &[out, inp, k, k], fan_in, rng)?,
            self.uniform(format!("{name}.bias"), &[out], fan_in, rng)?,
        ))
    }
    /// A layer norm's scale (ones) and shift (zeros) of width `dim`.
    pub(crate) fn layer_norm(&mut self, name: &str, dim: usize) -> Result<LayerNorm, Error> {
        Ok(LayerNorm { w: self.constant(format!("{name}.weight"), &[dim], 1.0)?, b: self.constant(format!("{name}.bias"), &[dim], 0.0)? })
    }
    /// A weight without bias `(out, inp)` (Swin's patch merging reduction).
    pub(crate) fn matrix(&mut self, name: &str, inp: usize, out: usize, rng: &mut ChaCha8Rng) -> Result<Tensor, Error> {
        self.uniform(format!("{name}.weight"), &[out, inp], inp, rng)
    }
}

/// A 2-D convolution with bias.
#[derive(Debug, Clone)]
pub struct Conv2d {
    w: Tensor,
    b: Tensor,
    stride: usize,
    padding: usize,
}

impl Conv2d {
    pub(crate) fn new(
        p: &mut Params,
        name: &str,
        (inp, out, k): (usize, usize, usize),
        stride: usize,
        padding: usize,
        rng: &mut ChaCha8Rng,
    ) -> Result<Conv2d, Error> {
        let (w, b) = p.conv2d(name, inp, out, k, rng)?;
        Ok(Conv2d { w, b, stride, padding })
    }
    /// `(N, inp, H, W)` -> `(N, out, H', W')`, as `torch.nn.Conv2d`.
    ///
    /// Done as im2col and one matrix product rather than with candle's `conv2d`: on the
    /// CPU, candle 0.11 computes a convolution's input gradient with a direct transposed
    /// convolution that took 20 s for 256 80x60 frames here (the product's backward takes
    /// well under a second), and it gets the gradient's width wrong when the height and
    /// width differ in parity. The columns are strided slices of the padded input (a reshape
    /// splits each axis into `stride` phases), so gradients flow through ordinary ops.
    pub fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        let (n, c, h, w) = x.dims4()?;
        let (o, _, k, _) = self.w.dims4()?;
        let (s, p) = (self.stride.max(1), self.padding);
        let (hp, wp) = (h + 2 * p, w + 2 * p);
        if hp < k || wp < k {
            return Err(Error::Observation { message: format!("a {h}x{w} map is smaller than a {k}x{k} kernel") });
        }
        let (oh, ow) = ((hp - k) / s + 1, (wp - k) / s + 1);
        // Padded to whole strides: `(N, C, hp/s, s, wp/s, s)`, phase (py, px) = x[py::s, px::s].
        let (hs, ws) = (hp.div_ceil(s), wp.div_ceil(s));
        let xp = x.pad_with_zeros(2, p, p + hs * s - hp)?.pad_with_zeros(3, p, p + ws * s - wp)?.reshape((n, c, hs, s, ws, s))?;
        let mut cols = Vec::with_capacity(k * k);
        for ky in 0..k {
            for kx in 0..k {
                let phase = xp.narrow(3, ky % s, 1)?.narrow(5, kx % s, 1)?.reshape((n, c, hs, ws))?;
                cols.push(phase.narrow(2, ky / s, oh)?.narrow(3, kx / s, ow)?);
            }
        }
        // (N, C, k*k, oh, ow) -> rows (N*oh*ow) of (C, ky, kx) columns, the kernel's layout.
        let cols = Tensor::stack(&cols, 2)?.permute((0, 3, 4, 1, 2))?.reshape((n * oh * ow, c * k * k))?;
        let y = cols.matmul(&self.w.reshape((o, c * k * k))?.t()?)?.broadcast_add(&self.b)?;
        Ok(y.reshape((n, oh, ow, o))?.permute((0, 3, 1, 2))?.contiguous()?)
    }
}

/// Layer normalisation over the last dimension (eps 1e-5, as PyTorch's default).
#[derive(Debug, Clone)]
pub struct LayerNorm {
    w: Tensor,
    b: Tensor,
}

impl LayerNorm {
    pub fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        Ok(candle_nn::ops::layer_norm_slow(x, &self.w, &self.b, 1e-5)?)
    }
}

/// A linear layer on the last dimension of a tensor of any rank.
pub(crate) fn linear_nd(l: &Linear, x: &Tensor) -> Result<Tensor, Error> {
    let dims = x.dims().to_vec();
    let (last, lead) = dims.split_last().map_or((0, &[][..]), |(l, r)| (*l, r));
    let y = l.forward(&x.reshape(((), last))?)?;
    let mut out = lead.to_vec();
    out.push(y.dim(1)?);
    Ok(y.reshape(out)?)
}

/// `x W^T` for a bias-free weight on the last dimension of any rank.
pub(crate) fn matmul_nd(w: &Tensor, x: &Tensor) -> Result<Tensor, Error> {
    let dims = x.dims().to_vec();
    let (last, lead) = dims.split_last().map_or((0, &[][..]), |(l, r)| (*l, r));
    let y = x.reshape(((), last))?.matmul(&w.t()?)?;
    let mut out = lead.to_vec();
    out.push(y.dim(1)?);
    Ok(y.reshape(out)?)
}

/// The `(out, inp)` matrix of adaptive average pooling along one axis, with PyTorch's bins
/// (`[floor(i*inp/out), ceil((i+1)*inp/out))`): bins overlap when `out` does not divide
/// `inp`, and repeat inputs when `out > inp`.
fn pool_matrix(inp: usize, out: usize) -> Result<Tensor, Error> {
    let mut m = vec![0f32; out * inp];
    for i in 0..out {
        let start = i * inp / out;
        let end = ((i + 1) * inp).div_ceil(out).max(start + 1);
        for j in start..end {
            m[i * inp + j] = 1.0 / (end - start) as f32;
        }
    }
    Ok(Tensor::from_vec(m, (out, inp), &Device::Cpu)?)
}

/// Adaptive average pooling `(N, C, H, W)` -> `(N, C, oh, ow)` for any `H, W`, as
/// `torch.nn.AdaptiveAvgPool2d`: two products with pooling matrices, so gradients flow.
pub fn adaptive_avg_pool2d(x: &Tensor, oh: usize, ow: usize) -> Result<Tensor, Error> {
    let (n, c, h, w) = x.dims4()?;
    let pw = pool_matrix(w, ow)?.t()?.contiguous()?; // (W, ow)
    let ph = pool_matrix(h, oh)?; // (oh, H)
    let y = x.reshape((n * c * h, w))?.matmul(&pw)?.reshape((n * c, h, ow))?; // rows pooled
    let y = ph.unsqueeze(0)?.broadcast_as((n * c, oh, h))?.contiguous()?.matmul(&y)?;
    Ok(y.reshape((n, c, oh, ow))?)
}

/// Softmax over the last dimension from basic operations (so it has gradients).
pub fn softmax_last(x: &Tensor) -> Result<Tensor, Error> {
    Ok(candle_nn::ops::softmax(x, D::Minus1)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn im2col_convolution_matches_candles() -> Result<(), Error> {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let x = Tensor::rand(0f32, 1f32, (2, 3, 9, 11), &Device::Cpu)?;
        for (k, stride, pad) in [(3, 2, 1), (4, 4, 0), (5, 2, 2), (3, 1, 1)] {
            let mut p = Params::default();
            let c = Conv2d::new(&mut p, "c", (3, 4, k), stride, pad, &mut rng)?;
            let want = x.conv2d(&c.w, pad, stride, 1, 1)?.broadcast_add(&c.b.reshape((1, (), 1, 1))?)?;
            let got = c.forward(&x)?;
            assert_eq!(got.dims(), want.dims(), "k {k} stride {stride}");
            let diff = (got - want)?.abs()?.max_all()?.to_scalar::<f32>()?;
            assert!(diff < 1e-4, "k {k} stride {stride}: {diff}");
        }
        Ok(())
    }
}
