//! The plant process (simulation only): integrates the platform and owns the clock. It waits
//! until every participant of the run reports `Running`, then publishes truth and tick for
//! t = 0. Lockstep: it advances as soon as the tick's wheel and CMG commands are in. Paced: it
//! advances every period of wall time, holding the last command when an answer is late. It
//! stops when the run's duration is reached; the launcher then stops the rest.
//!
//! The commands it integrates are the controller's (`run.actuation = "direct"`), or, with
//! `run.actuation = "can_node"`, the ones the CAN board applies after the wheel and CMG
//! gateways and the CAN bus (`AppliedWheelCommand`, `AppliedCmgCommand`, same time stamps).
//!
//! With thrusters (`[model.thrusters]` and `[controller.thrusters]`) and direct actuation the
//! plant is also the simulated thruster drive: each tick's [`ThrusterCommand`] is part of the
//! tick's answer, checked as the thruster gateway checks it ([`ThrusterGuard`]: a bad command is
//! refused, counted, every valve shut), the valves are sensed at the end of the period (a
//! stuck-open valve shuts the latch valve and is reported as
//! [`HealthEventKind::ThrustersDisabled`]), and a [`ThrusterStatus`] goes out every tick. With
//! `run.actuation = "can_node"` the thruster gateway does the checking, the sensing and the
//! status over the bus, and the plant takes the board's [`AppliedThrusterCommand`] (its latch
//! flag shuts the latch valve).

use ipc_types::ClockMode;
use ipc_types::{
    AppliedCmgCommand, AppliedThrusterCommand, AppliedWheelCommand, CmgCommand, HealthEventKind,
    SampleHeader, SimClockTick, SimTruth, ThrusterCommand, ThrusterStatus, WheelCommand,
};
use std::time::{Duration, Instant};
use testbed_bus::{
    Flow, LoopExit, SourceId, SubscriberOptions, TopicPublisher, TopicSubscriber, Wake,
};
use testbed_config::Actuation;
use testbed_config::RunConfig;
use testbed_flight::convert::Sequence;
use testbed_gateways::thrusters::ThrusterGuard;
use testbed_model::thruster_config::THRUSTER_COUNT;
use testbed_runtime::{Context, Io, Node, WakeOn};
use testbed_sim::plant_task::PlantTask;

/// Buffer of the command subscribers: commands of the current tick wait there while the plant
/// integrates.
const COMMAND_BUFFER: usize = 64;

/// Where the plant's commands come from.
pub enum CommandPorts {
    /// The controller's commands (`run.actuation = "direct"`).
    Direct {
        wheels: TopicSubscriber<WheelCommand>,
        cmg: TopicSubscriber<CmgCommand>,
    },
    /// What the CAN board applies (`run.actuation = "can_node"`).
    Applied {
        wheels: TopicSubscriber<AppliedWheelCommand>,
        cmg: TopicSubscriber<AppliedCmgCommand>,
    },
}

/// The thruster drive's ports (runs with thruster control).
// One value per process, built once: the variants' size difference costs nothing.
#[allow(clippy::large_enum_variant)]
pub enum ThrusterPorts {
    /// Direct actuation: the controller's commands in, checked here; the status out.
    Direct {
        commands: TopicSubscriber<ThrusterCommand>,
        status: TopicPublisher<ThrusterStatus>,
    },
    /// CAN actuation: what the board applies (the thruster gateway checked it and publishes the
    /// status).
    Applied {
        applied: TopicSubscriber<AppliedThrusterCommand>,
    },
}

/// The plant's ports: truth and clock out, commands in.
pub struct PlantPorts {
    truth: TopicPublisher<SimTruth>,
    clock: TopicPublisher<SimClockTick>,
    commands: CommandPorts,
    thrusters: Option<ThrusterPorts>,
}

/// The simulated thruster drive: the gateway's checks in front of the plant's valves.
struct ThrusterDrive {
    guard: ThrusterGuard,
    /// On-times applied in the current period, s.
    applied: [f64; THRUSTER_COUNT],
    status_seq: Sequence,
}

impl ThrusterDrive {
    fn new(valves: &testbed_model::thruster_config::ThrusterConfig, period_s: f64) -> Self {
        Self {
            guard: ThrusterGuard::new(valves, period_s, valves.stuck_open_confirm_periods),
            applied: [0.0; THRUSTER_COUNT],
            status_seq: Sequence::default(),
        }
    }

    /// A command from the bus: checked, and what passes (all valves shut if refused) goes to
    /// the plant. Only the current tick's command counts (as on the CAN board): a stale one would
    /// otherwise be checked, and counted if refused, twice.
    fn on_command(&mut self, c: &ThrusterCommand, plant: &mut PlantTask) {
        if c.header.time_ns != plant.time_ns() {
            return;
        }
        let (on_time, refusal) = self.guard.check(c);
        if let Some(refusal) = refusal {
            tracing::warn!(
                t_ns = c.header.time_ns,
                "thruster command refused: {refusal}"
            );
        }
        self.applied = on_time;
        plant.on_thruster_command(&ThrusterCommand { on_time, ..*c });
    }

    /// After the plant's step: senses the valves (a valve newly found stuck open shuts the
    /// latch valve and is returned) and gives the period's status.
    fn end_of_period(&mut self, plant: &mut PlantTask) -> (ThrusterStatus, Option<usize>) {
        let valves_open = plant.valves_open();
        let stuck = self.guard.on_valves_sensed(valves_open);
        if stuck.is_some() {
            plant.shut_thruster_latch();
        }
        let status = ThrusterStatus {
            header: self.status_seq.header(plant.time_ns(), SampleHeader::VALID),
            applied_on_time: std::mem::take(&mut self.applied),
            valves_open,
            disabled: u32::from(plant.thruster_latch_shut()),
            refused: self.guard.refused().total(),
            propellant_used: plant.propellant_used_kg(),
        };
        (status, stuck)
    }
}

/// The plant process: [`PlantTask`] as the clock owner of the run.
pub struct PlantProcess {
    plant: PlantTask,
    period: Duration,
    /// The pacing interval (paced runs).
    pace: Option<SourceId>,
    started: Instant,
    /// `run.command_timeout_s` (reported with a zeroing).
    command_timeout_s: f64,
    /// The thruster drive (runs with thruster control).
    thrusters: Option<ThrusterDrive>,
}

impl PlantProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, PlantPorts)> {
        let restarts = ipc_types::restart_count();
        anyhow::ensure!(
            restarts == 0,
            "the plant owns the run's clock and cannot restart mid-run (restart {restarts}): time would start again at 0"
        );
        let plant = PlantTask::new(cx.config)?;
        let period = Duration::from_secs_f64(cx.config.schedule()?.period_s());
        let bus = cx.bus;
        let truth = bus.publisher()?;
        let clock = bus.publisher()?;
        let options = SubscriberOptions::buffer(COMMAND_BUFFER);
        let commands = match cx.config.run.actuation {
            Actuation::Direct => CommandPorts::Direct {
                wheels: bus.subscriber_with(options)?,
                cmg: bus.subscriber_with(options)?,
            },
            Actuation::CanNode => CommandPorts::Applied {
                wheels: bus.subscriber_with(options)?,
                cmg: bus.subscriber_with(options)?,
            },
        };
        let (thrusters, thruster_ports) =
            match (&cx.config.controller.thrusters, &cx.config.model.thrusters) {
                (None, _) => (None, None),
                (Some(_), None) => {
                    anyhow::bail!(
                        "controller.thrusters is set but the model has no [model.thrusters]"
                    )
                }
                (Some(_), Some(valves)) => match cx.config.run.actuation {
                    Actuation::Direct => {
                        let drive = ThrusterDrive::new(valves, period.as_secs_f64());
                        let ports = ThrusterPorts::Direct {
                            commands: bus.subscriber_with(options)?,
                            status: bus.publisher()?,
                        };
                        (Some(drive), Some(ports))
                    }
                    Actuation::CanNode => (
                        None,
                        Some(ThrusterPorts::Applied {
                            applied: bus.subscriber_with(options)?,
                        }),
                    ),
                },
            };
        let process = Self {
            plant,
            period,
            pace: None,
            started: Instant::now(),
            command_timeout_s: cx.config.run.command_timeout_s,
            thrusters,
        };
        Ok((
            process,
            PlantPorts {
                truth,
                clock,
                commands,
                thrusters: thruster_ports,
            },
        ))
    }

    fn publish(&mut self, ports: &PlantPorts) -> anyhow::Result<()> {
        let (truth, clock) = self.plant.outputs();
        ports.truth.publish(&truth)?;
        ports.clock.publish(&clock)?;
        Ok(())
    }
}

impl Node for PlantProcess {
    type Ports = PlantPorts;

    fn start_barrier(&self, config: &RunConfig) -> Option<Vec<String>> {
        Some(config.run.participants.clone())
    }

    fn wake_on<'a>(
        &mut self,
        ports: &'a PlantPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        // Paced: the plant advances on its own interval and integrates the commands that
        // answer the current tick; `on_wake` drains them at that wake-up, so waking for each
        // as it arrives (two or three wake-ups a tick) changed nothing but the CPU.
        if wake.mode() == ClockMode::Lockstep {
            match &ports.commands {
                // One wake-up a tick, not one per command. The controller publishes a cycle's
                // commands in one go, thrusters, wheels, then the CMG last (each in shared
                // memory before its ring), so when the CMG command wakes the plant the others
                // of the tick are there; `on_wake` takes them all, and the plant advances only
                // once every command of the tick is in.
                CommandPorts::Direct { cmg, .. } => {
                    wake.data(cmg)?;
                }
                CommandPorts::Applied { wheels, cmg } => {
                    wake.data(wheels)?;
                    wake.data(cmg)?;
                }
            }
            if let Some(ThrusterPorts::Applied { applied }) = &ports.thrusters {
                wake.data(applied)?;
            }
        }
        if wake.mode() == ClockMode::Paced {
            self.pace = Some(wake.interval(self.period)?);
        }
        Ok(())
    }

    fn start(&mut self, ports: &PlantPorts, _io: &Io) -> anyhow::Result<Flow> {
        self.started = Instant::now();
        self.publish(ports)?;
        Ok(Flow::Continue)
    }

    fn on_wake(&mut self, ports: &PlantPorts, wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        let plant = &mut self.plant;
        match &ports.commands {
            CommandPorts::Direct { wheels, cmg } => {
                wheels.drain(|c| plant.on_wheel_command(c))?;
                cmg.drain(|c| plant.on_cmg_command(c))?;
            }
            CommandPorts::Applied { wheels, cmg } => {
                wheels.drain(|c| plant.on_wheel_command(&WheelCommand::new(c.header, c.torque)))?;
                cmg.drain(|c| plant.on_cmg_command(&CmgCommand::new(c.header, c.gimbal_rate)))?;
            }
        }
        match (&ports.thrusters, &mut self.thrusters) {
            (Some(ThrusterPorts::Direct { commands, .. }), Some(drive)) => {
                commands.drain(|c| drive.on_command(c, plant))?;
            }
            (Some(ThrusterPorts::Applied { applied }), _) => {
                applied.drain(|c| {
                    if c.latch_shut != 0 {
                        plant.shut_thruster_latch();
                    }
                    plant.on_thruster_command(&ThrusterCommand {
                        header: c.header,
                        on_time: c.on_time,
                    });
                })?;
            }
            _ => {}
        }
        let advance_now = match self.pace {
            None => plant.answered(),
            Some(pace) => wake == Wake::Tick(pace),
        };
        if !advance_now {
            return Ok(Flow::Continue);
        }
        if plant.at_end() {
            return Ok(Flow::Stop);
        }
        let was_zeroed = plant.commands_zeroed();
        plant.advance()?;
        let t_ns = self.plant.time_ns();
        if let (
            Some(ThrusterPorts::Direct {
                status: publisher, ..
            }),
            Some(drive),
        ) = (&ports.thrusters, &mut self.thrusters)
        {
            let (status, stuck) = drive.end_of_period(&mut self.plant);
            if let Some(stuck) = stuck {
                tracing::error!(
                    "thruster {stuck}: valve stuck open; latch valve shut, thrusters disabled"
                );
                io.health.report(
                    t_ns,
                    HealthEventKind::ThrustersDisabled,
                    "actuators/thrusters",
                    stuck as u32,
                    0.0,
                );
            }
            publisher.publish(&status)?;
        }
        match (was_zeroed, self.plant.commands_zeroed()) {
            (false, true) => {
                tracing::warn!(
                    "no wheel and CMG commands for run.command_timeout_s: applying zero torque and gimbal rate"
                );
                io.health.report(
                    t_ns,
                    HealthEventKind::CommandsZeroed,
                    "actuators/commands",
                    0,
                    self.command_timeout_s,
                );
            }
            (true, false) => io.health.report(
                t_ns,
                HealthEventKind::CommandsResumed,
                "actuators/commands",
                0,
                0.0,
            ),
            _ => {}
        }
        self.publish(ports)?;
        io.heartbeat.set_time_ns(self.plant.time_ns());
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &PlantPorts, _io: &Io, exit: LoopExit) -> anyhow::Result<()> {
        let wall = self.started.elapsed().as_secs_f64();
        let simulated = self.plant.time_ns() as f64 * 1e-9;
        tracing::info!(
            ?exit,
            simulated_s = simulated,
            wall_s = wall,
            x_real_time = simulated / wall.max(1e-9),
            deadline_misses = self.plant.deadline_misses(),
            ticks_with_commands_zeroed = self.plant.zeroed_ticks(),
            "plant done"
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_model::thruster_config::{StuckOpenValve, ThrusterConfig};

    /// A run configuration with the default thrusters and thruster control.
    fn config(stuck_open: Option<StuckOpenValve>) -> RunConfig {
        let mut config = RunConfig::default();
        config.model.thrusters = Some(ThrusterConfig {
            stuck_open,
            ..ThrusterConfig::default()
        });
        config.controller.thrusters = Some(Default::default());
        config
    }

    fn command(plant: &PlantTask, on_time: [f64; THRUSTER_COUNT]) -> ThrusterCommand {
        ThrusterCommand {
            header: SampleHeader::new(plant.time_ns(), plant.tick(), SampleHeader::VALID),
            on_time,
        }
    }

    fn drive_for(config: &RunConfig) -> ThrusterDrive {
        ThrusterDrive::new(
            config.model.thrusters.as_ref().unwrap(),
            config.schedule().unwrap().period_s(),
        )
    }

    #[test]
    fn bad_commands_are_refused_counted_and_shut_every_valve() {
        let config = config(None);
        let mut plant = PlantTask::new(&config).unwrap();
        let mut drive = drive_for(&config);
        let bad = [
            [f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, -0.01, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.5, 0.0, 0.0, 0.0], // longer than the 0.1 s period
            [0.0, 0.0, 0.0, 0.01, 0.0, 0.0], // shorter than the 20 ms minimum
        ];
        for (k, on_time) in bad.into_iter().enumerate() {
            let c = command(&plant, on_time);
            drive.on_command(&c, &mut plant);
            assert!(
                !plant.answered(),
                "no wheel/CMG command, so not answered yet"
            );
            plant.advance().unwrap();
            let (status, stuck) = drive.end_of_period(&mut plant);
            assert_eq!(stuck, None);
            assert_eq!(status.applied_on_time, [0.0; THRUSTER_COUNT], "{on_time:?}");
            assert_eq!(status.valves_open, 0);
            assert_eq!(status.refused, k as u64 + 1);
            assert_eq!(status.propellant_used, 0.0, "no valve opened");
        }
        // A good command passes and uses propellant.
        let c = command(&plant, [0.05, 0.0, 0.0, 0.0, 0.0, 0.0]);
        drive.on_command(&c, &mut plant);
        plant.advance().unwrap();
        let (status, _) = drive.end_of_period(&mut plant);
        assert_eq!(status.applied_on_time[0], 0.05);
        assert_eq!(status.refused, 4);
        assert!(status.propellant_used > 0.0);
        // A command for another tick is ignored, not counted.
        let mut stale = command(&plant, [f64::NAN; THRUSTER_COUNT]);
        stale.header.time_ns += 1;
        drive.on_command(&stale, &mut plant);
        plant.advance().unwrap();
        assert_eq!(drive.end_of_period(&mut plant).0.refused, 4);
    }

    #[test]
    fn a_stuck_open_valve_shuts_the_latch_after_the_confirmation_periods() {
        // Thruster 2 sticks open at 0.25 s, in the third period; it is confirmed at the end of
        // the third period that reads it open when it should be shut (0.5 s).
        let config = config(Some(StuckOpenValve {
            thruster: 2,
            from_s: 0.25,
        }));
        let mut plant = PlantTask::new(&config).unwrap();
        let mut drive = drive_for(&config);
        let mut disabled_at = None;
        for _ in 0..10 {
            let c = command(&plant, [0.0; THRUSTER_COUNT]);
            drive.on_command(&c, &mut plant);
            plant.advance().unwrap();
            let (status, stuck) = drive.end_of_period(&mut plant);
            if let Some(thruster) = stuck {
                assert_eq!(thruster, 2);
                assert!(disabled_at.is_none(), "reported once");
                disabled_at = Some(plant.time_ns());
                assert_eq!(status.disabled, 1);
            }
        }
        assert_eq!(disabled_at, Some(500_000_000));
        assert!(plant.thruster_latch_shut());
        // From then on every command that opens a valve is refused.
        let c = command(&plant, [0.05, 0.0, 0.0, 0.0, 0.0, 0.0]);
        drive.on_command(&c, &mut plant);
        plant.advance().unwrap();
        let (status, _) = drive.end_of_period(&mut plant);
        assert_eq!(status.applied_on_time, [0.0; THRUSTER_COUNT]);
        assert_eq!(status.refused, 1);
    }
}
