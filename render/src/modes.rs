//! The paper's four observation modes, selectable per environment.

use crate::backend::Backend;
use crate::cpu::CpuBackend;
use crate::frame::{FrameBuilder, VlmOptions};
use avacraft_engine::{Env, Team, UnitInfo, describe, unit_list};
use image::RgbImage;

/// Image sizes (width, height) of the three frame kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sizes {
    pub screen: (u32, u32),
    pub minimap: (u32, u32),
    pub vlm: (u32, u32),
}

/// Frame sizes; the paper's defaults are a 160x120 screen, a 32x32 minimap and a 1920x1080
/// VLM screenshot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderConfig(pub Sizes);

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig(Sizes { screen: (160, 120), minimap: (32, 32), vlm: (1920, 1080) })
    }
}

impl RenderConfig {
    pub fn screen(&self) -> (u32, u32) {
        self.0.screen
    }
    pub fn minimap(&self) -> (u32, u32) {
        self.0.minimap
    }
    pub fn vlm(&self) -> (u32, u32) {
        self.0.vlm
    }
    pub fn with_screen(mut self, w: u32, h: u32) -> Self {
        self.0.screen = (w.max(1), h.max(1));
        self
    }
    pub fn with_minimap(mut self, w: u32, h: u32) -> Self {
        self.0.minimap = (w.max(1), h.max(1));
        self
    }
    pub fn with_vlm(mut self, w: u32, h: u32) -> Self {
        self.0.vlm = (w.max(1), h.max(1));
        self
    }
}

/// Which observation an environment hands its agents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObsMode {
    /// Screen and minimap images.
    Rgb,
    /// SMAC-compatible features.
    Features,
    /// Both.
    Hybrid,
    /// Annotated screenshot, text description and structured unit list.
    Vlm,
}

/// SMAC features for every agent of a team.
#[derive(Clone, Debug, PartialEq)]
pub struct Features {
    pub obs: Vec<Vec<f32>>,
    pub state: Vec<f32>,
    pub avail: Vec<Vec<u8>>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Observation {
    Rgb { screen: RgbImage, minimap: RgbImage },
    Features(Features),
    Hybrid { screen: RgbImage, minimap: RgbImage, features: Features },
    Vlm { screenshot: RgbImage, text: String, units: Vec<UnitInfo> },
}

/// Produces observations of one mode for an environment, reusing its buffers. Frames come
/// from the CPU back end unless another is given ([`Observer::with_backend`]); a back end
/// that fails on a frame falls back to the CPU for that frame, so no observation is lost.
#[derive(Debug)]
pub struct Observer {
    pub config: RenderConfig,
    pub mode: ObsMode,
    frames: FrameBuilder,
    cpu: CpuBackend,
    backend: Option<Box<dyn Backend + Send>>,
}

impl Observer {
    pub fn new(mode: ObsMode, config: RenderConfig) -> Self {
        Self { config, mode, frames: FrameBuilder::new(), cpu: CpuBackend::new(), backend: None }
    }

    /// Draws with `backend` (e.g. `BackendChoice::Auto.open()?`).
    pub fn with_backend(mut self, backend: Box<dyn Backend + Send>) -> Self {
        self.backend = Some(backend);
        self
    }

    fn draw(&mut self, scene: &crate::Scene) -> RgbImage {
        match self.backend.as_mut().map(|b| b.render(scene)) {
            Some(Ok(img)) => img,
            _ => self.cpu.render(scene),
        }
    }

    pub fn screen(&mut self, env: &Env, team: Team) -> RgbImage {
        let (w, h) = self.config.screen();
        let scene = self.frames.screen(env.world(), team, w, h);
        self.draw(&scene)
    }

    pub fn minimap(&mut self, env: &Env, team: Team) -> RgbImage {
        let (w, h) = self.config.minimap();
        let scene = self.frames.minimap(env.world(), team, w, h);
        self.draw(&scene)
    }

    pub fn screenshot(&mut self, env: &Env, team: Team, opts: &VlmOptions) -> RgbImage {
        let (w, h) = self.config.vlm();
        let scene = self.frames.vlm(env.world(), team, w, h, opts);
        self.draw(&scene)
    }

    fn features(env: &Env, team: Team) -> Features {
        let l = env.smac_layout(team);
        let obs = (0..l.n_agents)
            .map(|a| {
                let mut o = vec![0.0; l.obs_size];
                env.obs_agent(team, a, &mut o);
                o
            })
            .collect();
        let avail = (0..l.n_agents)
            .map(|a| {
                let mut m = vec![0; l.n_actions];
                env.avail_agent(team, a, &mut m);
                m
            })
            .collect();
        let mut state = vec![0.0; l.state_size];
        env.state(team, &mut state);
        Features { obs, state, avail }
    }

    /// The observation of this observer's mode for `team`.
    pub fn observe(&mut self, env: &Env, team: Team, opts: &VlmOptions) -> Observation {
        match self.mode {
            ObsMode::Rgb => Observation::Rgb { screen: self.screen(env, team), minimap: self.minimap(env, team) },
            ObsMode::Features => Observation::Features(Self::features(env, team)),
            ObsMode::Hybrid => Observation::Hybrid {
                screen: self.screen(env, team),
                minimap: self.minimap(env, team),
                features: Self::features(env, team),
            },
            ObsMode::Vlm => Observation::Vlm {
                screenshot: self.screenshot(env, team, opts),
                text: describe(env, team),
                units: unit_list(env.world(), team),
            },
        }
    }
}
