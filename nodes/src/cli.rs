//! Flags every node shares (flattened into each node's command), logging, and shutdown on
//! SIGINT / SIGTERM.

use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// How a node joins the Zenoh network.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SessionMode {
    /// Talks to peers directly and through routers (the default, as rmw_zenoh nodes do).
    Peer,
    /// Talks only through a router.
    Client,
    /// Routes for others (what `avacraft launch` hosts so ROS 2 tools can attach).
    Router,
}

impl SessionMode {
    pub fn name(self) -> &'static str {
        match self {
            SessionMode::Peer => "peer",
            SessionMode::Client => "client",
            SessionMode::Router => "router",
        }
    }
}

/// Zenoh and ROS settings common to every node.
#[derive(Args, Clone, Debug, PartialEq, Eq)]
pub struct NodeArgs {
    /// Zenoh mode.
    #[arg(long, value_enum, default_value_t = SessionMode::Peer)]
    pub mode: SessionMode,
    /// Endpoints to connect to (repeatable), e.g. tcp/10.0.0.5:7447. Default: the local
    /// router rmw_zenoh expects, tcp/127.0.0.1:7447.
    #[arg(long = "connect", default_values_t = ["tcp/127.0.0.1:7447".to_owned()])]
    pub connect: Vec<String>,
    /// How long to keep trying to reach the `--connect` endpoints, milliseconds (0: one
    /// attempt; -1: forever). Hosts that may start before the router set it.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub connect_timeout_ms: i64,
    /// Endpoints to listen on (repeatable), e.g. tcp/0.0.0.0:7447.
    #[arg(long = "listen")]
    pub listen: Vec<String>,
    /// ROS domain id (the first segment of every key).
    #[arg(long, default_value_t = 0)]
    pub domain: u32,
    /// Enable Zenoh multicast scouting (off: discovery through the router only).
    #[arg(long)]
    pub multicast: bool,
    /// ROS namespace of every topic.
    #[arg(long, default_value = crate::topics::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Mutual TLS for `tls/` endpoints: the PEM certificate of the deployment's authority
    /// (as made by `avacraft certs`). Needs --tls-cert and --tls-key.
    #[arg(long, requires_all = ["tls_cert", "tls_key"])]
    pub tls_ca: Option<PathBuf>,
    /// This host's certificate (PEM); its common name is the host's name in access control.
    #[arg(long, requires = "tls_ca")]
    pub tls_cert: Option<PathBuf>,
    /// This host's private key (PEM).
    #[arg(long, requires = "tls_ca")]
    pub tls_key: Option<PathBuf>,
    /// Zenoh access control (the `access_control` JSON5 object) for a router; set by
    /// `avacraft launch` from the launch file, not a flag.
    #[arg(skip)]
    pub access_control: Option<String>,
}

impl NodeArgs {
    /// The flags that hand this node's TLS identity to a child process.
    pub fn tls_flags(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (flag, v) in [("--tls-ca", &self.tls_ca), ("--tls-cert", &self.tls_cert), ("--tls-key", &self.tls_key)] {
            if let Some(p) = v {
                out.push(flag.to_owned());
                out.push(p.display().to_string());
            }
        }
        out
    }
}

impl Default for NodeArgs {
    fn default() -> Self {
        Self {
            mode: SessionMode::Peer,
            connect: vec!["tcp/127.0.0.1:7447".to_owned()],
            connect_timeout_ms: 0,
            listen: Vec::new(),
            domain: 0,
            multicast: false,
            namespace: crate::topics::DEFAULT_NAMESPACE.to_owned(),
            tls_ca: None,
            tls_cert: None,
            tls_key: None,
            access_control: None,
        }
    }
}

/// Logs to stderr, filtered by `RUST_LOG` (default `info`, Zenoh's own at `warn`, RustDDS's
/// off: the bridge reports DDS failures itself). Safe to call more than once.
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=warn,zenoh_transport=warn,zenoh_link_tcp=warn,rustdds=off"));
    use std::io::IsTerminal;
    let ansi = std::io::stderr().is_terminal();
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_ansi(ansi).with_target(false).try_init();
}

/// Set when SIGINT or SIGTERM arrives; nodes check it between steps and shut down cleanly.
#[derive(Clone, Debug, Default)]
pub struct Shutdown(Arc<AtomicBool>);

impl Shutdown {
    /// Installs the signal handler (once per process; later calls share the first flag).
    pub fn install() -> Shutdown {
        static FLAG: std::sync::OnceLock<Shutdown> = std::sync::OnceLock::new();
        FLAG.get_or_init(|| {
            let s = Shutdown::default();
            let f = s.clone();
            if let Err(e) = ctrlc::set_handler(move || f.0.store(true, Ordering::SeqCst)) {
                tracing::warn!("no signal handler ({e}); stop with the process's own end");
            }
            s
        })
        .clone()
    }
    pub fn requested(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
    pub fn request(&self) {
        self.0.store(true, Ordering::SeqCst)
    }
}
