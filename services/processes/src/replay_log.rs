//! Replay: a recorded run's samples, tick by tick, to feed back into the estimator and
//! controller in place of the plant and the gateways.
//!
//! The replay process owns the clock as the plant does in lockstep: it publishes tick k's truth
//! and clock (for the log and the summary) and its sensor and actuator telemetry, then waits for
//! the controller's commands of tick k before the next. The estimator and controller cannot tell
//! a replay from a live run, so on the same configuration they reproduce the recorded estimates
//! and commands exactly.

use ipc_types::{
    CmgTelemetry, GyroSample, InclinometerSample, MagnetometerSample, SampleHeader, SimClockTick,
    SimTruth, WheelTelemetry,
};
use std::collections::BTreeMap;
use std::path::Path;
use testbed_log::{LogError, LogRecord, RunLog};

/// Everything recorded for one time stamp that the pipeline's inputs consist of.
#[derive(Debug, Default, Clone, Copy)]
pub struct ReplayTick {
    pub time_ns: u64,
    pub truth: Option<SimTruth>,
    pub clock: Option<SimClockTick>,
    pub gyro: Option<GyroSample>,
    pub inclinometer: Option<InclinometerSample>,
    pub magnetometer: Option<MagnetometerSample>,
    pub wheels: Option<WheelTelemetry>,
    pub cmg: Option<CmgTelemetry>,
}

/// Marks a sample as replayed, keeping everything else as recorded.
fn replayed(mut header: SampleHeader) -> SampleHeader {
    header.flags |= SampleHeader::REPLAYED;
    header
}

/// The inputs of a recorded run, in time order. A truncated log yields every complete record.
pub fn load(path: &Path) -> Result<Vec<ReplayTick>, LogError> {
    let log = RunLog::open(path)?;
    let mut ticks: BTreeMap<u64, ReplayTick> = BTreeMap::new();
    for record in log.records()? {
        let record = record?;
        let time_ns = record.header().time_ns;
        let tick = ticks.entry(time_ns).or_insert_with(|| ReplayTick {
            time_ns,
            ..ReplayTick::default()
        });
        match record {
            LogRecord::SimTruth(mut s) => {
                s.header = replayed(s.header);
                tick.truth = Some(s);
            }
            LogRecord::SimClock(mut s) => {
                s.header = replayed(s.header);
                tick.clock = Some(s);
            }
            LogRecord::Gyro(mut s) => {
                s.header = replayed(s.header);
                tick.gyro = Some(s);
            }
            LogRecord::Inclinometer(mut s) => {
                s.header = replayed(s.header);
                tick.inclinometer = Some(s);
            }
            LogRecord::Magnetometer(mut s) => {
                s.header = replayed(s.header);
                tick.magnetometer = Some(s);
            }
            LogRecord::WheelTelemetry(mut s) => {
                s.header = replayed(s.header);
                tick.wheels = Some(s);
            }
            LogRecord::CmgTelemetry(mut s) => {
                s.header = replayed(s.header);
                tick.cmg = Some(s);
            }
            _ => {}
        }
    }
    // Only times that carry inputs; the controller's outputs are what the replay recomputes.
    Ok(ticks.into_values().filter(|t| t.gyro.is_some()).collect())
}
