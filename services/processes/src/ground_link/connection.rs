//! One connection to the ground link: its stream (plain or TLS), its request (the page, the
//! counters, or a WebSocket upgrade with its role), and a viewer's WebSocket session: the
//! messages the node queued for it out, its subscriptions, advertisements and commands in.

use super::command::{self, Decimator, Malformed, RateLimit, Role};
use super::http::{Conn, LINGER, PAGE, POLL, read_request, respond};
use super::protocol::{self, BadMessage, ClientMessage};
use super::shared::{Outgoing, Settings, Shared, ToBus, Viewer};
use super::stats::add;
use ipc_types::{GroundAckStatus, GroundCommandAck};
use std::collections::HashMap;
use std::io::{ErrorKind, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use tungstenite::protocol::frame::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{Role as WsRole, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// Least wall time between two `time` messages to a viewer (the page and Foxglove draw at a
/// few hertz; the run clock moves in 100-ms control steps).
const TIME_PERIOD: Duration = Duration::from_millis(100);
/// First byte of a TLS record holding a handshake (the ClientHello).
const TLS_HANDSHAKE: u8 = 0x16;

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

pub(super) fn connection(
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
