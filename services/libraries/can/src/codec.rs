//! Encoding and decoding of the protocol's frames: no I/O, no allocation, no panics.

use crate::frame::CanFrame;
use crate::message::{Message, NodeHeartbeatMsg, NodeState, Record};
use crate::protocol::{DeviceSet, MAX_CHANNELS, MAX_PARTS, MessageKind, Protocol, Quantity};
use crate::wire::{Channel, FieldKind};

/// Why a message could not be encoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// A value is NaN or infinite.
    #[error("{kind:?} channel {channel} ({quantity}): value {value} is not finite")]
    NonFinite {
        kind: MessageKind,
        channel: usize,
        quantity: &'static str,
        value: f64,
    },
    /// A value is beyond the device range or command limit.
    #[error(
        "{kind:?} channel {channel} ({quantity}): value {value} beyond the limit ±{limit} (SI units)"
    )]
    OutOfRange {
        kind: MessageKind,
        channel: usize,
        quantity: &'static str,
        value: f64,
        limit: f64,
    },
    /// The heartbeat's node state is not one of the defined values.
    #[error("node state {0} is not a defined state (0 to 3)")]
    BadState(u8),
}

/// The frames of one encoded message (1 to [`MAX_PARTS`]), in part order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameBatch {
    frames: [CanFrame; MAX_PARTS],
    len: usize,
}

impl FrameBatch {
    /// The frames.
    pub fn as_slice(&self) -> &[CanFrame] {
        &self.frames[..self.len.min(MAX_PARTS)]
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.as_slice().len()
    }

    /// Whether there are no frames (never, for a batch from the encoder).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Iterate over the frames.
    pub fn iter(&self) -> std::slice::Iter<'_, CanFrame> {
        self.as_slice().iter()
    }
}

impl<'a> IntoIterator for &'a FrameBatch {
    type Item = &'a CanFrame;
    type IntoIter = std::slice::Iter<'a, CanFrame>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// Quantise `value` (SI) for `quantity`: range-checked round-to-nearest, or wrapped for angles.
fn quantise(
    p: &Protocol,
    kind: MessageKind,
    channel: usize,
    q: Quantity,
    value: f64,
) -> Result<i32, EncodeError> {
    if !value.is_finite() {
        return Err(EncodeError::NonFinite {
            kind,
            channel,
            quantity: q.name(),
            value,
        });
    }
    if q.wraps() {
        // Fraction of a turn in [0, 1], then 2^24 counts per turn, two's complement mod 2^24.
        let turns = value / std::f64::consts::TAU;
        let frac = turns - turns.floor();
        let counts = (frac * f64::from(1u32 << q.bits())).round() as i64;
        return Ok(sign_extend((counts as u32) & mask(q.bits()), q.bits()));
    }
    let limit = p.limits().range(q).unwrap_or(0.0);
    if value.abs() > limit {
        return Err(EncodeError::OutOfRange {
            kind,
            channel,
            quantity: q.name(),
            value,
            limit,
        });
    }
    let raw_limit = p.raw_limit(q);
    Ok(((value / q.lsb_si()).round() as i32).clamp(-raw_limit, raw_limit))
}

/// The SI value of `raw`, clipped to the range; the flag says whether it was clipped.
fn dequantise(p: &Protocol, q: Quantity, raw: i32) -> (f64, bool) {
    if q.wraps() {
        return (f64::from(raw) * q.lsb_si(), false);
    }
    let raw_limit = p.raw_limit(q);
    if raw.unsigned_abs() > raw_limit.unsigned_abs() {
        let range = p.limits().range(q).unwrap_or(0.0);
        (range.copysign(f64::from(raw)), true)
    } else {
        (f64::from(raw) * q.lsb_si(), false)
    }
}

const fn mask(bits: u32) -> u32 {
    if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    }
}

const fn sign_extend(v: u32, bits: u32) -> i32 {
    let shift = 32 - bits;
    ((v << shift) as i32) >> shift
}

fn read_uint(data: &[u8; 8], offset: usize, width: usize) -> u32 {
    let mut v = 0u32;
    for i in 0..width.min(4) {
        v |= u32::from(*data.get(offset + i).unwrap_or(&0)) << (8 * i);
    }
    v
}

fn write_uint(data: &mut [u8; 8], offset: usize, width: usize, v: u32) {
    for i in 0..width.min(4) {
        if let Some(b) = data.get_mut(offset + i) {
            *b = (v >> (8 * i)) as u8;
        }
    }
}

fn read_raw(data: &[u8; 8], offset: usize, q: Quantity) -> i32 {
    sign_extend(read_uint(data, offset, q.bytes()), q.bits())
}

fn channel(channels: &[Channel], ch: u8) -> Option<Channel> {
    channels.get(usize::from(ch)).copied()
}

/// Encodes messages into frames, keeping one rolling counter per message.
#[derive(Debug, Clone)]
pub struct Encoder {
    protocol: Protocol,
    counters: [u8; MessageKind::ALL.len()],
}

impl Encoder {
    /// An encoder whose counters all start at 0.
    pub fn new(protocol: Protocol) -> Self {
        Self {
            protocol,
            counters: [0; MessageKind::ALL.len()],
        }
    }

    /// The protocol.
    pub fn protocol(&self) -> &Protocol {
        &self.protocol
    }

    /// The counter the next `kind` message will carry.
    pub fn next_counter(&self, kind: MessageKind) -> u8 {
        self.counters[kind.index()]
    }

    /// Encode `message` with its message's counter, then advance the counter (only on success).
    pub fn encode(&mut self, message: &Message) -> Result<FrameBatch, EncodeError> {
        let i = message.kind().index();
        let batch = self.encode_with_counter(message, self.counters[i])?;
        self.counters[i] = self.counters[i].wrapping_add(1);
        Ok(batch)
    }

    /// Encode `message` with rolling counter `counter`, every frame of it sharing the counter.
    /// Refuses non-finite values and values beyond the [`crate::Limits`] (gimbal angles wrap).
    pub fn encode_with_counter(
        &self,
        message: &Message,
        counter: u8,
    ) -> Result<FrameBatch, EncodeError> {
        let kind = message.kind();
        let layout = kind.layout();
        let record = message.to_record();
        if let Message::NodeHeartbeat(NodeHeartbeatMsg {
            state: NodeState::Unknown(v),
            ..
        }) = message
        {
            return Err(EncodeError::BadState(*v));
        }
        let mut raw = [0i32; MAX_CHANNELS];
        for (i, ch) in layout.channels.iter().enumerate() {
            raw[i] = quantise(&self.protocol, kind, i, ch.quantity, record.values[i])?;
        }
        let mut batch = FrameBatch {
            frames: [CanFrame::default(); MAX_PARTS],
            len: 0,
        };
        for (part, pl) in layout.parts.iter().enumerate() {
            let mut data = [0u8; 8];
            data[0] = counter;
            for field in pl.fields {
                let offset = usize::from(field.offset);
                let width = field.kind.width(layout.channels);
                let v = match field.kind {
                    FieldKind::Status => u32::from(record.status),
                    FieldKind::Time => record.time_us,
                    FieldKind::State => u32::from(record.state),
                    FieldKind::Links => u32::from(record.links),
                    FieldKind::Errors => u32::from(record.errors),
                    FieldKind::Flags => u32::from(record.flags),
                    FieldKind::Valves => u32::from(record.valves),
                    FieldKind::Value(ch) => raw.get(usize::from(ch)).copied().unwrap_or(0) as u32,
                };
                write_uint(&mut data, offset, width, v);
            }
            let id = self.protocol.ids().id(kind, part).unwrap_or(0);
            let len = usize::from(pl.dlc).min(8);
            // The identifier map and layouts are validated, so this cannot fail; keep the
            // default frame rather than panic if it ever did.
            if let (Ok(frame), Some(slot)) = (
                CanFrame::standard(id, &data[..len]),
                batch.frames.get_mut(part),
            ) {
                *slot = frame;
            }
            batch.len = part + 1;
        }
        Ok(batch)
    }
}

/// What a frame was, as decided by the [`Decoder`]. Every frame gets exactly one class; when
/// several apply, the first in this order wins: `UnknownId`, `Ignored`, `WrongDlc`,
/// `Duplicate`, `CounterJump`, `IncompleteSample`, `OutOfRange`, `Ok`. The events behind the
/// later classes are counted separately in [`DecoderStats`] whatever the class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameClass {
    /// A frame of the map, in sequence, values in range. Used.
    Ok,
    /// Not a frame of the map: identifier outside it, extended identifier or remote frame. Dropped.
    UnknownId,
    /// A frame of the map for a device this decoder was told to ignore. Dropped.
    Ignored,
    /// A frame of the map with the wrong data length. Dropped.
    WrongDlc {
        /// The length the map defines.
        expected: u8,
        /// The length received.
        got: u8,
    },
    /// Same counter as the previous frame with this identifier: a repeat. Dropped.
    Duplicate,
    /// The counter skipped values: `lost` frames of this identifier went missing before it
    /// (a node reboot or reordering also looks like this). Used.
    CounterJump {
        /// Frames of this identifier missed, 1 to 254.
        lost: u8,
    },
    /// Used, but its arrival abandoned an incomplete earlier sample of the same message
    /// (a frame of it never came).
    IncompleteSample,
    /// A value in the frame is beyond the device range (or an undefined heartbeat state).
    /// Used; the decoded value is clipped and its channel flagged.
    OutOfRange,
}

/// Counts of every frame class and decoding event.
///
/// The class counts add up to `frames`: every frame is counted in exactly one class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DecoderStats {
    /// Frames given to the decoder.
    pub frames: u64,
    /// Frames classed [`FrameClass::Ok`].
    pub ok: u64,
    /// Frames classed [`FrameClass::UnknownId`].
    pub unknown_id: u64,
    /// Frames classed [`FrameClass::Ignored`].
    pub ignored: u64,
    /// Frames classed [`FrameClass::WrongDlc`].
    pub wrong_dlc: u64,
    /// Frames classed [`FrameClass::Duplicate`].
    pub duplicate: u64,
    /// Frames classed [`FrameClass::CounterJump`].
    pub counter_jump: u64,
    /// Frames classed [`FrameClass::IncompleteSample`].
    pub incomplete: u64,
    /// Frames classed [`FrameClass::OutOfRange`].
    pub out_of_range: u64,
    /// Event: frames missed, the sum of every counter jump's `lost`.
    pub lost_frames: u64,
    /// Event: multi-frame samples abandoned incomplete (by a newer sample or [`Decoder::flush`]).
    pub incomplete_samples: u64,
    /// Event: accepted frames holding at least one out-of-range value.
    pub out_of_range_frames: u64,
    /// Event: values clipped to their range in decoded messages.
    pub clipped_values: u64,
    /// Event: complete messages decoded.
    pub messages: u64,
}

impl DecoderStats {
    /// Sum of the class counts (equals `frames`).
    pub fn classified(&self) -> u64 {
        self.ok
            + self.unknown_id
            + self.ignored
            + self.wrong_dlc
            + self.duplicate
            + self.counter_jump
            + self.incomplete
            + self.out_of_range
    }

    fn count(&mut self, class: FrameClass) {
        match class {
            FrameClass::Ok => self.ok += 1,
            FrameClass::UnknownId => self.unknown_id += 1,
            FrameClass::Ignored => self.ignored += 1,
            FrameClass::WrongDlc { .. } => self.wrong_dlc += 1,
            FrameClass::Duplicate => self.duplicate += 1,
            FrameClass::CounterJump { .. } => self.counter_jump += 1,
            FrameClass::IncompleteSample => self.incomplete += 1,
            FrameClass::OutOfRange => self.out_of_range += 1,
        }
    }
}

/// A complete decoded message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Received {
    /// The rolling counter its frames shared.
    pub counter: u8,
    /// The message, values in SI units (clipped to range where flagged in `clipped`).
    pub message: Message,
    /// Channels (bit per axis / wheel / gimbal, as the status saturation bits) that the decoder
    /// clipped to their range.
    pub clipped: u8,
}

/// The decoder's answer for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decoded {
    /// The frame's class.
    pub class: FrameClass,
    /// The message this frame completed, if any.
    pub message: Option<Received>,
    /// The message whose incomplete sample this frame abandoned, if any.
    pub abandoned: Option<MessageKind>,
}

const NO_SLOT: u8 = 0xFF;
const NO_COUNTER: u16 = 0x100;
/// Frames of all messages: one counter slot each.
const SLOTS: usize = 23;

#[derive(Debug, Clone, Copy, Default)]
struct Pending {
    counter: u8,
    /// Bit per part received; 0 = nothing pending.
    mask: u8,
    data: [[u8; 8]; MAX_PARTS],
}

/// Classifies and reassembles frames into messages, keeping per-identifier counter state.
///
/// Never panics, never allocates. One decoder per bus (or per gateway with
/// [`Decoder::with_devices`]).
#[derive(Debug, Clone)]
pub struct Decoder {
    protocol: Protocol,
    devices: DeviceSet,
    /// Per 11-bit identifier: `kind << 3 | part`, or `NO_SLOT`.
    lookup: [u8; 0x800],
    /// Index of part 0 of each message in `last_counter`.
    slot_base: [u8; MessageKind::ALL.len()],
    /// Last counter per (message, part), `NO_COUNTER` before the first frame.
    last_counter: [u16; SLOTS],
    pending: [Pending; MessageKind::ALL.len()],
    stats: DecoderStats,
}

impl Decoder {
    /// A decoder for every device of the map.
    pub fn new(protocol: Protocol) -> Self {
        Self::with_devices(protocol, DeviceSet::ALL)
    }

    /// A decoder for the frames of `devices`; frames of other devices are classed
    /// [`FrameClass::Ignored`].
    pub fn with_devices(protocol: Protocol, devices: DeviceSet) -> Self {
        let mut lookup = [NO_SLOT; 0x800];
        let mut slot_base = [0u8; MessageKind::ALL.len()];
        let mut next = 0u8;
        for kind in MessageKind::ALL {
            slot_base[kind.index()] = next;
            next = next.saturating_add(kind.parts() as u8);
            for part in 0..kind.parts() {
                let id = protocol.ids().id(kind, part).map(usize::from);
                if let Some(e) = id.and_then(|id| lookup.get_mut(id)) {
                    *e = ((kind.index() as u8) << 3) | part as u8;
                }
            }
        }
        Self {
            protocol,
            devices,
            lookup,
            slot_base,
            last_counter: [NO_COUNTER; SLOTS],
            pending: [Pending::default(); MessageKind::ALL.len()],
            stats: DecoderStats::default(),
        }
    }

    /// The protocol.
    pub fn protocol(&self) -> &Protocol {
        &self.protocol
    }

    /// The counts so far.
    pub fn stats(&self) -> &DecoderStats {
        &self.stats
    }

    /// Forget counters and pending samples (after a node reboot); the counts are kept.
    pub fn reset(&mut self) {
        self.last_counter = [NO_COUNTER; SLOTS];
        self.pending = [Pending::default(); MessageKind::ALL.len()];
    }

    /// Abandon every pending incomplete sample (e.g. when a sample's frames stop arriving);
    /// returns how many were abandoned (also counted in `incomplete_samples`).
    pub fn flush(&mut self) -> usize {
        let mut n = 0;
        for p in &mut self.pending {
            if p.mask != 0 {
                p.mask = 0;
                n += 1;
            }
        }
        self.stats.incomplete_samples += n as u64;
        n
    }

    /// Classify `frame`, and decode the message it completes, if any.
    pub fn decode(&mut self, frame: &CanFrame) -> Decoded {
        let decoded = self.classify(frame);
        self.stats.frames += 1;
        self.stats.count(decoded.class);
        decoded
    }

    fn classify(&mut self, frame: &CanFrame) -> Decoded {
        let none = |class| Decoded {
            class,
            message: None,
            abandoned: None,
        };
        if frame.is_remote() {
            return none(FrameClass::UnknownId);
        }
        let Some(id) = frame.standard_id() else {
            return none(FrameClass::UnknownId);
        };
        let entry = self.lookup.get(usize::from(id)).copied().unwrap_or(NO_SLOT);
        if entry == NO_SLOT {
            return none(FrameClass::UnknownId);
        }
        let Some(&kind) = MessageKind::ALL.get(usize::from(entry >> 3)) else {
            return none(FrameClass::UnknownId);
        };
        let part = usize::from(entry & 7);
        let layout = kind.layout();
        if !self.devices.contains(layout.device) {
            return none(FrameClass::Ignored);
        }
        let Some(pl) = layout.parts.get(part) else {
            return none(FrameClass::UnknownId);
        };
        if frame.dlc() != pl.dlc {
            return none(FrameClass::WrongDlc {
                expected: pl.dlc,
                got: frame.dlc(),
            });
        }
        let data = frame.data_padded();
        let counter = data[0];

        // Rolling counter of this identifier.
        let slot = usize::from(self.slot_base[kind.index()]) + part;
        let mut lost = 0u8;
        if let Some(last) = self.last_counter.get_mut(slot) {
            if *last != NO_COUNTER {
                let diff = counter.wrapping_sub(*last as u8);
                if diff == 0 {
                    return none(FrameClass::Duplicate);
                }
                lost = diff - 1;
            }
            *last = u16::from(counter);
        }
        if lost > 0 {
            self.stats.lost_frames += u64::from(lost);
        }

        // Range check of the values in this frame.
        let mut out_of_range = false;
        for field in pl.fields {
            match field.kind {
                FieldKind::Value(ch) => {
                    if let Some(c) = channel(layout.channels, ch).filter(|c| !c.quantity.wraps()) {
                        let raw = read_raw(&data, usize::from(field.offset), c.quantity);
                        out_of_range |=
                            raw.unsigned_abs() > self.protocol.raw_limit(c.quantity).unsigned_abs();
                    }
                }
                FieldKind::State => {
                    let state = data.get(usize::from(field.offset)).copied().unwrap_or(0);
                    out_of_range |= matches!(NodeState::from_wire(state), NodeState::Unknown(_));
                }
                _ => {}
            }
        }
        if out_of_range {
            self.stats.out_of_range_frames += 1;
        }

        // Reassembly: all frames of a sample share the counter.
        let full = ((1u16 << layout.parts.len()) - 1) as u8;
        let mut abandoned = None;
        let mut message = None;
        if let Some(p) = self.pending.get_mut(kind.index()) {
            if p.mask != 0 && p.counter != counter {
                abandoned = Some(kind);
                p.mask = 0;
                self.stats.incomplete_samples += 1;
            }
            p.counter = counter;
            p.mask |= 1 << part;
            if let Some(d) = p.data.get_mut(part) {
                *d = data;
            }
            if p.mask == full {
                p.mask = 0;
                let pending = *p;
                message = Some(self.assemble(kind, &pending));
            }
        }

        let class = if lost > 0 {
            FrameClass::CounterJump { lost }
        } else if abandoned.is_some() {
            FrameClass::IncompleteSample
        } else if out_of_range {
            FrameClass::OutOfRange
        } else {
            FrameClass::Ok
        };
        Decoded {
            class,
            message,
            abandoned,
        }
    }

    fn assemble(&mut self, kind: MessageKind, p: &Pending) -> Received {
        let layout = kind.layout();
        let mut record = Record::default();
        let mut clipped = 0u8;
        for (part, pl) in layout.parts.iter().enumerate() {
            let Some(data) = p.data.get(part) else {
                continue;
            };
            for field in pl.fields {
                let offset = usize::from(field.offset);
                let byte = data.get(offset).copied().unwrap_or(0);
                match field.kind {
                    FieldKind::Status => record.status = byte,
                    FieldKind::State => record.state = byte,
                    FieldKind::Links => record.links = byte,
                    FieldKind::Errors => record.errors = byte,
                    FieldKind::Flags => record.flags = byte,
                    FieldKind::Valves => record.valves = byte,
                    FieldKind::Time => record.time_us = read_uint(data, offset, 4),
                    FieldKind::Value(ch) => {
                        let Some(c) = channel(layout.channels, ch) else {
                            continue;
                        };
                        let (value, clip) = dequantise(
                            &self.protocol,
                            c.quantity,
                            read_raw(data, offset, c.quantity),
                        );
                        if let Some(v) = record.values.get_mut(usize::from(ch)) {
                            *v = value;
                        }
                        if clip {
                            clipped |= crate::message::DeviceStatus::saturated_bit(c.axis);
                            self.stats.clipped_values += 1;
                        }
                    }
                }
            }
        }
        self.stats.messages += 1;
        Received {
            counter: p.counter,
            message: Message::from_record(kind, &record),
            clipped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::*;
    use crate::protocol::{IdMap, Limits, MAX_VALVE_ON_TIME_S};

    fn gyro(rate: [f64; 3]) -> Message {
        Message::Gyro(GyroMsg {
            node_time_us: 123_456,
            status: DeviceStatus(0),
            rate_rad_s: rate,
        })
    }

    #[test]
    fn counter_slots_cover_every_frame() {
        assert_eq!(
            SLOTS,
            MessageKind::ALL.iter().map(|k| k.parts()).sum::<usize>()
        );
        assert!(
            MessageKind::ALL.len() <= 32 && MAX_PARTS <= 8,
            "lookup entry is kind << 3 | part"
        );
    }

    #[test]
    fn gyro_round_trip_and_layout() {
        let mut enc = Encoder::new(Protocol::default());
        let mut dec = Decoder::new(Protocol::default());
        let m = gyro([0.1, -0.2, 0.3]);
        let batch = enc.encode(&m).unwrap();
        assert_eq!(batch.len(), 2);
        assert_eq!(batch.as_slice()[0].standard_id(), Some(0x120));
        assert_eq!(batch.as_slice()[1].standard_id(), Some(0x121));
        let first = dec.decode(&batch.as_slice()[0]);
        assert_eq!(first.class, FrameClass::Ok);
        assert!(first.message.is_none());
        let second = dec.decode(&batch.as_slice()[1]);
        let r = second.message.unwrap();
        let Message::Gyro(g) = r.message else {
            panic!("not a gyro message")
        };
        assert_eq!(g.node_time_us, 123_456);
        for (a, b) in g.rate_rad_s.iter().zip([0.1, -0.2, 0.3]) {
            assert!((a - b).abs() <= Quantity::GyroRate.lsb_si() / 2.0);
        }
        assert_eq!(enc.next_counter(MessageKind::Gyro), 1);
    }

    #[test]
    fn wire_bytes_are_as_documented() {
        // 1 °/s on x = 100000 LSB = 0x0186A0, little-endian.
        let enc = Encoder::new(Protocol::default());
        let deg = testbed_model::config::DEG;
        let batch = enc
            .encode_with_counter(&gyro([deg, -1e-5 * deg, 0.0]), 7)
            .unwrap();
        let f = batch.as_slice();
        assert_eq!(f[0].data(), &[7, 0, 0xA0, 0x86, 0x01, 0xFF, 0xFF, 0xFF]);
        assert_eq!(f[1].data(), &[7, 0, 0, 0, 0x40, 0xE2, 0x01, 0x00]);
    }

    #[test]
    fn commands_out_of_range_are_refused() {
        let enc = Encoder::new(Protocol::default());
        let e = enc.encode_with_counter(
            &Message::WheelCommand(WheelCommandMsg {
                torque_nm: [0.1, -0.1001, 0.0],
            }),
            0,
        );
        assert!(
            matches!(e, Err(EncodeError::OutOfRange { channel: 1, .. })),
            "{e:?}"
        );
        let e = enc.encode_with_counter(
            &Message::WheelCommand(WheelCommandMsg {
                torque_nm: [f64::NAN, 0.0, 0.0],
            }),
            0,
        );
        assert!(matches!(e, Err(EncodeError::NonFinite { channel: 0, .. })));
        let big = 91.0 * testbed_model::config::DEG;
        let e = enc.encode_with_counter(
            &Message::CmgCommand(CmgCommandMsg {
                gimbal_rate_rad_s: [0.0, 0.0, 0.0, big],
            }),
            0,
        );
        assert!(matches!(e, Err(EncodeError::OutOfRange { channel: 3, .. })));
        let hb = NodeHeartbeatMsg {
            node_time_us: 0,
            state: NodeState::Unknown(9),
            links: DeviceSet(0),
            serial_errors: 0,
        };
        assert_eq!(
            enc.encode_with_counter(&Message::NodeHeartbeat(hb), 0),
            Err(EncodeError::BadState(9))
        );
    }

    #[test]
    fn counters_jumps_duplicates_and_incomplete_samples() {
        let p = Protocol::new(IdMap::new(0x300).unwrap(), Limits::default()).unwrap();
        let enc = Encoder::new(p);
        let mut dec = Decoder::new(p);
        let b = |c| enc.encode_with_counter(&gyro([0.0; 3]), c).unwrap();
        let (b0, b1, b5) = (b(0), b(1), b(5));
        assert_eq!(dec.decode(&b0.as_slice()[0]).class, FrameClass::Ok);
        assert_eq!(dec.decode(&b0.as_slice()[0]).class, FrameClass::Duplicate);
        assert!(dec.decode(&b0.as_slice()[1]).message.is_some());
        // Frame B of sample 1 lost; frame A of sample 5 abandons sample 1 and jumps 3.
        assert_eq!(dec.decode(&b1.as_slice()[0]).class, FrameClass::Ok);
        let d = dec.decode(&b5.as_slice()[0]);
        assert_eq!(d.class, FrameClass::CounterJump { lost: 3 });
        assert_eq!(d.abandoned, Some(MessageKind::Gyro));
        let d = dec.decode(&b5.as_slice()[1]);
        assert_eq!(d.class, FrameClass::CounterJump { lost: 4 });
        assert_eq!(d.message.unwrap().counter, 5);
        let s = dec.stats();
        assert_eq!((s.frames, s.classified()), (6, 6));
        assert_eq!(
            (
                s.duplicate,
                s.counter_jump,
                s.lost_frames,
                s.incomplete_samples,
                s.messages
            ),
            (1, 2, 7, 1, 2)
        );
    }

    #[test]
    fn out_of_range_values_are_clipped_and_flagged() {
        let p = Protocol::default();
        let mut dec = Decoder::new(p);
        // Gyro x = +8_388_607 LSB (83.9 °/s) beyond the 80 °/s range.
        let a = CanFrame::standard(0x120, &[0, 0, 0xFF, 0xFF, 0x7F, 0, 0, 0]).unwrap();
        let b = CanFrame::standard(0x121, &[0, 0, 0, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(dec.decode(&a).class, FrameClass::OutOfRange);
        let r = dec.decode(&b).message.unwrap();
        assert_eq!(r.clipped, 0b001);
        let Message::Gyro(g) = r.message else {
            panic!("not gyro")
        };
        assert_eq!(g.rate_rad_s[0], p.limits().gyro_range_rad_s);
        let Some(Sample::Gyro(s)) = r
            .message
            .to_sample(ipc_types::SampleHeader::default(), r.clipped)
        else {
            panic!("no sample")
        };
        assert!(
            s.header
                .has(ipc_types::SampleHeader::SATURATED_X | ipc_types::SampleHeader::VALID)
        );
    }

    #[test]
    fn wrong_dlc_unknown_and_ignored() {
        let p = Protocol::default();
        let mut dec = Decoder::with_devices(p, DeviceSet::of(&[crate::Device::Gyro]));
        assert_eq!(
            dec.decode(&CanFrame::standard(0x120, &[0; 7]).unwrap())
                .class,
            FrameClass::WrongDlc {
                expected: 8,
                got: 7
            }
        );
        assert_eq!(
            dec.decode(&CanFrame::standard(0x0FF, &[]).unwrap()).class,
            FrameClass::UnknownId
        );
        assert_eq!(
            dec.decode(&CanFrame::standard(0x12F, &[0; 8]).unwrap())
                .class,
            FrameClass::UnknownId
        );
        let ext = CanFrame::new(crate::CanId::Extended(0x120), &[0; 8]).unwrap();
        assert_eq!(dec.decode(&ext).class, FrameClass::UnknownId);
        assert_eq!(
            dec.decode(&CanFrame::standard(0x100, &[0; 7]).unwrap())
                .class,
            FrameClass::Ignored
        );
        assert_eq!(dec.stats().classified(), 5);
    }

    #[test]
    fn gimbal_angle_wraps() {
        let enc = Encoder::new(Protocol::default());
        let mut dec = Decoder::new(Protocol::default());
        let pi = std::f64::consts::PI;
        let m = Message::CmgTelemetry(CmgTelemetryMsg {
            node_time_us: 1,
            status: DeviceStatus(0),
            gimbal_angle_rad: [pi, -pi, 3.0 * pi / 2.0, -7.0],
            gimbal_rate_rad_s: [0.0; 4],
        });
        let batch = enc.encode_with_counter(&m, 0).unwrap();
        let mut out = None;
        for f in &batch {
            out = dec.decode(f).message.or(out);
        }
        let Some(Received {
            message: Message::CmgTelemetry(t),
            ..
        }) = out
        else {
            panic!("no telemetry")
        };
        let lsb = Quantity::GimbalAngle.lsb_si();
        assert!((t.gimbal_angle_rad[0] + pi).abs() <= lsb / 2.0); // π wraps to −π
        assert!((t.gimbal_angle_rad[1] + pi).abs() <= lsb / 2.0);
        assert!((t.gimbal_angle_rad[2] + pi / 2.0).abs() <= lsb / 2.0);
        assert!((t.gimbal_angle_rad[3] - (-7.0 + 2.0 * pi)).abs() <= lsb);
    }

    fn decode_all(dec: &mut Decoder, batch: &FrameBatch) -> Option<Received> {
        let mut out = None;
        for f in batch {
            out = dec.decode(f).message.or(out);
        }
        out
    }

    #[test]
    fn thruster_command_round_trip_and_wire_bytes() {
        let mut enc = Encoder::new(Protocol::default());
        let mut dec = Decoder::new(Protocol::default());
        let on = [0.1, 0.0, 0.012_34, 0.0, 0.02, 0.099_999];
        let m = Message::ThrusterCommand(ThrusterCommandMsg {
            on_time_s: on,
            latch_shut: true,
        });
        let batch = enc.encode(&m).unwrap();
        let f = batch.as_slice();
        assert_eq!(f.len(), 2);
        assert_eq!(f[0].standard_id(), Some(0x160));
        assert_eq!(f[1].standard_id(), Some(0x161));
        // 0.1 s = 10000 LSB of 10 µs = 0x2710; the latch flag is bit 0 of byte 1.
        assert_eq!(f[0].data(), &[0, 1, 0x10, 0x27, 0, 0, 0xD2, 0x04]);
        let Some(Received {
            message: Message::ThrusterCommand(c),
            clipped: 0,
            ..
        }) = decode_all(&mut dec, &batch)
        else {
            panic!("no thruster command")
        };
        assert!(c.latch_shut);
        for (a, b) in c.on_time_s.iter().zip(on) {
            assert!((a - b).abs() <= Quantity::ValveOnTime.lsb_si() / 2.0);
        }
        // Beyond the field's limit or not finite: refused, nothing sent.
        for bad in [MAX_VALVE_ON_TIME_S + 0.01, -0.31, f64::NAN] {
            let mut on = [0.0; 6];
            on[3] = bad;
            let e = enc.encode(&Message::ThrusterCommand(ThrusterCommandMsg {
                on_time_s: on,
                latch_shut: false,
            }));
            assert!(e.is_err(), "{bad} encoded");
        }
    }

    #[test]
    fn thruster_status_round_trip() {
        let mut enc = Encoder::new(Protocol::default());
        let mut dec = Decoder::new(Protocol::default());
        let m = ThrusterStatusMsg {
            node_time_us: 4_000_000,
            status: DeviceStatus(0),
            applied_on_time_s: [0.0, 0.05, 0.0, 0.0, 0.1, 0.0],
            valves_open: 0b01_0010,
            latch_shut: true,
        };
        let batch = enc.encode(&Message::ThrusterStatus(m)).unwrap();
        assert_eq!(batch.len(), 3);
        assert_eq!(batch.as_slice()[0].standard_id(), Some(0x162));
        assert_eq!(batch.as_slice()[1].data()[1], 0b1001_0010); // valves + latch bit
        let Some(Received {
            message: Message::ThrusterStatus(s),
            ..
        }) = decode_all(&mut dec, &batch)
        else {
            panic!("no thruster status")
        };
        assert_eq!(s.node_time_us, m.node_time_us);
        assert_eq!((s.valves_open, s.latch_shut), (m.valves_open, true));
        assert_eq!(s.applied_on_time_s, m.applied_on_time_s); // multiples of the LSB
        let Some(Sample::ThrusterStatus(sample)) =
            Message::ThrusterStatus(s).to_sample(ipc_types::SampleHeader::default(), 0)
        else {
            panic!("no sample")
        };
        assert_eq!((sample.valves_open, sample.disabled), (0b01_0010, 1));
        assert!(sample.header.is_valid());
    }
}
