//! Episode videos as animated GIFs, which any browser or image viewer plays.

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbImage, RgbaImage};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    #[error("{path}: cannot create the video file: {source}")]
    Create { path: PathBuf, source: std::io::Error },
    #[error("{path}: cannot write a frame: {source}")]
    Encode { path: PathBuf, source: image::ImageError },
}

/// Writes frames to a GIF as they come, so a long episode never sits in memory.
pub struct VideoWriter {
    path: PathBuf,
    encoder: GifEncoder<BufWriter<File>>,
    delay_ms: u32,
    frames: u32,
}

impl std::fmt::Debug for VideoWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoWriter").field("path", &self.path).field("frames", &self.frames).finish()
    }
}

impl VideoWriter {
    /// A GIF at `path` showing each frame for `delay_ms`.
    pub fn create(path: &Path, delay_ms: u32) -> Result<Self, VideoError> {
        let file = File::create(path).map_err(|source| VideoError::Create { path: path.to_owned(), source })?;
        // Speed 30: the fastest colour quantisation; frames have few colours anyway.
        let mut encoder = GifEncoder::new_with_speed(BufWriter::new(file), 30);
        encoder.set_repeat(Repeat::Infinite).map_err(|source| VideoError::Encode { path: path.to_owned(), source })?;
        Ok(Self { path: path.to_owned(), encoder, delay_ms, frames: 0 })
    }

    pub fn push(&mut self, img: &RgbImage) -> Result<(), VideoError> {
        let rgba: RgbaImage = image::DynamicImage::ImageRgb8(img.clone()).to_rgba8();
        let frame = Frame::from_parts(rgba, 0, 0, Delay::from_numer_denom_ms(self.delay_ms, 1));
        self.encoder.encode_frame(frame).map_err(|source| VideoError::Encode { path: self.path.clone(), source })?;
        self.frames += 1;
        Ok(())
    }

    pub fn frames(&self) -> u32 {
        self.frames
    }
}
