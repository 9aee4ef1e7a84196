//! Classical fixed-step fourth-order Runge–Kutta, independent of the platform so it can be tested
//! alone.

use nalgebra::SVector;

/// One RK4 step of `y' = f(t, y)` from `(t, y)` over `h`, returning `y(t + h)`.
///
/// Local error O(h⁵), global O(h⁴). Discontinuities of `f` inside the step (friction sign,
/// command changes) cost that order, which is why the plant freezes every switching decision for
/// the length of a step and splits steps at known switching instants.
pub fn rk4_step<const N: usize>(
    t: f64,
    y: &SVector<f64, N>,
    h: f64,
    mut f: impl FnMut(f64, &SVector<f64, N>) -> SVector<f64, N>,
) -> SVector<f64, N> {
    let k1 = f(t, y);
    let k2 = f(t + 0.5 * h, &(y + k1 * (0.5 * h)));
    let k3 = f(t + 0.5 * h, &(y + k2 * (0.5 * h)));
    let k4 = f(t + h, &(y + k3 * h));
    y + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    /// Harmonic oscillator x'' = −x from (1, 0): truth (cos t, −sin t).
    fn oscillator_error(h: f64, t_end: f64) -> f64 {
        let steps = (t_end / h).round() as usize;
        let mut y = Vector2::new(1.0, 0.0);
        for k in 0..steps {
            y = rk4_step(k as f64 * h, &y, h, |_, y| Vector2::new(y[1], -y[0]));
        }
        (y - Vector2::new(t_end.cos(), -t_end.sin())).norm()
    }

    #[test]
    fn global_error_is_fourth_order_on_harmonic_oscillator() {
        let coarse = oscillator_error(0.1, 10.0);
        let fine = oscillator_error(0.05, 10.0);
        let ratio = coarse / fine;
        // 2⁴ = 16 for a fourth-order method; a third- or fifth-order one would give 8 or 32.
        assert!((14.0..18.0).contains(&ratio), "error ratio {ratio}");
        assert!(fine < 1e-5, "{fine}");
    }

    #[test]
    fn exponential_decay_matches_the_rk4_amplification_factor() {
        // For y' = −y one step multiplies by 1 − h + h²/2 − h³/6 + h⁴/24 exactly.
        let h = 0.3;
        let y = rk4_step(0.0, &SVector::<f64, 1>::new(2.0), h, |_, y| -y);
        let factor = 1.0 - h + h * h / 2.0 - h.powi(3) / 6.0 + h.powi(4) / 24.0;
        assert!((y[0] - 2.0 * factor).abs() < 1e-15);
        assert!((y[0] - 2.0 * (-h).exp()).abs() < 1e-4);
    }

    #[test]
    fn time_argument_reaches_the_stages() {
        // y' = t integrates exactly (quadrature is Simpson's rule).
        let y = rk4_step(1.0, &SVector::<f64, 1>::new(0.0), 2.0, |t, _| {
            SVector::<f64, 1>::new(t * t)
        });
        assert!((y[0] - (27.0 - 1.0) / 3.0).abs() < 1e-12);
    }
}
