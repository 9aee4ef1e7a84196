//! Thruster control: a pulse modulator turning a commanded torque into valve on-times,
//! wheel momentum dumping with hysteresis, and rate damping on the thrusters alone.
//!
//! **Pulse modulator** (pulse-width modulation with impulse-error feedback, a discrete
//! equivalent of pulse-width pulse-frequency modulation). Per body axis it accumulates the
//! angular impulse asked for, `e += τ_cmd T`, and fires the axis's `+` or `−` thruster when
//! `|e|` reaches half a minimum impulse bit, for the electrical on-time that delivers `|e|`:
//! `t_on = |e|/τ_a − (d_close − d_open)`, clamped to `[t_min, T]`; the impulse the pulse is
//! expected to deliver, `τ_a (t_on + d_close − d_open)`, is taken off `e`. So the average torque
//! equals the command within one minimum impulse bit per period, small commands give sparse
//! minimum pulses (the pulse frequency), large ones wide pulses (the width), and the command
//! is never smaller than the valve allows. `|e|` is bounded by two full periods (no wind-up).
//!
//! **Momentum dumping.** The wheels hold the attitude; the thrusters apply `τ = −k h_w`
//! (clamped per axis), `h_w = J n` the wheels' momentum, so the wheels, holding the attitude
//! against that torque, slow down. Dumping starts when any wheel's momentum exceeds
//! `dump_start_fraction` of its limit and stops when every wheel is below `dump_stop_fraction`
//! (hysteresis). The expected thruster torque is fed forward to the wheels so the attitude
//! loop does not have to see it as an error first.
//!
//! **Rate damping** (safe mode with thrusters): `τ = −K w` clamped to the thrusters' torque,
//! nothing inside a dead band; the wheels are not used.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use testbed_model::physics::ThrusterCommand;
use testbed_model::thruster_config::{THRUSTER_COUNT, ThrusterConfig};

use crate::control::ControlError;

/// What the thrusters are used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ThrusterUse {
    /// Wheels hold the attitude; thrusters unload them past the momentum threshold.
    MomentumDumping,
    /// Thrusters alone damp the body rate; the wheels are off (the safe mode with thrusters).
    RateDamping,
}

/// Thruster control configuration (`[controller.thrusters]`; off unless present).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ThrusterControlConfig {
    #[serde(rename = "use")]
    pub usage: ThrusterUse,
    /// Dumping starts when a wheel's |momentum| exceeds this fraction of its limit `J n_max`.
    pub dump_start_fraction: f64,
    /// Dumping stops when every wheel's |momentum| is below this fraction of its limit.
    pub dump_stop_fraction: f64,
    /// Dumping gain `k` of `τ = −k h_w`, 1/s.
    pub dump_gain_per_s: f64,
    /// Largest dumping torque per axis, Nm (below the wheels' torque, which must hold the
    /// attitude against it).
    pub max_dump_torque_nm: f64,
    /// Rate-damping gain `K` of `τ = −K w`, Nm/(rad/s).
    pub damping_gain_nm_s: f64,
    /// Rate-damping dead band, °/s per axis (edge unit).
    pub damping_deadband_deg_s: f64,
    /// With momentum dumping: window of the external-torque estimate, s (0: no estimate). The
    /// estimate (the rate of the total angular momentum `I w + J n`, less the thrusters'
    /// expected torque, over this window) is fed forward to the wheels, so a constant
    /// disturbance leaves no steady attitude error.
    pub disturbance_window_s: f64,
}

impl Default for ThrusterControlConfig {
    fn default() -> Self {
        Self {
            usage: ThrusterUse::MomentumDumping,
            dump_start_fraction: 0.5,
            dump_stop_fraction: 0.1,
            dump_gain_per_s: 0.05,
            max_dump_torque_nm: 0.01,
            damping_gain_nm_s: 50.0,
            damping_deadband_deg_s: 0.003,
            disturbance_window_s: 60.0,
        }
    }
}

impl ThrusterControlConfig {
    pub fn validate(&self) -> Result<(), ControlError> {
        let bad = |key: &str, value: f64, reason: &str| {
            Err(ControlError::InvalidConfig {
                key: format!("controller.thrusters.{key}"),
                value: format!("{value}"),
                reason: reason.into(),
            })
        };
        for (key, x) in [
            ("dump_gain_per_s", self.dump_gain_per_s),
            ("max_dump_torque_nm", self.max_dump_torque_nm),
            ("damping_gain_nm_s", self.damping_gain_nm_s),
        ] {
            if !(x.is_finite() && x > 0.0) {
                return bad(key, x, "must be finite and > 0");
            }
        }
        if !(self.disturbance_window_s.is_finite()
            && (0.0..=3600.0).contains(&self.disturbance_window_s))
        {
            return bad(
                "disturbance_window_s",
                self.disturbance_window_s,
                "must be within [0, 3600] s",
            );
        }
        if !(self.damping_deadband_deg_s.is_finite() && self.damping_deadband_deg_s >= 0.0) {
            return bad(
                "damping_deadband_deg_s",
                self.damping_deadband_deg_s,
                "must be finite and >= 0",
            );
        }
        if !(0.0 < self.dump_stop_fraction
            && self.dump_stop_fraction < self.dump_start_fraction
            && self.dump_start_fraction < 1.0)
        {
            return bad(
                "dump_start_fraction",
                self.dump_start_fraction,
                "must satisfy 0 < dump_stop_fraction < dump_start_fraction < 1",
            );
        }
        Ok(())
    }
}

/// Pulse modulator: commanded torque (Nm, body axes) to valve on-times, per period.
#[derive(Debug, Clone)]
pub struct PulseModulator {
    /// For each axis, the `+` and `−` thruster and the torque magnitude they give, Nm.
    axes: [(usize, usize, f64); 3],
    /// `d_close − d_open`, s.
    delay_gain_s: f64,
    min_on_s: f64,
    period_s: f64,
    /// Angular impulse asked for and not yet delivered, Nms, body axes.
    error_nms: Vector3<f64>,
}

impl PulseModulator {
    /// The modulator of the thrusters of `config` at command period `period_s`. The layout must
    /// give each body axis a `+` and a `−` thruster (the one with the largest torque component
    /// of each sign is used).
    pub fn new(config: &ThrusterConfig, period_s: f64) -> Result<Self, ControlError> {
        let mut axes = [(0, 0, 0.0); 3];
        for (a, slot) in axes.iter_mut().enumerate() {
            let comp = |i: usize| config.torque_nm(i)[a];
            let plus = (0..THRUSTER_COUNT).max_by(|i, j| comp(*i).total_cmp(&comp(*j)));
            let minus = (0..THRUSTER_COUNT).min_by(|i, j| comp(*i).total_cmp(&comp(*j)));
            match (plus, minus) {
                (Some(p), Some(m)) if comp(p) > 0.0 && comp(m) < 0.0 => {
                    *slot = (p, m, comp(p).min(-comp(m)));
                }
                _ => {
                    return Err(ControlError::InvalidConfig {
                        key: "thrusters.position_m".into(),
                        value: format!("axis {a}"),
                        reason: "the layout gives no + and − torque about this body axis".into(),
                    });
                }
            }
        }
        if !(period_s.is_finite() && period_s > config.min_on_time_s) {
            return Err(ControlError::InvalidConfig {
                key: "period_s".into(),
                value: format!("{period_s}"),
                reason: "the command period must exceed the valves' minimum on-time".into(),
            });
        }
        Ok(Self {
            axes,
            delay_gain_s: config.close_delay_s - config.open_delay_s,
            min_on_s: config.min_on_time_s,
            period_s,
            error_nms: Vector3::zeros(),
        })
    }

    /// Largest torque per axis the thrusters give, Nm.
    pub fn max_torque_nm(&self) -> Vector3<f64> {
        Vector3::from_fn(|a, _| self.axes[a].2)
    }

    /// Forget the undelivered impulse (a mode change).
    pub fn reset(&mut self) {
        self.error_nms = Vector3::zeros();
    }

    /// Valve on-times for this period to deliver `torque_nm` (Nm, body axes) on average, and
    /// the torque these pulses are expected to deliver over the period, Nm.
    pub fn modulate(&mut self, torque_nm: &Vector3<f64>) -> (ThrusterCommand, Vector3<f64>) {
        let mut command = ThrusterCommand::default();
        let mut delivered = Vector3::zeros();
        for a in 0..3 {
            let (plus, minus, tau) = self.axes[a];
            let asked = if torque_nm[a].is_finite() {
                torque_nm[a].clamp(-tau, tau)
            } else {
                0.0
            };
            let limit = 2.0 * tau * self.period_s;
            let e = (self.error_nms[a] + asked * self.period_s).clamp(-limit, limit);
            let duration = e.abs() / tau;
            let min_duration = self.min_on_s + self.delay_gain_s;
            let mut out = 0.0;
            if duration >= 0.5 * min_duration {
                let t_on = (duration - self.delay_gain_s).clamp(self.min_on_s, self.period_s);
                command.on_time_s[if e > 0.0 { plus } else { minus }] = t_on;
                out = e.signum() * tau * (t_on + self.delay_gain_s);
            }
            self.error_nms[a] = e - out;
            delivered[a] = out / self.period_s;
        }
        (command, delivered)
    }
}

/// Momentum dumping with hysteresis.
#[derive(Debug, Clone)]
pub struct MomentumDumper {
    start_nms: f64,
    stop_nms: f64,
    gain_per_s: f64,
    max_torque_nm: f64,
    dumping: bool,
}

impl MomentumDumper {
    /// `wheel_limit_nms`: each wheel's momentum limit `J n_max`, Nms.
    pub fn new(config: &ThrusterControlConfig, wheel_limit_nms: f64) -> Self {
        Self {
            start_nms: config.dump_start_fraction * wheel_limit_nms,
            stop_nms: config.dump_stop_fraction * wheel_limit_nms,
            gain_per_s: config.dump_gain_per_s,
            max_torque_nm: config.max_dump_torque_nm,
            dumping: false,
        }
    }

    pub fn dumping(&self) -> bool {
        self.dumping
    }

    /// Thruster torque to ask for, Nm, body axes, given the wheels' momentum `h_w` (Nms, body
    /// axes); zero outside a dump.
    pub fn torque(&mut self, wheel_momentum_nms: &Vector3<f64>) -> Vector3<f64> {
        let largest = wheel_momentum_nms.amax();
        if !self.dumping && largest > self.start_nms {
            self.dumping = true;
        } else if self.dumping && largest < self.stop_nms {
            self.dumping = false;
        }
        if !self.dumping {
            return Vector3::zeros();
        }
        let m = self.max_torque_nm;
        (-wheel_momentum_nms * self.gain_per_s).map(|x| x.clamp(-m, m))
    }
}

/// External torque estimate from the total angular momentum: over a window of `n` periods,
/// `d = (H_k − H_{k−n}) / (n T) − mean expected thruster torque`, `H = I w + J n` (body axes;
/// the platform turns slowly while holding attitude, so the body-frame difference is the
/// torque's). Zero until the window is full.
#[derive(Debug, Clone)]
pub struct DisturbanceObserver {
    inertia: nalgebra::Matrix3<f64>,
    window: usize,
    period_s: f64,
    /// (H, expected thruster torque of the period that follows), oldest first.
    history: std::collections::VecDeque<(Vector3<f64>, Vector3<f64>)>,
    thrust_sum: Vector3<f64>,
}

impl DisturbanceObserver {
    pub fn new(inertia: nalgebra::Matrix3<f64>, window: usize, period_s: f64) -> Self {
        Self {
            inertia,
            window: window.max(1),
            period_s,
            history: std::collections::VecDeque::with_capacity(window + 1),
            thrust_sum: Vector3::zeros(),
        }
    }

    /// Take this tick's rate (rad/s), wheel momentum (Nms) and the thruster torque about to be
    /// applied (Nm); returns the estimate, Nm, body axes.
    pub fn update(
        &mut self,
        rate_b: &Vector3<f64>,
        wheel_momentum: &Vector3<f64>,
        thrust_next: &Vector3<f64>,
    ) -> Vector3<f64> {
        let h = self.inertia * rate_b + wheel_momentum;
        let estimate = if self.history.len() == self.window {
            let (h_old, _) = self.history[0];
            (h - h_old - self.thrust_sum * self.period_s) / (self.window as f64 * self.period_s)
        } else {
            Vector3::zeros()
        };
        if self.history.len() == self.window
            && let Some((_, t)) = self.history.pop_front()
        {
            self.thrust_sum -= t;
        }
        self.history.push_back((h, *thrust_next));
        self.thrust_sum += thrust_next;
        estimate
    }
}

/// Rate damping on the thrusters alone: `τ = −K w`, zero inside the dead band, Nm.
pub fn rate_damping_torque(
    config: &ThrusterControlConfig,
    rate_b_rad_s: &Vector3<f64>,
) -> Vector3<f64> {
    let band = config.damping_deadband_deg_s.to_radians();
    rate_b_rad_s.map(|w| {
        if w.abs() <= band {
            0.0
        } else {
            -config.damping_gain_nm_s * w
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_modulator_delivers_the_commanded_average_torque_within_one_impulse_bit() {
        let t = ThrusterConfig::default();
        let period = 0.1;
        for torque in [0.0005, 0.004, 0.02, -0.031, 0.049] {
            let mut m = PulseModulator::new(&t, period).unwrap();
            let n = 600;
            let mut impulse = Vector3::zeros();
            let mut pulses = 0;
            for _ in 0..n {
                let (c, d) = m.modulate(&Vector3::new(torque, -torque, 0.5 * torque));
                impulse += d * period;
                pulses += c.on_time_s.iter().filter(|x| **x > 0.0).count();
                // Never below the valves' minimum on-time, never longer than the period.
                assert!(
                    c.on_time_s
                        .iter()
                        .all(|x| *x == 0.0 || (*x >= t.min_on_time_s && *x <= period))
                );
                // Never both thrusters of one axis.
                for a in 0..3 {
                    assert!(c.on_time_s[2 * a] == 0.0 || c.on_time_s[2 * a + 1] == 0.0);
                }
            }
            // Average over 60 s: the undelivered impulse is below one minimum impulse bit of
            // torque impulse (0.05 Nm × 18 ms = 0.9 mNms) per axis.
            let want = Vector3::new(torque, -torque, 0.5 * torque) * period * n as f64;
            let mib = 0.05 * (t.min_on_time_s + t.close_delay_s - t.open_delay_s);
            assert!(
                (impulse - want).amax() <= mib,
                "torque {torque}: {impulse:?} vs {want:?}"
            );
            assert!(pulses > 0);
        }
    }

    #[test]
    fn the_modulated_pulses_deliver_the_expected_impulse_in_the_valve_model() {
        use testbed_model::ModelConfig;
        use testbed_model::physics::ThrusterBank;
        let model = ModelConfig {
            thrusters: Some(ThrusterConfig {
                thrust_noise_fraction: 0.0,
                ..ThrusterConfig::default()
            }),
            ..ModelConfig::default()
        };
        let t = model.thrusters.clone().unwrap();
        let mut bank = ThrusterBank::from_config(&model).unwrap();
        let mut m = PulseModulator::new(&t, 0.1).unwrap();
        let mut expected = Vector3::zeros();
        let mut time = 0.0;
        // 0.012 Nm about X: pulses of 24 ms − 2 ms each period, separated (never back to back).
        for _ in 0..100 {
            let (c, d) = m.modulate(&Vector3::new(0.012, 0.0, 0.0));
            expected += d * 0.1;
            bank.command(time, &c, 0.1);
            time += 0.1;
        }
        // Integrate the valves' thrust over the whole run, segment by segment.
        let mut t_now = 0.0;
        let mut impulse = Vector3::zeros();
        while let Some(s) = bank.next_switch_after(t_now) {
            let f = bank.factors_at(t_now);
            impulse += bank.torque_b(&f) * (s - t_now);
            t_now = s;
        }
        assert!(
            (impulse - expected).norm() < 1e-12,
            "{impulse:?} vs {expected:?}"
        );
        assert!((impulse.x - 0.012 * 10.0).abs() < 0.0009);
    }

    #[test]
    fn dumping_starts_and_stops_at_its_thresholds() {
        let c = ThrusterControlConfig::default();
        let mut d = MomentumDumper::new(&c, 1.0);
        assert_eq!(d.torque(&Vector3::new(0.49, 0.0, 0.0)), Vector3::zeros());
        assert!(!d.dumping());
        let tau = d.torque(&Vector3::new(0.51, -0.1, 0.0));
        assert!(d.dumping());
        // −k h, clamped: −0.05 × 0.51 = −0.0255 → −0.01; +0.005.
        assert!(
            (tau - Vector3::new(-0.01, 0.005, 0.0)).norm() < 1e-15,
            "{tau:?}"
        );
        // Hysteresis: still dumping between the thresholds, stops below 10 %.
        d.torque(&Vector3::new(0.3, 0.0, 0.0));
        assert!(d.dumping());
        assert_eq!(d.torque(&Vector3::new(0.09, 0.0, -0.05)), Vector3::zeros());
        assert!(!d.dumping());
        d.torque(&Vector3::new(0.3, 0.0, 0.0));
        assert!(!d.dumping());
    }

    #[test]
    fn the_observer_finds_a_constant_torque_under_thruster_pulses() {
        let inertia = nalgebra::Matrix3::from_diagonal(&Vector3::new(45.0, 46.0, 62.0));
        let t = 0.1;
        let mut o = DisturbanceObserver::new(inertia, 50, t);
        let d = Vector3::new(1.2e-4, -3e-5, 2e-4);
        // The momentum grows by the disturbance and by the thrust pulses (every 7th period),
        // split between the platform's rate and the wheels.
        let mut h = Vector3::zeros();
        let mut last = Vector3::zeros();
        for k in 0..200 {
            let thrust = if k % 7 == 0 {
                Vector3::new(0.05, 0.0, -0.05) * 0.2
            } else {
                Vector3::zeros()
            };
            let rate = Vector3::new(1e-5, -2e-5, 3e-6) * (k as f64).sin();
            let wheels = h - inertia * rate;
            last = o.update(&rate, &wheels, &thrust);
            if k < 50 {
                assert_eq!(last, Vector3::zeros());
            }
            h += (d + thrust) * t;
        }
        assert!((last - d).norm() < 1e-15, "{last:?}");
    }

    #[test]
    fn rate_damping_opposes_the_rate_outside_its_dead_band() {
        let c = ThrusterControlConfig::default();
        let w = Vector3::new(0.01, -0.00002, -0.2);
        let tau = rate_damping_torque(&c, &w);
        assert!(
            (tau - Vector3::new(-0.5, 0.0, 10.0)).norm() < 1e-14,
            "{tau:?}"
        );
        let mut bad = c.clone();
        bad.dump_stop_fraction = 0.6;
        assert!(bad.validate().is_err());
        c.validate().unwrap();
    }
}

/// What the thrusters do at one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ThrusterActivity {
    /// Nothing asked of them.
    #[default]
    Idle,
    /// Unloading the wheels.
    Dumping,
    /// Damping the rate alone (wheels off).
    RateDamping,
}

/// One tick's thruster output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrusterOutput {
    pub command: ThrusterCommand,
    /// Torque the thrusters were asked for, Nm, body axes.
    pub requested_nm: Vector3<f64>,
    /// Torque the commanded pulses are expected to deliver over the period, Nm, body axes.
    pub expected_nm: Vector3<f64>,
    /// External torque estimate fed forward to the wheels (momentum dumping), Nm, body axes.
    pub disturbance_nm: Vector3<f64>,
    pub activity: ThrusterActivity,
}

/// The thruster law of the controller: modulator, dumper and rate damping.
#[derive(Debug, Clone)]
pub struct ThrusterLaw {
    config: ThrusterControlConfig,
    modulator: PulseModulator,
    dumper: MomentumDumper,
    wheel_inertia_kgm2: f64,
    observer: Option<DisturbanceObserver>,
}

impl ThrusterLaw {
    /// `thrusters`: the platform's thrusters as the flight software knows them; `period_s`: the
    /// control period, s.
    pub fn new(
        config: &ThrusterControlConfig,
        thrusters: &ThrusterConfig,
        wheels: &testbed_model::WheelConfig,
        inertia: &nalgebra::Matrix3<f64>,
        period_s: f64,
    ) -> Result<Self, ControlError> {
        config.validate()?;
        Ok(Self {
            config: config.clone(),
            modulator: PulseModulator::new(thrusters, period_s)?,
            dumper: MomentumDumper::new(config, wheels.max_momentum_nms()),
            wheel_inertia_kgm2: wheels.inertia_kgm2,
            observer: (config.usage == ThrusterUse::MomentumDumping
                && config.disturbance_window_s > 0.0)
                .then(|| {
                    DisturbanceObserver::new(
                        *inertia,
                        (config.disturbance_window_s / period_s).round().max(1.0) as usize,
                        period_s,
                    )
                }),
        })
    }

    pub fn usage(&self) -> ThrusterUse {
        self.config.usage
    }

    /// Rate damping on the thrusters alone, whatever the configured use (the safe mode);
    /// without a rate every valve stays shut.
    pub fn damp(&mut self, rate_b_rad_s: Option<&Vector3<f64>>) -> ThrusterOutput {
        let requested =
            rate_b_rad_s.map_or_else(Vector3::zeros, |w| rate_damping_torque(&self.config, w));
        let (command, expected) = self.modulator.modulate(&requested);
        ThrusterOutput {
            command,
            requested_nm: requested,
            expected_nm: expected,
            disturbance_nm: Vector3::zeros(),
            activity: ThrusterActivity::RateDamping,
        }
    }

    /// The thrusters' command for one period, from the body rate (rad/s, body axes) and the
    /// wheel speeds (rad/s). With momentum dumping the caller feeds `expected_nm` forward to the
    /// wheels; with rate damping the wheels are off.
    pub fn step(
        &mut self,
        rate_b_rad_s: &Vector3<f64>,
        wheel_speed_rad_s: &Vector3<f64>,
    ) -> ThrusterOutput {
        let (requested, activity) = match self.config.usage {
            ThrusterUse::MomentumDumping => {
                let was = self.dumper.dumping();
                let tau = self
                    .dumper
                    .torque(&(wheel_speed_rad_s * self.wheel_inertia_kgm2));
                if was && !self.dumper.dumping() {
                    self.modulator.reset();
                }
                let activity = if self.dumper.dumping() {
                    ThrusterActivity::Dumping
                } else {
                    ThrusterActivity::Idle
                };
                (tau, activity)
            }
            ThrusterUse::RateDamping => (
                rate_damping_torque(&self.config, rate_b_rad_s),
                ThrusterActivity::RateDamping,
            ),
        };
        let (command, expected) = if activity == ThrusterActivity::Idle {
            (ThrusterCommand::default(), Vector3::zeros())
        } else {
            self.modulator.modulate(&requested)
        };
        let disturbance = self.observer.as_mut().map_or_else(Vector3::zeros, |o| {
            o.update(
                rate_b_rad_s,
                &(wheel_speed_rad_s * self.wheel_inertia_kgm2),
                &expected,
            )
        });
        ThrusterOutput {
            command,
            requested_nm: requested,
            expected_nm: expected,
            disturbance_nm: disturbance,
            activity,
        }
    }
}
