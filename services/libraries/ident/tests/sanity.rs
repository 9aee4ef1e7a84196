//! Data sanity before science: every export mistake, made on clean simulated records of several
//! seeds, is refused as that mistake with its file and columns and no cause is named; clean
//! records, with and without physical effects (library causes and effects outside the library),
//! pass untouched.

mod common;
use common::*;
use std::f64::consts::PI;
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::sanity::{self, Finding, Mistake};
use testbed_ident::{DataError, Dataset, IdentError, identify};

const SEEDS: [u64; 3] = [11, 12, 13];
const DURATION_S: f64 = 300.0;

/// A mistake made on a clean record, and what the report must say.
struct Case {
    label: &'static str,
    file: &'static str,
    columns: &'static [&'static str],
    expect: Expect,
    make: fn(&mut Dataset, &Dataset),
}

/// The mistake the report must name.
#[derive(Debug, Clone, Copy)]
enum Expect {
    Unit(&'static str),
    Flipped,
    SignsDisagree,
    /// Exchanged columns, the mapping containing this.
    Exchanged(&'static str),
    OtherRun,
}

impl Expect {
    fn matches(self, m: &Mistake) -> bool {
        match (self, m) {
            (Expect::Unit(name), Mistake::Units { unit, .. }) => *unit == name,
            (Expect::Flipped, Mistake::SignFlipped) => true,
            (Expect::SignsDisagree, Mistake::SignsDisagree) => true,
            (Expect::Exchanged(part), Mistake::Permuted { mapping }) => mapping.contains(part),
            (Expect::OtherRun, Mistake::OtherRun) => true,
            _ => false,
        }
    }
}

fn case(
    label: &'static str,
    file: &'static str,
    columns: &'static [&'static str],
    expect: Expect,
    make: fn(&mut Dataset, &Dataset),
) -> Case {
    Case {
        label,
        file,
        columns,
        expect,
        make,
    }
}

fn unit(name: &'static str) -> impl Fn(&Mistake) -> bool {
    move |m| Expect::Unit(name).matches(m)
}

/// A run of another programme (other slews, steps and seed), on the same clock.
fn other_run() -> Dataset {
    let options = ExperimentOptions {
        duration_s: DURATION_S,
        seed: 77,
        heading_amplitude_deg: 35.0,
        heading_rate_deg_s: 0.35,
        tilt_deg: 5.0,
        tilt_dwell_s: 20.0,
        ..ExperimentOptions::default()
    };
    experiment::run(&nominal(), &options)
        .expect("the other run simulates")
        .0
}

const RATES: &[&str] = &["wx", "wy", "wz"];
const FIELD: &[&str] = &["bx", "by", "bz"];
const TILTS: &[&str] = &["tilt_x", "tilt_y"];

fn cases() -> Vec<Case> {
    use Expect::*;
    let (gyro, mag, tilt, wheels) = (
        "gyro.csv",
        "magnetometer.csv",
        "inclinometer.csv",
        "wheels.csv",
    );
    vec![
        case("gyro in °/s", gyro, RATES, Unit("°/s"), |d, _| {
            d.gyro.iter_mut().for_each(|r| r.rate_rad_s *= 180.0 / PI)
        }),
        case("gyro in mrad/s", gyro, RATES, Unit("mrad/s"), |d, _| {
            d.gyro.iter_mut().for_each(|r| r.rate_rad_s *= 1e3)
        }),
        case("gyro wy flipped", gyro, &["wy"], Flipped, |d, _| {
            d.gyro.iter_mut().for_each(|r| r.rate_rad_s.y *= -1.0)
        }),
        case("gyro wz flipped", gyro, &["wz"], Flipped, |d, _| {
            d.gyro.iter_mut().for_each(|r| r.rate_rad_s.z *= -1.0)
        }),
        case(
            "gyro wx, wy swapped",
            gyro,
            &["wx", "wy"],
            Exchanged("wx holds wy's"),
            |d, _| d.gyro.iter_mut().for_each(|r| r.rate_rad_s.swap_rows(0, 1)),
        ),
        case(
            "gyro wy, wz swapped",
            gyro,
            &["wy", "wz"],
            Exchanged("wz holds wy's"),
            |d, _| d.gyro.iter_mut().for_each(|r| r.rate_rad_s.swap_rows(1, 2)),
        ),
        case("gyro of another run", gyro, RATES, OtherRun, |d, other| {
            d.gyro = other.gyro.clone()
        }),
        case("field in gauss", mag, FIELD, Unit("gauss"), |d, _| {
            d.magnetometer.iter_mut().for_each(|r| r.field_t *= 1e4)
        }),
        case("field in nT", mag, FIELD, Unit("nT"), |d, _| {
            d.magnetometer.iter_mut().for_each(|r| r.field_t *= 1e9)
        }),
        case("field by flipped", mag, &["by"], Flipped, |d, _| {
            d.magnetometer.iter_mut().for_each(|r| r.field_t.y *= -1.0)
        }),
        case(
            "field bx, bz swapped",
            mag,
            &["bx", "bz"],
            Exchanged("bx holds bz's"),
            |d, _| {
                d.magnetometer
                    .iter_mut()
                    .for_each(|r| r.field_t.swap_rows(0, 2))
            },
        ),
        case("field of another run", mag, FIELD, OtherRun, |d, other| {
            d.magnetometer = other.magnetometer.clone()
        }),
        case("tilts in degrees", tilt, TILTS, Unit("degrees"), |d, _| {
            let to_degrees = |x: f64| x * 180.0 / PI;
            d.inclinometer
                .iter_mut()
                .for_each(|r| r.tilt_rad = r.tilt_rad.map(to_degrees))
        }),
        case("tilt_x flipped", tilt, &["tilt_x"], Flipped, |d, _| {
            d.inclinometer
                .iter_mut()
                .for_each(|r| r.tilt_rad[0] *= -1.0)
        }),
        case(
            "tilts swapped",
            tilt,
            TILTS,
            Exchanged("tilt_x holds tilt_y's"),
            |d, _| {
                d.inclinometer
                    .iter_mut()
                    .for_each(|r| r.tilt_rad.swap(0, 1))
            },
        ),
        case("tilts of another run", tilt, TILTS, OtherRun, |d, other| {
            d.inclinometer = other.inclinometer.clone()
        }),
        case(
            "wheel speeds in rpm",
            wheels,
            &["speed_x", "speed_y", "speed_z"],
            Unit("rpm"),
            |d, _| {
                d.wheels
                    .iter_mut()
                    .for_each(|r| r.speed_rad_s *= 60.0 / (2.0 * PI))
            },
        ),
        case(
            "wheel torques in mNm",
            wheels,
            &["torque_x", "torque_y", "torque_z"],
            Unit("mNm"),
            |d, _| d.wheels.iter_mut().for_each(|r| r.torque_nm *= 1e3),
        ),
        case(
            "wheel speed_y flipped",
            wheels,
            &["speed_y", "torque_y"],
            SignsDisagree,
            |d, _| d.wheels.iter_mut().for_each(|r| r.speed_rad_s.y *= -1.0),
        ),
        case(
            "all time stamps in ms",
            gyro,
            &["t_s"],
            Unit("milliseconds"),
            |d, _| {
                d.gyro.iter_mut().for_each(|r| r.t_s *= 1e3);
                d.inclinometer.iter_mut().for_each(|r| r.t_s *= 1e3);
                d.magnetometer.iter_mut().for_each(|r| r.t_s *= 1e3);
                d.wheels.iter_mut().for_each(|r| r.t_s *= 1e3);
            },
        ),
        case(
            "magnetometer time stamps in ns",
            mag,
            &["t_s"],
            Unit("nanoseconds"),
            |d, _| d.magnetometer.iter_mut().for_each(|r| r.t_s *= 1e9),
        ),
    ]
}

/// Identify `data` and return the data error it must stop with.
fn refused(label: &str, data: &Dataset) -> Finding {
    match identify(data, &nominal(), &options()) {
        Err(IdentError::Data(DataError::Implausible(f))) => *f,
        Err(e) => panic!("{label}: another error: {e}"),
        Ok(id) => panic!("{label}: accepted, verdict {}", id.report.verdict),
    }
}

#[test]
fn every_export_mistake_is_refused_naming_its_file_columns_and_factor() {
    let other = other_run();
    for seed in SEEDS {
        let clean = experiment_data(&nominal(), seed, DURATION_S);
        for case in cases() {
            let mut data = clean.clone();
            (case.make)(&mut data, &other);
            let label = format!("{} (seed {seed})", case.label);
            let f = refused(&label, &data);
            let text = DataError::Implausible(Box::new(f.clone())).to_string();
            println!("{label}: {text}");
            assert!(f.file.ends_with(case.file), "{label}: {text}");
            assert_eq!(f.columns, case.columns, "{label}: {text}");
            assert!(case.expect.matches(&f.mistake), "{label}: {text}");
            assert!(text.contains(case.file) && text.contains("no cause is named"));
        }
    }
}

#[test]
fn the_factor_found_is_the_units() {
    let clean = experiment_data(&nominal(), 21, DURATION_S);
    let mut data = clean.clone();
    data.gyro
        .iter_mut()
        .for_each(|r| r.rate_rad_s *= 180.0 / PI);
    let f = refused("°/s", &data);
    let Mistake::Units { factor, .. } = f.mistake else {
        panic!("{f}")
    };
    // Against the field's direction only the gyro's 1 % or so of noise-limited scale is left.
    assert!((factor / (180.0 / PI) - 1.0).abs() < 0.05, "{f}");
    let mut data = clean;
    data.wheels
        .iter_mut()
        .for_each(|r| r.speed_rad_s.x *= 60.0 / (2.0 * PI));
    let f = refused("rpm on one wheel", &data);
    assert_eq!(f.columns, ["speed_x"], "{f}");
    let Mistake::Units { factor, .. } = f.mistake else {
        panic!("{f}")
    };
    assert!((factor / (60.0 / (2.0 * PI)) - 1.0).abs() < 0.02, "{f}");
}

#[test]
fn small_tilts_in_degrees_are_found_against_the_gyro() {
    // Tilts of 0.3°: in degrees they stay within the sensor's range as radians, so only the
    // gyro and the field say they turn 57× too fast.
    let options = ExperimentOptions {
        duration_s: DURATION_S,
        seed: 31,
        tilt_deg: 0.3,
        ..ExperimentOptions::default()
    };
    let mut data = experiment::run(&nominal(), &options).expect("runs").0;
    data.inclinometer
        .iter_mut()
        .for_each(|r| r.tilt_rad = r.tilt_rad.map(|x| x * 180.0 / PI));
    let f = refused("small tilts in degrees", &data);
    assert!(f.file.ends_with("inclinometer.csv"), "{f}");
    assert!(unit("degrees")(&f.mistake), "{f}");
}

#[test]
fn a_gyro_flip_is_found_with_the_inclinometer_alone() {
    // No magnetometer: a flip of one gyro axis (an improper permutation) cannot be the
    // inclinometer's, so it is named the gyro's.
    let mut data = experiment_data(&nominal(), 41, DURATION_S);
    data.magnetometer.clear();
    data.gyro.iter_mut().for_each(|r| r.rate_rad_s.x *= -1.0);
    let f = refused("wx flipped, no magnetometer", &data);
    assert!(f.file.ends_with("gyro.csv"), "{f}");
    assert_eq!(f.columns, ["wx"], "{f}");
    assert_eq!(f.mistake, Mistake::SignFlipped, "{f}");
}

/// Physical effects, of the library and outside it, that must never be called data mistakes.
const PHYSICS: &[&str] = &[
    "",
    "[effects.com_offset]\nr_m = [2.5e-6, -1.5e-6, -1.0e-6]\n",
    "[effects.gyro_scale]\nppm = [10000.0, -10000.0, 10000.0]\n",
    "[effects.magnetic_disturbance]\nhard_iron_gauss = [0.3, -0.2, 0.25]\n",
    "[effects.soft_iron]\nmatrix = [[0.1, 0.03, 0.0], [0.03, -0.05, 0.02], [0.0, 0.02, 0.08]]\n\
     [effects.magnetic_disturbance]\nhard_iron_gauss = [0.2, 0.1, -0.2]\n",
    "[effects.gyro_misalignment]\nangles_rad = [1e-3, -1e-3, 1e-3]\n\
     [effects.inclinometer_scale]\nppm = [2.0e4, -1.0e4]\n\
     [effects.inclinometer_bias]\noffset_rad = [8.7e-4, -5.2e-4]\n",
    "[effects.wheel_torque_scale]\nscale = [0.9, 1.1, 0.95]\n[effects.actuator_delay]\ndelay_s = 0.15\n",
    "[effects.heading_torque]\ncos_nm = [2e-3, -1e-3, 0.0]\nsin_nm = [0.0, 1.5e-3, 1e-3]\n\
     [effects.wheel_drag]\nquadratic_nm_per_rad2_s2 = [2e-7, 2e-7, 2e-7]\n",
    "[effects.com_drift]\nrate_m_per_s = [2e-9, -1e-9, 0.0]\n[effects.earth_rate]\nlatitude_deg = 43.88\n",
];

#[test]
fn clean_records_pass_untouched_with_and_without_physical_effects() {
    // The margins: the least fraction of a sensor's changes the recorded gyro explains (the
    // thresholds are 0.85 and 0.70) and the largest scale `κ` off 1 (physics within 1/3–3).
    let (mut least_explained, mut worst_kappa) = (1.0f64, 1.0f64);
    for (i, effects) in PHYSICS.iter().enumerate() {
        let truth = truth(effects);
        for seed in [1, 2, 3] {
            let data = experiment_data(&truth, seed + 10 * i as u64, DURATION_S);
            let result = sanity::check(&data, &nominal());
            assert!(
                result.is_ok(),
                "effects {effects:?}, seed {seed}: {}",
                result.err().map(|e| e.to_string()).unwrap_or_default()
            );
            for f in sanity::rotation_fits(&data, &nominal()) {
                assert!(
                    f.excited,
                    "{effects:?} seed {seed}: {:?} not excited",
                    f.sensor
                );
                let id = f.identity();
                least_explained = least_explained.min(1.0 - id.unexplained);
                if (id.kappa.ln()).abs() > worst_kappa.ln().abs() {
                    worst_kappa = id.kappa;
                }
                // The identity is the best hypothesis, by far.
                assert_eq!(
                    f.best().hypothesis,
                    id.hypothesis,
                    "{effects:?} seed {seed}"
                );
            }
        }
    }
    println!("least explained {least_explained:.4}, worst κ {worst_kappa:.4}");
    // Stated bound: clean records stay far from every threshold.
    assert!(least_explained > 0.95, "{least_explained}");
    assert!((worst_kappa.ln()).abs() < 2f64.ln(), "{worst_kappa}");
}

#[test]
fn a_record_without_motion_is_not_judged() {
    // Held level at heading 0 with the wheels idle: nothing to compare, nothing refused, even
    // with a gyro axis flipped (there is no evidence either way).
    let options = ExperimentOptions {
        duration_s: 120.0,
        seed: 51,
        heading_amplitude_deg: 0.0,
        tilt_deg: 0.0,
        wheel_momentum_nms: [0.0; 3],
        ..ExperimentOptions::default()
    };
    let mut data = experiment::run(&nominal(), &options).expect("runs").0;
    assert!(sanity::check(&data, &nominal()).is_ok());
    data.gyro.iter_mut().for_each(|r| r.rate_rad_s.x *= -1.0);
    let fits = sanity::rotation_fits(&data, &nominal());
    assert!(fits.iter().all(|f| !f.excited), "{fits:?}");
    assert!(sanity::check(&data, &nominal()).is_ok());
}

#[test]
fn lags_between_the_clocks_and_noisier_sensors_pass() {
    // Another simulator's habits: the vector sensors stamped 0.3 s late, the magnetometer five
    // times noisier, the inclinometer at 5 Hz. Physics, not mistakes.
    let noisy = truth(
        "[magnetometer]\nnoise_gauss = [3.5e-3, 1.8e-3, 2.8e-3]\n\
         [inclinometer]\nrate_hz = 5.0\n\
         [effects.magnetic_disturbance]\nhard_iron_gauss = [0.3, -0.2, 0.25]\n",
    );
    for seed in [61, 62, 63] {
        let mut data = experiment_data(&noisy, seed, DURATION_S);
        data.inclinometer.iter_mut().for_each(|r| r.t_s += 0.3);
        data.magnetometer.iter_mut().for_each(|r| r.t_s += 0.3);
        let result = sanity::check(&data, &nominal());
        assert!(
            result.is_ok(),
            "seed {seed}: {}",
            result.err().map(|e| e.to_string()).unwrap_or_default()
        );
        for f in sanity::rotation_fits(&data, &nominal()) {
            println!(
                "seed {seed} {:?}: explained {:.4}, κ {:.3}, motion/noise {:.0}",
                f.sensor,
                1.0 - f.identity().unexplained,
                f.identity().kappa,
                f.motion_to_noise
            );
        }
    }
}
