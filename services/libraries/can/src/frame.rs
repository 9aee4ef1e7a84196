//! The crate's own classic-CAN frame type, independent of any transport.

use std::fmt;

/// Largest payload of a classic CAN frame, bytes.
pub const MAX_DATA_LEN: usize = 8;
/// Largest 11-bit (standard) identifier.
pub const MAX_STANDARD_ID: u16 = 0x7FF;
/// Largest 29-bit (extended) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// Flag bit of [`CanFrame::can_id`]: the identifier is a 29-bit extended one (as Linux `CAN_EFF_FLAG`).
pub const EXTENDED_FLAG: u32 = 0x8000_0000;
/// Flag bit of [`CanFrame::can_id`]: remote transmission request (as Linux `CAN_RTR_FLAG`).
pub const REMOTE_FLAG: u32 = 0x4000_0000;

/// A CAN identifier: 11-bit standard or 29-bit extended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CanId {
    /// 11-bit identifier, 0 to 0x7FF.
    Standard(u16),
    /// 29-bit identifier, 0 to 0x1FFF_FFFF.
    Extended(u32),
}

impl CanId {
    /// Whether the numeric value fits its kind.
    pub const fn is_valid(self) -> bool {
        match self {
            CanId::Standard(id) => id <= MAX_STANDARD_ID,
            CanId::Extended(id) => id <= MAX_EXTENDED_ID,
        }
    }

    /// The numeric identifier without flags.
    pub const fn raw(self) -> u32 {
        match self {
            CanId::Standard(id) => id as u32,
            CanId::Extended(id) => id,
        }
    }
}

impl fmt::Display for CanId {
    /// candump notation: 3 hex digits for standard, 8 for extended identifiers.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CanId::Standard(id) => write!(f, "{id:03X}"),
            CanId::Extended(id) => write!(f, "{id:08X}"),
        }
    }
}

/// Why a [`CanFrame`] could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The identifier does not fit 11 (standard) or 29 (extended) bits.
    #[error("CAN identifier {0:?} out of range")]
    BadId(CanId),
    /// More than 8 data bytes (or a remote-frame DLC above 8).
    #[error("CAN frame length {0} exceeds 8 bytes (classic CAN only)")]
    TooLong(usize),
}

/// One classic CAN 2.0 frame (data or remote), at most 8 data bytes.
///
/// A plain 16-byte value with no padding holes (`#[repr(C)]`: `can_id: u32`, `len: u8`,
/// 3 reserved zero bytes, `data: [u8; 8]`), the same shape as Linux `struct can_frame`, so a
/// shared-memory transport can carry it as a fixed-layout sample (see
/// [`crate::transport`]). Bytes of `data` beyond `len` are always zero, so equal frames compare
/// equal. Error frames are not represented: transports drop (and count) them.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(C)]
pub struct CanFrame {
    can_id: u32,
    len: u8,
    reserved: [u8; 3],
    data: [u8; 8],
}

impl CanFrame {
    /// A data frame; `data` at most 8 bytes.
    pub fn new(id: CanId, data: &[u8]) -> Result<Self, FrameError> {
        if !id.is_valid() {
            return Err(FrameError::BadId(id));
        }
        if data.len() > MAX_DATA_LEN {
            return Err(FrameError::TooLong(data.len()));
        }
        let mut bytes = [0u8; 8];
        bytes[..data.len()].copy_from_slice(data);
        let flag = if matches!(id, CanId::Extended(_)) {
            EXTENDED_FLAG
        } else {
            0
        };
        Ok(Self {
            can_id: id.raw() | flag,
            len: data.len() as u8,
            reserved: [0; 3],
            data: bytes,
        })
    }

    /// A data frame with an 11-bit identifier.
    pub fn standard(id: u16, data: &[u8]) -> Result<Self, FrameError> {
        Self::new(CanId::Standard(id), data)
    }

    /// A remote transmission request asking for `dlc` bytes (0 to 8); it carries no data.
    pub fn remote(id: CanId, dlc: u8) -> Result<Self, FrameError> {
        let mut frame = Self::new(id, &[])?;
        if usize::from(dlc) > MAX_DATA_LEN {
            return Err(FrameError::TooLong(usize::from(dlc)));
        }
        frame.can_id |= REMOTE_FLAG;
        frame.len = dlc;
        Ok(frame)
    }

    /// A frame from the Linux representation: `can_id` with [`EXTENDED_FLAG`] / [`REMOTE_FLAG`]
    /// (the error flag, bit 29, is refused as a bad identifier), `len` and the 8 data bytes
    /// (bytes past `len` are ignored).
    pub fn from_linux_parts(can_id: u32, len: u8, data: [u8; 8]) -> Result<Self, FrameError> {
        let id = if can_id & EXTENDED_FLAG != 0 {
            CanId::Extended(can_id & !(EXTENDED_FLAG | REMOTE_FLAG))
        } else {
            let raw = can_id & !REMOTE_FLAG;
            if raw > u32::from(MAX_STANDARD_ID) {
                return Err(FrameError::BadId(CanId::Extended(raw)));
            }
            CanId::Standard(raw as u16)
        };
        if can_id & REMOTE_FLAG != 0 {
            return Self::remote(id, len);
        }
        let n = usize::from(len);
        if n > MAX_DATA_LEN {
            return Err(FrameError::TooLong(n));
        }
        Self::new(id, &data[..n])
    }

    /// The identifier.
    pub const fn id(&self) -> CanId {
        if self.can_id & EXTENDED_FLAG != 0 {
            CanId::Extended(self.can_id & MAX_EXTENDED_ID)
        } else {
            CanId::Standard((self.can_id & MAX_STANDARD_ID as u32) as u16)
        }
    }

    /// Identifier with the Linux flag bits ([`EXTENDED_FLAG`], [`REMOTE_FLAG`]).
    pub const fn can_id(&self) -> u32 {
        self.can_id
    }

    /// The 11-bit identifier, or `None` for an extended one.
    pub const fn standard_id(&self) -> Option<u16> {
        match self.id() {
            CanId::Standard(id) => Some(id),
            CanId::Extended(_) => None,
        }
    }

    /// Whether the identifier is 29-bit.
    pub const fn is_extended(&self) -> bool {
        self.can_id & EXTENDED_FLAG != 0
    }

    /// Whether this is a remote transmission request.
    pub const fn is_remote(&self) -> bool {
        self.can_id & REMOTE_FLAG != 0
    }

    /// Data length code (0 to 8): payload length of a data frame, requested length of a remote one.
    pub const fn dlc(&self) -> u8 {
        self.len
    }

    /// The payload (empty for a remote frame).
    pub fn data(&self) -> &[u8] {
        if self.is_remote() {
            &[]
        } else {
            &self.data[..usize::from(self.len).min(MAX_DATA_LEN)]
        }
    }

    /// All 8 data bytes (zero past the payload).
    pub const fn data_padded(&self) -> [u8; 8] {
        self.data
    }
}

impl fmt::Display for CanFrame {
    /// candump notation without time stamp and interface: `123#DEADBEEF`, `123#R`, `123#R4`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}#", self.id())?;
        if self.is_remote() {
            f.write_str("R")?;
            if self.len > 0 {
                write!(f, "{}", self.len)?;
            }
            return Ok(());
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CanFrame({self})")
    }
}

/// Where a receive time stamp came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimeSource {
    /// The kernel's socket time stamp (SocketCAN `SO_TIMESTAMPNS`, CLOCK_REALTIME).
    Kernel,
    /// The time stamp written in a candump log.
    Log,
    /// Read by this process when the frame reached it (serial, in-memory; CLOCK_REALTIME).
    Host,
}

/// A received frame with the time it reached the computer.
///
/// The receive time is for diagnostics (latency, logs, replay pacing) only: the time a
/// measurement describes is the node's own time stamp inside the payload (see
/// [`crate::protocol`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TimestampedFrame {
    /// The frame.
    pub frame: CanFrame,
    /// Receive time, ns since the Unix epoch.
    pub time_ns: u64,
    /// Where `time_ns` came from.
    pub source: TimeSource,
}

/// The host's real-time clock, ns since the Unix epoch (0 if the clock is before 1970).
pub(crate) fn host_time_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_16_bytes() {
        assert_eq!(std::mem::size_of::<CanFrame>(), 16);
        assert_eq!(std::mem::align_of::<CanFrame>(), 4);
    }

    #[test]
    fn constructors_validate() {
        assert!(CanFrame::standard(0x7FF, &[1; 8]).is_ok());
        assert_eq!(
            CanFrame::standard(0x800, &[]),
            Err(FrameError::BadId(CanId::Standard(0x800)))
        );
        assert_eq!(CanFrame::standard(1, &[0; 9]), Err(FrameError::TooLong(9)));
        assert!(CanFrame::new(CanId::Extended(MAX_EXTENDED_ID), &[]).is_ok());
        assert!(CanFrame::new(CanId::Extended(MAX_EXTENDED_ID + 1), &[]).is_err());
        assert!(CanFrame::remote(CanId::Standard(1), 9).is_err());
    }

    #[test]
    fn display_is_candump_notation() {
        let f = CanFrame::standard(0x123, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap();
        assert_eq!(f.to_string(), "123#DEADBEEF");
        let r = CanFrame::remote(CanId::Extended(0x1234), 4).unwrap();
        assert_eq!(r.to_string(), "00001234#R4");
        assert!(r.data().is_empty());
        assert_eq!(r.dlc(), 4);
    }

    #[test]
    fn linux_parts_round_trip() {
        for f in [
            CanFrame::standard(0x7FF, &[1, 2, 3]).unwrap(),
            CanFrame::new(CanId::Extended(0x1ABCDEF), &[9; 8]).unwrap(),
            CanFrame::remote(CanId::Standard(5), 2).unwrap(),
        ] {
            let back = CanFrame::from_linux_parts(f.can_id(), f.dlc(), f.data_padded()).unwrap();
            assert_eq!(back, f);
        }
        assert!(CanFrame::from_linux_parts(0x800, 0, [0; 8]).is_err());
        assert!(CanFrame::from_linux_parts(0x1, 9, [0; 8]).is_err());
    }
}
