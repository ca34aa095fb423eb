//! Images for a local model with a vision projector (llama.cpp's mtmd): each image's PNG is
//! decoded by mtmd, encoded by the projector and read into the context where its marker
//! stands in the prompt.

use super::decode::{BATCH, check_room};
use super::llama::{check_gguf_llm, local};
use crate::llm::{LlmError, Png};
use llama_cpp_2::context::LlamaContext;
use llama_cpp_2::model::LlamaModel;
use llama_cpp_2::mtmd::{MtmdBitmap, MtmdContext, MtmdContextParams, MtmdInputText};
use std::path::Path;

/// A loaded vision projector.
#[derive(Debug)]
pub(super) struct Vision {
    ctx: MtmdContext,
}

impl Vision {
    pub(super) fn load(path: &Path, model: &LlamaModel, n_threads: i32) -> Result<Vision, LlmError> {
        check_gguf_llm(path, "vision projector")?;
        let name = path.to_str().ok_or_else(|| local(format!("vision projector {}: the path is not UTF-8", path.display())))?;
        let params = MtmdContextParams { use_gpu: false, print_timings: false, n_threads, ..MtmdContextParams::default() };
        let ctx = MtmdContext::init_from_file(name, model, &params)
            .map_err(|e| local(format!("llama.cpp cannot load the vision projector {} for this model: {e}", path.display())))?;
        if !ctx.support_vision() {
            return Err(local(format!("{} is a projector without vision (audio only?)", path.display())));
        }
        Ok(Vision { ctx })
    }

    /// Reads the prompt `text` (with a marker where each of `images` goes) into `llama`;
    /// returns the next position and the prompt's token count, images included.
    pub(super) fn read(
        &mut self,
        llama: &mut LlamaContext<'_>,
        text: &str,
        images: &[&Png],
        n_ctx: u32,
        max_tokens: u32,
    ) -> Result<(i32, usize), LlmError> {
        let bitmaps = images
            .iter()
            .map(|png| MtmdBitmap::from_buffer(&self.ctx, &png.bytes, false))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| local(format!("cannot decode an image: {e}")))?;
        let refs: Vec<&MtmdBitmap> = bitmaps.iter().collect();
        let input = MtmdInputText { text: text.to_owned(), add_special: true, parse_special: true };
        let chunks = self.ctx.tokenize(input, &refs).map_err(|e| local(format!("cannot lay out the images in the prompt: {e}")))?;
        check_room(chunks.total_tokens(), n_ctx, max_tokens)?;
        let pos = chunks
            .eval_chunks(&mut self.ctx, llama, 0, 0, BATCH as i32, true)
            .map_err(|e| local(format!("reading the prompt and its images: {e}")))?;
        Ok((pos, chunks.total_tokens()))
    }
}
