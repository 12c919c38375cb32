//! Empirical frequency response from input/output data (docs/math.md §2): Welch
//! cross-spectra with coherence (MATLAB `tfestimate`/`mscohere`, `spa`-like),
//! and the empirical transfer-function estimate ETFE (`etfe`: `Y(f)/U(f)`).
//!
//! Welch: the record is cut into segments of `L` samples overlapping by
//! `overlap`, each mean-removed and Hann-windowed;
//! `P_uu = sum |U_i|^2`, `P_yu = sum Y_i conj(U_i)`, `P_yy = sum |Y_i|^2`,
//! `H1 = P_yu / P_uu` (unbiased by output noise, which is uncorrelated with
//! `u`), coherence `gamma^2 = |P_yu|^2 / (P_uu P_yy)`: 1 where `y` is a linear
//! function of `u`, lower where noise, nonlinearity or missing excitation
//! dominate. Averaging trades frequency resolution `1/(L Ts)` for variance.

pub use super::periodic::{PeriodicParams, detect_period, periodic_response};
use crate::lti::c64;
use fts_kernels::fft::RealFft;

/// Why a frequency estimate cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FreqError {
    /// Record shorter than one segment.
    #[error(
        "too few samples for the frequency estimate: {samples} samples, a segment needs {segment}"
    )]
    TooShort {
        /// Samples available.
        samples: usize,
        /// Segment length.
        segment: usize,
    },
    /// The input carries no power (constant input).
    #[error(
        "the input has no power at any frequency (constant input): the frequency response is undefined"
    )]
    NoInputPower,
    /// Bad settings.
    #[error("invalid frequency-estimate settings: {0}")]
    BadParams(String),
}

/// Settings of [`welch`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchParams {
    /// Segment length `L` in samples. Default `None`: chosen from the record
    /// by [`choose_segment`] (the power of two of best bias-corrected median
    /// coherence).
    pub segment: Option<usize>,
    /// Fractional overlap of consecutive segments, `0 <= overlap < 1`
    /// (default 0.5, the usual choice for a Hann window).
    pub overlap: f64,
}

impl Default for WelchParams {
    fn default() -> Self {
        WelchParams {
            segment: None,
            overlap: 0.5,
        }
    }
}

/// A frequency response on a grid, with coherence when averaged.
#[derive(Debug, Clone, PartialEq)]
pub struct FreqResponse {
    /// Frequencies in Hz (`0 ..= 1/(2 Ts)`).
    pub freq_hz: Vec<f64>,
    /// `H(f)`; NaN where the input has no power.
    pub response: Vec<c64>,
    /// Magnitude-squared coherence (Welch only).
    pub coherence: Option<Vec<f64>>,
    /// Segments averaged (1 for ETFE).
    pub segments: usize,
    /// Segment length in samples (the record length for ETFE).
    pub segment_len: usize,
}

impl FreqResponse {
    /// Phase in degrees, unwrapped along the grid; NaN at bins without
    /// input power (which the unwrapping skips).
    pub fn phase_deg_unwrapped(&self) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.response.len());
        let mut offset = 0.0;
        let mut prev: Option<f64> = None;
        for v in &self.response {
            if !v.re.is_finite() {
                out.push(f64::NAN);
                continue;
            }
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
            prev = Some(raw + offset);
            out.push(raw + offset);
        }
        out
    }
}

/// Default Welch segment length for `n` samples.
pub fn default_segment(n: usize) -> usize {
    let target = (n / 8).clamp(64, 8192);
    let mut l = 1;
    while l * 2 <= target {
        l *= 2;
    }
    l.min(n)
}

/// Median coherence of an estimate over the bins the input excites (DC
/// left out), corrected for the bias of averaging few segments: with `n`
/// averages an incoherent bin still shows about `1/n`, so the score is
/// `(median - 1/n) / (1 - 1/n)`, comparable across segment lengths.
pub fn coherence_score(h: &FreqResponse) -> f64 {
    let bias = 1.0 / h.segments as f64;
    (median_coherence(h) - bias) / (1.0 - bias)
}

/// Median coherence over the bins the input excites, DC left out (the mean
/// of the two middle values for an even count, as numpy's); NaN without
/// coherence (ETFE), 0 when nothing is excited.
pub fn median_coherence(h: &FreqResponse) -> f64 {
    let Some(c) = &h.coherence else {
        return f64::NAN;
    };
    let mut excited: Vec<f64> = (1..c.len())
        .filter(|&i| h.response[i].re.is_finite())
        .map(|i| c[i])
        .collect();
    if excited.is_empty() {
        return 0.0;
    }
    excited.sort_by(f64::total_cmp);
    let m = excited.len();
    0.5 * (excited[(m - 1) / 2] + excited[m / 2])
}

/// Score margin within which two segment lengths count as equally coherent.
const SCORE_TIE: f64 = 0.02;

/// The Welch segment length for this record: among powers of two from 64
/// (fewer for short records) to `N/2` (at least three half-overlapping
/// segments), the one whose [`coherence_score`] is best. A lightly damped
/// system or a swept input needs segments long against its ring-down, or
/// leakage and the segment edges decorrelate `y` from `u` (the DaISy robot
/// arm: median coherence 0.07 at 64 samples, 0.81 at 256); well-behaved
/// data scores alike at every length, and then the length nearest
/// [`default_segment`] (eight segments) is kept, for variance.
pub fn choose_segment(u: &[f64], y: &[f64], ts: f64, overlap: f64) -> Result<usize, FreqError> {
    Ok(chosen_estimate(u, y, ts, overlap)?.segment_len)
}

/// The Welch estimate at the segment length [`choose_segment`] picks,
/// computed once per candidate length (the winner is not recomputed).
fn chosen_estimate(u: &[f64], y: &[f64], ts: f64, overlap: f64) -> Result<FreqResponse, FreqError> {
    let n = u.len().min(y.len());
    let fallback = default_segment(n);
    let mut candidates = Vec::new();
    let mut l = 64.min(fallback).max(4);
    while l <= n / 2 {
        candidates.push(l);
        l *= 2;
    }
    if candidates.len() < 2 {
        candidates = vec![fallback];
    }
    let mut scored = Vec::with_capacity(candidates.len());
    for &l in &candidates {
        let params = WelchParams {
            segment: Some(l),
            overlap,
        };
        let estimate = welch(u, y, ts, &params)?;
        scored.push((coherence_score(&estimate), estimate));
    }
    let best = scored.iter().map(|s| s.0).fold(f64::NEG_INFINITY, f64::max);
    let distance = |l: usize| (l as f64 / fallback as f64).log2().abs();
    let pick = (0..scored.len())
        .filter(|&i| scored[i].0 >= best - SCORE_TIE)
        .min_by(|&a, &b| {
            distance(scored[a].1.segment_len).total_cmp(&distance(scored[b].1.segment_len))
        })
        .unwrap_or(0);
    Ok(scored.swap_remove(pick).1)
}

fn hann(l: usize) -> Vec<f64> {
    // Periodic Hann (the DFT-even form used for spectral averaging).
    (0..l)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / l as f64).cos())
        .collect()
}

/// Welch estimate `H1 = P_yu/P_uu` with coherence.
pub fn welch(
    u: &[f64],
    y: &[f64],
    ts: f64,
    params: &WelchParams,
) -> Result<FreqResponse, FreqError> {
    let n = u.len().min(y.len());
    if !(0.0..1.0).contains(&params.overlap) {
        return Err(FreqError::BadParams(format!(
            "overlap must be in [0, 1), got {}",
            params.overlap
        )));
    }
    let Some(l) = params.segment else {
        return chosen_estimate(u, y, ts, params.overlap);
    };
    if l < 4 {
        return Err(FreqError::BadParams(format!(
            "segment length {l} is below 4"
        )));
    }
    if n < l {
        return Err(FreqError::TooShort {
            samples: n,
            segment: l,
        });
    }
    let hop = (((1.0 - params.overlap) * l as f64).round() as usize).max(1);
    let win = hann(l);
    let fft = RealFft::new(l);
    let bins = fft.bins();
    let mut buf = vec![0.0; l];
    let mut uspec = vec![c64::new(0.0, 0.0); bins];
    let mut yspec = vec![c64::new(0.0, 0.0); bins];
    let mut puu = vec![0.0; bins];
    let mut pyy = vec![0.0; bins];
    let mut pyu = vec![c64::new(0.0, 0.0); bins];
    let mut segments = 0;
    let mut start = 0;
    while start + l <= n {
        for (spec, src) in [(&mut uspec, u), (&mut yspec, y)] {
            let seg = &src[start..start + l];
            let mean = seg.iter().sum::<f64>() / l as f64;
            for ((b, s), w) in buf.iter_mut().zip(seg).zip(&win) {
                *b = (s - mean) * w;
            }
            fft.process(&mut buf, spec);
        }
        for i in 0..bins {
            let uu = uspec[i];
            let yy = yspec[i];
            puu[i] += uu.norm_sqr();
            pyy[i] += yy.norm_sqr();
            pyu[i] += yy * uu.conj();
        }
        segments += 1;
        start += hop;
    }
    let pmax = puu.iter().copied().fold(0.0, f64::max);
    if pmax == 0.0 {
        return Err(FreqError::NoInputPower);
    }
    // Bins where the input power is below 1e-12 of its peak carry no
    // information (division by round-off): reported as NaN.
    let floor = 1e-12 * pmax;
    let response = (0..bins)
        .map(|i| {
            if puu[i] > floor {
                pyu[i] / puu[i]
            } else {
                c64::new(f64::NAN, f64::NAN)
            }
        })
        .collect();
    let coherence = (0..bins)
        .map(|i| {
            if puu[i] > floor && pyy[i] > 0.0 {
                (pyu[i].norm_sqr() / (puu[i] * pyy[i])).min(1.0)
            } else {
                0.0
            }
        })
        .collect();
    Ok(FreqResponse {
        freq_hz: (0..bins).map(|i| i as f64 / (l as f64 * ts)).collect(),
        response,
        coherence: Some(coherence),
        segments,
        segment_len: l,
    })
}

/// ETFE `Y(f)/U(f)` over the whole (mean-removed, unwindowed) record: full
/// resolution `1/(N Ts)`, no averaging, exact for a periodic input measured
/// over whole periods; noisy otherwise.
pub fn etfe(u: &[f64], y: &[f64], ts: f64) -> Result<FreqResponse, FreqError> {
    let n = u.len().min(y.len());
    if n < 4 {
        return Err(FreqError::TooShort {
            samples: n,
            segment: 4,
        });
    }
    let fft = RealFft::new(n);
    let spec = |x: &[f64]| -> Vec<c64> {
        let mean = x[..n].iter().sum::<f64>() / n as f64;
        let mut buf: Vec<f64> = x[..n].iter().map(|v| v - mean).collect();
        let mut out = vec![c64::new(0.0, 0.0); fft.bins()];
        fft.process(&mut buf, &mut out);
        out
    };
    let us = spec(u);
    let ys = spec(y);
    let pmax = us.iter().map(|z| z.norm_sqr()).fold(0.0, f64::max);
    if pmax == 0.0 {
        return Err(FreqError::NoInputPower);
    }
    let floor = 1e-12 * pmax;
    let response = us
        .iter()
        .zip(&ys)
        .map(|(uu, yy)| {
            if uu.norm_sqr() > floor {
                yy / uu
            } else {
                c64::new(f64::NAN, f64::NAN)
            }
        })
        .collect();
    Ok(FreqResponse {
        freq_hz: (0..us.len()).map(|i| i as f64 / (n as f64 * ts)).collect(),
        response,
        coherence: None,
        segments: 1,
        segment_len: n,
    })
}

/// Which estimator [`empirical_response`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Estimator {
    /// Period-synchronous averaging when the input repeats (given or found
    /// by [`detect_period`]), Welch otherwise (default).
    #[default]
    Auto,
    /// [`welch`].
    Welch,
    /// [`etfe`].
    Etfe,
    /// [`periodic_response`]; needs a period (given or found).
    Periodic,
}

/// Settings of [`empirical_response`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmpiricalParams {
    /// Estimator (default [`Estimator::Auto`]).
    pub estimator: Estimator,
    /// Welch settings (a given segment length makes `Auto` use Welch).
    pub welch: WelchParams,
    /// Input period in samples (default `None`: found from the input).
    pub period: Option<usize>,
    /// Whole periods dropped as transient (default 1).
    pub skip_periods: usize,
}

impl Default for EmpiricalParams {
    fn default() -> Self {
        EmpiricalParams {
            estimator: Estimator::Auto,
            welch: WelchParams::default(),
            period: None,
            skip_periods: 1,
        }
    }
}

/// How an [`Empirical`] estimate was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EstimateKind {
    /// Welch; `chosen`: the segment length was chosen from the record.
    Welch { chosen: bool },
    /// ETFE over the whole record.
    Etfe,
    /// Averaged over whole periods; `detected`: the period was found in the input.
    Periodic { detected: bool, skipped: usize },
}

/// An empirical frequency response and how it was estimated.
#[derive(Debug, Clone, PartialEq)]
pub struct Empirical {
    /// The estimate.
    pub response: FreqResponse,
    /// The estimator and its choices.
    pub kind: EstimateKind,
}

/// The empirical response of a record as an engineer would take it: averaged
/// over whole periods when the input repeats (no leakage, exact lines),
/// Welch-averaged otherwise, or the estimator `params` name.
pub fn empirical_response(
    u: &[f64],
    y: &[f64],
    ts: f64,
    params: &EmpiricalParams,
) -> Result<Empirical, FreqError> {
    let n = u.len().min(y.len());
    let wants_period = match params.estimator {
        Estimator::Auto => params.welch.segment.is_none(),
        Estimator::Periodic => true,
        Estimator::Welch | Estimator::Etfe => false,
    };
    let period = match (wants_period, params.period) {
        (false, _) => None,
        (true, Some(p)) => Some((p, false)),
        (true, None) => detect_period(&u[..n]).map(|p| (p, true)),
    };
    if let Some((period, detected)) = period {
        let p = PeriodicParams {
            period,
            skip: params.skip_periods,
        };
        let response = periodic_response(u, y, ts, &p)?;
        let kind = EstimateKind::Periodic {
            detected,
            skipped: params.skip_periods,
        };
        return Ok(Empirical { response, kind });
    }
    match params.estimator {
        Estimator::Periodic => Err(FreqError::BadParams(
            "the input does not repeat: no period to average over (give one)".into(),
        )),
        Estimator::Etfe => Ok(Empirical {
            response: etfe(u, y, ts)?,
            kind: EstimateKind::Etfe,
        }),
        Estimator::Auto | Estimator::Welch => Ok(Empirical {
            response: welch(u, y, ts, &params.welch)?,
            kind: EstimateKind::Welch {
                chosen: params.welch.segment.is_none(),
            },
        }),
    }
}

impl Empirical {
    /// One line for a plot title and stderr: the estimator, its averaging
    /// and the median coherence.
    pub fn summary(&self) -> String {
        let h = &self.response;
        let coherence = match h.coherence {
            Some(_) => format!(", median coherence {:.2}", median_coherence(h)),
            None => String::new(),
        };
        match self.kind {
            EstimateKind::Welch { chosen } => format!(
                "Welch {} x {} samples{}{coherence}",
                h.segments,
                h.segment_len,
                if chosen {
                    " (chosen for coherence)"
                } else {
                    ""
                }
            ),
            EstimateKind::Etfe => format!("ETFE over {} samples", h.segment_len),
            EstimateKind::Periodic { detected, skipped } => format!(
                "average of {} periods x {} samples{}, {skipped} skipped{coherence}",
                h.segments,
                h.segment_len,
                if detected {
                    " (period found in the input)"
                } else {
                    ""
                }
            ),
        }
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::linear::filter_ab;
    use crate::ident::testutil::noise;
    use crate::lti::DiscreteTf;

    pub fn welch_recovers_known_response_with_unit_coherence() {
        // White input through a known, well-damped filter: H1 matches G within
        // a few percent where the coherence is high.
        let (b, a) = (vec![0.2, 0.1], vec![1.0, -0.7]);
        let u = noise(65_536, 3);
        let y = filter_ab(&b, &a, 1, &u);
        let h = welch(&u, &y, 1e-3, &WelchParams::default()).unwrap();
        let g = DiscreteTf::new(b, a, 1, 1e-3).unwrap();
        let mut checked = 0;
        for (i, f) in h.freq_hz.iter().enumerate().skip(1) {
            let c = h.coherence.as_ref().unwrap()[i];
            assert!(c > 0.98, "coherence {c} at {f}");
            let err = (h.response[i] - g.response_at_hz(*f)).norm() / g.response_at_hz(*f).norm();
            assert!(err < 0.05, "rel err {err} at {f} Hz");
            checked += 1;
        }
        assert!(checked > 100);
        assert_eq!(h.segment_len, 8192);
    }

    pub fn etfe_exact_for_periodic_input() {
        // A periodic input measured after the transient over whole periods:
        // ETFE equals G at the excited bins.
        let period = 64;
        let one: Vec<f64> = noise(period, 9);
        let u: Vec<f64> = (0..period * 40).map(|k| one[k % period]).collect();
        let (b, a) = (vec![0.5], vec![1.0, -0.5]);
        let y = filter_ab(&b, &a, 0, &u);
        let (u2, y2) = (&u[period * 20..], &y[period * 20..]);
        let h = etfe(u2, y2, 1.0).unwrap();
        let g = DiscreteTf::new(b, a, 0, 1.0).unwrap();
        for (i, f) in h.freq_hz.iter().enumerate() {
            if i % 20 == 0 && i > 0 {
                let err = (h.response[i] - g.response_at_hz(*f)).norm();
                assert!(err < 1e-9, "bin {i}: {err}");
            }
        }
        assert_eq!(
            welch(&[1.0; 100], &[2.0; 100], 1.0, &WelchParams::default()).unwrap_err(),
            FreqError::NoInputPower
        );
    }
}
