//! The estimator task: the MEKF fed with gyro samples (body rate, rad/s, bias included) and
//! vector samples (inclinometer angles in rad, magnetometer field in tesla, body axes), times in
//! nanoseconds; it initialises itself by TRIAD and publishes [`MekfEstimate`]s (attitude level
//! frame to body frame).

use crate::mekf::{Mekf, MekfConfig, MekfError, MekfEstimate, UpdateReport, VectorMeasurements};
use nalgebra::Vector3;
use testbed_model::attitude;

/// The MEKF with its start-up: it initialises itself by TRIAD from the first sample time that
/// has both a tilt and a field measurement, and until then only remembers the gyro.
#[derive(Debug, Clone)]
pub struct EstimatorTask {
    config: MekfConfig,
    mekf: Option<Mekf>,
    last_gyro: Option<(u64, Vector3<f64>)>,
}

impl EstimatorTask {
    pub fn new(config: MekfConfig) -> Self {
        Self {
            config,
            mekf: None,
            last_gyro: None,
        }
    }

    /// A gyro sample (body rate, rad/s, bias included) valid at `t_ns`.
    pub fn on_gyro(&mut self, t_ns: u64, rate_rad_s: &Vector3<f64>) -> Result<(), MekfError> {
        self.last_gyro = Some((t_ns, *rate_rad_s));
        match &mut self.mekf {
            Some(mekf) => mekf.propagate(t_ns, rate_rad_s),
            None => Ok(()),
        }
    }

    /// Vector samples valid at `t_ns`. Returns the update's report once the filter runs, `None`
    /// while it still waits for a complete pair to initialise from.
    pub fn on_vectors(
        &mut self,
        t_ns: u64,
        measurements: &VectorMeasurements,
    ) -> Result<Option<UpdateReport>, MekfError> {
        if let Some(mekf) = &mut self.mekf {
            return mekf.update(t_ns, measurements).map(Some);
        }
        let (Some(tilt), Some(field)) = (measurements.tilt_rad, measurements.field_b_t) else {
            return Ok(None);
        };
        let Some(gravity) = attitude::gravity_from_tilt(tilt[0], tilt[1]) else {
            return Ok(None);
        };
        let mut mekf = Mekf::initialise_from_vectors(self.config.clone(), t_ns, &gravity, &field)?;
        if let Some((t_gyro, rate)) = self.last_gyro.filter(|(t, _)| *t == t_ns) {
            mekf.propagate(t_gyro, &rate)?;
        }
        self.mekf = Some(mekf);
        Ok(None)
    }

    /// The current estimate, once initialised.
    pub fn estimate(&self) -> Option<MekfEstimate> {
        self.mekf.as_ref().map(Mekf::estimate)
    }

    pub fn filter(&self) -> Option<&Mekf> {
        self.mekf.as_ref()
    }
}
