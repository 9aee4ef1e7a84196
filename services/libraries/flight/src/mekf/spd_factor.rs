//! Robust factorisation of the innovation covariance `S = H P Hᵀ + R` (symmetric positive
//! definite; the gravity block is dimensionless, the magnetic block in tesla², up to 1e-15
//! apart): Cholesky after symmetric diagonal equilibration, refusing ill-conditioned matrices.
//! Used for the gate's NIS and whitened innovations and for the Kalman gain.
//!
//! Sized at compile time (`D` = 2, 3 or 5: gravity, magnetic field, both), so a factorisation
//! lives on the stack: the update allocates nothing.

use nalgebra::{Cholesky, Const, SMatrix, SVector};

/// Smallest pivot² of the equilibrated (unit-diagonal) innovation covariance accepted by the
/// factorisation: a condition number of about 1e12.
const MIN_PIVOT_SQ: f64 = 1e-12;

/// Cholesky factor of an equilibrated symmetric positive definite `D×D` matrix:
/// `S = D⁻¹ L Lᵀ D⁻¹` with `D = diag(1/sqrt(S_ii))`.
pub(super) struct SpdFactor<const D: usize> {
    d: SVector<f64, D>,
    l: SMatrix<f64, D, D>,
    chol: Cholesky<f64, Const<D>>,
}

impl<const D: usize> SpdFactor<D> {
    pub(super) fn new(s: &SMatrix<f64, D, D>) -> Option<Self> {
        let mut d = SVector::<f64, D>::zeros();
        for i in 0..D {
            let sii = s[(i, i)];
            if !(sii.is_finite() && sii > 0.0) {
                return None;
            }
            d[i] = 1.0 / sii.sqrt();
        }
        let scaled =
            SMatrix::<f64, D, D>::from_fn(|i, j| 0.5 * (s[(i, j)] + s[(j, i)]) * d[i] * d[j]);
        if !scaled.iter().all(|x| x.is_finite()) {
            return None;
        }
        let chol = scaled.cholesky()?;
        let l = chol.l();
        if (0..D).any(|i| l[(i, i)] * l[(i, i)] < MIN_PIVOT_SQ) {
            return None;
        }
        Some(Self { d, l, chol })
    }

    /// `S⁻¹ b`.
    pub(super) fn solve<const C: usize>(&self, b: &SMatrix<f64, D, C>) -> SMatrix<f64, D, C> {
        let mut x = *b;
        for (i, mut row) in x.row_iter_mut().enumerate() {
            row *= self.d[i];
        }
        let mut y = self.chol.solve(&x);
        for (i, mut row) in y.row_iter_mut().enumerate() {
            row *= self.d[i];
        }
        y
    }

    /// `L_S = D⁻¹ L`, the lower-triangular factor of `S = L_S L_Sᵀ` ([`SpdFactor::whiten`]
    /// solves with it).
    pub(super) fn lower(&self) -> SMatrix<f64, D, D> {
        SMatrix::<f64, D, D>::from_fn(|i, j| self.l[(i, j)] / self.d[i])
    }

    /// Whitened vector `L_S⁻¹ v` with `S = L_S L_Sᵀ` (`L_S = D⁻¹ L`, lower triangular).
    pub(super) fn whiten(&self, v: &SVector<f64, D>) -> Option<SVector<f64, D>> {
        self.l.solve_lower_triangular(&v.component_mul(&self.d))
    }
}
