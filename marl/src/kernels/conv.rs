//! The CNN image encoder ([`crate::encoders`] with `Backbone::Cnn`: a convolutional stream
//! over the screen and one over the minimap, each ending in adaptive average pooling, the
//! `head` projection with its ReLU and, in `vision-text`, the `text` projection) forward and
//! backward over `N` frames, by hand, on one flat parameter vector.
//!
//! Why not candle: in the image modes the encoder is nearly all of an update (MAPPO rgb
//! encodes its whole rollout, 3,200 frames, at each of its 15 epochs). Candle's pass built
//! float NCHW copies of the frames, im2col as a graph of strided slices, and allocated every
//! intermediate afresh; its backward pass walked that graph (about 7 s for 3,200 frames
//! here, against about 0.25 s of CPU time for this module). Here:
//! - the pixels are read as the renderer's u8 HWC bytes, converted an image row at a time
//!   straight into the stem's patch rows, so a batch never exists as floats (4x the bytes);
//! - activations are channels-last (NHWC), so a patch row is a few runs of contiguous
//!   channels (the 4x4 stride-4 stem's: four runs of 12 values) and each layer is one
//!   matrix product per block of frames; the kernels are reordered to match,
//!   `(out, ky, kx, in)`;
//! - frames go through in blocks small enough that a block's patch matrix stays in the
//!   core's L2 cache between being written and being multiplied;
//! - the tape keeps the activations only: the backward pass rebuilds the patch matrices from
//!   them (and the stem's from the pixels), a gather without arithmetic, where keeping them
//!   would take about twice the tape's bytes;
//! - the tape and the scratch buffers live in [`EncoderForward`], which callers hand back
//!   ([`EncoderLayout::forward_into`]) so an update's hundred-odd megabytes are not
//!   allocated and page-faulted again at every epoch;
//! - the elementwise passes (patch rows, their inverse) are compiled for the processor's
//!   best instruction set through `pulp::Arch::dispatch`, as in [`super::net`].
//!
//! Where the time goes (`perf`, 3,200 80x60 + 32x32 frames): the matrix products about
//! half, near the cores' AVX-512 peak; building and scattering patch rows about a fifth.
//!
//! Threads: as in [`super::net`], the frames are cut into a fixed number of chunks that
//! depends on `N` alone, each chunk runs its forward and backward passes on any thread
//! (rayon), and the chunks' parameter gradients are summed in chunk order, so the results
//! are the same bits whatever the number of threads.
//!
//! Checked against candle's autograd on the reference encoder ([`crate::ObsEncoder`]) by
//! the tests in `conv_tests.rs`.

use super::act::simd;
use super::gemm::{Mat, matmul};
use super::net::{col_sums, relu_grad};
use crate::Error;
use rayon::prelude::*;

/// Kernel size, stride and padding of convolution `i` of a stream (shared with candle's
/// encoder, `crate::encoders::cnn`, so the two cannot drift apart).
pub(crate) fn geometry(i: usize) -> (usize, usize, usize) {
    if i == 0 { (4, 4, 0) } else { (3, 2, 1) }
}

/// One convolution of a stream, its input and output maps `(h, w, channels)`, and where
/// its kernel and bias sit in the flat vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Conv {
    cin: usize,
    cout: usize,
    k: usize,
    stride: usize,
    pad: usize,
    ih: usize,
    iw: usize,
    oh: usize,
    ow: usize,
    w: usize,
    b: usize,
}

impl Conv {
    /// Width of a patch row: `k x k x cin`.
    fn patch(&self) -> usize {
        self.k * self.k * self.cin
    }
    fn positions(&self) -> usize {
        self.oh * self.ow
    }
    /// Floats of one frame's output map.
    fn map(&self) -> usize {
        self.positions() * self.cout
    }
}

/// One stream: its convolutions, and PyTorch's adaptive pooling bins over the last map.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Stream {
    convs: Vec<Conv>,
    pool: usize,
    rows: Vec<(usize, usize)>,
    cols: Vec<(usize, usize)>,
    /// Where its features start in the head's input row, and how many (channels x pool^2).
    feat: usize,
    out: usize,
    /// Bytes of one frame (`h x w x 3`).
    frame: usize,
}

/// The encoder's sizes and where each parameter sits in its flat vector: the order of the
/// encoder's variables in [`crate::nets::Params`] (screen convolutions, minimap
/// convolutions, each kernel then bias; `head`; `text`), so the vector is their
/// concatenation ([`crate::nets::Params::flat`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EncoderLayout {
    streams: [Stream; 2],
    head_in: usize,
    dim: usize,
    /// `text_dim`, 0 without the text projection.
    text: usize,
    /// The text embedding's width (the vision-text mode's slots x 384).
    text_in: usize,
    head_w: usize,
    head_b: usize,
    text_w: usize,
    text_b: usize,
    len: usize,
    /// Frames per block (see the module docs).
    block: usize,
}

/// PyTorch's adaptive pooling bins of `inp` cells into `out`:
/// `[floor(i * inp / out), ceil((i + 1) * inp / out))`.
fn bins(inp: usize, out: usize) -> Vec<(usize, usize)> {
    (0..out)
        .map(|i| {
            let start = i * inp / out;
            (start, ((i + 1) * inp).div_ceil(out).max(start + 1))
        })
        .collect()
}

/// Floats a block's largest patch matrix may take (512 kB: a block's working set, patches
/// and outputs, then fits a 1-2 MB L2 cache).
const BLOCK_FLOATS: usize = 1 << 17;

impl EncoderLayout {
    /// The encoder of `channels` convolutions per stream (the config's `cnn_channels`),
    /// pooled to `pool x pool`, over `screen` and `minimap` frames (`(width, height)`),
    /// projected to `dim`, with a projection of the text features (`(input width, output
    /// width)`) if given.
    pub fn new(
        channels: &[usize],
        pool: usize,
        screen: (usize, usize),
        minimap: (usize, usize),
        dim: usize,
        text: Option<(usize, usize)>,
    ) -> Result<EncoderLayout, Error> {
        let (text_in, text_dim) = match text {
            Some((i, o)) => (i, Some(o)),
            None => (0, None),
        };
        let bad = |message: String| Err(Error::Observation { message });
        if channels.is_empty()
            || channels.contains(&0)
            || pool == 0
            || dim == 0
            || text_dim == Some(0)
            || (text_dim.is_some() && text_in == 0)
        {
            return bad(format!("no CNN encoder of channels {channels:?}, pool {pool}, width {dim}, text width {text_dim:?}"));
        }
        let mut at = 0;
        let mut feat = 0;
        let mut streams = Vec::with_capacity(2);
        for (w, h) in [screen, minimap] {
            let (mut ih, mut iw, mut cin) = (h, w, 3);
            let mut convs = Vec::with_capacity(channels.len());
            for (i, &cout) in channels.iter().enumerate() {
                let (k, stride, pad) = geometry(i);
                // `stem_patches` reads the first convolution's patches in place.
                assert!(i > 0 || (stride == k && pad == 0), "the stem must not overlap or pad");
                if ih + 2 * pad < k || iw + 2 * pad < k {
                    return bad(format!("a {ih}x{iw} map is smaller than a {k}x{k} kernel"));
                }
                let (oh, ow) = ((ih + 2 * pad - k) / stride + 1, (iw + 2 * pad - k) / stride + 1);
                let b = at + cout * cin * k * k;
                convs.push(Conv { cin, cout, k, stride, pad, ih, iw, oh, ow, w: at, b });
                at = b + cout;
                (ih, iw, cin) = (oh, ow, cout);
            }
            let out = cin * pool * pool;
            streams.push(Stream { convs, pool, rows: bins(ih, pool), cols: bins(iw, pool), feat, out, frame: w * h * 3 });
            feat += out;
        }
        let head_in = feat;
        let (head_w, head_b) = (at, at + dim * head_in);
        let text = text_dim.unwrap_or(0);
        let (text_w, text_b) = (head_b + dim, head_b + dim + text * text_in);
        let len = text_b + text;
        let widest = streams.iter().flat_map(|s| &s.convs).map(|c| c.positions() * c.patch()).max().unwrap_or(1);
        let block = (BLOCK_FLOATS / widest.max(1)).clamp(1, 64);
        let [screen, minimap]: [Stream; 2] = streams.try_into().map_err(|_| Error::Observation { message: "two streams".into() })?;
        Ok(EncoderLayout { streams: [screen, minimap], head_in, dim, text, text_in, head_w, head_b, text_w, text_b, len, block })
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The width of a frame's features: `encoder_dim`, plus `text_dim` with text.
    pub fn out(&self) -> usize {
        self.dim + self.text
    }

    /// The chunks `n` frames are cut into: a function of `n` only (see the module docs).
    fn chunks(n: usize) -> Vec<(usize, usize)> {
        const MIN_FRAMES: usize = 16;
        const MAX_CHUNKS: usize = 16;
        let k = (n / MIN_FRAMES).clamp(1, MAX_CHUNKS);
        (0..k).map(|c| (c * n / k, (c + 1) * n / k)).filter(|(a, b)| b > a).collect()
    }

    /// How many chunks `n` frames are cut into.
    pub fn chunk_count(n: usize) -> usize {
        EncoderLayout::chunks(n).len()
    }

    /// Checks `px` against the frame sizes (its pixels come from outside: the renderer, a
    /// replay buffer, a caller).
    fn check(&self, px: &Pixels<'_>) -> Result<(), Error> {
        let bad = |message: String| Err(Error::Observation { message });
        let n = px.stored;
        for (what, got, frame) in [("screen", px.screen.len(), self.streams[0].frame), ("minimap", px.minimap.len(), self.streams[1].frame)]
        {
            if got != n * frame {
                return bad(format!("{what}: {got} bytes for {n} frames of {frame}"));
            }
        }
        if self.text > 0 && px.text.len() != px.stored * self.text_in {
            return bad(format!("text: {} values for {} embeddings of {}", px.text.len(), px.stored, self.text_in));
        }
        if let Some(p) = px.pick
            && let Some(&i) = p.iter().find(|&&i| i as usize >= n)
        {
            return bad(format!("frame {i} picked of {n}"));
        }
        Ok(())
    }

    /// Encodes the frames of `px`: features `(N, out)` in [`EncoderForward::out`]. With
    /// `tape`, keeps what [`EncoderLayout::backward`] needs.
    pub fn forward(&self, theta: &[f32], px: &Pixels<'_>, tape: bool) -> Result<EncoderForward, Error> {
        let mut f = EncoderForward::default();
        self.forward_into(theta, px, tape, &mut f)?;
        Ok(f)
    }

    /// [`EncoderLayout::forward`] into `f`, reusing its buffers.
    pub fn forward_into(&self, theta: &[f32], px: &Pixels<'_>, tape: bool, f: &mut EncoderForward) -> Result<(), Error> {
        assert_eq!(theta.len(), self.len, "encoder parameters");
        self.check(px)?;
        let n = px.n();
        let width = self.out();
        let ranges = EncoderLayout::chunks(n);
        f.n = n;
        f.tape = tape;
        f.out.clear();
        f.out.resize(n * width, 0.0);
        f.chunks.resize_with(ranges.len(), ChunkTape::default);
        let kernels = self.reordered(theta);
        let mut outs = Vec::with_capacity(ranges.len());
        let mut rest = &mut f.out[..];
        for &(a, b) in &ranges {
            let (head, tail) = rest.split_at_mut((b - a) * width);
            outs.push(head);
            rest = tail;
        }
        f.chunks.par_iter_mut().zip(outs).zip(ranges).for_each(|((c, out), range)| {
            c.range = range;
            self.forward_chunk(theta, &kernels, px, tape, c, out);
        });
        Ok(())
    }

    /// Every convolution's kernel reordered from candle's `(out, in, ky, kx)` to the patch
    /// rows' `(out, ky, kx, in)`, screen's then minimap's.
    fn reordered(&self, theta: &[f32]) -> Vec<Vec<f32>> {
        let mut out = Vec::new();
        for cv in self.streams.iter().flat_map(|s| &s.convs) {
            let (kk, cin) = (cv.k * cv.k, cv.cin);
            let mut w = vec![0f32; cv.cout * cv.patch()];
            for (o, row) in w.chunks_exact_mut(cv.patch()).enumerate() {
                let src = &theta[cv.w + o * cin * kk..cv.w + (o + 1) * cin * kk];
                for c in 0..cin {
                    for q in 0..kk {
                        row[q * cin + c] = src[c * kk + q];
                    }
                }
            }
            out.push(w);
        }
        out
    }

    /// One chunk's forward pass, its features into `out` (`nc x out`).
    fn forward_chunk(&self, theta: &[f32], kernels: &[Vec<f32>], px: &Pixels<'_>, tape: bool, c: &mut ChunkTape, out: &mut [f32]) {
        let (c0, c1) = c.range;
        let nc = c1 - c0;
        let kept = if tape { nc } else { nc.min(self.block) };
        c.feats.resize(nc * self.head_in, 0.0);
        let mut k_at = 0;
        let nl = self.streams[0].convs.len();
        c.acts.resize_with(2 * nl, Vec::new);
        for (s, st) in self.streams.iter().enumerate() {
            let pixels = if s == 0 { px.screen } else { px.minimap };
            for (l, cv) in st.convs.iter().enumerate() {
                c.acts[s * nl + l].resize(kept * cv.map(), 0.0);
            }
            for b0 in (0..nc).step_by(self.block) {
                let nb = (nc - b0).min(self.block);
                let at = if tape { b0 } else { 0 };
                for (l, cv) in st.convs.iter().enumerate() {
                    let rows = nb * cv.positions();
                    c.cols.resize(c.cols.len().max(rows * cv.patch()), 0.0);
                    let cols = &mut c.cols[..rows * cv.patch()];
                    let (before, after) = c.acts.split_at_mut(s * nl + l);
                    if l == 0 {
                        for (i, dst) in cols.chunks_exact_mut(cv.positions() * cv.patch()).enumerate() {
                            let fr = px.frame(c0 + b0 + i);
                            stem_patches(&pixels[fr * st.frame..(fr + 1) * st.frame], cv, dst, &mut c.row);
                        }
                    } else {
                        let prev = &before[s * nl + l - 1];
                        let pm = st.convs[l - 1].map();
                        for (i, dst) in cols.chunks_exact_mut(cv.positions() * cv.patch()).enumerate() {
                            im2col(&prev[(at + i) * pm..(at + i + 1) * pm], cv, dst);
                        }
                    }
                    // Row-major output: the product kernel then runs along the channels (16
                    // or 32, one or two vectors) and reads the patch rows in place. Computing
                    // the transpose instead (its tiles along the rows) made it repack the
                    // patch matrix and the result be transposed back, which cost more.
                    let y = &mut after[0][at * cv.map()..(at + nb) * cv.map()];
                    matmul(y, cv.cout, Mat::rows(cols, rows, cv.patch()), Mat::t(&kernels[k_at + l], cv.patch(), cv.cout), false);
                    bias_relu(y, cv.cout, &theta[cv.b..cv.b + cv.cout]);
                }
                let last = st.convs[nl - 1];
                let y = &c.acts[s * nl + nl - 1];
                for i in 0..nb {
                    let feats = &mut c.feats[(b0 + i) * self.head_in + st.feat..][..st.out];
                    pool_forward(st, &last, &y[(at + i) * last.map()..(at + i + 1) * last.map()], feats, &mut c.pool);
                }
            }
            k_at += nl;
        }
        let w = self.out();
        matmul(out, w, Mat::rows(&c.feats, nc, self.head_in), Mat::t(&theta[self.head_w..self.head_b], self.head_in, self.dim), false);
        bias_relu(out, w, &theta[self.head_b..self.head_b + self.dim]);
        if self.text > 0 {
            c.text.clear();
            for i in c0..c1 {
                let fr = px.frame(i);
                c.text.extend_from_slice(&px.text[fr * self.text_in..(fr + 1) * self.text_in]);
            }
            let tw = &theta[self.text_w..self.text_b];
            matmul(&mut out[self.dim..], w, Mat::rows(&c.text, nc, self.text_in), Mat::t(tw, self.text_in, self.text), false);
            let tb = &theta[self.text_b..self.text_b + self.text];
            for row in out.chunks_exact_mut(w) {
                row[self.dim..].iter_mut().zip(tb).for_each(|(v, b)| *v += b);
            }
        }
    }

    /// Gradients of a loss from its gradient `d_out` `(N, out)` with respect to the
    /// features of the forward pass `f` (run with a tape on the same `px`): every
    /// parameter's, summed into `grad`. The pixels get none (nothing upstream learns).
    pub fn backward(&self, theta: &[f32], f: &mut EncoderForward, px: &Pixels<'_>, d_out: &[f32], grad: &mut [f32]) {
        assert!(f.tape || f.n == 0, "backward needs a forward pass run with a tape");
        assert_eq!(px.n(), f.n, "the forward pass's frames");
        assert_eq!(d_out.len(), f.n * self.out(), "feature gradients");
        assert_eq!((theta.len(), grad.len()), (self.len, self.len), "encoder parameters");
        let kernels = self.reordered(theta);
        let w = self.out();
        let out = &f.out;
        f.chunks.par_iter_mut().for_each(|c| {
            let (c0, c1) = c.range;
            self.backward_chunk(theta, &kernels, px, &d_out[c0 * w..c1 * w], &out[c0 * w..c1 * w], c);
        });
        for c in &f.chunks {
            simd(|| grad.iter_mut().zip(&c.grad).for_each(|(a, b)| *a += b));
        }
    }

    fn backward_chunk(&self, theta: &[f32], kernels: &[Vec<f32>], px: &Pixels<'_>, d_out: &[f32], out: &[f32], c: &mut ChunkTape) {
        let (c0, c1) = c.range;
        let nc = c1 - c0;
        let (w, dim) = (self.out(), self.dim);
        c.grad.clear();
        c.grad.resize(self.len, 0.0);
        let g = &mut c.grad;
        // The head: its ReLU's output is the forward's `out`.
        let mut d_img = std::mem::take(&mut c.scratch[0]);
        d_img.clear();
        for (d, y) in d_out.chunks_exact(w).zip(out.chunks_exact(w)) {
            d_img.extend(d[..dim].iter().zip(&y[..dim]).map(|(&d, &y)| if y > 0.0 { d } else { 0.0 }));
        }
        matmul(&mut g[self.head_w..self.head_b], self.head_in, Mat::t(&d_img, dim, nc), Mat::rows(&c.feats, nc, self.head_in), false);
        col_sums(&d_img, dim, &mut g[self.head_b..self.head_b + dim]);
        let mut d_feats = std::mem::take(&mut c.scratch[1]);
        d_feats.resize(nc * self.head_in, 0.0);
        matmul(
            &mut d_feats,
            self.head_in,
            Mat::rows(&d_img, nc, dim),
            Mat::rows(&theta[self.head_w..self.head_b], dim, self.head_in),
            false,
        );
        if self.text > 0 {
            let d_text = Mat::strided(&d_out[dim..], self.text, nc, 1, w);
            matmul(&mut g[self.text_w..self.text_b], self.text_in, d_text, Mat::rows(&c.text, nc, self.text_in), false);
            for d in d_out.chunks_exact(w) {
                g[self.text_b..self.text_b + self.text].iter_mut().zip(&d[dim..]).for_each(|(a, b)| *a += b);
            }
        }
        // The streams, block by block, from the last convolution back.
        let nl = self.streams[0].convs.len();
        let (mut dy, mut dprev) = (std::mem::take(&mut c.scratch[2]), std::mem::take(&mut c.scratch[3]));
        let mut gk = std::mem::take(&mut c.gk);
        let mut k_at = 0;
        for (s, st) in self.streams.iter().enumerate() {
            let pixels = if s == 0 { px.screen } else { px.minimap };
            gk.resize_with(nl, Vec::new);
            for (gl, cv) in gk.iter_mut().zip(&st.convs) {
                gl.clear();
                gl.resize(cv.cout * cv.patch(), 0.0);
            }
            for b0 in (0..nc).step_by(self.block) {
                let nb = (nc - b0).min(self.block);
                let last = st.convs[nl - 1];
                dy.clear();
                dy.resize(nb * last.map(), 0.0);
                for i in 0..nb {
                    let df = &d_feats[(b0 + i) * self.head_in + st.feat..][..st.out];
                    pool_backward(st, &last, df, &mut dy[i * last.map()..(i + 1) * last.map()], &mut c.pool);
                }
                relu_grad(&mut dy, &c.acts[s * nl + nl - 1][b0 * last.map()..(b0 + nb) * last.map()]);
                for l in (0..nl).rev() {
                    let cv = st.convs[l];
                    let rows = nb * cv.positions();
                    let cols = &mut c.cols[..rows * cv.patch()];
                    if l == 0 {
                        for (i, dst) in cols.chunks_exact_mut(cv.positions() * cv.patch()).enumerate() {
                            let fr = px.frame(c0 + b0 + i);
                            stem_patches(&pixels[fr * st.frame..(fr + 1) * st.frame], &cv, dst, &mut c.row);
                        }
                    } else {
                        let pm = st.convs[l - 1].map();
                        let prev = &c.acts[s * nl + l - 1][b0 * pm..(b0 + nb) * pm];
                        for (i, dst) in cols.chunks_exact_mut(cv.positions() * cv.patch()).enumerate() {
                            im2col(&prev[i * pm..(i + 1) * pm], &cv, dst);
                        }
                    }
                    matmul(&mut gk[l], cv.patch(), Mat::t(&dy, cv.cout, rows), Mat::rows(cols, rows, cv.patch()), true);
                    col_sums(&dy, cv.cout, &mut g[cv.b..cv.b + cv.cout]);
                    if l == 0 {
                        break;
                    }
                    let pm = st.convs[l - 1].map();
                    c.dcols.resize(c.dcols.len().max(rows * cv.patch()), 0.0);
                    let dcols = &mut c.dcols[..rows * cv.patch()];
                    matmul(dcols, cv.patch(), Mat::rows(&dy, rows, cv.cout), Mat::rows(&kernels[k_at + l], cv.cout, cv.patch()), false);
                    dprev.clear();
                    dprev.resize(nb * pm, 0.0);
                    for (i, d) in dprev.chunks_exact_mut(pm).enumerate() {
                        col2im(&dcols[i * cv.positions() * cv.patch()..(i + 1) * cv.positions() * cv.patch()], &cv, d);
                    }
                    relu_grad(&mut dprev, &c.acts[s * nl + l - 1][b0 * pm..(b0 + nb) * pm]);
                    std::mem::swap(&mut dy, &mut dprev);
                }
            }
            // Back to candle's kernel layout.
            for (gl, cv) in gk.iter().zip(&st.convs) {
                let (kk, cin) = (cv.k * cv.k, cv.cin);
                for (o, row) in gl.chunks_exact(cv.patch()).enumerate() {
                    let dst = &mut g[cv.w + o * cin * kk..cv.w + (o + 1) * cin * kk];
                    for ch in 0..cin {
                        for q in 0..kk {
                            dst[ch * kk + q] = row[q * cin + ch];
                        }
                    }
                }
            }
            k_at += nl;
        }
        c.scratch = [d_img, d_feats, dy, dprev];
        c.gk = gk;
    }
}

/// The frames an encoder reads: `stored` frames' u8 HWC pixels (and, with the text
/// projection, their `(stored, 384)` text embeddings), of which it encodes `pick` (indices
/// into the stored frames, repeats allowed), or all in order.
#[derive(Clone, Copy, Debug)]
pub struct Pixels<'a> {
    pub stored: usize,
    pub screen: &'a [u8],
    pub minimap: &'a [u8],
    pub text: &'a [f32],
    pub pick: Option<&'a [u32]>,
}

impl Pixels<'_> {
    /// The number of frames encoded.
    pub fn n(&self) -> usize {
        self.pick.map_or(self.stored, <[u32]>::len)
    }
    /// The stored frame that encoded frame `i` is.
    fn frame(&self, i: usize) -> usize {
        self.pick.map_or(i, |p| p[i] as usize)
    }
}

/// One forward pass: the features, and with a tape what the backward pass needs. Also the
/// buffers both passes reuse when it is handed back to [`EncoderLayout::forward_into`].
#[derive(Debug, Default)]
pub struct EncoderForward {
    pub n: usize,
    /// `(N, out)`.
    pub out: Vec<f32>,
    tape: bool,
    chunks: Vec<ChunkTape>,
}

/// One chunk's activations and scratch buffers.
#[derive(Debug, Default)]
struct ChunkTape {
    range: (usize, usize),
    /// Each stream's convolutions' outputs (after the ReLU), NHWC, screen's then minimap's.
    acts: Vec<Vec<f32>>,
    /// `(nc, head_in)`: the pooled features.
    feats: Vec<f32>,
    /// `(nc, 384)`: the frames' text embeddings.
    text: Vec<f32>,
    cols: Vec<f32>,
    dcols: Vec<f32>,
    /// One image row of the stem's pixels, as floats.
    row: Vec<f32>,
    /// One pooling bin's channels.
    pool: Vec<f32>,
    scratch: [Vec<f32>; 4],
    /// The reordered kernels' gradients of the stream in hand.
    gk: Vec<Vec<f32>>,
    grad: Vec<f32>,
}

/// The stem's patch rows of one frame's u8 pixels, as floats in [0, 1] (divided by 255 as
/// candle's reference does). The stem does not overlap or pad (stride = kernel, see
/// [`geometry`]), so each patch row is `k` runs of `k * 3` bytes of `k` image rows: each
/// image row is converted whole (a long loop, vectorised; the runs' 12 bytes one by one
/// were not) into `row`, then copied out run by run.
fn stem_patches(px: &[u8], cv: &Conv, cols: &mut [f32], row: &mut Vec<f32>) {
    row.resize(cv.ow * cv.k * cv.cin, 0.0);
    vectorized(Op::Stem(px, cv, cols, row));
}

#[inline(always)]
fn stem_patches_body(px: &[u8], cv: &Conv, cols: &mut [f32], row: &mut [f32]) {
    let (k, run, patch) = (cv.k, cv.k * cv.cin, cv.patch());
    let row_bytes = cv.iw * cv.cin;
    for oy in 0..cv.oh {
        for ky in 0..k {
            let src = &px[(oy * cv.stride + ky) * row_bytes..][..row.len()];
            row.iter_mut().zip(src).for_each(|(d, &s)| *d = f32::from(s) / 255.0);
            let dst = &mut cols[oy * cv.ow * patch..(oy + 1) * cv.ow * patch];
            for (d, s) in dst.chunks_exact_mut(patch).zip(row.chunks_exact(run)) {
                copy_run(&mut d[ky * run..(ky + 1) * run], s);
            }
        }
    }
}

/// The patch rows `(positions, k * k * cin)` of one frame's NHWC map, `(ky, kx, c)` order,
/// zeros where a patch reaches into the padding.
fn im2col(src: &[f32], cv: &Conv, cols: &mut [f32]) {
    vectorized(Op::Im2col(src, cv, cols));
}

#[inline(always)]
fn im2col_body(src: &[f32], cv: &Conv, cols: &mut [f32]) {
    let (k, c, patch) = (cv.k, cv.cin, cv.patch());
    for oy in 0..cv.oh {
        for ox in 0..cv.ow {
            let row = &mut cols[(oy * cv.ow + ox) * patch..][..patch];
            let (lo, hi, first) = span(ox, cv.stride, cv.pad, k, cv.iw);
            for ky in 0..k {
                let dst = &mut row[ky * k * c..(ky + 1) * k * c];
                let iy = (oy * cv.stride + ky).wrapping_sub(cv.pad);
                if iy >= cv.ih || lo >= hi {
                    dst.fill(0.0);
                    continue;
                }
                dst[..lo * c].fill(0.0);
                dst[hi * c..].fill(0.0);
                let start = (iy * cv.iw + first) * c;
                copy_run(&mut dst[lo * c..hi * c], &src[start..start + (hi - lo) * c]);
            }
        }
    }
}

/// A short copy (a patch row's run: 12 floats in the stem, 16 to 96 after), of a length
/// known at compile time where it is a usual one: `copy_from_slice` of a length known only
/// at run time calls `memcpy`, whose call cost as much as these copies.
#[inline(always)]
fn copy_run(dst: &mut [f32], src: &[f32]) {
    #[inline(always)]
    fn fixed<const N: usize>(dst: &mut [f32], src: &[f32]) {
        match (<&mut [f32; N]>::try_from(&mut *dst), <&[f32; N]>::try_from(src)) {
            (Ok(d), Ok(s)) => *d = *s,
            _ => dst.copy_from_slice(src),
        }
    }
    match dst.len() {
        12 => fixed::<12>(dst, src),
        16 => fixed::<16>(dst, src),
        24 => fixed::<24>(dst, src),
        32 => fixed::<32>(dst, src),
        48 => fixed::<48>(dst, src),
        64 => fixed::<64>(dst, src),
        96 => fixed::<96>(dst, src),
        _ => dst.copy_from_slice(src),
    }
}

/// The elementwise passes here, each compiled for the best instruction set this processor
/// has. A struct whose `with_simd` inlines an `#[inline(always)]` body, not a closure: the
/// larger closures were compiled apart, for baseline x86-64, and ran their copies 16 bytes
/// at a time.
enum Op<'a> {
    Stem(&'a [u8], &'a Conv, &'a mut [f32], &'a mut [f32]),
    Im2col(&'a [f32], &'a Conv, &'a mut [f32]),
    Col2im(&'a [f32], &'a Conv, &'a mut [f32]),
}

impl pulp::WithSimd for Op<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        match self {
            Op::Stem(px, cv, cols, row) => stem_patches_body(px, cv, cols, row),
            Op::Im2col(src, cv, cols) => im2col_body(src, cv, cols),
            Op::Col2im(dcols, cv, d) => col2im_body(dcols, cv, d),
        }
    }
}

fn vectorized(op: Op<'_>) {
    pulp::Arch::new().dispatch(op);
}

/// The inverse of [`im2col`]'s gather: each patch row's gradient added to the map cells it
/// was read from (padding dropped).
fn col2im(dcols: &[f32], cv: &Conv, d: &mut [f32]) {
    vectorized(Op::Col2im(dcols, cv, d));
}

#[inline(always)]
fn col2im_body(dcols: &[f32], cv: &Conv, d: &mut [f32]) {
    let (k, c, patch) = (cv.k, cv.cin, cv.patch());
    for oy in 0..cv.oh {
        for ox in 0..cv.ow {
            let row = &dcols[(oy * cv.ow + ox) * patch..][..patch];
            let (lo, hi, first) = span(ox, cv.stride, cv.pad, k, cv.iw);
            for ky in 0..k {
                let iy = (oy * cv.stride + ky).wrapping_sub(cv.pad);
                if iy >= cv.ih || lo >= hi {
                    continue;
                }
                let start = (iy * cv.iw + first) * c;
                let dst = &mut d[start..start + (hi - lo) * c];
                dst.iter_mut().zip(&row[ky * k * c + lo * c..ky * k * c + hi * c]).for_each(|(d, &v)| *d += v);
            }
        }
    }
}

/// The kernel columns `lo..hi` of output column `ox` that fall inside a map `iw` wide
/// (the others read the padding), and the map column kernel column `lo` reads.
#[inline(always)]
fn span(ox: usize, stride: usize, pad: usize, k: usize, iw: usize) -> (usize, usize, usize) {
    // Kernel column `kx` reads map column `ox * stride + kx - pad`.
    let left = ox * stride;
    let lo = pad.saturating_sub(left).min(k);
    let hi = (iw + pad).saturating_sub(left).min(k).max(lo);
    (lo, hi, (left + lo).saturating_sub(pad))
}

/// `y = max(y + b, 0)` on the first `b.len()` columns of rows `ld` wide.
fn bias_relu(y: &mut [f32], ld: usize, b: &[f32]) {
    let w = b.len();
    simd(|| {
        for row in y.chunks_mut(ld) {
            row[..w].iter_mut().zip(b).for_each(|(v, &b)| *v = (*v + b).max(0.0));
        }
    });
}

/// Adaptive average pooling of one frame's last map `(oh, ow, C)` into `feats`, candle's
/// flattened `(C, pool, pool)` order.
fn pool_forward(st: &Stream, cv: &Conv, y: &[f32], feats: &mut [f32], acc: &mut Vec<f32>) {
    let (c, p) = (cv.cout, st.pool);
    acc.resize(c, 0.0);
    for (py, &(r0, r1)) in st.rows.iter().enumerate() {
        for (px, &(q0, q1)) in st.cols.iter().enumerate() {
            acc.fill(0.0);
            for yy in r0..r1 {
                for xx in q0..q1 {
                    acc.iter_mut().zip(&y[(yy * cv.ow + xx) * c..][..c]).for_each(|(a, &v)| *a += v);
                }
            }
            let inv = 1.0 / ((r1 - r0) * (q1 - q0)) as f32;
            for (ch, &a) in acc.iter().enumerate() {
                feats[ch * p * p + py * p + px] = a * inv;
            }
        }
    }
}

/// The pooling's gradient: each bin's share of its feature's gradient added to its cells.
fn pool_backward(st: &Stream, cv: &Conv, df: &[f32], dy: &mut [f32], v: &mut Vec<f32>) {
    let (c, p) = (cv.cout, st.pool);
    v.resize(c, 0.0);
    for (py, &(r0, r1)) in st.rows.iter().enumerate() {
        for (px, &(q0, q1)) in st.cols.iter().enumerate() {
            let inv = 1.0 / ((r1 - r0) * (q1 - q0)) as f32;
            for (ch, x) in v.iter_mut().enumerate() {
                *x = df[ch * p * p + py * p + px] * inv;
            }
            for yy in r0..r1 {
                for xx in q0..q1 {
                    dy[(yy * cv.ow + xx) * c..][..c].iter_mut().zip(v.iter()).for_each(|(d, &g)| *d += g);
                }
            }
        }
    }
}
