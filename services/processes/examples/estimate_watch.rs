//! The README's worked example of a process: a node that counts attitude estimates and reports
//! how many were invalid when it stops. `tests/tests/worked_example.rs` runs it on a bus.

use ipc_types::AttitudeEstimate;
use testbed_bus::{Flow, LoopExit, TopicSubscriber, Wake};
use testbed_runtime::{Context, Io, Node, WakeOn};

pub struct EstimateWatch {
    seen: u64,
    invalid: u64,
}

pub struct EstimateWatchPorts {
    estimate: TopicSubscriber<AttitudeEstimate>,
}

impl EstimateWatch {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, EstimateWatchPorts)> {
        Ok((
            Self {
                seen: 0,
                invalid: 0,
            },
            EstimateWatchPorts {
                estimate: cx.bus.subscriber()?,
            },
        ))
    }
}

impl Node for EstimateWatch {
    type Ports = EstimateWatchPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a EstimateWatchPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        wake.data(&ports.estimate)?;
        Ok(())
    }

    fn on_wake(
        &mut self,
        ports: &EstimateWatchPorts,
        _wake: Wake,
        io: &Io,
    ) -> anyhow::Result<Flow> {
        let n = ports.estimate.drain(|e| {
            self.seen += 1;
            self.invalid += u64::from(!e.header.is_valid());
        })?;
        io.heartbeat.add_samples_in(n as u64);
        Ok(Flow::Continue)
    }

    fn stop(
        &mut self,
        _ports: &EstimateWatchPorts,
        _io: &Io,
        _exit: LoopExit,
    ) -> anyhow::Result<()> {
        tracing::info!(
            seen = self.seen,
            invalid = self.invalid,
            "estimate watch done"
        );
        Ok(())
    }
}

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("estimate-watch", EstimateWatch::open)
}
