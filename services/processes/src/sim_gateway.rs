//! The simulated gateways: a device model on the plant's truth, publishing exactly what the
//! real gateway of that device would.
//!
//! On every wake-up the truth samples are taken first, then the commands that preceded them
//! (in lockstep a command of tick k−1 always precedes the truth of tick k, so telemetry
//! reports the command in effect deterministically), then each truth gives at most one sample.
//! Commands do not wake the gateway: only the truth does, and only the truth of a tick on
//! which the device samples (a 2.5-Hz sensor on the 10-Hz truth wakes 2.5 times a second:
//! [`TopicSubscriber::wake_from`]); the truths in between are taken with the next sample's.

use ipc_types::{CmgCommand, SimTruth, Topic, WheelCommand};
use testbed_bus::{Bus, BusError, Flow, TopicPublisher, TopicSubscriber, Wake};
use testbed_flight::schedule::Schedule;
use testbed_runtime::{Context, Io, Node, RunConfig, WakeOn};
use testbed_sim::sim_devices::{SimCmg, SimGyro, SimInclinometer, SimMagnetometer, SimWheels};

/// A device model behind a simulated gateway.
pub trait SimDevice: Sized + 'static {
    /// What the gateway publishes.
    type Sample: Topic;
    /// The device model for this run.
    fn new(config: &RunConfig, schedule: Schedule) -> Self;
    /// The sample of `truth`'s tick, if the device samples then.
    fn on_truth(&mut self, truth: &SimTruth) -> Option<Self::Sample>;
    /// Ticks between the device's samples (1: every tick).
    fn ticks_per_sample(&self) -> u64;
    /// The command stream the device follows (wheels, CMG); `None` for sensors.
    fn commands(_bus: &Bus) -> Result<Option<Box<dyn CommandInput<Self>>>, BusError> {
        Ok(None)
    }
}

/// A command stream that a device model follows.
pub trait CommandInput<D> {
    /// Applies every pending command to `device`; the number applied.
    fn drain_into(&self, device: &mut D) -> Result<usize, BusError>;
}

struct Commands<C: Topic>(TopicSubscriber<C>);

impl CommandInput<SimWheels> for Commands<WheelCommand> {
    fn drain_into(&self, device: &mut SimWheels) -> Result<usize, BusError> {
        self.0.drain(|c| device.on_command(c))
    }
}

impl CommandInput<SimCmg> for Commands<CmgCommand> {
    fn drain_into(&self, device: &mut SimCmg) -> Result<usize, BusError> {
        self.0.drain(|c| device.on_command(c))
    }
}

macro_rules! sim_device {
    ($device:ty, $sample:ty) => {
        sim_device!($device, $sample, |_bus| Ok(None));
    };
    ($device:ty, $sample:ty, $commands:expr) => {
        impl SimDevice for $device {
            type Sample = $sample;
            fn new(config: &RunConfig, schedule: Schedule) -> Self {
                <$device>::new(config, schedule)
            }
            fn on_truth(&mut self, truth: &SimTruth) -> Option<$sample> {
                <$device>::on_truth(self, truth)
            }
            fn ticks_per_sample(&self) -> u64 {
                <$device>::ticks_per_sample(self)
            }
            fn commands(bus: &Bus) -> Result<Option<Box<dyn CommandInput<Self>>>, BusError> {
                $commands(bus)
            }
        }
    };
}

sim_device!(SimGyro, ipc_types::GyroSample);
sim_device!(SimInclinometer, ipc_types::InclinometerSample);
sim_device!(SimMagnetometer, ipc_types::MagnetometerSample);
sim_device!(SimWheels, ipc_types::WheelTelemetry, |bus: &Bus| Ok(Some(
    Box::new(Commands(bus.subscriber::<WheelCommand>()?)) as Box<dyn CommandInput<SimWheels>>
)));
sim_device!(SimCmg, ipc_types::CmgTelemetry, |bus: &Bus| Ok(Some(
    Box::new(Commands(bus.subscriber::<CmgCommand>()?)) as Box<dyn CommandInput<SimCmg>>
)));

/// A simulated gateway's ports: truth (and commands) in, the device's samples out.
pub struct SimGatewayPorts<D: SimDevice> {
    truth: TopicSubscriber<SimTruth>,
    commands: Option<Box<dyn CommandInput<D>>>,
    output: TopicPublisher<D::Sample>,
}

/// The simulated gateway of device `D`.
pub struct SimGateway<D> {
    device: D,
    truths: Vec<SimTruth>,
    schedule: Schedule,
    /// The device's sample period: how often the gateway takes the truth (liveness of the
    /// truth stream as this gateway sees it).
    period: std::time::Duration,
}

impl<D: SimDevice> SimGateway<D> {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, SimGatewayPorts<D>)> {
        let schedule = cx.config.schedule()?;
        let device = D::new(cx.config, schedule);
        let period =
            std::time::Duration::from_nanos(schedule.period_ns * device.ticks_per_sample());
        let commands = D::commands(cx.bus)?;
        let ports = SimGatewayPorts {
            truth: cx.bus.subscriber()?,
            commands,
            output: cx.bus.publisher()?,
        };
        Ok((
            Self {
                device,
                truths: Vec::new(),
                schedule,
                period,
            },
            ports,
        ))
    }
}

impl<D: SimDevice> Node for SimGateway<D> {
    type Ports = SimGatewayPorts<D>;

    fn wake_on<'a>(
        &mut self,
        ports: &'a Self::Ports,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        wake.input(&ports.truth, self.period)?;
        Ok(())
    }

    fn on_wake(&mut self, ports: &Self::Ports, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        // A gateway that asks to be woken only from its next sample's tick on looks at the
        // truth once more after asking: a truth published before the publisher could see the
        // request would otherwise wait, unrung, for the sample after it.
        loop {
            self.truths.clear();
            ports.truth.drain_into(&mut self.truths)?;
            if let Some(commands) = &ports.commands {
                commands.drain_into(&mut self.device)?;
            }
            if self.truths.is_empty() {
                return Ok(Flow::Continue);
            }
            for truth in &self.truths {
                io.heartbeat.add_samples_in(1);
                io.heartbeat.set_time_ns(truth.header.time_ns);
                if let Some(sample) = self.device.on_truth(truth) {
                    ports.output.publish(&sample)?;
                    io.heartbeat.add_samples_out(1);
                }
            }
            let every = self.device.ticks_per_sample();
            if every == 1 {
                return Ok(Flow::Continue);
            }
            let last_tick = self
                .truths
                .last()
                .and_then(|t| self.schedule.tick_at(t.header.time_ns));
            if let Some(k) = last_tick {
                ports
                    .truth
                    .wake_from(self.schedule.time_ns(Schedule::next_due(k, every)));
            }
        }
    }
}
