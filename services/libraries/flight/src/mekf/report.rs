//! What the filter reports: the outcome of each measurement block in an update
//! ([`UpdateReport`], [`BlockStatus`], [`InnovationStats`]: residuals in body axes, gravity
//! dimensionless and magnetic field in tesla, whitened and normalised innovations
//! dimensionless), the counters since construction ([`MekfCounters`]) and the published
//! snapshot ([`MekfEstimate`]: attitude L→B, rates in rad/s, body axes, time in ns).

use nalgebra::{Matrix3, Matrix3x6, Matrix6, SMatrix, Vector3, Vector6};
use testbed_model::attitude::Attitude;

/// The two measurement blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Block {
    /// Gravity direction from the inclinometer.
    Gravity = 0,
    /// Magnetic field from the magnetometer.
    Magnetic = 1,
}

/// What an update did with one block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BlockStatus {
    /// No sample supplied.
    #[default]
    Missing,
    /// Sample not usable (non-finite, or tilt angles outside the model's domain).
    Invalid,
    /// Innovation covariance not invertible (see the [`mekf`](super) documentation); nothing
    /// applied.
    NotInvertible,
    /// Rejected by the innovation gate.
    Rejected,
    /// Applied to the state.
    Applied,
}

/// Innovation statistics of one block, computed with the prior state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InnovationStats {
    /// Residual `y − A(q⁻) r`, body axes (gravity: dimensionless; magnetic field: tesla).
    pub residual: Vector3<f64>,
    /// Whitened innovation `L⁻¹ ν` with `S = L Lᵀ` (Cholesky), dimensionless, each component
    /// N(0, 1) for a consistent filter. Magnetic field: body axes order. Gravity: components
    /// along the tangent basis `t₁` (body X projected orthogonal to the predicted gravity),
    /// `t₂ = t₁ × G`; the third component is 0 (the radial direction carries no information).
    /// For a level platform `t₁ = X`, `t₂ = Y`.
    pub whitened: Vector3<f64>,
    /// Per-component normalised innovation in body axes: residual component (gravity: its
    /// tangent-plane part) divided by the square root of the innovation-covariance diagonal;
    /// 0 where that diagonal carries no measurement (gravity's radial direction).
    pub normalised: Vector3<f64>,
    /// `true` where `normalised` is defined.
    pub normalised_mask: [bool; 3],
    /// Normalised innovation squared `νᵀ S⁻¹ ν`.
    pub nis: f64,
    /// Degrees of freedom of the block (gravity 2, magnetic field 3).
    pub dof: usize,
    /// Gate threshold the NIS was compared with (infinite with gating off).
    pub threshold: f64,
}

/// One block of an update linearised about the prior state, as its whitened innovation saw it:
/// for sensitivity analyses (identification's first-order screens), which carry a change of
/// the measurement `dy` to the whitened innovation, `L_S⁻¹ (P dy − H dx)`, with the state's change
/// `dx` (`[δθ, δb]`, in the error state's convention).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockLinearisation {
    /// Rows of the block: 2 (gravity, in its tangent plane) or 3 (magnetic field).
    pub dim: usize,
    /// `P`: the projection of a 3-D change of the measurement onto the block's rows (the
    /// tangent basis' transpose for gravity, the identity for the field), leading `dim` rows.
    pub projection: Matrix3<f64>,
    /// `H`: the rows' sensitivity to the error state, leading `dim` rows.
    pub h: Matrix3x6<f64>,
    /// `L_S`, lower triangular with `S = L_S L_Sᵀ` (the block's innovation covariance): the
    /// whitening is `W = L_S⁻¹`. Leading `dim × dim`, the identity past it.
    pub factor_lower: Matrix3<f64>,
}

/// The last update's linearisation ([`crate::mekf::Mekf::last_linearisation`]): each block's as
/// it was gated and whitened (with the prior), and the gain applied to the stacked innovation
/// of the applied blocks (gravity's rows first), at the last iteration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UpdateLinearisation {
    /// Indexed by [`Block`]; `None` where the block had no innovation.
    pub blocks: [Option<BlockLinearisation>; 2],
    /// The blocks applied, indexed by [`Block`].
    pub applied: [bool; 2],
    /// `K`, leading columns: one per row of the applied blocks, stacked; zero without an update.
    pub gain: SMatrix<f64, 6, 5>,
}

/// Result of one block in an update.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BlockResult {
    pub status: BlockStatus,
    /// Present when the innovation could be computed.
    pub stats: Option<InnovationStats>,
}

/// Result of [`Mekf::update`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateReport {
    /// Time stamp of the vector samples, ns.
    pub t_ns: u64,
    /// Age of the samples relative to the state's time when applied, s (≥ 0).
    pub lag_s: f64,
    /// Gravity (inclinometer) block.
    pub gravity: BlockResult,
    /// Magnetic-field (magnetometer) block.
    pub magnetic: BlockResult,
    /// Linearisations used (0 if nothing was applied).
    pub iterations: u32,
    /// Applied correction `[δθ (rad), δb (rad/s)]` (zero if nothing was applied).
    pub correction: Vector6<f64>,
}

impl UpdateReport {
    /// Whitened innovations `[G(3), M(3)]` and a mask (bit i set: component i valid) in the
    /// layout of `ipc_types::AttitudeEstimate::innovation` (gravity bits 0–1 only: its third
    /// component is the radial direction, not a degree of freedom).
    pub fn whitened_array(&self) -> ([f64; 6], u32) {
        self.array(|s| (s.whitened, [true, true, s.dof == 3]))
    }

    /// Per-component normalised innovations `[G(3), M(3)]`, body axes, and a mask (bit i set:
    /// component i valid).
    pub fn normalised_array(&self) -> ([f64; 6], u32) {
        self.array(|s| (s.normalised, s.normalised_mask))
    }

    fn array(
        &self,
        pick: impl Fn(&InnovationStats) -> (Vector3<f64>, [bool; 3]),
    ) -> ([f64; 6], u32) {
        let mut out = [0.0; 6];
        let mut mask = 0u32;
        for (k, block) in [&self.gravity, &self.magnetic].into_iter().enumerate() {
            if let Some(stats) = &block.stats {
                let (v, valid) = pick(stats);
                for i in 0..3 {
                    if valid[i] {
                        out[3 * k + i] = v[i];
                        mask |= 1 << (3 * k + i);
                    }
                }
            }
        }
        (out, mask)
    }
}

/// Counters of one measurement block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BlockCounters {
    /// Samples applied.
    pub applied: u64,
    /// Update calls without a sample of this block.
    pub missing: u64,
    /// Samples not usable (non-finite, out of the model's domain).
    pub invalid: u64,
    /// Samples rejected by the gate.
    pub rejected: u64,
    /// Samples skipped because the innovation covariance was not invertible.
    pub not_invertible: u64,
    /// Gate rejections since the last applied sample (a persistently rejected block, e.g. a
    /// magnetic disturbance or a lost estimate, shows here; re-initialise from vectors).
    pub consecutive_rejections: u64,
}

/// Filter counters since construction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MekfCounters {
    /// Gyro samples applied.
    pub propagations: u64,
    /// Extrapolations with the held rate to a vector sample stamped ahead of the state.
    pub extrapolations: u64,
    /// Gyro samples refused: older than the state's time.
    pub out_of_order_gyro: u64,
    /// Gyro samples refused: not finite.
    pub invalid_gyro: u64,
    /// Vector samples refused: older than the state's time beyond the tolerance.
    pub out_of_order_vector: u64,
    /// Update calls that applied at least one block.
    pub updates_applied: u64,
    /// Update calls with no usable block (all missing, invalid or not invertible).
    pub updates_skipped: u64,
    /// Update calls whose usable blocks were all rejected by the gate.
    pub updates_rejected: u64,
    /// Gravity block.
    pub gravity: BlockCounters,
    /// Magnetic-field block.
    pub magnetic: BlockCounters,
}

/// Everything a publisher needs, at the filter's time of validity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MekfEstimate {
    /// Time of validity, ns.
    pub t_ns: u64,
    /// Attitude, L to B.
    pub attitude: Attitude,
    /// Body rate relative to L, body axes, rad/s: latest gyro sample minus the bias estimate.
    pub rate_rad_s: Vector3<f64>,
    /// Gyro bias estimate, body axes, rad/s.
    pub bias_rad_s: Vector3<f64>,
    /// Error-state covariance `[δθ, δb]` (rad², rad²/s, rad²/s²).
    pub covariance: Matrix6<f64>,
    /// The latest update, if any.
    pub last_update: Option<UpdateReport>,
    /// Counters since construction.
    pub counters: MekfCounters,
}
