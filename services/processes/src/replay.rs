//! The replay process: feeds a recorded run's sensor and actuator telemetry (and its truth and
//! clock, for the log) back into the estimator and controller, one tick at a time, waiting for
//! the controller's commands of each tick as the plant does in lockstep. Stops after the last
//! tick.

use crate::replay_log::{self, ReplayTick};
use anyhow::Context as _;
use ipc_types::*;
use testbed_bus::{Flow, LoopExit, SubscriberOptions, TopicPublisher, TopicSubscriber, Wake};
use testbed_config::RunConfig;
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The replay's ports: everything the plant and the gateways would publish, and the commands.
pub struct ReplayPorts {
    truth: TopicPublisher<SimTruth>,
    clock: TopicPublisher<SimClockTick>,
    gyro: TopicPublisher<GyroSample>,
    inclinometer: TopicPublisher<InclinometerSample>,
    magnetometer: TopicPublisher<MagnetometerSample>,
    wheels: TopicPublisher<WheelTelemetry>,
    cmg: TopicPublisher<CmgTelemetry>,
    wheel_command: TopicSubscriber<WheelCommand>,
    cmg_command: TopicSubscriber<CmgCommand>,
}

impl ReplayPorts {
    fn publish(&self, t: &ReplayTick) -> anyhow::Result<()> {
        // Truth and clock first: the logger takes a clock sample as the end of the tick before.
        fn send<T: Topic>(publisher: &TopicPublisher<T>, sample: &Option<T>) -> anyhow::Result<()> {
            if let Some(s) = sample {
                publisher.publish(s)?;
            }
            Ok(())
        }
        send(&self.truth, &t.truth)?;
        send(&self.clock, &t.clock)?;
        send(&self.gyro, &t.gyro)?;
        send(&self.inclinometer, &t.inclinometer)?;
        send(&self.magnetometer, &t.magnetometer)?;
        send(&self.wheels, &t.wheels)?;
        send(&self.cmg, &t.cmg)
    }
}

/// The replay process: the recorded ticks and how far it got.
pub struct ReplayProcess {
    ticks: Vec<ReplayTick>,
    index: usize,
    wheel_answered: bool,
    cmg_answered: bool,
}

impl ReplayProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, ReplayPorts)> {
        let source = cx
            .config
            .run
            .replay
            .clone()
            .context("run.replay names no log to replay")?;
        let ticks =
            replay_log::load(&source).with_context(|| format!("reading {}", source.display()))?;
        anyhow::ensure!(
            !ticks.is_empty(),
            "{} holds no gyro samples to replay",
            source.display()
        );
        tracing::info!(log = %source.display(), ticks = ticks.len(), "replaying");
        let bus = cx.bus;
        let ports = ReplayPorts {
            truth: bus.publisher()?,
            clock: bus.publisher()?,
            gyro: bus.publisher()?,
            inclinometer: bus.publisher()?,
            magnetometer: bus.publisher()?,
            wheels: bus.publisher()?,
            cmg: bus.publisher()?,
            wheel_command: bus.subscriber_with(SubscriberOptions::buffer(64))?,
            cmg_command: bus.subscriber_with(SubscriberOptions::buffer(64))?,
        };
        Ok((
            Self {
                ticks,
                index: 0,
                wheel_answered: false,
                cmg_answered: false,
            },
            ports,
        ))
    }
}

impl Node for ReplayProcess {
    type Ports = ReplayPorts;

    fn start_barrier(&self, config: &RunConfig) -> Option<Vec<String>> {
        Some(config.run.participants.clone())
    }

    fn wake_on<'a>(
        &mut self,
        ports: &'a ReplayPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        wake.data(&ports.wheel_command)?;
        wake.data(&ports.cmg_command)?;
        Ok(())
    }

    fn start(&mut self, ports: &ReplayPorts, _io: &Io) -> anyhow::Result<Flow> {
        ports.publish(&self.ticks[0])?;
        Ok(Flow::Continue)
    }

    fn on_wake(&mut self, ports: &ReplayPorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        let now = self.ticks[self.index].time_ns;
        let (wheel, cmg) = (&mut self.wheel_answered, &mut self.cmg_answered);
        ports
            .wheel_command
            .drain(|c| *wheel |= c.header.time_ns == now)?;
        ports
            .cmg_command
            .drain(|c| *cmg |= c.header.time_ns == now)?;
        if !(self.wheel_answered && self.cmg_answered) {
            return Ok(Flow::Continue);
        }
        self.index += 1;
        (self.wheel_answered, self.cmg_answered) = (false, false);
        let Some(next) = self.ticks.get(self.index) else {
            return Ok(Flow::Stop);
        };
        io.heartbeat.set_time_ns(next.time_ns);
        ports.publish(next)?;
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &ReplayPorts, _io: &Io, _exit: LoopExit) -> anyhow::Result<()> {
        tracing::info!(ticks = self.index, "replay done");
        Ok(())
    }
}
