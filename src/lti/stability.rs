//! Exact stability verdicts on polynomial coefficients as stored.
//!
//! A stored `f64` is an exact dyadic rational, so the Schur–Cohn (discrete)
//! and Routh (continuous) recursions can be run without rounding in
//! rational arithmetic. That matters for clustered roots: rounding the
//! expansion of a `k`-fold root moves the roots by about `eps^(1/k)`, so a
//! verdict from computed root moduli can say "stable" for a polynomial
//! whose stored coefficients have a root outside the unit circle (the float
//! expansion of `(1 - 0.99 z^-1)^8` has one at `|z| = 1.00567`). Root
//! finders answer where the poles are; these tests answer whether the
//! polynomial as given is stable.
//!
//! The rationals are reduced at every step, so their size grows with the
//! Schur–Cohn / Routh minors (linearly in the degree), not exponentially;
//! degrees above [`EXACT_MAX_DEGREE`] are not attempted (`None`), and a
//! recursion whose work exceeds [`EXACT_MAX_WORK`] is abandoned
//! (`None`): coefficients with full 53-bit mantissas make the rationals
//! about 115 bits longer per step, and `fts zpetc` on a random degree-60
//! denominator spent 2.3 s of CPU here (90 % of it in big-integer gcds),
//! growing steeply with the degree up to the cut-off at 100
//! (docs/benchmarks.md, "Every size from 2 to 160 states").

use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{Signed, Zero};

/// Highest degree tested exactly (a degree-100 polynomial with coefficients
/// spread over 1e-10..1e10 takes tens of milliseconds).
pub const EXACT_MAX_DEGREE: usize = 100;

/// Work, in (64-bit words)^2 summed over the rationals of every row, after
/// which the exact recursions give up (`None`: the caller takes computed
/// roots). Every operation on a rational takes a gcd, whose cost grows as
/// the square of the length. Full-mantissa coefficients make the rationals
/// about 115 bits longer per step, so this decides those up to degree 13
/// or so exactly (random degree-12 root sets, as in the tests below, spend
/// at most about 3,000; the clustered poles of `tests/data/stability`, up
/// to 8-fold, at most 823). Measured on `fts zpetc` with a random
/// degree-100 denominator (release, loaded machine): a bound of 2048 bits
/// on the length alone left 0.6 s of gcds, a work bound of 100,000 left
/// 0.12 s, against 14 ms for degree 101 where the computed roots decide.
pub const EXACT_MAX_WORK: u64 = 10_000;

/// Work spent so far by an exact recursion (see [`EXACT_MAX_WORK`]).
struct Budget(u64);

impl Budget {
    /// Charges a new row; true once the budget is exhausted.
    fn exhausted_by(&mut self, row: &[BigRational]) -> bool {
        for x in row {
            let words = x.numer().bits().max(x.denom().bits()) / 64 + 1;
            self.0 += words * words;
        }
        self.0 > EXACT_MAX_WORK
    }
}

fn exact(x: f64) -> BigRational {
    // Finite floats are checked by the callers; from_float is exact.
    BigRational::from_float(x).unwrap_or_else(|| BigRational::from_integer(BigInt::zero()))
}

/// Coefficients after leading zeros, if all are finite, the polynomial is
/// not zero and its degree is within [`EXACT_MAX_DEGREE`].
fn usable(descending: &[f64]) -> Option<&[f64]> {
    if descending.iter().any(|c| !c.is_finite()) {
        return None;
    }
    let start = descending.iter().position(|&c| c != 0.0)?;
    let p = &descending[start..];
    (p.len() - 1 <= EXACT_MAX_DEGREE).then_some(p)
}

/// Whether every root of `c[0] z^n + c[1] z^(n-1) + ... + c[n]` lies
/// strictly inside the unit circle (Schur stability), decided exactly on the
/// stored coefficients. A discrete denominator in ascending powers of
/// `z^-1`, `a0 + a1 z^-1 + ... + an z^-n`, is this polynomial as it stands.
///
/// Schur–Cohn reduction (Jury 1964; Åström & Wittenmark, *Computer-
/// Controlled Systems*, Sec. 3.3): with `p(z) = sum c_k z^k` (ascending),
/// `p` is Schur stable iff `|c_0| < |c_n|` and
/// `q(z) = (c_n p(z) - c_0 p*(z)) / z` is, `p*` the reversed polynomial.
/// `None` when the degree exceeds [`EXACT_MAX_DEGREE`], the work exceeds
/// [`EXACT_MAX_WORK`], a coefficient is not finite, or all are zero.
pub fn schur_stable(descending: &[f64]) -> Option<bool> {
    let p = usable(descending)?;
    let mut c: Vec<BigRational> = p.iter().rev().map(|&x| exact(x)).collect();
    let mut budget = Budget(0);
    while c.len() > 1 {
        let n = c.len() - 1;
        let (c0, cn) = (c[0].clone(), c[n].clone());
        if c0.abs() >= cn.abs() {
            return Some(false);
        }
        // Made monic at each step: the reduced rationals stay small.
        let lead = &cn * &cn - &c0 * &c0;
        c = (0..n)
            .map(|k| (&cn * &c[k + 1] - &c0 * &c[n - 1 - k]) / &lead)
            .collect();
        if budget.exhausted_by(&c) {
            return None;
        }
    }
    Some(true)
}

/// Whether every root of `c[0] s^n + c[1] s^(n-1) + ... + c[n]` lies in the
/// open left half plane (Hurwitz stability), decided exactly on the stored
/// coefficients: the first column of the Routh array is non-zero and of one
/// sign (Routh 1877; a zero entry means a root on or right of the axis, so
/// the polynomial is not Hurwitz). `None` as for [`schur_stable`].
pub fn hurwitz_stable(descending: &[f64]) -> Option<bool> {
    let p = usable(descending)?;
    let a: Vec<BigRational> = p.iter().map(|&x| exact(x)).collect();
    let n = a.len() - 1;
    let mut upper: Vec<BigRational> = a.iter().step_by(2).cloned().collect();
    let mut lower: Vec<BigRational> = a.iter().skip(1).step_by(2).cloned().collect();
    let positive = a[0].is_positive();
    let mut budget = Budget(0);
    for _ in 0..n {
        let pivot = match lower.first() {
            Some(x) if !x.is_zero() && x.is_positive() == positive => x.clone(),
            _ => return Some(false),
        };
        let at =
            |row: &[BigRational], i: usize| row.get(i).cloned().unwrap_or_else(BigRational::zero);
        let next: Vec<BigRational> = (0..upper.len().max(lower.len()).saturating_sub(1))
            .map(|i| (&pivot * at(&upper, i + 1) - &upper[0] * at(&lower, i + 1)) / &pivot)
            .collect();
        if budget.exhausted_by(&next) {
            return None;
        }
        upper = std::mem::replace(&mut lower, next);
    }
    Some(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Descending coefficients of `prod (x - r)`.
    fn expand(roots: &[f64]) -> Vec<f64> {
        let mut c = vec![1.0];
        for &r in roots {
            let mut next = c.clone();
            next.push(0.0);
            for (i, &ci) in c.iter().enumerate() {
                next[i + 1] -= r * ci;
            }
            c = next;
        }
        c
    }

    #[test]
    fn schur_closed_forms() {
        assert_eq!(schur_stable(&expand(&[0.5, -0.9, 0.99])), Some(true));
        assert_eq!(schur_stable(&expand(&[0.5, 1.01])), Some(false));
        // On the circle is not stable.
        assert_eq!(schur_stable(&expand(&[1.0, 0.5])), Some(false));
        assert_eq!(schur_stable(&expand(&[-1.0])), Some(false));
        // Complex pair 0.9 e^{±j}: z^2 - 1.8 cos(1) z + 0.81.
        let c1 = 1.8 * 1f64.cos();
        assert_eq!(schur_stable(&[1.0, -c1, 0.81]), Some(true));
        assert_eq!(schur_stable(&[1.0, -c1 * 1.2, 0.81 * 1.44]), Some(false));
        // Roots at the origin and leading zeros.
        assert_eq!(schur_stable(&[0.0, 1.0, 0.0, 0.0]), Some(true));
        assert_eq!(schur_stable(&[0.0, 0.0]), None);
        assert_eq!(schur_stable(&[1.0, f64::NAN]), None);
    }

    #[test]
    fn clustered_root_as_stored_is_unstable() {
        // numpy's float expansion of (z - 0.99)^8 as stored: its largest
        // root has modulus 1.00567 (200-digit roots of these very floats,
        // tests/data/stability/gen_clusters.py), though every root finder
        // in f64 puts all eight inside.
        let den = [
            1.0,
            -7.920000000000001,
            27.442800000000002,
            -54.336743999999996,
            67.2417207,
            -53.2554427944,
            26.361444183227995,
            -7.456522783255918,
            0.92274469442792,
        ];
        assert_eq!(schur_stable(&den), Some(false));
        // Scaling by a power of two is exact and changes nothing.
        let scaled: Vec<f64> = den.iter().map(|c| c * 1024.0).collect();
        assert_eq!(schur_stable(&scaled), Some(false));
    }

    #[test]
    fn hurwitz_closed_forms() {
        assert_eq!(hurwitz_stable(&expand(&[-1.0, -2.0, -3.0])), Some(true));
        assert_eq!(hurwitz_stable(&expand(&[-1.0, 2.0])), Some(false));
        // s^2 + 1: roots on the axis.
        assert_eq!(hurwitz_stable(&[1.0, 0.0, 1.0]), Some(false));
        // Negative leading coefficient: same roots.
        assert_eq!(hurwitz_stable(&[-1.0, -3.0, -2.0]), Some(true));
        // s^3 + s^2 + 2 s + 8 has a right-half-plane pair.
        assert_eq!(hurwitz_stable(&[1.0, 1.0, 2.0, 8.0]), Some(false));
        // s^3 + 2 s^2 + 3 s + 1 (Routh column 1, 2, 2.5, 1).
        assert_eq!(hurwitz_stable(&[1.0, 2.0, 3.0, 1.0]), Some(true));
        assert_eq!(hurwitz_stable(&[5.0]), Some(true));
        // A root at the origin.
        assert_eq!(hurwitz_stable(&[1.0, 1.0, 0.0]), Some(false));
    }

    #[test]
    fn full_mantissa_coefficients_stop_at_the_work_budget() {
        // 1 + sum a_k z^-k with sum |a_k| = 0.5 and full 53-bit mantissas:
        // stable by Rouche on |z| = 1. Exactly, the Schur–Cohn rationals
        // grow ~115 bits a step; the recursion now stops at EXACT_MAX_WORK
        // (None: the caller takes the computed roots) instead of taking
        // tens of seconds at degree 100. A short one is still decided.
        let mut seed = 20261127u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let a: Vec<f64> = (0..100).map(|_| rnd()).collect();
        let scale = 0.5 / a.iter().map(|x| x.abs()).sum::<f64>();
        let den: Vec<f64> = std::iter::once(1.0)
            .chain(a.iter().map(|x| x * scale))
            .collect();
        let started = std::time::Instant::now();
        assert_eq!(schur_stable(&den), None);
        assert!(
            started.elapsed().as_secs_f64() < 5.0,
            "{:?}",
            started.elapsed()
        );
        assert_eq!(schur_stable(&den[..6]), Some(true));
    }

    #[test]
    fn agrees_with_well_separated_roots() {
        // Random real and complex roots away from the boundary: the exact
        // verdicts equal the verdicts from the roots themselves.
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..300 {
            let n = 1 + (rnd() * 12.0) as usize;
            let radii: Vec<f64> = (0..n).map(|_| 0.05 + 1.9 * rnd()).collect();
            let radii: Vec<f64> = radii
                .into_iter()
                .filter(|r| (r - 1.0).abs() > 0.02)
                .collect();
            let roots: Vec<f64> = radii
                .iter()
                .map(|&r| if rnd() < 0.5 { r } else { -r })
                .collect();
            let c = expand(&roots);
            let inside = roots.iter().all(|r| r.abs() < 1.0);
            assert_eq!(schur_stable(&c), Some(inside), "{roots:?}");
            let s_roots: Vec<f64> = roots.iter().map(|r| r - 1.0).collect();
            let left = s_roots.iter().all(|r| *r < 0.0);
            assert_eq!(hurwitz_stable(&expand(&s_roots)), Some(left), "{s_roots:?}");
        }
    }
}
