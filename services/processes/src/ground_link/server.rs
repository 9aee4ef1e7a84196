//! The ground link's server: one TCP port for the ground page (HTTP GET) and the Foxglove
//! WebSocket protocol (an HTTP upgrade), plain or, with `ground.tls_cert`, TLS only
//! (`https://`, `wss://`). One thread accepts; each connection has its own thread (a
//! synchronous server: no async runtime in a flight-platform process). The bus stays on the
//! node's thread: it hands each viewer its messages through the viewer's bounded queue
//! (`try_send`, what does not fit is dropped and counted), and viewers hand commands to it
//! through another bounded queue. Nothing here can block the node.
//!
//! A connection's role is decided at its handshake: with the run's command token on its URL
//! (`?token=`) it may command, without one it watches; a wrong token is refused there.

use super::command::{self, Decimator, Limits, Malformed, RateLimit, Role};
use super::protocol::{self, BadMessage, Channel, ClientMessage};
use ipc_types::{GroundAckStatus, GroundCommand, GroundCommandAck, SampleHeader};
use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use testbed_config::GroundConfig;
use tungstenite::protocol::frame::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{Role as WsRole, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// The ground page, embedded: no internet and no files needed at run time.
const PAGE: &[(&str, &str, &str)] = &[
    (
        "/",
        "text/html; charset=utf-8",
        include_str!("../../ground-page/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_str!("../../ground-page/app.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_str!("../../ground-page/style.css"),
    ),
    // uPlot 1.6.32 (MIT), from npm's `uplot` package, unmodified (tests/js checks it).
    (
        "/uPlot.iife.min.js",
        "text/javascript; charset=utf-8",
        include_str!("../../ground-page/vendor/uPlot.iife.min.js"),
    ),
    (
        "/uPlot.min.css",
        "text/css; charset=utf-8",
        include_str!("../../ground-page/vendor/uPlot.min.css"),
    ),
];

/// Largest HTTP request head read, bytes.
const MAX_REQUEST_HEAD: usize = 8192;
/// How long a viewer thread waits for input before it looks at its queue again.
const POLL: Duration = Duration::from_millis(20);
/// Least wall time between two `time` messages to a viewer (the page and Foxglove draw at a
/// few hertz; the run clock moves in 100-ms control steps).
const TIME_PERIOD: Duration = Duration::from_millis(100);
/// How long a connection being closed gets to read the close frame (and answer it) before its
/// socket is closed: closing a socket with unread input resets it, and the peer may then never
/// see the close frame.
const LINGER: Duration = Duration::from_secs(1);
/// How long [`Server::stop`] waits for the viewers' threads to send their close frames.
const STOP_WAIT: Duration = Duration::from_secs(2);
/// First byte of a TLS record holding a handshake (the ClientHello).
const TLS_HANDSHAKE: u8 = 0x16;

/// What a viewer hands the node.
#[derive(Debug, Clone)]
pub enum ToBus {
    /// An accepted command, to publish for the controller.
    Command(GroundCommand),
    /// A rejection decided by the link, to publish (and log). Boxed: with its 256-byte reason
    /// it is four times a command.
    Ack(Box<GroundCommandAck>),
}

/// A message for one viewer.
enum Outgoing {
    Text(String),
    /// A `messageData` frame and its sample's stamp (run clock, ns) for the latency, if the
    /// stamp is on the run clock.
    Data(Vec<u8>, Option<u64>),
}

/// Counters of the link (served at `/stats` and on `testbed/ground/link`).
#[derive(Debug, Default)]
pub struct Stats {
    pub viewers: AtomicU64,
    pub connections: AtomicU64,
    pub sent: AtomicU64,
    pub sent_bytes: AtomicU64,
    pub dropped: AtomicU64,
    pub bad_messages: AtomicU64,
    pub oversized: AtomicU64,
    pub commands_forwarded: AtomicU64,
    pub commands_rejected: AtomicU64,
    pub rate_limited: AtomicU64,
    pub refused_viewers: AtomicU64,
    /// Handshakes refused: a wrong command token, a plain connection to the TLS link, a
    /// failed TLS handshake.
    pub refused_handshakes: AtomicU64,
    /// Advertisements and commands of watching connections, refused.
    pub refused_watch_only: AtomicU64,
    pub latency: Latency,
}

impl Stats {
    pub fn to_json(&self) -> serde_json::Value {
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        serde_json::json!({
            "viewers": g(&self.viewers),
            "connections": g(&self.connections),
            "sent": g(&self.sent),
            "sent_bytes": g(&self.sent_bytes),
            "dropped": g(&self.dropped),
            "bad_messages": g(&self.bad_messages),
            "oversized": g(&self.oversized),
            "commands_forwarded": g(&self.commands_forwarded),
            "commands_rejected": g(&self.commands_rejected),
            "rate_limited": g(&self.rate_limited),
            "refused_viewers": g(&self.refused_viewers),
            "refused_handshakes": g(&self.refused_handshakes),
            "refused_watch_only": g(&self.refused_watch_only),
            "latency_ms": self.latency.to_json(),
        })
    }
}

fn add(counter: &AtomicU64, n: u64) {
    counter.fetch_add(n, Ordering::Relaxed);
}

/// Stamped-to-sent latency: from a sample's stamp (its header time, run clock) to the moment
/// its frame is written to a viewer's socket. The run clock is mapped to wall time by the
/// node ([`Latency::observe_stamp`]): the smallest gap between a stamp and the wall time the
/// link drained it, over the last two windows of [`Latency::WINDOW`] (a paced run's clock
/// keeps to the wall clock but may fall behind it under load, measured 4 ms/s: the short
/// window follows that drift, and a drain of every topic every 100 ms gives it samples
/// drained just after they were published). Only paced runs have it: a
/// lockstep run's clock is not wall time.
#[derive(Debug, Default)]
pub struct Latency {
    /// Whether the run clock follows wall time (a paced run).
    paced: AtomicBool,
    /// Smallest `wall − stamp` seen, ns: this window, the previous one.
    offset_now: AtomicU64,
    offset_before: AtomicU64,
    window_start_ns: AtomicU64,
    /// Over the current report period: sum and count (for the mean) and the largest, µs.
    sum_us: AtomicU64,
    count: AtomicU64,
    max_us: AtomicU64,
    /// The last report period's mean and largest, µs (`u64::MAX`: none).
    last_mean_us: AtomicU64,
    last_max_us: AtomicU64,
}

impl Latency {
    /// The window of the stamp-to-wall offset, ns.
    pub const WINDOW: u64 = 2_000_000_000;

    pub fn set_paced(&self, paced: bool) {
        self.paced.store(paced, Ordering::Relaxed);
        self.offset_now.store(u64::MAX, Ordering::Relaxed);
        self.offset_before.store(u64::MAX, Ordering::Relaxed);
        self.last_mean_us.store(u64::MAX, Ordering::Relaxed);
        self.last_max_us.store(u64::MAX, Ordering::Relaxed);
    }

    /// A sample stamped `stamp_ns` (run clock) drained at wall time `wall_ns`. Node thread:
    /// a few atomic operations.
    pub fn observe_stamp(&self, stamp_ns: u64, wall_ns: u64) {
        if !self.paced.load(Ordering::Relaxed) {
            return;
        }
        let gap = wall_ns.saturating_sub(stamp_ns);
        if wall_ns.saturating_sub(self.window_start_ns.load(Ordering::Relaxed)) > Self::WINDOW {
            self.window_start_ns.store(wall_ns, Ordering::Relaxed);
            let now = self.offset_now.swap(gap, Ordering::Relaxed);
            self.offset_before.store(now, Ordering::Relaxed);
        } else {
            self.offset_now.fetch_min(gap, Ordering::Relaxed);
        }
    }

    /// A frame of a sample stamped `stamp_ns` written to a socket at wall time `wall_ns`.
    fn sent(&self, stamp_ns: u64, wall_ns: u64) {
        let offset = self
            .offset_now
            .load(Ordering::Relaxed)
            .min(self.offset_before.load(Ordering::Relaxed));
        if offset == u64::MAX {
            return;
        }
        let us = wall_ns.saturating_sub(stamp_ns.saturating_add(offset)) / 1000;
        self.sum_us.fetch_add(us, Ordering::Relaxed);
        self.count.fetch_add(1, Ordering::Relaxed);
        self.max_us.fetch_max(us, Ordering::Relaxed);
    }

    /// Ends a report period (the node, every second): its mean and largest become the ones
    /// reported.
    pub fn roll(&self) {
        let sum = self.sum_us.swap(0, Ordering::Relaxed);
        let count = self.count.swap(0, Ordering::Relaxed);
        let max = self.max_us.swap(0, Ordering::Relaxed);
        let (mean, max) = sum
            .checked_div(count)
            .map_or((u64::MAX, u64::MAX), |mean| (mean, max));
        self.last_mean_us.store(mean, Ordering::Relaxed);
        self.last_max_us.store(max, Ordering::Relaxed);
    }

    /// `{"mean": ms, "max": ms}` over the last second of sending, or nulls (nothing sent, or
    /// a lockstep run).
    pub fn to_json(&self) -> serde_json::Value {
        let ms = |a: &AtomicU64| match a.load(Ordering::Relaxed) {
            u64::MAX => serde_json::Value::Null,
            us => (us as f64 / 1000.0).into(),
        };
        serde_json::json!({"mean": ms(&self.last_mean_us), "max": ms(&self.last_max_us)})
    }
}

/// One connected viewer, as the node sees it.
struct Viewer {
    id: u32,
    queue: SyncSender<Outgoing>,
    /// Channel id → subscription id.
    subscriptions: HashMap<u32, u32>,
    decimator: Decimator,
    dropped: u64,
}

/// What the server's threads and the node share.
pub struct Shared {
    viewers: Mutex<Vec<Viewer>>,
    pub stats: Stats,
    /// The newest sample time the node has seen, ns (the header time of link commands).
    pub now_ns: AtomicU64,
    /// See [`Settings::start_time_ns`].
    pub start_time_ns: u64,
    shutdown: AtomicBool,
    next_viewer: AtomicU32,
    next_sequence: AtomicU64,
    /// Connection threads running (the server's stop waits for them to close).
    live: AtomicUsize,
}

impl Shared {
    fn viewers(&self) -> MutexGuard<'_, Vec<Viewer>> {
        // A viewer thread that panicked holding the lock leaves consistent data (plain
        // inserts and removes): go on with it.
        self.viewers
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Whether any viewer is connected (the node skips encoding what no one would get).
    pub fn has_viewers(&self) -> bool {
        !self.viewers().is_empty()
    }

    /// The header of a message the link itself makes.
    pub fn header(&self) -> SampleHeader {
        SampleHeader::new(
            self.now_ns.load(Ordering::Relaxed),
            self.next_sequence.fetch_add(1, Ordering::Relaxed) + 1,
            SampleHeader::VALID,
        )
    }

    /// Hands a message of channel `channel` at `time_ns` (run clock) to every viewer
    /// subscribed to it, decimated (`decimate`) per viewer and `source` (a sample's source id).
    /// `stamped`: `time_ns` is a sample's stamp, counted in the latency (heartbeats and the
    /// link's own status are not). Never blocks.
    pub fn broadcast(
        &self,
        channel: u32,
        source: u32,
        decimate: bool,
        time_ns: u64,
        stamped: bool,
        payload: &[u8],
    ) {
        let now = Instant::now();
        let mut viewers = self.viewers();
        for viewer in viewers.iter_mut() {
            let Some(&subscription) = viewer.subscriptions.get(&channel) else {
                continue;
            };
            if decimate && !viewer.decimator.pass((channel, source), now) {
                continue;
            }
            let log_time = self.start_time_ns.saturating_add(time_ns);
            let frame = protocol::message_data(subscription, log_time, payload);
            let len = frame.len() as u64;
            match viewer
                .queue
                .try_send(Outgoing::Data(frame, stamped.then_some(time_ns)))
            {
                Ok(()) => {
                    add(&self.stats.sent, 1);
                    add(&self.stats.sent_bytes, len);
                }
                Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                    viewer.dropped += 1;
                    add(&self.stats.dropped, 1);
                }
            }
        }
    }

    /// Sends a status text to viewer `id`, or to every viewer (`None`). Never blocks.
    pub fn status_to(&self, id: Option<u32>, text: &str) {
        for viewer in self.viewers().iter_mut() {
            if id.is_none_or(|id| id == viewer.id)
                && viewer
                    .queue
                    .try_send(Outgoing::Text(text.to_owned()))
                    .is_err()
            {
                viewer.dropped += 1;
                add(&self.stats.dropped, 1);
            }
        }
    }

    /// Counts and logs a refused handshake of `peer`.
    fn refuse_handshake(&self, peer: SocketAddr, why: &str) {
        add(&self.stats.refused_handshakes, 1);
        tracing::warn!(%peer, "ground link: handshake refused: {why}");
    }
}

/// The server's fixed settings.
pub struct Settings {
    pub channels: Vec<Channel>,
    /// Wall-clock start of the run, ns since the Unix epoch: message times are this plus the
    /// run clock, as in the run log.
    pub start_time_ns: u64,
    pub metadata: serde_json::Value,
    /// The run configuration as read-only parameters (`getParameters`), secrets left out.
    pub parameters: Vec<(String, serde_json::Value)>,
    pub limits: Limits,
    /// Where to listen, viewer rates and queues, command rate (`[ground]` of the run).
    pub ground: GroundConfig,
    /// TLS (`ground.tls_cert`): every connection must be TLS; `None`: plain.
    pub tls: Option<Arc<rustls::ServerConfig>>,
    /// Where commands go: the node's queue.
    pub to_bus: SyncSender<ToBus>,
    /// The channel viewers publish commands on.
    pub command_topic: &'static str,
}

/// The running server.
pub struct Server {
    pub addr: SocketAddr,
    pub shared: Arc<Shared>,
    accept: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Listens on `ground.bind:ground.port`; if that port is taken, on a free one (said in a
    /// warning).
    pub fn start(settings: Settings) -> std::io::Result<Self> {
        let (bind, port) = (settings.ground.bind.as_str(), settings.ground.port);
        let listener = match TcpListener::bind((bind, port)) {
            Ok(l) => l,
            Err(e) if e.kind() == ErrorKind::AddrInUse && port != 0 => {
                // Said at info: `testbed run` prints the address actually served.
                tracing::info!(
                    "ground link: port {port} is in use (another run?): serving on a free port instead"
                );
                TcpListener::bind((bind, 0))?
            }
            Err(e) => return Err(e),
        };
        let addr = listener.local_addr()?;
        let shared = Arc::new(Shared {
            viewers: Mutex::new(Vec::new()),
            stats: Stats::default(),
            now_ns: AtomicU64::new(0),
            start_time_ns: settings.start_time_ns,
            shutdown: AtomicBool::new(false),
            next_viewer: AtomicU32::new(1),
            next_sequence: AtomicU64::new(0),
            live: AtomicUsize::new(0),
        });
        shared.stats.latency.set_paced(false);
        let settings = Arc::new(settings);
        let accept_shared = Arc::clone(&shared);
        let accept = std::thread::Builder::new()
            .name("ground-accept".into())
            .spawn(move || accept_loop(&listener, &accept_shared, &settings))?;
        Ok(Self {
            addr,
            shared,
            accept: Some(accept),
        })
    }

    /// Stops accepting and closes every viewer with a close frame (1001, going away): waits
    /// up to [`STOP_WAIT`] for their threads to send it.
    pub fn stop(&mut self) {
        self.shared.shutdown.store(true, Ordering::Relaxed);
        // Wake the accept call.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_millis(200));
        if let Some(handle) = self.accept.take() {
            let _ = handle.join();
        }
        let start = Instant::now();
        while self.shared.live.load(Ordering::Relaxed) > 0 && start.elapsed() < STOP_WAIT {
            std::thread::sleep(POLL);
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop();
    }
}

fn accept_loop(listener: &TcpListener, shared: &Arc<Shared>, settings: &Arc<Settings>) {
    for stream in listener.incoming() {
        if shared.shutdown.load(Ordering::Relaxed) {
            break;
        }
        let Ok(stream) = stream else { continue };
        let Ok(peer) = stream.peer_addr() else {
            continue;
        };
        let (shared, settings) = (Arc::clone(shared), Arc::clone(settings));
        shared.live.fetch_add(1, Ordering::Relaxed);
        let spawned = std::thread::Builder::new()
            .name("ground-viewer".into())
            .spawn(move || {
                if let Err(e) = connection(stream, peer, &shared, &settings) {
                    tracing::debug!(%peer, "ground link connection: {e}");
                }
                shared.live.fetch_sub(1, Ordering::Relaxed);
            });
        if let Err(e) = spawned {
            // The closure (and its count) never ran.
            tracing::warn!("ground link: cannot start a connection thread: {e}");
        }
    }
}

/// A connection's byte stream: plain TCP, or TLS over it.
pub enum Conn {
    Plain(TcpStream),
    Tls(Box<rustls::StreamOwned<rustls::ServerConnection, TcpStream>>),
}

impl Conn {
    fn tcp(&self) -> &TcpStream {
        match self {
            Self::Plain(s) => s,
            Self::Tls(s) => &s.sock,
        }
    }

    /// Ends the connection cleanly: TLS's close_notify, then no more writes.
    fn finish(&mut self) {
        if let Self::Tls(s) = self {
            s.conn.send_close_notify();
            let _ = s.flush();
        }
        let _ = self.tcp().shutdown(std::net::Shutdown::Write);
    }

    /// Closes the connection without a reset: no more writes, then what the peer still sends
    /// read and dropped for up to [`LINGER`] (until it closes its side).
    fn linger(&mut self) {
        self.finish();
        let start = Instant::now();
        let _ = self.tcp().set_read_timeout(Some(POLL));
        let mut sink = [0u8; 4096];
        while start.elapsed() < LINGER {
            match self.tcp().read(&mut sink) {
                Ok(0) => break,
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                Err(_) => break,
            }
        }
    }
}

impl Read for Conn {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Self::Plain(s) => s.read(buf),
            Self::Tls(s) => s.read(buf),
        }
    }
}

impl Write for Conn {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Self::Plain(s) => s.write(buf),
            Self::Tls(s) => s.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Self::Plain(s) => s.flush(),
            Self::Tls(s) => s.flush(),
        }
    }
}

/// A parsed HTTP request head.
struct Request {
    path: String,
    query: String,
    headers: HashMap<String, String>,
    /// Bytes read past the head (a client's first WebSocket frame).
    rest: Vec<u8>,
}

impl Request {
    /// The value of `key` in the query, percent-decoded (`None` if absent or not UTF-8).
    fn query_value(&self, key: &str) -> Option<String> {
        let raw = self
            .query
            .split('&')
            .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))?;
        percent_decode(raw)
    }
}

/// `%XX` escapes decoded (what `encodeURIComponent` makes).
fn percent_decode(raw: &str) -> Option<String> {
    let bytes = raw.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = raw.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

fn read_request(stream: &mut Conn) -> std::io::Result<Option<Request>> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    let end = loop {
        if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break i;
        }
        if buf.len() > MAX_REQUEST_HEAD {
            return Ok(None);
        }
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Ok(None);
        }
        buf.extend_from_slice(&chunk[..n]);
    };
    let head = String::from_utf8_lossy(&buf[..end]).into_owned();
    let rest = buf[end + 4..].to_vec();
    let mut lines = head.split("\r\n");
    let mut first = lines.next().unwrap_or_default().split(' ');
    if first.next() != Some("GET") {
        return Ok(None);
    }
    let target = first.next().unwrap_or("/");
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_owned()))
        .collect();
    Ok(Some(Request {
        path: path.to_owned(),
        query: query.to_owned(),
        headers,
        rest,
    }))
}

fn respond(stream: &mut Conn, status: &str, kind: &str, body: &[u8]) -> std::io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(body)?;
    stream.flush()?;
    stream.finish();
    Ok(())
}

/// The connection's stream: plain, or (with TLS configured) TLS once the first byte shows a
/// TLS handshake; `None` if it was refused (a plain request to the TLS link) or closed.
fn open(stream: TcpStream, peer: SocketAddr, shared: &Shared, settings: &Settings) -> Option<Conn> {
    let Some(tls) = &settings.tls else {
        return Some(Conn::Plain(stream));
    };
    let mut first = [0u8; 1];
    match stream.peek(&mut first) {
        Ok(1) if first[0] == TLS_HANDSHAKE => {}
        Ok(1) => {
            shared.refuse_handshake(peer, "a plain (not TLS) connection to the TLS link");
            let mut plain = Conn::Plain(stream);
            // The request read first: closing on unread input would reset the connection and
            // the answer could be lost.
            let _ = read_request(&mut plain);
            let _ = respond(
                &mut plain,
                "400 Bad Request",
                "text/plain",
                b"this ground link serves https:// and wss:// only\n",
            );
            return None;
        }
        // Closed (or silent) before a byte: nothing to refuse.
        _ => return None,
    }
    match rustls::ServerConnection::new(Arc::clone(tls)) {
        Ok(c) => Some(Conn::Tls(Box::new(rustls::StreamOwned::new(c, stream)))),
        Err(e) => {
            tracing::warn!(%peer, "ground link: TLS session not made: {e}");
            None
        }
    }
}

fn connection(
    stream: TcpStream,
    peer: SocketAddr,
    shared: &Shared,
    settings: &Settings,
) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
    stream.set_write_timeout(Some(Duration::from_secs(2)))?;
    let Some(mut stream) = open(stream, peer, shared, settings) else {
        return Ok(());
    };
    let request = match read_request(&mut stream) {
        Ok(Some(r)) => r,
        Ok(None) => {
            add(&shared.stats.bad_messages, 1);
            return respond(
                &mut stream,
                "400 Bad Request",
                "text/plain",
                b"bad request\n",
            );
        }
        // The TLS handshake failed (the peer refused the certificate, or spoke no TLS).
        Err(e) if matches!(stream, Conn::Tls(_)) && e.kind() == ErrorKind::InvalidData => {
            shared.refuse_handshake(peer, &format!("TLS handshake failed: {e}"));
            return Ok(());
        }
        Err(e) => return Err(e),
    };
    let upgrade = request
        .headers
        .get("upgrade")
        .is_some_and(|v| v.eq_ignore_ascii_case("websocket"));
    if !upgrade {
        if request.path == "/stats" {
            let body = shared.stats.to_json().to_string();
            return respond(&mut stream, "200 OK", "application/json", body.as_bytes());
        }
        return match PAGE.iter().find(|(p, _, _)| *p == request.path) {
            Some((_, kind, body)) => respond(&mut stream, "200 OK", kind, body.as_bytes()),
            None => respond(&mut stream, "404 Not Found", "text/plain", b"not found\n"),
        };
    }
    let Some(key) = request.headers.get("sec-websocket-key") else {
        add(&shared.stats.bad_messages, 1);
        return respond(&mut stream, "400 Bad Request", "text/plain", b"no key\n");
    };
    let role = match command::role_of(request.query_value("token").as_deref(), &settings.limits) {
        Ok(role) => role,
        Err(why) => {
            shared.refuse_handshake(peer, why);
            return respond(
                &mut stream,
                "401 Unauthorized",
                "text/plain",
                format!("{why}: connect without ?token= to watch\n").as_bytes(),
            );
        }
    };
    if shared.viewers().len() >= settings.ground.max_viewers {
        add(&shared.stats.refused_viewers, 1);
        tracing::warn!(%peer, "ground link: viewer refused: too many viewers");
        return respond(
            &mut stream,
            "503 Service Unavailable",
            "text/plain",
            b"too many viewers\n",
        );
    }
    let accept = tungstenite::handshake::derive_accept_key(key.as_bytes());
    let wants_foxglove = request
        .headers
        .get("sec-websocket-protocol")
        .is_some_and(|p| p.split(',').any(|p| p.trim() == protocol::SUBPROTOCOL));
    let protocol_line = if wants_foxglove {
        format!("Sec-WebSocket-Protocol: {}\r\n", protocol::SUBPROTOCOL)
    } else {
        String::new()
    };
    write!(
        stream,
        "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {accept}\r\n{protocol_line}\r\n"
    )?;
    stream.flush()?;
    let rate_hz = request
        .query_value("rate_hz")
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|r| r.is_finite() && *r > 0.0)
        .map_or(settings.ground.viewer_rate_hz, |r| {
            r.min(settings.ground.max_viewer_rate_hz)
        });
    stream.tcp().set_read_timeout(Some(POLL))?;
    let config = WebSocketConfig::default()
        .max_message_size(Some(settings.ground.max_message_bytes))
        .max_frame_size(Some(settings.ground.max_message_bytes))
        .max_write_buffer_size(4 << 20);
    let ws = WebSocket::from_partially_read(stream, request.rest, WsRole::Server, Some(config));
    let id = shared.next_viewer.fetch_add(1, Ordering::Relaxed);
    let (tx, rx) = std::sync::mpsc::sync_channel(settings.ground.viewer_queue);
    shared.viewers().push(Viewer {
        id,
        queue: tx,
        subscriptions: HashMap::new(),
        decimator: Decimator::new(rate_hz),
        dropped: 0,
    });
    add(&shared.stats.viewers, 1);
    add(&shared.stats.connections, 1);
    tracing::info!(viewer = id, %peer, role = role.name(), rate_hz, "ground viewer connected");
    let session = Session {
        id,
        peer,
        role,
        shared,
        settings,
        client_channels: HashMap::new(),
        rate: RateLimit::new(
            settings.ground.command_burst,
            settings.ground.command_rate_hz,
        ),
        rate_limited_unlogged: 0,
        rate_logged_at: None,
    };
    let result = viewer(ws, session, rate_hz, &rx);
    let dropped = {
        let mut viewers = shared.viewers();
        let dropped = viewers.iter().find(|v| v.id == id).map_or(0, |v| v.dropped);
        viewers.retain(|v| v.id != id);
        dropped
    };
    shared.stats.viewers.fetch_sub(1, Ordering::Relaxed);
    tracing::info!(viewer = id, %peer, dropped, "ground viewer left");
    result
}

/// What a viewer's connection thread keeps.
struct Session<'a> {
    id: u32,
    peer: SocketAddr,
    role: Role,
    shared: &'a Shared,
    settings: &'a Settings,
    /// Client channel id → topic.
    client_channels: HashMap<u32, String>,
    rate: RateLimit,
    /// Rate-limited commands not yet said in the log, and when it last said some: a flood is
    /// logged once a second, not once a command.
    rate_limited_unlogged: u64,
    rate_logged_at: Option<Instant>,
}

type Ws = WebSocket<Conn>;

fn is_timeout(e: &tungstenite::Error) -> bool {
    matches!(e, tungstenite::Error::Io(io) if matches!(io.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut))
}

/// Sends a close frame (`code`, `reason`), then closes without a reset.
fn close(ws: &mut Ws, code: CloseCode, reason: &str) {
    let frame = CloseFrame {
        code,
        reason: reason.to_owned().into(),
    };
    let _ = ws.close(Some(frame));
    // A write that timed out is still buffered: give it the linger's time.
    let start = Instant::now();
    while ws.flush().is_err_and(|e| is_timeout(&e)) && start.elapsed() < LINGER {}
    ws.get_mut().linger();
}

fn viewer(
    mut ws: Ws,
    mut session: Session<'_>,
    rate_hz: f64,
    rx: &Receiver<Outgoing>,
) -> std::io::Result<()> {
    let (shared, settings, id) = (session.shared, session.settings, session.id);
    let mut metadata = settings.metadata.clone();
    metadata["viewer_id"] = id.into();
    metadata["viewer_rate_hz"] = rate_hz.into();
    metadata["role"] = session.role.name().into();
    let mut capabilities = vec![protocol::CAP_PARAMETERS, protocol::CAP_TIME];
    if session.role == Role::Command {
        capabilities.insert(0, protocol::CAP_CLIENT_PUBLISH);
    }
    let hello = [
        protocol::server_info(&format!("viewer-{id}"), &capabilities, &metadata),
        protocol::advertise(&settings.channels),
    ];
    for text in hello {
        if ws.send(Message::Text(text.into())).is_err() {
            return Ok(());
        }
    }
    let mut time_sent: Option<(Instant, u64)> = None;
    loop {
        if shared.shutdown.load(Ordering::Relaxed) {
            close(&mut ws, CloseCode::Away, "ground link stopping");
            return Ok(());
        }
        match ws.read() {
            Ok(Message::Text(text)) => session.on_text(&mut ws, text.as_str()),
            Ok(Message::Binary(data)) => session.on_binary(&mut ws, &data),
            Ok(Message::Close(_)) => {
                // tungstenite queued the answering close frame: send it.
                let _ = ws.flush();
                return Ok(());
            }
            Ok(_) => {}
            Err(e) if is_timeout(&e) => {}
            Err(tungstenite::Error::Capacity(e)) => {
                // Oversized: counted; the stream cannot be resynchronised, so the viewer goes,
                // told why (1009).
                add(&shared.stats.oversized, 1);
                add(&shared.stats.bad_messages, 1);
                tracing::warn!(
                    viewer = id,
                    peer = %session.peer,
                    "ground viewer sent an oversized message ({e}): closed"
                );
                let limit = settings.ground.max_message_bytes;
                close(
                    &mut ws,
                    CloseCode::Size,
                    &format!("message larger than {limit} bytes"),
                );
                return Ok(());
            }
            Err(tungstenite::Error::Protocol(e)) => {
                add(&shared.stats.bad_messages, 1);
                tracing::warn!(
                    viewer = id,
                    peer = %session.peer,
                    "ground viewer broke the WebSocket protocol ({e}): closed"
                );
                close(&mut ws, CloseCode::Protocol, "WebSocket protocol error");
                return Ok(());
            }
            Err(tungstenite::Error::Utf8(_)) => {
                add(&shared.stats.bad_messages, 1);
                close(&mut ws, CloseCode::Invalid, "text message not UTF-8");
                return Ok(());
            }
            Err(_) => return Ok(()),
        }
        // The run clock, when it moved (`time`; the message times' clock).
        let now_ns = shared.now_ns.load(Ordering::Relaxed);
        if time_sent.is_none_or(|(at, t)| t != now_ns && at.elapsed() >= TIME_PERIOD) {
            let time = protocol::time(shared.start_time_ns.saturating_add(now_ns));
            if ws.write(Message::Binary(time.to_vec().into())).is_ok() {
                time_sent = Some((Instant::now(), now_ns));
            }
        }
        // Everything queued for the viewer, then one flush. A full write buffer (the viewer
        // stopped reading) drops what did not fit.
        let mut stamps = Vec::new();
        while let Ok(out) = rx.try_recv() {
            let message = match out {
                Outgoing::Text(t) => Message::Text(t.into()),
                Outgoing::Data(b, stamp) => {
                    stamps.extend(stamp);
                    Message::Binary(b.into())
                }
            };
            match ws.write(message) {
                Ok(()) => {}
                Err(tungstenite::Error::WriteBufferFull(_)) => add(&shared.stats.dropped, 1),
                Err(e) if is_timeout(&e) => {}
                Err(_) => return Ok(()),
            }
        }
        match ws.flush() {
            Ok(()) => {
                let wall = testbed_log::unix_time_ns();
                for stamp in stamps {
                    shared.stats.latency.sent(stamp, wall);
                }
            }
            Err(e) if is_timeout(&e) => {}
            Err(_) => return Ok(()),
        }
    }
}

impl Session<'_> {
    fn bad(&self, ws: &mut Ws, why: &BadMessage) {
        add(&self.shared.stats.bad_messages, 1);
        let _ = ws.write(Message::Text(
            protocol::status(2, &format!("message dropped: {why}"), None).into(),
        ));
    }

    fn status(&self, ws: &mut Ws, level: u8, text: &str) {
        let _ = ws.write(Message::Text(protocol::status(level, text, None).into()));
    }

    fn on_text(&mut self, ws: &mut Ws, text: &str) {
        match protocol::parse_text(text) {
            Ok(ClientMessage::Subscribe(subs)) => {
                let known: Vec<u32> = self.settings.channels.iter().map(|c| c.id).collect();
                let mut unknown = Vec::new();
                {
                    let mut viewers = self.shared.viewers();
                    if let Some(v) = viewers.iter_mut().find(|v| v.id == self.id) {
                        for (sub, channel) in subs {
                            if known.contains(&channel) {
                                v.subscriptions.insert(channel, sub);
                            } else {
                                unknown.push(channel);
                            }
                        }
                    }
                }
                if !unknown.is_empty() {
                    self.status(ws, 1, &format!("no channel {unknown:?}: not subscribed"));
                }
            }
            Ok(ClientMessage::Unsubscribe(ids)) => {
                let mut viewers = self.shared.viewers();
                if let Some(v) = viewers.iter_mut().find(|v| v.id == self.id) {
                    v.subscriptions.retain(|_, sub| !ids.contains(sub));
                }
            }
            Ok(ClientMessage::Advertise(channels)) => self.on_advertise(ws, channels),
            Ok(ClientMessage::Unadvertise(ids)) => {
                self.client_channels.retain(|id, _| !ids.contains(id));
            }
            Ok(ClientMessage::GetParameters { names, id }) => {
                let params = &self.settings.parameters;
                let chosen = params
                    .iter()
                    .filter(|(n, _)| names.is_empty() || names.contains(n))
                    .map(|(n, v)| (n.as_str(), v));
                let _ = ws.write(Message::Text(
                    protocol::parameter_values(chosen, id.as_deref()).into(),
                ));
            }
            Ok(ClientMessage::SetParameters { names, id }) => {
                tracing::info!(viewer = self.id, peer = %self.peer, ?names, "ground viewer tried to set parameters: refused");
                self.status(
                    ws,
                    2,
                    &format!(
                        "parameters are read-only (the run's configuration): {} not set",
                        names.join(", ")
                    ),
                );
                // The values stay: the client is told them back.
                if id.is_some() {
                    let current = self
                        .settings
                        .parameters
                        .iter()
                        .filter(|(n, _)| names.contains(n))
                        .map(|(n, v)| (n.as_str(), v));
                    let _ = ws.write(Message::Text(
                        protocol::parameter_values(current, id.as_deref()).into(),
                    ));
                }
            }
            Ok(ClientMessage::Publish { .. }) => self.bad(ws, &BadMessage::Binary),
            Err(why) => self.bad(ws, &why),
        }
    }

    fn on_advertise(&mut self, ws: &mut Ws, channels: Vec<protocol::ClientChannel>) {
        if self.role != Role::Command {
            add(&self.shared.stats.refused_watch_only, 1);
            tracing::warn!(viewer = self.id, peer = %self.peer, "ground viewer (watching) advertised a channel: refused");
            self.status(
                ws,
                2,
                &format!("advertise refused: {}", command::WATCH_ONLY),
            );
            return;
        }
        for c in channels {
            let refusal = if c.encoding != protocol::ENCODING {
                Some(format!(
                    "encoding {:?} not supported (supportedEncodings: {:?})",
                    c.encoding,
                    protocol::ENCODING
                ))
            } else if c.topic != self.settings.command_topic {
                Some(format!(
                    "the link takes commands on {} only, not {:?}",
                    self.settings.command_topic, c.topic
                ))
            } else if self.client_channels.len() >= 64 && !self.client_channels.contains_key(&c.id)
            {
                Some("64 client channels already".into())
            } else {
                None
            };
            match refusal {
                Some(why) => {
                    add(&self.shared.stats.bad_messages, 1);
                    self.status(ws, 2, &format!("client channel {} refused: {why}", c.id));
                }
                None => {
                    self.client_channels.insert(c.id, c.topic);
                }
            }
        }
    }

    fn on_binary(&mut self, ws: &mut Ws, data: &[u8]) {
        match protocol::parse_binary(data) {
            Ok(ClientMessage::Publish { channel, payload }) => {
                if self.role != Role::Command {
                    self.on_command(ws, &payload);
                    return;
                }
                match self.client_channels.get(&channel) {
                    Some(topic) if topic == self.settings.command_topic => {
                        self.on_command(ws, &payload);
                    }
                    _ => self.bad(
                        ws,
                        &BadMessage::Malformed("message on an unadvertised channel"),
                    ),
                }
            }
            Ok(_) => self.bad(ws, &BadMessage::Binary),
            Err(why) => self.bad(ws, &why),
        }
    }

    /// Tells the sender and publishes the rejection (logged in the run log, and every viewer
    /// sees it); said in the process log with the sender's address.
    fn reject(&self, ws: &mut Ws, id: u64, kind: u32, reason: &str, log: bool) {
        add(&self.shared.stats.commands_rejected, 1);
        let _ = ws.write(Message::Text(
            protocol::status(
                2,
                &format!("command {id} rejected: {reason}"),
                Some(&format!("cmd-{id}")),
            )
            .into(),
        ));
        if log {
            tracing::warn!(viewer = self.id, peer = %self.peer, id, reason, "ground command refused");
            let ack = GroundCommandAck::new(
                self.shared.header(),
                id,
                kind,
                GroundAckStatus::Rejected,
                self.id,
                GroundCommandAck::BY_LINK,
                reason,
            );
            let _ = self.settings.to_bus.try_send(ToBus::Ack(Box::new(ack)));
        }
    }

    fn on_command(&mut self, ws: &mut Ws, payload: &[u8]) {
        // Rate first: a flood (of guesses, too) is refused before anything else, counted,
        // and said in the log once a second rather than once a command.
        let now = Instant::now();
        if !self.rate.allow(now) {
            add(&self.shared.stats.rate_limited, 1);
            self.rate_limited_unlogged += 1;
            if self
                .rate_logged_at
                .is_none_or(|t| now - t >= Duration::from_secs(1))
            {
                tracing::warn!(viewer = self.id, peer = %self.peer, commands = self.rate_limited_unlogged, "ground commands refused: rate limited");
                self.rate_limited_unlogged = 0;
                self.rate_logged_at = Some(now);
            }
            let id = Malformed::id_of(payload);
            self.reject(ws, id, 0, "rate limited: too many commands", false);
            return;
        }
        if self.role != Role::Command {
            add(&self.shared.stats.refused_watch_only, 1);
            self.reject(ws, Malformed::id_of(payload), 0, command::WATCH_ONLY, true);
            return;
        }
        let request = match command::parse(payload) {
            Ok(r) => r,
            Err(e) => {
                add(&self.shared.stats.bad_messages, 1);
                self.reject(
                    ws,
                    Malformed::id_of(payload),
                    0,
                    &format!("malformed: {e}"),
                    true,
                );
                return;
            }
        };
        match command::validate(
            &request,
            &self.settings.limits,
            self.role,
            self.id,
            self.shared.header(),
        ) {
            Ok(command) => match self.settings.to_bus.try_send(ToBus::Command(command)) {
                Ok(()) => {
                    add(&self.shared.stats.commands_forwarded, 1);
                    tracing::info!(viewer = self.id, peer = %self.peer, id = request.id, "ground command accepted");
                    let _ = ws.write(Message::Text(
                        protocol::status(
                            0,
                            &format!("command {} sent to the controller", request.id),
                            Some(&format!("cmd-{}", request.id)),
                        )
                        .into(),
                    ));
                }
                Err(_) => self.reject(ws, request.id, request.kind as u32, "link busy", false),
            },
            Err(reason) => self.reject(ws, request.id, request.kind as u32, &reason, true),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::PAGE;
    use std::path::Path;

    /// The page's uPlot is npm's `uplot` 1.6.32 byte for byte (tests/js pins that version; run
    /// `npm ci --prefix tests/js`, as .ci/run does, to check it; skipped outside CI without it).
    #[test]
    fn the_served_uplot_is_the_npm_package() {
        let dist =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/js/node_modules/uplot/dist");
        if !dist.is_dir() {
            assert!(
                std::env::var_os("CI").is_none(),
                "under CI, tests/js/node_modules is needed (run `npm ci` in tests/js)"
            );
            eprintln!("skipped: needs `npm ci` in tests/js");
            return;
        }
        for (path, file) in [
            ("/uPlot.iife.min.js", "uPlot.iife.min.js"),
            ("/uPlot.min.css", "uPlot.min.css"),
        ] {
            let served = PAGE.iter().find(|(p, _, _)| *p == path).expect("served");
            let npm = std::fs::read_to_string(dist.join(file)).expect("npm's file");
            assert!(
                served.2 == npm,
                "{path} differs from npm's uplot/dist/{file}"
            );
        }
    }
}
