//! First-order sensitivities of the filter's whitened innovations to sensor parameters, carried
//! beside the filter through the record with its gains held (the tangent of the filter at its
//! own linearisation; the gains' own change is second order in the innovations).
//!
//! A direction is a parameter's step: the sensor model at the stepped value and the step. Per
//! direction the state's change `x = [δθ, δb]` (the error state's convention: the attitude
//! `(I − [δθ×]) A`, the bias `b + δb`) follows
//!
//! * **propagation**, with `Φ` the filter's transition matrix over the interval and `dw` the
//!   change of the corrected gyro reading: `x ← Φ x − Φ₁₂ dw` (a rate change enters as a
//!   bias change of the opposite sign);
//! * **update**, per block with the filter's projection `P`, sensitivity `H` and whitening
//!   `L_S⁻¹` and the change `dy` of the corrected reading: the whitened innovation changes by
//!   `L_S⁻¹ (P dy − H x)`, and the applied blocks' stacked `dν = P dy − H x` moves the state by
//!   `K dν`.
//!
//! The corrected readings' changes `dw`, `dy` are differences of the sensor models' corrections
//! (any sensor cause, exactly as the filter run would see it). Against finite differences of
//! whole filter runs: `tangent::tests` and `tests/sensitivities.rs`.

use crate::data::Aligned;
use crate::reconstruct::{INNOVATION_LEN, SensorModel};
use nalgebra::{SMatrix, Vector3, Vector6};
use testbed_flight::mekf::{Block, UpdateLinearisation, VectorMeasurements, transition_matrix};
use testbed_model::attitude::{self, Attitude};

/// Which of a tick's gyro changes a propagation uses: the mean over the interval (the filter's
/// hold convention) or the tick's own (the first interval after the filter starts).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rate {
    Mean,
    Current,
}

/// Per recorded innovation, per direction: the whitened innovation's change per unit of the
/// parameter, `[g_t1, g_t2, m_x, m_y, m_z]` as [`crate::reconstruct::Innovation::values`].
pub type Sensitivities = Vec<Vec<[f64; INNOVATION_LEN]>>;

/// The sensitivities of one filter run to a set of directions.
pub struct Tangent {
    /// Per direction: the sensor model at the stepped parameter and the step.
    models: Vec<(SensorModel, f64)>,
    /// Per direction: the state's change per unit of the parameter.
    state: Vec<Vector6<f64>>,
    /// Per direction: the corrected gyro reading's change at the last tick and this one, and
    /// their mean.
    previous: Option<Vec<Vector3<f64>>>,
    current: Vec<Vector3<f64>>,
    mean: Vec<Vector3<f64>>,
    /// Per direction: the corrected readings' changes of the pending update (down vector, field).
    gravity: Vec<Option<Vector3<f64>>>,
    field: Vec<Option<Vector3<f64>>>,
    /// The sensitivities of the innovations recorded so far.
    pub innovations: Sensitivities,
}

impl Tangent {
    /// Directions: the sensor model at each stepped parameter, and the step.
    pub fn new(models: Vec<(SensorModel, f64)>) -> Self {
        let n = models.len();
        Self {
            models,
            state: vec![Vector6::zeros(); n],
            previous: None,
            current: vec![Vector3::zeros(); n],
            mean: vec![Vector3::zeros(); n],
            gravity: vec![None; n],
            field: vec![None; n],
            innovations: Vec::new(),
        }
    }

    /// The filter starts: its state does not depend on the parameters yet.
    pub fn start(&mut self) {
        self.state.iter_mut().for_each(|x| *x = Vector6::zeros());
    }

    /// The filter starts again after a break with the bias it had: the attitude's dependence
    /// starts anew, the bias's carries over.
    pub fn restart(&mut self) {
        for x in &mut self.state {
            x.fixed_rows_mut::<3>(0).fill(0.0);
        }
    }

    /// Tick `k`'s gyro reading, corrected by the run's model to `corrected` at attitude `q`.
    pub fn gyro(&mut self, data: &Aligned, k: usize, q: &Attitude, corrected: &Vector3<f64>) {
        for (j, (model, step)) in self.models.iter().enumerate() {
            let reading = model.gyro_of_tick(data, k);
            self.current[j] = (model.correct_gyro(&reading, q) - corrected) / *step;
        }
        let previous = self.previous.get_or_insert_with(|| self.current.clone());
        for j in 0..self.models.len() {
            self.mean[j] = 0.5 * (previous[j] + self.current[j]);
            previous[j] = self.current[j];
        }
    }

    /// The filter propagates by `dt_s` at the rate estimate `w_hat` (corrected reading less
    /// bias).
    pub fn propagate(&mut self, w_hat: &Vector3<f64>, dt_s: f64, rate: Rate) {
        if dt_s <= 0.0 {
            return;
        }
        let phi = transition_matrix(w_hat, dt_s);
        // A rate change moves the attitude only: `Φ₁₂`, the attitude rows of the bias columns.
        let phi12 = phi.fixed_view::<3, 3>(0, 3).into_owned();
        let changes = match rate {
            Rate::Mean => &self.mean,
            Rate::Current => &self.current,
        };
        for (x, dw) in self.state.iter_mut().zip(changes) {
            *x = phi * *x;
            let mut attitude = x.fixed_rows_mut::<3>(0);
            attitude -= phi12 * dw;
        }
    }

    /// The pending update's readings, `raw` (the tilt, rad; the field, tesla, taken out at the
    /// filter's attitude `q`) and as the run's model corrected them (`corrected`).
    pub fn readings(
        &mut self,
        raw_tilt: Option<(&[f64; 2], &Attitude, &Vector3<f64>)>,
        raw_field: Option<(&Vector3<f64>, &Attitude, &Vector3<f64>)>,
        corrected: &VectorMeasurements,
    ) {
        let down = |[a, b]: [f64; 2]| attitude::gravity_from_tilt(a, b);
        let down0 = corrected.tilt_rad.and_then(down);
        for (j, (model, step)) in self.models.iter().enumerate() {
            self.gravity[j] = raw_tilt.zip(down0).and_then(|((t, qt, w), g0)| {
                Some((down(model.correct_tilt(t, qt, w))? - g0) / *step)
            });
            self.field[j] = raw_field
                .zip(corrected.field_b_t)
                .map(|((m, q, w), f0)| (model.correct_field(m, q, w) - f0) / *step);
        }
    }

    /// The filter updated with the readings of [`Tangent::readings`] and linearisation `lin`:
    /// the whitened innovations' changes (per direction) and the state's.
    pub fn update(&mut self, lin: &UpdateLinearisation) -> Vec<[f64; INNOVATION_LEN]> {
        let mut out = Vec::with_capacity(self.models.len());
        for j in 0..self.models.len() {
            let x = self.state[j];
            let mut values = [0.0; INNOVATION_LEN];
            let mut stacked = SMatrix::<f64, 5, 1>::zeros();
            let mut row = 0;
            for (block, first, dy) in [
                (Block::Gravity, 0, self.gravity[j]),
                (Block::Magnetic, 2, self.field[j]),
            ] {
                let Some(b) = &lin.blocks[block as usize] else {
                    continue;
                };
                let dnu = b.projection * dy.unwrap_or_else(Vector3::zeros) - b.h * x;
                let white = b
                    .factor_lower
                    .solve_lower_triangular(&dnu)
                    .unwrap_or_else(Vector3::zeros);
                for i in 0..b.dim {
                    values[first + i] = white[i];
                }
                if lin.applied[block as usize] {
                    for i in 0..b.dim {
                        stacked[row + i] = dnu[i];
                    }
                    row += b.dim;
                }
            }
            self.state[j] = x + lin.gain * stacked;
            out.push(values);
        }
        out
    }
}
