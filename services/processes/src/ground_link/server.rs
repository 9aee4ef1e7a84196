//! The ground link's server: one TCP port for the ground page (HTTP GET) and the Foxglove
//! WebSocket protocol (an HTTP upgrade). One thread accepts; each connection has its own
//! thread. The bus stays on the node's thread: it hands each viewer its messages through the
//! viewer's bounded queue (`try_send`, what does not fit is dropped and counted), and viewers
//! hand commands to it through another bounded queue. Nothing here can block the node.

use super::command::{self, Decimator, Limits, Malformed, RateLimit};
use super::protocol::{self, BadMessage, Channel, ClientMessage};
use ipc_types::{GroundAckStatus, GroundCommand, GroundCommandAck, SampleHeader};
use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tungstenite::protocol::{Role, WebSocketConfig};
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
];

/// Largest HTTP request head read, bytes.
const MAX_REQUEST_HEAD: usize = 8192;
/// How long a viewer thread waits for input before it looks at its queue again.
const POLL: Duration = Duration::from_millis(20);

/// What a viewer hands the node.
#[derive(Debug, Clone, Copy)]
pub enum ToBus {
    /// An accepted command, to publish for the controller.
    Command(GroundCommand),
    /// A rejection decided by the link, to publish (and log).
    Ack(GroundCommandAck),
}

/// A message for one viewer.
enum Outgoing {
    Text(String),
    Binary(Vec<u8>),
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
        })
    }
}

fn add(counter: &AtomicU64, n: u64) {
    counter.fetch_add(n, Ordering::Relaxed);
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

    /// Hands a message of channel `channel` to every viewer subscribed to it, decimated
    /// (`decimate`) per viewer and `source` (a sample's source id). Never blocks.
    pub fn broadcast(
        &self,
        channel: u32,
        source: u32,
        decimate: bool,
        time_ns: u64,
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
            match viewer.queue.try_send(Outgoing::Binary(frame)) {
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
}

/// The server's fixed settings.
pub struct Settings {
    pub channels: Vec<Channel>,
    /// Wall-clock start of the run, ns since the Unix epoch: message times are this plus the
    /// run clock, as in the run log.
    pub start_time_ns: u64,
    pub metadata: serde_json::Value,
    pub limits: Limits,
    pub viewer_rate_hz: f64,
    pub max_viewer_rate_hz: f64,
    pub max_viewers: usize,
    pub viewer_queue: usize,
    pub max_message_bytes: usize,
    pub command_burst: u32,
    pub command_rate_hz: f64,
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
    /// Listens on `bind:port`; if that port is taken, on a free one (said in a warning).
    pub fn start(bind: &str, port: u16, settings: Settings) -> std::io::Result<Self> {
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
        });
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

    /// Stops accepting, closes every viewer (their threads end within [`POLL`]).
    pub fn stop(&mut self) {
        self.shared.shutdown.store(true, Ordering::Relaxed);
        // Wake the accept call.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_millis(200));
        if let Some(handle) = self.accept.take() {
            let _ = handle.join();
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
        let (shared, settings) = (Arc::clone(shared), Arc::clone(settings));
        let spawned = std::thread::Builder::new()
            .name("ground-viewer".into())
            .spawn(move || {
                if let Err(e) = connection(stream, &shared, &settings) {
                    tracing::debug!("ground link connection: {e}");
                }
            });
        if let Err(e) = spawned {
            tracing::warn!("ground link: cannot start a connection thread: {e}");
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

fn read_request(stream: &mut TcpStream) -> std::io::Result<Option<Request>> {
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
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

fn respond(stream: &mut TcpStream, status: &str, kind: &str, body: &[u8]) -> std::io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(body)?;
    stream.flush()
}

fn connection(mut stream: TcpStream, shared: &Shared, settings: &Settings) -> std::io::Result<()> {
    let Some(request) = read_request(&mut stream)? else {
        add(&shared.stats.bad_messages, 1);
        return respond(
            &mut stream,
            "400 Bad Request",
            "text/plain",
            b"bad request\n",
        );
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
    if shared.viewers().len() >= settings.max_viewers {
        add(&shared.stats.refused_viewers, 1);
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
        .query
        .split('&')
        .find_map(|kv| kv.strip_prefix("rate_hz="))
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|r| r.is_finite() && *r > 0.0)
        .map_or(settings.viewer_rate_hz, |r| {
            r.min(settings.max_viewer_rate_hz)
        });
    stream.set_read_timeout(Some(POLL))?;
    stream.set_write_timeout(Some(Duration::from_secs(2)))?;
    let config = WebSocketConfig::default()
        .max_message_size(Some(settings.max_message_bytes))
        .max_frame_size(Some(settings.max_message_bytes))
        .max_write_buffer_size(4 << 20);
    let ws = WebSocket::from_partially_read(stream, request.rest, Role::Server, Some(config));
    let id = shared.next_viewer.fetch_add(1, Ordering::Relaxed);
    let (tx, rx) = std::sync::mpsc::sync_channel(settings.viewer_queue);
    shared.viewers().push(Viewer {
        id,
        queue: tx,
        subscriptions: HashMap::new(),
        decimator: Decimator::new(rate_hz),
        dropped: 0,
    });
    add(&shared.stats.viewers, 1);
    add(&shared.stats.connections, 1);
    tracing::info!(viewer = id, rate_hz, "ground viewer connected");
    let result = viewer(ws, id, rate_hz, &rx, shared, settings);
    let dropped = {
        let mut viewers = shared.viewers();
        let dropped = viewers.iter().find(|v| v.id == id).map_or(0, |v| v.dropped);
        viewers.retain(|v| v.id != id);
        dropped
    };
    shared.stats.viewers.fetch_sub(1, Ordering::Relaxed);
    tracing::info!(viewer = id, dropped, "ground viewer left");
    result
}

/// What a viewer's connection thread keeps.
struct Session<'a> {
    id: u32,
    shared: &'a Shared,
    settings: &'a Settings,
    /// Client channel id → topic.
    client_channels: HashMap<u32, String>,
    rate: RateLimit,
}

fn is_timeout(e: &tungstenite::Error) -> bool {
    matches!(e, tungstenite::Error::Io(io) if matches!(io.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut))
}

fn viewer(
    mut ws: WebSocket<TcpStream>,
    id: u32,
    rate_hz: f64,
    rx: &Receiver<Outgoing>,
    shared: &Shared,
    settings: &Settings,
) -> std::io::Result<()> {
    let mut session = Session {
        id,
        shared,
        settings,
        client_channels: HashMap::new(),
        rate: RateLimit::new(settings.command_burst, settings.command_rate_hz),
    };
    let mut metadata = settings.metadata.clone();
    metadata["viewer_id"] = id.into();
    metadata["viewer_rate_hz"] = rate_hz.into();
    let hello = [
        protocol::server_info(&format!("viewer-{id}"), &metadata),
        protocol::advertise(&settings.channels),
    ];
    for text in hello {
        if ws.send(Message::Text(text.into())).is_err() {
            return Ok(());
        }
    }
    loop {
        if shared.shutdown.load(Ordering::Relaxed) {
            let _ = ws.close(None);
            let _ = ws.flush();
            return Ok(());
        }
        match ws.read() {
            Ok(Message::Text(text)) => session.on_text(&mut ws, text.as_str()),
            Ok(Message::Binary(data)) => session.on_binary(&mut ws, &data),
            Ok(Message::Close(_)) => {
                let _ = ws.flush();
                return Ok(());
            }
            Ok(_) => {}
            Err(e) if is_timeout(&e) => {}
            Err(tungstenite::Error::Capacity(e)) => {
                // Oversized: counted; the stream cannot be resynchronised, so the viewer goes.
                add(&shared.stats.oversized, 1);
                add(&shared.stats.bad_messages, 1);
                tracing::warn!(
                    viewer = id,
                    "ground viewer sent an oversized message ({e}): closed"
                );
                return Ok(());
            }
            Err(tungstenite::Error::Protocol(e)) => {
                add(&shared.stats.bad_messages, 1);
                tracing::warn!(
                    viewer = id,
                    "ground viewer broke the WebSocket protocol ({e}): closed"
                );
                return Ok(());
            }
            Err(tungstenite::Error::Utf8(_)) => {
                add(&shared.stats.bad_messages, 1);
                return Ok(());
            }
            Err(_) => return Ok(()),
        }
        // Everything queued for the viewer, then one flush. A full write buffer (the viewer
        // stopped reading) drops what did not fit.
        while let Ok(out) = rx.try_recv() {
            let message = match out {
                Outgoing::Text(t) => Message::Text(t.into()),
                Outgoing::Binary(b) => Message::Binary(b.into()),
            };
            match ws.write(message) {
                Ok(()) => {}
                Err(tungstenite::Error::WriteBufferFull(_)) => add(&shared.stats.dropped, 1),
                Err(e) if is_timeout(&e) => {}
                Err(_) => return Ok(()),
            }
        }
        match ws.flush() {
            Ok(()) => {}
            Err(e) if is_timeout(&e) => {}
            Err(_) => return Ok(()),
        }
    }
}

impl Session<'_> {
    fn bad(&self, ws: &mut WebSocket<TcpStream>, why: &BadMessage) {
        add(&self.shared.stats.bad_messages, 1);
        let _ = ws.write(Message::Text(
            protocol::status(2, &format!("message dropped: {why}"), None).into(),
        ));
    }

    fn on_text(&mut self, ws: &mut WebSocket<TcpStream>, text: &str) {
        match protocol::parse_text(text) {
            Ok(ClientMessage::Subscribe(subs)) => {
                let known: Vec<u32> = self.settings.channels.iter().map(|c| c.id).collect();
                let mut viewers = self.shared.viewers();
                if let Some(v) = viewers.iter_mut().find(|v| v.id == self.id) {
                    for (sub, channel) in subs {
                        if known.contains(&channel) {
                            v.subscriptions.insert(channel, sub);
                        }
                    }
                }
            }
            Ok(ClientMessage::Unsubscribe(ids)) => {
                let mut viewers = self.shared.viewers();
                if let Some(v) = viewers.iter_mut().find(|v| v.id == self.id) {
                    v.subscriptions.retain(|_, sub| !ids.contains(sub));
                }
            }
            Ok(ClientMessage::Advertise(channels)) => {
                for (id, topic) in channels {
                    if self.client_channels.len() < 64 {
                        self.client_channels.insert(id, topic);
                    }
                }
            }
            Ok(ClientMessage::Unadvertise(ids)) => {
                self.client_channels.retain(|id, _| !ids.contains(id));
            }
            Ok(ClientMessage::Publish { .. }) => self.bad(ws, &BadMessage::UnknownOp),
            Err(why) => self.bad(ws, &why),
        }
    }

    fn on_binary(&mut self, ws: &mut WebSocket<TcpStream>, data: &[u8]) {
        match protocol::parse_binary(data) {
            Ok(ClientMessage::Publish { channel, payload }) => {
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

    /// Tells the sender and publishes the rejection (logged, and every viewer sees it).
    fn reject(&self, ws: &mut WebSocket<TcpStream>, id: u64, kind: u32, reason: &str, log: bool) {
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
            let ack = GroundCommandAck::new(
                self.shared.header(),
                id,
                kind,
                GroundAckStatus::Rejected,
                self.id,
                GroundCommandAck::BY_LINK,
                reason,
            );
            let _ = self.settings.to_bus.try_send(ToBus::Ack(ack));
        }
    }

    fn on_command(&mut self, ws: &mut WebSocket<TcpStream>, payload: &[u8]) {
        // Rate first: a flood (of guesses, too) is refused before anything else, and only
        // counted, not logged.
        if !self.rate.allow(Instant::now()) {
            add(&self.shared.stats.rate_limited, 1);
            let id = Malformed::id_of(payload);
            self.reject(ws, id, 0, "rate limited: too many commands", false);
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
            self.id,
            self.shared.header(),
        ) {
            Ok(command) => match self.settings.to_bus.try_send(ToBus::Command(command)) {
                Ok(()) => {
                    add(&self.shared.stats.commands_forwarded, 1);
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
