//! The flight software's two jobs as small tasks with a clear lifecycle: the estimator and the
//! controller. The in-process closed loop wires them to the plant directly; the pipeline's
//! processes wrap the same tasks around iceoryx2 ports, so both run identical code.

use crate::cmg_steering::{CmgSteering, CmgSteeringConfig, SlewConfig, SlewController};
use crate::control::{ControlError, WheelControlConfig, WheelController};
use crate::mekf::{Mekf, MekfConfig, MekfError, MekfEstimate, UpdateReport, VectorMeasurements};
use nalgebra::{Vector3, Vector4};
use serde::{Deserialize, Serialize};
use testbed_model::attitude::{self, Attitude};
use testbed_model::physics::ActuatorCommand;
use testbed_model::ModelConfig;

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
        Self { config, mekf: None, last_gyro: None }
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
}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self {
            actuators: Actuators::Wheels,
            wheels: WheelControlConfig::default(),
            slew: SlewConfig::default(),
            steering: CmgSteeringConfig::default(),
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

enum Law {
    Wheels(WheelController),
    Cmg { slew: SlewController, steering: CmgSteering },
}

/// The attitude controller: holds the target and turns an estimate into actuator commands.
pub struct ControllerTask {
    law: Law,
    target: Attitude,
}

impl ControllerTask {
    pub fn new(config: &ControllerConfig, model: &ModelConfig, target: Attitude) -> Result<Self, ControlError> {
        let law = match config.actuators {
            Actuators::Wheels => Law::Wheels(WheelController::new(&config.wheels, &model.wheels)?),
            Actuators::Cmg => {
                // The controller knows the nominal inertia, never the plant's true one.
                let inertia = model.platform.inertia().ok_or_else(|| ControlError::InvalidConfig {
                    key: "platform.inertia_kgm2".into(),
                    value: format!("{:?}", model.platform.inertia_kgm2),
                    reason: "must be symmetric positive definite".into(),
                })?;
                Law::Cmg {
                    slew: SlewController::new(&config.slew, inertia)?,
                    steering: CmgSteering::new(&config.steering, &model.cmg)?,
                }
            }
        };
        Ok(Self { law, target })
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
                let c = controller.command(q_est, rate_b, &self.target, &telemetry.wheel_speed_rad_s)?;
                Ok(ControlOutput {
                    command: ActuatorCommand { wheel_torque_nm: c.motor_torque_nm, gimbal_rate_rad_s: Vector4::zeros() },
                    error_rad: c.error_rad,
                    saturated: c.saturated,
                    singularity_measure: None,
                })
            }
            Law::Cmg { slew, steering } => {
                let s = slew.torque(q_est, rate_b, &self.target)?;
                let c = steering.steer(&s.torque_nm, &telemetry.gimbal_rad, rate_b, t_s)?;
                Ok(ControlOutput {
                    command: ActuatorCommand { wheel_torque_nm: Vector3::zeros(), gimbal_rate_rad_s: c.gimbal_rate_rad_s },
                    error_rad: s.error_rad,
                    saturated: s.saturated || c.saturated,
                    singularity_measure: Some(c.singularity_measure),
                })
            }
        }
    }
}
