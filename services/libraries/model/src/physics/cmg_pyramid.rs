//! Geometry of the four-CMG pyramid: momentum and its Jacobian as functions of the gimbal angles.
//!
//! Gimbal axis `i` (i = 0..3) lies in the vertical plane at azimuth `i·90°` about body Z and is
//! tilted by the skew angle β from body Z towards the outside of the pyramid (Wie, *Space Vehicle
//! Dynamics and Control*, §7.3). With rotor momentum `h0`, at gimbal angle `δ_i` the rotor
//! momentum of CMG i is `h0 (cos δ_i · s_i + sin δ_i · t_i)`, where `s_i` (the spin direction at
//! `δ = 0`) is horizontal and tangent to the pyramid, and `t_i = g_i × s_i`. In body axes:
//!
//! ```text
//! h = h0 [ −cβ sδ1 − cδ2 + cβ sδ3 + cδ4,
//!           cδ1 − cβ sδ2 − cδ3 + cβ sδ4,
//!           sβ (sδ1 + sδ2 + sδ3 + sδ4) ]
//! ```

use nalgebra::{Matrix3x4, Vector3, Vector4};

/// Pyramid cluster of four single-gimbal CMGs with equal rotor momentum.
///
/// The axes of each CMG depend only on the skew angle, so they are computed once here: the
/// plant evaluates the momentum and its Jacobian forty times a tick (four RK4 stages of ten
/// substeps), and recomputing six sines and cosines of constant angles per CMG and per
/// Jacobian entry was a third of its instructions. [`new`](Self::new) uses the formulas that
/// were evaluated at each call before, so the axes are the same bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CmgPyramid {
    /// Rotor momentum of each CMG, Nms.
    rotor_momentum_nms: f64,
    /// Skew angle β between each gimbal axis and body Z, rad.
    skew_rad: f64,
    /// Per CMG: gimbal axis `g_i`, spin axis `s_i` (rotor direction at δ = 0), torque axis
    /// `t_i = g_i × s_i` (rotor direction at δ = 90°), body axes.
    axes: [CmgAxes; 4],
}

/// The fixed axes of one CMG of the pyramid, body axes, unit vectors.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CmgAxes {
    gimbal: Vector3<f64>,
    spin: Vector3<f64>,
    torque: Vector3<f64>,
}

impl CmgPyramid {
    /// A pyramid of rotor momentum `rotor_momentum_nms` (Nms) per CMG and skew angle `skew_rad`
    /// (rad).
    pub fn new(rotor_momentum_nms: f64, skew_rad: f64) -> Self {
        let (sb, cb) = skew_rad.sin_cos();
        let axes = std::array::from_fn(|i| {
            let az = i as f64 * std::f64::consts::FRAC_PI_2;
            let gimbal = Vector3::new(sb * az.cos(), sb * az.sin(), cb);
            // Horizontal tangent at azimuth az, then t = g × s.
            let spin = Vector3::new(-az.sin(), az.cos(), 0.0);
            CmgAxes {
                gimbal,
                spin,
                torque: gimbal.cross(&spin),
            }
        });
        Self {
            rotor_momentum_nms,
            skew_rad,
            axes,
        }
    }

    pub fn from_config(config: &crate::config::CmgConfig) -> Self {
        Self::new(
            config.rotor_momentum_nms,
            config.skew_deg * crate::config::DEG,
        )
    }

    /// Rotor momentum of each CMG, Nms.
    pub fn rotor_momentum_nms(&self) -> f64 {
        self.rotor_momentum_nms
    }

    /// Skew angle β between each gimbal axis and body Z, rad.
    pub fn skew_rad(&self) -> f64 {
        self.skew_rad
    }

    /// Unit gimbal axis of CMG `i` (0..3) in body axes.
    pub fn gimbal_axis(&self, i: usize) -> Vector3<f64> {
        self.axes[i].gimbal
    }

    /// Unit rotor momentum direction of CMG `i` at gimbal angle `delta` (rad), body axes.
    pub fn rotor_direction(&self, i: usize, delta: f64) -> Vector3<f64> {
        self.rotor_direction_and_rate(i, delta).0
    }

    /// The rotor direction of CMG `i` at `delta` (rad) and its derivative with respect to
    /// `delta` (1/rad, `g_i × ĥ_i`), from one sine and cosine of the angle.
    fn rotor_direction_and_rate(&self, i: usize, delta: f64) -> (Vector3<f64>, Vector3<f64>) {
        let CmgAxes { spin, torque, .. } = self.axes[i];
        let (sin, cos) = (delta.sin(), delta.cos());
        (spin * cos + torque * sin, torque * cos - spin * sin)
    }

    /// Total cluster momentum in body axes, Nms.
    pub fn momentum(&self, gimbal_rad: &Vector4<f64>) -> Vector3<f64> {
        self.momentum_and_jacobian(gimbal_rad).0
    }

    /// Jacobian `∂h/∂δ` (Nms/rad), so that `h' = J(δ) δ'`. Column i is `h0 · g_i × ĥ_i`.
    pub fn jacobian(&self, gimbal_rad: &Vector4<f64>) -> Matrix3x4<f64> {
        self.momentum_and_jacobian(gimbal_rad).1
    }

    /// [`Self::momentum`] and [`Self::jacobian`] at the same gimbal angles, each angle's sine and
    /// cosine taken once: the equations of motion need both at every evaluation, and taking
    /// them twice was an eighth of the plant's instructions (bench/README.md).
    pub fn momentum_and_jacobian(
        &self,
        gimbal_rad: &Vector4<f64>,
    ) -> (Vector3<f64>, Matrix3x4<f64>) {
        let mut directions = Vector3::zeros();
        let columns: [Vector3<f64>; 4] = std::array::from_fn(|i| {
            let (direction, rate) = self.rotor_direction_and_rate(i, gimbal_rad[i]);
            directions += direction;
            rate * self.rotor_momentum_nms
        });
        (
            directions * self.rotor_momentum_nms,
            Matrix3x4::from_columns(&columns),
        )
    }

    /// Maximum momentum the cluster can store along body X or Y (the envelope's extent), Nms:
    /// `h0 (2 + 2 cos β)`.
    pub fn envelope_xy_nms(&self) -> f64 {
        self.rotor_momentum_nms * (2.0 + 2.0 * self.skew_rad.cos())
    }

    /// Maximum momentum along body Z, Nms: `4 h0 sin β`.
    pub fn envelope_z_nms(&self) -> f64 {
        4.0 * self.rotor_momentum_nms * self.skew_rad.sin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pyramid() -> CmgPyramid {
        CmgPyramid::new(1.0, 54.74_f64.to_radians())
    }

    #[test]
    fn matches_the_closed_form_of_wie() {
        let p = pyramid();
        let (sb, cb) = p.skew_rad().sin_cos();
        let d = Vector4::new(0.3, -1.1, 2.0, 0.7);
        let (s, c) = (d.map(f64::sin), d.map(f64::cos));
        let expected = Vector3::new(
            -cb * s[0] - c[1] + cb * s[2] + c[3],
            c[0] - cb * s[1] - c[2] + cb * s[3],
            sb * (s[0] + s[1] + s[2] + s[3]),
        );
        assert!((p.momentum(&d) - expected).norm() < 1e-12);
    }

    #[test]
    fn jacobian_is_the_derivative_of_momentum() {
        let p = pyramid();
        let d = Vector4::new(0.4, 0.1, -0.9, 1.3);
        let jac = p.jacobian(&d);
        for i in 0..4 {
            let mut dp = d;
            let mut dm = d;
            dp[i] += 1e-6;
            dm[i] -= 1e-6;
            let numeric = (p.momentum(&dp) - p.momentum(&dm)) / 2e-6;
            assert!((jac.column(i) - numeric).norm() < 1e-8);
        }
    }

    #[test]
    fn rotor_stays_perpendicular_to_its_gimbal() {
        let p = pyramid();
        for i in 0..4 {
            for k in 0..16 {
                let d = k as f64 * 0.4;
                assert!(p.gimbal_axis(i).dot(&p.rotor_direction(i, d)).abs() < 1e-12);
            }
        }
    }
}
