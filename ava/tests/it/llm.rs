//! AVA against a fake OpenAI-compatible server on loopback: the request's shape, whole
//! episodes through every kind of failure, and record-then-replay.

use crate::common::{FakeServer, Fault, play, setup};
use avacraft_ava::AvaConfig;
use avacraft_ava::llm::{ChatModel, ChatRequest, LlmError, Message, Part, Png, Replay, Role, Sampling, Stage};
use avacraft_engine::Team;

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("ava-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn fast() -> AvaConfig {
    AvaConfig { backoff_ms: 1, image_max: 320, ..AvaConfig::default() }
}

#[test]
fn requests_carry_the_image_the_schema_and_the_key() {
    let server = FakeServer::start();
    let mut client = server.client(10.0);
    let img = image::RgbImage::from_pixel(8, 4, image::Rgb([10, 20, 30]));
    let png = Png::encode(&img).expect("png");
    let req = ChatRequest {
        stage: Stage::Decision,
        messages: vec![
            Message::text(Role::System, "sys"),
            Message {
                role: Role::User,
                parts: vec![Part::Text("Your units:\n- 1 Marine at cell [1, 1]\n".into()), Part::Image(png.clone())],
            },
        ],
        schema: Some((
            "ava_decision".into(),
            avacraft_ava::decision::schema(&[avacraft_engine::UnitId::new(0)], &[avacraft_engine::UnitId::new(3)], &["stimpack"]),
        )),
        sampling: Sampling::default(),
    };
    let reply = client.complete(&req).expect("reply");
    assert_eq!(reply.usage.map(|u| (u.prompt_tokens, u.completion_tokens)), Some((1000, 50)));
    assert!(reply.text.contains("\"unit\":1"), "{}", reply.text);
    let seen = server.seen();
    assert_eq!(seen.len(), 1);
    let s = &seen[0];
    assert_eq!(s.authorization.as_deref(), Some("Bearer sk-test"));
    assert!(s.content_type.as_deref().is_some_and(|c| c.starts_with("application/json")));
    let b = &s.body;
    assert_eq!(b["model"], "gpt-4o-mini");
    assert_eq!(b["max_tokens"], 1024);
    assert!((b["temperature"].as_f64().unwrap_or(0.0) - 0.7).abs() < 1e-6);
    assert!((b["top_p"].as_f64().unwrap_or(0.0) - 0.95).abs() < 1e-6);
    assert_eq!(b["messages"][0]["content"], "sys");
    let parts = b["messages"][1]["content"].as_array().expect("parts");
    assert_eq!(parts[0]["type"], "text");
    assert_eq!(parts[1]["type"], "image_url");
    let url = parts[1]["image_url"]["url"].as_str().expect("url");
    let b64 = url.strip_prefix("data:image/png;base64,").expect("a PNG data URL");
    use base64::Engine as _;
    let bytes = base64::engine::general_purpose::STANDARD.decode(b64).expect("base64");
    assert_eq!(bytes, *png.bytes, "the image goes out byte for byte");
    assert_eq!(b["response_format"]["type"], "json_schema");
    assert_eq!(b["response_format"]["json_schema"]["name"], "ava_decision");
    assert_eq!(
        b["response_format"]["json_schema"]["schema"]["properties"]["actions"]["items"]["properties"]["ability"]["anyOf"][0]["enum"][0],
        "stimpack"
    );
    // Strict decoding writes properties in the order the schema lists them: the schema goes
    // out in the order of `required` (reasoning before actions, the unit first in an item).
    let at = |k: &str| s.raw.find(&format!("\"{k}\":")).unwrap_or_else(|| panic!("{k} missing from {}", s.raw));
    assert!(at("reasoning") < at("actions"), "{}", s.raw);
    assert!(at("unit") < at("action") && at("action") < at("target") && at("target") < at("ability"), "{}", s.raw);
}

#[test]
fn errors_are_classified() {
    let server = FakeServer::start();
    let mut client = server.client(0.3);
    let req =
        ChatRequest { stage: Stage::Planner, messages: vec![Message::text(Role::User, "x")], schema: None, sampling: Sampling::default() };
    server.push([Fault::Status(429), Fault::Status(500), Fault::Status(400), Fault::Malformed, Fault::Slow(1500)]);
    let e = client.complete(&req).expect_err("429");
    assert!(matches!(e, LlmError::Status { status: 429, .. }) && e.retryable(), "{e}");
    let e = client.complete(&req).expect_err("500");
    assert!(matches!(e, LlmError::Status { status: 500, .. }) && e.retryable(), "{e}");
    let e = client.complete(&req).expect_err("400");
    assert!(matches!(e, LlmError::Status { status: 400, .. }) && !e.retryable(), "{e}");
    let e = client.complete(&req).expect_err("not json");
    assert!(matches!(e, LlmError::Envelope { .. }) && !e.retryable(), "{e}");
    let e = client.complete(&req).expect_err("slow");
    assert!(matches!(e, LlmError::Timeout { .. }) && e.retryable(), "{e}");
    let mut nowhere = avacraft_ava::llm::OpenAi::new(avacraft_ava::llm::OpenAiConfig {
        base_url: "http://127.0.0.1:9/v1".into(),
        model: "m".into(),
        key: None,
        timeout_s: 2.0,
        schema_mode: avacraft_ava::llm::SchemaMode::None,
    });
    let e = nowhere.complete(&req).expect_err("nothing listens on port 9");
    assert!(matches!(e, LlmError::Transport { .. }) && e.retryable(), "{e}");
    assert!(e.to_string().contains("127.0.0.1:9"), "the error names the endpoint: {e}");
}

#[test]
fn an_episode_completes_through_every_failure_and_counts_them() {
    let server = FakeServer::start();
    // The first decision's planner call meets two server errors (then answers); the roles
    // call a malformed body (not retried: the stage is skipped); the priority call is slow
    // beyond the time limit once; the decision a truncated answer, then invalid items,
    // then prose around valid JSON.
    server.push([
        Fault::Status(500),
        Fault::Status(429),
        Fault::None,
        Fault::Malformed,
        Fault::Slow(1500),
        Fault::Truncated,
        Fault::BadItems,
        Fault::Prose,
    ]);
    let s = setup(Box::new(server.client(0.5)), fast(), None);
    let env = play("3m_vlm", 3, &s, 400);
    assert!(env.done(), "the episode ends");
    eprintln!("outcome {:?} after {} steps", env.outcome(), env.steps());
    assert_eq!(env.refused()[0], 0, "no order AVA gave was refused by the engine");
    assert!(s.run.fatal().is_none(), "{:?}", s.run.fatal());
    let eps = s.run.episodes();
    assert_eq!(eps.len(), 1);
    let c = &eps[0];
    assert!(c.decisions > 5, "{c:?}");
    // 500, 429, the malformed body and the timeout.
    assert_eq!(c.total.failed_calls, 4, "{c:?}");
    // Truncated, then two bad items.
    assert!(c.refused_items >= 3, "{c:?}");
    assert_eq!(c.repairs, 2, "{c:?}");
    assert_eq!(c.fallbacks, 0, "{c:?}");
    assert!(c.total.prompt_tokens >= 1000 * (c.total.calls - c.total.failed_calls), "{c:?}");
    // gpt-4o-mini is priced: 1000 prompt and 50 completion tokens a call.
    let ok = (c.total.calls - c.total.failed_calls) as f64;
    assert!((c.total.cost_usd - ok * (1000.0 * 0.15 + 50.0 * 0.60) / 1e6).abs() < 1e-9, "{c:?}");
    let seen = server.seen();
    assert_eq!(seen.len() as u64, c.total.calls, "every call reached the server once");
    assert!(seen.iter().all(|s| s.authorization.as_deref() == Some("Bearer sk-test")));
}

#[test]
fn a_dead_endpoint_falls_back_and_the_episode_ends() {
    let cfg = AvaConfig { max_retries: 1, planner: false, roles: false, priority: false, ..fast() };
    let model = avacraft_ava::llm::OpenAi::new(avacraft_ava::llm::OpenAiConfig {
        base_url: "http://127.0.0.1:9/v1".into(),
        model: "m".into(),
        key: None,
        timeout_s: 1.0,
        schema_mode: avacraft_ava::llm::SchemaMode::JsonSchema,
    });
    let s = setup(Box::new(model), cfg, None);
    let env = play("3m_vlm", 1, &s, 60);
    let c = &s.run.episodes()[0];
    assert!(c.decisions > 0);
    assert_eq!(c.transport_failures, c.decisions, "{c:?}");
    assert_eq!(c.fallbacks, c.decisions, "{c:?}");
    assert_eq!(c.total.failed_calls, 2 * c.decisions, "one retry per decision: {c:?}");
    assert_eq!(env.refused()[0], 0);
}

#[test]
fn a_recorded_episode_replays_exactly_without_the_model() {
    let server = FakeServer::start();
    server.push([Fault::Status(500), Fault::BadItems]);
    let dir = tmp("replay");
    let s = setup(Box::new(server.client(5.0)), fast(), Some(&dir));
    let env = play("3m_vlm", 7, &s, 400);
    let calls = server.seen().len();
    let hash = env.trajectory_hash();
    let cost = s.run.episodes();
    assert!(s.run.fatal().is_none());

    let replay = Replay::open(&dir).expect("recording");
    assert_eq!(replay.remaining(), calls, "every call is recorded, failed ones too");
    let r = setup(Box::new(replay), fast(), None);
    let env2 = play("3m_vlm", 7, &r, 400);
    assert!(r.run.fatal().is_none(), "{:?}", r.run.fatal());
    assert_eq!(env2.trajectory_hash(), hash, "the replay re-simulates the episode");
    assert_eq!(server.seen().len(), calls, "the replay called no model");
    let (a, b) = (&cost[0], &r.run.episodes()[0]);
    assert_eq!(
        (a.total.calls, a.total.prompt_tokens, a.repairs, a.refused_items),
        (b.total.calls, b.total.prompt_tokens, b.repairs, b.refused_items)
    );
    // The recording refuses to be overwritten.
    let again = avacraft_ava::llm::Recorder::create(&dir).expect_err("exists");
    assert!(again.to_string().contains("already holds a recording"), "{again}");

    // Another seed asks other questions: the replay stops instead of answering them.
    let replay = Replay::open(&dir).expect("recording");
    let r = setup(Box::new(replay), fast(), None);
    let _ = play("3m_vlm", 8, &r, 40);
    let why = r.run.fatal().expect("a diverging replay is fatal");
    assert!(why.contains("differs from the recording"), "{why}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn realtime_applies_actions_after_the_model_time() {
    let server = FakeServer::start();
    // Each decision's calls take ~600 ms of wall time: about two steps of game time.
    let slow: Vec<Fault> = (0..200).map(|_| Fault::Slow(300)).collect();
    server.push(slow);
    let cfg = AvaConfig { timing: avacraft_ava::Timing::Realtime, planner: false, roles: false, priority: true, ..fast() };
    let s = setup(Box::new(server.client(5.0)), cfg, None);
    let env = play("3m_vlm", 2, &s, 12);
    let c = &s.run.episodes()[0];
    // Lockstep would decide at steps 0, 2, 4, ...; real time waits for the model.
    assert!(c.decisions <= 4, "decisions wait for the model's answers: {c:?}");
    assert!(c.decisions >= 1 && c.fallbacks == 0, "the model's answers, slow as they are, are decided on: {c:?}");
    assert_eq!(env.refused()[0], 0);
    let _ = Team::One;
}

/// Procedural scenarios: AVA plays episodes whose teams are drawn from the seed, its orders
/// are all taken, and what it is told names the unit types this episode drew.
#[test]
fn ava_plays_procedural_scenarios() {
    for (name, seed) in [("protoss_5_vs_5", 2), ("terran_10_vs_11", 3)] {
        let server = FakeServer::start();
        let s = setup(Box::new(server.client(5.0)), fast(), None);
        let env = play(name, seed, &s, 400);
        assert!(env.done(), "{name}: the episode ends");
        assert_eq!(env.refused()[0], 0, "{name}: no order AVA gave was refused");
        let c = &s.run.episodes()[0];
        assert!(c.decisions > 0 && c.fallbacks == 0, "{name}: {c:?}");
        let drawn: std::collections::BTreeSet<&str> = env.scenario().team_units(Team::One).map(|(_, u)| u.kind.base().name()).collect();
        let seen = server.seen();
        for k in &drawn {
            assert!(seen.iter().any(|q| q.raw.contains(k)), "{name}: no request names the drawn {k}");
        }
    }
}
