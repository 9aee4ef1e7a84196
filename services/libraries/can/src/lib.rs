//! The real platform path: the smart CAN node's protocol, its codec and the CAN transports.
//!
//! On the platform every sensor and actuator reaches the computer over one CAN bus through a
//! "smart CAN node" that talks RS-232/RS-485 to the devices. This crate is the library half of
//! the CAN and serial gateways:
//!
//! - [`protocol`]: the protocol itself (also in `services/libraries/can/PROTOCOL.md`, which is the
//!   module's documentation): 11-bit identifier map with a configurable base ([`IdMap`]),
//!   fixed-point payloads ([`Quantity`]), rolling counters, the node's µs time stamps,
//!   multi-frame samples. Device ranges and command limits ([`Limits`]) come from the model
//!   configuration.
//! - [`Encoder`] / [`Decoder`]: every message both ways, no I/O, never panics. The decoder
//!   classifies every frame ([`FrameClass`]), counts every class and event ([`DecoderStats`])
//!   and reassembles multi-frame samples into typed [`Message`]s in SI units, which convert to
//!   the `ipc-types` samples the gateways publish ([`Message::to_sample`]).
//! - [`transport`]: [`CanTransport`] and its implementations — SocketCAN, `candump -L` logs
//!   (replay and recording), RS-232 serial, in-memory — and the extension point for the
//!   software bus. [`CanFrame::to_bus_frame`] / [`CanFrame::from_bus_frame`] convert to and
//!   from the software bus's sample (`ipc_types::CanBusFrame`) with its frame check; the
//!   transport itself is `testbed_processes::software_bus::SoftwareBusTransport`.
//!
//! A gateway's loop is: `transport.recv(timeout)` → `decoder.decode(&frame)` → for each
//! completed [`Received`], map [`Message::node_time_us`] through a [`NodeClock`] to the run
//! clock and publish [`Message::to_sample`]; for commands, `encoder.encode(&message)` →
//! `transport.send` for each frame.
//!
//! ```
//! use testbed_can::{Decoder, Encoder, GyroMsg, Message, Protocol, DeviceStatus};
//!
//! let protocol = Protocol::default();
//! let mut encoder = Encoder::new(protocol);
//! let mut decoder = Decoder::new(protocol);
//! let sample = Message::Gyro(GyroMsg {
//!     node_time_us: 1_000_000,
//!     status: DeviceStatus::default(),
//!     rate_rad_s: [1e-3, -2e-3, 0.5],
//! });
//! let frames = encoder.encode(&sample).expect("in range");
//! let mut decoded = None;
//! for frame in &frames {
//!     decoded = decoder.decode(frame).message.or(decoded);
//! }
//! assert_eq!(decoded.map(|r| r.message.kind()), Some(sample.kind()));
//! assert_eq!(decoder.stats().ok, 2);
//! ```

mod bus_frame;
mod codec;
mod frame;
mod message;
pub mod protocol;
pub mod protocol_doc;
pub mod transport;
mod wire;

pub use bus_frame::{BusFrameError, crc15, frame_check};
pub use codec::{
    Decoded, Decoder, DecoderStats, EncodeError, Encoder, FrameBatch, FrameClass, Received,
};
pub use frame::{CanFrame, CanId, FrameError, TimeSource, TimestampedFrame};
pub use message::{
    CmgCommandMsg, CmgTelemetryMsg, DeviceStatus, GyroMsg, InclinometerMsg, MagnetometerMsg,
    Message, NodeClock, NodeHeartbeatMsg, NodeState, Sample, ThrusterCommandMsg, ThrusterStatusMsg,
    WheelCommandMsg, WheelTelemetryMsg,
};
pub use protocol::{
    Device, DeviceSet, Direction, IdMap, Limits, MessageKind, Protocol, ProtocolError, Quantity,
};
pub use transport::{CanTransport, TransportError};

/// Frame-level constants (flag bits, limits).
pub mod frame_consts {
    pub use crate::frame::{
        EXTENDED_FLAG, MAX_DATA_LEN, MAX_EXTENDED_ID, MAX_STANDARD_ID, REMOTE_FLAG,
    };
}
