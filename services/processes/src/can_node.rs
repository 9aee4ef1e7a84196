//! The simulated smart CAN node process: the plant's truth through the device models onto the
//! software CAN bus as sensor frames and tick syncs; command frames from the bus to the plant
//! as applied commands ([`SimCanNode`]).

use crate::can_link::BUS_BUFFER;
use anyhow::Context as _;
use ipc_types::{
    AppliedCmgCommand, AppliedWheelCommand, CanLinkStatus, SampleHeader, SimTruth, can_source,
};
use testbed_bus::{Flow, LoopExit, TopicPublisher, TopicSubscriber, Wake};
use testbed_gateways::bus_transport::SoftwareBusTransport;
use testbed_gateways::node::{SimCanNode, TxFrame};
use testbed_gateways::status::{HeartbeatCounters, StatusTracker};
use testbed_runtime::run_config::Actuation;
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The node's ports: truth in, the software CAN bus both ways, applied commands out.
pub struct CanNodePorts {
    truth: TopicSubscriber<SimTruth>,
    link: SoftwareBusTransport,
    wheel: TopicPublisher<AppliedWheelCommand>,
    cmg: TopicPublisher<AppliedCmgCommand>,
    status: TopicPublisher<CanLinkStatus>,
}

/// The simulated CAN node process.
pub struct CanNodeProcess {
    node: SimCanNode,
    tracker: StatusTracker,
    counters: HeartbeatCounters,
    truths: Vec<SimTruth>,
}

impl CanNodeProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, CanNodePorts)> {
        let (config, bus) = (cx.config, cx.bus);
        if config.run.actuation != Actuation::CanNode {
            tracing::warn!(
                "{}: run.actuation is not \"can_node\": the plant ignores the commands the node applies",
                cx.name
            );
        }
        let node = SimCanNode::new(config).context("the simulated CAN node")?;
        let ports = CanNodePorts {
            truth: bus.subscriber()?,
            link: SoftwareBusTransport::open(
                bus,
                can_source::NODE,
                SampleHeader::VALID | SampleHeader::SIMULATED,
                BUS_BUFFER,
            )?,
            wheel: bus.publisher()?,
            cmg: bus.publisher()?,
            status: bus.publisher()?,
        };
        let process = Self {
            node,
            tracker: StatusTracker::new(can_source::NODE),
            counters: HeartbeatCounters::default(),
            truths: Vec::new(),
        };
        Ok((process, ports))
    }
}

impl Node for CanNodeProcess {
    type Ports = CanNodePorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a CanNodePorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        wake.data(&ports.truth)?;
        wake.data(ports.link.subscriber())?;
        Ok(())
    }

    fn on_wake(&mut self, ports: &CanNodePorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        let (node, link) = (&mut self.node, &ports.link);
        self.truths.clear();
        ports.truth.drain_into(&mut self.truths)?;
        for t in &self.truths {
            io.heartbeat.add_samples_in(1);
            io.heartbeat.set_time_ns(t.header.time_ns);
            link.set_time_ns(t.header.time_ns);
            for frame in node.on_truth(t) {
                let sent = match frame {
                    TxFrame::Send(f) => link.send_frame(&f),
                    TxFrame::Corrupt(f, bit) => link.send_corrupted(&f, bit),
                };
                if let Err(e) = sent {
                    node.count_transport_error();
                    tracing::warn!("{}: sending: {e}", io.name);
                }
            }
        }
        while let Some(frame) = link.poll().context("receiving from the software CAN bus")? {
            node.set_link_check_errors(link.stats().check_errors + link.stats().invalid);
            let Some(applied) = node.on_frame(&frame.frame) else {
                continue;
            };
            let t_ns = applied.wheel.header.time_ns;
            if let Some(s) = self.tracker.due(t_ns, node.status()) {
                ports.status.publish(&s)?;
            }
            ports.wheel.publish(&applied.wheel)?;
            ports.cmg.publish(&applied.cmg)?;
            io.heartbeat.add_samples_out(2);
            self.counters.update(io.heartbeat, &node.status());
        }
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &CanNodePorts, io: &Io, exit: LoopExit) -> anyhow::Result<()> {
        let s = self.node.status();
        tracing::info!(
            ?exit,
            sent = s.frames_sent,
            tx_drop = s.injected_tx_drop,
            tx_corrupt = s.injected_tx_corrupt,
            tx_delay = s.injected_tx_delay,
            tx_duplicate = s.injected_tx_duplicate,
            rx_drop = s.injected_rx_drop,
            rx_corrupt = s.injected_rx_corrupt,
            rx_delay = s.injected_rx_delay,
            rx_duplicate = s.injected_rx_duplicate,
            overdue_ticks = self.node.overdue_ticks(),
            "{} stopping",
            io.name
        );
        Ok(())
    }
}
