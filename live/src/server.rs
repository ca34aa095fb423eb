//! The Foxglove WebSocket server (subprotocol `foxglove.sdk.v1`, the foxglove crate's
//! message types; `foxglove.websocket.v1` too, the same protocol under the name Lichtblick,
//! Foxglove Studio 1.x and `@foxglove/ws-protocol` offer), with a thread per client.
//!
//! The loop is ours rather than the foxglove crate's server for two guarantees that server
//! does not give: a slow or stuck client's messages are dropped *and counted* (each client
//! has a bounded queue the simulation only ever `try_send`s into, and its thread only takes
//! from the queue once the socket has taken everything before), and a client that sends
//! something that is not the protocol is disconnected, with the reason logged and sent in
//! the close frame. Nothing the server does can block the caller of [`LiveServer::publish`].

use crate::channels::LiveChannel;
use foxglove::ws_protocol::client::ClientMessage;
use foxglove::ws_protocol::server::{Advertise, Channel, MessageData, ServerInfo};
use foxglove::ws_protocol::{BinaryMessage, JsonMessage};
use std::collections::BTreeMap;
use std::io::ErrorKind;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tungstenite::handshake::server::{Request, Response};
use tungstenite::protocol::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::{Message, WebSocket};

/// The WebSocket subprotocol the server speaks (Foxglove's SDK protocol, version 1: channel
/// advertisements carry their schemas inline).
pub const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// The same protocol under its name before Foxglove's SDK: what Lichtblick (the open-source
/// fork), Foxglove Studio 1.x and `@foxglove/ws-protocol`'s client offer. Taken when a
/// client does not offer [`SUBPROTOCOL`].
pub const LEGACY_SUBPROTOCOL: &str = "foxglove.websocket.v1";

/// Messages a client's queue holds before newer ones are dropped (about two seconds of a
/// battle's six channels at 22 steps per second).
pub const DEFAULT_BACKLOG: usize = 256;

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error("cannot listen on {addr}")]
    Bind {
        addr: SocketAddr,
        #[source]
        source: std::io::Error,
    },
    #[error("the channel advertisement")]
    Schema(#[source] foxglove::ws_protocol::schema::EncodeError),
}

/// What the server has done so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LiveStats {
    /// Clients that completed the handshake.
    pub clients: u64,
    /// Clients connected now.
    pub connected: u64,
    /// Messages delivered to a client's socket.
    pub sent: u64,
    /// Messages dropped because a client's queue was full (it read too slowly).
    pub dropped: u64,
    /// Clients disconnected for sending something that is not the protocol.
    pub refused: u64,
}

#[derive(Default)]
struct Counters {
    clients: AtomicU64,
    connected: AtomicU64,
    sent: AtomicU64,
    dropped: AtomicU64,
    refused: AtomicU64,
}

/// A connected client, as the publishing side sees it.
struct Client {
    tx: SyncSender<Vec<u8>>,
    /// Channel id to the client's subscription id.
    subs: Arc<Mutex<BTreeMap<u64, u32>>>,
    dropped: Arc<AtomicU64>,
    alive: Arc<AtomicBool>,
}

struct Shared {
    clients: Mutex<Vec<Client>>,
    stop: AtomicBool,
    counters: Counters,
    backlog: usize,
    /// The serverInfo and advertise messages every client gets first.
    hello: [String; 2],
}

/// A running server; stopped (its clients sent a close frame) when dropped.
pub struct LiveServer {
    addr: SocketAddr,
    shared: Arc<Shared>,
    accept: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer").field("addr", &self.addr).field("stats", &self.stats()).finish()
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl LiveServer {
    /// Listens on `addr` (port 0: any free port; see [`LiveServer::addr`]) and advertises
    /// every [`LiveChannel`] to each client. `name` is shown by Foxglove as the source.
    pub fn start(addr: SocketAddr, name: &str, backlog: usize) -> Result<LiveServer, LiveError> {
        let listener = TcpListener::bind(addr).map_err(|source| LiveError::Bind { addr, source })?;
        let local = listener.local_addr().map_err(|source| LiveError::Bind { addr, source })?;
        listener.set_nonblocking(true).map_err(|source| LiveError::Bind { addr, source })?;
        let mut channels = Vec::new();
        let topics = LiveChannel::ALL.map(LiveChannel::topic);
        for (c, topic) in LiveChannel::ALL.into_iter().zip(&topics) {
            let (schema_name, schema_encoding, data) = c.schema();
            let schema = foxglove::ws_protocol::schema::Schema::new(schema_name, schema_encoding, data);
            channels.push(Channel::builder(c.id(), topic.as_str(), c.encoding()).with_schema(schema).build().map_err(LiveError::Schema)?);
        }
        let hello = [ServerInfo::new(name).to_string(), Advertise::new(channels).to_string()];
        let shared = Arc::new(Shared {
            clients: Mutex::new(Vec::new()),
            stop: AtomicBool::new(false),
            counters: Counters::default(),
            backlog: backlog.max(1),
            hello,
        });
        let s = Arc::clone(&shared);
        let accept = std::thread::Builder::new()
            .name("foxglove-accept".into())
            .spawn(move || accept_loop(&listener, &s))
            .map_err(|source| LiveError::Bind { addr, source })?;
        tracing::info!("Foxglove live view on ws://{local} (open it in Foxglove or Lichtblick: Open connection, Foxglove WebSocket)");
        Ok(LiveServer { addr: local, shared, accept: Some(accept) })
    }

    /// The address the server listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Whether any client is subscribed to `ch` (so that nobody's frames are not drawn).
    pub fn wanted(&self, ch: LiveChannel) -> bool {
        lock(&self.shared.clients).iter().any(|c| c.alive.load(Ordering::Relaxed) && lock(&c.subs).contains_key(&ch.id()))
    }

    /// Hands `payload` (already encoded for `ch`) to every client subscribed to `ch`, stamped
    /// with `log_time` (nanoseconds). Never blocks: a client whose queue is full loses it,
    /// and the loss is counted.
    pub fn publish(&self, ch: LiveChannel, log_time: u64, payload: &[u8]) {
        let mut clients = lock(&self.shared.clients);
        clients.retain(|c| c.alive.load(Ordering::Relaxed));
        for c in clients.iter() {
            let Some(&sub) = lock(&c.subs).get(&ch.id()) else { continue };
            let msg = MessageData::new(sub, log_time, payload);
            let mut bytes = Vec::with_capacity(msg.encoded_len());
            msg.encode(&mut bytes);
            match c.tx.try_send(bytes) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => {
                    c.dropped.fetch_add(1, Ordering::Relaxed);
                    self.shared.counters.dropped.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Disconnected(_)) => c.alive.store(false, Ordering::Relaxed),
            }
        }
    }

    pub fn stats(&self) -> LiveStats {
        let c = &self.shared.counters;
        LiveStats {
            clients: c.clients.load(Ordering::Relaxed),
            connected: c.connected.load(Ordering::Relaxed),
            sent: c.sent.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
            refused: c.refused.load(Ordering::Relaxed),
        }
    }

    /// Waits up to `timeout` for `n` clients to be subscribed to `ch` (for callers that
    /// want a watcher before they start, e.g. `--foxglove-wait`).
    pub fn wait_for(&self, ch: LiveChannel, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        while Instant::now() < end {
            if self.wanted(ch) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        self.wanted(ch)
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.accept.take() {
            let _ = h.join();
        }
    }
}

fn accept_loop(listener: &TcpListener, shared: &Arc<Shared>) {
    let mut threads: Vec<JoinHandle<()>> = Vec::new();
    while !shared.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, addr)) => {
                let s = Arc::clone(shared);
                match std::thread::Builder::new().name(format!("foxglove-{addr}")).spawn(move || serve(stream, addr, &s)) {
                    Ok(h) => threads.push(h),
                    Err(e) => tracing::warn!("Foxglove client {addr}: no thread for it: {e}"),
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => {
                tracing::warn!("Foxglove server: accept failed: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
        threads.retain(|h| !h.is_finished());
    }
    for h in threads {
        let _ = h.join();
    }
}

/// The handshake: the client must offer [`SUBPROTOCOL`] (preferred) or [`LEGACY_SUBPROTOCOL`].
fn handshake(stream: TcpStream, addr: SocketAddr) -> Option<WebSocket<TcpStream>> {
    // The error type is tungstenite's callback signature, not ours to shrink.
    #[allow(clippy::result_large_err)]
    let pick = |req: &Request, mut resp: Response| {
        let offered: Vec<&str> = req
            .headers()
            .get_all("sec-websocket-protocol")
            .iter()
            .filter_map(|h| h.to_str().ok())
            .flat_map(|h| h.split(','))
            .map(str::trim)
            .collect();
        if let Some(p) = [SUBPROTOCOL, LEGACY_SUBPROTOCOL].into_iter().find(|p| offered.contains(p)) {
            resp.headers_mut().insert("sec-websocket-protocol", tungstenite::http::HeaderValue::from_static(p));
            Ok(resp)
        } else {
            let mut r = tungstenite::handshake::server::ErrorResponse::new(Some(format!(
                "offer the WebSocket subprotocol {SUBPROTOCOL} (or {LEGACY_SUBPROTOCOL})"
            )));
            *r.status_mut() = tungstenite::http::StatusCode::BAD_REQUEST;
            Err(r)
        }
    };
    match tungstenite::accept_hdr(stream, pick) {
        Ok(ws) => Some(ws),
        Err(e) => {
            tracing::warn!("Foxglove client {addr}: handshake refused: {e}");
            None
        }
    }
}

/// A client's thread: handshake, greeting, then its queue out and its requests in.
fn serve(stream: TcpStream, addr: SocketAddr, shared: &Arc<Shared>) {
    // The handshake gets a few seconds; afterwards reads wait briefly so the queue moves.
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_read_timeout(Some(Duration::from_secs(5)));
    let _ = stream.set_write_timeout(Some(Duration::from_secs(5)));
    let _ = stream.set_nodelay(true);
    let Some(mut ws) = handshake(stream, addr) else { return };
    let _ = ws.get_ref().set_read_timeout(Some(Duration::from_millis(10)));
    let _ = ws.get_ref().set_write_timeout(Some(Duration::from_millis(50)));
    let (tx, rx) = sync_channel::<Vec<u8>>(shared.backlog);
    let subs = Arc::new(Mutex::new(BTreeMap::new()));
    let dropped = Arc::new(AtomicU64::new(0));
    let alive = Arc::new(AtomicBool::new(true));
    for m in &shared.hello {
        if ws.send(Message::text(m.clone())).is_err() {
            return;
        }
    }
    shared.counters.clients.fetch_add(1, Ordering::Relaxed);
    shared.counters.connected.fetch_add(1, Ordering::Relaxed);
    lock(&shared.clients).push(Client { tx, subs: Arc::clone(&subs), dropped: Arc::clone(&dropped), alive: Arc::clone(&alive) });
    tracing::info!("Foxglove client {addr} connected");
    let why = client_loop(&mut ws, &rx, &subs, shared);
    alive.store(false, Ordering::Relaxed);
    shared.counters.connected.fetch_sub(1, Ordering::Relaxed);
    let lost = dropped.load(Ordering::Relaxed);
    match why {
        End::Garbage(reason) => {
            shared.counters.refused.fetch_add(1, Ordering::Relaxed);
            tracing::warn!("Foxglove client {addr}: disconnected: {reason} ({lost} messages dropped for it)");
            close(&mut ws, CloseCode::Policy, reason);
        }
        End::Stopped => {
            close(&mut ws, CloseCode::Away, "the server stops".into());
            tracing::info!("Foxglove client {addr}: closed, the server stops ({lost} messages dropped for it)");
        }
        End::Gone(e) => tracing::info!("Foxglove client {addr} left ({e}; {lost} messages dropped for it)"),
    }
}

/// Sends a close frame saying why, giving the socket half a second to take it.
fn close(ws: &mut WebSocket<TcpStream>, code: CloseCode, reason: String) {
    let _ = ws.close(Some(CloseFrame { code, reason: reason.into() }));
    let end = Instant::now() + Duration::from_millis(500);
    while Instant::now() < end && ws.flush().is_err_and(|e| would_block(&e)) {}
}

enum End {
    Garbage(String),
    Stopped,
    Gone(String),
}

fn would_block(e: &tungstenite::Error) -> bool {
    matches!(e, tungstenite::Error::Io(io) if matches!(io.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut))
}

/// Out: once the socket has taken everything before (so that a slow reader's backlog stays
/// in its bounded queue, where the publisher drops and counts), up to 64 queued messages go
/// to it. `None`: the socket is still busy; otherwise how many went (0: the queue is empty).
/// The error says why the connection is gone.
fn pump(ws: &mut WebSocket<TcpStream>, rx: &Receiver<Vec<u8>>, sent: &AtomicU64) -> Result<Option<usize>, String> {
    match ws.flush() {
        Ok(()) => {}
        Err(e) if would_block(&e) => return Ok(None),
        Err(e) => return Err(e.to_string()),
    }
    let mut n = 0;
    while n < 64 {
        let Ok(bytes) = rx.try_recv() else { break };
        n += 1;
        // A write that would block has queued the message in tungstenite's buffer.
        sent.fetch_add(1, Ordering::Relaxed);
        match ws.write(Message::binary(bytes)) {
            Ok(()) => {}
            Err(e) if would_block(&e) => break,
            Err(e) => return Err(e.to_string()),
        }
    }
    match ws.flush() {
        Err(e) if !would_block(&e) => Err(e.to_string()),
        _ => Ok(Some(n)),
    }
}

fn client_loop(ws: &mut WebSocket<TcpStream>, rx: &Receiver<Vec<u8>>, subs: &Mutex<BTreeMap<u64, u32>>, shared: &Shared) -> End {
    loop {
        if shared.stop.load(Ordering::Relaxed) {
            // What was published before the stop still goes out (for up to a second).
            let end = Instant::now() + Duration::from_secs(1);
            while Instant::now() < end {
                match pump(ws, rx, &shared.counters.sent) {
                    Ok(Some(0)) | Err(_) => break,
                    Ok(_) => {}
                }
            }
            return End::Stopped;
        }
        if let Err(e) = pump(ws, rx, &shared.counters.sent) {
            return End::Gone(e);
        }
        // In: subscriptions; anything that is not the protocol ends the connection.
        let msg = match ws.read() {
            Ok(m) => m,
            Err(e) if would_block(&e) => continue,
            Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => return End::Gone("closed".into()),
            Err(tungstenite::Error::Io(e)) => return End::Gone(e.to_string()),
            Err(e) => return End::Garbage(format!("not a WebSocket stream: {e}")),
        };
        let parsed = match &msg {
            Message::Text(t) => ClientMessage::parse_json(t.as_str()),
            Message::Binary(b) => ClientMessage::parse_binary(b),
            Message::Close(_) => return End::Gone("closed by the client".into()),
            _ => continue,
        };
        match parsed {
            Ok(ClientMessage::Subscribe(s)) => {
                let mut subs = lock(subs);
                for sub in s.subscriptions {
                    if LiveChannel::from_id(sub.channel_id).is_none() {
                        return End::Garbage(format!("subscribe: no channel {}", sub.channel_id));
                    }
                    subs.insert(sub.channel_id, sub.id);
                }
            }
            Ok(ClientMessage::Unsubscribe(u)) => lock(subs).retain(|_, id| !u.subscription_ids.contains(id)),
            // Requests for capabilities the server did not advertise are not answered.
            Ok(other) => tracing::debug!("Foxglove client: ignored {other:?}"),
            Err(e) => {
                let shown: String = match &msg {
                    Message::Text(t) => t.as_str().chars().take(60).collect(),
                    other => format!("{} bytes", other.len()),
                };
                return End::Garbage(format!("invalid message ({e}): {shown:?}"));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use foxglove::ws_protocol::client::{Subscribe, Subscription};
    use foxglove::ws_protocol::server::ServerMessage;
    use tungstenite::client::IntoClientRequest;

    type R = Result<(), Box<dyn std::error::Error>>;

    fn server(backlog: usize) -> Result<LiveServer, LiveError> {
        LiveServer::start(SocketAddr::from(([127, 0, 0, 1], 0)), "test", backlog)
    }

    fn connect(
        s: &LiveServer,
        protocol: Option<&str>,
    ) -> Result<WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>, Box<dyn std::error::Error>> {
        let mut req = format!("ws://{}", s.addr()).into_client_request()?;
        if let Some(p) = protocol {
            req.headers_mut().insert("sec-websocket-protocol", p.parse()?);
        }
        Ok(tungstenite::connect(req)?.0)
    }

    /// Reads the greeting and returns the advertised channels (id, topic).
    fn greeting(
        ws: &mut WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>,
    ) -> Result<Vec<(u64, String)>, Box<dyn std::error::Error>> {
        let info = ws.read()?;
        assert!(matches!(ServerMessage::parse_json(info.to_text()?)?, ServerMessage::ServerInfo(_)), "{info:?}");
        let adv = ws.read()?;
        let ServerMessage::Advertise(a) = ServerMessage::parse_json(adv.to_text()?)? else { return Err("no advertise".into()) };
        Ok(a.channels.iter().map(|c| (c.id, c.topic.to_string())).collect())
    }

    /// A client that got the greeting and is subscribed to `ch` (subscription `id`).
    fn subscribed(
        s: &LiveServer,
        id: u32,
        ch: LiveChannel,
    ) -> Result<WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>, Box<dyn std::error::Error>> {
        let mut ws = connect(s, Some(SUBPROTOCOL))?;
        greeting(&mut ws)?;
        ws.send(Message::text(Subscribe::new([Subscription { id, channel_id: ch.id() }]).to_string()))?;
        assert!(s.wait_for(ch, Duration::from_secs(10)));
        Ok(ws)
    }

    /// Reads until the server's close frame (what it says why).
    fn close_frame(ws: &mut WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>) -> Result<CloseFrame, Box<dyn std::error::Error>> {
        loop {
            match ws.read() {
                Ok(Message::Close(Some(f))) => return Ok(f),
                Ok(Message::Close(None)) => return Err("a close frame without a reason".into()),
                Ok(_) => {}
                Err(e) => return Err(format!("no close frame: {e}").into()),
            }
        }
    }

    #[test]
    fn a_client_without_the_subprotocol_is_refused() -> R {
        let s = server(8)?;
        assert!(connect(&s, None).is_err());
        assert!(connect(&s, Some("foxglove.websocket.v0")).is_err());
        assert!(connect(&s, Some("foxglove.sdk.v1.1")).is_err(), "schema tables are not spoken here");
        assert_eq!(s.stats().clients, 0);
        Ok(())
    }

    /// Lichtblick and Foxglove Studio 1.x offer the protocol's older name; a client offering
    /// both gets the SDK's.
    #[test]
    fn the_legacy_subprotocol_name_is_accepted_and_the_sdk_s_preferred() -> R {
        let s = server(8)?;
        let chosen = |offer: &str| -> Result<Option<String>, Box<dyn std::error::Error>> {
            let mut req = format!("ws://{}", s.addr()).into_client_request()?;
            req.headers_mut().insert("sec-websocket-protocol", offer.parse()?);
            let (mut ws, resp) = tungstenite::connect(req)?;
            greeting(&mut ws)?;
            Ok(resp.headers().get("sec-websocket-protocol").and_then(|h| h.to_str().ok()).map(str::to_owned))
        };
        assert_eq!(chosen(LEGACY_SUBPROTOCOL)?.as_deref(), Some(LEGACY_SUBPROTOCOL));
        assert_eq!(chosen(&format!("{LEGACY_SUBPROTOCOL}, {SUBPROTOCOL}"))?.as_deref(), Some(SUBPROTOCOL));
        Ok(())
    }

    #[test]
    fn a_subscriber_gets_what_is_published_on_its_channels_only() -> R {
        let s = server(8)?;
        let mut ws = connect(&s, Some(SUBPROTOCOL))?;
        let channels = greeting(&mut ws)?;
        assert_eq!(channels.len(), LiveChannel::ALL.len());
        assert!(channels.contains(&(LiveChannel::Status.id(), LiveChannel::Status.topic().to_string())));
        ws.send(Message::text(Subscribe::new([Subscription { id: 7, channel_id: LiveChannel::Status.id() }]).to_string()))?;
        assert!(s.wait_for(LiveChannel::Status, Duration::from_secs(10)));
        assert!(!s.wanted(LiveChannel::Screen));
        s.publish(LiveChannel::Screen, 5, b"not for you");
        s.publish(LiveChannel::Status, 42, b"{\"step\":1}");
        let m = ws.read()?;
        let Message::Binary(b) = m else { return Err(format!("{m:?}").into()) };
        // opcode 1, subscription id, log time, payload (the protocol's MessageData).
        assert_eq!(b[0], 1);
        assert_eq!(u32::from_le_bytes([b[1], b[2], b[3], b[4]]), 7);
        assert_eq!(u64::from_le_bytes(b[5..13].try_into()?), 42);
        assert_eq!(&b[13..], b"{\"step\":1}");
        Ok(())
    }

    #[test]
    fn what_was_published_before_the_server_stops_still_arrives() -> R {
        let s = server(64)?;
        let mut ws = subscribed(&s, 2, LiveChannel::Status)?;
        for t in 0..50 {
            s.publish(LiveChannel::Status, t, b"{}");
        }
        drop(s);
        let mut got = 0;
        while let Ok(m) = ws.read() {
            got += usize::from(m.is_binary());
        }
        assert_eq!(got, 50);
        Ok(())
    }

    #[test]
    fn a_client_sending_garbage_is_disconnected_with_the_reason() -> R {
        let s = server(8)?;
        let mut ws = connect(&s, Some(SUBPROTOCOL))?;
        greeting(&mut ws)?;
        ws.send(Message::text("hello, server"))?;
        let why = close_frame(&mut ws)?;
        assert_eq!(why.code, CloseCode::Policy);
        assert!(why.reason.contains("invalid message") && why.reason.contains("hello, server"), "{}", why.reason);
        // And a subscription to a channel that does not exist.
        let mut ws = connect(&s, Some(SUBPROTOCOL))?;
        greeting(&mut ws)?;
        ws.send(Message::text(Subscribe::new([Subscription { id: 1, channel_id: 999 }]).to_string()))?;
        assert!(close_frame(&mut ws)?.reason.contains("no channel 999"));
        let end = Instant::now() + Duration::from_secs(10);
        while s.stats().refused < 2 && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(s.stats().refused, 2);
        Ok(())
    }

    #[test]
    fn a_client_that_does_not_read_loses_messages_and_they_are_counted() -> R {
        let s = server(4)?;
        let _ws = subscribed(&s, 1, LiveChannel::Screen)?;
        // The client never reads: the socket buffers fill, then its queue, then messages
        // are dropped, while publish goes on returning.
        let big = vec![7u8; 1 << 20];
        let n = 400;
        for t in 0..n {
            s.publish(LiveChannel::Screen, t, &big);
        }
        let st = s.stats();
        assert!(st.dropped > 0, "{st:?}");
        assert!(st.dropped + st.sent <= n + 4, "{st:?}");
        // A second, reading client is not held back by the stuck one.
        let mut other = subscribed(&s, 3, LiveChannel::Log)?;
        s.publish(LiveChannel::Log, 1, b"x");
        assert!(matches!(other.read()?, Message::Binary(b) if b.ends_with(b"x")));
        Ok(())
    }
}
