//! Conversions between the library's nalgebra types and the fixed-layout samples.

use ipc_types::SampleHeader;
use nalgebra::{Quaternion, UnitQuaternion, Vector3, Vector4};
use testbed_model::attitude::Attitude;

/// Scalar-last `[x, y, z, w]`, as `ipc-types` documents.
pub fn quaternion_to_array(q: &Attitude) -> [f64; 4] {
    let c = q.coords;
    [c.x, c.y, c.z, c.w]
}

/// `None` for a zero or non-finite quaternion (an invalid sample). A quaternion that is already
/// unit to rounding is taken as it is, so a sample round-trips bit for bit (the pipeline must
/// compute exactly what the in-process loop computes); anything else is normalised.
pub fn quaternion_from_array(q: &[f64; 4]) -> Option<Attitude> {
    let raw = Quaternion::new(q[3], q[0], q[1], q[2]);
    let norm = raw.norm();
    if !(raw.coords.iter().all(|x| x.is_finite()) && norm > 0.5) {
        return None;
    }
    Some(if (norm - 1.0).abs() < 1e-12 {
        UnitQuaternion::new_unchecked(raw)
    } else {
        UnitQuaternion::new_normalize(raw)
    })
}

pub fn v3(a: &[f64; 3]) -> Vector3<f64> {
    Vector3::from(*a)
}

pub fn v4(a: &[f64; 4]) -> Vector4<f64> {
    Vector4::from(*a)
}

pub fn a3(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

pub fn a4(v: &Vector4<f64>) -> [f64; 4] {
    [v[0], v[1], v[2], v[3]]
}

/// Saturation flags of up to four channels.
pub fn saturation_flags(saturated: &[bool]) -> u32 {
    saturated
        .iter()
        .enumerate()
        .filter(|(_, s)| **s)
        .fold(0, |flags, (i, _)| flags | SampleHeader::saturated(i as u32))
}

/// Seconds of a time stamp.
pub fn seconds(t_ns: u64) -> f64 {
    t_ns as f64 * 1e-9
}

/// Per-publisher sequence numbers.
#[derive(Debug, Default, Clone, Copy)]
pub struct Sequence(u64);

impl Sequence {
    /// A header for a sample at `t_ns` with `flags`, taking the next sequence number.
    pub fn header(&mut self, t_ns: u64, flags: u32) -> SampleHeader {
        let h = SampleHeader::new(t_ns, self.0, flags);
        self.0 += 1;
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_round_trips_exactly_scalar_last() {
        let q = testbed_model::attitude::from_heading_pitch_roll(0.3, 0.1, -0.2);
        let a = quaternion_to_array(&q);
        assert_eq!(a[3], q.coords.w);
        assert_eq!(quaternion_from_array(&a).unwrap(), q);
        assert!(quaternion_from_array(&[0.0; 4]).is_none());
    }
}
