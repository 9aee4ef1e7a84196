//! `pd_friction`: the paper's law, PD on the error quaternion with wheel friction compensation,
//! `u = −P q_v − D ω − T_f(n)` on the three reaction wheels (maths and default gains in
//! [`crate::control`]). Parameters: `[controller.pd_friction]`, [`PdFrictionConfig`].

use super::{ControlLaw, ControlOutput, Drives, LawDefinition, LawInput, LawParams};
use crate::control::{ControlError, WheelController};
use nalgebra::Vector4;
use testbed_model::ModelConfig;
use testbed_model::physics::ActuatorCommand;

pub use crate::control::PdFrictionConfig;

impl LawParams for PdFrictionConfig {
    fn validate(&self) -> Result<(), ControlError> {
        PdFrictionConfig::validate(self)
    }
}

/// The paper's PD + friction compensation on the wheels.
pub struct PdFriction {
    controller: WheelController,
}

impl LawDefinition for PdFriction {
    type Params = PdFrictionConfig;

    fn build(params: &PdFrictionConfig, model: &ModelConfig) -> Result<Self, ControlError> {
        Ok(Self {
            controller: WheelController::new(params, &model.wheels)?,
        })
    }
}

impl ControlLaw for PdFriction {
    fn drives(&self) -> Drives {
        Drives::WHEELS
    }

    fn command(&mut self, input: &LawInput<'_>) -> Result<ControlOutput, ControlError> {
        let c = self.controller.command(
            input.attitude,
            input.rate_b_rad_s,
            input.target,
            &input.telemetry.wheel_speed_rad_s,
        )?;
        Ok(ControlOutput {
            command: ActuatorCommand {
                wheel_torque_nm: c.motor_torque_nm,
                gimbal_rate_rad_s: Vector4::zeros(),
            },
            error_rad: c.error_rad,
            saturated: c.saturated,
            singularity_measure: None,
        })
    }

    fn describe(&self) -> String {
        let c = self.controller.config();
        format!(
            "reaction-wheel PD, P {:?} Nm per unit q_v, D {:?} Nm s, friction compensation {}, period {} s",
            c.p_nm.map(|x| (x * 1000.0).round() / 1000.0),
            c.d_nms.map(|x| (x * 1000.0).round() / 1000.0),
            if c.friction_compensation { "on" } else { "off" },
            c.control_period_s
        )
    }
}
