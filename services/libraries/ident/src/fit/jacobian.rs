//! The one finite-difference Jacobian of the fits, and the Gauss–Newton normal equations built
//! from it.

use crate::stats::NormalEquations;

/// Forward-difference Jacobian columns `∂r/∂θ_j` at `theta` for the parameters `which`, given
/// the residuals `r0` there. Each step `steps[j]` goes away from the nearer bound (`bounds(j)`),
/// and the perturbed parameter is clamped to its bounds; the difference is divided by the step
/// actually taken. `residuals` evaluates the residual vectors at all the perturbed parameter
/// vectors at once (in `which` order), so that it can spread them across cores.
pub fn forward_jacobian<E>(
    theta: &[f64],
    r0: &[f64],
    which: &[usize],
    steps: &[f64],
    bounds: impl Fn(usize) -> (f64, f64),
    residuals: impl FnOnce(&[Vec<f64>]) -> Result<Vec<Vec<f64>>, E>,
) -> Result<Vec<Vec<f64>>, E> {
    let perturbed = perturbations(theta, which, steps, bounds);
    let values = residuals(&perturbed)?;
    Ok(which
        .iter()
        .zip(&perturbed)
        .zip(values)
        .map(|((&j, t), rj)| {
            let hh = t[j] - theta[j];
            rj.iter().zip(r0).map(|(a, b)| (a - b) / hh).collect()
        })
        .collect())
}

/// The parameter vectors [`forward_jacobian`] evaluates the residuals at, in `which` order.
pub fn perturbations(
    theta: &[f64],
    which: &[usize],
    steps: &[f64],
    bounds: impl Fn(usize) -> (f64, f64),
) -> Vec<Vec<f64>> {
    which
        .iter()
        .map(|&j| {
            let mut t = theta.to_vec();
            let (lo, hi) = bounds(j);
            let h = if theta[j] + steps[j] > hi {
                -steps[j]
            } else {
                steps[j]
            };
            t[j] = (theta[j] + h).clamp(lo, hi);
            t
        })
        .collect()
}

/// Normal equations of the linearised problem `J δ = −r0` (columns of `J` as
/// [`forward_jacobian`] gives them).
pub fn normal_equations(columns: &[Vec<f64>], r0: &[f64]) -> NormalEquations {
    let mut ne = NormalEquations::new(columns.len());
    let mut row = vec![0.0; columns.len()];
    for i in 0..r0.len() {
        for (c, col) in columns.iter().enumerate() {
            row[c] = col[i];
        }
        ne.add(&row, -r0[i]);
    }
    ne
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_away_from_the_bound_and_divides_by_the_step_taken() {
        // r(θ) = [θ0², 3 θ1]; θ1 sits at its upper bound, so its step goes down.
        let r1 = |t: &[f64]| vec![t[0] * t[0], 3.0 * t[1]];
        let r = |ts: &[Vec<f64>]| -> Result<Vec<Vec<f64>>, ()> {
            Ok(ts.iter().map(|t| r1(t)).collect())
        };
        let theta = [2.0, 1.0];
        let r0 = r1(&theta);
        let bounds = |j: usize| if j == 1 { (0.0, 1.0) } else { (-10.0, 10.0) };
        let cols = forward_jacobian(&theta, &r0, &[0, 1], &[1e-6, 0.1], bounds, r).unwrap();
        assert!((cols[0][0] - 4.0).abs() < 1e-5 && cols[0][1] == 0.0);
        assert!(cols[1][0] == 0.0 && (cols[1][1] - 3.0).abs() < 1e-12);
        let only = forward_jacobian(&theta, &r0, &[1], &[1e-6, 0.1], bounds, r).unwrap();
        assert_eq!(only, vec![cols[1].clone()]);
        assert_eq!(normal_equations(&cols, &r0).params(), 2);
    }
}
