//! Which file is wrong, from the gyro's fits against each vector sensor ([`super::rotation`]).
//!
//! Each sensor alone cannot tell a mistake of the gyro from its own: a gyro column flipped and
//! a field column flipped both make the field turn the wrong way. Two sensors can: a gyro
//! mistake shows the same way in both, a sensor's only in its own. The order of the judgement:
//!
//! 0. **Tilt units**: tilts the gyro does not explain as radians but does read in degrees (or
//!    mrad, arcmin) are in that unit (small tilts in degrees stay within the range as radians).
//! 1. **Another run**: a sensor that moved (it is excited) but whose changes the gyro explains
//!    less than [`UNRELATED_BELOW`] under every hypothesis does not belong with the gyro. If the
//!    other sensor does belong, it is that sensor; if neither does, the gyro.
//! 2. **Units**: the field sees the gyro's scale whatever its own unit (it is normalised), so
//!    `1/κ` of the field's fit is the gyro's factor; the inclinometer's `κ` over the field's is
//!    the inclinometer's. Without a magnetometer a `κ` below 1 is the gyro's (its rates too
//!    large), above 1 the inclinometer's (angles exported in larger units than radians are far
//!    more common than rates in smaller units than rad/s).
//! 3. **Axes**: the hypothesis best for all the consistent sensors together, when it is not
//!    the identity and the identity leaves [`REFUSAL_RATIO`] times as much unexplained, is the
//!    gyro's mistake; a sensor that refuses the identity while the other accepts it has its own
//!    (its columns' mistake `T` is `±S`, see [`SignedPermutation::sensor_side`]).
//!
//! Only gross failures count: a few percent of scale error, a misalignment, a hard or soft iron,
//! a lag between the clocks leave the identity explaining far more than any other hypothesis,
//! and `κ` within [`units::PHYSICAL_BAND`].

use super::axes::SignedPermutation;
use super::finding::{Finding, Mistake, times};
use super::rotation::{HypothesisFit, Sensor, SensorFit, WINDOW_S};
use super::units::{self, Unit, Verdict};
use super::value_columns;
use crate::csv::columns;
use crate::data::files;
use std::path::Path;

/// Below this explained fraction under the best hypothesis, an excited sensor's motion is not
/// the gyro's. Clean data explain above 0.96 (noise alone leaves at most 1/25 at the excitation
/// threshold; soft iron of 10 % and a lag of half a second a percent more), a channel of another
/// run of a similar programme up to half (its slews and steps come at other times, but some
/// motion is alike).
pub const UNRELATED_BELOW: f64 = 0.7;
/// A sensor is consistent with the gyro (its `κ` and hypotheses are believed) from this
/// explained fraction on.
pub const CONSISTENT_FROM: f64 = 0.85;
/// A hypothesis other than the identity is a mistake only when the identity leaves this many
/// times as much unexplained: a flipped or exchanged axis with any motion about it leaves
/// several times the whole signal of that axis, physical effects a few percent.
pub const REFUSAL_RATIO: f64 = 10.0;
/// `κ` is believed to this relative standard error.
const KAPPA_RELATIVE_STDERR: f64 = 0.1;

fn file_of(sensor: Sensor) -> &'static str {
    match sensor {
        Sensor::Inclinometer => files::INCLINOMETER,
        Sensor::Magnetometer => files::MAGNETOMETER,
    }
}

fn name_of(sensor: Sensor) -> &'static str {
    match sensor {
        Sensor::Inclinometer => "inclinometer",
        Sensor::Magnetometer => "magnetometer",
    }
}

fn sensor_columns(sensor: Sensor) -> [String; 3] {
    match sensor {
        Sensor::Inclinometer => {
            let c = value_columns(columns::INCLINOMETER);
            [c[0].clone(), c[1].clone(), "(the computed vertical)".into()]
        }
        Sensor::Magnetometer => {
            let c = value_columns(columns::MAGNETOMETER);
            [c[0].clone(), c[1].clone(), c[2].clone()]
        }
    }
}

fn gyro_columns() -> [String; 3] {
    let c = value_columns(columns::GYRO);
    [c[0].clone(), c[1].clone(), c[2].clone()]
}

fn explained(f: &HypothesisFit) -> f64 {
    1.0 - f.unexplained
}

/// The first mistake the fits show, if any; `tilt_units` are the inclinometer's fits with its
/// angles read in other units.
pub fn judge(dir: &Path, fits: &[SensorFit], tilt_units: &[(Unit, SensorFit)]) -> Option<Finding> {
    let excited: Vec<&SensorFit> = fits.iter().filter(|f| f.excited).collect();
    if excited.is_empty() {
        return None;
    }
    tilt_unit(dir, &excited, tilt_units)
        .or_else(|| other_run(dir, &excited))
        .or_else(|| units_of(dir, &excited))
        .or_else(|| axes_of(dir, &excited))
}

/// The inclinometer's angles in another unit: as recorded the gyro does not explain them, read
/// in that unit it does (with `κ` of SI, under the identity).
fn tilt_unit(
    dir: &Path,
    excited: &[&SensorFit],
    tilt_units: &[(Unit, SensorFit)],
) -> Option<Finding> {
    let recorded = excited.iter().find(|f| f.sensor == Sensor::Inclinometer)?;
    if explained(recorded.best()) >= CONSISTENT_FROM {
        return None;
    }
    let (unit, fit) = tilt_units.iter().find(|(_, f)| {
        let id = f.identity();
        f.excited
            && explained(id) >= CONSISTENT_FROM
            && units::classify(id.kappa, units::ANGLE) == Verdict::Si
    })?;
    Some(Finding {
        file: dir.join(files::INCLINOMETER),
        columns: value_columns(columns::INCLINOMETER),
        mistake: Mistake::Units {
            unit: unit.name,
            si: "radians",
            factor: unit.factor * fit.identity().kappa,
        },
        evidence: format!(
            "read as radians the gyro-integrated rotation explains {:.0} % of the tilt changes, \
             read as {} {:.1} %",
            100.0 * explained(recorded.best()),
            unit.name,
            100.0 * explained(fit.identity())
        ),
    })
}

fn other_run(dir: &Path, excited: &[&SensorFit]) -> Option<Finding> {
    let unrelated: Vec<&&SensorFit> = excited
        .iter()
        .filter(|f| explained(f.best()) < UNRELATED_BELOW)
        .collect();
    let first = unrelated.first()?;
    let consistent: Vec<&&SensorFit> = excited
        .iter()
        .filter(|f| explained(f.best()) >= CONSISTENT_FROM)
        .collect();
    let said = |f: &SensorFit| {
        format!(
            "{:.0} % of the {}'s changes",
            100.0 * explained(f.best()),
            name_of(f.sensor)
        )
    };
    if let Some(good) = consistent.first() {
        return Some(Finding {
            file: dir.join(file_of(first.sensor)),
            columns: sensor_columns(first.sensor)
                .into_iter()
                .filter(|c| !c.starts_with('('))
                .collect(),
            mistake: Mistake::OtherRun,
            evidence: format!(
                "the gyro-integrated rotation explains at best {} over {:.0}-s windows where it \
                 moved ({:.0}× its noise), against {}",
                said(first),
                WINDOW_S,
                first.motion_to_noise,
                said(good)
            ),
        });
    }
    if unrelated.len() < excited.len() {
        return None;
    }
    let alternative = if excited.len() == 1 {
        format!(", or {} is", file_of(first.sensor))
    } else {
        String::new()
    };
    Some(Finding {
        file: dir.join(files::GYRO),
        columns: gyro_columns().to_vec(),
        mistake: Mistake::OtherRun,
        evidence: format!(
            "its integrated rotation explains at best {} where they moved{alternative}",
            excited
                .iter()
                .map(|f| said(f))
                .collect::<Vec<_>>()
                .join(" and ")
        ),
    })
}

/// A sensor's `κ` under its best hypothesis, if consistent and precise.
fn kappa(f: &SensorFit) -> Option<f64> {
    let best = f.best();
    (explained(best) >= CONSISTENT_FROM
        && best.kappa > 0.0
        && best.kappa_stderr <= KAPPA_RELATIVE_STDERR * best.kappa)
        .then_some(best.kappa)
}

fn units_of(dir: &Path, excited: &[&SensorFit]) -> Option<Finding> {
    let of = |s: Sensor| {
        excited
            .iter()
            .find(|f| f.sensor == s)
            .and_then(|f| kappa(f))
    };
    let (tilt, field) = (of(Sensor::Inclinometer), of(Sensor::Magnetometer));
    // The gyro's factor: recorded rate over SI rate.
    let gyro_factor = match (tilt, field) {
        (_, Some(k)) => Some(1.0 / k),
        (Some(k), None) if k < 1.0 => Some(1.0 / k),
        _ => None,
    };
    if let Some(g) = gyro_factor {
        let seen = match (tilt, field) {
            (Some(t), Some(m)) => format!(
                "the gyro-integrated rotation is {} the magnetometer's and {} the \
                 inclinometer's",
                times(1.0 / m),
                times(1.0 / t)
            ),
            (_, Some(m)) => format!(
                "the gyro-integrated rotation is {} the magnetometer's",
                times(1.0 / m)
            ),
            (Some(t), None) => format!(
                "the gyro-integrated rotation is {} the inclinometer's",
                times(1.0 / t)
            ),
            _ => String::new(),
        };
        let mistake = match units::classify(g, units::RATE) {
            Verdict::Si => None,
            Verdict::Unit(u) => Some(Mistake::Units {
                unit: u.name,
                si: "rad/s",
                factor: g,
            }),
            Verdict::Unknown => Some(Mistake::Scale {
                si: "rad/s",
                factor: g,
            }),
        };
        if let Some(mistake) = mistake {
            return Some(Finding {
                file: dir.join(files::GYRO),
                columns: gyro_columns().to_vec(),
                mistake,
                evidence: seen,
            });
        }
    }
    let tilt_factor = match (tilt, field) {
        (Some(t), Some(m)) => t / m,
        (Some(t), None) if t > 1.0 => t,
        _ => return None,
    };
    let mistake = match units::classify(tilt_factor, units::ANGLE) {
        Verdict::Si => return None,
        Verdict::Unit(u) => Mistake::Units {
            unit: u.name,
            si: "radians",
            factor: tilt_factor,
        },
        Verdict::Unknown => Mistake::Scale {
            si: "radians",
            factor: tilt_factor,
        },
    };
    Some(Finding {
        file: dir.join(files::INCLINOMETER),
        columns: value_columns(columns::INCLINOMETER),
        mistake,
        evidence: format!(
            "the inclinometer's tilt changes are {} what the gyro-integrated rotation{} gives",
            times(tilt_factor),
            if field.is_some() {
                ", checked against the magnetometer,"
            } else {
                ""
            }
        ),
    })
}

fn axes_of(dir: &Path, excited: &[&SensorFit]) -> Option<Finding> {
    let consistent: Vec<&&SensorFit> = excited
        .iter()
        .filter(|f| explained(f.best()) >= CONSISTENT_FROM)
        .collect();
    if consistent.is_empty() {
        return None;
    }
    // The hypothesis best for all together: the sum of their unexplained fractions.
    let joint = |h: &SignedPermutation| -> f64 {
        consistent
            .iter()
            .map(|f| f.fit_of(h).map_or(1.0, |x| x.unexplained))
            .sum()
    };
    let all = SignedPermutation::all();
    let best = *all
        .iter()
        .min_by(|a, b| joint(a).total_cmp(&joint(b)))
        .unwrap_or(&SignedPermutation::IDENTITY);
    let good_for_all = consistent.iter().all(|f| {
        f.fit_of(&best)
            .is_some_and(|x| explained(x) >= CONSISTENT_FROM)
    });
    let refused = |f: &SensorFit, h: &SignedPermutation| {
        let at = f.fit_of(h).map_or(0.0, |x| x.unexplained);
        f.identity().unexplained >= REFUSAL_RATIO * at && !h.is_identity()
    };
    let describe_rates = |f: &SensorFit, h: &SignedPermutation| {
        format!(
            "the {} explains {:.1} % of its changes with that, {:.1} % as recorded",
            name_of(f.sensor),
            100.0 * f.fit_of(h).map_or(0.0, explained),
            100.0 * explained(f.identity())
        )
    };
    if good_for_all
        && !best.is_identity()
        && joint(&SignedPermutation::IDENTITY) >= REFUSAL_RATIO * joint(&best)
    {
        // The recorded rate is `best⁻¹` applied to the true one.
        let mistake = best.inverse();
        let single = consistent.len() == 1;
        // With one sensor, its own columns could be at fault instead (when `best` is proper).
        let alternative = if single {
            let s = consistent[0].sensor;
            mistake_of_sensor(s, &best)
                .map(|(cols, m)| {
                    format!(
                        "; or {} {} {}",
                        file_of(s),
                        cols.join(", "),
                        m.phrase(cols.len() > 1)
                    )
                })
                .unwrap_or_default()
        } else {
            String::new()
        };
        let (cols, m) = mistake.describe(&gyro_columns())?;
        return Some(Finding {
            file: dir.join(files::GYRO),
            columns: cols,
            mistake: m,
            evidence: format!(
                "with the columns mended, the gyro-integrated rotation turns the sensors' \
                 directions as they turned: {}{alternative}",
                consistent
                    .iter()
                    .map(|f| describe_rates(f, &best))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        });
    }
    // A sensor that refuses the identity while another accepts it.
    for f in &consistent {
        let own = f.best().hypothesis;
        let others_accept = consistent.iter().any(|o| {
            o.sensor != f.sensor
                && explained(o.identity()) >= CONSISTENT_FROM
                && !refused(o, &o.best().hypothesis)
        });
        if refused(f, &own) && others_accept {
            let (cols, m) = mistake_of_sensor(f.sensor, &own)?;
            return Some(Finding {
                file: dir.join(file_of(f.sensor)),
                columns: cols,
                mistake: m,
                evidence: format!(
                    "{}, while the other sensor agrees with the gyro as recorded",
                    describe_rates(f, &own)
                ),
            });
        }
    }
    None
}

/// The mistake of a sensor's columns that makes it move as under the gyro hypothesis `h`.
fn mistake_of_sensor(sensor: Sensor, h: &SignedPermutation) -> Option<(Vec<String>, Mistake)> {
    let possible = h.sensor_side().into_iter().find(|t| match sensor {
        // The inclinometer's vertical is computed from the two tilts: only they can be
        // exchanged or flipped.
        Sensor::Inclinometer => t.perm[2] == 2 && t.sign[2] > 0.0,
        Sensor::Magnetometer => true,
    })?;
    possible.describe(&sensor_columns(sensor))
}
