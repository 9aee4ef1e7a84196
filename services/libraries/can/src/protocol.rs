#![doc = include_str!("../PROTOCOL.md")]

use testbed_model::config::{DEG, GAUSS, ModelConfig, RPM};

/// Number of identifiers one device occupies (`base + SLOT_STRIDE · slot + message`).
pub const SLOT_STRIDE: u16 = 0x10;
/// Default identifier base.
pub const DEFAULT_BASE: u16 = 0x100;
/// Largest base: the last device block must end at or below 0x7FF.
pub const MAX_BASE: u16 = 0x800 - SLOT_STRIDE * Device::ALL.len() as u16;
/// Most frames one message (sample) is split into.
pub const MAX_PARTS: usize = 5;
/// Most value channels one message carries.
pub const MAX_CHANNELS: usize = 8;

/// A device (or the node itself) behind the smart CAN node: one block of 16 identifiers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Device {
    /// The three reaction wheels (slot 0, highest bus priority).
    Wheels,
    /// The four control moment gyros (slot 1).
    Cmg,
    /// The three fibre-optic gyros (slot 2).
    Gyro,
    /// The two-axis inclinometer (slot 3).
    Inclinometer,
    /// The three-axis magnetometer (slot 4).
    Magnetometer,
    /// The smart CAN node itself: heartbeat (slot 5).
    Node,
    /// The six thruster valves (slot 6, appended after the node so that every earlier
    /// identifier, and every recorded log, stays as it was).
    Thrusters,
}

impl Device {
    /// Every device, in slot order.
    pub const ALL: [Device; 7] = [
        Device::Wheels,
        Device::Cmg,
        Device::Gyro,
        Device::Inclinometer,
        Device::Magnetometer,
        Device::Node,
        Device::Thrusters,
    ];

    /// Slot number: identifiers `base + 0x10 · slot + 0..=0xF`.
    pub const fn slot(self) -> u16 {
        self as u16
    }

    /// Bit of this device in a [`DeviceSet`] and in the heartbeat's link mask.
    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }

    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Device::Wheels => "wheels",
            Device::Cmg => "cmg",
            Device::Gyro => "gyro",
            Device::Inclinometer => "inclinometer",
            Device::Magnetometer => "magnetometer",
            Device::Node => "node",
            Device::Thrusters => "thrusters",
        }
    }
}

/// A set of devices (bit `Device::bit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DeviceSet(pub u8);

impl DeviceSet {
    /// Every device.
    pub const ALL: DeviceSet = DeviceSet(0b111_1111);

    /// The set of the listed devices.
    pub fn of(devices: &[Device]) -> Self {
        DeviceSet(devices.iter().fold(0, |m, d| m | d.bit()))
    }

    /// Whether `device` is in the set.
    pub const fn contains(self, device: Device) -> bool {
        self.0 & device.bit() != 0
    }
}

/// Who sends a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Node to computer (measurements, telemetry, heartbeat).
    FromNode,
    /// Computer to node (actuator commands).
    ToNode,
}

/// One message of the protocol: a sample or command, carried by one or more frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MessageKind {
    /// Reaction wheel motor torques (computer → node), 1 frame.
    WheelCommand,
    /// Reaction wheel speeds and torques (node → computer), 3 frames.
    WheelTelemetry,
    /// CMG gimbal rate command (computer → node), 2 frames.
    CmgCommand,
    /// CMG gimbal angles and rates (node → computer), 5 frames.
    CmgTelemetry,
    /// Gyro rates (node → computer), 2 frames.
    Gyro,
    /// Inclinometer tilt angles (node → computer), 2 frames.
    Inclinometer,
    /// Magnetometer field (node → computer), 2 frames.
    Magnetometer,
    /// Node heartbeat and link status (node → computer), 1 frame.
    NodeHeartbeat,
    /// Thruster valve on-times for one period and the latch valve (computer → node), 2 frames.
    ThrusterCommand,
    /// Thruster on-times applied, valves sensed, latch valve (node → computer), 3 frames.
    ThrusterStatus,
}

impl MessageKind {
    /// Every message, in identifier order.
    pub const ALL: [MessageKind; 10] = [
        MessageKind::WheelCommand,
        MessageKind::WheelTelemetry,
        MessageKind::CmgCommand,
        MessageKind::CmgTelemetry,
        MessageKind::Gyro,
        MessageKind::Inclinometer,
        MessageKind::Magnetometer,
        MessageKind::NodeHeartbeat,
        MessageKind::ThrusterCommand,
        MessageKind::ThrusterStatus,
    ];

    /// Index into [`MessageKind::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            MessageKind::WheelCommand => "wheel command",
            MessageKind::WheelTelemetry => "wheel telemetry",
            MessageKind::CmgCommand => "cmg command",
            MessageKind::CmgTelemetry => "cmg telemetry",
            MessageKind::Gyro => "gyro",
            MessageKind::Inclinometer => "inclinometer",
            MessageKind::Magnetometer => "magnetometer",
            MessageKind::NodeHeartbeat => "node heartbeat",
            MessageKind::ThrusterCommand => "thruster command",
            MessageKind::ThrusterStatus => "thruster status",
        }
    }
}

/// A fixed-point physical quantity on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// Gyro angular rate: signed 24 bit, LSB 1e-5 °/s.
    GyroRate,
    /// Inclinometer tilt angle: signed 24 bit, LSB 1e-5 °.
    Tilt,
    /// Magnetic flux density: signed 24 bit, LSB 1e-6 G (1e-10 T).
    Field,
    /// Reaction wheel speed: signed 24 bit, LSB 0.001 rpm.
    WheelSpeed,
    /// Reaction wheel motor torque: signed 16 bit, LSB 1e-5 Nm.
    WheelTorque,
    /// CMG gimbal angle: signed 24 bit over one turn, LSB 360°/2²⁴; wraps to [−180°, 180°).
    GimbalAngle,
    /// CMG gimbal rate: signed 24 bit, LSB 1e-4 °/s.
    GimbalRate,
    /// Thruster valve on-time: signed 16 bit, LSB 10 µs.
    ValveOnTime,
}

impl Quantity {
    /// Every quantity.
    pub const ALL: [Quantity; 8] = [
        Quantity::GyroRate,
        Quantity::Tilt,
        Quantity::Field,
        Quantity::WheelSpeed,
        Quantity::WheelTorque,
        Quantity::GimbalAngle,
        Quantity::GimbalRate,
        Quantity::ValveOnTime,
    ];

    /// Width on the wire, bits (two's complement, little-endian).
    pub const fn bits(self) -> u32 {
        match self {
            Quantity::WheelTorque | Quantity::ValveOnTime => 16,
            _ => 24,
        }
    }

    /// Width on the wire, bytes.
    pub const fn bytes(self) -> usize {
        (self.bits() / 8) as usize
    }

    /// Largest raw magnitude the field holds: 2^(bits−1) − 1.
    pub const fn raw_max(self) -> i32 {
        (1 << (self.bits() - 1)) - 1
    }

    /// Value of one LSB in the wire unit ([`Quantity::unit`]).
    pub fn lsb_unit(self) -> f64 {
        match self {
            Quantity::GyroRate => 1e-5,
            Quantity::Tilt => 1e-5,
            Quantity::Field => 1e-6,
            Quantity::WheelSpeed => 1e-3,
            Quantity::WheelTorque => 1e-5,
            Quantity::GimbalAngle => 360.0 / (1u32 << 24) as f64,
            Quantity::GimbalRate => 1e-4,
            Quantity::ValveOnTime => 1e-5,
        }
    }

    /// The wire unit's name.
    pub const fn unit(self) -> &'static str {
        match self {
            Quantity::GyroRate | Quantity::GimbalRate => "°/s",
            Quantity::Tilt | Quantity::GimbalAngle => "°",
            Quantity::Field => "G",
            Quantity::WheelSpeed => "rpm",
            Quantity::WheelTorque => "Nm",
            Quantity::ValveOnTime => "s",
        }
    }

    /// One wire unit in SI (rad/s, rad, T, rad/s, Nm).
    pub fn unit_si(self) -> f64 {
        match self {
            Quantity::GyroRate | Quantity::GimbalRate | Quantity::Tilt | Quantity::GimbalAngle => {
                DEG
            }
            Quantity::Field => GAUSS,
            Quantity::WheelSpeed => RPM,
            Quantity::WheelTorque | Quantity::ValveOnTime => 1.0,
        }
    }

    /// Value of one LSB in SI units.
    pub fn lsb_si(self) -> f64 {
        self.lsb_unit() * self.unit_si()
    }

    /// Whether the quantity wraps (an angle over one turn) instead of having a range.
    pub const fn wraps(self) -> bool {
        matches!(self, Quantity::GimbalAngle)
    }

    /// Name used in errors and documentation.
    pub const fn name(self) -> &'static str {
        match self {
            Quantity::GyroRate => "gyro rate",
            Quantity::Tilt => "tilt",
            Quantity::Field => "magnetic field",
            Quantity::WheelSpeed => "wheel speed",
            Quantity::WheelTorque => "wheel torque",
            Quantity::GimbalAngle => "gimbal angle",
            Quantity::GimbalRate => "gimbal rate",
            Quantity::ValveOnTime => "valve on-time",
        }
    }
}

/// Longest valve on-time a thruster message carries, s: the limit of the on-time field (its
/// wire span is 0.32767 s). It is a property of the wire format, not of the valves: the
/// thruster gateway refuses an on-time longer than the control period (0.1 s) before encoding.
pub const MAX_VALVE_ON_TIME_S: f64 = 0.3;

/// Why a protocol configuration was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProtocolError {
    /// The identifier base is not a multiple of 0x10 or leaves no room for every device block.
    #[error("CAN identifier base {base:#05x} must be a multiple of 0x10 and at most {max:#05x}")]
    BadBase { base: u16, max: u16 },
    /// A device range or command limit is not a finite positive number.
    #[error("{name} limit {value} must be a finite number > 0")]
    BadLimit { name: &'static str, value: f64 },
    /// A device range or command limit does not fit the wire field.
    #[error("{name} limit {value} exceeds what the {bits}-bit wire field holds ({span})")]
    LimitTooWide {
        name: &'static str,
        value: f64,
        bits: u32,
        span: f64,
    },
}

/// The 11-bit identifier map: `id = base + 0x10 · device slot + message number`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct IdMap {
    base: u16,
}

impl Default for IdMap {
    fn default() -> Self {
        Self { base: DEFAULT_BASE }
    }
}

impl IdMap {
    /// A map with identifier base `base` (a multiple of 0x10, at most [`MAX_BASE`]).
    pub fn new(base: u16) -> Result<Self, ProtocolError> {
        if base % SLOT_STRIDE != 0 || base > MAX_BASE {
            return Err(ProtocolError::BadBase {
                base,
                max: MAX_BASE,
            });
        }
        Ok(Self { base })
    }

    /// The identifier base.
    pub const fn base(&self) -> u16 {
        self.base
    }

    /// First identifier of a device's block.
    pub const fn device_base(&self, device: Device) -> u16 {
        self.base + SLOT_STRIDE * device.slot()
    }

    /// Identifier of frame `part` of `kind` (None if `part` is out of range).
    pub fn id(&self, kind: MessageKind, part: usize) -> Option<u16> {
        (part < kind.parts())
            .then(|| self.device_base(kind.device()) + kind.first_message() + part as u16)
    }

    /// Which message and frame an identifier carries (None outside the map).
    pub fn lookup(&self, id: u16) -> Option<(MessageKind, usize)> {
        let offset = id.checked_sub(self.base)?;
        let slot = usize::from(offset / SLOT_STRIDE);
        let message = offset % SLOT_STRIDE;
        let device = *Device::ALL.get(slot)?;
        MessageKind::ALL.iter().find_map(|&kind| {
            let first = kind.first_message();
            (kind.device() == device
                && message >= first
                && usize::from(message - first) < kind.parts())
            .then(|| (kind, usize::from(message - first)))
        })
    }

    /// Kernel receive filter `(id, mask)` accepting exactly the block of `device` (16 identifiers,
    /// standard frames only when used with SocketCAN's `CAN_EFF_FLAG` in the mask).
    pub const fn device_filter(&self, device: Device) -> (u16, u16) {
        (self.device_base(device), 0x7FF & !(SLOT_STRIDE - 1))
    }
}

/// Device ranges and command limits in SI units.
///
/// Decoding clips measurements beyond these ranges (and flags the channel saturated); encoding
/// refuses values beyond them. Build them from the model configuration ([`Limits::from_model`]);
/// the [`Default`] is the default model configuration's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Gyro measurement range ±, rad/s (`gyro.range_deg_s`, 80 °/s).
    pub gyro_range_rad_s: f64,
    /// Inclinometer measurement range ±, rad (`inclinometer.range_deg`, 25°).
    pub tilt_range_rad: f64,
    /// Magnetometer measurement range ±, T (`magnetometer.range_gauss`, 1 G).
    pub field_range_t: f64,
    /// Reaction wheel speed limit ±, rad/s (`wheels.max_speed_rpm`, 6000 rpm).
    pub wheel_speed_rad_s: f64,
    /// Reaction wheel motor torque limit ±, Nm (`wheels.max_torque_nm`, 0.1 Nm), for telemetry and commands.
    pub wheel_torque_nm: f64,
    /// CMG gimbal rate limit ±, rad/s (`cmg.max_gimbal_rate_deg_s`, 90 °/s), for telemetry and commands.
    pub gimbal_rate_rad_s: f64,
    /// Thruster valve on-time limit, s ([`MAX_VALVE_ON_TIME_S`]).
    pub valve_on_time_s: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self::from_model(&ModelConfig::default())
    }
}

impl Limits {
    /// The ranges and limits of a model configuration.
    pub fn from_model(config: &ModelConfig) -> Self {
        Self {
            gyro_range_rad_s: config.gyro.range_deg_s * DEG,
            tilt_range_rad: config.inclinometer.range_deg * DEG,
            field_range_t: config.magnetometer.range_gauss * GAUSS,
            wheel_speed_rad_s: config.wheels.max_speed_rad_s(),
            wheel_torque_nm: config.wheels.max_torque_nm,
            gimbal_rate_rad_s: config.cmg.max_gimbal_rate_rad_s(),
            valve_on_time_s: MAX_VALVE_ON_TIME_S,
        }
    }

    /// The range of a quantity, SI (None for the wrapping gimbal angle).
    pub fn range(&self, quantity: Quantity) -> Option<f64> {
        match quantity {
            Quantity::GyroRate => Some(self.gyro_range_rad_s),
            Quantity::Tilt => Some(self.tilt_range_rad),
            Quantity::Field => Some(self.field_range_t),
            Quantity::WheelSpeed => Some(self.wheel_speed_rad_s),
            Quantity::WheelTorque => Some(self.wheel_torque_nm),
            Quantity::GimbalAngle => None,
            Quantity::GimbalRate => Some(self.gimbal_rate_rad_s),
            Quantity::ValveOnTime => Some(self.valve_on_time_s),
        }
    }

    /// Refuses non-finite or non-positive limits and limits the wire fields cannot hold.
    pub fn validate(&self) -> Result<(), ProtocolError> {
        for q in Quantity::ALL {
            let Some(value) = self.range(q) else { continue };
            if !(value.is_finite() && value > 0.0) {
                return Err(ProtocolError::BadLimit {
                    name: q.name(),
                    value,
                });
            }
            let span = f64::from(q.raw_max()) * q.lsb_si();
            if value > span {
                return Err(ProtocolError::LimitTooWide {
                    name: q.name(),
                    value,
                    bits: q.bits(),
                    span,
                });
            }
        }
        Ok(())
    }
}

/// A validated protocol configuration: identifier map and limits, with the limits in raw counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Protocol {
    ids: IdMap,
    limits: Limits,
    /// Per quantity (index in `Quantity::ALL`): largest raw magnitude inside the range.
    raw_limit: [i32; 8],
}

impl Default for Protocol {
    fn default() -> Self {
        // The defaults are checked by a test; fall back to the wire spans if they ever break.
        Self::new(IdMap::default(), Limits::default()).unwrap_or_else(|_| Self {
            ids: IdMap::default(),
            limits: Limits::default(),
            raw_limit: Quantity::ALL.map(Quantity::raw_max),
        })
    }
}

impl Protocol {
    /// A protocol with identifier map `ids` and device limits `limits` (validated).
    pub fn new(ids: IdMap, limits: Limits) -> Result<Self, ProtocolError> {
        limits.validate()?;
        let raw_limit = Quantity::ALL.map(|q| match limits.range(q) {
            // round(): any value within the range quantises to at most this magnitude.
            Some(r) => ((r / q.lsb_si()).round() as i32).clamp(0, q.raw_max()),
            None => q.raw_max(),
        });
        Ok(Self {
            ids,
            limits,
            raw_limit,
        })
    }

    /// The protocol of a model configuration with identifier base `base`.
    pub fn from_model(base: u16, config: &ModelConfig) -> Result<Self, ProtocolError> {
        Self::new(IdMap::new(base)?, Limits::from_model(config))
    }

    /// The identifier map.
    pub const fn ids(&self) -> &IdMap {
        &self.ids
    }

    /// The limits.
    pub const fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Largest raw magnitude of `quantity` inside its range.
    pub(crate) fn raw_limit(&self, quantity: Quantity) -> i32 {
        self.raw_limit[quantity_index(quantity)]
    }
}

pub(crate) const fn quantity_index(q: Quantity) -> usize {
    match q {
        Quantity::GyroRate => 0,
        Quantity::Tilt => 1,
        Quantity::Field => 2,
        Quantity::WheelSpeed => 3,
        Quantity::WheelTorque => 4,
        Quantity::GimbalAngle => 5,
        Quantity::GimbalRate => 6,
        Quantity::ValveOnTime => 7,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        Limits::default().validate().unwrap();
        Protocol::new(IdMap::default(), Limits::default()).unwrap();
    }

    #[test]
    fn base_is_checked() {
        assert!(IdMap::new(0).is_ok());
        assert!(IdMap::new(MAX_BASE).is_ok());
        assert!(IdMap::new(MAX_BASE + 0x10).is_err());
        assert!(IdMap::new(0x101).is_err());
        let top = IdMap::new(MAX_BASE).unwrap();
        for kind in MessageKind::ALL {
            for part in 0..kind.parts() {
                assert!(top.id(kind, part).unwrap() <= 0x7FF);
            }
        }
        assert_eq!(MAX_BASE, 0x790);
    }

    #[test]
    fn every_id_maps_back() {
        for base in [0, 0x100, 0x230, MAX_BASE] {
            let map = IdMap::new(base).unwrap();
            let mut seen = std::collections::HashSet::new();
            for kind in MessageKind::ALL {
                for part in 0..kind.parts() {
                    let id = map.id(kind, part).unwrap();
                    assert!(seen.insert(id), "duplicate id {id:#x}");
                    assert_eq!(map.lookup(id), Some((kind, part)));
                    let (fid, mask) = map.device_filter(kind.device());
                    assert_eq!(id & mask, fid & mask);
                }
            }
            let mapped = (0..=0x7FF).filter(|&id| map.lookup(id).is_some()).count();
            assert_eq!(mapped, seen.len());
        }
    }

    #[test]
    fn limits_from_model_and_refusals() {
        let l = Limits::default();
        assert!((l.gyro_range_rad_s - 80.0 * DEG).abs() < 1e-15);
        assert!((l.wheel_speed_rad_s - 6000.0 * RPM).abs() < 1e-12);
        let mut bad = l;
        bad.gyro_range_rad_s = 90.0 * DEG; // beyond the 24-bit field at 1e-5 °/s
        assert!(matches!(
            bad.validate(),
            Err(ProtocolError::LimitTooWide { .. })
        ));
        bad = l;
        bad.wheel_torque_nm = f64::NAN;
        assert!(matches!(
            bad.validate(),
            Err(ProtocolError::BadLimit { .. })
        ));
    }
}
