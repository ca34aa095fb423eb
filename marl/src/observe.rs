//! Where the image modes' observations come from while training: every step, team 1's
//! screen and minimap of each of the vector environment's environments, drawn by the
//! renderer's CPU back end from the environment's current state (after an automatic reset,
//! the new episode's first state, as the feature buffers hold), and in `vision-text` the
//! slot embeddings of the team's text description (the Python package's `vlm` text, cut
//! into clauses: [`crate::encoders::clauses`], [`crate::encoders::clause_cache`]).
//!
//! One view per team (the renderer has no per-unit view): the agents of an environment
//! share its frames and tell themselves apart by their agent id. How the frames are kept:
//! [`crate::frames`].

use crate::encoders::ObsKind;
use crate::encoders::clause_cache::TextEmbedder;
use crate::encoders::clauses::{SlotLayout, clauses};
use crate::frames::sizes;
use crate::{Config, Error};
use avacraft_engine::{Env, Team, World, describe};
use avacraft_render::{CpuBackend, FrameBuilder, RgbImage};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

// The frame types were defined here; their old paths stay valid.
pub use crate::buffer::FrameBatch;
pub use crate::frames::{Frames, Sizes, StepFrames, concat_steps};

/// How many parts [`ObsSource::observe`] draws the environments in, in parallel.
const RENDER_PARTS: usize = 2;

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
