//! Sample types of the hop benchmark: the pipeline's own (gyro sample out, wheel command back,
//! 48 B each) and fixed-size blobs from 64 B to 64 KiB for the payload sweep.

use iceoryx2::prelude::ZeroCopySend;
use ipc_types::{SampleHeader, Topic};

/// Sequence number that ends a benchmark.
pub const STOP: u64 = u64::MAX;

/// A fixed-layout sample of `24 + N` bytes: the common header, then `N` bytes.
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub struct Blob<const N: usize, const DIR: u8> {
    pub header: SampleHeader,
    pub data: [u8; N],
}

impl<const N: usize, const DIR: u8> Default for Blob<N, DIR> {
    fn default() -> Self {
        Self { header: SampleHeader::default(), data: [0; N] }
    }
}

// SAFETY: repr(C), plain bytes after a plain header, no pointers; N is a multiple of 8 in every
// size used (checked in `size_is_exact`), so there is no padding. The type name includes N and
// the direction, so iceoryx2 refuses a mismatched peer.
unsafe impl<const N: usize, const DIR: u8> ZeroCopySend for Blob<N, DIR> {}

/// Outgoing (ping) blobs.
pub type Ping<const N: usize> = Blob<N, 0>;
/// Returning (pong) blobs.
pub type Pong<const N: usize> = Blob<N, 1>;

impl<const N: usize> Topic for Blob<N, 0> {
    const NAME: &'static str = "bench/hop/ping";
    const EVENT_NAME: &'static str = "bench/hop/ping/event";
    fn header(&self) -> &SampleHeader {
        &self.header
    }
    fn header_mut(&mut self) -> &mut SampleHeader {
        &mut self.header
    }
}

impl<const N: usize> Topic for Blob<N, 1> {
    const NAME: &'static str = "bench/hop/pong";
    const EVENT_NAME: &'static str = "bench/hop/pong/event";
    fn header(&self) -> &SampleHeader {
        &self.header
    }
    fn header_mut(&mut self) -> &mut SampleHeader {
        &mut self.header
    }
}

/// The bytes of a plain sample.
pub fn bytes_of<T: Copy>(value: &T) -> &[u8] {
    // SAFETY: the samples are repr(C) plain data without padding; any byte view is valid.
    unsafe { std::slice::from_raw_parts((value as *const T).cast::<u8>(), std::mem::size_of::<T>()) }
}

/// The bytes of a plain sample, writable (every bit pattern is a valid sample).
pub fn bytes_of_mut<T: Copy>(value: &mut T) -> &mut [u8] {
    // SAFETY: as above; the sample types hold only integers, floats and byte arrays, for which
    // every bit pattern is valid.
    unsafe { std::slice::from_raw_parts_mut((value as *mut T).cast::<u8>(), std::mem::size_of::<T>()) }
}

/// A sample of `T` with sequence `seq` and every payload byte set (so the whole sample is
/// really written and copied).
pub fn filled<T: Topic>(seq: u64) -> T {
    let mut value = T::default();
    for (i, b) in bytes_of_mut(&mut value).iter_mut().enumerate() {
        *b = (i as u8).wrapping_mul(31);
    }
    *value.header_mut() = SampleHeader::new(seq, seq, SampleHeader::VALID);
    value
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_is_exact() {
        assert_eq!(std::mem::size_of::<Ping<40>>(), 64);
        assert_eq!(std::mem::size_of::<Pong<65_512>>(), 65_536);
        assert_eq!(std::mem::size_of::<ipc_types::GyroSample>(), 48);
        assert_eq!(std::mem::size_of::<ipc_types::WheelCommand>(), 48);
        let s: Ping<40> = filled(7);
        assert_eq!(s.header.sequence, 7);
        assert_eq!(bytes_of(&s).len(), 64);
    }
}
