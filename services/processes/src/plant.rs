//! The plant process (simulation only): integrates the platform and owns the clock. It waits
//! until every participant of the run reports `Running`, then publishes truth and tick for
//! t = 0. Lockstep: it advances as soon as the tick's wheel and CMG commands are in. Paced: it
//! advances every period of wall time, holding the last command when an answer is late. It
//! stops when the run's duration is reached; the launcher then stops the rest.
//!
//! The commands it integrates are the controller's (`run.actuation = "direct"`), or, with
//! `run.actuation = "can_node"`, the ones the smart CAN node applies after the wheel and CMG
//! gateways and the CAN bus (`AppliedWheelCommand`, `AppliedCmgCommand`, same time stamps).

use ipc_types::{
    AppliedCmgCommand, AppliedWheelCommand, CmgCommand, HealthEventKind, SimClockTick, SimTruth,
    WheelCommand,
};
use std::time::{Duration, Instant};
use testbed_bus::{
    Flow, LoopExit, SourceId, SubscriberOptions, TopicPublisher, TopicSubscriber, Wake,
};
use testbed_runtime::run_config::Actuation;
use testbed_runtime::{ClockMode, Context, Io, Node, RunConfig, WakeOn};
use testbed_sim::plant_node::PlantNode;

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
    /// What the smart CAN node applies (`run.actuation = "can_node"`).
    Applied {
        wheels: TopicSubscriber<AppliedWheelCommand>,
        cmg: TopicSubscriber<AppliedCmgCommand>,
    },
}

/// The plant's ports: truth and clock out, commands in.
pub struct PlantPorts {
    truth: TopicPublisher<SimTruth>,
    clock: TopicPublisher<SimClockTick>,
    commands: CommandPorts,
}

/// The plant process: [`PlantNode`] as the clock owner of the run.
pub struct PlantProcess {
    node: PlantNode,
    period: Duration,
    /// The pacing interval (paced runs).
    pace: Option<SourceId>,
    started: Instant,
    /// `run.command_timeout_s` (reported with a zeroing).
    command_timeout_s: f64,
}

impl PlantProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, PlantPorts)> {
        let restarts = ipc_types::restart_count();
        anyhow::ensure!(
            restarts == 0,
            "the plant owns the run's clock and cannot restart mid-run (restart {restarts}): time would start again at 0"
        );
        let node = PlantNode::new(cx.config)?;
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
        let process = Self {
            node,
            period,
            pace: None,
            started: Instant::now(),
            command_timeout_s: cx.config.run.command_timeout_s,
        };
        Ok((
            process,
            PlantPorts {
                truth,
                clock,
                commands,
            },
        ))
    }

    fn publish(&mut self, ports: &PlantPorts) -> anyhow::Result<()> {
        let (truth, clock) = self.node.outputs();
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
        match &ports.commands {
            CommandPorts::Direct { wheels, cmg } => {
                wake.data(wheels)?;
                wake.data(cmg)?;
            }
            CommandPorts::Applied { wheels, cmg } => {
                wake.data(wheels)?;
                wake.data(cmg)?;
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
        let node = &mut self.node;
        match &ports.commands {
            CommandPorts::Direct { wheels, cmg } => {
                wheels.drain(|c| node.on_wheel_command(&c))?;
                cmg.drain(|c| node.on_cmg_command(&c))?;
            }
            CommandPorts::Applied { wheels, cmg } => {
                wheels.drain(|c| node.on_wheel_command(&WheelCommand::new(c.header, c.torque)))?;
                cmg.drain(|c| node.on_cmg_command(&CmgCommand::new(c.header, c.gimbal_rate)))?;
            }
        }
        let advance_now = match self.pace {
            None => node.answered(),
            Some(pace) => wake == Wake::Tick(pace),
        };
        if !advance_now {
            return Ok(Flow::Continue);
        }
        if node.at_end() {
            return Ok(Flow::Stop);
        }
        let was_zeroed = node.commands_zeroed();
        node.advance()?;
        let t_ns = self.node.time_ns();
        match (was_zeroed, self.node.commands_zeroed()) {
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
        io.heartbeat.set_time_ns(self.node.time_ns());
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &PlantPorts, _io: &Io, exit: LoopExit) -> anyhow::Result<()> {
        let wall = self.started.elapsed().as_secs_f64();
        let simulated = self.node.time_ns() as f64 * 1e-9;
        tracing::info!(
            ?exit,
            simulated_s = simulated,
            wall_s = wall,
            x_real_time = simulated / wall.max(1e-9),
            deadline_misses = self.node.deadline_misses(),
            ticks_with_commands_zeroed = self.node.zeroed_ticks(),
            "plant done"
        );
        Ok(())
    }
}
