//! The magnetometer's unit: the magnitude of the readings against the lab field of the model
//! (`[platform] field_l_gauss`).
//!
//! A rotation keeps a field's magnitude, so whatever the attitude the readings' magnitude is the
//! lab field's, give or take a hard iron (tens of µT against the lab's 55) and the building's
//! steel: at most a few times more or less. Gauss, milligauss, µT and nT written as tesla make
//! it 10⁴ to 10⁹ times larger.

use super::finding::{Finding, Mistake};
use super::units::{self, Verdict};
use crate::data::{Dataset, files};
use testbed_model::ModelConfig;
use testbed_model::config::GAUSS;

/// Magnitudes within this band of the lab field's are physics (hard and soft iron, a lab field
/// other than configured).
const PHYSICAL_FIELD_BAND: (f64, f64) = (0.01, 100.0);
/// A magnitude ratio names a unit within half a decade of its factor: a hard iron can move the
/// magnitude by a few times, and the nearest units (µT, mG) are a decade apart.
const FIELD_UNIT_TOLERANCE: f64 = 3.16;

/// The magnetometer file, if its readings are not in tesla.
pub fn check(data: &Dataset, model: &ModelConfig) -> Option<Finding> {
    if data.magnetometer.is_empty() {
        return None;
    }
    let lab_t = nalgebra::Vector3::from(model.platform.field_l_gauss).norm() * GAUSS;
    if !(lab_t.is_finite() && lab_t > 0.0) {
        return None;
    }
    let mut magnitudes: Vec<f64> = data.magnetometer.iter().map(|r| r.field_t.norm()).collect();
    magnitudes.sort_by(f64::total_cmp);
    let median = magnitudes[magnitudes.len() / 2];
    let factor = median / lab_t;
    let mistake = match units::classify_within(
        factor,
        units::FIELD,
        PHYSICAL_FIELD_BAND,
        FIELD_UNIT_TOLERANCE,
    ) {
        Verdict::Si => return None,
        Verdict::Unit(u) => Mistake::Units {
            unit: u.name,
            si: "tesla",
            factor,
        },
        Verdict::Unknown => Mistake::Scale {
            si: "tesla",
            factor,
        },
    };
    Some(Finding {
        file: data.source.join(files::MAGNETOMETER),
        columns: vec!["bx".into(), "by".into(), "bz".into()],
        mistake,
        evidence: format!(
            "the median field magnitude is {median:.4e} \"T\", {factor:.4e}× the lab field's \
             {lab_t:.3e} T"
        ),
    })
}
