//! System norms.
//!
//! * H2 from the controllability Gramian: `||G||_2^2 = tr(C P C')` with
//!   `A P + P A' + B B' = 0` (continuous, `D = 0`) or
//!   `tr(C P C' + D D')` with `A P A' - P + B B' = 0` (discrete)
//!   (Zhou & Doyle, Essentials §4.4).
//! * H-infinity by the Bruinsma–Steinbuch two-step algorithm (Systems &
//!   Control Letters 14, 1990; Boyd, Balakrishnan & Kabamba 1989): `gamma` is
//!   a singular value of `G(jw)` iff the Hamiltonian `H(gamma)` has the
//!   eigenvalue `jw`; the lower bound is raised to the peak over the midpoints
//!   of the imaginary-axis eigenvalues until none remain. The level at which
//!   none remain is the certified upper bound; the peak is then refined by
//!   golden-section search between the last crossings and reported as the
//!   value `sigma_max(G(jw))` actually attained ([`HinfNorm`]: `peak <=
//!   ||G|| <= upper`). Discrete systems are searched on their bilinear image
//!   `z = (a+s)/(a-s)` (which preserves the H-infinity norm exactly); their
//!   peak is refined and evaluated on the unit circle of the discrete system
//!   itself.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c64;
use super::freqresp::HessenbergResponse;
use super::lyapunov::{MatEqError, dlyap_factor, lyap_factor};
use super::schur::{cplx, gen_schur};
use super::ss::{SsError, StateSpace, block2, eigvals, frequency_point, fro, inv, sigma_max, tr};
use faer::Mat;
use thiserror::Error;

/// Errors of the norm computations.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum NormError {
    /// The system is not asymptotically stable (the norm is infinite).
    #[error("the system is not stable: its norm is infinite")]
    Unstable,
    /// Underlying computation failed.
    #[error(transparent)]
    Ss(#[from] SsError),
    /// Gramian computation failed.
    #[error(transparent)]
    MatEq(#[from] MatEqError),
    /// The Gramian is too inaccurate to give a norm (residual shown).
    #[error(
        "the H2 norm's Gramian is inaccurate (relative Lyapunov residual {residual:.1e}): the system is too badly conditioned"
    )]
    Inaccurate {
        /// Relative residual of the Lyapunov solve.
        residual: f64,
    },
}

/// Gramians with a worse relative residual are not trusted for a norm.
const MAX_GRAMIAN_RESIDUAL: f64 = 1e-8;

/// H2 norm (infinite for a continuous system with `D != 0`), as
/// `||C L||_F` with `L` the Cholesky factor of the controllability Gramian
/// (Hammarling's method, [`lyap_factor`]), of the balanced realisation (the
/// exact power-of-two state scaling leaves the norm unchanged and brings
/// stiff closed loops, with poles from 1e-3 to 1e8 rad/s, within reach of
/// the Lyapunov solver). Through the factor a norm that is zero by
/// cancellation comes out at rounding (`trace(C X C')` would leave the
/// square root of rounding). A Gramian whose residual exceeds 1e-8 is an
/// error, never a silently wrong norm.
pub fn h2_norm(sys: &StateSpace) -> Result<f64, NormError> {
    if !sys.is_stable()? {
        return Err(NormError::Unstable);
    }
    h2_norm_of_stable(sys)
}

/// [`h2_norm`] of a system already known to be stable.
pub(crate) fn h2_norm_of_stable(sys: &StateSpace) -> Result<f64, NormError> {
    let sys = &sys.balanced();
    let (gramian, extra) = match sys.ts {
        None => {
            if fro(&sys.d) > 0.0 {
                return Ok(f64::INFINITY);
            }
            (lyap_factor(&sys.a, &sys.b)?, 0.0)
        }
        Some(_) => (dlyap_factor(&sys.a, &sys.b)?, fro(&sys.d).powi(2)),
    };
    if !(gramian.residual <= MAX_GRAMIAN_RESIDUAL) {
        return Err(NormError::Inaccurate {
            residual: gramian.residual,
        });
    }
    let cl = cplx(&sys.c) * &gramian.l;
    let mut val = extra;
    for j in 0..cl.ncols() {
        for i in 0..cl.nrows() {
            val += cl[(i, j)].norm_sqr();
        }
    }
    Ok(val.sqrt())
}

/// Continuous equivalent of a discrete system under `z = (a+s)/(a-s)`,
/// i.e. `s = a (z-1)/(z+1)` (same H-infinity norm and stability for any
/// `a > 0`; `w_c = a tan(theta/2)`). `a = 2/ts` keeps the poles near their
/// physical values, which keeps the Riccati problems well scaled.
pub fn bilinear_to_continuous(sys: &StateSpace, alpha: f64) -> Result<StateSpace, SsError> {
    let n = sys.nx();
    let ap = &sys.a + Mat::<f64>::identity(n, n);
    let api = inv(&ap).ok_or(SsError::IllPosed)?;
    let r2 = (2.0 * alpha).sqrt();
    let am = &sys.a - Mat::<f64>::identity(n, n);
    StateSpace::new(
        &(&api * &am) * alpha,
        &(&api * &sys.b) * r2,
        &(&sys.c * &api) * r2,
        &sys.d - &sys.c * &api * &sys.b,
        None,
    )
}

/// The H-infinity norm of a stable system with its certificate:
/// `peak <= ||G||_inf <= upper`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HinfNorm {
    /// Attained value, a true lower bound: `sigma_max(G)` evaluated on the
    /// system as given (for a discrete system at `z = e^{j omega ts}`) at
    /// `omega`, refined by golden-section search.
    pub peak: f64,
    /// Frequency of the peak, rad/s; `f64::INFINITY` when the supremum is
    /// `sigma_max(D)` approached as `omega -> inf` (continuous only: a
    /// discrete system's highest frequency is the Nyquist `pi/ts`).
    pub omega: f64,
    /// Certified upper bound: the top of the final Bruinsma–Steinbuch
    /// interval, a level at which the Hamiltonian has no imaginary-axis
    /// eigenvalue (or only ones where `sigma_max < upper`, i.e. none that
    /// are genuine). `upper <= peak (1 + 2 rtol)` normally; looser when the
    /// first levels tried were inconclusive, `f64::INFINITY` when no level
    /// could be certified.
    pub upper: f64,
}

impl HinfNorm {
    /// Frequency of the peak in Hz.
    pub fn freq_hz(&self) -> f64 {
        self.omega / std::f64::consts::TAU
    }

    /// Relative width of the certified interval, `upper / peak - 1`
    /// (0 for a zero system).
    pub fn gap(&self) -> f64 {
        if self.peak > 0.0 {
            self.upper / self.peak - 1.0
        } else {
            0.0
        }
    }
}

/// H-infinity norm of a stable system to relative accuracy `rtol`: the
/// attained peak, its frequency and a certified upper bound
/// ([`HinfNorm`]), natively in continuous (Hamiltonian) and discrete
/// (symplectic pencil) time. Errors for unstable systems.
pub fn hinf_norm(sys: &StateSpace, rtol: f64) -> Result<HinfNorm, NormError> {
    hinf_norm_with_poles(sys, rtol, &sys.poles()?)
}

/// [`hinf_norm`] with the poles of `sys` already computed.
fn hinf_norm_with_poles(sys: &StateSpace, rtol: f64, poles: &[c64]) -> Result<HinfNorm, NormError> {
    if !sys.poles_are_stable(poles) {
        return Err(NormError::Unstable);
    }
    let rtol = rtol.clamp(1e-12, 1e-1);
    // The crossing test on the balanced realisation (an exact power-of-two
    // similarity): a companion-form realisation of a resonance at 300 Hz has
    // ||H|| ~ 1e13, whose absolute eigenvalue tolerance swallowed the axis
    // distance of every eigenvalue, so no level was ever certified.
    let balanced = sys.balanced();
    let fast = FastSigma::new(&balanced);
    let found = bruinsma_steinbuch(&balanced, &fast, poles, rtol)?;
    let (lo, hi) = found.bracket;
    let (mut peak, mut omega) = (sigma_at_or_d(sys, found.omega), found.omega);
    if hi.is_finite() && hi > lo {
        // Searched on the Hessenberg form, reported as evaluated on `sys`.
        let (w, _) = golden_max(|w| fast.at(w), lo, hi);
        let s = sys.sigma_at(w);
        if s > peak {
            (peak, omega) = (s, w);
        }
    }
    // A peak at DC: the search converges onto w = 0 from above and stops a
    // rounding step away (9.3e-8 rad/s for 1/(s+1)). DC itself is tested
    // and reported when it attains the peak to rounding.
    let dc = sigma_at_or_d(sys, 0.0);
    if dc.is_finite() && dc >= peak * (1.0 - 8.0 * f64::EPSILON) {
        (peak, omega) = (dc, 0.0);
    }
    if !peak.is_finite() {
        return Err(NormError::Ss(SsError::IllPosed));
    }
    Ok(HinfNorm {
        peak,
        omega,
        upper: found.upper.max(peak),
    })
}

/// `sigma_max(G(j w))` for the searches, by the Hessenberg form (Laub
/// 1981; `O(n^2)` a frequency where a dense solve is `O(n^3)`: the start
/// alone evaluates `2n + 66` frequencies), and `sigma_max(D)` for
/// `w = INFINITY`. What is reported is evaluated on the system as given.
struct FastSigma {
    response: HessenbergResponse,
    at_infinity: f64,
}

impl FastSigma {
    fn new(sys: &StateSpace) -> Self {
        Self {
            response: HessenbergResponse::new(sys),
            at_infinity: sigma_max(&sys.d),
        }
    }

    fn at(&self, w: f64) -> f64 {
        if w.is_finite() {
            self.response.sigma_at(w)
        } else {
            self.at_infinity
        }
    }
}

/// `sigma_max(G(j w))`, and `sigma_max(D)` for `w = INFINITY`.
fn sigma_at_or_d(sys: &StateSpace, w: f64) -> f64 {
    if w.is_finite() {
        sys.sigma_at(w)
    } else {
        sigma_max(&sys.d)
    }
}

/// Maximum of `sigma_max(G(j w))` over `[lo, hi]` by golden-section search
/// (the bracket of a converged Bruinsma–Steinbuch step holds one peak).
fn golden_max(sigma: impl Fn(f64) -> f64, lo: f64, hi: f64) -> (f64, f64) {
    const INV_PHI: f64 = 0.618_033_988_749_894_8;
    let (mut a, mut b) = (lo, hi);
    let mut x1 = b - INV_PHI * (b - a);
    let mut x2 = a + INV_PHI * (b - a);
    let (mut f1, mut f2) = (sigma(x1), sigma(x2));
    for _ in 0..200 {
        if b - a <= 1e-15 * b.abs().max(f64::MIN_POSITIVE) {
            break;
        }
        if f1 >= f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - INV_PHI * (b - a);
            f1 = sigma(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + INV_PHI * (b - a);
            f2 = sigma(x2);
        }
    }
    [(lo, sigma(lo)), (hi, sigma(hi)), (x1, f1), (x2, f2)]
        .into_iter()
        .fold((lo, f64::NEG_INFINITY), |best, (w, s)| {
            if s > best.1 { (w, s) } else { best }
        })
}

/// `count` log-spaced frequencies from `margin` times below the slowest
/// pole to `margin` times above the fastest (empty without non-zero poles).
pub(crate) fn log_grid(poles: &[c64], count: usize, margin: f64) -> Vec<f64> {
    let mags = poles.iter().map(|p| p.norm()).filter(|&w| w > 0.0);
    let (lo, hi) = mags.fold((f64::INFINITY, 0.0f64), |(l, h), w| (l.min(w), h.max(w)));
    if !(lo.is_finite() && hi > 0.0) {
        return Vec::new();
    }
    let (a, b) = ((lo / margin).log10(), (hi * margin).log10());
    (0..count)
        .map(|i| 10f64.powf(a + (b - a) * i as f64 / (count - 1) as f64))
        .collect()
}

/// Relative distance from the imaginary axis (unit circle) within which an
/// eigenvalue counts as a crossing. 1e-6 took the Hamiltonian eigenvalues
/// of a pole damped by 1e-6 (SLICOT's AB13DD example) for crossings at
/// every level, so no bound was ever certified; a true crossing computed
/// off the axis by more than 1e-8 is one of a nearly coalescing pair, whose
/// level is then within rounding of the peak.
const AXIS_TOL: f64 = 1e-8;

/// What the Bruinsma–Steinbuch iteration found.
struct Found {
    /// Best frequency seen, rad/s (`INFINITY`: the value of `D`).
    omega: f64,
    /// Certified upper bound (`INFINITY` when no level was certified).
    upper: f64,
    /// Frequencies around `omega` (the crossings of the last level that
    /// raised the lower bound): the peak lies between them.
    bracket: (f64, f64),
}

/// Highest frequency: infinity (continuous) or Nyquist `pi/ts` (discrete).
fn top_frequency(sys: &StateSpace) -> f64 {
    sys.ts.map_or(f64::INFINITY, |t| std::f64::consts::PI / t)
}

/// The best of the sorted `candidates` (frequencies, rad/s) by
/// `sigma_max`, if above `floor`, with its neighbours as bracket.
fn best_of(sigma: &FastSigma, candidates: &[f64], floor: (f64, f64)) -> (f64, f64, (f64, f64)) {
    let (mut glb, mut wpk, mut bracket) = (floor.0, floor.1, (floor.1, floor.1));
    for (i, &w) in candidates.iter().enumerate() {
        let s = sigma.at(w);
        if s > glb {
            let lo = if i > 0 { candidates[i - 1] } else { w };
            let hi = candidates.get(i + 1).copied().unwrap_or(w);
            (glb, wpk, bracket) = (s, w, (lo, hi));
        }
    }
    (glb, wpk, bracket)
}

/// Start (Bruinsma–Steinbuch step 1): DC, the top frequency, the poles'
/// frequencies and a coarse log grid over their range (continuous
/// equivalents `ln(p)/ts` for a discrete system). A start at the top
/// alone puts gamma within 2 rtol of `sigma_max(D)` when the peak is
/// elsewhere, where `R = D'D - gamma^2 I` is nearly singular and the
/// crossings are lost; the grid's best point keeps the test well posed.
fn seed(sys: &StateSpace, poles: &[c64]) -> Vec<f64> {
    let top = top_frequency(sys);
    let poles: Vec<c64> = poles
        .iter()
        .copied()
        .filter(|p| p.norm() > 0.0)
        .map(|p| sys.ts.map_or(p, |t| p.ln() / t))
        .collect();
    let mut cands = vec![0.0, top];
    for p in &poles {
        cands.extend([p.norm(), p.im.abs()]);
    }
    cands.extend(log_grid(&poles, 64, 10.0));
    cands.retain(|w| *w <= top);
    cands.sort_by(f64::total_cmp);
    cands.dedup();
    cands
}

/// Non-negative frequencies where some singular value of the continuous
/// `G(jw)` may equal `gamma`: the imaginary-axis eigenvalues of the
/// Hamiltonian (Bruinsma & Steinbuch 1990) with `R = D'D - g^2 I`,
/// `S = DD' - g^2 I`; `None` when either is singular.
fn continuous_crossings(sys: &StateSpace, gamma: f64) -> Result<Option<Vec<f64>>, NormError> {
    let (a, b, c, d) = (&sys.a, &sys.b, &sys.c, &sys.d);
    let (m, p) = (sys.nu(), sys.ny());
    let g2 = gamma * gamma;
    let r = &(tr(d) * d) - &(Mat::<f64>::identity(m, m) * g2);
    let s = &(d * tr(d)) - &(Mat::<f64>::identity(p, p) * g2);
    let (Some(ri), Some(si)) = (inv(&r), inv(&s)) else {
        return Ok(None);
    };
    let h11 = a - &(b * &ri * tr(d) * c);
    let h12 = &(b * &ri * tr(b)) * (-gamma);
    let h21 = &(tr(c) * &si * c) * gamma;
    let h22 = &(tr(c) * d * &ri * tr(b)) - &tr(a);
    let h = block2(&h11, &h12, &h21, &h22);
    let hn = fro(&h);
    Ok(Some(
        eigvals(&h)?
            .iter()
            .filter(|l: &&c64| l.im >= 0.0 && l.re.abs() <= AXIS_TOL * l.norm() + 1e-10 * hn)
            .map(|l| l.im)
            .collect(),
    ))
}

/// Frequencies (rad/s, `0..=pi/ts`) where some singular value of the
/// discrete `G(e^{j theta})` may equal `gamma`: the unit-circle eigenvalues
/// of the extended symplectic pencil `z L - M` in `(x, w, u, v)`,
/// `z x = A x + B u`, `z (A' w + C' v) = w`, `C x + D u = g v`,
/// `B' w + D' v = g u` (the discrete Bruinsma–Steinbuch test without
/// inverting `D'D - g^2 I`; SLICOT AB13DD works on the same pencil).
fn discrete_crossings(sys: &StateSpace, gamma: f64, ts: f64) -> Result<Vec<f64>, NormError> {
    let (n, m, p) = (sys.nx(), sys.nu(), sys.ny());
    let k = 2 * n + m + p;
    let (mut big_m, mut big_l) = (Mat::<f64>::zeros(k, k), Mat::<f64>::zeros(k, k));
    let (w0, u0, v0) = (n, 2 * n, 2 * n + m);
    let put = |t: &mut Mat<f64>, r0: usize, c0: usize, blk: &Mat<f64>, f: f64| {
        for i in 0..blk.nrows() {
            for j in 0..blk.ncols() {
                t[(r0 + i, c0 + j)] += f * blk[(i, j)];
            }
        }
    };
    let (eye_n, eye_m, eye_p) = (
        Mat::<f64>::identity(n, n),
        Mat::<f64>::identity(m, m),
        Mat::<f64>::identity(p, p),
    );
    put(&mut big_l, 0, 0, &eye_n, 1.0);
    put(&mut big_m, 0, 0, &sys.a, 1.0);
    put(&mut big_m, 0, u0, &sys.b, 1.0);
    put(&mut big_l, w0, w0, &tr(&sys.a), 1.0);
    put(&mut big_l, w0, v0, &tr(&sys.c), 1.0);
    put(&mut big_m, w0, w0, &eye_n, 1.0);
    // Rows: n state, n costate, p output and m input equations.
    let (out_row, in_row) = (2 * n, 2 * n + p);
    put(&mut big_m, out_row, 0, &sys.c, 1.0);
    put(&mut big_m, out_row, u0, &sys.d, 1.0);
    put(&mut big_m, out_row, v0, &eye_p, -gamma);
    put(&mut big_m, in_row, w0, &tr(&sys.b), 1.0);
    put(&mut big_m, in_row, v0, &tr(&sys.d), 1.0);
    put(&mut big_m, in_row, u0, &eye_m, -gamma);
    let qz = gen_schur(&big_m, &big_l).map_err(|_| NormError::Ss(SsError::IllPosed))?;
    Ok(qz
        .pairs()
        .into_iter()
        .filter(|(_, beta)| beta.norm() > 0.0)
        .map(|(alpha, beta)| alpha / beta)
        .filter(|z| z.im >= 0.0 && (z.norm() - 1.0).abs() <= AXIS_TOL)
        .map(|z| z.arg() / ts)
        .collect())
}

/// A discrete system's crossing frequencies from its continuous equivalent
/// under the bilinear map (`s = a (z-1)/(z+1)`, `a = 2/ts`, which keeps the
/// frequency response on the axis: `theta = 2 atan(w_c / a)`), for when the
/// QZ iteration on the symplectic pencil does not converge (a closed loop
/// with a pole 1e-7 inside the unit circle beside one near `z = -1`);
/// `None` when that test cannot be posed either.
fn bilinear_crossings(sys: &StateSpace, gamma: f64, ts: f64) -> Option<Vec<f64>> {
    let alpha = 2.0 / ts;
    let cont = bilinear_to_continuous(sys, alpha).ok()?;
    let ws = continuous_crossings(&cont, gamma).ok()??;
    Some(ws.iter().map(|w| 2.0 * (w / alpha).atan() / ts).collect())
}

/// Sorted crossing frequencies at level `gamma`, or `None` when the test
/// is not posed (continuous `R` or `S` singular).
fn crossings(sys: &StateSpace, gamma: f64) -> Result<Option<Vec<f64>>, NormError> {
    let mut ws = match sys.ts {
        None => match continuous_crossings(sys, gamma)? {
            Some(ws) => ws,
            None => return Ok(None),
        },
        Some(ts) => match discrete_crossings(sys, gamma, ts) {
            Ok(ws) => ws,
            Err(e) => match bilinear_crossings(sys, gamma, ts) {
                Some(ws) => ws,
                None => return Err(e),
            },
        },
    };
    ws.sort_by(f64::total_cmp);
    Ok(Some(ws))
}

/// Bruinsma–Steinbuch two-step iteration on a stable system: raise the
/// lower bound to the best of the midpoints of the crossing frequencies at
/// `gamma = (1 + margin) glb` until there is no crossing, which certifies
/// `gamma` as an upper bound.
fn bruinsma_steinbuch(
    sys: &StateSpace,
    sigma: &FastSigma,
    poles: &[c64],
    rtol: f64,
) -> Result<Found, NormError> {
    let top = top_frequency(sys);
    if sys.nx() == 0 {
        let upper = sigma_max(&sys.d);
        return Ok(Found {
            omega: top,
            upper,
            bracket: (top, top),
        });
    }
    let (mut glb, mut wpk, mut bracket) = best_of(sigma, &seed(sys, poles), (0.0, 0.0));
    if glb == 0.0 {
        return Ok(Found {
            omega: 0.0,
            upper: 0.0,
            bracket: (0.0, 0.0),
        });
    }
    let mut margin = 2.0 * rtol;
    for _ in 0..60 {
        let gamma = (1.0 + margin) * glb;
        let Some(ws) = crossings(sys, gamma)? else {
            break;
        };
        if ws.is_empty() {
            return Ok(Found {
                omega: wpk,
                upper: gamma,
                bracket,
            });
        }
        // Midpoints, the crossings themselves, DC (the midpoint of a
        // crossing interval symmetric about 0) and the top frequency (the
        // end of an interval unbounded above, or Nyquist).
        let mut cands: Vec<f64> = ws.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        cands.extend(ws.iter().copied());
        cands.extend([0.0, top]);
        cands.sort_by(f64::total_cmp);
        let old = glb;
        let best = best_of(sigma, &cands, (glb, wpk));
        if best.0 > glb {
            (glb, wpk) = (best.0, best.1);
            bracket = enclosing(&ws, wpk, top);
        }
        if glb <= old * (1.0 + 0.1 * rtol) {
            // Eigenvalues near the axis (circle) where sigma_max stays below
            // gamma: rounding, not crossings. Retry at a wider margin, whose
            // certificate is looser but sound.
            margin *= 4.0;
            if margin > 1e-2 {
                break;
            }
        }
    }
    Ok(Found {
        omega: wpk,
        upper: f64::INFINITY,
        bracket,
    })
}

/// The crossings on either side of `w` (0 and `top` where there is none).
fn enclosing(ws: &[f64], w: f64, top: f64) -> (f64, f64) {
    let lo = ws
        .iter()
        .copied()
        .filter(|&x| x < w)
        .fold(0.0f64.min(w), f64::max);
    let hi = ws.iter().copied().filter(|&x| x > w).fold(top, f64::min);
    (lo, hi)
}

/// `sigma_max` of the frequency response at `omega` rad/s evaluated in
/// double-double arithmetic (`lti::accurate::response_extended`);
/// infinite where `s I - A` is singular.
pub fn sigma_extended(sys: &StateSpace, omega: f64) -> f64 {
    crate::lti::accurate::response_extended(sys, frequency_point(sys.ts, omega))
        .map_or(f64::INFINITY, |g| crate::lti::ss::sigma_max_c(&g))
}

/// [`sigma_extended`] by mixed-precision refinement
/// (`lti::accurate::response_refined`), and by double-double elimination
/// where refinement does not converge: the same value to far below the
/// 1e-9 that [`confirm_extended`]'s probes decide on, in `O(n^3)` double
/// and `O(n^2)` double-double work instead of `O(n^3)` double-double.
fn sigma_refined(sys: &StateSpace, omega: f64) -> f64 {
    crate::lti::accurate::response_refined(sys, frequency_point(sys.ts, omega))
        .map(|g| crate::lti::ss::sigma_max_c(&g))
        .unwrap_or_else(|| sigma_extended(sys, omega))
}

/// [`hinf_norm`], then [`confirm_extended`] on a log grid spanning the
/// poles (400 points, two decades beyond them, up to Nyquist): what the
/// user-facing norm reports, so that a stiff realisation's peak is the
/// double-double value, and its certificate is withdrawn when double
/// precision was off.
pub fn hinf_norm_confirmed(sys: &StateSpace, rtol: f64) -> Result<HinfNorm, NormError> {
    hinf_norm_confirmed_with_poles(sys, rtol, &sys.poles()?)
}

/// [`hinf_norm_confirmed`] with the poles of `sys` already computed.
pub(crate) fn hinf_norm_confirmed_with_poles(
    sys: &StateSpace,
    rtol: f64,
    poles: &[c64],
) -> Result<HinfNorm, NormError> {
    let mut h = hinf_norm_with_poles(sys, rtol, poles)?;
    let grid = log_grid_to_nyquist(poles, sys.ts, 400);
    confirm_extended(sys, &grid, &mut h);
    Ok(h)
}

/// [`log_grid`] with two decades of margin, without the points above the
/// Nyquist frequency of a discrete system.
pub(crate) fn log_grid_to_nyquist(poles: &[c64], ts: Option<f64>, count: usize) -> Vec<f64> {
    let nyquist = ts.map(|t| std::f64::consts::PI / t);
    log_grid(poles, count, 100.0)
        .into_iter()
        .filter(|w| nyquist.is_none_or(|n| *w <= n))
        .collect()
}

/// Whether a norm computed in double precision on `sys` can be trusted:
/// `sigma_max` at the peak, at DC and at seven frequencies of `grid` agrees
/// with its double-double value ([`sigma_extended`]) to 1e-9. When it does
/// not (a stiff realisation: a cheap-control H-infinity loop whose entries
/// reach 1e12 beside a pole at 0.02 loses three digits of its DC gain), the
/// peak is searched again in double-double: on every fourth point of
/// `grid`, refined by golden section around the three largest local maxima,
/// at the double search's peak frequency, at DC and at the top of the grid
/// (and the Nyquist frequency). `h` then holds that attained peak, and its upper bound is
/// withdrawn (the Hamiltonian's certificate was computed in double).
/// Returns `true` when the double-precision result stood.
pub fn confirm_extended(sys: &StateSpace, grid: &[f64], h: &mut HinfNorm) -> bool {
    let mut probes: Vec<f64> = vec![0.0];
    if h.omega.is_finite() {
        probes.push(h.omega);
    }
    if !grid.is_empty() {
        probes.extend((0..7).map(|k| grid[k * (grid.len() - 1) / 6]));
    }
    let agrees = |w: f64| {
        let (d, e) = (sys.sigma_at(w), sigma_refined(sys, w));
        (d - e).abs() <= 1e-9 * e.abs().max(f64::MIN_POSITIVE)
    };
    if probes.into_iter().all(agrees) {
        return true;
    }
    let coarse: Vec<(f64, f64)> = grid
        .iter()
        .step_by(4)
        .map(|&w| (w, sigma_extended(sys, w)))
        .collect();
    // DC, the double search's peak and the top of the grid (the Nyquist
    // frequency of a discrete system) are attained values too.
    let mut best = (0.0, sigma_extended(sys, 0.0));
    let ends = [h.omega, grid.last().copied().unwrap_or(0.0)];
    for w in ends.into_iter().filter(|w| w.is_finite()) {
        let s = sigma_extended(sys, w);
        if s > best.1 {
            best = (w, s);
        }
    }
    if let Some(t) = sys.ts {
        let w = std::f64::consts::PI / t;
        let s = sigma_extended(sys, w);
        if s > best.1 {
            best = (w, s);
        }
    }
    let mut maxima: Vec<(usize, f64)> = (0..coarse.len())
        .filter(|&i| {
            let left = i == 0 || coarse[i - 1].1 <= coarse[i].1;
            let right = i + 1 == coarse.len() || coarse[i + 1].1 <= coarse[i].1;
            left && right
        })
        .map(|i| (i, coarse[i].1))
        .collect();
    maxima.sort_by(|a, b| b.1.total_cmp(&a.1));
    for &(i, _) in maxima.iter().take(3) {
        let lo = coarse[i.saturating_sub(1)].0;
        let hi = coarse[(i + 1).min(coarse.len() - 1)].0;
        let (w, s) = golden_max(|w| sigma_extended(sys, w), lo, hi);
        if s > best.1 {
            best = (w, s);
        }
    }
    (h.peak, h.omega, h.upper) = (best.1, best.0, f64::INFINITY);
    false
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn h2_norm_of_a_stiff_badly_scaled_realisation() {
        // G = 1/(s + 1e-3) + 1/(s + 1e8) + coupling, realised with states
        // scaled by 1e-6 and 1e6: ||G||^2 = 1/(2a1) + 1/(2a2) + 2/(a1 + a2)
        // for the uncoupled part (closed form), and the scaling must not
        // change the norm.
        let (a1, a2) = (1e-3f64, 1e8f64);
        let exact = (1.0 / (2.0 * a1) + 1.0 / (2.0 * a2) + 2.0 / (a1 + a2)).sqrt();
        let (t1, t2) = (1e-6, 1e6);
        let g = StateSpace::new(
            Mat::from_fn(2, 2, |i, j| match (i, j) {
                (0, 0) => -a1,
                (1, 1) => -a2,
                _ => 0.0,
            }),
            Mat::from_fn(2, 1, |i, _| if i == 0 { 1.0 / t1 } else { 1.0 / t2 }),
            Mat::from_fn(1, 2, |_, j| if j == 0 { t1 } else { t2 }),
            Mat::zeros(1, 1),
            None,
        )
        .unwrap();
        let h2 = h2_norm(&g).unwrap();
        assert!((h2 - exact).abs() < 1e-12 * exact, "{h2} vs {exact}");
    }

    pub fn first_order_norms() {
        // 1/(s+1): H2 = sqrt(1/2), Hinf = 1 at w = 0.
        let g = StateSpace::from_tf(&[1.0], &[1.0, 1.0], None).unwrap();
        assert!((h2_norm(&g).unwrap() - 0.5f64.sqrt()).abs() < 1e-14);
        let h = hinf_norm(&g, 1e-9).unwrap();
        assert!((h.peak - 1.0).abs() < 1e-15 && h.omega == 0.0, "{h:?}");
        assert!(h.upper >= 1.0 && h.upper <= 1.0 + 2.1e-9, "{h:?}");
    }

    /// Largest singular value of a discrete system over a 2000-point grid
    /// on `[0, pi]` refined by golden-section search around the best point:
    /// an independent lower bound on the H-inf norm.
    fn discrete_sweep_peak(sys: &StateSpace) -> f64 {
        let k = 2000;
        let step = std::f64::consts::PI / k as f64;
        let (mut peak, mut at) = (0.0, 0.0);
        for i in 0..=k {
            let s = sys.sigma_at(i as f64 * step);
            if s > peak {
                (peak, at) = (s, i as f64 * step);
            }
        }
        let (mut lo, mut hi) = ((at - step).max(0.0), (at + step).min(std::f64::consts::PI));
        for _ in 0..80 {
            let (m1, m2) = (lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo));
            if sys.sigma_at(m1) > sys.sigma_at(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        peak.max(sys.sigma_at(0.5 * (lo + hi)))
    }

    /// Uniform numbers in [-1, 1) from a 64-bit LCG (Knuth's MMIX constants).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    /// The fallback for a pencil QZ cannot reduce: the crossings of the
    /// bilinear equivalent, mapped back, are the pencil's own.
    pub fn bilinear_crossings_are_the_pencils() {
        let mut rnd = uniform(7);
        let mut compared = 0;
        for case in 0..40 {
            let n = 2 + case % 4;
            let a0 = Mat::from_fn(n, n, |_, _| rnd());
            let radius = eigvals(&a0)
                .unwrap()
                .iter()
                .fold(1e-9f64, |r, z| r.max(z.norm()));
            let a = Mat::from_fn(n, n, |i, j| a0[(i, j)] * 0.9 / radius);
            let (b, c) = (
                Mat::from_fn(n, 1, |_, _| rnd()),
                Mat::from_fn(1, n, |_, _| rnd()),
            );
            let ts = 1e-3;
            let sys = StateSpace::new(a, b, c, Mat::zeros(1, 1), Some(ts)).unwrap();
            let gamma = 0.8 * hinf_norm(&sys, 1e-9).unwrap().peak;
            let mut direct = discrete_crossings(&sys, gamma, ts).unwrap();
            let mut mapped = bilinear_crossings(&sys, gamma, ts).unwrap();
            direct.sort_by(f64::total_cmp);
            mapped.sort_by(f64::total_cmp);
            assert_eq!(direct.len(), mapped.len(), "case {case}");
            assert!(!direct.is_empty(), "case {case}");
            for (x, y) in direct.iter().zip(&mapped) {
                assert!(
                    (x - y).abs() <= 1e-7 * (std::f64::consts::PI / ts),
                    "{x} vs {y}"
                );
            }
            compared += direct.len();
        }
        assert!(compared >= 40);
    }

    pub fn discrete_norm_finds_peaks_below_nyquist() {
        // Random stable discrete systems, 1..6 states, SISO to 2x2, with and
        // without D. Seeding the search at sigma(D) alone (the Nyquist value
        // after the bilinear map) missed peaks by up to 11 % on 16 of 2000
        // such systems.
        let mut rnd = uniform(99);
        let (mut worst, mut loose) = (0.0f64, 0);
        for case in 0..400 {
            let n = 1 + (case % 6);
            let (m, p) = (1 + (case / 6) % 2, 1 + (case / 12) % 2);
            let a0 = Mat::from_fn(n, n, |_, _| rnd());
            let b = Mat::from_fn(n, m, |_, _| rnd());
            let c = Mat::from_fn(p, n, |_, _| rnd());
            let d = Mat::from_fn(p, m, |_, _| if case % 3 == 0 { 0.0 } else { rnd() });
            let radius = eigvals(&a0)
                .unwrap()
                .iter()
                .fold(1e-9f64, |r, z| r.max(z.norm()));
            let shrink = (0.5 + 0.499 * rnd().abs()) / radius;
            let a = Mat::from_fn(n, n, |i, j| a0[(i, j)] * shrink);
            let sys = StateSpace::new(a, b, c, d, Some(1.0)).unwrap();
            let h = hinf_norm(&sys, 1e-9).unwrap();
            let peak = discrete_sweep_peak(&sys);
            worst = worst.max(1.0 - h.peak / peak);
            // The certificate holds against the independent sweep, and the
            // reported peak is attained where it is said to be.
            assert!(h.upper >= peak * (1.0 - 1e-14), "{case}: {h:?} vs {peak}");
            assert_eq!(h.peak, sys.sigma_at(h.omega), "{case}");
            // 2 rtol, or a few times more where the first levels were
            // inconclusive (eigenvalues near the axis that are not crossings:
            // a sharp resonance, or a peak at Nyquist, infinity on the
            // bilinear image, where R is nearly singular).
            assert!(h.gap() <= 1e-6, "{case}: {h:?}");
            loose += usize::from(h.gap() > 2.1e-9);
        }
        assert!(worst < 1e-6, "worst relative shortfall {worst:e}");
        eprintln!("worst shortfall {worst:e}, {loose} of 400 bounds looser than 2 rtol");
        // None was on the last run; a few may be after a platform change.
        assert!(loose <= 4, "{loose} of 400 bounds looser than 2 rtol");
    }

    pub fn resonance_peak() {
        // w0^2/(s^2 + 2 z w0 s + w0^2), z = 0.05: peak 1/(2 z sqrt(1 - z^2)).
        let (z, w0) = (0.05, 10.0);
        let g = StateSpace::from_tf(&[w0 * w0], &[1.0, 2.0 * z * w0, w0 * w0], None).unwrap();
        let h = hinf_norm(&g, 1e-10).unwrap();
        let want = 1.0 / (2.0 * z * (1.0 - z * z).sqrt());
        // The refined peak is the closed form to rounding, not to rtol.
        assert!((h.peak - want).abs() < 1e-14 * want, "{h:?} vs {want}");
        assert!(h.peak <= want * (1.0 + 1e-15) && h.upper >= want, "{h:?}");
        assert!(
            (h.omega - w0 * (1.0 - 2.0 * z * z).sqrt()).abs() < 1e-6,
            "{h:?}"
        );
        // Discrete: the norm of a stable discrete system equals the peak over the circle.
        let gd = StateSpace::new(
            Mat::from_fn(1, 1, |_, _| 0.5),
            Mat::from_fn(1, 1, |_, _| 1.0),
            Mat::from_fn(1, 1, |_, _| 1.0),
            Mat::from_fn(1, 1, |_, _| 0.0),
            Some(0.1),
        )
        .unwrap();
        let h = hinf_norm(&gd, 1e-10).unwrap();
        assert!((h.peak - 2.0).abs() < 1e-15 && h.omega == 0.0, "{h:?}");
        // H2 of 1/(z - 0.5): sum 0.25^k = 4/3.
        assert!((h2_norm(&gd).unwrap() - (4.0f64 / 3.0).sqrt()).abs() < 1e-14);
    }

    pub fn peaks_at_nyquist_and_at_infinity() {
        // 1/(z + 0.5), ts = 1e-3: |G| peaks at z = -1 (the Nyquist
        // frequency pi/ts) with 1/0.5 = 2.
        let ts = 1e-3;
        let gd = StateSpace::new(
            Mat::from_fn(1, 1, |_, _| -0.5),
            Mat::from_fn(1, 1, |_, _| 1.0),
            Mat::from_fn(1, 1, |_, _| 1.0),
            Mat::zeros(1, 1),
            Some(ts),
        )
        .unwrap();
        let h = hinf_norm(&gd, 1e-10).unwrap();
        assert!((h.peak - 2.0).abs() < 1e-14, "{h:?}");
        assert!(
            (h.omega - std::f64::consts::PI / ts).abs() < 1e-6 / ts,
            "{h:?}"
        );
        assert!(h.upper >= 2.0 && h.gap() <= 2.1e-10, "{h:?}");
        // s/(s + 1) = 1 - 1/(s + 1): the supremum 1 is approached as w -> inf.
        let hp = StateSpace::from_tf(&[1.0, 0.0], &[1.0, 1.0], None).unwrap();
        let h = hinf_norm(&hp, 1e-10).unwrap();
        assert!(h.peak == 1.0 && h.omega.is_infinite(), "{h:?}");
        assert!(h.upper >= 1.0 && h.gap() <= 2.1e-10, "{h:?}");
    }

    pub fn discrete_h2_with_feedthrough() {
        // G(z) = d + c b / (z - a): impulse response d, c b, c a b, ...
        // ||G||_2^2 = d^2 + (c b)^2 / (1 - a^2).
        let (a, b, c, d) = (-0.8, 1.5, 0.4, 0.7);
        let g = StateSpace::new(
            Mat::from_fn(1, 1, |_, _| a),
            Mat::from_fn(1, 1, |_, _| b),
            Mat::from_fn(1, 1, |_, _| c),
            Mat::from_fn(1, 1, |_, _| d),
            Some(0.01),
        )
        .unwrap();
        let want = (d * d + (c * b) * (c * b) / (1.0 - a * a)).sqrt();
        let got = h2_norm(&g).unwrap();
        assert!((got - want).abs() < 1e-14 * want, "{got} vs {want}");
        // Continuous with D: infinite.
        let hp = StateSpace::from_tf(&[1.0, 0.0], &[1.0, 1.0], None).unwrap();
        assert_eq!(h2_norm(&hp).unwrap(), f64::INFINITY);
    }

    pub fn unstable_is_an_error() {
        let g = StateSpace::from_tf(&[1.0], &[1.0, -1.0], None).unwrap();
        assert_eq!(hinf_norm(&g, 1e-6), Err(NormError::Unstable));
        assert_eq!(h2_norm(&g), Err(NormError::Unstable));
    }

    /// The user-facing norm of the cancelling pair is the exact DC value
    /// `(a - 1)/a` (double precision alone misses it past 1e-10), with no
    /// certificate; a well-conditioned system keeps its certificate.
    pub fn the_confirmed_norm_is_exact_on_a_cancelling_pair() {
        let (sys, exact) = crate::lti::accurate::cancelling_pair();
        let h = hinf_norm_confirmed(&sys, 1e-9).unwrap();
        assert!(
            (h.peak - exact).abs() <= 1e-12 * exact,
            "{} vs {exact}",
            h.peak
        );
        assert_eq!(h.upper, f64::INFINITY);
        let g = StateSpace::from_tf(&[1.0], &[1.0, 0.2, 1.0], None).unwrap();
        let h = hinf_norm_confirmed(&g, 1e-9).unwrap();
        // |G(jw)| peaks at 1/(2 zeta sqrt(1 - zeta^2)), zeta = 0.1.
        let closed = 1.0 / (0.2 * (1.0f64 - 0.01).sqrt());
        assert!((h.peak - closed).abs() <= 1e-12 * closed && h.upper.is_finite());
    }

    /// `1/(s + 1) - 1/(s + a)`, `a = 1 + 1e-9`: the peak is at DC,
    /// `(a - 1)/a` exactly, which double precision gets to 7 digits; the
    /// double-double check notices and replaces it.
    pub fn confirm_extended_replaces_a_cancelled_peak() {
        let (sys, exact) = crate::lti::accurate::cancelling_pair();
        let mut h = hinf_norm(&sys, 1e-8).unwrap();
        let grid = log_grid(&sys.poles().unwrap(), 200, 100.0);
        assert!(!confirm_extended(&sys, &grid, &mut h));
        assert!(
            (h.peak / exact - 1.0).abs() < 1e-14,
            "{} vs {exact}",
            h.peak
        );
        assert_eq!(h.omega, 0.0);
        assert!(h.upper.is_infinite());
        // A well-conditioned system stands as computed.
        let plain = StateSpace::from_tf(&[1.0], &[1.0, 0.2, 1.0], None).unwrap();
        let mut h = hinf_norm(&plain, 1e-8).unwrap();
        let before = h;
        let grid = log_grid(&plain.poles().unwrap(), 200, 100.0);
        assert!(confirm_extended(&plain, &grid, &mut h));
        assert_eq!(h, before);
    }
}
