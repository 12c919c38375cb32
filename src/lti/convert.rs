//! Conversions between model forms (docs/responses.md §3):
//!
//! * state space to transfer functions, one per output/input channel, by
//!   `num(s) = det(sI - A + b c) + (d - 1) det(sI - A)` (scipy `ss2tf`);
//! * zeros, poles and gain (MATLAB `zpk`: `G = k prod(s - z_i)/prod(s - p_i)`,
//!   in `z` for discrete systems, zeros and poles at the origin included);
//! * minimal realisations by the orthogonal controllability and
//!   observability staircase (Varga 1981; MATLAB `minreal`);
//! * balanced truncation of discrete systems through the norm- and
//!   Hankel-singular-value-preserving bilinear map;
//! * the inverse of the zero-order-hold discretisation, `d2c`, from the
//!   principal matrix logarithm of `[Ad Bd; 0 I]` (the inverse of Van Loan's
//!   block exponential used by [`super::c2d`]).

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::balred::{Reduced, balred};
use super::c2d::{C2dMethod, bilinear_to_discrete, c2d};
use super::c64;
use super::norms::bilinear_to_continuous;
use super::roots::{RootsError, roots_descending};
use super::ss::{SsError, StateSpace, block2, eigvals, inv, sub, tr};
use super::tf::{ContinuousTf, DiscreteTf, TfError, TransferFunction};
use faer::Mat;

/// Why a conversion failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConvertError {
    /// The model cannot be converted as asked (the message says why).
    #[error("{0}")]
    Refused(String),
    /// A state-space operation failed.
    #[error("{0}")]
    Ss(#[from] SsError),
    /// A transfer function could not be built.
    #[error("{0}")]
    Tf(#[from] TfError),
    /// Root finding failed.
    #[error("{0}")]
    Roots(#[from] RootsError),
    /// The result does not reproduce its input (a numerical failure).
    #[error("{0}")]
    Inaccurate(String),
}

/// The channel `output i <- input j` of `sys`.
pub fn channel(sys: &StateSpace, i: usize, j: usize) -> Result<StateSpace, SsError> {
    let n = sys.nx();
    StateSpace::new(
        sys.a.clone(),
        sub(&sys.b, 0, n, j, j + 1),
        sub(&sys.c, i, i + 1, 0, n),
        sub(&sys.d, i, i + 1, j, j + 1),
        sys.ts,
    )
}

/// Drops the leading numerator coefficients that are rounding residue of
/// `p - den` (relative to the terms they came from), and trailing pairs of
/// residue in both polynomials (a common factor `z`, discrete only).
fn trim_residue(num: &mut Vec<f64>, den: &mut Vec<f64>, p: &[f64], discrete: bool) {
    let n = num.len();
    let residue = |k: usize, x: f64| x.abs() <= 1e-11 * (n as f64) * (p[k].abs() + den[k].abs());
    let lead = (0..n).take_while(|&k| residue(k, num[k])).count();
    if lead == n {
        num.clear();
        return;
    }
    for x in num.iter_mut().take(lead) {
        *x = 0.0;
    }
    if discrete {
        while den.len() > 1 && num.len() > lead + 1 {
            let k = den.len() - 1;
            let scale = 1e-11 * (n as f64) * den.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if den[k].abs() <= scale && num[k].abs() <= scale {
                den.pop();
                num.pop();
            } else {
                break;
            }
        }
    }
}

/// The transfer function of a SISO state-space system.
pub fn siso_tf(sys: &StateSpace) -> Result<TransferFunction, ConvertError> {
    let (mut num, mut den) = sys.to_tf()?;
    let abc = &sys.a - &sys.b * &sys.c;
    let p = super::ss::poly_from_roots(&eigvals(&abc)?);
    trim_residue(&mut num, &mut den, &p, sys.is_discrete());
    if num.is_empty() {
        num = vec![0.0];
    }
    Ok(match sys.ts {
        None => TransferFunction::Continuous(ContinuousTf::new(num, den)?),
        // Descending powers of z over the same degree are ascending powers of z^-1.
        Some(ts) => TransferFunction::Discrete(DiscreteTf::new(num, den, 0, ts)?),
    })
}

/// One transfer function per channel: `tfs[i][j]` from input `j` to output
/// `i`, each with the full denominator `det(sI - A)` (no cancellation; see
/// [`minreal`]). A channel that is identically zero is `None`.
pub fn ss_to_tfs(sys: &StateSpace) -> Result<Vec<Vec<Option<TransferFunction>>>, ConvertError> {
    (0..sys.ny())
        .map(|i| {
            (0..sys.nu())
                .map(|j| match siso_tf(&channel(sys, i, j)?) {
                    Ok(t) => Ok(Some(t)),
                    Err(ConvertError::Tf(TfError::ZeroNumerator)) => Ok(None),
                    Err(e) => Err(e),
                })
                .collect()
        })
        .collect()
}

/// Zeros, poles and gain of a SISO transfer function.
#[derive(Debug, Clone, PartialEq)]
pub struct Zpk {
    /// Zeros (s-plane, or z-plane including zeros at the origin).
    pub zeros: Vec<c64>,
    /// Poles (s-plane, or z-plane including poles at the origin).
    pub poles: Vec<c64>,
    /// `k` in `G = k prod(x - z_i) / prod(x - p_i)`, `x = s` or `z`.
    pub gain: f64,
    /// Sample time, `None` when continuous.
    pub ts: Option<f64>,
}

/// MATLAB `zpk` of a transfer function. A discrete
/// `z^-d B(z^-1)/A(z^-1)` (degrees `m`, `n`) is read in `z` after
/// multiplying by `z^N`, `N = max(n, m + d)`: `N - n` poles and
/// `N - m - d` zeros at the origin join the roots of `B` and `A`, and
/// `k = b0/a0`.
pub fn zpk(g: &TransferFunction) -> Result<Zpk, ConvertError> {
    let origin = |k: usize| vec![c64::new(0.0, 0.0); k];
    Ok(match g {
        TransferFunction::Continuous(c) => Zpk {
            zeros: roots_descending(c.num())?,
            poles: roots_descending(c.den())?,
            gain: c.num()[0] / c.den()[0],
            ts: None,
        },
        TransferFunction::Discrete(d) => {
            let (b, a) = (d.num().coeffs(), d.den().coeffs());
            let (m, n) = (b.len() - 1, a.len() - 1);
            let big = n.max(m + d.delay());
            let mut zeros = d.num().z_roots()?;
            zeros.extend(origin(big - m - d.delay()));
            let mut poles = d.den().z_roots()?;
            poles.extend(origin(big - n));
            Zpk {
                zeros,
                poles,
                gain: b[0] / a[0],
                ts: Some(d.ts()),
            }
        }
    })
}

/// Orthonormal basis of the reachable subspace of `(a, b)`: the block
/// Krylov sequence `b, a b, a^2 b, ...` orthogonalised as it is built
/// (Gram-Schmidt twice); a vector whose new part is below `tol` times
/// `max(||A||, ||B||)` is dependent. That is the scale of the rank
/// decisions of the staircase form SLICOT `TB01PD` computes for
/// python-control's `minreal` (tolerance relative to the norms of `A` and
/// `B`, or `C`), and MATLAB's: "increasing this tolerance forces
/// additional cancellations". Measuring `B` against its own norm instead
/// kept every mode of a system whose modes are all equally weak (a
/// discrete system with both pole-zero pairs matched within 1e-10 has
/// `||C|| ~ 1e-10 ||A||`, and kept both states at any tolerance).
fn reachable_basis(a: &Mat<f64>, b: &Mat<f64>, tol: f64) -> Vec<Vec<f64>> {
    let n = a.nrows();
    let mut basis: Vec<Vec<f64>> = Vec::new();
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let a_scale = a.norm_l2().max(f64::MIN_POSITIVE);
    let b_scale = b.norm_l2().max(a_scale);
    let mut block: Vec<(Vec<f64>, f64)> = (0..b.ncols())
        .map(|j| ((0..n).map(|i| b[(i, j)]).collect(), b_scale))
        .collect();
    while !block.is_empty() && basis.len() < n {
        let mut added = Vec::new();
        for (mut v, scale) in block {
            for _ in 0..2 {
                for q in &basis {
                    let d: f64 = q.iter().zip(&v).map(|(x, y)| x * y).sum();
                    v.iter_mut().zip(q).for_each(|(x, y)| *x -= d * y);
                }
            }
            let r = norm(&v);
            if r > tol * scale && basis.len() < n {
                v.iter_mut().for_each(|x| *x /= r);
                basis.push(v.clone());
                added.push(v);
            }
        }
        block = added
            .into_iter()
            .map(|q| {
                let w = (0..n)
                    .map(|i| (0..n).map(|k| a[(i, k)] * q[k]).sum())
                    .collect();
                (w, a_scale)
            })
            .collect();
    }
    basis
}

fn project(sys: &StateSpace, basis: &[Vec<f64>]) -> Result<StateSpace, SsError> {
    let (n, r) = (sys.nx(), basis.len());
    let q = Mat::from_fn(n, r, |i, k| basis[k][i]);
    let qt = tr(&q);
    StateSpace::new(
        &qt * &sys.a * &q,
        &qt * &sys.b,
        &sys.c * &q,
        sys.d.clone(),
        sys.ts,
    )
}

/// A minimal realisation: the reachable part, then its observable part
/// (the reachable part of the dual), MATLAB `minreal` for state space
/// ("eliminates uncontrollable or unobservable state in state-space
/// models ... The default value is tol = sqrt(eps) and increasing this
/// tolerance forces additional cancellations", MATLAB `minreal`
/// reference; python-control `minreal(sys, tol)` likewise). `tol` is
/// relative to `max(||A||, ||B||)` and `max(||A||, ||C||)` (default in
/// the commands: `sqrt(eps)`, about 1.5e-8).
pub fn minreal(sys: &StateSpace, tol: f64) -> Result<StateSpace, SsError> {
    let reach = reachable_basis(&sys.a, &sys.b, tol);
    let r = project(sys, &reach)?;
    let obs = reachable_basis(&tr(&r.a), &tr(&r.c), tol);
    project(&r, &obs)
}

/// Balanced truncation of a stable continuous or discrete system. A
/// discrete one is mapped by `s = a (z-1)/(z+1)`, `a = 2/ts`, reduced and
/// mapped back: the bilinear map preserves the Hankel singular values and
/// the H-infinity norm, so the bound `2 sum sigma_tail` holds unchanged.
pub fn balred_any(sys: &StateSpace, order: usize) -> Result<Reduced, SsError> {
    match sys.ts {
        None => balred(sys, order),
        Some(ts) => {
            let alpha = 2.0 / ts;
            let cont = bilinear_to_continuous(sys, alpha)?;
            let red = balred(&cont, order)?;
            Ok(Reduced {
                sys: bilinear_to_discrete(&red.sys, alpha, ts)?,
                ..red
            })
        }
    }
}

fn fro(m: &Mat<f64>) -> f64 {
    m.norm_l2()
}

/// Principal square root by the Denman-Beavers iteration.
fn sqrtm(x: &Mat<f64>) -> Option<Mat<f64>> {
    let n = x.nrows();
    let mut y = x.clone();
    let mut z = Mat::<f64>::identity(n, n);
    for _ in 0..100 {
        let yi = inv(&y)?;
        let zi = inv(&z)?;
        let y2 = (&y + &zi) * 0.5;
        let z2 = (&z + &yi) * 0.5;
        let change = fro(&(&y2 - &y));
        y = y2;
        z = z2;
        if change <= 1e-15 * fro(&y) {
            return Some(y);
        }
    }
    None
}

/// Principal matrix logarithm by inverse scaling and squaring: square
/// roots until `||X - I|| <= 0.25`, then the Gregory series
/// `log X = 2 sum Z^(2j+1)/(2j+1)`, `Z = (X - I)(X + I)^-1`, times `2^k`
/// (Kenney & Laub 1989). The caller excludes eigenvalues on the closed
/// negative real axis.
pub fn logm(m: &Mat<f64>) -> Option<Mat<f64>> {
    let n = m.nrows();
    let i = Mat::<f64>::identity(n, n);
    let mut x = m.clone();
    let mut k = 0;
    while fro(&(&x - &i)) > 0.25 {
        if k == 60 {
            return None;
        }
        x = sqrtm(&x)?;
        k += 1;
    }
    let z = &(&x - &i) * &inv(&(&x + &i))?;
    let z2 = &z * &z;
    let mut term = z.clone();
    let mut sum = z.clone();
    for j in 1..30 {
        term = &term * &z2;
        sum += &term * (1.0 / (2 * j + 1) as f64);
    }
    Some(sum * (2.0 * (1u64 << k) as f64))
}

/// The continuous system whose zero-order-hold discretisation is `sys`:
/// `[A B; 0 0] = logm([Ad Bd; 0 I]) / ts`. Refused when a pole of `Ad` is
/// at 0 or on the negative real axis (no real `A` has `e^(A ts)` there),
/// and checked by discretising the result again.
pub fn d2c(sys: &StateSpace) -> Result<StateSpace, ConvertError> {
    let Some(ts) = sys.ts else {
        return Err(ConvertError::Refused(
            "the system is already continuous".into(),
        ));
    };
    for p in eigvals(&sys.a)? {
        if p.norm() <= 1e-12 {
            return Err(ConvertError::Refused(
                "a pole at z = 0 (a delay or a dead-beat mode) is the ZOH image of no finite continuous pole".into(),
            ));
        }
        if p.arg().abs() >= std::f64::consts::PI - 1e-9 {
            return Err(ConvertError::Refused(format!(
                "pole z = {:.6}{:+.6}j on the negative real axis: no real continuous system discretises to it (ZOH)",
                p.re, p.im
            )));
        }
    }
    let (n, m) = (sys.nx(), sys.nu());
    let big = block2(&sys.a, &sys.b, &Mat::zeros(m, n), &Mat::identity(m, m));
    let l = logm(&big)
        .ok_or_else(|| ConvertError::Inaccurate("the matrix logarithm did not converge".into()))?
        * (1.0 / ts);
    let cont = StateSpace::new(
        sub(&l, 0, n, 0, n),
        sub(&l, 0, n, n, n + m),
        sys.c.clone(),
        sys.d.clone(),
        None,
    )?;
    let back = c2d(&cont, ts, C2dMethod::Zoh)?;
    let err = fro(&(&back.a - &sys.a)) + fro(&(&back.b - &sys.b));
    let scale = fro(&sys.a) + fro(&sys.b);
    if !(err <= 1e-8 * scale.max(1.0)) {
        return Err(ConvertError::Inaccurate(format!(
            "d2c: discretising the result again misses the input by {err:.3e} (relative {:.3e})",
            err / scale.max(f64::MIN_POSITIVE)
        )));
    }
    Ok(cont)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn ss_to_tf_round_trip_continuous() {
        let g = StateSpace::from_tf(&[2.0, 3.0], &[1.0, 4.0, 5.0, 6.0], None).unwrap();
        let t = siso_tf(&g).unwrap();
        let TransferFunction::Continuous(c) = t else {
            panic!()
        };
        assert_eq!(c.num().len(), 2, "{:?}", c.num());
        assert!((c.num()[0] - 2.0).abs() < 1e-12 && (c.num()[1] - 3.0).abs() < 1e-12);
    }

    pub fn logm_inverts_expm() {
        let a = Mat::from_fn(3, 3, |i, j| {
            [[-1.0, 2.0, 0.3], [-2.0, -1.0, 0.0], [0.5, 0.1, -3.0]][i][j]
        });
        let e = nalgebra::DMatrix::from_fn(3, 3, |i, j| a[(i, j)] * 0.2).exp();
        let ef = Mat::from_fn(3, 3, |i, j| e[(i, j)]);
        let l = logm(&ef).unwrap();
        assert!(fro(&(&l * 5.0 - &a)) < 1e-12, "{l:?}");
    }

    pub fn d2c_refuses_the_negative_axis_and_the_origin() {
        let g = StateSpace::from_tf(&[1.0, 0.0], &[1.0, 0.5], Some(0.1)).unwrap();
        assert!(matches!(d2c(&g), Err(ConvertError::Refused(_))));
        let h = StateSpace::from_tf(&[1.0], &[1.0, 0.0], Some(0.1)).unwrap();
        assert!(matches!(d2c(&h), Err(ConvertError::Refused(_))));
    }

    /// `G(z) = (z - 0.5 - 1e-10)(z + 0.3 + 1e-10) / ((z - 0.5)(z + 0.3))`:
    /// both pole-zero pairs match within 1e-10, so MATLAB's and
    /// python-control's `minreal` (tolerance `sqrt(eps)`) leave the gain 1;
    /// a tolerance below the mismatch (1e-12) keeps both states.
    pub fn minreal_cancels_pairs_matched_within_the_tolerance() {
        let (p1, p2, d) = (0.5, -0.3, 1e-10);
        // z^2 + a1 z + a2 with roots p1, p2 and p1 + d, p2 - d.
        let num = [1.0, -(p1 + d) - (p2 - d), (p1 + d) * (p2 - d)];
        let den = [1.0, -p1 - p2, p1 * p2];
        let g = StateSpace::from_tf(&num, &den, Some(1e-3)).unwrap();
        assert_eq!(g.nx(), 2);
        let m = minreal(&g, f64::EPSILON.sqrt()).unwrap();
        assert_eq!(m.nx(), 0, "{m:?}");
        assert!((m.d[(0, 0)] - 1.0).abs() < 1e-15);
        assert_eq!(minreal(&g, 1e-12).unwrap().nx(), 2);
    }

    pub fn minreal_removes_a_duplicate() {
        let g = StateSpace::from_tf(&[1.0], &[1.0, 3.0, 2.0], None).unwrap();
        let gg = g.parallel(&g).unwrap();
        assert_eq!(gg.nx(), 4);
        let m = minreal(&gg, 1.5e-8).unwrap();
        assert_eq!(m.nx(), 2);
        let s = c64::new(0.3, 0.7);
        let e = (m.eval(s).unwrap()[(0, 0)] - gg.eval(s).unwrap()[(0, 0)]).norm();
        assert!(e < 1e-12);
    }
}
