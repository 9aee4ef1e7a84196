//! Configuration of the six cold-gas thrusters (`[thrusters]`). Off unless the table is
//! present: without it the plant, the controller and every output are exactly as before.
//!
//! Every default is **assumed** (the paper lists six thrusters among the platform's actuators and
//! gives no number for them); `docs/thrusters.md` gives the reasoning and the literature each
//! value comes from. Units carry their name in the key; everything is SI.

use crate::config::ConfigError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Number of thrusters on the platform.
pub const THRUSTER_COUNT: usize = 6;

/// Standard gravity for the specific impulse, m/s² (exact, CGPM 1901).
pub const G0_MPS2: f64 = 9.806_65;

/// The six on/off cold-gas thrusters, their valves and their tank.
///
/// Thruster `2a` gives `+` torque about body axis `a`, thruster `2a + 1` gives `−` torque (the
/// default layout; any layout is accepted through `position_m` and `direction`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ThrusterConfig {
    /// Thrust of one open valve, N. Assumed: 0.1 N, the order of the nitrogen thrusters of
    /// air-bearing tables (0.05–1 N).
    pub thrust_n: f64,
    /// Nozzle position of each thruster relative to the bearing's centre of rotation, m, body
    /// axes. Assumed: on the table's rim, 0.5 m from the vertical axis, in the bearing's plane.
    pub position_m: [[f64; 3]; THRUSTER_COUNT],
    /// Direction of the force each thruster puts on the platform (unit vector), body axes.
    /// Assumed (with `position_m`, pure ± torque about each body axis).
    pub direction: [[f64; 3]; THRUSTER_COUNT],
    /// Valve opening delay: thrust starts this long after the valve is commanded open, s.
    /// Assumed: 5 ms (small solenoid valves open in 2–10 ms).
    pub open_delay_s: f64,
    /// Valve closing delay: thrust stops this long after the valve is commanded shut, s.
    /// Assumed: 3 ms.
    pub close_delay_s: f64,
    /// Shortest electrical on-time the valve driver accepts, s; a shorter command is refused at
    /// the gateway, and the valve model stretches it to this. Assumed: 20 ms, so the minimum
    /// impulse bit is `thrust_n · (min_on_time_s + close_delay_s − open_delay_s)` = 1.8 mNs.
    pub min_on_time_s: f64,
    /// Thrust noise: each pulse's thrust is `thrust_n · (1 + σ ξ)`, `ξ ~ N(0, 1)` drawn at the
    /// valve's opening, 1σ relative. Assumed: 2 % (pulse-to-pulse repeatability of cold-gas
    /// thrusters is quoted at 1–5 %).
    pub thrust_noise_fraction: f64,
    /// Seed of the thrust noise (reproducible runs).
    pub noise_seed: u64,
    /// Specific impulse, s; propellant flow `ṁ = F / (Isp g0)` per open thruster. Assumed: 65 s
    /// (nitrogen: 73 s theoretical, 60–70 s measured for small nozzles).
    pub isp_s: f64,
    /// Propellant in the tank at the start, kg. Assumed: 1 kg (a 2 L tank of nitrogen at
    /// 300 bar holds about 0.7 kg; compressed air similar).
    pub propellant_kg: f64,
    /// Centre of mass of the propellant in the tank, m, body axes, relative to the bearing's
    /// centre of rotation. Assumed: below the bearing on the vertical axis, 2 mm and 1 mm off
    /// it horizontally (a mounting tolerance), so the draining tank moves the centre of mass and
    /// makes a slowly growing gravity torque.
    pub tank_position_m: [f64; 3],
    /// Periods in a row a valve must read open when it should be shut before the thruster
    /// drive declares it stuck open, shuts the latch valve and disables the thrusters.
    /// Assumed: 3 (0.3 s at 10 Hz): one period's sensor glitch is not a fault, and a stuck
    /// valve's 0.05 N m torque acts for under half a second before the latch shuts.
    pub stuck_open_confirm_periods: u32,
    /// Injected fault: one valve stuck open from a time on (off unless present).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stuck_open: Option<StuckOpenValve>,
}

/// An injected fault: thruster `thruster` (0..6) thrusts continuously from plant time `from_s`
/// on, whatever it is commanded, until the tank is empty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StuckOpenValve {
    pub thruster: usize,
    /// Plant time the valve sticks open, s.
    pub from_s: f64,
}

/// Effect `thruster_torque_scale`: thruster i delivers `scale[i]` × its nominal thrust (and so
/// torque); identification names it from data with thruster firings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThrusterTorqueScale {
    pub scale: [f64; THRUSTER_COUNT],
}

/// Rim radius of the default layout, m.
const RIM_M: f64 = 0.5;

impl Default for ThrusterConfig {
    fn default() -> Self {
        let r = RIM_M;
        Self {
            thrust_n: 0.1,
            // +X, −X: vertical thrust at ±Y on the rim; +Y, −Y: vertical thrust at ∓X;
            // +Z, −Z: tangential thrust (+Y) at ±X.
            position_m: [
                [0.0, r, 0.0],
                [0.0, -r, 0.0],
                [-r, 0.0, 0.0],
                [r, 0.0, 0.0],
                [r, 0.0, 0.0],
                [-r, 0.0, 0.0],
            ],
            direction: [
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            open_delay_s: 0.005,
            close_delay_s: 0.003,
            min_on_time_s: 0.02,
            thrust_noise_fraction: 0.02,
            noise_seed: 0,
            isp_s: 65.0,
            propellant_kg: 1.0,
            tank_position_m: [0.002, 0.001, -0.10],
            stuck_open_confirm_periods: 3,
            stuck_open: None,
        }
    }
}

impl ThrusterConfig {
    /// Torque of thruster `i` at nominal thrust, `r × F`, Nm, body axes.
    pub fn torque_nm(&self, i: usize) -> Vector3<f64> {
        Vector3::from(self.position_m[i]).cross(&(Vector3::from(self.direction[i]) * self.thrust_n))
    }

    /// Propellant flow of one open thruster, `F / (Isp g0)`, kg/s.
    pub fn mass_flow_kg_s(&self) -> f64 {
        self.thrust_n / (self.isp_s * G0_MPS2)
    }

    /// Minimum impulse bit, N s: the impulse of a pulse of `min_on_time_s`.
    pub fn minimum_impulse_bit_ns(&self) -> f64 {
        self.thrust_n * (self.min_on_time_s + self.close_delay_s - self.open_delay_s)
    }

    /// Refuse what no thruster can be, naming the key and value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let fail = |key: &str, value: String, reason: &str| {
            Err(ConfigError::Invalid {
                key: format!("thrusters.{key}"),
                value,
                reason: reason.to_string(),
            })
        };
        let positive = [
            ("thrust_n", self.thrust_n),
            ("isp_s", self.isp_s),
            ("min_on_time_s", self.min_on_time_s),
        ];
        for (key, x) in positive {
            if !(x.is_finite() && x > 0.0) {
                return fail(key, format!("{x}"), "must be a finite number > 0");
            }
        }
        let non_negative = [
            ("open_delay_s", self.open_delay_s),
            ("close_delay_s", self.close_delay_s),
            ("thrust_noise_fraction", self.thrust_noise_fraction),
            ("propellant_kg", self.propellant_kg),
        ];
        for (key, x) in non_negative {
            if !(x.is_finite() && x >= 0.0) {
                return fail(key, format!("{x}"), "must be a finite number >= 0");
            }
        }
        if self.stuck_open_confirm_periods == 0 {
            return fail(
                "stuck_open_confirm_periods",
                "0".into(),
                "must be at least 1",
            );
        }
        if self.thrust_noise_fraction > 0.5 {
            return fail(
                "thrust_noise_fraction",
                format!("{}", self.thrust_noise_fraction),
                "must be at most 0.5",
            );
        }
        for i in 0..THRUSTER_COUNT {
            let p = self.position_m[i];
            if p.iter().any(|x| !x.is_finite()) {
                return fail(
                    &format!("position_m[{i}]"),
                    format!("{p:?}"),
                    "must be finite",
                );
            }
            let d = self.direction[i];
            let norm = Vector3::from(d).norm();
            if !norm.is_finite() || (norm - 1.0).abs() >= 1e-6 {
                return fail(
                    &format!("direction[{i}]"),
                    format!("{d:?}"),
                    "must be a unit vector",
                );
            }
        }
        if self.tank_position_m.iter().any(|x| !x.is_finite()) {
            return fail(
                "tank_position_m",
                format!("{:?}", self.tank_position_m),
                "must be finite",
            );
        }
        if let Some(s) = &self.stuck_open {
            if s.thruster >= THRUSTER_COUNT {
                return fail(
                    "stuck_open.thruster",
                    format!("{}", s.thruster),
                    "must be 0..6",
                );
            }
            if !(s.from_s.is_finite() && s.from_s >= 0.0) {
                return fail(
                    "stuck_open.from_s",
                    format!("{}", s.from_s),
                    "must be a finite time >= 0",
                );
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_layout_gives_plus_and_minus_torque_about_each_axis() {
        let c = ThrusterConfig::default();
        for i in 0..THRUSTER_COUNT {
            let axis = i / 2;
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            // Closed form: rim radius × thrust about the thruster's own axis, nothing else.
            let want = Vector3::ith(axis, sign * RIM_M * c.thrust_n);
            assert!(
                (c.torque_nm(i) - want).norm() < 1e-15,
                "thruster {i}: {:?}",
                c.torque_nm(i)
            );
        }
        c.validate().unwrap();
        // ṁ = 0.1 / (65 · 9.80665) and the minimum impulse bit 0.1 · (20 + 3 − 5) ms.
        assert!((c.mass_flow_kg_s() / 1.568_794_17e-4 - 1.0).abs() < 1e-8);
        assert!((c.minimum_impulse_bit_ns() - 1.8e-3).abs() < 1e-15);
    }

    #[test]
    fn invalid_values_are_refused_naming_the_key() {
        let mut c = ThrusterConfig::default();
        c.direction[3] = [0.0, 0.0, 2.0];
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("thrusters.direction[3]"), "{e}");
        let c = ThrusterConfig {
            thrust_n: f64::NAN,
            ..ThrusterConfig::default()
        };
        assert!(c.validate().unwrap_err().to_string().contains("thrust_n"));
        let c = ThrusterConfig {
            stuck_open: Some(StuckOpenValve {
                thruster: 6,
                from_s: 0.0,
            }),
            ..ThrusterConfig::default()
        };
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("stuck_open.thruster")
        );
    }
}
