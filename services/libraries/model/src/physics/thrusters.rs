//! The six on/off cold-gas thrusters: valves with opening and closing delays and a
//! minimum on-time, the torque `r × F` about the bearing centre, propellant use and the moving
//! centre of mass of a draining tank. Off unless `[thrusters]` is configured.
//!
//! Valve timing. A command issued at plant time `t0` asks thruster `i` to be open (electrically)
//! for `t_on` seconds, `0 ≤ t_on ≤` the command period (0: shut). A command shorter than the
//! minimum on-time is stretched to it (the driver's shortest pulse; the gateways refuse such
//! commands before they get here). Thrust starts `open_delay_s` after the valve is commanded open
//! and stops `close_delay_s` after it is commanded shut:
//!
//! ```text
//! thrust on  [t0 + d_open, t0 + t_on + d_close)     impulse  F (t_on + d_close − d_open)
//! ```
//!
//! A pulse commanded while the valve is still electrically open (back-to-back full periods)
//! continues the open pulse without a gap. Each pulse's thrust is `F (1 + σ ξ)`, `ξ ~ N(0, 1)`
//! drawn from the bank's own seeded generator when the valve opens, times the
//! `thruster_torque_scale` effect.
//!
//! Torque. Thruster `i` at `r_i` with force `F_i d_i` (body axes) gives `r_i × F_i d_i` about the
//! bearing centre; the net force is carried by the bearing.
//!
//! Propellant. Each open thruster draws `ṁ = F / (Isp g0)`; the thrust stops when the tank is
//! empty (checked per substep: at most one substep of flow, 1.6 µg at the defaults, is overdrawn).
//!
//! Centre of mass. The tank's propellant sits at `r_t`. With `m_u` used, the platform's weight
//! moment `Σ m g r` changes by `−m_u g r_t`: the centre of mass moves by
//! `Δr = −m_u (r_t − r_c) / (M − m_u)` (`r_c` the full platform's centre of mass, `M` its
//! mass), and the gravity torque of the `com_offset` effect becomes
//! `(W_0 − m_u g r_t) × G_B`. The change of inertia (`m_u |r_t|²` ≈ 0.01 kg m² per kg, 0.02 %
//! of the platform's) is neglected.

use crate::config::ModelConfig;
use crate::thruster_config::{THRUSTER_COUNT, ThrusterConfig};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Times closer than this are the same instant, s (as [`super::delay::TIME_TOLERANCE_S`]).
const TOL_S: f64 = 1e-9;

/// Valve on-times asked of the six thrusters for one command period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThrusterCommand {
    /// Electrical on-time of each valve from the command's issue time, s (0: shut).
    pub on_time_s: [f64; THRUSTER_COUNT],
}

impl ThrusterCommand {
    pub fn is_finite(&self) -> bool {
        self.on_time_s.iter().all(|x| x.is_finite())
    }
    /// True if any valve is commanded open.
    pub fn any(&self) -> bool {
        self.on_time_s.iter().any(|t| *t > 0.0)
    }
}

/// Shift of the centre of mass when `used_kg` of propellant has left a tank at `tank_m`, m,
/// body axes, for a platform of full mass `mass_kg` whose centre of mass was at `com_m`:
/// `Δr = −m_u (r_t − r_c) / (M − m_u)`.
pub fn propellant_com_shift_m(
    tank_m: &Vector3<f64>,
    used_kg: f64,
    mass_kg: f64,
    com_m: &Vector3<f64>,
) -> Vector3<f64> {
    -(tank_m - com_m) * (used_kg / (mass_kg - used_kg))
}

/// One thrust interval of one thruster, plant time, s.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pulse {
    start_s: f64,
    end_s: f64,
    /// Thrust relative to nominal (noise and scale), dimensionless.
    factor: f64,
}

/// The thrusters, their valves and tank, stepped by the plant.
#[derive(Debug, Clone)]
pub struct ThrusterBank {
    config: ThrusterConfig,
    /// Nominal torque of each thruster, Nm, body axes.
    torque_nm: [Vector3<f64>; THRUSTER_COUNT],
    scale: [f64; THRUSTER_COUNT],
    /// Mass flow of one thruster at nominal thrust, kg/s.
    mass_flow_kg_s: f64,
    /// Planned thrust intervals per thruster, in time order (ended ones are dropped).
    pulses: [Vec<Pulse>; THRUSTER_COUNT],
    /// When each valve is (or was last) commanded shut, s.
    electrical_end_s: [f64; THRUSTER_COUNT],
    propellant_used_kg: f64,
    /// Total impulse delivered per thruster, N s (noise and scale included).
    impulse_ns: [f64; THRUSTER_COUNT],
    /// Time each thruster has been thrusting, s.
    firing_s: [f64; THRUSTER_COUNT],
    /// Pulses started per thruster.
    pulse_count: [u64; THRUSTER_COUNT],
    gravity_mps2: f64,
    rng: ChaCha8Rng,
    /// The latch (isolation) valve upstream of the six thruster valves is shut: no thrust, even
    /// from a stuck-open valve (how the thrusters are disabled).
    latch_shut: bool,
}

impl ThrusterBank {
    /// The bank of `config.thrusters`; `None` without it. The configuration must be valid.
    pub fn from_config(config: &ModelConfig) -> Option<Self> {
        let t = config.thrusters.clone()?;
        let scale = config
            .effects
            .thruster_torque_scale
            .map_or([1.0; THRUSTER_COUNT], |s| s.scale);
        Some(Self {
            torque_nm: std::array::from_fn(|i| t.torque_nm(i)),
            scale,
            mass_flow_kg_s: t.mass_flow_kg_s(),
            pulses: Default::default(),
            electrical_end_s: [f64::NEG_INFINITY; THRUSTER_COUNT],
            propellant_used_kg: 0.0,
            impulse_ns: [0.0; THRUSTER_COUNT],
            firing_s: [0.0; THRUSTER_COUNT],
            pulse_count: [0; THRUSTER_COUNT],
            gravity_mps2: config.platform.gravity_mps2,
            rng: ChaCha8Rng::seed_from_u64(t.noise_seed),
            latch_shut: false,
            config: t,
        })
    }

    pub fn config(&self) -> &ThrusterConfig {
        &self.config
    }

    /// Issue `command` at plant time `t0_s`, for a period of `period_s` (on-times are clamped to
    /// `[0, period_s]`; a positive on-time below the minimum is stretched to it).
    pub fn command(&mut self, t0_s: f64, command: &ThrusterCommand, period_s: f64) {
        for i in 0..THRUSTER_COUNT {
            let mut t_on = command.on_time_s[i].clamp(0.0, period_s);
            if t_on <= 0.0 {
                continue;
            }
            t_on = t_on.max(self.config.min_on_time_s);
            let end = t0_s + t_on + self.config.close_delay_s;
            let continuing = self.electrical_end_s[i] >= t0_s - TOL_S;
            self.electrical_end_s[i] = t0_s + t_on;
            if continuing && let Some(last) = self.pulses[i].last_mut() {
                last.end_s = last.end_s.max(end);
                continue;
            }
            let start = t0_s + self.config.open_delay_s;
            if end <= start + TOL_S {
                continue;
            }
            let xi: f64 = self.rng.sample(StandardNormal);
            self.pulses[i].push(Pulse {
                start_s: start,
                end_s: end,
                factor: (1.0 + self.config.thrust_noise_fraction * xi) * self.scale[i],
            });
            self.pulse_count[i] += 1;
        }
    }

    fn tank_empty(&self) -> bool {
        self.propellant_used_kg >= self.config.propellant_kg
    }

    /// Shut (`true`) or open the latch valve upstream of all thrusters.
    pub fn set_latch_shut(&mut self, shut: bool) {
        self.latch_shut = shut;
    }

    pub fn latch_shut(&self) -> bool {
        self.latch_shut
    }

    /// Whether valve `i` is physically open at `t_s` (what a valve position sensor reads),
    /// whatever the latch and the tank.
    pub fn valve_open(&self, i: usize, t_s: f64) -> bool {
        self.stuck_at(i, t_s)
            || self.pulses[i]
                .iter()
                .any(|p| p.start_s <= t_s + TOL_S && t_s < p.end_s - TOL_S)
    }

    fn stuck_at(&self, i: usize, t_s: f64) -> bool {
        self.config
            .stuck_open
            .is_some_and(|s| s.thruster == i && t_s >= s.from_s - TOL_S)
    }

    /// Thrust of thruster `i` relative to nominal at time `t_s` (0 when shut).
    fn factor_at(&self, i: usize, t_s: f64) -> f64 {
        if self.tank_empty() || self.latch_shut {
            return 0.0;
        }
        if self.stuck_at(i, t_s) {
            return self.scale[i];
        }
        self.pulses[i]
            .iter()
            .find(|p| p.start_s <= t_s + TOL_S && t_s < p.end_s - TOL_S)
            .map_or(0.0, |p| p.factor)
    }

    /// Relative thrust of each thruster over `[t_s, next switch)`.
    pub fn factors_at(&self, t_s: f64) -> [f64; THRUSTER_COUNT] {
        std::array::from_fn(|i| self.factor_at(i, t_s))
    }

    /// First instant after `t_s` at which a valve's thrust switches, if any.
    pub fn next_switch_after(&self, t_s: f64) -> Option<f64> {
        let stuck = self
            .config
            .stuck_open
            .map(|s| s.from_s)
            .filter(|t| *t > t_s + TOL_S);
        self.pulses
            .iter()
            .flatten()
            .flat_map(|p| [p.start_s, p.end_s])
            .filter(|t| *t > t_s + TOL_S)
            .chain(stuck)
            .min_by(f64::total_cmp)
    }

    /// Torque of the thrusters at relative thrusts `factors`, Nm, body axes.
    pub fn torque_b(&self, factors: &[f64; THRUSTER_COUNT]) -> Vector3<f64> {
        (0..THRUSTER_COUNT).fold(Vector3::zeros(), |acc, i| {
            acc + self.torque_nm[i] * factors[i]
        })
    }

    /// Account `h` seconds of thrusting at relative thrusts `factors`: propellant, impulse and
    /// firing time.
    pub fn consume(&mut self, factors: &[f64; THRUSTER_COUNT], h: f64) {
        for (i, f) in factors.iter().enumerate() {
            if *f > 0.0 {
                self.propellant_used_kg += self.mass_flow_kg_s * f * h;
                self.impulse_ns[i] += self.config.thrust_n * f * h;
                self.firing_s[i] += h;
            }
        }
    }

    /// Drop the pulses that ended by `t_s`.
    pub fn discard_before(&mut self, t_s: f64) {
        for pulses in &mut self.pulses {
            pulses.retain(|p| p.end_s > t_s + TOL_S);
        }
    }

    /// Propellant used so far, kg.
    pub fn propellant_used_kg(&self) -> f64 {
        self.propellant_used_kg
    }

    /// Propellant left, kg.
    pub fn propellant_left_kg(&self) -> f64 {
        (self.config.propellant_kg - self.propellant_used_kg).max(0.0)
    }

    /// Change of the platform's weight moment `Σ m g r` from the propellant used, N m, body axes:
    /// `−m_u g r_t`.
    pub fn weight_moment_change_b(&self) -> Vector3<f64> {
        -Vector3::from(self.config.tank_position_m) * (self.propellant_used_kg * self.gravity_mps2)
    }

    /// Shift of the centre of mass from the propellant used, m, body axes, for a platform of
    /// full mass `mass_kg` whose centre of mass was at `com_m`:
    /// `Δr = −m_u (r_t − r_c) / (M − m_u)`.
    pub fn com_shift_m(&self, mass_kg: f64, com_m: &Vector3<f64>) -> Vector3<f64> {
        propellant_com_shift_m(
            &self.config.tank_position_m.into(),
            self.propellant_used_kg,
            mass_kg,
            com_m,
        )
    }

    /// Total impulse delivered per thruster, N s.
    pub fn impulse_ns(&self) -> &[f64; THRUSTER_COUNT] {
        &self.impulse_ns
    }

    /// Thrusting time per thruster, s.
    pub fn firing_s(&self) -> &[f64; THRUSTER_COUNT] {
        &self.firing_s
    }

    /// Pulses started per thruster.
    pub fn pulse_count(&self) -> &[u64; THRUSTER_COUNT] {
        &self.pulse_count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quiet() -> ModelConfig {
        ModelConfig {
            thrusters: Some(ThrusterConfig {
                thrust_noise_fraction: 0.0,
                ..ThrusterConfig::default()
            }),
            ..ModelConfig::default()
        }
    }

    /// Steps a bank as the plant does: one command per period, integration split at every valve
    /// switch, and returns the angular impulse (Nms, body axes).
    fn run_pulses(
        bank: &mut ThrusterBank,
        commands: &[ThrusterCommand],
        period_s: f64,
    ) -> Vector3<f64> {
        let mut t = 0.0;
        let mut angular_impulse = Vector3::zeros();
        for c in commands {
            bank.command(t, c, period_s);
            let t_end = t + period_s;
            while t_end - t > TOL_S {
                let seg_end = bank.next_switch_after(t).map_or(t_end, |s| s.min(t_end));
                let f = bank.factors_at(t);
                angular_impulse += bank.torque_b(&f) * (seg_end - t);
                bank.consume(&f, seg_end - t);
                t = seg_end;
            }
            t = t_end;
            bank.discard_before(t);
        }
        // Let the last pulses finish.
        while let Some(s) = bank.next_switch_after(t) {
            let f = bank.factors_at(t);
            angular_impulse += bank.torque_b(&f) * (s - t);
            bank.consume(&f, s - t);
            t = s;
        }
        angular_impulse
    }

    #[test]
    fn each_thruster_alone_gives_its_closed_form_torque() {
        let config = quiet();
        let bank = ThrusterBank::from_config(&config).unwrap();
        let t = config.thrusters.as_ref().unwrap();
        for i in 0..THRUSTER_COUNT {
            let mut f = [0.0; THRUSTER_COUNT];
            f[i] = 1.0;
            // r × F by hand for the default layout: rim 0.5 m × 0.1 N = 0.05 Nm about axis i/2.
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let want = Vector3::ith(i / 2, sign * 0.5 * t.thrust_n);
            assert!((bank.torque_b(&f) - want).norm() < 1e-15, "thruster {i}");
        }
    }

    #[test]
    fn impulse_of_a_pulse_train_is_n_times_thrust_times_on_time_plus_close_minus_open_delay() {
        let config = quiet();
        let t = config.thrusters.clone().unwrap();
        let period = 0.1;
        // Thruster 2 (+Y): 7 pulses of 40 ms, one per period, separated by off periods.
        let mut commands = Vec::new();
        for k in 0..14 {
            let mut c = ThrusterCommand::default();
            if k % 2 == 0 {
                c.on_time_s[2] = 0.04;
            }
            commands.push(c);
        }
        let mut bank = ThrusterBank::from_config(&config).unwrap();
        let h = run_pulses(&mut bank, &commands, period);
        let impulse = 7.0 * t.thrust_n * (0.04 + t.close_delay_s - t.open_delay_s);
        assert!(
            (bank.impulse_ns()[2] - impulse).abs() < 1e-12,
            "{:?}",
            bank.impulse_ns()
        );
        assert!(
            (h - Vector3::new(0.0, 0.5 * impulse, 0.0)).norm() < 1e-12,
            "{h:?}"
        );
        assert_eq!(bank.pulse_count()[2], 7);
        // Propellant: the impulse over Isp g0.
        let used = impulse / (t.isp_s * crate::thruster_config::G0_MPS2);
        assert!((bank.propellant_used_kg() - used).abs() < 1e-15);

        // Back-to-back full periods make one continuous pulse: one opening delay, one closing.
        let mut bank = ThrusterBank::from_config(&config).unwrap();
        let mut full = ThrusterCommand::default();
        full.on_time_s[5] = period;
        run_pulses(&mut bank, &[full; 5], period);
        let impulse = t.thrust_n * (5.0 * period + t.close_delay_s - t.open_delay_s);
        assert!((bank.impulse_ns()[5] - impulse).abs() < 1e-12);
        assert_eq!(bank.pulse_count()[5], 1);

        // A command below the minimum on-time gives the minimum impulse bit.
        let mut bank = ThrusterBank::from_config(&config).unwrap();
        let mut short = ThrusterCommand::default();
        short.on_time_s[0] = 0.002;
        run_pulses(&mut bank, &[short], period);
        assert!((bank.impulse_ns()[0] - t.minimum_impulse_bit_ns()).abs() < 1e-15);
    }

    #[test]
    fn thrust_noise_averages_to_nominal_within_its_standard_error() {
        // 400 pulses of 50 ms with 2 % pulse noise: the mean impulse is nominal within 4 standard
        // errors (σ/√n = 0.1 %; a fixed seed, so the test is deterministic; 4σ leaves it far
        // from flaky for any seed).
        let config = ModelConfig {
            thrusters: Some(ThrusterConfig::default()),
            ..ModelConfig::default()
        };
        let t = config.thrusters.clone().unwrap();
        let mut c = ThrusterCommand::default();
        c.on_time_s[1] = 0.05;
        let off = ThrusterCommand::default();
        let commands: Vec<_> = (0..800).map(|k| if k % 2 == 0 { c } else { off }).collect();
        let mut bank = ThrusterBank::from_config(&config).unwrap();
        run_pulses(&mut bank, &commands, 0.1);
        let nominal = 400.0 * t.thrust_n * (0.05 + t.close_delay_s - t.open_delay_s);
        let rel = bank.impulse_ns()[1] / nominal - 1.0;
        assert!(
            rel.abs() < 4.0 * 0.02 / 400f64.sqrt(),
            "relative error {rel}"
        );
        assert!(rel != 0.0, "noise is on");
    }

    #[test]
    fn com_shift_per_kilogram_of_propellant_is_the_tank_lever_over_the_remaining_mass() {
        let mut config = quiet();
        let t = config.thrusters.as_mut().unwrap();
        t.propellant_kg = 2.0;
        let t = t.clone();
        let mut bank = ThrusterBank::from_config(&config).unwrap();
        // Fire thruster 4 continuously until exactly 1 kg is used (closed form time).
        let dt = 1.0 / t.mass_flow_kg_s();
        let mut f = [0.0; THRUSTER_COUNT];
        f[4] = 1.0;
        bank.consume(&f, dt);
        assert!((bank.propellant_used_kg() - 1.0).abs() < 1e-12);
        let m = config.platform.mass_kg;
        let r_t = Vector3::from(t.tank_position_m);
        // Centre of mass of (M at 0) minus (1 kg at r_t): −r_t / (M − 1).
        let shift = bank.com_shift_m(m, &Vector3::zeros());
        assert!((shift - (-r_t / (m - 1.0))).norm() < 1e-15, "{shift:?}");
        // Its gravity torque: the remaining mass's weight at the shifted centre equals the
        // weight moment change −1 kg g r_t.
        let w = bank.weight_moment_change_b();
        assert!((w - shift * (m - 1.0) * config.platform.gravity_mps2).norm() < 1e-12);
        // An empty tank stops the thrust.
        let mut c = ThrusterCommand::default();
        c.on_time_s[0] = 0.1;
        bank.consume(&f, dt);
        bank.command(0.0, &c, 0.1);
        assert_eq!(bank.factors_at(0.05), [0.0; THRUSTER_COUNT]);
    }

    #[test]
    fn a_stuck_open_valve_thrusts_from_its_time_on_whatever_it_is_commanded() {
        let mut config = quiet();
        config.thrusters.as_mut().unwrap().stuck_open =
            Some(crate::thruster_config::StuckOpenValve {
                thruster: 3,
                from_s: 0.25,
            });
        let bank = ThrusterBank::from_config(&config).unwrap();
        assert_eq!(bank.factors_at(0.2)[3], 0.0);
        assert_eq!(bank.next_switch_after(0.0), Some(0.25));
        assert_eq!(bank.factors_at(0.25)[3], 1.0);
        assert_eq!(bank.factors_at(100.0)[3], 1.0);
    }
}
