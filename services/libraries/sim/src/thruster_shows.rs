//! The runs that show the thrusters at work, in the in-process closed loop:
//! momentum dumping against a constant disturbance over two hours, and rate damping on the
//! thrusters alone. Used by `tests/thrusters.rs` and `examples/thrusters.rs`.

use crate::closed_loop::{self, LoopError, Scenario, Trace};
use crate::thruster_trace::ThrusterTrace;
use nalgebra::Vector3;
use std::fmt;
use testbed_flight::manoeuvre::Manoeuvre;
use testbed_flight::thruster_control::{ThrusterControlConfig, ThrusterUse};
use testbed_model::ModelConfig;
use testbed_model::config::{ConstantTorque, DEG, RPM};
use testbed_model::thruster_config::ThrusterConfig;

/// The constant disturbance torque of the momentum-dumping show, Nm, body axes: within what the
/// wheel PD holds to 0.05° (its steady error is `2 τ / P` ≈ 0.03° per axis) and enough to
/// saturate the Z wheel (1 Nms) in 5600 s.
pub const DUMP_DISTURBANCE_NM: [f64; 3] = [1.2e-4, -1.2e-4, 1.8e-4];

/// Time after each dump during which the attitude is still allowed to settle, s (the dump
/// window is the dump plus this).
pub const DUMP_SETTLE_S: f64 = 30.0;

/// Momentum dumping show: level start at the target, the constant disturbance, `duration_s`
/// of simulated time; with `thrusters` the model has the six thrusters and the controller
/// dumps momentum, without them it has neither.
pub fn momentum_dumping_scenario(thrusters: bool, duration_s: f64, seed: u64) -> Scenario {
    let mut model = ModelConfig::default();
    model.effects.constant_torque = Some(ConstantTorque {
        torque_nm: DUMP_DISTURBANCE_NM,
    });
    let mut scenario = Scenario::paper_stabilisation(model, seed);
    scenario.manoeuvre = Manoeuvre {
        initial_heading_deg: 0.0,
        initial_pitch_deg: 0.0,
        initial_roll_deg: 0.0,
        ..Manoeuvre::default()
    };
    scenario.duration_s = duration_s;
    if thrusters {
        scenario.model.thrusters = Some(ThrusterConfig::default());
        scenario.controller.thrusters = Some(ThrusterControlConfig::default());
    }
    scenario
}

/// Rate damping show: the platform level, turning at `rate_deg_s` (°/s, body axes), the
/// thrusters alone damp it (wheels off).
pub fn rate_damping_scenario(rate_deg_s: [f64; 3], duration_s: f64, seed: u64) -> Scenario {
    let model = ModelConfig {
        thrusters: Some(ThrusterConfig::default()),
        ..ModelConfig::default()
    };
    let mut scenario = Scenario::paper_stabilisation(model, seed);
    scenario.manoeuvre = Manoeuvre {
        initial_heading_deg: 0.0,
        initial_pitch_deg: 0.0,
        initial_roll_deg: 0.0,
        initial_rate_deg_s: rate_deg_s,
        ..Manoeuvre::default()
    };
    scenario.duration_s = duration_s;
    scenario.controller.thrusters = Some(ThrusterControlConfig {
        usage: ThrusterUse::RateDamping,
        ..ThrusterControlConfig::default()
    });
    scenario
}

/// Figures of a thruster run.
#[derive(Debug, Clone, PartialEq)]
pub struct ThrusterRunSummary {
    pub duration_s: f64,
    /// Largest |wheel speed| over the run as a fraction of the speed limit, per wheel.
    pub peak_wheel_fraction: [f64; 3],
    /// First time a wheel reached 99 % of its speed limit, s.
    pub wheel_saturated_at_s: Option<f64>,
    /// Largest |attitude error| per axis outside the dump windows (after `from_s`), degrees.
    pub max_error_outside_dumps_deg: [f64; 3],
    /// Largest |attitude error| per axis over the whole run (after `from_s`), degrees.
    pub max_error_deg: [f64; 3],
    /// Number of dumps and the time spent in dump windows (dump + settle), s.
    pub dumps: usize,
    pub dump_window_s: f64,
    pub propellant_used_kg: f64,
    pub com_shift_m: Vector3<f64>,
    pub pulses: u64,
    /// First time after which |true rate| stays below `rate_band_deg_s`, s.
    pub rate_settled_at_s: Option<f64>,
    pub rate_band_deg_s: f64,
    pub final_rate_deg_s: f64,
}

impl ThrusterRunSummary {
    /// `from_s`: the attitude statistics start here (s); `rate_band_deg_s`: the band of
    /// `rate_settled_at_s`, °/s.
    pub fn of(
        trace: &Trace,
        thrusters: &ThrusterTrace,
        model: &ModelConfig,
        from_s: f64,
        rate_band_deg_s: f64,
    ) -> Self {
        let limit = model.wheels.max_speed_rpm * RPM;
        let windows = thrusters.dump_windows(DUMP_SETTLE_S);
        let in_dump = |t: f64| windows.iter().any(|(a, b)| t >= *a && t < *b);
        let mut peak = [0.0_f64; 3];
        let mut saturated = None;
        let mut outside = [0.0_f64; 3];
        let mut all = [0.0_f64; 3];
        for tick in &trace.ticks {
            for i in 0..3 {
                let f = tick.truth.wheel_speed[i].abs() / limit;
                peak[i] = peak[i].max(f);
                if f >= 0.99 && saturated.is_none() {
                    saturated = Some(tick.t_s);
                }
                if tick.t_s >= from_s {
                    let e = tick.pointing_error_rad[i].abs() / DEG;
                    all[i] = all[i].max(e);
                    if !in_dump(tick.t_s) {
                        outside[i] = outside[i].max(e);
                    }
                }
            }
        }
        let band = rate_band_deg_s * DEG;
        let last_outside = trace
            .ticks
            .iter()
            .rposition(|t| t.truth.rate_b.norm() >= band);
        let rate_settled_at_s = match last_outside {
            None => trace.ticks.first().map(|t| t.t_s),
            Some(i) => trace.ticks.get(i + 1).map(|t| t.t_s),
        };
        Self {
            duration_s: trace.ticks.last().map_or(0.0, |t| t.t_s),
            peak_wheel_fraction: peak,
            wheel_saturated_at_s: saturated,
            max_error_outside_dumps_deg: outside,
            max_error_deg: all,
            dumps: windows.len(),
            dump_window_s: windows.iter().map(|(a, b)| b - a).sum::<f64>() + 0.0,
            propellant_used_kg: thrusters.propellant_used_kg,
            com_shift_m: thrusters.com_shift_m,
            pulses: thrusters.pulses.iter().sum(),
            rate_settled_at_s,
            rate_band_deg_s,
            final_rate_deg_s: trace
                .ticks
                .last()
                .map_or(0.0, |t| t.truth.rate_b.norm() / DEG),
        }
    }
}

impl fmt::Display for ThrusterRunSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.peak_wheel_fraction.map(|x| x * 100.0);
        writeln!(f, "  duration             {:.1} s", self.duration_s)?;
        writeln!(
            f,
            "  peak wheel speed     X {:.1} %  Y {:.1} %  Z {:.1} %   (of the speed limit)",
            p[0], p[1], p[2]
        )?;
        match self.wheel_saturated_at_s {
            Some(t) => writeln!(f, "  wheel saturated      at {t:.1} s (99 % of the limit)")?,
            None => writeln!(f, "  wheel saturated      never")?,
        }
        let e = self.max_error_deg;
        let o = self.max_error_outside_dumps_deg;
        writeln!(
            f,
            "  max attitude error   X {:.4}  Y {:.4}  Z {:.4} deg (whole run)",
            e[0], e[1], e[2]
        )?;
        writeln!(
            f,
            "  outside dump windows X {:.4}  Y {:.4}  Z {:.4} deg ({} dumps, {:.0} s in dump windows incl. {DUMP_SETTLE_S} s settling)",
            o[0], o[1], o[2], self.dumps, self.dump_window_s
        )?;
        let c = self.com_shift_m * 1e6;
        writeln!(
            f,
            "  propellant used      {:.2} g in {} pulses; CoM shift ({:.3}, {:.3}, {:.3}) µm",
            self.propellant_used_kg * 1e3,
            self.pulses,
            c.x,
            c.y,
            c.z
        )?;
        match self.rate_settled_at_s {
            Some(t) => writeln!(
                f,
                "  |rate| < {} °/s     from {t:.1} s on; final {:.5} °/s",
                self.rate_band_deg_s, self.final_rate_deg_s
            ),
            None => writeln!(
                f,
                "  |rate| < {} °/s     not reached; final {:.5} °/s",
                self.rate_band_deg_s, self.final_rate_deg_s
            ),
        }
    }
}

/// Run a scenario and summarise it (`from_s`: attitude statistics start, s).
pub fn run_and_summarise(
    scenario: &Scenario,
    from_s: f64,
    rate_band_deg_s: f64,
) -> Result<(Trace, ThrusterTrace, ThrusterRunSummary), LoopError> {
    let (trace, _, thrusters) = closed_loop::run_with_thrusters(scenario)?;
    let summary =
        ThrusterRunSummary::of(&trace, &thrusters, &scenario.model, from_s, rate_band_deg_s);
    Ok((trace, thrusters, summary))
}
