//! The tick schedule shared by every part of a run: the loop ticks at the gyro rate and the
//! vector sensors sample on whole multiples of it.

use testbed_model::ModelConfig;

/// A sensor rate that does not fall on the gyro's tick grid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key} = {rate_hz} must divide the gyro rate {gyro_rate_hz} Hz (the loop's tick)")]
pub struct ScheduleError {
    /// The configuration key of the offending rate.
    pub key: String,
    /// Its value, Hz.
    pub rate_hz: f64,
    /// The gyro rate, Hz.
    pub gyro_rate_hz: f64,
}

/// When each device samples, in control ticks. The loop ticks at the gyro rate; the inclinometer
/// and magnetometer rates must divide it, so every sample falls on a tick. The pipeline's
/// processes use the same schedule, so a tick means the same samples everywhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Schedule {
    /// Tick period (the gyro's), ns.
    pub period_ns: u64,
    /// Ticks between inclinometer samples.
    pub tilt_every: u64,
    /// Ticks between magnetometer samples.
    pub field_every: u64,
}

impl Schedule {
    pub fn from_model(model: &ModelConfig) -> Result<Self, ScheduleError> {
        let gyro = model.gyro.rate_hz;
        Ok(Self {
            period_ns: (1e9 / gyro).round() as u64,
            tilt_every: ticks_per_sample(gyro, model.inclinometer.rate_hz, "inclinometer.rate_hz")?,
            field_every: ticks_per_sample(
                gyro,
                model.magnetometer.rate_hz,
                "magnetometer.rate_hz",
            )?,
        })
    }
    /// Time of tick `k`, ns.
    pub fn time_ns(&self, k: u64) -> u64 {
        k * self.period_ns
    }
    /// The tick at `t_ns`, if `t_ns` falls on one.
    pub fn tick_at(&self, t_ns: u64) -> Option<u64> {
        t_ns.is_multiple_of(self.period_ns)
            .then_some(t_ns / self.period_ns)
    }
    pub fn period_s(&self) -> f64 {
        self.period_ns as f64 * 1e-9
    }
    /// Index of the last tick of a run of `duration_s` seconds (ticks run `0..=tick_count`).
    pub fn tick_count(&self, duration_s: f64) -> u64 {
        (duration_s * 1e9 / self.period_ns as f64).round() as u64
    }
    pub fn tilt_due(&self, k: u64) -> bool {
        k.is_multiple_of(self.tilt_every)
    }
    pub fn field_due(&self, k: u64) -> bool {
        k.is_multiple_of(self.field_every)
    }
    /// The first tick after tick `k` on which a device sampling every `every` ticks samples.
    pub fn next_due(k: u64, every: u64) -> u64 {
        let every = every.max(1);
        (k / every + 1) * every
    }
}

/// How many ticks between samples of a device at `rate_hz`; it must divide the gyro rate.
fn ticks_per_sample(gyro_rate_hz: f64, rate_hz: f64, key: &str) -> Result<u64, ScheduleError> {
    let ratio = gyro_rate_hz / rate_hz;
    let whole = ratio.round();
    if whole < 1.0 || (ratio - whole).abs() > 1e-9 {
        return Err(ScheduleError {
            key: key.to_string(),
            rate_hz,
            gyro_rate_hz,
        });
    }
    Ok(whole as u64)
}
