//! A Swin Transformer stream (Liu et al. 2021), as torchvision's `swin_t` builds it: patch
//! embedding (a `patch x patch` stride-`patch` convolution, done as a reshape and a matrix
//! product) with layer norm; stages of blocks alternating window attention and shifted-window
//! attention (relative position bias, cyclic shift with the attention mask that keeps
//! shifted-in regions apart), each block `x + attn(norm(x))`, `x + mlp(norm(x))` with a 4x
//! GELU MLP; patch merging (2x2 neighbours concatenated, normed, linearly halved) between
//! stages; a final norm and global average pooling (the adaptive pooling that makes the
//! width independent of the frame size).
//!
//! Frames of any size work: feature maps are zero-padded to whole windows (and to even
//! sizes before a merge), as torchvision does; where a map is no larger than a window the
//! window shrinks to the map and is not shifted, as the original implementation does.
//!
//! The weights start from the seeded stream and train from scratch with the agent network:
//! no pretrained Swin weights can be had here (the paper's were ImageNet-pretrained, not
//! stated otherwise). Dropout and stochastic depth are left out (DQN-style learners train
//! without dropout).

use super::layers::{LayerNorm, linear_nd, matmul_nd, softmax_last};
use crate::Error;
use crate::config::SwinSizes;
use crate::params::{Linear, Params};
use candle_core::{D, DType, Device, Tensor};
use rand_chacha::ChaCha8Rng;

/// Window attention with a relative position bias table of `(2w-1)^2` rows per head.
#[derive(Debug, Clone)]
struct Attention {
    qkv: Linear,
    proj: Linear,
    table: Tensor,
    heads: usize,
    window: usize,
}

impl Attention {
    fn new(p: &mut Params, name: &str, dim: usize, heads: usize, window: usize, rng: &mut ChaCha8Rng) -> Result<Attention, Error> {
        let qkv = Linear::new(p, &format!("{name}.qkv"), dim, 3 * dim, rng)?;
        let proj = Linear::new(p, &format!("{name}.proj"), dim, dim, rng)?;
        // Swin draws the table from a truncated normal of std 0.02: uniform +-0.02 here.
        let rows = (2 * window - 1) * (2 * window - 1);
        let table = p.uniform(format!("{name}.relative_position_bias_table"), &[rows, heads], 2500, rng)?;
        Ok(Attention { qkv, proj, table, heads, window })
    }

    /// The `(heads, w*w, w*w)` bias of a window of side `w` (at most the configured one):
    /// the table is indexed by the relative offset of each pair of positions.
    fn bias(&self, w: usize) -> Result<Tensor, Error> {
        let big = 2 * self.window - 1;
        let mut idx = Vec::with_capacity(w.pow(4));
        for a in 0..w * w {
            for b in 0..w * w {
                let dy = (a / w) as i64 - (b / w) as i64 + self.window as i64 - 1;
                let dx = (a % w) as i64 - (b % w) as i64 + self.window as i64 - 1;
                idx.push((dy * big as i64 + dx) as u32);
            }
        }
        let idx = Tensor::from_vec(idx, w.pow(4), &Device::Cpu)?;
        Ok(self.table.index_select(&idx, 0)?.reshape((w * w, w * w, self.heads))?.permute((2, 0, 1))?.contiguous()?)
    }

    /// Windows `(B_, L, C)` -> `(B_, L, C)`; `mask` `(nW, L, L)` for shifted windows, whose
    /// windows are the fastest-varying part of `B_`.
    fn forward(&self, x: &Tensor, w: usize, mask: Option<&Tensor>) -> Result<Tensor, Error> {
        let (b, l, c) = x.dims3()?;
        let hd = c / self.heads;
        let qkv = linear_nd(&self.qkv, x)?.reshape((b, l, 3, self.heads, hd))?.permute((2, 0, 3, 1, 4))?;
        let q = (qkv.get(0)?.contiguous()? * (1.0 / (hd as f64).sqrt()))?;
        let k = qkv.get(1)?.contiguous()?;
        let v = qkv.get(2)?.contiguous()?;
        let mut attn = q.matmul(&k.t()?)?.broadcast_add(&self.bias(w)?.unsqueeze(0)?)?; // (B_, heads, L, L)
        if let Some(m) = mask {
            let nw = m.dim(0)?;
            attn = attn
                .reshape((b / nw, nw, self.heads, l, l))?
                .broadcast_add(&m.unsqueeze(1)?.unsqueeze(0)?)?
                .reshape((b, self.heads, l, l))?;
        }
        let out = softmax_last(&attn)?.matmul(&v)?.transpose(1, 2)?.reshape((b, l, c))?;
        linear_nd(&self.proj, &out)
    }
}

/// The attention mask of shifted windows over a padded `(h, w)` map: `-100` between
/// positions that came from different regions of the unshifted map, else 0.
fn shift_mask(h: usize, wd: usize, win: usize, shift: usize) -> Result<Tensor, Error> {
    let region = |x: usize, n: usize| -> usize {
        if x < n - win {
            0
        } else if x < n - shift {
            1
        } else {
            2
        }
    };
    let (nh, nw) = (h / win, wd / win);
    let l = win * win;
    let mut m = vec![0f32; nh * nw * l * l];
    for wy in 0..nh {
        for wx in 0..nw {
            let ids: Vec<usize> = (0..l).map(|i| region(wy * win + i / win, h) * 3 + region(wx * win + i % win, wd)).collect();
            let base = (wy * nw + wx) * l * l;
            for a in 0..l {
                for bb in 0..l {
                    if ids[a] != ids[bb] {
                        m[base + a * l + bb] = -100.0;
                    }
                }
            }
        }
    }
    Ok(Tensor::from_vec(m, (nh * nw, l, l), &Device::Cpu)?)
}

#[derive(Debug, Clone)]
struct Block {
    norm1: LayerNorm,
    attn: Attention,
    norm2: LayerNorm,
    fc1: Linear,
    fc2: Linear,
    window: usize,
    shifted: bool,
}

impl Block {
    fn new(
        p: &mut Params,
        name: &str,
        dim: usize,
        heads: usize,
        window: usize,
        shifted: bool,
        rng: &mut ChaCha8Rng,
    ) -> Result<Block, Error> {
        Ok(Block {
            norm1: p.layer_norm(&format!("{name}.norm1"), dim)?,
            attn: Attention::new(p, &format!("{name}.attn"), dim, heads, window, rng)?,
            norm2: p.layer_norm(&format!("{name}.norm2"), dim)?,
            fc1: Linear::new(p, &format!("{name}.mlp.0"), dim, 4 * dim, rng)?,
            fc2: Linear::new(p, &format!("{name}.mlp.3"), 4 * dim, dim, rng)?,
            window,
            shifted,
        })
    }

    /// `(N, H, W, C)` -> `(N, H, W, C)`.
    fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        let (n, h, wd, c) = x.dims4()?;
        // A map no larger than a window: one window of the map's size, not shifted.
        let (win, shift) =
            if h.min(wd) <= self.window { (h.min(wd), 0) } else { (self.window, if self.shifted { self.window / 2 } else { 0 }) };
        let (ph, pw) = (h.div_ceil(win) * win, wd.div_ceil(win) * win);
        let mut y = self.norm1.forward(x)?.pad_with_zeros(1, 0, ph - h)?.pad_with_zeros(2, 0, pw - wd)?;
        if shift > 0 {
            y = y.roll(-(shift as i32), 1)?.roll(-(shift as i32), 2)?;
        }
        let (nh, nw) = (ph / win, pw / win);
        let windows = y.reshape((n, nh, win, nw, win, c))?.permute((0, 1, 3, 2, 4, 5))?.reshape((n * nh * nw, win * win, c))?;
        let mask = if shift > 0 { Some(shift_mask(ph, pw, win, shift)?) } else { None };
        let out = self.attn.forward(&windows, win, mask.as_ref())?;
        let mut y = out.reshape((n, nh, nw, win, win, c))?.permute((0, 1, 3, 2, 4, 5))?.reshape((n, ph, pw, c))?;
        if shift > 0 {
            y = y.roll(shift as i32, 1)?.roll(shift as i32, 2)?;
        }
        let x = (x + y.narrow(1, 0, h)?.narrow(2, 0, wd)?)?;
        let m = linear_nd(&self.fc2, &linear_nd(&self.fc1, &self.norm2.forward(&x)?)?.gelu_erf()?)?;
        Ok((x + m)?)
    }
}

/// Concatenates each 2x2 neighbourhood (zero-padded to even sizes), norms, halves the width.
#[derive(Debug, Clone)]
struct Merge {
    norm: LayerNorm,
    reduction: Tensor,
}

impl Merge {
    fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        let (n, h, w, c) = x.dims4()?;
        let x = x.pad_with_zeros(1, 0, h % 2)?.pad_with_zeros(2, 0, w % 2)?;
        let (h2, w2) = (h.div_ceil(2), w.div_ceil(2));
        // (n, h2, dy, w2, dx, c) -> (n, h2, w2, dx, dy, c): torchvision's order x0, x1, x2, x3.
        let x = x.reshape((n, h2, 2, w2, 2, c))?.permute((0, 1, 3, 4, 2, 5))?.reshape((n, h2, w2, 4 * c))?;
        matmul_nd(&self.reduction, &self.norm.forward(&x)?)
    }
}

/// One Swin stream.
#[derive(Debug, Clone)]
pub struct SwinStream {
    patch: usize,
    embed: Linear,
    embed_norm: LayerNorm,
    stages: Vec<(Vec<Block>, Option<Merge>)>,
    norm: LayerNorm,
    /// Width of the pooled output.
    pub out: usize,
}

impl SwinStream {
    pub fn new(p: &mut Params, name: &str, s: &SwinSizes, rng: &mut ChaCha8Rng) -> Result<SwinStream, Error> {
        let embed = Linear::new(p, &format!("{name}.patch_embed"), 3 * s.patch * s.patch, s.embed_dim, rng)?;
        let embed_norm = p.layer_norm(&format!("{name}.patch_norm"), s.embed_dim)?;
        let mut stages = Vec::new();
        let mut dim = s.embed_dim;
        for (i, (&depth, &heads)) in s.depths.iter().zip(&s.heads).enumerate() {
            let blocks = (0..depth)
                .map(|j| Block::new(p, &format!("{name}.stage{i}.block{j}"), dim, heads, s.window, j % 2 == 1, rng))
                .collect::<Result<Vec<_>, _>>()?;
            let merge = if i + 1 < s.depths.len() {
                let m = Merge {
                    norm: p.layer_norm(&format!("{name}.stage{i}.merge.norm"), 4 * dim)?,
                    reduction: p.matrix(&format!("{name}.stage{i}.merge.reduction"), 4 * dim, 2 * dim, rng)?,
                };
                dim *= 2;
                Some(m)
            } else {
                None
            };
            stages.push((blocks, merge));
        }
        let norm = p.layer_norm(&format!("{name}.norm"), dim)?;
        Ok(SwinStream { patch: s.patch, embed, embed_norm, stages, norm, out: dim })
    }

    /// Images `(N, 3, H, W)` in [0, 1] -> `(N, out)`.
    pub fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        let (n, c, h, w) = x.dims4()?;
        let ps = self.patch;
        let (hp, wp) = (h.div_ceil(ps), w.div_ceil(ps));
        let x = x.pad_with_zeros(2, 0, hp * ps - h)?.pad_with_zeros(3, 0, wp * ps - w)?;
        // Patches as (C, ky, kx) vectors: a stride-`ps` convolution's input layout.
        let patches = x.reshape((n, c, hp, ps, wp, ps))?.permute((0, 2, 4, 1, 3, 5))?.reshape((n, hp, wp, c * ps * ps))?;
        let mut y = self.embed_norm.forward(&linear_nd(&self.embed, &patches)?)?;
        for (blocks, merge) in &self.stages {
            for b in blocks {
                y = b.forward(&y)?;
            }
            if let Some(m) = merge {
                y = m.forward(&y)?;
            }
        }
        let y = self.norm.forward(&y)?;
        let (_, hh, ww, cc) = y.dims4()?;
        Ok(y.reshape((n, hh * ww, cc))?.mean(D::Minus2)?.to_dtype(DType::F32)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shift_mask_separates_regions() -> Result<(), Error> {
        // A 4x4 map, window 2, shift 1: the last window mixes three regions.
        let m = shift_mask(4, 4, 2, 1)?;
        assert_eq!(m.dims(), &[4, 4, 4]);
        let first: Vec<f32> = m.get(0)?.flatten_all()?.to_vec1()?;
        assert!(first.iter().all(|&v| v == 0.0));
        let last: Vec<f32> = m.get(3)?.flatten_all()?.to_vec1()?;
        assert!(last.contains(&-100.0));
        Ok(())
    }
}
