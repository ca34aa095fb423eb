//! The live view, watched by a client that is not ours: Foxglove's own WebSocket protocol
//! client (the npm package `@foxglove/ws-protocol`, under Node) connects to a live
//! `avacraft episode --foxglove`, subscribes to every channel it advertises, and decodes a
//! screen image and a SceneUpdate with the protobuf schemas the server sent.

use crate::common::exe;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};

/// tests/node, where `.ci/run` installs the client (`npm ci --prefix tests/node`).
fn node_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/node");
    assert!(
        dir.join("node_modules/@foxglove/ws-protocol").is_dir(),
        "Foxglove's client is not installed: run `npm ci --prefix tests/node` (Node and npm are needed; .ci/run does it)"
    );
    dir
}

/// Runs avacraft with `args` (which ask for `--foxglove 127.0.0.1:0`), finds the URL it
/// serves on, and points Foxglove's own client at it (`log_prefix`: also wait for a log line
/// so named). The client's JSON, and the run's output and log.
fn watched_by_foxglove(args: &[&str], log_prefix: Option<&str>) -> (serde_json::Value, std::process::Output, String) {
    let node = node_dir();
    let mut run = Command::new(exe()).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("avacraft starts");
    let stderr = run.stderr.take().expect("stderr");
    let mut lines = BufReader::new(stderr).lines();
    let url = loop {
        let line = lines.next().expect("the run says where it serves").expect("a line");
        if let Some(at) = line.find("ws://") {
            break line[at..].split_whitespace().next().expect("a URL").to_owned();
        }
    };
    assert!(url.starts_with("ws://127.0.0.1:"), "loopback: {url}");
    let rest = std::thread::spawn(move || lines.map_while(Result::ok).collect::<Vec<_>>());
    let client = Command::new("node")
        .arg(node.join("foxglove_client.js"))
        .arg(&url)
        .args(log_prefix)
        .current_dir(&node)
        .output()
        .expect("node runs (Node.js is needed for this test: apt-get install nodejs npm)");
    let out = run.wait_with_output().expect("the run ends");
    let log = rest.join().unwrap_or_default().join("\n");
    assert!(client.status.success(), "the client failed: {}\nthe run's log: {log}", String::from_utf8_lossy(&client.stderr));
    assert!(out.status.success(), "the run failed: {log}");
    let seen: serde_json::Value = serde_json::from_slice(&client.stdout).expect("the client's JSON");
    (seen, out, log)
}

#[test]
fn foxglove_s_own_client_watches_a_live_episode() {
    let (seen, out, log) = watched_by_foxglove(
        &[
            "episode",
            "--scenario",
            "3m_vlm",
            "--agent",
            "focus-fire",
            "--episodes",
            "1",
            "--seed",
            "4",
            "--json",
            "--foxglove",
            "127.0.0.1:0",
            "--foxglove-wait",
            "60",
            "--foxglove-speed",
            "4",
        ],
        None,
    );
    assert_eq!(seen["serverInfo"], "avacraft episode");
    let topics: Vec<&str> = seen["channels"].as_array().expect("channels").iter().filter_map(|t| t.as_str()).collect();
    for t in ["screen_image", "minimap_image", "scene_update", "screen_annotations", "log_lines", "episode_status"] {
        assert!(topics.contains(&format!("/avacraft/live/{t}").as_str()), "{t} not advertised: {topics:?}");
    }
    let img = &seen["image"];
    assert_eq!(img["schema"], "foxglove.RawImage");
    assert_eq!((img["width"].as_u64(), img["height"].as_u64(), img["encoding"].as_str()), (Some(640), Some(480), Some("rgb8")));
    assert_eq!(img["bytes"].as_u64(), Some(640 * 480 * 3));
    let scene = &seen["scene"];
    assert_eq!(scene["schema"], "foxglove.SceneUpdate");
    // 3m_vlm: three marines a side, all alive near the start.
    assert!(scene["entities"].as_u64().is_some_and(|n| (1..=6).contains(&n)), "{scene}");
    assert_eq!(scene["frame"], "map");
    assert!(scene["label"].as_str().is_some_and(|l| l.contains("Marine")), "{scene}");
    assert_eq!(seen["status"]["scenario"], "3m_vlm");
    assert_eq!(seen["status"]["seed"], 4);
    // The episode's own result is unchanged by being watched.
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("episode JSON");
    let unwatched = Command::new(exe())
        .args(["episode", "--scenario", "3m_vlm", "--agent", "focus-fire", "--episodes", "1", "--seed", "4", "--json"])
        .output()
        .expect("runs");
    let plain: serde_json::Value = serde_json::from_slice(&unwatched.stdout).expect("episode JSON");
    assert_eq!(report["episodes"][0]["trajectory_hash"], plain["episodes"][0]["trajectory_hash"]);
    assert!(log.contains("foxglove: 1 viewer(s)"), "{log}");
}

/// A launch whose AVA agents are node processes: the simulator node serving the view puts
/// their model calls (off the nodes' `model_calls` topics) into the live log, where
/// Foxglove's client reads one.
#[test]
fn a_launch_s_live_log_shows_its_ava_nodes_model_calls() {
    let body = format!(
        "router: tcp/127.0.0.1:{}\nscenario: 3m_vlm\nepisodes: 1\nseed: 4\nava:\n  model: {{kind: synthetic}}\n  record: {}\n  config: {{image_max: 256}}\nagents:\n  - {{id: front, units: [1, 2, 3], policy: ava}}\n",
        crate::common::free_port(),
        crate::common::tmp("fox-ava-calls").display()
    );
    let file = crate::common::write_launch("fox-ava.yaml", &body);
    let (seen, _, log) = watched_by_foxglove(
        &["launch", "--json", file.to_str().expect("utf-8"), "--foxglove", "127.0.0.1:0", "--foxglove-wait", "60", "--foxglove-speed", "0"],
        Some("ava/"),
    );
    assert_eq!(seen["serverInfo"], "avacraft launch");
    let line = &seen["log"];
    assert_eq!(line["schema"], "foxglove.Log");
    // The node's first call: its planner's (the stages are named as in-process runs name them).
    let stage = line["name"].as_str().and_then(|n| n.strip_prefix("ava/front/"));
    assert!(stage.is_some_and(|s| ["Planner", "Roles", "Priority", "Decision"].contains(&s)), "{line}\n{log}");
    assert!(line["message"].as_str().is_some_and(|m| m.starts_with("step ") && m.len() > "step 0: ".len()), "{line}");
}

#[test]
fn foxglove_flags_are_checked() {
    let run =
        |args: &[&str]| Command::new(exe()).args(["episode", "--scenario", "3m_vlm", "--episodes", "1"]).args(args).output().expect("runs");
    let bad = run(&["--foxglove", "localhost"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--foxglove"), "{}", String::from_utf8_lossy(&bad.stderr));
    let bad = run(&["--foxglove", "127.0.0.1:0", "--foxglove-speed=-1"]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--foxglove-speed -1"), "{}", String::from_utf8_lossy(&bad.stderr));
    let bad = run(&["--foxglove-speed", "2"]);
    assert!(!bad.status.success(), "--foxglove-speed needs --foxglove");
}

/// `launch` with `record:` and `--foxglove`, then `replay --foxglove` of its recording: a
/// WebSocket client (tungstenite, speaking the protocol by hand) subscribes to the status
/// channel of each and counts one status per step of the episode.
#[test]
fn launch_and_replay_serve_the_live_view() {
    use tungstenite::Message;
    use tungstenite::client::IntoClientRequest;
    let mcap = crate::common::tmp("fox.mcap");
    let body = format!(
        "router: tcp/127.0.0.1:{}\nscenario: 3m_vlm\nclock: lockstep\nepisodes: 1\nseed: 9\nrecord: {}\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
        crate::common::free_port(),
        mcap.display()
    );
    let file = crate::common::write_launch("fox.yaml", &body);
    // Watches a run started with `--foxglove 127.0.0.1:0 --foxglove-wait 60`: the statuses'
    // steps until the run closes the connection.
    let watch = |args: &[&str]| -> (Vec<u64>, std::process::Output) {
        let mut run = Command::new(exe())
            .args(args)
            .args(["--foxglove", "127.0.0.1:0", "--foxglove-wait", "60", "--foxglove-speed", "0"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("starts");
        let mut lines = BufReader::new(run.stderr.take().expect("stderr")).lines();
        let url = loop {
            let line = lines.next().expect("it says where it serves").expect("a line");
            if let Some(at) = line.find("ws://") {
                break line[at..].split_whitespace().next().expect("a URL").to_owned();
            }
        };
        let rest = std::thread::spawn(move || lines.map_while(Result::ok).collect::<Vec<_>>());
        let mut req = url.into_client_request().expect("a request");
        req.headers_mut().insert("sec-websocket-protocol", avacraft_live::SUBPROTOCOL.parse().expect("a header"));
        let (mut ws, _) = tungstenite::connect(req).expect("connects");
        let (_info, _adv) = (ws.read().expect("serverInfo"), ws.read().expect("advertise"));
        let id = avacraft_live::LiveChannel::Status.id();
        ws.send(Message::text(format!(r#"{{"op":"subscribe","subscriptions":[{{"id":3,"channelId":{id}}}]}}"#))).expect("subscribe");
        let mut steps = Vec::new();
        while let Ok(m) = ws.read() {
            if let Message::Binary(b) = m {
                let st: serde_json::Value = serde_json::from_slice(&b[13..]).expect("status JSON");
                steps.push(st["step"].as_u64().expect("a step"));
            }
        }
        let out = run.wait_with_output().expect("ends");
        assert!(out.status.success(), "{args:?}: {}", rest.join().unwrap_or_default().join("\n"));
        (steps, out)
    };
    let (live, out) = watch(&["launch", "--json", file.to_str().expect("utf-8")]);
    let eps: serde_json::Value = serde_json::from_slice(&out.stdout).expect("launch JSON");
    let n = eps[0]["steps"].as_u64().expect("steps");
    // The simulator node shows each step before its actions, and the end.
    assert_eq!(live.first(), Some(&0));
    assert_eq!(live.last(), Some(&n), "{live:?}");
    assert!(mcap.is_file());
    let (replayed, _) = watch(&["replay", mcap.to_str().expect("utf-8")]);
    assert_eq!(replayed, (1..=n).collect::<Vec<_>>(), "one status per re-simulated step");
}
