//! What the thrusters did over a record, as the model's valves deliver the measured on-times:
//! each thruster's thrust time per tick interval, and the propellant used at each tick.
//!
//! The valve model is the model's own (`testbed_model::physics::ThrusterBank`: opening and
//! closing delays, minimum on-time, back-to-back pulses, the empty tank), run at nominal thrust
//! (no pulse noise, unit scale): each command of the data is issued at its time for the period
//! up to the next command, and the relative thrust is integrated exactly between valve
//! switches. The thrust noise is unknown and left out (it averages over the pulses).
//!
//! With thrust scale `s_i` (`effects.thruster_torque_scale`), thruster i's torque over tick
//! interval k is `s_i T_i a_{k,i}` (`T_i = r_i × F_i d_i`, `a` the thrust time below) and the
//! propellant used by tick k is `m_u,k = ṁ Σ_i s_i A_{k,i}` (`ṁ = F / (Isp g0)`, `A` the thrust
//! time up to tick k), as the model's bank draws it.

use crate::data::Aligned;
use nalgebra::{Matrix3, Vector3};
use testbed_model::ModelConfig;
use testbed_model::physics::{ThrusterBank, ThrusterCommand};
use testbed_model::thruster_config::THRUSTER_COUNT;

/// Times closer than this are the same instant, s.
const TOL_S: f64 = 1e-9;

/// The thrusters over a record, on the data's ticks (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct ThrusterHistory {
    /// Per tick k: each thruster's thrust time (nominal relative thrust integrated) over
    /// `[t_k, t_{k+1}]`, s (zero for the last tick).
    pub thrust_s: Vec<[f64; THRUSTER_COUNT]>,
    /// Per tick k: each thruster's thrust time over `[t_k, t_{k+1}]` weighted by the time then
    /// left in the interval, `∫ (t_{k+1} − τ) f(τ) dτ`, s² (`f` the relative thrust): where in
    /// the interval the thrust fell, which sets the mean rate over it (zero for the last tick).
    pub thrust_moment_s2: Vec<[f64; THRUSTER_COUNT]>,
    /// Per tick k: each thruster's thrust time from the record's start to `t_k`, s.
    pub cumulative_s: Vec<[f64; THRUSTER_COUNT]>,
    /// Nominal torque of each thruster `r × F`, Nm, body axes.
    pub torque_nm: [Vector3<f64>; THRUSTER_COUNT],
    /// Propellant flow of one thruster at nominal thrust, kg/s.
    pub mass_flow_kg_s: f64,
    /// The configuration's thrust scale per thruster (1 without the effect).
    pub scale: [f64; THRUSTER_COUNT],
    /// The configuration's tank position, m, body axes.
    pub tank_m: Vector3<f64>,
    /// Local gravity, m/s².
    pub gravity_mps2: f64,
    /// Per thruster, its pulses: `(tick in which the pulse started, thrust time s)`. Each pulse
    /// has its own thrust noise (`thrust_noise_fraction`, drawn at the valve's opening).
    pub pulses: [Vec<(usize, f64)>; THRUSTER_COUNT],
    /// The configuration's pulse-to-pulse thrust noise, 1σ relative.
    pub thrust_noise_fraction: f64,
}

impl ThrusterHistory {
    /// The history of `data`'s thruster commands under `config`; `None` without thruster
    /// firings in the data or without `[thrusters]` in the configuration.
    pub fn new(data: &Aligned, config: &ModelConfig) -> Option<Self> {
        let thrusters = config.thrusters.clone()?;
        if !data.has_thruster_firings() || data.is_empty() {
            return None;
        }
        let scale = config
            .effects
            .thruster_torque_scale
            .map_or([1.0; THRUSTER_COUNT], |s| s.scale);
        let mut nominal = config.clone();
        nominal.effects.thruster_torque_scale = None;
        if let Some(t) = nominal.thrusters.as_mut() {
            t.thrust_noise_fraction = 0.0;
        }
        let mut bank = ThrusterBank::from_config(&nominal)?;
        let cmds = &data.thruster_cmd;
        let period_of = |j: usize| {
            cmds.get(j + 1)
                .map_or(data.period_s, |(t, _)| t - cmds[j].0)
                .max(0.0)
        };
        let n = data.len();
        let mut thrust_s = vec![[0.0; THRUSTER_COUNT]; n];
        let mut thrust_moment_s2 = vec![[0.0; THRUSTER_COUNT]; n];
        let mut cumulative_s = vec![[0.0; THRUSTER_COUNT]; n];
        let mut total = [0.0; THRUSTER_COUNT];
        let mut pulses: [Vec<(usize, f64)>; THRUSTER_COUNT] = Default::default();
        // Integrate the relative thrust over [t, until), splitting at valve switches, into
        // `acc` and, weighted by the time left to `interval_end`, into `moment`; the thrust
        // time also goes to each thruster's current pulse.
        let integrate = |bank: &mut ThrusterBank,
                         t: &mut f64,
                         until: f64,
                         interval_end: f64,
                         acc: &mut [f64],
                         moment: &mut [f64],
                         pulses: &mut [Vec<(usize, f64)>; THRUSTER_COUNT]| {
            while until - *t > TOL_S {
                let end = bank.next_switch_after(*t).map_or(until, |s| s.min(until));
                let f = bank.factors_at(*t);
                let left = |x: f64| (interval_end - x).powi(2);
                for i in 0..THRUSTER_COUNT {
                    acc[i] += f[i] * (end - *t);
                    moment[i] += f[i] * 0.5 * (left(*t) - left(end));
                    if let Some(p) = pulses[i].last_mut() {
                        p.1 += f[i] * (end - *t);
                    }
                }
                bank.consume(&f, end - *t);
                *t = end;
            }
            *t = until.max(*t);
        };
        // Issue command j; a pulse it starts is recorded at tick `k`.
        let issue = |bank: &mut ThrusterBank,
                     t: f64,
                     j: usize,
                     k: usize,
                     pulses: &mut [Vec<(usize, f64)>; THRUSTER_COUNT]| {
            let before = *bank.pulse_count();
            bank.command(t, &command(&cmds[j].1), period_of(j));
            for i in 0..THRUSTER_COUNT {
                if bank.pulse_count()[i] > before[i] {
                    pulses[i].push((k, 0.0));
                }
            }
        };
        let mut next = 0;
        let mut t = data.t[0];
        // Commands before the first tick: issued, their thrust before it not recorded.
        if let Some((t_first, _)) = cmds.first() {
            t = t.min(*t_first);
        }
        let (mut discard, mut discard_moment) = ([0.0; THRUSTER_COUNT], [0.0; THRUSTER_COUNT]);
        let start = data.t[0];
        while next < cmds.len() && cmds[next].0 < start - TOL_S {
            let until = cmds[next].0;
            let (acc, moment) = (&mut discard, &mut discard_moment);
            integrate(&mut bank, &mut t, until, start, acc, moment, &mut pulses);
            issue(&mut bank, t, next, 0, &mut pulses);
            next += 1;
        }
        let (acc, moment) = (&mut discard, &mut discard_moment);
        integrate(&mut bank, &mut t, start, start, acc, moment, &mut pulses);
        for k in 0..n {
            cumulative_s[k] = total;
            let Some(&end) = data.t.get(k + 1) else {
                break;
            };
            let (mut acc, mut moment) = ([0.0; THRUSTER_COUNT], [0.0; THRUSTER_COUNT]);
            while next < cmds.len() && cmds[next].0 < end - TOL_S {
                let until = cmds[next].0;
                integrate(
                    &mut bank,
                    &mut t,
                    until,
                    end,
                    &mut acc,
                    &mut moment,
                    &mut pulses,
                );
                issue(&mut bank, t, next, k, &mut pulses);
                next += 1;
            }
            integrate(
                &mut bank,
                &mut t,
                end,
                end,
                &mut acc,
                &mut moment,
                &mut pulses,
            );
            bank.discard_before(t);
            for i in 0..THRUSTER_COUNT {
                total[i] += acc[i];
            }
            thrust_s[k] = acc;
            thrust_moment_s2[k] = moment;
        }
        Some(Self {
            thrust_s,
            thrust_moment_s2,
            cumulative_s,
            torque_nm: std::array::from_fn(|i| thrusters.torque_nm(i)),
            mass_flow_kg_s: thrusters.mass_flow_kg_s(),
            scale,
            tank_m: Vector3::from(thrusters.tank_position_m),
            gravity_mps2: config.platform.gravity_mps2,
            pulses,
            thrust_noise_fraction: thrusters.thrust_noise_fraction,
        })
    }

    /// Propellant used by tick `k` at the configuration's scales, kg.
    pub fn used_kg(&self, k: usize) -> f64 {
        self.mass_flow_kg_s
            * (0..THRUSTER_COUNT)
                .map(|i| self.scale[i] * self.cumulative_s[k][i])
                .sum::<f64>()
    }

    /// Angular impulse of the thrusters over `[t_k, t_{k+1}]` at the configuration's scales,
    /// Nms, body axes.
    pub fn impulse_nms(&self, k: usize) -> Vector3<f64> {
        (0..THRUSTER_COUNT).fold(Vector3::zeros(), |acc, i| {
            acc + self.torque_nm[i] * (self.scale[i] * self.thrust_s[k][i])
        })
    }

    /// What the thrusters add over `[t_k, t_{k+1}]` to the body's mean rate beyond the mean of
    /// the rates at the interval's ends, rad/s, body axes, with `inertia_inv` the platform's
    /// inverse inertia: `J⁻¹ Σ_i T_i (M_{k,i} / Δt − a_{k,i} / 2)` (`a` the thrust time, `M`
    /// its moment [`thrust_moment_s2`](Self::thrust_moment_s2)). A rate sampled at the ticks
    /// misses where in the interval a pulse fell: a pulse at its start turns the body for
    /// nearly the whole interval at the new rate, one at its end hardly at all; the mean of the
    /// ends counts half of either.
    ///
    /// At nominal thrust: the attitude filter that uses it must depend on the sensor causes
    /// only (its runs are shared between configurations that differ in the torque causes), and
    /// a thrust scale error changes this small correction by its own small fraction.
    pub fn intra_tick_rate(&self, k: usize, dt_s: f64, inertia_inv: &Matrix3<f64>) -> Vector3<f64> {
        if dt_s <= 0.0 {
            return Vector3::zeros();
        }
        let torque_s = (0..THRUSTER_COUNT).fold(Vector3::zeros(), |acc, i| {
            let excess = self.thrust_moment_s2[k][i] / dt_s - 0.5 * self.thrust_s[k][i];
            acc + self.torque_nm[i] * excess
        });
        inertia_inv * torque_s
    }

    /// Gravity torque of the propellant used by tick `k` at attitude gravity direction `g_b`
    /// (unit, body axes): `−m_u g r_t × G_B`, Nm.
    pub fn propellant_torque(&self, k: usize, g_b: &Vector3<f64>) -> Vector3<f64> {
        -(self.tank_m * (self.used_kg(k) * self.gravity_mps2)).cross(g_b)
    }

    /// Total thrust time per thruster over the record, s.
    pub fn total_thrust_s(&self) -> [f64; THRUSTER_COUNT] {
        self.cumulative_s
            .last()
            .copied()
            .unwrap_or([0.0; THRUSTER_COUNT])
    }
}

fn command(on_time_s: &[f64; THRUSTER_COUNT]) -> ThrusterCommand {
    ThrusterCommand {
        on_time_s: *on_time_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{Dataset, GyroRow, ThrusterRow};

    /// 10 s of 10 Hz ticks with thruster 2 commanded for 40 ms at every other tick and thruster
    /// 5 for two back-to-back full periods at 5.0 s.
    fn data() -> Dataset {
        let mut d = Dataset::default();
        for k in 0..=100 {
            let t = 0.1 * k as f64;
            d.gyro.push(GyroRow {
                t_s: t,
                rate_rad_s: Vector3::zeros(),
            });
            let mut on = [0.0; THRUSTER_COUNT];
            if k % 2 == 0 && k < 20 {
                on[2] = 0.04;
            }
            if k == 50 || k == 51 {
                on[5] = 0.1;
            }
            d.thrusters.push(ThrusterRow {
                t_s: t,
                on_time_s: on,
            });
        }
        d
    }

    #[test]
    fn thrust_time_is_the_valve_models_on_time_plus_close_minus_open_delay() {
        let config = ModelConfig {
            thrusters: Some(testbed_model::thruster_config::ThrusterConfig::default()),
            ..ModelConfig::default()
        };
        let t = config.thrusters.clone().unwrap_or_default();
        let aligned = Aligned::new(&data());
        let h = ThrusterHistory::new(&aligned, &config).expect("thrusters fired");
        // Each 40 ms pulse thrusts over [t0 + 5 ms, t0 + 43 ms): inside its own tick interval.
        let pulse = 0.04 + t.close_delay_s - t.open_delay_s;
        for k in 0..20 {
            let want = if k % 2 == 0 { pulse } else { 0.0 };
            assert!((h.thrust_s[k][2] - want).abs() < 1e-12, "tick {k}");
        }
        // Back-to-back full periods: one pulse from 5.005 s to 5.203 s.
        assert!((h.thrust_s[50][5] - 0.095).abs() < 1e-12);
        assert!((h.thrust_s[51][5] - 0.1).abs() < 1e-12);
        assert!((h.thrust_s[52][5] - 0.003).abs() < 1e-12);
        assert_eq!(h.pulses[5].len(), 1);
        assert_eq!(h.pulses[2].len(), 10);
        assert!((h.pulses[5][0].1 - 0.198).abs() < 1e-12);
        // Propellant: the thrust time times the flow, at the configuration's scale.
        let total = 10.0 * pulse + 0.198;
        assert!((h.used_kg(100) - total * t.mass_flow_kg_s()).abs() < 1e-15);
        // Angular impulse of thruster 2 (+Y, 0.05 Nm) over tick 0.
        assert!((h.impulse_nms(0) - Vector3::new(0.0, 0.05 * pulse, 0.0)).norm() < 1e-15);
        assert!(h.pulses[2].iter().all(|p| (p.1 - pulse).abs() < 1e-12));
        assert_eq!(h.pulses[2][3].0, 6);
    }

    #[test]
    fn a_pulse_early_in_its_interval_adds_to_the_mean_rate_and_a_full_one_does_not() {
        let config = ModelConfig {
            thrusters: Some(testbed_model::thruster_config::ThrusterConfig::default()),
            ..ModelConfig::default()
        };
        let t = config.thrusters.clone().unwrap_or_default();
        let h = ThrusterHistory::new(&Aligned::new(&data()), &config).expect("thrusters fired");
        // Thruster 2's 40 ms pulse thrusts over [open delay, 40 ms + close delay) of its 0.1-s
        // interval: the rate steps by J⁻¹ T a spread around the thrust's midpoint `m`, so the
        // mean rate over the interval gains J⁻¹ T a (1 − m / Δt) where the ends' mean counts
        // J⁻¹ T a / 2 (closed form, J = 1).
        let (start, end) = (t.open_delay_s, 0.04 + t.close_delay_s);
        let (a, m) = (end - start, 0.5 * (start + end));
        let moment = 0.5 * ((0.1 - start).powi(2) - (0.1 - end).powi(2));
        assert!((h.thrust_moment_s2[0][2] - moment).abs() < 1e-15);
        let excess = h.intra_tick_rate(0, 0.1, &Matrix3::identity());
        let want = Vector3::new(0.0, 0.05 * a * (0.5 - m / 0.1), 0.0);
        assert!((excess - want).norm() < 1e-15, "{excess} against {want}");
        // Inverse inertia: scales it.
        let j_inv = Matrix3::from_diagonal(&Vector3::new(0.5, 0.02, 0.25));
        assert!((h.intra_tick_rate(0, 0.1, &j_inv) - 0.02 * want).norm() < 1e-17);
        // Thrust over the whole interval (thruster 5 at 5.1 s) steps the rate linearly: the
        // mean of the ends is the mean. No thrust: nothing.
        assert!(h.intra_tick_rate(51, 0.1, &Matrix3::identity()).norm() < 1e-15);
        assert_eq!(
            h.intra_tick_rate(1, 0.1, &Matrix3::identity()),
            Vector3::zeros()
        );
    }

    #[test]
    fn no_history_without_firings_or_without_thrusters_in_the_model() {
        let mut quiet = data();
        for r in &mut quiet.thrusters {
            r.on_time_s = [0.0; THRUSTER_COUNT];
        }
        let with = ModelConfig {
            thrusters: Some(testbed_model::thruster_config::ThrusterConfig::default()),
            ..ModelConfig::default()
        };
        assert!(ThrusterHistory::new(&Aligned::new(&quiet), &with).is_none());
        assert!(ThrusterHistory::new(&Aligned::new(&data()), &ModelConfig::default()).is_none());
    }
}
