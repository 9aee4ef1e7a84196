//! A device gateway's logic, without I/O: frames in, samples out; commands in, frames out.
//!
//! [`Gateway::on_frame`] takes every frame its link delivers (after the link's own checks) and
//! returns the sample to publish, if any; [`Gateway::wheel_command`] / [`Gateway::cmg_command`] limit
//! a command and encode it into the frames to send. The process shell (`crate::run`) moves
//! frames and samples between this and the bus.
//!
//! # When samples are published
//!
//! - **Free-running** (hardware, paced runs): a sample is published as soon as its last frame
//!   arrives, if it is newer than the last one published.
//! - **Tick sync** (lockstep): the CAN board sends its heartbeat after the frames of every
//!   tick (the *tick sync*, see the crate documentation). At the sync of tick `T` the gateway
//!   publishes exactly one sample for `T` if the schedule has its device sampling at `T`: the
//!   complete sample if it arrived, otherwise the last good values flagged `STALE` without
//!   `VALID` (zeros before the first good sample), counted in `stale_samples`. So every tick is
//!   answered whatever frames were lost, and what is published depends only on which frames
//!   arrived before the sync — never on timing.
//!
//! # Counting
//!
//! Every frame the decoder classifies is counted ([`CanLinkStatus`]): used frames in
//! `frames_ok`; rejected ones (wrong length, unknown identifier, duplicate, late, and the
//! link's failed frame checks) in `frames_bad`; missed frames (rolling-counter jumps) in
//! `lost_frames`. A frame is *late* when it belongs to a sample whose tick was already closed by
//! a sync: the gateway knows the rolling counter of every closed sample (the counter it saw, or
//! the previous closed counter + 1 when none of the sample's frames arrived in time), and a
//! frame whose counter is not newer than that is late. A late frame still goes through the
//! decoder (so its counter does not read as a loss later), but a sample it completes is thrown
//! away.

use ipc_types::Device;
use ipc_types::{
    CanLinkStatus, CmgCommand, CmgTelemetry, GyroSample, InclinometerSample, MagnetometerSample,
    SampleHeader, ThrusterStatus, WheelCommand, WheelTelemetry, can_source,
};
use testbed_can::{
    CanFrame, CmgCommandMsg, Decoder, Device as CanDevice, DeviceSet, EncodeError, Encoder,
    FrameBatch, FrameClass, Message, MessageKind, NodeClock, NodeState, Protocol, Sample,
    ThrusterCommandMsg, WheelCommandMsg,
};
use testbed_flight::schedule::Schedule;

/// What the gateways know about each platform device ([`Device`]).
pub trait GatewayDevice: Copy {
    /// The gateway process's name.
    fn process_name(self) -> &'static str;
    /// The device's identifier block in the board's protocol.
    fn can_device(self) -> CanDevice;
    /// The message the device sends.
    fn telemetry(self) -> MessageKind;
    /// `header.source_id` of the gateway's bus frames and status ([`can_source`]).
    fn source_id(self) -> u32;
    /// Whether the device samples at tick `k`.
    fn due(self, schedule: &Schedule, k: u64) -> bool;
}

impl GatewayDevice for Device {
    /// The gateway process's name.
    fn process_name(self) -> &'static str {
        match self {
            Self::Gyro => "gyro-gateway",
            Self::Inclinometer => "inclinometer-gateway",
            Self::Magnetometer => "magnetometer-gateway",
            Self::Wheels => "wheel-gateway",
            Self::Cmg => "cmg-gateway",
        }
    }

    /// The device's identifier block in the board's protocol.
    fn can_device(self) -> CanDevice {
        match self {
            Self::Gyro => CanDevice::Gyro,
            Self::Inclinometer => CanDevice::Inclinometer,
            Self::Magnetometer => CanDevice::Magnetometer,
            Self::Wheels => CanDevice::Wheels,
            Self::Cmg => CanDevice::Cmg,
        }
    }

    /// The message the device sends.
    fn telemetry(self) -> MessageKind {
        match self {
            Self::Gyro => MessageKind::Gyro,
            Self::Inclinometer => MessageKind::Inclinometer,
            Self::Magnetometer => MessageKind::Magnetometer,
            Self::Wheels => MessageKind::WheelTelemetry,
            Self::Cmg => MessageKind::CmgTelemetry,
        }
    }

    /// `header.source_id` of the gateway's bus frames and status ([`can_source`]).
    fn source_id(self) -> u32 {
        match self {
            Self::Gyro => can_source::GYRO,
            Self::Inclinometer => can_source::INCLINOMETER,
            Self::Magnetometer => can_source::MAGNETOMETER,
            Self::Wheels => can_source::WHEELS,
            Self::Cmg => can_source::CMG,
        }
    }

    /// Whether the device samples at tick `k`.
    fn due(self, schedule: &Schedule, k: u64) -> bool {
        match self {
            Self::Inclinometer => schedule.tilt_due(k),
            Self::Magnetometer => schedule.field_due(k),
            Self::Gyro | Self::Wheels | Self::Cmg => true,
        }
    }
}

/// What a gateway serves: one of the platform's devices, or the six thruster valves. The
/// thrusters are not an [`ipc_types::Device`]: they are optional (runs with `[model.thrusters]`
/// only), so profiles neither list nor must serve them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Served {
    /// A sensor or the wheels or CMGs.
    Device(Device),
    /// The thruster valves (`thruster-gateway`).
    Thrusters,
}

impl Served {
    /// The name used in configurations (`[can.serial.<name>]`) and messages.
    pub const fn name(self) -> &'static str {
        match self {
            Served::Device(d) => d.name(),
            Served::Thrusters => "thrusters",
        }
    }
}

impl From<Device> for Served {
    fn from(device: Device) -> Self {
        Served::Device(device)
    }
}

impl GatewayDevice for Served {
    fn process_name(self) -> &'static str {
        match self {
            Served::Device(d) => d.process_name(),
            Served::Thrusters => "thruster-gateway",
        }
    }

    fn can_device(self) -> CanDevice {
        match self {
            Served::Device(d) => d.can_device(),
            Served::Thrusters => CanDevice::Thrusters,
        }
    }

    fn telemetry(self) -> MessageKind {
        match self {
            Served::Device(d) => d.telemetry(),
            Served::Thrusters => MessageKind::ThrusterStatus,
        }
    }

    fn source_id(self) -> u32 {
        match self {
            Served::Device(d) => d.source_id(),
            Served::Thrusters => can_source::THRUSTERS,
        }
    }

    fn due(self, schedule: &Schedule, k: u64) -> bool {
        match self {
            Served::Device(d) => d.due(schedule, k),
            // The board reports the valves after every period.
            Served::Thrusters => true,
        }
    }
}

/// A zero sample of the device (what a stale sample repeats before any good one).
fn zero_sample(served: Served) -> Sample {
    match served {
        Served::Device(Device::Gyro) => Sample::Gyro(GyroSample::default()),
        Served::Device(Device::Inclinometer) => Sample::Inclinometer(InclinometerSample::default()),
        Served::Device(Device::Magnetometer) => Sample::Magnetometer(MagnetometerSample::default()),
        Served::Device(Device::Wheels) => Sample::WheelTelemetry(WheelTelemetry::default()),
        Served::Device(Device::Cmg) => Sample::CmgTelemetry(CmgTelemetry::default()),
        Served::Thrusters => Sample::ThrusterStatus(ThrusterStatus::default()),
    }
}

/// The header of a sample.
pub fn sample_header(sample: &Sample) -> &SampleHeader {
    match sample {
        Sample::Gyro(s) => &s.header,
        Sample::Inclinometer(s) => &s.header,
        Sample::Magnetometer(s) => &s.header,
        Sample::WheelTelemetry(s) => &s.header,
        Sample::WheelCommand(s) => &s.header,
        Sample::CmgTelemetry(s) => &s.header,
        Sample::CmgCommand(s) => &s.header,
        Sample::ThrusterStatus(s) => &s.header,
        Sample::ThrusterCommand(s) => &s.header,
    }
}

fn sample_header_mut(sample: &mut Sample) -> &mut SampleHeader {
    match sample {
        Sample::Gyro(s) => &mut s.header,
        Sample::Inclinometer(s) => &mut s.header,
        Sample::Magnetometer(s) => &mut s.header,
        Sample::WheelTelemetry(s) => &mut s.header,
        Sample::WheelCommand(s) => &mut s.header,
        Sample::CmgTelemetry(s) => &mut s.header,
        Sample::CmgCommand(s) => &mut s.header,
        Sample::ThrusterStatus(s) => &mut s.header,
        Sample::ThrusterCommand(s) => &mut s.header,
    }
}

/// What one frame led to.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameOutcome {
    /// The frame was the board's tick sync for this run-clock time (tick-sync mode).
    pub tick: Option<u64>,
    /// The sample to publish, if any (a frame completes or closes at most one).
    pub sample: Option<Sample>,
}

/// The board's µs stamp on the run clock: extended to 64 bits, in ns, and snapped to the
/// schedule's tick when within 1 µs of one (the stamp's resolution).
pub fn run_time_ns(clock: &mut NodeClock, schedule: &Schedule, stamp_us: u32) -> Option<u64> {
    let us = u64::try_from(clock.extend(stamp_us)).ok()?;
    let t_ns = us.checked_mul(1000)?;
    let period = schedule.period_ns.max(1);
    let k = (t_ns + period / 2) / period;
    let tick = k.checked_mul(period)?;
    Some(if tick.abs_diff(t_ns) < 1000 {
        tick
    } else {
        t_ns
    })
}

/// The board's µs stamp for run-clock time `t_ns` (wraps every 2³² µs, as the board's clock).
pub fn board_stamp_us(t_ns: u64) -> u32 {
    (t_ns / 1000) as u32
}

/// Limits a command: refused (all zero) if not valid or any channel is not finite, otherwise
/// each channel clamped to ±`limit`. Returns the values and whether they were refused or
/// clamped.
pub fn limit_command<const N: usize>(
    values: &[f64; N],
    limit: f64,
    valid: bool,
) -> ([f64; N], bool, bool) {
    if !valid || values.iter().any(|v| !v.is_finite()) {
        return ([0.0; N], true, false);
    }
    let clamped = values.map(|v| v.clamp(-limit, limit));
    (clamped, false, clamped != *values)
}

/// One gateway's state; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Gateway {
    device: Served,
    protocol: Protocol,
    decoder: Decoder,
    encoder: Encoder,
    schedule: Schedule,
    tick_sync: bool,
    clock: NodeClock,
    /// A complete sample waiting for its tick's sync.
    completed: Option<(u64, Sample)>,
    last_good: Option<Sample>,
    published_until: Option<u64>,
    sequence: u64,
    /// Counter of the telemetry sample in progress, from its on-time frames.
    current_counter: Option<u8>,
    /// Counter of the last sample closed by a sync.
    closed_counter: Option<u8>,
    late_frames: u64,
    late_messages: u64,
    foreign_messages: u64,
    stale_samples: u64,
    link_check_errors: u64,
    frames_sent: u64,
    commands_clamped: u64,
    commands_refused: u64,
    transport_errors: u64,
    node_state: Option<NodeState>,
    node_heartbeats: u64,
}

impl Gateway {
    /// A gateway for `device` speaking `protocol`. `tick_sync`: publish at the board's tick sync
    /// (lockstep), else as samples complete.
    pub fn new(
        device: impl Into<Served>,
        protocol: Protocol,
        schedule: Schedule,
        tick_sync: bool,
    ) -> Self {
        let device = device.into();
        Self {
            device,
            protocol,
            decoder: Decoder::with_devices(
                protocol,
                DeviceSet::of(&[device.can_device(), CanDevice::Node]),
            ),
            encoder: Encoder::new(protocol),
            schedule,
            tick_sync,
            clock: NodeClock::new(),
            completed: None,
            last_good: None,
            published_until: None,
            sequence: 0,
            current_counter: None,
            closed_counter: None,
            late_frames: 0,
            late_messages: 0,
            foreign_messages: 0,
            stale_samples: 0,
            link_check_errors: 0,
            frames_sent: 0,
            commands_clamped: 0,
            commands_refused: 0,
            transport_errors: 0,
            node_state: None,
            node_heartbeats: 0,
        }
    }

    /// What the gateway serves.
    pub fn device(&self) -> Served {
        self.device
    }

    /// The board's state from its latest heartbeat.
    pub fn node_state(&self) -> Option<NodeState> {
        self.node_state
    }

    /// Board heartbeats received so far (the board is alive while this grows).
    pub fn node_heartbeats(&self) -> u64 {
        self.node_heartbeats
    }

    /// Samples completed after their tick was published (dropped), and complete messages of
    /// this device that it does not take (e.g. another sender's command).
    pub fn dropped_messages(&self) -> (u64, u64) {
        (self.late_messages, self.foreign_messages)
    }

    /// Frames the link itself rejected so far (software bus: failed frame checks; serial:
    /// bad packets; SocketCAN: error frames) — a total, set by the process after each read.
    pub fn set_link_check_errors(&mut self, total: u64) {
        self.link_check_errors = total;
    }

    /// Counts frames the process sent.
    pub fn count_sent(&mut self, frames: u64) {
        self.frames_sent += frames;
    }

    /// Counts a failed send or receive.
    pub fn count_transport_error(&mut self) {
        self.transport_errors += 1;
    }

    /// The counters (header left default: the publisher stamps it).
    pub fn status(&self) -> CanLinkStatus {
        let s = self.decoder.stats();
        let used = s.ok + s.counter_jump + s.incomplete + s.out_of_range;
        CanLinkStatus {
            frames_ok: used.saturating_sub(self.late_frames),
            frames_bad: self.link_check_errors
                + s.wrong_dlc
                + s.unknown_id
                + s.duplicate
                + self.late_frames,
            crc_errors: self.link_check_errors,
            wrong_dlc: s.wrong_dlc,
            unknown_id: s.unknown_id,
            duplicates: s.duplicate,
            lost_frames: s.lost_frames,
            incomplete_samples: s.incomplete_samples,
            late_frames: self.late_frames,
            out_of_range: s.out_of_range_frames,
            stale_samples: self.stale_samples,
            frames_sent: self.frames_sent,
            commands_clamped: self.commands_clamped,
            commands_refused: self.commands_refused,
            transport_errors: self.transport_errors,
            ..CanLinkStatus::default()
        }
    }

    /// Takes one received frame; returns what to publish.
    pub fn on_frame(&mut self, frame: &CanFrame) -> FrameOutcome {
        let decoded = self.decoder.decode(frame);
        let kind = frame
            .standard_id()
            .and_then(|id| self.protocol.ids().lookup(id))
            .map(|(kind, _)| kind);
        let used = matches!(
            decoded.class,
            FrameClass::Ok
                | FrameClass::CounterJump { .. }
                | FrameClass::IncompleteSample
                | FrameClass::OutOfRange
        );
        let mut late = false;
        if self.tick_sync && used && kind == Some(self.device.telemetry()) {
            let counter = frame.data().first().copied().unwrap_or(0);
            if self
                .closed_counter
                .is_some_and(|closed| closed.wrapping_sub(counter) < 128)
            {
                late = true;
                self.late_frames += 1;
            } else {
                self.current_counter = Some(counter);
            }
        }
        let Some(received) = decoded.message else {
            return FrameOutcome::default();
        };
        match received.message {
            Message::NodeHeartbeat(hb) => {
                if hb.state == NodeState::Booting
                    && self.node_state.is_some_and(|s| s != NodeState::Booting)
                {
                    // The board restarted: its counters and clock start again.
                    self.decoder.reset();
                    self.clock.reset();
                    self.current_counter = None;
                    self.closed_counter = None;
                }
                self.node_state = Some(hb.state);
                self.node_heartbeats += 1;
                match run_time_ns(&mut self.clock, &self.schedule, hb.node_time_us) {
                    Some(t_ns) if self.tick_sync => self.on_sync(t_ns),
                    _ => FrameOutcome::default(),
                }
            }
            message if message.kind() == self.device.telemetry() => {
                let Some(t_ns) = message
                    .node_time_us()
                    .and_then(|us| run_time_ns(&mut self.clock, &self.schedule, us))
                else {
                    return FrameOutcome::default();
                };
                if late || self.published_until.is_some_and(|p| t_ns <= p) {
                    self.late_messages += 1;
                    return FrameOutcome::default();
                }
                let Some(sample) =
                    message.to_sample(SampleHeader::new(t_ns, 0, 0), received.clipped)
                else {
                    return FrameOutcome::default();
                };
                if self.tick_sync {
                    self.completed = Some((t_ns, sample));
                    FrameOutcome::default()
                } else {
                    FrameOutcome {
                        tick: None,
                        sample: Some(self.publish(t_ns, sample)),
                    }
                }
            }
            _ => {
                self.foreign_messages += 1;
                FrameOutcome::default()
            }
        }
    }

    /// Stamps `sample` for publication at `t_ns` with the next sequence number.
    fn publish(&mut self, t_ns: u64, mut sample: Sample) -> Sample {
        let header = sample_header_mut(&mut sample);
        header.time_ns = t_ns;
        header.sequence = self.sequence;
        self.sequence += 1;
        if header.is_valid() {
            self.last_good = Some(sample);
        }
        self.published_until = Some(t_ns);
        sample
    }

    /// The board's tick sync for `t_ns`: close the tick.
    fn on_sync(&mut self, t_ns: u64) -> FrameOutcome {
        let mut out = FrameOutcome {
            tick: Some(t_ns),
            sample: None,
        };
        if self.published_until.is_some_and(|p| t_ns <= p) {
            return out;
        }
        let due = self
            .schedule
            .tick_at(t_ns)
            .is_some_and(|k| self.device.due(&self.schedule, k));
        match self.completed.take() {
            Some((t, sample)) if t == t_ns => {
                out.sample = Some(self.publish(t_ns, sample));
                self.closed_counter = self
                    .current_counter
                    .take()
                    .or(self.closed_counter.map(|c| c.wrapping_add(1)));
            }
            other => {
                if other.is_some() {
                    // A sample of an earlier time that was never due: not published.
                    self.late_messages += 1;
                }
                if due {
                    let mut stale = self.last_good.unwrap_or_else(|| zero_sample(self.device));
                    let header = sample_header_mut(&mut stale);
                    header.flags =
                        (header.flags & SampleHeader::SATURATED_ANY) | SampleHeader::STALE;
                    self.stale_samples += 1;
                    out.sample = Some(self.publish(t_ns, stale));
                    self.closed_counter = self
                        .current_counter
                        .take()
                        .or(self.closed_counter.map(|c| c.wrapping_add(1)));
                }
            }
        }
        out
    }

    /// Limits and encodes a wheel torque command (wheel gateway).
    pub fn wheel_command(&mut self, command: &WheelCommand) -> Result<FrameBatch, EncodeError> {
        let limit = self.protocol.limits().wheel_torque_nm;
        let (torque_nm, refused, clamped) =
            limit_command(&command.torque, limit, command.header.is_valid());
        self.commands_refused += u64::from(refused);
        self.commands_clamped += u64::from(clamped);
        self.encoder
            .encode(&Message::WheelCommand(WheelCommandMsg { torque_nm }))
    }

    /// Limits and encodes a gimbal rate command (CMG gateway).
    pub fn cmg_command(&mut self, command: &CmgCommand) -> Result<FrameBatch, EncodeError> {
        let limit = self.protocol.limits().gimbal_rate_rad_s;
        let (gimbal_rate_rad_s, refused, clamped) =
            limit_command(&command.gimbal_rate, limit, command.header.is_valid());
        self.commands_refused += u64::from(refused);
        self.commands_clamped += u64::from(clamped);
        self.encoder
            .encode(&Message::CmgCommand(CmgCommandMsg { gimbal_rate_rad_s }))
    }

    /// Encodes valve on-times already checked by the thruster gateway's
    /// [`ThrusterGuard`](crate::thrusters::ThrusterGuard) (thruster gateway); `latch_shut` asks
    /// the board to shut the latch valve. An encoding error (an on-time beyond the wire field)
    /// counts as a refused command.
    pub fn thruster_command(
        &mut self,
        on_time_s: [f64; 6],
        latch_shut: bool,
    ) -> Result<FrameBatch, EncodeError> {
        let result = self
            .encoder
            .encode(&Message::ThrusterCommand(ThrusterCommandMsg {
                on_time_s,
                latch_shut,
            }));
        self.commands_refused += u64::from(result.is_err());
        result
    }

    /// Counts a command refused before encoding (by the thruster gateway's checks).
    pub fn count_refused_command(&mut self) {
        self.commands_refused += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_can::{DeviceStatus, GyroMsg, NodeHeartbeatMsg};

    fn schedule() -> Schedule {
        Schedule {
            period_ns: 100_000_000,
            tilt_every: 4,
            field_every: 4,
        }
    }

    fn gyro(encoder: &mut Encoder, k: u64, rate: f64) -> Vec<CanFrame> {
        let t_us = board_stamp_us(k * 100_000_000);
        let m = Message::Gyro(GyroMsg {
            node_time_us: t_us,
            status: DeviceStatus::default(),
            rate_rad_s: [rate; 3],
        });
        encoder.encode(&m).unwrap().iter().copied().collect()
    }

    fn sync(encoder: &mut Encoder, k: u64) -> CanFrame {
        let m = Message::NodeHeartbeat(NodeHeartbeatMsg {
            node_time_us: board_stamp_us(k * 100_000_000),
            state: NodeState::Running,
            links: DeviceSet::ALL,
            serial_errors: 0,
        });
        encoder.encode(&m).unwrap().as_slice()[0]
    }

    fn published(g: &mut Gateway, frames: &[CanFrame]) -> Vec<Sample> {
        frames.iter().filter_map(|f| g.on_frame(f).sample).collect()
    }

    #[test]
    fn tick_sync_publishes_complete_stale_and_drops_late_frames() {
        let p = Protocol::default();
        let mut board = Encoder::new(p);
        let mut g = Gateway::new(Device::Gyro, p, schedule(), true);
        // Tick 0 complete.
        let mut frames = gyro(&mut board, 0, 0.01);
        frames.push(sync(&mut board, 0));
        let out = published(&mut g, &frames);
        let [Sample::Gyro(s)] = out.as_slice() else {
            panic!("{out:?}")
        };
        assert_eq!(
            (s.header.time_ns, s.header.sequence, s.header.is_valid()),
            (0, 0, true)
        );
        let good = s.rate;
        assert!((good[0] - 0.01).abs() <= testbed_can::Quantity::GyroRate.lsb_si());
        // Tick 1: frame B delayed past the sync → stale, then the late frame is dropped.
        let t1 = gyro(&mut board, 1, 0.02);
        let out = published(&mut g, &[t1[0], sync(&mut board, 1), t1[1]]);
        let [Sample::Gyro(s)] = out.as_slice() else {
            panic!("{out:?}")
        };
        assert_eq!(s.header.time_ns, 100_000_000);
        assert!(!s.header.is_valid() && s.header.has(SampleHeader::STALE));
        assert_eq!(s.rate, good, "stale repeats the last good values");
        // Tick 2: both frames lost (no frame at all) → stale again, counter predicted.
        let _lost = gyro(&mut board, 2, 0.03);
        let out = published(&mut g, &[sync(&mut board, 2)]);
        assert!(matches!(out.as_slice(), [Sample::Gyro(s)] if s.header.has(SampleHeader::STALE)));
        // Tick 3 complete, and a duplicate.
        let t3 = gyro(&mut board, 3, 0.04);
        let out = published(&mut g, &[t3[0], t3[0], t3[1], sync(&mut board, 3)]);
        assert!(
            matches!(out.as_slice(), [Sample::Gyro(s)] if s.header.is_valid() && (s.rate[2] - 0.04).abs() < 1e-6)
        );
        let st = g.status();
        assert_eq!(
            (
                st.late_frames,
                st.stale_samples,
                st.duplicates,
                st.lost_frames
            ),
            (1, 2, 1, 2)
        );
        assert_eq!(st.frames_bad, 2);
        // 4 sync frames + 2 + 1 + 2 gyro frames used, the late one not.
        assert_eq!(st.frames_ok, 4 + 2 + 1 + 2);
    }

    #[test]
    fn free_running_publishes_on_completion_in_time_order() {
        let p = Protocol::default();
        let mut board = Encoder::new(p);
        let mut g = Gateway::new(Device::Gyro, p, schedule(), false);
        let out = published(&mut g, &gyro(&mut board, 5, 0.1));
        assert!(matches!(out.as_slice(), [Sample::Gyro(s)] if s.header.time_ns == 500_000_000));
        assert!(published(&mut g, &[sync(&mut board, 5)]).is_empty());
    }

    #[test]
    fn commands_are_clamped_or_refused_before_encoding() {
        let p = Protocol::default();
        let mut g = Gateway::new(Device::Wheels, p, schedule(), true);
        let limit = p.limits().wheel_torque_nm;
        let mut decoder = Decoder::new(p);
        let mut decode = |batch: FrameBatch| {
            let mut out = None;
            for f in &batch {
                out = decoder.decode(f).message.or(out);
            }
            match out.map(|r| r.message) {
                Some(Message::WheelCommand(m)) => m.torque_nm,
                other => panic!("{other:?}"),
            }
        };
        let ok = WheelCommand::new(
            SampleHeader::new(0, 0, SampleHeader::VALID),
            [0.01, -0.02, 0.0],
        );
        assert_eq!(decode(g.wheel_command(&ok).unwrap()), [0.01, -0.02, 0.0]);
        let big = WheelCommand::new(
            SampleHeader::new(1, 1, SampleHeader::VALID),
            [1.0, -1.0, 0.0],
        );
        assert_eq!(decode(g.wheel_command(&big).unwrap()), [limit, -limit, 0.0]);
        let nan = WheelCommand::new(
            SampleHeader::new(2, 2, SampleHeader::VALID),
            [f64::NAN, 0.01, 0.0],
        );
        assert_eq!(decode(g.wheel_command(&nan).unwrap()), [0.0; 3]);
        let invalid = WheelCommand::new(SampleHeader::new(3, 3, 0), [0.01; 3]);
        assert_eq!(decode(g.wheel_command(&invalid).unwrap()), [0.0; 3]);
        let st = g.status();
        assert_eq!((st.commands_clamped, st.commands_refused), (1, 2));
    }

    #[test]
    fn run_time_snaps_to_the_tick_and_extends_the_node_clock() {
        let s = Schedule {
            period_ns: 33_333_333,
            tilt_every: 1,
            field_every: 1,
        };
        let mut clock = NodeClock::new();
        assert_eq!(
            run_time_ns(&mut clock, &s, board_stamp_us(3 * 33_333_333)),
            Some(99_999_999)
        );
        assert_eq!(
            run_time_ns(&mut clock, &s, 100_000_500),
            Some(100_000_500_000)
        );
        let mut clock = NodeClock::new();
        let s = schedule();
        let before_wrap = u32::MAX - 99_999;
        assert_eq!(
            run_time_ns(&mut clock, &s, before_wrap),
            Some(u64::from(before_wrap) * 1000)
        );
        // 100 ms later the board's 32-bit µs clock has wrapped; the run clock goes on.
        assert_eq!(
            run_time_ns(&mut clock, &s, 0),
            Some((u64::from(u32::MAX) + 1) * 1000)
        );
    }
}
