//! [`ModelConfig::validate`]: what no physical platform can have, refused with the key and the
//! value.

use super::{
    ConfigError, GYRO_BIAS_DRIFT_MAX_RAD_S2, GYRO_DELAY_MAX_S, ModelConfig, SENSOR_LAG_MAX_S,
};
use crate::devices::fitted_field::FieldFunction;
use crate::physics::fitted_torque::{TorqueFunction, axis_index};
use crate::physics::fitted_wheel_torque::WheelFunction;
use nalgebra::Matrix3;

impl ModelConfig {
    /// Refuse what no physical platform can have. Names the first offending key and value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let mut v = Validator::default();
        let p = &self.platform;
        for (i, row) in p.inertia_kgm2.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                v.finite(&format!("platform.inertia_kgm2[{i}][{j}]"), *x);
            }
        }
        v.inertia("platform.inertia_kgm2", &p.inertia_kgm2);
        v.positive("platform.mass_kg", p.mass_kg);
        v.positive("platform.gravity_mps2", p.gravity_mps2);
        v.within("platform.latitude_deg", p.latitude_deg, -90.0, 90.0);
        v.within("platform.tilt_limit_deg", p.tilt_limit_deg, 0.0, 90.0);
        v.finite_all("platform.field_l_gauss", &p.field_l_gauss);

        let g = &self.gyro;
        // The gyro rate is the loop's tick: from 1 Hz (slower, and a paced run waits seconds
        // per tick) to 1 kHz (the event loop's timers resolve milliseconds).
        v.within("gyro.rate_hz", g.rate_hz, 1.0, 1000.0);
        v.finite_all("gyro.bias_deg_s", &g.bias_deg_s);
        v.non_negative_all("gyro.noise_density_deg_sqrt_s", &g.noise_density_deg_sqrt_s);
        v.non_negative_all("gyro.bias_walk_deg_s32", &g.bias_walk_deg_s32);
        v.non_negative("gyro.resolution_deg_s", g.resolution_deg_s);
        v.positive("gyro.range_deg_s", g.range_deg_s);

        let n = &self.inclinometer;
        v.positive("inclinometer.rate_hz", n.rate_hz);
        v.non_negative_all("inclinometer.noise_deg", &n.noise_deg);
        v.within("inclinometer.range_deg", n.range_deg, 0.0, 90.0);

        let m = &self.magnetometer;
        v.positive("magnetometer.rate_hz", m.rate_hz);
        v.non_negative_all("magnetometer.noise_gauss", &m.noise_gauss);
        v.positive("magnetometer.range_gauss", m.range_gauss);

        let w = &self.wheels;
        v.positive("wheels.inertia_kgm2", w.inertia_kgm2);
        v.positive("wheels.max_torque_nm", w.max_torque_nm);
        v.positive("wheels.max_speed_rpm", w.max_speed_rpm);
        v.non_negative_all("wheels.coulomb_nm", &w.coulomb_nm);
        v.non_negative_all("wheels.viscous_nm_per_rad_s", &w.viscous_nm_per_rad_s);
        v.positive("wheels.telemetry_rate_hz", w.telemetry_rate_hz);
        v.non_negative("wheels.speed_noise_rpm", w.speed_noise_rpm);
        v.non_negative("wheels.speed_resolution_rpm", w.speed_resolution_rpm);

        let c = &self.cmg;
        v.positive("cmg.rotor_momentum_nms", c.rotor_momentum_nms);
        v.within("cmg.skew_deg", c.skew_deg, 0.0, 90.0);
        v.positive("cmg.max_gimbal_rate_deg_s", c.max_gimbal_rate_deg_s);
        v.non_negative("cmg.stepper_step_deg", c.stepper_step_deg);
        v.non_negative("cmg.encoder_resolution_deg", c.encoder_resolution_deg);
        v.positive("cmg.telemetry_rate_hz", c.telemetry_rate_hz);

        let e = &self.effects;
        if let Some(x) = &e.com_offset {
            v.finite_all("effects.com_offset.r_m", &x.r_m);
        }
        if let Some(x) = &e.earth_rate {
            v.within(
                "effects.earth_rate.latitude_deg",
                x.latitude_deg,
                -90.0,
                90.0,
            );
        }
        if let Some(x) = &e.aero_drag {
            v.non_negative_all("effects.aero_drag.c1", &x.c1);
            v.non_negative_all("effects.aero_drag.c2", &x.c2);
        }
        if let Some(x) = &e.constant_torque {
            v.finite_all("effects.constant_torque.torque_nm", &x.torque_nm);
        }
        if let Some(x) = &e.inertia_error {
            for (i, f) in x.fraction.iter().enumerate() {
                v.within(
                    &format!("effects.inertia_error.fraction[{i}]"),
                    *f,
                    -0.5,
                    0.5,
                );
            }
            if let Some(p) = &x.products_kgm2 {
                v.finite_all("effects.inertia_error.products_kgm2", p);
            }
            let nominal = self.platform.inertia();
            let truth = self.true_inertia();
            if nominal.is_some() && truth.is_none() {
                v.fail(
                    "effects.inertia_error.fraction",
                    format!("{:?}", x.fraction),
                    "makes the true inertia non-positive-definite",
                );
            }
        }
        if let Some(x) = &e.gyro_scale {
            v.finite_all("effects.gyro_scale.ppm", &x.ppm);
        }
        if let Some(x) = &e.gyro_misalignment {
            for (i, a) in x.angles_rad.iter().enumerate() {
                v.within(
                    &format!("effects.gyro_misalignment.angles_rad[{i}]"),
                    *a,
                    -0.1,
                    0.1,
                );
            }
        }
        if let Some(x) = &e.gyro_delay {
            v.within(
                "effects.gyro_delay.delay_s",
                x.delay_s,
                0.0,
                GYRO_DELAY_MAX_S,
            );
        }
        if let Some(x) = &e.gyro_bias_drift {
            for (i, r) in x.rate_rad_s2.iter().enumerate() {
                v.within(
                    &format!("effects.gyro_bias_drift.rate_rad_s2[{i}]"),
                    *r,
                    -GYRO_BIAS_DRIFT_MAX_RAD_S2,
                    GYRO_BIAS_DRIFT_MAX_RAD_S2,
                );
            }
        }
        if let Some(x) = &e.wheel_friction {
            v.non_negative_all("effects.wheel_friction.coulomb_pos_nm", &x.coulomb_pos_nm);
            v.non_negative_all("effects.wheel_friction.coulomb_neg_nm", &x.coulomb_neg_nm);
            v.non_negative_all(
                "effects.wheel_friction.viscous_nm_per_rad_s",
                &x.viscous_nm_per_rad_s,
            );
            v.non_negative_all("effects.wheel_friction.stribeck_nm", &x.stribeck_nm);
            v.positive_all(
                "effects.wheel_friction.stribeck_speed_rad_s",
                &x.stribeck_speed_rad_s,
            );
        }
        if let Some(x) = &e.wheel_torque_scale {
            v.positive_all("effects.wheel_torque_scale.scale", &x.scale);
        }
        if let Some(x) = &e.actuator_delay {
            v.within("effects.actuator_delay.delay_s", x.delay_s, 0.0, 10.0);
        }
        if let Some(x) = &e.magnetic_disturbance {
            v.finite_all(
                "effects.magnetic_disturbance.hard_iron_gauss",
                &x.hard_iron_gauss,
            );
        }
        if let Some(x) = &e.inclinometer_bias {
            for (i, b) in x.offset_rad.iter().enumerate() {
                // Beyond a few degrees it is not a mounting offset but a wrong axis convention.
                v.within(
                    &format!("effects.inclinometer_bias.offset_rad[{i}]"),
                    *b,
                    -0.1,
                    0.1,
                );
            }
        }
        for (key, lag) in [
            (
                "inclinometer_lag",
                e.inclinometer_lag.as_ref().map(|l| l.time_constant_s),
            ),
            (
                "magnetometer_lag",
                e.magnetometer_lag.as_ref().map(|l| l.time_constant_s),
            ),
        ] {
            if let Some(tau) = lag {
                let field = format!("effects.{key}.time_constant_s");
                v.within(&field, tau, 0.0, SENSOR_LAG_MAX_S);
            }
        }
        if let Some(x) = &e.inclinometer_scale {
            for (i, s) in x.ppm.iter().enumerate() {
                v.within(
                    &format!("effects.inclinometer_scale.ppm[{i}]"),
                    *s,
                    -1e5,
                    1e5,
                );
            }
        }
        if let Some(x) = &e.inclinometer_cross_axis {
            for (i, k) in x.coupling.iter().enumerate() {
                v.within(
                    &format!("effects.inclinometer_cross_axis.coupling[{i}]"),
                    *k,
                    -0.1,
                    0.1,
                );
            }
        }
        if let Some(x) = &e.com_drift {
            v.finite_all("effects.com_drift.rate_m_per_s", &x.rate_m_per_s);
        }
        if let Some(x) = &e.soft_iron {
            for (i, row) in x.matrix.iter().enumerate() {
                for (j, m) in row.iter().enumerate() {
                    v.within(
                        &format!("effects.soft_iron.matrix[{i}][{j}]"),
                        *m,
                        -0.5,
                        0.5,
                    );
                }
            }
            v.symmetric("effects.soft_iron.matrix", &x.matrix);
        }
        if let Some(x) = &e.field_heading_error {
            v.finite_all(
                "effects.field_heading_error.cos_2psi_gauss",
                &x.cos_2psi_gauss,
            );
            v.finite_all(
                "effects.field_heading_error.sin_2psi_gauss",
                &x.sin_2psi_gauss,
            );
        }
        if let Some(x) = &e.heading_torque {
            v.finite_all("effects.heading_torque.cos_nm", &x.cos_nm);
            v.finite_all("effects.heading_torque.sin_nm", &x.sin_nm);
        }
        if let Some(x) = &e.dipole_torque {
            v.finite_all("effects.dipole_torque.moment_am2", &x.moment_am2);
        }
        if let Some(x) = &e.wheel_drag {
            for (i, c) in x.quadratic_nm_per_rad2_s2.iter().enumerate() {
                v.within(
                    &format!("effects.wheel_drag.quadratic_nm_per_rad2_s2[{i}]"),
                    *c,
                    0.0,
                    1.0,
                );
            }
        }
        if let Some(x) = &e.gauss_markov_torque {
            for (i, r) in x.rms_nm.iter().enumerate() {
                v.within(
                    &format!("effects.gauss_markov_torque.rms_nm[{i}]"),
                    *r,
                    0.0,
                    1.0,
                );
            }
            v.within(
                "effects.gauss_markov_torque.correlation_time_s",
                x.correlation_time_s,
                0.1,
                1e4,
            );
        }
        if let Some(x) = &e.wheel_tilt_torque {
            v.finite_all("effects.wheel_tilt_torque.sin_tilt_x_nm", &x.sin_tilt_x_nm);
            v.finite_all("effects.wheel_tilt_torque.sin_tilt_y_nm", &x.sin_tilt_y_nm);
        }
        if let Some(x) = &e.thruster_torque_scale {
            v.positive_all("effects.thruster_torque_scale.scale", &x.scale);
        }
        if let Some(x) = &e.fitted_torque {
            v.finite("effects.fitted_torque.start_time_s", x.start_time_s);
            for (i, t) in x.terms.iter().enumerate() {
                v.fitted_term(
                    &format!("effects.fitted_torque.terms[{i}]"),
                    ("axis", &t.axis, "must be x, y or z"),
                    &t.function,
                    TorqueFunction::from_name(&t.function).is_some(),
                    TorqueFunction::ALL.iter().map(|f| f.name()),
                    t.coefficient,
                );
            }
        }
        if let Some(x) = &e.fitted_wheel_torque {
            v.finite("effects.fitted_wheel_torque.start_time_s", x.start_time_s);
            for (i, t) in x.terms.iter().enumerate() {
                v.fitted_term(
                    &format!("effects.fitted_wheel_torque.terms[{i}]"),
                    (
                        "wheel",
                        &t.wheel,
                        "must be x, y or z (the wheel's spin axis)",
                    ),
                    &t.function,
                    WheelFunction::from_name(&t.function).is_some(),
                    WheelFunction::ALL.iter().map(|f| f.name()),
                    t.coefficient,
                );
            }
        }
        if let Some(x) = &e.fitted_field {
            for (i, t) in x.terms.iter().enumerate() {
                v.fitted_term(
                    &format!("effects.fitted_field.terms[{i}]"),
                    ("axis", &t.axis, "must be x, y or z"),
                    &t.function,
                    FieldFunction::from_name(&t.function).is_some(),
                    FieldFunction::ALL.iter().map(|f| f.name()),
                    t.coefficient,
                );
            }
        }
        v.finish()?;
        match &self.thrusters {
            Some(t) => t.validate(),
            None => Ok(()),
        }
    }
}

/// Collects the first validation failure with its key and value.
#[derive(Default)]
struct Validator {
    first: Option<ConfigError>,
}

impl Validator {
    fn fail(&mut self, key: &str, value: String, reason: &str) {
        if self.first.is_none() {
            self.first = Some(ConfigError::Invalid {
                key: key.to_string(),
                value,
                reason: reason.to_string(),
            });
        }
    }
    /// A fitted term's function name: `found` says whether it names one of `known`.
    /// One term of a fitted effect at `key`: its axis (`(field, value, what it must be)`),
    /// its function among `names` (`known`: it is one of them) and a finite coefficient.
    fn fitted_term<'a>(
        &mut self,
        key: &str,
        (axis_field, axis, axis_rule): (&str, &str, &str),
        function: &str,
        known: bool,
        names: impl Iterator<Item = &'a str>,
        coefficient: f64,
    ) {
        if axis_index(axis).is_none() {
            self.fail(&format!("{key}.{axis_field}"), axis.to_owned(), axis_rule);
        }
        self.known_function(&format!("{key}.function"), function, known, names);
        self.finite(&format!("{key}.coefficient"), coefficient);
    }

    fn known_function<'a>(
        &mut self,
        key: &str,
        name: &str,
        found: bool,
        known: impl Iterator<Item = &'a str>,
    ) {
        if !found {
            let known: Vec<&str> = known.collect();
            self.fail(
                key,
                name.to_string(),
                &format!("unknown function; known: {}", known.join(", ")),
            );
        }
    }
    fn finite(&mut self, key: &str, x: f64) {
        if !x.is_finite() {
            self.fail(key, format!("{x}"), "must be a finite number");
        }
    }
    fn finite_all(&mut self, key: &str, xs: &[f64]) {
        for (i, x) in xs.iter().enumerate() {
            self.finite(&format!("{key}[{i}]"), *x);
        }
    }
    fn positive(&mut self, key: &str, x: f64) {
        if !(x.is_finite() && x > 0.0) {
            self.fail(key, format!("{x}"), "must be a finite number > 0");
        }
    }
    fn positive_all(&mut self, key: &str, xs: &[f64]) {
        for (i, x) in xs.iter().enumerate() {
            self.positive(&format!("{key}[{i}]"), *x);
        }
    }
    fn non_negative(&mut self, key: &str, x: f64) {
        if !(x.is_finite() && x >= 0.0) {
            self.fail(key, format!("{x}"), "must be a finite number >= 0");
        }
    }
    fn non_negative_all(&mut self, key: &str, xs: &[f64]) {
        for (i, x) in xs.iter().enumerate() {
            self.non_negative(&format!("{key}[{i}]"), *x);
        }
    }
    fn within(&mut self, key: &str, x: f64, lo: f64, hi: f64) {
        if !(x.is_finite() && x >= lo && x <= hi) {
            self.fail(key, format!("{x}"), &format!("must be within [{lo}, {hi}]"));
        }
    }
    /// Each entry equal to its transpose's, to rounding (`1e-12` absolute: the matrix is
    /// dimensionless and of order 0.01–0.5).
    fn symmetric(&mut self, key: &str, rows: &[[f64; 3]; 3]) {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let (a, b) = (rows[i][j], rows[j][i]);
            if (a - b).abs() > 1e-12 {
                self.fail(
                    &format!("{key}[{i}][{j}]"),
                    format!("{a} (its transpose [{j}][{i}] is {b})"),
                    "must be symmetric",
                );
            }
        }
    }
    fn inertia(&mut self, key: &str, rows: &[[f64; 3]; 3]) {
        let m = Matrix3::from_fn(|i, j| rows[i][j]);
        if !m.iter().all(|x| x.is_finite()) {
            return; // already reported element-wise
        }
        let value = format!("{rows:?}");
        let scale = m.abs().max().max(f64::MIN_POSITIVE);
        if (m - m.transpose()).abs().max() > 1e-9 * scale {
            self.fail(key, value, "must be symmetric");
        } else if m.cholesky().is_none() {
            self.fail(
                key,
                value,
                "must be positive definite (all principal moments > 0)",
            );
        }
    }
    fn finish(self) -> Result<(), ConfigError> {
        self.first.map_or(Ok(()), Err)
    }
}
