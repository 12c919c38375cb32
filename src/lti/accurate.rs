//! Matrix products in double-double arithmetic (error-free transformations,
//! Dekker 1971; Ogita, Rump & Oishi 2005): used to evaluate Riccati
//! residuals whose terms cancel by many orders of magnitude (nearly
//! unstabilisable problems), where a plain `f64` evaluation returns rounding
//! noise and Newton refinement stalls on it.

use faer::Mat;

/// A matrix as an unevaluated sum `hi + lo`, `|lo| <= ulp(hi) / 2`.
#[derive(Debug, Clone)]
pub(crate) struct Dd {
    pub hi: Mat<f64>,
    pub lo: Mat<f64>,
}

#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    /// Exact embedding of an `f64` matrix.
    pub fn from(m: &Mat<f64>) -> Dd {
        Dd {
            hi: m.clone(),
            lo: Mat::zeros(m.nrows(), m.ncols()),
        }
    }

    /// Transpose.
    pub fn t(&self) -> Dd {
        Dd {
            hi: self.hi.transpose().to_owned(),
            lo: self.lo.transpose().to_owned(),
        }
    }

    /// Product, accurate to about 2^-104 relative to `|A| |B|`.
    pub fn mul(&self, b: &Dd) -> Dd {
        let (n, k, m) = (self.hi.nrows(), self.hi.ncols(), b.hi.ncols());
        assert_eq!(k, b.hi.nrows());
        let mut hi = Mat::zeros(n, m);
        let mut lo = Mat::zeros(n, m);
        for j in 0..m {
            for i in 0..n {
                let (mut s, mut e) = (0.0f64, 0.0f64);
                for l in 0..k {
                    let (ah, al) = (self.hi[(i, l)], self.lo[(i, l)]);
                    let (bh, bl) = (b.hi[(l, j)], b.lo[(l, j)]);
                    let (p, pe) = two_prod(ah, bh);
                    let (s1, se) = two_sum(s, p);
                    s = s1;
                    e += pe + se + ah * bl + al * bh;
                }
                let (h, l) = two_sum(s, e);
                hi[(i, j)] = h;
                lo[(i, j)] = l;
            }
        }
        Dd { hi, lo }
    }

    /// `self + sign * b`.
    pub fn add(&self, b: &Dd, sign: f64) -> Dd {
        let (n, m) = (self.hi.nrows(), self.hi.ncols());
        let mut hi = Mat::zeros(n, m);
        let mut lo = Mat::zeros(n, m);
        for j in 0..m {
            for i in 0..n {
                let (s, e) = two_sum(self.hi[(i, j)], sign * b.hi[(i, j)]);
                let e = e + self.lo[(i, j)] + sign * b.lo[(i, j)];
                let (h, l) = two_sum(s, e);
                hi[(i, j)] = h;
                lo[(i, j)] = l;
            }
        }
        Dd { hi, lo }
    }

    /// `self / s`, each entry to about 2^-104 relative (one Newton step on
    /// the double quotient, with its residual `x - q s` formed exactly).
    pub fn divided(&self, s: f64) -> Dd {
        let (n, m) = (self.hi.nrows(), self.hi.ncols());
        let mut hi = Mat::zeros(n, m);
        let mut lo = Mat::zeros(n, m);
        for j in 0..m {
            for i in 0..n {
                let q = self.hi[(i, j)] / s;
                let (p, pe) = two_prod(q, s);
                let residual = ((self.hi[(i, j)] - p) - pe) + self.lo[(i, j)];
                let (h, l) = two_sum(q, residual / s);
                hi[(i, j)] = h;
                lo[(i, j)] = l;
            }
        }
        Dd { hi, lo }
    }

    /// `-self`.
    pub fn neg(&self) -> Dd {
        Dd {
            hi: -&self.hi,
            lo: -&self.lo,
        }
    }

    /// The inverse: the double inverse of the rounded matrix (accepted as
    /// [`super::ss::inv`] accepts it), refined by two Newton-Schulz steps
    /// `X + X (I - M X)` in double-double. Each squares the relative error,
    /// `eps cond(M)`, so a matrix with `cond(M) < 1e5` comes out to 1e-30.
    pub fn inverse(&self) -> Option<Dd> {
        let mut x = Dd::from(&super::ss::inv(&self.round())?);
        let eye = Dd::from(&Mat::identity(self.hi.nrows(), self.hi.ncols()));
        for _ in 0..2 {
            x = x.add(&x.mul(&eye.add(&self.mul(&x), -1.0)), 1.0);
        }
        Some(x)
    }

    /// Rounded to `f64`.
    pub fn round(&self) -> Mat<f64> {
        Mat::from_fn(self.hi.nrows(), self.hi.ncols(), |i, j| {
            self.hi[(i, j)] + self.lo[(i, j)]
        })
    }
}

/// The frequency response `C (s I - A)^-1 B + D` of `sys` at the complex
/// point `s` (`z` for a discrete system), with the solve and the products in
/// double-double arithmetic (faer's `fx128`; Gaussian elimination with
/// partial pivoting) and the result rounded to `f64`. The data are exact in
/// both precisions, so this is the response of the stored realisation to
/// about `1e-32 cond(s I - A)`: a stiff closed loop whose plain evaluation
/// loses three digits to a realisation with entries of 1e12 beside a pole at
/// 0.02 (cheap-control H-infinity controllers) is evaluated to full double
/// precision. `None` when `s I - A` is singular to that precision.
pub(crate) fn response_extended(
    sys: &crate::lti::StateSpace,
    s: crate::lti::c64,
) -> Option<Mat<crate::lti::c64>> {
    type Cx = num_complex::Complex<faer::fx128>;
    let cx = |re: f64, im: f64| Cx::new(re.into(), im.into());
    let (n, m) = (sys.a.nrows(), sys.b.ncols());
    // [s I - A | B], reduced to [U | U^-1 L^-1 P B] in place.
    let mut w: Vec<Vec<Cx>> = (0..n)
        .map(|i| {
            (0..n + m)
                .map(|j| match j {
                    j if j < n && i == j => cx(s.re - sys.a[(i, j)], s.im),
                    j if j < n => cx(-sys.a[(i, j)], 0.0),
                    j => cx(sys.b[(i, j - n)], 0.0),
                })
                .collect()
        })
        .collect();
    let size = |z: &Cx| z.re.0.abs() + z.im.0.abs();
    for k in 0..n {
        let p = (k..n).max_by(|&a, &b| size(&w[a][k]).total_cmp(&size(&w[b][k])))?;
        if size(&w[p][k]).is_nan() || size(&w[p][k]) <= 0.0 {
            return None;
        }
        w.swap(k, p);
        let (top, rest) = w.split_at_mut(k + 1);
        let pivot_row = &top[k];
        for row in rest.iter_mut() {
            let f = row[k] / pivot_row[k];
            for (x, p) in row[k..].iter_mut().zip(&pivot_row[k..]) {
                *x -= f * *p;
            }
        }
    }
    // Back substitution: x = U^-1 (the right-hand side).
    let mut x = vec![vec![cx(0.0, 0.0); m]; n];
    for i in (0..n).rev() {
        for c in 0..m {
            let mut acc = w[i][n + c];
            for j in i + 1..n {
                acc -= w[i][j] * x[j][c];
            }
            x[i][c] = acc / w[i][i];
        }
    }
    let out = Mat::from_fn(sys.c.nrows(), m, |i, j| {
        let mut acc = cx(sys.d[(i, j)], 0.0);
        for (k, row) in x.iter().enumerate() {
            acc += cx(sys.c[(i, k)], 0.0) * row[j];
        }
        crate::lti::c64::new(acc.re.0 + acc.re.1, acc.im.0 + acc.im.1)
    });
    let finite = out
        .col_iter()
        .all(|c| c.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
    finite.then_some(out)
}

/// `G = 1/(s + 1) - 1/(s + a)`, `a = 1 + 1e-9` (as stored), and its exact
/// DC gain `(a - 1)/a` (exact in double by Sterbenz's lemma): the
/// difference of two terms 1e9 times larger, for the tests of the
/// double-double evaluation.
#[cfg(feature = "checks")]
pub(crate) fn cancelling_pair() -> (crate::lti::StateSpace, f64) {
    let a = 1.0 + 1e-9;
    let diag = |i: usize, j: usize| match (i == j, i) {
        (false, _) => 0.0,
        (true, 0) => -1.0,
        (true, _) => -a,
    };
    let sys = crate::lti::StateSpace::new(
        Mat::from_fn(2, 2, diag),
        Mat::from_fn(2, 1, |_, _| 1.0),
        Mat::from_fn(1, 2, |_, j| if j == 0 { 1.0 } else { -1.0 }),
        Mat::zeros(1, 1),
        None,
    )
    .unwrap();
    (sys, (a - 1.0) / a)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    /// `x / 3` and the inverse of a Hilbert matrix (condition 524) to
    /// double-double: `3 q - 1` and `M X - I`, evaluated in double-double,
    /// vanish to 1e-30 where the double quotient and inverse leave 1e-17.
    pub fn quotient_and_inverse_reach_double_double() {
        let one = Dd::from(&Mat::from_fn(1, 1, |_, _| 1.0));
        let three = Dd::from(&Mat::from_fn(1, 1, |_, _| 3.0));
        let q = one.divided(3.0);
        assert!(q.lo[(0, 0)] != 0.0);
        let r = three.mul(&q).add(&one, -1.0);
        assert!(r.hi[(0, 0)].abs() < 1e-31, "3 q - 1 = {:e}", r.hi[(0, 0)]);
        let h = Dd::from(&Mat::from_fn(3, 3, |i, j| 1.0 / (i + j + 1) as f64));
        let x = h.inverse().unwrap();
        let eye = Dd::from(&Mat::identity(3, 3));
        let plain = Dd::from(&crate::lti::ss::inv(&h.hi).unwrap());
        let err = |x: &Dd| h.mul(x).add(&eye, -1.0).round().norm_l2();
        assert!(err(&x) < 1e-28, "refined: {:e}", err(&x));
        assert!(err(&plain) > 1e-18, "the double inverse is already exact");
    }

    pub fn cancellation_is_exact() {
        // (1 + 2^-40)(1 - 2^-40) - 1 = -2^-80, lost entirely in f64.
        let e = 2f64.powi(-40);
        let a = Mat::from_fn(1, 2, |_, j| [1.0 + e, 1.0][j]);
        let b = Mat::from_fn(2, 1, |i, _| [1.0 - e, -1.0][i]);
        let p = Dd::from(&a).mul(&Dd::from(&b)).round();
        assert_eq!(p[(0, 0)], -2f64.powi(-80));
    }

    /// `G = 1/(s + 1) - 1/(s + a)` with `a` one ulp-scale step above 1:
    /// `G(0) = (a - 1)/a`, exact in double (Sterbenz) but the difference of
    /// two terms 1e9 times larger, which a double evaluation gets to about
    /// 7 digits and the double-double one to the last bit.
    pub fn response_extended_recovers_a_cancelling_dc_gain() {
        use crate::lti::c64;
        let (sys, exact) = cancelling_pair();
        let extended = response_extended(&sys, c64::new(0.0, 0.0)).unwrap()[(0, 0)];
        assert!(
            (extended.re / exact - 1.0).abs() < 4.0 * f64::EPSILON,
            "{extended}"
        );
        assert_eq!(extended.im, 0.0);
        let double = sys.eval(c64::new(0.0, 0.0)).unwrap()[(0, 0)].re;
        assert!((double / exact - 1.0).abs() > 1e-10, "{double}");
    }
}
