//! A CAN gateway's device link: the software CAN bus, a SocketCAN interface, a `candump -L`
//! file or a serial line, as the run configuration says.

use anyhow::Context as _;
use ipc_types::CanLinkStatus;
use ipc_types::SampleHeader;
use std::fs::File;
use std::io::BufReader;
use std::time::Duration;
use testbed_bus::{Bus, HeartbeatPublisher};
use testbed_can::transport::{
    CandumpReplay, Pacing, SerialConfig, SerialTransport, SocketCanTransport,
};
use testbed_can::{CanFrame, CanTransport, Device, TimestampedFrame, TransportError};
use testbed_gateways::can_board;
use testbed_gateways::gateway::{GatewayDevice, Served};

use crate::software_bus::SoftwareBusTransport;
use testbed_config::{CanLink, RunConfig};

/// Frames a software-bus receiver buffers (a tick holds about 20).
pub const BUS_BUFFER: usize = 128;

/// A gateway's device link.
pub enum Link {
    /// The software CAN bus.
    Bus(Box<SoftwareBusTransport>),
    /// A SocketCAN interface, filtered to the device's and the board's identifiers.
    SocketCan(SocketCanTransport),
    /// A `candump -L` file.
    Candump(CandumpReplay<BufReader<File>>),
    /// A device wired directly by RS-232.
    Serial(SerialTransport),
}

impl Link {
    /// Opens the link the run configuration gives `device`.
    pub fn open(bus: &Bus, config: &RunConfig, device: impl Into<Served>) -> anyhow::Result<Self> {
        let device = device.into();
        let can = &config.can;
        if let Some(serial) = can.serial.get(device.name()) {
            let path = serial.path.to_string_lossy().into_owned();
            let transport = SerialTransport::open(&SerialConfig {
                path: path.clone(),
                baud: serial.baud,
            })
            .with_context(|| format!("can.serial.{}: opening {path}", device.name()))?;
            return Ok(Link::Serial(transport));
        }
        Ok(match can.link {
            CanLink::SoftwareBus => Link::Bus(Box::new(SoftwareBusTransport::open(
                bus,
                device.source_id(),
                SampleHeader::VALID,
                BUS_BUFFER,
            )?)),
            CanLink::Socketcan => {
                let mut transport = SocketCanTransport::open(&can.interface)
                    .with_context(|| format!("can.interface = {:?}", can.interface))?;
                let protocol = can_board::protocol(config)?;
                transport
                    .set_device_filters(protocol.ids(), &[device.can_device(), Device::Node])
                    .with_context(|| format!("filters on {}", can.interface))?;
                transport
                    .report_error_frames()
                    .with_context(|| format!("error frames on {}", can.interface))?;
                Link::SocketCan(transport)
            }
            CanLink::Candump => {
                let path = can
                    .candump
                    .as_ref()
                    .context("can.link = \"candump\" needs can.candump (the file)")?;
                let pacing = match can.replay_speed {
                    0.0 => Pacing::AsFastAsPossible,
                    speed => Pacing::Timed { speed },
                };
                Link::Candump(
                    CandumpReplay::open(path, pacing)
                        .with_context(|| format!("can.candump = {}", path.display()))?,
                )
            }
        })
    }

    /// The next received frame, without waiting.
    pub fn poll(&mut self) -> Result<Option<TimestampedFrame>, TransportError> {
        match self {
            Link::Bus(t) => t.poll(),
            Link::SocketCan(t) => t.recv(Duration::ZERO),
            Link::Candump(t) => t.recv(Duration::ZERO),
            Link::Serial(t) => t.recv(Duration::ZERO),
        }
    }

    /// Sends `frame`, stamped `time_ns` where the link carries a time.
    pub fn send(&mut self, frame: &CanFrame, time_ns: u64) -> Result<(), TransportError> {
        match self {
            Link::Bus(t) => {
                t.set_time_ns(time_ns);
                t.send_frame(frame)
            }
            Link::SocketCan(t) => t.send(frame),
            Link::Candump(t) => t.send(frame),
            Link::Serial(t) => t.send(frame),
        }
    }

    /// Frames the link itself rejected so far: failed frame checks (software bus), error
    /// frames (SocketCAN), bad packets (serial), malformed lines (candump).
    pub fn rejected(&self) -> u64 {
        match self {
            Link::Bus(t) => t.stats().check_errors + t.stats().invalid,
            Link::SocketCan(t) => t.error_frames(),
            Link::Candump(t) => t.stats().malformed,
            Link::Serial(t) => t.stats().dropped(),
        }
    }

    /// Frames lost in the receive queue of a SocketCAN socket (`SO_RXQ_OVFL`); 0 for the other
    /// links.
    pub fn queue_drops(&self) -> u64 {
        match self {
            Link::SocketCan(t) => t.queue_drops(),
            _ => 0,
        }
    }

    /// Whether the link is up: false while a SocketCAN interface is down (`ip link set IFACE
    /// down`, or a controller that went bus-off and was not restarted); always true for the
    /// other links, whose loss shows as a transport error or their end.
    pub fn is_up(&self) -> Result<bool, TransportError> {
        match self {
            Link::SocketCan(t) => t.is_up(),
            _ => Ok(true),
        }
    }

    /// The interface or path of the link, for messages.
    pub fn name(&self) -> String {
        match self {
            Link::SocketCan(t) => t.iface().to_string(),
            other => other.describe().to_string(),
        }
    }

    pub fn describe(&self) -> &'static str {
        match self {
            Link::Bus(_) => "software CAN bus",
            Link::SocketCan(_) => "SocketCAN",
            Link::Candump(_) => "candump file",
            Link::Serial(_) => "serial line",
        }
    }
}

/// Carries a link's counters into its process's heartbeat (`frames_ok`, `frames_bad`,
/// `errors` = lost frames + abandoned samples + stale samples + transport errors).
#[derive(Debug, Default, Clone, Copy)]
pub struct HeartbeatCounters {
    ok: u64,
    bad: u64,
    errors: u64,
}

impl HeartbeatCounters {
    /// Adds what changed since the last call to `heartbeat`.
    pub fn update(&mut self, heartbeat: &HeartbeatPublisher, s: &CanLinkStatus) {
        let errors = s.lost_frames + s.incomplete_samples + s.stale_samples + s.transport_errors;
        heartbeat.add_frames_ok(s.frames_ok.saturating_sub(self.ok));
        heartbeat.add_frames_bad(s.frames_bad.saturating_sub(self.bad));
        heartbeat.add_errors(errors.saturating_sub(self.errors));
        *self = Self {
            ok: s.frames_ok,
            bad: s.frames_bad,
            errors,
        };
    }
}
