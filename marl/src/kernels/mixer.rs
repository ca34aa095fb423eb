//! QMIX's mixer forward and backward by hand, on one flat parameter vector in the order of
//! [`crate::nets::QmixMixer`]'s variables:
//! `Q_tot = elu(q . |W1(s)| + b1(s)) . |Wf(s)| + V(s)`.
//!
//! Why by hand: the mixer runs on every `(step, episode)` row of every batch, twice (online
//! and target), and in candle each of its two dozen small operations is a fresh tensor and
//! a backward node; for the feed-forward QMIX the mixer cost as much as the agent network.
//! Here the four layers that read the state run as one product (their weights stacked),
//! the hypernetworks' second layers as one product each, and the per-row mixing as one
//! fused loop.
//!
//! Threads: rows are cut into a fixed number of chunks that depends on the row count alone,
//! each chunk's weight gradients summed in chunk order (as [`super::net`] does), so results
//! are the same bits whatever the number of threads.

use super::act::exp;
use super::gemm::{Mat, matmul};
use rayon::prelude::*;

/// The mixer's sizes (see `configs/qmix.toml`: `mixing_embed_dim`, `hypernet_layers`,
/// `hypernet_embed`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MixerLayout {
    pub n_agents: usize,
    pub state: usize,
    pub embed: usize,
    pub hyper_embed: usize,
    /// Hypernetworks of two layers (ReLU between) rather than one.
    pub two_layer: bool,
}

/// Where one linear layer's weight `(out, in)` and bias `(out)` sit.
#[derive(Clone, Copy, Debug)]
struct Lin {
    w: usize,
    b: usize,
    out: usize,
}

/// Offsets of every layer, in the variables' creation order.
#[derive(Clone, Copy, Debug)]
struct Offsets {
    /// The layers that read the state: `W1`'s first (or only) layer, `Wf`'s, `b1`, `V.0`.
    first: [Lin; 4],
    /// The hypernetworks' second layers (two-layer only): `W1`'s and `Wf`'s.
    second: Option<[Lin; 2]>,
    /// `V.2` (`1 x embed`).
    v1: Lin,
    end: usize,
}

impl MixerLayout {
    fn offsets(&self) -> Offsets {
        let (s, e, h, ae) = (self.state, self.embed, self.hyper_embed, self.n_agents * self.embed);
        let mut at = 0;
        let mut lin = |inp: usize, out: usize| {
            let l = Lin { w: at, b: at + out * inp, out };
            at += out * inp + out;
            l
        };
        if self.two_layer {
            let w1a = lin(s, h);
            let w1b = lin(h, ae);
            let wfa = lin(s, h);
            let wfb = lin(h, e);
            let b1 = lin(s, e);
            let v0 = lin(s, e);
            let v1 = lin(e, 1);
            Offsets { first: [w1a, wfa, b1, v0], second: Some([w1b, wfb]), v1, end: at }
        } else {
            let w1 = lin(s, ae);
            let wf = lin(s, e);
            let b1 = lin(s, e);
            let v0 = lin(s, e);
            let v1 = lin(e, 1);
            Offsets { first: [w1, wf, b1, v0], second: None, v1, end: at }
        }
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.offsets().end
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The stacked first layers' width, and where each layer's outputs start in it.
    fn first_width(&self, off: &Offsets) -> (usize, [usize; 4]) {
        let mut starts = [0; 4];
        let mut at = 0;
        for (s, l) in starts.iter_mut().zip(&off.first) {
            *s = at;
            at += l.out;
        }
        (at, starts)
    }

    fn chunks(n: usize) -> Vec<(usize, usize)> {
        const MIN_ROWS: usize = 64;
        const MAX_CHUNKS: usize = 8;
        let k = (n / MIN_ROWS).clamp(1, MAX_CHUNKS);
        (0..k).map(|c| (c * n / k, (c + 1) * n / k)).filter(|(a, b)| b > a).collect()
    }

    /// `Q_tot` `(N)` of the agents' Q-values `q` `(N, A)` and states `s` `(N, S)`; with `tape`,
    /// what [`MixerLayout::backward`] needs.
    pub fn forward(&self, theta: &[f32], q: &[f32], s: &[f32], n: usize, tape: bool) -> MixerForward {
        assert_eq!(theta.len(), self.len(), "mixer parameters");
        assert_eq!(q.len(), n * self.n_agents, "agent Q-values");
        assert_eq!(s.len(), n * self.state, "states");
        let off = self.offsets();
        let (zw, _) = self.first_width(&off);
        // The first layers' weights stacked into one `(Z, S)` matrix and one bias.
        let mut w_first = Vec::with_capacity(zw * self.state);
        let mut b_first = Vec::with_capacity(zw);
        for l in &off.first {
            w_first.extend_from_slice(&theta[l.w..l.w + l.out * self.state]);
            b_first.extend_from_slice(&theta[l.b..l.b + l.out]);
        }
        let chunks: Vec<MixChunk> = MixerLayout::chunks(n)
            .into_par_iter()
            .map(|(a, b)| {
                self.forward_chunk(
                    theta,
                    &off,
                    (&w_first, &b_first),
                    &q[a * self.n_agents..b * self.n_agents],
                    &s[a * self.state..b * self.state],
                    (a, b),
                    tape,
                )
            })
            .collect();
        let mut out = Vec::with_capacity(n);
        for c in &chunks {
            out.extend_from_slice(&c.out);
        }
        MixerForward { n, out, chunks: if tape { chunks } else { Vec::new() } }
    }

    #[allow(clippy::too_many_arguments)]
    fn forward_chunk(
        &self,
        theta: &[f32],
        off: &Offsets,
        (w_first, b_first): (&[f32], &[f32]),
        q: &[f32],
        s: &[f32],
        range: (usize, usize),
        tape: bool,
    ) -> MixChunk {
        let (a_n, e, st) = (self.n_agents, self.embed, self.state);
        let ae = a_n * e;
        let rows = range.1 - range.0;
        let (zw, starts) = self.first_width(off);
        let mut z = bias_rows(b_first, rows);
        matmul(&mut z, zw, Mat::rows(s, rows, st), Mat::t(w_first, st, zw), true);
        // ReLU on the hidden layers (two-layer hypernetworks' first layers, and V's).
        for row in z.chunks_exact_mut(zw) {
            if self.two_layer {
                relu(&mut row[starts[0]..starts[0] + off.first[0].out]);
                relu(&mut row[starts[1]..starts[1] + off.first[1].out]);
            }
            relu(&mut row[starts[3]..starts[3] + e]);
        }
        // The mixing weights before their absolute value: `(rows, A*E)` and `(rows, E)`.
        let (w1, wf) = match off.second {
            Some([l1, lf]) => {
                let h = self.hyper_embed;
                let mut w1 = bias_rows(&theta[l1.b..l1.b + ae], rows);
                matmul(&mut w1, ae, Mat::strided(&z[starts[0]..], rows, h, zw, 1), Mat::t(&theta[l1.w..l1.w + ae * h], h, ae), true);
                let mut wf = bias_rows(&theta[lf.b..lf.b + e], rows);
                matmul(&mut wf, e, Mat::strided(&z[starts[1]..], rows, h, zw, 1), Mat::t(&theta[lf.w..lf.w + e * h], h, e), true);
                (w1, wf)
            }
            None => {
                let mut w1 = Vec::with_capacity(rows * ae);
                let mut wf = Vec::with_capacity(rows * e);
                for row in z.chunks_exact(zw) {
                    w1.extend_from_slice(&row[starts[0]..starts[0] + ae]);
                    wf.extend_from_slice(&row[starts[1]..starts[1] + e]);
                }
                (w1, wf)
            }
        };
        let v1 = &theta[off.v1.w..off.v1.w + e];
        let bv1 = theta[off.v1.b];
        let mut hpre = vec![0f32; rows * e];
        let mut out = vec![0f32; rows];
        for r in 0..rows {
            let zr = &z[r * zw..(r + 1) * zw];
            let hp = &mut hpre[r * e..(r + 1) * e];
            hp.copy_from_slice(&zr[starts[2]..starts[2] + e]);
            for (ai, &qa) in q[r * a_n..(r + 1) * a_n].iter().enumerate() {
                let w = &w1[r * ae + ai * e..r * ae + (ai + 1) * e];
                hp.iter_mut().zip(w).for_each(|(h, &w)| *h += qa * w.abs());
            }
            let wfr = &wf[r * e..(r + 1) * e];
            let v0 = &zr[starts[3]..starts[3] + e];
            let mut total = bv1;
            for k in 0..e {
                total += elu(hp[k]) * wfr[k].abs() + v0[k] * v1[k];
            }
            out[r] = total;
        }
        if !tape {
            return MixChunk { range, out, ..MixChunk::default() };
        }
        MixChunk { range, out, s: s.to_vec(), q: q.to_vec(), z, w1, wf, hpre }
    }

    /// The gradients of a loss from its gradient `d_out` `(N)` with respect to `Q_tot`: the
    /// parameters' (summed into `grad`) and the agents' Q-values' `(N, A)` (returned).
    pub fn backward(&self, theta: &[f32], f: &MixerForward, d_out: &[f32], grad: &mut [f32]) -> Vec<f32> {
        assert!(!f.chunks.is_empty() || f.n == 0, "backward needs a forward pass run with a tape");
        assert_eq!(d_out.len(), f.n, "output gradients");
        assert_eq!(grad.len(), self.len(), "parameter gradients");
        let off = self.offsets();
        let parts: Vec<(Vec<f32>, Vec<f32>)> =
            f.chunks.par_iter().map(|c| self.backward_chunk(theta, &off, c, &d_out[c.range.0..c.range.1])).collect();
        let mut dq = Vec::with_capacity(f.n * self.n_agents);
        for (g, d) in &parts {
            grad.iter_mut().zip(g).for_each(|(a, b)| *a += b);
            dq.extend_from_slice(d);
        }
        dq
    }

    fn backward_chunk(&self, theta: &[f32], off: &Offsets, c: &MixChunk, d_out: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let (a_n, e, st) = (self.n_agents, self.embed, self.state);
        let ae = a_n * e;
        let rows = c.range.1 - c.range.0;
        let (zw, starts) = self.first_width(off);
        let mut g = vec![0f32; self.len()];
        let v1 = &theta[off.v1.w..off.v1.w + e];
        // Gradients of the stacked first layers' outputs (pre-activation), and of the
        // mixing weights before their absolute value.
        let mut dz = vec![0f32; rows * zw];
        let mut dw1 = vec![0f32; rows * ae];
        let mut dwf = vec![0f32; rows * e];
        let mut dq = vec![0f32; rows * a_n];
        let (mut gv1, mut gbv1) = (vec![0f32; e], 0f32);
        let mut dh = vec![0f32; e];
        for r in 0..rows {
            let d = d_out[r];
            let zr = &c.z[r * zw..(r + 1) * zw];
            let hp = &c.hpre[r * e..(r + 1) * e];
            let wfr = &c.wf[r * e..(r + 1) * e];
            let dzr = &mut dz[r * zw..(r + 1) * zw];
            // Q_tot = elu(h) . |wf| + v0 . v1 + bv1.
            gbv1 += d;
            for k in 0..e {
                let y = elu(hp[k]);
                dwf[r * e + k] = d * y * sign(wfr[k]);
                let delu = if hp[k] > 0.0 { 1.0 } else { y + 1.0 };
                dh[k] = d * wfr[k].abs() * delu;
                let v0 = zr[starts[3] + k];
                gv1[k] += d * v0;
                dzr[starts[3] + k] = if v0 > 0.0 { d * v1[k] } else { 0.0 };
                // b1 enters h directly.
                dzr[starts[2] + k] = dh[k];
            }
            // h = b1 + sum_a q_a |w1_a|.
            for ai in 0..a_n {
                let qa = c.q[r * a_n + ai];
                let w = &c.w1[r * ae + ai * e..r * ae + (ai + 1) * e];
                let dw = &mut dw1[r * ae + ai * e..r * ae + (ai + 1) * e];
                let mut acc = 0f32;
                for k in 0..e {
                    acc += dh[k] * w[k].abs();
                    dw[k] = dh[k] * qa * sign(w[k]);
                }
                dq[r * a_n + ai] = acc;
            }
        }
        g[off.v1.w..off.v1.w + e].copy_from_slice(&gv1);
        g[off.v1.b] = gbv1;
        match off.second {
            Some([l1, lf]) => {
                let h = self.hyper_embed;
                // Second layers: weights from the hidden activations, then back through them.
                matmul(&mut g[l1.w..l1.w + ae * h], h, Mat::t(&dw1, ae, rows), Mat::strided(&c.z[starts[0]..], rows, h, zw, 1), false);
                col_sums(&dw1, ae, &mut g[l1.b..l1.b + ae]);
                matmul(&mut g[lf.w..lf.w + e * h], h, Mat::t(&dwf, e, rows), Mat::strided(&c.z[starts[1]..], rows, h, zw, 1), false);
                col_sums(&dwf, e, &mut g[lf.b..lf.b + e]);
                let mut du = vec![0f32; rows * h];
                matmul(&mut du, h, Mat::rows(&dw1, rows, ae), Mat::rows(&theta[l1.w..l1.w + ae * h], ae, h), false);
                put_relu_grad(&mut dz, zw, starts[0], &du, h, &c.z);
                matmul(&mut du, h, Mat::rows(&dwf, rows, e), Mat::rows(&theta[lf.w..lf.w + e * h], e, h), false);
                put_relu_grad(&mut dz, zw, starts[1], &du, h, &c.z);
            }
            None => {
                for r in 0..rows {
                    dz[r * zw + starts[0]..r * zw + starts[0] + ae].copy_from_slice(&dw1[r * ae..(r + 1) * ae]);
                    dz[r * zw + starts[1]..r * zw + starts[1] + e].copy_from_slice(&dwf[r * e..(r + 1) * e]);
                }
            }
        }
        // The stacked first layers: each layer's block of rows of `dz^T s`.
        let mut gw = vec![0f32; zw * st];
        matmul(&mut gw, st, Mat::t(&dz, zw, rows), Mat::rows(&c.s, rows, st), false);
        let mut gb = vec![0f32; zw];
        col_sums(&dz, zw, &mut gb);
        for (l, &start) in off.first.iter().zip(&starts) {
            g[l.w..l.w + l.out * st].copy_from_slice(&gw[start * st..(start + l.out) * st]);
            g[l.b..l.b + l.out].copy_from_slice(&gb[start..start + l.out]);
        }
        (g, dq)
    }
}

/// One forward pass's results.
#[derive(Debug, Default)]
pub struct MixerForward {
    pub n: usize,
    /// `Q_tot`, `(N)`.
    pub out: Vec<f32>,
    chunks: Vec<MixChunk>,
}

#[derive(Debug, Default)]
struct MixChunk {
    range: (usize, usize),
    out: Vec<f32>,
    s: Vec<f32>,
    q: Vec<f32>,
    /// The stacked first layers' outputs, after their ReLUs.
    z: Vec<f32>,
    /// The mixing weights before their absolute value.
    w1: Vec<f32>,
    wf: Vec<f32>,
    /// The mixing layer's pre-activation.
    hpre: Vec<f32>,
}

/// `dz[:, start..start + w] = du * [z > 0]` (the ReLU of a hidden layer, from its output).
fn put_relu_grad(dz: &mut [f32], zw: usize, start: usize, du: &[f32], w: usize, z: &[f32]) {
    for ((dr, ur), zr) in dz.chunks_exact_mut(zw).zip(du.chunks_exact(w)).zip(z.chunks_exact(zw)) {
        for ((d, &u), &zv) in dr[start..start + w].iter_mut().zip(ur).zip(&zr[start..start + w]) {
            *d = if zv > 0.0 { u } else { 0.0 };
        }
    }
}

/// candle's `elu` with alpha 1.
#[inline(always)]
fn elu(x: f32) -> f32 {
    if x > 0.0 { x } else { exp(x) - 1.0 }
}

/// The derivative of `|x|` as candle takes it: 1 at and above 0, -1 below.
#[inline(always)]
fn sign(x: f32) -> f32 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

fn relu(x: &mut [f32]) {
    x.iter_mut().for_each(|v| *v = v.max(0.0));
}

fn bias_rows(b: &[f32], rows: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(rows * b.len());
    for _ in 0..rows {
        out.extend_from_slice(b);
    }
    out
}

fn col_sums(m: &[f32], w: usize, out: &mut [f32]) {
    for row in m.chunks_exact(w) {
        out.iter_mut().zip(row).for_each(|(o, &v)| *o += v);
    }
}
