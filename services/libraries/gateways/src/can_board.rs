//! The simulated CAN board's logic, without I/O.
//!
//! Per tick `T` of the plant's truth ([`SimCanBoard::on_truth`]):
//! 1. the device models of the simulated gateways (`testbed_sim::sim_devices`, same seeds,
//!    so the same noise) sample the truth; the results are encoded with the board's protocol,
//!    board time stamp `T` in µs, in identifier (arbitration) order: wheels, CMG, gyro,
//!    inclinometer, magnetometer;
//! 2. each frame meets its fate ([`crate::faults`]): sent, dropped, corrupted, duplicated, or
//!    held back;
//! 3. the board's heartbeat for `T` follows: the **tick sync**, never faulted;
//! 4. the held-back (delayed) frames follow the sync: they arrive after the deadline.
//!
//! Then the board waits for the tick's commands ([`SimCanBoard::on_frame`]): one wheel command
//! frame and two CMG command frames. Once all three have arrived (before injection) it closes
//! the tick: the frames, ordered by identifier (arbitration order, so the result does not depend
//! on which gateway's frame the board read first), meet their fate, go through the decoder, and
//! the complete in-range commands become the applied ones ([`Applied`]); a command kind without
//! a new complete command holds the previous one (flagged `STALE`), zero after
//! `can.command_timeout_s`. Frames delayed on the way in are handed over at the next tick's
//! close, after that tick's deadline: they are late and their messages are not used.
//!
//! **Thrusters** (runs with `[model.thrusters]` and `[controller.thrusters]`): the tick's
//! command frames also include the thruster command's two frames. The board applies it as
//! [`Applied::thrusters`] (a missing or out-of-range command: every valve shut, flagged `STALE`;
//! a thruster command is never held), shuts the latch valve for good when a command asks, and
//! reports each period's applied on-times and the valves' position sensors in a thruster
//! status, the last message before the tick sync. It senses the valves with its own copy of
//! the plant's valve model (same configuration, same applied commands; valve timing has no
//! noise), which is what a position sensor on each valve would read, an injected stuck-open
//! valve included.
//!
//! No fault is injected in tick 0 nor in the last ticks of the run (as many as the slowest
//! device's sampling period), so that every injected fault is followed, within the run, by a
//! frame that lets its receiver see it.

use crate::faults::{Fault, FaultInjector};
use crate::gateway::board_stamp_us;
use ipc_types::{
    AppliedCmgCommand, AppliedThrusterCommand, AppliedWheelCommand, CanLinkStatus, CmgCommand,
    SampleHeader, SimTruth, WheelCommand,
};
use std::ops::RangeInclusive;
use testbed_can::{
    CanFrame, CmgTelemetryMsg, Decoder, Device, DeviceSet, DeviceStatus, Encoder, GyroMsg,
    InclinometerMsg, Limits, MagnetometerMsg, Message, MessageKind, NodeHeartbeatMsg, NodeState,
    Protocol, ProtocolError, ThrusterStatusMsg, WheelTelemetryMsg,
};
use testbed_config::RunConfig;
use testbed_flight::convert::Sequence;
use testbed_flight::schedule::Schedule;
use testbed_model::physics::thrusters::{ThrusterBank, ThrusterCommand as ValveCommand};
use testbed_model::thruster_config::THRUSTER_COUNT;
use testbed_sim::sim_devices::{SimCmg, SimGyro, SimInclinometer, SimMagnetometer, SimWheels};

/// Why the board cannot start.
#[derive(Debug, thiserror::Error)]
pub enum CanBoardError {
    /// The model's limits or the identifier base do not fit the protocol.
    #[error("CAN protocol: {0}")]
    Protocol(#[from] ProtocolError),
    /// The model's device rates do not fit the tick.
    #[error("schedule: {0}")]
    Schedule(#[from] testbed_flight::schedule::ScheduleError),
}

/// A frame for the bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TxFrame {
    /// Send as is.
    Send(CanFrame),
    /// Send with bit `bit` flipped after the frame check (fault injection).
    Corrupt(CanFrame, u32),
}

/// The commands the board applies for one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Applied {
    /// Wheel motor torques.
    pub wheel: AppliedWheelCommand,
    /// Gimbal rates.
    pub cmg: AppliedCmgCommand,
    /// Valve on-times (runs with thrusters).
    pub thrusters: Option<AppliedThrusterCommand>,
}

impl Applied {
    /// The wheel torques and gimbal rates as applied, as commands (what the plant and the
    /// simulated actuators take).
    pub fn commands(&self) -> (WheelCommand, CmgCommand) {
        (
            WheelCommand::new(self.wheel.header, self.wheel.torque),
            CmgCommand::new(self.cmg.header, self.cmg.gimbal_rate),
        )
    }
}

/// The board's side of the thruster valves.
struct BoardThrusters {
    /// The valves as their position sensors read them (a copy of the plant's valve model).
    valves: ThrusterBank,
    /// On-times applied in the period in progress, s.
    applied: [f64; THRUSTER_COUNT],
    latch_shut: bool,
    period_s: f64,
    seq: Sequence,
}

/// The board's protocol for a run: the model's limits, `can.id_base`.
pub fn protocol(config: &RunConfig) -> Result<Protocol, ProtocolError> {
    Protocol::from_model(config.can.id_base, &config.model)
}

/// The simulated CAN board; see the [module documentation](self).
pub struct SimCanBoard {
    protocol: Protocol,
    encoder: Encoder,
    decoder: Decoder,
    schedule: Schedule,
    gyro: SimGyro,
    tilt: SimInclinometer,
    field: SimMagnetometer,
    wheels: SimWheels,
    cmg: SimCmg,
    faults: FaultInjector,
    tx_window: RangeInclusive<u64>,
    rx_window: RangeInclusive<u64>,
    command_ids: Vec<u16>,
    timeout_ticks: u64,
    tick: Option<u64>,
    open: bool,
    rx: Vec<CanFrame>,
    rx_late: Vec<CanFrame>,
    wheel: [f64; 3],
    cmg_rate: [f64; 4],
    last_wheel_tick: Option<u64>,
    last_cmg_tick: Option<u64>,
    counters: CanLinkStatus,
    late_frames: u64,
    link_check_errors: u64,
    overdue_ticks: u64,
    wheel_seq: Sequence,
    cmg_seq: Sequence,
    thrusters: Option<BoardThrusters>,
}

impl SimCanBoard {
    /// The board of a run: its device models, protocol, faults and command time-out.
    pub fn new(config: &RunConfig) -> Result<Self, CanBoardError> {
        let protocol = protocol(config)?;
        let schedule = config.schedule()?;
        let ids = protocol.ids();
        let id = |kind, part| ids.id(kind, part).unwrap_or(0);
        let last = schedule.tick_count(config.run.duration_s);
        let guard = schedule.tilt_every.max(schedule.field_every).max(1);
        let timeout_ticks = (config.can.command_timeout_s / schedule.period_s())
            .ceil()
            .max(1.0) as u64;
        let thrusters = config
            .controller
            .thrusters
            .as_ref()
            .and(ThrusterBank::from_config(&config.model))
            .map(|valves| BoardThrusters {
                valves,
                applied: [0.0; THRUSTER_COUNT],
                latch_shut: false,
                period_s: schedule.period_s(),
                seq: Sequence::default(),
            });
        let mut command_ids = vec![
            id(MessageKind::WheelCommand, 0),
            id(MessageKind::CmgCommand, 0),
            id(MessageKind::CmgCommand, 1),
        ];
        let mut heard = vec![Device::Wheels, Device::Cmg];
        if thrusters.is_some() {
            command_ids.extend([
                id(MessageKind::ThrusterCommand, 0),
                id(MessageKind::ThrusterCommand, 1),
            ]);
            heard.push(Device::Thrusters);
        }
        Ok(Self {
            protocol,
            encoder: Encoder::new(protocol),
            decoder: Decoder::with_devices(protocol, DeviceSet::of(&heard)),
            schedule,
            gyro: SimGyro::new(config, schedule),
            tilt: SimInclinometer::new(config, schedule),
            field: SimMagnetometer::new(config, schedule),
            wheels: SimWheels::new(config, schedule),
            cmg: SimCmg::new(config, schedule),
            faults: FaultInjector::new(config.can.faults, config.run.seed),
            // Wrapping ends give an empty range for runs too short to hold faults.
            tx_window: 1..=last.saturating_sub(guard),
            rx_window: 1..=last.saturating_sub(1),
            command_ids,
            timeout_ticks,
            tick: None,
            open: false,
            rx: Vec::new(),
            rx_late: Vec::new(),
            wheel: [0.0; 3],
            cmg_rate: [0.0; 4],
            last_wheel_tick: None,
            last_cmg_tick: None,
            counters: CanLinkStatus::default(),
            late_frames: 0,
            link_check_errors: 0,
            overdue_ticks: 0,
            wheel_seq: Sequence::default(),
            cmg_seq: Sequence::default(),
            thrusters,
        })
    }

    /// The time of the current tick, ns.
    pub fn time_ns(&self) -> Option<u64> {
        self.tick.map(|k| self.schedule.time_ns(k))
    }

    /// Whether the board drives thruster valves (runs with thrusters).
    pub fn has_thrusters(&self) -> bool {
        self.thrusters.is_some()
    }

    /// Ticks closed before all their command frames arrived (paced runs only).
    pub fn overdue_ticks(&self) -> u64 {
        self.overdue_ticks
    }

    /// Frames the link rejected (failed frame checks), a total.
    pub fn set_link_check_errors(&mut self, total: u64) {
        self.link_check_errors = total;
    }

    /// Counts a failed send or receive.
    pub fn count_transport_error(&mut self) {
        self.counters.transport_errors += 1;
    }

    /// The counters (header left default).
    pub fn status(&self) -> CanLinkStatus {
        let s = self.decoder.stats();
        let used = s.ok + s.counter_jump + s.incomplete + s.out_of_range;
        let crc = self.counters.injected_rx_corrupt + self.link_check_errors;
        CanLinkStatus {
            frames_ok: used.saturating_sub(self.late_frames),
            frames_bad: crc + s.wrong_dlc + s.unknown_id + s.duplicate + self.late_frames,
            crc_errors: crc,
            wrong_dlc: s.wrong_dlc,
            unknown_id: s.unknown_id + self.counters.unknown_id,
            duplicates: s.duplicate,
            lost_frames: s.lost_frames,
            incomplete_samples: s.incomplete_samples,
            late_frames: self.late_frames,
            out_of_range: s.out_of_range_frames,
            ..self.counters
        }
    }

    /// Keeps every value of a message inside the protocol's ranges, as a board reports a device
    /// beyond its range: clipped and flagged saturated; a non-finite value is zero and the
    /// sample flagged faulty.
    fn sanitised(limits: &Limits, message: Message) -> Message {
        fn limit(
            values: &mut [f64],
            range: Option<f64>,
            status: &mut DeviceStatus,
            axis: impl Fn(usize) -> u8,
        ) {
            for (i, v) in values.iter_mut().enumerate() {
                if !v.is_finite() {
                    *v = 0.0;
                    status.0 |= DeviceStatus::FAULT;
                } else if let Some(r) = range.filter(|r| v.abs() > *r) {
                    *v = v.clamp(-r, r);
                    status.0 |= DeviceStatus::saturated_bit(axis(i));
                }
            }
        }
        let axis = |i: usize| i as u8;
        match message {
            Message::Gyro(mut m) => {
                limit(
                    &mut m.rate_rad_s,
                    Some(limits.gyro_range_rad_s),
                    &mut m.status,
                    axis,
                );
                Message::Gyro(m)
            }
            Message::Inclinometer(mut m) => {
                limit(
                    &mut m.tilt_rad,
                    Some(limits.tilt_range_rad),
                    &mut m.status,
                    axis,
                );
                Message::Inclinometer(m)
            }
            Message::Magnetometer(mut m) => {
                limit(
                    &mut m.field_t,
                    Some(limits.field_range_t),
                    &mut m.status,
                    axis,
                );
                Message::Magnetometer(m)
            }
            Message::WheelTelemetry(mut m) => {
                limit(
                    &mut m.speed_rad_s,
                    Some(limits.wheel_speed_rad_s),
                    &mut m.status,
                    axis,
                );
                limit(
                    &mut m.torque_nm,
                    Some(limits.wheel_torque_nm),
                    &mut m.status,
                    axis,
                );
                Message::WheelTelemetry(m)
            }
            Message::CmgTelemetry(mut m) => {
                limit(&mut m.gimbal_angle_rad, None, &mut m.status, axis);
                limit(
                    &mut m.gimbal_rate_rad_s,
                    Some(limits.gimbal_rate_rad_s),
                    &mut m.status,
                    axis,
                );
                Message::CmgTelemetry(m)
            }
            other => other,
        }
    }

    /// The frames of tick `truth.header.time_ns`, in sending order (see the module
    /// documentation). Empty for a truth off the schedule.
    pub fn on_truth(&mut self, truth: &SimTruth) -> Vec<TxFrame> {
        let t_ns = truth.header.time_ns;
        let Some(k) = self.schedule.tick_at(t_ns) else {
            return Vec::new();
        };
        if self.open {
            // Paced run: the previous tick's commands did not all come; close it with what did.
            self.overdue_ticks += 1;
            self.close();
        }
        let t_us = board_stamp_us(t_ns);
        let mut messages = Vec::with_capacity(5);
        messages.extend(
            self.wheels
                .on_truth(truth)
                .map(|s| Message::WheelTelemetry(WheelTelemetryMsg::from_sample(&s, t_us))),
        );
        messages.extend(
            self.cmg
                .on_truth(truth)
                .map(|s| Message::CmgTelemetry(CmgTelemetryMsg::from_sample(&s, t_us))),
        );
        messages.extend(
            self.gyro
                .on_truth(truth)
                .map(|s| Message::Gyro(GyroMsg::from_sample(&s, t_us))),
        );
        messages.extend(
            self.tilt
                .on_truth(truth)
                .map(|s| Message::Inclinometer(InclinometerMsg::from_sample(&s, t_us))),
        );
        messages.extend(
            self.field
                .on_truth(truth)
                .map(|s| Message::Magnetometer(MagnetometerMsg::from_sample(&s, t_us))),
        );
        if let Some(th) = &mut self.thrusters {
            // The period that ends now: what was applied and where the valves are.
            let t_s = t_ns as f64 * 1e-9;
            let valves_open = (0..THRUSTER_COUNT)
                .filter(|&i| th.valves.valve_open(i, t_s))
                .fold(0u8, |bits, i| bits | 1 << i);
            th.valves.discard_before(t_s);
            messages.push(Message::ThrusterStatus(ThrusterStatusMsg {
                node_time_us: t_us,
                status: DeviceStatus::default(),
                applied_on_time_s: std::mem::take(&mut th.applied),
                valves_open,
                latch_shut: th.latch_shut,
            }));
        }
        let in_window = self.tx_window.contains(&k);
        let mut out = Vec::with_capacity(24);
        let mut delayed = Vec::new();
        for message in messages {
            let message = Self::sanitised(self.protocol.limits(), message);
            let batch = match self.encoder.encode(&message) {
                Ok(batch) => batch,
                Err(e) => {
                    tracing::warn!("CAN board: cannot encode {:?}: {e}", message.kind());
                    self.counters.transport_errors += 1;
                    continue;
                }
            };
            for &frame in &batch {
                match if in_window {
                    self.faults.draw()
                } else {
                    Fault::None
                } {
                    Fault::None => out.push(TxFrame::Send(frame)),
                    Fault::Drop => self.counters.injected_tx_drop += 1,
                    Fault::Corrupt { bit } => {
                        self.counters.injected_tx_corrupt += 1;
                        out.push(TxFrame::Corrupt(frame, bit));
                    }
                    Fault::Delay => {
                        self.counters.injected_tx_delay += 1;
                        delayed.push(TxFrame::Send(frame));
                    }
                    Fault::Duplicate => {
                        self.counters.injected_tx_duplicate += 1;
                        out.extend([TxFrame::Send(frame), TxFrame::Send(frame)]);
                    }
                }
            }
        }
        let mut links = DeviceSet::of(&[
            Device::Wheels,
            Device::Cmg,
            Device::Gyro,
            Device::Inclinometer,
            Device::Magnetometer,
        ]);
        if self.thrusters.is_some() {
            links.0 |= Device::Thrusters.bit();
        }
        let sync = Message::NodeHeartbeat(NodeHeartbeatMsg {
            node_time_us: t_us,
            state: NodeState::Running,
            links,
            serial_errors: 0,
        });
        match self.encoder.encode(&sync) {
            Ok(batch) => out.extend(batch.iter().map(|f| TxFrame::Send(*f))),
            Err(e) => {
                tracing::warn!("CAN board: cannot encode its tick sync: {e}");
                self.counters.transport_errors += 1;
            }
        }
        out.extend(delayed);
        self.counters.frames_sent += out.len() as u64;
        self.tick = Some(k);
        self.open = true;
        out
    }

    /// A frame received from the bus (not the board's own). Returns the commands to apply when
    /// it completes the current tick's command frames.
    pub fn on_frame(&mut self, frame: &CanFrame) -> Option<Applied> {
        if !frame
            .standard_id()
            .is_some_and(|id| self.command_ids.contains(&id))
        {
            let known = frame
                .standard_id()
                .and_then(|id| self.protocol.ids().lookup(id))
                .is_some();
            self.counters.unknown_id += u64::from(!known);
            return None;
        }
        self.rx.push(*frame);
        let complete = self
            .command_ids
            .iter()
            .all(|want| self.rx.iter().any(|f| f.standard_id() == Some(*want)));
        (self.open && complete).then(|| self.close())
    }

    /// Closes the current tick: the received command frames meet their fate, are decoded and
    /// applied.
    fn close(&mut self) -> Applied {
        let k = self.tick.unwrap_or(0);
        let t_ns = self.schedule.time_ns(k);
        let in_window = self.rx_window.contains(&k);
        let mut batch = std::mem::take(&mut self.rx);
        batch.sort_by_key(|f| f.standard_id());
        let mut new_wheel = None;
        let mut new_cmg = None;
        let mut new_thrusters = None;
        for late in std::mem::take(&mut self.rx_late) {
            self.late_frames += 1;
            let _ = self.decoder.decode(&late); // keeps the counters; its message is not used
        }
        for frame in batch {
            let copies = match if in_window {
                self.faults.draw()
            } else {
                Fault::None
            } {
                Fault::None => 1,
                Fault::Drop => {
                    self.counters.injected_rx_drop += 1;
                    0
                }
                Fault::Corrupt { .. } => {
                    // The board's CAN controller drops it (counted as a CRC error in `status`).
                    self.counters.injected_rx_corrupt += 1;
                    0
                }
                Fault::Delay => {
                    self.counters.injected_rx_delay += 1;
                    self.rx_late.push(frame);
                    0
                }
                Fault::Duplicate => {
                    self.counters.injected_rx_duplicate += 1;
                    2
                }
            };
            for _ in 0..copies {
                let Some(received) = self.decoder.decode(&frame).message else {
                    continue;
                };
                // Out of range (clipped by the decoder): ignored, as the protocol says.
                match received.message {
                    Message::WheelCommand(m) if received.clipped == 0 => {
                        new_wheel = Some(m.torque_nm)
                    }
                    Message::CmgCommand(m) if received.clipped == 0 => {
                        new_cmg = Some(m.gimbal_rate_rad_s)
                    }
                    Message::ThrusterCommand(m) if received.clipped == 0 => new_thrusters = Some(m),
                    _ => {}
                }
            }
        }
        let timed_out =
            |last: Option<u64>| last.is_none_or(|l| k.saturating_sub(l) >= self.timeout_ticks);
        let wheel_flags = match new_wheel {
            Some(torque) => {
                self.wheel = torque;
                self.last_wheel_tick = Some(k);
                SampleHeader::VALID
            }
            None => {
                if timed_out(self.last_wheel_tick) {
                    self.wheel = [0.0; 3];
                }
                SampleHeader::VALID | SampleHeader::STALE
            }
        };
        let cmg_flags = match new_cmg {
            Some(rate) => {
                self.cmg_rate = rate;
                self.last_cmg_tick = Some(k);
                SampleHeader::VALID
            }
            None => {
                if timed_out(self.last_cmg_tick) {
                    self.cmg_rate = [0.0; 4];
                }
                SampleHeader::VALID | SampleHeader::STALE
            }
        };
        self.open = false;
        let wheel = AppliedWheelCommand {
            header: self.wheel_seq.header(t_ns, wheel_flags),
            torque: self.wheel,
        };
        let cmg = AppliedCmgCommand {
            header: self.cmg_seq.header(t_ns, cmg_flags),
            gimbal_rate: self.cmg_rate,
        };
        let thrusters = self.thrusters.as_mut().map(|th| {
            // Range-checked again: a negative or longer-than-the-period on-time is refused and
            // every valve stays shut, as for a missing command.
            let valid = new_thrusters.filter(|m| {
                m.on_time_s
                    .iter()
                    .all(|t| (0.0..=th.period_s + 1e-9).contains(t))
            });
            th.latch_shut |= new_thrusters.is_some_and(|m| m.latch_shut);
            th.valves.set_latch_shut(th.latch_shut);
            let (on_time, flags) = match valid {
                Some(m) => (m.on_time_s, SampleHeader::VALID),
                None => (
                    [0.0; THRUSTER_COUNT],
                    SampleHeader::VALID | SampleHeader::STALE,
                ),
            };
            th.valves.command(
                t_ns as f64 * 1e-9,
                &ValveCommand { on_time_s: on_time },
                th.period_s,
            );
            th.applied = on_time;
            AppliedThrusterCommand {
                header: th.seq.header(t_ns, flags),
                on_time,
                latch_shut: u32::from(th.latch_shut),
                _pad0: 0,
            }
        });
        let applied = Applied {
            wheel,
            cmg,
            thrusters,
        };
        // The telemetry of the next tick reports the commands in effect.
        let (wheel_command, cmg_command) = applied.commands();
        self.wheels.on_command(&wheel_command);
        self.cmg.on_command(&cmg_command);
        applied
    }
}
