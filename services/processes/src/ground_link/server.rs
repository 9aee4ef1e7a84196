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

use super::connection::connection;
use super::http::POLL;
pub use super::shared::{Settings, Shared, ToBus};
pub use super::stats::{Latency, Stats};
use std::io::ErrorKind;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long [`Server::stop`] waits for the viewers' threads to send their close frames.
const STOP_WAIT: Duration = Duration::from_secs(2);

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
