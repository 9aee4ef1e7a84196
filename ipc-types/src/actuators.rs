use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// Telemetry of the three reaction wheels (wheel `i` spins about body axis `i`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::WheelTelemetry.v1")
)]
#[repr(C)]
pub struct WheelTelemetry {
    /// Common header; `time_ns` is the device's sampling instant.
    pub header: SampleHeader,
    /// Wheel speeds relative to the platform, about each wheel's own axis, rad/s.
    pub speed: [f64; 3],
    /// Measured (motor-current-derived) motor torque on each wheel, about its axis, Nm.
    /// The platform feels the opposite torque.
    pub torque: [f64; 3],
}

impl WheelTelemetry {
    /// A sample from its parts.
    pub const fn new(header: SampleHeader, speed: [f64; 3], torque: [f64; 3]) -> Self {
        Self {
            header,
            speed,
            torque,
        }
    }
}

/// Motor torque command to the three reaction wheels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::WheelCommand.v1")
)]
#[repr(C)]
pub struct WheelCommand {
    /// Common header; `time_ns` is the time of the input the command was computed from.
    /// `SATURATED_*` flags mark channels clipped to the torque limit.
    pub header: SampleHeader,
    /// Commanded motor torque on each wheel, about its axis, Nm. The platform feels the
    /// opposite torque.
    pub torque: [f64; 3],
}

impl WheelCommand {
    /// A command from its parts.
    pub const fn new(header: SampleHeader, torque: [f64; 3]) -> Self {
        Self { header, torque }
    }
}

/// Telemetry of the four control moment gyros (pyramid, numbered 1–4 as index 0–3).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::CmgTelemetry.v1")
)]
#[repr(C)]
pub struct CmgTelemetry {
    /// Common header; `time_ns` is the device's sampling instant.
    pub header: SampleHeader,
    /// Gimbal angles from the encoders, rad.
    pub gimbal_angle: [f64; 4],
    /// Gimbal rates, rad/s.
    pub gimbal_rate: [f64; 4],
}

impl CmgTelemetry {
    /// A sample from its parts.
    pub const fn new(header: SampleHeader, gimbal_angle: [f64; 4], gimbal_rate: [f64; 4]) -> Self {
        Self {
            header,
            gimbal_angle,
            gimbal_rate,
        }
    }
}

/// Gimbal rate command to the four control moment gyros.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::CmgCommand.v1")
)]
#[repr(C)]
pub struct CmgCommand {
    /// Common header; `time_ns` is the time of the input the command was computed from.
    /// `SATURATED_*` flags mark gimbals clipped to the rate limit.
    pub header: SampleHeader,
    /// Commanded gimbal rates, rad/s.
    pub gimbal_rate: [f64; 4],
}

impl CmgCommand {
    /// A command from its parts.
    pub const fn new(header: SampleHeader, gimbal_rate: [f64; 4]) -> Self {
        Self {
            header,
            gimbal_rate,
        }
    }
}
