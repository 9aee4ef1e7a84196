//! `mekf`: the paper's multiplicative EKF (Lefferts, Markley & Shuster 1982, [`crate::mekf`])
//! behind the filter interface, started by TRIAD. Parameters: `[estimator.mekf]`,
//! [`MekfConfig`], derived from the model's sensor noise and field where absent.

use super::{AttitudeFilter, FilterDefinition, FilterEstimate, FilterParams};
use crate::mekf::{Mekf, MekfConfig, MekfCounters, MekfError, UpdateReport, VectorMeasurements};
use nalgebra::Vector3;
use testbed_model::ModelConfig;

impl FilterParams for MekfConfig {
    fn validate(&self) -> Result<(), MekfError> {
        MekfConfig::validate(self)
    }
}

impl AttitudeFilter for Mekf {
    fn propagate(&mut self, t_ns: u64, w_meas_rad_s: &Vector3<f64>) -> Result<(), MekfError> {
        Mekf::propagate(self, t_ns, w_meas_rad_s)
    }

    fn update(
        &mut self,
        t_ns: u64,
        measurements: &VectorMeasurements,
    ) -> Result<UpdateReport, MekfError> {
        Mekf::update(self, t_ns, measurements)
    }

    fn estimate(&self) -> FilterEstimate {
        Mekf::estimate(self)
    }

    fn counters(&self) -> MekfCounters {
        Mekf::counters(self)
    }
}

impl FilterDefinition for Mekf {
    type Params = MekfConfig;

    fn default_params(model: &ModelConfig) -> MekfConfig {
        MekfConfig::from_model(model)
    }

    fn initialise(
        params: &MekfConfig,
        t_ns: u64,
        gravity_b: &Vector3<f64>,
        field_b_t: &Vector3<f64>,
    ) -> Result<Self, MekfError> {
        Mekf::initialise_from_vectors(params.clone(), t_ns, gravity_b, field_b_t)
    }
}
