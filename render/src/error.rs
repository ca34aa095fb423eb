//! The back ends' error, in a module of its own: the wgpu back end is compiled only with the
//! `gpu` feature, and [`Backend`](crate::Backend) must keep one signature without it; kept
//! out of `backend`, which chooses among the back ends, so that the wgpu back end does not
//! import the module that imports it.

/// Why a GPU frame could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter (on Debian, `apt-get install mesa-vulkan-drivers` gives a CPU one): {0}")]
    NoAdapter(String),
    #[error("the GPU device could not be created: {0}")]
    Device(String),
    #[error("reading the frame back failed: {0}")]
    Readback(String),
    #[error("a {w}x{h} frame is outside what this device can render (1..={max} per side, {bytes} bytes to read back at most)")]
    Size { w: u32, h: u32, max: u32, bytes: u64 },
}
