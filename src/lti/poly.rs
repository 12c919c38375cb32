//! Real polynomials in ascending powers of `z^-1`:
//! `B(z^-1) = b0 + b1 z^-1 + ... + bm z^-m`, the convention of the FTS literature
//! and of MATLAB's `tf(..., 'Variable', 'z^-1')`.

use super::roots::{RootsError, roots_descending};
use crate::lti::c64;

/// A real polynomial `c0 + c1 x + ... + cn x^n`, used with `x = z^-1`.
#[derive(Debug, Clone, PartialEq)]
pub struct Poly {
    coeffs: Vec<f64>,
}

impl Poly {
    /// From coefficients in ascending powers. An empty list is the zero polynomial `[0]`.
    pub fn new(coeffs: Vec<f64>) -> Self {
        if coeffs.is_empty() {
            Self { coeffs: vec![0.0] }
        } else {
            Self { coeffs }
        }
    }

    /// The constant polynomial `c`.
    pub fn constant(c: f64) -> Self {
        Self { coeffs: vec![c] }
    }

    /// Coefficients in ascending powers.
    pub fn coeffs(&self) -> &[f64] {
        &self.coeffs
    }

    /// Consumes the polynomial, returning its coefficients.
    pub fn into_coeffs(self) -> Vec<f64> {
        self.coeffs
    }

    /// Highest power stored (the length minus one; trailing zeros count until trimmed).
    pub fn degree(&self) -> usize {
        self.coeffs.len() - 1
    }

    /// Whether every coefficient is exactly zero.
    pub fn is_zero(&self) -> bool {
        self.coeffs.iter().all(|&c| c == 0.0)
    }

    /// Value at `x` (Horner).
    pub fn eval(&self, x: c64) -> c64 {
        self.coeffs
            .iter()
            .rev()
            .fold(c64::new(0.0, 0.0), |acc, &c| acc * x + c)
    }

    /// Value at a real `x`.
    pub fn eval_real(&self, x: f64) -> f64 {
        self.coeffs.iter().rev().fold(0.0, |acc, &c| acc * x + c)
    }

    /// Value on the unit circle at normalised angular frequency `omega`
    /// (rad/sample): `x = z^-1 = e^{-j omega}`.
    pub fn eval_unit_circle(&self, omega: f64) -> c64 {
        self.eval(c64::from_polar(1.0, -omega))
    }

    /// Value at `z = 1` (DC): the sum of the coefficients.
    pub fn sum(&self) -> f64 {
        self.coeffs.iter().sum()
    }

    /// Product (convolution of the coefficient lists).
    pub fn mul(&self, other: &Poly) -> Poly {
        let mut out = vec![0.0; self.coeffs.len() + other.coeffs.len() - 1];
        for (i, &a) in self.coeffs.iter().enumerate() {
            for (j, &b) in other.coeffs.iter().enumerate() {
                out[i + j] += a * b;
            }
        }
        Poly { coeffs: out }
    }

    /// Sum, padding the shorter operand.
    pub fn add(&self, other: &Poly) -> Poly {
        let n = self.coeffs.len().max(other.coeffs.len());
        let coeffs = (0..n)
            .map(|i| self.coeffs.get(i).unwrap_or(&0.0) + other.coeffs.get(i).unwrap_or(&0.0))
            .collect();
        Poly { coeffs }
    }

    /// Every coefficient times `k`.
    pub fn scale(&self, k: f64) -> Poly {
        Poly {
            coeffs: self.coeffs.iter().map(|c| c * k).collect(),
        }
    }

    /// Multiplies by `x^k` (for `x = z^-1`, a delay of `k` samples).
    pub fn shift(&self, k: usize) -> Poly {
        let mut coeffs = vec![0.0; k];
        coeffs.extend_from_slice(&self.coeffs);
        Poly { coeffs }
    }

    /// Coefficients reversed: `x^n B(1/x)`. For `x = z^-1` this maps each
    /// zero `z_i` to `1/z_i` (\[Li21\] Eq. 9, `B^*`).
    pub fn reversed(&self) -> Poly {
        Poly {
            coeffs: self.coeffs.iter().rev().copied().collect(),
        }
    }

    /// Drops trailing (highest-power) coefficients whose magnitude is at most
    /// `rel_tol` times the largest one. `rel_tol = 0` drops exact zeros only.
    pub fn trimmed(&self, rel_tol: f64) -> Poly {
        let scale = self.coeffs.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        let mut n = self.coeffs.len();
        while n > 1 && self.coeffs[n - 1].abs() <= rel_tol * scale {
            n -= 1;
        }
        Poly {
            coeffs: self.coeffs[..n].to_vec(),
        }
    }

    /// Number of leading (lowest-power) coefficients that are exactly zero:
    /// for `x = z^-1`, a pure delay hidden in the polynomial.
    pub fn leading_zeros(&self) -> usize {
        self.coeffs.iter().take_while(|&&c| c == 0.0).count()
    }

    /// `gain * prod_i (1 - r_i x)`: the polynomial in `z^-1` whose zeros in
    /// the z-plane are `roots`, with constant term `gain`. Complex roots must
    /// come in conjugate pairs (the imaginary part of the result is dropped).
    pub fn from_z_roots(roots: &[c64], gain: f64) -> Poly {
        let mut acc = vec![c64::new(1.0, 0.0)];
        for &r in roots {
            let mut next = vec![c64::new(0.0, 0.0); acc.len() + 1];
            for (i, &a) in acc.iter().enumerate() {
                next[i] += a;
                next[i + 1] -= a * r;
            }
            acc = next;
        }
        Poly {
            coeffs: acc.iter().map(|c| c.re * gain).collect(),
        }
    }

    /// Zeros in the z-plane: the roots of `z^m B(z^-1) = b0 z^m + ... + bm`.
    /// Trailing zero coefficients are dropped first (they lower the degree, they
    /// are not zeros at the origin); leading zero coefficients (a hidden delay)
    /// are not zeros either and are skipped.
    pub fn z_roots(&self) -> Result<Vec<c64>, RootsError> {
        let trimmed = self.trimmed(0.0);
        let lead = trimmed.leading_zeros();
        if lead == trimmed.coeffs.len() {
            return Ok(Vec::new());
        }
        // b_lead z^(m-lead) + ... + b_m: descending in z.
        roots_descending(&trimmed.coeffs[lead..])
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn from_roots_and_back() {
        let roots = [
            c64::new(0.5, 0.25),
            c64::new(0.5, -0.25),
            c64::new(-0.3, 0.0),
        ];
        let p = Poly::from_z_roots(&roots, 2.0);
        // 2 (1 - z^-1 + 0.3125 z^-2)(1 + 0.3 z^-1)
        let expect = [2.0, -1.4, 0.025, 0.1875];
        for (a, b) in p.coeffs().iter().zip(expect) {
            assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        }
        let mut back = p.z_roots().unwrap();
        back.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        assert!((back[0] - roots[2]).norm() < 1e-14);
        assert!((back[1] - roots[1]).norm() < 1e-14);
        assert!((back[2] - roots[0]).norm() < 1e-14);
    }

    pub fn reverse_inverts_zeros() {
        let p = Poly::new(vec![1.0, -0.5]); // zero at 0.5
        let r = p.reversed().z_roots().unwrap(); // -0.5 + z^-1: zero at 2
        assert!((r[0] - c64::new(2.0, 0.0)).norm() < 1e-15);
    }

    pub fn arithmetic() {
        let a = Poly::new(vec![1.0, 2.0]);
        let b = Poly::new(vec![3.0, 0.0, 1.0]);
        assert_eq!(a.mul(&b).coeffs(), &[3.0, 6.0, 1.0, 2.0]);
        assert_eq!(a.add(&b).coeffs(), &[4.0, 2.0, 1.0]);
        assert_eq!(a.shift(2).coeffs(), &[0.0, 0.0, 1.0, 2.0]);
        assert_eq!(Poly::new(vec![1.0, 0.0, 0.0]).trimmed(0.0).coeffs(), &[1.0]);
        assert_eq!(a.eval_real(2.0), 5.0);
        let w = 0.3f64;
        let v = a.eval_unit_circle(w);
        assert!((v - c64::new(1.0 + 2.0 * w.cos(), -2.0 * w.sin())).norm() < 1e-15);
    }
}
