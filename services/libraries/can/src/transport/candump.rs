//! `candump -L` log files: `(1700000000.123456) can0 123#DEADBEEF`.
//!
//! Accepted per line (can-utils `lib.c` notation): a time stamp `(seconds.fraction)` with 1 to
//! 9 fraction digits, an interface name, and a frame: `III#DD..` (3 hex digits, standard ID),
//! `IIIIIIII#DD..` (8 hex digits, extended ID), up to 8 data bytes as hex pairs, optionally
//! followed by `_X` (the raw DLC of an 8-byte frame, ignored); remote frames `III#R` or
//! `III#R<len>`. A trailing direction marker `R`/`T` (`candump -x`) is accepted and ignored.
//! Empty lines are skipped. Error frames (ID with the error flag 0x20000000) and CAN FD frames
//! (`III##F…`) are valid lines this crate does not carry: they are skipped and counted.
//! Anything else is a malformed line: counted, its line number and reason kept (the first
//! [`MAX_KEPT_MALFORMED`]), and reading goes on.

use super::{CanTransport, TransportError};
use crate::frame::{CanFrame, CanId, MAX_DATA_LEN, TimeSource, TimestampedFrame, host_time_ns};
use std::fmt::Write as _;
use std::io::{BufRead, Write};
use std::time::{Duration, Instant};

/// Longest line read in full, bytes; longer lines are malformed (the rest is skipped).
pub const MAX_LINE_LEN: usize = 256;
/// Malformed lines whose number and reason [`LogStats`] keeps.
pub const MAX_KEPT_MALFORMED: usize = 100;

/// A parsed log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CandumpEntry<'a> {
    /// Time stamp, ns since the Unix epoch.
    pub time_ns: u64,
    /// Interface name.
    pub iface: &'a str,
    /// The frame.
    pub frame: CanFrame,
}

/// Why a line is not a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
pub enum LineError {
    /// No `(seconds.fraction)` at the start.
    #[error("missing or malformed time stamp")]
    BadTimestamp,
    /// No interface name.
    #[error("missing interface name")]
    NoInterface,
    /// No `ID#DATA` field.
    #[error("missing frame")]
    NoFrame,
    /// Identifier not 3 or 8 hex digits, or out of range.
    #[error("bad identifier")]
    BadId,
    /// Data not hex pairs, or a bad remote length.
    #[error("bad data")]
    BadData,
    /// More than 8 data bytes.
    #[error("more than 8 data bytes")]
    TooLong,
    /// Unexpected text after the frame.
    #[error("unexpected text after the frame")]
    TrailingText,
    /// Not UTF-8.
    #[error("not UTF-8 text")]
    NotUtf8,
    /// Longer than [`MAX_LINE_LEN`].
    #[error("line longer than {MAX_LINE_LEN} bytes")]
    LineTooLong,
    /// An error frame (valid, not carried: skipped).
    #[error("error frame (skipped)")]
    ErrorFrame,
    /// A CAN FD frame (valid, not carried: skipped).
    #[error("CAN FD frame (skipped)")]
    CanFd,
}

fn hex_value(s: &str) -> Option<u32> {
    if s.is_empty() || s.len() > 8 || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u32::from_str_radix(s, 16).ok()
}

fn parse_time(token: &str) -> Result<u64, LineError> {
    let inner = token
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or(LineError::BadTimestamp)?;
    let (secs, frac) = inner.split_once('.').ok_or(LineError::BadTimestamp)?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(secs) || !digits(frac) || frac.len() > 9 || secs.len() > 19 {
        return Err(LineError::BadTimestamp);
    }
    let secs: u64 = secs.parse().map_err(|_| LineError::BadTimestamp)?;
    let frac_value: u64 = frac.parse().map_err(|_| LineError::BadTimestamp)?;
    let frac_ns = frac_value * 10u64.pow(9 - frac.len() as u32);
    secs.checked_mul(1_000_000_000)
        .and_then(|ns| ns.checked_add(frac_ns))
        .ok_or(LineError::BadTimestamp)
}

fn parse_frame(token: &str) -> Result<CanFrame, LineError> {
    let (id_text, rest) = token.split_once('#').ok_or(LineError::NoFrame)?;
    let raw = hex_value(id_text).ok_or(LineError::BadId)?;
    let id = match id_text.len() {
        3 if raw <= 0x7FF => CanId::Standard(raw as u16),
        8 if raw & 0x2000_0000 != 0 => return Err(LineError::ErrorFrame),
        8 if raw <= 0x1FFF_FFFF => CanId::Extended(raw),
        _ => return Err(LineError::BadId),
    };
    if rest.starts_with('#') {
        return Err(LineError::CanFd);
    }
    if let Some(len) = rest.strip_prefix('R') {
        let dlc = match len.as_bytes() {
            [] => 0,
            [d @ b'0'..=b'8'] => d - b'0',
            _ => return Err(LineError::BadData),
        };
        return CanFrame::remote(id, dlc).map_err(|_| LineError::BadData);
    }
    // Optional `_X` raw DLC suffix (len8_dlc) after 8 data bytes.
    let hex = match rest.split_once('_') {
        Some((data, dlc))
            if data.len() == 2 * MAX_DATA_LEN && dlc.len() == 1 && hex_value(dlc).is_some() =>
        {
            data
        }
        Some(_) => return Err(LineError::BadData),
        None => rest,
    };
    if hex.len() > 2 * MAX_DATA_LEN {
        return Err(LineError::TooLong);
    }
    if hex.len() % 2 != 0 {
        return Err(LineError::BadData);
    }
    let mut data = [0u8; MAX_DATA_LEN];
    for (i, pair) in hex.as_bytes().chunks(2).enumerate() {
        let text = std::str::from_utf8(pair).map_err(|_| LineError::BadData)?;
        let v = hex_value(text).ok_or(LineError::BadData)?;
        *data.get_mut(i).ok_or(LineError::TooLong)? = v as u8;
    }
    CanFrame::new(id, &data[..hex.len() / 2]).map_err(|_| LineError::BadData)
}

/// Parse one `candump -L` line (without its line end).
pub fn parse_candump_line(line: &str) -> Result<CandumpEntry<'_>, LineError> {
    let mut tokens = line.split_ascii_whitespace();
    let time_ns = parse_time(tokens.next().ok_or(LineError::BadTimestamp)?)?;
    let iface = tokens.next().ok_or(LineError::NoInterface)?;
    if iface.contains('#') {
        return Err(LineError::NoInterface);
    }
    let frame = parse_frame(tokens.next().ok_or(LineError::NoFrame)?)?;
    match (tokens.next(), tokens.next()) {
        (None, _) | (Some("R" | "T"), None) => Ok(CandumpEntry {
            time_ns,
            iface,
            frame,
        }),
        _ => Err(LineError::TrailingText),
    }
}

/// One `candump -L` line (no line end) for `frame` received at `time_ns` (ns since the Unix
/// epoch, written rounded down to µs as candump does) on `iface`.
pub fn format_candump_line(time_ns: u64, iface: &str, frame: &CanFrame) -> String {
    let mut s = String::with_capacity(48);
    let _ = write!(
        s,
        "({:010}.{:06}) {iface} {frame}",
        time_ns / 1_000_000_000,
        (time_ns % 1_000_000_000) / 1000
    );
    s
}

/// A malformed line: where and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MalformedLine {
    /// Line number, from 1.
    pub line: u64,
    /// Why.
    pub reason: LineError,
}

/// What a [`CandumpReader`] has seen.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LogStats {
    /// Lines read.
    pub lines: u64,
    /// Frames delivered.
    pub frames: u64,
    /// Empty lines.
    pub blank: u64,
    /// Frames of other interfaces (when filtering by interface).
    pub other_iface: u64,
    /// Error frames skipped.
    pub error_frames: u64,
    /// CAN FD frames skipped.
    pub fd_frames: u64,
    /// Malformed lines.
    pub malformed: u64,
    /// The first [`MAX_KEPT_MALFORMED`] malformed lines.
    pub first_malformed: Vec<MalformedLine>,
}

impl std::fmt::Display for LogStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} lines: {} frames, {} blank, {} other interface, {} error frames, {} CAN FD, {} malformed",
            self.lines,
            self.frames,
            self.blank,
            self.other_iface,
            self.error_frames,
            self.fd_frames,
            self.malformed
        )?;
        for m in &self.first_malformed {
            write!(f, "; line {}: {}", m.line, m.reason)?;
        }
        Ok(())
    }
}

/// Reads frames from a `candump -L` log, skipping (and counting) what is not a frame.
#[derive(Debug)]
pub struct CandumpReader<R> {
    reader: R,
    iface: Option<String>,
    line: Vec<u8>,
    stats: LogStats,
}

impl<R: BufRead> CandumpReader<R> {
    /// A reader of every interface's frames.
    pub fn new(reader: R) -> Self {
        Self {
            reader,
            iface: None,
            line: Vec::with_capacity(MAX_LINE_LEN),
            stats: LogStats::default(),
        }
    }

    /// Deliver only the frames of interface `iface`.
    pub fn with_iface(mut self, iface: &str) -> Self {
        self.iface = Some(iface.to_string());
        self
    }

    /// What has been seen so far.
    pub fn stats(&self) -> &LogStats {
        &self.stats
    }

    /// Reads one line into `self.line` (at most MAX_LINE_LEN + 1 bytes kept). Ok(false) at the end.
    fn read_line(&mut self) -> std::io::Result<bool> {
        self.line.clear();
        let mut any = false;
        loop {
            let buf = match self.reader.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if buf.is_empty() {
                return Ok(any);
            }
            any = true;
            let (chunk, done) = match buf.iter().position(|&b| b == b'\n') {
                Some(i) => (&buf[..i], i + 1),
                None => (buf, buf.len()),
            };
            let room = (MAX_LINE_LEN + 1).saturating_sub(self.line.len());
            self.line.extend_from_slice(&chunk[..chunk.len().min(room)]);
            let newline = done > chunk.len();
            self.reader.consume(done);
            if newline {
                return Ok(true);
            }
        }
    }

    fn malformed(&mut self, reason: LineError) {
        self.stats.malformed += 1;
        if self.stats.first_malformed.len() < MAX_KEPT_MALFORMED {
            self.stats.first_malformed.push(MalformedLine {
                line: self.stats.lines,
                reason,
            });
        }
    }

    /// The next frame, stamped with the log's time ([`TimeSource::Log`]); `Ok(None)` at the end
    /// of the log. Malformed lines never end reading; only I/O errors are returned.
    pub fn next_frame(&mut self) -> std::io::Result<Option<TimestampedFrame>> {
        loop {
            if !self.read_line()? {
                return Ok(None);
            }
            self.stats.lines += 1;
            if self.line.len() > MAX_LINE_LEN {
                self.malformed(LineError::LineTooLong);
                continue;
            }
            let parsed = match std::str::from_utf8(&self.line) {
                Ok(text) => {
                    let text = text.trim_end_matches('\r');
                    if text.trim().is_empty() {
                        self.stats.blank += 1;
                        continue;
                    }
                    match parse_candump_line(text) {
                        Ok(e) => Ok((
                            e.time_ns,
                            e.frame,
                            self.iface.as_deref().is_none_or(|want| want == e.iface),
                        )),
                        Err(e) => Err(e),
                    }
                }
                Err(_) => Err(LineError::NotUtf8),
            };
            match parsed {
                Ok((time_ns, frame, true)) => {
                    self.stats.frames += 1;
                    return Ok(Some(TimestampedFrame {
                        frame,
                        time_ns,
                        source: TimeSource::Log,
                    }));
                }
                Ok((_, _, false)) => self.stats.other_iface += 1,
                Err(LineError::ErrorFrame) => self.stats.error_frames += 1,
                Err(LineError::CanFd) => self.stats.fd_frames += 1,
                Err(reason) => self.malformed(reason),
            }
        }
    }
}

/// How a [`CandumpReplay`] releases frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// Every frame at once.
    AsFastAsPossible,
    /// Frames at their logged spacing divided by `speed` (1.0 = as recorded, 2.0 = twice as
    /// fast), measured from the first frame. Time stamps that go backwards release at once.
    Timed {
        /// Speed-up factor, finite and > 0.
        speed: f64,
    },
}

/// A `candump -L` log as a transport: `recv` replays the frames, `send` discards (and counts).
///
/// At the end of the log `recv` returns [`TransportError::Closed`].
#[derive(Debug)]
pub struct CandumpReplay<R> {
    reader: CandumpReader<R>,
    pacing: Pacing,
    next: Option<TimestampedFrame>,
    start: Option<(Instant, u64)>,
    discarded: u64,
}

impl CandumpReplay<std::io::BufReader<std::fs::File>> {
    /// Replay the log file at `path`.
    pub fn open(path: &std::path::Path, pacing: Pacing) -> Result<Self, TransportError> {
        let file = std::fs::File::open(path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => {
                TransportError::NotFound(format!("candump log {}", path.display()))
            }
            _ => TransportError::io(format!("opening candump log {}", path.display()), e),
        })?;
        Self::new(CandumpReader::new(std::io::BufReader::new(file)), pacing)
    }
}

impl<R: BufRead> CandumpReplay<R> {
    /// Replay the frames of `reader`.
    pub fn new(reader: CandumpReader<R>, pacing: Pacing) -> Result<Self, TransportError> {
        if let Pacing::Timed { speed } = pacing {
            if !(speed.is_finite() && speed > 0.0) {
                return Err(TransportError::Config(format!(
                    "replay speed {speed} must be finite and > 0"
                )));
            }
        }
        Ok(Self {
            reader,
            pacing,
            next: None,
            start: None,
            discarded: 0,
        })
    }

    /// The log's statistics so far (malformed lines with their numbers).
    pub fn stats(&self) -> &LogStats {
        self.reader.stats()
    }

    /// Frames given to `send` (discarded).
    pub fn discarded(&self) -> u64 {
        self.discarded
    }
}

impl<R: BufRead> CanTransport for CandumpReplay<R> {
    fn send(&mut self, _frame: &CanFrame) -> Result<(), TransportError> {
        self.discarded += 1;
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        if self.next.is_none() {
            self.next = self
                .reader
                .next_frame()
                .map_err(|e| TransportError::io("reading candump log", e))?;
        }
        let Some(frame) = self.next else {
            return Err(TransportError::Closed);
        };
        let Pacing::Timed { speed } = self.pacing else {
            self.next = None;
            return Ok(Some(frame));
        };
        let (start, t0) = *self.start.get_or_insert((Instant::now(), frame.time_ns));
        let offset_s = frame.time_ns.saturating_sub(t0) as f64 * 1e-9 / speed;
        let due = Duration::try_from_secs_f64(offset_s)
            .ok()
            .and_then(|d| start.checked_add(d));
        let now = Instant::now();
        let wait = match due {
            Some(due) => due.saturating_duration_since(now),
            None => Duration::MAX,
        };
        if wait > timeout {
            std::thread::sleep(timeout);
            return Ok(None);
        }
        std::thread::sleep(wait);
        self.next = None;
        Ok(Some(frame))
    }
}

/// Writes frames as `candump -L` lines.
#[derive(Debug)]
pub struct CandumpWriter<W: Write> {
    writer: W,
    iface: String,
}

impl<W: Write> CandumpWriter<W> {
    /// A writer labelling every line with interface `iface` (no whitespace or `#`).
    pub fn new(writer: W, iface: &str) -> Result<Self, TransportError> {
        if iface.is_empty() || iface.contains(|c: char| c.is_whitespace() || c == '#') {
            return Err(TransportError::Config(format!(
                "interface name {iface:?} is not usable in a candump log"
            )));
        }
        Ok(Self {
            writer,
            iface: iface.to_string(),
        })
    }

    /// Write one line for `frame` at `time_ns` (ns since the Unix epoch).
    pub fn write(&mut self, time_ns: u64, frame: &CanFrame) -> std::io::Result<()> {
        writeln!(
            self.writer,
            "{}",
            format_candump_line(time_ns, &self.iface, frame)
        )
    }

    /// Flush the underlying writer.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.writer
    }
}

/// A transport that logs every frame it sends and receives as `candump -L` lines.
///
/// Received frames keep their receive time stamp; sent frames get the host time.
#[derive(Debug)]
pub struct Recorder<T, W: Write> {
    inner: T,
    log: CandumpWriter<W>,
}

impl<T: CanTransport, W: Write> Recorder<T, W> {
    /// Record the traffic of `inner` into `log`.
    pub fn new(inner: T, log: CandumpWriter<W>) -> Self {
        Self { inner, log }
    }

    /// The transport and the log writer.
    pub fn into_parts(self) -> (T, CandumpWriter<W>) {
        (self.inner, self.log)
    }
}

impl<T: CanTransport, W: Write> CanTransport for Recorder<T, W> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        self.inner.send(frame)?;
        self.log
            .write(host_time_ns(), frame)
            .map_err(|e| TransportError::io("writing candump log", e))
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        let got = self.inner.recv(timeout)?;
        if let Some(f) = &got {
            self.log
                .write(f.time_ns, &f.frame)
                .map_err(|e| TransportError::io("writing candump log", e))?;
        }
        Ok(got)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_example() {
        let e = parse_candump_line("(1700000000.123456) can0 123#DEADBEEF").unwrap();
        assert_eq!(e.time_ns, 1_700_000_000_123_456_000);
        assert_eq!(e.iface, "can0");
        assert_eq!(
            e.frame,
            CanFrame::standard(0x123, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap()
        );
        assert_eq!(
            format_candump_line(e.time_ns, e.iface, &e.frame),
            "(1700000000.123456) can0 123#DEADBEEF"
        );
    }

    #[test]
    fn parses_variants() {
        let ext = parse_candump_line("(0000000001.000001)  vcan0  1ABCDEF0#01 T").unwrap();
        assert_eq!(
            ext.frame,
            CanFrame::new(CanId::Extended(0x1ABC_DEF0), &[1]).unwrap()
        );
        assert_eq!(ext.time_ns, 1_000_001_000);
        let rtr = parse_candump_line("(1.5) can0 7FF#R3").unwrap();
        assert_eq!(
            rtr.frame,
            CanFrame::remote(CanId::Standard(0x7FF), 3).unwrap()
        );
        assert_eq!(rtr.time_ns, 1_500_000_000);
        assert!(
            parse_candump_line("(1.0) can0 001#")
                .unwrap()
                .frame
                .data()
                .is_empty()
        );
        let dlc = parse_candump_line("(1.0) can0 001#0102030405060708_C").unwrap();
        assert_eq!(dlc.frame.dlc(), 8);
    }

    #[test]
    fn rejects_malformed_lines() {
        use LineError::*;
        for (line, why) in [
            ("1700000000.123456 can0 123#00", BadTimestamp),
            ("(17x.1) can0 123#00", BadTimestamp),
            ("(1.1234567890) can0 123#00", BadTimestamp),
            ("(99999999999999999999.1) can0 123#00", BadTimestamp),
            ("(1.0)", NoInterface),
            ("(1.0) can0", NoFrame),
            ("(1.0) can0 123", NoFrame),
            ("(1.0) can0 800#00", BadId),
            ("(1.0) can0 12#00", BadId),
            ("(1.0) can0 G23#00", BadId),
            ("(1.0) can0 123#0", BadData),
            ("(1.0) can0 123#ZZ", BadData),
            ("(1.0) can0 123#000102030405060708", TooLong),
            ("(1.0) can0 123#R9", BadData),
            ("(1.0) can0 123#00 extra", TrailingText),
            ("(1.0) can0 20000080#0000000000000000", ErrorFrame),
            ("(1.0) can0 123##1DEAD", CanFd),
            ("(1.0) can0 123#+1", BadData),
            ("(1.0) can0 123#é1", BadData),
        ] {
            assert_eq!(
                parse_candump_line(line).map(|e| e.frame),
                Err(why),
                "{line}"
            );
        }
    }

    #[test]
    fn reader_counts_and_keeps_going() {
        let mut text = b"(1.000000) can0 100#01\n\ngarbage\n(2.0) can1 101#02\r\n".to_vec();
        text.extend_from_slice(b"(3.0) can0 102#\xFF\xFE\n");
        text.extend_from_slice(format!("(4.0) can0 103#{}\n", "0".repeat(1000)).as_bytes());
        text.extend_from_slice(b"(5.0) can0 20000004#0000000000000000\n(6.0) can0 104#0405");
        let mut r = CandumpReader::new(&text[..]).with_iface("can0");
        let mut ids = vec![];
        while let Some(f) = r.next_frame().unwrap() {
            ids.push(f.frame.standard_id().unwrap());
        }
        assert_eq!(ids, [0x100, 0x104]);
        let s = r.stats();
        assert_eq!(
            (
                s.lines,
                s.frames,
                s.blank,
                s.other_iface,
                s.error_frames,
                s.malformed
            ),
            (8, 2, 1, 1, 1, 3)
        );
        let lines: Vec<u64> = s.first_malformed.iter().map(|m| m.line).collect();
        assert_eq!(lines, [3, 5, 6]);
        assert_eq!(s.first_malformed[1].reason, LineError::NotUtf8);
        assert_eq!(s.first_malformed[2].reason, LineError::LineTooLong);
        assert!(
            s.to_string()
                .contains("line 3: missing or malformed time stamp"),
            "{s}"
        );
    }
}
