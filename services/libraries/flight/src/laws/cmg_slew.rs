//! `cmg_slew`: the rate-limited eigenaxis slew through the four-CMG pyramid with
//! singularity-robust steering (maths and defaults in [`crate::cmg_steering`]). Parameters:
//! `[controller.cmg_slew]` with the sub-tables `slew` ([`SlewConfig`]) and `steering`
//! ([`CmgSteeringConfig`]).

use super::{
    ControlLaw, ControlOutput, Drives, LawDefinition, LawInput, LawParams, nominal_inertia,
};
use crate::cmg_steering::{CmgSteering, CmgSteeringConfig, SlewConfig, SlewController};
use crate::control::ControlError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use testbed_model::ModelConfig;
use testbed_model::physics::ActuatorCommand;

/// Parameters of the CMG slew.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CmgSlewConfig {
    /// Gains and limits of the eigenaxis slew (torque demand).
    pub slew: SlewConfig,
    /// The steering law that turns the torque demand into gimbal rates.
    pub steering: CmgSteeringConfig,
}

impl LawParams for CmgSlewConfig {
    fn validate(&self) -> Result<(), ControlError> {
        self.slew.validate()?;
        self.steering.validate()
    }
}

/// Eigenaxis slew on the CMG pyramid.
pub struct CmgSlew {
    slew: SlewController,
    steering: CmgSteering,
}

impl LawDefinition for CmgSlew {
    type Params = CmgSlewConfig;

    fn build(params: &CmgSlewConfig, model: &ModelConfig) -> Result<Self, ControlError> {
        Ok(Self {
            slew: SlewController::new(&params.slew, nominal_inertia(model)?)?,
            steering: CmgSteering::new(&params.steering, &model.cmg)?,
        })
    }
}

impl ControlLaw for CmgSlew {
    fn drives(&self) -> Drives {
        Drives::CMGS
    }

    fn command(&mut self, input: &LawInput<'_>) -> Result<ControlOutput, ControlError> {
        let s = self
            .slew
            .torque(input.attitude, input.rate_b_rad_s, input.target)?;
        let c = self.steering.steer(
            &s.torque_nm,
            &input.telemetry.gimbal_rad,
            input.rate_b_rad_s,
            input.t_s,
        )?;
        Ok(ControlOutput {
            command: ActuatorCommand {
                wheel_torque_nm: Vector3::zeros(),
                gimbal_rate_rad_s: c.gimbal_rate_rad_s,
            },
            error_rad: s.error_rad,
            saturated: s.saturated || c.saturated,
            singularity_measure: Some(c.singularity_measure),
        })
    }

    fn describe(&self) -> String {
        let c = self.slew.config();
        format!(
            "four-CMG pyramid, rate-limited eigenaxis slew (k_a {} 1/s, k_r {} 1/s, ω_max {} rad/s, u_max {} Nm)",
            c.attitude_gain_per_s, c.rate_gain_per_s, c.max_rate_rad_s, c.max_torque_nm
        )
    }
}
