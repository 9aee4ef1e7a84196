//! Time stamps in the wrong unit: each file's median sample period against the rate the model
//! configures for its device.
//!
//! A device may run at another rate than configured (the magnetometer is programmable from 1 to
//! 150 Hz, a log may be decimated), so only a period near 10³, 10⁶ or 10⁹ times the configured
//! one is called a mistake: milliseconds, microseconds or nanoseconds written as seconds. No
//! device is sampled a thousand times slower than its configuration says.

use super::finding::{Finding, Mistake};
use super::units::{self, Verdict};
use crate::data::{Dataset, median_period};
use testbed_model::ModelConfig;

/// Periods up to this many times the configured one are a rate difference, not a unit.
const RATE_DIFFERENCE_MAX: f64 = 30.0;
/// A period names a time unit when within this ratio of its factor: half a decade, as the
/// units are three decades apart and the rate may differ from the configured one.
const TIME_UNIT_TOLERANCE: f64 = 3.16;

/// The first file whose time stamps look like another unit than seconds.
pub fn check(data: &Dataset, model: &ModelConfig) -> Option<Finding> {
    let gyro_period = 1.0 / model.gyro.rate_hz;
    // In `Dataset::time_stamps`' order; thruster commands are issued on the control loop's
    // tick, the gyro's.
    let expected = [
        gyro_period,
        1.0 / model.inclinometer.rate_hz,
        1.0 / model.magnetometer.rate_hz,
        1.0 / model.wheels.telemetry_rate_hz,
        1.0 / model.cmg.telemetry_rate_hz,
        gyro_period,
    ];
    data.time_stamps()
        .into_iter()
        .zip(expected)
        .find_map(|((name, times), expected_s)| {
            check_file(&times, expected_s).map(|(unit, factor, period)| Finding {
                file: data.source.join(name),
                columns: vec!["t_s".into()],
                mistake: Mistake::Units {
                    unit: unit.name,
                    si: "seconds",
                    factor,
                },
                evidence: format!(
                    "the median spacing of the rows is {period:.4e} \"s\", {factor:.4e}× the \
                 configured {expected_s} s"
                ),
            })
        })
}

/// The unit, factor and median period of one file's time stamps, if they are not seconds.
fn check_file(times: &[f64], expected_s: f64) -> Option<(units::Unit, f64, f64)> {
    if times.len() < 3 || !(expected_s.is_finite() && expected_s > 0.0) {
        return None;
    }
    let period = median_period(times.iter().copied());
    let factor = period / expected_s;
    match units::classify_within(
        factor,
        units::TIME,
        (0.0, RATE_DIFFERENCE_MAX),
        TIME_UNIT_TOLERANCE,
    ) {
        Verdict::Unit(u) => Some((u, factor, period)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn milliseconds_are_found_and_another_rate_is_not() {
        let ms: Vec<f64> = (0..100).map(|i| i as f64 * 100.0).collect();
        let (unit, factor, _) = check_file(&ms, 0.1).expect("ms found");
        assert_eq!(unit.name, "milliseconds");
        assert!((factor - 1000.0).abs() < 1e-9);
        // A magnetometer at 150 Hz configured at 2.5 Hz, or at 1 Hz: rates, not units.
        let fast: Vec<f64> = (0..100).map(|i| i as f64 / 150.0).collect();
        assert!(check_file(&fast, 0.4).is_none());
        let slow: Vec<f64> = (0..100).map(|i| i as f64).collect();
        assert!(check_file(&slow, 0.4).is_none());
        let ns: Vec<f64> = (0..100).map(|i| 1.7e18 + i as f64 * 4e8).collect();
        let (unit, _, _) = check_file(&ns, 0.4).expect("ns found");
        assert_eq!(unit.name, "nanoseconds");
    }
}
