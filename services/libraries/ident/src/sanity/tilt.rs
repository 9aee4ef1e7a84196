//! The inclinometer's unit by its range: tilt angles beyond anything the platform and the
//! sensor can give are not radians.
//!
//! The platform stops at `[platform] tilt_limit_deg` (30°) and the sensor reads to
//! `[inclinometer] range_deg` (25°). A reading beyond 1.5 times the larger of the two (45°) is no
//! bias or scale error, and a tilt in degrees written as radians gives one as soon as the
//! platform tilts by more than 0.8°. The unit named is the first of degrees, mrad and arcmin in
//! which the readings fit that bound. Smaller tilts in degrees stay within the range; the
//! comparison with the gyro (`rotation`) finds those.

use super::finding::{Finding, Mistake};
use super::units;
use super::value_columns;
use crate::csv::columns;
use crate::data::{Dataset, files};
use testbed_model::ModelConfig;
use testbed_model::config::DEG;

/// Readings beyond this multiple of the platform's and the sensor's largest tilt are not tilts
/// in radians.
const RANGE_MARGIN: f64 = 1.5;

/// The inclinometer file, if its angles lie beyond any tilt in radians.
pub fn check(data: &Dataset, model: &ModelConfig) -> Option<Finding> {
    if data.inclinometer.is_empty() {
        return None;
    }
    let bound_rad = RANGE_MARGIN
        * model
            .inclinometer
            .range_deg
            .max(model.platform.tilt_limit_deg)
        * DEG;
    let largest = |axis: usize| {
        data.inclinometer
            .iter()
            .map(|r| r.tilt_rad[axis].abs())
            .fold(0.0f64, f64::max)
    };
    let largest = [largest(0), largest(1)];
    let names = value_columns(columns::INCLINOMETER);
    let beyond: Vec<usize> = (0..2).filter(|&a| largest[a] > bound_rad).collect();
    let worst = beyond.iter().map(|&a| largest[a]).fold(0.0f64, f64::max);
    if beyond.is_empty() {
        return None;
    }
    let unit = units::ANGLE
        .iter()
        .filter(|u| worst / u.factor <= bound_rad)
        .min_by(|a, b| a.factor.total_cmp(&b.factor));
    let mistake = match unit {
        Some(u) => Mistake::Units {
            unit: u.name,
            si: "radians",
            factor: u.factor,
        },
        None => Mistake::OutOfRange,
    };
    let as_unit = unit.map_or(String::new(), |u| {
        format!("; as {} it is {:.3} rad", u.name, worst / u.factor)
    });
    Some(Finding {
        file: data.source.join(files::INCLINOMETER),
        columns: beyond.iter().map(|&a| names[a].clone()).collect(),
        mistake,
        evidence: format!(
            "the largest reading is {worst:.4} \"rad\", beyond the ±{bound_rad:.3} rad no tilt of \
             the platform (stop ±{}°) or the sensor (range ±{}°) can reach{as_unit}",
            model.platform.tilt_limit_deg, model.inclinometer.range_deg
        ),
    })
}
