//! The vector-measurement update (inclinometer and magnetometer, 2.5 Hz): time alignment of the
//! sample with the state (extrapolation ahead, lag tolerance behind; times in ns), the
//! measurement blocks (gravity direction in the tangent plane, dimensionless; magnetic field in
//! tesla; both in body axes), their linearisation, and the joint iterated update with the Joseph
//! form of the covariance. The gating of each block is in `gating`.

use super::model::{MIN_GRAVITY_Z, inclinometer_covariance, measurement_jacobian, tangent_basis};
use super::spd_factor::SpdFactor;
use super::{
    Block, BlockResult, BlockStatus, Mekf, MekfError, NS_PER_S, UpdateLinearisation, UpdateReport,
    symmetrise,
};
use nalgebra::{
    Matrix2x3, Matrix3, Matrix3x2, Matrix3x6, Matrix6, SMatrix, SVector, Vector3, Vector6,
};
use testbed_model::attitude::{self, Attitude};

/// Relinearise the update when the correction exceeds this, rad (see [`mekf`](super), "Iterated
/// update": the neglected second-order term is then below `(1e-4)²/2 = 5e-9` rad, 3e-4
/// inclinometer σ).
const RELINEARISE_ABOVE_RAD: f64 = 1e-4;

/// Vector samples taken at one time. Either may be absent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VectorMeasurements {
    /// Inclinometer angles `[θ, φ]`, rad: tilt of body X and body Y against the level plane.
    pub tilt_rad: Option<[f64; 2]>,
    /// Magnetometer reading, body axes, tesla.
    pub field_b_t: Option<Vector3<f64>>,
}

/// The usable blocks of an update, indexed by [`Block`] (`None`: absent, invalid or rejected).
pub(super) type Blocks = [Option<BlockData>; 2];

/// The blocks the gate accepted, each with its linearisation about the prior state (the first
/// iteration's), indexed by [`Block`].
pub(super) type Accepted = [Option<(BlockData, Linearised)>; 2];

/// One measurement block ready for linearisation.
#[derive(Debug, Clone, Copy)]
pub(super) enum BlockData {
    /// Measured unit down vector (body) and its 3×3 rank-2 covariance `R_G`.
    Gravity { y: Vector3<f64>, r: Matrix3<f64> },
    /// Measured field (body, T) and `R_M`.
    Magnetic { y: Vector3<f64>, r: Matrix3<f64> },
}

/// A block linearised about one state, in the leading `dim` rows (and columns) of fixed 3-row
/// storage: 2 for the gravity block, 3 for the magnetic block (the rest is zero). Fixed sizes
/// keep the update on the stack.
#[derive(Debug, Clone, Copy)]
pub(super) struct Linearised {
    /// Rows the block contributes: 2 (gravity, tangent plane) or 3 (magnetic field).
    pub(super) dim: usize,
    /// Innovation, first `dim` components.
    pub(super) nu: Vector3<f64>,
    /// Sensitivity to `[δθ, δb]`, first `dim` rows.
    pub(super) h: Matrix3x6<f64>,
    /// Measurement covariance, leading `dim × dim`.
    pub(super) r: Matrix3<f64>,
    /// Raw 3-D residual `y − A r`.
    pub(super) residual: Vector3<f64>,
    /// Tangent basis of the gravity block (None for the magnetic block).
    pub(super) basis: Option<Matrix3x2<f64>>,
}

impl Linearised {
    /// The block's innovation, sensitivity and covariance at its size `D` (= `dim`).
    pub(super) fn sized<const D: usize>(
        &self,
    ) -> (SVector<f64, D>, SMatrix<f64, D, 6>, SMatrix<f64, D, D>) {
        debug_assert_eq!(self.dim, D);
        (
            self.nu.fixed_rows::<D>(0).into_owned(),
            self.h.fixed_rows::<D>(0).into_owned(),
            self.r.fixed_view::<D, D>(0, 0).into_owned(),
        )
    }
}

impl Mekf {
    /// Vector-measurement update at `t_ns` with whichever blocks `meas` holds.
    ///
    /// * `t_ns` ahead of the state: the state is first extrapolated with the held gyro rate.
    /// * `t_ns` behind by at most `max_measurement_lag_s`: used, carried to the state's time.
    /// * further behind: refused ([`MekfError::Stale`]) and counted.
    ///
    /// Missing, invalid, non-invertible and gated-out blocks are reported and counted; the
    /// others are applied jointly. Returns what happened (also kept for [`Mekf::estimate`]).
    pub fn update(
        &mut self,
        t_ns: u64,
        meas: &VectorMeasurements,
    ) -> Result<UpdateReport, MekfError> {
        if t_ns < self.t_ns {
            let tolerance_ns = (self.config.max_measurement_lag_s * NS_PER_S) as u64;
            if self.t_ns - t_ns > tolerance_ns {
                self.counters.out_of_order_vector += 1;
                return Err(MekfError::Stale {
                    t_ns,
                    state_ns: self.t_ns,
                    tolerance_ns,
                });
            }
        } else if t_ns > self.t_ns {
            let w = self.last_w_meas.unwrap_or(self.bias);
            self.advance((t_ns - self.t_ns) as f64 / NS_PER_S, &w);
            self.t_ns = t_ns;
            self.counters.extrapolations += 1;
        }
        let lag_s = (self.t_ns - t_ns.min(self.t_ns)) as f64 / NS_PER_S;

        let mut report = UpdateReport {
            t_ns,
            lag_s,
            gravity: BlockResult::default(),
            magnetic: BlockResult::default(),
            iterations: 0,
            correction: Vector6::zeros(),
        };

        // Collect the usable blocks, indexed by `Block`.
        let mut blocks: Blocks = [None; 2];
        if let Some([theta, phi]) = meas.tilt_rad {
            match self.gravity_block(theta, phi) {
                Some(data) => blocks[Block::Gravity as usize] = Some(data),
                None => report.gravity.status = BlockStatus::Invalid,
            }
        }
        if let Some(m) = meas.field_b_t {
            if m.iter().all(|x| x.is_finite()) {
                let sigma = Vector3::from(self.config.magnetometer_sigma_t);
                let r = Matrix3::from_diagonal(&sigma.component_mul(&sigma));
                blocks[Block::Magnetic as usize] = Some(BlockData::Magnetic { y: m, r });
            } else {
                report.magnetic.status = BlockStatus::Invalid;
            }
        }

        // Gate each block on its own innovation, with the prior.
        let (accepted, linearisations) = self.gate_blocks(&blocks, lag_s, &mut report);
        self.last_linearisation = UpdateLinearisation {
            blocks: linearisations,
            ..UpdateLinearisation::default()
        };

        // The joint update at the size of the accepted blocks stacked.
        let applied = match accepted {
            [Some(gravity), Some(magnetic)] => Some(self.apply::<5>(&[gravity, magnetic], lag_s)),
            [Some(gravity), None] => Some(self.apply::<2>(&[gravity], lag_s)),
            [None, Some(magnetic)] => Some(self.apply::<3>(&[magnetic], lag_s)),
            [None, None] => None,
        };
        match applied {
            Some(Some((iterations, correction))) => {
                report.iterations = iterations;
                report.correction = correction;
                self.last_linearisation.applied = accepted.map(|a| a.is_some());
            }
            Some(None) => {
                for r in [&mut report.gravity, &mut report.magnetic] {
                    if r.status == BlockStatus::Applied {
                        r.status = BlockStatus::NotInvertible;
                    }
                }
            }
            None => {}
        }

        // Counters.
        for (r, c) in [
            (&report.gravity, &mut self.counters.gravity),
            (&report.magnetic, &mut self.counters.magnetic),
        ] {
            match r.status {
                BlockStatus::Missing => c.missing += 1,
                BlockStatus::Invalid => c.invalid += 1,
                BlockStatus::NotInvertible => c.not_invertible += 1,
                BlockStatus::Rejected => {
                    c.rejected += 1;
                    c.consecutive_rejections += 1;
                }
                BlockStatus::Applied => {
                    c.applied += 1;
                    c.consecutive_rejections = 0;
                }
            }
        }
        let statuses = [report.gravity.status, report.magnetic.status];
        if statuses.contains(&BlockStatus::Applied) {
            self.counters.updates_applied += 1;
        } else if statuses.contains(&BlockStatus::Rejected) {
            self.counters.updates_rejected += 1;
        } else {
            self.counters.updates_skipped += 1;
        }
        self.last_update = Some(report);
        Ok(report)
    }

    /// The gravity block from inclinometer angles, or `None` if unusable.
    fn gravity_block(&self, theta: f64, phi: f64) -> Option<BlockData> {
        if !(theta.is_finite() && phi.is_finite()) {
            return None;
        }
        let y = attitude::gravity_from_tilt(theta, phi)?;
        if y.z.abs() < MIN_GRAVITY_Z {
            return None;
        }
        let [st, sp] = self.config.inclinometer_sigma_rad;
        let r = inclinometer_covariance(theta, phi, st, sp)?;
        Some(BlockData::Gravity { y, r })
    }

    /// Linearise one block about attitude `q` with rate estimate `w_hat` and lag `lag_s`.
    pub(super) fn linearise(
        &self,
        data: &BlockData,
        q: &Attitude,
        w_hat: &Vector3<f64>,
        lag_s: f64,
    ) -> Linearised {
        match data {
            BlockData::Gravity { y, r } => {
                let (a, h3) = measurement_jacobian(q, &attitude::gravity_l(), w_hat, lag_s);
                let t = tangent_basis(&a);
                let tt: Matrix2x3<f64> = t.transpose();
                let residual = y - a;
                let mut lin = Linearised {
                    dim: 2,
                    nu: Vector3::zeros(),
                    h: Matrix3x6::zeros(),
                    r: Matrix3::zeros(),
                    residual,
                    basis: Some(t),
                };
                lin.nu.fixed_rows_mut::<2>(0).copy_from(&(tt * residual));
                lin.h.fixed_rows_mut::<2>(0).copy_from(&(tt * h3));
                lin.r.fixed_view_mut::<2, 2>(0, 0).copy_from(&(tt * r * t));
                lin
            }
            BlockData::Magnetic { y, r } => {
                let (a, h3) = measurement_jacobian(q, &self.field_l, w_hat, lag_s);
                let residual = y - a;
                Linearised {
                    dim: 3,
                    nu: residual,
                    h: h3,
                    r: *r,
                    residual,
                    basis: None,
                }
            }
        }
    }

    /// Joint (iterated) update with the accepted blocks, stacked in `M` rows (2 gravity, 3
    /// magnetic field, 5 both), each with its linearisation about the prior state (the gate's,
    /// which the first iteration uses). Returns the number of linearisations and the applied
    /// correction, or `None` (state untouched) if `S` is not invertible.
    fn apply<const M: usize>(
        &mut self,
        blocks: &[(BlockData, Linearised)],
        lag_s: f64,
    ) -> Option<(u32, Vector6<f64>)> {
        let p = self.p;
        let w_meas = self.last_w_meas.unwrap_or(self.bias);
        let mut delta = Vector6::<f64>::zeros();
        let mut iterations = 0;
        let mut last: Option<(SMatrix<f64, 6, M>, SMatrix<f64, M, 6>, SMatrix<f64, M, M>)> = None; // K, H, R
        while iterations < self.config.max_update_iterations {
            iterations += 1;
            let dtheta = Vector3::new(delta[0], delta[1], delta[2]);
            let q_i = attitude::apply_error(&self.q, &dtheta);
            let b_i = self.bias + Vector3::new(delta[3], delta[4], delta[5]);
            let w_hat = w_meas - b_i;
            let mut h = SMatrix::<f64, M, 6>::zeros();
            let mut nu = SVector::<f64, M>::zeros();
            let mut r = SMatrix::<f64, M, M>::zeros();
            let mut row = 0;
            for (block, prior) in blocks {
                let l = if iterations == 1 {
                    *prior
                } else {
                    self.linearise(block, &q_i, &w_hat, lag_s)
                };
                let k = l.dim;
                h.view_mut((row, 0), (k, 6)).copy_from(&l.h.rows(0, k));
                nu.rows_mut(row, k).copy_from(&l.nu.rows(0, k));
                r.view_mut((row, row), (k, k))
                    .copy_from(&l.r.view((0, 0), (k, k)));
                row += k;
            }
            debug_assert_eq!(row, M, "the blocks stack to M rows");
            let hp = h * p;
            let s = hp * h.transpose() + r;
            let factor = SpdFactor::new(&s)?;
            // K = P Hᵀ S⁻¹  ⇔  Kᵀ = S⁻¹ H P (S, P symmetric).
            let gain = factor.solve(&hp).transpose();
            // Gauss–Newton step of the iterated EKF: δ_{i+1} = K_i (ν_i + H_i δ_i).
            let next = gain * (nu + h * delta);
            let change = (next.fixed_rows::<3>(0) - delta.fixed_rows::<3>(0)).norm();
            delta = next;
            last = Some((gain, h, r));
            if !delta.iter().all(|x| x.is_finite()) {
                return None;
            }
            if change <= RELINEARISE_ABOVE_RAD {
                break;
            }
        }
        let (gain, h, r) = last?;
        self.last_linearisation
            .gain
            .fixed_columns_mut::<M>(0)
            .copy_from(&gain);
        // Joseph form: P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ.
        let i_kh = Matrix6::<f64>::identity() - gain * h;
        let p_new = i_kh * p * i_kh.transpose() + gain * r * gain.transpose();
        if !p_new.iter().all(|x| x.is_finite()) {
            return None;
        }
        let correction = delta;
        self.q = attitude::apply_error(&self.q, &correction.fixed_rows::<3>(0).into_owned());
        self.q.renormalize();
        self.bias += correction.fixed_rows::<3>(3);
        self.p = symmetrise(&p_new);
        Some((iterations, correction))
    }
}
