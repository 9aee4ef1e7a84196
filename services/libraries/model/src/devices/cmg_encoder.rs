//! The CMG gimbal encoders: the gimbal angle to the encoder's resolution.

use super::quantise;
use crate::config::{CmgConfig, DEG};
use nalgebra::Vector4;

/// Encoders of the four gimbals.
///
/// Noise-free (an optical encoder's error is its quantisation). The angle is rounded to the
/// nearest count, i.e. the count centre is reported, so the error is zero-mean within ±½ count.
/// The angle is not wrapped: the smart CAN node tracks whole turns, so the reading is continuous
/// like the true gimbal angle.
#[derive(Debug, Clone)]
pub struct CmgEncoder {
    resolution_rad: f64,
}

impl CmgEncoder {
    /// The encoders of `config` (`encoder_resolution_deg`; 0 = ideal).
    pub fn new(config: &CmgConfig) -> Self {
        Self {
            resolution_rad: config.encoder_resolution_deg * DEG,
        }
    }

    /// One count, rad.
    pub fn resolution_rad(&self) -> f64 {
        self.resolution_rad
    }

    /// Measured gimbal angles, rad, from the true angles `gimbal_rad` (rad).
    pub fn sample(&self, gimbal_rad: &Vector4<f64>) -> Vector4<f64> {
        gimbal_rad.map(|a| quantise(a, self.resolution_rad))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reading_is_a_whole_count_within_half_a_count() {
        let config = CmgConfig::default();
        let enc = CmgEncoder::new(&config);
        let res = enc.resolution_rad();
        assert!((res / DEG - 360.0 / 65536.0).abs() < 1e-15);
        let truth = Vector4::new(0.1234567, -2.5, 7.0, 1e-9);
        let r = enc.sample(&truth);
        for i in 0..4 {
            let counts = r[i] / res;
            assert!((counts - counts.round()).abs() < 1e-9);
            assert!((r[i] - truth[i]).abs() <= 0.5 * res + 1e-15);
        }
        assert_eq!(r[3], 0.0);
        // Multi-turn: 7 rad is not wrapped to 7 − 2π.
        assert!(r[2] > 6.9);
    }
}
