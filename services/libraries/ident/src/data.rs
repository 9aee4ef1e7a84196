//! Measured data in memory: one time series per device, SI units, body axes, as the
//! measured-data CSV contract (`docs/measured-data.md`) defines them; the conversion from and to
//! the CSV files' plain records ([`crate::csv`]); and the same data aligned on the gyro's clock
//! for the fits.
//!
//! Interpretation of the contract used throughout identification:
//! * every file's `t_s` is on one common clock (any origin);
//! * a gyro row is the body rate at `t_s` (the device model's instantaneous reading);
//! * a `wheels.csv` row's `torque_*` is the motor-torque command issued at `t_s` and held until
//!   the next row (zero-order hold, as the controller issues it); its `speed_*` is the
//!   tachometer reading at `t_s`;
//! * a `cmg.csv` row's `rate_cmd_*` is likewise held until the next row;
//! * a `thrusters.csv` row's `on_time_<i>_s` is the electrical on-time of thruster i's valve
//!   commanded at `t_s` for the period that starts there (the model's valve delays and minimum
//!   on-time turn it into thrust, `docs/thrusters.md`); a missing file means no thrusters.

use crate::csv::{
    CmgRecord, FieldRecord, GyroRecord, Records, ThrusterRecord, TiltRecord, WheelRecord, columns,
};
use crate::error::DataError;
use ipc_types::topic;
use nalgebra::{Vector3, Vector4};
use std::path::PathBuf;
use testbed_model::thruster_config::THRUSTER_COUNT;

/// Shortest record identification accepts, s of gyro data.
pub const MIN_DURATION_S: f64 = 60.0;

/// The time block that `t_s` falls in, blocks of `block_s` from 0 on the data's clock (one
/// block with `block_s` infinite): the units of the held-out split and of the
/// cross-validation's folds.
pub fn block_index(t_s: f64, block_s: f64) -> usize {
    (t_s / block_s).floor().max(0.0) as usize
}

/// One gyro row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroRow {
    pub t_s: f64,
    /// Measured body rate (bias and noise included), body axes, rad/s.
    pub rate_rad_s: Vector3<f64>,
}

/// One inclinometer row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltRow {
    pub t_s: f64,
    /// `[θ, φ]`: tilt of body X and body Y against the level plane, rad (paper eq. 2).
    pub tilt_rad: [f64; 2],
}

/// One magnetometer row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldRow {
    pub t_s: f64,
    /// Measured flux density, body axes, tesla.
    pub field_t: Vector3<f64>,
}

/// One reaction-wheel row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelRow {
    pub t_s: f64,
    /// Wheel speeds relative to the platform, about body X, Y, Z, rad/s.
    pub speed_rad_s: Vector3<f64>,
    /// Motor torque command on each wheel, Nm (the platform feels the opposite).
    pub torque_nm: Vector3<f64>,
}

/// One CMG row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CmgRow {
    pub t_s: f64,
    /// Gimbal angles, rad.
    pub gimbal_rad: Vector4<f64>,
    /// Commanded gimbal rates, rad/s.
    pub rate_cmd_rad_s: Vector4<f64>,
}

/// One thruster row: the valve on-times applied for the command period starting at `t_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrusterRow {
    pub t_s: f64,
    /// Electrical on-time of each thruster's valve from `t_s`, s (0: shut); thruster `2a` gives
    /// `+` torque about body axis `a`, `2a + 1` `−` torque in the default layout.
    pub on_time_s: [f64; THRUSTER_COUNT],
}

/// Where a record's rows came from, for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Origin {
    /// A directory of the CSV files of [`files`]: a device's rows are a file's lines.
    #[default]
    CsvDirectory,
    /// A run log: a device's rows are a topic's samples.
    RunLog,
}

/// A measured record. An empty series means the device was absent.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dataset {
    /// Where the data came from (for messages).
    pub source: PathBuf,
    pub origin: Origin,
    pub gyro: Vec<GyroRow>,
    pub inclinometer: Vec<TiltRow>,
    pub magnetometer: Vec<FieldRow>,
    pub wheels: Vec<WheelRow>,
    pub cmg: Vec<CmgRow>,
    /// Thruster valve on-times (empty: no thrusters).
    pub thrusters: Vec<ThrusterRow>,
}

/// File names of the CSV contract.
pub use crate::csv::files;

/// Read a measured-data CSV directory (see [`crate::csv`]).
pub fn read_dir(dir: &std::path::Path) -> Result<Dataset, DataError> {
    crate::csv::read_dir(dir)
}

/// Write `data` as a measured-data CSV directory (see [`crate::csv::write_dir`]).
pub fn write_dir(dir: &std::path::Path, data: &Dataset) -> Result<Vec<PathBuf>, DataError> {
    crate::csv::write_dir(dir, data)
}

impl From<Records> for Dataset {
    fn from(r: Records) -> Self {
        Self {
            source: r.dir,
            origin: Origin::CsvDirectory,
            gyro: r
                .gyro
                .iter()
                .map(|v| GyroRow {
                    t_s: v.t_s,
                    rate_rad_s: Vector3::new(v.wx, v.wy, v.wz),
                })
                .collect(),
            inclinometer: r
                .inclinometer
                .iter()
                .map(|v| TiltRow {
                    t_s: v.t_s,
                    tilt_rad: [v.tilt_x, v.tilt_y],
                })
                .collect(),
            magnetometer: r
                .magnetometer
                .iter()
                .map(|v| FieldRow {
                    t_s: v.t_s,
                    field_t: Vector3::new(v.bx, v.by, v.bz),
                })
                .collect(),
            wheels: r
                .wheels
                .iter()
                .map(|v| WheelRow {
                    t_s: v.t_s,
                    speed_rad_s: Vector3::new(v.speed_x, v.speed_y, v.speed_z),
                    torque_nm: Vector3::new(v.torque_x, v.torque_y, v.torque_z),
                })
                .collect(),
            cmg: r
                .cmg
                .iter()
                .map(|v| CmgRow {
                    t_s: v.t_s,
                    gimbal_rad: Vector4::new(v.gimbal_1, v.gimbal_2, v.gimbal_3, v.gimbal_4),
                    rate_cmd_rad_s: Vector4::new(
                        v.rate_cmd_1,
                        v.rate_cmd_2,
                        v.rate_cmd_3,
                        v.rate_cmd_4,
                    ),
                })
                .collect(),
            thrusters: r
                .thrusters
                .iter()
                .map(|v| ThrusterRow {
                    t_s: v.t_s,
                    on_time_s: [
                        v.on_time_0_s,
                        v.on_time_1_s,
                        v.on_time_2_s,
                        v.on_time_3_s,
                        v.on_time_4_s,
                        v.on_time_5_s,
                    ],
                })
                .collect(),
        }
    }
}

impl From<&Dataset> for Records {
    fn from(d: &Dataset) -> Self {
        Self {
            dir: d.source.clone(),
            gyro: d
                .gyro
                .iter()
                .map(|r| GyroRecord {
                    t_s: r.t_s,
                    wx: r.rate_rad_s.x,
                    wy: r.rate_rad_s.y,
                    wz: r.rate_rad_s.z,
                })
                .collect(),
            inclinometer: d
                .inclinometer
                .iter()
                .map(|r| TiltRecord {
                    t_s: r.t_s,
                    tilt_x: r.tilt_rad[0],
                    tilt_y: r.tilt_rad[1],
                })
                .collect(),
            magnetometer: d
                .magnetometer
                .iter()
                .map(|r| FieldRecord {
                    t_s: r.t_s,
                    bx: r.field_t.x,
                    by: r.field_t.y,
                    bz: r.field_t.z,
                })
                .collect(),
            wheels: d
                .wheels
                .iter()
                .map(|r| WheelRecord {
                    t_s: r.t_s,
                    speed_x: r.speed_rad_s.x,
                    speed_y: r.speed_rad_s.y,
                    speed_z: r.speed_rad_s.z,
                    torque_x: r.torque_nm.x,
                    torque_y: r.torque_nm.y,
                    torque_z: r.torque_nm.z,
                })
                .collect(),
            cmg: d
                .cmg
                .iter()
                .map(|r| CmgRecord {
                    t_s: r.t_s,
                    gimbal_1: r.gimbal_rad[0],
                    gimbal_2: r.gimbal_rad[1],
                    gimbal_3: r.gimbal_rad[2],
                    gimbal_4: r.gimbal_rad[3],
                    rate_cmd_1: r.rate_cmd_rad_s[0],
                    rate_cmd_2: r.rate_cmd_rad_s[1],
                    rate_cmd_3: r.rate_cmd_rad_s[2],
                    rate_cmd_4: r.rate_cmd_rad_s[3],
                })
                .collect(),
            thrusters: d
                .thrusters
                .iter()
                .map(|r| ThrusterRecord {
                    t_s: r.t_s,
                    on_time_0_s: r.on_time_s[0],
                    on_time_1_s: r.on_time_s[1],
                    on_time_2_s: r.on_time_s[2],
                    on_time_3_s: r.on_time_s[3],
                    on_time_4_s: r.on_time_s[4],
                    on_time_5_s: r.on_time_s[5],
                })
                .collect(),
        }
    }
}

impl Dataset {
    /// The rows from `from_s` to `to_s` (inclusive), s from the record's start (the first gyro
    /// row); `None`: from the start, to the end. The part of a record before or after a change
    /// within it (see [`crate::identify::ChangeReport`]).
    pub fn between(&self, from_s: Option<f64>, to_s: Option<f64>) -> Dataset {
        let t0 = self.gyro.first().map_or(0.0, |r| r.t_s);
        let (a, b) = (
            t0 + from_s.unwrap_or(f64::NEG_INFINITY),
            t0 + to_s.unwrap_or(f64::INFINITY),
        );
        fn keep<R: Copy>(rows: &[R], t: impl Fn(&R) -> f64, a: f64, b: f64) -> Vec<R> {
            rows.iter()
                .filter(|r| (a..=b).contains(&t(r)))
                .copied()
                .collect()
        }
        Dataset {
            source: self.source.clone(),
            origin: self.origin,
            gyro: keep(&self.gyro, |r| r.t_s, a, b),
            inclinometer: keep(&self.inclinometer, |r| r.t_s, a, b),
            magnetometer: keep(&self.magnetometer, |r| r.t_s, a, b),
            wheels: keep(&self.wheels, |r| r.t_s, a, b),
            cmg: keep(&self.cmg, |r| r.t_s, a, b),
            thrusters: keep(&self.thrusters, |r| r.t_s, a, b),
        }
    }

    /// Duration covered by the gyro, s.
    pub fn duration_s(&self) -> f64 {
        match (self.gyro.first(), self.gyro.last()) {
            (Some(a), Some(b)) => b.t_s - a.t_s,
            _ => 0.0,
        }
    }

    /// Every file's time stamps, s, with its name: the gyro first, then the inclinometer, the
    /// magnetometer, the wheels, the CMGs and the thrusters (empty where absent).
    pub fn time_stamps(&self) -> [(&'static str, Vec<f64>); 6] {
        fn stamps<R>(rows: &[R], t: impl Fn(&R) -> f64) -> Vec<f64> {
            rows.iter().map(t).collect()
        }
        [
            (files::GYRO, stamps(&self.gyro, |r| r.t_s)),
            (files::INCLINOMETER, stamps(&self.inclinometer, |r| r.t_s)),
            (files::MAGNETOMETER, stamps(&self.magnetometer, |r| r.t_s)),
            (files::WHEELS, stamps(&self.wheels, |r| r.t_s)),
            (files::CMG, stamps(&self.cmg, |r| r.t_s)),
            (files::THRUSTERS, stamps(&self.thrusters, |r| r.t_s)),
        ]
    }

    /// Where the rows of the CSV file `name` are, for messages: that file, or the run log's
    /// topic they were read from.
    pub(crate) fn file(&self, name: &str) -> PathBuf {
        match self.origin {
            Origin::CsvDirectory => self.source.join(name),
            Origin::RunLog => {
                let topic = match name {
                    files::GYRO => topic::GYRO,
                    files::INCLINOMETER => topic::INCLINOMETER,
                    files::MAGNETOMETER => topic::MAGNETOMETER,
                    files::WHEELS => topic::WHEEL_TELEMETRY,
                    files::CMG => topic::CMG_TELEMETRY,
                    files::THRUSTERS => topic::THRUSTER_STATUS,
                    other => other,
                };
                PathBuf::from(format!("{}, topic {topic}", self.source.display()))
            }
        }
    }

    /// The line of the first row in a file (after the header), none in a run log.
    fn first_line(&self) -> Option<usize> {
        (self.origin == Origin::CsvDirectory).then_some(2)
    }

    /// Check what identification needs: [`Dataset::check_rows`] and
    /// [`Dataset::check_coverage`]. Errors name the file and the row (rows counted from 1).
    /// (`identify` checks the time stamps' unit between the two: [`crate::sanity`].)
    pub fn check(&self) -> Result<(), DataError> {
        self.check_rows()?;
        self.check_coverage()
    }

    /// The rows: finite values, times strictly increasing in every series, no negative valve
    /// on-time, the gyro and at least one vector sensor present.
    pub fn check_rows(&self) -> Result<(), DataError> {
        check_series(
            &self.file(files::GYRO),
            self.first_line(),
            &self.gyro,
            |r| (r.t_s, r.rate_rad_s.as_slice().to_vec()),
            columns::GYRO,
        )?;
        check_series(
            &self.file(files::INCLINOMETER),
            self.first_line(),
            &self.inclinometer,
            |r| (r.t_s, r.tilt_rad.to_vec()),
            columns::INCLINOMETER,
        )?;
        check_series(
            &self.file(files::MAGNETOMETER),
            self.first_line(),
            &self.magnetometer,
            |r| (r.t_s, r.field_t.as_slice().to_vec()),
            columns::MAGNETOMETER,
        )?;
        check_series(
            &self.file(files::WHEELS),
            self.first_line(),
            &self.wheels,
            |r| {
                (
                    r.t_s,
                    r.speed_rad_s
                        .iter()
                        .chain(r.torque_nm.iter())
                        .copied()
                        .collect(),
                )
            },
            columns::WHEELS,
        )?;
        check_series(
            &self.file(files::CMG),
            self.first_line(),
            &self.cmg,
            |r| {
                (
                    r.t_s,
                    r.gimbal_rad
                        .iter()
                        .chain(r.rate_cmd_rad_s.iter())
                        .copied()
                        .collect(),
                )
            },
            columns::CMG,
        )?;
        check_series(
            &self.file(files::THRUSTERS),
            self.first_line(),
            &self.thrusters,
            |r| (r.t_s, r.on_time_s.to_vec()),
            columns::THRUSTERS,
        )?;
        if let Some((i, j, x)) = self.thrusters.iter().enumerate().find_map(|(i, r)| {
            r.on_time_s
                .iter()
                .enumerate()
                .find(|(_, x)| **x < 0.0)
                .map(|(j, x)| (i, j, *x))
        }) {
            return Err(DataError::Row {
                file: self.file(files::THRUSTERS),
                row: i + 1,
                line: self.first_line().map(|l| l + i),
                message: format!(
                    "column `{}`: on-time {x} s is negative",
                    columns::THRUSTERS[j + 1]
                ),
            });
        }
        if self.gyro.is_empty() {
            return Err(DataError::Missing {
                file: self.file(files::GYRO),
                why: "identification needs the body rates".into(),
            });
        }
        if self.inclinometer.is_empty() && self.magnetometer.is_empty() {
            return Err(DataError::Missing {
                file: self.file(files::INCLINOMETER),
                why: format!(
                    "and {} is missing too: the attitude needs at least one vector sensor",
                    files::MAGNETOMETER
                ),
            });
        }
        Ok(())
    }

    /// The coverage: a gyro record of at least [`MIN_DURATION_S`], every other file on its
    /// clock (overlapping it by half its duration at least), a sample period.
    pub fn check_coverage(&self) -> Result<(), DataError> {
        let duration = self.duration_s();
        if duration < MIN_DURATION_S {
            return Err(DataError::TooShort {
                file: self.file(files::GYRO),
                message: format!(
                    "{} rows cover {duration:.1} s; identification needs at least {MIN_DURATION_S} s \
                     (fit and held-out segments)",
                    self.gyro.len()
                ),
            });
        }
        let period = median_period(self.gyro.iter().map(|r| r.t_s));
        let t0 = self.gyro[0].t_s;
        let t1 = t0 + duration;
        for (name, times) in self.time_stamps().into_iter().skip(1) {
            if let (Some(a), Some(b)) = (times.first(), times.last()) {
                let overlap = b.min(t1) - a.max(t0);
                if overlap < 0.5 * duration {
                    return Err(DataError::Content {
                        file: self.file(name),
                        message: format!(
                            "covers {a:.3}..{b:.3} s, which overlaps the gyro's {t0:.3}..{t1:.3} s by only \
                             {:.1} s ({})",
                            overlap.max(0.0),
                            match self.origin {
                                Origin::CsvDirectory => "the files must share one clock",
                                Origin::RunLog => {
                                    "its valid samples must cover half the gyro's record; samples \
                                     not flagged valid, such as readings beyond the range, are left out"
                                }
                            }
                        ),
                    });
                }
            }
        }
        if period.is_nan() || period <= 0.0 {
            return Err(DataError::Content {
                file: self.file(files::GYRO),
                message: "cannot determine the sample period".into(),
            });
        }
        Ok(())
    }
}

/// Median spacing of a time series, s (0 if fewer than two samples).
pub fn median_period(times: impl Iterator<Item = f64>) -> f64 {
    let t: Vec<f64> = times.collect();
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

fn check_series<R>(
    file: &std::path::Path,
    first_line: Option<usize>,
    rows: &[R],
    values: impl Fn(&R) -> (f64, Vec<f64>),
    columns: &[&str],
) -> Result<(), DataError> {
    // The file's columns: time first, then the values in `values` order.
    let (time_column, value_columns) = columns.split_first().unwrap_or((&"t_s", &[]));
    let mut previous: Option<f64> = None;
    for (i, row) in rows.iter().enumerate() {
        let (t, xs) = values(row);
        let at = |message: String| DataError::Row {
            file: file.to_path_buf(),
            row: i + 1,
            line: first_line.map(|l| l + i),
            message,
        };
        if !t.is_finite() {
            return Err(at(format!(
                "column `{time_column}`: {t} is not a finite number"
            )));
        }
        for (x, name) in xs.iter().zip(value_columns) {
            if !x.is_finite() {
                return Err(at(format!("column `{name}`: {x} is not a finite number")));
            }
        }
        if let Some(p) = previous.filter(|p| t <= *p) {
            return Err(at(format!(
                "time {t} s is not after the previous row's {p} s (rows must be in time order)"
            )));
        }
        previous = Some(t);
    }
    Ok(())
}

/// A silence of the gyro longer than this breaks the record, s (see [`Aligned::breaks`]). Over a
/// silence the filter carries its attitude on the mean of the rates at its two ends; the rotation
/// in between is unknown, and 10–20 s in a manoeuvre left the tilt innovations 5–27 times the
/// noise, which the fits took for causes and the whiteness tests for coloured residuals. Up to
/// 1 s the mean rate's error (`T³ ω̈ / 12`) stays well inside the tilt noise at the platform's
/// manoeuvres, and a restart would throw away the converged bias: lost rows are no break.
pub const BREAK_S: f64 = 1.0;
/// ... nor a silence of fewer gyro periods than this (a slow gyro's lost rows).
pub const BREAK_PERIODS: f64 = 5.0;

/// The shortest silence that breaks a record whose gyro's median period is `period_s`, s.
fn break_s(period_s: f64) -> f64 {
    BREAK_S.max(BREAK_PERIODS * period_s)
}

/// A device's silence longer than a break ([`BREAK_S`]), on the data's clock.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Silence {
    /// `gyro` or `wheels`.
    pub device: &'static str,
    /// The last row before it and the first after it, s.
    pub from_s: f64,
    pub to_s: f64,
}

/// The report's line on the silences, if the record has any.
pub fn silences_summary(silences: &[Silence]) -> Option<String> {
    let each: Vec<String> = silences
        .iter()
        .map(|s| {
            format!(
                "the {} silent for {:.1} s from t = {:.3} s",
                s.device,
                s.to_s - s.from_s,
                s.from_s
            )
        })
        .collect();
    let last = each.last()?;
    let list = match &each[..each.len() - 1] {
        [] => last.clone(),
        first => format!("{} and {last}", first.join(", ")),
    };
    let restart = if silences.iter().any(|s| s.device == "gyro") {
        ", and the attitude filter starts again after the gyro's"
    } else {
        ""
    };
    Some(format!(
        "Breaks in the record (a device without rows for more than {BREAK_S} s; \
         `data.silences` lists each): {list}. No equation or prediction spans one{restart}."
    ))
}

/// The data on the gyro's clock: what the fits and predictions work with.
///
/// Tick k is gyro row k. Wheel speeds and gimbal angles are interpolated linearly to the tick
/// times; commands are the zero-order hold of the latest command at or before the tick. Vector
/// samples keep their own times and are attached to the tick at or after them.
#[derive(Debug, Clone)]
pub struct Aligned {
    /// Tick times, s, from the record's start (`t − t0`).
    pub t: Vec<f64>,
    /// Origin of the record on the data's clock, s.
    pub t0: f64,
    /// Nominal tick period (median gyro spacing), s.
    pub period_s: f64,
    /// Gyro readings, rad/s.
    pub gyro: Vec<Vector3<f64>>,
    /// Wheel speeds at the ticks, rad/s (`None` without `wheels.csv`).
    pub wheel_speed: Option<Vec<Vector3<f64>>>,
    /// Wheel commands: `(t − t0, command)` in time order, Nm.
    pub wheel_cmd: Vec<(f64, Vector3<f64>)>,
    /// Gaps in the wheel telemetry, `(t − t0)` of the rows on either side, in time order:
    /// consecutive rows more than 1.5 median intervals apart (lost rows). Inside a gap the
    /// command in effect is unknown and the speed only interpolated.
    pub wheel_gaps: Vec<(f64, f64)>,
    /// Breaks in the record: the ticks that follow a silence of the gyro longer than
    /// [`BREAK_S`] (and than [`BREAK_PERIODS`] periods), in time order. No estimate, equation or
    /// prediction spans one: the attitude filter starts again after it.
    pub breaks: Vec<usize>,
    /// Gimbal angles at the ticks, rad (`None` without `cmg.csv`).
    pub gimbal: Option<Vec<Vector4<f64>>>,
    /// Gimbal rate commands `(t − t0, rates)` in time order, rad/s.
    pub gimbal_cmd: Vec<(f64, Vector4<f64>)>,
    /// Inclinometer samples `(t − t0, [θ, φ])`.
    pub tilt: Vec<(f64, [f64; 2])>,
    /// Magnetometer samples `(t − t0, field T)`.
    pub field: Vec<(f64, Vector3<f64>)>,
    /// Thruster valve on-times `(t − t0, on-times s)` in time order (empty without
    /// `thrusters.csv`).
    pub thruster_cmd: Vec<(f64, [f64; THRUSTER_COUNT])>,
}

impl Aligned {
    /// Align a checked dataset (see [`Dataset::check`]).
    pub fn new(data: &Dataset) -> Self {
        let t0 = data.gyro.first().map_or(0.0, |r| r.t_s);
        let t: Vec<f64> = data.gyro.iter().map(|r| r.t_s - t0).collect();
        let wheel_speed = (!data.wheels.is_empty()).then(|| {
            let times: Vec<f64> = data.wheels.iter().map(|r| r.t_s - t0).collect();
            let values: Vec<Vector3<f64>> = data.wheels.iter().map(|r| r.speed_rad_s).collect();
            t.iter()
                .map(|&ti| interpolate(&times, &values, ti))
                .collect()
        });
        let gimbal = (!data.cmg.is_empty()).then(|| {
            let times: Vec<f64> = data.cmg.iter().map(|r| r.t_s - t0).collect();
            let values: Vec<Vector4<f64>> = data.cmg.iter().map(|r| r.gimbal_rad).collect();
            t.iter()
                .map(|&ti| interpolate(&times, &values, ti))
                .collect()
        });
        let wheel_times: Vec<f64> = data.wheels.iter().map(|r| r.t_s - t0).collect();
        let wheel_period = median_period(wheel_times.iter().copied());
        let wheel_gaps = wheel_times
            .windows(2)
            .filter(|w| w[1] - w[0] > 1.5 * wheel_period)
            .map(|w| (w[0], w[1]))
            .collect();
        let period_s = median_period(t.iter().copied());
        let breaks = (1..t.len())
            .filter(|&k| t[k] - t[k - 1] > break_s(period_s))
            .collect();
        Self {
            period_s,
            wheel_gaps,
            breaks,
            gyro: data.gyro.iter().map(|r| r.rate_rad_s).collect(),
            wheel_speed,
            wheel_cmd: data
                .wheels
                .iter()
                .map(|r| (r.t_s - t0, r.torque_nm))
                .collect(),
            gimbal,
            gimbal_cmd: data
                .cmg
                .iter()
                .map(|r| (r.t_s - t0, r.rate_cmd_rad_s))
                .collect(),
            tilt: data
                .inclinometer
                .iter()
                .map(|r| (r.t_s - t0, r.tilt_rad))
                .collect(),
            field: data
                .magnetometer
                .iter()
                .map(|r| (r.t_s - t0, r.field_t))
                .collect(),
            thruster_cmd: data
                .thrusters
                .iter()
                .map(|r| (r.t_s - t0, r.on_time_s))
                .collect(),
            t,
            t0,
        }
    }

    /// Number of ticks.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Whether any thruster valve was commanded open in the record.
    pub fn has_thruster_firings(&self) -> bool {
        self.thruster_cmd
            .iter()
            .any(|(_, on)| on.iter().any(|x| *x > 0.0))
    }

    /// Whether the record has wheels.
    pub fn has_wheels(&self) -> bool {
        self.wheel_speed.is_some()
    }

    /// Wheel speeds at tick k (zero without wheels), rad/s.
    pub fn wheel_speed_at(&self, k: usize) -> Vector3<f64> {
        self.wheel_speed
            .as_ref()
            .map_or_else(Vector3::zeros, |w| w[k])
    }

    /// Whether the wheel telemetry is complete over `[a, b]` (s from the record's start): no
    /// gap of lost rows overlaps it, so the commands held over it and the speeds at its ends
    /// are the ones the record says. True without wheels.
    pub fn wheel_record_complete(&self, a: f64, b: f64) -> bool {
        let i = self.wheel_gaps.partition_point(|g| g.1 <= a + 1e-9);
        self.wheel_gaps.get(i).is_none_or(|g| g.0 >= b - 1e-9)
    }

    /// The silences of the gyro and the wheel telemetry longer than a break, in time order.
    pub fn silences(&self) -> Vec<Silence> {
        let at = |device, from: f64, to: f64| Silence {
            device,
            from_s: self.t0 + from,
            to_s: self.t0 + to,
        };
        let gyro = (self.breaks.iter()).map(|&k| at("gyro", self.t[k - 1], self.t[k]));
        let wheels = (self.wheel_silences()).map(|&(a, b)| at("wheels", a, b));
        let mut out: Vec<Silence> = gyro.chain(wheels).collect();
        out.sort_by(|a, b| a.from_s.total_cmp(&b.from_s));
        out
    }

    /// The gaps in the wheel telemetry longer than a break.
    fn wheel_silences(&self) -> impl Iterator<Item = &(f64, f64)> {
        let shortest = break_s(self.period_s);
        self.wheel_gaps.iter().filter(move |g| g.1 - g.0 > shortest)
    }

    /// The ticks `[a, b)` less those where the wheel telemetry is silent for longer than a break
    /// ([`BREAK_S`]): the pieces on either side, in order. Over a short gap the command held is
    /// the one issued; over a silence the commands in effect are unknown, and a prediction
    /// driven by them runs away.
    pub fn without_wheel_silences(&self, a: usize, b: usize) -> Vec<(usize, usize)> {
        let mut pieces = Vec::new();
        let mut from = a;
        for &(g0, g1) in self.wheel_silences() {
            let before = from + self.t[from..b].partition_point(|&t| t <= g0);
            let after = from + self.t[from..b].partition_point(|&t| t < g1);
            if before > from {
                pieces.push((from, before));
            }
            from = after;
        }
        if b > from {
            pieces.push((from, b));
        }
        pieces
    }

    /// Gimbal angles at tick k (zero without CMGs), rad.
    pub fn gimbal_at(&self, k: usize) -> Vector4<f64> {
        self.gimbal.as_ref().map_or_else(Vector4::zeros, |g| g[k])
    }

    /// The wheel command acting at time `t` (s from the record's start) without delay: the
    /// latest issued at or before `t` (zero before the first), Nm.
    pub fn wheel_cmd_at(&self, t: f64) -> Vector3<f64> {
        held(&self.wheel_cmd, t).unwrap_or_else(Vector3::zeros)
    }

    /// The gimbal-rate command acting at `t` (zero before the first), rad/s.
    pub fn gimbal_cmd_at(&self, t: f64) -> Vector4<f64> {
        held(&self.gimbal_cmd, t).unwrap_or_else(Vector4::zeros)
    }

    /// `∫ cmd(s − delay) ds` over `[a, b]` for the wheel commands, each component clamped to
    /// `±limit` (the drive's torque limit), Nm s. Commands are held between their times.
    pub fn wheel_cmd_integral(&self, a: f64, b: f64, delay_s: f64, limit: f64) -> Vector3<f64> {
        integrate_held(
            &self.wheel_cmd,
            a - delay_s,
            b - delay_s,
            |v: &Vector3<f64>| v.map(|x| x.clamp(-limit, limit)),
        )
    }
}

/// Index of the last entry with time ≤ t + 1e-9 (times in order). Records are sampled at a
/// near-constant rate, so the search starts where a uniform spacing puts `t` and walks a few
/// entries from there; a binary search when that does not find it.
fn held_index<T>(series: &[(f64, T)], t: f64) -> Option<usize> {
    let key = t + 1e-9;
    let (first, last) = (series.first()?.0, series.last()?.0);
    // Before the first entry (or a NaN time): nothing is held yet.
    if key.partial_cmp(&first).is_none_or(|o| o.is_lt()) {
        return None;
    }
    let n = series.len();
    if key >= last {
        return Some(n - 1);
    }
    // Here first ≤ key < last: the answer is in 0..n − 1.
    let mut i = (((key - first) / (last - first) * (n - 1) as f64) as usize).min(n - 2);
    for _ in 0..8 {
        if series[i].0 > key {
            i -= 1;
        } else if series[i + 1].0 <= key {
            i += 1;
        } else {
            return Some(i);
        }
    }
    series.partition_point(|(ti, _)| *ti <= key).checked_sub(1)
}

fn held<T: Copy>(series: &[(f64, T)], t: f64) -> Option<T> {
    held_index(series, t).map(|i| series[i].1)
}

/// Integral of a zero-order-held series over `[a, b]` (zero before its first entry).
fn integrate_held<F: Fn(&Vector3<f64>) -> Vector3<f64>>(
    series: &[(f64, Vector3<f64>)],
    a: f64,
    b: f64,
    map: F,
) -> Vector3<f64> {
    let mut sum = Vector3::zeros();
    if b <= a {
        return sum;
    }
    let mut i = held_index(series, a);
    let mut t = a;
    while t < b {
        let next = match i {
            Some(j) => series.get(j + 1).map_or(f64::INFINITY, |(tn, _)| *tn),
            None => series.first().map_or(f64::INFINITY, |(tn, _)| *tn),
        };
        let end = next.min(b);
        if let Some(j) = i {
            sum += map(&series[j].1) * (end - t);
        }
        t = end;
        i = Some(i.map_or(0, |j| j + 1));
        if next == f64::INFINITY {
            break;
        }
    }
    sum
}

/// Linear interpolation of a sampled series at `t` (held constant beyond its ends).
pub(crate) fn interpolate<V>(times: &[f64], values: &[V], t: f64) -> V
where
    V: Copy + std::ops::Mul<f64, Output = V> + std::ops::Add<Output = V>,
{
    let n = times.partition_point(|&ti| ti <= t);
    if n == 0 {
        return values[0];
    }
    if n >= times.len() {
        return values[times.len() - 1];
    }
    let (ta, tb) = (times[n - 1], times[n]);
    let f = if tb > ta { (t - ta) / (tb - ta) } else { 0.0 };
    values[n - 1] * (1.0 - f) + values[n] * f
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Errors in data read from a run log name the log and the topic, and no line; from a
    /// directory, the file and the line.
    #[test]
    fn errors_name_the_topic_of_a_run_log_and_the_line_of_a_file() {
        let gyro = |t_s: f64| GyroRow {
            t_s,
            rate_rad_s: Vector3::zeros(),
        };
        let tilt = |t_s: f64| TiltRow {
            t_s,
            tilt_rad: [0.0; 2],
        };
        let mut data = Dataset {
            source: PathBuf::from("run.mcap"),
            origin: Origin::RunLog,
            gyro: (0..700).map(|k| gyro(0.1 * k as f64)).collect(),
            inclinometer: (0..50).map(|k| tilt(0.4 * k as f64)).collect(),
            ..Dataset::default()
        };
        let message = data.check().expect_err("coverage").to_string();
        assert!(
            message.starts_with(
                "run.mcap, topic testbed/sensors/inclinometer: covers 0.000..19.600 s"
            ),
            "{message}"
        );
        data.inclinometer = (0..100).map(|k| tilt(0.4 * (k % 50) as f64)).collect();
        let message = data.check().expect_err("times").to_string();
        assert!(
            message.starts_with(
                "run.mcap, topic testbed/sensors/inclinometer, row 51: time 0 s is not after"
            ),
            "{message}"
        );
        data.source = PathBuf::from("dir");
        data.origin = Origin::CsvDirectory;
        let message = data.check().expect_err("times").to_string();
        let file = PathBuf::from("dir").join(files::INCLINOMETER);
        assert!(
            message.starts_with(&format!(
                "{}, row 51 (line 52): time 0 s is not after",
                file.display()
            )),
            "{message}"
        );
    }

    /// A silence of more than 1 s is a break, lost rows are not; the pieces around a silence
    /// of the wheels hold every tick outside it.
    #[test]
    fn silences_longer_than_a_break_split_the_record() {
        // 10 Hz for 60 s; the gyro without 20.0–22.0 s and 40.0–40.2 s (two rows), the wheels
        // without 30.0–31.5 s.
        let times = |lost: &dyn Fn(f64) -> bool| -> Vec<f64> {
            (0..600)
                .map(|k| 0.1 * k as f64)
                .filter(|t| !lost(*t))
                .collect()
        };
        let gyro = times(&|t| (19.95..21.95).contains(&t) || (39.95..40.15).contains(&t));
        let wheels = times(&|t| (29.95..31.45).contains(&t));
        let data = Dataset {
            gyro: (gyro.iter())
                .map(|&t_s| GyroRow {
                    t_s,
                    rate_rad_s: Vector3::zeros(),
                })
                .collect(),
            wheels: (wheels.iter())
                .map(|&t_s| WheelRow {
                    t_s,
                    speed_rad_s: Vector3::zeros(),
                    torque_nm: Vector3::zeros(),
                })
                .collect(),
            ..Dataset::default()
        };
        let aligned = Aligned::new(&data);
        let after = |t: f64| {
            aligned
                .t
                .iter()
                .position(|&x| (x - t).abs() < 1e-9)
                .unwrap()
        };
        assert_eq!(aligned.breaks, vec![after(22.0)]);
        let silences = aligned.silences();
        let spans: Vec<(&str, f64, f64)> = (silences.iter())
            .map(|s| {
                (
                    s.device,
                    (s.from_s * 10.0).round() / 10.0,
                    (s.to_s * 10.0).round() / 10.0,
                )
            })
            .collect();
        assert_eq!(spans, vec![("gyro", 19.9, 22.0), ("wheels", 29.9, 31.5)]);
        let n = aligned.len();
        assert_eq!(
            aligned.without_wheel_silences(0, n),
            vec![(0, after(29.9) + 1), (after(31.5), n)]
        );
        assert_eq!(
            aligned.without_wheel_silences(0, after(25.0)),
            vec![(0, after(25.0))]
        );
        let line = silences_summary(&silences).unwrap();
        assert!(line.contains("the gyro silent for 2.1 s from t = 19.900 s and the wheels silent for 1.6 s from t = 29.900 s"), "{line}");
        assert!(line.ends_with("starts again after the gyro's."), "{line}");
    }

    /// The guessed search finds what a binary search finds: on a jittered 10-Hz series with a
    /// gap, repeated times and a burst, at times on, between and beyond its entries.
    #[test]
    fn held_index_is_the_binary_search() {
        let mut times: Vec<f64> = (0..2000)
            .map(|k| 0.1 * k as f64 + 0.003 * ((k * 7919 % 13) as f64 - 6.0))
            .collect();
        times.extend([200.0, 200.0, 200.0, 200.01, 200.02, 350.0, 350.1]);
        let series: Vec<(f64, ())> = times.iter().map(|&t| (t, ())).collect();
        let binary = |t: f64| {
            series
                .partition_point(|(ti, _)| *ti <= t + 1e-9)
                .checked_sub(1)
        };
        let probes = times
            .iter()
            .flat_map(|&t| [t, t - 1e-9, t + 1e-9, t - 2e-9, t + 0.05, t - 0.05])
            .chain([-1.0, -0.4, 1e9, f64::NAN, 275.0]);
        for t in probes {
            assert_eq!(held_index(&series, t), binary(t), "at t = {t}");
        }
        assert_eq!(held_index::<()>(&[], 1.0), None);
    }

    #[test]
    fn held_integral_splits_at_command_changes_and_delays() {
        let series = vec![
            (0.0, Vector3::new(1.0, 0.0, 0.0)),
            (1.0, Vector3::new(2.0, 0.0, 0.0)),
        ];
        let i = integrate_held(&series, 0.5, 1.5, |v| *v);
        assert!((i.x - (0.5 + 1.0)).abs() < 1e-12);
        // A delay of 0.25 s: over [1.0, 1.5] the command issued at 0 acts until 1.25.
        let d = integrate_held(&series, 1.0 - 0.25, 1.5 - 0.25, |v| *v);
        assert!((d.x - (0.25 + 0.5)).abs() < 1e-12);
        // Before the first command nothing acts.
        let early = integrate_held(&series, -1.0, 0.5, |v| *v);
        assert!((early.x - 0.5).abs() < 1e-12);
    }

    #[test]
    fn interpolation_is_linear_and_held_at_the_ends() {
        let times = [0.0, 1.0];
        let values = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(2.0, 0.0, 0.0)];
        assert_eq!(interpolate(&times, &values, 0.25).x, 0.5);
        assert_eq!(interpolate(&times, &values, -1.0).x, 0.0);
        assert_eq!(interpolate(&times, &values, 3.0).x, 2.0);
    }
}
