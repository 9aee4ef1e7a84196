//! The simulated gateways' logic: each applies one device model to the plant's truth and
//! produces exactly the sample the real gateway would publish, at the device's rate.

use ipc_types::{
    CmgCommand, CmgTelemetry, GyroSample, InclinometerSample, MagnetometerSample, SampleHeader,
    SimTruth, WheelCommand, WheelTelemetry,
};
use testbed_config::RunConfig;
use testbed_flight::convert::{Sequence, a3, a4, quaternion_from_array, saturation_flags, v3, v4};
use testbed_flight::schedule::Schedule;
use testbed_model::devices::{CmgEncoder, Gyro, Inclinometer, Magnetometer, WheelTachometer};

const SIMULATED_VALID: u32 = SampleHeader::VALID | SampleHeader::SIMULATED;

/// Flags of a simulated sample from a ranged sensor: out of range is published without `VALID`.
fn ranged_flags(valid: bool, saturated: &[bool]) -> u32 {
    let range = if valid {
        SampleHeader::VALID
    } else {
        SampleHeader::OUT_OF_RANGE
    };
    SampleHeader::SIMULATED | saturation_flags(saturated) | range
}

/// The tick of a truth sample, if it is a valid one on the schedule.
fn tick_of(schedule: &Schedule, truth: &SimTruth) -> Option<u64> {
    schedule.tick_at(truth.header.time_ns)
}

pub struct SimGyro {
    gyro: Gyro,
    schedule: Schedule,
    seq: Sequence,
}

impl SimGyro {
    pub fn new(config: &RunConfig, schedule: Schedule) -> Self {
        Self {
            gyro: Gyro::new(&config.model, config.run.seed),
            schedule,
            seq: Sequence::default(),
        }
    }

    /// Ticks between samples.
    pub fn ticks_per_sample(&self) -> u64 {
        1
    }

    /// The gyro samples on every tick.
    pub fn on_truth(&mut self, truth: &SimTruth) -> Option<GyroSample> {
        tick_of(&self.schedule, truth)?;
        let q = quaternion_from_array(&truth.quaternion)?;
        let reading = self.gyro.sample(&q, &v3(&truth.rate));
        let flags = SIMULATED_VALID | saturation_flags(&reading.saturated);
        Some(GyroSample {
            header: self.seq.header(truth.header.time_ns, flags),
            rate: a3(&reading.rate_rad_s),
        })
    }
}

pub struct SimInclinometer {
    device: Inclinometer,
    schedule: Schedule,
    seq: Sequence,
}

impl SimInclinometer {
    pub fn new(config: &RunConfig, schedule: Schedule) -> Self {
        Self {
            device: Inclinometer::new(&config.model, config.run.seed),
            schedule,
            seq: Sequence::default(),
        }
    }

    /// Ticks between samples.
    pub fn ticks_per_sample(&self) -> u64 {
        self.schedule.tilt_every
    }

    /// A sample on the inclinometer's ticks; out of range is published without `VALID`.
    pub fn on_truth(&mut self, truth: &SimTruth) -> Option<InclinometerSample> {
        let k = tick_of(&self.schedule, truth)?;
        if !self.schedule.tilt_due(k) {
            return None;
        }
        let q = quaternion_from_array(&truth.quaternion)?;
        let r = self.device.sample(&q, &v3(&truth.rate));
        let flags = ranged_flags(r.valid(), &r.saturated);
        Some(InclinometerSample {
            header: self.seq.header(truth.header.time_ns, flags),
            tilt: r.tilt_rad,
        })
    }
}

pub struct SimMagnetometer {
    device: Magnetometer,
    schedule: Schedule,
    seq: Sequence,
}

impl SimMagnetometer {
    pub fn new(config: &RunConfig, schedule: Schedule) -> Self {
        Self {
            device: Magnetometer::new(&config.model, config.run.seed),
            schedule,
            seq: Sequence::default(),
        }
    }

    /// Ticks between samples.
    pub fn ticks_per_sample(&self) -> u64 {
        self.schedule.field_every
    }

    pub fn on_truth(&mut self, truth: &SimTruth) -> Option<MagnetometerSample> {
        let k = tick_of(&self.schedule, truth)?;
        if !self.schedule.field_due(k) {
            return None;
        }
        let q = quaternion_from_array(&truth.quaternion)?;
        let r = self.device.sample(&q, &v3(&truth.rate));
        let flags = ranged_flags(r.valid(), &r.saturated);
        Some(MagnetometerSample {
            header: self.seq.header(truth.header.time_ns, flags),
            field: a3(&r.field_t),
        })
    }
}

/// Wheel telemetry every tick: tachometer speeds and the motor torque command in effect.
pub struct SimWheels {
    tachometer: WheelTachometer,
    schedule: Schedule,
    torque_in_effect: [f64; 3],
    seq: Sequence,
}

impl SimWheels {
    pub fn new(config: &RunConfig, schedule: Schedule) -> Self {
        Self {
            tachometer: WheelTachometer::new(&config.model, config.run.seed),
            schedule,
            torque_in_effect: [0.0; 3],
            seq: Sequence::default(),
        }
    }

    pub fn on_command(&mut self, c: &WheelCommand) {
        self.torque_in_effect = c.torque;
    }

    /// Ticks between samples.
    pub fn ticks_per_sample(&self) -> u64 {
        1
    }

    pub fn on_truth(&mut self, truth: &SimTruth) -> Option<WheelTelemetry> {
        tick_of(&self.schedule, truth)?;
        let speed = self.tachometer.sample(&v3(&truth.wheel_speed));
        Some(WheelTelemetry {
            header: self.seq.header(truth.header.time_ns, SIMULATED_VALID),
            speed: a3(&speed),
            torque: self.torque_in_effect,
        })
    }
}

/// CMG telemetry every tick: encoder angles and the gimbal rate command in effect.
pub struct SimCmg {
    encoder: CmgEncoder,
    schedule: Schedule,
    rate_in_effect: [f64; 4],
    seq: Sequence,
}

impl SimCmg {
    pub fn new(config: &RunConfig, schedule: Schedule) -> Self {
        Self {
            encoder: CmgEncoder::new(&config.model.cmg),
            schedule,
            rate_in_effect: [0.0; 4],
            seq: Sequence::default(),
        }
    }

    pub fn on_command(&mut self, c: &CmgCommand) {
        self.rate_in_effect = c.gimbal_rate;
    }

    /// Ticks between samples.
    pub fn ticks_per_sample(&self) -> u64 {
        1
    }

    pub fn on_truth(&mut self, truth: &SimTruth) -> Option<CmgTelemetry> {
        tick_of(&self.schedule, truth)?;
        let angle = self.encoder.sample(&v4(&truth.gimbal_angle));
        Some(CmgTelemetry {
            header: self.seq.header(truth.header.time_ns, SIMULATED_VALID),
            gimbal_angle: a4(&angle),
            gimbal_rate: self.rate_in_effect,
        })
    }
}
