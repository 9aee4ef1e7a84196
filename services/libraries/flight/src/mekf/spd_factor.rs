//! Robust factorisation of the innovation covariance `S = H P Hᵀ + R` (symmetric positive
//! definite; the gravity block is dimensionless, the magnetic block in tesla², up to 1e-15
//! apart): Cholesky after symmetric diagonal equilibration, refusing ill-conditioned matrices.
//! Used for the gate's NIS and whitened innovations and for the Kalman gain.

use nalgebra::{DMatrix, DVector};

/// Smallest pivot² of the equilibrated (unit-diagonal) innovation covariance accepted by the
/// factorisation: a condition number of about 1e12.
const MIN_PIVOT_SQ: f64 = 1e-12;

/// Cholesky factor of an equilibrated symmetric positive definite matrix: `S = D⁻¹ L Lᵀ D⁻¹`
/// with `D = diag(1/sqrt(S_ii))`.
pub(super) struct SpdFactor {
    d: DVector<f64>,
    l: DMatrix<f64>,
    chol: nalgebra::Cholesky<f64, nalgebra::Dyn>,
}

impl SpdFactor {
    pub(super) fn new(s: &DMatrix<f64>) -> Option<Self> {
        let n = s.nrows();
        let mut d = DVector::zeros(n);
        for i in 0..n {
            let sii = s[(i, i)];
            if !(sii.is_finite() && sii > 0.0) {
                return None;
            }
            d[i] = 1.0 / sii.sqrt();
        }
        let scaled = DMatrix::from_fn(n, n, |i, j| 0.5 * (s[(i, j)] + s[(j, i)]) * d[i] * d[j]);
        if !scaled.iter().all(|x| x.is_finite()) {
            return None;
        }
        let chol = scaled.cholesky()?;
        let l = chol.l();
        if (0..n).any(|i| l[(i, i)] * l[(i, i)] < MIN_PIVOT_SQ) {
            return None;
        }
        Some(Self { d, l, chol })
    }

    /// `S⁻¹ b`.
    pub(super) fn solve(&self, b: &DMatrix<f64>) -> DMatrix<f64> {
        let mut x = b.clone();
        for (i, mut row) in x.row_iter_mut().enumerate() {
            row *= self.d[i];
        }
        let mut y = self.chol.solve(&x);
        for (i, mut row) in y.row_iter_mut().enumerate() {
            row *= self.d[i];
        }
        y
    }

    /// Whitened vector `L_S⁻¹ v` with `S = L_S L_Sᵀ` (`L_S = D⁻¹ L`, lower triangular).
    pub(super) fn whiten(&self, v: &DVector<f64>) -> Option<DVector<f64>> {
        self.l.solve_lower_triangular(&v.component_mul(&self.d))
    }
}
