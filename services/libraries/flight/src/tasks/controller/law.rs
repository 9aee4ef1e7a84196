//! The law as the controller runs it: the configured [`ControlLaw`] (chosen by name,
//! [`crate::laws`]) with the target it points at (level frame to body frame), the actuators'
//! limits enforced after it, and thruster control ([`crate::thruster_control`]) beside it.
//! Safe mode, ground commands and timing are the task's ([`super::ControllerTask`]); the
//! in-process closed loop calls this guard directly, so no law reaches an actuator unguarded.

use super::ControllerConfig;
use crate::control::ControlError;
use crate::laws::{ActuatorTelemetry, ControlLaw, ControlOutput, Drives, LawInput};
use crate::thruster_control::{ThrusterLaw, ThrusterOutput, ThrusterUse};
use nalgebra::{Vector3, Vector4};
use testbed_model::ModelConfig;
use testbed_model::attitude::Attitude;

/// The actuators' limits the guard enforces on every law's command.
#[derive(Debug, Clone, Copy)]
struct ActuatorLimits {
    /// Wheel motor torque, N·m.
    max_wheel_torque_nm: f64,
    /// Wheel rotor inertia, kg m².
    wheel_inertia_kgm2: f64,
    /// Wheel speed relative to the platform, rad/s.
    max_wheel_speed_rad_s: f64,
    /// The control period over which a command is held, s.
    period_s: f64,
    /// Gimbal rate, rad/s.
    max_gimbal_rate_rad_s: f64,
}

impl ActuatorLimits {
    /// `output`'s command within the limits (a command for an actuator the law does not drive
    /// is zeroed); `saturated` set when a limit changed it. Each wheel's torque is clipped to
    /// its torque limit and to `J (±n_max − n) / T`, which keeps the wheel inside its speed
    /// limit over one period (friction only brakes it): the same bounds the paper's law
    /// applies itself, so for it this changes nothing.
    fn enforce(
        &self,
        drives: Drives,
        wheel_speed_rad_s: &Vector3<f64>,
        output: &mut ControlOutput,
    ) {
        let command = &mut output.command;
        if !drives.wheels {
            command.wheel_torque_nm = Vector3::zeros();
        }
        if !drives.cmgs {
            command.gimbal_rate_rad_s = Vector4::zeros();
        }
        let (j, n_max, period, t_max) = (
            self.wheel_inertia_kgm2,
            self.max_wheel_speed_rad_s,
            self.period_s,
            self.max_wheel_torque_nm,
        );
        for i in 0..3 {
            let n = wheel_speed_rad_s[i];
            let hi = j * (n_max - n) / period;
            let lo = j * (-n_max - n) / period;
            let torque = command.wheel_torque_nm[i];
            let limited = torque.min(hi).max(lo).clamp(-t_max, t_max);
            if limited != torque {
                output.saturated = true;
                command.wheel_torque_nm[i] = limited;
            }
        }
        let g_max = self.max_gimbal_rate_rad_s;
        for rate in command.gimbal_rate_rad_s.iter_mut() {
            let limited = rate.clamp(-g_max, g_max);
            if limited != *rate {
                output.saturated = true;
                *rate = limited;
            }
        }
    }
}

/// The configured control law inside the controller's limits, holding the target.
pub struct GuardedLaw {
    law: Box<dyn ControlLaw>,
    target: Attitude,
    thrusters: Option<ThrusterLaw>,
    limits: ActuatorLimits,
}

impl GuardedLaw {
    /// Built by [`ControllerConfig::law`], which checks the rest of the configuration first.
    pub(super) fn new(
        config: &ControllerConfig,
        model: &ModelConfig,
        target: Attitude,
    ) -> Result<Self, ControlError> {
        let law = config.build_law(model)?;
        let thrusters = match (&config.thrusters, &model.thrusters) {
            (None, _) => None,
            (Some(c), Some(t)) => {
                let inertia = crate::laws::nominal_inertia(model)?;
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
        let period_s = model.gyro.period_s();
        crate::control::check_positive("gyro period (control period)", period_s)?;
        Ok(Self {
            law,
            target,
            thrusters,
            limits: ActuatorLimits {
                max_wheel_torque_nm: model.wheels.max_torque_nm,
                wheel_inertia_kgm2: model.wheels.inertia_kgm2,
                max_wheel_speed_rad_s: model.wheels.max_speed_rad_s(),
                period_s,
                max_gimbal_rate_rad_s: model.cmg.max_gimbal_rate_rad_s(),
            },
        })
    }

    /// The actuators the law drives.
    pub fn drives(&self) -> Drives {
        self.law.drives()
    }

    /// The law and its gains in one line.
    pub fn describe(&self) -> String {
        self.law.describe()
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
        let t = self.limits.max_wheel_torque_nm;
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

    /// Command for the estimated attitude `q_est` and body rate `rate_b` (rad/s) at `t_s`: the
    /// law's, within the actuators' limits. A law's non-finite command is refused.
    pub fn command(
        &mut self,
        t_s: f64,
        q_est: &Attitude,
        rate_b: &Vector3<f64>,
        telemetry: &ActuatorTelemetry,
    ) -> Result<ControlOutput, ControlError> {
        let input = LawInput {
            t_s,
            attitude: q_est,
            rate_b_rad_s: rate_b,
            target: &self.target,
            telemetry,
        };
        let mut output = self.law.command(&input)?;
        let c = &output.command;
        if !c
            .wheel_torque_nm
            .iter()
            .chain(c.gimbal_rate_rad_s.iter())
            .all(|x| x.is_finite())
        {
            return Err(ControlError::NonFiniteInput("the law's command"));
        }
        self.limits
            .enforce(self.law.drives(), &telemetry.wheel_speed_rad_s, &mut output);
        Ok(output)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::physics::ActuatorCommand;

    fn limits() -> ActuatorLimits {
        let model = ModelConfig::default();
        ActuatorLimits {
            max_wheel_torque_nm: model.wheels.max_torque_nm,
            wheel_inertia_kgm2: model.wheels.inertia_kgm2,
            max_wheel_speed_rad_s: model.wheels.max_speed_rad_s(),
            period_s: model.gyro.period_s(),
            max_gimbal_rate_rad_s: model.cmg.max_gimbal_rate_rad_s(),
        }
    }

    fn output(wheels: [f64; 3], gimbals: [f64; 4]) -> ControlOutput {
        ControlOutput {
            command: ActuatorCommand {
                wheel_torque_nm: Vector3::from(wheels),
                gimbal_rate_rad_s: Vector4::from(gimbals),
            },
            error_rad: Vector3::zeros(),
            saturated: false,
            singularity_measure: None,
        }
    }

    #[test]
    fn a_law_cannot_exceed_the_torque_speed_or_gimbal_rate_limits_nor_drive_others() {
        let l = limits();
        let mut o = output([5.0, -0.05, 0.05], [9.0, 0.0, 0.0, 0.0]);
        // Wheel z at its speed limit: it may not be pushed further.
        let speeds = Vector3::new(0.0, 0.0, l.max_wheel_speed_rad_s);
        l.enforce(
            Drives {
                wheels: true,
                cmgs: true,
            },
            &speeds,
            &mut o,
        );
        assert!(o.saturated);
        assert_eq!(
            o.command.wheel_torque_nm,
            Vector3::new(l.max_wheel_torque_nm, -0.05, 0.0)
        );
        assert_eq!(o.command.gimbal_rate_rad_s[0], l.max_gimbal_rate_rad_s);
        let mut o = output([0.01, 0.0, 0.0], [0.1, 0.0, 0.0, 0.0]);
        l.enforce(Drives::WHEELS, &Vector3::zeros(), &mut o);
        assert!(!o.saturated);
        assert_eq!(o.command.gimbal_rate_rad_s, Vector4::zeros());
        assert_eq!(o.command.wheel_torque_nm.x, 0.01);
    }
}
