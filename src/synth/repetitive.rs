//! Plug-in repetitive control (Tomizuka, Tsao & Chew 1989; Inoue et al.
//! 1981), designed on an identified closed-loop model.
//!
//! The compensator `v = R e`, `R(z) = k_r Q(z) z^(m - N) / (1 - Q(z) z^-N)`,
//! adds to the reference of a stable loop `T` (loop reference to output;
//! the runtime block is `fts_runtime::RepetitiveSpec`). With it the loop's
//! characteristic equation is `1 - Q z^-N (1 - k_r z^m T) = 0`, so by the
//! small-gain theorem the loop stays stable and the periodic error
//! converges when
//!
//! `rho = max_w |Q(e^jw) F(e^jw) (1 - k_r e^{jwm} T(e^jw))| < 1`,          (1)
//!
//! `F` the fractional-delay interpolation of a non-integer period (1 for an
//! integer one); `rho` bounds the error's contraction per period and
//! `1 - rho` is the margin reported. At the harmonics of the period the
//! error falls, against the same loop without the compensator, by
//!
//! `|1 - Q F z^-N0| / |1 - Q F z^-N0 (1 - k_r z^m T)|`                      (2)
//!
//! (0 where `Q F z^-N0 = 1` exactly). \[Tang17\] Sec. 5.3 uses this structure
//! with `k_r = 0.5` but prints neither `Q` nor `m`; `Q` here is a
//! Hamming-windowed sinc, symmetric so it has no phase, with unit DC gain.

use crate::lti::{DiscreteTf, c64};
use std::f64::consts::PI;

/// The zero-phase low-pass `Q`.
#[derive(Debug, Clone, PartialEq)]
pub enum QFilter {
    /// Taps `[q_0, q_1, .., q_h]` as given.
    Taps(Vec<f64>),
    /// A Hamming-windowed sinc with cutoff `cutoff_hz` and `half_length`
    /// taps each side, scaled to unit DC gain.
    LowPass {
        /// Cutoff (-6 dB), Hz.
        cutoff_hz: f64,
        /// One-sided taps `h`.
        half_length: usize,
    },
}

impl QFilter {
    /// The taps `[q_0, .., q_h]` at sample time `ts`.
    pub fn taps(&self, ts: f64) -> Vec<f64> {
        match self {
            QFilter::Taps(t) => t.clone(),
            QFilter::LowPass {
                cutoff_hz,
                half_length,
            } => windowed_sinc(cutoff_hz * ts, *half_length),
        }
    }
}

/// Symmetric Hamming-windowed sinc, `fc` in cycles per sample, unit DC gain.
pub fn windowed_sinc(fc: f64, half: usize) -> Vec<f64> {
    let mut q: Vec<f64> = (0..=half)
        .map(|i| {
            let ideal = if i == 0 {
                2.0 * fc
            } else {
                (2.0 * PI * fc * i as f64).sin() / (PI * i as f64)
            };
            let window = 0.54 + 0.46 * (PI * i as f64 / (half as f64 + 1.0)).cos();
            ideal * window
        })
        .collect();
    let dc = q[0] + 2.0 * q[1..].iter().sum::<f64>();
    for v in &mut q {
        *v /= dc;
    }
    q
}

/// `Q(e^jw) = q_0 + 2 sum_i q_i cos(i w)`, real.
pub fn q_response(q: &[f64], omega: f64) -> f64 {
    q[0] + 2.0
        * q[1..]
            .iter()
            .enumerate()
            .map(|(i, v)| v * ((i + 1) as f64 * omega).cos())
            .sum::<f64>()
}

/// Settings of a repetitive design.
#[derive(Debug, Clone, PartialEq)]
pub struct RepetitiveParams {
    /// Period in samples (a fraction is interpolated); no default.
    pub period_samples: f64,
    /// The low-pass. Default: windowed sinc, cutoff a quarter of the
    /// sampling rate, 8 taps each side.
    pub q: Option<QFilter>,
    /// Phase lead `m`; default `None`: the lead in `0..=max_lead` with the
    /// smallest `rho`, Eq. (1).
    pub lead: Option<usize>,
    /// Largest lead tried. Default 20.
    pub max_lead: usize,
    /// Learning gain `k_r`. Default 0.5 (\[Tang17\]).
    pub gain: f64,
    /// Frequencies on which Eq. (1) is evaluated, uniform in `(0, Nyquist]`.
    /// Default 8192.
    pub points: usize,
}

impl RepetitiveParams {
    /// Defaults for a period of `period_samples`.
    pub fn new(period_samples: f64) -> Self {
        Self {
            period_samples,
            q: None,
            lead: None,
            max_lead: 20,
            gain: 0.5,
            points: 8192,
        }
    }
}

/// One harmonic of the period, Eq. (2).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HarmonicAttenuation {
    /// Harmonic number.
    pub harmonic: usize,
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Error with the compensator over error without it (0 = removed).
    pub ratio: f64,
}

/// A designed compensator with its checks.
#[derive(Debug, Clone, PartialEq)]
pub struct RepetitiveDesign {
    /// Whole samples of the period.
    pub period: usize,
    /// Its fraction, `[0, 1)`.
    pub fraction: f64,
    /// `Q` taps `[q_0, .., q_h]`.
    pub q: Vec<f64>,
    /// Phase lead `m`.
    pub lead: usize,
    /// Learning gain `k_r`.
    pub gain: f64,
    /// Sample time, s.
    pub ts: f64,
    /// `rho` of Eq. (1) (`< 1`: stable, converging).
    pub rho: f64,
    /// Where `rho` peaks, Hz.
    pub rho_at_hz: f64,
    /// `rho` for every lead tried, `(m, rho)`.
    pub lead_scan: Vec<(usize, f64)>,
    /// Eq. (2) at the harmonics below Nyquist.
    pub harmonics: Vec<HarmonicAttenuation>,
    /// Frequency where `|Q|` first falls to 1/2, Hz.
    pub q_cutoff_hz: f64,
}

impl RepetitiveDesign {
    /// The stability margin `1 - rho`.
    pub fn margin(&self) -> f64 {
        1.0 - self.rho
    }
}

/// Why no compensator was designed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RepetitiveError {
    /// A setting is out of range; the message names it.
    #[error("{0}")]
    Setting(String),
    /// The loop the compensator plugs into is not stable.
    #[error(
        "the closed-loop model is unstable: a repetitive compensator needs a stable loop to plug into"
    )]
    UnstableLoop,
    /// Eq. (1) fails: the compensator would destabilise the loop.
    #[error(
        "the stability condition fails: max |Q (1 - k_r z^m T)| = {rho:.4} >= 1 at {at_hz:.1} Hz (lead {lead}, gain {gain})"
    )]
    ConditionFails {
        /// `rho`, Eq. (1).
        rho: f64,
        /// Where, Hz.
        at_hz: f64,
        /// The lead.
        lead: usize,
        /// The gain.
        gain: f64,
    },
}

/// `Q F e^{-jw N0}` on the unit circle.
fn memory_response(q: &[f64], period: usize, fraction: f64, omega: f64) -> c64 {
    let f = c64::new(1.0 - fraction, 0.0) + c64::from_polar(fraction, -omega);
    f * q_response(q, omega) * c64::from_polar(1.0, -omega * period as f64)
}

/// `max_w |Q F (1 - k_r e^{jwm} T)|` and where (radians per sample).
fn rho(q: &[f64], fraction: f64, t: &[c64], omegas: &[f64], lead: usize, gain: f64) -> (f64, f64) {
    let mut worst = (0.0, 0.0);
    for (&w, &tw) in omegas.iter().zip(t) {
        let f = c64::new(1.0 - fraction, 0.0) + c64::from_polar(fraction, -w);
        let v = (f
            * q_response(q, w)
            * (c64::new(1.0, 0.0) - gain * c64::from_polar(1.0, w * lead as f64) * tw))
            .norm();
        if v > worst.0 {
            worst = (v, w);
        }
    }
    worst
}

fn check_params(p: &RepetitiveParams, q: &[f64]) -> Result<(usize, f64), RepetitiveError> {
    let bad = |m: String| Err(RepetitiveError::Setting(m));
    if !(p.period_samples.is_finite() && p.period_samples >= 2.0) {
        return bad(format!(
            "period: {} samples; a period needs at least 2",
            p.period_samples
        ));
    }
    if !(p.gain.is_finite() && p.gain > 0.0) {
        return bad(format!("gain: {}; expected a positive number", p.gain));
    }
    if q.is_empty() || q.iter().any(|v| !v.is_finite()) {
        return bad("q: expected finite taps [q0, q1, ..]".into());
    }
    if q.len() > crate::runtime::MAX_Q_HALF + 1 {
        return bad(format!(
            "q: {} taps each side; the runtime takes at most {}",
            q.len() - 1,
            crate::runtime::MAX_Q_HALF
        ));
    }
    let period = p.period_samples.floor() as usize;
    let fraction = p.period_samples - period as f64;
    let half = q.len() - 1;
    if period + half + 2 > crate::runtime::MAX_PERIOD {
        return bad(format!(
            "period: {} samples; the runtime's memory holds at most {}",
            p.period_samples,
            crate::runtime::MAX_PERIOD - half - 2
        ));
    }
    Ok((period, fraction))
}

/// Designs the compensator for the stable closed loop `t` (loop reference
/// to output, the sample time of the runtime).
pub fn design(
    t: &DiscreteTf,
    params: &RepetitiveParams,
) -> Result<RepetitiveDesign, RepetitiveError> {
    let ts = t.ts();
    let q = params
        .q
        .clone()
        .unwrap_or(QFilter::LowPass {
            cutoff_hz: 0.25 / ts,
            half_length: 8,
        })
        .taps(ts);
    let (period, fraction) = check_params(params, &q)?;
    if !t.is_stable().unwrap_or(false) {
        return Err(RepetitiveError::UnstableLoop);
    }
    let points = params.points.max(16);
    let omegas: Vec<f64> = (1..=points)
        .map(|i| PI * i as f64 / points as f64)
        .collect();
    let tw: Vec<c64> = omegas.iter().map(|&w| t.response_at_omega(w)).collect();
    // The lead must leave room for Q inside the period (N0 > h + m).
    let half = q.len() - 1;
    let leads: Vec<usize> = match params.lead {
        Some(m) => vec![m],
        None => (0..=params.max_lead.min(crate::runtime::MAX_LEAD)).collect(),
    };
    let lead_scan: Vec<(usize, f64)> = leads
        .iter()
        .filter(|&&m| period > half + m)
        .map(|&m| (m, rho(&q, fraction, &tw, &omegas, m, params.gain).0))
        .collect();
    let Some(&(lead, _)) = lead_scan.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Err(RepetitiveError::Setting(format!(
            "lead: a period of {period} samples leaves no room for {half} Q taps each side and the lead"
        )));
    };
    let (rho_max, at) = rho(&q, fraction, &tw, &omegas, lead, params.gain);
    let at_hz = at / (2.0 * PI * ts);
    if rho_max >= 1.0 {
        return Err(RepetitiveError::ConditionFails {
            rho: rho_max,
            at_hz,
            lead,
            gain: params.gain,
        });
    }
    let harmonics = harmonics(
        t,
        &q,
        period,
        fraction,
        lead,
        params.gain,
        params.period_samples,
    );
    let q_cutoff_hz = omegas
        .iter()
        .find(|&&w| q_response(&q, w) <= 0.5)
        .map_or(0.5 / ts, |w| w / (2.0 * PI * ts));
    Ok(RepetitiveDesign {
        period,
        fraction,
        q,
        lead,
        gain: params.gain,
        ts,
        rho: rho_max,
        rho_at_hz: at_hz,
        lead_scan,
        harmonics,
        q_cutoff_hz,
    })
}

/// Eq. (2) at every harmonic of the period below Nyquist.
fn harmonics(
    t: &DiscreteTf,
    q: &[f64],
    period: usize,
    fraction: f64,
    lead: usize,
    gain: f64,
    period_samples: f64,
) -> Vec<HarmonicAttenuation> {
    let count = (period_samples / 2.0).floor() as usize;
    (1..=count)
        .map(|h| {
            let omega = 2.0 * PI * h as f64 / period_samples;
            let m = memory_response(q, period, fraction, omega);
            let one = c64::new(1.0, 0.0);
            let tw = t.response_at_omega(omega);
            let ratio = (one - m).norm()
                / (one - m * (one - gain * c64::from_polar(1.0, omega * lead as f64) * tw)).norm();
            HarmonicAttenuation {
                harmonic: h,
                freq_hz: omega / (2.0 * PI * t.ts()),
                ratio,
            }
        })
        .collect()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn windowed_sinc_has_unit_dc_gain_and_its_cutoff() {
        let q = windowed_sinc(0.25, 8);
        assert!((q_response(&q, 0.0) - 1.0).abs() < 1e-15);
        // -6 dB at the cutoff (a windowed sinc's transition is centred there).
        assert!((q_response(&q, 2.0 * PI * 0.25) - 0.5).abs() < 0.02);
        assert!(q_response(&q, PI).abs() < 0.01);
    }

    /// A perfect loop `T = 1`: with `Q = 1`, `m = 0` Eq. (1) is `|1 - k_r|`
    /// everywhere and every harmonic is removed.
    pub fn an_ideal_loop_gives_the_closed_form() {
        let t = DiscreteTf::new(vec![1.0], vec![1.0], 0, 1e-4).unwrap();
        let mut p = RepetitiveParams::new(100.0);
        p.q = Some(QFilter::Taps(vec![1.0]));
        p.lead = Some(0);
        p.gain = 0.3;
        let d = design(&t, &p).unwrap();
        assert!((d.rho - 0.7).abs() < 1e-12, "{}", d.rho);
        assert_eq!(d.harmonics.len(), 50);
        assert!(d.harmonics.iter().all(|h| h.ratio < 1e-9));
        p.gain = 2.5;
        assert!(matches!(
            design(&t, &p),
            Err(RepetitiveError::ConditionFails { .. })
        ));
    }

    /// A pure delay of 3 samples: the lead scan finds `m = 3`, which makes
    /// `z^m T = 1` and `rho = |1 - k_r|` again.
    pub fn the_lead_scan_cancels_a_known_delay() {
        let t = DiscreteTf::new(vec![1.0], vec![1.0], 3, 1e-4).unwrap();
        let mut p = RepetitiveParams::new(100.0);
        p.q = Some(QFilter::Taps(vec![1.0]));
        let d = design(&t, &p).unwrap();
        assert_eq!(d.lead, 3);
        assert!((d.rho - 0.5).abs() < 1e-12);
        let unstable = DiscreteTf::new(vec![1.0], vec![1.0, -1.1], 1, 1e-4).unwrap();
        assert_eq!(design(&unstable, &p), Err(RepetitiveError::UnstableLoop));
    }
}
