#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// Header common to every sample (24 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::SampleHeader.v1")
)]
#[repr(C)]
pub struct SampleHeader {
    /// Time of validity: the instant the sample describes, ns on the run's clock (device time
    /// on hardware, simulation time in simulation). Never the wall clock at publication.
    pub time_ns: u64,
    /// Per-publisher sequence number, incremented by one for every published sample.
    pub sequence: u64,
    /// Bit set of the `SampleHeader` flag constants ([`VALID`](Self::VALID), ...).
    pub flags: u32,
    /// Identifier of the producing instance (device or simulated device), 0 if there is one.
    pub source_id: u32,
}

impl SampleHeader {
    /// The sample's data may be used. Unset: the fields are undefined and must be ignored.
    pub const VALID: u32 = 1 << 0;
    /// Channel 0 (x axis) was saturated by the device, or clipped to its range by a gateway.
    pub const SATURATED_X: u32 = Self::saturated(0);
    /// Channel 1 (y axis) saturated or clipped.
    pub const SATURATED_Y: u32 = Self::saturated(1);
    /// Channel 2 (z axis) saturated or clipped.
    pub const SATURATED_Z: u32 = Self::saturated(2);
    /// Channel 3 (4th CMG gimbal) saturated or clipped.
    pub const SATURATED_4: u32 = Self::saturated(3);
    /// Any channel saturated or clipped.
    pub const SATURATED_ANY: u32 =
        Self::SATURATED_X | Self::SATURATED_Y | Self::SATURATED_Z | Self::SATURATED_4;
    /// A value was outside its plausible range and was rejected (see [`VALID`](Self::VALID)).
    pub const OUT_OF_RANGE: u32 = 1 << 5;
    /// The data is a repeat of an older measurement (no fresh device data arrived in time).
    pub const STALE: u32 = 1 << 8;
    /// The sample comes from a simulated device or the simulation plant.
    pub const SIMULATED: u32 = 1 << 9;
    /// The sample is replayed from a log.
    pub const REPLAYED: u32 = 1 << 10;

    /// Saturation flag of data channel `channel` (0 to 3).
    pub const fn saturated(channel: u32) -> u32 {
        assert!(channel < 4, "saturation flags exist for channels 0 to 3");
        1 << (1 + channel)
    }

    /// A header with `source_id` 0.
    pub const fn new(time_ns: u64, sequence: u64, flags: u32) -> Self {
        Self {
            time_ns,
            sequence,
            flags,
            source_id: 0,
        }
    }

    /// The same header with `source_id` replaced.
    pub const fn with_source(self, source_id: u32) -> Self {
        Self { source_id, ..self }
    }

    /// Whether every bit of `flags` is set.
    pub const fn has(&self, flags: u32) -> bool {
        self.flags & flags == flags
    }

    /// Whether [`VALID`](Self::VALID) is set.
    pub const fn is_valid(&self) -> bool {
        self.has(Self::VALID)
    }

    /// Sets (`on`) or clears the bits of `flags`.
    pub const fn set(&mut self, flags: u32, on: bool) {
        if on {
            self.flags |= flags;
        } else {
            self.flags &= !flags;
        }
    }
}
