//! Thruster gateway logic: what reaches the valves and what is refused, and the
//! stuck-open valve monitor that disables the thrusters.
//!
//! **Refusal.** A [`ThrusterCommand`] is refused as a whole (every valve stays shut for the
//! period) and counted by class if any on-time is not finite ([`Refusal::NotFinite`]),
//! negative or longer than the command period ([`Refusal::OutOfRange`]), or positive and
//! shorter than the valves' minimum on-time ([`Refusal::TooShort`]).
//!
//! **Stuck-open valve.** At the end of each period the valves' position sensors are read. A
//! valve that reads open although its commanded pulse (on-time plus closing delay) ended
//! before the end of the period, `confirm_periods` periods in a row, is stuck open: the
//! monitor reports it once, the gateway shuts the latch valve and refuses every command from
//! then on (all valves shut), and the process publishes a health event.

use ipc_types::ThrusterCommand;
use testbed_model::thruster_config::{THRUSTER_COUNT, ThrusterConfig};

/// Why a thruster command was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    #[error("thruster {thruster}: on-time is not finite")]
    NotFinite { thruster: usize },
    #[error("thruster {thruster}: on-time outside [0, period]")]
    OutOfRange { thruster: usize },
    #[error("thruster {thruster}: on-time shorter than the valve's minimum")]
    TooShort { thruster: usize },
    #[error("thrusters disabled (stuck-open valve {thruster})")]
    Disabled { thruster: usize },
}

/// Refused commands by class since start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RefusalCounts {
    pub not_finite: u64,
    pub out_of_range: u64,
    pub too_short: u64,
    pub disabled: u64,
}

impl RefusalCounts {
    pub fn total(&self) -> u64 {
        self.not_finite + self.out_of_range + self.too_short + self.disabled
    }
}

/// The thruster gateway's checks.
#[derive(Debug, Clone)]
pub struct ThrusterGuard {
    min_on_s: f64,
    close_delay_s: f64,
    period_s: f64,
    confirm_periods: u32,
    refused: RefusalCounts,
    /// Consecutive periods each valve read open when it should have been shut.
    suspect: [u32; THRUSTER_COUNT],
    disabled: Option<usize>,
    /// On-times applied in the current period, s.
    applied: [f64; THRUSTER_COUNT],
}

impl ThrusterGuard {
    /// Checks for the valves of `config` at command period `period_s`; a stuck valve is
    /// confirmed after `confirm_periods` periods (≥ 1).
    pub fn new(config: &ThrusterConfig, period_s: f64, confirm_periods: u32) -> Self {
        Self {
            min_on_s: config.min_on_time_s,
            close_delay_s: config.close_delay_s,
            period_s,
            confirm_periods: confirm_periods.max(1),
            refused: RefusalCounts::default(),
            suspect: [0; THRUSTER_COUNT],
            disabled: None,
            applied: [0.0; THRUSTER_COUNT],
        }
    }

    pub fn refused(&self) -> RefusalCounts {
        self.refused
    }

    /// The stuck valve that disabled the thrusters, if any.
    pub fn disabled(&self) -> Option<usize> {
        self.disabled
    }

    /// The on-times to apply for `command` (all zero if it is refused; the refusal is counted
    /// and returned).
    pub fn check(&mut self, command: &ThrusterCommand) -> ([f64; THRUSTER_COUNT], Option<Refusal>) {
        let refusal = self.classify(command);
        match refusal {
            None => self.applied = command.on_time,
            Some(r) => {
                match r {
                    Refusal::NotFinite { .. } => self.refused.not_finite += 1,
                    Refusal::OutOfRange { .. } => self.refused.out_of_range += 1,
                    Refusal::TooShort { .. } => self.refused.too_short += 1,
                    Refusal::Disabled { .. } => self.refused.disabled += 1,
                }
                self.applied = [0.0; THRUSTER_COUNT];
            }
        }
        (self.applied, refusal)
    }

    fn classify(&self, command: &ThrusterCommand) -> Option<Refusal> {
        if let Some(thruster) = self.disabled {
            return command
                .on_time
                .iter()
                .any(|t| *t != 0.0)
                .then_some(Refusal::Disabled { thruster });
        }
        for (thruster, t) in command.on_time.iter().enumerate() {
            if !t.is_finite() {
                return Some(Refusal::NotFinite { thruster });
            }
            if *t < 0.0 || *t > self.period_s + 1e-12 {
                return Some(Refusal::OutOfRange { thruster });
            }
            if *t > 0.0 && *t < self.min_on_s {
                return Some(Refusal::TooShort { thruster });
            }
        }
        None
    }

    /// The valves' sensed positions at the end of the period (bit `i`: valve `i` open). Returns
    /// the valve newly found stuck open, once; from then on the thrusters are disabled.
    pub fn on_valves_sensed(&mut self, open_bits: u32) -> Option<usize> {
        if self.disabled.is_some() {
            return None;
        }
        for i in 0..THRUSTER_COUNT {
            let open = open_bits & (1 << i) != 0;
            // Shut by now unless the pulse runs to the period's end (plus the closing delay).
            let should_be_open = self.applied[i] + self.close_delay_s >= self.period_s - 1e-9;
            if open && !should_be_open {
                self.suspect[i] += 1;
                if self.suspect[i] >= self.confirm_periods {
                    self.disabled = Some(i);
                    return Some(i);
                }
            } else {
                self.suspect[i] = 0;
            }
        }
        None
    }
}

/// The propellant the gateway estimates from the on-times the board applied: each pulse of
/// electrical on-time `t` (stretched to the minimum on-time) lets gas through for
/// `t + close_delay − open_delay` at the nominal flow `F / (Isp g0)` of the configuration.
/// A gateway sees no thrust noise, scale error or empty tank: this is the nominal budget, and
/// the difference from the plant's truth is part of what identification can name.
#[derive(Debug, Clone)]
pub struct PropellantEstimate {
    flow_kg_s: f64,
    min_on_s: f64,
    gas_extra_s: f64,
    used_kg: f64,
}

impl PropellantEstimate {
    /// An estimate for the valves of `config`, starting from nothing used.
    pub fn new(config: &ThrusterConfig) -> Self {
        Self {
            flow_kg_s: config.mass_flow_kg_s(),
            min_on_s: config.min_on_time_s,
            gas_extra_s: config.close_delay_s - config.open_delay_s,
            used_kg: 0.0,
        }
    }

    /// Adds one period's applied on-times, s.
    pub fn add(&mut self, applied_on_time_s: &[f64; THRUSTER_COUNT]) {
        for &t in applied_on_time_s {
            if t.is_finite() && t > 0.0 {
                let gas_s = (t.max(self.min_on_s) + self.gas_extra_s).max(0.0);
                self.used_kg += gas_s * self.flow_kg_s;
            }
        }
    }

    /// Propellant used since start, kg.
    pub fn used_kg(&self) -> f64 {
        self.used_kg
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::SampleHeader;
    use testbed_model::ModelConfig;
    use testbed_model::physics::{ThrusterBank, ThrusterCommand as ValveCommand};
    use testbed_model::thruster_config::StuckOpenValve;

    fn command(on: [f64; 6]) -> ThrusterCommand {
        ThrusterCommand {
            header: SampleHeader::default(),
            on_time: on,
        }
    }

    #[test]
    fn bad_commands_are_refused_counted_and_shut_every_valve() {
        let mut g = ThrusterGuard::new(&ThrusterConfig::default(), 0.1, 3);
        let (applied, r) = g.check(&command([0.05, 0.0, 0.0, 0.0, 0.1, 0.0]));
        assert_eq!((applied, r), ([0.05, 0.0, 0.0, 0.0, 0.1, 0.0], None));
        let bad = [
            (
                [0.05, f64::NAN, 0.0, 0.0, 0.0, 0.0],
                Refusal::NotFinite { thruster: 1 },
            ),
            (
                [0.0, 0.0, f64::INFINITY, 0.0, 0.0, 0.0],
                Refusal::NotFinite { thruster: 2 },
            ),
            (
                [0.0, 0.0, 0.0, -0.01, 0.0, 0.0],
                Refusal::OutOfRange { thruster: 3 },
            ),
            (
                [0.0, 0.0, 0.0, 0.0, 0.15, 0.0],
                Refusal::OutOfRange { thruster: 4 },
            ),
            (
                [0.0, 0.0, 0.0, 0.0, 0.0, 0.019],
                Refusal::TooShort { thruster: 5 },
            ),
        ];
        for (on, want) in bad {
            let (applied, r) = g.check(&command(on));
            assert_eq!(r, Some(want));
            assert_eq!(applied, [0.0; 6]);
        }
        assert_eq!(
            g.refused(),
            RefusalCounts {
                not_finite: 2,
                out_of_range: 2,
                too_short: 1,
                disabled: 0
            }
        );
        // The minimum on-time itself and the full period pass.
        assert_eq!(g.check(&command([0.02, 0.0, 0.0, 0.0, 0.0, 0.1])).1, None);
    }

    #[test]
    fn a_stuck_open_valve_is_detected_and_the_thrusters_disabled() {
        let mut model = ModelConfig::default();
        let period = 0.1;
        model.thrusters = Some(ThrusterConfig {
            stuck_open: Some(StuckOpenValve {
                thruster: 2,
                from_s: 1.0,
            }),
            ..ThrusterConfig::default()
        });
        let t = model.thrusters.clone().unwrap();
        let mut bank = ThrusterBank::from_config(&model).unwrap();
        let mut g = ThrusterGuard::new(&t, period, 3);
        let mut found = None;
        for k in 0..40 {
            let t0 = k as f64 * period;
            // Normal pulsing on every thruster, including full periods on thruster 0.
            let on = [0.1, 0.03, 0.03, 0.0, 0.05, 0.0];
            let (applied, _) = g.check(&command(on));
            bank.command(t0, &ValveCommand { on_time_s: applied }, period);
            let end = t0 + period;
            let bits = (0..6).fold(0u32, |b, i| {
                b | (u32::from(bank.valve_open(i, end - 1e-6)) << i)
            });
            if let Some(i) = g.on_valves_sensed(bits) {
                assert!(found.is_none(), "reported once");
                found = Some((i, k));
                bank.set_latch_shut(true);
            }
        }
        // Stuck from 1.0 s (period 10); confirmed at the end of its third period (k = 12).
        assert_eq!(found, Some((2, 12)));
        assert_eq!(g.disabled(), Some(2));
        // Disabled: every non-zero command refused, no thrust at all.
        assert!(g.refused().disabled > 0);
        assert_eq!(bank.factors_at(5.0), [0.0; 6]);
        // Before the fault, no false alarm with the same commands.
        let mut g = ThrusterGuard::new(&t, period, 3);
        let mut clean = ThrusterBank::from_config(&ModelConfig {
            thrusters: Some(ThrusterConfig::default()),
            ..ModelConfig::default()
        })
        .unwrap();
        for k in 0..100 {
            let t0 = k as f64 * period;
            let (applied, _) = g.check(&command([0.1, 0.03, 0.03, 0.0, 0.05, 0.0]));
            clean.command(t0, &ValveCommand { on_time_s: applied }, period);
            let end = t0 + period;
            let bits = (0..6).fold(0u32, |b, i| {
                b | (u32::from(clean.valve_open(i, end - 1e-6)) << i)
            });
            assert_eq!(g.on_valves_sensed(bits), None, "period {k}");
        }
    }

    #[test]
    fn the_propellant_estimate_is_the_nominal_flow_times_the_gas_time() {
        let config = ThrusterConfig::default();
        let mut p = PropellantEstimate::new(&config);
        // One 50-ms pulse and one 1-ms pulse (stretched to the minimum on-time).
        p.add(&[0.05, 0.0, 0.001, 0.0, 0.0, 0.0]);
        let extra = config.close_delay_s - config.open_delay_s;
        let want = config.mass_flow_kg_s() * ((0.05 + extra) + (config.min_on_time_s + extra));
        assert!(
            (p.used_kg() - want).abs() <= 1e-15,
            "{} vs {want}",
            p.used_kg()
        );
        p.add(&[f64::NAN, -1.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((p.used_kg() - want).abs() <= 1e-15);
    }
}
