//! Image and text encoders for the `rgb`, `hybrid` and `vision-text` observation modes.
//!
//! An [`ObsEncoder`] turns a step's frames into a feature vector that replaces SMAC's
//! feature vector at the agent network's input (`hybrid` keeps both, concatenated):
//! - two streams with separate weights, one for the screen and one for the minimap, each
//!   ending in adaptive average pooling so the width does not depend on the frame size
//!   (the paper's design), concatenated and projected to `encoder_dim` with a ReLU;
//! - the stream is a small CNN ([`cnn`]) or a Swin Transformer ([`swin`]; Swin-Tiny's own
//!   sizes selectable), trained from scratch on the TD loss with the agent network: no
//!   pretrained Swin weights can be had here;
//! - `vision-text` appends a learned linear projection (`text_dim` wide) of the team
//!   text's slot embeddings: the description cut into clauses ([`clauses`]), each embedded
//!   once by the frozen all-MiniLM-L6-v2 ([`text`]; the paper used GTE-Base, 768-d, which
//!   cannot be had here), averaged into one 384-d embedding per slot ([`clause_cache`]):
//!   the header, each agent in agent order, each enemy in tag order, the rest.
//!   The projection is one linear layer over the slots' concatenation rather than one
//!   shared by every slot: a slot's place is what says whose line it is (a clause such as
//!   `HP 12/45` reads the same in every unit's line), and a shared projection would need
//!   slot embeddings or a second layer to keep it; at 3m_vlm's 8 slots it is 3,072 x 32 weights,
//!   small next to the image streams.
//!
//! The renderer draws one view per team (the whole playable area, as the Python package's
//! `rgb` mode does); it has no per-unit view, so every agent of a team reads the same
//! frames and tells itself apart by the agent-id one-hot (and, in `hybrid`, its own SMAC
//! features). The encoder runs once per frame, not per agent; its output is repeated for
//! each agent's row.
//!
//! Its weights are part of the agent network's [`Params`] (named `encoder.*`): the seed
//! fixes them, the optimiser trains them, target copies and checkpoints
//! (`agent.safetensors`) include them.

pub mod clause_cache;
pub mod clause_store;
pub mod clauses;
pub mod cnn;
pub mod layers;
pub mod swin;
pub mod text;

pub use crate::config::{Backbone, ObsKind, SwinSizes};

// `FrameTensors` was defined here; its old path stays valid.
pub use crate::frames::FrameTensors;

use crate::buffer::Shape;
use crate::frames::StepFrames;
use crate::kernels::EncoderLayout;
use crate::params::{Linear, Params};
use crate::{Config, Error};
use candle_core::Tensor;
use cnn::CnnStream;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use swin::SwinStream;

#[derive(Debug, Clone)]
enum Stream {
    Cnn(CnnStream),
    Swin(SwinStream),
}

impl Stream {
    fn new(p: &mut Params, name: &str, cfg: &Config, rng: &mut ChaCha8Rng) -> Result<Stream, Error> {
        Ok(match cfg.encoder {
            Backbone::Cnn => Stream::Cnn(CnnStream::new(p, name, &cfg.cnn_channels, cfg.cnn_pool, rng)?),
            Backbone::Swin | Backbone::SwinTiny => Stream::Swin(SwinStream::new(p, name, &SwinSizes::of(cfg), rng)?),
        })
    }
    fn out(&self) -> usize {
        match self {
            Stream::Cnn(s) => s.out,
            Stream::Swin(s) => s.out,
        }
    }
    fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        match self {
            Stream::Cnn(s) => s.forward(x),
            Stream::Swin(s) => s.forward(x),
        }
    }
}

/// The width of the encoder's output under `cfg` (0 in `features` mode).
pub fn encoder_width(cfg: &Config) -> usize {
    if !cfg.obs.images() {
        return 0;
    }
    cfg.encoder_dim + if cfg.obs.text() { cfg.text_dim } else { 0 }
}

/// The width of a step's text features for `shape`'s team: one 384-d embedding per slot.
pub fn text_width(shape: &Shape) -> usize {
    clauses::slot_count(shape.n_agents, shape.n_enemies) * text::TEXT_DIM
}

/// The agent network's input width under `cfg`: SMAC's (features, id, last action) or the
/// encoder's output with the id and last action (and the features in `hybrid`).
pub fn agent_input_width(cfg: &Config, shape: &Shape) -> usize {
    let base = shape.input(cfg.obs_agent_id, cfg.obs_last_action);
    if cfg.obs.features() { base + encoder_width(cfg) } else { base - shape.obs + encoder_width(cfg) }
}

/// The observation encoder in front of the agent network.
#[derive(Debug, Clone)]
pub struct ObsEncoder {
    kind: ObsKind,
    screen: Stream,
    minimap: Stream,
    head: Linear,
    text: Option<Linear>,
    /// Width of the text features the projection reads.
    text_in: usize,
    n_agents: usize,
    obs: usize,
    /// Output width ([`encoder_width`]).
    pub out: usize,
    /// The CNN backbone's fused kernels ([`crate::kernels::conv`]); Swin has none.
    kernel: Option<EncoderLayout>,
}

/// A row of [`ObsEncoder::fuse_flat`]'s that sees no frame (a padded step): zero features.
pub const NO_FRAME: u32 = u32::MAX;

impl ObsEncoder {
    /// The encoder `cfg` asks for (`None` in `features` mode), its weights appended to `p`
    /// from a stream of its own derived from `seed` (so the agent network and mixer draw
    /// the same weights in every mode).
    pub fn for_config(cfg: &Config, shape: &Shape, p: &mut Params, seed: u64) -> Result<Option<ObsEncoder>, Error> {
        if !cfg.obs.images() {
            return Ok(None);
        }
        let rng = &mut ChaCha8Rng::seed_from_u64(seed ^ 0x0e4c_0de5_0000_0001);
        let screen = Stream::new(p, "encoder.screen", cfg, rng)?;
        let minimap = Stream::new(p, "encoder.minimap", cfg, rng)?;
        let head = Linear::new(p, "encoder.head", screen.out() + minimap.out(), cfg.encoder_dim, rng)?;
        let text = if cfg.obs.text() { Some(Linear::new(p, "encoder.text", text_width(shape), cfg.text_dim, rng)?) } else { None };
        let kernel = match cfg.encoder {
            Backbone::Cnn => {
                let [sw, sh] = cfg.screen_size.map(|v| v as usize);
                let [mw, mh] = cfg.minimap_size.map(|v| v as usize);
                let text = cfg.obs.text().then(|| (text_width(shape), cfg.text_dim));
                Some(EncoderLayout::new(&cfg.cnn_channels, cfg.cnn_pool, (sw, sh), (mw, mh), cfg.encoder_dim, text)?)
            }
            Backbone::Swin | Backbone::SwinTiny => None,
        };
        Ok(Some(ObsEncoder {
            kind: cfg.obs,
            screen,
            minimap,
            head,
            text,
            text_in: text_width(shape),
            n_agents: shape.n_agents,
            obs: shape.obs,
            out: encoder_width(cfg),
            kernel,
        }))
    }

    /// The fused kernels of this encoder (the CNN backbone's), reading the encoder's
    /// variables as one flat vector in their [`Params`] order.
    pub fn kernel(&self) -> Option<&EncoderLayout> {
        self.kernel.as_ref()
    }

    /// The agent network's input rows `(M, F + rest)` from the features `feats` `(N, F)` of
    /// `N` frames and SMAC's rows `base` `(M, width)`: row `r` is frame `frame[r]`'s features
    /// (zeros for [`NO_FRAME`]) then `base`'s row without the SMAC features unless in
    /// `hybrid`, as [`ObsEncoder::fuse_rows`] builds them in candle.
    pub fn fuse_flat(&self, feats: &[f32], frame: &[u32], base: &[f32]) -> Vec<f32> {
        let (m, f) = (frame.len(), self.out);
        let width = base.len() / m.max(1);
        let skip = if self.kind.features() { 0 } else { self.obs.min(width) };
        let mut out = Vec::with_capacity(m * (f + width - skip));
        for (&i, row) in frame.iter().zip(base.chunks_exact(width.max(1))) {
            if i == NO_FRAME {
                out.extend(std::iter::repeat_n(0.0, f));
            } else {
                out.extend_from_slice(&feats[i as usize * f..(i as usize + 1) * f]);
            }
            out.extend_from_slice(&row[skip..]);
        }
        out
    }

    /// The features' gradient `(n, F)` from the input rows' `dx` (the inverse of
    /// [`ObsEncoder::fuse_flat`]: a frame's rows' gradients summed, in row order).
    pub fn feature_grads(&self, dx: &[f32], frame: &[u32], n: usize) -> Vec<f32> {
        let f = self.out;
        let width = dx.len() / frame.len().max(1);
        let mut d = vec![0f32; n * f];
        for (&i, row) in frame.iter().zip(dx.chunks_exact(width.max(1))) {
            if i != NO_FRAME {
                d[i as usize * f..(i as usize + 1) * f].iter_mut().zip(&row[..f]).for_each(|(a, b)| *a += b);
            }
        }
        d
    }

    /// Features `(N, out)` of `N` observations by the fused kernels when this encoder has
    /// them (`theta`: the encoder's flat weights), else by candle. Used for acting.
    pub fn encode_pixels(&self, theta: Option<&[f32]>, frames: &StepFrames) -> Result<Vec<f32>, Error> {
        match (&self.kernel, theta) {
            (Some(k), Some(theta)) => Ok(k.forward(theta, &frames.pixels(), false)?.out),
            _ => Ok(self.forward(&frames.tensors()?)?.flatten_all()?.to_vec1()?),
        }
    }

    /// Features `(N, out)` of `N` observations.
    pub fn forward(&self, f: &FrameTensors) -> Result<Tensor, Error> {
        let image = Tensor::cat(&[self.screen.forward(&f.screen)?, self.minimap.forward(&f.minimap)?], 1)?;
        let image = self.head.forward(&image)?.relu()?;
        match (&self.text, &f.text) {
            (Some(proj), Some(t)) => {
                if t.dim(1)? != self.text_in {
                    return Err(Error::Observation {
                        message: format!("text features {} wide; the encoder was built for {}", t.dim(1)?, self.text_in),
                    });
                }
                Ok(Tensor::cat(&[image, proj.forward(t)?], 1)?)
            }
            (Some(_), None) => Err(Error::Observation { message: "the vision-text encoder was given no text embeddings".into() }),
            (None, _) => Ok(image),
        }
    }

    /// Agent rows: `feats` `(N, F)` of `N` team observations repeated for each agent, then
    /// each row of `base` `(N * A, width)` (SMAC's input rows: features, id, last action)
    /// without the features unless in `hybrid`.
    pub(crate) fn fuse(&self, feats: &Tensor, base: &Tensor) -> Result<Tensor, Error> {
        let (n, f) = feats.dims2()?;
        let a = self.n_agents;
        let rows = feats.unsqueeze(1)?.broadcast_as((n, a, f))?.reshape((n * a, f))?;
        self.fuse_rows(rows, base)
    }

    /// Agent rows: each row of `rows` `(M, F)` (the features of that row's team
    /// observation) then the same row of `base` `(M, width)` without the features unless in
    /// `hybrid`.
    pub fn fuse_rows(&self, rows: Tensor, base: &Tensor) -> Result<Tensor, Error> {
        let width = base.dim(1)?;
        let rest = if self.kind.features() {
            base.clone()
        } else if width > self.obs {
            base.narrow(1, self.obs, width - self.obs)?
        } else {
            return Ok(rows);
        };
        Ok(Tensor::cat(&[rows, rest], 1)?)
    }
}
