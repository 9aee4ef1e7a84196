use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// One sample of the three fibre-optic gyros (10 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::GyroSample.v1")
)]
#[repr(C)]
pub struct GyroSample {
    /// Common header; `time_ns` is the device's sampling instant.
    pub header: SampleHeader,
    /// Measured angular rate of B against inertial space, body axes, rad/s, as the gyros sense
    /// it: including bias, noise and the Earth's rotation.
    pub rate: [f64; 3],
}

impl GyroSample {
    /// A sample from its parts.
    pub const fn new(header: SampleHeader, rate: [f64; 3]) -> Self {
        Self { header, rate }
    }
}

/// One sample of the two-axis inclinometer (2.5 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::InclinometerSample.v1")
)]
#[repr(C)]
pub struct InclinometerSample {
    /// Common header; `time_ns` is the device's sampling instant.
    pub header: SampleHeader,
    /// Measured tilt angles `[θ, φ]` of body x and body y against the level plane, rad, defined
    /// by the body components of gravity `G_B = [sin θ, sin φ, −√(1 − sin²θ − sin²φ)]`.
    pub tilt: [f64; 2],
}

impl InclinometerSample {
    /// A sample from its parts.
    pub const fn new(header: SampleHeader, tilt: [f64; 2]) -> Self {
        Self { header, tilt }
    }
}

/// One sample of the three-axis magnetometer (2.5 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::MagnetometerSample.v1")
)]
#[repr(C)]
pub struct MagnetometerSample {
    /// Common header; `time_ns` is the device's sampling instant.
    pub header: SampleHeader,
    /// Measured magnetic flux density, body axes, tesla (1 gauss = 1e-4 T).
    pub field: [f64; 3],
}

impl MagnetometerSample {
    /// A sample from its parts.
    pub const fn new(header: SampleHeader, field: [f64; 3]) -> Self {
        Self { header, field }
    }
}
