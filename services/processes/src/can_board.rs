//! The simulated CAN board process: the plant's truth through the device models onto the
//! CAN bus as sensor frames and tick syncs; command frames from the bus to the plant as applied
//! commands ([`SimCanBoard`]). The bus is the software CAN bus, or with `can.link = "socketcan"`
//! the SocketCAN interface `can.interface` (e.g. `vcan0`), the far side of the real gateways.

use crate::can_gateway::POLL_PERIOD;
use crate::can_link::BUS_BUFFER;
use crate::can_link::HeartbeatCounters;
use crate::software_bus::SoftwareBusTransport;
use anyhow::Context as _;
use ipc_types::{
    AppliedCmgCommand, AppliedThrusterCommand, AppliedWheelCommand, CanLinkStatus, SampleHeader,
    SimTruth, can_source,
};
use testbed_bus::{Flow, LoopExit, TopicPublisher, TopicSubscriber, Wake};
use testbed_can::transport::SocketCanTransport;
use testbed_can::{CanTransport, Device, TimestampedFrame};
use testbed_config::{Actuation, CanLink};
use testbed_gateways::can_board::{SimCanBoard, TxFrame};
use testbed_gateways::status::StatusTracker;
use testbed_runtime::{Context, Io, Node, WakeOn};

/// The board's ports: truth in, the software CAN bus both ways (when it is the link), applied
/// commands out.
pub struct CanBoardPorts {
    truth: TopicSubscriber<SimTruth>,
    link: Option<SoftwareBusTransport>,
    wheel: TopicPublisher<AppliedWheelCommand>,
    cmg: TopicPublisher<AppliedCmgCommand>,
    /// Runs with thrusters.
    thrusters: Option<TopicPublisher<AppliedThrusterCommand>>,
    status: TopicPublisher<CanLinkStatus>,
}

/// The simulated CAN board process (role `sim-can-node`).
pub struct CanBoardProcess {
    board: SimCanBoard,
    tracker: StatusTracker,
    counters: HeartbeatCounters,
    truths: Vec<SimTruth>,
    /// The SocketCAN interface when it is the link (polled: it cannot wake the event loop).
    socketcan: Option<SocketCanTransport>,
    /// Deliberately corrupted frames not sent: on a real bus every receiver's CAN controller
    /// drops a frame whose CRC fails, so SocketCAN never delivers one.
    corrupt_not_sent: u64,
}

impl CanBoardProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, CanBoardPorts)> {
        let (config, bus) = (cx.config, cx.bus);
        if config.run.actuation != Actuation::CanNode {
            tracing::warn!(
                "{}: run.actuation is not \"can_node\": the plant ignores the commands the board applies",
                cx.name
            );
        }
        let board = SimCanBoard::new(config).context("the simulated CAN board")?;
        let (link, socketcan) = match config.can.link {
            CanLink::SoftwareBus => (
                Some(SoftwareBusTransport::open(
                    bus,
                    can_source::NODE,
                    SampleHeader::VALID | SampleHeader::SIMULATED,
                    BUS_BUFFER,
                )?),
                None,
            ),
            CanLink::Socketcan => {
                let iface = &config.can.interface;
                let mut transport = SocketCanTransport::open(iface)
                    .with_context(|| format!("can.interface = {iface:?}"))?;
                // The board hears the computer's commands only: the wheel, CMG and thruster
                // blocks (its own telemetry in those blocks never comes back: no
                // CAN_RAW_RECV_OWN_MSGS).
                let protocol = testbed_gateways::can_board::protocol(config)?;
                transport
                    .set_device_filters(
                        protocol.ids(),
                        &[Device::Wheels, Device::Cmg, Device::Thrusters],
                    )
                    .with_context(|| format!("filters on {iface}"))?;
                (None, Some(transport))
            }
            CanLink::Candump => anyhow::bail!(
                "{}: the simulated CAN board needs a bus (can.link = \"software_bus\" or \"socketcan\"), not a candump file",
                cx.name
            ),
        };
        let ports = CanBoardPorts {
            truth: bus.subscriber()?,
            link,
            wheel: bus.publisher()?,
            cmg: bus.publisher()?,
            thrusters: board.has_thrusters().then(|| bus.publisher()).transpose()?,
            status: bus.publisher()?,
        };
        let process = Self {
            board,
            tracker: StatusTracker::new(can_source::NODE),
            counters: HeartbeatCounters::default(),
            truths: Vec::new(),
            socketcan,
            corrupt_not_sent: 0,
        };
        Ok((process, ports))
    }
}

impl Node for CanBoardProcess {
    type Ports = CanBoardPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a CanBoardPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        wake.data(&ports.truth)?;
        match &ports.link {
            Some(link) => wake.data(link.subscriber())?,
            None => wake.interval(POLL_PERIOD)?,
        };
        Ok(())
    }

    fn on_wake(&mut self, ports: &CanBoardPorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        let board = &mut self.board;
        self.truths.clear();
        ports.truth.drain_into(&mut self.truths)?;
        for t in &self.truths {
            io.heartbeat.add_samples_in(1);
            io.heartbeat.set_time_ns(t.header.time_ns);
            if let Some(link) = &ports.link {
                link.set_time_ns(t.header.time_ns);
            }
            for frame in board.on_truth(t) {
                let sent = match (frame, &ports.link, self.socketcan.as_mut()) {
                    (TxFrame::Send(f), Some(link), _) => link.send_frame(&f),
                    (TxFrame::Corrupt(f, bit), Some(link), _) => link.send_corrupted(&f, bit),
                    (TxFrame::Send(f), None, Some(socket)) => socket.send(&f),
                    (TxFrame::Corrupt(..), None, Some(_)) => {
                        self.corrupt_not_sent += 1;
                        Ok(())
                    }
                    (_, None, None) => Ok(()),
                };
                if let Err(e) = sent {
                    board.count_transport_error();
                    tracing::warn!("{}: sending: {e}", io.name);
                }
            }
        }
        loop {
            let frame: Option<TimestampedFrame> = match (&ports.link, self.socketcan.as_mut()) {
                (Some(link), _) => {
                    let frame = link.poll().context("receiving from the software CAN bus")?;
                    board.set_link_check_errors(link.stats().check_errors + link.stats().invalid);
                    frame
                }
                (None, Some(socket)) => match socket.recv(std::time::Duration::ZERO) {
                    Ok(frame) => {
                        board.set_link_check_errors(socket.error_frames());
                        frame
                    }
                    Err(e) => {
                        // The interface down (ENETDOWN) and the like: counted, the board keeps
                        // going and hears the bus again when it is back.
                        board.count_transport_error();
                        tracing::warn!("{}: receiving: {e}", io.name);
                        None
                    }
                },
                (None, None) => None,
            };
            let Some(frame) = frame else {
                break;
            };
            let Some(applied) = board.on_frame(&frame.frame) else {
                continue;
            };
            let t_ns = applied.wheel.header.time_ns;
            if let Some(s) = self.tracker.due(t_ns, board.status()) {
                ports.status.publish(&s)?;
            }
            ports.wheel.publish(&applied.wheel)?;
            ports.cmg.publish(&applied.cmg)?;
            io.heartbeat.add_samples_out(2);
            if let (Some(publisher), Some(thrusters)) = (&ports.thrusters, &applied.thrusters) {
                publisher.publish(thrusters)?;
                io.heartbeat.add_samples_out(1);
            }
            self.counters.update(io.heartbeat, &board.status());
        }
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &CanBoardPorts, io: &Io, exit: LoopExit) -> anyhow::Result<()> {
        let s = self.board.status();
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
            overdue_ticks = self.board.overdue_ticks(),
            corrupt_not_sent = self.corrupt_not_sent,
            "{} stopping",
            io.name
        );
        Ok(())
    }
}
