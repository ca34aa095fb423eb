//! Where the image modes' observations come from while training: every step, team 1's
//! screen and minimap of each of the vector environment's environments, drawn by the
//! renderer's CPU back end from the environment's current state (after an automatic reset,
//! the new episode's first state, as the feature buffers hold), and in `vision-text` the
//! slot embeddings of the team's text description (the Python package's `vlm` text, cut
//! into clauses: [`crate::encoders::clauses`], [`crate::encoders::clause_cache`]).
//!
//! One view per team (the renderer has no per-unit view): the agents of an environment
//! share its frames and tell themselves apart by their agent id. Frames are kept as the
//! renderer's u8 pixels (HWC) in the replay buffer, one per environment step rather than
//! per agent, and read as bytes by the fused CNN encoder ([`crate::kernels::conv`]); only
//! the candle encoders (Swin, the references) turn them into float tensors. At 80x60 plus
//! 32x32 that is 17.5 kB a step (a 60-step episode about 1 MB; mind `buffer_size`, 5,000
//! episodes by default). The text features add `slots x 384` floats a step: 12 kB on 3m
//! (8 slots), 18 kB on 2s3z (12).

use crate::buffer::Episode;
use crate::encoders::clause_cache::{TextEmbedder, TextStats};
use crate::encoders::clauses::{SlotLayout, clauses};
use crate::encoders::layers::pixels_to_tensor;
use crate::encoders::text::TEXT_DIM;
use crate::encoders::{FrameTensors, ObsKind};
use crate::kernels::Pixels;
use crate::{Config, Error};
use avacraft_engine::{Env, Team, World, describe};
use avacraft_render::{CpuBackend, FrameBuilder, RgbImage};
use candle_core::{Device, Tensor};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// How many parts [`ObsSource::observe`] draws the environments in, in parallel.
const RENDER_PARTS: usize = 2;

/// Frame sizes `(width, height)` of the screen and the minimap.
pub type Sizes = ((usize, usize), (usize, usize));

fn sizes(cfg: &Config) -> Sizes {
    let [sw, sh] = cfg.screen_size;
    let [mw, mh] = cfg.minimap_size;
    ((sw as usize, sh as usize), (mw as usize, mh as usize))
}

/// The observations of `n` environments at one step, or of a batch's `n` steps.
#[derive(Clone, Debug, Default)]
pub struct StepFrames {
    pub n: usize,
    /// `n x H x W x 3`.
    pub screen: Vec<u8>,
    /// `n x h x w x 3`.
    pub minimap: Vec<u8>,
    /// `n x slots x 384` (`vision-text` only, else empty).
    pub text: Vec<f32>,
    sizes: Sizes,
}

impl StepFrames {
    /// Frames of `n` environments from raw pixels (HWC) of the given `(width, height)`
    /// sizes, `((screen), (minimap))` (tests and benchmarks; [`StepFrames::check`] them).
    pub fn from_pixels(n: usize, sizes: Sizes, screen: Vec<u8>, minimap: Vec<u8>) -> StepFrames {
        StepFrames { n, screen, minimap, text: Vec::new(), sizes }
    }

    /// As float tensors for the candle encoders.
    pub fn tensors(&self) -> Result<FrameTensors, Error> {
        frame_tensors(&self.screen, &self.minimap, &self.text, self.n, self.sizes)
    }

    /// Checks the pixel and embedding counts against `n` and the sizes.
    pub fn check(&self) -> Result<(), Error> {
        check_sizes(&self.screen, &self.minimap, &self.text, self.n, self.sizes)
    }

    /// As the fused encoder reads them: every frame, in order.
    pub fn pixels(&self) -> Pixels<'_> {
        Pixels { stored: self.n, screen: &self.screen, minimap: &self.minimap, text: &self.text, pick: None }
    }
}

fn frame_tensors(screen: &[u8], minimap: &[u8], text: &[f32], n: usize, sizes: Sizes) -> Result<FrameTensors, Error> {
    check_sizes(screen, minimap, text, n, sizes)?;
    let (s, m) = sizes;
    let text = if text.is_empty() { None } else { Some(Tensor::from_slice(text, (n, text.len() / n.max(1)), &Device::Cpu)?) };
    Ok(FrameTensors { screen: pixels_to_tensor(screen, n, s)?, minimap: pixels_to_tensor(minimap, n, m)?, text })
}

fn check_sizes(screen: &[u8], minimap: &[u8], text: &[f32], n: usize, (s, m): Sizes) -> Result<(), Error> {
    let check = |what: &str, got: usize, want: usize| {
        if got == want {
            Ok(())
        } else {
            Err(Error::Observation { message: format!("{what}: {got} values for {n} frames, {want} expected") })
        }
    };
    check("screen", screen.len(), n * s.0 * s.1 * 3)?;
    check("minimap", minimap.len(), n * m.0 * m.1 * 3)?;
    if !text.is_empty() {
        let width = text.len() / n.max(1);
        if !width.is_multiple_of(TEXT_DIM) {
            return Err(Error::Observation { message: format!("text: {} values for {n} frames, not slots of {TEXT_DIM}", text.len()) });
        }
        check("text", text.len(), n * width)?;
    }
    Ok(())
}

/// The frames of `steps` (each of the same `n` environments) as one batch of
/// `steps.len() x n` observations, step-major.
pub fn concat_steps(steps: &[StepFrames]) -> Result<StepFrames, Error> {
    let Some(first) = steps.first() else {
        return Err(Error::Observation { message: "no frames to batch".into() });
    };
    let (mut screen, mut minimap, mut text) = (Vec::new(), Vec::new(), Vec::new());
    for s in steps {
        if s.n != first.n || s.sizes != first.sizes {
            return Err(Error::Observation { message: format!("frames of {} and {} environments in one batch", first.n, s.n) });
        }
        screen.extend_from_slice(&s.screen);
        minimap.extend_from_slice(&s.minimap);
        text.extend_from_slice(&s.text);
    }
    Ok(StepFrames { n: steps.len() * first.n, screen, minimap, text, sizes: first.sizes })
}

/// An episode's stored observations, one per step (the `len + 1`-th row of the episode,
/// after its last step, has none: the encoder gives it zero features, and it is masked).
#[derive(Clone, Debug, Default)]
pub struct Frames {
    pub len: usize,
    screen: Vec<u8>,
    minimap: Vec<u8>,
    text: Vec<f32>,
}

impl Frames {
    /// Appends environment `env`'s observation of `step`.
    pub fn push(&mut self, step: &StepFrames, env: usize) {
        let ((sw, sh), (mw, mh)) = step.sizes;
        let (s, m) = (sw * sh * 3, mw * mh * 3);
        self.screen.extend_from_slice(&step.screen[env * s..(env + 1) * s]);
        self.minimap.extend_from_slice(&step.minimap[env * m..(env + 1) * m]);
        if !step.text.is_empty() {
            let width = step.text.len() / step.n.max(1);
            self.text.extend_from_slice(&step.text[env * width..(env + 1) * width]);
        }
        self.len += 1;
    }
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.screen.len() + self.minimap.len() + 4 * self.text.len()
    }
}

/// The frames of a batch of episodes: every real step's, episode after episode.
#[derive(Debug, Clone)]
pub struct FrameBatch {
    pub frames: StepFrames,
    /// Steps with frames per episode.
    pub lens: Vec<usize>,
}

impl FrameBatch {
    pub fn new(episodes: &[&Episode], cfg: &Config) -> Result<FrameBatch, Error> {
        let n: usize = episodes.iter().map(|e| e.frames.len).sum();
        let mut screen = Vec::new();
        let mut minimap = Vec::new();
        let mut text = Vec::new();
        for e in episodes {
            if e.frames.len != e.len {
                return Err(Error::Observation { message: format!("an episode of {} steps holds {} frames", e.len, e.frames.len) });
            }
            screen.extend_from_slice(&e.frames.screen);
            minimap.extend_from_slice(&e.frames.minimap);
            text.extend_from_slice(&e.frames.text);
        }
        let frames = StepFrames { n, screen, minimap, text, sizes: sizes(cfg) };
        frames.check()?;
        Ok(FrameBatch { frames, lens: episodes.iter().map(|e| e.frames.len).collect() })
    }
}

/// One part's renderer: the scene builder's caches, the CPU back end and its image.
#[derive(Debug, Default)]
struct Painter {
    frames: FrameBuilder,
    cpu: CpuBackend,
    image: RgbImage,
}

/// Renders (and describes) environments for an image mode.
///
/// The environments are drawn in [`RENDER_PARTS`] contiguous parts in parallel, each by a
/// painter of its own (the renderer's CPU back end, as its `Observer` draws the `rgb` mode,
/// which keeps caches across steps): drawing the frames took about as long as the fused
/// encoder's updates on them. Each frame depends on its environment only, so the frames are
/// the same whatever the threads.
#[derive(Debug)]
pub struct ObsSource {
    kind: ObsKind,
    painters: Vec<Painter>,
    text: Option<Arc<Mutex<TextEmbedder>>>,
    sizes: Sizes,
}

/// Where clause embeddings are kept between runs (`text_disk_cache`): `$AVACRAFT_TEXT_CACHE`,
/// else `$XDG_CACHE_HOME/avacraft`, else `~/.cache/avacraft`; `None` when off or when there
/// is no home.
pub fn disk_cache_dir(cfg: &Config) -> Option<PathBuf> {
    if !cfg.text_disk_cache {
        return None;
    }
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("AVACRAFT_TEXT_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("avacraft")))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("avacraft")))
}

impl ObsSource {
    /// The source `cfg` needs (`None` in `features` mode); `vision-text` loads the text
    /// model (an error naming the pip command when it is not installed), or shares the one
    /// another live source loaded ([`crate::encoders::clause_cache::shared`]).
    pub fn new(cfg: &Config) -> Result<Option<ObsSource>, Error> {
        if !cfg.obs.images() {
            return Ok(None);
        }
        let text = if cfg.obs.text() {
            let model = crate::encoders::text::locate()?;
            Some(crate::encoders::clause_cache::shared(model, cfg.text_max_tokens, cfg.text_cache, disk_cache_dir(cfg))?)
        } else {
            None
        };
        Ok(Some(ObsSource::with_text(cfg, text)))
    }

    /// A source with a given text embedder (tests share one model).
    pub fn with_text(cfg: &Config, text: Option<Arc<Mutex<TextEmbedder>>>) -> ObsSource {
        let painters = (0..RENDER_PARTS).map(|_| Painter::default()).collect();
        ObsSource { kind: cfg.obs, painters, text, sizes: sizes(cfg) }
    }

    /// The text embedder's counters, if this mode embeds texts.
    pub fn text_stats(&self) -> Option<TextStats> {
        self.text.as_ref().and_then(|t| t.lock().ok().map(|t| t.stats()))
    }

    /// Team 1's observation of each environment as it is now.
    pub fn observe(&mut self, envs: &[Env]) -> Result<StepFrames, Error> {
        let mut out = StepFrames { n: envs.len(), sizes: self.sizes, ..StepFrames::default() };
        let parts = self.painters.len().max(1);
        // An environment is not `Sync` (its scripted opponent); its world is.
        let worlds: Vec<&World> = envs.iter().map(Env::world).collect();
        let ((sw, sh), (mw, mh)) = self.sizes;
        let drawn: Vec<(Vec<u8>, Vec<u8>)> = self
            .painters
            .par_iter_mut()
            .enumerate()
            .map(|(p, painter)| {
                let (mut screen, mut minimap) = (Vec::new(), Vec::new());
                for world in &worlds[p * worlds.len() / parts..(p + 1) * worlds.len() / parts] {
                    let scene = painter.frames.screen(world, Team::One, sw as u32, sh as u32);
                    painter.cpu.render_into(&scene, &mut painter.image);
                    screen.extend_from_slice(painter.image.as_raw());
                    let scene = painter.frames.minimap(world, Team::One, mw as u32, mh as u32);
                    painter.cpu.render_into(&scene, &mut painter.image);
                    minimap.extend_from_slice(painter.image.as_raw());
                }
                (screen, minimap)
            })
            .collect();
        for (s, m) in drawn {
            out.screen.extend(s);
            out.minimap.extend(m);
        }
        if self.kind.text() {
            let Some(text) = self.text.as_ref() else {
                return Err(Error::Observation { message: "vision-text needs the text model".into() });
            };
            text_features(text, envs, &mut out.text)?;
        }
        // Validates the renderer's sizes against the config once per step.
        let ((sw, sh), (mw, mh)) = self.sizes;
        if out.screen.len() != envs.len() * sw * sh * 3 || out.minimap.len() != envs.len() * mw * mh * 3 {
            return Err(Error::Observation { message: "the renderer drew frames of another size than configured".into() });
        }
        Ok(out)
    }
}

/// Team 1's text features of each environment, `slots x 384` each, appended to `out`.
pub fn text_features(text: &Mutex<TextEmbedder>, envs: &[Env], out: &mut Vec<f32>) -> Result<(), Error> {
    let Some(first) = envs.first() else { return Ok(()) };
    // Every environment plays the same scenario: one layout.
    let layout = SlotLayout::of(first, Team::One);
    let texts: Vec<String> = envs.iter().map(|e| describe(e, Team::One)).collect();
    let docs: Vec<_> = texts.iter().map(|t| clauses(t, &layout)).collect();
    let mut text = text.lock().map_err(|_| Error::Observation { message: "a thread panicked holding the text embedder".into() })?;
    text.features(&docs, layout.slots(), out)
}
