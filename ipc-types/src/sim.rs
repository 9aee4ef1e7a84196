use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// True state of the simulated platform (simulation only), published by the plant every tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::SimTruth.v1")
)]
#[repr(C)]
pub struct SimTruth {
    /// Common header; `time_ns` is the simulation time of the state.
    pub header: SampleHeader,
    /// True attitude quaternion `[x, y, z, w]`, level frame L to body frame B
    /// (convention in the crate documentation).
    pub quaternion: [f64; 4],
    /// True angular rate of B relative to L, body axes, rad/s.
    pub rate: [f64; 3],
    /// True reaction wheel speeds relative to the platform, about each wheel's axis, rad/s.
    pub wheel_speed: [f64; 3],
    /// True CMG gimbal angles, rad.
    pub gimbal_angle: [f64; 4],
    /// True bias of the simulated gyros, body axes, rad/s.
    pub gyro_bias: [f64; 3],
    /// Total angular momentum (platform, wheels and CMGs), level-frame L components, Nms.
    pub angular_momentum: [f64; 3],
    /// Total rotational kinetic energy (platform, wheels and CMGs), J.
    pub kinetic_energy: f64,
    /// Bit set of [`TILT_STOP_X`](Self::TILT_STOP_X) / [`TILT_STOP_Y`](Self::TILT_STOP_Y):
    /// the platform rests against the air bearing's tilt stop about that axis.
    pub tilt_stop: u32,
    /// Padding, always zero.
    pub _pad0: u32,
}

impl SimTruth {
    /// `tilt_stop` bit: at the tilt limit about body x.
    pub const TILT_STOP_X: u32 = 1 << 0;
    /// `tilt_stop` bit: at the tilt limit about body y.
    pub const TILT_STOP_Y: u32 = 1 << 1;
}

/// One tick of the simulation clock, published by the plant (simulation only).
///
/// In lockstep mode the plant publishes tick `n` and advances to `n + 1` only after the pipeline
/// has answered tick `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::SimClockTick.v1")
)]
#[repr(C)]
pub struct SimClockTick {
    /// Common header; `time_ns` equals `sim_time_ns`.
    pub header: SampleHeader,
    /// Tick index, 0 at the start of the run.
    pub tick: u64,
    /// Simulation time of this tick, ns since the start of the run.
    pub sim_time_ns: u64,
    /// Length of the step from this tick to the next, ns.
    pub step_ns: u64,
}

impl SimClockTick {
    /// A tick; the header gets `time_ns = sim_time_ns`, `sequence = tick` and the
    /// `VALID | SIMULATED` flags.
    pub const fn new(tick: u64, sim_time_ns: u64, step_ns: u64) -> Self {
        Self {
            header: SampleHeader::new(
                sim_time_ns,
                tick,
                SampleHeader::VALID | SampleHeader::SIMULATED,
            ),
            tick,
            sim_time_ns,
            step_ns,
        }
    }
}
