//! Each message's layout on the wire: its device block, direction and frames, what each byte
//! range of a frame holds, and its value channels. [`MessageKind`]'s wire facts are read from
//! here.

use crate::protocol::{Device, Direction, MessageKind, Quantity};

impl MessageKind {
    /// The message's wire layout.
    pub(crate) const fn layout(self) -> &'static MessageLayout {
        &LAYOUTS[self as usize]
    }

    /// The device block the message's identifiers are in.
    pub const fn device(self) -> Device {
        self.layout().device
    }

    /// Who sends it.
    pub const fn direction(self) -> Direction {
        self.layout().direction
    }

    /// Number of frames per sample.
    pub const fn parts(self) -> usize {
        self.layout().parts.len()
    }

    /// Message number of the first frame inside the device block (frames follow consecutively).
    pub const fn first_message(self) -> u16 {
        self.layout().first
    }

    /// Data length code of frame `part` (None if out of range).
    pub fn dlc(self, part: usize) -> Option<u8> {
        self.layout().parts.get(part).map(|p| p.dlc)
    }
}

/// What a byte range of a frame holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FieldKind {
    /// Device status bits ([`crate::DeviceStatus`]), 1 byte.
    Status,
    /// The node's µs time stamp, u32 little-endian.
    Time,
    /// A value channel of the message.
    Value(u8),
    /// Heartbeat: node state, 1 byte.
    State,
    /// Heartbeat: link bits, 1 byte.
    Links,
    /// Heartbeat: serial error count, 1 byte.
    Errors,
    /// Thruster command: flags (bit 0: shut the latch valve), 1 byte.
    Flags,
    /// Thruster status: valves sensed open (bits 0–5) and latch valve shut (bit 7), 1 byte.
    Valves,
}

impl FieldKind {
    pub(crate) const fn width(self, channels: &[Channel]) -> usize {
        match self {
            FieldKind::Status
            | FieldKind::State
            | FieldKind::Links
            | FieldKind::Errors
            | FieldKind::Flags
            | FieldKind::Valves => 1,
            FieldKind::Time => 4,
            FieldKind::Value(ch) => channels[ch as usize].quantity.bytes(),
        }
    }
}

/// A field at byte `offset` (byte 0 of every frame is the rolling counter).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Field {
    pub offset: u8,
    pub kind: FieldKind,
}

/// One frame of a message.
#[derive(Debug)]
pub(crate) struct PartLayout {
    pub dlc: u8,
    pub fields: &'static [Field],
}

/// A value channel: its quantity and the axis (saturation bit) it belongs to.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Channel {
    pub quantity: Quantity,
    pub axis: u8,
}

/// The layout of one message.
#[derive(Debug)]
pub(crate) struct MessageLayout {
    #[allow(dead_code)] // read by the layout consistency test
    pub kind: MessageKind,
    pub device: Device,
    pub direction: Direction,
    /// Message number (inside the device block) of part 0.
    pub first: u16,
    pub parts: &'static [PartLayout],
    pub channels: &'static [Channel],
}

const fn f(offset: u8, kind: FieldKind) -> Field {
    Field { offset, kind }
}
const fn c(quantity: Quantity, axis: u8) -> Channel {
    Channel { quantity, axis }
}
use FieldKind::{Errors, Flags, Links, State, Status, Time, Value, Valves};

/// Two frames: `[ctr][status][ch0 i24][ch1 i24]`, `[ctr][ch2 i24][t_us u32]`.
const THREE_AXIS_PARTS: &[PartLayout] = &[
    PartLayout {
        dlc: 8,
        fields: &[f(1, Status), f(2, Value(0)), f(5, Value(1))],
    },
    PartLayout {
        dlc: 8,
        fields: &[f(1, Value(2)), f(4, Time)],
    },
];

pub(crate) const LAYOUTS: [MessageLayout; 10] = [
    MessageLayout {
        kind: MessageKind::WheelCommand,
        device: Device::Wheels,
        direction: Direction::ToNode,
        first: 0x0,
        parts: &[PartLayout {
            dlc: 7,
            fields: &[f(1, Value(0)), f(3, Value(1)), f(5, Value(2))],
        }],
        channels: &[
            c(Quantity::WheelTorque, 0),
            c(Quantity::WheelTorque, 1),
            c(Quantity::WheelTorque, 2),
        ],
    },
    MessageLayout {
        kind: MessageKind::WheelTelemetry,
        device: Device::Wheels,
        direction: Direction::FromNode,
        first: 0x1,
        parts: &[
            PartLayout {
                dlc: 8,
                fields: &[f(1, Status), f(2, Value(0)), f(5, Value(1))],
            },
            PartLayout {
                dlc: 8,
                fields: &[f(1, Value(2)), f(4, Value(3)), f(6, Value(4))],
            },
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(5)), f(3, Time)],
            },
        ],
        channels: &[
            c(Quantity::WheelSpeed, 0),
            c(Quantity::WheelSpeed, 1),
            c(Quantity::WheelSpeed, 2),
            c(Quantity::WheelTorque, 0),
            c(Quantity::WheelTorque, 1),
            c(Quantity::WheelTorque, 2),
        ],
    },
    MessageLayout {
        kind: MessageKind::CmgCommand,
        device: Device::Cmg,
        direction: Direction::ToNode,
        first: 0x0,
        parts: &[
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(0)), f(4, Value(1))],
            },
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(2)), f(4, Value(3))],
            },
        ],
        channels: &[
            c(Quantity::GimbalRate, 0),
            c(Quantity::GimbalRate, 1),
            c(Quantity::GimbalRate, 2),
            c(Quantity::GimbalRate, 3),
        ],
    },
    MessageLayout {
        kind: MessageKind::CmgTelemetry,
        device: Device::Cmg,
        direction: Direction::FromNode,
        first: 0x2,
        parts: &[
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(0)), f(4, Value(4))],
            },
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(1)), f(4, Value(5))],
            },
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(2)), f(4, Value(6))],
            },
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(3)), f(4, Value(7))],
            },
            PartLayout {
                dlc: 6,
                fields: &[f(1, Status), f(2, Time)],
            },
        ],
        channels: &[
            c(Quantity::GimbalAngle, 0),
            c(Quantity::GimbalAngle, 1),
            c(Quantity::GimbalAngle, 2),
            c(Quantity::GimbalAngle, 3),
            c(Quantity::GimbalRate, 0),
            c(Quantity::GimbalRate, 1),
            c(Quantity::GimbalRate, 2),
            c(Quantity::GimbalRate, 3),
        ],
    },
    MessageLayout {
        kind: MessageKind::Gyro,
        device: Device::Gyro,
        direction: Direction::FromNode,
        first: 0x0,
        parts: THREE_AXIS_PARTS,
        channels: &[
            c(Quantity::GyroRate, 0),
            c(Quantity::GyroRate, 1),
            c(Quantity::GyroRate, 2),
        ],
    },
    MessageLayout {
        kind: MessageKind::Inclinometer,
        device: Device::Inclinometer,
        direction: Direction::FromNode,
        first: 0x0,
        parts: &[
            PartLayout {
                dlc: 8,
                fields: &[f(1, Status), f(2, Value(0)), f(5, Value(1))],
            },
            PartLayout {
                dlc: 5,
                fields: &[f(1, Time)],
            },
        ],
        channels: &[c(Quantity::Tilt, 0), c(Quantity::Tilt, 1)],
    },
    MessageLayout {
        kind: MessageKind::Magnetometer,
        device: Device::Magnetometer,
        direction: Direction::FromNode,
        first: 0x0,
        parts: THREE_AXIS_PARTS,
        channels: &[
            c(Quantity::Field, 0),
            c(Quantity::Field, 1),
            c(Quantity::Field, 2),
        ],
    },
    MessageLayout {
        kind: MessageKind::NodeHeartbeat,
        device: Device::Node,
        direction: Direction::FromNode,
        first: 0x0,
        parts: &[PartLayout {
            dlc: 8,
            fields: &[f(1, State), f(2, Links), f(3, Errors), f(4, Time)],
        }],
        channels: &[],
    },
    MessageLayout {
        kind: MessageKind::ThrusterCommand,
        device: Device::Thrusters,
        direction: Direction::ToNode,
        first: 0x0,
        parts: &[
            PartLayout {
                dlc: 8,
                fields: &[f(1, Flags), f(2, Value(0)), f(4, Value(1)), f(6, Value(2))],
            },
            PartLayout {
                dlc: 7,
                fields: &[f(1, Value(3)), f(3, Value(4)), f(5, Value(5))],
            },
        ],
        channels: &VALVE_CHANNELS,
    },
    MessageLayout {
        kind: MessageKind::ThrusterStatus,
        device: Device::Thrusters,
        direction: Direction::FromNode,
        first: 0x2,
        parts: &[
            PartLayout {
                dlc: 8,
                fields: &[f(1, Status), f(2, Value(0)), f(4, Value(1)), f(6, Value(2))],
            },
            PartLayout {
                dlc: 8,
                fields: &[f(1, Valves), f(2, Value(3)), f(4, Value(4)), f(6, Value(5))],
            },
            PartLayout {
                dlc: 5,
                fields: &[f(1, Time)],
            },
        ],
        channels: &VALVE_CHANNELS,
    },
];

/// The six valve on-times of the thruster messages (thruster `i` is channel and axis `i`).
const VALVE_CHANNELS: [Channel; 6] = [
    c(Quantity::ValveOnTime, 0),
    c(Quantity::ValveOnTime, 1),
    c(Quantity::ValveOnTime, 2),
    c(Quantity::ValveOnTime, 3),
    c(Quantity::ValveOnTime, 4),
    c(Quantity::ValveOnTime, 5),
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{MAX_CHANNELS, MAX_PARTS, SLOT_STRIDE};

    #[test]
    fn layouts_are_consistent() {
        for (i, l) in LAYOUTS.iter().enumerate() {
            assert_eq!(l.kind.index(), i);
            assert!(l.parts.len() <= MAX_PARTS && l.channels.len() <= MAX_CHANNELS);
            assert!(usize::from(l.first) + l.parts.len() <= usize::from(SLOT_STRIDE));
            let mut channel_seen = vec![0; l.channels.len()];
            let mut status = 0;
            let mut time = 0;
            for p in l.parts {
                assert!(p.dlc <= 8);
                // Fields cover bytes 1..dlc exactly once, byte 0 is the counter.
                let mut used = [false; 8];
                used[0] = true;
                for fld in p.fields {
                    let w = fld.kind.width(l.channels);
                    let start = usize::from(fld.offset);
                    assert!(
                        start + w <= usize::from(p.dlc),
                        "{:?}: field past DLC",
                        l.kind
                    );
                    for u in &mut used[start..start + w] {
                        assert!(!*u, "{:?}: overlapping fields", l.kind);
                        *u = true;
                    }
                    match fld.kind {
                        FieldKind::Value(ch) => channel_seen[usize::from(ch)] += 1,
                        FieldKind::Status => status += 1,
                        FieldKind::Time => time += 1,
                        _ => {}
                    }
                }
                assert!(
                    used[..usize::from(p.dlc)].iter().all(|&u| u),
                    "{:?}: gap in frame",
                    l.kind
                );
            }
            assert!(
                channel_seen.iter().all(|&n| n == 1),
                "{:?}: channels {channel_seen:?}",
                l.kind
            );
            let from_node = l.direction == Direction::FromNode;
            assert_eq!(time, usize::from(from_node), "{:?}: time stamp", l.kind);
            let status_expected = usize::from(from_node && l.kind != MessageKind::NodeHeartbeat);
            assert_eq!(status, status_expected, "{:?}: status", l.kind);
        }
    }
}
