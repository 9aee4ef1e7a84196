//! Thruster command and status samples: the six on/off cold-gas thrusters.
//!
//! Thruster `2a` gives `+` torque about body axis `a`, thruster `2a + 1` `−` torque (the default
//! layout, `docs/thrusters.md`). Topics: [`THRUSTER_COMMAND`](crate::topic::THRUSTER_COMMAND),
//! [`THRUSTER_STATUS`](crate::topic::THRUSTER_STATUS),
//! [`THRUSTER_APPLIED`](crate::topic::THRUSTER_APPLIED) (in the topic table, logged).

use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// Number of thrusters.
pub const THRUSTERS: usize = 6;

/// Valve on-times for one control period, from the controller.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::ThrusterCommand.v1")
)]
#[repr(C)]
pub struct ThrusterCommand {
    /// Common header; `time_ns` is the time of the input the command was computed from (the
    /// valves open at the start of the period that follows).
    pub header: SampleHeader,
    /// Electrical on-time of each valve from the start of the period, s (0: shut). A positive
    /// value below the valves' minimum on-time, above the period, or not finite is refused.
    pub on_time: [f64; THRUSTERS],
}

/// What the thruster gateway applied and counted.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::ThrusterStatus.v1")
)]
#[repr(C)]
pub struct ThrusterStatus {
    /// Common header; `time_ns` is the period the status describes.
    pub header: SampleHeader,
    /// Valve on-times applied this period, s.
    pub applied_on_time: [f64; THRUSTERS],
    /// Valve state sensed at the end of the period: bit `i` set if valve `i` is open.
    pub valves_open: u32,
    /// 1 if the thrusters are disabled (a stuck-open valve was detected), else 0.
    pub disabled: u32,
    /// Commands refused since start (NaN, out of range, shorter than the minimum on-time).
    pub refused: u64,
    /// Propellant used since start as the gateway integrates it, kg.
    pub propellant_used: f64,
}

/// Valve on-times as the smart CAN node applies them (CAN actuation path): the plant of a
/// `run.actuation = "can_node"` run with thrusters takes these instead of the controller's
/// [`ThrusterCommand`], so what reaches the valves is what came over the bus.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::AppliedThrusterCommand.v1")
)]
#[repr(C)]
pub struct AppliedThrusterCommand {
    /// Common header; `time_ns` is the tick the pulses start at. `STALE`: no complete command
    /// arrived for this tick, and every valve stays shut (a thruster command is never held).
    pub header: SampleHeader,
    /// Electrical on-time of each valve from the start of the period, s (0: shut).
    pub on_time: [f64; THRUSTERS],
    /// 1 once the latch valve upstream of every thruster is shut (no thrust at all), else 0.
    pub latch_shut: u32,
    /// Padding, always zero.
    pub _pad0: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{align_of, offset_of, size_of};

    #[test]
    fn layouts_are_pinned() {
        assert_eq!(size_of::<ThrusterCommand>(), 72);
        assert_eq!(align_of::<ThrusterCommand>(), 8);
        assert_eq!(offset_of!(ThrusterCommand, on_time), 24);
        assert_eq!(size_of::<ThrusterStatus>(), 96);
        assert_eq!(offset_of!(ThrusterStatus, applied_on_time), 24);
        assert_eq!(offset_of!(ThrusterStatus, valves_open), 72);
        assert_eq!(offset_of!(ThrusterStatus, disabled), 76);
        assert_eq!(offset_of!(ThrusterStatus, refused), 80);
        assert_eq!(offset_of!(ThrusterStatus, propellant_used), 88);
        assert_eq!(size_of::<AppliedThrusterCommand>(), 80);
        assert_eq!(offset_of!(AppliedThrusterCommand, on_time), 24);
        assert_eq!(offset_of!(AppliedThrusterCommand, latch_shut), 72);
    }
}
