//! `avacraft launch` and the nodes it starts, checked from outside: results, counters for
//! bad input, rmw_zenoh keys, liveliness tokens and attachments seen by a plain Zenoh
//! client, and the MCAP recording read back by an independent ROS 2 MCAP reader.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use zenoh::Wait;

use crate::common::{Child, exe, free_port, launch_json, marl_checkpoint, shm_frames, tmp, write_launch};

/// Runs `avacraft launch --json` on `body` with its own router on a free port.
fn launch_on_free_port(name: &str, body: &str) -> serde_json::Value {
    let file = write_launch(name, &format!("router: tcp/127.0.0.1:{}\n{body}", free_port()));
    launch_json(&file)
}

#[test]
fn launch_3m_with_three_agent_processes_finishes_episodes_and_records_them() {
    let _frames = shm_frames();
    let port = free_port();
    let mcap = tmp("3m_vlm.mcap");
    let file = write_launch(
        "3m_vlm.yaml",
        &format!(
            "scenario: 3m_vlm\nepisodes: 2\nseed: 5\nrouter: tcp/127.0.0.1:{port}\nrecord: {}\nframes:\n  kinds: [screen, minimap]\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
            mcap.display()
        ),
    );
    // A local reader of the zero-copy frame path (iceoryx2), next to the Zenoh topic.
    let shm = std::thread::spawn(|| {
        let mut s = avacraft_nodes::frames::FrameSubscriber::open("avacraft/team_1/screen", 8).expect("iceoryx2 subscriber");
        s.recv_timeout(Duration::from_secs(60))
            .expect("receive")
            .map(|f| (f.header().width, f.header().height, f.pixels().iter().any(|&b| b > 100)))
    });
    let v = launch_json(&file);
    let eps = v.as_array().expect("episodes");
    assert_eq!(eps.len(), 2);
    assert_eq!(shm.join().expect("reader"), Some((160, 120, true)), "a screen frame through shared memory");
    for e in eps {
        assert!(["win", "loss", "draw"].contains(&e["result"].as_str().unwrap_or("")), "{e}");
        assert!(e["steps"].as_u64().unwrap_or(0) > 5, "{e}");
        assert_eq!(e["missing_actions"][0], 0, "lockstep: every action arrived: {e}");
        assert_eq!(e["foreign_actions"][0], 0);
        assert_eq!(e["malformed_messages"], 0);
        // The round trip's legs: each measured, the answer's two legs no longer than a
        // whole step's worst round trip (the wall clock is shared on one host).
        let legs = &e["round_trip_parts_us"];
        let leg = |k: &str| legs[k].as_u64().unwrap_or_else(|| panic!("leg {k} missing: {e}"));
        let worst = e["round_trip_us"][1].as_u64().expect("round trip");
        assert!(leg("to_agents") > 0 && leg("back") > 0, "{e}");
        assert!(leg("publish") <= worst && leg("to_agents") + leg("back") <= 2 * worst, "{e}");
    }
    // The same seed in-process gives the same trajectory only with the same actions; here
    // we check the recording instead: readable, ros2 profile, every topic present.
    let bytes = std::fs::read(&mcap).expect("mcap written");
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("summary present");
    let topics: Vec<&str> = summary.channels.values().map(|c| c.topic.as_str()).collect();
    for t in [
        "/avacraft/team_1/unit_1/obs",
        "/avacraft/team_1/obs",
        "/avacraft/status",
        "/avacraft/agents/unit_1/actions",
        "/avacraft/roles",
        "/avacraft/applied",
        "/avacraft/session",
    ] {
        assert!(topics.contains(&t), "{t} missing from {topics:?}");
    }
    // Every channel, the live view's too, is a ROS 2 topic.
    for c in summary.channels.values() {
        let s = c.schema.as_ref().expect("every channel has a schema");
        assert_eq!((s.encoding.as_str(), c.message_encoding.as_str()), ("ros2msg", "cdr"), "{}", c.topic);
        assert!(c.metadata.contains_key("offered_qos_profiles"), "{}", c.topic);
    }
    crate::replay::check_live_channels(&bytes);
    // Frames: sensor_msgs/Image, 160x120 rgb8 screens with pixels.
    let screen = summary.channels.values().find(|c| c.topic == "/avacraft/team_1/screen").expect("screen topic recorded");
    assert_eq!(screen.schema.as_ref().map(|s| s.name.as_str()), Some("sensor_msgs/msg/Image"));
    let img = mcap::MessageStream::new(&bytes)
        .expect("stream")
        .filter_map(Result::ok)
        .find(|m| m.channel.topic == "/avacraft/team_1/screen")
        .map(|m| avacraft_msgs::decode::<avacraft_msgs::Image>(&m.data).expect("an Image"))
        .expect("a screen frame");
    assert_eq!((img.width, img.height, img.encoding.as_str(), img.data.len()), (160, 120, "rgb8", 160 * 120 * 3));
    assert!(img.data.iter().any(|&b| b > 100), "not a blank frame");
    let stats = summary.stats.expect("statistics");
    assert!(stats.message_count > 100, "{}", stats.message_count);
    // Decoded by the ROS 2 MCAP reader of the mcap project (Python, installed by .ci/run).
    let py = "import sys\nfrom mcap_ros2.reader import read_ros2_messages\nn=0\nlast=None\nfor m in read_ros2_messages(sys.argv[1], topics=['/avacraft/status']):\n    n+=1; last=m.ros_msg\nprint(n, last.scenario, last.result)\n";
    let out = Command::new("python3").args(["-c", py]).arg(&mcap).output().expect("python3");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the independent reader failed (is mcap-ros2-support installed?): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let parts: Vec<&str> = text.split_whitespace().collect();
    assert!(parts.first().and_then(|n| n.parse::<u32>().ok()).is_some_and(|n| n > 10), "{text}");
    assert_eq!(parts.get(1), Some(&"3m_vlm"), "{text}");
    // Opened whole by rosbags' AnyReader with the ROS 2 Jazzy type store (its own CDR reader
    // and type system, installed by .ci/run): every message of every topic decodes.
    let py = "import sys\nfrom pathlib import Path\nfrom rosbags.highlevel import AnyReader\nfrom rosbags.typesys import Stores, get_typestore\n\
              n = {}\nwith AnyReader([Path(sys.argv[1])], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as r:\n\
              \x20   for c, _, raw in r.messages(connections=r.connections):\n\
              \x20       r.deserialize(raw, c.msgtype); n[c.topic] = n.get(c.topic, 0) + 1\n\
              print(len(n), sum(n.values()), n.get('/avacraft/live/scene_update', 0))\n";
    let out = Command::new("python3").args(["-c", py]).arg(&mcap).output().expect("python3");
    assert!(
        out.status.success(),
        "rosbags could not read the recording (is rosbags installed? .ci/run installs it): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let n: Vec<u64> = text.split_whitespace().filter_map(|x| x.parse().ok()).collect();
    assert_eq!(n.first().copied(), Some(summary.channels.len() as u64), "every channel read: {text}");
    assert_eq!(n.get(1).copied(), Some(stats.message_count), "every message decoded: {text}");
    assert!(n.get(2).is_some_and(|&k| k > 10), "the scene too: {text}");
    // Replay from the recording alone, and tampered copies of it.
    crate::replay::check_recording(&mcap);
}

/// `record_by: simulator`: the simulator writes what it sends and receives, with no recorder
/// node; the file has the same topics (the agents' actions among them), every message reads
/// with rosbags, and the session replays from it alone.
#[test]
fn the_simulator_records_its_own_traffic() {
    let mcap = tmp("3m_by_sim.mcap");
    let _ = std::fs::remove_file(&mcap);
    let file = write_launch(
        "3m_by_sim.yaml",
        &format!(
            "scenario: 3m_vlm\nepisodes: 2\nseed: 5\nrouter: tcp/127.0.0.1:{}\nrecord: {}\nrecord_by: simulator\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
            free_port(),
            mcap.display()
        ),
    );
    let v = launch_json(&file);
    let steps: u64 = v.as_array().expect("episodes").iter().map(|e| e["steps"].as_u64().expect("steps")).sum();
    let bytes = std::fs::read(&mcap).expect("mcap written");
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("summary present");
    let topics: Vec<&str> = summary.channels.values().map(|c| c.topic.as_str()).collect();
    for t in
        ["/avacraft/team_1/unit_1/obs", "/avacraft/status", "/avacraft/agents/unit_2/actions", "/avacraft/applied", "/avacraft/session"]
    {
        assert!(topics.contains(&t), "{t} missing from {topics:?}");
    }
    let actions = mcap::MessageStream::new(&bytes)
        .expect("stream")
        .filter_map(Result::ok)
        .filter(|m| m.channel.topic.starts_with("/avacraft/agents/") && m.channel.topic.ends_with("/actions"))
        .count() as u64;
    // Every step's batches, as the simulator received them (a unit's node stops once it is dead).
    assert!(actions >= steps && actions <= 3 * (steps + 2), "{actions} action batches for {steps} steps");
    let py = "import sys\nfrom pathlib import Path\nfrom rosbags.highlevel import AnyReader\nfrom rosbags.typesys import Stores, get_typestore\n\
              n = 0\nwith AnyReader([Path(sys.argv[1])], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as r:\n\
              \x20   for c, _, raw in r.messages(connections=r.connections):\n\
              \x20       r.deserialize(raw, c.msgtype); n += 1\n\
              print(n)\n";
    let out = Command::new("python3").args(["-c", py]).arg(&mcap).output().expect("python3");
    assert!(out.status.success(), "rosbags: {}", String::from_utf8_lossy(&out.stderr));
    let n: u64 = String::from_utf8_lossy(&out.stdout).trim().parse().expect("a count");
    assert_eq!(Some(n), summary.stats.map(|s| s.message_count), "every message decoded");
    crate::replay::check_recording(&mcap);
}

fn start(args: &[&str]) -> Child {
    Child(Command::new(exe()).args(args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().expect("spawn a node"))
}

/// The simulator node of `file`, writing its summaries to `result`.
fn start_sim(file: &Path, result: &Path, endpoint: &str) -> Child {
    start(&["sim-node", "--launch", file.to_str().expect("utf8"), "--result-file", result.to_str().expect("utf8"), "--connect", endpoint])
}

type Bus = zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>;

/// A router on a free port hosted by the test, a subscription to everything under
/// `/avacraft` on it, its endpoint, and a launch file for `body` (the router line added).
fn deployment(name: &str, body: &str) -> (zenoh::Session, Bus, String, PathBuf) {
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let session = router(port);
    let bus = session.declare_subscriber("0/avacraft/**").with(zenoh::handlers::FifoChannel::new(100_000)).wait().expect("subscriber");
    let file = write_launch(name, &format!("router: {endpoint}\n{body}"));
    (session, bus, endpoint, file)
}

fn router(port: u16) -> zenoh::Session {
    let mut c = zenoh::Config::default();
    for (k, v) in [
        ("mode", "\"router\"".to_owned()),
        ("listen/endpoints", format!("[\"tcp/127.0.0.1:{port}\"]")),
        ("scouting/multicast/enabled", "false".into()),
    ] {
        c.insert_json5(k, &v).expect("config");
    }
    zenoh::open(c).wait().expect("router")
}

#[test]
fn bad_input_is_counted_and_ros_conventions_hold_for_a_plain_zenoh_client() {
    // The test process is the router and the independent client.
    let (session, samples, endpoint, file) = deployment(
        "2m.yaml",
        "scenario: 2m_vs_1z_vlm\nepisodes: 300\nseed: 3\ndeadline_ms: 300\nagents:\n  - per_unit: true\n    team: 1\n    policy: hold\n",
    );
    let _a1 =
        start(&["agent-node", "--id", "unit_1", "--units", "1", "--policy", "hold", "--scenario", "2m_vs_1z_vlm", "--connect", &endpoint]);
    let _a2 =
        start(&["agent-node", "--id", "unit_2", "--units", "2", "--policy", "hold", "--scenario", "2m_vs_1z_vlm", "--connect", &endpoint]);
    let result = tmp("2m.json");
    let sim = start_sim(&file, &result, &endpoint);
    // Wait for the first observation, then inject: garbage on an agent's action topic and an
    // action for unit 1 from a node that does not own it.
    let t0 = Instant::now();
    let mut first_obs = None;
    while first_obs.is_none() && t0.elapsed() < Duration::from_secs(60) {
        if let Ok(Some(s)) = samples.recv_timeout(Duration::from_millis(200))
            && s.key_expr().as_str().starts_with("0/avacraft/team_1/unit_1/obs/")
        {
            first_obs = Some(s);
        }
    }
    let s = first_obs.expect("an observation within 60 s");
    let key = s.key_expr().as_str().to_owned();
    assert!(key.starts_with("0/avacraft/team_1/unit_1/obs/avacraft_msgs::msg::dds_::UnitObservation_/RIHS01_"), "{key}");
    assert_eq!(key.rsplit('/').next().map(str::len), Some(7 + 64));
    let att = s.attachment().expect("every sample has the attachment").to_bytes();
    assert_eq!((att.len(), att[16]), (33, 0x10));
    // Liveliness: the sim and both agent nodes, and their endpoints, as rmw_zenoh names them.
    let replies = session.liveliness().get("@ros2_lv/0/**").timeout(Duration::from_secs(1)).wait().expect("liveliness");
    let mut tokens = Vec::new();
    while let Ok(r) = replies.recv() {
        if let Ok(s) = r.result() {
            tokens.push(s.key_expr().as_str().to_owned());
        }
    }
    for node in ["%avacraft/sim", "%avacraft/agent_unit_1", "%avacraft/agent_unit_2"] {
        assert!(tokens.iter().any(|t| t.contains("/NN/%/") && t.ends_with(node)), "node {node} not in {tokens:#?}");
    }
    assert!(
        tokens
            .iter()
            .any(|t| t.contains("/MP/%/%avacraft/sim/%avacraft%team_1%unit_1%obs/avacraft_msgs::msg::dds_::UnitObservation_/RIHS01_"))
    );
    assert!(tokens.iter().any(|t| t.contains("/MS/%/%avacraft/agent_unit_1/%avacraft%team_1%unit_1%obs/")));
    let hash = <avacraft_msgs::ActionBatch as avacraft_msgs::RosMessage>::type_hash();
    let dds = "avacraft_msgs::msg::dds_::ActionBatch_";
    let attach = avacraft_nodes::ros::attachment(1, 0, &[0; 16]).to_vec();
    let garbage = session.declare_publisher(format!("0/avacraft/agents/unit_1/actions/{dds}/{hash}")).wait().expect("publisher");
    let intruder = session.declare_publisher(format!("0/avacraft/agents/intruder/actions/{dds}/{hash}")).wait().expect("publisher");
    let t1 = Instant::now();
    while t1.elapsed() < Duration::from_secs(2) {
        garbage.put(vec![0u8, 1, 0, 0, 0xff, 0xff, 0xff, 0xff, 1]).attachment(attach.clone()).wait().expect("put");
        let batch = avacraft_msgs::ActionBatch {
            episode: 0,
            step: 0,
            agent_id: "intruder".into(),
            actions: vec![avacraft_msgs::UnitAction { unit_tag: 1, kind: 1, ..Default::default() }],
            ..Default::default()
        };
        for step in 0..40 {
            let b = avacraft_msgs::ActionBatch { step, ..batch.clone() };
            intruder.put(avacraft_msgs::encode(&b)).attachment(attach.clone()).wait().expect("put");
        }
        while let Ok(Some(_)) = samples.try_recv() {}
        std::thread::sleep(Duration::from_millis(50));
    }
    // Stop listening: an undrained subscriber would eventually hold up reliable publishers.
    drop(samples);
    let mut sim = sim;
    let t2 = Instant::now();
    while sim.0.try_wait().ok().flatten().is_none() && t2.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(100));
    }
    let text = std::fs::read_to_string(&result).expect("the sim node finished and wrote its results");
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    let eps = v.as_array().expect("episodes");
    assert_eq!(eps.len(), 300, "every episode finished despite the bad input");
    let total = |f: &dyn Fn(&serde_json::Value) -> u64| eps.iter().map(f).sum::<u64>();
    assert!(total(&|e| e["malformed_messages"].as_u64().unwrap_or(0)) > 0, "{v}");
    assert!(total(&|e| e["foreign_actions"][0].as_u64().unwrap_or(0)) > 0, "{v}");
}

fn wait_for_obs(samples: &Bus) {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(60) {
        if let Ok(Some(s)) = samples.recv_timeout(Duration::from_millis(200))
            && s.key_expr().as_str().starts_with("0/avacraft/team_1/unit_")
        {
            return;
        }
    }
    panic!("no observation within 60 s");
}

fn wait_exit(c: &mut Child, secs: u64) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(secs) {
        if c.0.try_wait().ok().flatten().is_some() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

#[test]
fn a_killed_agent_gets_no_ops_and_a_restarted_one_rejoins() {
    let (_session, samples, endpoint, file) = deployment(
        "kill.yaml",
        "scenario: 3m_vlm\nepisodes: 4\nseed: 1\ndeadline_ms: 1000\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
    );
    let agent = |id: &str, unit: &str| start(&["agent-node", "--id", id, "--units", unit, "--scenario", "3m_vlm", "--connect", &endpoint]);
    let (mut a1, _a2, _a3) = (agent("unit_1", "1"), agent("unit_2", "2"), agent("unit_3", "3"));
    let result = tmp("kill.json");
    let mut sim = start_sim(&file, &result, &endpoint);
    wait_for_obs(&samples);
    drop(samples);
    let _ = a1.0.kill();
    let _ = a1.0.wait();
    std::thread::sleep(Duration::from_millis(1200));
    let _a1 = agent("unit_1", "1");
    assert!(wait_exit(&mut sim, 120), "the episodes went on and finished");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&result).expect("results")).expect("json");
    let eps = v.as_array().expect("episodes");
    assert_eq!(eps.len(), 4);
    let missing: Vec<u64> = eps.iter().map(|e| e["missing_actions"][0].as_u64().unwrap_or(0)).collect();
    assert!(missing.iter().sum::<u64>() > 0, "the dead agent's unit got no-ops: {missing:?}");
    assert_eq!(missing.last(), Some(&0), "the restarted agent answered every step of the last episode: {missing:?}");
}

#[test]
fn the_recording_survives_a_killed_simulator() {
    let (_session, samples, endpoint, file) = deployment(
        "crash.yaml",
        "scenario: 3m_vlm\nepisodes: 1000\nseed: 1\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
    );
    let mcap = tmp("crash.mcap");
    let mut rec = start(&["record", "--out", mcap.to_str().expect("utf8"), "--connect", &endpoint]);
    let _agents: Vec<Child> = (1..=3)
        .map(|u| {
            start(&["agent-node", "--id", &format!("unit_{u}"), "--units", &u.to_string(), "--scenario", "3m_vlm", "--connect", &endpoint])
        })
        .collect();
    let mut sim = start(&["sim-node", "--launch", file.to_str().expect("utf8"), "--connect", &endpoint]);
    // Let the recorder see a good part of the run first (its subscription is up before
    // step 0: the simulator waits for it... only under `launch`; here, count on the bus).
    let t0 = Instant::now();
    let mut statuses = 0;
    while statuses < 60 && t0.elapsed() < Duration::from_secs(60) {
        if let Ok(Some(s)) = samples.recv_timeout(Duration::from_millis(200))
            && s.key_expr().as_str().starts_with("0/avacraft/status/")
        {
            statuses += 1;
        }
    }
    assert!(statuses >= 60, "the simulator ran");
    drop(samples);
    let _ = sim.0.kill();
    let _ = nix_term(&rec);
    assert!(wait_exit(&mut rec, 30), "the recorder stops on SIGTERM");
    let bytes = std::fs::read(&mcap).expect("mcap");
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("a finished file");
    assert!(summary.stats.is_some_and(|s| s.message_count > 50));
    let n = mcap::MessageStream::new(&bytes).expect("stream").filter(|m| m.is_ok()).count();
    assert!(n > 50, "{n} messages read back");
}

fn nix_term(c: &Child) -> Result<(), String> {
    let pid = nix::unistd::Pid::from_raw(c.0.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).map_err(|e| e.to_string())
}

#[test]
fn the_real_time_clock_paces_22_4_loops_per_second() {
    let v = launch_on_free_port(
        "rt.yaml",
        "scenario: 3m_vlm\nclock: realtime\nepisodes: 1\nseed: 2\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n",
    );
    let e = &v[0];
    let steps = e["steps"].as_f64().unwrap_or(0.0);
    let wall = e["wall_seconds"].as_f64().unwrap_or(0.0);
    assert!(steps > 5.0, "{e}");
    // A step is 8 loops: the episode cannot take less wall time than its game time.
    assert!(wall >= steps * 8.0 / 22.4 * 0.95, "{steps} steps in {wall} s is faster than real time");
    assert!(["win", "loss", "draw"].contains(&e["result"].as_str().unwrap_or("")), "{e}");
}

#[test]
fn pvp_launch_has_agent_nodes_on_both_teams() {
    let v = launch_on_free_port(
        "pvp.yaml",
        "scenario: MMM_vs_MMM\nepisodes: 1\nseed: 4\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n  - id: red\n    units: [13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24]\n    policy: attack-move\n",
    );
    let e = &v[0];
    assert!(["win", "loss"].contains(&e["result"].as_str().unwrap_or("")), "the armies met and one won: {e}");
    assert_eq!((e["missing_actions"][0].as_u64(), e["missing_actions"][1].as_u64()), (Some(0), Some(0)), "{e}");
}

/// `avacraft episode --launch FILE --json`: the launch file's games played in-process.
fn in_process(file: &Path) -> serde_json::Value {
    let out = Command::new(exe())
        .args(["episode", "--json", "--launch"])
        .arg(file)
        .stderr(Stdio::inherit())
        .output()
        .expect("run avacraft episode");
    assert!(out.status.success(), "episode --launch failed: {}", String::from_utf8_lossy(&out.stdout));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stdout)))
}

/// The deployment (one process per unit, or per role group, in lockstep) and the same plan
/// in-process play the same games: equal trajectory hashes, episode by episode.
#[test]
fn deployed_and_in_process_runs_of_a_plan_have_equal_trajectory_hashes() {
    let roles =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../launch/8m3mr1mv1st_roles.yaml")).expect("roles launch file");
    for (name, body) in [
        (
            "per_unit.yaml",
            "scenario: 3m_vlm\nepisodes: 3\nseed: 1\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n".to_owned(),
        ),
        ("roles.yaml", roles.lines().filter(|l| !l.starts_with("router:")).collect::<Vec<_>>().join("\n")),
        // Procedural: every process draws the episode's units from its seed.
        (
            "procedural.yaml",
            "scenario: protoss_5_vs_5\nepisodes: 3\nseed: 4\nagents:\n  - per_unit: true\n    team: 1\n    policy: focus-fire\n".to_owned(),
        ),
    ] {
        let file = write_launch(name, &format!("router: tcp/127.0.0.1:{}\n{body}\n", free_port()));
        let deployed = launch_json(&file);
        let local = in_process(&file);
        let deployed: Vec<(u64, String, String)> = deployed
            .as_array()
            .expect("episodes")
            .iter()
            .map(|e| (e["seed"].as_u64().unwrap_or(0), e["result"].to_string(), e["trajectory_hash"].to_string()))
            .collect();
        let local: Vec<(u64, String, String)> = local["episodes"]
            .as_array()
            .expect("episodes")
            .iter()
            .map(|e| (e["seed"].as_u64().unwrap_or(0), e["result"].to_string(), e["trajectory_hash"].to_string()))
            .collect();
        assert!(!deployed.is_empty());
        assert_eq!(deployed, local, "{name}: deployed vs in-process (seed, result, trajectory hash)");
    }
}

/// (seed, result, trajectory hash) of each episode of `launch --json` or `episode --json`.
fn outcomes(v: &serde_json::Value) -> Vec<(u64, String, String)> {
    v.as_array()
        .or_else(|| v["episodes"].as_array())
        .expect("episodes")
        .iter()
        .map(|e| (e["seed"].as_u64().unwrap_or(0), e["result"].to_string(), e["trajectory_hash"].to_string()))
        .collect()
}

/// A trained policy deployed as one agent node per Marine, each loading the checkpoint and
/// running the network on its own Marine's observation message, plays the games the same
/// plan plays in-process, episode by episode.
#[test]
fn deployed_and_in_process_marl_policies_have_equal_trajectory_hashes() {
    let ckpt = marl_checkpoint();
    let name = ckpt.file_name().and_then(|n| n.to_str()).expect("a directory name");
    // Relative to the launch file's directory (both are in the tests' temporary directory).
    let body =
        |policy: &str| format!("scenario: 3m_vlm\nepisodes: 3\nseed: 1\nagents:\n  - per_unit: true\n    team: 1\n    policy: {policy}\n");
    let file = write_launch("marl.yaml", &format!("router: tcp/127.0.0.1:{}\n{}", free_port(), body(&format!("marl:{name}"))));
    let deployed_raw = launch_json(&file);
    for e in deployed_raw.as_array().expect("episodes") {
        assert_eq!((e["missing_actions"][0].as_u64(), e["malformed_messages"].as_u64()), (Some(0), Some(0)), "{e}");
    }
    let deployed = outcomes(&deployed_raw);
    let local = outcomes(&in_process(&file));
    assert_eq!(deployed.len(), 3);
    assert_eq!(deployed, local, "deployed vs in-process (seed, result, trajectory hash)");
    // The network gave orders: units left idle play other games.
    let idle = outcomes(&in_process(&write_launch("idle.yaml", &body("noop"))));
    assert!(deployed.iter().zip(&idle).all(|(m, n)| m.2 != n.2), "{deployed:?} vs idle {idle:?}");
}

/// An image-mode checkpoint deployed as one agent node per Marine: the simulator draws team
/// 1's frames at the network's sizes every step and sends them reliably, and each node acts
/// once it holds its step's frames. It plays the games `episode --launch` plays in process,
/// and the games the evaluations' frames actor (`episode --agent`) plays: the same results
/// in the same number of steps.
#[test]
fn deployed_image_policies_read_the_simulators_frames_and_play_as_in_process() {
    let _frames = shm_frames();
    let body = "scenario: 3m_vlm\nepisodes: 2\nseed: 11\nagents:\n  - {per_unit: true, team: 1, policy: baseline:mappo-rgb}\n";
    // The three Marines' nodes share the team's encoder node (the default), or each runs
    // the encoder on the frames itself: the same games either way, and in process.
    let mcap = tmp("rgb_shared.mcap");
    let _ = std::fs::remove_file(&mcap);
    let file = write_launch("rgb.yaml", &format!("router: tcp/127.0.0.1:{}\nrecord: {}\n{body}", free_port(), mcap.display()));
    let own = write_launch("rgb_own.yaml", &format!("router: tcp/127.0.0.1:{}\nshare_encoder: false\n{body}", free_port()));
    let deployed_raw = launch_json(&file);
    for e in deployed_raw.as_array().expect("episodes") {
        assert_eq!((e["missing_actions"][0].as_u64(), e["malformed_messages"].as_u64()), (Some(0), Some(0)), "{e}");
    }
    let deployed = outcomes(&deployed_raw);
    assert_eq!(deployed.len(), 2);
    assert_eq!(deployed, outcomes(&in_process(&file)), "deployed vs in-process (seed, result, trajectory hash)");
    assert_eq!(deployed, outcomes(&launch_json(&own)), "a shared encoder vs one in each node");
    // The encoder node published one encoding a step, on the team's features topic.
    let bytes = std::fs::read(&mcap).expect("the recording");
    let mut encodings = Vec::new();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a message");
        if m.channel.topic == "/avacraft/team_1/features" {
            assert_eq!(m.channel.schema.as_ref().map(|s| s.name.as_str()), Some("avacraft_msgs/msg/TeamFeatures"));
            encodings.push(avacraft_msgs::decode::<avacraft_msgs::TeamFeatures>(&m.data).expect("a TeamFeatures"));
        }
    }
    let steps: u64 = deployed_raw.as_array().expect("episodes").iter().map(|e| e["steps"].as_u64().expect("steps") + 1).sum();
    assert!(!encodings.is_empty() && encodings.len() as u64 <= steps, "{} encodings for {steps} observed steps", encodings.len());
    assert!(encodings.iter().all(|f| f.team == 1 && !f.data.is_empty() && f.encoder.starts_with("rgb-")), "{:?}", encodings.first());
    let out = Command::new(exe())
        .args(["episode", "--json", "--scenario", "3m_vlm", "--agent", "baseline:mappo-rgb", "--seed", "11", "--episodes", "2"])
        .output()
        .expect("run avacraft episode");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let actor: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let games = |v: &serde_json::Value| -> Vec<(u64, String, u64)> {
        v.as_array()
            .or_else(|| v["episodes"].as_array())
            .expect("episodes")
            .iter()
            .map(|e| (e["seed"].as_u64().unwrap_or(0), e["result"].to_string(), e["steps"].as_u64().unwrap_or(0)))
            .collect()
    };
    assert_eq!(games(&deployed_raw), games(&actor), "deployed vs the frames actor (seed, result, steps)");
    assert!(games(&actor).iter().all(|g| g.1 == "\"win\""), "the shipped rgb MAPPO wins 3m_vlm: {actor}");
}

/// A checkpoint that cannot play is refused before any process starts, naming the field;
/// an agent node started by hand refuses it too.
#[test]
fn bad_marl_policies_are_refused_up_front() {
    let ckpt = marl_checkpoint();
    let run = |args: &[&str]| {
        let out = Command::new(exe()).args(args).stdin(Stdio::null()).output().expect("run avacraft");
        (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let on_2m = write_launch(
        "marl_2m.yaml",
        &format!("scenario: 2m_vs_1z_vlm\nagents:\n  - {{per_unit: true, team: 1, policy: marl:{}}}\n", ckpt.display()),
    );
    let missing = write_launch("marl_missing.yaml", "scenario: 3m_vlm\nagents:\n  - {per_unit: true, team: 1, policy: marl:no-such-dir}\n");
    for (file, says) in [(&on_2m, "trained on scenario `3m_vlm`, not `2m_vs_1z_vlm`"), (&missing, "does not exist")] {
        for cmd in ["launch", "episode"] {
            let f = file.to_str().expect("utf8");
            let args: Vec<&str> = if cmd == "launch" { vec!["launch", "--json", f] } else { vec!["episode", "--json", "--launch", f] };
            let (ok, err) = run(&args);
            assert!(!ok && err.contains("field `agents[0].policy`") && err.contains(says), "{cmd} {f}: {err}");
        }
    }
    let policy = format!("marl:{}", ckpt.display());
    let (ok, err) = run(&["agent-node", "--id", "a", "--units", "1", "--scenario", "2m_vs_1z_vlm", "--policy", &policy]);
    assert!(!ok && err.contains("--policy") && err.contains("trained on scenario `3m_vlm`, not `2m_vs_1z_vlm`"), "{err}");
    let (ok, err) = run(&["episode", "--scenario", "2m_vs_1z_vlm", "--agent", &policy, "--episodes", "1"]);
    assert!(!ok && err.contains("--agent") && err.contains("trained on scenario `3m_vlm`, not `2m_vs_1z_vlm`"), "{err}");
}

/// AVA as two role-group agent nodes (the instant stand-in model): the deployment plays the
/// game `episode --launch` plays in-process, every node records its own calls, and no
/// action is missing, foreign or refused.
#[test]
fn ava_role_groups_play_the_same_game_deployed_and_in_process() {
    let body = |calls: &Path| {
        format!(
            "scenario: 3m_vlm\nepisodes: 1\nseed: 3\nava:\n  model: {{kind: synthetic}}\n  record: {}\n  config: {{image_max: 256}}\nagents:\n  - {{id: front, units: [1, 2], policy: ava}}\n  - {{id: back, units: [3], policy: ava}}\n",
            calls.display()
        )
    };
    let (deployed_calls, local_calls) = (tmp("ava-deployed"), tmp("ava-local"));
    let v = launch_on_free_port("ava.yaml", &body(&deployed_calls));
    let e = &v[0];
    assert_eq!(e["missing_actions"][0], 0, "{e}");
    assert_eq!(e["foreign_actions"][0], 0, "{e}");
    assert_eq!(e["refused_actions"][0], 0, "{e}");
    for id in ["front", "back"] {
        let text = std::fs::read_to_string(deployed_calls.join(id).join("calls.jsonl")).expect("each node records its calls");
        let calls: Vec<avacraft_ava::llm::CallRecord> = text.lines().map(|l| serde_json::from_str(l).expect("a call record")).collect();
        assert!(calls.iter().any(|c| c.stage == avacraft_ava::llm::Stage::Decision), "{id}");
        assert!(calls.iter().all(|c| c.reply.is_some() && c.model == "synthetic"), "{id}");
    }
    let file = write_launch("ava-local.yaml", &format!("router: tcp/127.0.0.1:{}\n{}", free_port(), body(&local_calls)));
    let out = Command::new(exe()).args(["episode", "--json", "--launch"]).arg(&file).stderr(Stdio::inherit()).output().expect("episode");
    assert!(out.status.success());
    let local: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(local["episodes"][0]["trajectory_hash"], e["trajectory_hash"], "deployed and in-process AVA play the same game");
    let deployed_text = std::fs::read_to_string(deployed_calls.join("front/calls.jsonl")).expect("calls");
    let local_text = std::fs::read_to_string(local_calls.join("front/calls.jsonl")).expect("calls");
    let hashes = |t: &str| {
        t.lines().map(|l| serde_json::from_str::<avacraft_ava::llm::CallRecord>(l).expect("record").request_hash).collect::<Vec<_>>()
    };
    assert_eq!(hashes(&deployed_text), hashes(&local_text), "the node was asked exactly what the in-process agent was asked");
}

/// In-process `episode --launch` of launch text, as JSON.
fn in_process_text(name: &str, body: &str) -> serde_json::Value {
    in_process(&write_launch(name, &format!("router: tcp/127.0.0.1:{}\n{body}", free_port())))
}

/// Dynamic role groups: a commander (the scripted `rotate`, which hands every unit to the next
/// group every few steps) moves units between two running agent nodes with different
/// policies. Ownership follows the orders at step boundaries: no action is missing (a unit
/// driven by no node) or foreign (a unit driven by a node that does not own it), no order is
/// refused or late, units did change hands, and the game is the one played in-process.
#[test]
fn a_commander_moves_units_between_running_role_groups() {
    let body = "scenario: 3m_vlm\nepisodes: 2\nseed: 7\nagents:\n  - {id: cmd, team: 1, commander: true, policy: rotate}\n  - {id: front, units: [1, 2], policy: focus-fire, role: attacker}\n  - {id: back, units: [3], policy: hold, role: defender}\n";
    let v = launch_on_free_port("rotate.yaml", body);
    let local = in_process_text("rotate-local.yaml", body);
    for (k, e) in v.as_array().expect("episodes").iter().enumerate() {
        for field in ["missing_actions", "foreign_actions", "refused_actions", "refused_orders", "missing_orders"] {
            assert_eq!(e[field][0], 0, "{field}: {e}");
        }
        assert!(e["role_changes"][0].as_u64().unwrap_or(0) >= 3, "units changed groups: {e}");
        assert_eq!(
            local["episodes"][k]["trajectory_hash"], e["trajectory_hash"],
            "episode {k}: deployed and in-process play the same game"
        );
    }
    // Without the commander the same groups play another game: ownership mattered.
    let fixed = in_process_text(
        "fixed.yaml",
        &body
            .replace("  - {id: cmd, team: 1, commander: true, policy: rotate}\n", "")
            .replace(", role: attacker", "")
            .replace(", role: defender", ""),
    );
    assert_ne!(fixed["episodes"][0]["trajectory_hash"], local["episodes"][0]["trajectory_hash"]);
}

/// AVA under dynamic roles (the stand-in model): the commander node runs the planner, roles
/// and priorities, the role-group nodes decide for the units they are given, and the
/// deployment asks every model call the in-process run asks and plays the same game.
#[test]
fn an_ava_commander_and_its_role_groups_play_the_same_game_deployed_and_in_process() {
    let body = |calls: &Path| {
        format!(
            "scenario: 3m_vlm\nepisodes: 1\nseed: 4\nava:\n  model: {{kind: synthetic}}\n  record: {}\n  config: {{image_max: 256}}\nagents:\n  - {{id: cmd, team: 1, commander: true, policy: ava}}\n  - {{id: front, units: [1], policy: ava, role: attacker}}\n  - {{id: back, units: [2, 3], policy: ava, role: defender}}\n",
            calls.display()
        )
    };
    let (deployed_calls, local_calls, mcap) = (tmp("cmd-deployed"), tmp("cmd-local"), tmp("cmd.mcap"));
    let v = launch_on_free_port("ava-cmd.yaml", &format!("record: {}\n{}", mcap.display(), body(&deployed_calls)));
    let e = &v[0];
    for field in ["missing_actions", "foreign_actions", "refused_actions", "refused_orders", "missing_orders"] {
        assert_eq!(e[field][0], 0, "{field}: {e}");
    }
    assert!(e["role_changes"][0].as_u64().unwrap_or(0) >= 1, "the commander moved a unit: {e}");
    let local = in_process_text("ava-cmd-local.yaml", &body(&local_calls));
    assert_eq!(local["episodes"][0]["trajectory_hash"], e["trajectory_hash"], "deployed and in-process play the same game");
    let calls = |dir: &Path, id: &str| {
        let text = std::fs::read_to_string(dir.join(id).join("calls.jsonl")).unwrap_or_else(|e| panic!("{id} records its calls: {e}"));
        text.lines().map(|l| serde_json::from_str::<avacraft_ava::llm::CallRecord>(l).expect("a call record")).collect::<Vec<_>>()
    };
    // `episode --launch` reports each AVA node's accounting, as the node's costs.json has it.
    for id in ["cmd", "front", "back"] {
        let costs = &local["ava_nodes"][id];
        let episodes = costs.as_array().unwrap_or_else(|| panic!("{id}'s costs in the report: {local}"));
        let n: u64 = episodes.iter().map(|e| e["total"]["calls"].as_u64().expect("calls")).sum();
        assert_eq!(n, calls(&local_calls, id).len() as u64, "{id}: {costs}");
        let file = std::fs::read_to_string(local_calls.join(id).join("costs.json")).expect("each node leaves costs.json");
        assert_eq!(&serde_json::from_str::<serde_json::Value>(&file).expect("json"), costs, "{id}");
    }
    let stages = |c: &[avacraft_ava::llm::CallRecord]| c.iter().map(|c| c.stage).collect::<std::collections::BTreeSet<_>>();
    use avacraft_ava::llm::Stage;
    let cmd = calls(&deployed_calls, "cmd");
    assert!(
        stages(&cmd).contains(&Stage::Roles) && !stages(&cmd).contains(&Stage::Decision),
        "the commander plans and assigns, and decides nothing"
    );
    for id in ["front", "back"] {
        let c = calls(&deployed_calls, id);
        assert_eq!(stages(&c).into_iter().collect::<Vec<_>>(), vec![Stage::Decision], "{id}: the role groups only decide");
    }
    // The session's MCAP holds every call too, on each node's model_calls topic.
    let bytes = std::fs::read(&mcap).expect("the recording");
    let mut recorded: std::collections::BTreeMap<String, Vec<avacraft_msgs::ModelCall>> = Default::default();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a message");
        if let Some(id) = m.channel.topic.strip_prefix("/avacraft/agents/").and_then(|t| t.strip_suffix("/model_calls")) {
            assert_eq!(m.channel.schema.as_ref().map(|s| s.name.as_str()), Some("avacraft_msgs/msg/ModelCall"));
            recorded.entry(id.to_owned()).or_default().push(avacraft_msgs::decode(&m.data).expect("a ModelCall"));
        }
    }
    for id in ["cmd", "front", "back"] {
        let hashes = |c: Vec<avacraft_ava::llm::CallRecord>| c.into_iter().map(|c| c.request_hash).collect::<Vec<_>>();
        let deployed = hashes(calls(&deployed_calls, id));
        assert_eq!(deployed, hashes(calls(&local_calls, id)), "{id} was asked what it is asked in-process");
        let on_topic: Vec<String> = recorded.get(id).map(|v| v.iter().map(|c| c.request_hash.clone()).collect()).unwrap_or_default();
        assert_eq!(on_topic, deployed, "{id}: the MCAP has every call, in order");
    }
    // Each node leaves its accounting when it stops: one entry per episode, every call counted.
    for id in ["cmd", "front", "back"] {
        let path = deployed_calls.join(id).join("costs.json");
        let costs: Vec<avacraft_ava::cost::EpisodeCost> =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).expect("costs");
        assert_eq!(costs.len(), 1, "{id}");
        assert_eq!(costs[0].total.calls, calls(&deployed_calls, id).len() as u64, "{id}: {costs:?}");
    }
    // The recording's Foxglove log channel shows them too, named after their nodes.
    let mut shown: std::collections::BTreeMap<String, usize> = Default::default();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a message");
        if m.channel.topic == avacraft_live::LiveChannel::Log.topic().as_str() {
            let line: avacraft_msgs::foxglove_msgs::Log = avacraft_msgs::decode(&m.data).expect("a foxglove_msgs/Log");
            if let Some(node) = line.name.strip_prefix("ava/").and_then(|n| n.split('/').next()) {
                *shown.entry(node.to_owned()).or_default() += 1;
            }
        }
    }
    for id in ["cmd", "front", "back"] {
        let answered = calls(&deployed_calls, id).iter().filter(|c| c.reply.is_some() || c.error.is_some()).count();
        assert!(answered > 0, "{id}");
        assert_eq!(shown.get(id).copied(), Some(answered), "{id}: every call in the recording's live log: {shown:?}");
    }
    let first = &recorded["front"][0];
    assert_eq!((first.stage, first.model.as_str()), (avacraft_msgs::ModelCall::STAGE_DECISION, "synthetic"));
    assert!(first.first_image_png.starts_with(b"\x89PNG") && first.images >= 1 && !first.response.is_empty(), "{first:?}");
}
