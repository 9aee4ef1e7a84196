//! A torque fitted to data: what `testbed identify` reports as an **unexplained effect** in a
//! torque channel (`torque_z ≈ 9.7e-4 Nm × 1 + 8.1e-4 Nm × sin 2ψ`), carried into the model
//! so the plant reproduces it. Off unless `[effects.fitted_torque]` is configured.
//!
//! The torque about body axis `a` is `M_a = Σ c_{a,j} f_j(t, q, w)`, a sum of the functions of
//! [`TorqueFunction`] (the subset of identification's torque candidates that a forward
//! simulation can evaluate: angular accelerations are not among them) with coefficients
//! `c_{a,j}` in Nm per unit of the function. The functions' time is the record's time from its
//! start, s: `t = start_time_s + plant time`.

use crate::attitude::{self, Attitude};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A torque fitted to data, `M_a = Σ coefficient × function` per body axis `a`, written by
/// `testbed identify` from the unexplained effects it finds in the torque channels (or by
/// hand). Functions: [`TorqueFunction`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedTorque {
    /// The terms' time at the plant's start, s (their time is the record's time from its
    /// start; 0 when the run starts where the record did).
    #[serde(default)]
    pub start_time_s: f64,
    pub terms: Vec<FittedTorqueTerm>,
}

/// One term of a [`FittedTorque`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedTorqueTerm {
    /// Body axis of the torque: `x`, `y` or `z`.
    pub axis: String,
    /// The function, by name (`1`, `t_s`, `sin 2ψ`, `w_z`, …).
    pub function: String,
    /// Nm per unit of the function (Nm/s for `t_s`, Nm/(rad/s) for a rate).
    pub coefficient: f64,
}

/// A function a fitted torque term may use. Names are those identification prints, except
/// time, which is in seconds here (`t_s`; identification's `t` runs 0…1 over the record).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TorqueFunction {
    /// `1`
    One,
    /// `t_s`: time, s.
    Time,
    /// `sin tilt_x`, `sin tilt_y`: horizontal components of the unit down vector in body axes.
    SinTiltX,
    SinTiltY,
    /// `t_s·sin tilt_x`, `t_s·sin tilt_y` (a drifting centre of mass), s.
    TimeSinTiltX,
    TimeSinTiltY,
    /// `cos ψ`, `sin ψ`, `cos 2ψ`, `sin 2ψ`: heading harmonics.
    CosHeading,
    SinHeading,
    Cos2Heading,
    Sin2Heading,
    /// `w_x`, `w_y`, `w_z`: body rates, rad/s.
    RateX,
    RateY,
    RateZ,
    /// `w_x·|w_x|` …: quadratic damping, (rad/s)².
    RateXAbs,
    RateYAbs,
    RateZAbs,
    /// `w_x·w_y`, `w_y·w_z`, `w_z·w_x`: rate products, (rad/s)².
    RateXY,
    RateYZ,
    RateZX,
}

impl TorqueFunction {
    pub const ALL: [TorqueFunction; 19] = [
        Self::One,
        Self::Time,
        Self::SinTiltX,
        Self::SinTiltY,
        Self::TimeSinTiltX,
        Self::TimeSinTiltY,
        Self::CosHeading,
        Self::SinHeading,
        Self::Cos2Heading,
        Self::Sin2Heading,
        Self::RateX,
        Self::RateY,
        Self::RateZ,
        Self::RateXAbs,
        Self::RateYAbs,
        Self::RateZAbs,
        Self::RateXY,
        Self::RateYZ,
        Self::RateZX,
    ];

    /// The name used in the configuration.
    pub fn name(self) -> &'static str {
        match self {
            Self::One => "1",
            Self::Time => "t_s",
            Self::SinTiltX => "sin tilt_x",
            Self::SinTiltY => "sin tilt_y",
            Self::TimeSinTiltX => "t_s·sin tilt_x",
            Self::TimeSinTiltY => "t_s·sin tilt_y",
            Self::CosHeading => "cos ψ",
            Self::SinHeading => "sin ψ",
            Self::Cos2Heading => "cos 2ψ",
            Self::Sin2Heading => "sin 2ψ",
            Self::RateX => "w_x",
            Self::RateY => "w_y",
            Self::RateZ => "w_z",
            Self::RateXAbs => "w_x·|w_x|",
            Self::RateYAbs => "w_y·|w_y|",
            Self::RateZAbs => "w_z·|w_z|",
            Self::RateXY => "w_x·w_y",
            Self::RateYZ => "w_y·w_z",
            Self::RateZX => "w_z·w_x",
        }
    }

    /// The function of `name` (also `psi` for `ψ`, `*` for `·`).
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name.trim().replace("psi", "ψ").replace('*', "·");
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    fn index(self) -> usize {
        self as usize
    }

    /// Whether the function depends on time.
    pub fn uses_time(self) -> bool {
        matches!(self, Self::Time | Self::TimeSinTiltX | Self::TimeSinTiltY)
    }

    fn uses_heading(self) -> bool {
        matches!(
            self,
            Self::CosHeading | Self::SinHeading | Self::Cos2Heading | Self::Sin2Heading
        )
    }

    /// Value at time `t_s` (s), attitude `q` (L→B), body rate `w` (rad/s); `psi` the heading,
    /// rad, `g` the unit down vector in body axes.
    fn value(self, t_s: f64, g: &Vector3<f64>, psi: f64, w: &Vector3<f64>) -> f64 {
        match self {
            Self::One => 1.0,
            Self::Time => t_s,
            Self::SinTiltX => g.x,
            Self::SinTiltY => g.y,
            Self::TimeSinTiltX => t_s * g.x,
            Self::TimeSinTiltY => t_s * g.y,
            Self::CosHeading => psi.cos(),
            Self::SinHeading => psi.sin(),
            Self::Cos2Heading => (2.0 * psi).cos(),
            Self::Sin2Heading => (2.0 * psi).sin(),
            Self::RateX => w.x,
            Self::RateY => w.y,
            Self::RateZ => w.z,
            Self::RateXAbs => w.x * w.x.abs(),
            Self::RateYAbs => w.y * w.y.abs(),
            Self::RateZAbs => w.z * w.z.abs(),
            Self::RateXY => w.x * w.y,
            Self::RateYZ => w.y * w.z,
            Self::RateZX => w.z * w.x,
        }
    }
}

/// Body axis of a term: `x`, `y` or `z`.
pub fn axis_index(axis: &str) -> Option<usize> {
    match axis.trim() {
        "x" | "X" => Some(0),
        "y" | "Y" => Some(1),
        "z" | "Z" => Some(2),
        _ => None,
    }
}

/// The fitted torque resolved from the configuration: one coefficient vector (Nm per unit of
/// the function, body axes) per [`TorqueFunction`]. `Copy`, as the plant evaluates it four times
/// per integration step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FittedTorqueModel {
    coefficients: [Vector3<f64>; TorqueFunction::ALL.len()],
    /// The terms' time at plant time 0, s.
    start_time_s: f64,
    active: bool,
    uses_time: bool,
    uses_heading: bool,
}

impl FittedTorqueModel {
    /// Resolve a validated configuration (terms with an unknown axis or function are refused
    /// by [`crate::ModelConfig::validate`] and skipped here).
    pub fn from_config(config: Option<&FittedTorque>) -> Self {
        let mut out = Self::default();
        let Some(config) = config else {
            return out;
        };
        out.start_time_s = config.start_time_s;
        for term in &config.terms {
            let (Some(axis), Some(f)) = (
                axis_index(&term.axis),
                TorqueFunction::from_name(&term.function),
            ) else {
                continue;
            };
            out.coefficients[f.index()][axis] += term.coefficient;
            out.active = true;
            out.uses_time |= f.uses_time();
            out.uses_heading |= f.uses_heading();
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

    /// Torque at plant time `plant_time_s` (s), attitude `q` (L→B), body rate `rate_b`
    /// (rad/s), Nm, body axes. Zero without terms.
    pub fn torque(&self, plant_time_s: f64, q: &Attitude, rate_b: &Vector3<f64>) -> Vector3<f64> {
        if !self.active {
            return Vector3::zeros();
        }
        let t = self.start_time_s + plant_time_s;
        let g = attitude::gravity_b(q);
        let psi = if self.uses_heading {
            attitude::heading(q)
        } else {
            0.0
        };
        TorqueFunction::ALL
            .iter()
            .zip(&self.coefficients)
            .filter(|(_, c)| **c != Vector3::zeros())
            .map(|(f, c)| c * f.value(t, &g, psi, rate_b))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;

    fn term(axis: &str, function: &str, coefficient: f64) -> FittedTorqueTerm {
        FittedTorqueTerm {
            axis: axis.into(),
            function: function.into(),
            coefficient,
        }
    }

    #[test]
    fn every_function_is_found_by_its_name() {
        for f in TorqueFunction::ALL {
            assert_eq!(TorqueFunction::from_name(f.name()), Some(f));
        }
        assert_eq!(
            TorqueFunction::from_name("sin 2psi"),
            Some(TorqueFunction::Sin2Heading)
        );
        assert_eq!(
            TorqueFunction::from_name("t_s*sin tilt_y"),
            Some(TorqueFunction::TimeSinTiltY)
        );
        assert_eq!(TorqueFunction::from_name("dw_x/dt"), None);
    }

    #[test]
    fn the_torque_is_the_sum_of_its_terms_in_closed_form() {
        let config = FittedTorque {
            start_time_s: 100.0,
            terms: vec![
                term("z", "1", 1e-3),
                term("z", "sin 2ψ", 5e-4),
                term("x", "t_s·sin tilt_y", 2e-6),
                term("y", "w_z", -0.01),
                term("y", "w_z", -0.01),
            ],
        };
        let model = FittedTorqueModel::from_config(Some(&config));
        assert!(model.is_active() && model.uses_time());
        let (psi, pitch, roll) = (0.4f64, 0.05f64, -0.08f64);
        let q = from_heading_pitch_roll(psi, pitch, roll);
        let w = Vector3::new(0.01, -0.02, 0.03);
        let t = 50.0;
        let m = model.torque(t, &q, &w);
        let g = attitude::gravity_b(&q);
        let psi_back = attitude::heading(&q);
        assert!((psi_back - psi).abs() < 1e-12);
        let expected = Vector3::new(
            2e-6 * (100.0 + t) * g.y,
            -0.02 * w.z,
            1e-3 + 5e-4 * (2.0 * psi).sin(),
        );
        assert!((m - expected).norm() < 1e-15, "{m} vs {expected}");
    }

    #[test]
    fn without_terms_the_torque_is_zero_and_needs_no_time() {
        let model = FittedTorqueModel::from_config(None);
        assert!(!model.is_active() && !model.uses_time());
        let q = from_heading_pitch_roll(1.0, 0.1, 0.1);
        assert_eq!(
            model.torque(10.0, &q, &Vector3::new(1.0, 1.0, 1.0)),
            Vector3::zeros()
        );
    }
}
