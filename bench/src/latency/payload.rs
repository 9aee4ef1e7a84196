//! Sample types and their bytes. Over the bus a sample goes as itself; over a socket it goes
//! as its plain-bytes twin, a [`Pod`] type of the bench (the pipeline's sample types in
//! `ipc-types` are not `Pod`, so the bench copies them field by field into and out of the twin
//! instead of viewing their memory as bytes).
//!
//! The hop sends the pipeline's own samples (gyro sample out, wheel command back, 48 B each);
//! the payload sweep sends [`Blob`]s from 64 B to 64 KiB.

use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::ZeroCopySend;
use ipc_types::*;

/// Sequence number that ends a hop benchmark.
pub const STOP: u64 = u64::MAX;

/// [`SampleHeader`] as plain bytes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct WireHeader {
    pub time_ns: u64,
    pub sequence: u64,
    pub flags: u32,
    pub source_id: u32,
}

impl From<SampleHeader> for WireHeader {
    fn from(h: SampleHeader) -> Self {
        Self {
            time_ns: h.time_ns,
            sequence: h.sequence,
            flags: h.flags,
            source_id: h.source_id,
        }
    }
}

impl From<WireHeader> for SampleHeader {
    fn from(h: WireHeader) -> Self {
        Self {
            time_ns: h.time_ns,
            sequence: h.sequence,
            flags: h.flags,
            source_id: h.source_id,
        }
    }
}

/// A sample with a plain-bytes twin for sockets. Every twin starts with its [`WireHeader`].
pub trait Payload: Topic {
    type Wire: Pod;
    fn to_wire(&self) -> Self::Wire;
    fn from_wire(wire: &Self::Wire) -> Self;
}

/// The header at the start of a twin's bytes.
pub fn header_of(bytes: &[u8]) -> WireHeader {
    bytemuck::pod_read_unaligned(&bytes[..size_of::<WireHeader>()])
}

/// Sets the sequence number in a twin's bytes.
pub fn set_sequence<W: Pod>(wire: &mut W, sequence: u64) {
    let bytes = bytemuck::bytes_of_mut(wire);
    let mut header = header_of(bytes);
    header.sequence = sequence;
    bytes[..size_of::<WireHeader>()].copy_from_slice(bytemuck::bytes_of(&header));
}

/// Twins of the pipeline's sample types: the same fields after the header, copied one by one.
macro_rules! twins {
    ($($sample:ident => $wire:ident { $($field:ident: $ty:ty),* $(,)? })*) => {$(
        #[doc = concat!("[`", stringify!($sample), "`] as plain bytes.")]
        #[derive(Debug, Clone, Copy, Pod, Zeroable)]
        #[repr(C)]
        pub struct $wire {
            pub header: WireHeader,
            $(pub $field: $ty,)*
        }

        impl Payload for $sample {
            type Wire = $wire;
            fn to_wire(&self) -> $wire {
                $wire { header: self.header.into(), $($field: self.$field),* }
            }
            fn from_wire(w: &$wire) -> Self {
                Self { header: w.header.into(), $($field: w.$field),* }
            }
        }
    )*};
}

twins! {
    GyroSample => GyroWire { rate: [f64; 3] }
    InclinometerSample => TiltWire { tilt: [f64; 2] }
    MagnetometerSample => FieldWire { field: [f64; 3] }
    AttitudeEstimate => EstimateWire {
        quaternion: [f64; 4], rate: [f64; 3], gyro_bias: [f64; 3], covariance: [f64; 36], innovation: [f64; 6],
        innovation_time_ns: u64, innovation_mask: u32, _pad0: u32, updates_applied: u64, updates_skipped: u64,
        updates_rejected: u64,
    }
    WheelTelemetry => WheelTmWire { speed: [f64; 3], torque: [f64; 3] }
    CmgTelemetry => CmgTmWire { gimbal_angle: [f64; 4], gimbal_rate: [f64; 4] }
    ControllerStatus => StatusWire {
        mode: u32, _pad0: u32, attitude_error: [f64; 3], torque_command: [f64; 3], deadline_misses: u64,
        loop_period_ns: u64, compute_time_ns: u64,
    }
    WheelCommand => WheelCmdWire { torque: [f64; 3] }
    CmgCommand => CmgCmdWire { gimbal_rate: [f64; 4] }
}

/// A fixed-layout sample of `24 + N` bytes for the bus: the common header, then `N` bytes.
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub struct Blob<const N: usize, const DIR: u8> {
    pub header: SampleHeader,
    pub data: [u8; N],
}

impl<const N: usize, const DIR: u8> Default for Blob<N, DIR> {
    fn default() -> Self {
        Self {
            header: SampleHeader::default(),
            data: [0; N],
        }
    }
}

// SAFETY: repr(C), plain bytes after a plain header, no pointers. The type name includes N and
// the direction, so iceoryx2 refuses a mismatched peer.
unsafe impl<const N: usize, const DIR: u8> ZeroCopySend for Blob<N, DIR> {}

/// Outgoing (ping) blobs.
pub type Ping<const N: usize> = Blob<N, 0>;
/// Returning (pong) blobs.
pub type Pong<const N: usize> = Blob<N, 1>;

impl<const N: usize> Topic for Blob<N, 0> {
    const NAME: &'static str = "bench/hop/ping";
    fn header(&self) -> &SampleHeader {
        &self.header
    }
    fn header_mut(&mut self) -> &mut SampleHeader {
        &mut self.header
    }
}

impl<const N: usize> Topic for Blob<N, 1> {
    const NAME: &'static str = "bench/hop/pong";
    fn header(&self) -> &SampleHeader {
        &self.header
    }
    fn header_mut(&mut self) -> &mut SampleHeader {
        &mut self.header
    }
}

/// Twins of the blobs, one per size of the sweep (`Pod` cannot be derived for a generic type).
macro_rules! blob_twins {
    ($($wire:ident: $n:literal),*) => {$(
        #[doc = concat!("A blob of ", stringify!($n), " bytes after the header, as plain bytes.")]
        #[derive(Debug, Clone, Copy, Pod, Zeroable)]
        #[repr(C)]
        pub struct $wire {
            pub header: WireHeader,
            pub data: [u8; $n],
        }

        impl<const DIR: u8> Payload for Blob<$n, DIR>
        where
            Self: Topic,
        {
            type Wire = $wire;
            fn to_wire(&self) -> $wire {
                $wire { header: self.header.into(), data: self.data }
            }
            fn from_wire(w: &$wire) -> Self {
                Self { header: w.header.into(), data: w.data }
            }
        }
    )*};
}

blob_twins!(Blob64Wire: 40, Blob1KWire: 1000, Blob8KWire: 8168, Blob64KWire: 65_512);

/// The twin of a sample of `T` with sequence `seq` and every byte after the header set (so the
/// whole sample is really written and copied).
pub fn filled<T: Payload>(seq: u64) -> T::Wire {
    let mut wire = T::Wire::zeroed();
    for (i, b) in bytemuck::bytes_of_mut(&mut wire).iter_mut().enumerate() {
        *b = (i as u8).wrapping_mul(31);
    }
    let header = WireHeader::from(SampleHeader::new(seq, seq, SampleHeader::VALID));
    bytemuck::bytes_of_mut(&mut wire)[..size_of::<WireHeader>()]
        .copy_from_slice(bytemuck::bytes_of(&header));
    wire
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twins_have_the_samples_sizes_and_round_trip() {
        assert_eq!(size_of::<Ping<40>>(), 64);
        assert_eq!(size_of::<Blob64Wire>(), 64);
        assert_eq!(size_of::<Blob64KWire>(), 65_536);
        assert_eq!(size_of::<GyroWire>(), size_of::<GyroSample>());
        assert_eq!(size_of::<EstimateWire>(), size_of::<AttitudeEstimate>());
        assert_eq!(size_of::<StatusWire>(), size_of::<ControllerStatus>());
        let wire = filled::<Ping<40>>(7);
        assert_eq!(header_of(bytemuck::bytes_of(&wire)).sequence, 7);
        let blob = Ping::<40>::from_wire(&wire);
        assert_eq!(blob.header.sequence, 7);
        assert_eq!(
            bytemuck::bytes_of(&blob.to_wire()),
            bytemuck::bytes_of(&wire)
        );
        let mut w = filled::<GyroSample>(1);
        set_sequence(&mut w, 9);
        assert_eq!(GyroSample::from_wire(&w).header.sequence, 9);
    }
}
