//! The image modes' observations as the learners keep them. Frames are kept as the
//! renderer's u8 pixels (HWC) in the replay buffer, one per environment step rather than per
//! agent, and read as bytes by the fused CNN encoder ([`crate::kernels::conv`]); only the
//! candle encoders (Swin, the references) turn them into float tensors ([`FrameTensors`]).
//! At 80x60 plus 32x32 that is 17.5 kB a step (a 60-step episode about 1 MB; mind
//! `buffer_size`, 5,000 episodes by default). The text features add `slots x 384` floats a
//! step: 12 kB on 3m_vlm (8 slots), 18 kB on 2s3z_vlm (12).
//!
//! Apart from [`crate::observe`], which draws them: the replay buffer, the networks and the
//! encoders hold frames, and drawing needs none of those.

use crate::kernels::Pixels;
use crate::{Config, Error};
use avacraft_minilm::TEXT_DIM;
use candle_core::{DType, Device, Tensor};

/// Frame sizes `(width, height)` of the screen and the minimap.
pub type Sizes = ((usize, usize), (usize, usize));

pub(crate) fn sizes(cfg: &Config) -> Sizes {
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
    pub(crate) sizes: Sizes,
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

    /// Every frame of episodes' stored frames `stored`, episode after episode (a batch's).
    pub(crate) fn concat_stored(stored: &[&Frames], sizes: Sizes) -> StepFrames {
        let n: usize = stored.iter().map(|f| f.len).sum();
        let mut screen = Vec::new();
        let mut minimap = Vec::new();
        let mut text = Vec::new();
        for f in stored {
            screen.extend_from_slice(&f.screen);
            minimap.extend_from_slice(&f.minimap);
            text.extend_from_slice(&f.text);
        }
        StepFrames { n, screen, minimap, text, sizes }
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
#[derive(Clone, Debug, Default, PartialEq)]
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

/// Float tensors of `N` observations: images in [0, 1] and, in `vision-text`, embeddings.
#[derive(Debug, Clone)]
pub struct FrameTensors {
    /// `(N, 3, H, W)`.
    pub screen: Tensor,
    /// `(N, 3, h, w)`.
    pub minimap: Tensor,
    /// `(N, slots x 384)`: [`crate::encoders::clause_cache`]'s slot embeddings.
    pub text: Option<Tensor>,
}

/// u8 pixels `(N, H, W, 3)` (the renderer's layout) as floats in [0, 1] `(N, 3, H, W)`.
pub fn pixels_to_tensor(pixels: &[u8], n: usize, (w, h): (usize, usize)) -> Result<Tensor, Error> {
    let t = Tensor::from_slice(pixels, (n, h, w, 3), &Device::Cpu)?.to_dtype(DType::F32)?;
    Ok((t.permute((0, 3, 1, 2))?.contiguous()? / 255.0)?)
}
