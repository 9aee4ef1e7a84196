//! `eigenaxis_slew`: saturated quaternion feedback on the reaction wheels for large manoeuvres
//! (Wie, Weiss & Arapostathis 1989, "Quaternion feedback regulator for spacecraft eigenaxis
//! rotations", J. Guidance 12(3); the rate-limited form of Wie, Bailey & Heiberg 2002,
//! "Rapid multitarget acquisition and pointing control of agile spacecraft", J. Guidance 25(1)).
//!
//! # Law
//!
//! With `q_v` the error quaternion's vector part ([`crate::control::error_vector`], `|q_v| =
//! sin(θ/2)` for an error angle θ), `ω` the body rate, `I` the nominal inertia and `h` the
//! wheels' momentum (body axes):
//!
//! `u = −I (k sat_L(q_v) + c ω) + ω × (I ω + h)`,
//!
//! `sat_L(v) = v · min(1, L / |v|)` (vector saturation: the direction is kept), `L = c ω_max / k`.
//! Both gains are multiplied by the inertia and the gyroscopic torque is cancelled, so the body
//! obeys `ω' = −k sat_L(q_v) − c ω` in body axes: from rest the rate stays along the error's
//! eigenaxis, whatever the inertia's products (Wie et al.'s eigenaxis condition). While `|q_v| >
//! L` the rate tends to `k L / c = ω_max` about the eigenaxis; once `|q_v| < L` the loop is the
//! linear `θ'' + c θ' + (k/2) θ = 0` (small angles), `ω_n = sqrt(k/2)`, `ζ = c / (2 ω_n)`.
//! The wheel command is `τ_m = −u + T̂_f(n)` (the paper's friction compensation), `u` scaled
//! down, direction kept, to the wheels' torque limit.
//!
//! # Rest-to-rest slew time (closed form)
//!
//! From rest with error `θ0 > θ_L = 2 asin L`, the saturated phase gives the rate
//! `ω(t) = ω_max (1 − e^{−c t})` about the eigenaxis and the remaining angle
//! `θ(t) = θ0 − ω_max (t − (1 − e^{−c t}) / c)`; it ends at the `t1` where `θ(t1) = θ_L`
//! ([`saturated_phase_s`]). After it, the linear phase converges with the slow pole
//! `p = c/2 − sqrt(c²/4 − k/2)` (ζ ≥ 1) or `c/2` (ζ < 1).
//!
//! # Defaults
//!
//! `ω_n = 0.07 rad/s`, `ζ = 0.9` (the paper's PD's loop, [`crate::control`]): `k = 2 ω_n² =
//! 0.0098 1/s²`, `c = 2 ζ ω_n = 0.126 1/s`. `ω_max = 0.5 °/s = 8.73e-3 rad/s`: about Z the
//! platform then holds `62.7 · 8.73e-3 = 0.55 N m s`, inside a wheel's 1 N m s (digest), and
//! the initial torque `I_z c ω_max = 0.069 N m` is inside the 0.1 N m limit, so the slew is not
//! torque-limited about any body axis. `L = c ω_max / k = 0.112`: errors above 12.9° slew at
//! `ω_max`.

use super::{
    ControlLaw, ControlOutput, Drives, LawDefinition, LawInput, LawParams, WheelDrive,
    check_inputs, nominal_inertia, wheel_output,
};
use crate::control::{ControlError, check_positive, error_vector, rotation_vector};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use testbed_model::ModelConfig;

/// Parameters of the eigenaxis slew (`[controller.eigenaxis_slew]`); defaults in the module
/// documentation (assumed, chosen from the digest's wheel limits and inertia).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EigenaxisSlewConfig {
    /// `k`: attitude gain per unit of `q_v`, 1/s² (times the inertia: N m).
    pub attitude_gain_per_s2: f64,
    /// `c`: rate gain, 1/s (times the inertia: N m s).
    pub rate_gain_per_s: f64,
    /// `ω_max`: slew rate limit about the eigenaxis, rad/s.
    pub max_rate_rad_s: f64,
    /// Compensate the wheels' friction (the paper's `− T_f(n)` term).
    pub friction_compensation: bool,
    /// `n_s` of the smooth sign in the friction compensation, rad/s ([`crate::control`]).
    pub friction_speed_scale_rad_s: f64,
}

impl Default for EigenaxisSlewConfig {
    fn default() -> Self {
        let (natural_frequency_rad_s, damping_ratio) = (0.07, 0.9);
        Self {
            attitude_gain_per_s2: 2.0 * natural_frequency_rad_s * natural_frequency_rad_s,
            rate_gain_per_s: 2.0 * damping_ratio * natural_frequency_rad_s,
            max_rate_rad_s: 0.5_f64.to_radians(),
            friction_compensation: true,
            friction_speed_scale_rad_s: 0.2,
        }
    }
}

impl LawParams for EigenaxisSlewConfig {
    fn validate(&self) -> Result<(), ControlError> {
        check_positive("attitude_gain_per_s2", self.attitude_gain_per_s2)?;
        check_positive("rate_gain_per_s", self.rate_gain_per_s)?;
        check_positive("max_rate_rad_s", self.max_rate_rad_s)?;
        check_positive(
            "friction_speed_scale_rad_s",
            self.friction_speed_scale_rad_s,
        )
    }
}

impl EigenaxisSlewConfig {
    /// The saturation bound `L = c ω_max / k` on `|q_v|` (dimensionless).
    pub fn saturation_bound(&self) -> f64 {
        self.rate_gain_per_s * self.max_rate_rad_s / self.attitude_gain_per_s2
    }
}

/// The saturated eigenaxis slew on the wheels.
pub struct EigenaxisSlew {
    config: EigenaxisSlewConfig,
    inertia: Matrix3<f64>,
    wheel_inertia_kgm2: f64,
    drive: WheelDrive,
}

impl LawDefinition for EigenaxisSlew {
    type Params = EigenaxisSlewConfig;

    fn build(params: &EigenaxisSlewConfig, model: &ModelConfig) -> Result<Self, ControlError> {
        check_positive("wheels.inertia_kgm2", model.wheels.inertia_kgm2)?;
        Ok(Self {
            config: params.clone(),
            inertia: nominal_inertia(model)?,
            wheel_inertia_kgm2: model.wheels.inertia_kgm2,
            drive: WheelDrive::new(
                &model.wheels,
                params.friction_compensation,
                params.friction_speed_scale_rad_s,
            )?,
        })
    }
}

impl EigenaxisSlew {
    /// The body torque `u` (N m, body axes) of the law for error vector part `q_v`, body rate
    /// `rate_b` (rad/s) and wheel momentum `h` (N m s, body axes).
    pub fn body_torque(
        &self,
        q_v: &Vector3<f64>,
        rate_b: &Vector3<f64>,
        wheel_momentum_nms: &Vector3<f64>,
    ) -> Vector3<f64> {
        let c = &self.config;
        let bound = c.saturation_bound();
        let n = q_v.norm();
        let saturated_q = if n > bound { q_v * (bound / n) } else { *q_v };
        -self.inertia * (saturated_q * c.attitude_gain_per_s2 + rate_b * c.rate_gain_per_s)
            + rate_b.cross(&(self.inertia * rate_b + wheel_momentum_nms))
    }
}

impl ControlLaw for EigenaxisSlew {
    fn drives(&self) -> Drives {
        Drives::WHEELS
    }

    fn command(&mut self, input: &LawInput<'_>) -> Result<ControlOutput, ControlError> {
        check_inputs(input)?;
        let q_v = error_vector(input.attitude, input.target);
        let speeds = &input.telemetry.wheel_speed_rad_s;
        let u = self.body_torque(
            &q_v,
            input.rate_b_rad_s,
            &(speeds * self.wheel_inertia_kgm2),
        );
        let (torque, saturated) = self.drive.motor_torque(&u, speeds);
        Ok(wheel_output(torque, rotation_vector(&q_v), saturated))
    }

    fn describe(&self) -> String {
        let c = &self.config;
        format!(
            "saturated eigenaxis slew on the wheels (Wie 1989), k {} 1/s², c {} 1/s, ω_max {:.3} °/s, friction compensation {}",
            c.attitude_gain_per_s2,
            c.rate_gain_per_s,
            c.max_rate_rad_s.to_degrees(),
            if c.friction_compensation { "on" } else { "off" }
        )
    }
}

/// Duration (s) of the saturated phase of a rest-to-rest slew by `angle_rad` (see the module
/// documentation): the root `t1` of `ω_max (t − (1 − e^{−c t}) / c) = θ0 − θ_L`, by Newton's
/// method from the coasting asymptote (the left side is convex and increasing, so Newton from
/// above converges monotonically). Zero when the slew starts unsaturated.
pub fn saturated_phase_s(config: &EigenaxisSlewConfig, angle_rad: f64) -> f64 {
    let bound = config.saturation_bound();
    if bound >= 1.0 {
        return 0.0;
    }
    let to_go = angle_rad.abs() - 2.0 * bound.asin();
    if to_go <= 0.0 {
        return 0.0;
    }
    let (w, c) = (config.max_rate_rad_s, config.rate_gain_per_s);
    let mut t = to_go / w + 1.0 / c;
    for _ in 0..100 {
        let f = w * (t - (1.0 - (-c * t).exp()) / c) - to_go;
        let step = f / (w * (1.0 - (-c * t).exp()));
        t -= step;
        if step.abs() < 1e-12 * t.max(1.0) {
            break;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::laws::ActuatorTelemetry;
    use nalgebra::Vector4;
    use testbed_model::attitude::{self, Attitude};
    use testbed_model::config::DEG;
    use testbed_model::physics::{ActuatorCommand, Plant, PlatformState};

    struct Slew {
        /// Time the error first fell below the saturation angle `θ_L`, s.
        exit_s: Option<f64>,
        /// Largest angle between the rotation done so far and the eigenaxis, rad.
        off_axis_rad: f64,
        /// Largest body rate, rad/s.
        peak_rate_rad_s: f64,
        /// Final error angle, rad.
        final_error_rad: f64,
    }

    /// A rest-to-rest slew by `angle` about `axis` (body axes at the start) on the shared plant
    /// (full inertia with products, wheels with friction and stiction), truth feedback at the
    /// 10 Hz control rate.
    fn slew(axis: Vector3<f64>, angle: f64, duration_s: f64) -> Slew {
        let model = ModelConfig::default();
        let config = EigenaxisSlewConfig::default();
        let mut law = EigenaxisSlew::build(&config, &model).unwrap();
        let target = Attitude::identity();
        let axis = axis.normalize();
        let start = attitude::apply_error(&target, &(axis * angle));
        let mut plant = Plant::new(
            &model,
            PlatformState {
                q: start,
                ..PlatformState::default()
            },
        )
        .unwrap();
        let theta_l = 2.0 * config.saturation_bound().asin();
        let dt = model.gyro.period_s();
        let mut out = Slew {
            exit_s: None,
            off_axis_rad: 0.0,
            peak_rate_rad_s: 0.0,
            final_error_rad: 0.0,
        };
        for k in 0..(duration_s / dt).round() as usize {
            let s = plant.state().clone();
            let error = attitude::attitude_error(&s.q, &target);
            // The rotation done so far, in the start's body axes: along the eigenaxis −axis.
            let done = attitude::attitude_error(&s.q, &start);
            if done.norm() > 1.0 * DEG && error.norm() > theta_l {
                let cos = (-done.normalize()).dot(&axis).clamp(-1.0, 1.0);
                out.off_axis_rad = out.off_axis_rad.max(cos.acos());
            }
            if out.exit_s.is_none() && error.norm() < theta_l {
                out.exit_s = Some(k as f64 * dt);
            }
            out.peak_rate_rad_s = out.peak_rate_rad_s.max(s.rate_b.norm());
            out.final_error_rad = error.norm();
            let telemetry = ActuatorTelemetry {
                wheel_speed_rad_s: s.wheel_speed,
                gimbal_rad: Vector4::zeros(),
            };
            let o = law
                .command(&LawInput {
                    t_s: k as f64 * dt,
                    attitude: &s.q,
                    rate_b_rad_s: &s.rate_b,
                    target: &target,
                    telemetry: &telemetry,
                })
                .unwrap();
            let command = ActuatorCommand {
                wheel_torque_nm: o.command.wheel_torque_nm,
                gimbal_rate_rad_s: Vector4::zeros(),
            };
            plant.step(&command, dt).unwrap();
        }
        out
    }

    #[test]
    fn a_large_slew_stays_on_the_eigenaxis_at_the_rate_limit_and_takes_the_closed_form_time() {
        // 60° about an axis mostly vertical (the bearing's tilt stops are at ±30°): 10° tilt.
        let axis = Vector3::new(0.16, -0.12, 1.0);
        let angle = 60.0 * DEG;
        let config = EigenaxisSlewConfig::default();
        let r = slew(axis, angle, 250.0);
        let t1 = saturated_phase_s(&config, angle);
        eprintln!(
            "eigenaxis slew 60°: exit of saturation {:?} s (closed form {t1:.2} s), off axis {:.2e} rad, peak rate {:.4e} rad/s (limit {:.4e}), final error {:.2e} rad",
            r.exit_s, r.off_axis_rad, r.peak_rate_rad_s, config.max_rate_rad_s, r.final_error_rad
        );
        // The rate saturates at ω_max: it approaches it within e^{−c t1} (< 1e-3 here) and does
        // not exceed it by more than 0.5 %.
        let approach = (-config.rate_gain_per_s * t1).exp();
        assert!(approach < 1e-3);
        assert!(
            (r.peak_rate_rad_s / config.max_rate_rad_s - 1.0).abs() < 5e-3,
            "{}",
            r.peak_rate_rad_s
        );
        // Eigenaxis: the rotation done stays within 2 mrad of the axis (1.1 mrad measured; the
        // wheels' friction residual near zero speed and the 10 Hz hold move it).
        assert!(r.off_axis_rad < 2e-3, "{}", r.off_axis_rad);
        // The saturated phase ends at the closed-form time, within two control periods.
        let exit = r.exit_s.unwrap();
        assert!((exit - t1).abs() < 0.2, "exit {exit} s, closed form {t1} s");
        // And the slew ends at the target: within the paper's steady-error figure about Z
        // (0.05°, digest) 150 s after the saturated phase.
        assert!(r.final_error_rad < 0.05 * DEG, "{}", r.final_error_rad);
    }

    #[test]
    fn the_saturated_phase_time_solves_its_equation() {
        let c = EigenaxisSlewConfig::default();
        for angle_deg in [20.0_f64, 60.0, 120.0] {
            let t = saturated_phase_s(&c, angle_deg * DEG);
            let (w, k) = (c.max_rate_rad_s, c.rate_gain_per_s);
            let covered = w * (t - (1.0 - (-k * t).exp()) / k);
            let to_go = angle_deg * DEG - 2.0 * c.saturation_bound().asin();
            assert!(
                (covered - to_go).abs() < 1e-12,
                "{angle_deg}: {covered} {to_go}"
            );
        }
        assert_eq!(saturated_phase_s(&c, 5.0 * DEG), 0.0);
    }

    #[test]
    fn the_body_equation_is_the_eigenaxis_one_whatever_the_products_of_inertia() {
        // I ω' = u − ω × (I ω + h) = −I (k sat(q_v) + c ω): ω' along −(k sat(q_v) + c ω).
        let model = ModelConfig::default();
        let config = EigenaxisSlewConfig::default();
        let law = EigenaxisSlew::build(&config, &model).unwrap();
        let q_v = Vector3::new(0.1, -0.3, 0.4);
        let rate = Vector3::new(1e-3, -2e-3, 5e-3);
        let h = Vector3::new(0.1, 0.2, -0.3);
        let u = law.body_torque(&q_v, &rate, &h);
        let inertia = nominal_inertia(&model).unwrap();
        let rate_dot = inertia
            .lu()
            .solve(&(u - rate.cross(&(inertia * rate + h))))
            .unwrap();
        let bound = config.saturation_bound();
        let expected = -(q_v * (bound / q_v.norm()) * config.attitude_gain_per_s2
            + rate * config.rate_gain_per_s);
        assert!((rate_dot - expected).norm() < 1e-12 * expected.norm());
    }
}
