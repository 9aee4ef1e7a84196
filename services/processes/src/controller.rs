//! The controller process: PD + friction compensation on the wheels (or the CMG slew law), one
//! command per tick from the estimate and the actuators' telemetry. In a paced run a tick whose
//! estimate is later than its period plus the configured slack is a missed deadline. Safe mode
//! (see [`testbed_flight::safe_mode`]) takes over when the estimate or actuator telemetry is
//! lost or invalid or a wheel nears its speed limit; its changes go to the health topic.

use ipc_types::{
    AttitudeEstimate, CmgCommand, CmgTelemetry, ControllerStatus, GroundAckStatus, GroundCommand,
    GroundCommandAck, GyroSample, HealthEventKind, SampleHeader, ThrusterCommand, WheelCommand,
    WheelTelemetry,
};
use std::time::Duration;
use testbed_bus::{Flow, LoopExit, SourceId, TopicPublisher, TopicSubscriber, Wake};
use testbed_flight::safe_mode::SafeTransition;
use testbed_flight::tasks::{ControlCycle, ControllerTask};
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The controller's ports: estimate and actuator telemetry in; status and commands out.
pub struct ControllerPorts {
    estimate: TopicSubscriber<AttitudeEstimate>,
    wheels: TopicSubscriber<WheelTelemetry>,
    cmg: TopicSubscriber<CmgTelemetry>,
    /// The gyro, read on every wake-up (it wakes nothing): safe mode damps its rate.
    gyro: TopicSubscriber<GyroSample>,
    status: TopicPublisher<ControllerStatus>,
    wheel_command: TopicPublisher<WheelCommand>,
    cmg_command: TopicPublisher<CmgCommand>,
    /// Commands from the ground station (through the ground link), read on every wake-up:
    /// the only way a ground command reaches an actuator.
    ground: TopicSubscriber<GroundCommand>,
    /// The controller's answer to each ground command.
    ground_ack: TopicPublisher<GroundCommandAck>,
    /// Valve on-times, once per cycle (runs with `controller.thrusters`).
    thruster_command: Option<TopicPublisher<ThrusterCommand>>,
}

/// The controller process: [`ControllerTask`] on the bus.
pub struct ControllerProcess {
    task: ControllerTask,
    /// How late an estimate may be (paced runs): the tick period plus `run.deadline_slack_s`.
    deadline: Duration,
    /// The tick period.
    period: Duration,
    /// The estimate's attachment (its missed deadlines are missed control cycles).
    estimate_source: Option<SourceId>,
    /// Ground-command acknowledgements published.
    ack_sequence: u64,
    /// Deadlines missed in a row with no input at all (paced runs).
    silent_deadlines: u64,
    /// The run's end (`run.duration_s`), ns: silence from then on is the run ending.
    run_end_ns: u64,
    /// The cycles of one wake-up, a buffer kept for the run (a cycle allocates nothing).
    cycles: Vec<ControlCycle>,
}

impl ControllerProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, ControllerPorts)> {
        let config = cx.config;
        let schedule = config.schedule()?;
        let task = ControllerTask::new(
            &config.controller,
            &config.model,
            config.manoeuvre.target(),
            schedule,
        )?;
        let period = Duration::from_nanos(schedule.period_ns);
        let deadline = Duration::from_secs_f64(schedule.period_s() + config.run.deadline_slack_s);
        let ports = ControllerPorts {
            estimate: cx.bus.subscriber()?,
            wheels: cx.bus.subscriber()?,
            cmg: cx.bus.subscriber()?,
            gyro: cx.bus.subscriber()?,
            status: cx.bus.publisher()?,
            wheel_command: cx.bus.publisher()?,
            cmg_command: cx.bus.publisher()?,
            ground: cx.bus.subscriber()?,
            ground_ack: cx.bus.publisher()?,
            thruster_command: match config.controller.thrusters {
                Some(_) => Some(cx.bus.publisher()?),
                None => None,
            },
        };
        Ok((
            Self {
                task,
                deadline,
                period,
                estimate_source: None,
                ack_sequence: 0,
                silent_deadlines: 0,
                run_end_ns: (config.run.duration_s * 1e9) as u64,
                cycles: Vec::with_capacity(4),
            },
            ports,
        ))
    }
}

impl Node for ControllerProcess {
    type Ports = ControllerPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a ControllerPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        self.estimate_source = Some(wake.data_within(&ports.estimate, self.deadline)?);
        wake.watch(&ports.estimate, self.period);
        wake.input(&ports.wheels, self.period)?;
        wake.input(&ports.cmg, self.period)?;
        wake.watch(&ports.gyro, self.period);
        Ok(())
    }

    fn on_wake(&mut self, ports: &ControllerPorts, wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        let task = &mut self.task;
        let deadline_missed =
            matches!(wake, Wake::DeadlineMissed(source) if Some(source) == self.estimate_source);
        if deadline_missed {
            task.count_deadline_miss();
            tracing::warn!(
                misses = task.deadline_misses(),
                "control cycle missed its deadline"
            );
        }
        let received = ports.estimate.drain(|e| task.on_estimate(e))?
            + ports.wheels.drain(|t| task.on_wheel_telemetry(t))?
            + ports.cmg.drain(|t| task.on_cmg_telemetry(t))?
            + ports.gyro.drain(|g| task.on_gyro(g))?;
        io.heartbeat.add_samples_in(received as u64);
        // Ground commands take effect from the next cycle on.
        let mut commands = Vec::new();
        ports.ground.drain_into(&mut commands)?;
        for command in commands {
            let outcome = task.ground_command(&command);
            let t_ns = task.last_cycle_ns().unwrap_or(0);
            let (status, reason) = match &outcome {
                Ok(what) => (GroundAckStatus::Applied, what.as_str()),
                Err(why) => (GroundAckStatus::Rejected, why.as_str()),
            };
            tracing::info!(
                id = command.command_id,
                kind = command.kind,
                ?status,
                reason,
                "ground command"
            );
            self.ack_sequence += 1;
            ports.ground_ack.publish(&GroundCommandAck::new(
                SampleHeader::new(t_ns, self.ack_sequence, SampleHeader::VALID),
                command.command_id,
                command.kind,
                status,
                command.client_id,
                GroundCommandAck::BY_CONTROLLER,
                reason,
            ))?;
        }
        self.silent_deadlines = match (received, deadline_missed) {
            (0, true) => self.silent_deadlines + 1,
            (0, false) => self.silent_deadlines,
            _ => 0,
        };
        let silence = if deadline_missed {
            task.on_silence(self.silent_deadlines, self.run_end_ns)
        } else {
            None
        };
        let cycles = &mut self.cycles;
        cycles.clear();
        task.ready_into(cycles);
        cycles.extend(silence);
        // Telemetry the controller does not wait for wakes nothing (see
        // `telemetry_wake_from_ns`). Set before the commands go out, so that the telemetry
        // they cause finds it; then looked at once more, since telemetry sent before the
        // publisher could see a lower time did not ring.
        loop {
            let from = task.telemetry_wake_from_ns();
            ports.wheels.wake_from(from);
            ports.cmg.wake_from(from);
            let late = ports.wheels.drain(|t| task.on_wheel_telemetry(t))?
                + ports.cmg.drain(|t| task.on_cmg_telemetry(t))?;
            if late == 0 {
                break;
            }
            io.heartbeat.add_samples_in(late as u64);
            task.ready_into(cycles);
        }
        for cycle in cycles.drain(..) {
            io.heartbeat.set_time_ns(cycle.status.header.time_ns);
            ports.status.publish(&cycle.status)?;
            if let (Some(port), Some(thrusters)) = (&ports.thruster_command, &cycle.thrusters) {
                port.publish(thrusters)?;
                io.heartbeat.add_samples_out(1);
            }
            // The CMG command last: in lockstep the plant wakes on it alone and takes the
            // cycle's other commands with it (see the plant's `wake_on`).
            ports.wheel_command.publish(&cycle.wheels)?;
            ports.cmg_command.publish(&cycle.cmg)?;
            io.heartbeat.add_samples_out(3);
        }
        for (t_ns, transition) in task.take_transitions() {
            match transition {
                SafeTransition::Entered(reasons) => io.health.report(
                    t_ns,
                    HealthEventKind::SafeModeEntered,
                    io.name,
                    reasons.0,
                    0.0,
                ),
                SafeTransition::Left => {
                    io.health
                        .report(t_ns, HealthEventKind::SafeModeLeft, io.name, 0, 0.0)
                }
            }
        }
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &ControllerPorts, _io: &Io, _exit: LoopExit) -> anyhow::Result<()> {
        tracing::info!(
            deadline_misses = self.task.deadline_misses(),
            errors = self.task.errors(),
            safe_mode_entries = self.task.safe_mode().entries(),
            "controller stopping"
        );
        Ok(())
    }
}
