//! Episode videos as animated GIFs, which any browser or image viewer plays.

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbImage, RgbaImage};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    #[error("{path}: cannot create or write the video file: {source}")]
    Create { path: PathBuf, source: std::io::Error },
    #[error("{path}: cannot write a frame: {source}")]
    Encode { path: PathBuf, source: image::ImageError },
}

/// A file that remembers its first write error: the GIF encoder writes its trailer and the
/// buffer flushes when dropped, where errors cannot be returned.
struct Tracked {
    file: File,
    error: Arc<Mutex<Option<std::io::Error>>>,
}

impl Write for Tracked {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf).inspect_err(|e| self.remember(e))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush().inspect_err(|e| self.remember(e))
    }
}

impl Tracked {
    fn remember(&self, e: &std::io::Error) {
        if let Ok(mut slot) = self.error.lock()
            && slot.is_none()
        {
            *slot = Some(std::io::Error::new(e.kind(), e.to_string()));
        }
    }
}

/// Writes frames to a GIF as they come, so a long episode never sits in memory.
pub struct VideoWriter {
    path: PathBuf,
    encoder: GifEncoder<BufWriter<Tracked>>,
    error: Arc<Mutex<Option<std::io::Error>>>,
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
        let error = Arc::new(Mutex::new(None));
        // Speed 30: the fastest colour quantisation; frames have few colours anyway.
        let mut encoder = GifEncoder::new_with_speed(BufWriter::new(Tracked { file, error: Arc::clone(&error) }), 30);
        encoder.set_repeat(Repeat::Infinite).map_err(|source| VideoError::Encode { path: path.to_owned(), source })?;
        Ok(Self { path: path.to_owned(), encoder, error, delay_ms, frames: 0 })
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

    /// Writes the GIF trailer and flushes the file, reporting any error (dropping the writer
    /// would swallow it and could leave a truncated file behind).
    pub fn finish(self) -> Result<u32, VideoError> {
        let Self { path, encoder, error, frames, .. } = self;
        drop(encoder);
        match error.lock().ok().and_then(|mut e| e.take()) {
            Some(source) => Err(VideoError::Create { path, source }),
            None => Ok(frames),
        }
    }
}
