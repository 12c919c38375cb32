//! Reference trajectories for tracking runs ([Li21] Sec. 5): sines, the
//! 0-1000 Hz sweep and the five-leaved trajectory, each preceded by a smooth
//! lead-in from rest so that the start-up transient is not counted as
//! tracking error.

use crate::ident::excite::{self, ExciteError};
use std::f64::consts::PI;

/// A reference with the part over which tracking is evaluated.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Samples, one per controller period.
    pub samples: Vec<f64>,
    /// First sample of the evaluated ("steady") part.
    pub evaluate_from: usize,
    /// Description for summaries, e.g. `sine 5 um at 500 Hz`.
    pub label: String,
}

/// Lead-in: raised-cosine ramp from `from` to `to` over `ramp` samples, then
/// `hold` samples at `to`.
pub fn lead_in(from: f64, to: f64, ramp: usize, hold: usize) -> Vec<f64> {
    let mut v: Vec<f64> = (0..ramp)
        .map(|k| from + (to - from) * 0.5 * (1.0 - (PI * k as f64 / ramp as f64).cos()))
        .collect();
    v.extend(std::iter::repeat_n(to, hold));
    v
}

/// Timing shared by every reference kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceTiming {
    /// Sample time, s.
    pub ts: f64,
    /// Lead-in ramp length, s (from 0 to the signal's first value).
    pub ramp: f64,
    /// Hold after the ramp, s.
    pub hold: f64,
}

impl Default for ReferenceTiming {
    fn default() -> Self {
        Self {
            ts: 1e-4,
            ramp: 0.05,
            hold: 0.05,
        }
    }
}

fn with_lead_in(
    signal: Vec<f64>,
    timing: &ReferenceTiming,
    skip: usize,
    label: String,
) -> Reference {
    let ramp = (timing.ramp / timing.ts).round() as usize;
    let hold = (timing.hold / timing.ts).round() as usize;
    let first = signal.first().copied().unwrap_or(0.0);
    let mut samples = lead_in(0.0, first, ramp, hold);
    let evaluate_from = samples.len() + skip.min(signal.len());
    samples.extend(signal);
    Reference {
        samples,
        evaluate_from,
        label,
    }
}

/// `offset + amplitude sin(2 pi f t)` for `periods` periods (at least
/// `min_duration` s); the first `settle_periods` periods are not evaluated.
pub fn sine(
    amplitude: f64,
    freq_hz: f64,
    offset: f64,
    duration: f64,
    timing: &ReferenceTiming,
) -> Result<Reference, ExciteError> {
    let s = excite::sine(&excite::SineParams {
        amplitude,
        freq_hz,
        phase: 0.0,
        offset,
        duration,
        ts: timing.ts,
    })?;
    // Skip the first 20 % (at least one period) so integrators and the
    // hysteresis memory have settled.
    let period = if freq_hz > 0.0 {
        (1.0 / (freq_hz * timing.ts)).round() as usize
    } else {
        0
    };
    let skip = (s.len() / 5).max(period).min(s.len());
    Ok(with_lead_in(
        s,
        timing,
        skip,
        format!("sine {amplitude} um at {freq_hz} Hz"),
    ))
}

/// Linear sine sweep `f0..f1` Hz, evaluated over the whole sweep.
pub fn sweep(
    amplitude: f64,
    f0: f64,
    f1: f64,
    offset: f64,
    duration: f64,
    timing: &ReferenceTiming,
) -> Result<Reference, ExciteError> {
    let s = excite::sweep(&excite::SweepParams {
        f0,
        f1,
        duration,
        amplitude,
        offset,
        ts: timing.ts,
        spacing: excite::SweepSpacing::Linear,
    })?;
    Ok(with_lead_in(
        s,
        timing,
        0,
        format!("sweep {amplitude} um, {f0}-{f1} Hz"),
    ))
}

/// The five-leaved trajectory of [Li21] Eq. 13 times `scale`, plus `offset`.
pub fn five_leaf(
    scale: f64,
    offset: f64,
    duration: f64,
    timing: &ReferenceTiming,
) -> Result<Reference, ExciteError> {
    let s = excite::five_leaf(&excite::FiveLeafParams {
        duration,
        scale,
        offset,
        ts: timing.ts,
    })?;
    Ok(with_lead_in(s, timing, 0, format!("five-leaf x{scale}")))
}

/// A user's samples (already at the controller rate), evaluated throughout.
pub fn from_samples(samples: Vec<f64>, timing: &ReferenceTiming, label: String) -> Reference {
    with_lead_in(samples, timing, 0, label)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lead_in_is_smooth_and_reaches_the_start() {
        let r = sine(5.0, 100.0, 6.0, 0.1, &ReferenceTiming::default()).unwrap();
        assert_eq!(r.samples[0], 0.0);
        // Ramp 500 samples + hold 500 at 6.0, then the sine starts at 6.0.
        assert!((r.samples[999] - 6.0).abs() < 1e-12);
        assert!((r.samples[1000] - 6.0).abs() < 1e-12);
        // 20 % of 1000 sine samples skipped (more than one 100-sample period).
        assert_eq!(r.evaluate_from, 1200);
        let max_step = r
            .samples
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(max_step < 0.32, "{max_step}");
    }
}
