//! Zero phase error tracking control (Tomizuka 1987; \[Li21\] Eq. 6-10; docs/math.md §3).
//!
//! For a closed loop `G_c = z^-d B_c / A_c`, the zeros of `B_c` are split into
//! those a feedforward filter may cancel (`B_a`: inside radius `rho` and well
//! damped) and the `s` others (`B_u`). The filter
//!
//! `G_z = z^(d+s) A_c B_u^* / (B_a B_u(1)^2)`   (\[Li21\] Eq. 8)
//!
//! makes `G_z G_c = B_u(z^-1) B_u(z) / B_u(1)^2`: real and non-negative on the
//! unit circle (zero phase) with unit DC gain. The advance `z^(d+s)` is a
//! preview carried as an integer: the causal part is run on the reference
//! `d+s` samples ahead.
//!
//! Optionally ([`StableInversion`]), zeros well outside the unit circle are
//! not left to the phase cancellation above but inverted exactly by their
//! anticausal series (stable inversion, Devasia, Chen & Paden 1996; the
//! truncated series of Gross & Tomizuka's non-causal inverse). A factor
//! `B_o = prod (1 - z_i z^-1)`, `|z_i| > 1`, equals `P z^-m Q(z)` with
//! `P = prod(-z_i)` and `Q(w) = prod (1 - w / z_i)`, whose roots lie outside the
//! unit circle; so `1/B_o = z^m/P sum_k h_k z^k` converges on `|z| = 1`, with
//! `h` the power series of `1/Q`. Truncated after `N` terms it is an FIR
//! filter with `m + N` samples of preview, and `G_z G_c` then equals
//! `B_u(z^-1) B_u(z)/B_u(1)^2` for the remaining zeros only, up to the series'
//! tail (the tolerance). For an FTS the whole trajectory is known before the
//! cut, so the longer preview costs nothing; what it buys is the magnitude
//! that plain ZPETC gives up (for `z = 2.88`, 8 % at 500 Hz and 31 % at 1 kHz
//! with `Ts = 1e-4`; for a pair at `1.045` and 1.4 kHz, `|G_z G_c|` falls to
//! 0.34 at 1 kHz).

use crate::lti::{DiscreteTf, Poly, RootsError, TdfFilter, c64, linspace};
use std::f64::consts::PI;
use std::fmt;

/// Settings of the zero classification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZpetcParams {
    /// Zeros with `|z| >= rho` are not cancelled: a cancelling pole that close
    /// to the unit circle makes a slowly decaying, model-sensitive filter.
    /// Default `0.95`; must lie in `(0, 1]`.
    pub rho: f64,
    /// Zeros whose cancelling pole would have an equivalent damping ratio
    /// below this are not cancelled. The ratio of a z-plane point is that of
    /// `s = ln(z)/Ts`: `zeta = -ln|z| / |ln z|`. It rejects lightly damped
    /// complex pairs and zeros near `-1` (the ringing sampling zeros); e.g.
    /// `z = -0.75` has `zeta = 0.091`. Default `0.1`; must lie in `[0, 1]`.
    pub min_damping: f64,
    /// Invert zeros far outside the unit circle exactly by an anticausal
    /// series instead of cancelling only their phase. Default `None`: the
    /// classical ZPETC of Tomizuka and \[Li21\].
    pub stable_inversion: Option<StableInversion>,
}

impl Default for ZpetcParams {
    fn default() -> Self {
        Self {
            rho: 0.95,
            min_damping: 0.1,
            stable_inversion: None,
        }
    }
}

/// Settings of the exact (anticausal series) inversion of outside zeros.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableInversion {
    /// Zeros with `|z| >= min_radius` are inverted by the series. The series
    /// decays like `|z|^-k`, so its length grows as `ln(tol)/ln(1/|z|)`: at
    /// `1e-4`, 1.02 needs about 465 terms, 1.05 about 190, 2.88 about 9.
    /// Zeros between the unit circle and this radius stay with ZPETC (their
    /// exact inverse would need a preview too long, and amplify model error
    /// at their frequency). Default `1.02`; must exceed 1.
    pub min_radius: f64,
    /// Truncation: the series stops once its terms fall below
    /// `tolerance * sum |h_k|` (the relative error of the inversion on the
    /// unit circle is of this order). Default `1e-4`: far below the error of
    /// any identified model (a percent or so), and it keeps the filter short.
    pub tolerance: f64,
    /// Upper bound on the series length. Default 1000.
    pub max_terms: usize,
}

impl Default for StableInversion {
    fn default() -> Self {
        Self {
            min_radius: 1.02,
            tolerance: 1e-4,
            max_terms: 1000,
        }
    }
}

/// Why a zero was (not) cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZeroStatus {
    /// Cancelled by a pole of `G_z`.
    Cancelled,
    /// `|z| >= rho` (including zeros on or outside the unit circle).
    OutsideRadius,
    /// Inside `rho` but with damping below `min_damping`.
    PoorlyDamped,
    /// Outside the unit circle, inverted exactly by an anticausal series.
    InvertedBySeries,
}

impl ZeroStatus {
    /// Short label for summaries.
    pub fn label(self) -> &'static str {
        match self {
            ZeroStatus::Cancelled => "cancelled",
            ZeroStatus::OutsideRadius => "kept: |z| >= rho",
            ZeroStatus::PoorlyDamped => "kept: poorly damped",
            ZeroStatus::InvertedBySeries => "inverted: anticausal series",
        }
    }
}

/// One zero of the plant with its classification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClassifiedZero {
    /// The zero in the z-plane.
    pub zero: c64,
    /// `|z|`.
    pub magnitude: f64,
    /// Equivalent damping ratio `-ln|z| / |ln z|` (1 at the origin).
    pub damping: f64,
    /// The decision.
    pub status: ZeroStatus,
}

/// Why a ZPETC cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZpetcError {
    /// Bad settings.
    #[error("{0}")]
    InvalidParams(String),
    /// Zeros could not be computed.
    #[error("plant zeros: {0}")]
    Roots(#[from] RootsError),
    /// An uncancellable zero at `z = 1` makes `B_u(1) = 0`: the plant passes
    /// no DC and unit-DC normalisation is impossible.
    #[error("the plant has a zero at z = 1 (no DC gain); ZPETC cannot have unit DC gain")]
    ZeroAtDc,
    /// The closed loop has a pole on or outside the unit circle: a
    /// feedforward filter cannot make an unstable loop track.
    #[error(
        "the closed loop is unstable: pole {pole} has |z| = {magnitude}; ZPETC inverts a stable closed loop, stabilise the loop (or re-identify it) first"
    )]
    UnstablePlant {
        /// The pole of largest magnitude, written `re+imj`.
        pole: String,
        /// Its magnitude.
        magnitude: f64,
    },
    /// Cancelling a zero this close to the unit circle puts a filter pole
    /// there: the filter's gain near that frequency is about `1/(1 - |z|)`.
    #[error(
        "rho = {rho} would cancel the zero {zero} (|z| = {magnitude}, {distance:.1e} from the unit circle): the filter would have a pole there and a gain near {gain:.1e}; use rho below {limit}"
    )]
    CancelsNearUnitCircle {
        /// The rho given.
        rho: f64,
        /// The zero, written `re+imj`.
        zero: String,
        /// Its magnitude.
        magnitude: f64,
        /// `1 - |z|`.
        distance: f64,
        /// `1 / (1 - |z|)`.
        gain: f64,
        /// The largest magnitude a cancelled zero may have.
        limit: f64,
    },
    /// The anticausal series did not reach its tolerance within `max_terms`.
    #[error(
        "the series inverse of the zeros outside radius {min_radius} needs more than {max_terms} terms to reach {tolerance:e}; raise the radius or the term limit"
    )]
    SeriesTooLong {
        /// The radius used.
        min_radius: f64,
        /// The tolerance asked for.
        tolerance: f64,
        /// The limit.
        max_terms: usize,
    },
}

/// A designed ZPETC filter: `G_z = z^preview num(z^-1)/den(z^-1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Zpetc {
    /// Causal numerator `A_c B_u^* / B_u(1)^2`, ascending `z^-1`.
    pub num: Poly,
    /// Causal denominator `B_a` (constant term 1), ascending `z^-1`.
    pub den: Poly,
    /// Reference look-ahead in samples: `d + s`, plus `m + N` when `m` zeros
    /// are inverted by an `N`-term series.
    pub preview: usize,
    /// Length `N` of the anticausal series (0 without stable inversion).
    pub series_terms: usize,
    /// Sample time in seconds.
    pub ts: f64,
    /// Every zero of the plant with its classification.
    pub zeros: Vec<ClassifiedZero>,
    /// The settings used.
    pub params: ZpetcParams,
}

/// The self-check of a designed filter against its plant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZpetcCheck {
    /// Frequencies examined (uniform from 0 to Nyquist).
    pub points: usize,
    /// Largest `|arg(G_z G_c)|` in rad where `|G_z G_c|` is not negligible.
    pub max_phase_error_rad: f64,
    /// `G_z(1) G_c(1)`, which must be 1.
    pub dc_gain: f64,
    /// Largest relative deviation of `|G_z G_c|` from `|B_u(e^jw)|^2/B_u(1)^2`.
    pub max_magnitude_error: f64,
    /// Whether the causal filter is stable (all poles inside the unit circle).
    pub filter_stable: bool,
    /// Largest `|G_z G_c|` on the grid, and where (Hz): ZPETC's own
    /// magnitude `|B_u(e^jw)|^2 / B_u(1)^2`, about 1 unless a kept zero sits
    /// near `z = 1`.
    pub max_gain: f64,
    /// Where `max_gain` is reached, Hz.
    pub max_gain_hz: f64,
    /// Relative rounding error bound of the filter's DC gain as stored,
    /// `eps (sum |num_k| / |num(1)| + sum |den_k| / |den(1)|)`: the
    /// coefficients' size against the value they sum to (the condition
    /// number of evaluating a polynomial at `z = 1`, Higham 2002 §5.1).
    pub rounding_bound: f64,
}

/// `|G_z(1) G_c(1) - 1|` above this fails the self-check.
pub const DC_GAIN_TOLERANCE: f64 = 1e-6;

/// [`ZpetcCheck::rounding_bound`] above this fails the self-check: the
/// filter's coefficients are so much larger than its gain that double
/// precision cannot carry it (a kept zero within 1e-7 of `z = 1` gives
/// coefficients near 1e15 and a bound near 0.2).
pub const ROUNDING_LIMIT: f64 = 1e-6;

/// [`ZpetcCheck::max_gain`] above this (80 dB) fails the self-check: the
/// feedforward would amplify some frequency ten thousand times more than
/// DC, so any noise or model error there swamps the tracking (a kept real
/// zero at `0.99` gives `(1.99/0.01)^2 = 39601`).
pub const MAX_PRODUCT_GAIN: f64 = 1e4;

/// One way a designed filter fails its self-check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CheckFailure {
    /// `G_z(1) G_c(1)` is not 1.
    DcGain(f64),
    /// The causal filter has a pole on or outside the unit circle.
    Unstable,
    /// The coefficients are too large for double precision.
    Rounding(f64),
    /// `|G_z G_c|` reaches this at this frequency (Hz).
    Gain(f64, f64),
}

impl fmt::Display for CheckFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CheckFailure::DcGain(dc) => write!(
                f,
                "DC gain of G_z G_c = {dc:.9}, not 1 (tolerance {DC_GAIN_TOLERANCE:e})"
            ),
            CheckFailure::Unstable => write!(f, "the filter is unstable"),
            CheckFailure::Rounding(b) => write!(
                f,
                "the filter's coefficients carry a relative rounding error up to {b:.1e} at DC (limit {ROUNDING_LIMIT:e})"
            ),
            CheckFailure::Gain(g, hz) => write!(
                f,
                "|G_z G_c| reaches {g:.2e} at {hz:.1} Hz (limit {MAX_PRODUCT_GAIN:e})"
            ),
        }
    }
}

impl ZpetcCheck {
    /// The criteria this check fails (none for a usable filter): unit DC
    /// gain within [`DC_GAIN_TOLERANCE`], a stable filter, coefficients
    /// within [`ROUNDING_LIMIT`] and a gain within [`MAX_PRODUCT_GAIN`].
    pub fn failures(&self) -> Vec<CheckFailure> {
        let mut out = Vec::new();
        // NaN fails every test.
        let within = |x: f64, limit: f64| x <= limit;
        if !within((self.dc_gain - 1.0).abs(), DC_GAIN_TOLERANCE) {
            out.push(CheckFailure::DcGain(self.dc_gain));
        }
        if !self.filter_stable {
            out.push(CheckFailure::Unstable);
        }
        if !within(self.rounding_bound, ROUNDING_LIMIT) {
            out.push(CheckFailure::Rounding(self.rounding_bound));
        }
        if !within(self.max_gain, MAX_PRODUCT_GAIN) {
            out.push(CheckFailure::Gain(self.max_gain, self.max_gain_hz));
        }
        out
    }
}

fn damping_ratio(z: c64) -> f64 {
    let r = z.norm();
    if r == 0.0 {
        return 1.0;
    }
    let ln = c64::new(r.ln(), z.arg());
    if ln.norm() == 0.0 {
        // z = 1: an integrator-like zero, neither damped nor oscillating.
        return 0.0;
    }
    -r.ln() / ln.norm()
}

/// The largest magnitude of a zero ZPETC cancels: beyond it the cancelling
/// filter pole sits within 1e-6 of the unit circle, a gain above 1e6 at
/// that zero's frequency (the filter's numbers then mean nothing).
pub const MAX_CANCELLED_MAGNITUDE: f64 = 1.0 - 1e-6;

fn fmt_z(z: c64) -> String {
    format!("{}{:+}j", z.re, z.im)
}

/// Refuses a closed loop with a pole on or outside the unit circle.
fn check_stable(g: &DiscreteTf) -> Result<(), ZpetcError> {
    // The verdict is exact on the stored coefficients; the pole named is the
    // computed one of largest modulus (a clustered pole's computed modulus
    // can sit just inside the circle while the stored polynomial's is not).
    if g.is_stable()? {
        return Ok(());
    }
    let worst = g
        .poles()?
        .into_iter()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()));
    let p = worst.unwrap_or_default();
    Err(ZpetcError::UnstablePlant {
        pole: fmt_z(p),
        magnitude: p.norm(),
    })
}

/// Refuses to cancel a zero within 1e-6 of the unit circle.
fn check_cancellations(zeros: &[ClassifiedZero], rho: f64) -> Result<(), ZpetcError> {
    let near = zeros
        .iter()
        .filter(|z| z.status == ZeroStatus::Cancelled && z.magnitude > MAX_CANCELLED_MAGNITUDE)
        .max_by(|a, b| a.magnitude.total_cmp(&b.magnitude));
    match near {
        Some(z) => Err(ZpetcError::CancelsNearUnitCircle {
            rho,
            zero: fmt_z(z.zero),
            magnitude: z.magnitude,
            distance: 1.0 - z.magnitude,
            gain: 1.0 / (1.0 - z.magnitude),
            limit: MAX_CANCELLED_MAGNITUDE,
        }),
        None => Ok(()),
    }
}

/// Splits the zeros of `g` per `params`.
pub fn classify_zeros(
    g: &DiscreteTf,
    params: &ZpetcParams,
) -> Result<Vec<ClassifiedZero>, ZpetcError> {
    Ok(g.zeros()?
        .into_iter()
        .map(|zero| {
            let magnitude = zero.norm();
            let damping = damping_ratio(zero);
            let status = if let Some(si) = params.stable_inversion
                && magnitude >= si.min_radius
            {
                ZeroStatus::InvertedBySeries
            } else if magnitude >= params.rho {
                ZeroStatus::OutsideRadius
            } else if damping < params.min_damping {
                ZeroStatus::PoorlyDamped
            } else {
                ZeroStatus::Cancelled
            };
            ClassifiedZero {
                zero,
                magnitude,
                damping,
                status,
            }
        })
        .collect())
}

/// Designs the ZPETC of the closed loop `g` (\[Li21\] Eq. 8, or Eq. 10 when
/// every zero is cancellable).
pub fn design(g: &DiscreteTf, params: &ZpetcParams) -> Result<Zpetc, ZpetcError> {
    if !(params.rho > 0.0 && params.rho <= 1.0) {
        return Err(ZpetcError::InvalidParams(format!(
            "rho must lie in (0, 1], got {}",
            params.rho
        )));
    }
    if !(0.0..=1.0).contains(&params.min_damping) {
        return Err(ZpetcError::InvalidParams(format!(
            "min_damping must lie in [0, 1], got {}",
            params.min_damping
        )));
    }
    if let Some(si) = params.stable_inversion
        && !(si.min_radius > 1.0 && si.min_radius.is_finite())
    {
        return Err(ZpetcError::InvalidParams(format!(
            "the stable-inversion radius must exceed 1, got {}",
            si.min_radius
        )));
    }
    if let Some(si) = params.stable_inversion
        && !(si.tolerance > 0.0 && si.tolerance < 1.0)
    {
        return Err(ZpetcError::InvalidParams(format!(
            "the stable-inversion tolerance must lie in (0, 1), got {}",
            si.tolerance
        )));
    }
    check_stable(g)?;
    let zeros = classify_zeros(g, params)?;
    check_cancellations(&zeros, params.rho)?;
    let b0 = g.num().coeffs()[0];
    let a_c = g.den();
    let with_status = |wanted: &dyn Fn(ZeroStatus) -> bool| -> Vec<c64> {
        zeros
            .iter()
            .filter(|z| wanted(z.status))
            .map(|z| z.zero)
            .collect()
    };
    let kept = with_status(&|s| matches!(s, ZeroStatus::OutsideRadius | ZeroStatus::PoorlyDamped));
    let inverted = with_status(&|s| s == ZeroStatus::InvertedBySeries);

    let (num, den) = if kept.is_empty() && inverted.is_empty() {
        // [Li21] Eq. 10: G_z = z^d A_c / B_c, normalised so den[0] = 1.
        (a_c.scale(1.0 / b0), g.num().scale(1.0 / b0))
    } else {
        let cancelled = with_status(&|s| s == ZeroStatus::Cancelled);
        let b_a = Poly::from_z_roots(&cancelled, 1.0);
        let num = if kept.is_empty() {
            a_c.scale(1.0 / b0)
        } else {
            // [Li21] Eq. 8: A_c B_u^* / B_u(1)^2, with b0 carried by B_u.
            let b_u = Poly::from_z_roots(&kept, b0);
            if kept.iter().any(|&z| at_dc(g.num(), z)) {
                return Err(ZpetcError::ZeroAtDc);
            }
            let b_u_dc = factored_dc(&kept, b0);
            if b_u_dc == 0.0 {
                return Err(ZpetcError::ZeroAtDc);
            }
            a_c.mul(&b_u.reversed()).scale(1.0 / (b_u_dc * b_u_dc))
        };
        (num, b_a)
    };
    let (num, series_terms) = match params.stable_inversion {
        Some(si) if !inverted.is_empty() => {
            let series = series_inverse(&inverted, &si)?;
            let terms = series.coeffs().len() - 1;
            (num.mul(&series), terms)
        }
        _ => (num, 0),
    };
    Ok(Zpetc {
        num,
        den,
        preview: g.delay() + kept.len() + inverted.len() + series_terms,
        series_terms,
        ts: g.ts(),
        zeros,
        params: *params,
    })
}

/// `B_u(1) = b0 prod (1 - z_i)` in factored form: with a hundred zeros near
/// the unit circle the expanded coefficients of `B_u` are many orders above
/// `B_u(1)`, and their sum would be cancellation noise.
fn factored_dc(zeros: &[c64], b0: f64) -> f64 {
    zeros
        .iter()
        .fold(c64::new(b0, 0.0), |p, z| p * (1.0 - z))
        .re
}

/// Whether the computed zero `z` of the numerator `b` (ascending powers of
/// `z^-1`) is indistinguishable from `z = 1`: closer to 1 than ten times
/// its first-order error bound from rounding the coefficients,
/// `eps sum |b_k| |z|^(m-k) / |p'(z)|` with `p(z) = z^m b(z^-1)`
/// (Wilkinson; a multiple zero has `p' = 0` and an infinite bound), or
/// than 1e-12. The zeros decide, not the sum of the expanded coefficients:
/// with a hundred zeros near the unit circle that sum cancels to a tiny
/// fraction of the coefficients' size although no zero is near 1.
fn at_dc(b: &Poly, z: c64) -> bool {
    let distance = (1.0 - z).norm();
    // Horner on p(z) = sum b_k z^(m-k): the value, the derivative and the
    // same sum in absolute values.
    let (mut p, mut dp, mut size) = (c64::new(0.0, 0.0), c64::new(0.0, 0.0), 0.0);
    for &c in b.coeffs() {
        dp = dp * z + p;
        p = p * z + c;
        size = size * z.norm() + c.abs();
    }
    let bound = f64::EPSILON * size / dp.norm();
    !(distance > 1e-12 && distance > 10.0 * bound)
}

/// The causal FIR part `F` of `1/B_o ~= z^(m+N) F(z^-1)` for the zeros `z_i`
/// (all `|z_i| > 1`) of `B_o = prod (1 - z_i z^-1)`; see the module notes.
/// `F(1)` is set to `1/B_o(1)` exactly, so the DC gain is not touched by the
/// truncation.
fn series_inverse(zeros: &[c64], si: &StableInversion) -> Result<Poly, ZpetcError> {
    let m = zeros.len();
    let reciprocals: Vec<c64> = zeros.iter().map(|z| 1.0 / z).collect();
    // Q(w) = prod (1 - w / z_i), ascending powers of w.
    let q = Poly::from_z_roots(&reciprocals, 1.0);
    let q = q.coeffs();
    let decay = zeros.iter().map(|z| z.norm()).fold(f64::INFINITY, f64::min);
    let mut h = vec![1.0];
    let mut l1 = 1.0;
    // Stop once m consecutive terms are negligible: with m roots the sequence
    // can pass near zero between oscillations, a single small term is not
    // enough. The geometric tail beyond term k is below |h_k| r/(1-r),
    // r = 1/min|z_i|.
    let tail_factor = 1.0 / (decay - 1.0);
    let mut small_run = 0;
    while small_run < m.max(1) {
        if h.len() > si.max_terms {
            return Err(ZpetcError::SeriesTooLong {
                min_radius: si.min_radius,
                tolerance: si.tolerance,
                max_terms: si.max_terms,
            });
        }
        let k = h.len();
        // [1/Q] recursion: h_k = -sum_{j=1..min(k,m)} q_j h_{k-j}  (q_0 = 1).
        let next: f64 = -(1..q.len().min(k + 1))
            .map(|j| q[j] * h[k - j])
            .sum::<f64>();
        l1 += next.abs();
        h.push(next);
        if next.abs() * (1.0 + tail_factor) <= si.tolerance * l1 {
            small_run += 1;
        } else {
            small_run = 0;
        }
    }
    let scale: c64 = zeros.iter().fold(c64::new(1.0, 0.0), |acc, z| acc * (-z));
    // F_j = h_{N-j} / P, then exact DC: F(1) = 1 / prod(1 - z_i).
    let mut f: Vec<f64> = h.iter().rev().map(|hk| hk / scale.re).collect();
    let b_o_dc: c64 = zeros
        .iter()
        .fold(c64::new(1.0, 0.0), |acc, z| acc * (1.0 - z));
    let sum: f64 = f.iter().sum();
    let correction = 1.0 / (b_o_dc.re * sum);
    for c in &mut f {
        *c *= correction;
    }
    Ok(Poly::new(f))
}

/// `sum |c_k| / |sum c_k|`: how much larger the coefficients are than the
/// polynomial's value at `z = 1` (infinite when that value is 0).
fn dc_condition(c: &[f64]) -> f64 {
    let size: f64 = c.iter().map(|v| v.abs()).sum();
    size / c.iter().sum::<f64>().abs()
}

impl Zpetc {
    /// Zeros cancelled by the filter.
    pub fn cancelled_zeros(&self) -> impl Iterator<Item = &ClassifiedZero> {
        self.zeros
            .iter()
            .filter(|z| z.status == ZeroStatus::Cancelled)
    }

    /// Zeros left in the loop (the `s` of the preview `d + s`).
    pub fn uncancelled_zeros(&self) -> impl Iterator<Item = &ClassifiedZero> {
        self.zeros.iter().filter(|z| {
            matches!(
                z.status,
                ZeroStatus::OutsideRadius | ZeroStatus::PoorlyDamped
            )
        })
    }

    /// Zeros inverted by the anticausal series.
    pub fn series_inverted_zeros(&self) -> impl Iterator<Item = &ClassifiedZero> {
        self.zeros
            .iter()
            .filter(|z| z.status == ZeroStatus::InvertedBySeries)
    }

    /// The non-causal response `G_z(e^{j omega}) = e^{j omega preview} num/den`.
    pub fn response_at_omega(&self, omega: f64) -> c64 {
        c64::from_polar(1.0, omega * self.preview as f64) * self.num.eval_unit_circle(omega)
            / self.den.eval_unit_circle(omega)
    }

    /// The causal part `num/den` as a running filter; feed it `r(k + preview)`.
    pub fn causal_filter(&self) -> TdfFilter {
        TdfFilter::from_coeffs(self.num.coeffs(), self.den.coeffs(), 0)
    }

    /// Applies the filter to a whole reference, using the preview: the output
    /// at `k` is the causal part driven by `r(k + preview)`; beyond the end the
    /// reference is held at its last value.
    pub fn apply(&self, reference: &[f64]) -> Vec<f64> {
        let mut filter = self.causal_filter();
        let last = reference.last().copied().unwrap_or(0.0);
        (0..reference.len())
            .map(|k| filter.step(*reference.get(k + self.preview).unwrap_or(&last)))
            .collect()
    }

    /// Checks zero phase, unit DC gain and the predicted magnitude of
    /// `G_z G_c` on `points` frequencies from 0 to Nyquist.
    pub fn check(&self, plant: &DiscreteTf, points: usize) -> Result<ZpetcCheck, ZpetcError> {
        let kept: Vec<c64> = self.uncancelled_zeros().map(|z| z.zero).collect();
        let b_u = Poly::from_z_roots(&kept, plant.num().coeffs()[0]);
        let b_u_dc2 = factored_dc(&kept, plant.num().coeffs()[0]).powi(2);
        let omegas = linspace(0.0, PI, points.max(2));
        let products: Vec<(c64, f64)> = omegas
            .iter()
            .map(|&w| {
                let p = self.response_at_omega(w) * plant.response_at_omega(w);
                let expected = b_u.eval_unit_circle(w).norm_sqr() / b_u_dc2;
                (p, expected)
            })
            .collect();
        let (peak_at, scale) =
            products
                .iter()
                .enumerate()
                .fold((0, 0.0f64), |(i, m), (k, (p, _))| {
                    if p.norm() > m || p.norm().is_nan() {
                        (k, p.norm())
                    } else {
                        (i, m)
                    }
                });
        let mut max_phase_error_rad = 0.0f64;
        let mut max_magnitude_error = 0.0f64;
        for (p, expected) in &products {
            if p.norm() > 1e-9 * scale {
                max_phase_error_rad = max_phase_error_rad.max(p.arg().abs());
            }
            max_magnitude_error = max_magnitude_error
                .max((p.norm() - expected).abs() / expected.max(1e-300).max(1e-9 * scale));
        }
        let dc = self.response_at_omega(0.0) * plant.response_at_omega(0.0);
        let filter_stable = self.den.z_roots()?.iter().all(|p| p.norm() < 1.0);
        Ok(ZpetcCheck {
            points: omegas.len(),
            max_phase_error_rad,
            dc_gain: dc.re,
            max_magnitude_error,
            filter_stable,
            max_gain: scale,
            max_gain_hz: omegas[peak_at] / (2.0 * PI * self.ts),
            rounding_bound: f64::EPSILON
                * (dc_condition(self.num.coeffs()) + dc_condition(self.den.coeffs())),
        })
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn li21() -> DiscreteTf {
        DiscreteTf::new(
            vec![4.154, -9.631, 10.23, -5.511, 1.154],
            vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
            5,
            1e-4,
        )
        .unwrap()
    }

    pub fn li21_all_zeros_cancelled_eq10() {
        let z = design(&li21(), &ZpetcParams::default()).unwrap();
        assert_eq!(z.preview, 5);
        assert_eq!(z.uncancelled_zeros().count(), 0);
        // docs/reference-values.md: numerator A_c / 4.154, denominator B_c / 4.154.
        let num = [0.24073, -0.18902, 0.17571, -0.14781, 0.012412, 0.0082980];
        let den = [1.0, -2.31849, 2.46269, -1.32667, 0.277805];
        for (a, b) in z.num.coeffs().iter().zip(num) {
            assert!((a - b).abs() < 5e-6, "{a} vs {b}");
        }
        for (a, b) in z.den.coeffs().iter().zip(den) {
            assert!((a - b).abs() < 5e-6, "{a} vs {b}");
        }
        let check = z.check(&li21(), 2001).unwrap();
        assert!((check.dc_gain - 1.0).abs() < 1e-12);
        assert!(check.max_phase_error_rad < 1e-9);
        assert!(check.filter_stable);
    }

    pub fn unstable_zero_kept_and_phase_zero() {
        // B = (1 - 0.5 z^-1)(1 - 1.5 z^-1): 1.5 cannot be cancelled.
        let g = DiscreteTf::new(vec![1.0, -2.0, 0.75], vec![1.0, -0.3], 2, 1e-3).unwrap();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        assert_eq!(z.preview, 3);
        assert_eq!(z.uncancelled_zeros().count(), 1);
        let check = z.check(&g, 1001).unwrap();
        assert!(check.max_phase_error_rad < 1e-9, "{check:?}");
        assert!((check.dc_gain - 1.0).abs() < 1e-12);
        assert!(check.max_magnitude_error < 1e-9);
    }

    pub fn unstable_closed_loop_refused_with_its_pole() {
        // Pole at 1.5 (and a double pole at 1: marginal is refused too).
        for den in [vec![1.0, -1.5], vec![1.0, -2.0, 1.0]] {
            let g = DiscreteTf::new(vec![1.0, -0.5], den, 1, 1e-3).unwrap();
            match design(&g, &ZpetcParams::default()) {
                Err(ZpetcError::UnstablePlant { magnitude, .. }) => assert!(magnitude >= 1.0),
                other => panic!("{other:?}"),
            }
        }
    }

    pub fn cancelling_a_zero_at_the_unit_circle_is_refused() {
        // Zero at 1 - 1e-12: rho = 1 would cancel it with a filter pole
        // there (DC gain ~1e12); rho below the limit keeps it uncancelled.
        let g = DiscreteTf::new(vec![1.0, -(1.0 - 1e-12)], vec![1.0, -0.5], 1, 1e-3).unwrap();
        let one = ZpetcParams {
            rho: 1.0,
            ..Default::default()
        };
        match design(&g, &one) {
            Err(e @ ZpetcError::CancelsNearUnitCircle { .. }) => {
                let text = e.to_string();
                assert!(text.contains("rho = 1"), "{text}");
                assert!(text.contains("1.0e12"), "{text}");
            }
            other => panic!("{other:?}"),
        }
        // A zero just inside the limit is still cancelled, and the filter
        // gain stays below 1/(1 - MAX_CANCELLED_MAGNITUDE).
        let r = MAX_CANCELLED_MAGNITUDE - 1e-9;
        let g = DiscreteTf::new(vec![1.0, -r], vec![1.0, -0.5], 1, 1e-3).unwrap();
        let z = design(&g, &one).unwrap();
        assert_eq!(z.zeros[0].status, ZeroStatus::Cancelled);
        let dc = z.response_at_omega(0.0).norm();
        assert!(dc < 1.0 / (1.0 - MAX_CANCELLED_MAGNITUDE), "{dc}");
    }

    pub fn near_minus_one_zero_refused() {
        let g = DiscreteTf::new(vec![1.0, 0.8], vec![1.0, -0.5], 1, 1e-3).unwrap();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        assert_eq!(z.zeros[0].status, ZeroStatus::PoorlyDamped);
        let z = design(
            &g,
            &ZpetcParams {
                min_damping: 0.0,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(z.zeros[0].status, ZeroStatus::Cancelled);
    }

    pub fn bad_params_and_dc_zero() {
        let g = li21();
        assert!(matches!(
            design(
                &g,
                &ZpetcParams {
                    rho: 1.5,
                    ..Default::default()
                }
            ),
            Err(ZpetcError::InvalidParams(_))
        ));
        let g = DiscreteTf::new(vec![1.0, -1.0], vec![1.0, -0.5], 1, 1e-3).unwrap();
        assert_eq!(
            design(&g, &ZpetcParams::default()),
            Err(ZpetcError::ZeroAtDc)
        );
    }

    /// A deterministic stream in [0, 1) (Knuth's MMIX linear congruential
    /// generator, top 53 bits).
    fn uniform(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The random order-`n` plant of the size sweep (benches/eig_sweep.py):
    /// a Gaussian numerator of degree n - 1 (Box–Muller), so ~n zeros near
    /// the unit circle, over `1 + a_1 z^-1 + ... + a_n z^-n` with
    /// `sum |a_k| = 0.5` (stable by Rouché).
    fn random_plant(n: usize, seed: u64) -> DiscreteTf {
        let mut state = seed;
        let num: Vec<f64> = (0..n)
            .map(|_| {
                let (u1, u2) = (uniform(&mut state), uniform(&mut state));
                (-2.0 * (1.0 - u1).ln()).sqrt() * (2.0 * PI * u2).cos()
            })
            .collect();
        let a: Vec<f64> = (0..n).map(|_| 2.0 * uniform(&mut state) - 1.0).collect();
        let l1: f64 = a.iter().map(|x| x.abs()).sum();
        let den: Vec<f64> = std::iter::once(1.0)
            .chain(a.iter().map(|x| 0.5 * x / l1))
            .collect();
        DiscreteTf::new(num, den, 1, 1e-4).unwrap()
    }

    pub fn many_zeros_near_the_unit_circle_are_no_zero_at_dc() {
        // Order 144: ~140 uncancelled zeros, none within 1e-3 of z = 1, but
        // the expanded B_u has coefficients near 1e17 whose sum, B_u(1), is
        // a few hundred: the former test (|sum| <= 1e-12 sum |coeffs|)
        // refused it as a zero at z = 1.
        let g = random_plant(144, 1144);
        let params = ZpetcParams::default();
        let zeros = classify_zeros(&g, &params).unwrap();
        let kept: Vec<c64> = zeros
            .iter()
            .filter(|z| {
                matches!(
                    z.status,
                    ZeroStatus::OutsideRadius | ZeroStatus::PoorlyDamped
                )
            })
            .map(|z| z.zero)
            .collect();
        assert!(kept.len() > 130, "{}", kept.len());
        let nearest = kept
            .iter()
            .map(|z| (1.0 - z).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(nearest > 1e-3, "{nearest}");
        let b_u = Poly::from_z_roots(&kept, g.num().coeffs()[0]);
        let size: f64 = b_u.coeffs().iter().map(|c| c.abs()).sum();
        let dc = factored_dc(&kept, g.num().coeffs()[0]);
        assert!(
            dc.abs() <= 1e-12 * size,
            "B_u(1) {dc} against {size}: not the false-refusal case"
        );
        let z = design(&g, &params).unwrap();
        assert_eq!(z.uncancelled_zeros().count(), kept.len());
    }

    pub fn a_true_zero_at_dc_is_still_refused() {
        // The plant above times (1 - z^-1): a simple zero at exactly 1 among
        // 144 others, computed within rounding of 1.
        let g = random_plant(144, 1144);
        let num = g.num().mul(&Poly::new(vec![1.0, -1.0]));
        let g = DiscreteTf::new(num.into_coeffs(), g.den().coeffs().to_vec(), 1, 1e-4).unwrap();
        let e = design(&g, &ZpetcParams::default()).unwrap_err();
        assert_eq!(e, ZpetcError::ZeroAtDc);
        assert!(e.to_string().contains("zero at z = 1"), "{e}");
        // A double zero at 1 (computed about 1e-8 apart, an ill-conditioned
        // pair), and a zero 1e-13 from 1.
        for num in [vec![1.0, -2.0, 1.0], vec![1.0, -(1.0 - 1e-13)]] {
            let g = DiscreteTf::new(num, vec![1.0, -0.5], 1, 1e-3).unwrap();
            assert_eq!(
                design(&g, &ZpetcParams::default()),
                Err(ZpetcError::ZeroAtDc)
            );
        }
        // 1e-6 from 1 is a zero near, not at, DC.
        let g = DiscreteTf::new(vec![1.0, -(1.0 - 1e-6)], vec![1.0, -0.5], 1, 1e-3).unwrap();
        assert!(design(&g, &ZpetcParams::default()).is_ok());
    }

    pub fn apply_tracks_through_plant() {
        // ZPETC followed by the plant reproduces a slow sine almost exactly.
        let g = li21();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        let r: Vec<f64> = (0..4000)
            .map(|k| (2.0 * PI * 50.0 * k as f64 * 1e-4).sin())
            .collect();
        let y = crate::lti::lsim(&g, &z.apply(&r));
        let err = (1000..3900)
            .map(|k| (y[k] - r[k]).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
    }
    fn series_params(min_radius: f64, tolerance: f64) -> ZpetcParams {
        ZpetcParams {
            stable_inversion: Some(StableInversion {
                min_radius,
                tolerance,
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    /// `max |G_z G_c - 1|` over 0..Nyquist.
    fn max_deviation_from_one(z: &Zpetc, g: &DiscreteTf) -> f64 {
        linspace(0.0, PI, 2001)
            .iter()
            .map(|&w| (z.response_at_omega(w) * g.response_at_omega(w) - 1.0).norm())
            .fold(0.0, f64::max)
    }

    pub fn series_inverts_outside_zeros_exactly() {
        // B = 0.4 (1 - 0.5 z^-1)(1 - 2.5 z^-1)(1 - 1.3 e^{+-j0.9} z^-1):
        // a real and a complex pair outside the circle, one zero inside.
        let zeros = [
            c64::new(0.5, 0.0),
            c64::new(2.5, 0.0),
            c64::from_polar(1.3, 0.9),
            c64::from_polar(1.3, -0.9),
        ];
        let num = Poly::from_z_roots(&zeros, 0.4);
        let g = DiscreteTf::new(num.coeffs().to_vec(), vec![1.0, -1.2, 0.5], 3, 1e-4).unwrap();
        for tol in [1e-4, 1e-8, 1e-12] {
            let z = design(&g, &series_params(1.05, tol)).unwrap();
            assert_eq!(z.series_inverted_zeros().count(), 3);
            assert_eq!(z.uncancelled_zeros().count(), 0);
            assert_eq!(z.cancelled_zeros().count(), 1);
            assert_eq!(z.preview, 3 + 3 + z.series_terms);
            // The series decays like 1.3^-k: ln(tol)/ln(1/1.3) terms, a few more
            // for the two-root sequence's oscillation.
            let expected = (tol.ln() / (1.0f64 / 1.3).ln()).ceil() as usize;
            assert!(
                z.series_terms >= expected - 5 && z.series_terms <= expected + 15,
                "{} terms for {tol:e}, expected about {expected}",
                z.series_terms
            );
            // Exact inversion up to the truncation: the product is 1 (no
            // magnitude loss, unlike ZPETC), with DC exactly 1.
            let dev = max_deviation_from_one(&z, &g);
            assert!(dev < 20.0 * tol, "tol {tol:e}: deviation {dev:e}");
            let check = z.check(&g, 2001).unwrap();
            assert!((check.dc_gain - 1.0).abs() < 1e-12, "{check:?}");
            assert!(check.filter_stable);
        }
        // Classical ZPETC on the same plant loses magnitude at high frequency.
        let classical = design(&g, &ZpetcParams::default()).unwrap();
        assert!(max_deviation_from_one(&classical, &g) > 0.5);
    }

    pub fn series_and_zpetc_zeros_together() {
        // 1.01 stays with ZPETC (inside the series radius), 3.0 is inverted:
        // the product is then exactly the ZPETC part |B_u|^2 / B_u(1)^2.
        let zeros = [c64::new(1.01, 0.0), c64::new(3.0, 0.0), c64::new(-0.2, 0.0)];
        let num = Poly::from_z_roots(&zeros, 1.0);
        let g = DiscreteTf::new(num.coeffs().to_vec(), vec![1.0, -0.6], 1, 1e-3).unwrap();
        let z = design(&g, &series_params(1.02, 1e-10)).unwrap();
        assert_eq!(z.uncancelled_zeros().count(), 1);
        assert_eq!(z.series_inverted_zeros().count(), 1);
        let check = z.check(&g, 2001).unwrap();
        assert!(check.max_magnitude_error < 1e-8, "{check:?}");
        assert!(check.max_phase_error_rad < 1e-8, "{check:?}");
        assert!((check.dc_gain - 1.0).abs() < 1e-12);
    }

    pub fn series_tracks_through_a_nonminimum_phase_plant() {
        // The previewed filter followed by the plant reproduces a 2 kHz-rich
        // reference (1 kHz at Ts 1e-4 is where ZPETC's magnitude loss bites).
        let zeros = [c64::new(2.2, 0.0), c64::new(0.6, 0.0)];
        let num = Poly::from_z_roots(&zeros, 1.5);
        let g = DiscreteTf::new(num.coeffs().to_vec(), vec![1.0, -0.9, 0.2], 2, 1e-4).unwrap();
        let z = design(&g, &series_params(1.02, 1e-10)).unwrap();
        let r: Vec<f64> = (0..6000)
            .map(|k| {
                let t = k as f64 * 1e-4;
                (2.0 * PI * 300.0 * t).sin() + 0.5 * (2.0 * PI * 1000.0 * t).cos()
            })
            .collect();
        let y = crate::lti::lsim(&g, &z.apply(&r));
        // Away from the start-up transient and the end (where the preview
        // runs past the reference).
        let err = (2000..5900)
            .map(|k| (y[k] - r[k]).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-8, "{err}");
    }

    pub fn series_settings_are_checked() {
        let g = DiscreteTf::new(vec![1.0, -2.0], vec![1.0, -0.5], 1, 1e-3).unwrap();
        assert!(matches!(
            design(&g, &series_params(1.0, 1e-6)),
            Err(ZpetcError::InvalidParams(_))
        ));
        assert!(matches!(
            design(&g, &series_params(1.5, 0.0)),
            Err(ZpetcError::InvalidParams(_))
        ));
        // A zero at 1.001 needs ~ln(1e-12)/ln(1/1.001) = 27,600 terms.
        let g = DiscreteTf::new(vec![1.0, -1.001], vec![1.0, -0.5], 1, 1e-3).unwrap();
        let mut p = series_params(1.0005, 1e-12);
        if let Some(si) = p.stable_inversion.as_mut() {
            si.max_terms = 1000;
        }
        assert!(matches!(
            design(&g, &p),
            Err(ZpetcError::SeriesTooLong { .. })
        ));
    }
}

/// The self-check's verdict (docs/formats.md "Exit codes"): each criterion
/// fails on a filter built to break it alone, against the plant `G_c = 1`
/// (so the product is the filter itself).
#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod self_checks {
    use super::*;

    fn unit_plant() -> DiscreteTf {
        DiscreteTf::new(vec![1.0], vec![1.0], 0, 1e-4).unwrap()
    }

    fn filter(num: Vec<f64>, den: Vec<f64>) -> Zpetc {
        Zpetc {
            num: Poly::new(num),
            den: Poly::new(den),
            preview: 0,
            series_terms: 0,
            ts: 1e-4,
            zeros: Vec::new(),
            params: ZpetcParams::default(),
        }
    }

    fn failures(z: &Zpetc) -> Vec<CheckFailure> {
        z.check(&unit_plant(), 2001).unwrap().failures()
    }

    pub fn a_good_filter_passes() {
        assert_eq!(failures(&filter(vec![1.0], vec![1.0])), vec![]);
    }

    pub fn a_dc_gain_off_by_2e_6_fails_and_1e_7_passes() {
        assert_eq!(
            failures(&filter(vec![1.0 + 2e-6], vec![1.0])),
            vec![CheckFailure::DcGain(1.0 + 2e-6)]
        );
        assert_eq!(failures(&filter(vec![1.0 + 1e-7], vec![1.0])), vec![]);
    }

    pub fn an_unstable_filter_fails_though_its_response_is_one() {
        // (1 - 1.25 z^-1)/(1 - 1.25 z^-1): G_z = 1 on the circle, DC
        // exactly 1, but the running filter diverges.
        let z = filter(vec![1.0, -1.25], vec![1.0, -1.25]);
        assert_eq!(failures(&z), vec![CheckFailure::Unstable]);
    }

    pub fn coefficients_too_large_for_their_gain_fail() {
        // (1 - z^-1/2)^21 over itself: exact dyadic coefficients whose
        // partial sums are exact, so the DC gain is exactly 1, but
        // sum |c_k| / |sum c_k| = 1.5^21 / 0.5^21 = 3^21 each:
        // 2 eps 3^21 = 4.6e-6 > 1e-6.
        let p = Poly::from_z_roots(&[c64::new(0.5, 0.0); 21], 1.0);
        let z = filter(p.coeffs().to_vec(), p.coeffs().to_vec());
        let check = z.check(&unit_plant(), 2001).unwrap();
        let expected = 2.0 * f64::EPSILON * 3f64.powi(21);
        assert!((check.rounding_bound / expected - 1.0).abs() < 1e-12);
        assert_eq!(check.dc_gain, 1.0);
        assert_eq!(
            check.failures(),
            vec![CheckFailure::Rounding(check.rounding_bound)]
        );
        // 3^19: 2 eps 3^19 = 5.1e-7 passes.
        let p = Poly::from_z_roots(&[c64::new(0.5, 0.0); 19], 1.0);
        assert_eq!(
            failures(&filter(p.coeffs().to_vec(), p.coeffs().to_vec())),
            vec![]
        );
    }

    pub fn a_kept_zero_near_one_fails_on_gain() {
        // A kept zero at 0.99 (|z| >= rho): |G_z G_c| = |1 - 0.99 e^{-jw}|^2
        // / 0.01^2, (1.99/0.01)^2 = 39601 at Nyquist; at 0.98 it is
        // (1.98/0.02)^2 = 9801, within the limit.
        for (zero, gain) in [(0.99, 39601.0), (0.98, 9801.0)] {
            let g = DiscreteTf::new(vec![1.0, -zero], vec![1.0, -0.5], 1, 1e-4).unwrap();
            let z = design(&g, &ZpetcParams::default()).unwrap();
            let check = z.check(&g, 2001).unwrap();
            assert!((check.max_gain / gain - 1.0).abs() < 1e-9, "{check:?}");
            assert!((check.max_gain_hz - 5000.0).abs() < 1e-9);
            let expected = if gain > MAX_PRODUCT_GAIN {
                vec![CheckFailure::Gain(check.max_gain, check.max_gain_hz)]
            } else {
                vec![]
            };
            assert_eq!(check.failures(), expected);
        }
    }

    pub fn a_pair_at_one_fails_several_ways() {
        // The fitted PID-only loop of issue #27: zero 1 - 1e-7 and pole
        // 1 - 2e-7 in (0.3 + 0.1 z^-1)/(1 - 0.6 z^-1). The kept zero
        // makes B_u(1)^2 = 9e-16: coefficients near 1e15.
        let (zero, pole) = (1.0 - 1e-7, 1.0 - 2e-7);
        let g = DiscreteTf::new(
            vec![0.3, 0.1 - 0.3 * zero, -0.1 * zero],
            vec![1.0, -pole - 0.6, 0.6 * pole],
            1,
            1e-4,
        )
        .unwrap();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        let f = z.check(&g, 2001).unwrap().failures();
        assert!(
            f.iter().any(|f| matches!(f, CheckFailure::Rounding(_))),
            "{f:?}"
        );
        assert!(
            f.iter()
                .any(|f| matches!(f, CheckFailure::Gain(g, _) if *g > 1e14)),
            "{f:?}"
        );
    }
}
