//! PyMARL's agent network (`fc1 -> ReLU -> GRUCell -> fc2`, or the feed-forward
//! `fc1 -> ReLU -> Linear -> ReLU -> fc2`) forward and backward over `L` steps of `N`
//! sequences, by hand, on one flat parameter vector; or the MAPPO repository's form of either
//! (`norm`): the inputs and every hidden layer's output layer-normalised, and the recurrent
//! one with a second hidden layer before its GRU (`LN -> fc1 -> ReLU -> LN -> fc -> ReLU ->
//! LN -> GRU -> LN -> fc2`; feed-forward: `LN -> fc1 -> ReLU -> LN -> Linear -> ReLU -> LN ->
//! fc2`).
//!
//! Why not candle's autograd: the GRU runs one step at a time, and candle builds and walks a
//! graph of about twenty tensors per step (each a fresh allocation), then a backward op per
//! node. Here a step is one matrix product and one fused elementwise loop, the products that
//! do not depend on the hidden state run over all steps at once, and the backward pass
//! needs no graph: the tape holds the gates.
//!
//! Threads: the `N` sequences are cut into a fixed number of chunks that depends on `N`
//! alone; each chunk runs its whole forward and backward pass on its own (sequences are
//! independent) on any thread, and the chunks' weight gradients are summed in chunk order.
//! So the results are the same bits whatever the number of threads.
//!
//! Checked against candle's autograd (the crate's reference networks, [`crate::nets`]) by
//! the tests below.

use super::act::{sigmoid, simd, tanh};
use super::chunk_in::ChunkIn;
use super::gemm::{Mat, matmul};
use super::norm::{NormTape, norm_backward_at, norm_forward};
use super::pack::{NONE, Packing, Want};
use rayon::prelude::*;

/// The network's sizes and where each parameter sits in the flat vector, in the order of
/// [`crate::nets::AgentNet`]'s variables (so a flat vector is their concatenation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NetLayout {
    pub input: usize,
    pub hidden: usize,
    pub out: usize,
    pub recurrent: bool,
    /// The MAPPO repository's layer-normalised form (see the module docs).
    pub norm: bool,
}

/// Offsets of the parameters. A layer norm's scale sits at its offset, its shift right after.
#[derive(Clone, Copy, Debug)]
struct Offsets {
    /// The inputs' layer norm (`norm` only).
    ln_in: usize,
    /// The layer norm after `fc1`'s ReLU (`norm` only).
    ln1: usize,
    /// The recurrent `norm` form's second hidden layer: weight, bias right after, its norm.
    mid: usize,
    ln_mid: usize,
    /// After the core: the GRU's hidden state's norm, or the feed-forward core's (`norm` only).
    ln2: usize,
    w1: usize,
    b1: usize,
    /// GRU: `w_ih`; feed-forward: the core layer's weight.
    wi: usize,
    /// GRU: `w_hh`; feed-forward: the core layer's bias.
    wh: usize,
    bi: usize,
    bh: usize,
    w2: usize,
    b2: usize,
    end: usize,
}

impl NetLayout {
    fn offsets(&self) -> Offsets {
        let (i, h, o) = (self.input, self.hidden, self.out);
        let mut end = 0;
        let mut take = |n: usize| {
            end += n;
            end - n
        };
        let ln_in = if self.norm { take(2 * i) } else { 0 };
        let w1 = take(h * i);
        let b1 = take(h);
        let ln1 = if self.norm { take(2 * h) } else { 0 };
        let (mid, ln_mid) = if self.norm && self.recurrent { (take(h * h + h), take(2 * h)) } else { (0, 0) };
        let (wi, wh, bi, bh) = if self.recurrent {
            (take(3 * h * h), take(3 * h * h), take(3 * h), take(3 * h))
        } else {
            // The core's weight, and its bias where the GRU's `w_hh` would be.
            let (wi, wh) = (take(h * h), take(h));
            (wi, wh, wh, wh)
        };
        let ln2 = if self.norm { take(2 * h) } else { 0 };
        let w2 = take(o * h);
        let b2 = take(o);
        Offsets { ln_in, ln1, mid, ln_mid, ln2, w1, b1, wi, wh, bi, bh, w2, b2, end: take(0) }
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.offsets().end
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The chunks `N` sequences are cut into: a function of `N` only (see the module docs).
    fn chunks(n: usize) -> Vec<(usize, usize)> {
        const MIN_ROWS: usize = 24;
        const MAX_CHUNKS: usize = 8;
        let k = (n / MIN_ROWS).clamp(1, MAX_CHUNKS);
        (0..k).map(|c| (c * n / k, (c + 1) * n / k)).filter(|(a, b)| b > a).collect()
    }

    /// How many chunks `n` sequences are cut into.
    pub fn chunk_count(n: usize) -> usize {
        NetLayout::chunks(n).len()
    }

    /// Runs the network over `l` steps of `n` sequences: `x` `(L, N, input)` time-major,
    /// `h0` `(N, hidden)` (ignored by the feed-forward network), `keep` `(L, N)` (0 where an
    /// episode starts at that step, resetting the hidden state; `None`: never). With `tape`,
    /// keeps what [`NetLayout::backward`] needs. `want`: the rows the caller reads (all, or
    /// not the padding past `lens`, or not those a mask leaves out). The others are skipped
    /// where no row read depends on them (see [`Want`]): their outputs are 0 and their
    /// gradients ignored, so padding and dead agents cost nothing.
    #[allow(clippy::too_many_arguments)]
    pub fn forward(
        &self,
        theta: &[f32],
        x: &[f32],
        h0: &[f32],
        keep: Option<&[f32]>,
        want: Want<'_>,
        l: usize,
        n: usize,
        tape: bool,
    ) -> Forward {
        self.forward_input(theta, Input::Rows(x), h0, keep, want, l, n, tape)
    }

    /// [`NetLayout::forward`] on inputs given as [`Input`] (rows, or rows that share a table).
    #[allow(clippy::too_many_arguments)]
    pub fn forward_input(
        &self,
        theta: &[f32],
        x: Input<'_>,
        h0: &[f32],
        keep: Option<&[f32]>,
        want: Want<'_>,
        l: usize,
        n: usize,
        tape: bool,
    ) -> Forward {
        assert_eq!(theta.len(), self.len(), "parameters");
        x.check(self.input, l * n);
        if self.recurrent {
            assert_eq!(h0.len(), n * self.hidden, "initial hidden states");
        }
        if let Some(k) = keep {
            assert_eq!(k.len(), l * n, "episode-start mask");
        }
        want.check(l, n);
        let chunks: Vec<Chunk> = NetLayout::chunks(n)
            .into_par_iter()
            .map(|(c0, c1)| {
                let pack = Packing::new(want, keep, self.recurrent, l, n, (c0, c1));
                let xs = match x {
                    Input::Rows(x) => ChunkIn::Rows(pack.gather(x, n, self.input, c0)),
                    Input::Shared { table, width, idx, ids } => {
                        ChunkIn::shared(table, width, &pack.gather(idx, n, 1, c0), pack.gather(ids, n, 1, c0))
                    }
                };
                let h0 = if self.recurrent { &h0[c0 * self.hidden..c1 * self.hidden] } else { &[][..] };
                let keep = keep.map(|k| pack.gather(k, n, 1, c0));
                self.forward_chunk(theta, xs, h0, keep, pack, tape, (c0, c1))
            })
            .collect();
        let mut out = vec![0f32; l * n * self.out];
        for c in &chunks {
            c.pack.scatter(&mut out, &c.out, n, self.out, c.range.0);
        }
        // Training reads the outputs only: the hidden states are written out without a tape
        // (acting), and on request with one.
        let mut f = Forward { l, n, width: self.hidden, out, hidden: Vec::new(), chunks };
        if !tape {
            f.hidden = f.hidden_states();
            f.chunks = Vec::new();
        }
        f
    }

    /// The layers before the core, on a chunk's `rows` rows: `a1 = relu(x W1^T + b1)`, and in
    /// the `norm` form the inputs' norm before it, its own norm after (`a1r` keeps the ReLU's
    /// output) and, recurrent, the second hidden layer (`am`, the GRU's input).
    fn front(&self, theta: &[f32], x: ChunkIn, rows: usize, c: &mut Chunk) {
        let (i, h) = (self.input, self.hidden);
        let off = self.offsets();
        let p = |a: usize, len: usize| &theta[a..a + len];
        let norm = |v: &mut Vec<f32>, width: usize, at: usize| norm_forward(v, width, p(at, width), p(at + width, width));
        // The normalised form reads each row whole (a shared table's rows are written out).
        let x = if self.norm {
            let mut rows_x = x.into_rows(i);
            c.n_in = norm(&mut rows_x, i, off.ln_in);
            ChunkIn::Rows(rows_x)
        } else {
            x
        };
        let mut a1 = bias_rows(p(off.b1, h), rows);
        x.first_layer(&mut a1, p(off.w1, h * i), i, h);
        relu(&mut a1);
        if self.norm {
            c.a1r = a1.clone();
            c.n1 = norm(&mut a1, h, off.ln1);
        }
        if self.norm && self.recurrent {
            let mut am = bias_rows(p(off.mid + h * h, h), rows);
            matmul(&mut am, h, Mat::rows(&a1, rows, h), Mat::t(p(off.mid, h * h), h, h), true);
            relu(&mut am);
            c.amr = am.clone();
            c.n_mid = norm(&mut am, h, off.ln_mid);
            c.am = am;
        }
        c.x = x;
        c.a1 = a1;
    }

    /// The gradients of [`NetLayout::front`]'s layers from `da1`, the gradient with respect to
    /// `a1`, into `g`; the inputs' gradient with `want_dx`.
    fn front_backward(&self, theta: &[f32], c: &Chunk, mut da1: Vec<f32>, g: &mut [f32], want_dx: bool) -> Option<Vec<f32>> {
        let (i, h) = (self.input, self.hidden);
        let off = self.offsets();
        let rows = c.pack.rows();
        let p = |a: usize, len: usize| &theta[a..a + len];
        if self.norm {
            norm_backward_at(theta, &mut da1, &c.n1, h, off.ln1, g);
            relu_grad(&mut da1, &c.a1r);
        } else {
            relu_grad(&mut da1, &c.a1);
        }
        c.x.first_layer_grad(&mut g[off.w1..off.w1 + h * i], &da1, i, h);
        col_sums(&da1, h, &mut g[off.b1..off.b1 + h]);
        // The inputs' norm has parameters: its gradient is needed whether or not the inputs' is.
        let dx = (want_dx || self.norm).then(|| {
            let mut dx = vec![0f32; rows * i];
            matmul(&mut dx, i, Mat::rows(&da1, rows, h), Mat::rows(p(off.w1, h * i), h, i), false);
            if self.norm {
                norm_backward_at(theta, &mut dx, &c.n_in, i, off.ln_in, g);
            }
            dx
        });
        dx.filter(|_| want_dx)
    }

    /// One chunk's pass on its packed rows.
    #[allow(clippy::too_many_arguments)]
    fn forward_chunk(
        &self,
        theta: &[f32],
        x: ChunkIn,
        h0: &[f32],
        keep: Option<Vec<f32>>,
        pack: Packing,
        tape: bool,
        range: (usize, usize),
    ) -> Chunk {
        let (h, o) = (self.hidden, self.out);
        let off = self.offsets();
        let nc = range.1 - range.0;
        let rows = pack.rows();
        let p = |a: usize, len: usize| &theta[a..a + len];
        let norm = |v: &mut Vec<f32>, width: usize, at: usize| norm_forward(v, width, p(at, width), p(at + width, width));
        let mut c = Chunk { range, ..Chunk::default() };
        self.front(theta, x, rows, &mut c);
        let steps = &pack.steps;
        if self.recurrent {
            let h3 = 3 * h;
            let gru_in = if self.norm { &c.am } else { &c.a1 };
            // The input side of every step at once: gi = a1 W_ih^T + b_ih.
            let mut gi = bias_rows(p(off.bi, h3), rows);
            matmul(&mut gi, h3, Mat::rows(gru_in, rows, h), Mat::t(p(off.wi, h3 * h), h, h3), true);
            let w_hh = Mat::t(p(off.wh, h3 * h), h, h3);
            let b_hh = p(off.bh, h3);
            let mut hs = vec![0f32; rows * h];
            // The gates of every step with a tape, of the current step only without.
            let kept = if tape { rows * h } else { nc * h };
            let (mut hp_all, mut r_all, mut z_all, mut n_all, mut ghn_all) =
                (vec![0f32; kept], vec![0f32; kept], vec![0f32; kept], vec![0f32; kept], vec![0f32; kept]);
            let mut hp = vec![0f32; nc * h];
            let mut gh = vec![0f32; nc * h3];
            for (t, &(base, cnt)) in steps.iter().enumerate() {
                let hp = &mut hp[..cnt * h];
                for (k, row) in hp.chunks_exact_mut(h.max(1)).enumerate() {
                    let r = base + k;
                    if t == 0 {
                        let s = pack.seqs[r] as usize;
                        row.copy_from_slice(&h0[s * h..(s + 1) * h]);
                        continue;
                    }
                    // A row whose step before was skipped starts an episode (see `Packing`).
                    let q = pack.prev[r];
                    let kv = if q == NONE { 0.0 } else { keep.as_deref().map_or(1.0, |k| k[r]) };
                    if kv == 0.0 {
                        row.fill(0.0);
                    } else {
                        let q = q as usize;
                        row.copy_from_slice(&hs[q * h..(q + 1) * h]);
                        if kv != 1.0 {
                            row.iter_mut().for_each(|v| *v *= kv);
                        }
                    }
                }
                let gh = &mut gh[..cnt * h3];
                for row in gh.chunks_exact_mut(h3) {
                    row.copy_from_slice(b_hh);
                }
                matmul(gh, h3, Mat::rows(hp, cnt, h), w_hh, true);
                let at = if tape { base * h } else { 0 };
                pulp::Arch::new().dispatch(GatesForward {
                    h,
                    gi: &gi[base * h3..(base + cnt) * h3],
                    gh,
                    hp,
                    hs: &mut hs[base * h..(base + cnt) * h],
                    r: &mut r_all[at..at + cnt * h],
                    z: &mut z_all[at..at + cnt * h],
                    n: &mut n_all[at..at + cnt * h],
                    ghn: &mut ghn_all[at..at + cnt * h],
                });
                hp_all[at..at + cnt * h].copy_from_slice(hp);
            }
            c.hs = hs;
            c.hp = hp_all;
            c.r = r_all;
            c.z = z_all;
            c.n = n_all;
            c.ghn = ghn_all;
            c.keep = keep;
        } else {
            let mut a2 = bias_rows(p(off.wh, h), rows);
            matmul(&mut a2, h, Mat::rows(&c.a1, rows, h), Mat::t(p(off.wi, h * h), h, h), true);
            relu(&mut a2);
            if self.norm {
                c.hr = a2.clone();
                c.n2 = norm(&mut a2, h, off.ln2);
            }
            c.hs = a2;
        }
        // The recurrent `norm` form's output layer reads the normalised hidden state; the
        // state carried on is the GRU's own.
        if self.norm && self.recurrent {
            let mut ho = c.hs.clone();
            c.n2 = norm(&mut ho, h, off.ln2);
            c.ho = ho;
        }
        let head_in = if self.norm && self.recurrent { &c.ho } else { &c.hs };
        let mut out = bias_rows(p(off.b2, o), rows);
        matmul(&mut out, o, Mat::rows(head_in, rows, h), Mat::t(p(off.w2, o * h), h, o), true);
        c.out = out;
        c.pack = pack;
        if !tape {
            let hs = std::mem::take(&mut c.hs);
            c = Chunk { range: c.range, pack: c.pack, out: c.out, hs, ..Chunk::default() };
        }
        c
    }

    /// Gradients of a loss from its gradients `d_out` `(L, N, out)` with respect to the
    /// outputs (and `d_hidden` `(L, N, hidden)`, to the hidden states, if the loss reads
    /// them): the parameters' gradient (summed into `grad`), and with `want_dx` the inputs'.
    pub fn backward(
        &self,
        theta: &[f32],
        f: &Forward,
        d_out: &[f32],
        d_hidden: Option<&[f32]>,
        grad: &mut [f32],
        want_dx: bool,
    ) -> Option<Vec<f32>> {
        assert!(!f.chunks.is_empty() || f.n == 0, "backward needs a forward pass run with a tape");
        assert_eq!(d_out.len(), f.l * f.n * self.out, "output gradients");
        assert_eq!(grad.len(), self.len(), "parameter gradients");
        let (l, n) = (f.l, f.n);
        let parts: Vec<(Vec<f32>, Option<Vec<f32>>)> = f
            .chunks
            .par_iter()
            .map(|c| {
                let dout = c.pack.gather(d_out, n, self.out, c.range.0);
                let dh = d_hidden.map(|d| c.pack.gather(d, n, self.hidden, c.range.0));
                self.backward_chunk(theta, c, dout, dh, want_dx)
            })
            .collect();
        let mut dx = want_dx.then(|| vec![0f32; l * n * self.input]);
        for ((g, cdx), c) in parts.iter().zip(&f.chunks) {
            grad.iter_mut().zip(g).for_each(|(a, b)| *a += b);
            if let (Some(dx), Some(cdx)) = (dx.as_mut(), cdx) {
                c.pack.scatter(dx, cdx, n, self.input, c.range.0);
            }
        }
        dx
    }

    fn backward_chunk(
        &self,
        theta: &[f32],
        c: &Chunk,
        dout: Vec<f32>,
        dh_extra: Option<Vec<f32>>,
        want_dx: bool,
    ) -> (Vec<f32>, Option<Vec<f32>>) {
        let (h, o) = (self.hidden, self.out);
        let off = self.offsets();
        let nc = c.range.1 - c.range.0;
        let rows = c.pack.rows();
        let p = |a: usize, len: usize| &theta[a..a + len];
        let mut g = vec![0f32; self.len()];
        // Output layer.
        let normed_state = self.norm && self.recurrent;
        let head_in = if normed_state { &c.ho } else { &c.hs };
        matmul(&mut g[off.w2..off.w2 + o * h], h, Mat::t(&dout, o, rows), Mat::rows(head_in, rows, h), false);
        col_sums(&dout, o, &mut g[off.b2..off.b2 + o]);
        // The loss's own gradient on the hidden states joins after the state's norm, if any.
        let (mut dhs, extra) =
            if normed_state { (vec![0f32; rows * h], dh_extra) } else { (dh_extra.unwrap_or_else(|| vec![0f32; rows * h]), None) };
        matmul(&mut dhs, h, Mat::rows(&dout, rows, o), Mat::rows(p(off.w2, o * h), o, h), true);
        if normed_state {
            norm_backward_at(theta, &mut dhs, &c.n2, h, off.ln2, &mut g);
            if let Some(extra) = &extra {
                dhs.iter_mut().zip(extra).for_each(|(a, b)| *a += b);
            }
        }
        // d(pre-activation of a1).
        let mut da1 = vec![0f32; rows * h];
        if self.recurrent {
            let h3 = 3 * h;
            let mut dgi = vec![0f32; rows * h3];
            let mut dgh = vec![0f32; rows * h3];
            let w_hh = Mat::rows(p(off.wh, h3 * h), h3, h);
            let mut carry = vec![0f32; nc * h];
            let mut dhp = vec![0f32; nc * h];
            let steps = &c.pack.steps;
            for t in (0..steps.len()).rev() {
                let (base, cnt) = steps[t];
                let (a, b) = (base * h, (base + cnt) * h);
                let dhp = &mut dhp[..cnt * h];
                pulp::Arch::new().dispatch(GatesBackward {
                    h,
                    dh: &dhs[a..b],
                    carry: &carry[..cnt * h],
                    tape: [&c.r[a..b], &c.z[a..b], &c.n[a..b], &c.ghn[a..b], &c.hp[a..b]],
                    dgi: &mut dgi[base * h3..(base + cnt) * h3],
                    dgh: &mut dgh[base * h3..(base + cnt) * h3],
                    dhp,
                });
                if t == 0 {
                    break;
                }
                matmul(dhp, h, Mat::rows(&dgh[base * h3..(base + cnt) * h3], cnt, h3), w_hh, true);
                let keep = c.keep.as_deref();
                // Each row's gradient goes to its sequence's row at the step before, if computed;
                // the rows there with no row after them get none.
                let pbase = steps[t - 1].0;
                carry[..steps[t - 1].1 * h].fill(0.0);
                simd(|| {
                    for (k, dr) in dhp.chunks_exact(h).enumerate() {
                        let q = c.pack.prev[base + k];
                        if q == NONE {
                            continue;
                        }
                        let kv = keep.map_or(1.0, |kp| kp[base + k]);
                        let at = (q as usize - pbase) * h;
                        carry[at..at + h].iter_mut().zip(dr).for_each(|(c, &d)| *c = kv * d);
                    }
                });
            }
            matmul(&mut g[off.wh..off.wh + h3 * h], h, Mat::t(&dgh, h3, rows), Mat::rows(&c.hp, rows, h), false);
            col_sums(&dgh, h3, &mut g[off.bh..off.bh + h3]);
            let gru_in = if self.norm { &c.am } else { &c.a1 };
            matmul(&mut g[off.wi..off.wi + h3 * h], h, Mat::t(&dgi, h3, rows), Mat::rows(gru_in, rows, h), false);
            col_sums(&dgi, h3, &mut g[off.bi..off.bi + h3]);
            if self.norm {
                // am = norm(relu(a1 Wm^T + bm)).
                let mut dam = vec![0f32; rows * h];
                matmul(&mut dam, h, Mat::rows(&dgi, rows, h3), Mat::rows(p(off.wi, h3 * h), h3, h), false);
                norm_backward_at(theta, &mut dam, &c.n_mid, h, off.ln_mid, &mut g);
                relu_grad(&mut dam, &c.amr);
                matmul(&mut g[off.mid..off.mid + h * h], h, Mat::t(&dam, h, rows), Mat::rows(&c.a1, rows, h), false);
                col_sums(&dam, h, &mut g[off.mid + h * h..off.mid + h * h + h]);
                matmul(&mut da1, h, Mat::rows(&dam, rows, h), Mat::rows(p(off.mid, h * h), h, h), false);
            } else {
                matmul(&mut da1, h, Mat::rows(&dgi, rows, h3), Mat::rows(p(off.wi, h3 * h), h3, h), false);
            }
        } else {
            // hs = relu(a1 Wc^T + bc) (normalised in the `norm` form): dhs through both.
            if self.norm {
                norm_backward_at(theta, &mut dhs, &c.n2, h, off.ln2, &mut g);
                relu_grad(&mut dhs, &c.hr);
            } else {
                relu_grad(&mut dhs, &c.hs);
            }
            matmul(&mut g[off.wi..off.wi + h * h], h, Mat::t(&dhs, h, rows), Mat::rows(&c.a1, rows, h), false);
            col_sums(&dhs, h, &mut g[off.wh..off.wh + h]);
            matmul(&mut da1, h, Mat::rows(&dhs, rows, h), Mat::rows(p(off.wi, h * h), h, h), false);
        }
        let dx = self.front_backward(theta, c, da1, &mut g, want_dx);
        (g, dx)
    }
}

/// One forward pass's results, time-major `(L, N, ·)`.
#[derive(Debug, Default)]
pub struct Forward {
    pub l: usize,
    pub n: usize,
    /// The hidden state's width.
    width: usize,
    /// `(L, N, out)`.
    pub out: Vec<f32>,
    /// `(L, N, hidden)`: the GRU's hidden states (feed-forward: the core layer's output), from
    /// a pass without a tape; with one, see [`Forward::hidden_states`].
    pub hidden: Vec<f32>,
    chunks: Vec<Chunk>,
}

impl Forward {
    /// The hidden states `(L, N, hidden)` of a pass run with a tape (0 on skipped rows).
    pub fn hidden_states(&self) -> Vec<f32> {
        let mut hidden = vec![0f32; self.l * self.n * self.width];
        for c in &self.chunks {
            c.pack.scatter(&mut hidden, &c.hs, self.n, self.width, c.range.0);
        }
        hidden
    }
}

/// One chunk's pass, its rows packed (see [`Packing`]).
#[derive(Debug, Default)]
struct Chunk {
    range: (usize, usize),
    pack: Packing,
    x: ChunkIn,
    a1: Vec<f32>,
    hs: Vec<f32>,
    out: Vec<f32>,
    /// The `norm` form's tapes: the inputs' norm, `fc1`'s ReLU output and norm, the second
    /// hidden layer's (its ReLU output, norm, normalised output), the core's norm (with the
    /// feed-forward core's ReLU output `hr`, or the GRU's normalised state `ho`).
    n_in: NormTape,
    a1r: Vec<f32>,
    n1: NormTape,
    amr: Vec<f32>,
    n_mid: NormTape,
    am: Vec<f32>,
    n2: NormTape,
    hr: Vec<f32>,
    ho: Vec<f32>,
    hp: Vec<f32>,
    r: Vec<f32>,
    z: Vec<f32>,
    n: Vec<f32>,
    ghn: Vec<f32>,
    keep: Option<Vec<f32>>,
}

/// The first layer's input.
#[derive(Clone, Copy, Debug)]
pub enum Input<'a> {
    /// `(L, N, input)`, time-major.
    Rows(&'a [f32]),
    /// Row `r` of `(L, N)` is `table[idx[r]]` (`width` values) followed by the one-hot of
    /// `ids[r]` (`input - width` wide). MAPPO's critic reads this way: every agent of an
    /// environment step sees the one global state with its own id. Taking the rows so, the
    /// first layer multiplies each table row once however many rows read it (an environment's
    /// agents: 23 on pvz_ht), and the `(L, N, input)` copy of the state never exists.
    Shared { table: &'a [f32], width: usize, idx: &'a [u32], ids: &'a [u32] },
}

impl Input<'_> {
    /// Panics (a caller's bug) unless these are `rows` rows of `input` values.
    fn check(&self, input: usize, rows: usize) {
        match *self {
            Input::Rows(x) => assert_eq!(x.len(), rows * input, "inputs"),
            Input::Shared { table, width, idx, ids } => {
                assert!(width <= input, "a table {width} wide for inputs {input} wide");
                assert_eq!((idx.len(), ids.len()), (rows, rows), "table indices and ids of {rows} rows");
                let stored = table.len() / width.max(1);
                assert_eq!(table.len(), stored * width, "a table of rows {width} wide");
                assert!(idx.iter().all(|&i| (i as usize) < stored), "a table index past the table's {stored} rows");
                assert!(ids.iter().all(|&i| (i as usize) < input - width), "an id past the {} one-hot columns", input - width);
            }
        }
    }
}

fn bias_rows(b: &[f32], rows: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(rows * b.len());
    for _ in 0..rows {
        out.extend_from_slice(b);
    }
    out
}

fn relu(x: &mut [f32]) {
    simd(|| x.iter_mut().for_each(|v| *v = v.max(0.0)));
}

/// One GRU step's gates for `nc` rows (PyTorch's `GRUCell`): `gi` and `gh` the input and
/// hidden projections `(nc, 3h)` (biases in), `hp` the previous hidden state. A struct (not a
/// closure) so that its loop is inlined into, and vectorised for, `dispatch`'s target.
struct GatesForward<'a> {
    h: usize,
    gi: &'a [f32],
    gh: &'a [f32],
    hp: &'a [f32],
    hs: &'a mut [f32],
    r: &'a mut [f32],
    z: &'a mut [f32],
    n: &'a mut [f32],
    ghn: &'a mut [f32],
}

impl pulp::WithSimd for GatesForward<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let GatesForward { h, gi, gh, hp, hs, r, z, n, ghn } = self;
        let h3 = 3 * h;
        for row in 0..hs.len() / h.max(1) {
            let (gir, ghr) = (&gi[row * h3..(row + 1) * h3], &gh[row * h3..(row + 1) * h3]);
            let s = row * h..(row + 1) * h;
            // Every slice exactly `h` long, so the loop runs without bounds checks (and vectorises).
            let (gi_r, gi_z, gi_n) = (&gir[..h], &gir[h..2 * h], &gir[2 * h..3 * h]);
            let (gh_r, gh_z, gh_n) = (&ghr[..h], &ghr[h..2 * h], &ghr[2 * h..3 * h]);
            let (rr, zr) = (&mut r[s.clone()][..h], &mut z[s.clone()][..h]);
            let (nr, gr) = (&mut n[s.clone()][..h], &mut ghn[s.clone()][..h]);
            let (hpr, out) = (&hp[s.clone()][..h], &mut hs[s][..h]);
            for k in 0..h {
                let rg = sigmoid(gi_r[k] + gh_r[k]);
                let zg = sigmoid(gi_z[k] + gh_z[k]);
                let ng = tanh(gi_n[k] + rg * gh_n[k]);
                rr[k] = rg;
                zr[k] = zg;
                gr[k] = gh_n[k];
                nr[k] = ng;
                out[k] = ng + zg * (hpr[k] - ng);
            }
        }
    }
}

/// One GRU step backwards: from `dh` (the loss's) plus `carry` (the next step's) to the
/// gates' pre-activations `dgi`, `dgh` `(nc, 3h)` and `dhp`, the direct part of the previous
/// hidden state's gradient (the part through `w_hh` is added after). `tape`: the step's
/// `r`, `z`, `n`, `gh_n` and previous hidden state.
struct GatesBackward<'a> {
    h: usize,
    dh: &'a [f32],
    carry: &'a [f32],
    tape: [&'a [f32]; 5],
    dgi: &'a mut [f32],
    dgh: &'a mut [f32],
    dhp: &'a mut [f32],
}

impl pulp::WithSimd for GatesBackward<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let GatesBackward { h, dh, carry, tape: [r, z, n, ghn, hp], dgi, dgh, dhp } = self;
        let h3 = 3 * h;
        for row in 0..dh.len() / h.max(1) {
            let s = row * h..(row + 1) * h;
            let (dhr, cr, rr, zr) = (&dh[s.clone()][..h], &carry[s.clone()][..h], &r[s.clone()][..h], &z[s.clone()][..h]);
            let (nr, gr, hpr) = (&n[s.clone()][..h], &ghn[s.clone()][..h], &hp[s.clone()][..h]);
            let dpr = &mut dhp[s][..h];
            let (dgir, dghr) = (&mut dgi[row * h3..(row + 1) * h3], &mut dgh[row * h3..(row + 1) * h3]);
            let (di_r, rest) = dgir.split_at_mut(h);
            let (di_z, di_n) = rest.split_at_mut(h);
            let (dh_r, rest) = dghr.split_at_mut(h);
            let (dh_z, dh_n) = rest.split_at_mut(h);
            let (di_r, di_z, di_n) = (&mut di_r[..h], &mut di_z[..h], &mut di_n[..h]);
            let (dh_r, dh_z, dh_n) = (&mut dh_r[..h], &mut dh_z[..h], &mut dh_n[..h]);
            for k in 0..h {
                let d = dhr[k] + cr[k];
                let dn = d * (1.0 - zr[k]);
                let dz = d * (hpr[k] - nr[k]);
                let dan = dn * (1.0 - nr[k] * nr[k]);
                let dar = dan * gr[k] * rr[k] * (1.0 - rr[k]);
                let daz = dz * zr[k] * (1.0 - zr[k]);
                di_r[k] = dar;
                di_z[k] = daz;
                di_n[k] = dan;
                dh_r[k] = dar;
                dh_z[k] = daz;
                dh_n[k] = dan * rr[k];
                dpr[k] = d * zr[k];
            }
        }
    }
}

/// `d *= [y > 0]` for `y = relu(·)`.
pub(super) fn relu_grad(d: &mut [f32], y: &[f32]) {
    simd(|| d.iter_mut().zip(y).for_each(|(d, &y)| *d = if y > 0.0 { *d } else { 0.0 }));
}

/// Adds the column sums of a row-major `(·, w)` matrix to `out`.
pub(super) fn col_sums(m: &[f32], w: usize, out: &mut [f32]) {
    simd(|| {
        for row in m.chunks_exact(w) {
            out.iter_mut().zip(row).for_each(|(o, &v)| *o += v);
        }
    });
}
