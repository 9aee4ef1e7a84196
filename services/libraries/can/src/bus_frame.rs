//! [`CanFrame`] ↔ [`ipc_types::CanBusFrame`]: the frame as a sample of the software CAN bus,
//! with its frame check.
//!
//! A real CAN controller appends a 15-bit CRC to every frame and every receiver drops a frame
//! whose CRC does not match (it never reaches software; the controller counts a receive
//! error). The software bus keeps that property: the sender stores [`frame_check`] of the
//! frame's 16 bytes in `CanBusFrame::check`, and [`CanFrame::from_bus_frame`] refuses a sample
//! whose check does not match ([`BusFrameError::Check`]), so a frame corrupted on the bus (the
//! simulated node's fault injection) is detected and counted by every receiver, exactly as on
//! the platform.

use crate::frame::CanFrame;
use ipc_types::{CanBusFrame, SampleHeader};

/// Why a [`CanBusFrame`] sample is not a usable frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BusFrameError {
    /// The frame check does not match the frame: corrupted on the bus.
    #[error("frame check mismatch (sent {sent:#06x}, computed {computed:#06x}): corrupted frame")]
    Check {
        /// The check the sample carries.
        sent: u32,
        /// The check of the sample's bytes.
        computed: u32,
    },
    /// The check matches but the fields are not a valid classic CAN frame.
    #[error("not a valid CAN frame: {0}")]
    Invalid(#[from] crate::frame::FrameError),
}

/// CRC-15/CAN (polynomial 0x4599, initial value 0, MSB first, no final xor) of `bytes`.
pub fn crc15(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &byte in bytes {
        for bit in (0..8).rev() {
            let next = ((byte >> bit) & 1) as u16 ^ ((crc >> 14) & 1);
            crc = (crc << 1) & 0x7FFF;
            if next != 0 {
                crc ^= 0x4599;
            }
        }
    }
    crc
}

/// The 16 bytes the check covers: `can_id` (little-endian), `len`, three zero bytes, `data`.
fn checked_bytes(can_id: u32, len: u8, data: &[u8; 8]) -> [u8; 16] {
    let mut bytes = [0u8; 16];
    bytes[..4].copy_from_slice(&can_id.to_le_bytes());
    bytes[4] = len;
    bytes[8..].copy_from_slice(data);
    bytes
}

/// The frame check of a sample's frame fields (what `check` must hold).
pub fn frame_check(sample: &CanBusFrame) -> u32 {
    u32::from(crc15(&checked_bytes(
        sample.can_id,
        sample.len,
        &sample.data,
    )))
}

impl CanFrame {
    /// The frame as a software-bus sample with `header`, its check computed.
    pub fn to_bus_frame(&self, header: SampleHeader) -> CanBusFrame {
        let mut sample = CanBusFrame {
            header,
            can_id: self.can_id(),
            len: self.dlc(),
            data: self.data_padded(),
            ..CanBusFrame::default()
        };
        sample.check = frame_check(&sample);
        sample
    }

    /// The frame of a software-bus sample: the check must match, and the fields must make a
    /// valid frame.
    pub fn from_bus_frame(sample: &CanBusFrame) -> Result<Self, BusFrameError> {
        let computed = frame_check(sample);
        if computed != sample.check {
            return Err(BusFrameError::Check {
                sent: sample.check,
                computed,
            });
        }
        Ok(CanFrame::from_linux_parts(
            sample.can_id,
            sample.len,
            sample.data,
        )?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc15_check_value() {
        // CRC-15/CAN check value for "123456789".
        assert_eq!(crc15(b"123456789"), 0x059E);
    }

    #[test]
    fn frames_round_trip_and_every_single_bit_flip_is_detected() {
        let frame = CanFrame::standard(0x121, &[7, 1, 2, 3, 4, 5, 6, 0xFF]).unwrap();
        let sample = frame.to_bus_frame(SampleHeader::new(100, 3, SampleHeader::VALID));
        assert_eq!(CanFrame::from_bus_frame(&sample), Ok(frame));
        for byte in 0..13 {
            for bit in 0..8 {
                let mut bad = sample;
                match byte {
                    0..4 => bad.can_id ^= 1 << (8 * byte + bit),
                    4 => bad.len ^= 1 << bit,
                    _ => bad.data[byte - 5] ^= 1 << bit,
                }
                assert!(
                    matches!(
                        CanFrame::from_bus_frame(&bad),
                        Err(BusFrameError::Check { .. })
                    ),
                    "byte {byte} bit {bit}"
                );
            }
        }
        let mut invalid = sample;
        invalid.len = 9;
        invalid.check = frame_check(&invalid);
        assert!(matches!(
            CanFrame::from_bus_frame(&invalid),
            Err(BusFrameError::Invalid(_))
        ));
    }
}
