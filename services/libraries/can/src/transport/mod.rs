//! Transports: everything that moves [`CanFrame`]s, behind one trait.
//!
//! - [`SocketCanTransport`]: a Linux SocketCAN interface (`can0`, `vcan0`), kernel receive
//!   time stamps and identifier filters.
//! - [`CandumpReplay`] / [`CandumpWriter`] / [`Recorder`]: `candump -L` logs, replayed paced
//!   by their time stamps or as fast as possible, and written.
//! - [`SerialTransport`]: a device wired directly by RS-232, the same frames in a COBS framing
//!   with CRC-16 (see [`serial`]).
//! - [`MemoryTransport`]: an in-process pair, for tests and simulated nodes.
//!
//! # Extension point: the software bus
//!
//! A transport carrying raw frames over the project's iceoryx2 bus (so several gateways, a
//! logger and a simulated node can share one "bus" without a kernel CAN interface) is an
//! implementation of [`CanTransport`]:
//!
//! - [`CanFrame`] is a 16-byte `#[repr(C)]` value without padding holes (`can_id: u32` with the
//!   Linux [`EXTENDED_FLAG`](crate::frame_consts::EXTENDED_FLAG)/[`REMOTE_FLAG`](crate::frame_consts::REMOTE_FLAG)
//!   bits, `len: u8`, 3 zero bytes, `data: [u8; 8]`). A fixed-layout `ipc-types` sample (e.g.
//!   a `RawCanFrame` holding a `SampleHeader` with the receive time, then these 16 bytes)
//!   converts with [`CanFrame::can_id`], [`CanFrame::dlc`], [`CanFrame::data_padded`] and back
//!   with [`CanFrame::from_linux_parts`], which validates.
//! - `send` publishes one sample; `recv(timeout)` waits on the bus's doorbell for at most
//!   `timeout` and returns `Ok(None)` when nothing came, `Err(TransportError::Closed)`
//!   when the publisher is gone for good.
//! - Time stamps: [`TimeSource::Host`] with the publisher's receive time.
//!
//! Everything above the trait ([`crate::Decoder`], gateways, [`Recorder`]) then works
//! unchanged.

pub mod candump;
mod memory;
pub mod serial;
mod socketcan;

pub use candump::{
    CandumpEntry, CandumpReader, CandumpReplay, CandumpWriter, LineError, LogStats, MalformedLine,
    Pacing, Recorder, format_candump_line, parse_candump_line,
};
pub use memory::MemoryTransport;
pub use serial::{SerialConfig, SerialTransport};
pub use socketcan::{SocketCanSupport, SocketCanTransport, probe_socketcan};

#[allow(unused_imports)] // used by the module documentation
use crate::frame::TimeSource;
use crate::frame::{CanFrame, TimestampedFrame};
use std::time::Duration;

/// Why a transport operation failed.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// The machine or kernel lacks what the transport needs (e.g. no SocketCAN).
    #[error("not supported here: {0}")]
    Unsupported(String),
    /// The named interface, port or file does not exist.
    #[error("{0} not found")]
    NotFound(String),
    /// An operating-system error.
    #[error("{context}: {source}")]
    Io {
        /// What was being done.
        context: String,
        /// The error.
        source: std::io::Error,
    },
    /// The transport cannot carry this frame (e.g. an extended identifier over serial).
    #[error("frame {frame} not supported by this transport: {reason}")]
    FrameNotSupported {
        /// The frame.
        frame: CanFrame,
        /// Why.
        reason: &'static str,
    },
    /// The stream ended (end of a log, peer gone) and no frame will ever come.
    #[error("transport closed")]
    Closed,
    /// An invalid setting.
    #[error("invalid transport setting: {0}")]
    Config(String),
}

impl TransportError {
    pub(crate) fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        TransportError::Io {
            context: context.into(),
            source,
        }
    }
}

/// Something that sends and receives classic CAN frames.
pub trait CanTransport {
    /// Send one frame (may block briefly while the device's queue is full).
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError>;

    /// Receive the next frame, waiting at most `timeout`; `Ok(None)` if none came in time.
    /// `Duration::ZERO` polls.
    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError>;
}

/// The end of a wait of `timeout` from now; `None` if it lies beyond what `Instant` holds
/// (wait without limit).
pub(crate) fn deadline_after(timeout: Duration) -> Option<std::time::Instant> {
    std::time::Instant::now().checked_add(timeout)
}

/// Time left until `deadline` (`Duration::MAX` without deadline, zero once passed).
pub(crate) fn time_left(deadline: Option<std::time::Instant>) -> Duration {
    deadline.map_or(Duration::MAX, |d| {
        d.saturating_duration_since(std::time::Instant::now())
    })
}

impl<T: CanTransport + ?Sized> CanTransport for &mut T {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        (**self).send(frame)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        (**self).recv(timeout)
    }
}

impl<T: CanTransport + ?Sized> CanTransport for Box<T> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        (**self).send(frame)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        (**self).recv(timeout)
    }
}
