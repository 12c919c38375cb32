//! Stability certified by the argument principle, on the unit circle
//! (discrete) and on the imaginary axis (continuous, [`roots_left`]).
//!
//! The number of roots of `p` inside the unit circle is the winding number
//! of `p(e^{j theta})`, `theta` from 0 to `2 pi`, about 0, provided `p` has
//! no root on the circle. The walk proves both with rigorous rounding
//! bounds, in `f64` or, where that is too coarse, double-double:
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

// `!(x < y)` is deliberate: it is also true for NaN, which must fail a test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::super::c64;
use super::{Dd, UNIT_ROUNDOFF, gamma};

/// Taylor terms computed at each point (`K`); the rest are bounded.
const TAYLOR_TERMS: usize = 24;
/// Radii `R = max(ratio r, least)` of the Cauchy circles tried for the
/// tail beyond `K` terms (`r` the arc's radius): the tail shrinks like
/// `(r / R)^(K + 1)` while `M(R)` grows like `(1 + R)^n`.
const CAUCHY_RADII: [(f64, f64); 5] =
    [(4.0, 0.0), (8.0, 0.0), (16.0, 0.0), (4.0, 0.05), (4.0, 0.2)];
/// Arcs shorter than this (relative to `max(1, |z|)`) mean a root (as good
/// as) on the curve.
const MIN_ARC: f64 = 1e-9;
/// Arcs walked before giving up (a degree-160 polynomial with poles at
/// moduli 0.7-0.99 takes about 4,000).
pub const MAX_STEPS: usize = 20_000;
/// Added to every arc on the circle: covers the rounding of `cos`, `sin`
/// and of the angle's sum (each well below 1e-15 near `2 pi`).
const CIRCLE_SLACK: f64 = 1e-14;

/// The number of roots of `p` (descending, finite, `p[0] != 0`) strictly
/// inside the unit circle, certified; `None` when the walk cannot prove it.
/// The Taylor coefficients are computed in `f64` and, when its rounding
/// bound swamps `|p|` somewhere on the circle (`sum |a_i|` large against
/// the dips of `|p|`), again in double-double.
pub fn roots_inside(p: &[f64]) -> Option<usize> {
    walk_circle(p, Precision::Double).or_else(|| walk_circle(p, Precision::DoubleDouble))
}

/// The number of roots of `p` (descending, real, finite, `p[0] != 0`) in
/// the open left half plane, certified by the argument principle on the
/// imaginary axis; `None` when the walk cannot prove it (a root on or
/// within the rounding bounds of the axis).
///
/// With no root on the axis, `arg p(j w)` grows by `pi (n_L - n_R)` from
/// `w = -inf` to `inf`, half of it on `w >= 0` (real coefficients). The
/// walk certifies `[0, W]`, `W` beyond which `|p(j w) / (a_0 (j w)^n) - 1|
/// <= 1/2` (so the rest of the increment is the principal argument of
/// `a_0 j^n / p(j W)`).
pub fn roots_left(p: &[f64]) -> Option<usize> {
    let p = balanced(p);
    walk_axis(&p, Precision::Double).or_else(|| walk_axis(&p, Precision::DoubleDouble))
}

/// `p(sigma s)` for the power of two `sigma` nearest the geometric mean of
/// the roots' moduli, `|a_n / a_0|^(1/n)`, when every coefficient scales
/// exactly (no overflow, underflow or subnormal): the roots' half planes
/// are unchanged, and a wide-band polynomial's values stay in range on the
/// axis. Otherwise `p` as it is.
fn balanced(p: &[f64]) -> Vec<f64> {
    let n = p.len() - 1;
    let (first, last) = (p[0], p[n]);
    if last == 0.0 {
        return p.to_vec();
    }
    let exponent = ((last / first).abs().log2() / n as f64).round() as i32;
    let scaled: Vec<f64> = p
        .iter()
        .enumerate()
        .map(|(i, &a)| a * 2f64.powi(exponent * (n - i) as i32))
        .collect();
    let exact = scaled.iter().zip(p).enumerate().all(|(i, (&b, &a))| {
        b.is_finite()
            && (a == 0.0 || b.is_normal())
            && b / 2f64.powi(exponent * (n - i) as i32) == a
    });
    if exact { scaled } else { p.to_vec() }
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
    let (mut theta, mut arc, mut total) = (0.0f64, 0.05f64, 0.0f64);
    for _ in 0..MAX_STEPS {
        arc = walk.longest_arc(&current, (2.0 * arc).min(0.5), CIRCLE_SLACK)?;
        let next_theta = theta + arc;
        if next_theta >= std::f64::consts::TAU + 4.0 * f64::EPSILON {
            total += turn(current.c[0], first.c[0]);
            let turns = total / std::f64::consts::TAU;
            return nearest_count(turns, n);
        }
        let next = walk.taylor_at(c64::new(next_theta.cos(), next_theta.sin()));
        total += turn(current.c[0], next.c[0]);
        (theta, current) = (next_theta, next);
    }
    None
}

fn walk_axis(p: &[f64], precision: Precision) -> Option<usize> {
    let n = p.len().checked_sub(1)?;
    if n == 0 {
        return Some(0);
    }
    let far = far_frequency(p)?;
    let walk = Walk::new(p, precision);
    let mut current = walk.taylor_at(c64::new(0.0, 0.0));
    let (mut w, mut arc, mut total) = (0.0f64, far / 64.0, 0.0f64);
    for _ in 0..MAX_STEPS {
        // The sum's rounding: the next point lies at most 2u (w + arc)
        // beyond w + arc.
        let slack = 4.0 * UNIT_ROUNDOFF * (w + 2.0 * arc);
        arc = walk.longest_arc(&current, 2.0 * arc, slack)?;
        let next_w = (w + arc).min(far);
        let next = walk.taylor_at(c64::new(0.0, next_w));
        // The computed value at W must itself be within 30 degrees of the
        // true one for the closing increment.
        if next_w == far && !(walk.spread(&next, 0.0) <= 0.5 * next.c[0].norm()) {
            return None;
        }
        total += turn(current.c[0], next.c[0]);
        (w, current) = (next_w, next);
        if w == far {
            let limit = c64::new(p[0], 0.0) * c64::new(0.0, 1.0).powi(n as i32);
            total += turn(current.c[0], limit);
            // Twice the increment on w >= 0 over pi is n_L - n_R.
            let difference = 2.0 * total / std::f64::consts::PI;
            let k = difference.round();
            let odd = (n as f64 - k).rem_euclid(2.0) != 0.0;
            if !((difference - k).abs() < 0.25) || odd || k.abs() > n as f64 {
                return None;
            }
            return Some(((n as f64 + k) / 2.0) as usize);
        }
    }
    None
}

/// A frequency `W` with `sum_{k>=1} |a_k| W^-k <= |a_0| / 3` (so also
/// beyond it): four times Fujiwara's bound `max |a_k / a_0|^(1/k)`, doubled
/// while rounding could spoil the check.
fn far_frequency(p: &[f64]) -> Option<f64> {
    let a0 = p[0].abs();
    let bound = p
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, a)| (a.abs() / a0).powf(1.0 / k as f64))
        .fold(0.0, f64::max);
    let mut far = 4.0 * bound.max(f64::MIN_POSITIVE);
    let inflate = 1.0 + gamma(UNIT_ROUNDOFF, 4.0 * p.len() as f64 + 8.0);
    for _ in 0..8 {
        let sum: f64 = p
            .iter()
            .enumerate()
            .skip(1)
            .map(|(k, a)| a.abs() / a0 / far.powi(k as i32))
            .sum();
        if far.is_finite() && sum * inflate <= 1.0 / 3.0 {
            return Some(far);
        }
        far *= 2.0;
    }
    None
}

/// The principal argument of `to / from`, in `(-pi, pi]`, from the two
/// arguments (a quotient of values near `f64::MAX` would overflow).
fn turn(from: c64, to: c64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let d = to.arg() - from.arg();
    if d > PI {
        d - TAU
    } else if d <= -PI {
        d + TAU
    } else {
        d
    }
}

/// `round(turns)` when it is within 0.25 of `turns` and a count `<= n`.
fn nearest_count(turns: f64, n: usize) -> Option<usize> {
    let count = turns.round();
    ((turns - count).abs() < 0.25 && count >= 0.0 && count <= n as f64).then_some(count as usize)
}

/// The polynomial and the arithmetic of its expansions.
struct Walk<'a> {
    p: &'a [f64],
    /// `gamma` bound factor of the computed coefficients' errors.
    error_factor: f64,
    precision: Precision,
}

/// Taylor coefficients `c_0..c_K` of `p` about `z` as computed, upper
/// bounds on those of `sum |a_i| x^(n - i)` at `x = |z|` (which bound the
/// computed ones' errors), and `z`.
#[derive(Clone)]
struct Expansion {
    c: Vec<c64>,
    absolute: Vec<f64>,
    z: c64,
}

impl<'a> Walk<'a> {
    fn new(p: &'a [f64], precision: Precision) -> Self {
        let n = p.len() - 1;
        // Each coefficient passes through at most n + 1 complex
        // multiply-adds (Higham Sec. 3.6: sqrt(2) gamma_2 a product,
        // u a sum), bounded generously by gamma_{6(n+1)+8}; double-double
        // with the unit 2^-100 (a generous bound on its per-operation
        // error, as in `horner_double_double`).
        let unit = match precision {
            Precision::Double => UNIT_ROUNDOFF,
            Precision::DoubleDouble => 2f64.powi(-100),
        };
        Walk {
            p,
            error_factor: gamma(unit, 6.0 * (n as f64 + 1.0) + 8.0),
            precision,
        }
    }

    /// The Taylor coefficients about `z`, rounded to `f64` (the rounding of
    /// a double-double result is charged in [`Walk::spread`]).
    fn taylor_at(&self, z: c64) -> Expansion {
        let n = self.p.len() - 1;
        let terms = TAYLOR_TERMS.min(n);
        let c = match self.precision {
            Precision::Double => {
                let start = self.p.iter().map(|&a| c64::new(a, 0.0));
                synthetic_divisions(start, terms, |q, a| a + z * q)
            }
            Precision::DoubleDouble => {
                let start = self.p.iter().map(|&a| (Dd(a, 0.0), Dd::ZERO));
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
        // Nonnegative data: the recursion's rounding is at most gamma_{2n}
        // relative, so inflating by gamma_{2n+4} gives upper bounds.
        let x = z.norm() * (1.0 + 4.0 * UNIT_ROUNDOFF);
        let inflate = 1.0 + gamma(UNIT_ROUNDOFF, 2.0 * n as f64 + 4.0);
        let absolute = synthetic_divisions(self.p.iter().map(|a| a.abs()), terms, |q, a| a + x * q)
            .into_iter()
            .map(|v| v * inflate)
            .collect();
        Expansion { c, absolute, z }
    }

    /// Bound on `|p(w) - c_0|` (computed `c_0`) over `|w - z| <= r`.
    fn spread(&self, e: &Expansion, r: f64) -> f64 {
        let slack = 1.0 + 4.0 * UNIT_ROUNDOFF;
        // The computed c_0's own error, and (double-double) its rounding to
        // f64, which moves the centre by at most 2u |c_0|.
        let mut sum = self.error_factor * e.absolute[0] + 2.0 * UNIT_ROUNDOFF * e.c[0].norm();
        let mut power = 1.0;
        for m in 1..e.c.len() {
            power *= r;
            sum += (e.c[m].norm() * slack + self.error_factor * e.absolute[m]) * power;
        }
        let sum_rounding = 1.0 + gamma(UNIT_ROUNDOFF, 2.0 * TAYLOR_TERMS as f64 + 8.0);
        (sum + self.tail(e, r)) * sum_rounding
    }

    /// Cauchy's bound on the terms beyond `K` over `|w - z| <= r`: for any
    /// `R > r`, `sum_{m > K} M(R) (r / R)^m = M(R) q^(K+1) / (1 - q)`,
    /// `q = r / R`; the least over a few radii (a small `R` keeps `M` near
    /// `p`'s size at `z`, a large one makes `q` small).
    fn tail(&self, e: &Expansion, r: f64) -> f64 {
        let n = self.p.len() - 1;
        if e.c.len() > n || r == 0.0 {
            return 0.0;
        }
        let modulus = e.z.norm() * (1.0 + 4.0 * UNIT_ROUNDOFF);
        let inflate = 1.0 + gamma(UNIT_ROUNDOFF, 2.0 * n as f64 + 8.0);
        let scale = modulus.max(1.0);
        CAUCHY_RADII
            .iter()
            .map(|&(ratio, least)| (ratio * r).max(least * scale))
            .map(|radius| {
                // The sum may round down; the Horner bound below does not
                // cover that.
                let x = (modulus + radius) * (1.0 + 2.0 * UNIT_ROUNDOFF);
                let m = self.p.iter().fold(0.0, |m, &a| m * x + a.abs()) * inflate;
                let q = r / radius;
                m * q.powi(e.c.len() as i32) / (1.0 - q)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The longest step from `e.z`, at most `guess`, halving, whose image
    /// (over `|w - z| <= step + slack`) stays within `|c_0| / 2` of the
    /// computed `c_0`.
    fn longest_arc(&self, e: &Expansion, guess: f64, slack: f64) -> Option<f64> {
        let limit = 0.5 * e.c[0].norm() * (1.0 - 4.0 * UNIT_ROUNDOFF);
        let smallest = MIN_ARC * e.z.norm().max(1.0);
        // Written so that NaN or an overflow fails, never passes.
        let holds = |arc: f64| self.spread(e, arc + slack) <= limit && limit < f64::INFINITY;
        let mut arc = guess;
        while !holds(arc) {
            arc *= 0.5;
            if arc < smallest {
                return None;
            }
        }
        Some(arc)
    }
}

/// `terms + 1` synthetic divisions by `(x - z)` of the descending
/// `coefficients`: the remainders, which are the Taylor coefficients about
/// `z` (`step(q, a)` is one Horner step `a + z q`).
fn synthetic_divisions<T: Copy>(
    coefficients: impl ExactSizeIterator<Item = T>,
    terms: usize,
    step: impl Fn(T, T) -> T,
) -> Vec<T> {
    // Division `j` turns the sequence `w_(j-1)` into `w_j`, `w_j[i] =
    // step(w_j[i-1], w_(j-1)[i])` for `1 <= i < len - j` (`w_(-1)` the
    // coefficients), and yields its last value, `c_j = w_j[len - 1 - j]`.
    // Walking `i` in the outer loop and the divisions in the inner one
    // makes the same steps on the same operands (so the same values, bit
    // for bit) as one division after the other, but each division's chain
    // no longer waits for the whole previous division: consecutive `i`
    // overlap in the pipeline.
    let len = coefficients.len();
    let mut coefficients = coefficients;
    let Some(first) = coefficients.next() else {
        return Vec::new();
    };
    let terms = terms.min(len - 1);
    // `c_j` for the divisions that never step (`len - 1 - j == 0`).
    let mut out = vec![first; terms + 1];
    // Last value of each division so far; every division starts at w[0].
    let mut last = vec![first; terms + 1];
    for (i, a) in coefficients.enumerate().map(|(k, a)| (k + 1, a)) {
        // Divisions that still reach index i: j < len - i.
        let reaching = (len - i).min(terms + 1);
        let mut v = a;
        for q in &mut last[..reaching] {
            v = step(*q, v);
            *q = v;
        }
        // Index i is the last of division len - 1 - i.
        if len - i <= terms + 1 {
            out[len - 1 - i] = v;
        }
    }
    out
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn synthetic_divisions_are_taylor_coefficients() {
        // p(x) = x^3 - 2x + 5 about 2: p(2) = 9, p'(2) = 10, p''(2)/2 = 6, 1.
        let c = synthetic_divisions([1.0, 0.0, -2.0, 5.0].into_iter(), 3, |q, a| a + 2.0 * q);
        assert_eq!(c, vec![9.0, 10.0, 6.0, 1.0]);
    }

    pub fn counts_roots_inside_closed_forms() {
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

    pub fn counts_roots_left_closed_forms() {
        // s + 1; a lightly damped pair either side of the axis; (s+1)(s-2).
        assert_eq!(roots_left(&[1.0, 1.0]), Some(1));
        assert_eq!(roots_left(&[-3.0, 1.0]), Some(0));
        assert_eq!(roots_left(&[1.0, 0.02, 1.0]), Some(2));
        assert_eq!(roots_left(&[1.0, -0.02, 1.0]), Some(0));
        assert_eq!(roots_left(&[1.0, -1.0, -2.0]), Some(1));
        // (s + 1e-3)(s + 1e3)(s^2 + 2e-4 s + 1e4): eight decades, one
        // barely damped pair.
        let mut p = vec![1.0];
        for f in [vec![1.0, 1e-3], vec![1.0, 1e3], vec![1.0, 2e-4, 1e4]] {
            let mut next = vec![0.0; p.len() + f.len() - 1];
            for (i, a) in p.iter().enumerate() {
                for (j, b) in f.iter().enumerate() {
                    next[i + j] += a * b;
                }
            }
            p = next;
        }
        assert_eq!(roots_left(&p), Some(4));
        // On the axis: s^2 + 1, s.
        assert_eq!(roots_left(&[1.0, 0.0, 1.0]), None);
        assert_eq!(roots_left(&[1.0, 0.0]), None);
    }
}
