//! The software CAN bus: raw CAN frames on the iceoryx2 topic `testbed/can/bus`
//! ([`ipc_types::CanBusFrame`]), as a [`CanTransport`].
//!
//! Every sender publishes its frames on the one topic and every receiver subscribes to it, so
//! the board, the gateways, a replay and the logger share one "bus" without a kernel CAN
//! interface. Like a CAN controller:
//!
//! - a receiver does not get its own frames back (`header.source_id` names the sender;
//!   SocketCAN's default without `CAN_RAW_RECV_OWN_MSGS`);
//! - every frame carries a frame check (CRC-15/CAN, [`testbed_can::frame_check`]); a frame
//!   whose check fails was corrupted on the bus and is dropped and counted
//!   ([`BusStats::check_errors`]), never handed to the decoder.
//!
//! Frames sent are stamped with the run-clock time set by [`SoftwareBusTransport::set_time_ns`]
//! (a frame's time is when it went on the bus; the measurement time is the board's stamp in the
//! payload). Received frames are returned with that time ([`TimeSource::Host`]).
//!
//! The transport works through `&self` (iceoryx2 ports are used through shared references), so
//! a process can attach [`SoftwareBusTransport::subscriber`] to its event loop and still send
//! and receive inside the loop's callback; [`CanTransport`] is implemented for
//! `&SoftwareBusTransport` as well.

use ipc_types::{CanBusFrame, SampleHeader};
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::time::Duration;
use testbed_bus::{
    Bus, BusError, EventLoop, Flow, SubscriberOptions, TopicPublisher, TopicSubscriber, Waiter,
};
use testbed_can::{
    BusFrameError, CanFrame, CanTransport, TimeSource, TimestampedFrame, TransportError,
};

/// Counts of a [`SoftwareBusTransport`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusStats {
    /// Frames sent (including deliberately corrupted ones).
    pub sent: u64,
    /// Frames received from other senders with a valid check.
    pub received: u64,
    /// Frames dropped because their frame check failed.
    pub check_errors: u64,
    /// Frames whose check matched but whose fields are not a valid frame.
    pub invalid: u64,
    /// Own frames seen on the bus and skipped.
    pub own: u64,
}

/// A [`CanTransport`] over the software CAN bus; see the [module documentation](self).
pub struct SoftwareBusTransport {
    publisher: TopicPublisher<CanBusFrame>,
    subscriber: TopicSubscriber<CanBusFrame>,
    source: u32,
    flags: u32,
    time_ns: Cell<u64>,
    sequence: Cell<u64>,
    queue: RefCell<VecDeque<TimestampedFrame>>,
    stats: Cell<BusStats>,
}

impl std::fmt::Debug for SoftwareBusTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SoftwareBusTransport")
            .field("source", &self.source)
            .field("stats", &self.stats.get())
            .finish()
    }
}

fn bus_error(context: &str, e: BusError) -> TransportError {
    TransportError::Io {
        context: context.to_string(),
        source: std::io::Error::other(e),
    }
}

impl SoftwareBusTransport {
    /// Joins the bus as sender `source` (`ipc_types::can_source`), sending frames with header
    /// `flags` (e.g. `VALID | SIMULATED`), receiving into a buffer of `buffer` frames.
    pub fn open(bus: &Bus, source: u32, flags: u32, buffer: usize) -> Result<Self, BusError> {
        Ok(Self {
            publisher: bus.publisher::<CanBusFrame>()?,
            subscriber: bus.subscriber_with::<CanBusFrame>(SubscriberOptions::buffer(buffer))?,
            source,
            flags,
            time_ns: Cell::new(0),
            sequence: Cell::new(0),
            queue: RefCell::new(VecDeque::new()),
            stats: Cell::new(BusStats::default()),
        })
    }

    /// The subscriber, to attach to an event loop ([`EventLoop::on_data`]).
    pub fn subscriber(&self) -> &TopicSubscriber<CanBusFrame> {
        &self.subscriber
    }

    /// Run-clock time stamped on the frames sent from now on, ns.
    pub fn set_time_ns(&self, time_ns: u64) {
        self.time_ns.set(time_ns);
    }

    /// The counts so far.
    pub fn stats(&self) -> BusStats {
        self.stats.get()
    }

    fn update(&self, f: impl FnOnce(&mut BusStats)) {
        let mut s = self.stats.get();
        f(&mut s);
        self.stats.set(s);
    }

    fn header(&self) -> SampleHeader {
        let sequence = self.sequence.get();
        self.sequence.set(sequence + 1);
        SampleHeader::new(self.time_ns.get(), sequence, self.flags).with_source(self.source)
    }

    /// Sends `frame`.
    pub fn send_frame(&self, frame: &CanFrame) -> Result<(), TransportError> {
        let sample = frame.to_bus_frame(self.header());
        self.publisher
            .publish(&sample)
            .map_err(|e| bus_error("sending on the software CAN bus", e))?;
        self.update(|s| s.sent += 1);
        Ok(())
    }

    /// Fault injection: sends `frame` with bit `bit` (of its 16 bytes, little-endian order)
    /// flipped after the frame check was computed, so every receiver's check fails.
    pub fn send_corrupted(&self, frame: &CanFrame, bit: u32) -> Result<(), TransportError> {
        let mut sample = frame.to_bus_frame(self.header());
        corrupt(&mut sample, bit);
        self.publisher
            .publish(&sample)
            .map_err(|e| bus_error("sending on the software CAN bus", e))?;
        self.update(|s| s.sent += 1);
        Ok(())
    }

    /// Moves every pending sample into the queue, checking each.
    fn fill(&self) -> Result<(), TransportError> {
        let mut queue = self.queue.borrow_mut();
        let mut stats = self.stats.get();
        self.subscriber
            .drain(|sample| {
                if sample.header.source_id == self.source {
                    stats.own += 1;
                    return;
                }
                match CanFrame::from_bus_frame(sample) {
                    Ok(frame) => {
                        stats.received += 1;
                        queue.push_back(TimestampedFrame {
                            frame,
                            time_ns: sample.header.time_ns,
                            source: TimeSource::Host,
                        });
                    }
                    Err(BusFrameError::Check { .. }) => stats.check_errors += 1,
                    Err(BusFrameError::Invalid(_)) => stats.invalid += 1,
                }
            })
            .map_err(|e| bus_error("receiving from the software CAN bus", e))?;
        self.stats.set(stats);
        Ok(())
    }

    /// The next received frame, if one is pending (never waits).
    pub fn poll(&self) -> Result<Option<TimestampedFrame>, TransportError> {
        if self.queue.borrow().is_empty() {
            self.fill()?;
        }
        Ok(self.queue.borrow_mut().pop_front())
    }

    /// Waits up to `timeout` for a frame.
    fn wait(&self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        if let Some(frame) = self.poll()? {
            return Ok(Some(frame));
        }
        if timeout.is_zero() {
            return Ok(None);
        }
        let waiter = Waiter::new().map_err(|e| bus_error("waiting on the software CAN bus", e))?;
        let mut events = EventLoop::new(&waiter);
        events
            .on_data(&self.subscriber)
            .map_err(|e| bus_error("waiting on the software CAN bus", e))?;
        let deadline = std::time::Instant::now().checked_add(timeout);
        loop {
            if let Some(frame) = self.poll()? {
                return Ok(Some(frame));
            }
            let left = deadline.map_or(Duration::MAX, |d| {
                d.saturating_duration_since(std::time::Instant::now())
            });
            if left.is_zero() {
                return Ok(None);
            }
            let exit = events
                .run_once(left, |_| Flow::Stop)
                .map_err(|e| bus_error("waiting on the software CAN bus", e))?;
            if exit == Some(testbed_bus::LoopExit::TerminationRequested) {
                return Err(TransportError::Closed);
            }
        }
    }
}

/// Flips bit `bit` (mod 128) of the 16 checked bytes of `sample`: `can_id` (little-endian),
/// `len`, three zero bytes, `data`.
pub fn corrupt(sample: &mut CanBusFrame, bit: u32) {
    let bit = bit % 128;
    let (byte, shift) = ((bit / 8) as usize, bit % 8);
    match byte {
        0..4 => sample.can_id ^= 1 << (8 * byte as u32 + shift),
        4 => sample.len ^= 1 << shift,
        5..8 => sample.check ^= 1 << shift, // the zero bytes: damage the check itself
        _ => {
            if let Some(b) = sample.data.get_mut(byte - 8) {
                *b ^= 1 << shift;
            }
        }
    }
}

impl CanTransport for &SoftwareBusTransport {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.send_frame(frame)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        self.wait(timeout)
    }
}

impl CanTransport for SoftwareBusTransport {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.send_frame(frame)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        self.wait(timeout)
    }
}
