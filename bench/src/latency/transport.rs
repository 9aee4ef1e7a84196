//! The ways a sample gets from one process to the next: the bus's ports and the raw polling
//! ones ([`Family`]: [`Events`], [`Polling`]) and datagram sockets ([`Sock`]), and how a
//! receiver waits on each.
//!
//! - `Transport::IoxEvent`: the pipeline's bus (`testbed-bus`): iceoryx2 shared memory plus
//!   the paired event service, an `EventLoop` waiting with a `WaitStrategy`.
//! - `Transport::IoxPoll`: iceoryx2 shared memory without events ([`PollPub`], [`PollSub`]),
//!   the receiver polling and yielding the CPU between polls (the floor).
//! - `Transport::Uds`, `Transport::Udp`: datagram sockets ([`Sock`]), blocking reads.
//!
//! Every transport copies a sample in on sending and out on receiving (the bus hands samples
//! out by value; sockets copy through the kernel), so the payload sweep compares like with like.

use crate::latency::protocol::{Addr, STALL, STARTUP};
use anyhow::{Context, Result, anyhow, bail};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe;
use ipc_types::Topic;
use std::cell::{Cell, RefCell};
use std::io::ErrorKind;
use std::net::UdpSocket;
use std::os::fd::{AsRawFd, RawFd};
use std::os::unix::net::UnixDatagram;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use testbed_bus::{Bus, EventLoop, Flow, TopicPublisher, TopicSubscriber};

/// Whether this process has received anything yet: until then a receiver waits up to
/// [`STARTUP`] (its peers may still be starting), after that up to [`STALL`].
static HEARD: AtomicBool = AtomicBool::new(false);

/// How long a receiver waits now.
fn patience() -> Duration {
    if HEARD.load(Ordering::Relaxed) {
        STALL
    } else {
        STARTUP
    }
}

/// Notes that something arrived (`got`), and passes it on.
fn heard(got: bool) -> bool {
    if got {
        HEARD.store(true, Ordering::Relaxed);
    }
    got
}

// ---------------------------------------------------------------------------------------------
// iceoryx2 without events: the busy-poll floor.

/// The raw publish/subscribe service of `T` for polling, beside (not on) the bus's own topic,
/// with the bus's limits.
fn poll_service<T: Topic>(
    bus: &Bus,
) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>> {
    let name = ServiceName::new(&format!("poll/{}", T::NAME)).map_err(|e| anyhow!("{e:?}"))?;
    let limits = bus.config().limits;
    bus.node()
        .service_builder(&name)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(limits.max_buffer_size)
        .history_size(limits.history_size)
        .max_publishers(limits.max_publishers)
        .max_subscribers(limits.max_subscribers)
        .max_nodes(limits.max_nodes)
        .open_or_create()
        .map_err(|e| anyhow!("opening poll/{}: {e:?}", T::NAME))
}

/// A publisher without a notifier.
pub struct PollPub<T: Topic> {
    publisher: Publisher<ipc::Service, T, ()>,
    service: publish_subscribe::PortFactory<ipc::Service, T, ()>,
}

impl<T: Topic> PollPub<T> {
    pub fn new(bus: &Bus) -> Result<Self> {
        let service = poll_service::<T>(bus)?;
        let publisher = service
            .publisher_builder()
            .create()
            .map_err(|e| anyhow!("poll publisher {}: {e:?}", T::NAME))?;
        Ok(Self { publisher, service })
    }
    pub fn send(&self, value: &T) -> Result<()> {
        self.publisher
            .send_copy(*value)
            .map_err(|e| anyhow!("send on poll/{}: {e:?}", T::NAME))?;
        Ok(())
    }
    pub fn subscriber_count(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }
}

/// A subscriber without a listener.
pub struct PollSub<T: Topic> {
    subscriber: Subscriber<ipc::Service, T, ()>,
    service: publish_subscribe::PortFactory<ipc::Service, T, ()>,
}

impl<T: Topic> PollSub<T> {
    pub fn new(bus: &Bus) -> Result<Self> {
        let service = poll_service::<T>(bus)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(16)
            .create()
            .map_err(|e| anyhow!("poll subscriber {}: {e:?}", T::NAME))?;
        Ok(Self {
            subscriber,
            service,
        })
    }
    /// A copy of the next pending sample, if any (copied out, as the bus does).
    pub fn try_receive(&self) -> Result<Option<T>> {
        match self.subscriber.receive() {
            Ok(sample) => Ok(sample.map(|s| std::hint::black_box(*s.payload()))),
            Err(e) => bail!("receive on poll/{}: {e:?}", T::NAME),
        }
    }
    pub fn publisher_count(&self) -> usize {
        self.service.dynamic_config().number_of_publishers()
    }
}

/// Polls `poll` (yielding between polls) until it has something, for at most [`patience`].
pub fn poll_until(mut poll: impl FnMut() -> Result<bool>) -> Result<()> {
    let start = Instant::now();
    let mut polls: u32 = 0;
    let limit = patience();
    while !heard(poll()?) {
        polls = polls.wrapping_add(1);
        if polls.is_multiple_of(65_536) && start.elapsed() > limit {
            bail!("nothing arrived for {limit:?}");
        }
        std::thread::yield_now();
    }
    Ok(())
}

/// Runs `events` until `drain` has something, for at most [`patience`].
pub fn wait_for_events(
    events: &mut EventLoop<'_, '_>,
    mut drain: impl FnMut() -> Result<bool>,
) -> Result<()> {
    let start = Instant::now();
    let mut got = false;
    let limit = patience();
    while !heard(got) {
        if start.elapsed() > limit {
            bail!("nothing arrived for {limit:?}");
        }
        let mut failure = None;
        events.run_once(Duration::from_millis(200), |_| match drain() {
            Ok(any) => {
                got |= any;
                Flow::Continue
            }
            Err(e) => {
                failure = Some(e);
                Flow::Stop
            }
        })?;
        if let Some(e) = failure {
            return Err(e);
        }
    }
    Ok(())
}

/// One family of publisher and subscriber ports on a bus: the bus's own (publish + notify,
/// event loop) or the raw polling ones.
pub trait Family {
    type Pub<T: Topic>;
    type Sub<T: Topic>;
    fn publisher<T: Topic>(bus: &Bus) -> Result<Self::Pub<T>>;
    fn subscriber<T: Topic>(bus: &Bus) -> Result<Self::Sub<T>>;
    fn send<T: Topic>(port: &Self::Pub<T>, value: &T) -> Result<()>;
    fn drain<T: Topic>(port: &Self::Sub<T>, visit: impl FnMut(T)) -> Result<()>;
    fn subscribers<T: Topic>(port: &Self::Pub<T>) -> usize;
}

/// The bus's ports.
pub struct Events;

impl Family for Events {
    type Pub<T: Topic> = TopicPublisher<T>;
    type Sub<T: Topic> = TopicSubscriber<T>;
    fn publisher<T: Topic>(bus: &Bus) -> Result<Self::Pub<T>> {
        Ok(bus.publisher()?)
    }
    fn subscriber<T: Topic>(bus: &Bus) -> Result<Self::Sub<T>> {
        Ok(bus.subscriber()?)
    }
    fn send<T: Topic>(port: &Self::Pub<T>, value: &T) -> Result<()> {
        port.publish(value)?;
        Ok(())
    }
    fn drain<T: Topic>(port: &Self::Sub<T>, mut visit: impl FnMut(T)) -> Result<()> {
        // The harness keeps what it receives (time-stamped), so it copies here.
        port.drain(|sample| visit(*sample))?;
        Ok(())
    }
    fn subscribers<T: Topic>(port: &Self::Pub<T>) -> usize {
        port.subscriber_count()
    }
}

/// iceoryx2 ports without events, polled.
pub struct Polling;

impl Family for Polling {
    type Pub<T: Topic> = PollPub<T>;
    type Sub<T: Topic> = PollSub<T>;
    fn publisher<T: Topic>(bus: &Bus) -> Result<Self::Pub<T>> {
        PollPub::new(bus)
    }
    fn subscriber<T: Topic>(bus: &Bus) -> Result<Self::Sub<T>> {
        PollSub::new(bus)
    }
    fn send<T: Topic>(port: &Self::Pub<T>, value: &T) -> Result<()> {
        port.send(value)
    }
    fn drain<T: Topic>(port: &Self::Sub<T>, mut visit: impl FnMut(T)) -> Result<()> {
        while let Some(v) = port.try_receive()? {
            visit(v);
        }
        Ok(())
    }
    fn subscribers<T: Topic>(port: &Self::Pub<T>) -> usize {
        port.subscriber_count()
    }
}

// ---------------------------------------------------------------------------------------------
// Sockets.

/// Largest UDP datagram sent; bigger samples go as several (64 KiB does not fit in one).
pub const UDP_CHUNK: usize = 65_000;

/// A datagram socket of either family, blocking.
pub struct Sock {
    inner: Inner,
    /// The peers a datagram has gone through to: until then a peer may not be there yet, and
    /// sending to it is tried again (see [`send_to`](Self::send_to)).
    reached: RefCell<Vec<Addr>>,
    /// Nothing received yet: receives wait up to [`STARTUP`], not [`STALL`].
    patient: Cell<bool>,
}

enum Inner {
    Uds(UnixDatagram),
    Udp(UdpSocket),
}

impl Sock {
    fn new(inner: Inner) -> Result<Self> {
        if let Inner::Udp(s) = &inner {
            set_buffers(s.as_raw_fd());
        }
        let sock = Self {
            inner,
            reached: RefCell::new(Vec::new()),
            patient: Cell::new(true),
        };
        sock.set_timeout(STARTUP)?;
        Ok(sock)
    }

    /// A socket receiving at `addr`, bound when this returns (say `ready` only after it).
    pub fn bind(addr: &Addr) -> Result<Self> {
        Self::new(match addr {
            Addr::Uds(path) => {
                let _ = std::fs::remove_file(path);
                Inner::Uds(
                    UnixDatagram::bind(path)
                        .with_context(|| format!("binding {}", path.display()))?,
                )
            }
            Addr::Udp(a) => Inner::Udp(UdpSocket::bind(a).with_context(|| format!("binding {a}"))?),
        })
    }

    /// A socket that only sends, to addresses of `family`'s kind, and never waits for room:
    /// where the receiver's queue is full (a Unix datagram socket queues 10 datagrams by
    /// default), [`send_to`](Self::send_to) drops the datagram, as UDP and the bus's overflow
    /// delivery do. Processes that send to each other in a cycle (the chain's controller and
    /// wheel gateway) would otherwise deadlock once both fall behind.
    pub fn sender(family: &Addr) -> Result<Self> {
        let sock = Self::new(match family {
            Addr::Uds(_) => Inner::Uds(UnixDatagram::unbound()?),
            Addr::Udp(_) => Inner::Udp(UdpSocket::bind("127.0.0.1:0")?),
        })?;
        match &sock.inner {
            Inner::Uds(s) => s.set_nonblocking(true)?,
            Inner::Udp(s) => s.set_nonblocking(true)?,
        }
        Ok(sock)
    }

    /// Sends `bytes` to `to` (UDP: in chunks of at most [`UDP_CHUNK`]). Until a datagram has
    /// gone through to `to`, a peer that is not there yet (no such socket, connection refused:
    /// on a loaded machine a peer may be slow to bind, or a socket file may exist before its
    /// socket is bound) is tried again, backing off from 100 µs to 20 ms, until [`STARTUP`]
    /// has passed since the first try; each peer on its own, so having reached one peer does
    /// not make a first send to another fatal. `false`: dropped, the receiver's queue was full
    /// (only a [`sender`](Self::sender) drops).
    pub fn send_to(&self, bytes: &[u8], to: &Addr) -> Result<bool> {
        self.send_to_within(bytes, to, STARTUP)
    }

    /// [`send_to`](Self::send_to), trying a peer that is not there yet for at most `patience`.
    pub(crate) fn send_to_within(
        &self,
        bytes: &[u8],
        to: &Addr,
        patience: Duration,
    ) -> Result<bool> {
        let mut first_contact: Option<(Instant, Duration)> = None;
        loop {
            let sent = match (&self.inner, to) {
                (Inner::Uds(s), Addr::Uds(path)) => s.send_to(bytes, path).map(drop),
                (Inner::Udp(s), Addr::Udp(a)) => bytes
                    .chunks(UDP_CHUNK)
                    .try_for_each(|chunk| s.send_to(chunk, a).map(drop)),
                _ => bail!("socket and address families differ"),
            };
            match sent {
                Ok(()) => {
                    // A few peers at most, compared only while sending: tens of ns beside
                    // the system call.
                    if !self.reached.borrow().contains(to) {
                        self.reached.borrow_mut().push(to.clone());
                    }
                    return Ok(true);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(false),
                Err(e)
                    if matches!(e.kind(), ErrorKind::NotFound | ErrorKind::ConnectionRefused)
                        && !self.reached.borrow().contains(to) =>
                {
                    let (since, backoff) =
                        first_contact.get_or_insert((Instant::now(), Duration::from_micros(100)));
                    if since.elapsed() >= patience {
                        return Err(e).with_context(|| {
                            format!("sending to {to:?}: no peer there for {patience:?}")
                        });
                    }
                    std::thread::sleep(*backoff);
                    *backoff = (*backoff * 2).min(Duration::from_millis(20));
                }
                Err(e) => return Err(e).with_context(|| format!("sending to {to:?}")),
            }
        }
    }

    fn set_timeout(&self, timeout: Duration) -> Result<()> {
        match &self.inner {
            Inner::Uds(s) => s.set_read_timeout(Some(timeout))?,
            Inner::Udp(s) => s.set_read_timeout(Some(timeout))?,
        }
        Ok(())
    }

    fn fd(&self) -> RawFd {
        match &self.inner {
            Inner::Uds(s) => s.as_raw_fd(),
            Inner::Udp(s) => s.as_raw_fd(),
        }
    }

    /// Blocks until a whole message of `buf.len()` bytes is in `buf` (UDP: reassembled from
    /// its chunks), or until a shorter datagram arrives; returns the bytes received.
    pub fn recv(&self, buf: &mut [u8]) -> Result<usize> {
        let mut filled = 0;
        loop {
            let n = match &self.inner {
                Inner::Uds(s) => s.recv(&mut buf[filled..]),
                Inner::Udp(s) => s.recv(&mut buf[filled..]),
            }
            .with_context(|| format!("receiving (nothing arrived for {:?}?)", patience()))?;
            if heard(true) && self.patient.replace(false) {
                // Once, not per receive: the baseline pays no extra system call per sample.
                self.set_timeout(STALL)?;
            }
            filled += n;
            if filled == buf.len() || n < UDP_CHUNK || matches!(self.inner, Inner::Uds(_)) {
                return Ok(filled);
            }
        }
    }

    /// Like [`recv`](Self::recv) if a datagram is pending, else `None` at once.
    pub fn try_recv(&self, buf: &mut [u8]) -> Result<Option<usize>> {
        // SAFETY: recv into a buffer we own, with its length.
        let n = unsafe {
            libc::recv(
                self.fd(),
                buf.as_mut_ptr().cast(),
                buf.len(),
                libc::MSG_DONTWAIT,
            )
        };
        if n < 0 {
            let e = std::io::Error::last_os_error();
            if e.kind() == ErrorKind::WouldBlock {
                return Ok(None);
            }
            return Err(e).context("receiving");
        }
        let mut filled = n as usize;
        if matches!(self.inner, Inner::Udp(_)) && filled == UDP_CHUNK && filled < buf.len() {
            // The rest of a chunked message follows at once.
            filled += self.recv(&mut buf[filled..])?;
        }
        Ok(Some(filled))
    }
}

/// 4 MiB socket buffers, so that a burst of large samples is never dropped for lack of room.
fn set_buffers(fd: RawFd) {
    let size: libc::c_int = 4 << 20;
    for option in [libc::SO_RCVBUF, libc::SO_SNDBUF] {
        // SAFETY: setsockopt reads an int of the given size.
        unsafe {
            libc::setsockopt(
                fd,
                libc::SOL_SOCKET,
                option,
                (&size as *const libc::c_int).cast(),
                size_of::<libc::c_int>() as u32,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("sock-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A peer that binds late (a loaded machine) is waited for, also where its socket file
    /// exists before a socket is bound to it ("connection refused"), and also after another
    /// peer has been reached.
    #[test]
    fn a_first_send_waits_for_a_peer_that_binds_late() {
        let dir = scratch("late");
        let (a, b) = (Addr::Uds(dir.join("a.sock")), Addr::Uds(dir.join("b.sock")));
        let sender = Sock::sender(&a).unwrap();
        let receiver_a = Sock::bind(&a).unwrap();
        assert!(sender.send_to(b"first", &a).unwrap());
        // b.sock: a socket file with nobody bound to it.
        drop(UnixDatagram::bind(dir.join("b.sock")).unwrap());
        let late = b.clone();
        let binder = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(150));
            Sock::bind(&late).unwrap()
        });
        assert!(sender.send_to(b"second", &b).unwrap());
        let receiver_b = binder.join().unwrap();
        let mut buf = [0_u8; 16];
        assert_eq!(receiver_a.recv(&mut buf).unwrap(), 5);
        assert_eq!(&buf[..5], b"first");
        assert_eq!(receiver_b.recv(&mut buf).unwrap(), 6);
        assert_eq!(&buf[..6], b"second");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A peer that was reached and is gone fails at once (a run's end), and one that never
    /// comes fails after the patience given, naming the peer.
    #[test]
    fn a_peer_gone_fails_at_once_and_one_never_there_after_the_patience() {
        let dir = scratch("gone");
        let a = Addr::Uds(dir.join("a.sock"));
        let sender = Sock::sender(&a).unwrap();
        let receiver = Sock::bind(&a).unwrap();
        assert!(sender.send_to(b"x", &a).unwrap());
        drop(receiver);
        let start = Instant::now();
        assert!(sender.send_to(b"x", &a).is_err());
        assert!(start.elapsed() < Duration::from_secs(1));
        let never = Addr::Uds(dir.join("never.sock"));
        let start = Instant::now();
        let error = sender
            .send_to_within(b"x", &never, Duration::from_millis(100))
            .unwrap_err();
        assert!(start.elapsed() >= Duration::from_millis(100));
        assert!(format!("{error:#}").contains("never.sock"), "{error:#}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
