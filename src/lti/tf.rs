//! Transfer functions: discrete `z^-d B(z^-1)/A(z^-1)` with sample time, and
//! continuous `N(s)/D(s)` in descending powers of `s` (MATLAB order).

use super::poly::Poly;
use super::roots::{RootsError, roots_descending};
use crate::lti::c64;
use std::f64::consts::PI;

/// Why a transfer function is not well formed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TfError {
    /// The denominator is identically zero, or its constant term (`a0`,
    /// discrete) / leading coefficient (continuous) is zero.
    #[error("{0}")]
    BadDenominator(String),
    /// A coefficient is NaN or infinite.
    #[error("{which} coefficient {index} is not finite")]
    NonFinite {
        /// `num` or `den`.
        which: &'static str,
        /// Position of the coefficient.
        index: usize,
    },
    /// The sample time is not a positive finite number.
    #[error("sample time must be a positive number of seconds, got {0}")]
    BadSampleTime(f64),
    /// The numerator is identically zero.
    #[error("numerator is identically zero")]
    ZeroNumerator,
    /// A continuous input delay is not a finite number of seconds >= 0.
    #[error("an input delay must be a finite number of seconds >= 0, got {0}")]
    BadDelay(f64),
    /// An operation that would need a rational model met an input delay.
    #[error("{0}")]
    Delayed(String),
}

fn check_finite(which: &'static str, c: &[f64]) -> Result<(), TfError> {
    match c.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(TfError::NonFinite { which, index }),
        None => Ok(()),
    }
}

/// A discrete SISO transfer function `G(z) = z^-delay num(z^-1) / den(z^-1)`.
///
/// Invariants (enforced by [`DiscreteTf::new`]): `den[0] != 0`, `num[0] != 0`
/// unless the numerator is zero (leading zeros of `num` are moved into
/// `delay`), all coefficients finite, `ts > 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiscreteTf {
    num: Poly,
    den: Poly,
    delay: usize,
    ts: f64,
}

/// The result of [`DiscreteTf::minreal`].
#[derive(Debug, Clone, PartialEq)]
pub struct Minreal {
    /// The reduced transfer function.
    pub tf: DiscreteTf,
    /// The removed `(zero, pole)` pairs (one entry per conjugate pair, upper
    /// half plane).
    pub removed: Vec<(c64, c64)>,
}

impl DiscreteTf {
    /// Builds and validates. Trailing exact zeros are trimmed from both
    /// polynomials; leading zeros of the numerator become delay.
    pub fn new(num: Vec<f64>, den: Vec<f64>, delay: usize, ts: f64) -> Result<Self, TfError> {
        check_finite("num", &num)?;
        check_finite("den", &den)?;
        if !(ts.is_finite() && ts > 0.0) {
            return Err(TfError::BadSampleTime(ts));
        }
        let den = Poly::new(den).trimmed(0.0);
        if den.coeffs()[0] == 0.0 {
            return Err(TfError::BadDenominator(
                "den[0] (the z^0 coefficient) must be non-zero: a denominator starting with z^-1 is not causal".into(),
            ));
        }
        let num = Poly::new(num).trimmed(0.0);
        if num.is_zero() {
            return Err(TfError::ZeroNumerator);
        }
        let lead = num.leading_zeros();
        let num = Poly::new(num.coeffs()[lead..].to_vec());
        Ok(Self {
            num,
            den,
            delay: delay + lead,
            ts,
        })
    }

    /// Numerator `B(z^-1)`, ascending powers.
    pub fn num(&self) -> &Poly {
        &self.num
    }

    /// Denominator `A(z^-1)`, ascending powers.
    pub fn den(&self) -> &Poly {
        &self.den
    }

    /// Pure delay in samples.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// Sample time in seconds.
    pub fn ts(&self) -> f64 {
        self.ts
    }

    /// Nyquist frequency in Hz.
    pub fn nyquist_hz(&self) -> f64 {
        0.5 / self.ts
    }

    /// `G(e^{j omega})` at normalised angular frequency `omega` (rad/sample).
    pub fn response_at_omega(&self, omega: f64) -> c64 {
        let delay = c64::from_polar(1.0, -omega * self.delay as f64);
        delay * self.num.eval_unit_circle(omega) / self.den.eval_unit_circle(omega)
    }

    /// `G(e^{j 2 pi f ts})` at `f` Hz.
    pub fn response_at_hz(&self, f: f64) -> c64 {
        self.response_at_omega(2.0 * PI * f * self.ts)
    }

    /// Steady-state gain `B(1)/A(1)`; infinite when `A(1) = 0` (integrator).
    pub fn dc_gain(&self) -> f64 {
        let a = self.den.sum();
        if a == 0.0 {
            f64::INFINITY * self.num.sum().signum()
        } else {
            self.num.sum() / a
        }
    }

    /// Zeros in the z-plane (roots of `B`); the delay's poles at the origin
    /// and degree-difference poles/zeros at the origin are not listed.
    pub fn zeros(&self) -> Result<Vec<c64>, RootsError> {
        self.num.z_roots()
    }

    /// Poles in the z-plane (roots of `A`).
    pub fn poles(&self) -> Result<Vec<c64>, RootsError> {
        self.den.z_roots()
    }

    /// All poles strictly inside the unit circle, decided exactly on the
    /// stored coefficients (Schur–Cohn, [`super::stability`]); computed
    /// root moduli only beyond its degree limit. Clustered poles make the
    /// computed moduli unreliable (`eps^(1/k)` for a `k`-fold pole).
    pub fn is_stable(&self) -> Result<bool, RootsError> {
        Ok(self.stability()?.stable)
    }

    /// The stability verdict and the test that gave it: exact or certified
    /// on the stored denominator ([`super::stability::schur_verdict`]), or,
    /// when that is too close to call, the computed poles' moduli.
    pub fn stability(&self) -> Result<super::stability::Verdict, RootsError> {
        if let Some(verdict) = super::stability::schur_verdict(self.den.coeffs()) {
            return Ok(verdict);
        }
        Ok(super::stability::Verdict {
            stable: self.poles()?.iter().all(|p| p.norm() < 1.0),
            test: super::stability::StabilityTest::ComputedRoots,
        })
    }

    /// Removes near pole-zero cancellations, as MATLAB's `minreal` does for
    /// transfer functions, with a tolerance that means something on the unit
    /// circle: a pair `(z, p)` goes when the factor `(1 - z e^{-jw}) / (1 - p
    /// e^{-jw})` it contributes stays within `tol` of 1 at every frequency,
    /// i.e. `|z - p| <= tol |1 - |p||`. Such pairs in identified models are
    /// mostly the fit absorbing noise or a weak nonlinearity; left in, a
    /// ZPETC treats the zero on its own (and, near the unit circle, refuses
    /// to cancel it) although the pole next to it already does. Pairs are
    /// matched greedily, closest first, conjugates together; the DC gain and
    /// the delay are kept.
    pub fn minreal(&self, tol: f64) -> Result<Minreal, RootsError> {
        let mut zeros = self.zeros()?;
        let mut poles = self.poles()?;
        let mut removed = Vec::new();
        loop {
            let mut best: Option<(usize, usize, f64)> = None;
            for (i, z) in zeros.iter().enumerate() {
                if z.im < 0.0 {
                    continue;
                }
                for (j, p) in poles.iter().enumerate() {
                    let margin = (1.0 - p.norm()).abs();
                    let distance = (z - p).norm();
                    // A real zero pairs with a real pole, a complex one with
                    // a complex one (conjugates then go together).
                    if (z.im == 0.0) != (p.im == 0.0) || distance > tol * margin {
                        continue;
                    }
                    let rel = distance / margin.max(f64::MIN_POSITIVE);
                    if best.is_none_or(|(_, _, r)| rel < r) {
                        best = Some((i, j, rel));
                    }
                }
            }
            let Some((i, j, _)) = best else { break };
            let (z, p) = (zeros[i], poles[j]);
            removed.push((z, p));
            zeros.swap_remove(i);
            poles.swap_remove(j);
            if z.im > 0.0 {
                let conj = |v: &[c64], x: c64| {
                    v.iter()
                        .position(|w| (w - x.conj()).norm() <= 1e-9 * (1.0 + x.norm()))
                };
                if let (Some(zi), Some(pj)) = (conj(&zeros, z), conj(&poles, p)) {
                    zeros.swap_remove(zi);
                    poles.swap_remove(pj);
                }
            }
        }
        if removed.is_empty() {
            return Ok(Minreal {
                tf: self.clone(),
                removed,
            });
        }
        let num = Poly::from_z_roots(&zeros, self.num.coeffs()[0]);
        let den = Poly::from_z_roots(&poles, 1.0);
        let mut tf = DiscreteTf {
            num,
            den,
            delay: self.delay,
            ts: self.ts,
        };
        let (before, after) = (self.dc_gain(), tf.dc_gain());
        if before.is_finite() && after.is_finite() && after != 0.0 {
            tf.num = tf.num.scale(before / after);
        }
        Ok(Minreal { tf, removed })
    }

    /// `self * other` (the sample times must agree; the caller checks).
    pub fn series(&self, other: &DiscreteTf) -> DiscreteTf {
        DiscreteTf {
            num: self.num.mul(&other.num),
            den: self.den.mul(&other.den),
            delay: self.delay + other.delay,
            ts: self.ts,
        }
    }

    /// Negative feedback `G / (1 + G H)` with `self = G` and `h = H`:
    /// `z^-dG BG AH / (AG AH + z^-(dG+dH) BG BH)`.
    pub fn feedback(&self, h: &DiscreteTf) -> DiscreteTf {
        let loop_term = self.num.mul(&h.num).shift(self.delay + h.delay);
        DiscreteTf {
            num: self.num.mul(&h.den),
            den: self.den.mul(&h.den).add(&loop_term),
            delay: self.delay,
            ts: self.ts,
        }
    }
}

/// A continuous SISO transfer function `e^{-s delay} N(s)/D(s)`,
/// coefficients in descending powers of `s`, the input delay in seconds
/// (0 unless set with [`ContinuousTf::with_delay`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousTf {
    num: Vec<f64>,
    den: Vec<f64>,
    delay: f64,
}

fn strip_leading_zeros(c: Vec<f64>) -> Vec<f64> {
    let start = c
        .iter()
        .position(|&x| x != 0.0)
        .unwrap_or(c.len().saturating_sub(1));
    c[start..].to_vec()
}

fn eval_descending(c: &[f64], s: c64) -> c64 {
    c.iter().fold(c64::new(0.0, 0.0), |acc, &x| acc * s + x)
}

impl ContinuousTf {
    /// Builds and validates; leading zeros are removed.
    pub fn new(num: Vec<f64>, den: Vec<f64>) -> Result<Self, TfError> {
        check_finite("num", &num)?;
        check_finite("den", &den)?;
        let den = strip_leading_zeros(den);
        if den.is_empty() || den.iter().all(|&c| c == 0.0) {
            return Err(TfError::BadDenominator(
                "denominator is identically zero".into(),
            ));
        }
        let num = strip_leading_zeros(num);
        if num.is_empty() || num.iter().all(|&c| c == 0.0) {
            return Err(TfError::ZeroNumerator);
        }
        Ok(Self {
            num,
            den,
            delay: 0.0,
        })
    }

    /// The same model behind an input delay of `seconds` (replacing any).
    pub fn with_delay(self, seconds: f64) -> Result<Self, TfError> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(TfError::BadDelay(seconds));
        }
        Ok(Self {
            delay: seconds,
            ..self
        })
    }

    /// Input delay, s.
    pub fn delay(&self) -> f64 {
        self.delay
    }

    /// `N(s)/D(s)` without the delay.
    pub fn rational(&self) -> ContinuousTf {
        Self {
            delay: 0.0,
            ..self.clone()
        }
    }

    /// Numerator, descending powers of `s`.
    pub fn num(&self) -> &[f64] {
        &self.num
    }

    /// Denominator, descending powers of `s`.
    pub fn den(&self) -> &[f64] {
        &self.den
    }

    /// Whether `deg N <= deg D`.
    pub fn is_proper(&self) -> bool {
        self.num.len() <= self.den.len()
    }

    /// `G(j 2 pi f)` at `f` Hz, the delay's `e^{-j 2 pi f delay}` included.
    pub fn response_at_hz(&self, f: f64) -> c64 {
        let w = 2.0 * PI * f;
        let s = c64::new(0.0, w);
        let rational = eval_descending(&self.num, s) / eval_descending(&self.den, s);
        if self.delay == 0.0 {
            rational
        } else {
            rational * c64::from_polar(1.0, -w * self.delay)
        }
    }

    /// `N(0)/D(0)`; infinite for an integrator.
    pub fn dc_gain(&self) -> f64 {
        let n0 = *self.num.last().unwrap_or(&0.0);
        let d0 = *self.den.last().unwrap_or(&0.0);
        if d0 == 0.0 {
            f64::INFINITY * n0.signum()
        } else {
            n0 / d0
        }
    }

    /// Zeros in the s-plane.
    pub fn zeros(&self) -> Result<Vec<c64>, RootsError> {
        roots_descending(&self.num)
    }

    /// Poles in the s-plane.
    pub fn poles(&self) -> Result<Vec<c64>, RootsError> {
        roots_descending(&self.den)
    }

    /// All poles in the open left half plane, decided exactly on the stored
    /// coefficients (Routh, [`super::stability`]); computed roots only
    /// beyond its degree limit.
    pub fn is_stable(&self) -> Result<bool, RootsError> {
        Ok(self.stability()?.stable)
    }

    /// The stability verdict and the test that gave it, as for the
    /// discrete [`DiscreteTf::stability`], in the s-plane.
    pub fn stability(&self) -> Result<super::stability::Verdict, RootsError> {
        if let Some(verdict) = super::stability::hurwitz_verdict(&self.den) {
            return Ok(verdict);
        }
        Ok(super::stability::Verdict {
            stable: self.poles()?.iter().all(|p| p.re < 0.0),
            test: super::stability::StabilityTest::ComputedRoots,
        })
    }

    /// `self * other` (the delays add).
    pub fn series(&self, other: &ContinuousTf) -> ContinuousTf {
        ContinuousTf {
            num: convolve(&self.num, &other.num),
            den: convolve(&self.den, &other.den),
            delay: self.delay + other.delay,
        }
    }

    /// Negative feedback `G / (1 + G H)` = `NG DH / (DG DH + NG NH)`; a loop
    /// with a delay has no rational closed loop and is refused.
    pub fn feedback(&self, h: &ContinuousTf) -> Result<ContinuousTf, TfError> {
        if self.delay != 0.0 || h.delay != 0.0 {
            return Err(TfError::Delayed(
                "a loop with an input delay has no rational closed loop".into(),
            ));
        }
        Ok(ContinuousTf {
            num: convolve(&self.num, &h.den),
            den: add_descending(&convolve(&self.den, &h.den), &convolve(&self.num, &h.num)),
            delay: 0.0,
        })
    }
}

/// Product of two coefficient lists (either power order).
pub(crate) fn convolve(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// Sum of two descending-power coefficient lists (aligned at the constant term).
pub(crate) fn add_descending(a: &[f64], b: &[f64]) -> Vec<f64> {
    let n = a.len().max(b.len());
    let mut out = vec![0.0; n];
    for (i, x) in a.iter().enumerate() {
        out[n - a.len() + i] += x;
    }
    for (i, x) in b.iter().enumerate() {
        out[n - b.len() + i] += x;
    }
    out
}

/// Either kind, as read from an `fts.tf/1` file.
#[derive(Debug, Clone, PartialEq)]
pub enum TransferFunction {
    /// `"var": "z^-1"`.
    Discrete(DiscreteTf),
    /// `"var": "s"`.
    Continuous(ContinuousTf),
}

impl TransferFunction {
    /// Frequency response at `f` Hz.
    pub fn response_at_hz(&self, f: f64) -> c64 {
        match self {
            TransferFunction::Discrete(g) => g.response_at_hz(f),
            TransferFunction::Continuous(g) => g.response_at_hz(f),
        }
    }

    /// Steady-state gain.
    pub fn dc_gain(&self) -> f64 {
        match self {
            TransferFunction::Discrete(g) => g.dc_gain(),
            TransferFunction::Continuous(g) => g.dc_gain(),
        }
    }

    /// Zeros (z-plane or s-plane).
    pub fn zeros(&self) -> Result<Vec<c64>, RootsError> {
        match self {
            TransferFunction::Discrete(g) => g.zeros(),
            TransferFunction::Continuous(g) => g.zeros(),
        }
    }

    /// Poles (z-plane or s-plane).
    pub fn poles(&self) -> Result<Vec<c64>, RootsError> {
        match self {
            TransferFunction::Discrete(g) => g.poles(),
            TransferFunction::Continuous(g) => g.poles(),
        }
    }

    /// Asymptotic stability.
    pub fn is_stable(&self) -> Result<bool, RootsError> {
        match self {
            TransferFunction::Discrete(g) => g.is_stable(),
            TransferFunction::Continuous(g) => g.is_stable(),
        }
    }

    /// Asymptotic stability and the test that decided it.
    pub fn stability(&self) -> Result<super::stability::Verdict, RootsError> {
        match self {
            TransferFunction::Discrete(g) => g.stability(),
            TransferFunction::Continuous(g) => g.stability(),
        }
    }
}

/// A Bode table: frequency (Hz), magnitude (linear and dB) and phase
/// (degrees, unwrapped along the grid so that it is continuous).
#[derive(Debug, Clone, PartialEq)]
pub struct Bode {
    /// Frequencies in Hz.
    pub freq_hz: Vec<f64>,
    /// `|G|`.
    pub magnitude: Vec<f64>,
    /// Phase in degrees, unwrapped.
    pub phase_deg: Vec<f64>,
}

impl Bode {
    /// Evaluates `response` on the grid and unwraps the phase.
    pub fn from_fn(freq_hz: &[f64], response: impl Fn(f64) -> c64) -> Bode {
        let values: Vec<c64> = freq_hz.iter().map(|&f| response(f)).collect();
        let magnitude = values.iter().map(|v| v.norm()).collect();
        let mut phase_deg = Vec::with_capacity(values.len());
        let mut offset = 0.0;
        let mut prev: Option<f64> = None;
        for v in &values {
            let raw = v.arg().to_degrees();
            if let Some(p) = prev {
                let mut d = raw + offset - p;
                while d > 180.0 {
                    offset -= 360.0;
                    d -= 360.0;
                }
                while d < -180.0 {
                    offset += 360.0;
                    d += 360.0;
                }
            }
            let unwrapped = raw + offset;
            phase_deg.push(unwrapped);
            prev = Some(unwrapped);
        }
        Bode {
            freq_hz: freq_hz.to_vec(),
            magnitude,
            phase_deg,
        }
    }

    /// Magnitude in dB.
    pub fn magnitude_db(&self) -> Vec<f64> {
        self.magnitude.iter().map(|m| 20.0 * m.log10()).collect()
    }
}

/// `n` points from `lo` to `hi` inclusive, evenly spaced.
pub fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    match n {
        0 => Vec::new(),
        1 => vec![lo],
        _ => (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}

/// `n` points from `lo` to `hi` inclusive, evenly spaced in log (both > 0).
pub fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    linspace(lo.log10(), hi.log10(), n)
        .into_iter()
        .map(|e| 10f64.powf(e))
        .collect()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn li21() -> DiscreteTf {
        // [Li21] Eq. 11, Ts = 1e-4 s (docs/math.md §2).
        DiscreteTf::new(
            vec![4.154, -9.631, 10.23, -5.511, 1.154],
            vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
            5,
            1e-4,
        )
        .unwrap()
    }

    pub fn validation() {
        assert!(matches!(
            DiscreteTf::new(vec![1.0], vec![0.0, 1.0], 0, 1.0),
            Err(TfError::BadDenominator(_))
        ));
        assert!(matches!(
            DiscreteTf::new(vec![1.0], vec![1.0], 0, 0.0),
            Err(TfError::BadSampleTime(_))
        ));
        assert!(matches!(
            DiscreteTf::new(vec![f64::NAN], vec![1.0], 0, 1.0),
            Err(TfError::NonFinite {
                which: "num",
                index: 0
            })
        ));
        let g = DiscreteTf::new(vec![0.0, 0.0, 2.0], vec![1.0], 1, 1.0).unwrap();
        assert_eq!(g.delay(), 3);
        assert_eq!(g.num().coeffs(), &[2.0]);
    }

    pub fn li21_phase_lag_matches_math_md() {
        // docs/math.md §2: about -15 deg at 100 Hz, -75 at 500 Hz, -145 at 1 kHz.
        let g = li21();
        let grid = linspace(0.0, 1000.0, 1001);
        let bode = Bode::from_fn(&grid, |f| g.response_at_hz(f));
        let at = |f: usize| bode.phase_deg[f];
        assert!((at(100) + 15.0).abs() < 3.0, "{}", at(100));
        assert!((at(500) + 75.0).abs() < 5.0, "{}", at(500));
        assert!((at(1000) + 145.0).abs() < 8.0, "{}", at(1000));
    }

    pub fn feedback_closed_form() {
        // G = 0.5 z^-1 / (1 - 0.5 z^-1), unity feedback:
        // T = 0.5 z^-1 / (1 - 0.5 z^-1 + 0.5 z^-1) = 0.5 z^-1.
        let g = DiscreteTf::new(vec![0.5], vec![1.0, -0.5], 1, 1.0).unwrap();
        let one = DiscreteTf::new(vec![1.0], vec![1.0], 0, 1.0).unwrap();
        let t = g.feedback(&one);
        assert_eq!(t.delay(), 1);
        assert_eq!(t.den().trimmed(1e-15).coeffs(), &[1.0]);
        assert!((t.dc_gain() - 0.5).abs() < 1e-15);
        let s = g.series(&g);
        assert_eq!(s.delay(), 2);
        assert!((s.dc_gain() - 1.0).abs() < 1e-15);
    }

    pub fn continuous_basics() {
        // 1/(s+1): dc 1, pole -1, -45 deg at 1/(2 pi) Hz.
        let g = ContinuousTf::new(vec![1.0], vec![1.0, 1.0]).unwrap();
        assert_eq!(g.dc_gain(), 1.0);
        assert_eq!(g.poles().unwrap(), vec![c64::new(-1.0, 0.0)]);
        let v = g.response_at_hz(1.0 / (2.0 * PI));
        assert!((v.arg().to_degrees() + 45.0).abs() < 1e-12);
        assert!(g.is_stable().unwrap());
        // 1/(s+1) in unity feedback: 1/(s+2).
        let one = ContinuousTf::new(vec![1.0], vec![1.0]).unwrap();
        let t = g.feedback(&one).unwrap();
        assert_eq!(t.num(), &[1.0]);
        assert_eq!(t.den(), &[1.0, 2.0]);
        assert_eq!(g.series(&g).den(), &[1.0, 2.0, 1.0]);
    }

    pub fn a_continuous_delay_turns_the_phase_and_nothing_else() {
        // e^{-s 1e-3}/(s+1) at 100 Hz: the rational phase minus 360 f tau
        // = 36 degrees; same magnitude, poles, zeros and DC gain.
        let g = ContinuousTf::new(vec![1.0], vec![1.0, 1.0]).unwrap();
        let d = g.clone().with_delay(1e-3).unwrap();
        let (a, b) = (g.response_at_hz(100.0), d.response_at_hz(100.0));
        assert!((a.norm() - b.norm()).abs() < 1e-15);
        let turn = (a.arg() - b.arg()).to_degrees().rem_euclid(360.0);
        assert!((turn - 36.0).abs() < 1e-9, "{turn}");
        assert_eq!(
            (d.dc_gain(), d.poles().unwrap()),
            (g.dc_gain(), g.poles().unwrap())
        );
        assert_eq!(d.series(&d).delay(), 2e-3);
        assert!(d.feedback(&g).is_err());
        assert!(g.clone().with_delay(-1.0).is_err() && g.with_delay(f64::NAN).is_err());
    }
    pub fn minreal_removes_near_cancellations_only() {
        // Poles 0.9 e^{+-j0.45} and 0.5; zeros 0.8999 e^{+-j0.4501} (a near
        // cancellation, distance ~1.4e-4 against 1 - |p| = 0.1), 2.5 and -0.3.
        let p = [
            c64::from_polar(0.9, 0.45),
            c64::from_polar(0.9, -0.45),
            c64::new(0.5, 0.0),
        ];
        let z = [
            c64::from_polar(0.8999, 0.4501),
            c64::from_polar(0.8999, -0.4501),
            c64::new(2.5, 0.0),
            c64::new(-0.3, 0.0),
        ];
        let g = DiscreteTf::new(
            Poly::from_z_roots(&z, 1.7).coeffs().to_vec(),
            Poly::from_z_roots(&p, 1.0).coeffs().to_vec(),
            2,
            1e-4,
        )
        .unwrap();
        let m = g.minreal(0.01).unwrap();
        assert_eq!(m.removed.len(), 1);
        assert!((m.removed[0].0 - z[0]).norm() < 1e-9);
        assert!((m.removed[0].1 - p[0]).norm() < 1e-9);
        assert_eq!(m.tf.num().degree(), 2);
        assert_eq!(m.tf.den().degree(), 1);
        assert_eq!(m.tf.delay(), 2);
        assert!((m.tf.dc_gain() - g.dc_gain()).abs() < 1e-12 * g.dc_gain().abs());
        // The response moves by at most the tolerance (relative), everywhere.
        for w in linspace(0.0, PI, 501) {
            let (a, b) = (g.response_at_omega(w), m.tf.response_at_omega(w));
            assert!((a - b).norm() <= 0.01 * a.norm() + 1e-12, "w {w}");
        }
        // A tighter tolerance keeps the pair; nothing else ever pairs.
        assert!(g.minreal(1e-4).unwrap().removed.is_empty());
        assert_eq!(g.minreal(0.5).unwrap().removed.len(), 1);
    }
}
