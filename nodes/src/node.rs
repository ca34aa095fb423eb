//! A node: one Zenoh session, its liveliness token, and typed publishers and subscribers
//! that follow rmw_zenoh's conventions, so ROS 2 Jazzy tools see every topic.

use crate::cli::NodeArgs;
use crate::ros::{self, EntityKind, NodeIdentity, Qos};
use crate::topics::{NodeName, Topic, TopicPattern};
use avacraft_msgs::{DecodeError, RosMessage, decode, encode};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;
use zenoh::Wait;
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;

/// What can go wrong in the middleware layer.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error("zenoh configuration `{key}` = {value}")]
    Config {
        key: String,
        value: String,
        #[source]
        source: zenoh::Error,
    },
    #[error("cannot open the Zenoh session ({mode} mode, connect {connect:?}, listen {listen:?})")]
    Open {
        mode: String,
        connect: Vec<String>,
        listen: Vec<String>,
        #[source]
        source: zenoh::Error,
    },
    #[error("cannot declare {what} on `{key}`")]
    Declare {
        what: &'static str,
        key: String,
        #[source]
        source: zenoh::Error,
    },
    #[error("cannot publish on `{key}`")]
    Put {
        key: String,
        #[source]
        source: zenoh::Error,
    },
    #[error("the subscription on `{key}` was closed")]
    Closed { key: String },
}

fn cfg_err(key: &str, value: &str, e: impl Into<zenoh::Error>) -> NodeError {
    NodeError::Config { key: key.to_owned(), value: value.to_owned(), source: e.into() }
}

/// A copy of a message a node sent or received, for a recorder in the same process: its data
/// key (topic, type and hash, as on the wire), its bytes and when its sender sent it.
#[derive(Debug)]
pub struct Tapped {
    pub key: String,
    pub payload: Vec<u8>,
    pub sent_ns: i64,
}

/// Where a node's taps go ([`Node::with_tap`]).
pub type Tap = std::sync::mpsc::Sender<Tapped>;

/// An open node.
pub struct Node {
    session: zenoh::Session,
    id: NodeIdentity,
    next_entity: AtomicU32,
    tap: Option<Tap>,
    _token: LivelinessToken,
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node").field("id", &self.id).finish()
    }
}

/// Builds a Zenoh configuration from the common flags.
pub fn zenoh_config(args: &NodeArgs) -> Result<zenoh::Config, NodeError> {
    let mut c = zenoh::Config::default();
    let mut set = |k: &str, v: String| c.insert_json5(k, &v).map_err(|e| cfg_err(k, &v, e));
    set("mode", format!("\"{}\"", args.mode.name()))?;
    let list = |v: &[String]| format!("[{}]", v.iter().map(|e| format!("\"{e}\"")).collect::<Vec<_>>().join(","));
    if !args.connect.is_empty() {
        set("connect/endpoints", list(&args.connect))?;
    }
    if args.connect_timeout_ms != 0 {
        if args.connect_timeout_ms < -1 {
            return Err(cfg_err("--connect-timeout-ms", &args.connect_timeout_ms.to_string(), "must be -1, 0 or a positive number"));
        }
        set("connect/timeout_ms", args.connect_timeout_ms.to_string())?;
    }
    if !args.listen.is_empty() {
        set("listen/endpoints", list(&args.listen))?;
    }
    // Discovery goes through the router by default (as rmw_zenoh does); multicast scouting
    // is opt-in so tests and CI never reach other machines.
    set("scouting/multicast/enabled", args.multicast.to_string())?;
    if let (Some(ca), Some(cert), Some(key)) = (&args.tls_ca, &args.tls_cert, &args.tls_key) {
        for (what, p) in [("--tls-ca", ca), ("--tls-cert", cert), ("--tls-key", key)] {
            if !p.is_file() {
                return Err(cfg_err(what, &p.display().to_string(), "no such file"));
            }
        }
        let s = |p: &std::path::Path| serde_json::Value::String(p.display().to_string()).to_string();
        set("transport/link/tls/root_ca_certificate", s(ca))?;
        // The same identity for both directions: a router proves itself to connecting hosts,
        // and every host proves itself to the router (mutual TLS), whose access control
        // then knows it by its certificate's common name.
        set("transport/link/tls/listen_certificate", s(cert))?;
        set("transport/link/tls/listen_private_key", s(key))?;
        set("transport/link/tls/connect_certificate", s(cert))?;
        set("transport/link/tls/connect_private_key", s(key))?;
        set("transport/link/tls/enable_mtls", "true".into())?;
    }
    if let Some(acl) = &args.access_control {
        set("access_control", acl.clone())?;
    }
    Ok(c)
}

impl Node {
    /// Opens a session and announces the node `name` under the ROS namespace `namespace`.
    pub fn open(args: &NodeArgs, namespace: &str, name: &NodeName) -> Result<Node, NodeError> {
        let config = zenoh_config(args)?;
        let session = zenoh::open(config).wait().map_err(|e| NodeError::Open {
            mode: args.mode.name().to_owned(),
            connect: args.connect.clone(),
            listen: args.listen.clone(),
            source: e,
        })?;
        let id = NodeIdentity {
            domain: args.domain,
            zid: session.zid().to_string(),
            node_id: 0,
            namespace: namespace.to_owned(),
            name: name.as_str().to_owned(),
        };
        let key = id.node_token();
        let token = session.liveliness().declare_token(key.clone()).wait().map_err(|e| NodeError::Declare {
            what: "a node liveliness token",
            key,
            source: e,
        })?;
        Ok(Node { session, id, next_entity: AtomicU32::new(1), tap: None, _token: token })
    }

    /// Every message this node's publishers and subscribers made from now on send or take is
    /// also handed to `tap` (the simulator recording its own traffic, instead of a second
    /// subscriber to each of its messages in another process).
    pub fn with_tap(mut self, tap: Tap) -> Node {
        self.tap = Some(tap);
        self
    }

    pub fn identity(&self) -> &NodeIdentity {
        &self.id
    }
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }

    fn token(&self, kind: EntityKind, topic: &Topic, dds: &str, hash: &str, qos: Qos) -> Result<(String, LivelinessToken), NodeError> {
        let entity = self.next_entity.fetch_add(1, Ordering::Relaxed);
        let key = self.id.endpoint_token(entity, kind, topic, dds, hash, qos);
        let token = self.session.liveliness().declare_token(key.clone()).wait().map_err(|e| NodeError::Declare {
            what: "an endpoint liveliness token",
            key: key.clone(),
            source: e,
        })?;
        Ok((key, token))
    }

    /// Every liveliness token of the domain alive now (nodes and endpoints).
    pub fn alive_tokens(&self, timeout: Duration) -> Result<Vec<String>, NodeError> {
        let key = ros::liveliness_space(self.id.domain);
        let replies = self.session.liveliness().get(key.clone()).timeout(timeout).wait().map_err(|e| NodeError::Declare {
            what: "a liveliness query",
            key,
            source: e,
        })?;
        let mut out = Vec::new();
        while let Ok(r) = replies.recv() {
            if let Ok(s) = r.result() {
                out.push(s.key_expr().as_str().to_owned());
            }
        }
        Ok(out)
    }

    /// Announces a subscription made outside [`Node::subscriber`] (the recorder's raw one),
    /// so others can wait for it.
    pub fn announce_subscription(&self, topic: &Topic, dds: &str, hash: &str) -> Result<LivelinessToken, NodeError> {
        self.token(EntityKind::Subscription, topic, dds, hash, Qos::Reliable { depth: 10 }).map(|(_, t)| t)
    }

    /// Names of the ROS nodes in this node's namespace alive now (from their tokens).
    pub fn alive_nodes(&self, timeout: Duration) -> Result<std::collections::BTreeSet<String>, NodeError> {
        let ns = ros::mangle(&self.id.namespace);
        Ok(self
            .alive_tokens(timeout)?
            .iter()
            .filter_map(|t| ros::parse_token(t))
            .filter(|t| t.kind == ros::TokenKind::Node && t.namespace == ns)
            .map(|t| t.node)
            .collect())
    }

    /// A publisher of `T` on `topic`.
    pub fn publisher<T: RosMessage>(&self, topic: &Topic, qos: Qos) -> Result<Publisher<T>, NodeError> {
        let (dds, hash) = (T::dds_type_name(), T::type_hash());
        let key = ros::data_key(self.id.domain, topic, dds, hash);
        let (token_key, token) = self.token(EntityKind::Publisher, topic, dds, hash, qos)?;
        // rmw_zenoh maps RELIABLE to congestion control BLOCK and BEST_EFFORT to DROP (the
        // transport itself is reliable TCP either way).
        let cc = match qos {
            Qos::Reliable { .. } => CongestionControl::Block,
            Qos::BestEffort { .. } => CongestionControl::Drop,
        };
        let inner = self.session.declare_publisher(key.clone()).congestion_control(cc).wait().map_err(|e| NodeError::Declare {
            what: "a publisher",
            key: key.clone(),
            source: e,
        })?;
        Ok(Publisher {
            inner,
            key,
            topic: topic.clone(),
            seq: 0,
            gid: ros::gid(&token_key),
            tap: self.tap.clone(),
            _token: token,
            _t: PhantomData,
        })
    }

    /// A subscription to `T` on a topic or a pattern of topics (every agent's actions);
    /// each sample says which topic it came on.
    pub fn subscriber<T: RosMessage>(&self, topic: impl Into<TopicPattern>, qos: Qos) -> Result<Subscriber<T>, NodeError> {
        let topic = topic.into();
        let (dds, hash) = (T::dds_type_name(), T::type_hash());
        let key = ros::pattern_key(self.id.domain, &topic, dds, hash);
        // A pattern is announced under its name with '*' shown as `any`, a valid ROS name.
        let (_, token) = self.token(EntityKind::Subscription, &topic.shown(), dds, hash, qos)?;
        let err = |e: zenoh::Error| NodeError::Declare { what: "a subscriber", key: key.clone(), source: e };
        // Reliable: a deep queue that holds the sender back when full. Best effort (frames):
        // a ring of `depth` that drops the oldest, so a slow reader never queues stale frames
        // or pushes back on the router.
        let inner = match qos {
            Qos::Reliable { .. } => {
                Inner::Fifo(self.session.declare_subscriber(key.clone()).with(zenoh::handlers::FifoChannel::new(4096)).wait().map_err(err)?)
            }
            Qos::BestEffort { depth } => Inner::Ring(
                self.session
                    .declare_subscriber(key.clone())
                    .with(zenoh::handlers::RingChannel::new(depth.max(1) as usize))
                    .wait()
                    .map_err(err)?,
            ),
        };
        Ok(Subscriber {
            inner,
            key,
            foreign_keys: std::sync::atomic::AtomicU64::new(0),
            tap: self.tap.clone(),
            _token: token,
            _t: PhantomData,
        })
    }
}

/// Publishes `T` with rmw_zenoh's attachment (sequence number, source time, GID).
pub struct Publisher<T> {
    inner: zenoh::pubsub::Publisher<'static>,
    key: String,
    topic: Topic,
    seq: i64,
    gid: [u8; 16],
    tap: Option<Tap>,
    _token: LivelinessToken,
    _t: PhantomData<fn(T)>,
}

impl<T> std::fmt::Debug for Publisher<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Publisher").field("key", &self.key).field("seq", &self.seq).finish()
    }
}

/// Nanoseconds since the Unix epoch: the source timestamp of the attachment (wall time is
/// fine here; the simulation never reads it).
pub fn now_ns() -> i64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as i64)
}

impl<T: RosMessage> Publisher<T> {
    pub fn put(&mut self, msg: &T) -> Result<(), NodeError> {
        self.put_bytes(encode(msg))
    }
    /// Publishes already encoded bytes (the recorder and tests of malformed input use it).
    pub fn put_bytes(&mut self, payload: Vec<u8>) -> Result<(), NodeError> {
        self.seq += 1;
        let sent_ns = now_ns();
        let att = ros::attachment(self.seq, sent_ns, &self.gid);
        if let Some(tap) = &self.tap {
            // A recorder that has stopped takes nothing more; the message still goes out.
            let _ = tap.send(Tapped { key: self.key.clone(), payload: payload.clone(), sent_ns });
        }
        self.inner.put(payload).attachment(att.to_vec()).wait().map_err(|e| NodeError::Put { key: self.key.clone(), source: e })
    }
    pub fn key(&self) -> &str {
        &self.key
    }
    /// The ROS topic this publisher serves.
    pub fn topic(&self) -> &Topic {
        &self.topic
    }
}

/// One received sample: its topic, its raw payload, and the decoded message or why not.
#[derive(Debug)]
pub struct Received<T> {
    pub topic: Topic,
    pub payload: Vec<u8>,
    pub attachment: Option<ros::Attachment>,
    pub msg: Result<T, DecodeError>,
}

enum Inner {
    Fifo(zenoh::pubsub::Subscriber<FifoChannelHandler<Sample>>),
    Ring(zenoh::pubsub::Subscriber<zenoh::handlers::RingChannelHandler<Sample>>),
}

impl Inner {
    fn recv_timeout(&self, timeout: Duration) -> zenoh::Result<Option<Sample>> {
        match self {
            Inner::Fifo(s) => s.recv_timeout(timeout),
            Inner::Ring(s) => s.recv_timeout(timeout),
        }
    }
    fn try_recv(&self) -> zenoh::Result<Option<Sample>> {
        match self {
            Inner::Fifo(s) => s.try_recv(),
            Inner::Ring(s) => s.try_recv(),
        }
    }
}

/// A typed subscription.
pub struct Subscriber<T> {
    inner: Inner,
    key: String,
    /// Samples whose key was not a valid data key (a segment a pattern matched that is not a
    /// ROS name): dropped, never handed out.
    foreign_keys: std::sync::atomic::AtomicU64,
    tap: Option<Tap>,
    _token: LivelinessToken,
    _t: PhantomData<fn() -> T>,
}

impl<T> std::fmt::Debug for Subscriber<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Subscriber").field("key", &self.key).finish()
    }
}

impl<T: RosMessage> Subscriber<T> {
    fn convert(&self, s: Sample) -> Option<Received<T>> {
        let Some(key) = ros::parse_data_key(s.key_expr().as_str()) else {
            self.foreign_keys.fetch_add(1, Ordering::Relaxed);
            return None;
        };
        let payload = s.payload().to_bytes().into_owned();
        let attachment = s.attachment().and_then(|a| ros::parse_attachment(&a.to_bytes()));
        if let Some(tap) = &self.tap {
            let sent_ns = attachment.as_ref().map_or_else(now_ns, |a| a.source_ns);
            let _ = tap.send(Tapped { key: s.key_expr().as_str().to_owned(), payload: payload.clone(), sent_ns });
        }
        Some(Received { topic: key.topic, msg: decode(&payload), payload, attachment })
    }
    /// Waits up to `timeout` for a sample; `Ok(None)` on timeout.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Option<Received<T>>, NodeError> {
        let end = std::time::Instant::now() + timeout;
        loop {
            let left = end.saturating_duration_since(std::time::Instant::now());
            match self.inner.recv_timeout(left) {
                Ok(Some(s)) => match self.convert(s) {
                    Some(r) => return Ok(Some(r)),
                    None if left.is_zero() => return Ok(None),
                    None => continue,
                },
                Ok(None) => return Ok(None),
                Err(_) => return Err(NodeError::Closed { key: self.key.clone() }),
            }
        }
    }
    /// A sample if one is waiting.
    pub fn try_recv(&self) -> Result<Option<Received<T>>, NodeError> {
        loop {
            match self.inner.try_recv() {
                Ok(Some(s)) => {
                    if let Some(r) = self.convert(s) {
                        return Ok(Some(r));
                    }
                }
                Ok(None) => return Ok(None),
                Err(_) => return Err(NodeError::Closed { key: self.key.clone() }),
            }
        }
    }
    /// Samples dropped because their key was not a data key of this deployment.
    pub fn foreign_keys(&self) -> u64 {
        self.foreign_keys.load(Ordering::Relaxed)
    }
    pub fn key(&self) -> &str {
        &self.key
    }
}
