//! One interface over the back ends, and the choice between them.

use crate::cpu::CpuBackend;
use crate::gpu::{GpuError, WgpuBackend};
use crate::scene::Scene;
use image::RgbImage;

/// Something that draws a [`Scene`].
pub trait Backend: std::fmt::Debug {
    /// A short name for reports ("cpu", "wgpu: llvmpipe ...").
    fn name(&self) -> String;
    fn render(&mut self, scene: &Scene) -> Result<RgbImage, GpuError>;
}

impl Backend for CpuBackend {
    fn name(&self) -> String {
        "cpu".to_owned()
    }
    fn render(&mut self, scene: &Scene) -> Result<RgbImage, GpuError> {
        Ok(CpuBackend::render(self, scene))
    }
}

impl Backend for WgpuBackend {
    fn name(&self) -> String {
        format!("wgpu: {}", self.adapter())
    }
    fn render(&mut self, scene: &Scene) -> Result<RgbImage, GpuError> {
        WgpuBackend::render(self, scene)
    }
}

/// Which back end to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// The CPU rasteriser: fastest for small MARL frames, available everywhere.
    #[default]
    Cpu,
    /// wgpu; an error where no adapter exists.
    Wgpu,
    /// wgpu where an adapter exists, else the CPU.
    Auto,
}

impl BackendChoice {
    pub fn open(self) -> Result<Box<dyn Backend + Send>, GpuError> {
        Ok(match self {
            BackendChoice::Cpu => Box::new(CpuBackend::new()),
            BackendChoice::Wgpu => Box::new(WgpuBackend::new()?),
            BackendChoice::Auto => match WgpuBackend::new() {
                Ok(g) => Box::new(g),
                Err(_) => Box::new(CpuBackend::new()),
            },
        })
    }
}
