//! Commands from the ground supervision station and their acknowledgements.
//!
//! The ground link publishes every command it accepted from a viewer as a [`GroundCommand`]
//! (`testbed/ground/command`); the controller, the only process that subscribes to it, applies
//! it and answers with a [`GroundCommandAck`] (`testbed/ground/command_ack`). A command the link
//! itself refuses (wrong token, out of limits, rate-limited, malformed) never reaches the bus as
//! a command: the link publishes only its rejection. Both topics are in the run log.

use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// What a [`GroundCommand`] asks for, stored as `u32` in [`GroundCommand::kind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum GroundCommandKind {
    /// Not a known kind (a zeroed sample).
    #[default]
    Unknown = 0,
    /// Change the controller mode to [`GroundCommand::mode`] (a `ControllerMode` wire value).
    Mode = 1,
    /// Hold a new target attitude ([`GroundCommand::target_heading_rad`], pitch, roll).
    Target = 2,
    /// Start an identification experiment.
    ExperimentStart = 3,
    /// Abort the running identification experiment.
    ExperimentAbort = 4,
}

impl GroundCommandKind {
    /// The kind with wire value `value`, if any.
    pub const fn from_u32(value: u32) -> Option<Self> {
        Some(match value {
            0 => Self::Unknown,
            1 => Self::Mode,
            2 => Self::Target,
            3 => Self::ExperimentStart,
            4 => Self::ExperimentAbort,
            _ => return None,
        })
    }

    /// The name used on the ground link's JSON commands.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Unknown => "unknown",
            Self::Mode => "mode",
            Self::Target => "target",
            Self::ExperimentStart => "experiment_start",
            Self::ExperimentAbort => "experiment_abort",
        }
    }
}

/// One command from the ground, accepted by the ground link (token, limits and rate checked).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::GroundCommand.v1")
)]
#[repr(C)]
pub struct GroundCommand {
    /// Common header; `time_ns` is the run's clock as the link last saw it (its newest
    /// sample time), `sequence` counts the link's commands.
    pub header: SampleHeader,
    /// [`GroundCommandKind`] as `u32`.
    pub kind: u32,
    /// With [`GroundCommandKind::Mode`]: the `ControllerMode` wire value asked for.
    pub mode: u32,
    /// With [`GroundCommandKind::Target`]: target heading (rotation about level z), rad.
    pub target_heading_rad: f64,
    /// With [`GroundCommandKind::Target`]: target tilt about body y (pitch), rad.
    pub target_pitch_rad: f64,
    /// With [`GroundCommandKind::Target`]: target tilt about body x (roll), rad.
    pub target_roll_rad: f64,
    /// The identifier the viewer gave the command (echoed in the acknowledgement).
    pub command_id: u64,
    /// The link's number for the viewer's connection (1, 2, …).
    pub client_id: u32,
    /// Padding, always zero.
    pub _pad0: u32,
}

impl GroundCommand {
    /// The kind, or `None` for an unknown wire value.
    pub const fn kind(&self) -> Option<GroundCommandKind> {
        GroundCommandKind::from_u32(self.kind)
    }
}

/// The outcome of a ground command, stored as `u32` in [`GroundCommandAck::status`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum GroundAckStatus {
    /// Not a known status (a zeroed sample).
    #[default]
    Unknown = 0,
    /// The controller applied the command.
    Applied = 1,
    /// Refused; [`GroundCommandAck::reason`] says why.
    Rejected = 2,
}

impl GroundAckStatus {
    /// The status with wire value `value`, if any.
    pub const fn from_u32(value: u32) -> Option<Self> {
        Some(match value {
            0 => Self::Unknown,
            1 => Self::Applied,
            2 => Self::Rejected,
            _ => return None,
        })
    }
}

/// The answer to one ground command: applied by the controller, or rejected (by the link or
/// the controller) with the reason.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::GroundCommandAck.v2")
)]
#[repr(C)]
pub struct GroundCommandAck {
    /// Common header; `time_ns` is the run's clock of the decision (the controller's tick the
    /// command took effect at, or the link's newest sample time).
    pub header: SampleHeader,
    /// The command's [`GroundCommand::command_id`] (0 if the message had none).
    pub command_id: u64,
    /// The command's [`GroundCommandKind`] as `u32` (0 if it could not be read).
    pub kind: u32,
    /// [`GroundAckStatus`] as `u32`.
    pub status: u32,
    /// The viewer's connection ([`GroundCommand::client_id`]).
    pub client_id: u32,
    /// Who decided: 1 the ground link, 2 the controller.
    pub decided_by: u32,
    /// Why it was rejected (or what was applied), UTF-8, NUL-padded.
    pub reason: [u8; GroundCommandAck::REASON_LEN],
}

impl Default for GroundCommandAck {
    fn default() -> Self {
        Self {
            header: SampleHeader::default(),
            command_id: 0,
            kind: 0,
            status: 0,
            client_id: 0,
            decided_by: 0,
            reason: [0; Self::REASON_LEN],
        }
    }
}

impl GroundCommandAck {
    /// Bytes of [`reason`](Self::reason): room for the longest reason the link and the
    /// controller give, a malformed command's (about 110 bytes, up to 210 when it quotes 32
    /// characters of the sender's multi-byte text) with margin. 64 (`.v1`) cut them short.
    pub const REASON_LEN: usize = 256;
    /// [`decided_by`](Self::decided_by): the ground link.
    pub const BY_LINK: u32 = 1;
    /// [`decided_by`](Self::decided_by): the controller.
    pub const BY_CONTROLLER: u32 = 2;

    /// An acknowledgement of `command_id`, its reason truncated at a character boundary to
    /// [`REASON_LEN`](Self::REASON_LEN) bytes.
    pub fn new(
        header: SampleHeader,
        command_id: u64,
        kind: u32,
        status: GroundAckStatus,
        client_id: u32,
        decided_by: u32,
        reason: &str,
    ) -> Self {
        let mut ack = Self {
            header,
            command_id,
            kind,
            status: status as u32,
            client_id,
            decided_by,
            reason: [0; Self::REASON_LEN],
        };
        let mut len = reason.len().min(ack.reason.len());
        while !reason.is_char_boundary(len) {
            len -= 1;
        }
        ack.reason[..len].copy_from_slice(&reason.as_bytes()[..len]);
        ack
    }

    /// The status, or `None` for an unknown wire value.
    pub const fn status(&self) -> Option<GroundAckStatus> {
        GroundAckStatus::from_u32(self.status)
    }

    /// The reason: bytes up to the first NUL, cut at the first invalid UTF-8 byte.
    pub fn reason(&self) -> &str {
        let len = self
            .reason
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(self.reason.len());
        let bytes = &self.reason[..len];
        match core::str::from_utf8(bytes) {
            Ok(s) => s,
            Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layouts_are_pinned_without_implicit_padding() {
        assert_eq!(size_of::<GroundCommand>(), 72);
        assert_eq!(offset_of!(GroundCommand, kind), 24);
        assert_eq!(offset_of!(GroundCommand, target_heading_rad), 32);
        assert_eq!(offset_of!(GroundCommand, command_id), 56);
        assert_eq!(offset_of!(GroundCommand, _pad0), 68);
        assert_eq!(size_of::<GroundCommandAck>(), 304);
        assert_eq!(offset_of!(GroundCommandAck, command_id), 24);
        assert_eq!(offset_of!(GroundCommandAck, decided_by), 44);
        assert_eq!(offset_of!(GroundCommandAck, reason), 48);
    }

    #[test]
    fn an_ack_keeps_its_reason_cut_at_a_character_boundary() {
        let long = "é".repeat(140);
        let ack = GroundCommandAck::new(
            SampleHeader::default(),
            7,
            1,
            GroundAckStatus::Rejected,
            1,
            GroundCommandAck::BY_LINK,
            &long,
        );
        assert_eq!(ack.reason(), "é".repeat(128));
        assert_eq!(ack.status(), Some(GroundAckStatus::Rejected));
        for v in 0..6 {
            assert_eq!(
                GroundCommandKind::from_u32(v).map(|k| k as u32),
                (v < 5).then_some(v)
            );
        }
    }
}
