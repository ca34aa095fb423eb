//! The chat-completions protocol OpenAI, vLLM, Ollama and llama.cpp's server share: text and
//! `image_url` parts (PNG as base64 data URLs), `response_format` with a JSON schema where
//! the server takes one, and `usage` token counts in the answer.

use super::{ChatModel, ChatReply, ChatRequest, LlmError, Part, Role, Usage};
use base64::Engine as _;
use serde::{Deserialize, Serialize};
use serde_json::value::RawValue;
use serde_json::{Value, json};
use std::time::{Duration, Instant};

/// How the answer's schema is asked for. Servers differ: OpenAI, vLLM, Ollama and llama.cpp
/// take `json_schema`; some only `json_object`; some nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum SchemaMode {
    #[default]
    JsonSchema,
    JsonObject,
    /// The schema goes into the prompt only.
    None,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpenAiConfig {
    /// Up to `/v1` (`https://api.openai.com/v1`, `http://localhost:11434/v1`).
    pub base_url: String,
    pub model: String,
    /// The API key's value (never recorded).
    #[serde(skip)]
    pub key: Option<String>,
    /// Whole-call time limit.
    pub timeout_s: f64,
    pub schema_mode: SchemaMode,
}

/// A client of one endpoint and model.
#[derive(Debug)]
pub struct OpenAi {
    cfg: OpenAiConfig,
    url: String,
    agent: ureq::Agent,
}

impl OpenAi {
    pub fn new(cfg: OpenAiConfig) -> OpenAi {
        let url = format!("{}/chat/completions", cfg.base_url.trim_end_matches('/'));
        let timeout = Duration::from_secs_f64(cfg.timeout_s.clamp(0.001, 86_400.0));
        let agent = ureq::Agent::config_builder().timeout_global(Some(timeout)).http_status_as_error(false).build().into();
        OpenAi { cfg, url, agent }
    }

    /// The request body, as sent. The schema keeps its properties in the order of `required`
    /// ([`super::schema_text`]): in strict mode the model writes them in the order listed.
    pub fn body(&self, req: &ChatRequest) -> Result<String, LlmError> {
        let messages: Vec<Value> = req
            .messages
            .iter()
            .map(|m| {
                let role = match m.role {
                    Role::System => "system",
                    Role::User => "user",
                    Role::Assistant => "assistant",
                };
                // Text-only messages as plain strings: every server takes those.
                let content = match m.parts.as_slice() {
                    [Part::Text(t)] => json!(t),
                    parts => Value::Array(
                        parts
                            .iter()
                            .map(|p| match p {
                                Part::Text(t) => json!({"type": "text", "text": t}),
                                Part::Image(png) => {
                                    let b64 = base64::engine::general_purpose::STANDARD.encode(png.bytes.as_slice());
                                    json!({"type": "image_url", "image_url": {"url": format!("data:image/png;base64,{b64}")}})
                                }
                            })
                            .collect(),
                    ),
                };
                json!({"role": role, "content": content})
            })
            .collect();
        let response_format = match (&req.schema, self.cfg.schema_mode) {
            (Some((name, schema)), SchemaMode::JsonSchema) => {
                let schema = RawValue::from_string(super::schema_text(schema)).map_err(|e| self.envelope(e))?;
                Some(ResponseFormat::JsonSchema { json_schema: JsonSchema { name, schema, strict: true } })
            }
            (Some(_), SchemaMode::JsonObject) => Some(ResponseFormat::JsonObject),
            (Some(_), SchemaMode::None) | (None, _) => None,
        };
        let body = Body {
            model: &self.cfg.model,
            messages,
            temperature: req.sampling.temperature,
            top_p: req.sampling.top_p,
            max_tokens: req.sampling.max_tokens,
            response_format,
        };
        serde_json::to_string(&body).map_err(|e| self.envelope(e))
    }

    fn envelope(&self, e: serde_json::Error) -> LlmError {
        LlmError::Envelope { url: self.url.clone(), why: format!("cannot write the request: {e}") }
    }

    fn err_transport(&self, e: ureq::Error) -> LlmError {
        match e {
            ureq::Error::Timeout(_) => LlmError::Timeout { url: self.url.clone(), seconds: self.cfg.timeout_s },
            e => LlmError::Transport { url: self.url.clone(), message: e.to_string() },
        }
    }
}

/// The request body; fields in the order servers document them.
#[derive(Serialize)]
struct Body<'a> {
    model: &'a str,
    messages: Vec<Value>,
    temperature: f32,
    top_p: f32,
    max_tokens: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    response_format: Option<ResponseFormat<'a>>,
}

#[derive(Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
enum ResponseFormat<'a> {
    JsonSchema { json_schema: JsonSchema<'a> },
    JsonObject,
}

#[derive(Serialize)]
struct JsonSchema<'a> {
    name: &'a str,
    /// Written as [`super::schema_text`] orders it.
    schema: Box<RawValue>,
    strict: bool,
}

#[derive(Deserialize)]
struct Completion {
    choices: Vec<Choice>,
    #[serde(default)]
    usage: Option<RawUsage>,
    #[serde(default)]
    model: Option<String>,
}

#[derive(Deserialize)]
struct Choice {
    message: ChoiceMessage,
    #[serde(default)]
    finish_reason: Option<String>,
}

#[derive(Deserialize)]
struct ChoiceMessage {
    #[serde(default)]
    content: Option<String>,
}

#[derive(Deserialize)]
struct RawUsage {
    #[serde(default)]
    prompt_tokens: u64,
    #[serde(default)]
    completion_tokens: u64,
}

impl ChatModel for OpenAi {
    fn model(&self) -> &str {
        &self.cfg.model
    }

    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError> {
        let body = self.body(req)?;
        let t0 = Instant::now();
        let mut call = self.agent.post(&self.url).header("Content-Type", "application/json");
        if let Some(key) = &self.cfg.key {
            call = call.header("Authorization", &format!("Bearer {key}"));
        }
        let mut resp = call.send(body.as_str()).map_err(|e| self.err_transport(e))?;
        let status = resp.status().as_u16();
        let text = resp.body_mut().read_to_string().map_err(|e| self.err_transport(e))?;
        let latency_ms = t0.elapsed().as_secs_f64() * 1000.0;
        if !(200..300).contains(&status) {
            let body: String = text.chars().take(500).collect();
            return Err(LlmError::Status { url: self.url.clone(), status, body });
        }
        let c: Completion = serde_json::from_str(&text).map_err(|e| LlmError::Envelope { url: self.url.clone(), why: e.to_string() })?;
        let choice = c.choices.into_iter().next().ok_or_else(|| LlmError::Envelope { url: self.url.clone(), why: "no choices".into() })?;
        Ok(ChatReply {
            text: choice.message.content.unwrap_or_default(),
            usage: c.usage.map(|u| Usage { prompt_tokens: u.prompt_tokens, completion_tokens: u.completion_tokens }),
            latency_ms,
            model: c.model.unwrap_or_else(|| self.cfg.model.clone()),
            finish: choice.finish_reason,
        })
    }
}
