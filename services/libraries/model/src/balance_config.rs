//! Configuration of the platform's balance masses (`[balance]` of a run configuration): sliding
//! masses that move the centre of mass for fine balancing, each along its own straight travel.
//!
//! The paper says only that the platform's two-plate cylinder "helps balancing"; it gives no
//! balance masses. Every default here is **assumed**, a lab-typical set (`docs/balance.md`):
//! three orthogonal motorised sliders, two for the horizontal offset (body X and Y) and one for
//! the vertical (body Z). Units carry their name in the key; everything is SI.

use crate::config::ConfigError;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use serde::{Deserialize, Serialize};

/// The balance masses and the balance's target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BalanceConfig {
    /// The vertical centre-of-mass offset to balance to, m, body Z (up when level); negative:
    /// below the bearing's centre (pendulous, a restoring gravity torque). Assumed: −1 µm, the
    /// "slightly negative" offset the digest calls common after balancing: 3.4 mNm/rad of
    /// restoring torque at 350 kg, a pendulum period of about 12 min about X and Y, weak beside
    /// the controller.
    pub vertical_target_m: f64,
    /// Horizontal offset the balance is for: the plan says whether its predicted residual's
    /// RMS stays under it, m. Assumed: 0.1 µm (0.34 mNm at 350 kg, a fifth of a wheel's
    /// Coulomb friction).
    pub horizontal_tolerance_m: f64,
    /// The sliding masses.
    pub masses: Vec<BalanceMass>,
}

/// One sliding mass: it moves along `axis` through the centre of its travel, `centre_m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BalanceMass {
    /// Name printed with its move.
    pub name: String,
    /// The moving mass, kg (part of the platform's `platform.mass_kg`).
    pub mass_kg: f64,
    /// Centre of its travel relative to the bearing's centre of rotation, m, body axes.
    pub centre_m: [f64; 3],
    /// Direction it moves along (unit vector), body axes.
    pub axis: [f64; 3],
    /// Travel limits along `axis` from `centre_m`, m: `[lowest, highest]`.
    pub travel_m: [f64; 2],
    /// Where it is now along `axis` from `centre_m`, m (update it after each move).
    #[serde(default)]
    pub position_m: f64,
    /// Positioning error of a move, 1σ, m.
    pub position_stddev_m: f64,
}

/// Default travel of each slider, ±m. Assumed: ±50 mm (a 100-mm lead-screw stage).
const TRAVEL_M: f64 = 0.05;
/// Default moving mass of each slider, kg. Assumed: 1 kg.
const MASS_KG: f64 = 1.0;
/// Default positioning error, 1σ, m. Assumed: 2 µm (a 1-mm-pitch lead screw at 200 full
/// steps per turn moves 5 µm a step; a uniform error over a step has σ = 5/√12 ≈ 1.4 µm,
/// rounded up for backlash).
const POSITION_STDDEV_M: f64 = 2e-6;

impl Default for BalanceConfig {
    fn default() -> Self {
        let slider = |name: &str, centre_m: [f64; 3], axis: [f64; 3]| BalanceMass {
            name: name.into(),
            mass_kg: MASS_KG,
            centre_m,
            axis,
            travel_m: [-TRAVEL_M, TRAVEL_M],
            position_m: 0.0,
            position_stddev_m: POSITION_STDDEV_M,
        };
        Self {
            vertical_target_m: -1e-6,
            horizontal_tolerance_m: 1e-7,
            // Assumed positions: the horizontal sliders on the upper plate 0.3 m from the
            // vertical axis, the vertical one on the axis (where they sit does not change what
            // a move does: only the axis and the mass do).
            masses: vec![
                slider("x", [0.0, 0.3, 0.1], [1.0, 0.0, 0.0]),
                slider("y", [-0.3, 0.0, 0.1], [0.0, 1.0, 0.0]),
                slider("z", [0.0, 0.0, 0.2], [0.0, 0.0, 1.0]),
            ],
        }
    }
}

/// Smallest eigenvalue of `Σ m_i² e_i e_iᵀ` relative to its largest below which the masses
/// cannot move the centre of mass along its eigenvector.
const RANK_TOLERANCE: f64 = 1e-9;

impl BalanceConfig {
    /// `m_i e_i` per mass, kg (a move `Δs_i` shifts the total moment `Σ m r` by `m_i Δs_i e_i`).
    pub fn moment_columns(&self) -> Vec<Vector3<f64>> {
        self.masses
            .iter()
            .map(|m| Vector3::from(m.axis) * m.mass_kg)
            .collect()
    }

    /// A direction (unit, body axes) along which the masses cannot move the centre of mass,
    /// if there is one.
    pub fn unreachable_direction(&self) -> Option<Vector3<f64>> {
        let mut g = Matrix3::zeros();
        for c in self.moment_columns() {
            g += c * c.transpose();
        }
        let eig = SymmetricEigen::new(g);
        let (imin, &lmin) = eig
            .eigenvalues
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))?;
        let lmax = eig.eigenvalues.amax();
        (lmax <= 0.0 || lmin <= RANK_TOLERANCE * lmax)
            .then(|| eig.eigenvectors.column(imin).into_owned())
    }

    /// Refuse what no balance can be, naming the key and value: no masses, a mass that is not
    /// positive, an axis that is not a unit vector, a travel of no length, a position outside
    /// its travel, a set of masses that cannot move the centre of mass along some direction.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let fail = |key: String, value: String, reason: &str| {
            Err(ConfigError::Invalid {
                key: format!("balance.{key}"),
                value,
                reason: reason.to_string(),
            })
        };
        if !self.vertical_target_m.is_finite() {
            return fail(
                "vertical_target_m".into(),
                self.vertical_target_m.to_string(),
                "must be finite",
            );
        }
        if !(self.horizontal_tolerance_m.is_finite() && self.horizontal_tolerance_m > 0.0) {
            return fail(
                "horizontal_tolerance_m".into(),
                self.horizontal_tolerance_m.to_string(),
                "must be a finite number > 0",
            );
        }
        if self.masses.is_empty() {
            return fail(
                "masses".into(),
                "[]".into(),
                "no balance masses: at least three along independent axes",
            );
        }
        for (i, m) in self.masses.iter().enumerate() {
            let key = |k: &str| format!("masses[{i}].{k}");
            if !(m.mass_kg.is_finite() && m.mass_kg > 0.0) {
                return fail(
                    key("mass_kg"),
                    m.mass_kg.to_string(),
                    "must be a finite mass > 0",
                );
            }
            if m.centre_m.iter().any(|x| !x.is_finite()) {
                return fail(
                    key("centre_m"),
                    format!("{:?}", m.centre_m),
                    "must be finite",
                );
            }
            let norm = Vector3::from(m.axis).norm();
            if !norm.is_finite() || (norm - 1.0).abs() >= 1e-6 {
                return fail(
                    key("axis"),
                    format!("{:?}", m.axis),
                    "must be a unit vector (body axes)",
                );
            }
            let [lo, hi] = m.travel_m;
            if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                return fail(
                    key("travel_m"),
                    format!("{:?}", m.travel_m),
                    "the mass has no travel: must be [lowest, highest] with highest > lowest",
                );
            }
            if !(m.position_m.is_finite() && (lo..=hi).contains(&m.position_m)) {
                return fail(
                    key("position_m"),
                    m.position_m.to_string(),
                    "must lie within travel_m",
                );
            }
            if !(m.position_stddev_m.is_finite() && m.position_stddev_m >= 0.0) {
                return fail(
                    key("position_stddev_m"),
                    m.position_stddev_m.to_string(),
                    "must be a finite number >= 0",
                );
            }
        }
        if let Some(d) = self.unreachable_direction() {
            return fail(
                "masses".into(),
                format!(
                    "axes {:?}",
                    self.masses.iter().map(|m| m.axis).collect::<Vec<_>>()
                ),
                &format!(
                    "these masses cannot move the centre of mass along [{:.3}, {:.3}, {:.3}] \
                     (body axes): at least three must move along independent axes",
                    d.x, d.y, d.z
                ),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(edit: impl FnOnce(&mut BalanceConfig)) -> String {
        let mut c = BalanceConfig::default();
        edit(&mut c);
        c.validate().expect_err("refused").to_string()
    }

    #[test]
    fn the_default_is_valid_and_reaches_every_direction() {
        let c = BalanceConfig::default();
        c.validate().expect("default valid");
        assert!(c.unreachable_direction().is_none());
    }

    #[test]
    fn bad_masses_are_refused_by_key() {
        let msg = refused(|c| c.masses[1].mass_kg = 0.0);
        assert!(
            msg.contains("balance.masses[1].mass_kg") && msg.contains("= 0"),
            "{msg}"
        );
        let msg = refused(|c| c.masses[0].mass_kg = -2.0);
        assert!(
            msg.contains("balance.masses[0].mass_kg") && msg.contains("-2"),
            "{msg}"
        );
        let msg = refused(|c| c.masses[2].travel_m = [0.01, 0.01]);
        assert!(
            msg.contains("balance.masses[2].travel_m") && msg.contains("no travel"),
            "{msg}"
        );
        let msg = refused(|c| c.masses[0].axis = [1.0, 1.0, 0.0]);
        assert!(msg.contains("balance.masses[0].axis"), "{msg}");
        let msg = refused(|c| c.masses[0].position_m = 0.06);
        assert!(msg.contains("balance.masses[0].position_m"), "{msg}");
        let msg = refused(|c| c.masses.clear());
        assert!(msg.contains("balance.masses"), "{msg}");
    }

    #[test]
    fn masses_that_miss_a_direction_are_refused_naming_it() {
        // Two sliders along X and one along Y: nothing moves the centre of mass vertically.
        let msg = refused(|c| c.masses[2].axis = [1.0, 0.0, 0.0]);
        assert!(msg.contains("balance.masses"), "{msg}");
        assert!(msg.contains("1.000] (body axes)"), "{msg}");
        // The vertical slider tilted into the X–Y plane at 45°: still no vertical reach.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let mut c = BalanceConfig::default();
        c.masses[2].axis = [s, s, 0.0];
        let d = c.unreachable_direction().expect("no vertical reach");
        assert!((d.z.abs() - 1.0).abs() < 1e-9, "{d:?}");
    }
}
