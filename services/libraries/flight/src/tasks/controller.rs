//! The controller task: holds the target attitude (level frame to body frame) and turns an
//! attitude estimate and body rate (rad/s, body axes) into actuator commands (wheel torques in
//! N·m or CMG gimbal rates in rad/s), by PD + friction compensation on the reaction wheels or a
//! rate-limited slew through the four-CMG pyramid.

use crate::cmg_steering::{CmgSteering, CmgSteeringConfig, SlewConfig, SlewController};
use crate::control::{ControlError, WheelControlConfig, WheelController};
use crate::safe_mode::SafeModeConfig;
use crate::thruster_control::{ThrusterControlConfig, ThrusterLaw, ThrusterOutput, ThrusterUse};
use nalgebra::{Matrix3, Vector3, Vector4};
use serde::{Deserialize, Serialize};
use testbed_model::ModelConfig;
use testbed_model::attitude::Attitude;
use testbed_model::physics::ActuatorCommand;

/// Which actuators the controller drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Actuators {
    /// PD + friction compensation on the three reaction wheels.
    Wheels,
    /// Rate-limited eigenaxis slew through the four-CMG pyramid.
    Cmg,
}

/// Controller configuration: the law and its gains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerConfig {
    pub actuators: Actuators,
    pub wheels: WheelControlConfig,
    pub slew: SlewConfig,
    pub steering: CmgSteeringConfig,
    /// When the controller stops trusting its inputs and what it commands then.
    pub safe_mode: SafeModeConfig,
    /// Thruster control (issue 14); off unless present (needs the model's `[thrusters]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thrusters: Option<ThrusterControlConfig>,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self {
            actuators: Actuators::Wheels,
            wheels: WheelControlConfig::default(),
            slew: SlewConfig::default(),
            steering: CmgSteeringConfig::default(),
            safe_mode: SafeModeConfig::default(),
            thrusters: None,
        }
    }
}

/// What the controller measured of the actuators (from their telemetry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorTelemetry {
    /// Wheel speeds relative to the platform, rad/s.
    pub wheel_speed_rad_s: Vector3<f64>,
    /// Gimbal angles, rad.
    pub gimbal_rad: Vector4<f64>,
}

/// One control output.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlOutput {
    pub command: ActuatorCommand,
    /// Attitude error of the estimate relative to the target (rotation vector), rad, body axes.
    pub error_rad: Vector3<f64>,
    /// A torque, momentum or gimbal-rate limit changed the command.
    pub saturated: bool,
    /// CMG singularity measure (`None` with wheels).
    pub singularity_measure: Option<f64>,
}

// One law per controller, built once: the size difference between the variants (the CMG
// pyramid keeps its axes) costs nothing.
#[allow(clippy::large_enum_variant)]
enum Law {
    Wheels(WheelController),
    Cmg {
        slew: SlewController,
        steering: CmgSteering,
    },
}

/// The attitude controller: holds the target and turns an estimate into actuator commands.
pub struct ControllerTask {
    law: Law,
    target: Attitude,
    thrusters: Option<ThrusterLaw>,
    max_wheel_torque_nm: f64,
}

impl ControllerTask {
    pub fn new(
        config: &ControllerConfig,
        model: &ModelConfig,
        target: Attitude,
    ) -> Result<Self, ControlError> {
        config.safe_mode.validate()?;
        let law = match config.actuators {
            Actuators::Wheels => Law::Wheels(WheelController::new(&config.wheels, &model.wheels)?),
            Actuators::Cmg => {
                let inertia = nominal_inertia(model)?;
                Law::Cmg {
                    slew: SlewController::new(&config.slew, inertia)?,
                    steering: CmgSteering::new(&config.steering, &model.cmg)?,
                }
            }
        };
        let thrusters = match (&config.thrusters, &model.thrusters) {
            (None, _) => None,
            (Some(c), Some(t)) => {
                let inertia = nominal_inertia(model)?;
                Some(ThrusterLaw::new(
                    c,
                    t,
                    &model.wheels,
                    &inertia,
                    model.gyro.period_s(),
                )?)
            }
            (Some(_), None) => {
                return Err(ControlError::InvalidConfig {
                    key: "controller.thrusters".into(),
                    value: "present".into(),
                    reason: "the model has no [thrusters]".into(),
                });
            }
        };
        Ok(Self {
            law,
            target,
            thrusters,
            max_wheel_torque_nm: model.wheels.max_torque_nm,
        })
    }

    /// Whether the controller commands thrusters (`controller.thrusters` set).
    pub fn has_thruster_control(&self) -> bool {
        self.thrusters.is_some()
    }

    /// Safe mode with thrusters: the thrusters alone damp `rate_b` (rad/s, body axes; `None`:
    /// no rate known, valves shut). `None` without thruster control.
    pub fn thruster_rate_damping(
        &mut self,
        rate_b: Option<&Vector3<f64>>,
    ) -> Option<ThrusterOutput> {
        let law = self.thrusters.as_mut()?;
        Some(law.damp(rate_b))
    }

    /// The thrusters' command for this tick (`None` without thruster control), given the body
    /// rate (rad/s, body axes) and telemetry, adjusting `output`: momentum dumping feeds the
    /// thrusters' expected torque forward to the wheels; rate damping turns the wheels off.
    pub fn thrusters(
        &mut self,
        rate_b: &Vector3<f64>,
        telemetry: &ActuatorTelemetry,
        output: &mut ControlOutput,
    ) -> Option<ThrusterOutput> {
        let law = self.thrusters.as_mut()?;
        let out = law.step(rate_b, &telemetry.wheel_speed_rad_s);
        let t = self.max_wheel_torque_nm;
        match law.usage() {
            ThrusterUse::MomentumDumping => {
                output.command.wheel_torque_nm =
                    (output.command.wheel_torque_nm + out.expected_nm + out.disturbance_nm)
                        .map(|x| x.clamp(-t, t));
            }
            ThrusterUse::RateDamping => output.command.wheel_torque_nm = Vector3::zeros(),
        }
        Some(out)
    }

    pub fn target(&self) -> &Attitude {
        &self.target
    }

    pub fn set_target(&mut self, target: Attitude) {
        self.target = target;
    }

    /// Command for the estimated attitude `q_est` and body rate `rate_b` (rad/s) at `t_s`.
    pub fn command(
        &self,
        t_s: f64,
        q_est: &Attitude,
        rate_b: &Vector3<f64>,
        telemetry: &ActuatorTelemetry,
    ) -> Result<ControlOutput, ControlError> {
        match &self.law {
            Law::Wheels(controller) => {
                let c = controller.command(
                    q_est,
                    rate_b,
                    &self.target,
                    &telemetry.wheel_speed_rad_s,
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
            Law::Cmg { slew, steering } => {
                let s = slew.torque(q_est, rate_b, &self.target)?;
                let c = steering.steer(&s.torque_nm, &telemetry.gimbal_rad, rate_b, t_s)?;
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
        }
    }
}

/// The platform's nominal inertia, kg m² (body frame): the flight software knows it, never the
/// plant's true one.
fn nominal_inertia(model: &ModelConfig) -> Result<Matrix3<f64>, ControlError> {
    model
        .platform
        .inertia()
        .ok_or_else(|| ControlError::InvalidConfig {
            key: "platform.inertia_kgm2".into(),
            value: format!("{:?}", model.platform.inertia_kgm2),
            reason: "must be symmetric positive definite".into(),
        })
}
