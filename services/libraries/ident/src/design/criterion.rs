//! The D-criterion of an information matrix: how much a programme determines the target
//! causes' parameters (the log-determinant over the directions it determines), and the
//! standard errors it predicts.

use nalgebra::DMatrix;
use serde::Serialize;

/// The D-criterion of a scaled information matrix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Criterion {
    /// Directions not determined (eigenvalues at or below 1e-12 of the largest; all of them
    /// when the matrix is zero).
    pub unidentified: usize,
    /// Sum of the natural logarithms of the other eigenvalues (`log det F_s` when
    /// `unidentified` is 0); −∞ when every direction is undetermined.
    pub log_det: f64,
}

impl Criterion {
    /// Strictly better: fewer undetermined directions, or as many and a larger `log_det`.
    pub fn better_than(&self, other: &Criterion) -> bool {
        self.unidentified < other.unidentified
            || (self.unidentified == other.unidentified && self.log_det > other.log_det)
    }
}

/// Relative eigenvalue threshold of an undetermined direction (as the fits' normal equations).
const SINGULAR: f64 = 1e-12;

/// D-criterion of a symmetric information matrix `f` (already scaled) and the predicted
/// standard errors `sqrt(diag f⁻¹)` (NaN for a parameter with a component above 1e-6 in an
/// undetermined direction; the others from the inverse on the determined subspace).
pub fn d_criterion(f: &DMatrix<f64>) -> (Criterion, Vec<f64>) {
    let p = f.nrows();
    if p == 0 {
        return (
            Criterion {
                unidentified: 0,
                log_det: 0.0,
            },
            Vec::new(),
        );
    }
    let (eigenvalues, eigenvectors, determined) = d_criterion_eigen(f);
    let unidentified = determined.iter().filter(|d| !**d).count();
    let log_det = if unidentified == p {
        f64::NEG_INFINITY
    } else {
        eigenvalues
            .iter()
            .zip(&determined)
            .filter(|(_, d)| **d)
            .map(|(x, _)| x.ln())
            .sum()
    };
    let stderr = (0..p)
        .map(|i| {
            let null: f64 = (0..p)
                .filter(|&k| !determined[k])
                .map(|k| eigenvectors[(i, k)].powi(2))
                .sum();
            if null > 1e-6 {
                return f64::NAN;
            }
            (0..p)
                .filter(|&k| determined[k])
                .map(|k| eigenvectors[(i, k)].powi(2) / eigenvalues[k])
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    (
        Criterion {
            unidentified,
            log_det,
        },
        stderr,
    )
}

/// The eigen-decomposition of a symmetric information matrix `f` (symmetrised) and which of
/// its directions it determines (eigenvalue above [`SINGULAR`] times the largest, all finite).
pub(crate) fn d_criterion_eigen(f: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>, Vec<bool>) {
    let p = f.nrows();
    let sym = DMatrix::from_fn(p, p, |i, j| 0.5 * (f[(i, j)] + f[(j, i)]));
    let eig = sym.symmetric_eigen();
    let max = eig.eigenvalues.iter().copied().fold(0.0f64, f64::max);
    let finite = eig.eigenvalues.iter().all(|x| x.is_finite());
    let determined = eig
        .eigenvalues
        .iter()
        .map(|&x| finite && max > 0.0 && x > SINGULAR * max)
        .collect();
    (
        eig.eigenvalues.iter().copied().collect(),
        eig.eigenvectors,
        determined,
    )
}
