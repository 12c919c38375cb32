//! Reference trajectories for tracking runs (\[Li21\] Sec. 5): sines, the
//! 0-1000 Hz sweep and the five-leaved trajectory, each preceded by a smooth
//! lead-in from rest so that the start-up transient is not counted as
//! tracking error, and followed by a short tail that continues the waveform
//! past the evaluated part. The tail matters for previewed feedforward: a
//! ZPETC with preview `p` reads the reference `p` samples ahead, and a
//! reference that simply stopped (or was held) would make the last `p`
//! evaluated samples track a trajectory that the cut never had.

use crate::ident::excite::{self, ExciteError};
use std::f64::consts::PI;

/// A reference with the part over which tracking is evaluated.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Samples, one per controller period.
    pub samples: Vec<f64>,
    /// First sample of the evaluated ("steady") part.
    pub evaluate_from: usize,
    /// One past the last evaluated sample; the samples after it are the tail.
    pub evaluate_to: usize,
    /// First sample after the lead-in ramp. Before it the loop is leaving
    /// rest; learning control ignores that error, which no feedforward can
    /// remove (it would need commands before the first sample, or below
    /// the amplifier's floor).
    pub ramp_end: usize,
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
    /// Continuation after the evaluated part, s; it should exceed the
    /// feedforward preview (see [`ReferenceTiming::with_preview`]).
    pub tail: f64,
}

impl Default for ReferenceTiming {
    fn default() -> Self {
        Self {
            ts: 1e-4,
            ramp: 0.05,
            hold: 0.05,
            tail: 0.01,
        }
    }
}

impl ReferenceTiming {
    /// The timing with a tail of at least twice `preview` samples (and never
    /// shorter than the current one).
    pub fn with_preview(mut self, preview: usize) -> Self {
        self.tail = self.tail.max(2.0 * preview as f64 * self.ts);
        self
    }

    /// Whole samples of the tail.
    fn tail_samples(&self) -> usize {
        (self.tail / self.ts).round() as usize
    }

    /// `duration` plus the tail, in seconds.
    fn extended(&self, duration: f64) -> f64 {
        duration + self.tail_samples() as f64 * self.ts
    }
}

/// `signal` holds `evaluated` samples of the trajectory followed by its tail.
fn with_lead_in(
    signal: Vec<f64>,
    evaluated: usize,
    timing: &ReferenceTiming,
    skip: usize,
    label: String,
) -> Reference {
    let ramp = (timing.ramp / timing.ts).round() as usize;
    let hold = (timing.hold / timing.ts).round() as usize;
    let first = signal.first().copied().unwrap_or(0.0);
    let mut samples = lead_in(0.0, first, ramp, hold);
    let evaluated = evaluated.min(signal.len());
    let evaluate_from = samples.len() + skip.min(evaluated);
    let evaluate_to = samples.len() + evaluated;
    samples.extend(signal);
    Reference {
        samples,
        evaluate_from,
        evaluate_to,
        ramp_end: ramp,
        label,
    }
}

/// [`with_lead_in`] whose hold fades the pattern in: over the hold the
/// reference is `first + w(t) (pattern(t) - pattern(0))`, `t < 0` the time
/// before the evaluated part and `w` a raised cosine from 0 to 1. The loop
/// then enters the evaluated part in motion, with the pattern's own
/// velocity, as a machine engages a periodic path, instead of meeting a
/// velocity jump at its first evaluated sample.
fn with_fade_in(
    signal: Vec<f64>,
    evaluated: usize,
    timing: &ReferenceTiming,
    pattern: impl Fn(f64) -> f64,
    label: String,
) -> Reference {
    let mut r = with_lead_in(signal, evaluated, timing, 0, label);
    let hold = r.evaluate_from - r.ramp_end;
    let first = r.samples[r.evaluate_from];
    let p0 = pattern(0.0);
    for i in 0..hold {
        let t = (i as f64 - hold as f64) * timing.ts;
        let w = 0.5 * (1.0 - (PI * i as f64 / hold as f64).cos());
        r.samples[r.ramp_end + i] = first + w * (pattern(t) - p0);
    }
    r
}

impl Reference {
    /// The evaluated samples, `evaluate_from..evaluate_to`.
    pub fn evaluated(&self) -> std::ops::Range<usize> {
        self.evaluate_from..self.evaluate_to
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
    let params = excite::SineParams {
        amplitude,
        freq_hz,
        phase: 0.0,
        offset,
        duration,
        ts: timing.ts,
    };
    let evaluated = excite::sample_count(duration, timing.ts)?;
    let s = excite::sine(&excite::SineParams {
        duration: timing.extended(duration),
        ..params
    })?;
    // Skip the first 20 % (at least one period) so integrators and the
    // hysteresis memory have settled.
    let period = if freq_hz > 0.0 {
        (1.0 / (freq_hz * timing.ts)).round() as usize
    } else {
        0
    };
    let skip = (evaluated / 5).max(period).min(evaluated);
    Ok(with_lead_in(
        s,
        evaluated,
        timing,
        skip,
        format!("sine {amplitude} um at {freq_hz} Hz"),
    ))
}

/// Linear sine sweep `f0..f1` Hz, evaluated over the whole sweep; the tail
/// continues the sweep at the same rate (up to 0.99 Nyquist).
pub fn sweep(
    amplitude: f64,
    f0: f64,
    f1: f64,
    offset: f64,
    duration: f64,
    timing: &ReferenceTiming,
) -> Result<Reference, ExciteError> {
    let params = excite::SweepParams {
        f0,
        f1,
        duration,
        amplitude,
        offset,
        ts: timing.ts,
        spacing: excite::SweepSpacing::Linear,
    };
    let evaluated = excite::sample_count(duration, timing.ts)?;
    let rate = (f1 - f0) / duration;
    let mut extended = timing.extended(duration);
    let ceiling = 0.99 * 0.5 / timing.ts;
    if rate > 0.0 && f0 + rate * extended > ceiling {
        extended = duration.max((ceiling - f0) / rate);
    }
    let s = excite::sweep(&excite::SweepParams {
        f1: f0 + rate * extended,
        duration: extended,
        ..params
    })?;
    Ok(with_lead_in(
        s,
        evaluated,
        timing,
        0,
        format!("sweep {amplitude} um, {f0}-{f1} Hz"),
    ))
}

/// The five-leaved trajectory of \[Li21\] Eq. 13 times `scale`, plus `offset`.
/// The hold before it fades the pattern in (a raised cosine on Eq. 13), so the
/// evaluated part starts in motion, not with a velocity jump of
/// `scale` x 31 mm/s.
pub fn five_leaf(
    scale: f64,
    offset: f64,
    duration: f64,
    timing: &ReferenceTiming,
) -> Result<Reference, ExciteError> {
    let params = excite::FiveLeafParams {
        duration,
        scale,
        offset,
        ts: timing.ts,
    };
    let evaluated = excite::sample_count(duration, timing.ts)?;
    let s = excite::five_leaf(&excite::FiveLeafParams {
        duration: timing.extended(duration),
        ..params
    })?;
    Ok(with_fade_in(
        s,
        evaluated,
        timing,
        |t| scale * excite::five_leaf_at(t),
        format!("five-leaf x{scale}"),
    ))
}

/// A user's samples (already at the controller rate), evaluated throughout.
/// Their continuation is unknown, so the tail holds the last value: with a
/// previewed feedforward, the last `preview` evaluated samples then see that
/// hold. A reference file that carries its own lead-out avoids this.
pub fn from_samples(mut samples: Vec<f64>, timing: &ReferenceTiming, label: String) -> Reference {
    let evaluated = samples.len();
    let last = samples.last().copied().unwrap_or(0.0);
    samples.extend(std::iter::repeat_n(last, timing.tail_samples()));
    with_lead_in(samples, evaluated, timing, 0, label)
}

/// Samples `values` taken at the times `t` (s, increasing) at the loop's
/// sample time `ts`: `r(t0 + k ts)` for every instant up to the last time,
/// linearly interpolated between the two samples around it. A file whose
/// time step is already `ts` comes back unchanged; one at 1 ms played at
/// 0.1 ms keeps its frequencies instead of running ten times faster.
/// `Err` says why (too many samples, fewer than two).
pub fn resample_linear(t: &[f64], values: &[f64], ts: f64) -> Result<Vec<f64>, String> {
    let (Some(&t0), Some(&t1)) = (t.first(), t.last()) else {
        return Err("no samples".into());
    };
    if t.len() != values.len() || t.len() < 2 {
        return Err("at least two timed samples are needed".into());
    }
    // The last instant counts when it falls on the grid within rounding.
    let n = ((t1 - t0) / ts * (1.0 + 1e-9)).floor() + 1.0;
    if n > excite::MAX_SAMPLES {
        return Err(format!(
            "{:.3} s at the loop's ts = {ts} s would be {n:.3e} samples, more than fts simulates ({:e})",
            t1 - t0,
            excite::MAX_SAMPLES
        ));
    }
    let mut out = Vec::with_capacity(n as usize);
    let mut j = 0;
    for k in 0..n as usize {
        let tk = (t0 + k as f64 * ts).min(t1);
        while j + 2 < t.len() && t[j + 1] < tk {
            j += 1;
        }
        // t[j] <= tk <= t[j + 1] (the last interval takes the end).
        let w = ((tk - t[j]) / (t[j + 1] - t[j])).clamp(0.0, 1.0);
        out.push(values[j] + w * (values[j + 1] - values[j]));
    }
    Ok(out)
}

/// A step of `amplitude` from `offset` at `step_at` s into the evaluated
/// part, held to `duration` s (and through the tail). The lead-in brings
/// the loop to `offset` first, so the step starts from rest.
pub fn step(
    amplitude: f64,
    offset: f64,
    step_at: f64,
    duration: f64,
    timing: &ReferenceTiming,
) -> Result<Reference, ExciteError> {
    let bad = |field, message: String| Err(ExciteError { field, message });
    if !(amplitude.is_finite() && amplitude != 0.0) {
        return bad(
            "amplitude",
            format!("a step needs a non-zero amplitude, got {amplitude}"),
        );
    }
    if !offset.is_finite() {
        return bad("offset", format!("expected a finite number, got {offset}"));
    }
    let evaluated = excite::sample_count(duration, timing.ts)?;
    if !(step_at.is_finite() && step_at >= 0.0 && step_at < duration) {
        return bad(
            "step-time",
            format!("expected 0 <= step time < the duration ({duration} s), got {step_at}"),
        );
    }
    let at = (step_at / timing.ts).round() as usize;
    let total = evaluated + timing.tail_samples();
    let signal = (0..total)
        .map(|k| if k < at { offset } else { offset + amplitude })
        .collect();
    Ok(with_lead_in(
        signal,
        evaluated,
        timing,
        0,
        format!("step {amplitude} um from {offset} um at {step_at} s"),
    ))
}

/// Step-tracking figures of a measured step (docs/responses.md §4).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StepTracking {
    /// The step figures of `(y - offset)/amplitude` from the step on, towards
    /// the measured final value (mean of the last 10 % of the evaluated part).
    pub info: crate::lti::response::StepInfo,
    /// The target minus the measured final value, in the reference's units
    /// (the error `r - y` left once the step has settled).
    pub steady_state_error: f64,
}

/// The step figures of `measurement` for a [`step`] reference whose step is
/// at sample `step_index`, evaluated up to `end`: times from the step,
/// values normalised by the step (`1` = the target), the final value the
/// mean of the last 10 % of samples (a measured trace has no DC gain).
pub fn step_tracking(
    measurement: &[f64],
    ts: f64,
    step_index: usize,
    end: usize,
    offset: f64,
    amplitude: f64,
) -> Result<StepTracking, crate::lti::response::NoStepInfo> {
    let y: Vec<f64> = measurement[step_index..end]
        .iter()
        .map(|v| (v - offset) / amplitude)
        .collect();
    let t: Vec<f64> = (0..y.len()).map(|k| k as f64 * ts).collect();
    let tail = &y[y.len() - (y.len() / 10).max(1)..];
    let y_final = tail.iter().sum::<f64>() / tail.len() as f64;
    let mut info = crate::lti::response::step_info(&t, &y, y_final)?;
    info.steady_state_error = 1.0 - y_final;
    Ok(StepTracking {
        info,
        steady_state_error: amplitude * (1.0 - y_final),
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod resample_checks {
    use super::resample_linear;

    pub fn a_line_resampled_is_the_same_line_and_the_same_grid_is_unchanged() {
        // r = 2 t + 1 at 1 ms, read at 0.1 ms: exact on a line.
        let t: Vec<f64> = (0..11).map(|k| k as f64 * 1e-3).collect();
        let r: Vec<f64> = t.iter().map(|t| 2.0 * t + 1.0).collect();
        let out = resample_linear(&t, &r, 1e-4).unwrap();
        assert_eq!(out.len(), 101);
        for (k, v) in out.iter().enumerate() {
            assert!(
                (v - (2.0 * k as f64 * 1e-4 + 1.0)).abs() < 1e-12,
                "{k}: {v}"
            );
        }
        assert_eq!(resample_linear(&t, &r, 1e-3).unwrap(), r);
    }

    pub fn an_absurd_length_is_refused_before_allocating() {
        let e = resample_linear(&[0.0, 1e6], &[0.0, 1.0], 1e-4).unwrap_err();
        assert!(e.contains("samples"), "{e}");
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn step_holds_the_offset_then_the_target() {
        let timing = ReferenceTiming::default();
        let r = step(2.0, 7.0, 0.01, 0.05, &timing).unwrap();
        let from = r.evaluate_from;
        assert_eq!(r.samples[from], 7.0);
        assert_eq!(r.samples[from + 99], 7.0);
        assert_eq!(r.samples[from + 100], 9.0);
        assert_eq!(*r.samples.last().unwrap(), 9.0);
        assert!(step(0.0, 7.0, 0.01, 0.05, &timing).is_err());
        assert!(step(1.0, 7.0, 0.06, 0.05, &timing).is_err());
        // A first-order lag 1 - 0.9^k towards 1: final 1, no overshoot.
        let y: Vec<f64> = (0..500)
            .map(|k| 7.0 + 2.0 * (1.0 - 0.9f64.powi(k)))
            .collect();
        let m = step_tracking(&y, 1e-4, 0, 500, 7.0, 2.0).unwrap();
        assert!(m.steady_state_error.abs() < 1e-9);
        assert_eq!(m.info.overshoot, 0.0);
        // 10 % at k = 1 (1 - 0.9), 90 % at k = 22 (0.9^22 = 0.098).
        assert!((m.info.rise_time.unwrap() - 21e-4).abs() < 1e-12);
    }

    pub fn lead_in_is_smooth_and_reaches_the_start() {
        let r = sine(5.0, 100.0, 6.0, 0.1, &ReferenceTiming::default()).unwrap();
        assert_eq!(r.samples[0], 0.0);
        // Ramp 500 samples + hold 500 at 6.0, then the sine starts at 6.0.
        assert!((r.samples[999] - 6.0).abs() < 1e-12);
        assert!((r.samples[1000] - 6.0).abs() < 1e-12);
        // 20 % of 1000 sine samples skipped (more than one 100-sample period).
        assert_eq!(r.evaluate_from, 1200);
        // 1000 evaluated samples, then the 100-sample tail continues the sine.
        assert_eq!(r.evaluate_to, 2000);
        assert_eq!(r.samples.len(), 2100);
        let w = 2.0 * PI * 100.0 * 1e-4;
        assert!((r.samples[2050] - (6.0 + 5.0 * (w * 1050.0).sin())).abs() < 1e-9);
        let max_step = r
            .samples
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(max_step < 0.32, "{max_step}");
    }

    /// The pattern is entered in motion: no step in the reference's
    /// velocity at the first evaluated sample (before the fade-in it jumped
    /// from 0 to 3.1 mm/s there), and the evaluated part is Eq. 13 itself.
    pub fn five_leaf_is_entered_with_its_own_velocity() {
        let timing = ReferenceTiming::default();
        let r = five_leaf(0.1, 7.0, 0.2, &timing).unwrap();
        let k = r.evaluate_from;
        assert_eq!(k, 1000);
        assert_eq!(r.ramp_end, 500);
        let v = |k: usize| (r.samples[k] - r.samples[k - 1]) / timing.ts;
        let pattern_v = 0.1 * 50.0 * 200.0 * PI; // um/s at t = 0
        assert!((v(k + 1) - pattern_v).abs() < 0.01 * pattern_v);
        assert!(
            (v(k) - v(k + 1)).abs() < 0.01 * pattern_v,
            "{} {}",
            v(k),
            v(k + 1)
        );
        assert!((v(k - 1) - v(k)).abs() < 0.01 * pattern_v);
        for j in [0, 37, 999] {
            let t = j as f64 * timing.ts;
            let eq13 = 7.0 + 0.1 * (50.0 - 10.0 * t) * (200.0 * PI * t).sin();
            assert!((r.samples[k + j] - eq13).abs() < 1e-12);
        }
        // The ramp ends at rest on the offset, where the fade-in starts.
        assert!((r.samples[r.ramp_end] - 7.0).abs() < 1e-12);
    }

    pub fn sweep_tail_continues_at_the_same_rate() {
        let timing = ReferenceTiming::default().with_preview(80);
        assert!((timing.tail - 0.016).abs() < 1e-12);
        let r = sweep(1.0, 0.0, 1000.0, 0.0, 0.5, &timing).unwrap();
        let plain = sweep(1.0, 0.0, 1000.0, 0.0, 0.5, &ReferenceTiming::default()).unwrap();
        assert_eq!(r.evaluated(), plain.evaluated());
        for k in plain.evaluated() {
            assert!((r.samples[k] - plain.samples[k]).abs() < 1e-9);
        }
        assert_eq!(r.samples.len() - r.evaluate_to, 160);
    }
}
