use crate::*;
use avacraft_ava::{AvaSpec, ModelSpec};
use avacraft_engine::{Scenario, Team};
use std::path::{Path, PathBuf};

/// The committed 3m_vlm checkpoint of the launch examples.
fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../launch/policies/3m_vlm")
}

fn synthetic() -> AvaSpec {
    AvaSpec { model: ModelSpec::Synthetic, config: Default::default(), record: None, prices: None, prompts: None }
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("avacraft-policy-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn every_policy_reads_back_from_its_name_and_settings() {
    let specs = [
        PolicySpec::parse("focus-fire", None).expect("scripted"),
        PolicySpec::parse(&format!("marl:{}", shipped().display()), None).expect("marl"),
        PolicySpec::parse("baseline:qmix", None).expect("baseline"),
        PolicySpec::resolve(AVA_POLICY, Some(synthetic()), Resolve::default()).expect("ava"),
        PolicySpec::parse(DDS_POLICY, None).expect("dds"),
    ];
    for p in specs {
        let again = PolicySpec::resolve(&p.to_string(), p.ava_spec().cloned(), Resolve::default()).expect("reads back");
        assert_eq!(again, p, "{p}");
    }
}

#[test]
fn ava_and_its_settings_go_together() {
    assert!(matches!(PolicySpec::parse(AVA_POLICY, None), Err(PolicyError::AvaWithoutSpec)));
    let e = PolicySpec::resolve("focus-fire", Some(synthetic()), Resolve::default()).expect_err("settings without ava");
    assert!(e.to_string().contains("not `focus-fire`"), "{e}");
    let mut bad = synthetic();
    bad.config.decide_every = 0;
    assert!(matches!(PolicySpec::resolve(AVA_POLICY, Some(bad), Resolve::default()), Err(PolicyError::Ava(_))));
    // AVA's files are resolved against the naming file's folder.
    let mut rec = synthetic();
    rec.record = Some(PathBuf::from("calls"));
    let p = PolicySpec::resolve(AVA_POLICY, Some(rec), Resolve::against(Some(Path::new("/base")))).expect("ava");
    assert_eq!(p.ava_spec().and_then(|s| s.record.clone()), Some(PathBuf::from("/base/calls")));
    let unknown = PolicySpec::parse("marl-ish", None).expect_err("unknown").to_string();
    assert!(unknown.contains("unknown policy `marl-ish`") && unknown.contains("ava") && unknown.contains("marl:DIR"), "{unknown}");
}

#[test]
fn commanders_are_rotate_or_ava() {
    assert_eq!(CommanderPolicy::resolve(ROTATE_POLICY, None, Resolve::default()).expect("rotate"), CommanderPolicy::Rotate);
    let ava = CommanderPolicy::resolve(AVA_POLICY, Some(synthetic()), Resolve::default()).expect("ava");
    assert_eq!(CommanderPolicy::resolve(&ava.to_string(), ava.ava_spec().cloned(), Resolve::default()).expect("again"), ava);
    let e = CommanderPolicy::resolve("focus-fire", None, Resolve::default()).expect_err("not a commander");
    assert!(matches!(e, PolicyError::NotACommander { .. }) && e.to_string().contains("`focus-fire`"), "{e}");
    assert!(CommanderPolicy::Rotate.make(&Calls::Own, None).expect("make").run.is_none());
    assert!(ava.make(&Calls::Own, None).expect("make").run.is_some());
}

#[test]
fn weights_are_read_where_named_or_on_first_use() {
    let d = tmp("corrupt");
    for f in ["agent.safetensors", "config.json"] {
        std::fs::copy(shipped().join(f), d.join(f)).expect("copy");
    }
    std::fs::write(d.join("agent.safetensors"), b"\x08\0\0\0\0\0\0\0{}garbage").expect("write");
    let name = format!("marl:{}", d.display());
    assert!(matches!(PolicySpec::parse(&name, None), Err(PolicyError::Checkpoint { .. })), "read where named");
    let later = PolicySpec::resolve(&name, None, Resolve { base: None, weights: Weights::Later }).expect("named, not read");
    assert!(matches!(later.factory(), Err(PolicyError::Checkpoint { .. })), "read on first use");
    // A folder that does not exist is refused either way.
    let missing = Resolve { base: None, weights: Weights::Later };
    assert!(matches!(PolicySpec::resolve("marl:/nonexistent/ckpt", None, missing), Err(PolicyError::MissingDir { .. })));
    let _ = std::fs::remove_dir_all(d);
}

#[test]
fn made_agents_play_and_checkpoints_check_their_scenario() {
    let three = Scenario::load("3m_vlm").expect("3m_vlm");
    let other = Scenario::load("2m_vs_1z_vlm").expect("2m_vs_1z_vlm");
    let marl = PolicySpec::parse(&format!("marl:{}", shipped().display()), None).expect("marl");
    marl.check(&three, Team::One).expect("fits 3m_vlm");
    assert!(matches!(marl.check(&other, Team::One), Err(PolicyError::OtherScenario { .. })));
    // An image-mode checkpoint (the shipped rgb IPPO) is refused where a features one plays:
    // as an agent it would give no orders at all.
    let rgb = Path::new(env!("CARGO_MANIFEST_DIR")).join("../baselines/3m_vlm/ippo-rgb");
    let rgb = PolicySpec::parse(&format!("marl:{}", rgb.display()), None).expect("rgb checkpoint");
    let e = rgb.check(&three, Team::One).expect_err("an rgb checkpoint is no agent");
    assert!(matches!(e, PolicyError::NotAnAgent { .. }) && e.to_string().contains("`rgb` observations"), "{e}");
    // Where the agent is shown its team's frames it plays team 1, and says which it reads;
    // team 2 would need the frames in the mirror image.
    rgb.check_seeing(&three, Team::One).expect("an rgb checkpoint shown its frames");
    let need = rgb.frames_need(&three).expect("config").expect("an image mode");
    assert_eq!((need.screen, need.minimap), ((80, 60), (32, 32)));
    assert_eq!(marl.frames_need(&three).expect("config"), None);
    let e = rgb.check_seeing(&three, Team::Two).expect_err("no mirrored frames");
    assert!(matches!(e, PolicyError::NotAnAgent { .. }) && e.to_string().contains("mirror image"), "{e}");
    let made = marl.make(&Calls::Own, None).expect("make");
    assert!(made.run.is_none() && (made.factory)().name().starts_with("marl:"));
    let dds = PolicySpec::parse(DDS_POLICY, None).expect("dds");
    assert!(dds.is_dds() && matches!(dds.factory(), Err(PolicyError::Dds)));
    let baseline = PolicySpec::parse("baseline:qmix", None).expect("baseline");
    assert!(matches!(baseline.factory(), Err(PolicyError::BaselineUnresolved { .. })));
    let ava = PolicySpec::resolve(AVA_POLICY, Some(synthetic()), Resolve::default()).expect("ava");
    let made = ava.make(&Calls::Own, None).expect("make");
    assert!(made.run.is_some());
}

#[test]
fn fingerprints_follow_the_files_acting_reads_and_ava_s_settings() {
    let dir = tmp("fingerprint");
    for f in ["config.json", "agent.safetensors"] {
        std::fs::copy(shipped().join(f), dir.join(f)).expect("copy the checkpoint");
    }
    let spec = PolicySpec::parse(&format!("marl:{}", dir.display()), None).expect("a checkpoint");
    let first = spec.fingerprint("3m_vlm").expect("readable").expect("a network has one");
    assert_eq!(spec.fingerprint("3m_vlm").expect("readable"), Some(first.clone()), "the same files, the same fingerprint");
    // Files acting does not read leave it alone; a weight changed does not.
    std::fs::write(dir.join("log.csv"), "step\n1\n").expect("write");
    assert_eq!(spec.fingerprint("3m_vlm").expect("readable"), Some(first.clone()));
    let mut w = std::fs::read(dir.join("agent.safetensors")).expect("read");
    let last = w.len() - 1;
    w[last] ^= 1;
    std::fs::write(dir.join("agent.safetensors"), w).expect("write");
    let trained_again = spec.fingerprint("3m_vlm").expect("readable").expect("some");
    assert_ne!(trained_again, first, "another network, another fingerprint");
    std::fs::remove_file(dir.join("agent.safetensors")).expect("remove");
    let gone = spec.fingerprint("3m_vlm").expect_err("a missing weights file is an error").to_string();
    assert!(gone.contains("agent.safetensors"), "{gone}");

    assert_eq!(PolicySpec::parse("focus-fire", None).expect("scripted").fingerprint("3m_vlm").expect("none to read"), None);
    let ava = |seed| {
        let mut s = synthetic();
        s.config.decide_every = seed;
        PolicySpec::resolve(AVA_POLICY, Some(s), Resolve::against(None)).expect("ava").fingerprint("3m_vlm").expect("settings")
    };
    assert_eq!(ava(4), ava(4));
    assert_ne!(ava(4), ava(8), "AVA's settings are part of what it plays");
    std::fs::remove_dir_all(&dir).ok();
}

/// What a deployment sends a node: a scripted agent's own `reads`, everything for the rest.
#[test]
fn a_policy_says_what_it_reads_without_loading_anything() {
    use avacraft_engine::agent::Reads;
    for name in ["focus-fire", "kite", "attack-move", "hold"] {
        let p = PolicySpec::parse(name, None).expect("scripted");
        let own = avacraft_engine::agent::by_name(name).expect("an engine agent").reads();
        assert_eq!(p.reads(), own, "{name}");
    }
    assert_eq!(PolicySpec::parse("focus-fire", None).expect("scripted").reads(), Reads::UNITS);
    for p in [
        PolicySpec::parse(&format!("marl:{}", shipped().display()), None).expect("marl"),
        PolicySpec::resolve(AVA_POLICY, Some(synthetic()), Resolve::default()).expect("ava"),
        PolicySpec::parse(DDS_POLICY, None).expect("dds"),
    ] {
        assert_eq!(p.reads(), Reads::ALL, "{p}");
    }
}
