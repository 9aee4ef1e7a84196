//! The recording the chain's gateways replay: what the devices reported at every tick of a
//! closed-loop run of the pipeline's scenario (gyro; inclinometer and magnetometer where due;
//! wheel and CMG telemetry).

use anyhow::{Context, Result};
use ipc_types::*;
use std::path::Path;
use testbed_config::RunConfig;

/// Device-time period of the recorded run's ticks (10 Hz).
pub const TICK_NS: u64 = 100_000_000;

/// The run configuration every chain process uses (the pipeline's defaults).
pub fn run_config() -> RunConfig {
    RunConfig::default()
}

const FIELDS: usize = 17;

/// What the devices reported at every tick of a closed-loop run.
pub struct Recording {
    ticks: Vec<[f64; FIELDS]>,
}

impl Recording {
    /// Runs the pipeline's scenario in process for `ticks` ticks and writes what its devices
    /// reported to `path`.
    pub fn record(path: &Path, ticks: usize) -> Result<()> {
        let mut scenario = testbed_sim::closed_loop::Scenario::from_run(&run_config());
        scenario.duration_s = ticks as f64 * TICK_NS as f64 * 1e-9;
        let (_, measurements) = testbed_sim::closed_loop::run_recorded(&scenario)?;
        let mut bytes = Vec::with_capacity(measurements.len() * FIELDS * 8);
        for m in &measurements {
            let tilt = m.tilt_rad;
            let field = m.field_t;
            let row: [f64; FIELDS] = [
                m.gyro_rad_s.x,
                m.gyro_rad_s.y,
                m.gyro_rad_s.z,
                f64::from(u8::from(tilt.is_some())),
                tilt.map_or(0.0, |t| t[0]),
                tilt.map_or(0.0, |t| t[1]),
                f64::from(u8::from(field.is_some())),
                field.map_or(0.0, |f| f.x),
                field.map_or(0.0, |f| f.y),
                field.map_or(0.0, |f| f.z),
                m.wheel_speed_rad_s.x,
                m.wheel_speed_rad_s.y,
                m.wheel_speed_rad_s.z,
                m.gimbal_rad[0],
                m.gimbal_rad[1],
                m.gimbal_rad[2],
                m.gimbal_rad[3],
            ];
            for v in row {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
    }

    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let ticks = bytes
            .chunks_exact(FIELDS * 8)
            .map(|row| {
                std::array::from_fn(|i| {
                    f64::from_le_bytes(row[i * 8..i * 8 + 8].try_into().expect("8 bytes"))
                })
            })
            .collect();
        Ok(Self { ticks })
    }

    pub fn len(&self) -> usize {
        self.ticks.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ticks.is_empty()
    }

    fn header(k: usize) -> SampleHeader {
        SampleHeader::new(k as u64 * TICK_NS, k as u64, SampleHeader::VALID)
    }

    pub fn gyro(&self, k: usize) -> GyroSample {
        let r = &self.ticks[k];
        GyroSample::new(Self::header(k), [r[0], r[1], r[2]])
    }

    pub fn tilt(&self, k: usize) -> Option<InclinometerSample> {
        let r = &self.ticks[k];
        (r[3] != 0.0).then(|| InclinometerSample::new(Self::header(k), [r[4], r[5]]))
    }

    pub fn field(&self, k: usize) -> Option<MagnetometerSample> {
        let r = &self.ticks[k];
        (r[6] != 0.0).then(|| MagnetometerSample::new(Self::header(k), [r[7], r[8], r[9]]))
    }

    pub fn wheels(&self, k: usize, torque: [f64; 3]) -> WheelTelemetry {
        let r = &self.ticks[k];
        WheelTelemetry::new(Self::header(k), [r[10], r[11], r[12]], torque)
    }

    pub fn cmg(&self, k: usize, rate: [f64; 4]) -> CmgTelemetry {
        let r = &self.ticks[k];
        CmgTelemetry::new(Self::header(k), [r[13], r[14], r[15], r[16]], rate)
    }
}
