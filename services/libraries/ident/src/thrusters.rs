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
use nalgebra::Vector3;
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
        let mut cumulative_s = vec![[0.0; THRUSTER_COUNT]; n];
        let mut total = [0.0; THRUSTER_COUNT];
        // Integrate the relative thrust over [t, until), splitting at valve switches.
        let integrate = |bank: &mut ThrusterBank, t: &mut f64, until: f64, acc: &mut [f64]| {
            while until - *t > TOL_S {
                let end = bank.next_switch_after(*t).map_or(until, |s| s.min(until));
                let f = bank.factors_at(*t);
                for i in 0..THRUSTER_COUNT {
                    acc[i] += f[i] * (end - *t);
                }
                bank.consume(&f, end - *t);
                *t = end;
            }
            *t = until.max(*t);
        };
        let mut next = 0;
        let mut t = data.t[0];
        // Commands before the first tick: issued, their thrust before it not recorded.
        if let Some((t_first, _)) = cmds.first() {
            t = t.min(*t_first);
        }
        let mut discard = [0.0; THRUSTER_COUNT];
        while next < cmds.len() && cmds[next].0 < data.t[0] - TOL_S {
            integrate(&mut bank, &mut t, cmds[next].0, &mut discard);
            bank.command(t, &command(&cmds[next].1), period_of(next));
            next += 1;
        }
        integrate(&mut bank, &mut t, data.t[0], &mut discard);
        for k in 0..n {
            cumulative_s[k] = total;
            let Some(&end) = data.t.get(k + 1) else {
                break;
            };
            let mut acc = [0.0; THRUSTER_COUNT];
            while next < cmds.len() && cmds[next].0 < end - TOL_S {
                integrate(&mut bank, &mut t, cmds[next].0, &mut acc);
                bank.command(t, &command(&cmds[next].1), period_of(next));
                next += 1;
            }
            integrate(&mut bank, &mut t, end, &mut acc);
            bank.discard_before(t);
            for i in 0..THRUSTER_COUNT {
                total[i] += acc[i];
            }
            thrust_s[k] = acc;
        }
        Some(Self {
            thrust_s,
            cumulative_s,
            torque_nm: std::array::from_fn(|i| thrusters.torque_nm(i)),
            mass_flow_kg_s: thrusters.mass_flow_kg_s(),
            scale,
            tank_m: Vector3::from(thrusters.tank_position_m),
            gravity_mps2: config.platform.gravity_mps2,
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
