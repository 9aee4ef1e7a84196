//! A torque between a wheel and the platform fitted to data: what `testbed identify` reports as
//! an **unexplained effect** in the wheel channel (`wheel_y ≈ −1.0e-8 Nm × n·|n|`), carried
//! into the model so the plant reproduces it. Off unless `[effects.fitted_wheel_torque]` is
//! configured.
//!
//! The torque on wheel `i` is `T_i = Σ c_{i,j} f_j`, a sum of the functions of
//! [`WheelFunction`] (identification's wheel candidates) with coefficients `c_{i,j}` in Nm per
//! unit of the function, positive accelerating the wheel in its positive sense; the platform
//! takes the reaction ([`super::dynamics`] adds it to the wheel's net torque beside the motor
//! and friction while the wheel slides; as for `wheel_tilt_torque`, a stuck wheel's holding
//! torque, checked against breakaway, leaves it out). The
//! functions' time is the record's time from its start, s: `t = start_time_s + plant time`.

use crate::attitude::{self, Attitude};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A torque between each wheel and the platform fitted to data, `T_i = Σ coefficient ×
/// function` per wheel `i`, accelerating the wheel in its positive sense (the platform takes the
/// reaction); written by `testbed identify` from the unexplained effects it finds in the wheel
/// channel (or by hand). Functions: [`WheelFunction`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedWheelTorque {
    /// The terms' time at the plant's start, s (their time is the record's time from its
    /// start; 0 when the run starts where the record did).
    #[serde(default)]
    pub start_time_s: f64,
    pub terms: Vec<FittedWheelTorqueTerm>,
}

/// One term of a [`FittedWheelTorque`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedWheelTorqueTerm {
    /// The wheel, by the body axis it spins about: `x`, `y` or `z`.
    pub wheel: String,
    /// The function, by name (`1`, `t_s`, `sign n`, `n·|n|`, `τ`, `sin tilt_x`, …).
    pub function: String,
    /// Nm per unit of the function (Nm/s for `t_s`, Nm/(rad/s) for `n` or a rate,
    /// Nm/(rad/s)² for `n·|n|` and `n²`, Nm/Nm for `τ`).
    pub coefficient: f64,
}

/// A function a fitted wheel torque term may use. Names are those identification prints,
/// except time, which is in seconds here (`t_s`; identification's `t` runs 0…1 over the
/// record).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WheelFunction {
    /// `1`
    One,
    /// `t_s`: time, s.
    Time,
    /// `sign n`: direction of the wheel's spin relative to the platform (±1; a Coulomb level).
    SignSpeed,
    /// `n`: the wheel's speed relative to the platform, rad/s.
    Speed,
    /// `n·|n|`: quadratic drag (windage), (rad/s)².
    SpeedAbs,
    /// `n²`: an even function of the speed, (rad/s)².
    SpeedSquared,
    /// `τ`: the motor torque delivered to the wheel (after the drive's limit and the torque
    /// scale), Nm.
    MotorTorque,
    /// `sin tilt_x`, `sin tilt_y`: horizontal components of the unit down vector in body axes.
    SinTiltX,
    SinTiltY,
    /// `cos ψ`, `sin ψ`: heading harmonics.
    CosHeading,
    SinHeading,
    /// `w_x`, `w_y`, `w_z`: body rates, rad/s.
    RateX,
    RateY,
    RateZ,
}

impl WheelFunction {
    pub const ALL: [WheelFunction; 14] = [
        Self::One,
        Self::Time,
        Self::SignSpeed,
        Self::Speed,
        Self::SpeedAbs,
        Self::SpeedSquared,
        Self::MotorTorque,
        Self::SinTiltX,
        Self::SinTiltY,
        Self::CosHeading,
        Self::SinHeading,
        Self::RateX,
        Self::RateY,
        Self::RateZ,
    ];

    /// The name used in the configuration.
    pub fn name(self) -> &'static str {
        match self {
            Self::One => "1",
            Self::Time => "t_s",
            Self::SignSpeed => "sign n",
            Self::Speed => "n",
            Self::SpeedAbs => "n·|n|",
            Self::SpeedSquared => "n²",
            Self::MotorTorque => "τ",
            Self::SinTiltX => "sin tilt_x",
            Self::SinTiltY => "sin tilt_y",
            Self::CosHeading => "cos ψ",
            Self::SinHeading => "sin ψ",
            Self::RateX => "w_x",
            Self::RateY => "w_y",
            Self::RateZ => "w_z",
        }
    }

    /// The function of `name` (also `psi` for `ψ`, `tau` for `τ`, `*` for `·`, `n^2` for `n²`).
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name
            .trim()
            .replace("psi", "ψ")
            .replace("tau", "τ")
            .replace('*', "·")
            .replace("n^2", "n²");
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    fn index(self) -> usize {
        self as usize
    }

    fn uses_time(self) -> bool {
        self == Self::Time
    }

    fn uses_attitude(self) -> bool {
        matches!(
            self,
            Self::SinTiltX | Self::SinTiltY | Self::CosHeading | Self::SinHeading
        )
    }

    /// Value for a wheel at speed `n` (rad/s) spinning in `direction` (±1), delivered motor
    /// torque `tau` (Nm), time `t_s` (s), and the platform's `[G_x, G_y, cos ψ, sin ψ, w_x,
    /// w_y, w_z]` (`platform`).
    fn value(self, n: f64, direction: f64, tau: f64, t_s: f64, platform: &[f64; 7]) -> f64 {
        match self {
            Self::One => 1.0,
            Self::Time => t_s,
            Self::SignSpeed => direction,
            Self::Speed => n,
            Self::SpeedAbs => n * n.abs(),
            Self::SpeedSquared => n * n,
            Self::MotorTorque => tau,
            Self::SinTiltX => platform[0],
            Self::SinTiltY => platform[1],
            Self::CosHeading => platform[2],
            Self::SinHeading => platform[3],
            Self::RateX => platform[4],
            Self::RateY => platform[5],
            Self::RateZ => platform[6],
        }
    }
}

/// The fitted wheel torque resolved from the configuration: per wheel, one coefficient per
/// [`WheelFunction`] (Nm per unit of the function). `Copy`, as the plant evaluates it four
/// times per integration step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FittedWheelTorqueModel {
    coefficients: [[f64; WheelFunction::ALL.len()]; 3],
    /// The terms' time at plant time 0, s.
    start_time_s: f64,
    /// Plant time the terms are evaluated at ([`FittedWheelTorqueModel::set_time`]), s.
    time_s: f64,
    active: bool,
    uses_time: bool,
    uses_attitude: bool,
}

impl FittedWheelTorqueModel {
    /// Resolve a validated configuration (terms with an unknown wheel or function are refused
    /// by [`crate::ModelConfig::validate`] and skipped here).
    pub fn from_config(config: Option<&FittedWheelTorque>) -> Self {
        let mut out = Self::default();
        let Some(config) = config else {
            return out;
        };
        out.start_time_s = config.start_time_s;
        for term in &config.terms {
            let (Some(wheel), Some(f)) = (
                super::fitted_torque::axis_index(&term.wheel),
                WheelFunction::from_name(&term.function),
            ) else {
                continue;
            };
            out.coefficients[wheel][f.index()] += term.coefficient;
            out.active = true;
            out.uses_time |= f.uses_time();
            out.uses_attitude |= f.uses_attitude();
        }
        out
    }

    /// Whether any term is configured.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// Whether the torque depends on time (the plant then passes its time).
    pub fn uses_time(&self) -> bool {
        self.uses_time
    }

    /// Evaluate the time terms at plant time `plant_time_s`, s (held over a substep, as the
    /// external torque's).
    pub fn set_time(&mut self, plant_time_s: f64) {
        self.time_s = plant_time_s;
    }

    /// The platform's part of the functions at attitude `q` (L→B) and body rate `rate_b`
    /// (rad/s): `[G_x, G_y, cos ψ, sin ψ, w_x, w_y, w_z]` (the attitude's part zero when no term
    /// uses it, so the heading is not computed).
    pub fn platform(&self, q: &Attitude, rate_b: &Vector3<f64>) -> [f64; 7] {
        let (g, psi) = if self.uses_attitude {
            (attitude::gravity_b(q), attitude::heading(q))
        } else {
            (Vector3::zeros(), 0.0)
        };
        [g.x, g.y, psi.cos(), psi.sin(), rate_b.x, rate_b.y, rate_b.z]
    }

    /// Torque on wheel `wheel` (0 = X, 1 = Y, 2 = Z), Nm, positive accelerating it in its
    /// positive sense: speed `n` relative to the platform (rad/s), spin `direction` (±1, the
    /// sliding direction the plant froze for the step), delivered motor torque `tau` (Nm),
    /// `platform` from [`FittedWheelTorqueModel::platform`]. Zero without terms.
    pub fn torque(
        &self,
        wheel: usize,
        n: f64,
        direction: f64,
        tau: f64,
        platform: &[f64; 7],
    ) -> f64 {
        let Some(c) = self.coefficients.get(wheel).filter(|_| self.active) else {
            return 0.0;
        };
        let t = self.start_time_s + self.time_s;
        WheelFunction::ALL
            .iter()
            .zip(c)
            .filter(|(_, c)| **c != 0.0)
            .map(|(f, c)| c * f.value(n, direction, tau, t, platform))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;

    fn term(wheel: &str, function: &str, coefficient: f64) -> FittedWheelTorqueTerm {
        FittedWheelTorqueTerm {
            wheel: wheel.into(),
            function: function.into(),
            coefficient,
        }
    }

    #[test]
    fn every_function_is_found_by_its_name() {
        for f in WheelFunction::ALL {
            assert_eq!(WheelFunction::from_name(f.name()), Some(f));
        }
        assert_eq!(
            WheelFunction::from_name("n*|n|"),
            Some(WheelFunction::SpeedAbs)
        );
        assert_eq!(
            WheelFunction::from_name("n^2"),
            Some(WheelFunction::SpeedSquared)
        );
        assert_eq!(
            WheelFunction::from_name(" tau "),
            Some(WheelFunction::MotorTorque)
        );
        assert_eq!(
            WheelFunction::from_name("sin psi"),
            Some(WheelFunction::SinHeading)
        );
        assert_eq!(WheelFunction::from_name("t"), None);
        assert_eq!(WheelFunction::from_name("sin 2ψ"), None);
    }

    #[test]
    fn the_torque_is_the_sum_of_its_terms_in_closed_form() {
        let config = FittedWheelTorque {
            start_time_s: 100.0,
            terms: vec![
                term("y", "n·|n|", -1e-8),
                term("y", "sign n", 2e-4),
                term("y", "t_s", 1e-7),
                term("x", "sin tilt_x", 1e-2),
                term("x", "sin ψ", 3e-4),
                term("x", "τ", 0.05),
                term("z", "n²", 2e-9),
                term("z", "w_z", -0.01),
                term("z", "w_z", -0.01),
            ],
        };
        let mut model = FittedWheelTorqueModel::from_config(Some(&config));
        assert!(model.is_active() && model.uses_time());
        model.set_time(50.0);
        let psi = 0.4f64;
        let q = from_heading_pitch_roll(psi, 0.05, -0.08);
        let w = Vector3::new(0.01, -0.02, 0.03);
        let platform = model.platform(&q, &w);
        let g = attitude::gravity_b(&q);
        let (n, tau) = (-300.0f64, 0.04);
        let y = model.torque(1, n, -1.0, tau, &platform);
        let y_truth = -1e-8 * n * n.abs() - 2e-4 + 1e-7 * 150.0;
        assert!((y - y_truth).abs() < 1e-15, "{y} vs {y_truth}");
        let x = model.torque(0, n, -1.0, tau, &platform);
        let x_truth = 1e-2 * g.x + 3e-4 * psi.sin() + 0.05 * tau;
        assert!((x - x_truth).abs() < 1e-15, "{x} vs {x_truth}");
        let z = model.torque(2, n, -1.0, tau, &platform);
        let z_truth = 2e-9 * n * n - 0.02 * w.z;
        assert!((z - z_truth).abs() < 1e-15, "{z} vs {z_truth}");
        assert_eq!(model.torque(3, n, 1.0, tau, &platform), 0.0);
    }

    #[test]
    fn without_terms_the_torque_is_zero_and_needs_no_time() {
        let model = FittedWheelTorqueModel::from_config(None);
        assert!(!model.is_active() && !model.uses_time());
        let q = from_heading_pitch_roll(1.0, 0.1, 0.1);
        let platform = model.platform(&q, &Vector3::new(1.0, 1.0, 1.0));
        for wheel in 0..3 {
            assert_eq!(model.torque(wheel, 100.0, 1.0, 0.1, &platform), 0.0);
        }
    }
}
