//! The reaction wheels' units and signs: the speed change of each wheel against the impulse of
//! its motor-torque command over its inertia.
//!
//! Per wheel and time window (`WINDOW_S`): `J Δn = k ∫τ dt + c₀ ∫sign n dt + c₁ ∫n dt`, the
//! friction's Coulomb and viscous parts as free terms (their values are what identification
//! is for). `k` is 1 for clean data, a few percent off with a torque-scale error; rpm for rad/s
//! makes it 9.55, mNm for Nm 1/1000, a flipped speed or torque column −1 (which of the two,
//! the wheel's own data cannot tell). The platform's own
//! acceleration (the speed is relative to it) is left out: `J Δω` is 10⁻⁴ of the torque
//! impulses that decide. Windows across a gap in the rows are skipped.

use super::finding::{Finding, Mistake, times};
use super::units::{self, Verdict};
use crate::csv::columns;
use crate::data::{Dataset, files, median_period};
use crate::stats::NormalEquations;
use testbed_model::ModelConfig;

/// Window length, s: long enough for a torque impulse to stand out of the tachometer's noise.
const WINDOW_S: f64 = 5.0;
/// The fit must explain this fraction of the speed changes before its factor is believed (clean
/// data: above 0.95; a wheel that is barely used gives much less and is not judged).
const MIN_EXPLAINED: f64 = 0.8;
/// And the factor must be known to this relative standard error.
const MAX_RELATIVE_STDERR: f64 = 0.1;

/// One wheel's factor `k` (recorded speed change per SI speed change the command implies).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelFactor {
    pub k: f64,
    pub stderr: f64,
    pub explained: f64,
}

/// The wheels file, if a wheel's speed and torque disagree by a unit or a sign.
pub fn check(data: &Dataset, model: &ModelConfig) -> Option<Finding> {
    let j = model.wheels.inertia_kgm2;
    let factors: Vec<Option<WheelFactor>> = (0..3).map(|a| wheel_factor(data, a, j)).collect();
    // Group the wheels with the same mistake, so three wheels in rpm are one finding.
    let verdicts: Vec<Option<(Mistake, Vec<usize>)>> =
        factors.iter().map(|f| f.and_then(|f| judge(f.k))).collect();
    let (mistake, which) = verdicts.iter().flatten().next()?.clone();
    let axes: Vec<usize> = (0..3)
        .filter(|&a| {
            verdicts[a]
                .as_ref()
                .is_some_and(|(m, _)| same_kind(m, &mistake))
        })
        .collect();
    let names = columns::WHEELS;
    let columns: Vec<String> = which
        .iter()
        .flat_map(|&part| {
            axes.iter()
                .map(move |&a| names[1 + part * 3 + a].to_string())
        })
        .collect();
    let ks: Vec<String> = axes
        .iter()
        .filter_map(|&a| factors[a].map(|f| format!("{} {}", ["x", "y", "z"][a], times(f.k))))
        .collect();
    Some(Finding {
        file: data.source.join(files::WHEELS),
        columns,
        mistake,
        evidence: format!(
            "the speed changes are {} the commanded torque's impulse over the wheel inertia \
             {j:.3e} kg m²",
            ks.join(", ")
        ),
    })
}

/// The mistake a wheel's factor shows, and which of the file's parts (0 speed, 1 torque) it
/// concerns; `None` for physics.
fn judge(k: f64) -> Option<(Mistake, Vec<usize>)> {
    let size = k.abs();
    match units::classify(size, units::WHEEL_SPEED) {
        Verdict::Unit(u) if size > 1.0 => {
            return Some((
                Mistake::Units {
                    unit: u.name,
                    si: "rad/s",
                    factor: k,
                },
                vec![0],
            ));
        }
        Verdict::Si if k < 0.0 => return Some((Mistake::SignsDisagree, vec![0, 1])),
        Verdict::Si => return None,
        _ => {}
    }
    if let Verdict::Unit(u) = units::classify(1.0 / size, units::TORQUE) {
        return Some((
            Mistake::Units {
                unit: u.name,
                si: "Nm",
                factor: 1.0 / k,
            },
            vec![1],
        ));
    }
    Some((
        Mistake::Scale {
            si: "rad/s and Nm",
            factor: k,
        },
        vec![0, 1],
    ))
}

fn same_kind(a: &Mistake, b: &Mistake) -> bool {
    match (a, b) {
        (Mistake::Units { unit: x, .. }, Mistake::Units { unit: y, .. }) => x == y,
        _ => std::mem::discriminant(a) == std::mem::discriminant(b),
    }
}

/// The factor of wheel `axis`, if the record determines it (see the module documentation).
pub fn wheel_factor(data: &Dataset, axis: usize, inertia_kgm2: f64) -> Option<WheelFactor> {
    let rows = &data.wheels;
    if rows.len() < 3 {
        return None;
    }
    let period = median_period(rows.iter().map(|r| r.t_s));
    let mut normal = NormalEquations::new(3);
    let mut tss = 0.0;
    let mut start = 0;
    while start < rows.len() {
        let mut end = start;
        let mut gap = false;
        while end + 1 < rows.len() && rows[end].t_s - rows[start].t_s < WINDOW_S {
            gap |= rows[end + 1].t_s - rows[end].t_s > 3.0 * period;
            end += 1;
        }
        if end == start || rows[end].t_s - rows[start].t_s < 0.5 * WINDOW_S {
            break;
        }
        if !gap {
            let (mut impulse, mut coulomb, mut viscous) = (0.0, 0.0, 0.0);
            for k in start..end {
                let dt = rows[k + 1].t_s - rows[k].t_s;
                let n = rows[k].speed_rad_s[axis];
                impulse += rows[k].torque_nm[axis] * dt;
                coulomb += n.signum() * dt;
                viscous += n * dt;
            }
            let y = inertia_kgm2 * (rows[end].speed_rad_s[axis] - rows[start].speed_rad_s[axis]);
            normal.add(&[impulse, coulomb, viscous], y);
            tss += y * y;
        }
        start = end;
    }
    let fit = normal.solve()?;
    let explained = 1.0 - fit.rss / tss;
    let k = fit.theta[0];
    let stderr = fit.stderr()[0];
    (explained >= MIN_EXPLAINED && stderr <= MAX_RELATIVE_STDERR * k.abs()).then_some(WheelFactor {
        k,
        stderr,
        explained,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_are_judged_as_units_signs_or_physics() {
        assert_eq!(judge(1.0), None);
        assert_eq!(judge(0.93), None);
        assert!(matches!(judge(-1.0), Some((Mistake::SignsDisagree, _))));
        assert!(matches!(
            judge(9.5),
            Some((Mistake::Units { unit: "rpm", .. }, ref p)) if p == &vec![0]
        ));
        assert!(matches!(
            judge(1e-3),
            Some((Mistake::Units { unit: "mNm", .. }, ref p)) if p == &vec![1]
        ));
    }
}
