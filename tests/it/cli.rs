//! The command line, driven in-process with the binary's own parser.

fn run(args: &[&str]) -> Result<String, String> {
    let mut out = Vec::new();
    let mut full = vec!["avacraft"];
    full.extend_from_slice(args);
    avacraft_cli::run_args(full, &mut out).map_err(|e| format!("{e:#}"))?;
    String::from_utf8(out).map_err(|e| e.to_string())
}

#[test]
fn env_info_prints_smac_keys() {
    let out = run(&["env-info", "--scenario", "3m_vlm", "--json"]).expect("runs");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["n_agents"], 3);
    assert_eq!(v["obs_shape"], 30);
    assert_eq!(v["state_shape"], 48);
    assert_eq!(v["n_actions"], 9);
    assert_eq!(v["episode_limit"], 840);
    let out = run(&["env-info", "--scenario", "2s3z_vlm", "--json"]).expect("runs");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!((v["obs_shape"].as_u64(), v["state_shape"].as_u64(), v["n_actions"].as_u64()), (Some(80), Some(120), Some(11)));
}

#[test]
fn scenarios_lists_the_papers_21_smacs_23_and_the_15_procedural_ones() {
    let out = run(&["scenarios", "--json"]).expect("runs");
    let v: Vec<serde_json::Value> = serde_json::from_str(&out).expect("json");
    assert_eq!(v.len(), 21 + 23 + 15);
    let from = |f: &str| v.iter().filter(|r| r["family"] == f).count();
    assert_eq!((from("paper"), from("smac"), from("smacv2")), (21, 23, 15));
    let smac = v.iter().find(|r| r["name"] == "3m" && r["family"] == "smac").expect("SMAC's 3m");
    // SMAC's 60 steps of 8 loops.
    assert!(smac["time_limit_s"].as_f64().is_some_and(|t| (t - 480.0 / 22.4).abs() < 1e-3), "{smac}");
    assert_eq!(smac["data"].as_str(), Some("liberty"));
    let zerg = v.iter().find(|r| r["name"] == "zerg_10_vs_11").expect("zerg_10_vs_11");
    assert_eq!((zerg["team1"].as_u64(), zerg["team2"].as_u64()), (Some(10), Some(11)));
    assert_eq!(zerg["team1_units"].as_str(), Some("drawn: Zergling 0.45 / Hydralisk 0.45 / Baneling 0.1"));
    let pvz = v.iter().find(|r| r["name"] == "pvz_ht").expect("pvz_ht");
    assert_eq!((pvz["team1"].as_u64(), pvz["team2"].as_u64(), pvz["mode"].as_str()), (Some(23), Some(102), Some("PvE")));
    let table = run(&["scenarios"]).expect("runs");
    assert!(table.contains("MMM_vs_MMM") && table.contains("PvP") && table.contains("3m -> 3m_vlm"));
}

#[test]
fn episode_json_has_per_episode_records_and_rates() {
    let out = run(&["episode", "--scenario", "3m_vlm", "--episodes", "4", "--seed", "7", "--json", "--opponent", "random"]).expect("runs");
    let r: avacraft_cli::Report = serde_json::from_str(&out).expect("report");
    assert_eq!(r.episodes.len(), 4);
    assert_eq!(r.episodes.iter().map(|e| e.seed).collect::<Vec<_>>(), [7, 8, 9, 10]);
    let total = r.summary.win.mean + r.summary.draw.mean + r.summary.loss.mean;
    assert!((total - 1.0).abs() < 1e-9);
    for e in &r.episodes {
        assert_eq!(e.trajectory_hash.len(), 16);
        assert!(e.game_loops > 0 && e.game_loops <= 6720);
    }
    // Same seeds, same hashes.
    let again: avacraft_cli::Report = serde_json::from_str(
        &run(&["episode", "--scenario", "3m_vlm", "--episodes", "4", "--seed", "7", "--json", "--opponent", "random"]).expect("runs"),
    )
    .expect("report");
    let h = |r: &avacraft_cli::Report| r.episodes.iter().map(|e| e.trajectory_hash.clone()).collect::<Vec<_>>();
    assert_eq!(h(&r), h(&again));
    // PvP takes two agent policies.
    let out = run(&["episode", "--scenario", "MMM_vs_MMM", "--episodes", "1", "--agent", "focus-fire", "--agent2", "kite"]).expect("runs");
    assert!(out.contains("focus-fire (team 1) vs kite (team 2)"), "{out}");
}

#[test]
fn bad_arguments_say_what_is_wrong() {
    let e = run(&["episode", "--scenario", "nope"]).expect_err("unknown scenario");
    assert!(e.contains("unknown scenario `nope`"), "{e}");
    let e = run(&["episode", "--scenario", "3m_vlm", "--agent", "genius"]).expect_err("unknown policy");
    assert!(e.contains("--agent") && e.contains("genius"), "{e}");
    let e = run(&["episode", "--scenario", "3m_vlm", "--opponent", "genius"]).expect_err("unknown opponent");
    assert!(e.contains("--opponent") && e.contains("unknown opponent"), "{e}");
    let e = run(&["episode", "--scenario", "MMM_vs_MMM", "--opponent", "builtin"]).expect_err("pvp");
    assert!(e.contains("--agent2"), "{e}");
    let e = run(&["env-info", "--scenario", "3m_vlm", "--team", "3"]).expect_err("team");
    assert!(e.contains("--team"), "{e}");
    let e = run(&["episode", "--scenario", "3m_vlm", "--episodes", "0"]).expect_err("zero");
    assert!(e.contains("--episodes"), "{e}");
}

#[test]
fn bench_reports_steps_per_second() {
    let out = run(&["bench", "--scenario", "3m_vlm", "--seconds", "0.05", "--json"]).expect("runs");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert!(v["steps_per_sec"].as_f64().is_some_and(|x| x > 0.0), "{v}");
    assert!(v.get("bytes_per_env").is_some());
    assert!(v["ratio_to_sim_only"].as_f64().is_some());
}

#[test]
fn training_bench_reports_learning_against_the_game_alone() {
    for (algo, small) in [("vdn", "batch_size=4"), ("mappo", "rollout_len=20")] {
        let out = run(&["bench", "--train", "--algo", algo, "--steps", "400", "--set", small, "--json"]).expect("runs");
        let v: Vec<serde_json::Value> = serde_json::from_str(&out).expect("json");
        assert_eq!(v.len(), 1, "{out}");
        let r = &v[0];
        assert_eq!((r["algo"].as_str(), r["scenario"].as_str(), r["steps"].as_u64()), (Some(algo), Some("3m_vlm"), Some(400)), "{r}");
        assert!(r.get("goal").is_none(), "only goal rows have goals: {r}");
        assert!(r["updates"].as_u64().is_some_and(|u| u > 0), "it learned: {r}");
        let (Some(train), Some(game), Some(ratio)) =
            (r["train_steps_per_sec"].as_f64(), r["env_steps_per_sec"].as_f64(), r["ratio"].as_f64())
        else {
            panic!("rates missing: {r}")
        };
        assert!(train > 0.0 && game > 0.0 && (ratio - train / game).abs() < 1e-9, "{r}");
    }
    let err = run(&["bench", "--train", "--algo", "sarsa", "--steps", "10"]).expect_err("unknown algorithm");
    assert!(err.contains("sarsa"), "{err}");
    let err = run(&["bench", "--train", "--steps", "0"]).expect_err("no steps");
    assert!(err.contains("--steps"), "{err}");
    // A refused value: its key, value, rule and the nearest valid value come first.
    let err = run(&["bench", "--train", "--algo", "ippo", "--steps", "400", "--set", "rollout_len=117"]).expect_err("not a multiple");
    assert!(err.trim_start().starts_with("`rollout_len = 117`"), "{err}");
    assert!(err.contains("multiple of data_chunk_length (10)") && err.contains("nearest valid value: 120"), "{err}");
}

#[test]
fn vector_bench_reports_its_ratio_to_one_env() {
    let out = run(&["bench", "--vec", "--envs", "4", "--scenario", "3m_vlm", "--seconds", "0.05", "--json"]).expect("runs");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    let r = &v[0];
    assert_eq!((r["scenario"].as_str(), r["envs"].as_u64()), (Some("3m_vlm"), Some(4)), "{v}");
    let (single, many, ratio) = (r["single_steps_per_sec"].as_f64(), r["vec_steps_per_sec"].as_f64(), r["ratio"].as_f64());
    let (Some(single), Some(many), Some(ratio)) = (single, many, ratio) else { panic!("rates missing: {v}") };
    assert!(single > 0.0 && many > 0.0 && (ratio - many / single).abs() < 1e-9, "{v}");
    let err = run(&["bench", "--vec", "--envs", "0"]).expect_err("no environments");
    assert!(err.contains("--envs"), "{err}");
}

#[test]
fn llm_local_names_a_missing_model_and_excludes_the_other_back_ends() {
    let dir = std::env::temp_dir().join(format!("avacraft-llm-local-{}", std::process::id()));
    let missing = dir.join("missing.gguf");
    let record = dir.join("rec");
    let (m, r) = (missing.to_string_lossy().into_owned(), record.to_string_lossy().into_owned());
    let e = run(&["episode", "--scenario", "3m_vlm", "--agent", "ava", "--llm-local", &m, "--llm-record", &r]).expect_err("no model file");
    assert!(e.contains("--llm-local") && e.contains(&m) && e.contains("no such file"), "{e}");
    let e = run(&["episode", "--scenario", "3m_vlm", "--agent", "ava", "--llm-local", &m, "--llm-url", "http://127.0.0.1:9/v1"])
        .expect_err("two back ends");
    assert!(e.contains("--llm-local") && e.contains("--llm-url"), "{e}");
    // The flags become the same settings a launch file's `model: {kind: local}` holds, checked
    // the same way before anything loads.
    let e = run(&["episode", "--scenario", "3m_vlm", "--agent", "ava", "--llm-local", &m, "--llm-threads", "5000", "--llm-record", &r])
        .expect_err("bad threads");
    assert!(e.contains("--llm-local") && e.contains("n_threads 5000"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
