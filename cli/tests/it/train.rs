//! `avacraft train` as a user runs it: a short run over a scenario file, then `--resume`
//! with nothing but the run's directory.

use crate::common::{exe, tmp};
use std::process::Command;

fn train(args: &[&str]) -> std::process::Output {
    Command::new(exe()).arg("train").args(args).output().expect("run avacraft train")
}

#[test]
fn a_short_run_resumes_from_its_directory_alone() {
    let dir = tmp("train-resume");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().expect("utf-8 temp path");
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../engine/scenarios/3m_vlm.toml");
    let small = ["--set", "batch_size=4", "--set", "test_interval=200", "--set", "test_nepisode=2", "--set", "episode_limit=60"];
    let mut first = vec!["--algo", "vdn", "--scenario", file, "--steps", "400", "--envs", "2", "--seed", "3", "--out", d];
    first.extend(small);
    let out = train(&first);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("vdn (features) on 3m_vlm: 400 steps"), "{text}");
    assert!(dir.join("scenario.toml").is_file(), "the scenario file is kept with the run");
    let log = |d: &std::path::Path| std::fs::read_to_string(d.join("log.csv")).expect("log.csv").lines().count();
    assert_eq!(log(&dir), 3, "a header and two test rounds");

    // No --scenario, no --seed: the run's own.
    let out = train(&["--resume", d, "--steps", "600"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("on 3m_vlm: 600 steps"), "{text}");
    assert_eq!(log(&dir), 4, "the log goes on");

    // A different seed is refused, naming both.
    let out = train(&["--resume", d, "--steps", "800", "--seed", "4"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--seed 4") && err.contains("seed 3"), "{err}");
    assert_eq!(log(&dir), 4, "a refused resume leaves the run as it was");

    // A directory without a run is named in the error.
    let empty = tmp("train-no-run");
    std::fs::create_dir_all(&empty).expect("dir");
    let out = train(&["--resume", empty.to_str().expect("utf-8"), "--steps", "800"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("train-no-run") && err.contains("config.json"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
