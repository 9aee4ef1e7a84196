//! A device wired directly to the computer by RS-232, speaking the CAN protocol's frames in a
//! byte-stream framing.
//!
//! The smart node normally turns a sensor's RS-232 messages into CAN frames. When a sensor is
//! wired straight to the computer instead, a small adapter (or a simulated device) sends the
//! very same frames — same identifiers, payloads, counters and node-style µs time stamps — over
//! the serial line, so the same [`crate::Decoder`] and gateways serve both paths.
//!
//! # Line protocol
//!
//! 8 data bits, no parity, 1 stop bit, no flow control, 115200 baud by default. Each frame is
//! one packet:
//!
//! ```text
//! packet  = COBS(header ‖ len ‖ data ‖ crc) 0x00
//! header  = u16 big-endian: bits 0–10 the 11-bit identifier, bit 15 remote frame, bits 11–14 zero
//! len     = u8, 0–8: data length (requested length for a remote frame, which carries no data)
//! data    = len bytes (none for a remote frame)
//! crc     = u16 big-endian, CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection,
//!           no final xor; check value 0x29B1 for "123456789") over header ‖ len ‖ data
//! ```
//!
//! COBS (consistent overhead byte stuffing) removes every 0x00 from the packet, so 0x00 only
//! ever delimits packets and a receiver resynchronises at the next 0x00 after any line noise.
//! A packet is at most 13 bytes before and 14 after stuffing, 15 on the line with the
//! delimiter: 1.3 ms at 115200 baud. Empty packets (consecutive 0x00) are ignored, so a sender
//! may start with a 0x00 to flush a receiver's partial packet. Extended identifiers are not
//! carried. A receiver drops (and counts) packets with a bad CRC, bad stuffing, bad length or
//! non-zero reserved header bits, and packets longer than 14 bytes.

use super::{CanTransport, TransportError};
use crate::frame::{CanFrame, CanId, MAX_DATA_LEN, TimeSource, TimestampedFrame, host_time_ns};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::Duration;

/// Largest unstuffed packet: header 2 + len 1 + data 8 + crc 2.
pub const MAX_PACKET: usize = 13;
/// Largest stuffed packet (without the 0x00 delimiter).
pub const MAX_STUFFED: usize = MAX_PACKET + 1;
/// Largest packet on the line, delimiter included.
pub const MAX_WIRE: usize = MAX_STUFFED + 1;

const REMOTE_BIT: u16 = 0x8000;
const RESERVED_BITS: u16 = 0x7800;

/// CRC-16/CCITT-FALSE of `bytes`.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for &b in bytes {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// COBS-encode `input` (at most 254 bytes) into `out`; returns the length (None if `out` is too small).
fn cobs_encode(input: &[u8], out: &mut [u8]) -> Option<usize> {
    let mut code_at = 0usize;
    let mut n = 1usize;
    let mut code = 1u8;
    for &b in input {
        if b == 0 {
            *out.get_mut(code_at)? = code;
            code_at = n;
            n += 1;
            code = 1;
        } else {
            *out.get_mut(n)? = b;
            n += 1;
            code += 1;
            if code == 0xFF {
                *out.get_mut(code_at)? = code;
                code_at = n;
                n += 1;
                code = 1;
            }
        }
    }
    *out.get_mut(code_at)? = code;
    Some(n)
}

/// COBS-decode `input` into `out`; returns the length (None if malformed or `out` too small).
fn cobs_decode(input: &[u8], out: &mut [u8]) -> Option<usize> {
    let mut i = 0usize;
    let mut n = 0usize;
    while i < input.len() {
        let code = input[i];
        if code == 0 {
            return None;
        }
        i += 1;
        for _ in 1..code {
            let b = *input.get(i)?;
            if b == 0 {
                return None;
            }
            *out.get_mut(n)? = b;
            n += 1;
            i += 1;
        }
        if code != 0xFF && i < input.len() {
            *out.get_mut(n)? = 0;
            n += 1;
        }
    }
    Some(n)
}

/// Encode `frame` as one packet with its trailing 0x00 into `out`; returns the length.
pub fn encode_packet(frame: &CanFrame, out: &mut [u8; MAX_WIRE]) -> Result<usize, TransportError> {
    let CanId::Standard(id) = frame.id() else {
        return Err(TransportError::FrameNotSupported {
            frame: *frame,
            reason: "extended identifiers are not carried over serial",
        });
    };
    let header = id | if frame.is_remote() { REMOTE_BIT } else { 0 };
    let mut packet = [0u8; MAX_PACKET];
    packet[..2].copy_from_slice(&header.to_be_bytes());
    packet[2] = frame.dlc();
    let data = frame.data();
    packet[3..3 + data.len()].copy_from_slice(data);
    let body = 3 + data.len();
    let crc = crc16(&packet[..body]);
    packet[body..body + 2].copy_from_slice(&crc.to_be_bytes());
    let n = cobs_encode(&packet[..body + 2], &mut out[..MAX_STUFFED]).ok_or(
        TransportError::FrameNotSupported {
            frame: *frame,
            reason: "packet too long",
        },
    )?;
    out[n] = 0;
    Ok(n + 1)
}

/// Why a packet was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
pub enum PacketError {
    /// More than [`MAX_STUFFED`] bytes before the delimiter.
    #[error("packet too long")]
    TooLong,
    /// Invalid COBS stuffing.
    #[error("bad byte stuffing")]
    BadStuffing,
    /// Length byte inconsistent with the packet size, or above 8.
    #[error("bad length")]
    BadLength,
    /// CRC mismatch.
    #[error("CRC mismatch")]
    BadCrc,
    /// Reserved header bits set.
    #[error("reserved header bits set")]
    BadHeader,
}

/// Counts of a [`Deframer`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SerialStats {
    /// Bytes received.
    pub bytes: u64,
    /// Frames delivered.
    pub frames: u64,
    /// Packets dropped: too long.
    pub too_long: u64,
    /// Packets dropped: bad stuffing.
    pub bad_stuffing: u64,
    /// Packets dropped: bad length.
    pub bad_length: u64,
    /// Packets dropped: CRC mismatch.
    pub bad_crc: u64,
    /// Packets dropped: reserved header bits.
    pub bad_header: u64,
}

impl SerialStats {
    /// All dropped packets.
    pub fn dropped(&self) -> u64 {
        self.too_long + self.bad_stuffing + self.bad_length + self.bad_crc + self.bad_header
    }
}

/// Splits a received byte stream into frames. No I/O, no allocation, never panics.
#[derive(Debug, Clone, Default)]
pub struct Deframer {
    buf: [u8; MAX_STUFFED],
    len: usize,
    overflow: bool,
    stats: SerialStats,
}

impl Deframer {
    /// An empty deframer.
    pub fn new() -> Self {
        Self::default()
    }

    /// Counts so far.
    pub fn stats(&self) -> &SerialStats {
        &self.stats
    }

    /// Feed one byte; a packet delimiter yields the frame or why the packet was dropped.
    pub fn push(&mut self, byte: u8) -> Option<Result<CanFrame, PacketError>> {
        self.stats.bytes += 1;
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => self.overflow = true,
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if overflow {
            self.stats.too_long += 1;
            return Some(Err(PacketError::TooLong));
        }
        if len == 0 {
            return None;
        }
        let result = self.unpack(len);
        match result {
            Ok(_) => self.stats.frames += 1,
            Err(PacketError::TooLong) => self.stats.too_long += 1,
            Err(PacketError::BadStuffing) => self.stats.bad_stuffing += 1,
            Err(PacketError::BadLength) => self.stats.bad_length += 1,
            Err(PacketError::BadCrc) => self.stats.bad_crc += 1,
            Err(PacketError::BadHeader) => self.stats.bad_header += 1,
        }
        Some(result)
    }

    fn unpack(&self, len: usize) -> Result<CanFrame, PacketError> {
        let mut packet = [0u8; MAX_PACKET];
        let stuffed = self.buf.get(..len).ok_or(PacketError::TooLong)?;
        let n = cobs_decode(stuffed, &mut packet).ok_or(PacketError::BadStuffing)?;
        if n < 5 {
            return Err(PacketError::BadLength);
        }
        let header = u16::from_be_bytes([packet[0], packet[1]]);
        let dlc = packet[2];
        let remote = header & REMOTE_BIT != 0;
        let data_len = if remote { 0 } else { usize::from(dlc) };
        if usize::from(dlc) > MAX_DATA_LEN || n != 3 + data_len + 2 {
            return Err(PacketError::BadLength);
        }
        let body = 3 + data_len;
        let crc = u16::from_be_bytes([packet[body], packet[body + 1]]);
        if crc16(&packet[..body]) != crc {
            return Err(PacketError::BadCrc);
        }
        if header & RESERVED_BITS != 0 {
            return Err(PacketError::BadHeader);
        }
        let id = CanId::Standard(header & 0x7FF);
        let frame = if remote {
            CanFrame::remote(id, dlc)
        } else {
            CanFrame::new(id, &packet[3..body])
        };
        frame.map_err(|_| PacketError::BadLength)
    }
}

/// Serial port settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SerialConfig {
    /// Device path, e.g. `/dev/ttyS0`, `/dev/ttyUSB0`.
    pub path: String,
    /// Line rate, baud (bits/s).
    pub baud: u32,
}

impl SerialConfig {
    /// Default line rate, baud.
    pub const DEFAULT_BAUD: u32 = 115_200;

    /// `path` at the default line rate.
    pub fn new(path: &str) -> Self {
        Self {
            path: path.to_string(),
            baud: Self::DEFAULT_BAUD,
        }
    }
}

/// Frames over a serial port ([module documentation](self) for the line protocol).
///
/// Received frames are stamped with the host time when their bytes were read
/// ([`TimeSource::Host`]); the measurement time is the node-style stamp in the payload.
pub struct SerialTransport {
    port: Box<dyn serialport::SerialPort>,
    name: String,
    deframer: Deframer,
    queue: VecDeque<TimestampedFrame>,
    /// The most recent dropped-packet reason, for diagnostics.
    last_error: Option<PacketError>,
}

impl std::fmt::Debug for SerialTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialTransport")
            .field("name", &self.name)
            .field("stats", self.deframer.stats())
            .finish()
    }
}

fn port_error(context: String, e: serialport::Error) -> TransportError {
    match e.kind() {
        serialport::ErrorKind::NoDevice => TransportError::NotFound(context),
        serialport::ErrorKind::Io(std::io::ErrorKind::NotFound) => {
            TransportError::NotFound(context)
        }
        serialport::ErrorKind::InvalidInput => TransportError::Config(format!("{context}: {e}")),
        _ => TransportError::io(context, std::io::Error::from(e)),
    }
}

impl SerialTransport {
    /// Open and configure (8N1, no flow control) the port of `config`.
    pub fn open(config: &SerialConfig) -> Result<Self, TransportError> {
        if config.baud == 0 {
            return Err(TransportError::Config("baud rate 0".into()));
        }
        let port = serialport::new(&config.path, config.baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(Duration::from_millis(10))
            .open()
            .map_err(|e| port_error(format!("serial port {}", config.path), e))?;
        Ok(Self::from_port(port, &config.path))
    }

    /// Use an already open port (e.g. one end of `serialport::TTYPort::pair()`).
    pub fn from_port(port: Box<dyn serialport::SerialPort>, name: &str) -> Self {
        Self {
            port,
            name: name.to_string(),
            deframer: Deframer::new(),
            queue: VecDeque::new(),
            last_error: None,
        }
    }

    /// Byte and packet counts.
    pub fn stats(&self) -> &SerialStats {
        self.deframer.stats()
    }

    /// Why the most recent dropped packet was dropped.
    pub fn last_error(&self) -> Option<PacketError> {
        self.last_error
    }

    fn feed(&mut self, bytes: &[u8]) {
        let time_ns = host_time_ns();
        for &b in bytes {
            match self.deframer.push(b) {
                Some(Ok(frame)) => self.queue.push_back(TimestampedFrame {
                    frame,
                    time_ns,
                    source: TimeSource::Host,
                }),
                Some(Err(e)) => self.last_error = Some(e),
                None => {}
            }
        }
    }
}

impl CanTransport for SerialTransport {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let mut out = [0u8; MAX_WIRE];
        let n = encode_packet(frame, &mut out)?;
        self.port
            .write_all(&out[..n])
            .map_err(|e| TransportError::io(format!("writing to {}", self.name), e))
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        let deadline = super::deadline_after(timeout);
        let mut buf = [0u8; 256];
        loop {
            if let Some(f) = self.queue.pop_front() {
                return Ok(Some(f));
            }
            let left = super::time_left(deadline);
            self.port
                .set_timeout(left)
                .map_err(|e| port_error(format!("setting time-out on {}", self.name), e))?;
            match self.port.read(&mut buf) {
                Ok(0) => return Err(TransportError::Closed),
                Ok(n) => self.feed(&buf[..n.min(buf.len())]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                    ) =>
                {
                    if super::time_left(deadline).is_zero() {
                        return Ok(None);
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                    return Err(TransportError::Closed);
                }
                Err(e) => return Err(TransportError::io(format!("reading from {}", self.name), e)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_check_value() {
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn cobs_round_trip() {
        let cases: [&[u8]; 5] = [&[], &[0], &[0, 0], &[1, 2, 0, 3], &[0x11; 13]];
        for input in cases {
            let mut enc = [0u8; 32];
            let n = cobs_encode(input, &mut enc).unwrap();
            assert!(!enc[..n].contains(&0));
            let mut dec = [0u8; 32];
            let m = cobs_decode(&enc[..n], &mut dec).unwrap();
            assert_eq!(&dec[..m], input);
        }
    }

    #[test]
    fn packets_round_trip() {
        let mut d = Deframer::new();
        for f in [
            CanFrame::standard(0x123, &[0, 0, 0, 0, 0, 0, 0, 0]).unwrap(),
            CanFrame::standard(0x7FF, &[0xFF; 8]).unwrap(),
            CanFrame::standard(0, &[]).unwrap(),
            CanFrame::remote(CanId::Standard(0x10), 8).unwrap(),
        ] {
            let mut out = [0u8; MAX_WIRE];
            let n = encode_packet(&f, &mut out).unwrap();
            assert!(n <= MAX_WIRE && out[..n - 1].iter().all(|&b| b != 0) && out[n - 1] == 0);
            let got: Vec<_> = out[..n].iter().filter_map(|&b| d.push(b)).collect();
            assert_eq!(got, [Ok(f)]);
        }
        assert!(
            encode_packet(
                &CanFrame::new(CanId::Extended(1), &[]).unwrap(),
                &mut [0; MAX_WIRE]
            )
            .is_err()
        );
    }

    #[test]
    fn corrupt_packets_are_dropped_and_counted() {
        let f = CanFrame::standard(0x120, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap();
        let mut out = [0u8; MAX_WIRE];
        let n = encode_packet(&f, &mut out).unwrap();
        let mut d = Deframer::new();
        let mut bad = out;
        bad[5] ^= 0x01; // flip a data bit: CRC
        let mut results: Vec<_> = bad[..n].iter().filter_map(|&b| d.push(b)).collect();
        results.extend([0x55u8; 40].iter().chain(&[0]).filter_map(|&b| d.push(b))); // too long
        results.extend([3u8, 1, 0].iter().filter_map(|&b| d.push(b))); // COBS says 2 more bytes
        results.extend(out[..n].iter().filter_map(|&b| d.push(b)));
        assert_eq!(
            results,
            [
                Err(PacketError::BadCrc),
                Err(PacketError::TooLong),
                Err(PacketError::BadStuffing),
                Ok(f)
            ]
        );
        assert_eq!(d.stats().dropped(), 3);
        assert_eq!(d.stats().frames, 1);
    }
}
