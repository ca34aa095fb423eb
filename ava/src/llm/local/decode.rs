//! How a call runs on llama.cpp: a fresh context, the prompt read in batches, then tokens
//! sampled one by one until an end-of-generation token or `max_tokens`.

use super::llama::{backend, local};
use crate::llm::LlmError;
use llama_cpp_2::context::LlamaContext;
use llama_cpp_2::context::params::LlamaContextParams;
use llama_cpp_2::llama_batch::LlamaBatch;
use llama_cpp_2::model::LlamaModel;
use llama_cpp_2::sampling::LlamaSampler;
use llama_cpp_2::token::LlamaToken;
use std::num::NonZeroU32;

/// Tokens decoded per batch while reading the prompt.
pub(super) const BATCH: u32 = 512;

/// Refuses a prompt of `prompt` tokens that leaves less than `max_tokens` of the context.
pub(super) fn check_room(prompt: usize, n_ctx: u32, max_tokens: u32) -> Result<(), LlmError> {
    let room = u64::from(n_ctx).saturating_sub(u64::from(max_tokens));
    if prompt as u64 > room {
        return Err(local(format!(
            "the prompt is {prompt} tokens, more than the {room} that n_ctx {n_ctx} minus max_tokens {max_tokens} leaves; \
             raise n_ctx or lower max_tokens"
        )));
    }
    Ok(())
}

/// A fresh context over `model`.
pub(super) fn new_context(model: &LlamaModel, n_ctx: u32, n_threads: i32) -> Result<LlamaContext<'_>, LlmError> {
    let params = LlamaContextParams::default()
        .with_n_ctx(NonZeroU32::new(n_ctx))
        .with_n_batch(BATCH.min(n_ctx))
        .with_n_ubatch(BATCH.min(n_ctx))
        .with_n_threads(n_threads)
        .with_n_threads_batch(n_threads);
    model.new_context(backend()?, params).map_err(|e| local(format!("cannot make a {n_ctx}-token context: {e}")))
}

/// The seed of call `k`: SplitMix64 of the configured seed and `k`.
pub(super) fn call_seed(seed: u64, k: u64) -> u32 {
    let mut z = seed ^ k.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 32) as u32
}

/// Reads the prompt into `ctx`; returns the next position and the prompt's token count.
pub(super) fn read_prompt(
    model: &LlamaModel,
    ctx: &mut LlamaContext<'_>,
    text: &str,
    n_ctx: u32,
    max_tokens: u32,
) -> Result<(i32, usize), LlmError> {
    let tokens = model.vocab().tokenize(text.as_bytes(), true, true);
    if tokens.is_empty() {
        return Err(local("the prompt is empty"));
    }
    check_room(tokens.len(), n_ctx, max_tokens)?;
    let mut batch = LlamaBatch::new(BATCH as usize, 1);
    let mut pos = 0i32;
    for chunk in tokens.chunks(BATCH as usize) {
        batch.clear();
        for (i, &t) in chunk.iter().enumerate() {
            batch.add(t, pos, &[0], i + 1 == chunk.len()).map_err(|e| local(e.to_string()))?;
            pos += 1;
        }
        ctx.decode(&mut batch).map_err(|e| local(format!("reading the prompt: {e}")))?;
    }
    Ok((pos, tokens.len()))
}

/// Generates up to `max_tokens`; returns the answer's bytes, its token count and why it stopped.
pub(super) fn generate(
    model: &LlamaModel,
    ctx: &mut LlamaContext<'_>,
    sampler: &mut LlamaSampler,
    mut pos: i32,
    max_tokens: u32,
) -> Result<(Vec<u8>, u64, &'static str), LlmError> {
    let vocab = model.vocab();
    let mut batch = LlamaBatch::new(1, 1);
    let mut out = Vec::new();
    let mut n = 0u64;
    loop {
        if n >= u64::from(max_tokens) {
            return Ok((out, n, "length"));
        }
        let token: LlamaToken = sampler.sample(ctx, -1);
        if vocab.is_eog(token) {
            return Ok((out, n, "stop"));
        }
        out.extend(vocab.token_to_piece(token, false, None));
        n += 1;
        batch.clear();
        batch.add(token, pos, &[0], true).map_err(|e| local(e.to_string()))?;
        pos += 1;
        ctx.decode(&mut batch).map_err(|e| local(format!("generating: {e}")))?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn room_is_checked_and_named() {
        assert!(check_room(3072, 4096, 1024).is_ok());
        let e = check_room(3073, 4096, 1024).expect_err("one token too many");
        let msg = e.to_string();
        assert!(msg.contains("3073") && msg.contains("n_ctx 4096") && msg.contains("max_tokens 1024"), "{msg}");
        assert!(check_room(1, 100, 200).is_err(), "max_tokens beyond the context leaves no room");
    }

    #[test]
    fn call_seeds_differ_by_seed_and_call() {
        let a: Vec<u32> = (0..4).map(|k| call_seed(7, k)).collect();
        assert_eq!(a, (0..4).map(|k| call_seed(7, k)).collect::<Vec<_>>());
        assert!(a.windows(2).all(|w| w[0] != w[1]), "{a:?}");
        assert_ne!(call_seed(7, 0), call_seed(8, 0));
    }
}
