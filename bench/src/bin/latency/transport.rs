//! The ways a sample gets from one process to the next, each behind the same two operations:
//! send a sample, and wait (the transport's way) for the next ones to arrive.
//!
//! - `iox-event`: the pipeline's bus (`testbed-bus`): iceoryx2 shared memory plus the paired
//!   event service, an `EventLoop` waiting with a `WaitStrategy`.
//! - `iox-poll`: iceoryx2 shared memory without events, the receiver polling its subscribers
//!   and yielding the CPU between polls (the floor).
//! - `uds`, `udp`: a Unix datagram socket or a UDP socket on loopback, blocking reads.
//!
//! Every transport copies a sample in on sending and out on receiving (the bus hands samples
//! out by value; sockets copy through the kernel), so the payload sweep compares like with like.

use crate::payload::{bytes_of, bytes_of_mut};
use crate::system::now_ns;
use anyhow::{Context, Result, bail};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe;
use ipc_types::Topic;
use serde::{Deserialize, Serialize};
use std::net::{SocketAddr, UdpSocket};
use std::os::fd::AsRawFd;
use std::os::unix::net::UnixDatagram;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, EventLoop, Flow, TopicPublisher, TopicSubscriber};

/// How long a receiver waits for anything before it gives up (a broken run must not hang).
pub const STALL: Duration = Duration::from_secs(10);

/// A transport and, for the bus, how its event loops wait.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Transport {
    /// The bus with this `TESTBED_BUS_WAIT` strategy (`block`, `spin:<µs>`, `anticipate:…`).
    IoxEvent(String),
    IoxPoll,
    Uds,
    Udp,
}

impl Transport {
    pub fn label(&self) -> String {
        match self {
            Self::IoxEvent(wait) if wait == "block" => "iceoryx2 event (block)".into(),
            Self::IoxEvent(wait) => format!("iceoryx2 event ({wait})"),
            Self::IoxPoll => "iceoryx2 busy-poll (floor)".into(),
            Self::Uds => "Unix datagram socket".into(),
            Self::Udp => "UDP loopback".into(),
        }
    }

    pub fn key(&self) -> String {
        match self {
            Self::IoxEvent(wait) => format!("iox-event-{wait}"),
            Self::IoxPoll => "iox-poll".into(),
            Self::Uds => "uds".into(),
            Self::Udp => "udp".into(),
        }
    }

    pub fn is_bus(&self) -> bool {
        matches!(self, Self::IoxEvent(_) | Self::IoxPoll)
    }
}

// ---------------------------------------------------------------------------------------------
// iceoryx2 without events: the busy-poll floor.

/// Raw publish/subscribe service of `T` for polling, beside (not on) the bus's own topic.
fn poll_service_of<T: Topic>(bus: &Bus, name: &str) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>> {
    let service_name = ServiceName::new(&format!("poll/{name}")).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let limits = bus.config().limits;
    bus.node()
        .service_builder(&service_name)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(limits.max_buffer_size)
        .history_size(limits.history_size)
        .max_publishers(limits.max_publishers)
        .max_subscribers(limits.max_subscribers)
        .max_nodes(limits.max_nodes)
        .open_or_create()
        .map_err(|e| anyhow::anyhow!("opening poll/{name}: {e:?}"))
}

/// A publisher without a notifier.
pub struct PollPub<T: Topic> {
    publisher: Publisher<ipc::Service, T, ()>,
    _service: publish_subscribe::PortFactory<ipc::Service, T, ()>,
}

impl<T: Topic> PollPub<T> {
    pub fn new(bus: &Bus) -> Result<Self> {
        let service = poll_service_of::<T>(bus, T::NAME)?;
        let publisher = service.publisher_builder().create().map_err(|e| anyhow::anyhow!("poll publisher {}: {e:?}", T::NAME))?;
        Ok(Self { publisher, _service: service })
    }
    pub fn send(&self, value: &T) -> Result<()> {
        self.publisher.send_copy(*value).map_err(|e| anyhow::anyhow!("send on poll/{}: {e:?}", T::NAME))?;
        Ok(())
    }
    pub fn subscriber_count(&self) -> usize {
        self._service.dynamic_config().number_of_subscribers()
    }
}

/// A subscriber without a listener.
pub struct PollSub<T: Topic> {
    subscriber: Subscriber<ipc::Service, T, ()>,
    _service: publish_subscribe::PortFactory<ipc::Service, T, ()>,
}

impl<T: Topic> PollSub<T> {
    pub fn new(bus: &Bus) -> Result<Self> {
        let service = poll_service_of::<T>(bus, T::NAME)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(16)
            .create()
            .map_err(|e| anyhow::anyhow!("poll subscriber {}: {e:?}", T::NAME))?;
        Ok(Self { subscriber, _service: service })
    }
    /// A copy of the next pending sample, if any (copied out, as the bus does).
    pub fn try_receive(&self) -> Result<Option<T>> {
        match self.subscriber.receive() {
            Ok(Some(sample)) => Ok(Some(std::hint::black_box(*sample.payload()))),
            Ok(None) => Ok(None),
            Err(e) => bail!("receive on poll/{}: {e:?}", T::NAME),
        }
    }
    pub fn publisher_count(&self) -> usize {
        self._service.dynamic_config().number_of_publishers()
    }
}

// ---------------------------------------------------------------------------------------------
// Sockets.

/// Where a socket receives.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Addr {
    Uds(PathBuf),
    Udp(SocketAddr),
}

/// Largest UDP datagram sent; bigger samples go as several (64 KiB does not fit in one).
pub const UDP_CHUNK: usize = 65_000;

/// A datagram socket of either family, blocking.
pub enum Sock {
    Uds(UnixDatagram),
    Udp(UdpSocket),
}

impl Sock {
    /// A socket receiving at `addr`.
    pub fn bind(addr: &Addr) -> Result<Self> {
        let sock = match addr {
            Addr::Uds(path) => {
                let _ = std::fs::remove_file(path);
                Self::Uds(UnixDatagram::bind(path).with_context(|| format!("binding {}", path.display()))?)
            }
            Addr::Udp(a) => {
                let s = UdpSocket::bind(a).with_context(|| format!("binding {a}"))?;
                set_buffers(s.as_raw_fd());
                Self::Udp(s)
            }
        };
        // Once, not per receive: a broken run must not hang, but the baseline pays no extra
        // system call per sample.
        sock.set_timeout(Some(STALL))?;
        Ok(sock)
    }

    /// A socket that only sends, to addresses of `family`'s kind.
    pub fn sender(family: &Addr) -> Result<Self> {
        Ok(match family {
            Addr::Uds(_) => Self::Uds(UnixDatagram::unbound()?),
            Addr::Udp(_) => {
                let s = UdpSocket::bind("127.0.0.1:0")?;
                set_buffers(s.as_raw_fd());
                Self::Udp(s)
            }
        })
    }

    /// Sends `bytes` to `to` (UDP: in chunks of at most [`UDP_CHUNK`]).
    pub fn send_to(&self, bytes: &[u8], to: &Addr) -> Result<()> {
        match (self, to) {
            (Self::Uds(s), Addr::Uds(path)) => {
                s.send_to(bytes, path).with_context(|| format!("sending to {}", path.display()))?;
            }
            (Self::Udp(s), Addr::Udp(a)) => {
                for chunk in bytes.chunks(UDP_CHUNK) {
                    s.send_to(chunk, a).with_context(|| format!("sending to {a}"))?;
                }
            }
            _ => bail!("socket and address families differ"),
        }
        Ok(())
    }

    /// Blocks until a whole message of `buf.len()` bytes is in `buf` (UDP: reassembled from
    /// its chunks), or until a shorter datagram arrives; returns the bytes received.
    pub fn recv(&self, buf: &mut [u8]) -> Result<usize> {
        let mut filled = 0;
        loop {
            let n = match self {
                Self::Uds(s) => s.recv(&mut buf[filled..]),
                Self::Udp(s) => s.recv(&mut buf[filled..]),
            }
            .context("receiving (nothing arrived for 20 s?)")?;
            filled += n;
            if filled == buf.len() || n < UDP_CHUNK || matches!(self, Self::Uds(_)) {
                return Ok(filled);
            }
        }
    }

    /// Like [`recv`](Self::recv) if a datagram is pending, else `None` at once.
    pub fn try_recv(&self, buf: &mut [u8]) -> Result<Option<usize>> {
        let fd = match self {
            Self::Uds(s) => s.as_raw_fd(),
            Self::Udp(s) => s.as_raw_fd(),
        };
        // SAFETY: recv into a buffer we own, with its length.
        let n = unsafe { libc::recv(fd, buf.as_mut_ptr().cast(), buf.len(), libc::MSG_DONTWAIT) };
        if n < 0 {
            let e = std::io::Error::last_os_error();
            if e.kind() == std::io::ErrorKind::WouldBlock {
                return Ok(None);
            }
            return Err(e).context("receiving");
        }
        let mut filled = n as usize;
        if matches!(self, Self::Udp(_)) && filled == UDP_CHUNK && filled < buf.len() {
            // The rest of a chunked message follows at once.
            filled += self.recv(&mut buf[filled..])?;
        }
        Ok(Some(filled))
    }

    fn set_timeout(&self, t: Option<Duration>) -> Result<()> {
        match self {
            Self::Uds(s) => s.set_read_timeout(t)?,
            Self::Udp(s) => s.set_read_timeout(t)?,
        }
        Ok(())
    }
}

/// 4 MiB socket buffers, so that a burst of large samples is never dropped for lack of room.
fn set_buffers(fd: i32) {
    let size: libc::c_int = 4 << 20;
    for option in [libc::SO_RCVBUF, libc::SO_SNDBUF] {
        // SAFETY: setsockopt reads an int of the given size.
        unsafe {
            libc::setsockopt(fd, libc::SOL_SOCKET, option, (&size as *const libc::c_int).cast(), std::mem::size_of::<libc::c_int>() as u32);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A point-to-point link for the hop benchmark: send `Tx`, receive `Rx`.

/// One direction out, one in. `recv` waits the transport's way for at least one sample and
/// reports every arrived sample's sequence number with the time it was taken.
pub trait Link<Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()>;
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()>;
    /// Whether the peer is connected (bus transports); sockets are always ready.
    fn peer_ready(&self) -> bool {
        true
    }
    /// Wait statistics of the event loop, if any.
    fn wait_stats(&self) -> Option<testbed_bus::WaitStats> {
        None
    }
}

/// The bus: publish, and an event loop on the subscriber.
pub struct BusLink<'w, 'a, Tx: Topic, Rx: Topic> {
    pub tx: &'a TopicPublisher<Tx>,
    pub rx: &'a TopicSubscriber<Rx>,
    pub events: EventLoop<'w, 'a>,
    pub msg: Box<Tx>,
}

impl<Tx: Topic, Rx: Topic> Link<Tx, Rx> for BusLink<'_, '_, Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()> {
        self.msg.header_mut().sequence = seq;
        self.tx.publish(&self.msg)?;
        Ok(())
    }
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()> {
        let start = Instant::now();
        let rx = self.rx;
        while out.is_empty() {
            if start.elapsed() > STALL {
                bail!("nothing arrived on {} for {STALL:?}", Rx::NAME);
            }
            self.events.run_once(Duration::from_millis(200), |_| {
                let _ = rx.drain(|s| {
                    let t = now_ns();
                    out.push((std::hint::black_box(&s).header().sequence, t));
                });
                Flow::Continue
            })?;
        }
        Ok(())
    }
    fn peer_ready(&self) -> bool {
        self.tx.subscriber_count() > 0 && self.rx.publisher_count() > 0
    }
    fn wait_stats(&self) -> Option<testbed_bus::WaitStats> {
        Some(self.events.wait_stats())
    }
}

/// iceoryx2 without events, polling.
pub struct PollLink<Tx: Topic, Rx: Topic> {
    pub tx: PollPub<Tx>,
    pub rx: PollSub<Rx>,
    pub msg: Box<Tx>,
}

impl<Tx: Topic, Rx: Topic> Link<Tx, Rx> for PollLink<Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()> {
        self.msg.header_mut().sequence = seq;
        self.tx.send(&self.msg)
    }
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()> {
        let start = Instant::now();
        let mut polls: u32 = 0;
        loop {
            while let Some(s) = self.rx.try_receive()? {
                out.push((s.header().sequence, now_ns()));
            }
            if !out.is_empty() {
                return Ok(());
            }
            polls = polls.wrapping_add(1);
            if polls.is_multiple_of(65_536) && start.elapsed() > STALL {
                bail!("nothing arrived on poll/{} for {STALL:?}", Rx::NAME);
            }
            std::thread::yield_now();
        }
    }
    fn peer_ready(&self) -> bool {
        self.tx.subscriber_count() > 0 && self.rx.publisher_count() > 0
    }
}

/// A socket: send to the peer's address, blocking receive on our own.
pub struct SockLink<Tx: Topic, Rx: Topic> {
    pub sock: Sock,
    pub peer: Addr,
    pub msg: Box<Tx>,
    pub buf: Box<Rx>,
}

impl<Tx: Topic, Rx: Topic> Link<Tx, Rx> for SockLink<Tx, Rx> {
    fn send(&mut self, seq: u64) -> Result<()> {
        self.msg.header_mut().sequence = seq;
        self.sock.send_to(bytes_of(&*self.msg), &self.peer)
    }
    fn recv(&mut self, out: &mut Vec<(u64, u64)>) -> Result<()> {
        let size = std::mem::size_of::<Rx>();
        let n = self.sock.recv(bytes_of_mut(&mut *self.buf))?;
        let t = now_ns();
        if n != size {
            bail!("short message: {n} of {size} bytes");
        }
        out.push((std::hint::black_box(&*self.buf).header().sequence, t));
        while let Some(n) = self.sock.try_recv(bytes_of_mut(&mut *self.buf))? {
            let t = now_ns();
            if n != size {
                bail!("short message: {n} of {size} bytes");
            }
            out.push((self.buf.header().sequence, t));
        }
        Ok(())
    }
}
