//! The protocol's messages as typed values in SI units, and their conversion to and from the
//! `ipc-types` samples the gateways publish and subscribe to.

use crate::protocol::{DeviceSet, MAX_CHANNELS, MessageKind};
use ipc_types::SampleHeader;

/// The status byte of a measurement (byte 1 of the first frame of gyro, inclinometer,
/// magnetometer and wheel samples; of the last frame of CMG telemetry).
///
/// Bits 0–3: channel (axis, wheel, gimbal) 0–3 saturated as reported by the device; bit 4
/// reserved (0); bit 5 [`STALE`](Self::STALE); bit 6 [`SERIAL_ERRORS`](Self::SERIAL_ERRORS);
/// bit 7 [`FAULT`](Self::FAULT).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DeviceStatus(pub u8);

impl DeviceStatus {
    /// No fresh device message arrived since the last sample: the node repeats the old values.
    pub const STALE: u8 = 1 << 5;
    /// The node dropped at least one malformed serial message of this device since the last sample.
    pub const SERIAL_ERRORS: u8 = 1 << 6;
    /// The device reports a fault or its link is down: the values must not be used.
    pub const FAULT: u8 = 1 << 7;
    /// Mask of the four saturation bits.
    pub const SATURATION_MASK: u8 = 0x0F;

    /// Saturation bit of channel `axis` (0 to 3; 0 for larger values).
    pub const fn saturated_bit(axis: u8) -> u8 {
        if axis < 4 { 1 << axis } else { 0 }
    }

    /// The four saturation bits.
    pub const fn saturation(self) -> u8 {
        self.0 & Self::SATURATION_MASK
    }

    /// Whether every bit of `bits` is set.
    pub const fn has(self, bits: u8) -> bool {
        self.0 & bits == bits
    }

    /// `SampleHeader` flags for this status plus the channels in `clipped` (bit per axis) that the
    /// decoder clipped to their range: `VALID` unless [`FAULT`](Self::FAULT), `SATURATED_*` for
    /// device-saturated or clipped channels, `STALE`.
    pub const fn header_flags(self, clipped: u8) -> u32 {
        let mut flags = 0u32;
        if !self.has(Self::FAULT) {
            flags |= SampleHeader::VALID;
        }
        let sat = (self.saturation() | clipped) & Self::SATURATION_MASK;
        flags |= (sat as u32) << 1; // SATURATED_X is bit 1, ..., SATURATED_4 bit 4
        if self.has(Self::STALE) {
            flags |= SampleHeader::STALE;
        }
        flags
    }

    /// The status a node would report for a sample with these `SampleHeader` flags (used to
    /// encode simulated or replayed samples): `FAULT` if not `VALID`, saturation bits, `STALE`.
    pub const fn from_header_flags(flags: u32) -> Self {
        let mut s = ((flags >> 1) as u8) & Self::SATURATION_MASK;
        if flags & SampleHeader::VALID == 0 {
            s |= Self::FAULT;
        }
        if flags & SampleHeader::STALE != 0 {
            s |= Self::STALE;
        }
        DeviceStatus(s)
    }
}

/// State of the smart CAN node (heartbeat byte 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NodeState {
    /// 0: starting; counters restart from 0 after this.
    Booting,
    /// 1: every configured link is up.
    Running,
    /// 2: at least one device link is down (see the link bits).
    Degraded,
    /// 3: the node itself has failed; actuators are held at zero.
    Fault,
    /// Any other value (decoding only; flagged out of range).
    Unknown(u8),
}

impl NodeState {
    /// Wire value.
    pub const fn to_wire(self) -> u8 {
        match self {
            NodeState::Booting => 0,
            NodeState::Running => 1,
            NodeState::Degraded => 2,
            NodeState::Fault => 3,
            NodeState::Unknown(v) => v,
        }
    }

    /// From the wire value.
    pub const fn from_wire(v: u8) -> Self {
        match v {
            0 => NodeState::Booting,
            1 => NodeState::Running,
            2 => NodeState::Degraded,
            3 => NodeState::Fault,
            v => NodeState::Unknown(v),
        }
    }
}

/// One gyro sample (10 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GyroMsg {
    /// The node's time stamp of the sampling instant, µs (32-bit, wraps after 71.6 min).
    pub node_time_us: u32,
    /// Device status.
    pub status: DeviceStatus,
    /// Angular rate about body x, y, z, rad/s.
    pub rate_rad_s: [f64; 3],
}

/// One inclinometer sample (2.5 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InclinometerMsg {
    /// The node's time stamp of the sampling instant, µs.
    pub node_time_us: u32,
    /// Device status.
    pub status: DeviceStatus,
    /// Tilt angles `[θ, φ]` of body x and y against the level plane, rad.
    pub tilt_rad: [f64; 2],
}

/// One magnetometer sample (2.5 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MagnetometerMsg {
    /// The node's time stamp of the sampling instant, µs.
    pub node_time_us: u32,
    /// Device status.
    pub status: DeviceStatus,
    /// Magnetic flux density, body axes, T.
    pub field_t: [f64; 3],
}

/// Reaction wheel telemetry (10 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelTelemetryMsg {
    /// The node's time stamp of the sampling instant, µs.
    pub node_time_us: u32,
    /// Device status (saturation bit i: wheel i at its speed or torque limit).
    pub status: DeviceStatus,
    /// Wheel speeds relative to the platform, rad/s.
    pub speed_rad_s: [f64; 3],
    /// Measured motor torques, Nm.
    pub torque_nm: [f64; 3],
}

/// Reaction wheel motor torque command.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelCommandMsg {
    /// Commanded motor torque per wheel, Nm.
    pub torque_nm: [f64; 3],
}

/// CMG telemetry (10 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CmgTelemetryMsg {
    /// The node's time stamp of the sampling instant, µs.
    pub node_time_us: u32,
    /// Device status (saturation bit i: gimbal i at its rate limit).
    pub status: DeviceStatus,
    /// Gimbal angles, rad, in [−π, π).
    pub gimbal_angle_rad: [f64; 4],
    /// Gimbal rates, rad/s.
    pub gimbal_rate_rad_s: [f64; 4],
}

/// CMG gimbal rate command.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CmgCommandMsg {
    /// Commanded gimbal rates, rad/s.
    pub gimbal_rate_rad_s: [f64; 4],
}

/// The node's heartbeat (1 Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeHeartbeatMsg {
    /// The node's clock, µs.
    pub node_time_us: u32,
    /// Node state.
    pub state: NodeState,
    /// Devices whose serial link delivered a valid message in the last second.
    pub links: DeviceSet,
    /// Malformed serial messages the node dropped, all devices, rolling count mod 256.
    pub serial_errors: u8,
}

/// Thruster valve command for one control period (computer → node).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThrusterCommandMsg {
    /// Electrical on-time of each valve from the start of the period, s (0: shut).
    pub on_time_s: [f64; 6],
    /// Shut the latch valve upstream of every thruster (a stuck-open valve was found): no
    /// thrust at all until the node restarts.
    pub latch_shut: bool,
}

/// Thruster status (node → computer, 10 Hz): what the node applied in the period that just
/// ended and the valves' position sensors at its end.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThrusterStatusMsg {
    /// The node's time stamp of the valve sensing, µs.
    pub node_time_us: u32,
    /// Device status (bit 7: the valve drive reports a fault).
    pub status: DeviceStatus,
    /// On-times the node applied in the period that ended, s.
    pub applied_on_time_s: [f64; 6],
    /// Valves sensed open at the end of the period: bit `i` for thruster `i` (bits 0–5).
    pub valves_open: u8,
    /// The latch valve is shut.
    pub latch_shut: bool,
}

impl ThrusterStatusMsg {
    /// Bit of the valves byte saying the latch valve is shut.
    pub const LATCH_SHUT_BIT: u8 = 1 << 7;
    /// The valve bits of the valves byte.
    pub const VALVE_MASK: u8 = 0x3F;
}

impl ThrusterCommandMsg {
    /// Bit of the flags byte asking the node to shut the latch valve.
    pub const LATCH_SHUT_FLAG: u8 = 1 << 0;
}

/// Any message of the protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Message {
    /// [`MessageKind::WheelCommand`].
    WheelCommand(WheelCommandMsg),
    /// [`MessageKind::WheelTelemetry`].
    WheelTelemetry(WheelTelemetryMsg),
    /// [`MessageKind::CmgCommand`].
    CmgCommand(CmgCommandMsg),
    /// [`MessageKind::CmgTelemetry`].
    CmgTelemetry(CmgTelemetryMsg),
    /// [`MessageKind::Gyro`].
    Gyro(GyroMsg),
    /// [`MessageKind::Inclinometer`].
    Inclinometer(InclinometerMsg),
    /// [`MessageKind::Magnetometer`].
    Magnetometer(MagnetometerMsg),
    /// [`MessageKind::NodeHeartbeat`].
    NodeHeartbeat(NodeHeartbeatMsg),
    /// [`MessageKind::ThrusterCommand`].
    ThrusterCommand(ThrusterCommandMsg),
    /// [`MessageKind::ThrusterStatus`].
    ThrusterStatus(ThrusterStatusMsg),
}

/// The generic form of a message: what the layout tables read and write.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Record {
    pub status: u8,
    pub time_us: u32,
    pub values: [f64; MAX_CHANNELS],
    pub state: u8,
    pub links: u8,
    pub errors: u8,
    pub flags: u8,
    pub valves: u8,
}

fn put<const N: usize>(values: &mut [f64; MAX_CHANNELS], at: usize, src: &[f64; N]) {
    values[at..at + N].copy_from_slice(src);
}

fn get<const N: usize>(values: &[f64; MAX_CHANNELS], at: usize) -> [f64; N] {
    let mut out = [0.0; N];
    out.copy_from_slice(&values[at..at + N]);
    out
}

impl Message {
    /// Which message this is.
    pub const fn kind(&self) -> MessageKind {
        match self {
            Message::WheelCommand(_) => MessageKind::WheelCommand,
            Message::WheelTelemetry(_) => MessageKind::WheelTelemetry,
            Message::CmgCommand(_) => MessageKind::CmgCommand,
            Message::CmgTelemetry(_) => MessageKind::CmgTelemetry,
            Message::Gyro(_) => MessageKind::Gyro,
            Message::Inclinometer(_) => MessageKind::Inclinometer,
            Message::Magnetometer(_) => MessageKind::Magnetometer,
            Message::NodeHeartbeat(_) => MessageKind::NodeHeartbeat,
            Message::ThrusterCommand(_) => MessageKind::ThrusterCommand,
            Message::ThrusterStatus(_) => MessageKind::ThrusterStatus,
        }
    }

    /// The node's time stamp, µs (None for commands).
    pub const fn node_time_us(&self) -> Option<u32> {
        match self {
            Message::WheelCommand(_) | Message::CmgCommand(_) | Message::ThrusterCommand(_) => None,
            Message::ThrusterStatus(m) => Some(m.node_time_us),
            Message::WheelTelemetry(m) => Some(m.node_time_us),
            Message::CmgTelemetry(m) => Some(m.node_time_us),
            Message::Gyro(m) => Some(m.node_time_us),
            Message::Inclinometer(m) => Some(m.node_time_us),
            Message::Magnetometer(m) => Some(m.node_time_us),
            Message::NodeHeartbeat(m) => Some(m.node_time_us),
        }
    }

    /// The device status (None for commands and the heartbeat).
    pub const fn status(&self) -> Option<DeviceStatus> {
        match self {
            Message::WheelTelemetry(m) => Some(m.status),
            Message::CmgTelemetry(m) => Some(m.status),
            Message::Gyro(m) => Some(m.status),
            Message::Inclinometer(m) => Some(m.status),
            Message::Magnetometer(m) => Some(m.status),
            Message::ThrusterStatus(m) => Some(m.status),
            _ => None,
        }
    }

    pub(crate) fn to_record(self) -> Record {
        let mut r = Record::default();
        match self {
            Message::WheelCommand(m) => put(&mut r.values, 0, &m.torque_nm),
            Message::WheelTelemetry(m) => {
                (r.status, r.time_us) = (m.status.0, m.node_time_us);
                put(&mut r.values, 0, &m.speed_rad_s);
                put(&mut r.values, 3, &m.torque_nm);
            }
            Message::CmgCommand(m) => put(&mut r.values, 0, &m.gimbal_rate_rad_s),
            Message::CmgTelemetry(m) => {
                (r.status, r.time_us) = (m.status.0, m.node_time_us);
                put(&mut r.values, 0, &m.gimbal_angle_rad);
                put(&mut r.values, 4, &m.gimbal_rate_rad_s);
            }
            Message::Gyro(m) => {
                (r.status, r.time_us) = (m.status.0, m.node_time_us);
                put(&mut r.values, 0, &m.rate_rad_s);
            }
            Message::Inclinometer(m) => {
                (r.status, r.time_us) = (m.status.0, m.node_time_us);
                put(&mut r.values, 0, &m.tilt_rad);
            }
            Message::Magnetometer(m) => {
                (r.status, r.time_us) = (m.status.0, m.node_time_us);
                put(&mut r.values, 0, &m.field_t);
            }
            Message::NodeHeartbeat(m) => {
                r.time_us = m.node_time_us;
                r.state = m.state.to_wire();
                r.links = m.links.0;
                r.errors = m.serial_errors;
            }
            Message::ThrusterCommand(m) => {
                put(&mut r.values, 0, &m.on_time_s);
                r.flags = if m.latch_shut {
                    ThrusterCommandMsg::LATCH_SHUT_FLAG
                } else {
                    0
                };
            }
            Message::ThrusterStatus(m) => {
                (r.status, r.time_us) = (m.status.0, m.node_time_us);
                put(&mut r.values, 0, &m.applied_on_time_s);
                r.valves = (m.valves_open & ThrusterStatusMsg::VALVE_MASK)
                    | if m.latch_shut {
                        ThrusterStatusMsg::LATCH_SHUT_BIT
                    } else {
                        0
                    };
            }
        }
        r
    }

    pub(crate) fn from_record(kind: MessageKind, r: &Record) -> Self {
        let status = DeviceStatus(r.status);
        let node_time_us = r.time_us;
        match kind {
            MessageKind::WheelCommand => Message::WheelCommand(WheelCommandMsg {
                torque_nm: get(&r.values, 0),
            }),
            MessageKind::WheelTelemetry => Message::WheelTelemetry(WheelTelemetryMsg {
                node_time_us,
                status,
                speed_rad_s: get(&r.values, 0),
                torque_nm: get(&r.values, 3),
            }),
            MessageKind::CmgCommand => Message::CmgCommand(CmgCommandMsg {
                gimbal_rate_rad_s: get(&r.values, 0),
            }),
            MessageKind::CmgTelemetry => Message::CmgTelemetry(CmgTelemetryMsg {
                node_time_us,
                status,
                gimbal_angle_rad: get(&r.values, 0),
                gimbal_rate_rad_s: get(&r.values, 4),
            }),
            MessageKind::Gyro => Message::Gyro(GyroMsg {
                node_time_us,
                status,
                rate_rad_s: get(&r.values, 0),
            }),
            MessageKind::Inclinometer => Message::Inclinometer(InclinometerMsg {
                node_time_us,
                status,
                tilt_rad: get(&r.values, 0),
            }),
            MessageKind::Magnetometer => Message::Magnetometer(MagnetometerMsg {
                node_time_us,
                status,
                field_t: get(&r.values, 0),
            }),
            MessageKind::NodeHeartbeat => Message::NodeHeartbeat(NodeHeartbeatMsg {
                node_time_us,
                state: NodeState::from_wire(r.state),
                links: DeviceSet(r.links),
                serial_errors: r.errors,
            }),
            MessageKind::ThrusterCommand => Message::ThrusterCommand(ThrusterCommandMsg {
                on_time_s: get(&r.values, 0),
                latch_shut: r.flags & ThrusterCommandMsg::LATCH_SHUT_FLAG != 0,
            }),
            MessageKind::ThrusterStatus => Message::ThrusterStatus(ThrusterStatusMsg {
                node_time_us,
                status,
                applied_on_time_s: get(&r.values, 0),
                valves_open: r.valves & ThrusterStatusMsg::VALVE_MASK,
                latch_shut: r.valves & ThrusterStatusMsg::LATCH_SHUT_BIT != 0,
            }),
        }
    }
}

/// A decoded message as an `ipc-types` sample, ready to publish.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// Gyro sample.
    Gyro(ipc_types::GyroSample),
    /// Inclinometer sample.
    Inclinometer(ipc_types::InclinometerSample),
    /// Magnetometer sample.
    Magnetometer(ipc_types::MagnetometerSample),
    /// Wheel telemetry.
    WheelTelemetry(ipc_types::WheelTelemetry),
    /// Wheel command (seen on the bus, e.g. when replaying a log).
    WheelCommand(ipc_types::WheelCommand),
    /// CMG telemetry.
    CmgTelemetry(ipc_types::CmgTelemetry),
    /// CMG command (seen on the bus).
    CmgCommand(ipc_types::CmgCommand),
    /// Thruster status: applied on-times and sensed valves. The gateway fills in what only it
    /// knows (refusals, propellant, disabled).
    ThrusterStatus(ipc_types::ThrusterStatus),
    /// Thruster command (seen on the bus).
    ThrusterCommand(ipc_types::ThrusterCommand),
}

impl Message {
    /// The message as an `ipc-types` sample with header `header`, whose flags get the
    /// status-derived flags ([`DeviceStatus::header_flags`] with `clipped`) OR-ed in. Commands
    /// get `VALID` and the `SATURATED_*` bits of `clipped`. `None` for the heartbeat.
    ///
    /// `header.time_ns` is the caller's: map [`Message::node_time_us`] to the run clock first
    /// (see [`crate::NodeClock`]).
    pub fn to_sample(&self, header: SampleHeader, clipped: u8) -> Option<Sample> {
        let mut h = header;
        let command_flags =
            SampleHeader::VALID | (u32::from(clipped & DeviceStatus::SATURATION_MASK) << 1);
        Some(match *self {
            Message::Gyro(m) => {
                h.flags |= m.status.header_flags(clipped);
                Sample::Gyro(ipc_types::GyroSample::new(h, m.rate_rad_s))
            }
            Message::Inclinometer(m) => {
                h.flags |= m.status.header_flags(clipped);
                Sample::Inclinometer(ipc_types::InclinometerSample::new(h, m.tilt_rad))
            }
            Message::Magnetometer(m) => {
                h.flags |= m.status.header_flags(clipped);
                Sample::Magnetometer(ipc_types::MagnetometerSample::new(h, m.field_t))
            }
            Message::WheelTelemetry(m) => {
                h.flags |= m.status.header_flags(clipped);
                Sample::WheelTelemetry(ipc_types::WheelTelemetry::new(
                    h,
                    m.speed_rad_s,
                    m.torque_nm,
                ))
            }
            Message::CmgTelemetry(m) => {
                h.flags |= m.status.header_flags(clipped);
                Sample::CmgTelemetry(ipc_types::CmgTelemetry::new(
                    h,
                    m.gimbal_angle_rad,
                    m.gimbal_rate_rad_s,
                ))
            }
            Message::WheelCommand(m) => {
                h.flags |= command_flags;
                Sample::WheelCommand(ipc_types::WheelCommand::new(h, m.torque_nm))
            }
            Message::CmgCommand(m) => {
                h.flags |= command_flags;
                Sample::CmgCommand(ipc_types::CmgCommand::new(h, m.gimbal_rate_rad_s))
            }
            Message::ThrusterStatus(m) => {
                h.flags |= m.status.header_flags(clipped);
                Sample::ThrusterStatus(ipc_types::ThrusterStatus {
                    header: h,
                    applied_on_time: m.applied_on_time_s,
                    valves_open: u32::from(m.valves_open),
                    disabled: u32::from(m.latch_shut),
                    ..Default::default()
                })
            }
            Message::ThrusterCommand(m) => {
                h.flags |= command_flags;
                Sample::ThrusterCommand(ipc_types::ThrusterCommand {
                    header: h,
                    on_time: m.on_time_s,
                })
            }
            Message::NodeHeartbeat(_) => return None,
        })
    }
}

impl From<&ipc_types::WheelCommand> for WheelCommandMsg {
    fn from(c: &ipc_types::WheelCommand) -> Self {
        Self {
            torque_nm: c.torque,
        }
    }
}

impl From<&ipc_types::CmgCommand> for CmgCommandMsg {
    fn from(c: &ipc_types::CmgCommand) -> Self {
        Self {
            gimbal_rate_rad_s: c.gimbal_rate,
        }
    }
}

impl GyroMsg {
    /// The frames a node would send for `sample` stamped `node_time_us` (simulated node, tests).
    pub fn from_sample(sample: &ipc_types::GyroSample, node_time_us: u32) -> Self {
        let status = DeviceStatus::from_header_flags(sample.header.flags);
        Self {
            node_time_us,
            status,
            rate_rad_s: sample.rate,
        }
    }
}

impl InclinometerMsg {
    /// The message a node would send for `sample` stamped `node_time_us`.
    pub fn from_sample(sample: &ipc_types::InclinometerSample, node_time_us: u32) -> Self {
        let status = DeviceStatus::from_header_flags(sample.header.flags);
        Self {
            node_time_us,
            status,
            tilt_rad: sample.tilt,
        }
    }
}

impl MagnetometerMsg {
    /// The message a node would send for `sample` stamped `node_time_us`.
    pub fn from_sample(sample: &ipc_types::MagnetometerSample, node_time_us: u32) -> Self {
        let status = DeviceStatus::from_header_flags(sample.header.flags);
        Self {
            node_time_us,
            status,
            field_t: sample.field,
        }
    }
}

impl WheelTelemetryMsg {
    /// The message a node would send for `sample` stamped `node_time_us`.
    pub fn from_sample(sample: &ipc_types::WheelTelemetry, node_time_us: u32) -> Self {
        let status = DeviceStatus::from_header_flags(sample.header.flags);
        Self {
            node_time_us,
            status,
            speed_rad_s: sample.speed,
            torque_nm: sample.torque,
        }
    }
}

impl CmgTelemetryMsg {
    /// The message a node would send for `sample` stamped `node_time_us`.
    pub fn from_sample(sample: &ipc_types::CmgTelemetry, node_time_us: u32) -> Self {
        let status = DeviceStatus::from_header_flags(sample.header.flags);
        Self {
            node_time_us,
            status,
            gimbal_angle_rad: sample.gimbal_angle,
            gimbal_rate_rad_s: sample.gimbal_rate,
        }
    }
}

/// Extends the node's 32-bit µs time stamps (which wrap every 2³² µs ≈ 71.6 min) to a
/// continuous 64-bit count.
///
/// Consecutive stamps must be less than 2³¹ µs (35.8 min) apart; a stamp slightly older than
/// the previous one (reordering) moves the result back instead of forward. One clock per
/// node; reset it when the node reboots ([`NodeState::Booting`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct NodeClock {
    last: Option<(u32, i64)>,
}

impl NodeClock {
    /// A clock that has seen no stamp.
    pub const fn new() -> Self {
        Self { last: None }
    }

    /// The continuous time of `stamp_us`, µs on the node's clock (the first stamp maps to
    /// itself; may be negative if later stamps are older than the first).
    pub fn extend(&mut self, stamp_us: u32) -> i64 {
        let extended = match self.last {
            None => i64::from(stamp_us),
            Some((prev, prev_ext)) => {
                prev_ext.saturating_add(i64::from(stamp_us.wrapping_sub(prev) as i32))
            }
        };
        self.last = Some((stamp_us, extended));
        extended
    }

    /// Forget every stamp (after a node reboot).
    pub fn reset(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_flags_map_both_ways() {
        let s = DeviceStatus(0b0000_0101 | DeviceStatus::STALE);
        let flags = s.header_flags(0b0010);
        assert!(flags & SampleHeader::VALID != 0);
        assert!(flags & SampleHeader::SATURATED_X != 0);
        assert!(flags & SampleHeader::SATURATED_Y != 0);
        assert!(flags & SampleHeader::SATURATED_Z != 0);
        assert!(flags & SampleHeader::SATURATED_4 == 0);
        assert!(flags & SampleHeader::STALE != 0);
        assert_eq!(DeviceStatus::from_header_flags(s.header_flags(0)), s);
        let fault = DeviceStatus(DeviceStatus::FAULT);
        assert_eq!(fault.header_flags(0) & SampleHeader::VALID, 0);
        assert_eq!(DeviceStatus::from_header_flags(0), fault);
    }

    #[test]
    fn node_clock_unwraps() {
        let mut c = NodeClock::new();
        assert_eq!(c.extend(u32::MAX - 10), i64::from(u32::MAX - 10));
        assert_eq!(c.extend(5), i64::from(u32::MAX) + 6);
        assert_eq!(c.extend(3), i64::from(u32::MAX) + 4); // slightly older: goes back
        assert_eq!(c.extend(u32::MAX - 100), i64::from(u32::MAX) - 100);
        c.reset();
        assert_eq!(c.extend(7), 7);
    }
}
