//! Algebraic Riccati equations: the stabilising solution by the Schur
//! method on the Hamiltonian matrix (Laub 1979, IEEE TAC 24(6)), with the
//! stable invariant subspace from the ordered *real* Schur form
//! ([`super::schur::ordered_real_schur`]), or on the symplectic pencil
//! (Pappas, Laub & Sandell 1980, IEEE TAC 25(4)) with an ordered *complex*
//! QZ ([`super::schur::gen_schur`]); then refined by Newton's method in
//! residual-correction form (Kleinman 1968 for CARE, Hewer 1971 for DARE)
//! with the residual evaluated in double-double arithmetic, until it stops
//! decreasing. Each solve returns its relative residual and the rounding
//! floor below which no `f64` solution can go; the stabilising property is
//! checked on the closed loop.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::accurate::Dd;
use super::c64;
use super::lyapunov::{MatEqError, dlyap, lyap};
use super::schur::{SchurError, gen_schur, ordered_real_schur, quasi_triangular_eigenvalues};
use super::ss::{balancing_scales, block2, eigvals, fro, inv, tr};
use faer::Mat;
use thiserror::Error;

/// Errors of the Riccati solvers.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RiccatiError {
    /// Dimensions do not fit.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// No stabilising solution exists (or it could not be computed reliably).
    #[error("no stabilising solution: {0}")]
    NoStabilizing(String),
    /// `R` is singular.
    #[error("the control weight R is singular")]
    SingularR,
    /// Schur form failed.
    #[error(transparent)]
    Schur(#[from] SchurError),
}

impl From<MatEqError> for RiccatiError {
    fn from(e: MatEqError) -> Self {
        RiccatiError::NoStabilizing(format!("Newton step failed: {e}"))
    }
}

/// A stabilising Riccati solution.
#[derive(Debug, Clone)]
pub struct RiccatiSolution {
    /// The symmetric solution X.
    pub x: Mat<f64>,
    /// Gain `K` (`u = -K x`): `R^-1 (B'X + S')` (CARE) or
    /// `(R + B'XB)^-1 (B'XA + S')` (DARE); empty for [`care_g`].
    pub k: Mat<f64>,
    /// Relative residual `||Res||_F / (sum of the norms of the terms)`.
    pub residual: f64,
    /// Eigenvalues of the closed loop (`A - G X` or `A - B K`).
    pub closed_loop: Vec<c64>,
    /// Newton refinement steps taken.
    pub newton_steps: usize,
    /// Rounding floor of the residual: the relative residual that perturbing
    /// each entry of X by one rounding error (`eps |X|`) can cause, to first
    /// order (`eps || |Ac'| |X| + |X| |Ac| ||_F`, resp.
    /// `eps (|| |Ac'| |X| |Ac| ||_F + ||X||_F)` for the DARE, over the
    /// residual's denominator; `Ac` the closed loop). No `f64` matrix can be
    /// expected to beat it; it exceeds 1e-10 only for nearly
    /// unstabilisable/undetectable problems, where `||X||` and the
    /// non-normality of `Ac` are huge.
    pub residual_floor: f64,
    /// CARE: the smallest `|Re lambda|` over the Hamiltonian's eigenvalues
    /// (`None` for the DARE and for `n = 0`). It shrinks to zero, like the
    /// square root of the distance, as a parameter of the equation (the
    /// H-infinity level) approaches a value where a pair of eigenvalues
    /// meets on the imaginary axis and the stabilising solution ceases to
    /// exist: the H-infinity search extrapolates its square.
    pub axis_gap: Option<f64>,
    /// CARE: the Hamiltonian's stable invariant subspace, before the Newton
    /// refinement (`None` for the DARE and for `n = 0`).
    pub subspace: Option<StableSubspace>,
}

/// A basis `[U1; U2]` of the stable invariant subspace of a Hamiltonian `H`
/// with `H [U1; U2] = [U1; U2] T11`, so that `X = U2 U1^-1`.
///
/// Near a level where the stabilising solution ceases to exist (`U1`
/// becomes singular, `X` unbounded), formulas in `U1`, `U2` and `T11` stay
/// well-conditioned where formulas in `X` do not: `X`'s rounding error is
/// `eps ||X||` in every direction, which swamps its small eigenvalues,
/// whereas the basis is accurate to `eps / sep` in each entry (the
/// descriptor form of the H-infinity central controller; Safonov,
/// Limebeer & Chiang 1989, Int. J. Control 50(6)).
#[derive(Debug, Clone)]
pub struct StableSubspace {
    /// Upper block of the basis.
    pub u1: Mat<f64>,
    /// Lower block of the basis.
    pub u2: Mat<f64>,
    /// The restriction of `H` to the subspace (quasi-upper-triangular).
    pub t11: Mat<f64>,
}

fn abs_mat(m: &Mat<f64>) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)].abs())
}

/// [`RiccatiSolution::residual_floor`] of a CARE with closed loop `ac`.
fn care_floor(x: &Mat<f64>, ac: &Mat<f64>, den: f64) -> f64 {
    let xa = abs_mat(x) * abs_mat(ac);
    let f = f64::EPSILON * (&xa + tr(&xa)).norm_l2();
    if den > 0.0 { f / den } else { f }
}

/// [`RiccatiSolution::residual_floor`] of a DARE with closed loop `ac`.
fn dare_floor(x: &Mat<f64>, ac: &Mat<f64>, den: f64) -> f64 {
    let aa = abs_mat(ac);
    let f = f64::EPSILON * ((tr(&aa) * abs_mat(x) * &aa).norm_l2() + fro(x));
    if den > 0.0 { f / den } else { f }
}

/// Relative residual of `A'X + XA - XGX + Q`, evaluated in double-double
/// arithmetic ([`super::accurate`]): near-unstabilisable problems have
/// `||X||` many orders above the residual, and an `f64` evaluation would
/// return only rounding noise for Newton to chase.
/// `scale` is added to the denominator: the size of the data the reduced
/// `Q` was formed from (`Q - S R^-1 S'` can cancel to rounding noise, and a
/// residual relative to that noise alone would be meaningless).
fn care_residual(
    a: &Mat<f64>,
    g: &Mat<f64>,
    q: &Mat<f64>,
    x: &Mat<f64>,
    scale: f64,
) -> (Mat<f64>, f64, f64) {
    let xd = Dd::from(x);
    let xa = xd.mul(&Dd::from(a));
    let xgx = xd.mul(&Dd::from(g)).mul(&xd);
    let r = xa
        .add(&xa.t(), 1.0)
        .add(&xgx, -1.0)
        .add(&Dd::from(q), 1.0)
        .round();
    let den = fro(&xa.hi) * 2.0 + fro(&xgx.hi) + fro(q) + scale;
    let r_sym = Mat::from_fn(r.nrows(), r.ncols(), |i, j| 0.5 * (r[(i, j)] + r[(j, i)]));
    let rel = if den > 0.0 {
        fro(&r_sym) / den
    } else {
        fro(&r_sym)
    };
    (r_sym, rel, den)
}

fn check_square(a: &Mat<f64>, others: &[(&Mat<f64>, &str)]) -> Result<usize, RiccatiError> {
    let n = a.nrows();
    if a.ncols() != n {
        return Err(RiccatiError::Dimension("A must be square".into()));
    }
    for (m, name) in others {
        if m.nrows() != n || m.ncols() != n {
            return Err(RiccatiError::Dimension(format!("{name} must be {n}x{n}")));
        }
    }
    for m in std::iter::once(a).chain(others.iter().map(|(m, _)| *m)) {
        if !m.is_all_finite() {
            return Err(RiccatiError::Dimension("non-finite entries".into()));
        }
    }
    Ok(n)
}

/// `X = U2 U1^-1` from the first `n` columns of `Z`, real part, symmetrised.
fn subspace_solution(z: &Mat<c64>, n: usize) -> Result<Mat<f64>, RiccatiError> {
    let u1 = Mat::from_fn(n, n, |i, j| z[(i, j)]);
    let u2 = Mat::from_fn(n, n, |i, j| z[(n + i, j)]);
    // X U1 = U2  <=>  U1^T X^T = U2^T.
    let u1t = u1.transpose().to_owned();
    let u2t = u2.transpose().to_owned();
    let sv = fts_kernels::dense::singular_values_c64(u1.as_ref())
        .map_err(|_| RiccatiError::NoStabilizing("SVD of the stable subspace failed".into()))?;
    let smin = sv.iter().cloned().fold(f64::INFINITY, f64::min);
    let smax = sv.iter().cloned().fold(0.0, f64::max);
    if !(smin > 1e-13 * smax.max(1e-300)) {
        return Err(RiccatiError::NoStabilizing(
            "the stable invariant subspace is not a graph (U1 singular): \
             the system has undetectable or unstabilisable modes"
                .into(),
        ));
    }
    let xt = fts_kernels::dense::lu_solve_c64(u1t.as_ref(), u2t.as_ref());
    let x = Mat::from_fn(n, n, |i, j| 0.5 * (xt[(j, i)].re + xt[(i, j)].re));
    if !x.is_all_finite() {
        return Err(RiccatiError::NoStabilizing("solution overflowed".into()));
    }
    Ok(x)
}

/// `X = U2 U1^-1` from the first `n` columns of the real orthogonal `Z`, symmetrised.
fn subspace_solution_real(z: &Mat<f64>, n: usize) -> Result<Mat<f64>, RiccatiError> {
    let u1 = Mat::from_fn(n, n, |i, j| z[(i, j)]);
    let u2t = Mat::from_fn(n, n, |i, j| z[(n + j, i)]);
    let sv = fts_kernels::dense::singular_values(u1.as_ref())
        .map_err(|_| RiccatiError::NoStabilizing("SVD of the stable subspace failed".into()))?;
    let smin = sv.iter().cloned().fold(f64::INFINITY, f64::min);
    let smax = sv.iter().cloned().fold(0.0, f64::max);
    if !(smin > 1e-13 * smax.max(1e-300)) {
        return Err(RiccatiError::NoStabilizing(
            "the stable invariant subspace is not a graph (U1 singular): \
             the system has undetectable or unstabilisable modes"
                .into(),
        ));
    }
    // X U1 = U2  <=>  U1^T X^T = U2^T.
    let xt = fts_kernels::dense::lu_solve(u1.transpose(), u2t.as_ref());
    let x = Mat::from_fn(n, n, |i, j| 0.5 * (xt[(j, i)] + xt[(i, j)]));
    if !x.is_all_finite() {
        return Err(RiccatiError::NoStabilizing("solution overflowed".into()));
    }
    Ok(x)
}

/// Stabilising solution of `A'X + XA - XGX + Q = 0` (`G`, `Q` symmetric, `G`
/// possibly indefinite as in H-infinity), i.e. `A - G X` Hurwitz:
/// `X = Ric(H)`, `H = [A, -G; -Q, -A']` (Zhou & Doyle, Essentials §12.1).
pub fn care_g(a: &Mat<f64>, g: &Mat<f64>, q: &Mat<f64>) -> Result<RiccatiSolution, RiccatiError> {
    care_g_scaled(a, g, q, 0.0)
}

/// The Hamiltonian as given first; balanced only when that fails. Balancing
/// is a general (not symplectic) similarity: on well-scaled problems it can
/// blur the eigenvalues near the imaginary axis that the H-infinity
/// bisection decides on, so it is kept for the badly scaled ones it rescues.
fn care_g_scaled(
    a: &Mat<f64>,
    g: &Mat<f64>,
    q: &Mat<f64>,
    scale: f64,
) -> Result<RiccatiSolution, RiccatiError> {
    if let Some(zero) = zero_solution(a, g, q, scale) {
        return Ok(zero);
    }
    care_g_hamiltonian(a, g, q, scale, false).or_else(|e| match e {
        RiccatiError::NoStabilizing(_) | RiccatiError::Schur(_) => {
            care_g_hamiltonian(a, g, q, scale, true).map_err(|_| e)
        }
        e => Err(e),
    })
}

/// `X = 0` when it is the stabilising solution: `Q` (the cross term
/// already removed) vanishes to rounding against the terms it came from
/// (`scale`), and `A` is Hurwitz. The Hamiltonian is then block triangular,
/// `[A, -G; 0, -A']`, with eigenvalues `eig(A)` and their mirror images.
///
/// The shortcut matters where a mode of `A` lies close to the imaginary
/// axis: the H-infinity filter equation of a mixed-sensitivity problem
/// (`Q = B1 (I - D.1' R~^-1 D.1) B1' = 0` exactly, since `R~ e_y = D.1`)
/// carries the performance weight's pole `-p`, and with `p` at 1e-9 times
/// the bandwidth the pair `+-p` is closer than `sqrt(eps)` to a Jordan
/// block: the Schur method's eigenvalues land on the axis, and a feasible
/// level is declared infeasible. `A`'s own eigenvalue `-p` is computed to
/// `eps ||A||`. `None` when the shortcut does not apply.
fn zero_solution(a: &Mat<f64>, g: &Mat<f64>, q: &Mat<f64>, scale: f64) -> Option<RiccatiSolution> {
    let n = a.nrows();
    if n == 0 || !(scale > 0.0) || !(fro(q) <= 64.0 * f64::EPSILON * scale) {
        return None;
    }
    let closed_loop = eigvals(a).ok()?;
    if !closed_loop.iter().all(|l| l.re < 0.0) {
        return None;
    }
    let x = Mat::<f64>::zeros(n, n);
    let (_, residual, den) = care_residual(a, g, q, &x, scale);
    let axis_gap = closed_loop
        .iter()
        .map(|l| l.re.abs())
        .fold(f64::INFINITY, f64::min);
    Some(RiccatiSolution {
        residual_floor: care_floor(&x, a, den),
        x,
        k: Mat::zeros(0, n),
        residual,
        closed_loop,
        newton_steps: 0,
        axis_gap: Some(axis_gap),
        // H [I; 0] = [A; -Q] = [I; 0] A.
        subspace: Some(StableSubspace {
            u1: Mat::identity(n, n),
            u2: Mat::zeros(n, n),
            t11: a.clone(),
        }),
    })
}

fn care_g_hamiltonian(
    a: &Mat<f64>,
    g: &Mat<f64>,
    q: &Mat<f64>,
    scale: f64,
    balance: bool,
) -> Result<RiccatiSolution, RiccatiError> {
    let n = check_square(a, &[(g, "G"), (q, "Q")])?;
    if n == 0 {
        return Ok(RiccatiSolution {
            x: Mat::zeros(0, 0),
            k: Mat::zeros(0, 0),
            residual: 0.0,
            closed_loop: Vec::new(),
            newton_steps: 0,
            residual_floor: 0.0,
            axis_gap: None,
            subspace: None,
        });
    }
    // The Hamiltonian, if asked balanced by an exact diagonal similarity
    // `D^-1 H D` (Parlett & Reinsch): badly scaled problems (cheap control,
    // `G` ~ 1e16 beside `A` ~ 1) otherwise lose their slow eigenvalues to the
    // rounding errors of the large entries. Its stable subspace is `D` times
    // the balanced one.
    let h0 = block2(a, &(-g), &(-q), &(-tr(a)));
    let empty = Mat::<f64>::zeros(2 * n, 0);
    let scales = if balance {
        balancing_scales(&h0, &empty, &tr(&empty))
    } else {
        vec![1.0; 2 * n]
    };
    let h = Mat::from_fn(2 * n, 2 * n, |i, j| h0[(i, j)] * scales[j] / scales[i]);
    let hn = fro(&h);
    // Ordered real Schur form of the Hamiltonian, stable eigenvalues first.
    let os = ordered_real_schur(&h, |l| l.re < 0.0).map_err(|e| match e {
        SchurError::SwapRejected(..) => RiccatiError::NoStabilizing(format!(
            "the Hamiltonian matrix has eigenvalues (numerically) on the imaginary axis: {e}"
        )),
        e => RiccatiError::Schur(e),
    })?;
    // An eigenvalue is treated as lying on the imaginary axis when its real
    // part is at round-off level both absolutely (relative to ||H||) and
    // relative to its own modulus; the second test keeps slow but genuinely
    // stable modes of badly scaled Hamiltonians off the axis.
    let eigenvalues = quasi_triangular_eigenvalues(&os.t);
    let on_axis = eigenvalues
        .iter()
        .any(|l| l.re.abs() <= 1e-12 * hn && l.re.abs() <= 1e-7 * l.norm());
    let axis_gap = eigenvalues
        .iter()
        .map(|l| l.re.abs())
        .fold(f64::INFINITY, f64::min);
    if on_axis || os.n_selected != n {
        return Err(RiccatiError::NoStabilizing(
            "the Hamiltonian matrix has eigenvalues on the imaginary axis".into(),
        ));
    }
    let z = Mat::from_fn(2 * n, 2 * n, |i, j| os.q[(i, j)] * scales[i]);
    let mut x = subspace_solution_real(&z, n)?;
    let subspace = StableSubspace {
        u1: Mat::from_fn(n, n, |i, j| z[(i, j)]),
        u2: Mat::from_fn(n, n, |i, j| z[(n + i, j)]),
        t11: Mat::from_fn(n, n, |i, j| os.t[(i, j)]),
    };
    let (mut res, mut rel, mut den) = care_residual(a, g, q, &x, scale);
    // Newton–Kleinman in correction form: (A - GX)' D + D (A - GX) + Res(X) = 0,
    // continued while the (accurately evaluated) residual decreases, until it
    // reaches the rounding floor.
    let mut steps = 0;
    for _ in 0..20 {
        let ak = a - g * &x;
        if rel < 1e-15 || rel <= 0.1 * care_floor(&x, &ak, den) {
            break;
        }
        let Ok(d) = lyap(&tr(&ak), &res) else { break };
        let xn = &x + &d.x;
        let (rn, reln, denn) = care_residual(a, g, q, &xn, scale);
        if !(reln < rel) {
            break;
        }
        steps += 1;
        (x, res, rel, den) = (xn, rn, reln, denn);
    }
    let closed_loop = eigvals(&(a - g * &x))
        .map_err(|_| RiccatiError::NoStabilizing("closed-loop eigenvalues failed".into()))?;
    if closed_loop.iter().any(|l| !(l.re < 0.0)) {
        return Err(RiccatiError::NoStabilizing(
            "the computed solution does not stabilise A - G X".into(),
        ));
    }
    if !(rel < 1e-6) {
        return Err(RiccatiError::NoStabilizing(format!(
            "residual {rel:.1e} after refinement: the problem is too ill-conditioned"
        )));
    }
    let residual_floor = care_floor(&x, &(a - g * &x), den);
    Ok(RiccatiSolution {
        x,
        k: Mat::zeros(0, n),
        residual: rel,
        residual_floor,
        closed_loop,
        newton_steps: steps,
        axis_gap: Some(axis_gap),
        subspace: Some(subspace),
    })
}

/// `(A~, G, Q~, R^-1)` of a CARE/DARE with the cross term removed.
type Reduced = (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>);

fn reduce(
    a: &Mat<f64>,
    b: &Mat<f64>,
    q: &Mat<f64>,
    r: &Mat<f64>,
    s: Option<&Mat<f64>>,
) -> Result<Reduced, RiccatiError> {
    let n = check_square(a, &[(q, "Q")])?;
    let m = b.ncols();
    if b.nrows() != n || r.nrows() != m || r.ncols() != m {
        return Err(RiccatiError::Dimension(format!(
            "B must be {n}xm and R mxm (m = {m})"
        )));
    }
    let s0 = Mat::zeros(n, m);
    let s = s.unwrap_or(&s0);
    if s.nrows() != n || s.ncols() != m {
        return Err(RiccatiError::Dimension(format!("S must be {n}x{m}")));
    }
    let ri = inv(r).ok_or(RiccatiError::SingularR)?;
    // Remove the cross term: A~ = A - B R^-1 S', Q~ = Q - S R^-1 S'.
    let at = a - b * &ri * tr(s);
    let qt = q - s * &ri * tr(s);
    let g = b * &ri * tr(b);
    Ok((at, g, qt, ri))
}

/// Stabilising solution of the CARE
/// `A'X + XA - (XB + S) R^-1 (B'X + S') + Q = 0`; `K = R^-1 (B'X + S')`.
pub fn care(
    a: &Mat<f64>,
    b: &Mat<f64>,
    q: &Mat<f64>,
    r: &Mat<f64>,
    s: Option<&Mat<f64>>,
) -> Result<RiccatiSolution, RiccatiError> {
    let (at, g, qt, ri) = reduce(a, b, q, r, s)?;
    let scale = fro(q) + fro(&(q - &qt));
    let mut sol = care_g_scaled(&at, &g, &qt, scale)?;
    let st = s
        .map(tr)
        .unwrap_or_else(|| Mat::zeros(b.ncols(), a.nrows()));
    sol.k = &ri * &(&(tr(b) * &sol.x) + &st);
    Ok(sol)
}

/// The stabilising solution `x` of the CARE
/// `A'X + XA - (XB + S) R^-1 (B'X + S') + Q = 0` (from [`care`]) refined to
/// double-double: two Newton steps `(A - BK)'D + D(A - BK) + Res(X) = 0`
/// with `Res` and `K = R^-1 (B'X + S')` evaluated in double-double on the
/// equation as given (`B`, `Q`, `R`, `S` exact in double-double), not on
/// its reduced form. [`care`]'s `X` solves the
/// reduced equation (`A - B R^-1 S'`, `B R^-1 B'`, `Q - S R^-1 S'`, each
/// rounded) to its rounding floor; where `B R^-1 B'` is 1e10 (cheap
/// control), those roundings alone move `X` by 1e-13 of its norm, which
/// formulas that cancel `B K` against `A` cannot afford.
pub(crate) fn care_extended(
    b: &Dd,
    q: &Dd,
    r: &Dd,
    s: &Dd,
    a: &Mat<f64>,
    x: &Mat<f64>,
) -> Option<Dd> {
    let ad = Dd::from(a);
    let ri = r.inverse()?;
    let mut xd = Dd::from(x);
    for _ in 0..2 {
        let l = b.t().mul(&xd).add(&s.t(), 1.0);
        let k = ri.mul(&l);
        let xa = xd.mul(&ad);
        let res = xa.add(&xa.t(), 1.0).add(q, 1.0).add(&l.t().mul(&k), -1.0);
        let ak = a - b.round() * k.round();
        let d = lyap_balanced(&ak, &res.round())?;
        xd = xd.add(&Dd::from(&d), 1.0);
    }
    Some(xd)
}

/// `D` with `A'D + DA + R = 0`, solved in the coordinates `T^-1 A T` that
/// balance `A` ([`balancing_scales`]; `T D T` is their solution). The
/// closed loop `A - BK` of a cheap-control problem has entries of 1e12 in
/// one row beside poles at 1e-3, whose sums the Lyapunov solver would take
/// for zero against `1e-14 ||A||`; balanced, `||A||` is the poles' size.
fn lyap_balanced(a: &Mat<f64>, r: &Mat<f64>) -> Option<Mat<f64>> {
    let n = a.nrows();
    let none = Mat::<f64>::zeros(n, 0);
    let t = balancing_scales(a, &none, &tr(&none));
    let ab = Mat::from_fn(n, n, |i, j| a[(i, j)] * t[j] / t[i]);
    let rb = Mat::from_fn(n, n, |i, j| r[(i, j)] * t[i] * t[j]);
    let db = lyap(&tr(&ab), &rb).ok()?.x;
    Some(Mat::from_fn(n, n, |i, j| db[(i, j)] / (t[i] * t[j])))
}

/// Relative residual of `A'XA - X - (A'XB + S)(R + B'XB)^-1 (B'XA + S') + Q`,
/// with the gain `K = (R + B'XB)^-1 (B'XA + S')`. Evaluated in double-double
/// arithmetic in the form `A'XA - X + Q - L'K - K'L + K'(R + B'XB)K`,
/// `L = B'XA + S'`, which is stationary in `K` (an error in the computed
/// gain enters only to second order).
fn dare_residual(
    a: &Mat<f64>,
    b: &Mat<f64>,
    q: &Mat<f64>,
    r: &Mat<f64>,
    s: &Mat<f64>,
    x: &Mat<f64>,
) -> Option<(Mat<f64>, f64, Mat<f64>, f64)> {
    let (ad, bd, xd) = (Dd::from(a), Dd::from(b), Dd::from(x));
    let xa = xd.mul(&ad);
    let xb = xd.mul(&bd);
    let rr = Dd::from(r).add(&bd.t().mul(&xb), 1.0);
    let l = bd.t().mul(&xa).add(&Dd::from(&tr(s)), 1.0);
    let kk = inv(&rr.round())? * l.round();
    let kd = Dd::from(&kk);
    let axa = ad.t().mul(&xa);
    let lk = l.t().mul(&kd);
    let krk = kd.t().mul(&rr).mul(&kd);
    let res = axa
        .add(&xd, -1.0)
        .add(&Dd::from(q), 1.0)
        .add(&lk, -1.0)
        .add(&lk.t(), -1.0)
        .add(&krk, 1.0)
        .round();
    let res = Mat::from_fn(res.nrows(), res.ncols(), |i, j| {
        0.5 * (res[(i, j)] + res[(j, i)])
    });
    let den = fro(&axa.hi) + fro(x) + fro(&lk.hi) + fro(q);
    let rel = if den > 0.0 {
        fro(&res) / den
    } else {
        fro(&res)
    };
    kk.is_all_finite().then_some((res, rel, kk, den))
}

/// Stabilising solution of the DARE
/// `A'XA - X - (A'XB + S)(R + B'XB)^-1 (B'XA + S') + Q = 0`;
/// `K = (R + B'XB)^-1 (B'XA + S')`, `A - BK` Schur stable.
pub fn dare(
    a: &Mat<f64>,
    b: &Mat<f64>,
    q: &Mat<f64>,
    r: &Mat<f64>,
    s: Option<&Mat<f64>>,
) -> Result<RiccatiSolution, RiccatiError> {
    let (at, g, qt, _) = reduce(a, b, q, r, s)?;
    let n = a.nrows();
    let s0 = Mat::zeros(n, b.ncols());
    let s = s.unwrap_or(&s0);
    if n == 0 {
        return Ok(RiccatiSolution {
            x: Mat::zeros(0, 0),
            k: Mat::zeros(b.ncols(), 0),
            residual: 0.0,
            closed_loop: Vec::new(),
            newton_steps: 0,
            residual_floor: 0.0,
            axis_gap: None,
            subspace: None,
        });
    }
    // Symplectic pencil lambda L - M, M = [A~, 0; -Q~, I], L = [I, G; 0, A~'] (Pappas et al. 1980).
    let i = Mat::<f64>::identity(n, n);
    let mm = block2(&at, &Mat::zeros(n, n), &(-&qt), &i);
    let ll = block2(&i, &g, &Mat::zeros(n, n), &tr(&at));
    let mut gs = gen_schur(&mm, &ll)?;
    let scale = fro(&mm).max(fro(&ll));
    let on_circle = gs
        .pairs()
        .iter()
        .any(|(al, be)| (al.norm() - be.norm()).abs() <= 1e-12 * scale);
    let k = gs.reorder(|al, be| al.norm() < be.norm());
    if on_circle || k != n {
        return Err(RiccatiError::NoStabilizing(
            "the symplectic pencil has eigenvalues on the unit circle".into(),
        ));
    }
    let mut x = subspace_solution(&gs.z, n)?;
    let Some((mut res, mut rel, mut kk, mut den)) = dare_residual(a, b, q, r, s, &x) else {
        return Err(RiccatiError::NoStabilizing("R + B'XB is singular".into()));
    };
    // Hewer (Newton) refinement: (A-BK)' D (A-BK) - D + Res(X) = 0, continued
    // while the (accurately evaluated) residual decreases, until it reaches
    // the rounding floor.
    let mut steps = 0;
    for _ in 0..20 {
        let ak = a - b * &kk;
        if rel < 1e-15 || rel <= 0.1 * dare_floor(&x, &ak, den) {
            break;
        }
        let Ok(d) = dlyap(&tr(&ak), &res) else { break };
        let xn = &x + &d.x;
        let Some((rn, reln, kn, denn)) = dare_residual(a, b, q, r, s, &xn) else {
            break;
        };
        if !(reln < rel) {
            break;
        }
        steps += 1;
        (x, res, rel, kk, den) = (xn, rn, reln, kn, denn);
    }
    let closed_loop = eigvals(&(a - b * &kk))
        .map_err(|_| RiccatiError::NoStabilizing("closed-loop eigenvalues failed".into()))?;
    if closed_loop.iter().any(|l| !(l.norm() < 1.0)) {
        return Err(RiccatiError::NoStabilizing(
            "the computed solution does not stabilise A - B K".into(),
        ));
    }
    if !(rel < 1e-6) {
        return Err(RiccatiError::NoStabilizing(format!(
            "residual {rel:.1e} after refinement: the problem is too ill-conditioned"
        )));
    }
    let residual_floor = dare_floor(&x, &(a - b * &kk), den);
    Ok(RiccatiSolution {
        x,
        residual: rel,
        residual_floor,
        k: kk,
        closed_loop,
        newton_steps: steps,
        axis_gap: None,
        subspace: None,
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn m(rows: &[&[f64]]) -> Mat<f64> {
        Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
    }

    /// `care_extended` carries `X` to double-double: on the scalar CARE
    /// `2x - x^2 + 1 = 0` to `1 + sqrt 2` within 1e-30; on a cheap-control
    /// pair (`B R^-1 B'` of 1e12, the closed loop's balanced Lyapunov
    /// solves) to a residual of the unreduced equation, evaluated in
    /// double-double, 1e-25 of its terms, where [`care`]'s own `X` leaves
    /// more than 1e-20.
    pub fn care_extended_reaches_double_double() {
        let one = m(&[&[1.0]]);
        let d = |x: &Mat<f64>| Dd::from(x);
        let s = care(&one, &one, &one, &one, None).unwrap();
        let x = care_extended(&d(&one), &d(&one), &d(&one), &d(&m(&[&[0.0]])), &one, &s.x).unwrap();
        let sqrt2 = Dd {
            hi: m(&[&[2f64.sqrt()]]),
            lo: m(&[&[-9.667293313452913e-17]]),
        };
        let err = x.add(&sqrt2, -1.0).add(&d(&one), -1.0).round()[(0, 0)];
        assert!(err.abs() < 1e-30, "X - (1 + sqrt 2) = {err:e}");

        let a = m(&[&[0.0, 1.0], &[0.0, -1e-3]]);
        let b = m(&[&[0.0], &[1e6]]);
        let (q, r, s0) = (Mat::identity(2, 2), one.clone(), Mat::zeros(2, 1));
        let plain = care(&a, &b, &q, &r, None).unwrap();
        let x = care_extended(&d(&b), &d(&q), &d(&r), &d(&s0), &a, &plain.x).unwrap();
        let relative = |x: &Dd| {
            let xa = x.mul(&d(&a));
            let xb = x.mul(&d(&b));
            let xgx = xb.mul(&xb.t());
            let res = xa.add(&xa.t(), 1.0).add(&d(&q), 1.0).add(&xgx, -1.0);
            res.round().norm_l2() / (2.0 * xa.hi.norm_l2() + xgx.hi.norm_l2() + 1.0)
        };
        assert!(relative(&x) < 1e-25, "refined residual {:e}", relative(&x));
        assert!(relative(&d(&plain.x)) > 1e-20, "care's X is already exact");
    }

    pub fn scalar_care() {
        // 2 a x - x^2 b^2 / r + q = 0 with a = 1, b = 1, r = 1, q = 1: x = 1 + sqrt 2.
        let s = care(
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            None,
        )
        .unwrap();
        assert!((s.x[(0, 0)] - (1.0 + 2f64.sqrt())).abs() < 1e-14);
        assert!(s.residual < 1e-15);
    }

    pub fn double_integrator_lqr() {
        // A = [0 1; 0 0], B = [0; 1], Q = I, R = 1: X = [sqrt3 1; 1 sqrt3], K = [1 sqrt3].
        let a = m(&[&[0.0, 1.0], &[0.0, 0.0]]);
        let b = m(&[&[0.0], &[1.0]]);
        let s = care(&a, &b, &Mat::identity(2, 2), &m(&[&[1.0]]), None).unwrap();
        let r3 = 3f64.sqrt();
        assert!((s.x[(0, 0)] - r3).abs() < 1e-13 && (s.x[(0, 1)] - 1.0).abs() < 1e-13);
        assert!((s.k[(0, 1)] - r3).abs() < 1e-13);
        assert!(s.residual < 1e-10);
    }

    pub fn scalar_dare() {
        // x = a^2 x - a^2 x^2 /(1 + x) + 1 with a = 2: x^2 - 4x - 1 = 0 => x = 2 + sqrt 5.
        let s = dare(
            &m(&[&[2.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            None,
        )
        .unwrap();
        assert!(
            (s.x[(0, 0)] - (2.0 + 5f64.sqrt())).abs() < 1e-13,
            "{:?}",
            s.x
        );
        assert!(s.residual < 1e-14);
    }

    pub fn a_vanishing_q_with_a_hurwitz_closed_loop_gives_zero() {
        // Q = S R^-1 S' makes Q~ = 0; A - B R^-1 S' = diag(-1e-9, -1) is
        // Hurwitz, with a mode 1e-9 from the axis. X = 0 exactly, K = S'.
        let (eps_mode, b, s_) = (1e-9, m(&[&[1.0], &[1.0]]), m(&[&[1.0], &[2.0]]));
        let a = m(&[&[1.0 - eps_mode, 2.0], &[1.0, 1.0]]);
        let q = &s_ * tr(&s_);
        let sol = care(&a, &b, &q, &m(&[&[1.0]]), Some(&s_)).unwrap();
        assert_eq!(fro(&sol.x), 0.0);
        assert!((sol.k[(0, 0)] - 1.0).abs() < 1e-15 && (sol.k[(0, 1)] - 2.0).abs() < 1e-15);
        let mut re: Vec<f64> = sol.closed_loop.iter().map(|l| l.re).collect();
        re.sort_by(f64::total_cmp);
        assert!(
            (re[0] + 1.0).abs() < 1e-14 && (re[1] + eps_mode).abs() < 1e-15,
            "{re:?}"
        );
        let basis = sol.subspace.unwrap();
        assert_eq!(fro(&basis.u2), 0.0);
        // A Q~ of 1e-6 is not rounding: the Hamiltonian decides, and X != 0.
        let q2 = &q + Mat::<f64>::identity(2, 2) * 1e-6;
        let sol2 = care(&a, &b, &q2, &m(&[&[1.0]]), Some(&s_)).unwrap();
        assert!(fro(&sol2.x) > 1e-9, "{:?}", sol2.x);
    }

    pub fn unstabilisable_is_an_error() {
        // Unstable mode a = 1 not reachable (b = 0).
        let e = care(
            &m(&[&[1.0]]),
            &m(&[&[0.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            None,
        );
        assert!(matches!(e, Err(RiccatiError::NoStabilizing(_))), "{e:?}");
        let e = dare(
            &m(&[&[2.0]]),
            &m(&[&[0.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            None,
        );
        assert!(matches!(e, Err(RiccatiError::NoStabilizing(_))), "{e:?}");
        let e = care(
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            &m(&[&[1.0]]),
            &m(&[&[0.0]]),
            None,
        );
        assert!(matches!(e, Err(RiccatiError::SingularR)));
    }
}
