//! What the thrusters did in an in-process closed-loop run: per tick the activity,
//! the valve command and the propellant used; at the end the totals and the centre-of-mass shift.

use nalgebra::Vector3;
use testbed_flight::thruster_control::{ThrusterActivity, ThrusterOutput};
use testbed_model::ModelConfig;
use testbed_model::physics::{ThrusterBank, ThrusterCommand};
use testbed_model::thruster_config::THRUSTER_COUNT;

/// One control tick of the thrusters.
#[derive(Debug, Clone, PartialEq)]
pub struct ThrusterTick {
    pub t_s: f64,
    pub activity: ThrusterActivity,
    /// Valve on-times commanded at this tick, s.
    pub command: ThrusterCommand,
    /// Propellant used by this tick, kg.
    pub propellant_used_kg: f64,
    /// True wheel momentum `J n`, Nms, body axes.
    pub wheel_momentum_nms: Vector3<f64>,
}

/// The thrusters over a run (empty without `[thrusters]`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ThrusterTrace {
    pub ticks: Vec<ThrusterTick>,
    /// Propellant used over the run, kg.
    pub propellant_used_kg: f64,
    /// Shift of the centre of mass the propellant used caused, m, body axes.
    pub com_shift_m: Vector3<f64>,
    /// Impulse delivered per thruster, N s.
    pub impulse_ns: [f64; THRUSTER_COUNT],
    /// Pulses per thruster.
    pub pulses: [u64; THRUSTER_COUNT],
    /// Thrusting time per thruster, s.
    pub firing_s: [f64; THRUSTER_COUNT],
}

impl ThrusterTrace {
    pub(crate) fn record(
        &mut self,
        t_s: f64,
        output: Option<&ThrusterOutput>,
        bank: &ThrusterBank,
        wheel_speed_rad_s: &Vector3<f64>,
        model: &ModelConfig,
    ) {
        self.ticks.push(ThrusterTick {
            t_s,
            activity: output.map_or(ThrusterActivity::Idle, |o| o.activity),
            command: output.map_or_else(ThrusterCommand::default, |o| o.command),
            propellant_used_kg: bank.propellant_used_kg(),
            wheel_momentum_nms: wheel_speed_rad_s * model.wheels.inertia_kgm2,
        });
    }

    pub(crate) fn finish(&mut self, bank: &ThrusterBank, model: &ModelConfig) {
        let com = model
            .effects
            .com_offset
            .as_ref()
            .map_or_else(Vector3::zeros, |c| Vector3::from(c.r_m));
        self.propellant_used_kg = bank.propellant_used_kg();
        self.com_shift_m = bank.com_shift_m(model.platform.mass_kg, &com);
        self.impulse_ns = *bank.impulse_ns();
        self.pulses = *bank.pulse_count();
        self.firing_s = *bank.firing_s();
    }

    /// Time windows `[start, end)` (s) during which the thrusters were dumping momentum, each
    /// extended by `settle_s` after the dump's last tick.
    pub fn dump_windows(&self, settle_s: f64) -> Vec<(f64, f64)> {
        let mut windows: Vec<(f64, f64)> = Vec::new();
        for t in self
            .ticks
            .iter()
            .filter(|t| t.activity == ThrusterActivity::Dumping)
        {
            match windows.last_mut() {
                Some(w) if t.t_s <= w.1 => w.1 = t.t_s + settle_s,
                _ => windows.push((t.t_s, t.t_s + settle_s)),
            }
        }
        windows
    }
}
