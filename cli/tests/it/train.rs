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

    // While one process trains the run, a second is refused by name and changes nothing;
    // once the first is gone (killed: the system drops its lock), the run is free again.
    let mut busy = Command::new(exe())
        .args(["train", "--resume", d, "--steps", "100000000"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start a long resume");
    // Training once its log grows past the rounds it had (so it holds the run's lock).
    for _ in 0..1200 {
        if log(&dir) > 4 {
            break;
        }
        assert!(busy.try_wait().expect("poll").is_none(), "the long run ended early");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let out = train(&["--resume", d, "--steps", "200000000"]);
    let refused = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success());
    busy.kill().expect("stop the long run");
    let _ = busy.wait();
    assert!(refused.contains("another process is training into") && refused.contains("train.lock"), "{refused}");
    let out = train(&["--resume", d, "--steps", "800"]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("another process"), "{}", String::from_utf8_lossy(&out.stderr));

    // Another game (here other unit data) is not replayed into: the run goes on, from fresh
    // episodes and a new buffer, and says so.
    // The killed run may have trained far past 800 steps: 400 more than it has.
    let text = std::fs::read_to_string(dir.join("log.csv")).expect("log.csv");
    let last: u64 = text.lines().last().and_then(|l| l.split(',').next()?.parse().ok()).expect("a test round's step");
    let (rows, steps) = (log(&dir), (last + 400).to_string());
    let out = train(&["--resume", d, "--steps", &steps, "--set", "data=\"void\""]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("changes the game") && text.contains("fresh episodes"), "{text}");
    assert!(log(&dir) > rows, "the log goes on");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs are kept in folders named after their scenarios (`runs/<plan>/<scenario>/<run>`): such
/// a folder in the working directory does not hide the built-in scenario of that name.
#[test]
fn a_folder_named_like_a_scenario_does_not_hide_it() {
    let dir = tmp("named-folder");
    std::fs::create_dir_all(dir.join("3m_vlm")).expect("folder");
    let out = Command::new(exe())
        .args(["episode", "--scenario", "3m_vlm", "--agent", "focus-fire", "--episodes", "1", "--json"])
        .current_dir(&dir)
        .output()
        .expect("avacraft runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"scenario\": \"3m_vlm\""));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The flags set the config's fields after `--set` (they win over it), and a bad value is
/// refused naming the flag and what it takes, before anything is written.
#[test]
fn flags_win_over_set_and_bad_ones_are_refused_by_name() {
    let dir = tmp("train-flags");
    let _ = std::fs::remove_dir_all(&dir);
    let d = dir.to_str().expect("utf-8 temp path");
    let small = ["--set", "batch_size=4", "--set", "test_interval=200", "--set", "test_nepisode=2", "--set", "episode_limit=60"];
    let mut args = vec!["--algo", "iql", "--scenario", "3m_vlm", "--set", "t_max=5000", "--steps", "200", "--envs", "2", "--out", d];
    args.extend(small);
    let out = train(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("200 steps"), "--steps wins over --set t_max");
    for (flag, value, words) in [("--opponent", "dance", "focus-fire"), ("--obs", "pixels", "vision-text")] {
        let bad = tmp(&format!("train-bad-{value}"));
        let out =
            train(&["--algo", "qmix", "--scenario", "MMM_vs_MMM", flag, value, "--steps", "10", "--out", bad.to_str().expect("utf-8")]);
        assert!(!out.status.success(), "{flag} {value}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&format!("{flag} {value}")) && err.contains(words), "{flag} {value}: {err}");
        assert!(!bad.join("log.csv").exists(), "nothing trained");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--threads` sizes the learner's pool as well as the environments' threads, and the run it
/// trains is the same, byte for byte, on one thread as on two.
#[test]
fn threads_change_the_pace_not_the_run() {
    let small = ["--set", "batch_size=4", "--set", "test_interval=200", "--set", "test_nepisode=2", "--set", "episode_limit=60"];
    let mut logs = Vec::new();
    let mut weights = Vec::new();
    for n in ["1", "2"] {
        let dir = tmp(&format!("train-threads-{n}"));
        let _ = std::fs::remove_dir_all(&dir);
        let mut args = vec!["--algo", "qmix", "--scenario", "3m_vlm", "--steps", "400", "--envs", "2", "--threads", n];
        args.extend(["--out", dir.to_str().expect("utf-8 temp path")]);
        args.extend(small);
        let out = train(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains(&format!("threads: {n} stepping environments, {n} in the learner")), "{text}");
        let log = std::fs::read_to_string(dir.join("log.csv")).expect("log.csv");
        let header: Vec<&str> = log.lines().next().expect("a header").split(',').collect();
        let elapsed = header.iter().position(|c| *c == "elapsed_s").expect("an elapsed_s column");
        let rows: Vec<String> = log
            .lines()
            .map(|l| l.split(',').enumerate().filter(|(i, _)| *i != elapsed).map(|(_, c)| c).collect::<Vec<_>>().join(","))
            .collect();
        assert!(rows.len() >= 3, "a header and two test rounds: {log}");
        logs.push(rows);
        weights.push(std::fs::read(dir.join("agent.safetensors")).expect("agent.safetensors"));
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert_eq!(logs[0], logs[1], "the log but its clock is the same on one thread as on two");
    assert!(weights[0] == weights[1], "the trained weights are the same on one thread as on two");
}

/// A fresh folder `name` with `plan.toml`: a plan of `steps` a run into `runs/`, its `runs`
/// tables with `SMALL` standing for a tiny run's settings.
fn small_plan(name: &str, steps: u64, runs: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let small = "[\"batch_size=4\", \"test_interval=200\", \"test_nepisode=2\", \"episode_limit=60\", \"envs=2\"]";
    let plan = dir.join("plan.toml");
    let text = format!("name = \"p\"\nout = \"runs\"\nsteps = {steps}\nseeds = [1]\n{}", runs.replace("SMALL", small));
    std::fs::write(&plan, text).expect("plan");
    (dir, plan)
}

/// `train --plan P --ship DIR` ships a plan's run resumed by hand (`train --resume`) once it
/// reaches the plan's budget, and not before.
#[test]
fn a_run_resumed_by_hand_ships_at_the_plans_budget() {
    let (dir, plan) = small_plan("ship-by-hand", 400, "[[runs]]\nname = \"vdn\"\nalgo = \"vdn\"\nscenarios = [\"3m_vlm\"]\nset = SMALL\n");
    let run = dir.join("runs/3m_vlm/vdn-s1");
    let r = run.to_str().expect("utf-8");
    let set = ["--set", "batch_size=4", "--set", "test_interval=200", "--set", "test_nepisode=2", "--set", "episode_limit=60"];
    let mut first = vec!["--algo", "vdn", "--scenario", "3m_vlm", "--steps", "200", "--envs", "2", "--out", r];
    first.extend(set);
    let out = train(&first);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let ship = || {
        let out = train(&["--plan", plan.to_str().expect("utf-8"), "--ship", dir.join("shipped").to_str().expect("utf-8")]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let text = ship();
    assert!(text.contains("not finished yet: 3m_vlm/vdn-s1"), "200 of 400 steps: {text}");
    assert!(!dir.join("shipped/3m_vlm/vdn").exists());
    let out = train(&["--resume", r, "--steps", "400"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = ship();
    assert!(text.contains("to its budget") && text.contains("not finished yet: none"), "{text}");
    assert!(dir.join("shipped/3m_vlm/vdn/config.json").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A plan's run with `from` goes on from an earlier run once that one reaches its budget: its
/// log starts with the earlier run's rows, its checkpoint has its own settings, the earlier run
/// is left as it was; it is in the earlier run's shard.
#[test]
fn a_plan_run_goes_on_from_an_earlier_one() {
    let (dir, plan) = small_plan(
        "plan-from",
        200,
        "[[runs]]\nname = \"a\"\nalgo = \"vdn\"\nscenarios = [\"3m_vlm\"]\nset = SMALL\n\
         [[runs]]\nname = \"b\"\nalgo = \"vdn\"\nscenarios = [\"3m_vlm\"]\nsteps = 400\nfrom = \"a\"\nset = [\"lr=0.0001\"]\n",
    );
    let p = plan.to_str().expect("utf-8");
    // The continuation is in its source's shard (the first of two): the second has nothing.
    let out = train(&["--plan", p, "--shard", "2/2"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("0 runs of shard 2/2"), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(!dir.join("runs/3m_vlm/b-s1").exists(), "nothing trained before its source");
    let out = train(&["--plan", p, "--shard", "1/2"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (a, b) = (dir.join("runs/3m_vlm/a-s1"), dir.join("runs/3m_vlm/b-s1"));
    let read = |f: &std::path::Path| std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
    let (log_a, log_b) = (read(&a.join("log.csv")), read(&b.join("log.csv")));
    assert!(log_b.starts_with(&log_a) && log_b.lines().count() > log_a.lines().count(), "{log_a}\n---\n{log_b}");
    assert!(log_b.lines().last().is_some_and(|l| l.starts_with("400,")), "{log_b}");
    let lr = |d: &std::path::Path| read(&d.join("config.json")).lines().find(|l| l.contains("\"lr\"")).map(str::trim).map(str::to_owned);
    assert_eq!(lr(&b).as_deref(), Some("\"lr\": 0.0001,"));
    assert_ne!(lr(&a), lr(&b), "the earlier run keeps its settings");
    assert!(!b.join("done.json").exists() || read(&b.join("done.json")).contains("400"));
    let out = train(&["--plan", p]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.matches("done before").count(), 2, "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `avacraft smac-report`: a run's log beside the published numbers, one row per SMAC map, the
/// gap computed, the table written into a document's marked section, the figure drawn; a
/// published file naming a map SMAC lacks is refused, naming it.
#[test]
fn smac_report_sets_runs_beside_published_results() {
    let dir = tmp("smac-report");
    let _ = std::fs::remove_dir_all(&dir);
    let run = dir.join("runs/3m/qmix-s1");
    std::fs::create_dir_all(&run).expect("run dir");
    let mut log =
        String::from("t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s\n");
    for k in 1..=12 {
        // The last 10 test rounds: 0.5 twice, then 0.9 eight times: median 0.9.
        let w = if k <= 4 { 0.5 } else { 0.9 };
        // Stood paused for 10,000 s after its sixth row: its clock ran on.
        let secs = k * 100 + if k > 6 { 10_000 } else { 0 };
        log.push_str(&format!("{},{k},{k},0.05,0.1,0.1,0.1,0.5,{w},10,{secs}\n", k * 10000));
    }
    std::fs::write(run.join("log.csv"), log).expect("log");
    // Planned for 200k steps: 80k left at its pace of 100 steps a second (the pause aside).
    std::fs::write(run.join("config.json"), r#"{"config": {"t_max": 200000}}"#).expect("config");
    let published = dir.join("published.toml");
    std::fs::write(&published, "[maps.3m]\nclass = \"easy\"\nmappo = { value = 100.0, check = \"u\" }\n").expect("published");
    let doc = dir.join("page.md");
    std::fs::write(&doc, "# page\n<!-- smac-report:begin -->\nstale table\n<!-- smac-report:end -->\ntail\n").expect("doc");
    let args = |p: &std::path::Path| {
        let mut c = Command::new(exe());
        c.args(["smac-report", "--runs"])
            .arg(dir.join("runs"))
            .arg("--published")
            .arg(p)
            .arg("--out")
            .arg(dir.join("out"))
            .arg("--baselines")
            .arg(dir.join("baselines"))
            .arg("--doc")
            .arg(&doc);
        c.output().expect("run avacraft smac-report")
    };
    // Every map needs an entry: 3m alone is refused, naming the next map.
    let out = args(&published);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no entry for `8m`"), "{}", String::from_utf8_lossy(&out.stderr));
    let mut all = String::new();
    for m in avacraft_engine::smac_names() {
        let v = if m == "3m" { "mappo = { value = 100.0, check = \"u\" }\n" } else { "" };
        all.push_str(&format!("[maps.{m}]\nclass = \"easy\"\n{v}"));
    }
    std::fs::write(&published, &all).expect("published");
    let out = args(&published);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let table = String::from_utf8_lossy(&out.stdout);
    // Still training: shown, not compared.
    assert!(table.contains("| 3m | easy | 90 @ 0.1M (unfinished) | not run | – | – | 100 ᵘ | – |"), "{table}");
    assert!(table.contains("maps with a finished run and a published number: none yet"), "{table}");
    // How soon: 50% at the first round, 90% at the fifth and in every round after.
    assert!(table.contains("| map | QMIX 50% at | QMIX 90% at | QMIX rounds ≥ 90% after |"), "{table}");
    assert!(table.contains("\n| 3m | 10k | 50k | 100% | – | – | – |\n"), "{table}");
    assert!(
        table.starts_with("**At a glance.** Runs at SMAC's budget, of 23 maps: qmix on 0 (1 stopped short, 22 not run); mappo on 0 (0 stopped short, 23 not run)."),
        "{table}"
    );
    assert!(table.contains("best published result: no finished run with a published number yet."), "{table}");
    // Its resume state gone (not on this machine): the whole budget again.
    assert!(
        table.contains("**Left to SMAC's budget** (1 hours of one core in all, at the pace of each run's last 50 test rounds):\n\n| run | steps left | trains on from | hours |\n|---|---|---|---|\n| 3m qmix | 0.20M | step 0 (only its shipped copy is here) | 0.6 |\n"),
        "{table}"
    );
    std::fs::create_dir_all(run.join("resume")).expect("resume state");
    let table = String::from_utf8_lossy(&args(&published).stdout).into_owned();
    assert!(
        table.contains("**Left to SMAC's budget** (0 hours of one core in all, at the pace of each run's last 50 test rounds):\n\n| run | steps left | trains on from | hours |\n|---|---|---|---|\n| 3m qmix | 0.08M | where it stopped | 0.2 |\n"),
        "{table}"
    );
    std::fs::write(run.join("done.json"), "{}").expect("done");
    // A finished run with other settings that does better is compared, and named.
    let other = dir.join("runs/3m/mappo-ln-s1");
    std::fs::create_dir_all(&other).expect("variant dir");
    let mut log =
        String::from("t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s\n");
    for k in 1..=10 {
        log.push_str(&format!("{},{k},{k},0,0.1,0.1,0.1,0.9,0.95,19,{k}\n", k * 10000));
    }
    std::fs::write(other.join("log.csv"), log).expect("variant log");
    std::fs::write(other.join("done.json"), "{}").expect("variant done");
    let out = args(&published);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("| 3m | easy | 90 @ 0.1M | not run | – | – | 100 ᵘ | -5 (mappo-ln) |"), "{table}");
    assert!(
        table.contains("| 3m | mappo-ln | the MAPPO repository's network (layer norms, orthogonal initialisation) | 95 @ 0.1M |"),
        "{table}"
    );
    // Runs on another game (the weapon period from the shot, another data set) are listed
    // with what differs, never compared.
    let perfect = std::fs::read_to_string(other.join("log.csv")).expect("variant log").replace(",0.95,", ",1,");
    for (run, game) in [("qmix-shot", "period from the shot"), ("qmix-void", "the Void data set")] {
        let elsewhere = dir.join("runs/3m").join(format!("{run}-s1"));
        std::fs::create_dir_all(&elsewhere).expect("other game's dir");
        std::fs::write(elsewhere.join("log.csv"), &perfect).expect("other game's log");
        std::fs::write(elsewhere.join("done.json"), "{}").expect("other game's run done");
        let table = String::from_utf8_lossy(&args(&published).stdout).into_owned();
        assert!(table.contains(&format!("| 3m | {run} | another game: {game}; never compared | 100 @ 0.1M |")), "{table}");
        assert!(table.contains("| 3m | easy | 90 @ 0.1M | not run | – | – | 100 ᵘ | -5 (mappo-ln) |"), "{table}");
        std::fs::remove_dir_all(&elsewhere).expect("other game's run removed");
    }
    // On a tie the compared learner's run is the one compared.
    let tied = std::fs::read_to_string(other.join("log.csv")).expect("variant log").replace(",0.95,", ",0.9,");
    std::fs::write(other.join("log.csv"), tied).expect("variant log");
    let table = String::from_utf8_lossy(&args(&published).stdout).into_owned();
    assert!(table.contains("| 3m | easy | 90 @ 0.1M | not run | – | – | 100 ᵘ | -10 |"), "{table}");
    std::fs::remove_dir_all(&other).expect("variant removed");
    let out = args(&published);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("| 3m | easy | 90 @ 0.1M | not run | – | – | 100 ᵘ | -10 |"), "{table}");
    assert!(!table.contains("Left to SMAC's budget"), "a finished run has nothing left: {table}");
    assert!(table.contains("Median gap over the 1 maps with a finished run and a published number: -10.0 points"), "{table}");
    // The must-holds at a glance: held-out games not played yet on any easy map here; a
    // median gap of 10 points short still holds.
    assert!(table.contains("qmix on 1 (0 stopped short, 22 not run)"), "{table}");
    assert!(table.contains("held-out episodes (the issue's first must-hold: all of them): 0 of 23 (not played: 23)."), "{table}");
    assert!(table.contains("-10.0 points over 1 maps: the second must-hold (a median of at least -10) holds."), "{table}");
    let page = std::fs::read_to_string(&doc).expect("doc");
    assert!(
        page.starts_with("# page\n<!-- smac-report:begin -->\n**At a glance.**")
            && page.contains(".\n\n| map |")
            && page.ends_with("<!-- smac-report:end -->\ntail\n")
            && !page.contains("stale table"),
        "{page}"
    );
    assert!(dir.join("out/curves.png").is_file() && dir.join("out/table.md").is_file());
    assert!(!table.contains("Other settings"), "{table}");
    // A run with other settings (the feed-forward MAPPO) is listed under the table, not compared.
    let variant = dir.join("runs/3m/mappo-ff-s1");
    std::fs::create_dir_all(&variant).expect("variant dir");
    std::fs::copy(run.join("log.csv"), variant.join("log.csv")).expect("variant log");
    let table = String::from_utf8_lossy(&args(&published).stdout).into_owned();
    assert!(table.contains("| 3m | easy | 90 @ 0.1M | not run | – | – | 100 ᵘ | -10 |"), "{table}");
    assert!(!table.contains("Left to SMAC's budget"), "a finished run has nothing left: {table}");
    assert!(table.contains("**Other settings** (seed 1; test / held-out @ steps, as in the table):\n\n| map | run | what differs | result |\n|---|---|---|---|\n| 3m | mappo-ff | feed-forward actor and critic, 5 PPO epochs (the MAPPO repository's script) | 90 @ 0.1M (unfinished) |\n"), "{table}");
    // A run whose training folder is gone is read from its shipped copy, its held-out games
    // played again (seed 2 of QMIX on 3m: a short run, shipped by hand).
    let trained = dir.join("trained");
    let small = ["--set", "batch_size=4", "--set", "test_interval=200", "--set", "test_nepisode=2", "--envs", "2"];
    let mut first = vec!["--algo", "qmix", "--scenario", "3m", "--steps", "200", "--out", trained.to_str().expect("utf-8")];
    first.extend(small);
    let out = train(&first);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let shipped = dir.join("baselines/3m/qmix-s2");
    std::fs::create_dir_all(&shipped).expect("shipped");
    for f in ["log.csv", "config.json", "agent.safetensors"] {
        std::fs::copy(trained.join(f), shipped.join(f)).expect("copy");
    }
    let out = args(&published);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        table.contains("| map | run | seed 1 | seed 2 | seed 3 | median over seeds (test) |\n|---|---|---|---|---|---|\n"),
        "no seeds table: {table}"
    );
    let line = table.lines().find(|l| l.starts_with("| 3m | qmix | ")).unwrap_or_else(|| panic!("no seeds row: {table}"));
    let cells: Vec<&str> = line.split(" | ").collect();
    assert_eq!(cells.len(), 6, "{line}");
    assert!(cells[2].starts_with("90 @ 0.1M"), "seed 1: {line}");
    assert!(cells[3].contains(" / ") && cells[3].contains("@ 0.0M") && !cells[3].contains("unfinished"), "seed 2: {line}");
    assert_eq!(cells[4], "–", "seed 3 never ran: {line}");
    // The median of two seeds' final rates: their mean.
    let seed2: f64 = cells[3].split(' ').next().and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("seed 2's rate: {line}"));
    assert_eq!(cells[5], format!("{:.0} |", (90.0 + seed2) / 2.0), "{line}");
    // A training folder with a checkpoint and no held-out report (an unfinished run here) has
    // its held-out games played from its checkpoint.
    let third = dir.join("runs/3m/qmix-s3");
    std::fs::create_dir_all(&third).expect("seed 3's folder");
    for f in ["log.csv", "config.json", "agent.safetensors"] {
        std::fs::copy(trained.join(f), third.join(f)).expect("copy");
    }
    let table = String::from_utf8_lossy(&args(&published).stdout).into_owned();
    let line = table.lines().find(|l| l.starts_with("| 3m | qmix | ")).unwrap_or_else(|| panic!("no seeds row: {table}"));
    let cells: Vec<&str> = line.split(" | ").collect();
    assert!(cells[4].contains(" / ") && cells[4].contains("@ 0.0M"), "seed 3, held out from its folder: {line}");
    // With a best-test checkpoint (`best/`), that one plays, as its shipped copy would: the
    // folder's own (the last round's), made unreadable here, is not read.
    std::fs::create_dir_all(third.join("best")).expect("seed 3's best");
    for f in ["config.json", "agent.safetensors"] {
        std::fs::copy(trained.join(f), third.join("best").join(f)).expect("copy");
    }
    std::fs::write(third.join("agent.safetensors"), b"not a checkpoint").expect("spoiled");
    let out = args(&published);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let table = String::from_utf8_lossy(&out.stdout);
    let line = table.lines().find(|l| l.starts_with("| 3m | qmix | ")).unwrap_or_else(|| panic!("no seeds row: {table}"));
    assert!(line.split(" | ").nth(4).is_some_and(|c| c.contains(" / ")), "seed 3, held out from best/: {line}");
    std::fs::remove_dir_all(&third).expect("seed 3's folder removed");
    // Its budget, from the shipped config: short of it, unfinished.
    let config = std::fs::read_to_string(shipped.join("config.json")).expect("config");
    std::fs::write(shipped.join("config.json"), config.replace("\"t_max\": 200", "\"t_max\": 2000000")).expect("config");
    let out = args(&published);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        table
            .lines()
            .any(|l| l.starts_with("| 3m | qmix | ") && l.contains("@ 0.0M (unfinished) | – | ") && l.ends_with(" (a seed unfinished) |")),
        "{table}"
    );
    // A map SMAC does not have.
    std::fs::write(&published, format!("{all}[maps.4m]\nclass = \"easy\"\n")).expect("published");
    let out = args(&published);
    assert!(String::from_utf8_lossy(&out.stderr).contains("`4m` is not one of SMAC's maps"), "{}", String::from_utf8_lossy(&out.stderr));
}

/// A plan's budget may change under a run: raised, the run goes on to it (finished or not, as
/// `train --resume --steps` would); lowered below what the run has trained, the plan is refused
/// naming both numbers, and the run is left as it was.
#[test]
fn a_plans_budget_changed_under_a_run() {
    let runs = "[[runs]]\nname = \"vdn\"\nalgo = \"vdn\"\nscenarios = [\"3m_vlm\"]\nset = SMALL\n";
    let (dir, plan) = small_plan("plan-budget", 200, runs);
    let run = dir.join("runs/3m_vlm/vdn-s1");
    let r = run.to_str().expect("utf-8");
    let mut first = vec!["--algo", "vdn", "--scenario", "3m_vlm", "--steps", "400", "--envs", "2", "--out", r];
    first.extend(["--set", "batch_size=4", "--set", "test_interval=200", "--set", "test_nepisode=2", "--set", "episode_limit=60"]);
    let out = train(&first);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let log = || std::fs::read_to_string(run.join("log.csv")).expect("log.csv");
    let before = log();
    let p = plan.to_str().expect("utf-8");
    let out = train(&["--plan", p]);
    assert!(!out.status.success(), "400 steps trained, a plan of 200");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("has trained 400 steps") && err.contains("budget of 200"), "{err}");
    assert_eq!(log(), before, "a refused plan leaves the run as it was");
    for steps in [600, 800] {
        let text = std::fs::read_to_string(&plan).expect("plan");
        let old = text.lines().find(|l| l.starts_with("steps = ")).expect("steps line").to_owned();
        std::fs::write(&plan, text.replace(&old, &format!("steps = {steps}"))).expect("plan");
        let out = train(&["--plan", p]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("resumed"), "{steps}: {text}");
        assert!(log().starts_with(&before), "the log goes on");
        assert!(log().lines().last().is_some_and(|l| l.starts_with(&format!("{steps},"))), "{}", log());
        assert!(std::fs::read_to_string(run.join("done.json")).is_ok_and(|d| d.contains(&steps.to_string())));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `train --plan P --only RUN` trains that run alone; a run the plan lacks is refused, naming
/// the plan's. With `--ship`, `--only` ships that run alone of two finished ones.
#[test]
fn a_plan_trains_only_the_runs_named() {
    let runs = "[[runs]]\nname = \"a\"\nalgo = \"vdn\"\nscenarios = [\"3m_vlm\"]\nset = SMALL\n\
                [[runs]]\nname = \"c\"\nalgo = \"vdn\"\nscenarios = [\"3m_vlm\"]\nset = SMALL\n";
    let (dir, plan) = small_plan("plan-only", 200, runs);
    let p = plan.to_str().expect("utf-8");
    let out = train(&["--plan", p, "--only", "3m_vlm/nope-s1"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--only 3m_vlm/nope-s1") && err.contains("3m_vlm/a-s1, 3m_vlm/c-s1"), "{err}");
    let out = train(&["--plan", p, "--only", "3m_vlm/c-s1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 runs"), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(dir.join("runs/3m_vlm/c-s1/done.json").is_file());
    assert!(!dir.join("runs/3m_vlm/a-s1").exists(), "a run not named was trained");
    let out = train(&["--plan", p]);
    assert!(out.status.success() && dir.join("runs/3m_vlm/a-s1/done.json").is_file(), "{}", String::from_utf8_lossy(&out.stderr));
    let shipped = dir.join("shipped");
    let to = shipped.to_str().expect("utf-8");
    let out = train(&["--plan", p, "--ship", to, "--only", "3m_vlm/c-s1", "--unfinished", "3m_vlm/a-s1"]);
    assert!(!out.status.success() && !shipped.exists(), "--unfinished outside --only");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--unfinished 3m_vlm/a-s1: not one of the runs --only names (3m_vlm/c-s1)"), "{err}");
    let out = train(&["--plan", p, "--ship", to, "--only", "3m_vlm/c-s1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 runs shipped"), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(shipped.join("3m_vlm/c/config.json").is_file() && !shipped.join("3m_vlm/a").exists(), "only c is shipped");
    let _ = std::fs::remove_dir_all(&dir);
}
