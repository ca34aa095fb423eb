//! Pixels for AVACraft: the MARL screen and minimap, the annotated screenshot for VLM agents,
//! and episode videos, all obeying the viewing team's fog of war.
//!
//! VLM agents get [`FrameBuilder::vlm_obs`]: the screenshot drawn from an agent's
//! observation alone, framed by a StarCraft II-like [`Camera`] over the team's units.
//!
//! Frames are built as a back-end-independent display list ([`Scene`]) and drawn by a back
//! end: [`CpuBackend`] runs everywhere, [`WgpuBackend`] wherever wgpu finds an adapter
//! (Mesa's lavapipe gives one on machines without a GPU).
#![forbid(unsafe_code)]

mod backend;
mod camera;
mod cpu;
mod draw;
mod error;
mod font;
mod frame;
// wgpu is heavy to compile; the `gpu` feature (on by default) brings it in, and builds
// that only need CPU frames (the Python extension) leave it out.
#[cfg(feature = "gpu")]
mod gpu;
mod map_view;
mod modes;
mod obs_frame;
mod scene;
mod style;
mod video;

pub use backend::{Backend, BackendChoice};
pub use camera::Camera;
pub use cpu::CpuBackend;
pub use error::GpuError;
pub use frame::{FrameBuilder, FramePainter, VlmOptions, vlm_layout};
#[cfg(feature = "gpu")]
pub use gpu::WgpuBackend;
pub use map_view::MapView;
pub use modes::{ObsMode, Observation, Observer, RenderConfig};
pub use obs_frame::{ObsLayout, vlm_obs_layout};
pub use scene::{Prim, Rgba, Scene};
pub use style::{ENEMY, OWN};
pub use video::{VideoError, VideoWriter};

pub use image::RgbImage;
