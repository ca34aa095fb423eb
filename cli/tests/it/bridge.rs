//! The DDS bridge against an independent DDS implementation: a Python agent on Eclipse
//! Cyclone DDS (installed by `.ci/run`), which knows the messages only from the `.msg`
//! files, receives the bridged topics and plays 3m_vlm through the bridge.

use crate::common::{Child, free_port, launch_json, tmp, write_launch};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Cyclone DDS on loopback only, finding RustDDS by unicast (no multicast needed).
const CYCLONE: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<CycloneDDS xmlns="https://cdds.io/config">
  <Domain Id="any">
    <General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
    <Internal><SocketReceiveBufferSize min="4MB"/></Internal>
    <Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>
      <Peers><Peer address="127.0.0.1"/></Peers></Discovery>
  </Domain>
</CycloneDDS>
"#;

#[test]
fn an_agent_on_cyclone_dds_plays_through_the_bridge() {
    // A DDS domain of its own, so parallel runs do not meet.
    let domain = 20 + std::process::id() % 150;
    let xml = tmp("cyclonedds.xml");
    std::fs::write(&xml, CYCLONE).expect("cyclone config");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace");
    let script = root.join("cli/tests/it/dds_agent.py");
    let msgs = root.join("msgs/msg");
    let agent_out = tmp("dds_agent.out");
    let agent_err = tmp("dds_agent.err");
    let file_of = |p: &std::path::Path| Stdio::from(std::fs::File::create(p).expect("output file"));
    // Killed when dropped, should the launch below fail.
    let mut agent = Child(
        Command::new("python3")
            .arg(&script)
            .arg(&msgs)
            .args(["dds_agent", "1,2,3", &domain.to_string(), "2", "120"])
            .env("CYCLONEDDS_URI", format!("file://{}", xml.display()))
            .stdout(file_of(&agent_out))
            .stderr(file_of(&agent_err))
            .spawn()
            .expect("python3"),
    );
    let file = write_launch(
        "bridge.yaml",
        &format!(
            "scenario: 3m_vlm\nepisodes: 2\nseed: 2\ndeadline_ms: 500\nrouter: tcp/127.0.0.1:{}\nframes:\n  kinds: [screen]\nagents:\n  - {{id: dds_agent, units: [1, 2, 3], policy: dds}}\nbridge:\n  dds_domain: {domain}\n  dds_networks: [127.0.0.1]\n  frame_size: [80, 60]\n",
            free_port()
        ),
    );
    let eps = launch_json(&file);
    let t0 = Instant::now();
    while agent.0.try_wait().ok().flatten().is_none() && t0.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(100));
    }
    drop(agent);
    let stderr = std::fs::read_to_string(&agent_err).unwrap_or_default();
    let stdout = std::fs::read_to_string(&agent_out).unwrap_or_default();
    let r: serde_json::Value = serde_json::from_str(&stdout)
        .unwrap_or_else(|e| panic!("the Cyclone DDS agent (is the cyclonedds package installed?): {e}: {stderr}"));
    // The simulator got the DDS agent's actions: in lockstep a missing answer is counted.
    let eps = eps.as_array().expect("episodes");
    assert_eq!(eps.len(), 2);
    let mut steps = 0;
    for e in eps {
        let s = e["steps"].as_u64().unwrap_or(0);
        steps += s;
        assert!(s > 5, "{e}");
        assert!(e["missing_actions"][0].as_u64().is_some_and(|m| m * 10 <= s * 3), "the DDS agent's actions did not arrive: {e}");
        // The agent's one order per episode for a unit it does not own: refused, counted.
        assert_eq!(e["foreign_actions"], serde_json::json!([1, 0]), "{e}");
        assert_eq!(e["refused_actions"][0], 0, "{e}");
    }
    // And the DDS agent decoded every bridged topic, from the .msg files alone.
    let got = &r["received"];
    assert!(got["team_obs"].as_u64().is_some_and(|n| n >= steps), "{r}");
    assert!(got["status"].as_u64().is_some_and(|n| n >= steps), "{r}");
    assert!(got["unit_obs"].as_u64().is_some_and(|n| n >= steps), "{r}");
    assert_eq!(r["unit_obs_tags"], serde_json::json!([1]), "{r}");
    assert_eq!(r["units_seen"], 6, "{r}");
    assert!(r["text"].as_str().is_some_and(|t| t.contains("Marine")), "{r}");
    assert!(r["sent"].as_u64().is_some_and(|n| n >= steps), "{r}");
    assert_eq!(r["results"].as_object().map(|m| m.len()), Some(2), "both episodes' ends seen: {r}");
    // Frames scaled down for DDS: 80x60 rgb8, not blank.
    assert!(got["screen"].as_u64().is_some_and(|n| n > 0), "{r}");
    let s = &r["screens"][0];
    assert_eq!((s[0].as_u64(), s[1].as_u64(), s[2].as_str(), s[3].as_u64()), (Some(80), Some(60), Some("rgb8"), Some(80 * 60 * 3)), "{r}");
    assert!(s[4].as_u64().is_some_and(|m| m > 100), "{r}");
}
