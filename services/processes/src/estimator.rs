//! The estimator process: the MEKF, propagating on every gyro sample and updating from the
//! inclinometer and magnetometer; one attitude estimate per tick.

use ipc_types::{AttitudeEstimate, GyroSample, InclinometerSample, MagnetometerSample};
use std::time::Duration;
use testbed_bus::{Flow, TopicPublisher, TopicSubscriber, Wake};
use testbed_flight::tasks::EstimatorTask;
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The estimator's ports: the three sensor streams in, the estimate out.
pub struct EstimatorPorts {
    gyro: TopicSubscriber<GyroSample>,
    tilt: TopicSubscriber<InclinometerSample>,
    field: TopicSubscriber<MagnetometerSample>,
    estimate: TopicPublisher<AttitudeEstimate>,
}

/// The estimator process: [`EstimatorTask`] on the bus.
pub struct EstimatorProcess {
    task: EstimatorTask,
    /// Sample periods of the gyro, inclinometer and magnetometer (liveness of the inputs).
    periods: [Duration; 3],
    /// The estimates of one wake-up, a buffer kept for the run (a tick allocates nothing).
    estimates: Vec<AttitudeEstimate>,
}

impl EstimatorProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, EstimatorPorts)> {
        let schedule = cx.config.schedule()?;
        let task = EstimatorTask::new(cx.config.estimator_setup()?, schedule);
        let tick = Duration::from_nanos(schedule.period_ns);
        let every = |ticks: u64| tick * u32::try_from(ticks).unwrap_or(u32::MAX);
        let periods = [
            tick,
            every(schedule.tilt_every),
            every(schedule.field_every),
        ];
        let ports = EstimatorPorts {
            gyro: cx.bus.subscriber()?,
            tilt: cx.bus.subscriber()?,
            field: cx.bus.subscriber()?,
            estimate: cx.bus.publisher()?,
        };
        Ok((
            Self {
                task,
                periods,
                estimates: Vec::with_capacity(4),
            },
            ports,
        ))
    }
}

impl Node for EstimatorProcess {
    type Ports = EstimatorPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a EstimatorPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        let [gyro, tilt, field] = self.periods;
        wake.input(&ports.gyro, gyro)?;
        wake.input(&ports.tilt, tilt)?;
        wake.input(&ports.field, field)?;
        Ok(())
    }

    fn on_wake(&mut self, ports: &EstimatorPorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        let task = &mut self.task;
        let received = ports.gyro.drain(|s| task.on_gyro(s))?
            + ports.tilt.drain(|s| task.on_inclinometer(s))?
            + ports.field.drain(|s| task.on_magnetometer(s))?;
        io.heartbeat.add_samples_in(received as u64);
        task.ready_into(&mut self.estimates);
        for estimate in self.estimates.drain(..) {
            io.heartbeat.set_time_ns(estimate.header.time_ns);
            ports.estimate.publish(&estimate)?;
            io.heartbeat.add_samples_out(1);
        }
        Ok(Flow::Continue)
    }

    /// A tick's gyro, inclinometer and magnetometer samples wake the estimator once, not once
    /// per sensor.
    fn samples_awaited(&self) -> u32 {
        self.task.samples_awaited()
    }

    fn stop(
        &mut self,
        _ports: &EstimatorPorts,
        _io: &Io,
        _exit: testbed_bus::LoopExit,
    ) -> anyhow::Result<()> {
        let counters = self.task.counters();
        tracing::info!(?counters, "estimator stopping");
        Ok(())
    }
}
