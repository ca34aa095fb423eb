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
use llama_cpp_2::token::data::LlamaTokenData;
use llama_cpp_2::token::data_array::LlamaTokenDataArray;
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

/// How a call draws its tokens: the draw (greedy, or temperature, nucleus and a seeded
/// draw) and the answer schema's grammar, kept apart. Applying a grammar checks every token of
/// the vocabulary (49,152 for SmolLM2) against it, so each token is first drawn without it and
/// only that token checked; the grammar filters the whole vocabulary only when the token
/// fails, and the token is drawn again from what it allows (llama.cpp's own common sampler
/// does the same). Without truncation this draws from exactly the constrained distribution:
/// a valid token x comes out with p(x) + (1 - Z) p(x) / Z = p(x) / Z, Z being the valid
/// tokens' mass; greedy decoding picks the same token as filtering first.
pub(super) struct Draw {
    pub(super) grammar: Option<LlamaSampler>,
    pub(super) draw: LlamaSampler,
}

impl Draw {
    /// The next token from the last decoded logits; accepted by the grammar and the draw.
    fn next(&mut self, ctx: &LlamaContext<'_>) -> LlamaToken {
        let t = pick(&mut ctx.token_data_array(), &mut self.draw);
        let token = match &mut self.grammar {
            None => t,
            Some(grammar) => {
                // The grammar only sets a refused token's logit to minus infinity.
                let mut one = LlamaTokenDataArray::new(vec![LlamaTokenData::new(t, 0.0, 0.0)], false);
                grammar.apply(&mut one);
                if one.data.first().is_some_and(|d| d.logit().is_finite()) {
                    t
                } else {
                    // Rare: the whole vocabulary again, filtered this time.
                    let mut all = ctx.token_data_array();
                    grammar.apply(&mut all);
                    pick(&mut all, &mut self.draw)
                }
            }
        };
        if let Some(g) = &mut self.grammar {
            g.accept(token);
        }
        self.draw.accept(token);
        token
    }
}

/// The draw's token from `data` (its selection; the first candidate if it selected none).
fn pick(data: &mut LlamaTokenDataArray, draw: &mut LlamaSampler) -> LlamaToken {
    draw.apply(data);
    data.selected_token().or_else(|| data.data.first().map(LlamaTokenData::id)).unwrap_or(LlamaToken::new(0))
}

/// Generates up to `max_tokens`; returns the answer's bytes, its token count and why it stopped.
pub(super) fn generate(
    model: &LlamaModel,
    ctx: &mut LlamaContext<'_>,
    sampler: &mut Draw,
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
        let token = sampler.next(ctx);
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
