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

#[inline(always)]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

#[inline(always)]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// Column `j` of a matrix as a slice (faer stores columns contiguously).
fn column(m: &Mat<f64>, j: usize) -> &[f64] {
    m.col(j)
        .try_as_col_major()
        .expect("an owned matrix's columns are contiguous")
        .as_slice()
}

/// Whether this CPU has AVX2 and FMA (decided once per product).
fn fused_multiply_add() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `(s_i, e_i) += ah_i bh + (ah_i bl + al_i bh)` with the product's and the
/// sum's rounding errors carried in `e_i` (Ogita, Rump & Oishi 2005,
/// Dot2). The same operations in the same order whichever build runs: the
/// product's error is exact either way.
#[inline(always)]
fn accumulate(s: &mut [f64], e: &mut [f64], ah: &[f64], al: &[f64], bh: f64, bl: f64) {
    for (((s, e), &ah), &al) in s.iter_mut().zip(e.iter_mut()).zip(ah).zip(al) {
        let (p, pe) = two_prod(ah, bh);
        let (s1, se) = two_sum(*s, p);
        *s = s1;
        *e += pe + se + ah * bl + al * bh;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn accumulate_avx2(s: &mut [f64], e: &mut [f64], ah: &[f64], al: &[f64], bh: f64, bl: f64) {
    accumulate(s, e, ah, al, bh, bl);
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

    /// Product, accurate to about 2^-104 relative to `|A| |B|`. Each entry
    /// is summed over `k` in order; the columns of the result are formed a
    /// column of `A` at a time (contiguous, each entry's sum independent of
    /// its neighbours', so the loop runs four entries to a vector register
    /// where the CPU has AVX2 and FMA).
    pub fn mul(&self, b: &Dd) -> Dd {
        let (n, k, m) = (self.hi.nrows(), self.hi.ncols(), b.hi.ncols());
        assert_eq!(k, b.hi.nrows());
        let mut hi = Mat::zeros(n, m);
        let mut lo = Mat::zeros(n, m);
        let (mut s, mut e) = (vec![0.0; n], vec![0.0; n]);
        let fused = fused_multiply_add();
        for j in 0..m {
            s.fill(0.0);
            e.fill(0.0);
            for l in 0..k {
                let (ah, al) = (column(&self.hi, l), column(&self.lo, l));
                let (bh, bl) = (b.hi[(l, j)], b.lo[(l, j)]);
                if fused {
                    // SAFETY: `fused_multiply_add` confirmed AVX2 and FMA.
                    #[cfg(target_arch = "x86_64")]
                    unsafe {
                        accumulate_avx2(&mut s, &mut e, ah, al, bh, bl)
                    };
                } else {
                    accumulate(&mut s, &mut e, ah, al, bh, bl);
                }
            }
            for i in 0..n {
                let (h, l) = two_sum(s[i], e[i]);
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
    output_extended(sys, |k, j| x[k][j])
}

/// `C x + D` in double-double from the state response `x(k, j)` (state
/// `k`, input `j`), rounded; `None` unless finite.
fn output_extended(
    sys: &crate::lti::StateSpace,
    x: impl Fn(usize, usize) -> num_complex::Complex<faer::fx128>,
) -> Option<Mat<crate::lti::c64>> {
    type Cx = num_complex::Complex<faer::fx128>;
    let cx = |re: f64, im: f64| Cx::new(re.into(), im.into());
    let out = Mat::from_fn(sys.c.nrows(), sys.b.ncols(), |i, j| {
        let mut acc = cx(sys.d[(i, j)], 0.0);
        for k in 0..sys.a.nrows() {
            acc += cx(sys.c[(i, k)], 0.0) * x(k, j);
        }
        crate::lti::c64::new(acc.re.0 + acc.re.1, acc.im.0 + acc.im.1)
    });
    out.is_all_finite().then_some(out)
}

/// [`response_extended`] by mixed-precision iterative refinement: `s I - A`
/// factored once in double (LU with partial pivoting), then `x <- x + (s I -
/// A)^-1 r` with the residual `r = B - (s I - A) x` and `x` itself in
/// double-double (Wilkinson 1963; Higham, *Accuracy and Stability*, §12.1:
/// each step gains about `-log10(cond eps)` digits while `cond eps < 1`),
/// and `C x + D` in double-double. `O(n^3)` in double and `O(n^2)` a step
/// in double-double, against `O(n^3)` in double-double for the elimination.
/// `None` when the corrections do not shrink to `2^-100` of `x` (a
/// matrix too ill-conditioned for double-precision factors to steer); the
/// caller then eliminates in double-double.
pub(crate) fn response_refined(
    sys: &crate::lti::StateSpace,
    s: crate::lti::c64,
) -> Option<Mat<crate::lti::c64>> {
    use crate::lti::c64;
    type Cx = num_complex::Complex<faer::fx128>;
    let cx = |z: c64| Cx::new(z.re.into(), z.im.into());
    let round = |z: Cx| c64::new(z.re.0 + z.re.1, z.im.0 + z.im.1);
    let (n, m) = (sys.a.nrows(), sys.b.ncols());
    let lu = fts_kernels::dense::lu_c64(sys.shifted(s).as_ref());
    let b = Mat::from_fn(n, m, |i, j| c64::new(sys.b[(i, j)], 0.0));
    let first = fts_kernels::dense::lu_c64_solve(&lu, b.as_ref());
    let mut x: Vec<Cx> = (0..n * m).map(|k| cx(first[(k % n, k / n)])).collect();
    let (sx, mut previous) = (cx(s), f64::INFINITY);
    for _ in 0..12 {
        let residual = Mat::from_fn(n, m, |i, c| {
            let col = &x[c * n..(c + 1) * n];
            let mut acc = cx(c64::new(sys.b[(i, c)], 0.0)) - sx * col[i];
            for (j, xj) in col.iter().enumerate() {
                acc += *xj * faer::fx128::from(sys.a[(i, j)]);
            }
            round(acc)
        });
        let d = fts_kernels::dense::lu_c64_solve(&lu, residual.as_ref());
        let size = |z: c64| z.re.abs() + z.im.abs();
        let mut dn: f64 = 0.0;
        for (k, xk) in x.iter_mut().enumerate() {
            let dk = d[(k % n, k / n)];
            dn = dn.max(size(dk));
            *xk += cx(dk);
        }
        let xn = x.iter().map(|&z| size(round(z))).fold(0.0, f64::max);
        if !(dn.is_finite() && xn.is_finite()) || dn > 0.5 * previous {
            return None;
        }
        if dn <= 2f64.powi(-100) * xn {
            return output_extended(sys, |k, j| x[j * n + k]);
        }
        previous = dn;
    }
    None
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
