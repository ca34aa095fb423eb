//! A secured deployment across hosts, for real: network namespaces joined by veth pairs
//! stand in for machines (made in a user namespace of the test's own, so no root is needed:
//! see `common::Net`). The server hosts the TLS router with access control and the
//! simulator; each PvP team's agent nodes run on a host of their own; an intruder host
//! tries to listen and to speak for a team.

use crate::common::{Net, exe, tmp};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const PORT: u16 = 7447;
/// A step's deadline far above the default 2 s: this test is about who may see and send, and
/// on two cores shared with the rest of the suite (14 processes here, Chromium and training
/// beside them) agent nodes were starved past 2 s on most steps, so actions that got through
/// counted as missing. Lockstep moves on as soon as every action is in, so a long deadline
/// costs nothing when actions arrive; blocked ones would miss it on every step.
const DEADLINE_MS: u32 = 15_000;

/// `--mode client --connect <router> --tls-*` for `host`'s identity from `certs`.
fn identity(router: &str, certs: &Path, host: &str) -> Vec<String> {
    let p = |f: String| certs.join(f).display().to_string();
    vec![
        "--mode".into(),
        "client".into(),
        "--connect".into(),
        router.into(),
        "--tls-ca".into(),
        p("ca.pem".into()),
        "--tls-cert".into(),
        p(format!("{host}.pem")),
        "--tls-key".into(),
        p(format!("{host}.key")),
    ]
}

fn write(path: &Path, text: &str) {
    std::fs::write(path, text).expect("write a launch file");
}

fn certs(file: &Path) {
    let out = Command::new(exe()).arg("certs").arg(file).output().expect("avacraft certs");
    assert!(out.status.success(), "certs: {}", String::from_utf8_lossy(&out.stderr));
}

/// A process whose output goes to files (a full pipe cannot block it), killed if the test
/// ends before it does.
struct Spawned {
    child: std::process::Child,
    out: std::path::PathBuf,
    err: std::path::PathBuf,
}

impl Drop for Spawned {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn spawn(mut c: Command, name: &str) -> Spawned {
    let (out, err) = (tmp(&format!("{name}.out")), tmp(&format!("{name}.err")));
    let file = |p: &Path| Stdio::from(std::fs::File::create(p).expect("output file"));
    let child = c.stdout(file(&out)).stderr(file(&err)).spawn().expect("spawn");
    Spawned { child, out, err }
}

/// Waits for a process (killing it after `limit`); its exit status, stdout and stderr.
fn finish(mut s: Spawned, limit: Duration) -> (std::process::ExitStatus, String, String) {
    let t0 = Instant::now();
    let status = loop {
        if let Ok(Some(st)) = s.child.try_wait() {
            break st;
        }
        if t0.elapsed() > limit {
            let _ = s.child.kill();
            panic!("still running after {limit:?}; stderr: {}", std::fs::read_to_string(&s.err).unwrap_or_default());
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
    (status, read(&s.out), read(&s.err))
}

fn report(name: &str, s: Spawned) -> avacraft_cli::ProbeReport {
    let (status, out, err) = finish(s, Duration::from_secs(300));
    assert!(status.success(), "probe {name} failed: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("probe {name}: {e}: {out}"))
}

// Long on purpose: one deployment across hosts, its machines, and what each may see and send.
#[test]
fn a_secured_pvp_deployment_across_hosts_keeps_each_team_and_intruders_out() {
    let net = Net::new(&["server", "blue", "red", "mallory"]);
    let dir = tmp("hosts");
    std::fs::create_dir_all(&dir).expect("dir");
    let router = format!("tls/{}:{PORT}", net.addr("server"));
    let agents = "agents:\n  - {id: blue_a, units: [1, 2, 3, 4, 5, 6], policy: focus-fire, host: blue}\n  - {id: blue_b, units: [7, 8, 9, 10, 11, 12], policy: focus-fire, host: blue}\n  - {id: red_all, units: [13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24], policy: attack-move, host: red}\n";
    let head = |hosts: &str, certs: &str| {
        format!(
            "scenario: MMM_vs_MMM\nepisodes: 2\nseed: 4\ndeadline_ms: {DEADLINE_MS}\nrouter: {router}\nsecurity:\n  certs: {certs}\nhosts: [{hosts}]\n"
        )
    };
    // The authority signs one more pair than the deployment names: `mallory` holds a valid
    // certificate of the right authority, but no rule.
    let wide = dir.join("wide.yaml");
    write(&wide, &format!("{}agents:\n  - {{id: a, units: [1], policy: noop}}\n", head("server, blue, red, mallory", "certs")));
    certs(&wide);
    // Another authority altogether.
    let foreign = dir.join("foreign.yaml");
    write(&foreign, &format!("{}agents:\n  - {{id: a, units: [1], policy: noop}}\n", head("server, mallory", "foreign")));
    certs(&foreign);
    let file = dir.join("pvp.yaml");
    write(&file, &format!("{}{agents}", head("server, blue, red", "certs")));
    let (good, bad) = (dir.join("certs"), dir.join("foreign"));

    let mut server = net.on("server", exe());
    server.args(["launch", "--json", "--startup-timeout", "60"]).arg(&file);
    let server = spawn(server, "server");
    net.wait_listening("server", PORT, Duration::from_secs(30));

    let probe = |name: &str, host: &str, id: Vec<String>, extra: &[&str]| {
        let mut c = net.on(host, exe());
        c.arg("probe").args(id).args(extra);
        spawn(c, name)
    };
    // Hosts that may see the simulator's node probe until it is gone; the intruder, which
    // sees nothing, for a fixed time that covers the match. The limits here guard against a
    // hang, not a slow machine: two cores shared with a training run take minutes.
    let secs = ["--seconds", "280", "--until-sim-exits"];
    let monitor = probe(
        "monitor",
        "server",
        identity(&router, &good, "server"),
        &[&["--watch", "actions", "--watch", "team:2", "--mark", "monitor"][..], &secs].concat(),
    );
    let blue_eye = probe(
        "blue_eye",
        "blue",
        identity(&router, &good, "blue"),
        &[&["--watch", "team:1", "--watch", "team:2", "--watch", "status", "--mark", "blue_eye"][..], &secs].concat(),
    );
    // Red speaking for a blue agent node, and listening to blue.
    let red_as_blue = probe(
        "red_as_blue",
        "red",
        identity(&router, &good, "red"),
        &[&["--send-as", "blue_a", "--mark", "red_as_blue", "--watch", "team:1"][..], &secs].concat(),
    );
    // Control: red on its own action topic gets through (so the monitor would see a leak).
    let red_own =
        probe("red_own", "red", identity(&router, &good, "red"), &[&["--send-as", "red_all", "--mark", "red_own"][..], &secs].concat());
    let mallory = probe(
        "mallory",
        "mallory",
        identity(&router, &good, "mallory"),
        &["--send-as", "blue_a", "--mark", "mallory", "--watch", "team:1", "--watch", "status", "--seconds", "15"],
    );
    // Another authority's certificate and key, with this deployment's authority to check
    // the router by: the router refuses the client. Then entirely the other authority's.
    let mut forged = identity(&router, &bad, "mallory");
    forged[5] = good.join("ca.pem").display().to_string();
    let mallory_forged = probe("mallory_forged", "mallory", forged, &["--seconds", "1"]);
    let mallory_foreign = probe("mallory_foreign", "mallory", identity(&router, &bad, "mallory"), &["--seconds", "1"]);
    // No TLS at all (the router listens only for TLS).
    let plain = format!("tcp/{}:{PORT}", net.addr("server"));
    let mallory_plain =
        probe("mallory_plain", "mallory", vec!["--mode".into(), "client".into(), "--connect".into(), plain], &["--seconds", "1"]);
    std::thread::sleep(Duration::from_secs(2));

    let mut blue = net.on("blue", exe());
    blue.args(["launch", "--host", "blue"]).arg(&file);
    let blue = spawn(blue, "blue");
    let mut red = net.on("red", exe());
    red.args(["launch", "--host", "red"]).arg(&file);
    let red = spawn(red, "red");

    // The deployment works across hosts: both teams play every episode and their actions
    // arrive (a loaded machine may still miss a unit's step now and then; blocked actions
    // would miss every unit every step).
    let (status, out, err) = finish(server, Duration::from_secs(300));
    assert!(status.success(), "server: {err}");
    let eps: serde_json::Value = serde_json::from_str(&out).expect("summaries");
    let eps = eps.as_array().expect("episodes");
    assert_eq!(eps.len(), 2);
    for e in eps {
        assert!(e["steps"].as_u64().unwrap_or(0) > 5, "{e}");
        let steps = e["steps"].as_u64().unwrap_or(0);
        for team in 0..2 {
            assert!(e["missing_actions"][team].as_u64().is_some_and(|m| m * 10 <= steps * 12), "{e}");
        }
        assert_eq!(e["foreign_actions"], serde_json::json!([0, 0]), "{e}");
        assert_eq!(e["malformed_messages"], 0, "{e}");
    }
    for (name, c) in [("blue", blue), ("red", red)] {
        let (status, out, err) = finish(c, Duration::from_secs(30));
        assert!(status.success(), "{name}: {err}");
        assert!(out.contains("until the simulator"), "{name}: {out}");
    }

    let monitor = report("monitor", monitor);
    let blue_eye = report("blue_eye", blue_eye);
    let red_as_blue = report("red_as_blue", red_as_blue);
    let red_own = report("red_own", red_own);
    let mallory = report("mallory", mallory);
    // A team reads its own observations and the status, never the other team's.
    assert!(blue_eye.received["team:1"] > 50 && blue_eye.received["status"] > 10, "{blue_eye:?}");
    assert_eq!(blue_eye.received["team:2"], 0, "blue read red's observations: {blue_eye:?}");
    assert_eq!(red_as_blue.received["team:1"], 0, "red read blue's observations: {red_as_blue:?}");
    assert!(monitor.received["team:2"] > 50, "the server sees everything: {monitor:?}");
    // Actions: the real agent nodes and red's probe on red's own topic arrive; red speaking
    // for blue and the intruder never do.
    assert!(red_own.sent > 10 && red_as_blue.sent > 10 && mallory.sent > 10);
    for sender in ["blue_a", "blue_b", "red_all", "red_own"] {
        assert!(monitor.action_senders.get(sender).is_some_and(|&n| n > 0), "{sender} missing: {monitor:?}");
    }
    for sender in ["red_as_blue", "mallory"] {
        assert_eq!(monitor.action_senders.get(sender), None, "{sender} got through: {monitor:?}");
    }
    // The ROS graph: the server sees every node of the deployment, and no probe of another
    // host (a host announces only its own nodes); a team host learns only of the simulator.
    for n in ["sim", "agent_blue_a", "agent_blue_b", "agent_red_all", "launch_blue", "launch_red"] {
        assert!(monitor.nodes_seen.contains(n), "{n} not in the server's graph: {monitor:?}");
    }
    assert!(!monitor.nodes_seen.iter().any(|n| n.starts_with("probe_") && n != "probe_monitor"), "{monitor:?}");
    assert_eq!(blue_eye.nodes_seen.iter().map(String::as_str).collect::<Vec<_>>(), ["probe_blue_eye", "sim"], "{blue_eye:?}");
    // A host with the right authority but not in the deployment: nothing in.
    assert!(mallory.received.values().all(|&n| n == 0), "{mallory:?}");
    // Another authority's certificate, or no TLS at all: no session.
    for (name, c) in [("forged", mallory_forged), ("foreign", mallory_foreign), ("plain", mallory_plain)] {
        let (status, out, err) = finish(c, Duration::from_secs(60));
        assert!(!status.success(), "{name}: an intruder opened a session: {out}");
        assert!(err.contains("cannot open the Zenoh session"), "{name}: {err}");
    }
}
