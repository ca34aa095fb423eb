//! Helpers shared by the process tests.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_avacraft")
}

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).expect("a free port")
}

pub fn tmp(name: &str) -> PathBuf {
    static SWEPT: OnceLock<()> = OnceLock::new();
    SWEPT.get_or_init(sweep_old_folders);
    let d = std::env::temp_dir().join(format!("avacraft-it-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d.join(name)
}

/// The folder [`tmp`] makes lives as long as the test process (a static is never dropped), so
/// each run removes those of earlier runs whose process is gone (Linux: no `/proc/<pid>`).
fn sweep_old_folders() {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else { return };
    for e in entries.filter_map(Result::ok) {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name.strip_prefix("avacraft-it-").and_then(|p| p.parse::<u32>().ok()) else { continue };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Held by tests whose simulators publish frames of team 1 in the default namespace: the
/// iceoryx2 services are named by the namespace only, so one test's reader would take
/// another's frames (of another size) while both run.
pub fn shm_frames() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

pub fn write_launch(name: &str, body: &str) -> PathBuf {
    let p = tmp(name);
    std::fs::File::create(&p).and_then(|mut f| f.write_all(body.as_bytes())).expect("launch file");
    p
}

/// A 3m_vlm checkpoint from a short QMIX run of `avacraft_marl::train` (300 steps: it plays,
/// it need not win), made once per test process in `tmp("marl-3m")`, next to the launch
/// files `write_launch` writes (so they can name it `marl:marl-3m`).
pub fn marl_checkpoint() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tmp("marl-3m");
        let overrides = ["t_max=300", "envs=2", "batch_size=4", "test_interval=300", "test_nepisode=2", "episode_limit=60"];
        let cfg = avacraft_marl::Config::for_algo("qmix", &overrides.map(String::from)).expect("config");
        let scenario = Arc::new(avacraft_engine::Scenario::load("3m_vlm").expect("3m_vlm"));
        let opts = avacraft_marl::RunOptions { scenario, seed: 7, threads: 1, out: Some(dir.clone()) };
        avacraft_marl::train(&cfg, &opts, &mut |_| {}).expect("a short training run");
        dir
    })
}

/// Runs `avacraft launch --json` on a launch file; its episode summaries.
pub fn launch_json(file: &Path) -> serde_json::Value {
    let out = Command::new(exe()).args(["launch", "--json"]).arg(file).stderr(Stdio::inherit()).output().expect("run avacraft launch");
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

/// Separate hosts on this machine, made without privileges: a process of util-linux's
/// `unshare` holds a user namespace of its own (in which this user is root) and, in it, a
/// network namespace with a bridge (the lab); every host is a network namespace inside the
/// lab, held by a process of its own and joined to the bridge by a veth pair, on one /24.
/// Nothing is named in `/var/run/netns` and nothing changes in the machine's own network,
/// so an ordinary user and root run it alike, and it all goes when the holders exit: when
/// dropped, or when the test process dies (a holder ends when its standard input closes).
/// Needs util-linux's `unshare` and `nsenter`, iproute2's `ip` and `ss`, and a kernel that
/// lets this user make user namespaces with network capabilities; `new` fails saying so
/// otherwise.
pub struct Net {
    /// Dropped before the lab (fields drop in order).
    hosts: Vec<(String, Holder)>,
    lab: Holder,
}

/// A process that keeps namespaces alive: `sh` that says `ready` once inside them, then
/// `cat` reading its standard input until this end of the pipe closes. Killed when dropped.
struct Holder(Child);

impl Holder {
    fn start(mut c: Command, what: &str) -> Holder {
        c.args(["sh", "-c", "echo ready; exec cat >/dev/null"]).stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::piped());
        let mut child =
            c.spawn().unwrap_or_else(|e| panic!("cannot start {what} ({c:?}): {e}; util-linux's unshare and nsenter are needed"));
        let mut line = String::new();
        if let Some(out) = child.stdout.take() {
            let _ = BufReader::new(out).read_line(&mut line);
        }
        if line.trim() != "ready" {
            let mut err = String::new();
            let _ = child.stderr.take().map(|mut e| e.read_to_string(&mut err));
            let _ = child.kill();
            let _ = child.wait();
            panic!("cannot make {what} ({c:?}): {}{USERNS}", err.trim());
        }
        Holder(Child(child))
    }

    fn pid(&self) -> u32 {
        self.0.0.id()
    }

    /// A command that runs `program` in this holder's user and network namespaces (as root
    /// there, which is this user outside).
    fn run(&self, program: &str) -> Command {
        let mut c = Command::new("nsenter");
        c.args(["--preserve-credentials", "--user", "--net", "--target", &self.pid().to_string(), program]);
        c
    }

    fn ip(&self, args: &[&str]) {
        let out = self.run("ip").args(args).output().expect("run `ip` (iproute2) through nsenter (util-linux)");
        assert!(out.status.success(), "ip {}: {}{USERNS}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim());
    }
}

/// Why making the test network may fail.
const USERNS: &str = "\nThe multi-host tests make their hosts as network namespaces inside an unprivileged user \
namespace (`unshare --user --map-root-user --net`). The kernel must allow that for this user: \
sysctl user.max_user_namespaces > 0, kernel.unprivileged_userns_clone = 1 where it exists (Debian's \
kernels), kernel.apparmor_restrict_unprivileged_userns = 0 where it exists (Ubuntu 23.10 and newer), \
and no container seccomp profile refusing unshare(CLONE_NEWUSER).";

impl Net {
    /// Hosts `names` get addresses 10.0.0.1, 10.0.0.2, ... in order.
    pub fn new(names: &[&str]) -> Net {
        let mut lab = Command::new("unshare");
        lab.args(["--user", "--map-root-user", "--net"]);
        let lab = Holder::start(lab, "a user and network namespace for the test's hosts");
        lab.ip(&["link", "add", "br0", "type", "bridge"]);
        lab.ip(&["link", "set", "br0", "up"]);
        // Built as it goes, so whatever was made is removed if a step below fails.
        let mut net = Net { hosts: Vec::new(), lab };
        for (i, name) in names.iter().enumerate() {
            let mut host = net.lab.run("unshare");
            host.arg("--net");
            let host = Holder::start(host, &format!("a network namespace for host {name}"));
            let (eth, port) = (format!("eth{i}"), format!("port{i}"));
            net.lab.ip(&["link", "add", &eth, "type", "veth", "peer", "name", &port]);
            net.lab.ip(&["link", "set", &eth, "netns", &host.pid().to_string()]);
            net.lab.ip(&["link", "set", &port, "master", "br0"]);
            net.lab.ip(&["link", "set", &port, "up"]);
            host.ip(&["addr", "add", &format!("{}/24", net.addr_of(i)), "dev", &eth]);
            host.ip(&["link", "set", &eth, "up"]);
            host.ip(&["link", "set", "lo", "up"]);
            net.hosts.push(((*name).to_owned(), host));
        }
        net
    }

    fn addr_of(&self, i: usize) -> String {
        format!("10.0.0.{}", i + 1)
    }

    fn host(&self, name: &str) -> (usize, &Holder) {
        self.hosts.iter().enumerate().find(|(_, (n, _))| n == name).map(|(i, (_, h))| (i, h)).unwrap_or_else(|| panic!("no host {name}"))
    }

    /// The address of host `name`.
    pub fn addr(&self, name: &str) -> String {
        self.addr_of(self.host(name).0)
    }

    /// A command that runs `program` on host `name`. `nsenter` execs `program`, so the
    /// command's process is the program's (killing it kills the program).
    pub fn on(&self, name: &str, program: &str) -> Command {
        self.host(name).1.run(program)
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
