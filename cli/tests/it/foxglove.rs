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

#[test]
fn foxglove_s_own_client_watches_a_live_episode() {
    let node = node_dir();
    let mut episode = Command::new(exe())
        .args(["episode", "--scenario", "3m", "--agent", "focus-fire", "--episodes", "1", "--seed", "4", "--json"])
        .args(["--foxglove", "127.0.0.1:0", "--foxglove-wait", "60", "--foxglove-speed", "4"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("avacraft episode starts");
    let stderr = episode.stderr.take().expect("stderr");
    let mut lines = BufReader::new(stderr).lines();
    let url = loop {
        let line = lines.next().expect("the episode says where it serves").expect("a line");
        if let Some(at) = line.find("ws://") {
            break line[at..].split_whitespace().next().expect("a URL").to_owned();
        }
    };
    assert!(url.starts_with("ws://127.0.0.1:"), "loopback: {url}");
    let rest = std::thread::spawn(move || lines.map_while(Result::ok).collect::<Vec<_>>());
    let client = Command::new("node")
        .arg(node.join("foxglove_client.js"))
        .arg(&url)
        .current_dir(&node)
        .output()
        .expect("node runs (Node.js is needed for this test: apt-get install nodejs npm)");
    assert!(client.status.success(), "the client failed: {}", String::from_utf8_lossy(&client.stderr));
    let out = episode.wait_with_output().expect("the episode ends");
    let log = rest.join().unwrap_or_default().join("\n");
    assert!(out.status.success(), "episode failed: {log}");
    let seen: serde_json::Value = serde_json::from_slice(&client.stdout).expect("the client's JSON");
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
    // 3m: three marines a side, all alive near the start.
    assert!(scene["entities"].as_u64().is_some_and(|n| (1..=6).contains(&n)), "{scene}");
    assert_eq!(scene["frame"], "map");
    assert!(scene["label"].as_str().is_some_and(|l| l.contains("Marine")), "{scene}");
    assert_eq!(seen["status"]["scenario"], "3m");
    assert_eq!(seen["status"]["seed"], 4);
    // The episode's own result is unchanged by being watched.
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("episode JSON");
    let unwatched = Command::new(exe())
        .args(["episode", "--scenario", "3m", "--agent", "focus-fire", "--episodes", "1", "--seed", "4", "--json"])
        .output()
        .expect("runs");
    let plain: serde_json::Value = serde_json::from_slice(&unwatched.stdout).expect("episode JSON");
    assert_eq!(report["episodes"][0]["trajectory_hash"], plain["episodes"][0]["trajectory_hash"]);
    assert!(log.contains("foxglove: 1 viewer(s)"), "{log}");
}

#[test]
fn foxglove_flags_are_checked() {
    let run =
        |args: &[&str]| Command::new(exe()).args(["episode", "--scenario", "3m", "--episodes", "1"]).args(args).output().expect("runs");
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
        "router: tcp/127.0.0.1:{}\nscenario: 3m\nclock: lockstep\nepisodes: 1\nseed: 9\nrecord: {}\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
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
