//! The continuous-time linear-quadratic regulator: the stabilising solution `P` of the
//! algebraic Riccati equation `Aᵀ P + P A − P B R⁻¹ Bᵀ P + Q = 0` and the gain `K = R⁻¹ Bᵀ P`
//! (`u = −K x` minimises `∫ xᵀ Q x + uᵀ R u dt`).
//!
//! Solved by Newton–Kleinman iteration (Kleinman 1968, "On an iterative technique for Riccati
//! equation computations", IEEE TAC 13(1)): from a stabilising gain `K₀`, solve the Lyapunov
//! equation `(A − B Kᵢ)ᵀ Pᵢ + Pᵢ (A − B Kᵢ) + Q + Kᵢᵀ R Kᵢ = 0`, set `Kᵢ₊₁ = R⁻¹ Bᵀ Pᵢ`; every
//! iterate is stabilising and `Pᵢ` decreases monotonically to the solution, quadratically near
//! it. The Lyapunov equations are solved exactly (for these small systems) as the Kronecker
//! linear system `(I ⊗ Aᶜᵀ + Aᶜᵀ ⊗ I) vec P = −vec M`.

use nalgebra::DMatrix;

/// Why no LQR gain was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LqrError {
    #[error("LQR: matrix sizes do not fit ({0})")]
    Shape(&'static str),
    #[error("LQR: R is not positive definite")]
    WeightR,
    #[error(
        "LQR: the Lyapunov equation of iteration {0} is singular (initial gain not stabilising?)"
    )]
    Lyapunov(usize),
    #[error("LQR: Newton–Kleinman did not converge in {0} iterations")]
    NoConvergence(usize),
}

/// The Riccati solution and its gain.
#[derive(Debug, Clone, PartialEq)]
pub struct Lqr {
    /// `P` (n×n, symmetric positive semi-definite).
    pub p: DMatrix<f64>,
    /// `K = R⁻¹ Bᵀ P` (m×n).
    pub k: DMatrix<f64>,
    /// Newton iterations used.
    pub iterations: usize,
}

/// The LQR of `(A, B, Q, R)` from the stabilising gain `k0` (`A − B k0` Hurwitz).
pub fn solve(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    k0: &DMatrix<f64>,
) -> Result<Lqr, LqrError> {
    let n = a.nrows();
    let m = b.ncols();
    if a.ncols() != n || b.nrows() != n || q.shape() != (n, n) || r.shape() != (m, m) {
        return Err(LqrError::Shape("A n×n, B n×m, Q n×n, R m×m"));
    }
    if k0.shape() != (m, n) {
        return Err(LqrError::Shape("K0 m×n"));
    }
    let r_inv = r.clone().cholesky().ok_or(LqrError::WeightR)?.inverse();
    let mut k = k0.clone();
    let mut p_prev: Option<DMatrix<f64>> = None;
    const MAX_ITERATIONS: usize = 60;
    for i in 0..MAX_ITERATIONS {
        let a_c = a - b * &k;
        let m_rhs = q + k.transpose() * r * &k;
        let p = lyapunov(&a_c, &m_rhs).ok_or(LqrError::Lyapunov(i))?;
        k = &r_inv * b.transpose() * &p;
        if let Some(prev) = &p_prev {
            let change = (&p - prev).amax();
            if change <= 1e-14 * p.amax() {
                return Ok(Lqr {
                    p,
                    k,
                    iterations: i + 1,
                });
            }
        }
        p_prev = Some(p);
    }
    Err(LqrError::NoConvergence(MAX_ITERATIONS))
}

/// The `P` with `Aᶜᵀ P + P Aᶜ + M = 0` (symmetrised), `None` if the equation is singular.
pub fn lyapunov(a_c: &DMatrix<f64>, m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = a_c.nrows();
    let eye = DMatrix::<f64>::identity(n, n);
    let at = a_c.transpose();
    // Column-major vec: vec(X B) = (Bᵀ ⊗ I) vec X, vec(A X) = (I ⊗ A) vec X.
    let system = eye.kronecker(&at) + at.kronecker(&eye);
    let rhs = -DMatrix::from_column_slice(n * n, 1, m.as_slice());
    let x = system.lu().solve(&rhs)?;
    let p = DMatrix::from_column_slice(n, n, x.as_slice());
    Some((&p + p.transpose()) * 0.5)
}

/// `Aᵀ P + P A − P B R⁻¹ Bᵀ P + Q`: zero at the solution.
pub fn riccati_residual(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let r_inv = r.clone().cholesky()?.inverse();
    Some(a.transpose() * p + p * a - p * b * r_inv * b.transpose() * p + q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_double_integrator_has_the_textbook_gain() {
        // x'' = u, Q = diag(q1, q2), R = ρ: K = [sqrt(q1/ρ), sqrt(q2/ρ + 2 sqrt(q1/ρ))].
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let (q1, q2, rho) = (4.0, 1.0, 0.5);
        let q = DMatrix::from_row_slice(2, 2, &[q1, 0.0, 0.0, q2]);
        let r = DMatrix::from_element(1, 1, rho);
        let k0 = DMatrix::from_row_slice(1, 2, &[1.0, 2.0]);
        let lqr = solve(&a, &b, &q, &r, &k0).unwrap();
        let k1 = (q1 / rho).sqrt();
        let k2 = (q2 / rho + 2.0 * k1).sqrt();
        assert!((lqr.k[(0, 0)] - k1).abs() < 1e-12 * k1, "{}", lqr.k);
        assert!((lqr.k[(0, 1)] - k2).abs() < 1e-12 * k2, "{}", lqr.k);
        let residual = riccati_residual(&a, &b, &q, &r, &lqr.p).unwrap();
        assert!(residual.amax() < 1e-12, "{residual}");
    }
}
