//! Helpers shared by the process tests.

use std::io::Write;
use std::path::{Path, PathBuf};

pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_avacraft")
}

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).expect("a free port")
}

pub fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("avacraft-it-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d.join(name)
}

pub fn write_launch(name: &str, body: &str) -> PathBuf {
    let p = tmp(name);
    std::fs::File::create(&p).and_then(|mut f| f.write_all(body.as_bytes())).expect("launch file");
    p
}

/// Runs `avacraft launch --json` on a launch file; its episode summaries.
pub fn launch_json(file: &Path) -> serde_json::Value {
    let out = std::process::Command::new(exe())
        .args(["launch", "--json"])
        .arg(file)
        .stderr(std::process::Stdio::inherit())
        .output()
        .expect("run avacraft launch");
    assert!(out.status.success(), "launch failed: {}", String::from_utf8_lossy(&out.stdout));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stdout)))
}

/// A node process of the deployment, killed when dropped.
pub struct Child(pub std::process::Child);

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Separate hosts on this machine: one network namespace per host, each joined to a
/// bridge (in a hub namespace of its own) by a veth pair, on a /24 of its own. Removed
/// when dropped. Needs root (CAP_NET_ADMIN) and iproute2, which `.ci/run` installs.
pub struct Net {
    hub: String,
    hosts: Vec<(String, String)>,
    subnet: String,
    /// Host ends of the veth pairs, removed from this namespace if still here.
    veths: Vec<String>,
}

fn ip(args: &[&str]) {
    let out = std::process::Command::new("ip").args(args).output().expect("run `ip` (iproute2)");
    assert!(out.status.success(), "ip {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
}

impl Net {
    /// Hosts `names` get addresses .1, .2, ... in order.
    pub fn new(tag: &str, names: &[&str]) -> Net {
        let pid = std::process::id();
        // Interface names are at most 15 bytes: keep the prefix short and unique per run.
        let prefix = format!("a{}{tag}", pid % 100_000);
        let subnet = format!("10.{}.{}", 100 + pid % 100, (pid / 100) % 250);
        let hub = format!("{prefix}hub");
        // Built first, so whatever was made is removed if a step below fails.
        let mut net = Net { hub: hub.clone(), hosts: Vec::new(), subnet, veths: Vec::new() };
        ip(&["netns", "add", &hub]);
        ip(&["-n", &hub, "link", "add", "br0", "type", "bridge"]);
        ip(&["-n", &hub, "link", "set", "br0", "up"]);
        for (i, name) in names.iter().enumerate() {
            let ns = format!("{prefix}{name}");
            ip(&["netns", "add", &ns]);
            net.hosts.push(((*name).to_owned(), ns.clone()));
            let (a, b) = (format!("{prefix}h{i}"), format!("{prefix}b{i}"));
            ip(&["link", "add", &a, "type", "veth", "peer", "name", &b]);
            net.veths.push(a.clone());
            ip(&["link", "set", &a, "netns", &ns]);
            ip(&["link", "set", &b, "netns", &hub]);
            ip(&["-n", &hub, "link", "set", &b, "master", "br0"]);
            ip(&["-n", &hub, "link", "set", &b, "up"]);
            let addr = format!("{}/24", net.addr(name));
            ip(&["-n", &ns, "addr", "add", &addr, "dev", &a]);
            ip(&["-n", &ns, "link", "set", &a, "up"]);
            ip(&["-n", &ns, "link", "set", "lo", "up"]);
        }
        net
    }

    /// The address of host `name`.
    pub fn addr(&self, name: &str) -> String {
        let i = self.hosts.iter().position(|(n, _)| n == name).unwrap_or(self.hosts.len());
        format!("{}.{}", self.subnet, i + 1)
    }

    /// A command that runs `program` on host `name`.
    pub fn on(&self, name: &str, program: &str) -> std::process::Command {
        let ns = &self.hosts.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no host {name}")).1;
        let mut c = std::process::Command::new("ip");
        c.args(["netns", "exec", ns, program]);
        c
    }

    /// Waits until something listens on TCP `port` on host `name`.
    pub fn wait_listening(&self, name: &str, port: u16, timeout: std::time::Duration) {
        let t0 = std::time::Instant::now();
        while t0.elapsed() < timeout {
            let out = self.on(name, "ss").args(["-Hltn", &format!("sport = :{port}")]).output().expect("ss (iproute2)");
            if !String::from_utf8_lossy(&out.stdout).trim().is_empty() {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        panic!("nothing listens on {name}:{port} after {timeout:?}");
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for (_, ns) in &self.hosts {
            let _ = std::process::Command::new("ip").args(["netns", "del", ns]).output();
        }
        let _ = std::process::Command::new("ip").args(["netns", "del", &self.hub]).output();
        for v in &self.veths {
            let _ = std::process::Command::new("ip").args(["link", "del", v]).output();
        }
    }
}
