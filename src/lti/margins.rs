//! Analysis of a SISO negative-feedback loop `L = G K` before it runs:
//! gain, phase, delay and modulus margins, the peaks of the four closed-loop
//! transfer functions `S = 1/(1+L)`, `T = L/(1+L)`, `KS`, `GS`, the
//! closed-loop bandwidth, the closed-loop poles and stability.
//!
//! Semantics follow MATLAB `allmargin` / python-control `stability_margins`:
//!
//! * a *phase crossover* is a frequency where `L(jw)` is real and negative
//!   (`0 <= w`, up to Nyquist for discrete loops, both ends included); its
//!   gain margin is `1/|L|`. The reported gain margin is the one closest to
//!   1 in log scale (`min |ln GM|`), none (infinite) without phase crossovers;
//! * a *gain crossover* is a frequency `w > 0` where `|L(jw)| = 1`; its phase
//!   margin is `(angle L mod 360) - 180` degrees, in `[-180, 180)`. The
//!   reported phase margin is the one of smallest magnitude;
//! * the delay margin of a crossover is `(PM mod 360)` in radians over the
//!   crossover's angular frequency, in seconds (and in samples for discrete
//!   loops); the reported one is the smallest over all crossovers;
//! * the modulus margin is `min_w |1 + L|`, i.e. `1 / max |S|`;
//! * the bandwidth is the first frequency where `|T|` falls 3 dB below its
//!   DC value (python-control `bandwidth`).
//!
//! Crossovers are bracketed on a dense logarithmic grid and refined with
//! Brent's root finder to machine precision; peaks are refined with Brent's
//! minimiser in log frequency. Closed-loop stability comes from the
//! closed-loop poles (eigenvalues of the state-space realisation of the
//! loop), never from the margins: with an unstable open loop the margins
//! must be read against the Nyquist criterion, and the report says so.
//!
//! Every frequency in the report is in Hz.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c64;
use super::ss::{SsError, StateSpace};
use super::tf::{DiscreteTf, TransferFunction};
use faer::Mat;
use serde::Serialize;
use std::f64::consts::PI;

/// Why a loop cannot be analysed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LoopError {
    /// The plant or the controller is not single-input single-output.
    #[error("{which} must be SISO, it has {outputs} outputs and {inputs} inputs")]
    NotSiso {
        /// `plant` or `controller`.
        which: &'static str,
        /// Number of outputs.
        outputs: usize,
        /// Number of inputs.
        inputs: usize,
    },
    /// Continuous and discrete, or two different sample times.
    #[error(
        "plant and controller differ in sample time (plant {}, controller {})",
        describe_ts(*plant),
        describe_ts(*controller)
    )]
    SampleTimeMismatch {
        /// Plant sample time, `None` when continuous.
        plant: Option<f64>,
        /// Controller sample time, `None` when continuous.
        controller: Option<f64>,
    },
    /// A setting is out of range.
    #[error("{0}")]
    BadParams(String),
    /// A realisation, interconnection or eigenvalue computation failed
    /// (improper transfer function, `1 + L(inf) = 0`, no convergence).
    #[error("{0}")]
    Ss(#[from] SsError),
}

fn describe_ts(ts: Option<f64>) -> String {
    match ts {
        None => "continuous".into(),
        Some(t) => format!("ts = {t} s"),
    }
}

/// A SISO system as given: a transfer function (evaluated from its
/// coefficients) or a state-space model.
#[derive(Debug, Clone, PartialEq)]
pub enum LoopSystem {
    /// `fts.tf/1`, continuous or discrete.
    Tf(TransferFunction),
    /// `fts.ss/1`, one input and one output.
    Ss(StateSpace),
}

impl LoopSystem {
    /// Sample time in seconds, `None` for continuous systems.
    pub fn ts(&self) -> Option<f64> {
        match self {
            LoopSystem::Tf(TransferFunction::Continuous(_)) => None,
            LoopSystem::Tf(TransferFunction::Discrete(d)) => Some(d.ts()),
            LoopSystem::Ss(s) => s.ts,
        }
    }

    /// Frequency response at `f` Hz (`z = e^{j 2 pi f ts}` when discrete);
    /// non-finite at a pole.
    pub fn response_at_hz(&self, f: f64) -> c64 {
        match self {
            LoopSystem::Tf(t) => t.response_at_hz(f),
            LoopSystem::Ss(s) => s
                .freq_response(2.0 * PI * f)
                .map(|m| m[(0, 0)])
                .unwrap_or(c64::new(f64::INFINITY, 0.0)),
        }
    }

    /// A state-space realisation (controllable canonical form for a
    /// transfer function; a discrete one keeps its delay as states). A
    /// continuous input delay has none: refused ([`SsError::Delayed`]).
    pub fn to_ss(&self) -> Result<StateSpace, SsError> {
        match self {
            LoopSystem::Tf(TransferFunction::Continuous(c)) => StateSpace::from_continuous_tf(c),
            _ => self.rational_ss(),
        }
    }

    /// [`Self::to_ss`] with a continuous delay approximated by
    /// [`StateSpace::delay_approximation`]: for the closed-loop poles only.
    fn to_ss_delay_approximated(&self) -> Result<StateSpace, SsError> {
        let rational = self.rational_ss()?;
        match self.continuous_delay() {
            0.0 => Ok(rational),
            tau => StateSpace::delay_approximation(tau)?.series(&rational),
        }
    }

    /// [`Self::to_ss`] without a continuous delay.
    fn rational_ss(&self) -> Result<StateSpace, SsError> {
        match self {
            LoopSystem::Ss(s) => Ok(s.clone()),
            LoopSystem::Tf(TransferFunction::Continuous(c)) => {
                StateSpace::from_continuous_tf(&c.rational())
            }
            LoopSystem::Tf(TransferFunction::Discrete(d)) => discrete_tf_to_ss(d),
        }
    }

    /// The input delay of a continuous transfer function, s (0 otherwise).
    pub fn continuous_delay(&self) -> f64 {
        match self {
            LoopSystem::Tf(TransferFunction::Continuous(c)) => c.delay(),
            _ => 0.0,
        }
    }

    fn check_siso(&self, which: &'static str) -> Result<(), LoopError> {
        if let LoopSystem::Ss(s) = self
            && (s.nu() != 1 || s.ny() != 1)
        {
            return Err(LoopError::NotSiso {
                which,
                outputs: s.ny(),
                inputs: s.nu(),
            });
        }
        Ok(())
    }
}

/// The most states a discrete transfer function is realised with: `z^-d`
/// becomes `d` states of a dense matrix, and the commands that work on
/// state space (`loop`, `response`, `minreal`, `convert`, `d2c`, `c2d`)
/// take about 1 to 4 s at 200 states (docs/formats.md, Bounds).
pub const MAX_REALISED_STATES: usize = 200;

/// Refuses a delayed discrete transfer function whose realisation would
/// exceed [`MAX_REALISED_STATES`] (before any allocation).
pub fn check_realisable(sys: &LoopSystem) -> Result<(), SsError> {
    let LoopSystem::Tf(TransferFunction::Discrete(d)) = sys else {
        return Ok(());
    };
    let nn = (d.num().coeffs().len() - 1 + d.delay()).max(d.den().coeffs().len() - 1);
    if nn > MAX_REALISED_STATES {
        return Err(SsError::TooManyStates {
            delay: d.delay(),
            states: nn,
            max: MAX_REALISED_STATES,
        });
    }
    Ok(())
}

/// `z^-d b(z^-1)/a(z^-1)` as a state-space model: descending powers of `z`
/// after multiplying by `z^N`. Refused (before any allocation) beyond
/// [`MAX_REALISED_STATES`].
pub fn discrete_tf_to_ss(d: &DiscreteTf) -> Result<StateSpace, SsError> {
    check_realisable(&LoopSystem::Tf(TransferFunction::Discrete(d.clone())))?;
    let (b, a) = (d.num().coeffs(), d.den().coeffs());
    let nn = (b.len() - 1 + d.delay()).max(a.len() - 1);
    let mut num = vec![0.0; nn + 1];
    let mut den = vec![0.0; nn + 1];
    for (i, x) in b.iter().enumerate() {
        num[d.delay() + i] = *x;
    }
    den[..a.len()].copy_from_slice(a);
    StateSpace::from_tf(&num, &den, Some(d.ts()))
}

/// Settings of the analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopParams {
    /// Grid density used to bracket crossovers and peaks (default 200 per
    /// decade). Two crossovers closer than one grid step can be missed.
    pub points_per_decade: usize,
    /// The automatic range spans this many decades below the slowest and
    /// above the fastest pole or zero of `G` and `K` (default 3).
    pub decades_beyond: f64,
    /// Lowest frequency analysed in Hz (default: automatic).
    pub f_min_hz: Option<f64>,
    /// Highest frequency in Hz (default: automatic; a discrete loop always
    /// stops at Nyquist).
    pub f_max_hz: Option<f64>,
}

impl Default for LoopParams {
    fn default() -> Self {
        Self {
            points_per_decade: 200,
            decades_beyond: 3.0,
            f_min_hz: None,
            f_max_hz: None,
        }
    }
}

/// A frequency where `L` is real and negative.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseCrossover {
    /// Frequency in Hz.
    pub freq_hz: f64,
    /// `1/|L|` at that frequency (linear).
    pub gain_margin: f64,
    /// The same in dB.
    pub gain_margin_db: f64,
}

/// A frequency where `|L| = 1`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GainCrossover {
    /// Frequency in Hz.
    pub freq_hz: f64,
    /// `(angle L mod 360) - 180`, degrees in `[-180, 180)`.
    pub phase_margin_deg: f64,
    /// `(PM mod 360)` in radians over `2 pi f`: seconds of extra loop delay
    /// that bring this crossover onto -1.
    pub delay_margin_s: f64,
    /// The delay margin in samples (discrete loops only).
    pub delay_margin_samples: Option<f64>,
}

/// The largest value of a magnitude response and where it occurs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Peak {
    /// Peak magnitude (linear).
    pub value: f64,
    /// The same in dB.
    pub value_db: f64,
    /// Frequency in Hz.
    pub freq_hz: f64,
}

/// How the analysis went, and what to keep in mind when reading it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoopDiagnostics {
    /// Lowest frequency analysed, Hz.
    pub f_min_hz: f64,
    /// Highest frequency analysed, Hz.
    pub f_max_hz: f64,
    /// Grid points used for bracketing.
    pub grid_points: usize,
    /// Number of phase crossovers found.
    pub phase_crossovers: usize,
    /// Number of gain crossovers found.
    pub gain_crossovers: usize,
    /// Open-loop poles (of `G` and `K`) strictly outside the stability region.
    pub open_loop_unstable_poles: usize,
    /// Open-loop poles on its boundary (integrators, undamped modes).
    pub open_loop_boundary_poles: usize,
    /// The loop's features ([`feature_band_hz`]): lowest and highest
    /// pole/zero frequency of `G` and `K`, Hz; `None` when all are at the
    /// origin.
    pub feature_band_hz: Option<(f64, f64)>,
    /// Whether the open loop is unstable: the margins are then distances
    /// on the Nyquist plot, not guarantees by themselves.
    pub open_loop_unstable: bool,
    /// Remarks for the reader.
    pub notes: Vec<String>,
}

/// The loop analysis. Frequencies are in Hz.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoopReport {
    /// Sample time in seconds, `None` for a continuous loop.
    pub ts: Option<f64>,
    /// The worst gain margin (closest to 1 in log scale); `None` = infinite.
    pub gain_margin: Option<PhaseCrossover>,
    /// The worst phase margin (smallest magnitude); `None` = infinite.
    pub phase_margin: Option<GainCrossover>,
    /// The smallest delay margin over all gain crossovers (its crossover);
    /// `None` = infinite.
    pub delay_margin: Option<GainCrossover>,
    /// `min |1 + L|` (the value) and where it occurs; `1 / peak_s.value`.
    pub modulus_margin: Peak,
    /// Peak of `|S| = |1/(1+L)|`.
    pub peak_s: Peak,
    /// Peak of `|T| = |L/(1+L)|`.
    pub peak_t: Peak,
    /// Peak of `|K S|` (reference or noise to control effort).
    pub peak_ks: Peak,
    /// Peak of `|G S|` (input disturbance to output).
    pub peak_gs: Peak,
    /// First frequency (Hz) where `|T|` falls 3 dB below `|T(0)|`; `None`
    /// when it never does in the range or `T(0)` is infinite.
    pub bandwidth_hz: Option<f64>,
    /// Every phase crossover, by frequency.
    pub phase_crossovers: Vec<PhaseCrossover>,
    /// Every gain crossover, by frequency.
    pub gain_crossovers: Vec<GainCrossover>,
    /// Closed-loop poles as `[re, im]`: s-plane in rad/s (continuous), or
    /// z-plane (discrete). The summary adds their natural frequencies in Hz.
    pub closed_loop_poles: Vec<[f64; 2]>,
    /// All closed-loop poles strictly inside the stability region.
    pub closed_loop_stable: bool,
    /// How the analysis went.
    pub diagnostics: LoopDiagnostics,
}

/// Relative tolerance that puts a pole on the stability boundary.
const BOUNDARY_TOL: f64 = 1e-9;

enum Region {
    Stable,
    Boundary,
    Unstable,
}

fn region(p: c64, ts: Option<f64>) -> Region {
    let margin = match ts {
        None => -p.re / p.norm().max(1.0),
        Some(_) => 1.0 - p.norm(),
    };
    if margin > BOUNDARY_TOL {
        Region::Stable
    } else if margin < -BOUNDARY_TOL {
        Region::Unstable
    } else {
        Region::Boundary
    }
}

/// A characteristic frequency (rad/s) of a pole or zero, 0 when at the origin.
fn feature_rad_s(p: c64, ts: Option<f64>) -> f64 {
    match ts {
        None => p.norm(),
        Some(t) => {
            if p.norm() == 0.0 {
                0.0
            } else {
                p.ln().norm() / t
            }
        }
    }
}

/// Brent's root finder on `[a, b]` with `f(a) f(b) <= 0`, to machine precision.
fn brent_root(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, mut fa: f64, mut fb: f64) -> f64 {
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + f64::MIN_POSITIVE;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qa = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qa * (qa - r) - (b - a) * (r - 1.0));
                q = (qa - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol * m.signum() };
        fb = f(b);
    }
    b
}

/// Brent's minimiser of `f` on `[a, b]` (golden section with parabolic
/// steps), absolute tolerance `tol` in `x`.
fn brent_min(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> (f64, f64) {
    let golden = 0.381_966_011_250_105_1;
    let mut x = a + golden * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let xm = 0.5 * (a + b);
        let tol1 = tol + f64::EPSILON.sqrt() * 1e-3 * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden_step = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            if p.abs() < (0.5 * q * e).abs() && p > q * (a - x) && p < q * (b - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                golden_step = false;
            }
        }
        if golden_step {
            e = if x >= xm { a - x } else { b - x };
            d = golden * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

fn db(x: f64) -> f64 {
    20.0 * x.log10()
}

/// The loop `L = G K` under analysis, with everything evaluated from `G`
/// and `K` at each frequency.
struct Loop<'a> {
    g: &'a LoopSystem,
    k: &'a LoopSystem,
}

impl Loop<'_> {
    fn gk(&self, f: f64) -> (c64, c64) {
        (self.g.response_at_hz(f), self.k.response_at_hz(f))
    }
    fn l(&self, f: f64) -> c64 {
        let (g, k) = self.gk(f);
        g * k
    }
}

/// The frequency below `f0` (where `drop(f0) = v0 < 0`) at which `drop`
/// changes sign, searched a decade at a time down to `1e-12 f0`.
fn bandwidth_below(drop: &dyn Fn(f64) -> f64, f0: f64, v0: f64) -> Option<f64> {
    let (mut hi, mut v_hi) = (f0, v0);
    for _ in 0..12 {
        let lo = hi / 10.0;
        let v_lo = drop(lo);
        if v_lo >= 0.0 {
            return Some(brent_root(drop, lo, hi, v_lo, v_hi));
        }
        (hi, v_hi) = (lo, v_lo);
    }
    None
}

/// The loop's features: the smallest and largest non-zero pole/zero
/// frequency of `G` and `K`, Hz (`|s|/2pi`, or `|ln z|/(2pi Ts)`); `None`
/// when every pole and zero is at the origin (or `z = 1`). A delay's
/// approximation is left out: it is no feature of the loop. The default
/// plotting and analysis spans extend from here (python-control's
/// `_default_frequency_range` rule).
pub fn feature_band_hz(g: &LoopSystem, k: &LoopSystem) -> Result<Option<(f64, f64)>, LoopError> {
    let ts = g.ts();
    let (gr, kr) = (g.rational_ss()?, k.rational_ss()?);
    let mut features: Vec<f64> = gr
        .poles()?
        .into_iter()
        .chain(kr.poles()?)
        .map(|p| feature_rad_s(p, ts))
        .collect();
    for s in [&gr, &kr] {
        if s.nx() > 0
            && let Ok(z) = s.zeros()
        {
            features.extend(z.iter().map(|&p| feature_rad_s(p, ts)));
        }
    }
    let features: Vec<f64> = features
        .into_iter()
        .filter(|w| w.is_finite() && *w > 1e-12)
        .collect();
    let lo = features.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = features.iter().copied().fold(0.0, f64::max);
    Ok(lo.is_finite().then(|| (lo / (2.0 * PI), hi / (2.0 * PI))))
}

/// Decades drawn beyond the loop's outermost poles and zeros (as
/// python-control's `_default_frequency_range`).
const PLOT_DECADES_BEYOND: f64 = 1.0;

impl LoopReport {
    /// The default span of the loop's plot: a decade below the smallest
    /// non-zero pole/zero frequency of `G` and `K` to a decade above the largest,
    /// widened to show every crossover the report measures (with a factor 3 of
    /// room), within the analysed range (which stops at Nyquist). The analysis
    /// itself searches wider, for crossovers far from the features.
    pub fn plot_span_hz(&self) -> (f64, f64) {
        let d = &self.diagnostics;
        let Some((lo, hi)) = d.feature_band_hz else {
            return (d.f_min_hz, d.f_max_hz);
        };
        let beyond = 10f64.powf(PLOT_DECADES_BEYOND);
        let (mut lo, mut hi) = (lo / beyond, hi * beyond);
        let crossings = self
            .gain_crossovers
            .iter()
            .map(|c| c.freq_hz)
            .chain(self.phase_crossovers.iter().map(|c| c.freq_hz))
            .chain(self.bandwidth_hz);
        for f in crossings.filter(|f| f.is_finite() && *f > 0.0) {
            lo = lo.min(f / 3.0);
            hi = hi.max(f * 3.0);
        }
        let (lo, hi) = (lo.max(d.f_min_hz), hi.min(d.f_max_hz));
        if lo < hi {
            (lo, hi)
        } else {
            (d.f_min_hz, d.f_max_hz)
        }
    }
}

/// Analyses the negative-feedback loop of plant `g` and controller `k`.
pub fn analyze_loop(
    g: &LoopSystem,
    k: &LoopSystem,
    params: &LoopParams,
) -> Result<LoopReport, LoopError> {
    g.check_siso("plant")?;
    k.check_siso("controller")?;
    let ts = match (g.ts(), k.ts()) {
        (None, None) => None,
        (Some(a), Some(b)) if (a - b).abs() <= 1e-12 * a.max(b) => Some(a),
        (plant, controller) => return Err(LoopError::SampleTimeMismatch { plant, controller }),
    };
    if params.points_per_decade < 10 || params.points_per_decade > 100_000 {
        return Err(LoopError::BadParams(format!(
            "points per decade must be between 10 and 100000, got {}",
            params.points_per_decade
        )));
    }
    if !(params.decades_beyond.is_finite() && params.decades_beyond >= 0.0) {
        return Err(LoopError::BadParams(
            "decades beyond the poles and zeros must be a non-negative number".into(),
        ));
    }
    for (name, v) in [("f_min", params.f_min_hz), ("f_max", params.f_max_hz)] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return Err(LoopError::BadParams(format!(
                "{name} must be a positive number of Hz, got {v}"
            )));
        }
    }

    // Closed loop and open-loop poles from state-space realisations.
    let gs = g.to_ss_delay_approximated()?;
    let ks = k.to_ss_delay_approximated()?;
    let l_ss = ks.series(&gs)?;
    let one = StateSpace::gain(Mat::from_fn(1, 1, |_, _| 1.0), ts);
    let cl = l_ss.feedback(&one)?;
    let cl_poles = cl.poles()?;
    let closed_loop_stable = cl_poles
        .iter()
        .all(|&p| matches!(region(p, ts), Region::Stable));
    let mut ol_poles = gs.poles()?;
    ol_poles.extend(ks.poles()?);
    let mut unstable = 0;
    let mut boundary = 0;
    for &p in &ol_poles {
        match region(p, ts) {
            Region::Unstable => unstable += 1,
            Region::Boundary => boundary += 1,
            Region::Stable => {}
        }
    }

    let features = feature_band_hz(g, k)?;
    let (lo_feature, hi_feature) = features.unwrap_or((1.0, 1.0));
    let span = 10f64.powf(params.decades_beyond);
    let nyquist = ts.map(|t| 0.5 / t);
    let lp = Loop { g, k };
    let mut f_lo = params.f_min_hz.unwrap_or(lo_feature / span);
    let mut f_hi = params.f_max_hz.unwrap_or(hi_feature * span);
    if params.f_max_hz.is_none() {
        // Continue upwards while the loop gain is still above 1.
        for _ in 0..12 {
            if nyquist.is_some_and(|n| f_hi >= n) || !(lp.l(f_hi).norm() >= 1.0) {
                break;
            }
            f_hi *= 10.0;
        }
    }
    if params.f_min_hz.is_none() {
        // Continue downwards while the loop gain is below 1 and still moving.
        for _ in 0..6 {
            let (a, b) = (lp.l(f_lo).norm(), lp.l(f_lo / 10.0).norm());
            if !(a < 1.0) || (a - b).abs() <= 1e-3 * a {
                break;
            }
            f_lo /= 10.0;
        }
    }
    if let Some(n) = nyquist {
        f_hi = f_hi.min(n);
        f_lo = f_lo.min(n * 1e-6);
    }
    if !(f_lo < f_hi) {
        return Err(LoopError::BadParams(format!(
            "the frequency range is empty: {f_lo} Hz to {f_hi} Hz"
        )));
    }
    let decades = (f_hi / f_lo).log10();
    let n = ((decades * params.points_per_decade as f64).ceil() as usize).max(2) + 1;
    let mut grid = super::tf::logspace(f_lo, f_hi, n);
    *grid.last_mut().expect("grid") = f_hi;
    let lv: Vec<c64> = grid.iter().map(|&f| lp.l(f)).collect();
    let mut notes = Vec::new();
    let delay = g.continuous_delay() + k.continuous_delay();
    if delay > 0.0 {
        notes.push(format!(
            "the loop holds an input delay of {delay} s: margins, peaks and bandwidth use it exactly (e^(-j w tau)); the closed-loop poles and stability are those of the delay approximated by {} all-pass sections (phase error about (w tau)^3/{} rad)",
            StateSpace::DELAY_SECTIONS,
            12 * StateSpace::DELAY_SECTIONS * StateSpace::DELAY_SECTIONS
        ));
    }

    // Phase crossovers: Im L changes sign where Re L < 0; plus w = 0 and Nyquist.
    let mut pcs: Vec<f64> = Vec::new();
    // An open-loop pole at DC (integrator) makes L(0) infinite, whatever
    // rounding leaves of it.
    let dc_pole = ol_poles.iter().any(|&p| match ts {
        None => p.norm() <= 1e-9 * hi_feature.max(1.0),
        Some(_) => (p - 1.0).norm() <= 1e-9,
    });
    let l0 = if dc_pole {
        c64::new(f64::INFINITY, 0.0)
    } else {
        lp.l(0.0)
    };
    if l0.re.is_finite() && l0.re < 0.0 && l0.im.abs() <= 1e-12 * l0.norm() {
        pcs.push(0.0);
    }
    let sin_arg = |f: f64| {
        let v = lp.l(f);
        v.im / v.norm()
    };
    for i in 0..grid.len() - 1 {
        let (a, b) = (lv[i], lv[i + 1]);
        let (sa, sb) = (a.im / a.norm(), b.im / b.norm());
        if !(sa.is_finite() && sb.is_finite()) || (sa > 0.0) == (sb > 0.0) && sa != 0.0 {
            continue;
        }
        if !(a.re < 0.0 || b.re < 0.0) {
            continue;
        }
        let f = brent_root(&sin_arg, grid[i], grid[i + 1], sa, sb);
        if lp.l(f).re < 0.0 {
            pcs.push(f);
        }
    }
    if let Some(nq) = nyquist
        && f_hi == nq
    {
        let v = lp.l(nq);
        if v.re < 0.0 {
            pcs.push(nq);
        }
    }
    pcs.sort_by(f64::total_cmp);
    pcs.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * a.abs().max(b.abs()));
    let phase_crossovers: Vec<PhaseCrossover> = pcs
        .iter()
        .map(|&f| {
            let gm = 1.0 / lp.l(f).norm();
            PhaseCrossover {
                freq_hz: f,
                gain_margin: gm,
                gain_margin_db: db(gm),
            }
        })
        .collect();

    // Gain crossovers: ln |L| changes sign.
    let ln_mag = |f: f64| lp.l(f).norm().ln();
    let mut gcs: Vec<f64> = Vec::new();
    for i in 0..grid.len() - 1 {
        let (a, b) = (lv[i].norm().ln(), lv[i + 1].norm().ln());
        if !(a.is_finite() && b.is_finite()) || (a > 0.0) == (b > 0.0) && a != 0.0 {
            continue;
        }
        gcs.push(brent_root(&ln_mag, grid[i], grid[i + 1], a, b));
    }
    gcs.sort_by(f64::total_cmp);
    gcs.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * a.abs().max(b.abs()));
    let gain_crossovers: Vec<GainCrossover> = gcs
        .iter()
        .map(|&f| {
            let pm = lp.l(f).arg().to_degrees().rem_euclid(360.0) - 180.0;
            let dm = pm.rem_euclid(360.0).to_radians() / (2.0 * PI * f);
            GainCrossover {
                freq_hz: f,
                phase_margin_deg: pm,
                delay_margin_s: dm,
                delay_margin_samples: ts.map(|t| dm / t),
            }
        })
        .collect();

    let gain_margin = phase_crossovers
        .iter()
        .filter(|p| p.gain_margin.is_finite())
        .min_by(|a, b| {
            a.gain_margin
                .ln()
                .abs()
                .total_cmp(&b.gain_margin.ln().abs())
        })
        .copied();
    let phase_margin = gain_crossovers
        .iter()
        .min_by(|a, b| {
            a.phase_margin_deg
                .abs()
                .total_cmp(&b.phase_margin_deg.abs())
        })
        .copied();
    let delay_margin = gain_crossovers
        .iter()
        .min_by(|a, b| a.delay_margin_s.total_cmp(&b.delay_margin_s))
        .copied();

    // Peaks of S, T, KS, GS.
    let s_of = |f: f64| {
        let (g, k) = lp.gk(f);
        (1.0 / (1.0 + g * k)).norm()
    };
    let t_of = |f: f64| {
        let (g, k) = lp.gk(f);
        (g * k / (1.0 + g * k)).norm()
    };
    let ks_of = |f: f64| {
        let (g, k) = lp.gk(f);
        (k / (1.0 + g * k)).norm()
    };
    let gs_of = |f: f64| {
        let (g, k) = lp.gk(f);
        (g / (1.0 + g * k)).norm()
    };
    // DC competes too: evaluated at 0 Hz when the loop is finite there,
    // else as the limit (a millionth of the lowest grid frequency).
    let f_dc = if dc_pole { f_lo * 1e-6 } else { 0.0 };
    let peak_s = peak(&s_of, &grid, f_dc);
    let peak_t = peak(&t_of, &grid, f_dc);
    let peak_ks = peak(&ks_of, &grid, f_dc);
    let peak_gs = peak(&gs_of, &grid, f_dc);
    let mm = 1.0 / peak_s.value;
    let modulus_margin = Peak {
        value: mm,
        value_db: db(mm),
        freq_hz: peak_s.freq_hz,
    };

    // Bandwidth: T(0), with T(0) = 1 for an infinite loop gain at DC.
    let t0 = if l0.norm().is_finite() {
        (l0 / (1.0 + l0)).norm()
    } else {
        1.0
    };
    let bandwidth_hz = if t0.is_finite() {
        let level = t0 * 10f64.powf(-3.0 / 20.0);
        let drop = |f: f64| t_of(f) - level;
        let tv: Vec<f64> = grid.iter().map(|&f| drop(f)).collect();
        match tv.iter().position(|&v| v < 0.0) {
            None => {
                notes.push(format!(
                    "|T| stays within 3 dB of its DC value up to {f_hi:.6e} Hz: no bandwidth"
                ));
                None
            }
            // Already 3 dB down at the lowest analysed frequency: the
            // crossing lies below the range, so look for it there, a decade
            // at a time, rather than report the range's edge.
            Some(0) => {
                let crossing = bandwidth_below(&drop, grid[0], tv[0]);
                if crossing.is_none() {
                    notes.push(format!(
                        "|T| is 3 dB below its DC value already at {:.6e} Hz and no crossing was found down to 1e-12 of it: no bandwidth",
                        grid[0]
                    ));
                }
                crossing
            }
            Some(i) => Some(brent_root(&drop, grid[i - 1], grid[i], tv[i - 1], tv[i])),
        }
    } else {
        notes.push("T has an infinite DC gain: no bandwidth".into());
        None
    };

    let open_loop_unstable = unstable > 0;
    if open_loop_unstable {
        notes.push(format!(
            "the open loop has {unstable} unstable pole(s): read the margins with the Nyquist criterion (the closed loop is stable only with {unstable} counter-clockwise encirclement(s) of -1); stability is judged from the closed-loop poles"
        ));
    }
    if !closed_loop_stable {
        notes.push(
            "the closed loop is NOT stable: the margins do not describe a working loop".into(),
        );
    }
    if phase_crossovers.is_empty() {
        notes.push("no phase crossover: the gain margin is infinite".into());
    }
    if gain_crossovers.is_empty() {
        notes.push("no gain crossover: the phase and delay margins are infinite".into());
    }

    Ok(LoopReport {
        ts,
        gain_margin,
        phase_margin,
        delay_margin,
        modulus_margin,
        peak_s,
        peak_t,
        peak_ks,
        peak_gs,
        bandwidth_hz,
        diagnostics: LoopDiagnostics {
            f_min_hz: f_lo,
            f_max_hz: f_hi,
            grid_points: grid.len(),
            phase_crossovers: phase_crossovers.len(),
            gain_crossovers: gain_crossovers.len(),
            open_loop_unstable_poles: unstable,
            open_loop_boundary_poles: boundary,
            feature_band_hz: features,
            open_loop_unstable,
            notes,
        },
        phase_crossovers,
        gain_crossovers,
        closed_loop_poles: cl_poles.iter().map(|p| [p.re, p.im]).collect(),
        closed_loop_stable,
    })
}

/// The largest value of `h` on the grid, refined around the best few local
/// maxima by Brent's minimiser in log frequency. The DC value `h(f_dc)`
/// competes as frequency 0.
fn peak(h: &dyn Fn(f64) -> f64, grid: &[f64], f_dc: f64) -> Peak {
    let v: Vec<f64> = grid.iter().map(|&f| h(f)).collect();
    let n = v.len();
    let mut cands: Vec<usize> = (0..n)
        .filter(|&i| {
            v[i].is_finite() && (i == 0 || v[i] >= v[i - 1]) && (i + 1 == n || v[i] >= v[i + 1])
        })
        .collect();
    cands.sort_by(|&a, &b| v[b].total_cmp(&v[a]));
    cands.truncate(4);
    let mut best = (f64::NAN, f64::NEG_INFINITY);
    let v0 = h(f_dc);
    if v0.is_finite() && v0 >= v[0] {
        best = (0.0, v0);
    }
    for i in cands {
        let (mut f, mut val) = (grid[i], v[i]);
        if i > 0 && i + 1 < n {
            let neg = |x: f64| -h(x.exp());
            let (x, fx) = brent_min(&neg, grid[i - 1].ln(), grid[i + 1].ln(), 1e-12);
            if -fx > val {
                (f, val) = (x.exp(), -fx);
            }
        }
        if val > best.1 {
            best = (f, val);
        }
    }
    Peak {
        value: best.1,
        value_db: db(best.1),
        freq_hz: best.0,
    }
}

impl std::fmt::Display for LoopReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.ts {
            None => writeln!(f, "loop L = G K (continuous, negative feedback)")?,
            Some(t) => writeln!(
                f,
                "loop L = G K (discrete, ts = {t} s, Nyquist {:.6} Hz, negative feedback)",
                0.5 / t
            )?,
        }
        match &self.gain_margin {
            Some(g) => writeln!(
                f,
                "gain margin:     {:.6} ({:+.3} dB) at {:.6} Hz",
                g.gain_margin, g.gain_margin_db, g.freq_hz
            )?,
            None => writeln!(f, "gain margin:     infinite (no phase crossover)")?,
        }
        match &self.phase_margin {
            Some(p) => writeln!(
                f,
                "phase margin:    {:.4} deg at {:.6} Hz",
                p.phase_margin_deg, p.freq_hz
            )?,
            None => writeln!(f, "phase margin:    infinite (no gain crossover)")?,
        }
        match &self.delay_margin {
            Some(d) => {
                write!(
                    f,
                    "delay margin:    {:.6e} s at {:.6} Hz",
                    d.delay_margin_s, d.freq_hz
                )?;
                match d.delay_margin_samples {
                    Some(n) => writeln!(f, " ({n:.4} samples)")?,
                    None => writeln!(f)?,
                }
            }
            None => writeln!(f, "delay margin:    infinite")?,
        }
        writeln!(
            f,
            "modulus margin:  {:.6} (min |1+L|) at {:.6} Hz",
            self.modulus_margin.value, self.modulus_margin.freq_hz
        )?;
        for (name, p) in [
            ("peak |S|:", &self.peak_s),
            ("peak |T|:", &self.peak_t),
            ("peak |KS|:", &self.peak_ks),
            ("peak |GS|:", &self.peak_gs),
        ] {
            writeln!(
                f,
                "{name:<17}{:.6} ({:+.3} dB) at {:.6} Hz",
                p.value, p.value_db, p.freq_hz
            )?;
        }
        match self.bandwidth_hz {
            Some(b) => writeln!(f, "bandwidth:       {b:.6} Hz (|T| -3 dB)")?,
            None => writeln!(f, "bandwidth:       none")?,
        }
        writeln!(
            f,
            "crossovers:      {} gain, {} phase",
            self.gain_crossovers.len(),
            self.phase_crossovers.len()
        )?;
        for g in &self.gain_crossovers {
            writeln!(
                f,
                "  |L| = 1   at {:.6} Hz: PM {:.4} deg, delay margin {:.6e} s",
                g.freq_hz, g.phase_margin_deg, g.delay_margin_s
            )?;
        }
        for p in &self.phase_crossovers {
            writeln!(
                f,
                "  L < 0 real at {:.6} Hz: GM {:.6} ({:+.3} dB)",
                p.freq_hz, p.gain_margin, p.gain_margin_db
            )?;
        }
        writeln!(
            f,
            "closed loop:     {} ({} poles, {})",
            if self.closed_loop_stable {
                "stable"
            } else {
                "NOT stable"
            },
            self.closed_loop_poles.len(),
            if self.ts.is_some() {
                "z-plane"
            } else {
                "s-plane in rad/s"
            }
        )?;
        // Each real pole and each upper-half-plane pole of a complex pair,
        // slowest first, with its natural frequency (Hz) and damping ratio
        // (of the s-plane equivalent ln(z)/ts when discrete).
        let mut shown: Vec<(f64, f64, c64)> = self
            .closed_loop_poles
            .iter()
            .map(|p| c64::new(p[0], p[1]))
            .filter(|p| p.im >= 0.0)
            .map(|p| {
                let s = match self.ts {
                    None => p,
                    Some(t) if p.norm() > 0.0 => p.ln() / t,
                    Some(_) => c64::new(f64::NEG_INFINITY, 0.0),
                };
                let wn = s.norm();
                (wn / (2.0 * PI), -s.re / wn, p)
            })
            .collect();
        shown.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (fn_hz, zeta, p) in shown {
            let pole = if p.im == 0.0 {
                format!("{:.6e}", p.re)
            } else {
                format!("{:.6e} +/- {:.6e}j", p.re, p.im)
            };
            if fn_hz.is_finite() {
                writeln!(f, "  pole {pole}: f_n {fn_hz:.6} Hz, zeta {zeta:.4}")?;
            } else {
                writeln!(f, "  pole {pole} (z-plane origin: a pure delay)")?;
            }
        }
        for n in &self.diagnostics.notes {
            writeln!(f, "note: {n}")?;
        }
        Ok(())
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::ContinuousTf;

    fn ct(num: &[f64], den: &[f64]) -> LoopSystem {
        LoopSystem::Tf(TransferFunction::Continuous(
            ContinuousTf::new(num.to_vec(), den.to_vec()).unwrap(),
        ))
    }

    pub fn integrator_with_lag() {
        // L = 1/(s (s+1)): |L| = 1 at w^4 + w^2 - 1 = 0, PM = 90 - atan(w).
        let g = ct(&[1.0], &[1.0, 1.0, 0.0]);
        let k = ct(&[1.0], &[1.0]);
        let r = analyze_loop(&g, &k, &LoopParams::default()).unwrap();
        let w = ((5f64.sqrt() - 1.0) / 2.0).sqrt();
        let pm = r.phase_margin.unwrap();
        assert!((pm.freq_hz * 2.0 * PI - w).abs() < 1e-12 * w);
        assert!((pm.phase_margin_deg - (90.0 - w.atan().to_degrees())).abs() < 1e-10);
        assert!(r.gain_margin.is_none());
        assert!(r.closed_loop_stable);
        assert_eq!(r.diagnostics.open_loop_boundary_poles, 1);
    }

    pub fn a_bandwidth_below_the_analysed_range_is_found_not_clamped() {
        // T = 1/(s + 2): |T| = 0.5 / 10^(3/20) at w = 2 sqrt(10^0.3 - 1).
        let g = ct(&[1.0], &[1.0, 1.0]);
        let k = ct(&[1.0], &[1.0]);
        let expected = 2.0 * (10f64.powf(0.3) - 1.0).sqrt() / (2.0 * PI);
        for f_min in [None, Some(10.0)] {
            let params = LoopParams {
                f_min_hz: f_min,
                f_max_hz: Some(1e3),
                ..LoopParams::default()
            };
            let r = analyze_loop(&g, &k, &params).unwrap();
            let b = r.bandwidth_hz.unwrap();
            assert!((b - expected).abs() < 1e-9 * expected, "{f_min:?}: {b}");
        }
    }

    pub fn mismatched_sample_times_are_refused() {
        let g = ct(&[1.0], &[1.0, 1.0]);
        let k = LoopSystem::Tf(TransferFunction::Discrete(
            DiscreteTf::new(vec![1.0], vec![1.0], 0, 1e-3).unwrap(),
        ));
        assert!(matches!(
            analyze_loop(&g, &k, &LoopParams::default()),
            Err(LoopError::SampleTimeMismatch { .. })
        ));
    }
}
