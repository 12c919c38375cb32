//! Period-synchronous averaging (docs/math.md §2): the empirical frequency
//! response of a record whose input repeats, such as the multisine of
//! `fts excite multisine`.
//!
//! With an input of period `P` samples, the output after the transient is
//! periodic too, so averaging the record over whole periods removes the
//! noise without the leakage and the resolution loss of Welch's windows:
//! the DFT of one averaged period gives `H(f_k) = mean(Y_p)(k) / mean(U_p)(k)`
//! exactly at the lines `f_k = k / (P Ts)` the input excites (Pintelon and
//! Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.,
//! §2.4). The coherence across periods,
//! `|sum Y_p conj U_p|^2 / (sum |U_p|^2 sum |Y_p|^2)`, is Welch's formula with
//! one rectangular segment per period: 1 for a noiseless linear response,
//! `|mean Y|^2 / mean |Y|^2` (signal over signal plus noise) otherwise.

use super::freq::{FreqError, FreqResponse};
use crate::lti::c64;
use fts_kernels::fft::{RealFft, RealIfft};

/// Settings of [`periodic_response`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeriodicParams {
    /// Period of the input in samples (at least 4).
    pub period: usize,
    /// Whole periods dropped at the start as transient (default 1).
    pub skip: usize,
}

impl Default for PeriodicParams {
    fn default() -> Self {
        PeriodicParams { period: 0, skip: 1 }
    }
}

/// A period given in seconds as whole samples of `ts`; `Err` says why not
/// (for the caller to name its option).
pub fn period_in_samples(period_s: f64, ts: f64) -> Result<usize, String> {
    let samples = (period_s / ts).round();
    if !(period_s > 0.0 && period_s.is_finite()) || samples < 4.0 {
        return Err(format!(
            "expected a period of at least 4 samples of {ts} s, got {period_s} s"
        ));
    }
    if ((samples * ts - period_s) / period_s).abs() > 1e-6 {
        return Err(format!(
            "{period_s} s is not a whole number of samples of {ts} s"
        ));
    }
    Ok(samples as usize)
}

/// Relative size of the difference between periods that still counts as
/// the same input: a record written with five significant digits repeats
/// to about `1e-5` of its range.
const REPEAT_TOLERANCE: f64 = 1e-4;

/// The period of `u` in samples, when the record holds at least two whole
/// periods: the smallest lag `P >= 4` at which every sample equals the one
/// `P` later to within `1e-4` of the input's range. `None` for a
/// constant or aperiodic input.
///
/// The mean-square difference `d(P) = sum (u[k+P] - u[k])^2` is computed
/// for every lag at once from prefix sums of squares and the FFT
/// autocorrelation (O(N log N)); the few lags where it is small are then
/// checked sample by sample.
pub fn detect_period(u: &[f64]) -> Option<usize> {
    let n = u.len();
    let (lo, hi) = u
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let range = hi - lo;
    if n < 8 || !range.is_finite() || range <= 0.0 {
        return None;
    }
    let mean = u.iter().sum::<f64>() / n as f64;
    let x: Vec<f64> = u.iter().map(|v| v - mean).collect();
    let r = autocorrelation(&x);
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for v in &x {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + v * v);
    }
    let tolerance = REPEAT_TOLERANCE * range;
    let mut checked = 0;
    for lag in 4..=n / 2 {
        let overlap = n - lag;
        let d = (prefix[n] - prefix[lag]) + prefix[overlap] - 2.0 * r[lag];
        if d > tolerance * tolerance * overlap as f64 {
            continue;
        }
        if (0..overlap).all(|k| (u[k + lag] - u[k]).abs() <= 10.0 * tolerance) {
            return Some(lag);
        }
        // A handful of near misses is possible; a long run of them means an
        // input that is nearly but not truly periodic.
        checked += 1;
        if checked == 16 {
            return None;
        }
    }
    None
}

/// `r[lag] = sum_k x[k] x[k + lag]` for every lag, by a zero-padded FFT.
fn autocorrelation(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let m = (2 * n).next_power_of_two();
    let forward = RealFft::new(m);
    let mut buf = vec![0.0; m];
    buf[..n].copy_from_slice(x);
    let mut spec = vec![c64::new(0.0, 0.0); forward.bins()];
    forward.process(&mut buf, &mut spec);
    for z in spec.iter_mut() {
        *z = c64::new(z.norm_sqr(), 0.0);
    }
    RealIfft::new(m).process(&mut spec, &mut buf);
    buf.truncate(n);
    buf.iter_mut().for_each(|v| *v /= m as f64);
    buf
}

/// The response at the lines of one period, averaged over the whole periods
/// after `skip` (module docs): bins `0..=P/2` at `k / (P Ts)` Hz, NaN where
/// the averaged input has less than `1e-12` of its strongest line's power
/// (DC aside),
/// at DC and at Nyquist; coherence across periods when two or more are
/// averaged. `segments` is the number of periods averaged, `segment_len`
/// the period.
pub fn periodic_response(
    u: &[f64],
    y: &[f64],
    ts: f64,
    params: &PeriodicParams,
) -> Result<FreqResponse, FreqError> {
    let (period, skip) = (params.period, params.skip);
    let n = u.len().min(y.len());
    if period < 4 {
        return Err(FreqError::BadParams(format!(
            "a period of {period} samples is below 4"
        )));
    }
    if n < period * (skip + 1) {
        return Err(FreqError::TooShort {
            samples: n,
            segment: period * (skip + 1),
        });
    }
    let periods = n / period - skip;
    let spectra = PeriodSpectra::new(u, y, period, skip, periods);
    let bins = period / 2 + 1;
    let peak = (1..bins)
        .map(|k| spectra.u_mean[k].norm_sqr())
        .fold(0.0, f64::max);
    if peak == 0.0 {
        return Err(FreqError::NoInputPower);
    }
    let excited = |k: usize| k > 0 && 2 * k < period && spectra.u_mean[k].norm_sqr() > 1e-12 * peak;
    let nan = c64::new(f64::NAN, f64::NAN);
    let response = (0..bins)
        .map(|k| {
            if excited(k) {
                spectra.y_mean[k] / spectra.u_mean[k]
            } else {
                nan
            }
        })
        .collect();
    let coherence = (periods > 1).then(|| {
        (0..bins)
            .map(|k| {
                if excited(k) {
                    spectra.coherence(k)
                } else {
                    0.0
                }
            })
            .collect()
    });
    Ok(FreqResponse {
        freq_hz: (0..bins).map(|k| k as f64 / (period as f64 * ts)).collect(),
        response,
        coherence,
        segments: periods,
        segment_len: period,
    })
}

/// Sums over the averaged periods, per bin.
struct PeriodSpectra {
    u_mean: Vec<c64>,
    y_mean: Vec<c64>,
    puu: Vec<f64>,
    pyy: Vec<f64>,
    pyu: Vec<c64>,
}

impl PeriodSpectra {
    fn new(u: &[f64], y: &[f64], period: usize, skip: usize, periods: usize) -> Self {
        let fft = RealFft::new(period);
        let bins = fft.bins();
        let zero = c64::new(0.0, 0.0);
        let mut buf = vec![0.0; period];
        let (mut us, mut ys) = (vec![zero; bins], vec![zero; bins]);
        let mut s = PeriodSpectra {
            u_mean: vec![zero; bins],
            y_mean: vec![zero; bins],
            puu: vec![0.0; bins],
            pyy: vec![0.0; bins],
            pyu: vec![zero; bins],
        };
        for p in skip..skip + periods {
            let range = p * period..(p + 1) * period;
            for (spec, src) in [(&mut us, &u[range.clone()]), (&mut ys, &y[range])] {
                buf.copy_from_slice(src);
                fft.process(&mut buf, spec);
            }
            for k in 0..bins {
                let (a, b) = (us[k], ys[k]);
                s.u_mean[k] += a / periods as f64;
                s.y_mean[k] += b / periods as f64;
                s.puu[k] += a.norm_sqr();
                s.pyy[k] += b.norm_sqr();
                s.pyu[k] += b * a.conj();
            }
        }
        s
    }

    fn coherence(&self, k: usize) -> f64 {
        let denominator = self.puu[k] * self.pyy[k];
        if denominator > 0.0 {
            (self.pyu[k].norm_sqr() / denominator).min(1.0)
        } else {
            0.0
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

    fn repeated(one: &[f64], times: usize) -> Vec<f64> {
        (0..one.len() * times).map(|k| one[k % one.len()]).collect()
    }

    pub fn the_period_of_a_repeated_record_is_found_and_an_aperiodic_one_has_none() {
        let one = noise(250, 4);
        assert_eq!(detect_period(&repeated(&one, 2)), Some(250));
        assert_eq!(detect_period(&repeated(&one, 7)[..1700]), Some(250));
        // Written with five significant digits, it still repeats.
        let rounded: Vec<f64> = repeated(&one, 4)
            .iter()
            .map(|v| format!("{v:.4e}").parse().unwrap())
            .collect();
        assert_eq!(detect_period(&rounded), Some(250));
        assert_eq!(detect_period(&noise(2000, 5)), None);
        assert_eq!(detect_period(&[3.0; 100]), None);
        // Fewer than two whole periods: not known to repeat.
        assert_eq!(detect_period(&repeated(&one, 2)[..499]), None);
        // A sine of a whole number of samples per cycle is periodic.
        let sine: Vec<f64> = (0..1000)
            .map(|k| (k as f64 * 0.1 * std::f64::consts::PI).sin())
            .collect();
        assert_eq!(detect_period(&sine), Some(20));
    }

    pub fn averaging_whole_periods_gives_the_system_at_its_lines() {
        // Noiseless: exact at every excited line once the transient is
        // skipped, coherence 1.
        let period = 128;
        let u = repeated(&noise(period, 9), 12);
        let (b, a) = (vec![0.3, 0.2], vec![1.0, -0.6]);
        let y = filter_ab(&b, &a, 1, &u);
        let g = DiscreteTf::new(b, a, 1, 1e-3).unwrap();
        let p = PeriodicParams { period, skip: 2 };
        let h = periodic_response(&u, &y, 1e-3, &p).unwrap();
        assert_eq!((h.segments, h.segment_len), (10, period));
        let mut lines = 0;
        for (k, f) in h.freq_hz.iter().enumerate() {
            if h.response[k].re.is_finite() {
                let err =
                    (h.response[k] - g.response_at_hz(*f)).norm() / g.response_at_hz(*f).norm();
                assert!(err < 1e-9, "line {k}: {err}");
                assert!((h.coherence.as_ref().unwrap()[k] - 1.0).abs() < 1e-9);
                lines += 1;
            }
        }
        assert_eq!(lines, period / 2 - 1, "DC and Nyquist are left out");
    }

    pub fn output_noise_averages_down_and_lowers_the_coherence() {
        // Noise of standard deviation s on y: the averaged line's error is
        // about s sqrt(P) / (|U| sqrt(periods)), and the coherence
        // |mean Y|^2 / mean|Y|^2 drops below 1.
        let period = 256;
        let u = repeated(&noise(period, 2), 41);
        let (b, a) = (vec![0.5], vec![1.0, -0.5]);
        let clean = filter_ab(&b, &a, 0, &u);
        let v = noise(u.len(), 77);
        let y: Vec<f64> = clean.iter().zip(&v).map(|(c, e)| c + 0.05 * e).collect();
        let g = DiscreteTf::new(b, a, 0, 1.0).unwrap();
        let h = periodic_response(&u, &y, 1.0, &PeriodicParams { period, skip: 1 }).unwrap();
        let coherence = h.coherence.as_ref().unwrap();
        let (mut worst, mut lowest) = (0.0_f64, 1.0_f64);
        for (k, f) in h.freq_hz.iter().enumerate() {
            if h.response[k].re.is_finite() {
                worst = worst.max(
                    (h.response[k] - g.response_at_hz(*f)).norm() / g.response_at_hz(*f).norm(),
                );
                lowest = lowest.min(coherence[k]);
            }
        }
        assert!(worst < 0.1, "worst relative error {worst}");
        assert!(lowest < 0.999 && lowest > 0.5, "lowest coherence {lowest}");
    }

    pub fn records_too_short_or_without_input_are_refused() {
        let u = repeated(&noise(64, 1), 3);
        let p = PeriodicParams {
            period: 64,
            skip: 3,
        };
        assert!(matches!(
            periodic_response(&u, &u, 1.0, &p),
            Err(FreqError::TooShort { .. })
        ));
        let p = PeriodicParams { period: 2, skip: 0 };
        assert!(matches!(
            periodic_response(&u, &u, 1.0, &p),
            Err(FreqError::BadParams(_))
        ));
        let p = PeriodicParams {
            period: 64,
            skip: 0,
        };
        assert_eq!(
            periodic_response(&[0.0; 128], &u, 1.0, &p),
            Err(FreqError::NoInputPower)
        );
    }
}
