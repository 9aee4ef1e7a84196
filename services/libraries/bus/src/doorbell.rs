//! Doorbells: one wake-up word per consuming process in shared memory, rung by every publisher
//! to that process after it sent a sample.
//!
//! # Why not iceoryx2's events
//!
//! An iceoryx2 0.10 event is a Unix datagram per listener: a process subscribed to three topics
//! owns three sockets, each publish costs a `sendto` per listener, and each wake-up costs an
//! `epoll_wait`, an `fcntl` per fired descriptor and two or three `recvfrom` to drain. Its
//! notifier/listener race can also leave a listener deaf for good (`docs/upstream/`). A
//! doorbell is instead one 32-bit counter per consumer in a shared-memory table:
//!
//! - **Ring** (publisher, after `send`): add one to the counter of every consumer subscribed to
//!   the topic, and only if that consumer is asleep, `futex(FUTEX_WAKE)`. A publish to a busy or
//!   polling consumer costs no system call at all.
//! - **Wait** (consumer): read the counter, look at *all* its subscribers, and if nothing is
//!   pending, `futex(FUTEX_WAIT, counter == seen, timeout)`. Every topic of the consumer shares
//!   the one counter, so samples published while it works are one wake-up, not one per topic.
//! - **Threshold** (consumer, optional): a consumer that knows it needs N more samples before
//!   it can do anything (the estimator on a tick with gyro, inclinometer and magnetometer
//!   samples due: 3) asks to be woken at the N-th ring after `seen`
//!   ([`Bell::wait_for_rings`]); the rings before it only count. One wake-up per cycle, however
//!   the samples' publishers are scheduled.
//!
//! # No lost wake-up
//!
//! The consumer reads the counter *before* looking at its subscribers, and the kernel's
//! `FUTEX_WAIT` sleeps only while the counter still equals what it read. A publisher adds to the
//! counter *after* its sample is in shared memory. So a sample is either seen by the look, or its
//! ring changed the counter first and the wait returns at once. The "asleep" check is a Dekker
//! pair: the consumer raises `sleepers` then the kernel reads the counter; the publisher raises
//! the counter then reads `sleepers`; both are sequentially consistent read-modify-writes, so at
//! least one side sees the other's write and no ring is skipped for a sleeping consumer. There
//! is no state that a drain must reset (the iceoryx2 race was a reset racing a send), hence
//! nothing to race. `tests` ping-pong between threads with no timeout fallback to catch one.
//!
//! The threshold keeps this: the consumer stores the count it wants waking at (`wake_at`)
//! *before* it raises `sleepers`, and a publisher reads `wake_at` *after* it has seen
//! `sleepers` raised, so it compares its ring with the threshold of the wait it may end. A ring
//! below the threshold skips the `FUTEX_WAKE` only for a consumer that asked to sleep through
//! it; a ring that lands before the consumer is in the kernel still changes the counter, so
//! the wait returns at once (one early look, never a lost one). The consumer counts only
//! samples it awaits, so every ring after `seen` is at least one of them or an extra.
//!
//! # The table
//!
//! One file per bus prefix, `/dev/shm/<prefix>doorbells`, created zero-filled by whichever
//! process comes first (all zeroes is the valid empty table, so concurrent creators agree) and
//! removed with the bus's other shared memory ([`crate::remove_all`]). It holds
//! [`MAX_CONSUMERS`] doorbells, each claimed by one [`Bus`](crate::Bus) and freed when it is
//! dropped (a dead process's doorbell is taken over when no free one is left), and
//! [`MAX_TOPICS`] topic entries, each a topic name's hash and the set of doorbells subscribed to
//! it, and per doorbell and topic the time stamp from which a publish rings
//! ([`Bell::ring_from`]: a consumer that needs only some samples of a topic to wake, such as a
//! 2.5-Hz sensor model on a 10-Hz truth stream, is not woken for the others).

use std::fs::OpenOptions;
use std::io;
use std::os::fd::AsRawFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::time::Duration;

use crate::BusError;

/// Consumers (buses) one table has room for.
pub const MAX_CONSUMERS: usize = 64;
/// Topics one table has room for.
pub const MAX_TOPICS: usize = 64;

/// The table's first word once initialised: layout name and version.
const MAGIC: u64 = u64::from_le_bytes(*b"tbbell03");

/// One consumer's doorbell, alone on its cache line (publishers of other consumers do not
/// contend for it).
#[repr(C, align(64))]
struct BellSlot {
    /// Rings so far (wrapping); the futex word.
    rings: AtomicU32,
    /// Threads of the owner waiting in `FUTEX_WAIT` on `rings`.
    sleepers: AtomicU32,
    /// Process id of the owner; 0 when free.
    owner: AtomicU32,
    /// The ring count at which a sleeping owner wants waking ([`Bell::wait_for_rings`]):
    /// publishers ring the futex only from it on. Written by the owner before it raises
    /// `sleepers`.
    wake_at: AtomicU32,
}

#[repr(C)]
struct TopicSlot {
    /// Hash of the topic name ([`topic_key`]); 0 when free.
    key: AtomicU64,
    /// Bit `i` set: doorbell `i` is rung on every publish.
    consumers: AtomicU64,
}

#[repr(C)]
struct Table {
    magic: AtomicU64,
    bells: [BellSlot; MAX_CONSUMERS],
    topics: [TopicSlot; MAX_TOPICS],
    /// `ring_from[bell][topic]`: a publish on the topic rings the doorbell only for a sample
    /// stamped at or after this time, ns (run time of the sample header); 0 rings for every
    /// sample.
    ring_from: [[AtomicU64; MAX_TOPICS]; MAX_CONSUMERS],
}

/// A mapping of one bus prefix's table.
pub(crate) struct Doorbells {
    table: *const Table,
    path: PathBuf,
}

impl Drop for Doorbells {
    fn drop(&mut self) {
        // SAFETY: `table` is the start of a mapping of exactly `size_of::<Table>()` bytes made by
        // `open`, unmapped only here.
        unsafe { libc::munmap(self.table as *mut libc::c_void, size_of::<Table>()) };
    }
}

fn table_error(path: &Path, what: &str, e: impl std::fmt::Display) -> BusError {
    BusError::Doorbell {
        path: path.display().to_string(),
        reason: format!("{what}: {e}"),
    }
}

impl Doorbells {
    /// Maps the table of the bus whose shared-memory files start with `prefix`, creating it if
    /// it does not exist.
    pub(crate) fn open(prefix: &str) -> Result<Rc<Self>, BusError> {
        Self::open_at(&PathBuf::from(format!("/dev/shm/{prefix}doorbells")))
    }

    fn open_at(path: &Path) -> Result<Rc<Self>, BusError> {
        // Owner only, like the run's other shared memory: nobody else may ring or stop a
        // doorbell.
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .mode(0o600)
            .open(path)
            .map_err(|e| table_error(path, "opening", e))?;
        let size = size_of::<Table>() as u64;
        let len = file
            .metadata()
            .map_err(|e| table_error(path, "reading its size", e))?
            .len();
        if len == 0 {
            // Zero-filled is the empty table; a concurrent creator truncating to the same size
            // changes nothing.
            file.set_len(size)
                .map_err(|e| table_error(path, "sizing", e))?;
        } else if len != size {
            return Err(table_error(
                path,
                "unexpected size",
                format!("{len} bytes, this version's table has {size} (another version's run?)"),
            ));
        }
        // SAFETY: maps `size` bytes of a file of that size, shared, for reading and writing;
        // the result is checked before use.
        let map = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                size as usize,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        if map == libc::MAP_FAILED {
            return Err(table_error(path, "mapping", io::Error::last_os_error()));
        }
        let this = Self {
            table: map as *const Table,
            path: path.to_owned(),
        };
        match this
            .table()
            .magic
            .compare_exchange(0, MAGIC, Ordering::AcqRel, Ordering::Acquire)
        {
            Ok(_) => {}
            Err(MAGIC) => {}
            Err(other) => {
                return Err(table_error(
                    path,
                    "not a doorbell table of this version",
                    format!("first word {other:#x}"),
                ));
            }
        }
        Ok(Rc::new(this))
    }

    fn table(&self) -> &Table {
        // SAFETY: the mapping lives as long as `self`, has the size and alignment of `Table`
        // (page aligned), and every field is an atomic, valid for any bit pattern.
        unsafe { &*self.table }
    }

    /// Claims a free doorbell for this process (or one whose owner died).
    pub(crate) fn claim(self: &Rc<Self>) -> Result<Bell, BusError> {
        let pid = std::process::id();
        let table = self.table();
        let free = (0..MAX_CONSUMERS).find(|&i| {
            table.bells[i]
                .owner
                .compare_exchange(0, pid, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        });
        let index = match free {
            Some(i) => i,
            None => (0..MAX_CONSUMERS)
                .find(|&i| {
                    let owner = table.bells[i].owner.load(Ordering::Acquire);
                    owner != pid
                        && !process_alive(owner)
                        && table.bells[i]
                            .owner
                            .compare_exchange(owner, pid, Ordering::AcqRel, Ordering::Acquire)
                            .is_ok()
                })
                .ok_or_else(|| {
                    table_error(
                        &self.path,
                        "claiming a doorbell",
                        format!("all {MAX_CONSUMERS} are taken by live processes"),
                    )
                })?,
        };
        // A doorbell taken over from a dead process: nobody sleeps on it and it is subscribed
        // to nothing of ours yet.
        table.bells[index].sleepers.store(0, Ordering::SeqCst);
        let bit = !(1u64 << index);
        for topic in &table.topics {
            topic.consumers.fetch_and(bit, Ordering::AcqRel);
        }
        for from in &table.ring_from[index] {
            from.store(0, Ordering::SeqCst);
        }
        Ok(Bell {
            doorbells: self.clone(),
            index,
            subscriptions: std::cell::RefCell::new([0; MAX_TOPICS]),
        })
    }

    /// The entry of topic `name`, claimed if it has none yet.
    pub(crate) fn topic(self: &Rc<Self>, name: &str) -> Result<TopicBells, BusError> {
        let key = topic_key(name);
        let table = self.table();
        for (index, slot) in table.topics.iter().enumerate() {
            match slot
                .key
                .compare_exchange(0, key, Ordering::AcqRel, Ordering::Acquire)
            {
                Ok(_) => {
                    return Ok(TopicBells {
                        doorbells: self.clone(),
                        index,
                    });
                }
                Err(existing) if existing == key => {
                    return Ok(TopicBells {
                        doorbells: self.clone(),
                        index,
                    });
                }
                Err(_) => {}
            }
        }
        Err(table_error(
            &self.path,
            "registering a topic",
            format!("all {MAX_TOPICS} topic entries are taken (topic {name:?})"),
        ))
    }
}

/// 64-bit FNV-1a of the topic name, never 0 (0 marks a free entry).
fn topic_key(name: &str) -> u64 {
    let hash = name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    hash.max(1)
}

fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: signal 0 only checks that the process exists.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
}

/// How a [`Bell::wait`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Woken {
    /// The doorbell was rung (the counter differs from the one waited on).
    Rung,
    /// The timeout passed.
    TimedOut,
    /// A signal arrived (a termination request is checked by the caller).
    Interrupted,
}

/// The doorbell a [`Bus`](crate::Bus) owns: every subscriber created from the bus has it rung.
pub(crate) struct Bell {
    doorbells: Rc<Doorbells>,
    index: usize,
    /// How many subscribers of this bus each topic entry has (the bit is cleared at zero).
    subscriptions: std::cell::RefCell<[u32; MAX_TOPICS]>,
}

impl Drop for Bell {
    fn drop(&mut self) {
        let slot = self.slot();
        let bit = !(1u64 << self.index);
        for topic in &self.doorbells.table().topics {
            topic.consumers.fetch_and(bit, Ordering::AcqRel);
        }
        slot.owner.store(0, Ordering::Release);
    }
}

impl Bell {
    fn slot(&self) -> &BellSlot {
        &self.doorbells.table().bells[self.index]
    }

    /// Has this doorbell rung by every publish on `topic` until [`unsubscribe`](Self::unsubscribe).
    pub(crate) fn subscribe(&self, topic: &TopicBells) {
        let mut counts = self.subscriptions.borrow_mut();
        counts[topic.index] += 1;
        self.doorbells.table().topics[topic.index]
            .consumers
            .fetch_or(1 << self.index, Ordering::AcqRel);
    }

    /// Undoes one [`subscribe`](Self::subscribe).
    pub(crate) fn unsubscribe(&self, topic: &TopicBells) {
        let mut counts = self.subscriptions.borrow_mut();
        counts[topic.index] = counts[topic.index].saturating_sub(1);
        if counts[topic.index] == 0 {
            self.doorbells.table().topics[topic.index]
                .consumers
                .fetch_and(!(1 << self.index), Ordering::AcqRel);
            self.ring_from(topic, 0);
        }
    }

    /// From now on publishes on `topic` ring this doorbell only for samples stamped at or after
    /// `time_ns` (earlier ones are delivered all the same, and taken with the next wake-up);
    /// 0 rings for every sample. Shared by all subscribers of the topic on this doorbell.
    ///
    /// A publisher reads the time after its sample is sent, so a sample stamped at or after
    /// `time_ns` that was sent before this call may have been sent unrung: the caller looks at
    /// its subscriber once more after this call, or waits for the next ring.
    pub(crate) fn ring_from(&self, topic: &TopicBells, time_ns: u64) {
        self.doorbells.table().ring_from[self.index][topic.index].store(time_ns, Ordering::SeqCst);
    }

    /// The ring counter now. Read it *before* looking for samples, and wait on it.
    pub(crate) fn rings(&self) -> u32 {
        self.slot().rings.load(Ordering::SeqCst)
    }

    /// Sleeps until the doorbell rings after `seen` was read, `timeout` passes or a signal
    /// arrives. Returns at once if it rang already.
    #[cfg(test)]
    pub(crate) fn wait(&self, seen: u32, timeout: Duration) -> Woken {
        self.wait_for_rings(seen, 1, timeout)
    }

    /// Like [`wait`](Self::wait), but sleeps through the rings after `seen` until the
    /// `rings`-th (at least 1): for a consumer that needs that many more samples before it can
    /// act. Returns at once if the count moved since `seen` (before the consumer was asleep, a
    /// ring cannot be told from the threshold's last one).
    pub(crate) fn wait_for_rings(&self, seen: u32, rings: u32, timeout: Duration) -> Woken {
        let slot = self.slot();
        // Bounded so that `reached` stays meaningful across the counter's wrap.
        let rings = rings.clamp(1, MAX_RINGS_AWAITED);
        slot.wake_at
            .store(seen.wrapping_add(rings), Ordering::SeqCst);
        slot.sleepers.fetch_add(1, Ordering::SeqCst);
        let woken = futex_wait(&slot.rings, seen, timeout);
        slot.sleepers.fetch_sub(1, Ordering::SeqCst);
        woken
    }
}

/// The doorbells subscribed to one topic: what a publisher rings.
pub(crate) struct TopicBells {
    doorbells: Rc<Doorbells>,
    index: usize,
}

impl TopicBells {
    /// Rings every doorbell subscribed to the topic; returns how many.
    pub(crate) fn ring(&self) -> u32 {
        self.ring_for(u64::MAX)
    }

    /// Rings every doorbell subscribed to the topic that asked to be rung for a sample stamped
    /// `time_ns` ([`Bell::ring_from`]); returns how many.
    pub(crate) fn ring_for(&self, time_ns: u64) -> u32 {
        let table = self.doorbells.table();
        // The sample was sent before the consumers' times are read, and a consumer sets its
        // time before it looks for samples: with a full fence on both sides (the consumer's
        // sequentially consistent store is one) either the consumer finds the sample or this
        // publisher finds the new time.
        std::sync::atomic::fence(Ordering::SeqCst);
        let mut consumers = table.topics[self.index].consumers.load(Ordering::Acquire);
        let mut rung = 0;
        while consumers != 0 {
            let index = consumers.trailing_zeros() as usize;
            consumers &= consumers - 1;
            if time_ns >= table.ring_from[index][self.index].load(Ordering::SeqCst) {
                ring_slot(&table.bells[index]);
                rung += 1;
            }
        }
        rung
    }
}

/// Most rings a consumer may sleep through ([`Bell::wait_for_rings`]).
pub(crate) const MAX_RINGS_AWAITED: u32 = 1 << 16;

fn ring_slot(slot: &BellSlot) {
    let rings = slot.rings.fetch_add(1, Ordering::SeqCst).wrapping_add(1);
    if slot.sleepers.load(Ordering::SeqCst) != 0
        && reached(rings, slot.wake_at.load(Ordering::SeqCst))
    {
        futex_wake(&slot.rings);
    }
}

/// Whether the ring count `rings` is at or past `wake_at`, across the counter's wrap.
fn reached(rings: u32, wake_at: u32) -> bool {
    rings.wrapping_sub(wake_at) < u32::MAX / 2
}

/// A doorbell private to one process, for an event loop without subscribers (intervals only):
/// it is never rung, and waiting on it is a sleep that a signal interrupts.
pub(crate) struct LocalBell {
    rings: AtomicU32,
}

impl LocalBell {
    pub(crate) fn new() -> Self {
        Self {
            rings: AtomicU32::new(0),
        }
    }

    pub(crate) fn rings(&self) -> u32 {
        self.rings.load(Ordering::SeqCst)
    }

    pub(crate) fn wait(&self, seen: u32, timeout: Duration) -> Woken {
        futex_wait(&self.rings, seen, timeout)
    }
}

/// `FUTEX_WAIT` (shared: the word may be in memory mapped by several processes) on `word` while
/// it equals `seen`, for at most `timeout`.
fn futex_wait(word: &AtomicU32, seen: u32, timeout: Duration) -> Woken {
    if timeout.is_zero() {
        return if word.load(Ordering::SeqCst) == seen {
            Woken::TimedOut
        } else {
            Woken::Rung
        };
    }
    // Longer than any loop waits; keeps the timespec in range.
    let timeout = timeout.min(Duration::from_secs(3600));
    let ts = libc::timespec {
        tv_sec: timeout.as_secs() as libc::time_t,
        tv_nsec: timeout.subsec_nanos() as libc::c_long,
    };
    // SAFETY: FUTEX_WAIT reads the aligned 32-bit word `word` points to and the timespec; it
    // writes nothing.
    let r = unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAIT,
            seen,
            &ts as *const libc::timespec,
            std::ptr::null::<u32>(),
            0,
        )
    };
    if r == 0 {
        return Woken::Rung;
    }
    match io::Error::last_os_error().raw_os_error() {
        Some(libc::EAGAIN) => Woken::Rung,
        Some(libc::ETIMEDOUT) => Woken::TimedOut,
        // EINTR; anything else (cannot happen for a valid word) is treated like a signal: the
        // caller looks again and waits again.
        _ => Woken::Interrupted,
    }
}

fn futex_wake(word: &AtomicU32) {
    // SAFETY: FUTEX_WAKE only uses the address as a key; it reads and writes no memory.
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAKE,
            i32::MAX,
            std::ptr::null::<libc::timespec>(),
            std::ptr::null::<u32>(),
            0,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    use std::time::Instant;

    fn table_path(name: &str) -> PathBuf {
        PathBuf::from(format!(
            "/dev/shm/tbtest{}_{name}_doorbells",
            std::process::id()
        ))
    }

    #[test]
    fn a_ring_wakes_a_waiter_and_a_ring_before_the_wait_is_not_lost() {
        let path = table_path("ring");
        let doorbells = Doorbells::open_at(&path).expect("table");
        let bell = doorbells.claim().expect("bell");
        let topic = doorbells.topic("a/topic").expect("topic");
        bell.subscribe(&topic);

        // Rung between reading the counter and waiting: the wait returns at once.
        let seen = bell.rings();
        assert_eq!(topic.ring(), 1);
        let started = Instant::now();
        assert_eq!(bell.wait(seen, Duration::from_secs(5)), Woken::Rung);
        assert!(started.elapsed() < Duration::from_secs(1));

        // Nothing rung: times out.
        let seen = bell.rings();
        assert_eq!(bell.wait(seen, Duration::from_millis(20)), Woken::TimedOut);

        // Unsubscribed: the topic rings nobody.
        bell.unsubscribe(&topic);
        assert_eq!(topic.ring(), 0);
        drop(bell);
        drop(topic);
        drop(doorbells);
        std::fs::remove_file(&path).expect("removing the table");
    }

    #[test]
    fn a_waiter_sleeps_through_the_rings_below_its_threshold() {
        let path = table_path("threshold");
        let doorbells = Doorbells::open_at(&path).expect("table");
        let bell = doorbells.claim().expect("bell");
        let topic = doorbells.topic("a/topic").expect("topic");
        bell.subscribe(&topic);
        let index = bell.index;

        // The owner waits for 3 rings; another thread rings twice, then a third time.
        let seen = bell.rings();
        let ringer = {
            let path = path.clone();
            std::thread::spawn(move || {
                let doorbells = Doorbells::open_at(&path).expect("table");
                let topic = doorbells.topic("a/topic").expect("topic");
                let sleepers = || {
                    doorbells.table().bells[index]
                        .sleepers
                        .load(Ordering::SeqCst)
                };
                // Ring only once the owner is asleep (or about to be, in the kernel).
                while sleepers() == 0 {
                    std::thread::sleep(Duration::from_millis(1));
                }
                std::thread::sleep(Duration::from_millis(20));
                topic.ring();
                topic.ring();
                // Two rings below the threshold: the owner must still be asleep 200 ms later.
                std::thread::sleep(Duration::from_millis(200));
                let asleep_after_two = sleepers() == 1;
                let third_at = Instant::now();
                topic.ring();
                (asleep_after_two, third_at)
            })
        };
        let woken = bell.wait_for_rings(seen, 3, Duration::from_secs(10));
        let woke_at = Instant::now();
        let (asleep_after_two, third_at) = ringer.join().expect("ringer");
        assert_eq!(woken, Woken::Rung);
        assert!(
            asleep_after_two,
            "two rings woke a waiter that asked for three"
        );
        assert!(woke_at >= third_at, "woken before the third ring");
        assert_eq!(bell.rings(), seen.wrapping_add(3));

        // A ring between reading the count and the wait still returns at once, threshold or
        // not (it cannot be told from the threshold's last ring).
        let seen = bell.rings();
        topic.ring();
        let started = Instant::now();
        assert_eq!(
            bell.wait_for_rings(seen, 3, Duration::from_secs(5)),
            Woken::Rung
        );
        assert!(started.elapsed() < Duration::from_secs(1));

        // The threshold holds across the counter's wrap.
        assert!(reached(2, u32::MAX - 1));
        assert!(reached(5, 5));
        assert!(!reached(4, 5));
        assert!(!reached(u32::MAX, 1));

        drop((bell, topic, doorbells));
        std::fs::remove_file(&path).expect("removing the table");
    }

    #[test]
    fn a_doorbell_is_rung_only_for_samples_from_the_time_it_asked_for() {
        let path = table_path("from");
        let doorbells = Doorbells::open_at(&path).expect("table");
        let sparse = doorbells.claim().expect("bell");
        let every = doorbells.claim().expect("bell");
        let topic = doorbells.topic("a/topic").expect("topic");
        sparse.subscribe(&topic);
        every.subscribe(&topic);

        sparse.ring_from(&topic, 400);
        let (sparse_seen, every_seen) = (sparse.rings(), every.rings());
        // Stamped before 400: only the consumer that wants every sample is rung.
        assert_eq!(topic.ring_for(100), 1);
        assert_eq!(sparse.rings(), sparse_seen);
        assert_eq!(every.rings(), every_seen.wrapping_add(1));
        // At and after 400: both.
        assert_eq!(topic.ring_for(400), 2);
        assert_eq!(topic.ring_for(500), 2);
        assert_eq!(sparse.rings(), sparse_seen.wrapping_add(2));
        // A ring without a time (a new publisher) rings everyone.
        sparse.ring_from(&topic, u64::MAX - 1);
        assert_eq!(topic.ring(), 2);

        // Unsubscribing resets the time: a later subscription is rung for every sample, and
        // so is a doorbell claimed after this one was freed.
        sparse.unsubscribe(&topic);
        sparse.subscribe(&topic);
        assert_eq!(topic.ring_for(0), 2);
        sparse.ring_from(&topic, 1_000);
        let index = sparse.index;
        drop(sparse);
        let again = doorbells.claim().expect("bell");
        assert_eq!(again.index, index);
        again.subscribe(&topic);
        assert_eq!(topic.ring_for(0), 2);

        drop((again, every, topic, doorbells));
        std::fs::remove_file(&path).expect("removing the table");
    }

    #[test]
    fn doorbells_are_claimed_once_and_freed_on_drop() {
        let path = table_path("claim");
        let doorbells = Doorbells::open_at(&path).expect("table");
        let bells: Vec<Bell> = (0..MAX_CONSUMERS)
            .map(|_| doorbells.claim().expect("a free doorbell"))
            .collect();
        let mut indices: Vec<usize> = bells.iter().map(|b| b.index).collect();
        indices.dedup();
        assert_eq!(indices.len(), MAX_CONSUMERS);
        let err = doorbells.claim().err().expect("the table is full");
        assert!(err.to_string().contains("doorbells"), "{err}");
        drop(bells);
        doorbells.claim().expect("freed on drop");
        // The same table opened again (another process) agrees; a table of another size is
        // refused with its path.
        drop(Doorbells::open_at(&path).expect("reopened"));
        drop(doorbells);
        std::fs::write(&path, [1u8; 10]).expect("overwrite");
        let err = Doorbells::open_at(&path)
            .err()
            .expect("wrong size")
            .to_string();
        assert!(err.contains(&path.display().to_string()), "{err}");
        std::fs::remove_file(&path).expect("removing the table");
    }

    /// Waits on `bell` until `needed` says it is done (`None`), each time for the rings it asks
    /// for (`Some(rings)`), with a 5-s timeout standing in for "forever": a timed-out wait is
    /// counted in `timeouts` and sets `failed`, which ends this and the other side's waits.
    /// Returns how many waits it made.
    fn wait_until(
        bell: &Bell,
        mut needed: impl FnMut() -> Option<u32>,
        timeouts: &AtomicU64,
        failed: &AtomicBool,
    ) -> u64 {
        let mut waits = 0;
        loop {
            let seen = bell.rings();
            let Some(rings) = needed() else {
                return waits;
            };
            if failed.load(Ordering::Relaxed) {
                return waits;
            }
            waits += 1;
            if bell.wait_for_rings(seen, rings, Duration::from_secs(5)) == Woken::TimedOut {
                timeouts.fetch_add(1, Ordering::SeqCst);
                failed.store(true, Ordering::Relaxed);
            }
        }
    }

    /// The lost wake-up a doorbell must never have: a consumer that reads the counter, finds
    /// nothing, and sleeps through a ring that came in between. Two threads exchange 100 000
    /// messages through two doorbells as fast as they can (each side waits only when it finds
    /// nothing new), with a 5-s timeout standing in for "forever": a lost wake-up shows as a
    /// timed-out wait. The bound is zero timeouts: any lost ring is a bug, not noise.
    #[test]
    fn no_wake_up_is_lost_in_a_fast_ping_pong() {
        let path = table_path("pingpong");
        const MESSAGES: u64 = 100_000;
        // Each side publishes a counter in plain shared memory (an atomic) and rings the other.
        let sent = Arc::new([AtomicU64::new(0), AtomicU64::new(0)]);
        let timeouts = Arc::new(AtomicU64::new(0));
        let failed = Arc::new(AtomicBool::new(false));
        let run = |me: usize| {
            let (sent, timeouts, failed, path) =
                (sent.clone(), timeouts.clone(), failed.clone(), path.clone());
            std::thread::spawn(move || {
                let doorbells = Doorbells::open_at(&path).expect("table");
                let bell = doorbells.claim().expect("bell");
                let mine = doorbells.topic(&format!("to/{me}")).expect("topic");
                let theirs = doorbells.topic(&format!("to/{}", 1 - me)).expect("topic");
                bell.subscribe(&mine);
                // A ring before the other side subscribed is not needed: each side looks at
                // the other's counter before it waits.
                let mut received = 0;
                for i in 1..=MESSAGES {
                    // Side 0 starts; each side answers the other's message i.
                    if me == 0 {
                        sent[0].store(i, Ordering::SeqCst);
                        theirs.ring();
                    }
                    let next = || {
                        received = sent[1 - me].load(Ordering::SeqCst);
                        (received < i).then_some(1)
                    };
                    wait_until(&bell, next, &timeouts, &failed);
                    if failed.load(Ordering::Relaxed) {
                        break;
                    }
                    if me == 1 {
                        sent[1].store(i, Ordering::SeqCst);
                        theirs.ring();
                    }
                }
                received
            })
        };
        let (a, b) = (run(0), run(1));
        let (ra, rb) = (a.join().expect("side 0"), b.join().expect("side 1"));
        assert_eq!(
            timeouts.load(Ordering::SeqCst),
            0,
            "a wait slept through a ring (side 0 got {ra}, side 1 got {rb})"
        );
        assert_eq!((ra, rb), (MESSAGES, MESSAGES));
        std::fs::remove_file(&path).expect("removing the table");
    }

    /// One side of the burst test: its own doorbell, and the data and acknowledgement topics.
    fn burst_side(path: &Path) -> (Bell, TopicBells, TopicBells) {
        let doorbells = Doorbells::open_at(path).expect("table");
        let bell = doorbells.claim().expect("bell");
        let data = doorbells.topic("burst/data").expect("topic");
        let acks = doorbells.topic("burst/ack").expect("topic");
        (bell, data, acks)
    }

    /// The same race with thresholds: one side publishes bursts of three messages, ringing after
    /// each, and the other sleeps until as many rings as messages of the burst it still misses
    /// (the estimator's wait on a tick with three sensor samples due), then acknowledges the
    /// burst. 30 000 bursts with a 5-s timeout standing in for "forever"; the bound is zero
    /// timeouts: a ring below the threshold that was the last one the waiter needed, or any
    /// other lost wake-up, is a bug.
    #[test]
    fn no_wake_up_is_lost_when_waiting_for_several_rings() {
        let path = table_path("burst");
        const BURSTS: u64 = 30_000;
        const PER_BURST: u64 = 3;
        // Messages sent by the producer so far, and bursts acknowledged by the consumer.
        let sent = Arc::new(AtomicU64::new(0));
        let acked = Arc::new(AtomicU64::new(0));
        let timeouts = Arc::new(AtomicU64::new(0));
        let failed = Arc::new(AtomicBool::new(false));
        let shared = || {
            (
                sent.clone(),
                acked.clone(),
                timeouts.clone(),
                failed.clone(),
                path.clone(),
            )
        };
        let producer = {
            let (sent, acked, timeouts, failed, path) = shared();
            std::thread::spawn(move || {
                let (bell, data, acks) = burst_side(&path);
                bell.subscribe(&acks);
                for burst in 1..=BURSTS {
                    for _ in 0..PER_BURST {
                        sent.fetch_add(1, Ordering::SeqCst);
                        data.ring();
                        // Vary the spacing so the waiter is caught at every step of its wait.
                        if burst % 7 == 0 {
                            std::thread::yield_now();
                        }
                    }
                    let acknowledged = || (acked.load(Ordering::SeqCst) < burst).then_some(1);
                    wait_until(&bell, acknowledged, &timeouts, &failed);
                    if failed.load(Ordering::Relaxed) {
                        break;
                    }
                }
            })
        };
        let consumer = {
            let (sent, acked, timeouts, failed, path) = shared();
            std::thread::spawn(move || {
                let (bell, data, acks) = burst_side(&path);
                bell.subscribe(&data);
                let mut waits = 0u64;
                for burst in 1..=BURSTS {
                    // As many rings as messages of the burst still missing.
                    let missing = || {
                        let missing =
                            (burst * PER_BURST).saturating_sub(sent.load(Ordering::SeqCst));
                        (missing > 0).then(|| u32::try_from(missing).expect("at most a burst"))
                    };
                    waits += wait_until(&bell, missing, &timeouts, &failed);
                    if failed.load(Ordering::Relaxed) {
                        break;
                    }
                    acked.store(burst, Ordering::SeqCst);
                    acks.ring();
                }
                waits
            })
        };
        producer.join().expect("producer");
        let waits = consumer.join().expect("consumer");
        assert_eq!(
            timeouts.load(Ordering::SeqCst),
            0,
            "a wait slept through the ring it needed ({} of {BURSTS} bursts acknowledged)",
            acked.load(Ordering::SeqCst)
        );
        assert_eq!(acked.load(Ordering::SeqCst), BURSTS);
        std::fs::remove_file(&path).expect("removing the table");
        eprintln!("{waits} waits for {} messages", BURSTS * PER_BURST);
    }
}
