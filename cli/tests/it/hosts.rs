//! A secured deployment across hosts, for real: network namespaces joined by veth pairs
//! stand in for machines. The server hosts the TLS router with access control and the
//! simulator; each PvP team's agent nodes run on a host of their own; an intruder host
//! tries to listen and to speak for a team.

use crate::common::{Net, exe, tmp};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const PORT: u16 = 7447;

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

/// Waits for a process, killing it after `limit`.
fn finish(mut c: std::process::Child, limit: Duration) -> Output {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if let Ok(Some(_)) = c.try_wait() {
            return c.wait_with_output().expect("output");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = c.kill();
    let out = c.wait_with_output().expect("output");
    panic!("still running after {limit:?}; stderr: {}", String::from_utf8_lossy(&out.stderr));
}

fn report(name: &str, out: &Output) -> avacraft_cli::ProbeReport {
    assert!(out.status.success(), "probe {name} failed: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("probe {name}: {e}: {}", String::from_utf8_lossy(&out.stdout)))
}

#[test]
fn a_secured_pvp_deployment_across_hosts_keeps_each_team_and_intruders_out() {
    let net = Net::new("s", &["server", "blue", "red", "mallory"]);
    let dir = tmp("hosts");
    std::fs::create_dir_all(&dir).expect("dir");
    let router = format!("tls/{}:{PORT}", net.addr("server"));
    let agents = "agents:\n  - {id: blue_a, units: [1, 2, 3, 4, 5, 6], policy: focus-fire, host: blue}\n  - {id: blue_b, units: [7, 8, 9, 10, 11, 12], policy: focus-fire, host: blue}\n  - {id: red_all, units: [13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24], policy: attack-move, host: red}\n";
    let head = |hosts: &str, certs: &str| {
        format!("scenario: MMM_vs_MMM\nepisodes: 2\nseed: 4\nrouter: {router}\nsecurity:\n  certs: {certs}\nhosts: [{hosts}]\n")
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

    let piped = |mut c: Command| c.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    let mut server = net.on("server", exe());
    server.args(["launch", "--json", "--startup-timeout", "60"]).arg(&file);
    let server = piped(server);
    net.wait_listening("server", PORT, Duration::from_secs(30));

    let probe = |host: &str, id: Vec<String>, extra: &[&str]| {
        let mut c = net.on(host, exe());
        c.arg("probe").args(id).args(extra);
        piped(c)
    };
    let secs = ["--seconds", "12"];
    let monitor = probe("server", identity(&router, &good, "server"), &[&["--watch", "actions", "--watch", "team:2"][..], &secs].concat());
    let blue_eye = probe(
        "blue",
        identity(&router, &good, "blue"),
        &[&["--watch", "team:1", "--watch", "team:2", "--watch", "status"][..], &secs].concat(),
    );
    // Red speaking for a blue agent node, and listening to blue.
    let red_as_blue = probe(
        "red",
        identity(&router, &good, "red"),
        &[&["--send-as", "blue_a", "--mark", "red_as_blue", "--watch", "team:1"][..], &secs].concat(),
    );
    // Control: red on its own action topic gets through (so the monitor would see a leak).
    let red_own = probe("red", identity(&router, &good, "red"), &[&["--send-as", "red_all", "--mark", "red_own"][..], &secs].concat());
    let mallory = probe(
        "mallory",
        identity(&router, &good, "mallory"),
        &[&["--send-as", "blue_a", "--mark", "mallory", "--watch", "team:1", "--watch", "status"][..], &secs].concat(),
    );
    let mallory_foreign = probe("mallory", identity(&router, &bad, "mallory"), &["--seconds", "1"]);
    let plain = format!("tcp/{}:{PORT}", net.addr("server"));
    let mallory_plain = probe("mallory", vec!["--mode".into(), "client".into(), "--connect".into(), plain], &["--seconds", "1"]);
    std::thread::sleep(Duration::from_secs(2));

    let mut blue = net.on("blue", exe());
    blue.args(["launch", "--host", "blue"]).arg(&file);
    let blue = piped(blue);
    let mut red = net.on("red", exe());
    red.args(["launch", "--host", "red"]).arg(&file);
    let red = piped(red);

    // The deployment works across hosts: both teams play every episode and their actions
    // arrive (an agent node acts on what it has after 200 ms, so a loaded machine may miss
    // a unit's step now and then; blocked actions would miss every unit every step).
    let out = finish(server, Duration::from_secs(120));
    assert!(out.status.success(), "server: {}", String::from_utf8_lossy(&out.stderr));
    let eps: serde_json::Value = serde_json::from_slice(&out.stdout).expect("summaries");
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
        let out = finish(c, Duration::from_secs(30));
        assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(String::from_utf8_lossy(&out.stdout).contains("until the simulator"), "{name}");
    }

    let monitor = report("monitor", &finish(monitor, Duration::from_secs(60)));
    let blue_eye = report("blue", &finish(blue_eye, Duration::from_secs(60)));
    let red_as_blue = report("red_as_blue", &finish(red_as_blue, Duration::from_secs(60)));
    let red_own = report("red_own", &finish(red_own, Duration::from_secs(60)));
    let mallory = report("mallory", &finish(mallory, Duration::from_secs(60)));
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
    // A host with the right authority but not in the deployment: nothing in.
    assert!(mallory.received.values().all(|&n| n == 0), "{mallory:?}");
    // Another authority's certificate, or no TLS at all: no session.
    for (name, c) in [("foreign", mallory_foreign), ("plain", mallory_plain)] {
        let out = finish(c, Duration::from_secs(60));
        assert!(!out.status.success(), "{name}: an intruder opened a session: {}", String::from_utf8_lossy(&out.stdout));
    }
}
