//! The simulated gateways: a device model on the plant's truth, publishing exactly what the
//! real gateway of that device would.
//!
//! On every wake-up the truth samples are taken first, then the commands that preceded them
//! (in lockstep a command of tick k−1 always precedes the truth of tick k, so telemetry
//! reports the command in effect deterministically), then each truth gives at most one sample.
//! Commands do not wake the gateway: only the truth does, and only the truth of a tick on
//! which the device samples (a 2.5-Hz sensor on the 10-Hz truth wakes 2.5 times a second:
//! [`TopicSubscriber::wake_from`]); the truths in between are taken with the next sample's.
//!
//! One process may host several devices (`sim-devices`, the profile's `device` list): each is a
//! task with its own model, commands and output, all fed the same truths in the same order, so
//! each publishes what it would in a process of its own; the process wakes from the next tick
//! on which any of its devices samples. On this project's virtual machine a paced tick's cost
//! is mostly per process woken, which is what grouping saves (bench/README.md, "One process
//! for the simulated gateways").

use ipc_types::{CmgCommand, Device, SimTruth, Topic, WheelCommand};
use testbed_bus::{Bus, BusError, Flow, TopicPublisher, TopicSubscriber, Wake};
use testbed_config::RunConfig;
use testbed_flight::schedule::Schedule;
use testbed_runtime::{Context, Io, Node, WakeOn};
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

/// One simulated device's work on the truth: its model, the commands it follows and the
/// samples it publishes, whichever gateway process hosts it.
struct DeviceTask<D: SimDevice> {
    device: D,
    commands: Option<Box<dyn CommandInput<D>>>,
    output: TopicPublisher<D::Sample>,
}

/// A [`DeviceTask`] of any device, as a gateway hosting several holds it.
trait Task {
    /// Applies every pending command (wheels, CMG).
    fn take_commands(&mut self) -> Result<(), BusError>;
    /// Publishes the sample of `truth`'s tick if the device samples then; whether it did.
    fn on_truth(&mut self, truth: &SimTruth) -> Result<bool, BusError>;
    /// Ticks between the device's samples.
    fn ticks_per_sample(&self) -> u64;
}

impl<D: SimDevice> Task for DeviceTask<D> {
    fn take_commands(&mut self) -> Result<(), BusError> {
        if let Some(commands) = &self.commands {
            commands.drain_into(&mut self.device)?;
        }
        Ok(())
    }

    fn on_truth(&mut self, truth: &SimTruth) -> Result<bool, BusError> {
        let Some(sample) = self.device.on_truth(truth) else {
            return Ok(false);
        };
        self.output.publish(&sample)?;
        Ok(true)
    }

    fn ticks_per_sample(&self) -> u64 {
        self.device.ticks_per_sample()
    }
}

fn open_task<D: SimDevice>(cx: &Context, schedule: Schedule) -> anyhow::Result<Box<dyn Task>> {
    Ok(Box::new(DeviceTask {
        device: D::new(cx.config, schedule),
        commands: D::commands(cx.bus)?,
        output: cx.bus.publisher::<D::Sample>()?,
    }))
}

/// A simulated gateway's port: the plant's truth (the devices' own ports are in their tasks).
pub struct SimGatewayPorts {
    truth: TopicSubscriber<SimTruth>,
}

/// A simulated gateway process: one device (`sim-gyro`, …) or several sharing a process and a
/// wake-up per tick (`sim-devices`). Each device samples and publishes exactly as it would
/// alone: the tasks take the same truths in the same order.
pub struct SimGateway {
    tasks: Vec<Box<dyn Task>>,
    truths: Vec<SimTruth>,
    schedule: Schedule,
    /// Ticks between the samples of the device that samples most often: the gateway takes
    /// the truth at that period (and watches the truth stream's liveness at it).
    every: u64,
    period: std::time::Duration,
}

impl SimGateway {
    /// The gateway of `devices` (at least one, none twice).
    pub fn open(cx: &Context, devices: &[Device]) -> anyhow::Result<(Self, SimGatewayPorts)> {
        anyhow::ensure!(!devices.is_empty(), "a simulated gateway needs a device");
        let schedule = cx.config.schedule()?;
        let mut tasks = Vec::with_capacity(devices.len());
        for (i, device) in devices.iter().enumerate() {
            anyhow::ensure!(
                !devices[..i].contains(device),
                "device {device} is listed twice"
            );
            tasks.push(match device {
                Device::Gyro => open_task::<SimGyro>(cx, schedule)?,
                Device::Inclinometer => open_task::<SimInclinometer>(cx, schedule)?,
                Device::Magnetometer => open_task::<SimMagnetometer>(cx, schedule)?,
                Device::Wheels => open_task::<SimWheels>(cx, schedule)?,
                Device::Cmg => open_task::<SimCmg>(cx, schedule)?,
            });
        }
        let every = tasks
            .iter()
            .map(|t| t.ticks_per_sample())
            .min()
            .unwrap_or(1);
        let period = std::time::Duration::from_nanos(schedule.period_ns * every);
        let ports = SimGatewayPorts {
            truth: cx.bus.subscriber()?,
        };
        Ok((
            Self {
                tasks,
                truths: Vec::new(),
                schedule,
                every,
                period,
            },
            ports,
        ))
    }

    /// The gateway of the devices the launcher says this process serves
    /// ([`ipc_types::ENV_SERVED_DEVICES`]).
    pub fn open_served(cx: &Context) -> anyhow::Result<(Self, SimGatewayPorts)> {
        let devices = ipc_types::served_devices().map_err(anyhow::Error::msg)?;
        Self::open(cx, &devices)
    }

    /// The first tick after `k` on which any device samples.
    fn next_sample_tick(&self, k: u64) -> u64 {
        self.tasks
            .iter()
            .map(|t| Schedule::next_due(k, t.ticks_per_sample()))
            .min()
            .unwrap_or(k + 1)
    }
}

impl Node for SimGateway {
    type Ports = SimGatewayPorts;

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
            for task in &mut self.tasks {
                task.take_commands()?;
            }
            if self.truths.is_empty() {
                return Ok(Flow::Continue);
            }
            for truth in &self.truths {
                io.heartbeat.add_samples_in(1);
                io.heartbeat.set_time_ns(truth.header.time_ns);
                for task in &mut self.tasks {
                    if task.on_truth(truth)? {
                        io.heartbeat.add_samples_out(1);
                    }
                }
            }
            if self.every == 1 {
                return Ok(Flow::Continue);
            }
            let last_tick = self
                .truths
                .last()
                .and_then(|t| self.schedule.tick_at(t.header.time_ns));
            if let Some(k) = last_tick {
                let next = self.next_sample_tick(k);
                ports.truth.wake_from(self.schedule.time_ns(next));
            }
        }
    }
}
