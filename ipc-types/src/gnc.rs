use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// Output of the attitude estimator (MEKF), published after every propagation or update.
///
/// Error state order (covariance rows/columns, innovation components as noted below):
/// `[dθ_x, dθ_y, dθ_z, db_x, db_y, db_z]`, with `dθ` the small-angle attitude error in body axes
/// (rad) and `db` the gyro bias error (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::AttitudeEstimate.v1")
)]
#[repr(C)]
pub struct AttitudeEstimate {
    /// Common header; `time_ns` is the time the estimate refers to (the latest gyro sample).
    pub header: SampleHeader,
    /// Estimated attitude quaternion `[x, y, z, w]`, level frame L to body frame B
    /// (convention in the crate documentation).
    pub quaternion: [f64; 4],
    /// Estimated angular rate of B relative to L, body axes, rad/s (gyro rate minus estimated
    /// bias).
    pub rate: [f64; 3],
    /// Estimated gyro bias, body axes, rad/s (absorbs the Earth's rotation as the gyro senses it).
    pub gyro_bias: [f64; 3],
    /// 6×6 error-state covariance, row-major (`P[i][j]` at `6 * i + j`); units rad², rad²/s,
    /// rad²/s² by block.
    pub covariance: [f64; 36],
    /// Normalised innovations of the latest vector update (innovation component divided by the
    /// square root of its innovation-covariance diagonal, dimensionless), in the order
    /// `[G_x, G_y, G_z, M_x, M_y, M_z]`: gravity direction from the inclinometer, then magnetic
    /// field from the magnetometer, body axes.
    pub innovation: [f64; 6],
    /// Time of the latest vector update the innovations belong to, ns on the run's clock.
    pub innovation_time_ns: u64,
    /// Bit `i` set: `innovation[i]` was computed in the latest update (bits 0–2 gravity,
    /// 3–5 magnetic field). Unset components are undefined.
    pub innovation_mask: u32,
    /// Padding, always zero.
    pub _pad0: u32,
    /// Vector-measurement updates applied since start.
    pub updates_applied: u64,
    /// Updates skipped since start (measurement invalid, stale, or not usable).
    pub updates_skipped: u64,
    /// Updates rejected by innovation gating since start.
    pub updates_rejected: u64,
}

impl AttitudeEstimate {
    /// `innovation_mask` bits of the gravity (inclinometer) components.
    pub const INNOVATION_GRAVITY: u32 = 0b000_111;
    /// `innovation_mask` bits of the magnetic-field (magnetometer) components.
    pub const INNOVATION_MAGNETIC: u32 = 0b111_000;

    /// Number of valid innovation components (set bits of `innovation_mask`).
    pub const fn innovation_count(&self) -> u32 {
        self.innovation_mask.count_ones()
    }

    /// Covariance element `P[row][col]`.
    pub const fn covariance_at(&self, row: usize, col: usize) -> f64 {
        self.covariance[6 * row + col]
    }

    /// The covariance diagonal (variances of `[dθ, db]`).
    pub fn covariance_diagonal(&self) -> [f64; 6] {
        core::array::from_fn(|i| self.covariance_at(i, i))
    }
}

impl Default for AttitudeEstimate {
    /// All zero (note: the zero quaternion is not a valid attitude).
    fn default() -> Self {
        Self {
            header: SampleHeader::default(),
            quaternion: [0.0; 4],
            rate: [0.0; 3],
            gyro_bias: [0.0; 3],
            covariance: [0.0; 36],
            innovation: [0.0; 6],
            innovation_time_ns: 0,
            innovation_mask: 0,
            _pad0: 0,
            updates_applied: 0,
            updates_skipped: 0,
            updates_rejected: 0,
        }
    }
}

/// Operating mode of the attitude controller, stored as `u32` in [`ControllerStatus::mode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum ControllerMode {
    /// No commands issued (actuators held at zero).
    #[default]
    Idle = 0,
    /// Rate damping with the reaction wheels.
    RateDamping = 1,
    /// Attitude hold / pointing with the reaction wheels (PD + friction compensation).
    WheelPointing = 2,
    /// Large-angle manoeuvre with the CMGs.
    CmgSlew = 3,
    /// Fault: outputs zeroed after a detected failure.
    Fault = 4,
    /// Safe mode: an input is lost or invalid, a wheel is near its speed limit, or the ground
    /// asked for it; wheels at a safe torque (zero or rate damping on the gyro), gimbals held.
    Safe = 5,
    /// Wheel pointing while the thrusters unload the wheels (momentum dump).
    MomentumDump = 6,
    /// Rate damping on the thrusters alone, wheels off (the safe mode with thrusters).
    ThrusterRateDamping = 7,
}

impl ControllerMode {
    /// The mode with wire value `value`, if any.
    pub const fn from_u32(value: u32) -> Option<Self> {
        Some(match value {
            0 => Self::Idle,
            1 => Self::RateDamping,
            2 => Self::WheelPointing,
            3 => Self::CmgSlew,
            4 => Self::Fault,
            5 => Self::Safe,
            6 => Self::MomentumDump,
            7 => Self::ThrusterRateDamping,
            _ => return None,
        })
    }
}

/// Status of the attitude controller, published once per control cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::ControllerStatus.v1")
)]
#[repr(C)]
pub struct ControllerStatus {
    /// Common header; `time_ns` is the time of the estimate the cycle used.
    pub header: SampleHeader,
    /// [`ControllerMode`] as `u32`.
    pub mode: u32,
    /// Padding, always zero.
    pub _pad0: u32,
    /// Attitude error `2·q_e,v` (vector part of `q_e = q ⊗ q_ref*`), body axes, rad
    /// (small-angle rotation from the reference attitude to the current one).
    pub attitude_error: [f64; 3],
    /// Commanded control torque on the platform, body axes, Nm (before allocation to wheels or
    /// CMGs and including friction compensation).
    pub torque_command: [f64; 3],
    /// Control cycles that missed their deadline since start.
    pub deadline_misses: u64,
    /// Time since the previous control cycle, ns on the run's clock.
    pub loop_period_ns: u64,
    /// Compute time of this cycle, ns of wall-clock time. Diagnostic only; 0 in lockstep
    /// simulation so that logs stay reproducible.
    pub compute_time_ns: u64,
}

impl ControllerStatus {
    /// The mode, or `None` for an unknown wire value.
    pub const fn mode(&self) -> Option<ControllerMode> {
        ControllerMode::from_u32(self.mode)
    }

    /// Sets the mode.
    pub const fn set_mode(&mut self, mode: ControllerMode) {
        self.mode = mode as u32;
    }
}
