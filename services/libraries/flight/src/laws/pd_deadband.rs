//! `pd_deadband`: the worked example of `docs/control-laws.md` — a PD on the wheels that
//! leaves attitude errors inside a dead band alone (no proportional torque, so no wheel activity
//! from estimate noise), a common way to save actuator wear when the pointing requirement is
//! looser than the estimate's noise.
//!
//! Per body axis, with the attitude error `φ` (rad, [`crate::control::rotation_vector`] of the
//! error quaternion): `φ_db = sign(φ) max(|φ| − δ, 0)` (continuous: no torque step at the
//! band's edge), body torque `u = −K_p φ_db − K_d ω`, motor torque `τ_m = −u + T̂_f(n)`
//! ([`super::WheelDrive`]). The gains come from the model's inertia (diagonal `I_i`) and a
//! natural frequency and damping: `K_p = I ω_n²`, `K_d = 2 ζ ω_n I` (outside the band the loop
//! is `φ'' + 2 ζ ω_n φ' + ω_n² φ = 0`). Inside the band only the rate is damped, so the
//! platform stops anywhere in it: the steady error is at most `δ` per axis.

use super::{
    ControlLaw, ControlOutput, Drives, LawDefinition, LawInput, LawParams, WheelDrive,
    check_inputs, nominal_inertia, wheel_output,
};
use crate::control::{ControlError, check_positive, error_vector, invalid, rotation_vector};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use testbed_model::ModelConfig;

/// Parameters of the dead-band PD (`[controller.pd_deadband]`). Defaults (assumed): the paper's
/// PD's loop (`ω_n = 0.07 rad/s`, `ζ = 0.9`, [`crate::control`]) and a 0.01° band, half the
/// paper's 0.02° steady-error figure about X/Y (digest).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PdDeadbandConfig {
    /// `ω_n` outside the band, rad/s.
    pub natural_frequency_rad_s: f64,
    /// `ζ` outside the band, dimensionless.
    pub damping_ratio: f64,
    /// `δ`: half-width of the dead band per axis, rad.
    pub deadband_rad: f64,
}

impl Default for PdDeadbandConfig {
    fn default() -> Self {
        Self {
            natural_frequency_rad_s: 0.07,
            damping_ratio: 0.9,
            deadband_rad: 0.01_f64.to_radians(),
        }
    }
}

impl LawParams for PdDeadbandConfig {
    fn validate(&self) -> Result<(), ControlError> {
        check_positive("natural_frequency_rad_s", self.natural_frequency_rad_s)?;
        check_positive("damping_ratio", self.damping_ratio)?;
        if !(self.deadband_rad.is_finite() && self.deadband_rad >= 0.0) {
            return Err(invalid("deadband_rad", self.deadband_rad, "must be >= 0"));
        }
        Ok(())
    }
}

/// The error inside the dead band removed, per axis (rad).
pub fn deadband(error_rad: &Vector3<f64>, half_width_rad: f64) -> Vector3<f64> {
    error_rad.map(|e| e.signum() * (e.abs() - half_width_rad).max(0.0))
}

/// PD with a dead band on the wheels.
pub struct PdDeadband {
    config: PdDeadbandConfig,
    p_nm_per_rad: Vector3<f64>,
    d_nms: Vector3<f64>,
    drive: WheelDrive,
}

impl LawDefinition for PdDeadband {
    type Params = PdDeadbandConfig;

    fn build(params: &PdDeadbandConfig, model: &ModelConfig) -> Result<Self, ControlError> {
        let inertia = nominal_inertia(model)?.diagonal();
        let w = params.natural_frequency_rad_s;
        Ok(Self {
            config: params.clone(),
            p_nm_per_rad: inertia * (w * w),
            d_nms: inertia * (2.0 * params.damping_ratio * w),
            drive: WheelDrive::new(&model.wheels, true, 0.2)?,
        })
    }
}

impl ControlLaw for PdDeadband {
    fn drives(&self) -> Drives {
        Drives::WHEELS
    }

    fn command(&mut self, input: &LawInput<'_>) -> Result<ControlOutput, ControlError> {
        check_inputs(input)?;
        let error = rotation_vector(&error_vector(input.attitude, input.target));
        let outside = deadband(&error, self.config.deadband_rad);
        let u = -self.p_nm_per_rad.component_mul(&outside)
            - self.d_nms.component_mul(input.rate_b_rad_s);
        let (torque, saturated) = self
            .drive
            .motor_torque(&u, &input.telemetry.wheel_speed_rad_s);
        Ok(wheel_output(torque, error, saturated))
    }

    fn describe(&self) -> String {
        let c = &self.config;
        format!(
            "reaction-wheel PD with a ±{:.4}° dead band, ω_n {} rad/s, ζ {}",
            c.deadband_rad.to_degrees(),
            c.natural_frequency_rad_s,
            c.damping_ratio
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_removes_small_errors_and_is_continuous_at_its_edge() {
        let d = 1e-3;
        let e = Vector3::new(0.5e-3, -2e-3, 1e-3);
        let out = deadband(&e, d);
        assert_eq!(out, Vector3::new(0.0, -1e-3, 0.0));
        // Just outside the edge the output is just above zero: no step.
        assert!(deadband(&Vector3::new(d + 1e-12, 0.0, 0.0), d).x < 2e-12);
    }
}
