//! Shared by the AVA tests: a fake OpenAI-compatible server on loopback, and an episode
//! runner.
//!
//! The fake "model" reads the prompt as a model would and answers in the schema (the
//! synthetic model's answers: every unit of ours attacks the enemy with the lowest tag). Faults queued with
//! [`FakeServer::push`] replace the next answers: HTTP errors, broken envelopes, cut-off or
//! invalid JSON, slow answers.

#![allow(dead_code)]

use avacraft_ava::llm::{CeilingScript, OpenAi, OpenAiConfig, SchemaMode, Stage, ceiling_decision, read_prompt, synthetic_answer};
use avacraft_ava::{AvaAgent, AvaConfig, AvaRun, AvaSetup, Bm25, KnowledgeBase, Prompts};
use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, EnvConfig, Scenario, Team};
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::post;
use serde_json::{Value, json};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

#[derive(Clone, Debug)]
pub enum Fault {
    /// The normal answer (to let a call through in a queue of faults).
    None,
    /// Answer this HTTP status with a short body.
    Status(u16),
    /// A body that is not JSON.
    Malformed,
    /// A completion whose content is cut mid-object.
    Truncated,
    /// A completion with items naming a unit we do not have and an unknown ability.
    BadItems,
    /// The normal answer, wrapped in prose and a code fence.
    Prose,
    /// The normal answer after a pause.
    Slow(u64),
}

/// A request as the server received it.
#[derive(Clone, Debug)]
pub struct Seen {
    pub authorization: Option<String>,
    pub content_type: Option<String>,
    pub body: Value,
    /// The body as sent.
    pub raw: String,
}

#[derive(Default)]
struct Inner {
    faults: VecDeque<Fault>,
    seen: Vec<Seen>,
    /// Ceiling mode: decisions are answered as this script would, from the prompt alone.
    ceiling: Option<CeilingScript>,
}

#[derive(Clone)]
pub struct FakeServer {
    pub url: String,
    inner: Arc<Mutex<Inner>>,
}

impl FakeServer {
    /// Starts a server on an ephemeral loopback port (it lives until the test process ends).
    pub fn start() -> FakeServer {
        FakeServer::serve(Inner::default())
    }

    /// A server in ceiling mode: it answers decisions as `script` would, reading only the
    /// prompt's text (the ceiling back end's answers, over HTTP).
    pub fn start_ceiling(script: CeilingScript) -> FakeServer {
        FakeServer::serve(Inner { ceiling: Some(script), ..Inner::default() })
    }

    fn serve(inner: Inner) -> FakeServer {
        let inner = Arc::new(Mutex::new(inner));
        let state = Arc::clone(&inner);
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build().expect("runtime");
            rt.block_on(async move {
                let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind loopback");
                tx.send(listener.local_addr().expect("address")).expect("send address");
                let app = axum::Router::new().route("/v1/chat/completions", post(chat)).with_state(state);
                axum::serve(listener, app).await.expect("serve");
            });
        });
        let addr = rx.recv().expect("server address");
        FakeServer { url: format!("http://{addr}/v1"), inner }
    }

    pub fn push(&self, faults: impl IntoIterator<Item = Fault>) {
        self.inner.lock().expect("lock").faults.extend(faults);
    }

    pub fn seen(&self) -> Vec<Seen> {
        self.inner.lock().expect("lock").seen.clone()
    }

    pub fn client(&self, timeout_s: f64) -> OpenAi {
        OpenAi::new(OpenAiConfig {
            base_url: self.url.clone(),
            model: "gpt-4o-mini".into(),
            key: Some("sk-test".into()),
            timeout_s,
            schema_mode: SchemaMode::JsonSchema,
        })
    }
}

async fn chat(State(s): State<Arc<Mutex<Inner>>>, headers: HeaderMap, body: String) -> Response {
    let value: Value = serde_json::from_str(&body).unwrap_or(Value::Null);
    let header = |k: &str| headers.get(k).and_then(|v| v.to_str().ok()).map(str::to_owned);
    let (fault, ceiling) = {
        let mut g = s.lock().expect("lock");
        g.seen.push(Seen {
            authorization: header("authorization"),
            content_type: header("content-type"),
            body: value.clone(),
            raw: body.clone(),
        });
        (g.faults.pop_front(), g.ceiling)
    };
    let answer = answer(&value, ceiling);
    let completion = |content: String| {
        axum::Json(json!({
            "id": "fake", "object": "chat.completion", "model": "fake-model",
            "choices": [{"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}],
            "usage": {"prompt_tokens": 1000, "completion_tokens": 50, "total_tokens": 1050}
        }))
        .into_response()
    };
    match fault {
        None | Some(Fault::None) => completion(answer),
        Some(Fault::Status(code)) => (StatusCode::from_u16(code).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR), "fault").into_response(),
        Some(Fault::Malformed) => (StatusCode::OK, "this is not json").into_response(),
        Some(Fault::Truncated) => completion(answer.chars().take(answer.len() / 2).collect()),
        Some(Fault::BadItems) => {
            completion(json!({"reasoning": "x", "actions": [{"unit": 99, "action": "attack", "target": 4}, {"unit": 1, "action": "ability", "ability": "psionic_storm", "cell": [5, 5]}]}).to_string())
        }
        Some(Fault::Prose) => completion(format!("Here is my answer:\n```json\n{answer}\n```\nGood luck!")),
        Some(Fault::Slow(ms)) => {
            tokio::time::sleep(std::time::Duration::from_millis(ms)).await;
            completion(answer)
        }
    }
}

/// The fake model's answer: the synthetic model's, for the stage the schema names, from
/// the first user message (a repair re-answers for every unit; the agent keeps what it needs).
fn answer(body: &Value, ceiling: Option<CeilingScript>) -> String {
    let stage = match body["response_format"]["json_schema"]["name"].as_str().unwrap_or("") {
        "ava_planner" => Stage::Planner,
        "ava_priority" => Stage::Priority,
        "ava_roles" => Stage::Roles,
        _ => Stage::Decision,
    };
    let first_user = body["messages"].as_array().and_then(|m| m.iter().find(|m| m["role"] == "user").cloned()).unwrap_or(Value::Null);
    let text = match &first_user["content"] {
        Value::String(s) => s.clone(),
        Value::Array(parts) => parts.iter().filter_map(|p| p["text"].as_str()).collect::<Vec<_>>().join("\n"),
        _ => String::new(),
    };
    match (stage, ceiling) {
        (Stage::Decision, Some(script)) => ceiling_decision(script, &read_prompt(&text)).to_string(),
        _ => synthetic_answer(stage, &text),
    }
}

/// An AVA setup over `model` with `cfg`, recording into `record` when given.
pub fn setup(model: Box<dyn avacraft_ava::llm::ChatModel>, cfg: AvaConfig, record: Option<&std::path::Path>) -> AvaSetup {
    let recorder = record.map(|d| avacraft_ava::llm::Recorder::create(d).expect("recorder"));
    let kb = KnowledgeBase::builtin().expect("knowledge base");
    let prompts = Prompts::builtin_for(cfg.prompt).expect("prompts");
    AvaSetup {
        config: Arc::new(cfg),
        run: AvaRun::new(model, recorder, avacraft_ava::cost::PriceTable::builtin()),
        prompts: Arc::new(prompts),
        retriever: Arc::new(Bm25::new(&kb)),
    }
}

/// Plays one episode of `scenario` with AVA as team 1; returns the environment at the end.
pub fn play(scenario: &str, seed: u64, s: &AvaSetup, step_limit: u32) -> Env {
    play_with(scenario, seed, s, step_limit, EnvConfig::default())
}

/// [`play`] with the game's settings given (e.g. a shorter time limit).
pub fn play_with(scenario: &str, seed: u64, s: &AvaSetup, step_limit: u32, config: EnvConfig) -> Env {
    let scenario = Arc::new(Scenario::load(scenario).expect("scenario"));
    let s2 = s.clone();
    let team = AgentTeam::new(Team::One, Grouping::Team, move || Box::new(AvaAgent::new(s2.clone())));
    let mut controllers = Controllers::new(&scenario, vec![team]);
    let mut env = Env::new(Arc::clone(&scenario), config, seed);
    env.reset(seed);
    controllers.reset(&env);
    while !env.done() && env.steps() < step_limit {
        controllers.act(&mut env);
        env.step();
    }
    env
}

/// `scenario` after `steps` steps of attack-move for both sides.
pub fn state(scenario: &str, seed: u64, steps: u32) -> Env {
    let sc = Arc::new(Scenario::load(scenario).expect("scenario"));
    let mut env = Env::new(Arc::clone(&sc), EnvConfig::default(), seed);
    env.reset(seed);
    let mut c = Controllers::named(&sc, "attack-move", Some("attack-move")).expect("agents");
    c.reset(&env);
    while env.steps() < steps && !env.done() {
        c.act(&mut env);
        env.step();
    }
    env
}
