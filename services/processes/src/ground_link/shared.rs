//! What the ground link's threads share: the viewers' queues and subscriptions, the link's
//! counters, the settings, and the queue to the node.

use super::command::{Decimator, Limits};
use super::protocol::{self, Channel};
pub use super::stats::Stats;
use super::stats::add;
use ipc_types::{GroundCommand, GroundCommandAck, SampleHeader};
use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;
use testbed_config::GroundConfig;

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
pub(super) enum Outgoing {
    Text(String),
    /// A `messageData` frame and its sample's stamp (run clock, ns) for the latency, if the
    /// stamp is on the run clock.
    Data(Vec<u8>, Option<u64>),
}

/// One connected viewer, as the node sees it.
pub(super) struct Viewer {
    pub(super) id: u32,
    pub(super) queue: SyncSender<Outgoing>,
    /// Channel id → subscription id.
    pub(super) subscriptions: HashMap<u32, u32>,
    pub(super) decimator: Decimator,
    pub(super) dropped: u64,
}

/// What the server's threads and the node share.
pub struct Shared {
    pub(super) viewers: Mutex<Vec<Viewer>>,
    pub stats: Stats,
    /// The newest sample time the node has seen, ns (the header time of link commands).
    pub now_ns: AtomicU64,
    /// See [`Settings::start_time_ns`].
    pub start_time_ns: u64,
    pub(super) shutdown: AtomicBool,
    pub(super) next_viewer: AtomicU32,
    pub(super) next_sequence: AtomicU64,
    /// Connection threads running (the server's stop waits for them to close).
    pub(super) live: AtomicUsize,
}

impl Shared {
    pub(super) fn viewers(&self) -> MutexGuard<'_, Vec<Viewer>> {
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
    pub(super) fn refuse_handshake(&self, peer: SocketAddr, why: &str) {
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
