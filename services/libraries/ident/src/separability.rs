//! Which causes an experiment's data can tell apart: from the Fisher information `F` of their
//! parameters, the predicted correlation of two estimates, `C_ij / sqrt(C_ii C_jj)` with
//! `C = F⁻¹` (on the directions `F` determines). Two causes whose parameters are predicted to
//! correlate at `|ρ| ≥` [`UNSEPARABLE_CORRELATION`], or that share a direction `F` does not
//! determine at all, cannot be separated by that experiment: an effect of one would be named,
//! in part or in whole, as the other.
//!
//! The correlation does not depend on the parameters' units, but which directions count as
//! undetermined does (an eigenvalue below 1e-12 of the largest, as the design's criterion):
//! give `F` in the parameters' typical magnitudes, as the design does.

use crate::design::d_criterion_eigen;
use crate::effects::Cause;
use nalgebra::DMatrix;
use serde::Serialize;

/// The predicted correlation at or above which two causes count as not separable.
pub const UNSEPARABLE_CORRELATION: f64 = 0.95;

/// A component of an undetermined direction on a parameter that counts as taking part in it.
const IN_NULL_DIRECTION: f64 = 0.1;

/// Two causes an experiment cannot separate, by their most correlated parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Confusion {
    /// The parameters (`cause.key[i]`), the first of the earlier cause in the list.
    pub first: String,
    pub second: String,
    /// Their predicted correlation; `None` when they share a direction the information does
    /// not determine (the data cannot tell them apart at any noise level).
    pub correlation: Option<f64>,
}

/// The pairs of distinct causes among `params` (each parameter's cause and value offset, the
/// order of `information`'s rows) that the information cannot separate, each pair once with
/// its largest `|ρ|` (or undetermined), in the parameters' order.
pub fn unseparable(params: &[(Cause, usize)], information: &DMatrix<f64>) -> Vec<Confusion> {
    let p = params.len();
    if p == 0 || information.nrows() != p || information.ncols() != p {
        return Vec::new();
    }
    let (eigenvalues, eigenvectors, determined) = d_criterion_eigen(information);
    let covariance = |i: usize, j: usize| -> f64 {
        (0..p)
            .filter(|&k| determined[k])
            .map(|k| eigenvectors[(i, k)] * eigenvectors[(j, k)] / eigenvalues[k])
            .sum()
    };
    let name = |i: usize| params[i].0.value_name(params[i].1);
    // The worst pair of parameters of each pair of causes, in the order first seen.
    struct Worst {
        causes: (Cause, Cause),
        first: usize,
        second: usize,
        correlation: Option<f64>,
    }
    let mut worst: Vec<Worst> = Vec::new();
    let mut note = |i: usize, j: usize, correlation: Option<f64>| {
        let causes = (params[i].0, params[j].0);
        let severity = |c: Option<f64>| c.map_or(f64::INFINITY, f64::abs);
        let pair = Worst {
            causes,
            first: i,
            second: j,
            correlation,
        };
        match worst.iter_mut().find(|w| w.causes == causes) {
            Some(w) if severity(correlation) > severity(w.correlation) => *w = pair,
            Some(_) => {}
            None => worst.push(pair),
        }
    };
    for k in (0..p).filter(|&k| !determined[k]) {
        let taking_part: Vec<usize> = (0..p)
            .filter(|&i| eigenvectors[(i, k)].abs() >= IN_NULL_DIRECTION)
            .collect();
        for (a, &i) in taking_part.iter().enumerate() {
            for &j in &taking_part[a + 1..] {
                if params[i].0 != params[j].0 {
                    note(i, j, None);
                }
            }
        }
    }
    for i in 0..p {
        for j in i + 1..p {
            if params[i].0 == params[j].0 {
                continue;
            }
            let (cii, cjj) = (covariance(i, i), covariance(j, j));
            if !(cii > 0.0 && cjj > 0.0) {
                continue;
            }
            let rho = covariance(i, j) / (cii * cjj).sqrt();
            if rho.abs() >= UNSEPARABLE_CORRELATION {
                note(i, j, Some(rho));
            }
        }
    }
    worst
        .into_iter()
        .map(|w| Confusion {
            first: name(w.first),
            second: name(w.second),
            correlation: w.correlation,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO: [(Cause, usize); 2] = [(Cause::ConstantTorque, 0), (Cause::ComOffset, 0)];

    /// Closed form: for `F = [[1, c], [c, 1]]` the estimates correlate at `−c`.
    #[test]
    fn the_correlation_of_two_parameters_is_that_of_the_inverse() {
        let f = |c: f64| DMatrix::from_row_slice(2, 2, &[1.0, c, c, 1.0]);
        let found = unseparable(&TWO, &f(0.99));
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].first, Cause::ConstantTorque.value_name(0));
        assert_eq!(found[0].second, Cause::ComOffset.value_name(0));
        let rho = found[0].correlation.unwrap();
        assert!((rho + 0.99).abs() < 1e-12, "{rho}");
        assert!(unseparable(&TWO, &f(0.9)).is_empty());
        assert!(unseparable(&TWO, &DMatrix::identity(2, 2)).is_empty());
        // Another scaling of the parameters gives the same correlation.
        let s = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![10.0, 0.1]));
        let scaled = unseparable(&TWO, &(&s * f(0.99) * &s));
        assert!((scaled[0].correlation.unwrap() + 0.99).abs() < 1e-9);
    }

    /// A direction the information does not determine makes the causes in it unseparable
    /// with no correlation; parameters of one cause are never paired.
    #[test]
    fn a_shared_undetermined_direction_is_reported_and_one_cause_is_not_paired() {
        let f = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        let found = unseparable(&TWO, &f);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].correlation, None);
        let same = [(Cause::ConstantTorque, 0), (Cause::ConstantTorque, 1)];
        assert!(unseparable(&same, &f).is_empty());
        // Three parameters, the third independent: only the first pair.
        let three = [
            (Cause::ConstantTorque, 0),
            (Cause::ComOffset, 0),
            (Cause::InertiaError, 0),
        ];
        let f = DMatrix::from_row_slice(3, 3, &[1.0, 0.98, 0.0, 0.98, 1.0, 0.0, 0.0, 0.0, 2.0]);
        let found = unseparable(&three, &f);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].second, Cause::ComOffset.value_name(0));
    }
}
