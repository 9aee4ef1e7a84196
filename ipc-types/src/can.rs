use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// Who put a frame on the software CAN bus ([`CanBusFrame`]) or whose link a
/// [`CanLinkStatus`] describes: the value of `header.source_id`.
pub mod can_source {
    /// The smart CAN node (real or simulated).
    pub const NODE: u32 = 1;
    /// The gyro gateway.
    pub const GYRO: u32 = 2;
    /// The inclinometer gateway.
    pub const INCLINOMETER: u32 = 3;
    /// The magnetometer gateway.
    pub const MAGNETOMETER: u32 = 4;
    /// The reaction wheel gateway.
    pub const WHEELS: u32 = 5;
    /// The CMG gateway.
    pub const CMG: u32 = 6;
    /// A replay of a recorded bus (`candump -L` file).
    pub const REPLAY: u32 = 7;
    /// The thruster gateway.
    pub const THRUSTERS: u32 = 8;
}

/// One classic CAN 2.0 frame on the software CAN bus (iceoryx2 instead of a kernel CAN
/// interface), as one sender put it on the bus.
///
/// Bytes 24 to 39 are the frame in the shape of Linux `struct can_frame` (and of
/// `testbed_can::CanFrame`): `can_id` with the `EXTENDED` (bit 31) and `REMOTE` (bit 30) flags,
/// `len`, three zero bytes, `data` (zero past `len`). `check` is the sender's frame check
/// sequence over those 16 bytes (CRC-15/CAN, see `testbed_gateways`); a receiver drops a frame
/// whose check does not match, as every CAN controller drops a frame that fails its CRC.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::CanBusFrame.v1")
)]
#[repr(C)]
pub struct CanBusFrame {
    /// Common header; `time_ns` is the run-clock time the sender put the frame on the bus,
    /// `sequence` counts the sender's frames, `source_id` is the sender ([`can_source`]).
    pub header: SampleHeader,
    /// Identifier with the Linux flag bits: 11-bit (standard) or 29-bit (with bit 31) id,
    /// bit 30 remote transmission request.
    pub can_id: u32,
    /// Data length code, 0 to 8.
    pub len: u8,
    /// Padding, always zero.
    pub _pad0: u8,
    /// Padding, always zero.
    pub _pad1: u16,
    /// Payload; bytes past `len` are zero.
    pub data: [u8; 8],
    /// Frame check sequence (CRC-15/CAN in the low 15 bits) over bytes 24 to 39.
    pub check: u32,
    /// Padding, always zero.
    pub _pad2: u32,
}

/// Reaction wheel motor torques as the smart CAN node applies them (CAN actuation path).
///
/// The plant of a `run.actuation = "can_node"` run takes these instead of the controller's
/// [`WheelCommand`](crate::WheelCommand): what reaches the wheels is what came over the bus.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::AppliedWheelCommand.v1")
)]
#[repr(C)]
pub struct AppliedWheelCommand {
    /// Common header; `time_ns` is the tick the command is applied for. `STALE`: no complete,
    /// valid command arrived for this tick and the node holds the previous one (or zero after
    /// its command time-out).
    pub header: SampleHeader,
    /// Motor torque on each wheel, about its axis, Nm. The platform feels the opposite torque.
    pub torque: [f64; 3],
}

/// CMG gimbal rates as the smart CAN node applies them (CAN actuation path); see
/// [`AppliedWheelCommand`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::AppliedCmgCommand.v1")
)]
#[repr(C)]
pub struct AppliedCmgCommand {
    /// Common header; as [`AppliedWheelCommand::header`].
    pub header: SampleHeader,
    /// Gimbal rates, rad/s.
    pub gimbal_rate: [f64; 4],
}

/// Frame and error counters of one CAN link: a gateway's, or the smart CAN node's.
///
/// All counts are totals since start. Published by gateways and the simulated node when a
/// count changed and at least once a second of run time, stamped with the latest tick (or
/// sample) time, so a lockstep log holds them deterministically.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::CanLinkStatus.v1")
)]
#[repr(C)]
pub struct CanLinkStatus {
    /// Common header; `source_id` names the link ([`can_source`]).
    pub header: SampleHeader,
    /// Frames of this link's device decoded and used.
    pub frames_ok: u64,
    /// Frames rejected: `crc_errors + wrong_dlc + unknown_id + duplicates + late_frames`.
    pub frames_bad: u64,
    /// Frames dropped because their frame check failed (corrupted on the bus); every receiver
    /// counts every such frame, whatever its identifier claims.
    pub crc_errors: u64,
    /// Frames of the map with the wrong data length.
    pub wrong_dlc: u64,
    /// Frames outside the identifier map (or extended / remote).
    pub unknown_id: u64,
    /// Repeated frames (same rolling counter again).
    pub duplicates: u64,
    /// Frames missed, from rolling-counter jumps.
    pub lost_frames: u64,
    /// Multi-frame samples abandoned incomplete.
    pub incomplete_samples: u64,
    /// Frames that arrived after their tick's deadline (the node's tick sync); not used.
    pub late_frames: u64,
    /// Frames holding a value beyond the device range (used, clipped, flagged saturated).
    pub out_of_range: u64,
    /// Samples published without `VALID` (flagged `STALE`) because no complete sample had
    /// arrived by the tick's deadline.
    pub stale_samples: u64,
    /// Frames this end sent.
    pub frames_sent: u64,
    /// Commands with at least one channel clamped to its limit before sending.
    pub commands_clamped: u64,
    /// Commands refused (non-finite, or not `VALID`); the safe command (zero) went out instead.
    pub commands_refused: u64,
    /// Transport errors (send or receive failed).
    pub transport_errors: u64,
    /// Simulated node: frames it sent that it dropped (fault injection).
    pub injected_tx_drop: u64,
    /// Simulated node: frames it sent corrupted (frame check no longer matches).
    pub injected_tx_corrupt: u64,
    /// Simulated node: frames it sent late (after the tick's sync frame).
    pub injected_tx_delay: u64,
    /// Simulated node: frames it sent twice.
    pub injected_tx_duplicate: u64,
    /// Simulated node: received command frames it dropped.
    pub injected_rx_drop: u64,
    /// Simulated node: received command frames it corrupted.
    pub injected_rx_corrupt: u64,
    /// Simulated node: received command frames it delayed to the next tick.
    pub injected_rx_delay: u64,
    /// Simulated node: received command frames it duplicated.
    pub injected_rx_duplicate: u64,
}
