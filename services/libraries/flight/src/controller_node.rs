//! The controller process's logic: one command per tick from the estimate and the actuators'
//! telemetry of that tick.

use crate::convert::{Sequence, a3, a4, quaternion_from_array, seconds, v3, v4};
use crate::safe_mode::SafeWheels;
use crate::safe_mode::{SafeMode, SafeReason, SafeReasons, SafeTransition, safe_wheel_torque};
use crate::schedule::Schedule;
use crate::tasks::{ActuatorTelemetry, Actuators, ControllerConfig, ControllerTask};
use crate::thruster_control::ThrusterActivity;
use ipc_types::{
    AttitudeEstimate, CmgCommand, CmgTelemetry, ControllerMode, ControllerStatus, GroundCommand,
    GroundCommandKind, GyroSample, SampleHeader, WheelCommand, WheelTelemetry,
};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use testbed_model::WheelConfig;
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
    /// the law has none), `None` without (issue 14).
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

pub struct ControllerNode {
    task: ControllerTask,
    actuators: Actuators,
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

impl ControllerNode {
    /// The controller of `config` (actuators, safe mode) for wheels `wheels` on `schedule`.
    pub fn new(
        task: ControllerTask,
        config: &ControllerConfig,
        wheels: &WheelConfig,
        schedule: Schedule,
    ) -> Self {
        Self {
            task,
            actuators: config.actuators,
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
        }
    }

    /// Safe mode (state, reasons, entries).
    pub fn safe_mode(&self) -> &SafeMode {
        &self.safe
    }

    /// A ground command: `true` enters and holds safe mode, `false` releases it.
    pub fn ground_safe_mode(&mut self, safe: bool) {
        self.safe.ground_command(safe);
    }

    /// Applies a command from the ground (validated by the ground link; checked again here):
    /// what was applied, or why it was refused. Mode: idle (zero commands), rate damping (the
    /// wheels damp the estimated body rate, as safe mode does on the gyro), the configured
    /// pointing law (wheel pointing or CMG slew, whichever `controller.actuators` names), or
    /// safe (held until another mode is commanded). Target: the attitude the pointing law
    /// holds from the next cycle on. Experiments: refused, no runner exists on the platform.
    pub fn ground_command(&mut self, command: &GroundCommand) -> Result<String, String> {
        match command.kind() {
            Some(GroundCommandKind::Mode) => {
                let mode = ControllerMode::from_u32(command.mode)
                    .ok_or_else(|| format!("unknown mode {}", command.mode))?;
                let law = match self.actuators {
                    Actuators::Wheels => ControllerMode::WheelPointing,
                    Actuators::Cmg => ControllerMode::CmgSlew,
                };
                match mode {
                    ControllerMode::Safe => {
                        self.ground_safe_mode(true);
                        return Ok("safe mode held by the ground".into());
                    }
                    ControllerMode::Idle | ControllerMode::RateDamping => {
                        self.ground_mode = Some(mode)
                    }
                    m if m == law => self.ground_mode = None,
                    ControllerMode::WheelPointing | ControllerMode::CmgSlew => {
                        return Err(format!(
                            "{mode:?} needs controller.actuators = {}",
                            if mode == ControllerMode::CmgSlew {
                                "cmg"
                            } else {
                                "wheels"
                            }
                        ));
                    }
                    ControllerMode::Fault => return Err("Fault is not a mode to command".into()),
                    ControllerMode::MomentumDump | ControllerMode::ThrusterRateDamping => {
                        return Err(format!(
                            "{mode:?} is chosen by the thruster law (controller.thrusters), not commanded"
                        ));
                    }
                }
                self.ground_safe_mode(false);
                Ok(format!("mode {mode:?}"))
            }
            Some(GroundCommandKind::Target) => {
                let angles = [
                    command.target_heading_rad,
                    command.target_pitch_rad,
                    command.target_roll_rad,
                ];
                if !angles.iter().all(|a| a.is_finite()) {
                    return Err("target angles must be finite".into());
                }
                let half_pi = std::f64::consts::FRAC_PI_2;
                if angles[1].abs() >= half_pi || angles[2].abs() >= half_pi {
                    return Err("target tilt must be below 90°".into());
                }
                self.task
                    .set_target(testbed_model::attitude::from_heading_pitch_roll(
                        angles[0], angles[1], angles[2],
                    ));
                Ok("target set".into())
            }
            Some(GroundCommandKind::ExperimentStart | GroundCommandKind::ExperimentAbort) => {
                Err("no identification experiment runner on the platform yet".into())
            }
            _ => Err(format!("unknown command kind {}", command.kind)),
        }
    }

    /// The mode the ground holds the controller in instead of its configured law, if any.
    pub fn ground_mode(&self) -> Option<ControllerMode> {
        self.ground_mode
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
            Some((q, rate)) => match self.task.command(seconds(t_ns), &q, &rate, &telemetry) {
                Ok(mut o) => {
                    thrust = self.task.thrusters(&rate, &telemetry, &mut o);
                    let mode = match (self.actuators, thrust.map(|t| t.activity)) {
                        (_, Some(ThrusterActivity::Dumping)) => ControllerMode::MomentumDump,
                        (_, Some(ThrusterActivity::RateDamping)) => {
                            ControllerMode::ThrusterRateDamping
                        }
                        (Actuators::Wheels, _) => ControllerMode::WheelPointing,
                        (Actuators::Cmg, _) => ControllerMode::CmgSlew,
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
                let config = crate::safe_mode::SafeModeConfig {
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
        // With thrusters: they alone damp the gyro's rate, the wheels are off (issue 14).
        let thrust = self.task.thruster_rate_damping(fresh_gyro.as_ref());
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
                .or_else(|| self.task.has_thruster_control().then(Default::default))
                .map(|t| ipc_types::ThrusterCommand {
                    header: self.thruster_seq.header(t_ns, SampleHeader::VALID),
                    on_time: t.on_time_s,
                }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::ModelConfig;
    use testbed_model::attitude::Attitude;

    const TICK_NS: u64 = 100_000_000;

    fn node() -> ControllerNode {
        let model = ModelConfig::default();
        let config = ControllerConfig::default();
        let task = ControllerTask::new(&config, &model, Attitude::identity()).unwrap();
        ControllerNode::new(
            task,
            &config,
            &model.wheels,
            Schedule::from_model(&model).unwrap(),
        )
    }

    fn header(k: u64) -> SampleHeader {
        SampleHeader::new(k * TICK_NS, k, SampleHeader::VALID)
    }

    fn estimate(k: u64) -> AttitudeEstimate {
        AttitudeEstimate {
            header: header(k),
            quaternion: [0.0, 0.0, 0.0, 1.0],
            ..AttitudeEstimate::default()
        }
    }

    fn telemetry(node: &mut ControllerNode, k: u64, wheel_speed: f64) {
        node.on_wheel_telemetry(&WheelTelemetry {
            header: header(k),
            speed: [wheel_speed; 3],
            torque: [0.0; 3],
        });
        node.on_cmg_telemetry(&CmgTelemetry {
            header: header(k),
            ..CmgTelemetry::default()
        });
    }

    #[test]
    fn only_telemetry_that_can_complete_or_judge_a_tick_needs_to_wake_the_controller() {
        let mut node = node();
        assert_eq!(
            node.telemetry_wake_from_ns(),
            0,
            "before the first cycle: all"
        );
        for k in 0..=5 {
            node.on_estimate(&estimate(k));
            telemetry(&mut node, k, 0.0);
            assert_eq!(node.ready().len(), 1);
            // Tick k+1 waits for its estimate: its telemetry cannot complete it; tick k+2's
            // telemetry would judge a missing estimate, and wakes.
            assert_eq!(node.telemetry_wake_from_ns(), (k + 2) * TICK_NS);
        }
        // The estimate of tick 6 is in before its telemetry: the telemetry is awaited.
        node.on_estimate(&estimate(6));
        assert!(node.ready().is_empty());
        assert_eq!(node.telemetry_wake_from_ns(), 0);
        telemetry(&mut node, 6, 0.0);
        assert_eq!(node.ready().len(), 1);
        assert_eq!(node.telemetry_wake_from_ns(), 8 * TICK_NS);
        // The estimator stops: tick 8's telemetry finds the estimate lost, and from then on
        // every sample wakes (safe cycles run on the telemetry).
        telemetry(&mut node, 7, 0.0);
        assert!(node.ready().is_empty());
        telemetry(&mut node, 8, 0.0);
        assert_eq!(node.ready().len(), 1, "a safe cycle at tick 8");
        assert_eq!(node.telemetry_wake_from_ns(), 0);
    }

    #[test]
    fn a_lost_estimate_gives_rate_damping_on_the_gyro_at_the_second_silent_tick() {
        let mut node = node();
        for k in 0..=5 {
            node.on_estimate(&estimate(k));
            telemetry(&mut node, k, 0.0);
            let cycles = node.ready();
            assert_eq!(cycles.len(), 1);
            assert_eq!(cycles[0].status.mode(), Some(ControllerMode::WheelPointing));
        }
        // The estimator stops after tick 5; the gyro and the actuators go on.
        let rate = [0.01, -0.02, 0.005];
        let mut safe_at = None;
        for k in 6..=9 {
            node.on_gyro(&GyroSample::new(header(k), rate));
            telemetry(&mut node, k, 0.0);
            for cycle in node.ready() {
                let t = cycle.status.header.time_ns / TICK_NS;
                safe_at.get_or_insert(t);
                assert_eq!(cycle.status.mode(), Some(ControllerMode::Safe));
                assert_eq!(cycle.cmg.gimbal_rate, [0.0; 4], "gimbals held");
                // Platform torque −K·ω (K = 5 N m s): wheel motor torque +K·ω.
                assert_eq!(cycle.wheels.torque, rate.map(|w| 5.0 * w));
            }
        }
        // Tick 6 waits for its estimate; at tick 7 the estimate is two periods old: lost.
        assert_eq!(safe_at, Some(7));
        let transitions = node.take_transitions();
        assert_eq!(transitions.len(), 1);
        assert!(matches!(
            transitions[0],
            (t, SafeTransition::Entered(r)) if t == 7 * TICK_NS && r.contains(SafeReason::EstimateLost)
        ));

        // Estimates again: safe mode is left after recovery_s (5 s) of healthy inputs.
        let mut left_at = None;
        for k in 10..=80 {
            node.on_estimate(&estimate(k));
            telemetry(&mut node, k, 0.0);
            node.ready();
            if let Some((t, SafeTransition::Left)) = node.take_transitions().first() {
                left_at = Some(t / TICK_NS);
            }
        }
        assert_eq!(left_at, Some(60), "healthy from tick 10, left 5 s later");
    }

    /// A CAN link down silences every input: the deadlines alone enter safe mode, at the
    /// second silent deadline, with zero wheel torque (speeds unknown) and gimbals held; data
    /// again leave it after recovery_s.
    #[test]
    fn total_silence_enters_safe_mode_at_the_second_missed_deadline_with_zero_torque() {
        let mut node = node();
        assert!(
            node.on_silence(5, u64::MAX).is_none(),
            "no cycle yet: nothing to hold"
        );
        for k in 0..=5 {
            node.on_estimate(&estimate(k));
            telemetry(&mut node, k, 10.0);
            node.on_gyro(&GyroSample::new(header(k), [0.01, 0.0, 0.0]));
            assert_eq!(node.ready().len(), 1);
        }
        assert!(
            node.on_silence(1, u64::MAX).is_none(),
            "one missed deadline is not yet a loss"
        );
        let cycle = node
            .on_silence(2, u64::MAX)
            .expect("a safe cycle at the second missed deadline");
        assert_eq!(cycle.status.header.time_ns, 6 * TICK_NS);
        assert_eq!(cycle.status.mode(), Some(ControllerMode::Safe));
        assert_eq!(
            cycle.wheels.torque, [0.0; 3],
            "wheel speeds unknown: no torque"
        );
        assert_eq!(cycle.cmg.gimbal_rate, [0.0; 4], "gimbals held");
        assert!(
            node.on_silence(3, 7 * TICK_NS).is_none(),
            "the run's end silences everything: no fault"
        );
        let next = node
            .on_silence(3, u64::MAX)
            .expect("one safe cycle per further deadline");
        assert_eq!(next.status.header.time_ns, 7 * TICK_NS);
        let transitions = node.take_transitions();
        assert!(matches!(
            transitions.as_slice(),
            [(t, SafeTransition::Entered(r))] if *t == 6 * TICK_NS
                && r.contains(SafeReason::EstimateLost)
                && r.contains(SafeReason::WheelTelemetryLost)
        ));
        let mut left_at = None;
        for k in 9..=80 {
            node.on_estimate(&estimate(k));
            telemetry(&mut node, k, 10.0);
            node.ready();
            if let Some((t, SafeTransition::Left)) = node.take_transitions().first() {
                left_at = Some(t / TICK_NS);
            }
        }
        assert_eq!(left_at, Some(59), "healthy from tick 9, left 5 s later");
    }

    #[test]
    fn with_thrusters_safe_mode_damps_on_the_thrusters_alone_and_dumping_is_reported() {
        use crate::thruster_control::ThrusterControlConfig;
        use testbed_model::thruster_config::ThrusterConfig;
        let model = ModelConfig {
            thrusters: Some(ThrusterConfig::default()),
            ..ModelConfig::default()
        };
        let config = ControllerConfig {
            thrusters: Some(ThrusterControlConfig::default()),
            ..ControllerConfig::default()
        };
        let task = ControllerTask::new(&config, &model, Attitude::identity()).unwrap();
        let mut node = ControllerNode::new(
            task,
            &config,
            &model.wheels,
            Schedule::from_model(&model).unwrap(),
        );
        // Wheels at 3500 rpm (0.58 Nms, past the 0.5 Nms dump threshold): a dump.
        let speed = 3500.0 * std::f64::consts::PI / 30.0;
        for k in 0..=5 {
            node.on_estimate(&estimate(k));
            telemetry(&mut node, k, speed);
            let cycles = node.ready();
            assert_eq!(cycles.len(), 1);
            assert_eq!(cycles[0].status.mode(), Some(ControllerMode::MomentumDump));
            let thrust = cycles[0].thrusters.expect("a thruster command every cycle");
            // −k h on every axis: the − thrusters (1, 3, 5) fire, the + ones do not.
            if k == 0 {
                assert!(
                    thrust.on_time[1] > 0.0 && thrust.on_time[3] > 0.0 && thrust.on_time[5] > 0.0
                );
            }
            assert_eq!(
                (thrust.on_time[0], thrust.on_time[2], thrust.on_time[4]),
                (0.0, 0.0, 0.0)
            );
        }
        // The estimator stops: safe mode damps the gyro's rate on the thrusters, wheels off.
        let rate = [0.01, -0.02, 0.0];
        for k in 6..=9 {
            node.on_gyro(&GyroSample::new(header(k), rate));
            telemetry(&mut node, k, speed);
            for cycle in node.ready() {
                assert_eq!(
                    cycle.status.mode(),
                    Some(ControllerMode::ThrusterRateDamping)
                );
                assert_eq!(cycle.wheels.torque, [0.0; 3]);
                let thrust = cycle.thrusters.expect("thrusters in safe mode");
                // −K w: the − X thruster (1) and the + Y thruster (2), nothing about Z.
                assert!(
                    thrust.on_time[1] > 0.0 && thrust.on_time[2] > 0.0,
                    "{thrust:?}"
                );
                assert_eq!(
                    thrust.on_time[0] + thrust.on_time[3] + thrust.on_time[4] + thrust.on_time[5],
                    0.0
                );
            }
        }
    }

    #[test]
    fn a_wheel_near_its_limit_enters_safe_mode_and_is_not_driven_further() {
        let mut node = node();
        let limit = 6000.0 * std::f64::consts::PI / 30.0;
        node.on_gyro(&GyroSample::new(header(0), [0.01; 3]));
        node.on_estimate(&estimate(0));
        telemetry(&mut node, 0, 0.8 * limit);
        let cycle = node.ready()[0];
        assert_eq!(cycle.status.mode(), Some(ControllerMode::Safe));
        // +K·ω would speed up the +0.8-limit wheels: refused.
        assert_eq!(cycle.wheels.torque, [0.0; 3]);
    }

    fn ground(kind: GroundCommandKind, mode: ControllerMode) -> GroundCommand {
        GroundCommand {
            kind: kind as u32,
            mode: mode as u32,
            ..GroundCommand::default()
        }
    }

    fn step(node: &mut ControllerNode, k: u64, rate: [f64; 3]) -> ControlCycle {
        node.on_estimate(&AttitudeEstimate {
            rate,
            ..estimate(k)
        });
        telemetry(node, k, 0.0);
        let cycles = node.ready();
        assert_eq!(cycles.len(), 1);
        cycles[0]
    }

    #[test]
    fn ground_modes_replace_the_law_and_pointing_restores_it() {
        let mut node = node();
        let rate = [0.01, -0.02, 0.005];
        assert_eq!(
            step(&mut node, 0, rate).status.mode(),
            Some(ControllerMode::WheelPointing)
        );
        node.ground_command(&ground(GroundCommandKind::Mode, ControllerMode::Idle))
            .unwrap();
        let idle = step(&mut node, 1, rate);
        assert_eq!(idle.status.mode(), Some(ControllerMode::Idle));
        assert_eq!(idle.wheels.torque, [0.0; 3]);

        node.ground_command(&ground(
            GroundCommandKind::Mode,
            ControllerMode::RateDamping,
        ))
        .unwrap();
        let damping = step(&mut node, 2, rate);
        assert_eq!(damping.status.mode(), Some(ControllerMode::RateDamping));
        // Platform torque −K·ω (K = 5 N m s from the safe-mode gain): wheel torque +K·ω.
        assert_eq!(damping.wheels.torque, rate.map(|w| 5.0 * w));

        node.ground_command(&ground(GroundCommandKind::Mode, ControllerMode::Safe))
            .unwrap();
        assert_eq!(
            step(&mut node, 3, rate).status.mode(),
            Some(ControllerMode::Safe)
        );
        node.ground_command(&ground(
            GroundCommandKind::Mode,
            ControllerMode::WheelPointing,
        ))
        .unwrap();
        assert_eq!(
            step(&mut node, 4, rate).status.mode(),
            Some(ControllerMode::WheelPointing)
        );
    }

    #[test]
    fn ground_commands_the_controller_cannot_follow_are_refused_with_the_reason() {
        let mut node = node();
        let cmg = node.ground_command(&ground(GroundCommandKind::Mode, ControllerMode::CmgSlew));
        assert!(cmg.unwrap_err().contains("actuators = cmg"));
        assert!(
            node.ground_command(&ground(GroundCommandKind::Mode, ControllerMode::Fault))
                .is_err()
        );
        let start = node.ground_command(&ground(
            GroundCommandKind::ExperimentStart,
            ControllerMode::Idle,
        ));
        assert!(start.unwrap_err().contains("experiment"));
        let bad_target = GroundCommand {
            kind: GroundCommandKind::Target as u32,
            target_pitch_rad: f64::NAN,
            ..GroundCommand::default()
        };
        assert!(node.ground_command(&bad_target).is_err());
        assert_eq!(node.ground_mode(), None);
    }

    #[test]
    fn a_ground_target_moves_the_attitude_error() {
        let mut node = node();
        assert_eq!(step(&mut node, 0, [0.0; 3]).status.attitude_error, [0.0; 3]);
        let target = GroundCommand {
            kind: GroundCommandKind::Target as u32,
            target_heading_rad: 0.1,
            ..GroundCommand::default()
        };
        node.ground_command(&target).unwrap();
        let error = step(&mut node, 1, [0.0; 3]).status.attitude_error;
        // Level attitude, target heading 0.1 rad: the error is about z only.
        assert!((error[2].abs() - 0.1).abs() < 1e-3, "{error:?}");
        assert!(error[0].abs() < 1e-12 && error[1].abs() < 1e-12);
    }
}
