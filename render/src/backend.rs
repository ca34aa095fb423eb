//! One interface over the back ends, and the choice between them.

use crate::cpu::CpuBackend;
use crate::error::GpuError;
#[cfg(feature = "gpu")]
use crate::gpu::WgpuBackend;
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

#[cfg(feature = "gpu")]
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
            #[cfg(feature = "gpu")]
            BackendChoice::Wgpu => Box::new(WgpuBackend::new()?),
            #[cfg(feature = "gpu")]
            BackendChoice::Auto => match WgpuBackend::new() {
                Ok(g) => Box::new(g),
                Err(_) => Box::new(CpuBackend::new()),
            },
            #[cfg(not(feature = "gpu"))]
            BackendChoice::Wgpu => return Err(GpuError::NoAdapter("avacraft-render was built without its `gpu` feature".to_owned())),
            #[cfg(not(feature = "gpu"))]
            BackendChoice::Auto => Box::new(CpuBackend::new()),
        })
    }
}
