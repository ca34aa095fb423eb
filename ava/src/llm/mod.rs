//! Model back ends behind one trait: a chat request (text and image parts, an optional JSON
//! schema, sampling settings) in, the model's text with token counts and latency out.
//!
//! [`OpenAi`] speaks the chat-completions protocol that OpenAI, vLLM, Ollama and llama.cpp's
//! server share; `Local` (feature `local`) runs a GGUF model on the CPU, offline; [`Replay`]
//! answers from a recorded run without calling anything; [`Scripted`] answers from a list
//! (tests, dry runs). Every call the agent makes goes through a
//! [`Recorder`], which writes it to the run folder before the answer is used.

mod ceiling;
#[cfg(feature = "local")]
mod local;
mod openai;
mod record;
mod synthetic;

pub use ceiling::{Ceiling, CeilingScript, Read, Seen, ceiling_decision, read_prompt};
#[cfg(feature = "local")]
pub use local::{GgufError, Local, LocalConfig, LocalStats, SMOLLM2, SMOLLM2_ENV, SMOLLM2_FILE, SMOLLM2_INSTALL, check_gguf, find_smollm2};
pub use openai::{OpenAi, OpenAiConfig, SchemaMode};
pub use record::{CallRecord, RecordError, Recorder, Replay, StoredMessage, StoredPart, read_calls, unstored};
pub use synthetic::{Synthetic, first_user_text, synthetic_answer, tags_under};

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::sync::Arc;

/// Which step of the pipeline asked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    Planner,
    Priority,
    Roles,
    Decision,
}

impl Stage {
    pub const ALL: [Stage; 4] = [Stage::Planner, Stage::Priority, Stage::Roles, Stage::Decision];
    pub fn name(self) -> &'static str {
        match self {
            Stage::Planner => "planner",
            Stage::Priority => "priority",
            Stage::Roles => "roles",
            Stage::Decision => "decision",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    System,
    User,
    Assistant,
}

/// A PNG image, encoded once and shared by the requests that show it.
#[derive(Clone, Debug, PartialEq)]
pub struct Png {
    pub bytes: Arc<Vec<u8>>,
    pub width: u32,
    pub height: u32,
}

impl Png {
    /// Encodes an RGB image. Fast compression: a decision's screenshots are encoded while
    /// the game waits, and flat-coloured renders compress well anyway.
    pub fn encode(img: &image::RgbImage) -> Result<Png, image::ImageError> {
        use image::ImageEncoder as _;
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        let mut bytes = Vec::new();
        PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, FilterType::Sub).write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )?;
        Ok(Png { bytes: Arc::new(bytes), width: img.width(), height: img.height() })
    }
    /// A content hash, which names the image's file in a recording.
    pub fn hash(&self) -> String {
        format!("{:016x}", xxhash_rust::xxh3::xxh3_64(&self.bytes))
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Part {
    Text(String),
    Image(Png),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub role: Role,
    pub parts: Vec<Part>,
}

impl Message {
    pub fn text(role: Role, text: impl Into<String>) -> Message {
        Message { role, parts: vec![Part::Text(text.into())] }
    }
}

/// Sampling settings; the defaults are the paper's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sampling {
    pub temperature: f32,
    pub top_p: f32,
    /// At most this many tokens per answer.
    pub max_tokens: u32,
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling { temperature: 0.7, top_p: 0.95, max_tokens: 1024 }
    }
}

/// One call to a model.
#[derive(Clone, Debug, PartialEq)]
pub struct ChatRequest {
    pub stage: Stage,
    pub messages: Vec<Message>,
    /// The answer's JSON schema, with a name for the servers that want one.
    pub schema: Option<(String, Value)>,
    pub sampling: Sampling,
}

impl ChatRequest {
    /// A hash of everything the model is shown and asked: a replay checks it, so a replayed
    /// run that would ask something else stops instead of using an answer to another prompt.
    pub fn hash(&self) -> String {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        for m in &self.messages {
            h.update(format!("{:?}\u{0}", m.role).as_bytes());
            for p in &m.parts {
                match p {
                    Part::Text(t) => h.update(t.as_bytes()),
                    Part::Image(png) => h.update(png.hash().as_bytes()),
                }
                h.update(b"\0");
            }
        }
        if let Some((name, schema)) = &self.schema {
            h.update(name.as_bytes());
            h.update(canonical_text(schema).as_bytes());
        }
        format!("{:016x}", h.digest())
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Usage {
    pub prompt_tokens: u64,
    pub completion_tokens: u64,
}

/// A model's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChatReply {
    pub text: String,
    /// As the server reported them (`None`: it did not).
    pub usage: Option<Usage>,
    /// Wall-clock time of the call, milliseconds.
    pub latency_ms: f64,
    /// The model that answered, as the server names it.
    pub model: String,
    /// Why generation stopped (`stop`, `length`, ...), when reported.
    pub finish: Option<String>,
}

/// Why a call produced no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LlmError {
    #[error("cannot reach {url}: {message}")]
    Transport { url: String, message: String },
    #[error("{url} did not answer within {seconds} s")]
    Timeout { url: String, seconds: f64 },
    #[error("{url} answered HTTP {status}: {body}")]
    Status { url: String, status: u16, body: String },
    #[error("{url} answered something that is not a chat completion: {why}")]
    Envelope { url: String, why: String },
    #[error("replay: {why}")]
    Replay { why: String },
    #[error("local model: {why}")]
    Local { why: String },
}

impl LlmError {
    /// Worth trying again after a pause: the network, a timeout, rate limits and server
    /// errors. A refused request (4xx) or a broken replay will not get better.
    pub fn retryable(&self) -> bool {
        match self {
            LlmError::Transport { .. } | LlmError::Timeout { .. } => true,
            LlmError::Status { status, .. } => *status == 429 || *status >= 500,
            LlmError::Envelope { .. } | LlmError::Replay { .. } | LlmError::Local { .. } => false,
        }
    }
}

/// A model back end.
pub trait ChatModel: Send {
    /// The model's name as configured (`gpt-4o`, `replay:runs/x`).
    fn model(&self) -> &str;
    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError>;
    /// Whether retries should wait (a replay answers at once, and waiting would only slow it).
    fn waits(&self) -> bool {
        true
    }
}

/// Answers from a fixed list, in order (then repeats the last): for tests and `--dry-run`.
#[derive(Clone, Debug)]
pub struct Scripted {
    answers: Vec<String>,
    next: usize,
}

impl Scripted {
    pub fn new(answers: Vec<String>) -> Scripted {
        Scripted { answers, next: 0 }
    }
}

impl ChatModel for Scripted {
    fn model(&self) -> &str {
        "scripted"
    }
    fn complete(&mut self, _req: &ChatRequest) -> Result<ChatReply, LlmError> {
        let text = self.answers.get(self.next).or(self.answers.last()).cloned().unwrap_or_default();
        self.next += 1;
        Ok(ChatReply { text, usage: None, latency_ms: 0.0, model: "scripted".into(), finish: Some("stop".into()) })
    }
    fn waits(&self) -> bool {
        false
    }
}

/// The schema's text with each object's properties in the order of its `required` list (the
/// others after them, by name). Constrained decoders (llama.cpp's grammar, OpenAI's strict
/// mode) make the model write the properties in the order the text lists them, and
/// serde_json's maps list them by name: a decision item would start with `ability` and end
/// with `unit`, and `actions` would come before `reasoning`. In the schema's own order the
/// model names the unit first and reasons before it acts, as the schema's author meant.
pub(crate) fn schema_text(schema: &Value) -> String {
    json_text(schema, true)
}

/// The value's JSON with every object's keys by name, whatever order the map keeps them in
/// (serde_json keeps insertion order in any build where some crate turns on its
/// `preserve_order`; llguidance does): what a request's hash is taken over, so that a
/// recording replays in every build.
pub(crate) fn canonical_text(v: &Value) -> String {
    json_text(v, false)
}

/// JSON text with object keys by name; with `required_first`, the keys of each `properties`
/// object in the order of its sibling `required` list first.
fn json_text(v: &Value, required_first: bool) -> String {
    fn write(v: &Value, order: Option<&Vec<Value>>, required_first: bool, out: &mut String) {
        match v {
            Value::Object(map) => {
                let rank = |k: &str| order.and_then(|o| o.iter().position(|r| r.as_str() == Some(k))).unwrap_or(usize::MAX);
                let mut keys: Vec<&String> = map.keys().collect();
                keys.sort_by(|a, b| rank(a).cmp(&rank(b)).then_with(|| a.cmp(b)));
                out.push('{');
                for (i, k) in keys.into_iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    out.push_str(&Value::from(k.as_str()).to_string());
                    out.push(':');
                    let inner = if required_first && k == "properties" { map.get("required").and_then(Value::as_array) } else { None };
                    write(&map[k], inner, required_first, out);
                }
                out.push('}');
            }
            Value::Array(items) => {
                out.push('[');
                for (i, x) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    write(x, None, required_first, out);
                }
                out.push(']');
            }
            scalar => out.push_str(&scalar.to_string()),
        }
    }
    let mut out = String::new();
    write(v, None, required_first, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::{canonical_text, schema_text};
    use serde_json::{Value, json};

    #[test]
    fn properties_are_listed_in_the_order_they_are_required() {
        let schema = json!({"type": "object", "properties": {"b": {"type": "integer"}, "z": {"type": "object", "properties": {"y": {}, "x": {}}, "required": ["y", "x"]}, "a": {"enum": ["q\""]}},
            "required": ["z", "b"]});
        let text = schema_text(&schema);
        assert_eq!(
            text,
            r#"{"properties":{"z":{"properties":{"y":{},"x":{}},"required":["y","x"],"type":"object"},"b":{"type":"integer"},"a":{"enum":["q\""]}},"required":["z","b"],"type":"object"}"#
        );
        assert_eq!(serde_json::from_str::<Value>(&text).ok(), Some(schema), "the same schema");
    }

    #[test]
    fn the_canonical_text_lists_keys_by_name_whatever_the_insertion_order() {
        let mut a = serde_json::Map::new();
        a.insert("z".into(), json!({"b": 1, "a": [{"y": null, "x": "q"}]}));
        a.insert("m".into(), json!(2.5));
        let mut b = serde_json::Map::new();
        b.insert("m".into(), json!(2.5));
        b.insert("z".into(), json!({"a": [{"x": "q", "y": null}], "b": 1}));
        let (a, b) = (canonical_text(&Value::Object(a)), canonical_text(&Value::Object(b)));
        assert_eq!(a, b);
        assert_eq!(a, r#"{"m":2.5,"z":{"a":[{"x":"q","y":null}],"b":1}}"#, "serde_json's own text without preserve_order");
    }
}
