//! The controller task: one command per tick from the estimate and the actuators' telemetry of
//! that tick. It assembles each tick's inputs, judges them (lost or invalid inputs, a wheel
//! near its speed limit: safe mode, [`crate::safe_mode`]), follows the ground's commands
//! (`ground`) and calls the control law once per cycle (`law`: the law chosen by name,
//! [`crate::laws`], inside the actuators' limits, and the thrusters). Its configuration is
//! `config`.

mod config;
mod ground;
mod law;
#[cfg(test)]
mod tests;

pub use config::ControllerConfig;
pub use law::GuardedLaw;

use crate::control::ControlError;
use crate::convert::{Sequence, a3, a4, quaternion_from_array, seconds, v3, v4};
use crate::laws::{ActuatorTelemetry, Drives};
use crate::safe_mode::{
    SafeMode, SafeModeConfig, SafeReason, SafeReasons, SafeTransition, SafeWheels,
    safe_wheel_torque,
};
use crate::schedule::Schedule;
use crate::thruster_control::ThrusterActivity;
use ipc_types::{
    AttitudeEstimate, CmgCommand, CmgTelemetry, ControllerMode, ControllerStatus, GyroSample,
    SampleHeader, WheelCommand, WheelTelemetry,
};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use testbed_model::ModelConfig;
use testbed_model::attitude::Attitude;
use testbed_model::physics::ActuatorCommand;

/// An input is lost when the newest sample seen of any input is this many control periods
/// newer than its own newest sample.
const LOST_AFTER_PERIODS: u64 = 2;

#[derive(Debug, Default, Clone, Copy)]
struct Pending {
    estimate: Option<AttitudeEstimate>,
    wheels: Option<WheelTelemetry>,
    cmg: Option<CmgTelemetry>,
}

/// One tick's outputs, published status first, then the commands.
#[derive(Debug, Clone, Copy)]
pub struct ControlCycle {
    pub status: ControllerStatus,
    pub wheels: WheelCommand,
    pub cmg: CmgCommand,
    /// Valve on-times for the next period: every cycle with thruster control (all shut when
    /// the law has none), `None` without.
    pub thrusters: Option<ipc_types::ThrusterCommand>,
}

/// Newest sample times of the controller's inputs (run clock, ns): what tells a lost input.
#[derive(Debug, Default, Clone, Copy)]
struct InputTimes {
    /// The newest time of any input: the controller's "now".
    newest_ns: Option<u64>,
    estimate_ns: Option<u64>,
    wheels_ns: Option<u64>,
    cmg_ns: Option<u64>,
    /// A valid estimate has been seen: from then on an invalid one is a fault, not start-up.
    had_valid_estimate: bool,
}

impl InputTimes {
    fn saw(&mut self, t_ns: u64) {
        newest(&mut self.newest_ns, t_ns);
    }

    /// Whether an input whose newest sample is `own_ns` is lost: the freshest input is
    /// [`LOST_AFTER_PERIODS`] periods newer. An input never seen is judged from the first
    /// sample of any input on (start-up takes the same grace).
    fn lost(&self, own_ns: Option<u64>, first_ns: u64, period_ns: u64) -> bool {
        let newest = self.newest_ns.unwrap_or(0);
        newest >= own_ns.unwrap_or(first_ns) + LOST_AFTER_PERIODS * period_ns
    }
}

/// Keeps in `slot` the newest of its time and `t_ns`.
fn newest(slot: &mut Option<u64>, t_ns: u64) {
    *slot = Some(slot.map_or(t_ns, |n| n.max(t_ns)));
}

/// The wheels' limits the safe torque respects.
#[derive(Debug, Clone, Copy)]
struct WheelLimits {
    max_torque_nm: f64,
    max_speed_rad_s: f64,
}

/// The controller: one command per tick from the estimate and the actuators' telemetry, safe
/// mode, ground commands; the law ([`GuardedLaw`]: the configured law inside the actuators'
/// limits) computes the command.
pub struct ControllerTask {
    law: GuardedLaw,
    drives: Drives,
    schedule: Schedule,
    period_ns: u64,
    pending: BTreeMap<u64, Pending>,
    last_cycle_ns: Option<u64>,
    deadline_misses: u64,
    errors: u64,
    status_seq: Sequence,
    wheel_seq: Sequence,
    cmg_seq: Sequence,
    thruster_seq: Sequence,
    inputs: InputTimes,
    first_input_ns: Option<u64>,
    /// The latest gyro sample: time (ns) and body rate (rad/s), for rate damping in safe mode.
    gyro: Option<(u64, Vector3<f64>)>,
    safe: SafeMode,
    wheel_limits: WheelLimits,
    transitions: Vec<(u64, SafeTransition)>,
    /// The mode the ground asked for, when it is not the configured law (idle, rate damping).
    ground_mode: Option<ControllerMode>,
}

impl ControllerTask {
    /// The controller of `config` (actuators, law, safe mode) for `model`'s wheels on
    /// `schedule`, pointing at `target` (level frame to body frame).
    pub fn new(
        config: &ControllerConfig,
        model: &ModelConfig,
        target: Attitude,
        schedule: Schedule,
    ) -> Result<Self, ControlError> {
        let law = config.law(model, target)?;
        let wheels = &model.wheels;
        Ok(Self {
            drives: law.drives(),
            law,
            schedule,
            period_ns: (schedule.time_ns(1)).max(1),
            pending: BTreeMap::new(),
            last_cycle_ns: None,
            deadline_misses: 0,
            errors: 0,
            status_seq: Sequence::default(),
            wheel_seq: Sequence::default(),
            cmg_seq: Sequence::default(),
            thruster_seq: Sequence::default(),
            inputs: InputTimes::default(),
            first_input_ns: None,
            gyro: None,
            safe: SafeMode::new(config.safe_mode.clone()),
            wheel_limits: WheelLimits {
                max_torque_nm: wheels.max_torque_nm,
                max_speed_rad_s: wheels.max_speed_rad_s(),
            },
            transitions: Vec::new(),
            ground_mode: None,
        })
    }

    /// Safe mode (state, reasons, entries).
    pub fn safe_mode(&self) -> &SafeMode {
        &self.safe
    }

    /// The time of the newest control cycle, ns.
    pub fn last_cycle_ns(&self) -> Option<u64> {
        self.last_cycle_ns
    }

    /// From which time stamp on actuator telemetry needs to wake the controller, ns (0: all of
    /// it). While the estimate is healthy and no pending tick has its estimate yet, the
    /// telemetry of the next tick to run cannot complete anything: that tick waits for its
    /// estimate, which wakes the controller itself, and an estimate that never comes is
    /// judged lost only from the telemetry of the tick after ([`LOST_AFTER_PERIODS`]), which
    /// still wakes it. So the telemetry that usually comes first in a tick costs no
    /// wake-up of its own, and what runs when is unchanged. Before the first cycle, once an
    /// estimate is waiting for its telemetry, and once the estimate is lost (safe cycles run
    /// on the telemetry), every sample wakes.
    pub fn telemetry_wake_from_ns(&self) -> u64 {
        let Some(last) = self.last_cycle_ns else {
            return 0;
        };
        if self.estimate_lost() || self.pending.values().any(|p| p.estimate.is_some()) {
            return 0;
        }
        last + 2 * self.period_ns
    }

    /// Safe-mode changes since the last call, with their run times (ns).
    pub fn take_transitions(&mut self) -> Vec<(u64, SafeTransition)> {
        std::mem::take(&mut self.transitions)
    }

    fn saw(&mut self, t_ns: u64) {
        self.first_input_ns.get_or_insert(t_ns);
        self.inputs.saw(t_ns);
    }

    /// A cycle that should have run did not (reported by the process's deadline).
    pub fn count_deadline_miss(&mut self) {
        self.deadline_misses += 1;
    }

    pub fn deadline_misses(&self) -> u64 {
        self.deadline_misses
    }

    pub fn errors(&self) -> u64 {
        self.errors
    }

    fn slot(&mut self, t_ns: u64) -> Option<&mut Pending> {
        let fresh = self.last_cycle_ns.is_none_or(|last| t_ns > last);
        (fresh && self.schedule.tick_at(t_ns).is_some())
            .then(|| self.pending.entry(t_ns).or_default())
    }

    pub fn on_estimate(&mut self, e: &AttitudeEstimate) {
        let t_ns = e.header.time_ns;
        self.saw(t_ns);
        newest(&mut self.inputs.estimate_ns, t_ns);
        if let Some(p) = self.slot(t_ns) {
            p.estimate = Some(*e);
        }
    }

    pub fn on_wheel_telemetry(&mut self, t: &WheelTelemetry) {
        let t_ns = t.header.time_ns;
        self.saw(t_ns);
        newest(&mut self.inputs.wheels_ns, t_ns);
        if let Some(p) = self.slot(t_ns) {
            p.wheels = Some(*t);
        }
    }

    pub fn on_cmg_telemetry(&mut self, t: &CmgTelemetry) {
        let t_ns = t.header.time_ns;
        self.saw(t_ns);
        newest(&mut self.inputs.cmg_ns, t_ns);
        if let Some(p) = self.slot(t_ns) {
            p.cmg = Some(*t);
        }
    }

    /// A gyro sample: the body rate safe mode damps (the estimator may be what failed).
    pub fn on_gyro(&mut self, g: &GyroSample) {
        let t_ns = g.header.time_ns;
        let newer = self.gyro.is_none_or(|(last, _)| t_ns >= last);
        if newer && g.header.is_valid() {
            self.gyro = Some((t_ns, v3(&g.rate)));
        }
    }

    /// Whether the estimate stream is lost (see [`LOST_AFTER_PERIODS`]); never before the
    /// first estimate (the estimator may still be starting).
    fn estimate_lost(&self) -> bool {
        self.inputs.estimate_ns.is_some()
            && self.inputs.lost(
                self.inputs.estimate_ns,
                self.first_input_ns.unwrap_or(0),
                self.period_ns,
            )
    }

    /// Cycles for every tick whose estimate and telemetry are all in, oldest first. A tick
    /// overtaken by a later estimate runs with what it has (missing telemetry reads as zero).
    /// Once the estimate is lost, every tick with actuator telemetry runs in safe mode.
    pub fn ready(&mut self) -> Vec<ControlCycle> {
        let mut out = Vec::new();
        self.ready_into(&mut out);
        out
    }

    /// [`Self::ready`] appending to `out`, which is not cleared: a process keeps one buffer for
    /// the run, so that a cycle allocates nothing.
    pub fn ready_into(&mut self, out: &mut Vec<ControlCycle>) {
        let estimate_lost = self.estimate_lost();
        let newest_estimate = self
            .pending
            .iter()
            .rev()
            .find(|(_, p)| p.estimate.is_some())
            .map(|(t, _)| *t);
        while let Some((&t_ns, p)) = self.pending.first_key_value() {
            let complete = p.estimate.is_some() && p.wheels.is_some() && p.cmg.is_some();
            let overtaken = newest_estimate.is_some_and(|n| n > t_ns);
            let without_estimate = estimate_lost && (p.wheels.is_some() || p.cmg.is_some());
            if !(complete || overtaken || without_estimate) {
                break;
            }
            let p = *p;
            self.pending.remove(&t_ns);
            // Without an estimate only the newest tick is worth a command: one for an older
            // tick would reach the actuators late.
            let newest = self.inputs.newest_ns.is_none_or(|n| t_ns >= n);
            if p.estimate.is_some() || (without_estimate && newest) {
                out.push(self.cycle(t_ns, &p));
            }
        }
    }

    fn cycle(&mut self, t_ns: u64, p: &Pending) -> ControlCycle {
        let period = self.last_cycle_ns.map_or(0, |last| t_ns - last);
        self.last_cycle_ns = Some(t_ns);
        let telemetry = ActuatorTelemetry {
            wheel_speed_rad_s: v3(&p.wheels.map_or([0.0; 3], |w| w.speed)),
            gimbal_rad: v4(&p.cmg.map_or([0.0; 4], |c| c.gimbal_angle)),
        };
        let estimate = p.estimate.filter(|e| e.header.is_valid());
        let attitude =
            estimate.and_then(|e| quaternion_from_array(&e.quaternion).map(|q| (q, v3(&e.rate))));
        let usable = attitude
            .as_ref()
            .is_some_and(|(q, rate)| q.coords.iter().chain(rate.iter()).all(|x| x.is_finite()));
        self.inputs.had_valid_estimate |= usable;
        let wrong = self.wrong_inputs(t_ns, p, usable, &telemetry);
        if let Some(transition) = self.safe.update(t_ns, wrong) {
            self.transitions.push((t_ns, transition));
        }
        if self.safe.is_active() {
            return self.safe_cycle(t_ns, period, &telemetry);
        }
        let mut thrust = None;
        let (mut command, error, mut mode, saturated) = match attitude {
            Some((q, rate)) => match self.law.command(seconds(t_ns), &q, &rate, &telemetry) {
                Ok(mut o) => {
                    thrust = self.law.thrusters(&rate, &telemetry, &mut o);
                    let mode = match (self.drives.cmgs, thrust.map(|t| t.activity)) {
                        (_, Some(ThrusterActivity::Dumping)) => ControllerMode::MomentumDump,
                        (_, Some(ThrusterActivity::RateDamping)) => {
                            ControllerMode::ThrusterRateDamping
                        }
                        (false, _) => ControllerMode::WheelPointing,
                        (true, _) => ControllerMode::CmgSlew,
                    };
                    (o.command, o.error_rad, mode, o.saturated)
                }
                Err(e) => {
                    tracing::warn!(
                        "control law refused its inputs at t = {} s: {e}",
                        seconds(t_ns)
                    );
                    self.errors += 1;
                    (
                        ActuatorCommand::default(),
                        Default::default(),
                        ControllerMode::Fault,
                        false,
                    )
                }
            },
            None => (
                ActuatorCommand::default(),
                Default::default(),
                ControllerMode::Idle,
                false,
            ),
        };
        // A mode commanded from the ground replaces the law's command (the error is still
        // reported against the target).
        if let (Some(ground), Some((_, rate))) = (self.ground_mode, attitude.as_ref())
            && mode != ControllerMode::Fault
        {
            let wheel_torque_nm = if ground == ControllerMode::RateDamping {
                let config = SafeModeConfig {
                    wheels: SafeWheels::RateDamping,
                    ..self.safe.config().clone()
                };
                safe_wheel_torque(
                    &config,
                    Some(rate),
                    &telemetry.wheel_speed_rad_s,
                    self.wheel_limits.max_torque_nm,
                    self.wheel_limits.max_speed_rad_s,
                )
            } else {
                Vector3::zeros()
            };
            command = ActuatorCommand {
                wheel_torque_nm,
                gimbal_rate_rad_s: Default::default(),
            };
            mode = ground;
        }
        let mut status = ControllerStatus {
            header: self.status_seq.header(
                t_ns,
                SampleHeader::VALID
                    | if saturated {
                        SampleHeader::SATURATED_ANY
                    } else {
                        0
                    },
            ),
            attitude_error: a3(&error),
            // The platform feels the opposite of the wheels' motor torque.
            torque_command: a3(&(-command.wheel_torque_nm)),
            deadline_misses: self.deadline_misses,
            loop_period_ns: period,
            ..ControllerStatus::default()
        };
        status.set_mode(mode);
        self.outputs(t_ns, status, &command, thrust.map(|t| t.command))
    }

    /// What is wrong with the inputs of the cycle at `t_ns` (the reasons for safe mode).
    fn wrong_inputs(
        &self,
        t_ns: u64,
        p: &Pending,
        usable_estimate: bool,
        telemetry: &ActuatorTelemetry,
    ) -> SafeReasons {
        let first = self.first_input_ns.unwrap_or(t_ns);
        let limit = self.safe.config().wheel_speed_fraction * self.wheel_limits.max_speed_rad_s;
        let wheels_fast = p.wheels.is_some()
            && telemetry
                .wheel_speed_rad_s
                .iter()
                .any(|n| n.is_nan() || n.abs() >= limit);
        SafeReasons::NONE
            .with(
                SafeReason::EstimateLost,
                p.estimate.is_none() && self.estimate_lost(),
            )
            .with(
                SafeReason::EstimateInvalid,
                p.estimate.is_some() && !usable_estimate && self.inputs.had_valid_estimate,
            )
            .with(
                SafeReason::WheelTelemetryLost,
                self.inputs
                    .lost(self.inputs.wheels_ns, first, self.period_ns),
            )
            .with(
                SafeReason::CmgTelemetryLost,
                self.inputs.lost(self.inputs.cmg_ns, first, self.period_ns),
            )
            .with(SafeReason::WheelSpeedLimit, wheels_fast)
    }

    /// Every input has gone silent past the control deadline (a paced run's wall-clock deadline:
    /// a CAN link down, a dead estimator and gateways). The data-driven checks of [`Self::ready`]
    /// need a sample to notice anything, so the silence itself enters safe mode: once two
    /// periods have passed since the last cycle, the tick after it runs as a safe cycle, with
    /// the estimate and the actuators' telemetry counted lost (no wheel torque, gimbals held).
    /// `missed` is how many deadlines have passed in a row. None before the first cycle, and
    /// from `run_end_ns` on (the run's end silences every input; that is no fault).
    pub fn on_silence(&mut self, missed: u64, run_end_ns: u64) -> Option<ControlCycle> {
        let last = self.last_cycle_ns?;
        let t_ns = last + self.period_ns;
        if missed < LOST_AFTER_PERIODS || t_ns >= run_end_ns {
            return None;
        }
        let period = self.period_ns;
        self.last_cycle_ns = Some(t_ns);
        self.pending.retain(|&t, _| t > t_ns);
        let wrong = SafeReasons::NONE
            .with(SafeReason::EstimateLost, true)
            .with(SafeReason::WheelTelemetryLost, true)
            .with(SafeReason::CmgTelemetryLost, true);
        if let Some(transition) = self.safe.update(t_ns, wrong) {
            self.transitions.push((t_ns, transition));
        }
        let unknown = ActuatorTelemetry {
            wheel_speed_rad_s: Vector3::zeros(),
            gimbal_rad: Default::default(),
        };
        Some(self.safe_cycle(t_ns, period, &unknown))
    }

    /// A safe-mode cycle: safe wheel torque, gimbals held.
    fn safe_cycle(
        &mut self,
        t_ns: u64,
        period: u64,
        telemetry: &ActuatorTelemetry,
    ) -> ControlCycle {
        let fresh_gyro = self
            .gyro
            .filter(|(t, _)| *t + LOST_AFTER_PERIODS * self.period_ns > t_ns)
            .map(|(_, rate)| rate);
        // Without wheel telemetry the speeds are unknown: no torque at all.
        let wheels_unknown = self.safe.reasons().contains(SafeReason::WheelTelemetryLost);
        let wheel_torque_nm = if wheels_unknown {
            Vector3::zeros()
        } else {
            safe_wheel_torque(
                self.safe.config(),
                fresh_gyro.as_ref(),
                &telemetry.wheel_speed_rad_s,
                self.wheel_limits.max_torque_nm,
                self.wheel_limits.max_speed_rad_s,
            )
        };
        let mut command = ActuatorCommand {
            wheel_torque_nm,
            gimbal_rate_rad_s: Default::default(),
        };
        // With thrusters: they alone damp the gyro's rate, the wheels are off.
        let thrust = self.law.thruster_rate_damping(fresh_gyro.as_ref());
        if thrust.is_some() {
            command.wheel_torque_nm = Vector3::zeros();
        }
        let mut status = ControllerStatus {
            header: self.status_seq.header(t_ns, SampleHeader::VALID),
            torque_command: a3(&(-command.wheel_torque_nm)),
            deadline_misses: self.deadline_misses,
            loop_period_ns: period,
            ..ControllerStatus::default()
        };
        status.set_mode(if thrust.is_some() {
            ControllerMode::ThrusterRateDamping
        } else {
            ControllerMode::Safe
        });
        self.outputs(t_ns, status, &command, thrust.map(|t| t.command))
    }

    fn outputs(
        &mut self,
        t_ns: u64,
        status: ControllerStatus,
        command: &ActuatorCommand,
        thrust: Option<testbed_model::physics::ThrusterCommand>,
    ) -> ControlCycle {
        ControlCycle {
            status,
            wheels: WheelCommand {
                header: self.wheel_seq.header(t_ns, SampleHeader::VALID),
                torque: a3(&command.wheel_torque_nm),
            },
            cmg: CmgCommand {
                header: self.cmg_seq.header(t_ns, SampleHeader::VALID),
                gimbal_rate: a4(&command.gimbal_rate_rad_s),
            },
            // With thruster control there is a command every cycle (all valves shut when the law
            // has none), so the thruster drive can tell a late controller from a quiet one.
            thrusters: thrust
                .or_else(|| self.law.has_thruster_control().then(Default::default))
                .map(|t| ipc_types::ThrusterCommand {
                    header: self.thruster_seq.header(t_ns, SampleHeader::VALID),
                    on_time: t.on_time_s,
                }),
        }
    }
}
