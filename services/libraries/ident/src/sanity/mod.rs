//! Data sanity before science: the mistakes people make when exporting data (units, signs,
//! exchanged columns, a file of another run), found by checking each channel against the
//! others and against physical ranges, so that `identify` refuses them as data errors instead
//! of explaining them with physical causes.
//!
//! In order, each check on what the previous ones passed:
//! 1. the rows themselves ([`Dataset::check_rows`]: finite, in time order);
//! 2. the time stamps' unit ([`time_base`]: the median period against the configured rates);
//! 3. the coverage ([`Dataset::check_coverage`]: duration, one clock for all files);
//! 4. the field's unit ([`field`]: its magnitude against the lab field);
//! 5. the tilts' unit by their range ([`tilt`]);
//! 6. the wheels' speeds against their torque commands ([`wheels`]);
//! 7. the gyro against the vector sensors ([`rotation`], judged by [`attribution`]): another
//!    run, units, exchanged or flipped axes.
//!
//! Every threshold is stated where it is defined, with why it separates mistakes from
//! physics: only gross factors (units), signs, permutations and unrelated channels are
//! mistakes; scale errors of a few percent, misalignments, hard and soft iron, centre-of-mass
//! torques and lags are physics and pass.

mod attribution;
mod axes;
mod field;
mod finding;
mod rotation;
mod tilt;
mod time_base;
mod units;
mod wheels;

pub use axes::SignedPermutation;
pub use finding::{Finding, Mistake};
pub use rotation::{HypothesisFit, Sensor, SensorFit};
pub use units::{PHYSICAL_BAND, Unit};

use crate::data::Dataset;
use crate::error::DataError;
use testbed_model::ModelConfig;
use testbed_model::config::{DEG, GAUSS};

/// Check `data` before identification (see the module documentation): the first mistake found,
/// as a [`DataError`].
pub fn check(data: &Dataset, model: &ModelConfig) -> Result<(), DataError> {
    data.check_rows()?;
    refuse(time_base::check(data, model))?;
    data.check_coverage()?;
    refuse(find(data, model))
}

/// The first mistake of the channels of a dataset whose rows and coverage are checked.
pub fn find(data: &Dataset, model: &ModelConfig) -> Option<Finding> {
    field::check(data, model)
        .or_else(|| tilt::check(data, model))
        .or_else(|| wheels::check(data, model))
        .or_else(|| {
            attribution::judge(
                &data.source,
                &rotation_fits(data, model),
                &tilt_unit_fits(data, model),
            )
        })
}

/// The gyro's fits against each vector sensor present.
pub fn rotation_fits(data: &Dataset, model: &ModelConfig) -> Vec<SensorFit> {
    let tilt_range = model.inclinometer.range_deg * DEG;
    let field_range = model.magnetometer.range_gauss * GAUSS;
    let mut fits = Vec::new();
    if !data.inclinometer.is_empty()
        && let Some(f) = rotation::fit_sensor(
            data,
            Sensor::Inclinometer,
            &rotation::gravity(data, 1.0, tilt_range),
        )
    {
        fits.push(f);
    }
    if !data.magnetometer.is_empty()
        && let Some(f) = rotation::fit_sensor(
            data,
            Sensor::Magnetometer,
            &rotation::field(data, field_range),
        )
    {
        fits.push(f);
    }
    fits
}

/// The inclinometer's fits with its angles read in each unit of [`units::ANGLE`]: small tilts in
/// degrees stay within the range as radians, but only read in degrees do they turn as the gyro
/// says (the sine's argument, and with it the coupling of the heading rate into the tilts, is
/// wrong in any other unit).
pub fn tilt_unit_fits(data: &Dataset, model: &ModelConfig) -> Vec<(Unit, SensorFit)> {
    let tilt_range = model.inclinometer.range_deg * DEG;
    if data.inclinometer.is_empty() {
        return Vec::new();
    }
    units::ANGLE
        .iter()
        .filter_map(|u| {
            rotation::fit_sensor(
                data,
                Sensor::Inclinometer,
                &rotation::gravity(data, u.factor, tilt_range),
            )
            .map(|f| (*u, f))
        })
        .collect()
}

fn refuse(finding: Option<Finding>) -> Result<(), DataError> {
    match finding {
        Some(f) => Err(DataError::Implausible(Box::new(f))),
        None => Ok(()),
    }
}

/// A file's value columns (all but the time), as owned names.
fn value_columns(columns: &[&str]) -> Vec<String> {
    columns.iter().skip(1).map(|c| c.to_string()).collect()
}
