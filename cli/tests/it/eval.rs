//! `avacraft eval`: a plan of scripted, MARL and AVA agents on PvE scenarios and a
//! head-to-head matrix plays in parallel, writes its report, resumes after an interruption
//! without replaying finished episodes, splits into shards that merge to the same results,
//! and keeps other cells' results when one cell's endpoint is down.

use crate::common::{exe, marl_checkpoint, tmp};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn eval(args: &[&str]) -> Output {
    Command::new(exe()).arg("eval").args(args).stderr(Stdio::inherit()).output().expect("run avacraft eval")
}

/// `avacraft eval` with its standard error kept, for the messages of refusals.
fn eval_captured(args: &[&str]) -> Output {
    Command::new(exe()).arg("eval").args(args).output().expect("run avacraft eval")
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// (cell, seed) -> (result, trajectory hash) of a results file.
fn episodes(dir: &Path) -> BTreeMap<(String, u64), (String, String)> {
    let text = std::fs::read_to_string(dir.join("results.jsonl")).expect("results");
    text.lines()
        .filter_map(|l| serde_json::from_str::<avacraft_eval::EpisodeResult>(l).ok())
        .filter(|r| r.ok())
        .map(|r| ((r.cell.to_string(), r.seed), (r.result.map_or("", avacraft_engine::Outcome::name).to_owned(), r.trajectory_hash)))
        .collect()
}

fn plan(name: &str) -> std::path::PathBuf {
    let dir = tmp(&format!("eval-{name}"));
    std::fs::create_dir_all(&dir).expect("dir");
    let marl = marl_checkpoint();
    let body = format!(
        r#"name = "{name}"
scenarios = ["3m_vlm", "2m_vs_1z_vlm"]
seeds = [1, 2, 3]

[[agents]]
name = "focus-fire"
policy = "focus-fire"

[[agents]]
name = "hold"
policy = "hold"

[[agents]]
name = "qmix"
policy = "marl:{marl}"
scenarios = ["3m_vlm"]

[[agents]]
name = "ava-standin"
policy = "ava"
scenarios = ["3m_vlm"]
ava = {{ model = {{ kind = "synthetic" }}, record = "calls", config = {{ image = false, decide_every = 4 }} }}

[[headtohead]]
scenarios = ["MMM_vs_MMM"]
agents = ["focus-fire", "hold"]

[[curves]]
name = "qmix 3m_vlm"
dir = "{marl}"
"#,
        marl = marl.display()
    );
    let p = dir.join("plan.toml");
    std::fs::write(&p, body).expect("plan");
    p
}

#[test]
fn a_plan_plays_reports_resumes_and_shards_into_the_same_results() {
    let p = plan("full");
    let out = tmp("eval-full-out");
    let o = eval(&[p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8"), "--threads", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    // 3m_vlm: 4 agents, 2m_vs_1z_vlm: 2 (the checkpoint and AVA are limited to 3m_vlm), MMM: 4 pairings.
    let all = episodes(&out);
    assert_eq!(all.len(), (4 + 2 + 4) * 3, "{:?}", all.keys().collect::<Vec<_>>());
    for f in ["report.md", "report.csv", "report.json", "winrate.png", "headtohead-MMM_vs_MMM.png", "curves.png", "plan.json"] {
        assert!(out.join(f).is_file(), "{f} written");
    }
    let md = std::fs::read_to_string(out.join("report.md")).expect("report");
    for needle in [
        "## Win rate per scenario (default)",
        "### Best of each kind",
        "## Cost per agent",
        "## Head to head on MMM_vs_MMM",
        "| 3m_vlm |",
        "ava-standin",
    ] {
        assert!(md.contains(needle), "report lacks `{needle}`:\n{md}");
    }
    let report: avacraft_eval::Report =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).expect("json")).expect("report");
    let ff = report.cells.iter().find(|c| c.key.scenario == "3m_vlm" && c.key.agent == "focus-fire").expect("cell");
    assert_eq!(ff.episodes, 3);
    assert_eq!(ff.wins + ff.draws + ff.losses, 3);
    assert!(ff.win_ci95.0 <= ff.win_rate.mean && ff.win_rate.mean <= ff.win_ci95.1, "{ff:?}");
    let ava = report.cells.iter().find(|c| c.key.agent == "ava-standin").and_then(|c| c.cost.clone()).expect("AVA's cost");
    assert!(ava.calls_per_decision >= 1.0 && ava.decisions_per_episode > 0.0, "{ava:?}");
    let csv = std::fs::read_to_string(out.join("report.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 1 + report.cells.len());
    // marl-eval's raw data: the same cells, the wins per episode.
    let me: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("marl_eval.json")).expect("marl_eval.json")).expect("json");
    // Tasks are grouped by their set of agents (marl-eval needs the same set in every task).
    let env = me.as_object().and_then(|envs| envs.values().find(|e| e.get("3m_vlm").is_some())).expect("an environment with 3m_vlm");
    let ff_runs = &env["3m_vlm"]["focus-fire"]["run_1"];
    let wins = ff_runs["absolute_metrics"]["win_rate"].as_array().expect("win_rate");
    assert_eq!(wins.len(), 3);
    assert_eq!(wins.iter().filter_map(serde_json::Value::as_f64).sum::<f64>() as usize, ff.wins);
    assert_eq!(ff_runs["step_1"]["step_count"], 0);
    // The episodes equal what `episode` plays in-process for the same agent and seed.
    let one = Command::new(exe())
        .args(["episode", "--scenario", "3m_vlm", "--agent", "focus-fire", "--seed", "2", "--json"])
        .output()
        .expect("episode");
    let v: serde_json::Value = serde_json::from_slice(&one.stdout).expect("json");
    let key = ("3m_vlm / focus-fire vs opponent:default".to_owned(), 2);
    assert_eq!(v["episodes"][0]["trajectory_hash"].as_str(), Some(all[&key].1.as_str()));

    // Interrupted: half the lines and a torn last one are left; the rerun plays only the rest.
    let text_all = std::fs::read_to_string(out.join("results.jsonl")).expect("results");
    let lines: Vec<&str> = text_all.lines().collect();
    let keep = lines.len() / 2;
    let torn = format!("{}\n{}", lines[..keep].join("\n"), &lines[keep][..lines[keep].len() / 2]);
    std::fs::write(out.join("results.jsonl"), torn).expect("truncate");
    let o = eval(&[p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", text(&o));
    let said = text(&o);
    assert!(said.contains(&format!("{} played now, {keep} done before", lines.len() - keep)), "{said}");
    assert!(said.contains("skipped an unreadable result line"), "the torn line is reported: {said}");
    assert_eq!(episodes(&out), all, "the resumed run has the same episodes");

    // Two shards, merged: the same episodes, the same games.
    let (s1, s2, merged) = (tmp("eval-shard1"), tmp("eval-shard2"), tmp("eval-merged"));
    for (s, d) in [("1/2", &s1), ("2/2", &s2)] {
        let o = eval(&[p.to_str().expect("utf-8"), "--out", d.to_str().expect("utf-8"), "--shard", s]);
        assert!(o.status.success(), "{}", text(&o));
    }
    let (a, b) = (episodes(&s1), episodes(&s2));
    assert!(a.keys().all(|k| !b.contains_key(k)), "shards do not overlap");
    let o = eval(&["merge", "--out", merged.to_str().expect("utf-8"), s1.to_str().expect("utf-8"), s2.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(episodes(&merged), all, "merged shards hold the single run's episodes");
    assert!(merged.join("report.md").is_file());
    // Merging into a folder with results is refused (nothing is overwritten).
    let o = eval(&["merge", "--out", merged.to_str().expect("utf-8"), s1.to_str().expect("utf-8")]);
    assert!(!o.status.success());
    // The same shard twice is refused, naming it; one shard alone merges and says so.
    let twice = tmp("eval-merged-twice");
    let o = eval_captured(&["merge", "--out", twice.to_str().expect("utf-8"), s1.to_str().expect("utf-8"), s1.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("shard 1/2") && err.contains("named twice"), "{err}");
    assert!(!twice.join("results.jsonl").exists(), "nothing merged");
    let part = tmp("eval-merged-part");
    let o = eval(&["merge", "--out", part.to_str().expect("utf-8"), s2.to_str().expect("utf-8")]);
    assert!(o.status.success() && text(&o).contains("shards 1/2 are missing"), "{}", text(&o));
    // A shard's folder does not take the whole plan's results (or another shard's).
    let o = eval_captured(&[p.to_str().expect("utf-8"), "--out", s1.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("its results are shard 1/2's, not the whole plan's"), "{err}");
}

/// A plan grown by an agent resumes its folder and plays only the new cells; a checkpoint
/// trained again under the same name is refused there, and nothing recorded changes.
#[test]
fn a_grown_plan_plays_only_its_new_cells_and_a_changed_checkpoint_is_refused() {
    let dir = tmp("eval-grown");
    let ckpt = dir.join("qmix");
    std::fs::create_dir_all(&ckpt).expect("dir");
    for f in ["config.json", "agent.safetensors"] {
        std::fs::copy(marl_checkpoint().join(f), ckpt.join(f)).expect("copy the checkpoint");
    }
    let write = |agents: &[(&str, &str)]| {
        let mut body = "name = \"grown\"\nscenarios = [\"3m_vlm\"]\nseeds = [1, 2]\n".to_owned();
        for (name, policy) in agents {
            body.push_str(&format!("\n[[agents]]\nname = \"{name}\"\npolicy = \"{policy}\"\n"));
        }
        let p = dir.join("plan.toml");
        std::fs::write(&p, body).expect("plan");
        p
    };
    let marl = format!("marl:{}", ckpt.display());
    let out = dir.join("out");
    let run = |p: &Path| eval_captured(&[p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8"), "--threads", "1"]);

    let o = run(&write(&[("focus-fire", "focus-fire"), ("qmix", &marl)]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let before = episodes(&out);
    assert_eq!(before.len(), 4);

    let o = run(&write(&[("focus-fire", "focus-fire"), ("qmix", &marl), ("hold", "hold")]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text(&o).contains("2 played now, 4 done before"), "{}", text(&o));
    let after = episodes(&out);
    assert_eq!(after.len(), 6);
    assert!(before.iter().all(|(k, v)| after.get(k) == Some(v)), "the old episodes are kept as they were");
    assert!(std::fs::read_to_string(out.join("report.md")).expect("report").contains("hold"), "the report has the new agent");

    // The same name, the same folder, another network: refused, naming what changed.
    let mut w = std::fs::read(ckpt.join("agent.safetensors")).expect("read");
    let last = w.len() - 1;
    w[last] ^= 1;
    std::fs::write(ckpt.join("agent.safetensors"), w).expect("write");
    let o = run(&write(&[("focus-fire", "focus-fire"), ("qmix", &marl), ("hold", "hold")]));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("agent `qmix` on 3m_vlm played a policy whose fingerprint"), "{err}");
    assert_eq!(episodes(&out), after, "nothing recorded changed");
}

/// A shipped image-mode baseline plays PvE from frames rendered from the game (an engine
/// agent is not handed them): an evaluation's cells and `episode` play the same games, won
/// as its greedy tests were; in a PvP game it is refused with the reason.
#[test]
fn image_baselines_play_pve_from_rendered_frames() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = tmp("eval-rgb");
    std::fs::create_dir_all(&dir).expect("dir");
    let p = dir.join("plan.toml");
    std::fs::write(
        &p,
        "name = \"rgb\"\nscenarios = [\"3m_vlm\"]\nseeds = [7, 8]\n\n[[agents]]\nname = \"mappo-rgb\"\npolicy = \"baseline:mappo-rgb\"\n",
    )
    .expect("plan");
    let out = tmp("eval-rgb-out");
    let run = |args: &[&str]| Command::new(exe()).env("AVACRAFT_BASELINES", repo.join("baselines")).args(args).output().expect("avacraft");
    let o = run(&["eval", p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let all = episodes(&out);
    assert_eq!(all.len(), 2, "{all:?}");
    assert!(all.values().all(|(result, _)| result == "win"), "{all:?}");
    // The plan plays the network on the game it learned (`legacy`); so does `--data legacy`.
    let o = run(&[
        "episode",
        "--scenario",
        "3m_vlm",
        "--data",
        "legacy",
        "--agent",
        "baseline:mappo-rgb",
        "--seed",
        "7",
        "--episodes",
        "2",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let hashes: Vec<&str> =
        v["episodes"].as_array().expect("episodes").iter().map(|e| e["trajectory_hash"].as_str().expect("hash")).collect();
    let evaluated: Vec<&str> = all.values().map(|(_, h)| h.as_str()).collect();
    assert_eq!(hashes, evaluated, "episode and eval play the same games");
    let rgb = repo.join("baselines/3m_vlm/mappo-rgb");
    let o = run(&["episode", "--scenario", "MMM_vs_MMM", "--agent", &format!("marl:{}", rgb.display())]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("trained on `rgb` observations"), "{err}");
}

/// `baseline:NAME` plays each scenario's shipped policy and leaves out, by name, the
/// scenarios where none is shipped.
#[test]
fn baseline_agents_play_the_shipped_policy_of_each_scenario() {
    let root = tmp("eval-baselines-root");
    let qmix = root.join("3m_vlm").join("qmix");
    std::fs::create_dir_all(&qmix).expect("dir");
    for f in ["agent.safetensors", "config.json"] {
        std::fs::copy(marl_checkpoint().join(f), qmix.join(f)).expect("copy");
    }
    let dir = tmp("eval-baselines");
    std::fs::create_dir_all(&dir).expect("dir");
    let p = dir.join("plan.toml");
    std::fs::write(
        &p,
        "name = \"b\"\nscenarios = [\"3m_vlm\", \"2m_vs_1z_vlm\"]\nseeds = [7, 8]\n\n[[agents]]\nname = \"qmix\"\npolicy = \"baseline:qmix\"\n\n[[agents]]\nname = \"focus-fire\"\npolicy = \"focus-fire\"\n",
    )
    .expect("plan");
    let out = tmp("eval-baselines-out");
    let o = Command::new(exe())
        .env("AVACRAFT_BASELINES", &root)
        .args(["eval", p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8"), "--print"])
        .output()
        .expect("eval");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text(&o).contains("No shipped baseline, so not played: qmix on 2m_vs_1z_vlm"), "{}", text(&o));
    let md = text(&o);
    assert!(md.contains("## MARL against scripted agents") && md.contains("**mean over 1 scenarios**"), "{md}");
    let all = episodes(&out);
    // qmix on 3m_vlm only; focus-fire on both.
    assert_eq!(all.len(), 2 + 2 * 2, "{:?}", all.keys().collect::<Vec<_>>());
    // The same games as the checkpoint named by its folder.
    for seed in ["7", "8"] {
        let ep = |agent: &str| {
            let o = Command::new(exe())
                .env("AVACRAFT_BASELINES", &root)
                .args(["episode", "--scenario", "3m_vlm", "--agent", agent, "--seed", seed, "--json"])
                .output()
                .expect("episode");
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
            v["episodes"][0]["trajectory_hash"].as_str().expect("hash").to_owned()
        };
        let by_name = ep("baseline:qmix");
        assert_eq!(by_name, ep(&format!("marl:{}", qmix.display())));
        assert_eq!(all[&("3m_vlm / qmix vs opponent:default".to_owned(), seed.parse().expect("seed"))].1, by_name);
    }
    // A scenario without one is refused where it is named, with what is shipped.
    let o = Command::new(exe())
        .env("AVACRAFT_BASELINES", &root)
        .args(["episode", "--scenario", "3m_vlm", "--agent", "baseline:mappo"])
        .output()
        .expect("episode");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("no shipped `mappo` baseline for scenario `3m_vlm`") && err.contains("shipped there: qmix"),
        "{err}"
    );
}

#[test]
fn a_cell_whose_endpoint_is_down_plays_on_fallbacks_and_counts_the_failed_calls() {
    let dir = tmp("eval-down");
    std::fs::create_dir_all(&dir).expect("dir");
    let port = std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).expect("port");
    let body = format!(
        r#"scenarios = ["3m_vlm"]
seeds = [5, 6]
[[agents]]
name = "focus-fire"
policy = "focus-fire"
[[agents]]
name = "ava-down"
policy = "ava"
ava = {{ model = {{ kind = "openai", url = "http://127.0.0.1:{port}/v1", model = "m", timeout_s = 2.0 }}, config = {{ max_retries = 0, image = false, decide_every = 50 }} }}
"#
    );
    let p = dir.join("down.toml");
    std::fs::write(&p, body).expect("plan");
    let out = dir.join("out");
    let o = eval(&[p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8")]);
    let said = text(&o);
    // AVA falls back when its endpoint is down: the episodes finish, every failed call counted.
    let report: avacraft_eval::Report =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).expect("json")).expect("report");
    let ff = report.cells.iter().find(|c| c.key.agent == "focus-fire").expect("focus-fire's cell");
    assert_eq!(ff.episodes, 2, "{said}");
    let ava = report.cells.iter().find(|c| c.key.agent == "ava-down").expect("AVA's cell");
    let cost = ava.cost.as_ref().expect("cost");
    assert!(cost.failed_calls > 0 && cost.fallbacks > 0, "{cost:?}");
    assert!(o.status.success(), "{said}");
}

/// A cell whose agent cannot start (AVA replaying a recording that is not there) fails
/// episode by episode with the reason, the other cells' results are kept, the run exits with
/// an error, and the next run plays the failed episodes again (only those).
#[test]
fn failed_episodes_are_reported_kept_apart_and_played_again() {
    let dir = tmp("eval-fail");
    std::fs::create_dir_all(&dir).expect("dir");
    let body = r#"scenarios = ["3m_vlm"]
seeds = [1, 2]
[[agents]]
name = "focus-fire"
policy = "focus-fire"
[[agents]]
name = "ava-replay"
policy = "ava"
ava = { model = { kind = "replay", dir = "no-such-recording" } }
"#;
    let p = dir.join("fail.toml");
    std::fs::write(&p, body).expect("plan");
    let out = dir.join("out");
    for round in 0..2 {
        let o = eval_captured(&[p.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8")]);
        let said = text(&o);
        assert!(!o.status.success(), "failed episodes make the run fail: {said}");
        // Without a terminal (here, a pipe) each failure is still said, with its reason, and
        // where the run stands; every cell counts the seeds it plays (AVA's two, not the plan's).
        let err = String::from_utf8_lossy(&o.stderr);
        if round == 0 {
            assert_eq!(err.matches("FAILED 3m_vlm / ava-replay vs opponent:default seed").count(), 2, "{err}");
            assert!(err.contains("no-such-recording"), "{err}");
            assert!(err.contains("4/4 episodes; "), "the last episode's line: {err}");
        } else {
            assert!(err.contains("resuming: 2 of 4 episodes are done already"), "{err}");
        }
        let played = if round == 0 { "2 played now, 0 done before, 2 failed" } else { "0 played now, 2 done before, 2 failed" };
        assert!(said.contains(played), "round {round}: {said}");
        let report: avacraft_eval::Report =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).expect("json")).expect("report");
        assert_eq!(report.cells.len(), 1, "only focus-fire's cell has results");
        assert_eq!(report.missing.len(), 1, "AVA's cell is reported as not played");
        let lines = std::fs::read_to_string(out.join("results.jsonl")).expect("results");
        let failed: Vec<avacraft_eval::EpisodeResult> =
            lines.lines().filter_map(|l| serde_json::from_str::<avacraft_eval::EpisodeResult>(l).ok()).filter(|r| !r.ok()).collect();
        assert_eq!(failed.len(), 2 * (round + 1));
        assert!(failed.iter().all(|r| r.error.as_deref().is_some_and(|e| e.contains("no-such-recording"))), "{failed:?}");
    }
}

#[test]
fn plan_mistakes_name_the_field() {
    let dir = tmp("eval-bad");
    std::fs::create_dir_all(&dir).expect("dir");
    let cases = [
        ("seeds = []\nscenarios = [\"3m_vlm\"]\n", "seeds"),
        ("seeds = [1, 1]\nscenarios = [\"3m_vlm\"]\n[[agents]]\nname = \"a\"\npolicy = \"hold\"\n", "seeds[1]"),
        ("seeds = [1]\nscenarios = [\"4m\"]\n[[agents]]\nname = \"a\"\npolicy = \"hold\"\n", "scenarios[0]"),
        ("seeds = [1]\nscenarios = [\"MMM_vs_MMM\"]\n[[agents]]\nname = \"a\"\npolicy = \"hold\"\n", "headtohead"),
        ("seeds = [1]\nscenarios = [\"3m_vlm\"]\n[[agents]]\nname = \"a\"\npolicy = \"dance\"\n", "agents[0].policy"),
        ("seeds = [1]\nscenarios = [\"3m_vlm\"]\n[[agents]]\nname = \"a b\"\npolicy = \"hold\"\n", "agents[0].name"),
        ("seeds = [1]\nscenarios = [\"3m_vlm\"]\n[[agents]]\nname = \"a\"\npolicy = \"ava\"\n", "agents[0].policy"),
        ("seeds = [1]\nscenarios = [\"3m_vlm\"]\nopponents = [\"nice\"]\n[[agents]]\nname = \"a\"\npolicy = \"hold\"\n", "opponents[0]"),
        (
            "seeds = [1]\n[[agents]]\nname = \"a\"\npolicy = \"hold\"\n[[headtohead]]\nscenarios = [\"MMM_vs_MMM\"]\nagents = [\"b\"]\n",
            "headtohead[0].agents[0]",
        ),
        ("seeds = [1]\nscenarios = [\"3m_vlm\"]\nepisodes = 3\n", "unknown field"),
    ];
    for (body, field) in cases {
        let p = dir.join("bad.toml");
        std::fs::write(&p, body).expect("plan");
        let e = avacraft_eval::load(&p).expect_err(body);
        let msg = format!("{:#}", anyhow::Error::new(e));
        assert!(msg.contains(field), "{body}: {msg}");
        assert!(msg.starts_with(&p.display().to_string()), "{msg}");
    }
}

/// The paper's plan parses: every scenario with the four scripted agents, 100 evaluation
/// seeds apart from the training seeds, AVA on its three scenarios and five seeds, and the
/// report going to docs/results.md.
#[test]
fn the_paper_plan_is_valid() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../eval/plans/paper.toml");
    let plan = avacraft_eval::load(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(plan.seeds, (1001..=1100).collect::<Vec<u64>>());
    for name in avacraft_engine::builtin_names() {
        for agent in ["focus-fire", "kite", "attack-move", "random"] {
            assert!(plan.cells.iter().any(|c| c.key.scenario == name && c.key.agent == agent), "{agent} on {name}");
        }
        // `qmix-last` plays `baseline:qmix@last`, shipped only with runs trained since; the
        // PvP scenarios' head-to-heads name their agents and leave the last checkpoints out.
        let pvp = avacraft_engine::builtin(name).is_ok_and(|s| s.mode == avacraft_engine::Mode::Pvp);
        let lasts: &[&str] = if pvp { &[] } else { &["qmix-last", "mappo-last"] };
        for agent in ["qmix", "mappo"].iter().chain(lasts) {
            let agent = *agent;
            let played = plan.cells.iter().any(|c| c.key.scenario == name && c.key.agent == agent);
            let skipped = plan.unshipped.contains(&(agent.to_owned(), name.to_owned()));
            assert!(played != skipped, "{agent} on {name}: played or said to be unshipped");
        }
    }
    for (seed, of) in [("qmix-s2", "qmix"), ("qmix-s3", "qmix"), ("mappo-s2", "mappo"), ("mappo-s3", "mappo")] {
        assert!(plan.agents.iter().any(|a| a.name == seed && a.seed_of.as_deref() == Some(of)), "{seed}: a training seed of {of}");
    }
    for agent in ["ippo-rgb", "mappo-rgb"] {
        assert!(plan.cells.iter().any(|c| c.key.scenario == "3m_vlm" && c.key.agent == agent), "{agent} on 3m_vlm");
    }
    let ava: Vec<_> = plan.cells.iter().filter(|c| c.key.agent == "ava-smollm2-text").collect();
    assert_eq!(ava.len(), 3);
    assert!(ava.iter().all(|c| plan.seeds_of(c).len() == 5));
    assert!(plan.document.as_ref().is_some_and(|d| d.ends_with("docs/results.md")));
}

/// The shipped baselines, played on seeds outside the paper plan's (5001-5040), win about
/// as often as docs/results.md says: inside the table's 95% interval for the scenarios
/// most papers report.
#[test]
fn shipped_baselines_win_as_often_as_the_results_table_says() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let json = std::fs::read_to_string(repo.join("docs/results/report.json"))
        .expect("docs/results/report.json (avacraft eval eval/plans/paper.toml)");
    let report: avacraft_eval::Report = serde_json::from_str(&json).expect("the report");
    let mut checked = 0;
    let cases = [
        ("3m_vlm", "qmix"),
        ("3m_vlm", "mappo"),
        ("2s3z_vlm", "qmix"),
        ("2s3z_vlm", "mappo"),
        ("2m_vs_1z_vlm", "qmix"),
        ("8m1mv_vs_2st", "mappo"),
        ("8m1mv_vs_2st", "qmix"),
    ];
    for (scenario, agent) in cases {
        let cell = report
            .cells
            .iter()
            .find(|c| c.key.scenario == scenario && c.key.agent == agent && c.key.against == "opponent:default")
            .unwrap_or_else(|| panic!("docs/results has no {agent} on {scenario}"));
        let o = Command::new(exe())
            .env("AVACRAFT_BASELINES", repo.join("baselines"))
            .args([
                "episode",
                "--scenario",
                scenario,
                // The game the table was played on (eval/plans/paper.toml's `data`).
                "--data",
                "legacy",
                "--agent",
                &format!("baseline:{agent}"),
                "--seed",
                "5001",
                "--episodes",
                "40",
                "--json",
            ])
            .output()
            .expect("episode");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        let eps = v["episodes"].as_array().expect("episodes");
        assert_eq!(eps.len(), 40);
        let wins = eps.iter().filter(|e| e["result"] == "win").count();
        let rate = wins as f64 / 40.0;
        let (lo, hi) = cell.win_ci95;
        assert!(lo <= rate && rate <= hi, "{agent} on {scenario}: {wins}/40 on seeds 5001-5040, the table's interval [{lo:.2}, {hi:.2}]");
        checked += 1;
    }
    assert_eq!(checked, cases.len());
}

/// The shipped league policy with the ability slots plays through `episode` (which gives its
/// games the slots) the games the league page reports, against each script.
#[test]
fn the_ability_league_plays_the_games_its_page_reports() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let json = std::fs::read_to_string(repo.join("docs/pvp_league/report.json"))
        .expect("docs/pvp_league/report.json (avacraft eval eval/plans/pvp_league_eval.toml)");
    let report: avacraft_eval::Report = serde_json::from_str(&json).expect("the report");
    for against in ["focus-fire", "attack-move"] {
        let cell = report
            .cells
            .iter()
            .find(|c| c.key.scenario == "8s_vs_8m3mr1mv1st_pvp" && c.key.agent == "qmix-league-abilities" && c.key.against == against)
            .unwrap_or_else(|| panic!("docs/pvp_league has no qmix-league-abilities against {against}"));
        let o = Command::new(exe())
            .env("AVACRAFT_BASELINES", repo.join("baselines"))
            .args(["episode", "--scenario", "8s_vs_8m3mr1mv1st_pvp", "--agent", "baseline:qmix-league-abilities", "--agent2", against])
            .args(["--seed", "9000", "--episodes", "20", "--json"])
            .output()
            .expect("episode");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        let eps = v["episodes"].as_array().expect("episodes");
        let wins = eps.iter().filter(|e| e["result"] == "win").count();
        assert_eq!((eps.len(), wins), (20, cell.wins), "against {against}");
        // It blinks: the slots were there.
        assert!(eps.iter().any(|e| e["abilities"][0]["blink"].as_u64().unwrap_or(0) > 0), "against {against}");
    }
}

/// Without a plan-wide `data`, a trained network's cells play the unit data it learned on
/// (the shipped 3m_vlm QMIX: `legacy`), a script's the scenario's own (Liberty); with one, every
/// cell plays it.
#[test]
fn each_cell_plays_its_networks_game_unless_the_plan_names_one() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = |data: &str| {
        format!(
            "name = \"g\"\n{data}scenarios = [\"3m_vlm\"]\nseeds = [1]\n\n[[agents]]\nname = \"q\"\npolicy = \"marl:baselines/3m_vlm/qmix\"\n\n[[agents]]\nname = \"ff\"\npolicy = \"focus-fire\"\n"
        )
    };
    let game = |plan: &avacraft_eval::Plan, agent: &str| {
        plan.cells.iter().find(|c| c.key.agent == agent).map(|c| c.scenario.data).expect("a cell")
    };
    let own = avacraft_eval::parse("g.toml", &text(""), Some(&repo)).expect("plan");
    assert_eq!((game(&own, "q"), game(&own, "ff")), (avacraft_engine::DataSet::Legacy, avacraft_engine::DataSet::Liberty));
    let ladder = avacraft_eval::parse("g.toml", &text("data = \"ladder\"\n"), Some(&repo)).expect("plan");
    assert_eq!((game(&ladder, "q"), game(&ladder, "ff")), (avacraft_engine::DataSet::Ladder, avacraft_engine::DataSet::Ladder));
    let e = avacraft_eval::parse("g.toml", &text("data = \"lotv\"\n"), Some(&repo)).expect_err("no such set").to_string();
    assert!(e.contains("data") && e.contains("liberty, void, ladder, legacy"), "{e}");
}

/// A network played on other unit data than it learned on plays (a different game), with a
/// warning naming both sets; `--data` with its set plays the game it learned, quietly.
#[test]
fn a_baseline_on_other_unit_data_is_played_with_a_warning() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let run = |extra: &[&str]| {
        let mut args = vec!["episode", "--scenario", "3m_vlm", "--agent", "baseline:qmix", "--episodes", "1", "--json"];
        args.extend_from_slice(extra);
        let o = Command::new(exe()).env("AVACRAFT_BASELINES", repo.join("baselines")).args(&args).output().expect("episode");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let warned = run(&[]);
    assert!(warned.contains("trained on the legacy unit data") && warned.contains("3m_vlm plays on liberty"), "{warned}");
    let quiet = run(&["--data", "legacy"]);
    assert!(!quiet.contains("warning"), "{quiet}");
}

/// A network that learned under the surround experiment, played without it (or one that learned
/// without it, played under it), is played with a warning naming the flag that plays the game it
/// learned, on a map with melee units (2s3z's Zealots); with that flag, or on a map where the
/// rule changes nothing (3m's Marines), it plays quietly.
#[test]
fn a_network_played_off_its_surround_rule_is_warned_about() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = tmp("surround-checkpoint");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let shipped = repo.join("baselines/2s3z/qmix");
    for f in ["agent.safetensors", "mixer.safetensors"] {
        if shipped.join(f).is_file() {
            std::fs::copy(shipped.join(f), dir.join(f)).expect("weights");
        }
    }
    let text = std::fs::read_to_string(shipped.join("config.json")).expect("config");
    let mut meta: serde_json::Value = serde_json::from_str(&text).expect("json");
    meta["config"]["melee_surround"] = serde_json::Value::Bool(true);
    std::fs::write(dir.join("config.json"), meta.to_string()).expect("write");
    let run = |scenario: &str, agent: &str, extra: &[&str]| {
        let mut args = vec!["episode", "--scenario", scenario, "--agent", agent, "--episodes", "1", "--json"];
        args.extend_from_slice(extra);
        let o = Command::new(exe()).env("AVACRAFT_BASELINES", repo.join("baselines")).args(&args).output().expect("episode");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let agent = format!("marl:{}", dir.display());
    let warned = run("2s3z", &agent, &[]);
    assert!(
        warned.contains("learned under the surround experiment and plays without it") && warned.contains("--melee-surround true"),
        "{warned}"
    );
    assert!(!run("2s3z", &agent, &["--melee-surround", "true"]).contains("warning"));
    let warned = run("2s3z", "baseline:qmix", &["--melee-surround", "true"]);
    assert!(
        warned.contains("learned without the surround experiment and plays under it") && warned.contains("--melee-surround false"),
        "{warned}"
    );
    assert!(!run("2s3z", "baseline:qmix", &[]).contains("warning"));
    // 3m's Marines: the rule changes nothing there, so no warning (a SMAC 3m network plays).
    assert!(!run("3m", "baseline:qmix", &["--melee-surround", "true"]).contains("surround"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A plan's `env` sets the weapon periods and the surround experiment for every cell: a network
/// that learned under others plays, and the plan lists it with what differs (the surround only
/// on maps with melee units), for the report and the warning `avacraft eval` prints.
#[test]
fn a_plan_lists_the_networks_it_plays_off_their_rules() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = tmp("plan-off-rules");
    let _ = std::fs::remove_dir_all(&dir);
    let net = dir.join("shot-surround");
    std::fs::create_dir_all(&net).expect("dir");
    let shipped = repo.join("baselines/2s3z/qmix");
    for f in ["agent.safetensors", "mixer.safetensors"] {
        if shipped.join(f).is_file() {
            std::fs::copy(shipped.join(f), net.join(f)).expect("weights");
        }
    }
    let mut meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shipped.join("config.json")).expect("config")).expect("json");
    meta["config"]["melee_surround"] = serde_json::Value::Bool(true);
    meta["config"]["weapon_period"] = serde_json::Value::String("shot".into());
    std::fs::write(net.join("config.json"), meta.to_string()).expect("write");
    let text = |env: &str| {
        format!(
            "name = \"g\"\nscenarios = [\"2s3z\"]\nseeds = [1]\n{env}\n[[agents]]\nname = \"q\"\npolicy = \"marl:{}\"\n\n[[agents]]\nname = \"ff\"\npolicy = \"focus-fire\"\n",
            net.display()
        )
    };
    let plan = avacraft_eval::parse("g.toml", &text(""), Some(&repo)).expect("plan");
    assert_eq!(plan.off_rules.len(), 1, "{:?}", plan.off_rules);
    let (agent, scenario, what) = &plan.off_rules[0];
    assert_eq!((agent.as_str(), scenario.as_str()), ("q", "2s3z"));
    assert!(
        what.contains("weapon periods from the shot, played from the attack") && what.contains("under the surround experiment"),
        "{what}"
    );
    let only_surround = avacraft_eval::parse("g.toml", &text("[env]\nweapon_period = \"shot\"\n"), Some(&repo)).expect("plan");
    assert!(only_surround.off_rules.len() == 1 && !only_surround.off_rules[0].2.contains("weapon"), "{:?}", only_surround.off_rules);
    let its_own = text("[env]\nweapon_period = \"shot\"\nmelee_surround = true\n");
    assert!(avacraft_eval::parse("g.toml", &its_own, Some(&repo)).expect("plan").off_rules.is_empty());
    // The report says so.
    let m = avacraft_eval::Meta::of(&plan);
    let json = serde_json::to_string(&m).expect("meta json");
    let back: avacraft_eval::Meta = serde_json::from_str(&json).expect("meta back");
    assert_eq!(back.off_rules, plan.off_rules);
    let md = avacraft_eval::Report::build(back, &avacraft_eval::Loaded::default()).markdown();
    assert!(md.contains("Played under other rules than they learned") && md.contains("q on 2s3z (weapon periods from the shot"), "{md}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The shipped SMACv2 baselines (eval/plans/smacv2.toml) on protoss_5_vs_5, whose units and
/// start positions are drawn every episode, on 200 seeds apart from training's and from
/// docs/simulator.md's (5001-5200): both beat focus-fire (the issue's bar) and attack-move;
/// MAPPO beats kite, the best script there, too (QMIX is level with it: 0.74 against 0.68 on
/// the document's seeds, 0.685 against 0.715 on these).
#[test]
fn smacv2_baselines_beat_the_scripts_on_protoss_5_vs_5() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let wins = |agent: &str| {
        let o = Command::new(exe())
            .env("AVACRAFT_BASELINES", repo.join("baselines"))
            // The game these baselines trained on: the engine's legacy unit data.
            .args([
                "episode",
                "--scenario",
                "protoss_5_vs_5",
                "--data",
                "legacy",
                "--agent",
                agent,
                "--seed",
                "5001",
                "--episodes",
                "200",
                "--json",
            ])
            .output()
            .expect("episode");
        assert!(o.status.success(), "{agent}: {}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        let eps = v["episodes"].as_array().expect("episodes");
        assert_eq!(eps.len(), 200, "{agent}");
        eps.iter().filter(|e| e["result"] == "win").count()
    };
    let [focus, attack, kite] = ["focus-fire", "attack-move", "kite"].map(wins);
    for (learner, bar) in [("baseline:mappo", focus.max(attack).max(kite)), ("baseline:qmix", focus.max(attack))] {
        let won = wins(learner);
        assert!(won > bar, "{learner}: {won} of 200; focus-fire {focus}, attack-move {attack}, kite {kite}");
    }
}
