//! The units people export instead of the contract's SI ones, and how a measured factor is
//! matched to one of them.
//!
//! A factor is the recorded value over the SI value. It is matched to the unit whose factor is
//! nearest on a log scale, if within [`UNIT_TOLERANCE`]; a factor outside
//! [`PHYSICAL_BAND`] that matches no unit is still a gross mistake (no physical effect scales a
//! reading that much), reported as a scale of no known unit.

/// A unit instead of SI: its name and its factor (recorded value / SI value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    pub name: &'static str,
    pub factor: f64,
}

const DEG_PER_RAD: f64 = 180.0 / std::f64::consts::PI;

/// Body rates (SI rad/s).
pub const RATE: &[Unit] = &[
    Unit {
        name: "°/s",
        factor: DEG_PER_RAD,
    },
    Unit {
        name: "mrad/s",
        factor: 1e3,
    },
    Unit {
        name: "µrad/s",
        factor: 1e6,
    },
    Unit {
        name: "rpm",
        factor: 60.0 / (2.0 * std::f64::consts::PI),
    },
    Unit {
        name: "rev/s",
        factor: 1.0 / (2.0 * std::f64::consts::PI),
    },
    Unit {
        name: "°/h",
        factor: DEG_PER_RAD * 3600.0,
    },
];

/// Angles (SI rad).
pub const ANGLE: &[Unit] = &[
    Unit {
        name: "degrees",
        factor: DEG_PER_RAD,
    },
    Unit {
        name: "mrad",
        factor: 1e3,
    },
    Unit {
        name: "arcmin",
        factor: DEG_PER_RAD * 60.0,
    },
];

/// Flux density (SI tesla).
pub const FIELD: &[Unit] = &[
    Unit {
        name: "gauss",
        factor: 1e4,
    },
    Unit {
        name: "mG",
        factor: 1e7,
    },
    Unit {
        name: "µT",
        factor: 1e6,
    },
    Unit {
        name: "nT",
        factor: 1e9,
    },
];

/// Wheel speeds (SI rad/s).
pub const WHEEL_SPEED: &[Unit] = &[
    Unit {
        name: "rpm",
        factor: 60.0 / (2.0 * std::f64::consts::PI),
    },
    Unit {
        name: "°/s",
        factor: DEG_PER_RAD,
    },
    Unit {
        name: "rev/s",
        factor: 1.0 / (2.0 * std::f64::consts::PI),
    },
];

/// Wheel torques (SI Nm).
pub const TORQUE: &[Unit] = &[
    Unit {
        name: "mNm",
        factor: 1e3,
    },
    Unit {
        name: "µNm",
        factor: 1e6,
    },
];

/// Time stamps (SI s).
pub const TIME: &[Unit] = &[
    Unit {
        name: "milliseconds",
        factor: 1e3,
    },
    Unit {
        name: "microseconds",
        factor: 1e6,
    },
    Unit {
        name: "nanoseconds",
        factor: 1e9,
    },
];

/// A measured factor names a unit when within this ratio of the unit's factor. 1.35 takes in
/// the estimates' spread (a few percent of scale error, the sine's bend for angles read as
/// radians, soft iron) yet keeps the units apart: the closest pair above, rpm and °/s apart,
/// µT and mG, are 6× and 10× apart.
pub const UNIT_TOLERANCE: f64 = 1.35;

/// Factors within this band of 1 are physics (a scale error, a hard iron, a misread
/// configuration), never a data mistake: the largest physical scale errors are tens of
/// percent, while the nearest unit factor, 1/(2π) for rev/s, is 6.3× away.
pub const PHYSICAL_BAND: (f64, f64) = (1.0 / 3.0, 3.0);

/// What a measured factor says: SI, a unit, or a gross factor of no unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    Si,
    Unit(Unit),
    Unknown,
}

/// Classify `factor` (recorded / SI, > 0) against `units`. Within [`PHYSICAL_BAND`] it is SI
/// unless a unit is nearer (none is, for the tables above).
pub fn classify(factor: f64, units: &[Unit]) -> Verdict {
    classify_within(factor, units, PHYSICAL_BAND, UNIT_TOLERANCE)
}

/// [`classify`] with another band of physical factors and another tolerance (the field's band
/// is wider, a hard iron and the building's steel can double the lab field; a sample period
/// may differ from the configured one by several times, its units by 1000×).
pub fn classify_within(factor: f64, units: &[Unit], band: (f64, f64), tolerance: f64) -> Verdict {
    if !(factor.is_finite() && factor > 0.0) {
        return Verdict::Unknown;
    }
    if factor >= band.0 && factor <= band.1 {
        return Verdict::Si;
    }
    let nearest = units.iter().min_by(|a, b| {
        let da = (factor / a.factor).ln().abs();
        let db = (factor / b.factor).ln().abs();
        da.total_cmp(&db)
    });
    match nearest {
        Some(u) if (factor / u.factor).ln().abs() <= tolerance.ln() => Verdict::Unit(*u),
        _ => Verdict::Unknown,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_name_their_units_and_physics_stays_si() {
        assert_eq!(classify(1.0, RATE), Verdict::Si);
        assert_eq!(classify(1.05, RATE), Verdict::Si);
        assert_eq!(classify(0.5, RATE), Verdict::Si);
        let Verdict::Unit(u) = classify(57.0, RATE) else {
            panic!("°/s not found")
        };
        assert_eq!(u.name, "°/s");
        let Verdict::Unit(u) = classify(9.3, WHEEL_SPEED) else {
            panic!("rpm not found")
        };
        assert_eq!(u.name, "rpm");
        let Verdict::Unit(u) = classify(1.1e4, FIELD) else {
            panic!("gauss not found")
        };
        assert_eq!(u.name, "gauss");
        assert_eq!(classify(20.0, RATE), Verdict::Unknown);
        assert_eq!(classify(f64::NAN, RATE), Verdict::Unknown);
    }
}
