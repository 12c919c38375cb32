//! Frequency responses at many frequencies for the price of one
//! Hessenberg reduction (Laub 1981, "Efficient multivariable frequency
//! response computations", IEEE TAC 26(2)): `A = Q H Q'` with `H` upper
//! Hessenberg (Householder reflections, faer), then at each frequency
//! `G(s) = (C Q) (sI - H)^-1 (Q' B) + D`, where `(sI - H) X = Q' B` is solved
//! by Gaussian elimination with partial pivoting between adjacent rows in
//! `O(n^2)` per column instead of the `O(n^3)` of a dense LU.

use super::c64;
use super::ss::{StateSpace, frequency_point, sigma_max_c, tr};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::hessenberg;
use faer::linalg::householder;
use faer::linalg::qr::no_pivoting::factor::recommended_block_size;
use faer::{Conj, Mat, Par};

/// A system in Hessenberg coordinates, for repeated frequency responses.
#[derive(Debug, Clone)]
pub struct HessenbergResponse {
    /// Upper Hessenberg `Q' A Q`.
    h: Mat<f64>,
    /// `Q' B`.
    b: Mat<f64>,
    /// `C Q`.
    c: Mat<f64>,
    d: Mat<f64>,
    ts: Option<f64>,
}

/// `A = Q H Q'`: the orthogonal `Q` and the upper Hessenberg `H`.
fn hessenberg_form(a: &Mat<f64>) -> (Mat<f64>, Mat<f64>) {
    let n = a.nrows();
    if n < 2 {
        return (Mat::identity(n, n), a.clone());
    }
    let bs = recommended_block_size::<f64>(n - 1, n - 1);
    let mut h = a.clone();
    let mut factor = Mat::<f64>::zeros(bs, n - 1);
    let params = Default::default();
    let req = hessenberg::hessenberg_in_place_scratch::<f64>(n, bs, Par::Seq, params).or(
        householder::apply_block_householder_sequence_on_the_right_in_place_scratch::<f64>(
            n - 1,
            bs,
            n - 1,
        ),
    );
    let mut buf = MemBuffer::new(req);
    let stack = MemStack::new(&mut buf);
    hessenberg::hessenberg_in_place(h.as_mut(), factor.as_mut(), Par::Seq, stack, params);
    // Q from the reflections stored below the subdiagonal (as faer's own
    // eigenvalue driver forms it).
    let mut q = Mat::<f64>::identity(n, n);
    householder::apply_block_householder_sequence_on_the_right_in_place_with_conj(
        h.as_ref().submatrix(1, 0, n - 1, n - 1),
        factor.as_ref(),
        Conj::No,
        q.as_mut().submatrix_mut(1, 1, n - 1, n - 1),
        Par::Seq,
        stack,
    );
    for j in 0..n {
        for i in j + 2..n {
            h[(i, j)] = 0.0;
        }
    }
    (q, h)
}

impl HessenbergResponse {
    /// Reduces `sys` once (`O(n^3)`).
    pub fn new(sys: &StateSpace) -> Self {
        let (q, h) = hessenberg_form(&sys.a);
        Self {
            h,
            b: tr(&q) * &sys.b,
            c: &sys.c * &q,
            d: sys.d.clone(),
            ts: sys.ts,
        }
    }

    /// `G(s)` at the complex point `s` (`z` when discrete); `None` where
    /// `sI - H` is singular.
    pub fn eval(&self, s: c64) -> Option<Mat<c64>> {
        let (n, m) = (self.h.nrows(), self.b.ncols());
        let mut a = Mat::from_fn(n, n, |i, j| {
            let v = c64::new(-self.h[(i, j)], 0.0);
            if i == j { v + s } else { v }
        });
        let mut x = Mat::from_fn(n, m, |i, j| c64::new(self.b[(i, j)], 0.0));
        hessenberg_solve(&mut a, &mut x)?;
        let c = Mat::from_fn(self.c.nrows(), n, |i, j| c64::new(self.c[(i, j)], 0.0));
        let d = Mat::from_fn(self.d.nrows(), m, |i, j| c64::new(self.d[(i, j)], 0.0));
        let g = &c * &x + &d;
        g.is_all_finite().then_some(g)
    }

    /// `sigma_max(G(j omega))` (`z = e^{j omega ts}` when discrete);
    /// infinite where `G` is not defined, as [`StateSpace::sigma_at`].
    pub fn sigma_at(&self, omega: f64) -> f64 {
        self.eval(frequency_point(self.ts, omega))
            .map_or(f64::INFINITY, |g| sigma_max_c(&g))
    }
}

/// Solves `A X = B` in place (`X` overwrites `B`) for an upper Hessenberg
/// `A` (destroyed) by Gaussian elimination with partial pivoting, which
/// only ever compares and swaps adjacent rows; `None` on a zero pivot.
fn hessenberg_solve(a: &mut Mat<c64>, x: &mut Mat<c64>) -> Option<()> {
    let (n, m) = (a.nrows(), x.ncols());
    for k in 0..n.saturating_sub(1) {
        if a[(k + 1, k)].norm() > a[(k, k)].norm() {
            for j in k..n {
                let t = a[(k, j)];
                a[(k, j)] = a[(k + 1, j)];
                a[(k + 1, j)] = t;
            }
            for j in 0..m {
                let t = x[(k, j)];
                x[(k, j)] = x[(k + 1, j)];
                x[(k + 1, j)] = t;
            }
        }
        if a[(k, k)].norm() == 0.0 {
            return None;
        }
        let f = a[(k + 1, k)] / a[(k, k)];
        for j in k + 1..n {
            let t = a[(k, j)];
            a[(k + 1, j)] -= f * t;
        }
        for j in 0..m {
            let t = x[(k, j)];
            x[(k + 1, j)] -= f * t;
        }
    }
    for j in 0..m {
        for i in (0..n).rev() {
            let mut s = x[(i, j)];
            for l in i + 1..n {
                s -= a[(i, l)] * x[(l, j)];
            }
            if a[(i, i)].norm() == 0.0 {
                return None;
            }
            x[(i, j)] = s / a[(i, i)];
        }
    }
    Some(())
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    /// A deterministic pseudo-random matrix (a linear congruential
    /// generator), entries in [-1, 1).
    fn random(rows: usize, cols: usize, seed: u64) -> Mat<f64> {
        let mut state = seed;
        Mat::from_fn(rows, cols, |_, _| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
    }

    fn system(n: usize, ts: Option<f64>, seed: u64) -> StateSpace {
        let mut a = random(n, n, seed);
        let shift = if ts.is_some() {
            0.0
        } else {
            1.0 + (n as f64).sqrt()
        };
        for i in 0..n {
            a[(i, i)] -= shift;
        }
        if ts.is_some() {
            a = &a * (0.5 / (n as f64).sqrt());
        }
        StateSpace::new(
            a,
            random(n, 3, seed + 1),
            random(2, n, seed + 2),
            random(2, 3, seed + 3),
            ts,
        )
        .unwrap()
    }

    pub fn the_hessenberg_response_is_the_dense_one() {
        for (n, ts) in [
            (1, None),
            (2, None),
            (37, None),
            (90, None),
            (40, Some(1e-3)),
        ] {
            let sys = system(n, ts, 7 + n as u64);
            let fast = HessenbergResponse::new(&sys);
            assert!((0..n).all(|j| (j + 2..n).all(|i| fast.h[(i, j)] == 0.0)));
            for w in [0.0, 0.37, 3.0, 41.0, 900.0] {
                let (dense, hess) = (
                    sys.freq_response(w).unwrap(),
                    fast.eval(frequency_point(ts, w)).unwrap(),
                );
                let err = (&dense - &hess).norm_l2() / dense.norm_l2();
                assert!(err < 1e-12, "n {n}, w {w}: relative difference {err:e}");
                let (s1, s2) = (sys.sigma_at(w), fast.sigma_at(w));
                assert!((s1 - s2).abs() <= 1e-12 * s1, "n {n}, w {w}: {s1} vs {s2}");
            }
        }
    }

    pub fn a_pole_on_the_axis_is_infinite() {
        // G(s) = 1/s at s = 0.
        let sys = StateSpace::new(
            Mat::zeros(1, 1),
            Mat::identity(1, 1),
            Mat::identity(1, 1),
            Mat::zeros(1, 1),
            None,
        )
        .unwrap();
        assert_eq!(HessenbergResponse::new(&sys).sigma_at(0.0), f64::INFINITY);
        assert!((HessenbergResponse::new(&sys).sigma_at(2.0) - 0.5).abs() < 1e-15);
    }
}
