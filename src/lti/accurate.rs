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

    /// Rounded to `f64`.
    pub fn round(&self) -> Mat<f64> {
        Mat::from_fn(self.hi.nrows(), self.hi.ncols(), |i, j| {
            self.hi[(i, j)] + self.lo[(i, j)]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cancellation_is_exact() {
        // (1 + 2^-40)(1 - 2^-40) - 1 = -2^-80, lost entirely in f64.
        let e = 2f64.powi(-40);
        let a = Mat::from_fn(1, 2, |_, j| [1.0 + e, 1.0][j]);
        let b = Mat::from_fn(2, 1, |i, _| [1.0 - e, -1.0][i]);
        let p = Dd::from(&a).mul(&Dd::from(&b)).round();
        assert_eq!(p[(0, 0)], -2f64.powi(-80));
    }
}
