//! Experiment design: a target schedule for the in-process closed loop that excites what the
//! candidate effects need, and the run's measured data in the CSV contract's form.
//!
//! The excitation, all within the ±30° tilt stop and the wheels' 1 Nms:
//! * **heading slews**: the target heading ramps back and forth between ±`heading_amplitude_deg`
//!   at `heading_rate_deg_s` (Earth rate, gyro scale and misalignment, hard iron, drag, inertia
//!   about Z; the Z wheel runs through zero at every reversal), slowing to `slow_rate_deg_s`
//!   within `slow_zone_deg` of the headings where the X or Y wheel runs through zero;
//! * **tilt steps**: every `tilt_dwell_s` the target tilt moves through a pattern of pitch/roll
//!   steps of `tilt_deg` (centre-of-mass offset including its vertical part, inertia about X
//!   and Y, gyro scale on X and Y);
//! * **wheel-speed sweeps through zero**: the wheels start with a horizontal angular momentum
//!   (`wheel_momentum_nms`, level frame); as the platform turns, that momentum turns in body axes
//!   and the X and Y wheels sweep slowly through zero (friction asymmetry and Stribeck effect).

use crate::data::{CmgRow, Dataset, FieldRow, GyroRow, ThrusterRow, TiltRow, WheelRow};
use crate::error::IdentError;
use nalgebra::Vector4;
use serde::Serialize;
use std::path::PathBuf;
use testbed_flight::estimators::EstimatorConfig;
use testbed_flight::manoeuvre::Manoeuvre;
use testbed_flight::tasks::ControllerConfig;
use testbed_model::ModelConfig;
use testbed_model::config::RPM;
use testbed_sim::closed_loop::{self, Feedback, MeasurementRecord, Scenario, TargetChange, Trace};
use testbed_sim::thruster_trace::ThrusterTrace;

/// Parameters of the excitation schedule.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExperimentOptions {
    /// Simulated duration, s.
    pub duration_s: f64,
    /// Seed of the devices' noise.
    pub seed: u64,
    /// Heading swings between ± this, degrees.
    pub heading_amplitude_deg: f64,
    /// Heading slew rate of the target, °/s (0.6 °/s ≈ 0.66 Nms on the Z wheel).
    pub heading_rate_deg_s: f64,
    /// Slower slew rate near the headings at which the X or Y wheel runs through zero, °/s.
    pub slow_rate_deg_s: f64,
    /// Half-width of those slow zones, degrees.
    pub slow_zone_deg: f64,
    /// Size of the tilt steps, degrees (the stop is at 30°, the inclinometer's range 25°).
    pub tilt_deg: f64,
    /// Time between tilt steps, s.
    pub tilt_dwell_s: f64,
    /// Initial wheel momentum per wheel, Nms (body = level axes at the start).
    pub wheel_momentum_nms: [f64; 3],
    /// Momentum dumping with the thrusters on (`[controller.thrusters]` defaults; the model must
    /// have `[thrusters]`): data with thruster firings, for `thruster_torque_scale` and
    /// `propellant_com_shift`. See [`ExperimentOptions::thruster_programme`].
    pub thrusters: bool,
}

impl Default for ExperimentOptions {
    fn default() -> Self {
        Self {
            duration_s: 600.0,
            seed: 1,
            heading_amplitude_deg: 60.0,
            heading_rate_deg_s: 0.6,
            slow_rate_deg_s: 0.15,
            slow_zone_deg: 10.0,
            tilt_deg: 7.0,
            tilt_dwell_s: 30.0,
            wheel_momentum_nms: [0.25, 0.25, 0.0],
            thrusters: false,
        }
    }
}

impl ExperimentOptions {
    /// The thruster programme: heading held, the tilt steps of the default programme (so the
    /// propellant's gravity torque has a vertical lever too), the wheels starting at 0.55 Nms
    /// (55 % of the default wheels' 1 Nms, past the 50 % dump threshold) with signs [−, +, −],
    /// and momentum dumping: the first dump fires thrusters 0, 3 and 4 at once; a constant
    /// disturbance in the truth then fills the wheels the other way and the later dumps fire 1,
    /// 2 and 5. Without a disturbance only the first dump comes, and only those three thrusters
    /// are identified.
    pub fn thruster_programme(duration_s: f64, seed: u64) -> Self {
        Self {
            duration_s,
            seed,
            heading_amplitude_deg: 0.0,
            wheel_momentum_nms: [-0.55, 0.55, -0.55],
            thrusters: true,
            ..Self::default()
        }
    }
}

/// Tilt pattern (pitch, roll) in units of `tilt_deg`.
const TILT_PATTERN: [(f64, f64); 9] = [
    (0.0, 0.0),
    (1.0, 0.0),
    (0.0, 1.0),
    (-1.0, 0.0),
    (0.0, -1.0),
    (0.7, 0.7),
    (-0.7, 0.7),
    (-0.7, -0.7),
    (0.7, -0.7),
];

impl ExperimentOptions {
    /// Refuse options the schedule cannot use, naming the option.
    pub fn validate(&self) -> Result<(), IdentError> {
        let bad = |key: &str, value: f64, reason: &str| {
            Err(IdentError::Options {
                key: key.into(),
                value: value.to_string(),
                reason: reason.into(),
            })
        };
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return bad("duration_s", self.duration_s, "must be > 0");
        }
        if !(self.heading_rate_deg_s.is_finite() && self.heading_rate_deg_s > 0.0) {
            return bad("heading_rate_deg_s", self.heading_rate_deg_s, "must be > 0");
        }
        if !(self.slow_rate_deg_s.is_finite() && self.slow_rate_deg_s >= 0.0) {
            return bad("slow_rate_deg_s", self.slow_rate_deg_s, "must be >= 0");
        }
        if !(self.slow_zone_deg.is_finite() && (0.0..=45.0).contains(&self.slow_zone_deg)) {
            return bad(
                "slow_zone_deg",
                self.slow_zone_deg,
                "must be within [0, 45]",
            );
        }
        if !(self.heading_amplitude_deg.is_finite() && self.heading_amplitude_deg >= 0.0) {
            return bad(
                "heading_amplitude_deg",
                self.heading_amplitude_deg,
                "must be >= 0",
            );
        }
        if !(self.tilt_deg.is_finite() && self.tilt_deg.abs() <= 20.0) {
            return bad(
                "tilt_deg",
                self.tilt_deg,
                "must be within ±20° (the stop is at 30°)",
            );
        }
        if !(self.tilt_dwell_s.is_finite() && self.tilt_dwell_s > 0.0) {
            return bad("tilt_dwell_s", self.tilt_dwell_s, "must be > 0");
        }
        if self
            .wheel_momentum_nms
            .iter()
            .any(|h| !(h.is_finite() && h.abs() < 1.0))
        {
            return bad(
                "wheel_momentum_nms",
                self.wheel_momentum_nms[0],
                "each must be within ±1 Nms",
            );
        }
        Ok(())
    }

    /// Headings (degrees, modulo 180°) at which the X and Y wheels run through zero: the
    /// wheels' initial momentum is fixed in the level frame, and at heading ψ its body X
    /// component is `h_x cos ψ + h_y sin ψ`, its body Y component `−h_x sin ψ + h_y cos ψ`.
    pub fn wheel_zero_headings_deg(&self) -> [f64; 2] {
        let [hx, hy, _] = self.wheel_momentum_nms;
        [(-hx).atan2(hy).to_degrees(), hy.atan2(hx).to_degrees()]
    }

    /// Target slew rate at heading `psi` (degrees), °/s: slow within the zones around the
    /// wheels' zero crossings, so those wheels sweep slowly through zero.
    fn rate_at(&self, psi: f64) -> f64 {
        let near = |a: f64| {
            let d = (psi - a).rem_euclid(180.0);
            d.min(180.0 - d) <= self.slow_zone_deg
        };
        let [x, y] = self.wheel_zero_headings_deg();
        if self.slow_rate_deg_s > 0.0 && (near(x) || near(y)) {
            self.slow_rate_deg_s
        } else {
            self.heading_rate_deg_s
        }
    }

    /// Target headings at whole seconds from 0: back and forth between ±amplitude, starting at 0
    /// and rising, at the zone-dependent rate.
    pub fn headings_deg(&self) -> Vec<f64> {
        let n = self.duration_s.ceil() as usize;
        let a = self.heading_amplitude_deg;
        let mut out = Vec::with_capacity(n + 1);
        let (mut psi, mut dir) = (0.0f64, 1.0f64);
        for _ in 0..=n {
            out.push(psi);
            if a == 0.0 {
                continue;
            }
            psi += dir * self.rate_at(psi);
            if psi > a {
                psi = 2.0 * a - psi;
                dir = -1.0;
            } else if psi < -a {
                psi = -2.0 * a - psi;
                dir = 1.0;
            }
        }
        out
    }

    /// Target (pitch, roll) at time `t`, degrees.
    pub fn tilt_deg_at(&self, t: f64) -> (f64, f64) {
        let i = ((t / self.tilt_dwell_s).floor() as usize) % TILT_PATTERN.len();
        let (p, r) = TILT_PATTERN[i];
        (p * self.tilt_deg, r * self.tilt_deg)
    }

    /// The schedule: one target per second.
    pub fn schedule(&self) -> Vec<TargetChange> {
        self.headings_deg()
            .into_iter()
            .enumerate()
            .map(|(i, heading_deg)| {
                let t = i as f64;
                let (pitch, roll) = self.tilt_deg_at(t);
                TargetChange {
                    t_s: t,
                    heading_deg,
                    pitch_deg: pitch,
                    roll_deg: roll,
                }
            })
            .collect()
    }
}

/// The closed-loop scenario of the experiment on `model` (the truth, effects included): wheels
/// under PD + friction compensation, the MEKF in the loop, level start at heading 0.
pub fn scenario(model: &ModelConfig, options: &ExperimentOptions) -> Result<Scenario, IdentError> {
    options.validate()?;
    model.validate()?;
    if options.thrusters && model.thrusters.is_none() {
        return Err(IdentError::Options {
            key: "thrusters".into(),
            value: "true".into(),
            reason: "the model has no [thrusters] table: a thruster programme needs the valves' parameters".into(),
        });
    }
    let j = model.wheels.inertia_kgm2;
    let manoeuvre = Manoeuvre {
        initial_heading_deg: 0.0,
        initial_pitch_deg: 0.0,
        initial_roll_deg: 0.0,
        initial_rate_deg_s: [0.0; 3],
        initial_wheel_speed_rpm: options.wheel_momentum_nms.map(|h| h / j / RPM),
        target_heading_deg: 0.0,
        target_pitch_deg: 0.0,
        target_roll_deg: 0.0,
    };
    let mut controller = ControllerConfig::default();
    controller.thrusters = options.thrusters.then(Default::default);
    Ok(Scenario {
        estimator: EstimatorConfig::default(),
        model: model.clone(),
        controller,
        feedback: Feedback::Estimate,
        manoeuvre,
        duration_s: options.duration_s,
        seed: options.seed,
        schedule: options.schedule(),
    })
}

/// Run the experiment: the measured data (as a test bed would record them) and the trace.
pub fn run(
    model: &ModelConfig,
    options: &ExperimentOptions,
) -> Result<(Dataset, Trace), IdentError> {
    run_scenario(&scenario(model, options)?)
}

/// Run any closed-loop scenario: the measured data (with the thrusters' valve on-times when the
/// model has thrusters) and the trace.
pub fn run_scenario(scenario: &Scenario) -> Result<(Dataset, Trace), IdentError> {
    let (trace, measured, thrusters) = closed_loop::run_with_thrusters(scenario)?;
    let mut data = dataset_from_run(&trace, &measured, PathBuf::from("<experiment>"));
    data.thrusters = thruster_rows(&thrusters);
    Ok((data, trace))
}

/// The thrusters' rows of a closed-loop run: the valve on-times commanded at each tick (the
/// in-process loop has no gateway: what the controller commands is applied). Empty without
/// thrusters.
pub fn thruster_rows(thrusters: &ThrusterTrace) -> Vec<ThrusterRow> {
    thrusters
        .ticks
        .iter()
        .map(|t| ThrusterRow {
            t_s: t.t_s,
            on_time_s: t.command.on_time_s,
        })
        .collect()
}

/// The measured data of a closed-loop run in the CSV contract's form: gyro, inclinometer and
/// magnetometer readings at their sample ticks, wheel speeds with the motor-torque command
/// issued at that tick, and the CMGs if they were used.
pub fn dataset_from_run(trace: &Trace, measured: &[MeasurementRecord], source: PathBuf) -> Dataset {
    let mut data = Dataset {
        source,
        ..Dataset::default()
    };
    for (m, tick) in measured.iter().zip(&trace.ticks) {
        data.gyro.push(GyroRow {
            t_s: m.t_s,
            rate_rad_s: m.gyro_rad_s,
        });
        if let Some(tilt) = m.tilt_rad {
            data.inclinometer.push(TiltRow {
                t_s: m.t_s,
                tilt_rad: tilt,
            });
        }
        if let Some(field) = m.field_t {
            data.magnetometer.push(FieldRow {
                t_s: m.t_s,
                field_t: field,
            });
        }
        data.wheels.push(WheelRow {
            t_s: m.t_s,
            speed_rad_s: m.wheel_speed_rad_s,
            torque_nm: tick.command.wheel_torque_nm,
        });
        data.cmg.push(CmgRow {
            t_s: m.t_s,
            gimbal_rad: m.gimbal_rad,
            rate_cmd_rad_s: tick.command.gimbal_rate_rad_s,
        });
    }
    let cmg_used = data
        .cmg
        .iter()
        .any(|r| r.gimbal_rad != Vector4::zeros() || r.rate_cmd_rad_s != Vector4::zeros());
    if !cmg_used {
        data.cmg.clear();
    }
    data
}
