//! A magnetometer error fitted to data: what `testbed identify` reports as an **unexplained
//! effect** in the field innovations (`innovation_field_x ≈ … × B_y + … × cos 2ψ`), carried into
//! the model as an additive term of the reading so the simulated magnetometer reproduces it and
//! identification's filter takes it out of the readings. Off unless `[effects.fitted_field]` is
//! configured.
//!
//! The reading's error along body axis `a` is `ΔM_a = Σ c_{a,j} f_j(q)`, tesla, a sum of the
//! functions of [`FieldFunction`] (the attitude functions among identification's sensor-channel
//! candidates; time, rates and wheel speeds are not among them: a magnetometer reading is
//! modelled as a function of the attitude only) with coefficients `c_{a,j}` in tesla per unit of
//! the function. A soft-iron matrix `S` is the special case `ΔM = |M_L| S B̂`, `B̂` the lab field
//! in body axes over its magnitude (`B_x`, `B_y`, `B_z`).

use crate::attitude::{self, Attitude};
use crate::physics::fitted_torque::axis_index;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A magnetometer error fitted to data, `ΔM_a = Σ coefficient × function(q)` per body axis `a`
/// of the reading, written by `testbed identify` from the unexplained effects it finds in the
/// field innovations (or by hand). The simulated magnetometer adds it to its reading;
/// identification's filter takes it out of the readings. Functions: [`FieldFunction`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedField {
    pub terms: Vec<FittedFieldTerm>,
}

/// One term of a [`FittedField`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FittedFieldTerm {
    /// Body axis of the reading: `x`, `y` or `z`.
    pub axis: String,
    /// The function, by name (`1`, `cos 2ψ`, `B_y`, …).
    pub function: String,
    /// Tesla per unit of the function.
    pub coefficient: f64,
}

/// A function a fitted field term may use; names are those identification prints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldFunction {
    /// `1`: a constant (hard-iron-like) error.
    One,
    /// `cos ψ`, `sin ψ`, `cos 2ψ`, `sin 2ψ`: heading harmonics.
    CosHeading,
    SinHeading,
    Cos2Heading,
    Sin2Heading,
    /// `sin tilt_x`, `sin tilt_y`: horizontal components of the unit down vector in body axes.
    SinTiltX,
    SinTiltY,
    /// `B_x`, `B_y`, `B_z`: the lab field in body axes over its magnitude (dimensionless).
    FieldX,
    FieldY,
    FieldZ,
}

impl FieldFunction {
    pub const ALL: [FieldFunction; 10] = [
        Self::One,
        Self::CosHeading,
        Self::SinHeading,
        Self::Cos2Heading,
        Self::Sin2Heading,
        Self::SinTiltX,
        Self::SinTiltY,
        Self::FieldX,
        Self::FieldY,
        Self::FieldZ,
    ];

    /// The name used in the configuration (and in identification's report).
    pub fn name(self) -> &'static str {
        match self {
            Self::One => "1",
            Self::CosHeading => "cos ψ",
            Self::SinHeading => "sin ψ",
            Self::Cos2Heading => "cos 2ψ",
            Self::Sin2Heading => "sin 2ψ",
            Self::SinTiltX => "sin tilt_x",
            Self::SinTiltY => "sin tilt_y",
            Self::FieldX => "B_x",
            Self::FieldY => "B_y",
            Self::FieldZ => "B_z",
        }
    }

    /// The function of `name` (also `psi` for `ψ`).
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name.trim().replace("psi", "ψ");
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    fn index(self) -> usize {
        self as usize
    }

    /// Value at attitude `q` (L→B) with `field_unit_l` the lab field over its magnitude, level
    /// frame (dimensionless).
    pub fn value(self, q: &Attitude, field_unit_l: &Vector3<f64>) -> f64 {
        match self {
            Self::One => 1.0,
            Self::CosHeading => attitude::heading(q).cos(),
            Self::SinHeading => attitude::heading(q).sin(),
            Self::Cos2Heading => (2.0 * attitude::heading(q)).cos(),
            Self::Sin2Heading => (2.0 * attitude::heading(q)).sin(),
            Self::SinTiltX => attitude::gravity_b(q).x,
            Self::SinTiltY => attitude::gravity_b(q).y,
            Self::FieldX => (q * field_unit_l).x,
            Self::FieldY => (q * field_unit_l).y,
            Self::FieldZ => (q * field_unit_l).z,
        }
    }
}

/// The fitted field error resolved from the configuration: one coefficient vector (tesla per
/// unit of the function, body axes) per [`FieldFunction`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FittedFieldModel {
    coefficients: [Vector3<f64>; FieldFunction::ALL.len()],
    /// The lab field over its magnitude, level frame.
    field_unit_l: Vector3<f64>,
    active: bool,
}

impl FittedFieldModel {
    /// Resolve a validated configuration for the lab field `field_l_t` (tesla, level frame);
    /// terms with an unknown axis or function are refused by [`crate::ModelConfig::validate`]
    /// and skipped here.
    pub fn from_config(config: Option<&FittedField>, field_l_t: &Vector3<f64>) -> Self {
        let mut out = Self {
            coefficients: [Vector3::zeros(); FieldFunction::ALL.len()],
            field_unit_l: field_l_t / field_l_t.norm().max(1e-300),
            active: false,
        };
        let Some(config) = config else {
            return out;
        };
        for term in &config.terms {
            let (Some(axis), Some(f)) = (
                axis_index(&term.axis),
                FieldFunction::from_name(&term.function),
            ) else {
                continue;
            };
            out.coefficients[f.index()][axis] += term.coefficient;
            out.active = true;
        }
        out
    }

    /// Whether any term is configured.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// The error of the reading at attitude `q` (L→B), tesla, body axes; zero without terms.
    pub fn error_t(&self, q: &Attitude) -> Vector3<f64> {
        if !self.active {
            return Vector3::zeros();
        }
        FieldFunction::ALL
            .iter()
            .zip(&self.coefficients)
            .filter(|(_, c)| **c != Vector3::zeros())
            .map(|(f, c)| c * f.value(q, &self.field_unit_l))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::from_heading_pitch_roll;

    fn term(axis: &str, function: &str, coefficient: f64) -> FittedFieldTerm {
        FittedFieldTerm {
            axis: axis.into(),
            function: function.into(),
            coefficient,
        }
    }

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for f in FieldFunction::ALL {
            assert_eq!(FieldFunction::from_name(f.name()), Some(f));
        }
        assert_eq!(
            FieldFunction::from_name("cos 2psi"),
            Some(FieldFunction::Cos2Heading)
        );
        assert_eq!(FieldFunction::from_name("w_z"), None);
        assert_eq!(FieldFunction::from_name("t"), None);
    }

    /// The configuration refuses an unknown function or axis, naming the key; a valid table
    /// reads back from TOML unchanged.
    #[test]
    fn a_fitted_field_with_an_unknown_function_or_axis_is_refused() {
        let mut config = crate::ModelConfig::default();
        config.effects.fitted_field = Some(FittedField {
            terms: vec![term("x", "w_z", 1e-7)],
        });
        let e = config.validate().expect_err("w_z refused").to_string();
        assert!(e.contains("effects.fitted_field.terms[0].function"), "{e}");
        config.effects.fitted_field = Some(FittedField {
            terms: vec![term("q", "B_x", 1e-7)],
        });
        let e = config.validate().expect_err("axis q refused").to_string();
        assert!(e.contains("effects.fitted_field.terms[0].axis"), "{e}");
        config.effects.fitted_field = Some(FittedField {
            terms: vec![term("y", "cos 2ψ", -3e-7), term("z", "B_x", 2e-7)],
        });
        config.validate().expect("valid fitted field");
        let back = crate::ModelConfig::from_toml_str(&config.to_toml_string(), "round trip")
            .expect("reads back");
        assert_eq!(back.effects.fitted_field, config.effects.fitted_field);
    }

    /// A soft-iron matrix written as `B_*` terms gives `|M_L| S B̂` at any attitude.
    #[test]
    fn field_terms_reproduce_a_soft_iron_matrix() {
        let field_l = Vector3::new(2.0e-5, 0.3e-5, -4.8e-5);
        let s = [[0.03, 0.02, 0.0], [0.02, -0.03, 0.01], [0.0, 0.005, 0.0]];
        let mut terms = Vec::new();
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            for (j, f) in ["B_x", "B_y", "B_z"].iter().enumerate() {
                if s[i][j] != 0.0 {
                    terms.push(term(axis, f, s[i][j] * field_l.norm()));
                }
            }
        }
        let model = FittedFieldModel::from_config(Some(&FittedField { terms }), &field_l);
        assert!(model.is_active());
        let m = nalgebra::Matrix3::from_fn(|i, j| s[i][j]);
        for (psi, pitch, roll) in [(0.3, 0.02, -0.01), (-2.0, -0.03, 0.04), (1.4, 0.0, 0.0)] {
            let q = from_heading_pitch_roll(psi, pitch, roll);
            let want = m * (q * field_l);
            let got = model.error_t(&q);
            assert!((got - want).norm() < 1e-18, "{got} vs {want}");
        }
        let none = FittedFieldModel::from_config(None, &field_l);
        assert!(!none.is_active());
        assert_eq!(none.error_t(&Attitude::identity()), Vector3::zeros());
    }
}
