//! Policies as launch files name them: resolved against the file, one network per entry.

use crate::{LaunchError, chain, parse};
use avacraft_engine::{Env, Mode};
use avacraft_marl::Policy;
use avacraft_nodes::FrameKind;
use avacraft_policy::PolicySpec;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The committed 3m_vlm checkpoint (launch/policies/3m_vlm), whichever run wrote it.
fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("policies/3m_vlm")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("avacraft-launch-policy-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// A copy of the shipped checkpoint with `edit` applied to its config.json.
fn edited(name: &str, edit: impl Fn(&mut serde_json::Value)) -> PathBuf {
    let d = tmp(name);
    for f in ["agent.safetensors", "mixer.safetensors", "config.json"] {
        if shipped().join(f).exists() {
            std::fs::copy(shipped().join(f), d.join(f)).expect("copy");
        }
    }
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("config.json")).expect("read")).expect("json");
    edit(&mut v);
    std::fs::write(d.join("config.json"), v.to_string()).expect("write");
    d
}

fn launch(scenario: &str, policy: &str) -> String {
    format!("scenario: {scenario}\nagents:\n  - per_unit: true\n    team: 1\n    policy: {policy}\n")
}

/// One episode of `plan` in process, on `seed`, played to its end.
fn played(plan: &crate::Plan, seed: u64) -> Env {
    let mut c = plan.controllers().expect("controllers");
    let mut env = Env::new(Arc::clone(&plan.scenario), plan.env_config(), seed);
    c.reset(&env);
    while !env.done() {
        c.act(&mut env);
        env.step();
    }
    env
}

#[test]
fn marl_policies_resolve_against_the_launch_file_and_share_one_network() {
    let base = Path::new(env!("CARGO_MANIFEST_DIR"));
    let plan = parse("m.yaml", &launch("3m_vlm", "marl:policies/3m_vlm"), Some(base)).unwrap_or_else(|e| panic!("{}", chain(&e)));
    assert_eq!(plan.agents.len(), 3);
    let nets: Vec<&Arc<Policy>> = plan
        .agents
        .iter()
        .map(|a| match &a.policy {
            PolicySpec::Marl(m) => m.policy().expect("weights"),
            other => panic!("{other:?}"),
        })
        .collect();
    assert!(nets.iter().all(|p| Arc::ptr_eq(p, nets[0])), "one load for the entry's nodes");
    // What `launch` hands the agent nodes parses back to the same checkpoint, from anywhere.
    let text = plan.agents[0].policy.to_string();
    assert!(text.starts_with("marl:/"), "{text}");
    assert_eq!(PolicySpec::parse(&text, None).expect("reparse"), plan.agents[0].policy);
    // An absolute directory, and a role group of two units, are fine too.
    let abs = format!("marl:{}", shipped().display());
    let groups =
        "scenario: 3m_vlm\nagents:\n  - {id: pair, units: [1, 2], policy: POLICY}\n  - {id: solo, units: [3], policy: focus-fire}\n";
    parse("g.yaml", &groups.replace("POLICY", &abs), None).unwrap_or_else(|e| panic!("{}", chain(&e)));
}

#[test]
fn a_marl_plan_plays_in_process_with_one_network_per_unit() {
    let plan = parse("m.yaml", &launch("3m_vlm", &format!("marl:{}", shipped().display())), None).expect("plan");
    let noop = parse("n.yaml", &launch("3m_vlm", "noop"), None).expect("plan");
    assert_eq!(plan.scenario.mode, Mode::Pve);
    assert_ne!(played(&plan, 3).trajectory_hash(), played(&noop, 3).trajectory_hash(), "the network gives orders");
}

#[test]
fn bad_marl_policies_name_the_field_and_why() {
    let garbage = tmp("garbage");
    std::fs::write(garbage.join("config.json"), "{ not json").expect("write");
    let no_weights = edited("no_weights", |_| {});
    std::fs::remove_file(no_weights.join("agent.safetensors")).expect("remove");
    let bad_weights = edited("bad_weights", |_| {});
    std::fs::write(bad_weights.join("agent.safetensors"), b"\x08\0\0\0\0\0\0\0{}garbage").expect("write");
    let renamed = edited("renamed", |v| v["scenario"] = "2m_vs_1z_vlm".into());
    let file = tmp("file").join("config.json");
    std::fs::write(&file, "{}").expect("write");
    let s = |p: &Path| format!("marl:{}", p.display());
    let cases: Vec<(String, String, &str)> = vec![
        (launch("3m_vlm", "\"marl:\""), "marl:".into(), "needs the directory of a checkpoint"),
        (launch("3m_vlm", "marl:/nonexistent/ckpt"), "/nonexistent/ckpt".into(), "does not exist"),
        (launch("3m_vlm", &s(&file)), "config.json".into(), "is not a directory"),
        (launch("3m_vlm", &s(&garbage)), "config.json".into(), "cannot load the checkpoint"),
        (launch("3m_vlm", &s(&no_weights)), "agent.safetensors is missing".into(), "cannot load the checkpoint"),
        (launch("3m_vlm", &s(&bad_weights)), "bad_weights: tensor operation failed".into(), "cannot load the checkpoint"),
        (launch("2m_vs_1z_vlm", &s(&shipped())), "trained on scenario `3m_vlm`, not `2m_vs_1z_vlm`".into(), "trained on"),
        (launch("2m_vs_1z_vlm", &s(&renamed)), "3 agents".into(), "team 1 of 2m_vs_1z_vlm has 2 agents"),
        (launch("3m_vlm", "marl-ish"), "unknown policy `marl-ish`".into(), "marl:DIR"),
    ];
    for (text, says, why) in cases {
        let e = parse("bad.yaml", &text, None).expect_err(&text);
        assert!(matches!(e, LaunchError::Policy { .. }), "{e:?}");
        let msg = chain(&e);
        assert!(msg.starts_with("bad.yaml: field `agents[0].policy` = \""), "{msg}");
        assert!(msg.contains(&says) && msg.contains(why), "{text}: {msg}");
    }
    for d in [garbage, no_weights, bad_weights, renamed, file.parent().map(Path::to_path_buf).unwrap_or_default()] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// The shipped rgb MAPPO on 3m_vlm (an image-mode network).
fn rgb() -> String {
    format!("marl:{}", Path::new(env!("CARGO_MANIFEST_DIR")).join("../baselines/3m_vlm/mappo-rgb").display())
}

#[test]
fn an_image_checkpoint_has_the_simulator_draw_its_frames_and_plays_in_process() {
    let plan = parse("r.yaml", &launch("3m_vlm", &rgb()), None).unwrap_or_else(|e| panic!("{}", chain(&e)));
    let f = plan.frames.as_ref().expect("frames for the network");
    assert_eq!((f.screen, f.minimap, f.every, f.for_agents), ((80, 60), (32, 32), 1, true));
    assert!(f.kinds.contains(&FrameKind::Screen) && f.kinds.contains(&FrameKind::Minimap));
    // A file's own frames at the network's sizes are kept (with the VLM shot it asks for).
    let own = format!("{}frames: {{kinds: [vlm, screen, minimap], screen: [80, 60], minimap: [32, 32]}}\n", launch("3m_vlm", &rgb()));
    let kept = parse("o.yaml", &own, None).unwrap_or_else(|e| panic!("{}", chain(&e)));
    assert_eq!(kept.frames.as_ref().map(|f| (f.kinds.len(), f.for_agents)), Some((3, true)));
    // A features network's file draws nothing it did not ask for.
    assert!(parse("m.yaml", &launch("3m_vlm", &format!("marl:{}", shipped().display())), None).expect("plan").frames.is_none());
    // In process the agents are shown the frames and give orders.
    let noop = parse("n.yaml", &launch("3m_vlm", "noop"), None).expect("plan");
    assert_eq!(played(&plan, 3).outcome(), Some(avacraft_engine::Outcome::Win));
    assert_ne!(played(&noop, 3).outcome(), Some(avacraft_engine::Outcome::Win));
}

#[test]
fn frames_that_do_not_fit_an_image_checkpoint_name_the_field() {
    let with = |frames: &str| format!("{}frames: {frames}\n", launch("3m_vlm", &rgb()));
    let cases = [
        (with("{kinds: [screen, minimap], screen: [160, 120], minimap: [32, 32]}"), "frames.screen", "screen frames of [80, 60]"),
        (with("{kinds: [screen], screen: [80, 60], minimap: [32, 32]}"), "frames.kinds", "minimap frames"),
        (with("{kinds: [screen, minimap], screen: [80, 60], minimap: [32, 32], every: 2}"), "frames.every", "frames at every step"),
        (
            format!("scenario: 3m_vlm\nagents:\n  - {{id: g, units: [1, 2, 3], role: attacker, policy: {}}}\n", rgb()),
            "agents[0].role",
            "reads no frames",
        ),
    ];
    for (text, field, why) in cases {
        let msg = chain(&parse("bad.yaml", &text, None).expect_err(&text));
        assert!(msg.starts_with(&format!("bad.yaml: field `{field}`")) && msg.contains(why), "{text}: {msg}");
    }
}

/// A network trained with the ability slots (a short run: only its sizes and config matter)
/// needs a game that has them: refused without, naming the setting, and played with.
#[test]
fn a_network_with_ability_slots_needs_them_in_the_launch() {
    let dir = tmp("abilities");
    let cfg = avacraft_marl::Config::for_algo(
        "mappo",
        &["t_max=100", "envs=2", "rollout_len=50", "test_interval=100", "test_nepisode=1", "episode_limit=10", "ability_actions=true"]
            .map(String::from),
    )
    .expect("config");
    let scenario = Arc::new(avacraft_engine::Scenario::load("8s_vs_8m3mr1mv1st").expect("scenario"));
    let opts = avacraft_marl::RunOptions { scenario, seed: 1, threads: 1, out: Some(dir.clone()) };
    avacraft_marl::train(&cfg, &opts, &mut |_| {}).expect("a short run");
    let policy = format!("marl:{}", dir.join("best").display());
    let e = parse("a.yaml", &launch("8s_vs_8m3mr1mv1st", &policy), None).expect_err("no ability slots in the game");
    let msg = chain(&e);
    assert!(msg.contains("field `agents[0].policy`") && msg.contains("ability slots") && msg.contains("ability_actions: true"), "{msg}");
    let text = format!("{}env: {{ability_actions: true}}\n", launch("8s_vs_8m3mr1mv1st", &policy));
    let plan = parse("a.yaml", &text, None).unwrap_or_else(|e| panic!("{}", chain(&e)));
    assert!(plan.env_config().ability_actions);
    let noop = parse("n.yaml", &launch("8s_vs_8m3mr1mv1st", "noop"), None).expect("plan");
    assert_ne!(played(&plan, 3).world().state_hash(), played(&noop, 3).world().state_hash(), "the network gives orders");
    let _ = std::fs::remove_dir_all(dir);
}
