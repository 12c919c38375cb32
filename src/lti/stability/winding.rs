//! Schur stability certified by the argument principle on the unit circle.
//!
//! The number of roots of `p` inside the unit circle is the winding number
//! of `p(e^{j theta})`, `theta` from 0 to `2 pi`, about 0, provided `p` has
//! no root on the circle. The walk proves both with rigorous rounding
//! bounds, in `f64`:
//!
//! * at a point `z` near the circle it computes the Taylor coefficients
//!   `c_m` of `p` about `z` (`m <= K`, repeated synthetic division) with
//!   Higham's bound on their errors (*Accuracy and Stability of Numerical
//!   Algorithms*, 2nd ed., Sec. 5.1, `gamma_k` on the same recursion run on
//!   `|a_i|`), and bounds the remaining terms by Cauchy's estimate
//!   `|c_m| <= M / R^m`, `M = sum |a_i| (|z| + R)^(n - i)` the absolute
//!   polynomial, which bounds `|p|` on the disc of radius `R`;
//! * it takes the longest arc from `z` whose image provably stays in the
//!   disc of radius `|c_0| / 2` about the computed `c_0`: that disc holds
//!   no zero, so `p` has no root on the arc, and any two of its points are
//!   within 60 degrees of each other as seen from 0;
//! * consecutive computed values are therefore within 120 degrees
//!   (the true value at the next point lies in both discs), so the
//!   principal argument of their ratio is the continuous argument's
//!   increment, and the increments add up to `2 pi` times the winding
//!   number exactly; the sum is rounded to the nearest integer only when
//!   it is within 0.25 of one.
//!
//! It decides what root inclusion discs cannot at high degree: the
//! polynomial's roots need not be isolated, only its values on the circle
//! kept away from 0. Where `|p|` on the circle falls to its rounding bound
//! (a root within about `n eps sum |a_i|` of the circle) or the walk needs
//! more than [`MAX_STEPS`] arcs, it gives up (`None`).

use super::super::c64;
use super::{Dd, UNIT_ROUNDOFF, gamma};

/// Taylor terms computed at each point (`K`); the rest are bounded.
const TAYLOR_TERMS: usize = 24;
/// Radii `R = max(ratio r, least)` of the Cauchy circles tried for the
/// tail beyond `K` terms (`r` the arc's radius): the tail shrinks like
/// `(r / R)^(K + 1)` while `M(R)` grows like `(1 + R)^n`.
const CAUCHY_RADII: [(f64, f64); 5] =
    [(4.0, 0.0), (8.0, 0.0), (16.0, 0.0), (4.0, 0.05), (4.0, 0.2)];
/// Arcs shorter than this mean a root (as good as) on the circle.
const MIN_ARC: f64 = 1e-9;
/// Arcs walked before giving up (a degree-160 polynomial with poles at
/// moduli 0.7-0.99 takes about 4,000).
pub const MAX_STEPS: usize = 40_000;
/// Added to every arc's radius: covers the rounding of `cos`, `sin` and of
/// the angle's sum (each well below 1e-15 near `2 pi`).
const ARC_SLACK: f64 = 1e-14;

/// The number of roots of `p` (descending, finite, `p[0] != 0`) strictly
/// inside the unit circle, certified; `None` when the walk cannot prove it.
/// The Taylor coefficients are computed in `f64` and, when its rounding
/// bound swamps `|p|` somewhere on the circle (`sum |a_i|` large against
/// the dips of `|p|`), again in double-double.
pub fn roots_inside(p: &[f64]) -> Option<usize> {
    walk_circle(p, Precision::Double).or_else(|| walk_circle(p, Precision::DoubleDouble))
}

/// Arithmetic of the Taylor coefficients.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Precision {
    Double,
    DoubleDouble,
}

fn walk_circle(p: &[f64], precision: Precision) -> Option<usize> {
    let n = p.len().checked_sub(1)?;
    if n == 0 {
        return Some(0);
    }
    let walk = Walk::new(p, precision);
    let first = walk.taylor_at(c64::new(1.0, 0.0));
    let mut current = first.clone();
    let (mut theta, mut arc, mut total, mut steps) = (0.0f64, 0.05f64, 0.0f64, 0usize);
    loop {
        arc = match walk.longest_arc(&current, (2.0 * arc).min(0.5)) {
            Some(a) => a,
            None => {
                if std::env::var("WDBG").is_ok() {
                    eprintln!(
                        "fail dd={} at theta {theta} step {steps} |c0| {} err0 {} spread(1e-9) {} tail {}",
                        precision == Precision::DoubleDouble,
                        current.c[0].norm(),
                        walk.error_factor * walk.absolute[0],
                        walk.spread(&current, 1e-9),
                        walk.tail(&current, 1e-9)
                    );
                }
                return None;
            }
        };
        steps += 1;
        if steps > MAX_STEPS {
            return None;
        }
        let next_theta = theta + arc;
        if next_theta >= std::f64::consts::TAU + 4.0 * f64::EPSILON {
            total += (first.c[0] / current.c[0]).arg();
            break;
        }
        let next = walk.taylor_at(c64::new(next_theta.cos(), next_theta.sin()));
        total += (next.c[0] / current.c[0]).arg();
        (theta, current) = (next_theta, next);
    }
    let turns = total / std::f64::consts::TAU;
    let winding = turns.round();
    ((turns - winding).abs() < 0.25 && winding >= 0.0 && winding <= n as f64)
        .then_some(winding as usize)
}

/// The polynomial with what every point's bounds need.
struct Walk<'a> {
    p: &'a [f64],
    /// Upper bounds on the Taylor coefficients of `sum |a_i| x^(n - i)` at
    /// `x = 1 + 4u` (every point's modulus is below it), `m <= K`.
    absolute: Vec<f64>,
    /// `gamma` bound factor of the computed coefficients' errors.
    error_factor: f64,
    precision: Precision,
}

/// Taylor coefficients `c_0..c_K` of `p` about `z` as computed, and `z`.
#[derive(Clone)]
struct Expansion {
    c: Vec<c64>,
    z: c64,
}

impl<'a> Walk<'a> {
    fn new(p: &'a [f64], precision: Precision) -> Self {
        let n = p.len() - 1;
        let x = 1.0 + 4.0 * UNIT_ROUNDOFF;
        let terms = TAYLOR_TERMS.min(n);
        // Nonnegative data: the recursion's rounding is at most gamma_{2n}
        // relative, so inflating by gamma_{2n+4} gives upper bounds.
        let inflate = 1.0 + gamma(UNIT_ROUNDOFF, 2.0 * n as f64 + 4.0);
        let absolute =
            synthetic_divisions(p.iter().map(|a| a.abs()).collect(), terms, |q, a| a + x * q)
                .into_iter()
                .map(|v| v * inflate)
                .collect();
        // Each coefficient passes through at most n + 1 complex
        // multiply-adds (Higham Sec. 3.6: sqrt(2) gamma_2 a product,
        // u a sum), bounded generously by gamma_{6(n+1)+8}; double-double
        // with the unit 2^-100 (a generous bound on its per-operation
        // error, as in `horner_double_double`).
        let unit = match precision {
            Precision::Double => UNIT_ROUNDOFF,
            Precision::DoubleDouble => 2f64.powi(-100),
        };
        let error_factor = gamma(unit, 6.0 * (n as f64 + 1.0) + 8.0);
        Walk {
            p,
            absolute,
            error_factor,
            precision,
        }
    }

    /// The Taylor coefficients about `z`, rounded to `f64` (the rounding of
    /// a double-double result is charged in [`Walk::spread`]).
    fn taylor_at(&self, z: c64) -> Expansion {
        let terms = TAYLOR_TERMS.min(self.p.len() - 1);
        let c = match self.precision {
            Precision::Double => {
                let start = self.p.iter().map(|&a| c64::new(a, 0.0)).collect();
                synthetic_divisions(start, terms, |q, a| a + z * q)
            }
            Precision::DoubleDouble => {
                let start = self.p.iter().map(|&a| (Dd(a, 0.0), Dd::ZERO)).collect();
                synthetic_divisions(start, terms, |(qr, qi): (Dd, Dd), (ar, ai)| {
                    (
                        ar.add(qr.mul(z.re)).sub(qi.mul(z.im)),
                        ai.add(qi.mul(z.re)).add(qr.mul(z.im)),
                    )
                })
                .into_iter()
                .map(|(re, im)| c64::new(re.0 + re.1, im.0 + im.1))
                .collect()
            }
        };
        Expansion { c, z }
    }

    /// Bound on `|p(w) - c_0|` (computed `c_0`) over `|w - z| <= r`.
    fn spread(&self, e: &Expansion, r: f64) -> f64 {
        let slack = 1.0 + 4.0 * UNIT_ROUNDOFF;
        // The computed c_0's own error, and (double-double) its rounding to
        // f64, which moves the centre by at most 2u |c_0|.
        let mut sum = self.error_factor * self.absolute[0] + 2.0 * UNIT_ROUNDOFF * e.c[0].norm();
        let mut power = 1.0;
        for m in 1..e.c.len() {
            power *= r;
            sum += (e.c[m].norm() * slack + self.error_factor * self.absolute[m]) * power;
        }
        sum + self.tail(e, r)
    }

    /// Cauchy's bound on the terms beyond `K` over `|w - z| <= r`: for any
    /// `R > r`, `sum_{m > K} M(R) (r / R)^m = M(R) q^(K+1) / (1 - q)`,
    /// `q = r / R`; the least over a few radii (a small `R` keeps `M` near
    /// `p`'s size on the circle, a large one makes `q` small).
    fn tail(&self, e: &Expansion, r: f64) -> f64 {
        let n = self.p.len() - 1;
        if e.c.len() > n {
            return 0.0;
        }
        let modulus = e.z.norm() * (1.0 + 4.0 * UNIT_ROUNDOFF);
        let inflate = 1.0 + gamma(UNIT_ROUNDOFF, 2.0 * n as f64 + 8.0);
        CAUCHY_RADII
            .iter()
            .map(|&(ratio, least)| (ratio * r).max(least))
            .map(|radius| {
                let x = modulus + radius;
                let m = self.p.iter().fold(0.0, |m, &a| m * x + a.abs()) * inflate;
                let q = r / radius;
                m * q.powi(e.c.len() as i32) / (1.0 - q)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The longest arc from `e.z`, at most `guess`, halving, whose image
    /// stays within `|c_0| / 2` of the computed `c_0`.
    fn longest_arc(&self, e: &Expansion, guess: f64) -> Option<f64> {
        let limit = 0.5 * e.c[0].norm() * (1.0 - 4.0 * UNIT_ROUNDOFF);
        let sum_rounding = 1.0 + gamma(UNIT_ROUNDOFF, 2.0 * TAYLOR_TERMS as f64 + 8.0);
        let mut arc = guess;
        while self.spread(e, arc + ARC_SLACK) * sum_rounding > limit {
            arc *= 0.5;
            if arc < MIN_ARC {
                return None;
            }
        }
        Some(arc)
    }
}

/// `terms + 1` synthetic divisions by `(x - z)` of the descending
/// coefficients `work`: the remainders, which are the Taylor coefficients
/// about `z` (`step(q, a)` is one Horner step `a + z q`).
fn synthetic_divisions<T: Copy>(
    mut work: Vec<T>,
    terms: usize,
    step: impl Fn(T, T) -> T,
) -> Vec<T> {
    let mut out = Vec::with_capacity(terms + 1);
    let mut len = work.len();
    for _ in 0..=terms {
        for i in 1..len {
            work[i] = step(work[i - 1], work[i]);
        }
        out.push(work[len - 1]);
        len -= 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_divisions_are_taylor_coefficients() {
        // p(x) = x^3 - 2x + 5 about 2: p(2) = 9, p'(2) = 10, p''(2)/2 = 6, 1.
        let c = synthetic_divisions(vec![1.0, 0.0, -2.0, 5.0], 3, |q, a| a + 2.0 * q);
        assert_eq!(c, vec![9.0, 10.0, 6.0, 1.0]);
    }

    #[test]
    fn counts_roots_inside_closed_forms() {
        // z^n - 0.5^n: all inside; z^n - 2^n: none; (z - 0.5)(z - 2).
        for n in [1, 2, 5, 30, 64] {
            let mut p = vec![0.0; n + 1];
            p[0] = 1.0;
            p[n] = -(0.5f64.powi(n as i32));
            assert_eq!(roots_inside(&p), Some(n), "n {n}");
            p[n] = -(2f64.powi(n as i32));
            assert_eq!(roots_inside(&p), Some(0), "n {n}");
        }
        assert_eq!(roots_inside(&[1.0, -2.5, 1.0]), Some(1));
        // A root on the circle cannot be certified either way.
        assert_eq!(roots_inside(&[1.0, -1.0]), None);
        assert_eq!(roots_inside(&[1.0, 0.0, 1.0]), None);
    }
}
