//! Measured data from one of the project's MCAP run logs (`testbed-log`): the sensor topics,
//! the wheel speeds (telemetry) with the wheel commands, and the CMG telemetry with its
//! commands, and the thrusters' applied valve on-times (`testbed/actuators/thrusters/status`).
//! Samples without the `VALID` flag are left out.

use crate::data::{
    CmgRow, Dataset, FieldRow, GyroRow, Origin, ThrusterRow, TiltRow, WheelRow, median_period,
};
use crate::error::DataError;
use ipc_types::{
    CmgCommand, CmgTelemetry, GyroSample, InclinometerSample, MagnetometerSample, ThrusterStatus,
    WheelCommand, WheelTelemetry,
};
use nalgebra::{Vector3, Vector4};
use std::path::Path;
use testbed_log::{LogEncode, RunLog};

/// Nanoseconds to seconds.
const S_PER_NS: f64 = 1e-9;

/// Read the data of a run log.
pub fn read_log(path: &Path) -> Result<Dataset, DataError> {
    let err = |source| DataError::Log {
        file: path.to_path_buf(),
        source,
    };
    let log = RunLog::open(path).map_err(err)?;
    let gyro: Vec<GyroRow> = samples::<GyroSample>(&log, path)?
        .into_iter()
        .map(|s| GyroRow {
            t_s: s.header.time_ns as f64 * S_PER_NS,
            rate_rad_s: Vector3::from(s.rate),
        })
        .collect();
    let inclinometer = samples::<InclinometerSample>(&log, path)?
        .into_iter()
        .map(|s| TiltRow {
            t_s: s.header.time_ns as f64 * S_PER_NS,
            tilt_rad: s.tilt,
        })
        .collect();
    let magnetometer = samples::<MagnetometerSample>(&log, path)?
        .into_iter()
        .map(|s| FieldRow {
            t_s: s.header.time_ns as f64 * S_PER_NS,
            field_t: Vector3::from(s.field),
        })
        .collect();
    // Wheel rows: telemetry speeds with the command in force at that time (the telemetry's
    // measured torque when no command was logged).
    let telemetry = samples::<WheelTelemetry>(&log, path)?;
    let commands = samples::<WheelCommand>(&log, path)?;
    let wheels = telemetry
        .iter()
        .map(|s| {
            let t = s.header.time_ns;
            let torque = if commands.is_empty() {
                s.torque
            } else {
                latest(&commands, t, |c| c.header.time_ns).map_or([0.0; 3], |c| c.torque)
            };
            WheelRow {
                t_s: t as f64 * S_PER_NS,
                speed_rad_s: Vector3::from(s.speed),
                torque_nm: Vector3::from(torque),
            }
        })
        .collect();
    let cmg_telemetry = samples::<CmgTelemetry>(&log, path)?;
    let cmg_commands = samples::<CmgCommand>(&log, path)?;
    let cmg = cmg_telemetry
        .iter()
        .map(|s| {
            let t = s.header.time_ns;
            let rate =
                latest(&cmg_commands, t, |c| c.header.time_ns).map_or([0.0; 4], |c| c.gimbal_rate);
            CmgRow {
                t_s: t as f64 * S_PER_NS,
                gimbal_rad: Vector4::from(s.gimbal_angle),
                rate_cmd_rad_s: Vector4::from(rate),
            }
        })
        .collect();
    let thrusters = thruster_rows(&samples::<ThrusterStatus>(&log, path)?, &gyro);
    Ok(Dataset {
        source: path.to_path_buf(),
        origin: Origin::RunLog,
        gyro,
        inclinometer,
        magnetometer,
        wheels,
        cmg,
        thrusters,
    })
}

/// Thruster rows from the status samples. A status stamped `T` describes the period that ended
/// at `T` (the plant publishes it after its step): its on-times were commanded at `T − P`, `P`
/// the command period (the median spacing of the status samples; of the gyro's with a single
/// status).
fn thruster_rows(status: &[ThrusterStatus], gyro: &[GyroRow]) -> Vec<ThrusterRow> {
    let times = || status.iter().map(|s| s.header.time_ns as f64 * S_PER_NS);
    let period = if status.len() >= 2 {
        median_period(times())
    } else {
        median_period(gyro.iter().map(|r| r.t_s))
    };
    times()
        .zip(status)
        .map(|(t, s)| ThrusterRow {
            t_s: t - period,
            on_time_s: s.applied_on_time,
        })
        .collect()
}

/// The valid samples of one topic, in time order (a log written in file order may interleave
/// publishers; equal times keep the later sample).
fn samples<T: LogEncode + HasHeader>(log: &RunLog, path: &Path) -> Result<Vec<T>, DataError> {
    let mut out = Vec::new();
    for sample in log.samples::<T>().map_err(|source| DataError::Log {
        file: path.to_path_buf(),
        source,
    })? {
        let sample = sample.map_err(|source| DataError::Log {
            file: path.to_path_buf(),
            source,
        })?;
        if sample.sample_header().is_valid() {
            out.push(sample);
        }
    }
    out.sort_by_key(|s| s.sample_header().time_ns);
    out.dedup_by(|later, earlier| {
        let same = later.sample_header().time_ns == earlier.sample_header().time_ns;
        if same {
            std::mem::swap(later, earlier);
        }
        same
    });
    Ok(out)
}

/// The latest item at or before `t_ns`.
fn latest<T>(items: &[T], t_ns: u64, time: impl Fn(&T) -> u64) -> Option<&T> {
    let n = items.partition_point(|c| time(c) <= t_ns);
    n.checked_sub(1).map(|i| &items[i])
}

/// Access to the common header of the logged sample types.
trait HasHeader {
    fn sample_header(&self) -> &ipc_types::SampleHeader;
}

macro_rules! has_header {
    ($($t:ty),*) => {$(impl HasHeader for $t { fn sample_header(&self) -> &ipc_types::SampleHeader { &self.header } })*};
}
has_header!(
    GyroSample,
    InclinometerSample,
    MagnetometerSample,
    WheelTelemetry,
    WheelCommand,
    CmgTelemetry,
    CmgCommand,
    ThrusterStatus
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thruster_status_describes_the_period_before_its_time() {
        let status = |t_ns: u64, on: f64| ThrusterStatus {
            header: ipc_types::SampleHeader {
                time_ns: t_ns,
                ..Default::default()
            },
            applied_on_time: [on, 0.0, 0.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        let rows = thruster_rows(
            &[
                status(100_000_000, 0.05),
                status(200_000_000, 0.0),
                status(300_000_000, 0.1),
            ],
            &[],
        );
        let t: Vec<f64> = rows.iter().map(|r| r.t_s).collect();
        assert!(
            (t[0] - 0.0).abs() < 1e-12 && (t[2] - 0.2).abs() < 1e-12,
            "{t:?}"
        );
        assert_eq!(rows[0].on_time_s[0], 0.05);
        assert_eq!(rows[2].on_time_s[0], 0.1);
    }
}
