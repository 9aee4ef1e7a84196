//! Signed permutations of three axes: the ways a record's columns can be exchanged or
//! sign-flipped, and how such a mistake reads in words.
//!
//! `S` maps a vector `x` to `(S x)_a = sign[a] · x[perm[a]]`. As a data mistake `data = S ·
//! truth`: column `a` holds `sign[a]` times the values of column `perm[a]`.

use super::finding::Mistake;
use nalgebra::Matrix3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignedPermutation {
    pub perm: [usize; 3],
    pub sign: [f64; 3],
}

const PERMUTATIONS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

impl SignedPermutation {
    pub const IDENTITY: Self = Self {
        perm: [0, 1, 2],
        sign: [1.0; 3],
    };

    /// All 48 signed permutations, the identity first.
    pub fn all() -> Vec<Self> {
        let mut out = Vec::with_capacity(48);
        for perm in PERMUTATIONS {
            for bits in 0..8u8 {
                let sign = [0, 1, 2].map(|i| if bits >> i & 1 == 1 { -1.0 } else { 1.0 });
                out.push(Self { perm, sign });
            }
        }
        out
    }

    pub fn matrix(&self) -> Matrix3<f64> {
        let mut m = Matrix3::zeros();
        for a in 0..3 {
            m[(a, self.perm[a])] = self.sign[a];
        }
        m
    }

    /// The inverse (the transpose).
    pub fn inverse(&self) -> Self {
        let mut out = Self::IDENTITY;
        for a in 0..3 {
            out.perm[self.perm[a]] = a;
            out.sign[self.perm[a]] = self.sign[a];
        }
        out
    }

    pub fn negated(&self) -> Self {
        Self {
            perm: self.perm,
            sign: self.sign.map(|s| -s),
        }
    }

    pub fn determinant(&self) -> f64 {
        self.matrix().determinant()
    }

    pub fn is_identity(&self) -> bool {
        *self == Self::IDENTITY
    }

    fn flips(&self) -> usize {
        self.sign.iter().filter(|s| **s < 0.0).count()
    }

    /// The sensor-side mistakes `T` (`data = T · truth` for a vector sensor) that look, against
    /// a correct gyro, like the gyro-side hypothesis `self`: a rotation through an orthogonal
    /// `T` gives `T(v × ω) = det(T) (T v × T ω)`, so the readings move as under the rate
    /// `det(T) T ω`. Both `±self` qualify when `self` is proper, none otherwise; the one with
    /// fewer sign flips first.
    pub fn sensor_side(&self) -> Vec<Self> {
        if self.determinant() < 0.0 {
            return Vec::new();
        }
        let mut both = vec![*self, self.negated()];
        both.sort_by_key(|t| t.flips());
        both
    }

    /// This permutation as a data mistake on `columns` (`data = self · truth`): the columns
    /// concerned and the mistake. `None` for the identity.
    pub fn describe(&self, columns: &[String; 3]) -> Option<(Vec<String>, Mistake)> {
        if self.is_identity() {
            return None;
        }
        let concerned: Vec<usize> = (0..3)
            .filter(|&a| self.perm[a] != a || self.sign[a] < 0.0)
            .collect();
        let names = concerned.iter().map(|&a| columns[a].clone()).collect();
        if self.perm == [0, 1, 2] {
            return Some((names, Mistake::SignFlipped));
        }
        let mapping = concerned
            .iter()
            .map(|&a| {
                let minus = if self.sign[a] < 0.0 { "−" } else { "" };
                format!(
                    "{} holds {minus}{}'s values",
                    columns[a], columns[self.perm[a]]
                )
            })
            .collect::<Vec<_>>()
            .join(", ");
        Some((names, Mistake::Permuted { mapping }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_and_matrix_agree() {
        for s in SignedPermutation::all() {
            let product = s.matrix() * s.inverse().matrix();
            assert!((product - Matrix3::identity()).norm() < 1e-12, "{s:?}");
        }
        assert_eq!(SignedPermutation::all().len(), 48);
    }

    #[test]
    fn a_rotated_sensor_looks_like_its_signed_rate() {
        // T(v × ω) = det(T) (T v × T ω) for every signed permutation T.
        let v = nalgebra::Vector3::new(0.3, -0.5, 0.8);
        let w = nalgebra::Vector3::new(-0.2, 0.7, 0.1);
        for t in SignedPermutation::all() {
            let m = t.matrix();
            let lhs = m * v.cross(&w);
            let rhs = (m * v).cross(&(m * w)) * t.determinant();
            assert!((lhs - rhs).norm() < 1e-12);
            let rate_side = SignedPermutation {
                perm: t.perm,
                sign: t.sign.map(|s| s * t.determinant()),
            };
            assert!(rate_side.sensor_side().contains(&t));
        }
    }

    #[test]
    fn mistakes_read_as_columns() {
        let cols = ["wx".to_string(), "wy".into(), "wz".into()];
        let flip = SignedPermutation {
            perm: [0, 1, 2],
            sign: [1.0, 1.0, -1.0],
        };
        let (c, m) = flip.describe(&cols).unwrap();
        assert_eq!(c, vec!["wz".to_string()]);
        assert_eq!(m, Mistake::SignFlipped);
        let swap = SignedPermutation {
            perm: [1, 0, 2],
            sign: [1.0; 3],
        };
        let (c, m) = swap.describe(&cols).unwrap();
        assert_eq!(c, vec!["wx".to_string(), "wy".into()]);
        assert!(
            matches!(m, Mistake::Permuted { ref mapping } if mapping.contains("wx holds wy's"))
        );
    }
}
