//! The vector-measurement update (inclinometer and magnetometer, 2.5 Hz): time alignment of the
//! sample with the state (extrapolation ahead, lag tolerance behind; times in ns), the
//! measurement blocks (gravity direction in the tangent plane, dimensionless; magnetic field in
//! tesla; both in body axes), their linearisation, and the joint iterated update with the Joseph
//! form of the covariance. The gating of each block is in `gating`.

use super::model::{MIN_GRAVITY_Z, inclinometer_covariance, measurement_jacobian, tangent_basis};
use super::spd_factor::SpdFactor;
use super::{Block, BlockResult, BlockStatus, Mekf, MekfError, NS_PER_S, UpdateReport, symmetrise};
use nalgebra::{DMatrix, DVector, Matrix2x3, Matrix3, Matrix3x2, Matrix6, Vector3, Vector6};
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

/// One measurement block ready for linearisation.
#[derive(Debug, Clone, Copy)]
pub(super) enum BlockData {
    /// Measured unit down vector (body) and its 3×3 rank-2 covariance `R_G`.
    Gravity { y: Vector3<f64>, r: Matrix3<f64> },
    /// Measured field (body, T) and `R_M`.
    Magnetic { y: Vector3<f64>, r: Matrix3<f64> },
}

/// A block linearised about one state.
pub(super) struct Linearised {
    /// Innovation (2 or 3 components).
    pub(super) nu: DVector<f64>,
    /// Sensitivity to `[δθ, δb]` (2×6 or 3×6).
    pub(super) h: DMatrix<f64>,
    /// Measurement covariance (2×2 or 3×3).
    pub(super) r: DMatrix<f64>,
    /// Raw 3-D residual `y − A r`.
    pub(super) residual: Vector3<f64>,
    /// Tangent basis of the gravity block (None for the magnetic block).
    pub(super) basis: Option<Matrix3x2<f64>>,
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

        // Collect the usable blocks.
        let mut blocks: Vec<(Block, BlockData)> = Vec::with_capacity(2);
        if let Some([theta, phi]) = meas.tilt_rad {
            match self.gravity_block(theta, phi) {
                Some(data) => blocks.push((Block::Gravity, data)),
                None => report.gravity.status = BlockStatus::Invalid,
            }
        }
        if let Some(m) = meas.field_b_t {
            if m.iter().all(|x| x.is_finite()) {
                let sigma = Vector3::from(self.config.magnetometer_sigma_t);
                let r = Matrix3::from_diagonal(&sigma.component_mul(&sigma));
                blocks.push((Block::Magnetic, BlockData::Magnetic { y: m, r }));
            } else {
                report.magnetic.status = BlockStatus::Invalid;
            }
        }

        // Gate each block on its own innovation, with the prior.
        let accepted = self.gate_blocks(&blocks, lag_s, &mut report);

        if !accepted.is_empty() {
            match self.apply(&accepted, lag_s) {
                Some((iterations, correction)) => {
                    report.iterations = iterations;
                    report.correction = correction;
                }
                None => {
                    for r in [&mut report.gravity, &mut report.magnetic] {
                        if r.status == BlockStatus::Applied {
                            r.status = BlockStatus::NotInvertible;
                        }
                    }
                }
            }
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
                Linearised {
                    nu: DVector::from_column_slice((tt * residual).as_slice()),
                    h: DMatrix::from_column_slice(2, 6, (tt * h3).as_slice()),
                    r: DMatrix::from_column_slice(2, 2, (tt * r * t).as_slice()),
                    residual,
                    basis: Some(t),
                }
            }
            BlockData::Magnetic { y, r } => {
                let (a, h3) = measurement_jacobian(q, &self.field_l, w_hat, lag_s);
                let residual = y - a;
                Linearised {
                    nu: DVector::from_column_slice(residual.as_slice()),
                    h: DMatrix::from_column_slice(3, 6, h3.as_slice()),
                    r: DMatrix::from_column_slice(3, 3, r.as_slice()),
                    residual,
                    basis: None,
                }
            }
        }
    }

    /// Joint (iterated) update with the accepted blocks. Returns the number of linearisations and
    /// the applied correction, or `None` (state untouched) if `S` is not invertible.
    fn apply(&mut self, blocks: &[BlockData], lag_s: f64) -> Option<(u32, Vector6<f64>)> {
        let p = DMatrix::from_column_slice(6, 6, self.p.as_slice());
        let w_meas = self.last_w_meas.unwrap_or(self.bias);
        let mut delta = DVector::<f64>::zeros(6);
        let mut iterations = 0;
        let mut last: Option<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> = None; // K, H, R
        while iterations < self.config.max_update_iterations {
            iterations += 1;
            let dtheta = Vector3::new(delta[0], delta[1], delta[2]);
            let q_i = attitude::apply_error(&self.q, &dtheta);
            let b_i = self.bias + Vector3::new(delta[3], delta[4], delta[5]);
            let w_hat = w_meas - b_i;
            let lins: Vec<Linearised> = blocks
                .iter()
                .map(|b| self.linearise(b, &q_i, &w_hat, lag_s))
                .collect();
            let m: usize = lins.iter().map(|l| l.nu.len()).sum();
            let mut h = DMatrix::<f64>::zeros(m, 6);
            let mut nu = DVector::<f64>::zeros(m);
            let mut r = DMatrix::<f64>::zeros(m, m);
            let mut row = 0;
            for l in &lins {
                let k = l.nu.len();
                h.view_mut((row, 0), (k, 6)).copy_from(&l.h);
                nu.rows_mut(row, k).copy_from(&l.nu);
                r.view_mut((row, row), (k, k)).copy_from(&l.r);
                row += k;
            }
            let s = &h * &p * h.transpose() + &r;
            let factor = SpdFactor::new(&s)?;
            // K = P Hᵀ S⁻¹  ⇔  Kᵀ = S⁻¹ H P (S, P symmetric).
            let gain = factor.solve(&(&h * &p)).transpose();
            // Gauss–Newton step of the iterated EKF: δ_{i+1} = K_i (ν_i + H_i δ_i).
            let next = &gain * (&nu + &h * &delta);
            let change = (next.rows(0, 3) - delta.rows(0, 3)).norm();
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
        // Joseph form: P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ.
        let i_kh = DMatrix::<f64>::identity(6, 6) - &gain * &h;
        let p_new = &i_kh * &p * i_kh.transpose() + &gain * &r * gain.transpose();
        let p_new = Matrix6::from_column_slice(p_new.as_slice());
        if !p_new.iter().all(|x| x.is_finite()) {
            return None;
        }
        let correction = Vector6::from_column_slice(delta.as_slice());
        self.q = attitude::apply_error(&self.q, &correction.fixed_rows::<3>(0).into_owned());
        self.q.renormalize();
        self.bias += correction.fixed_rows::<3>(3);
        self.p = symmetrise(&p_new);
        Some((iterations, correction))
    }
}
