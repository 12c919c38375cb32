//! Closed-loop runs of a [`RuntimeController`] on a [`Plant`], and the
//! tracking metrics of \[Li21\] (max and RMS error, error in % of amplitude).

use super::Plant;
use crate::runtime::RuntimeController;

/// Everything recorded in a run, one entry per controller sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Sample time, s.
    pub ts: f64,
    /// Reference `r(k)`.
    pub reference: Vec<f64>,
    /// The loop's reference `r_f(k) + c(k)`: the ZPETC-filtered reference
    /// (`r` without ZPETC) plus the learning correction.
    pub filtered_reference: Vec<f64>,
    /// The learning correction `c(k)`: repetitive output plus learned
    /// feedforward (0 without either).
    pub correction: Vec<f64>,
    /// Feedforward `u_ff(k)`.
    pub feedforward: Vec<f64>,
    /// Command `u(k)`.
    pub command: Vec<f64>,
    /// Measurement `y(k)` (with sensor noise).
    pub measurement: Vec<f64>,
    /// True displacement `x(k)`, for plots.
    pub position: Vec<f64>,
}

impl Trace {
    /// Tracking error `e(k) = r(k) - y(k)` as the sensor sees it.
    pub fn error(&self) -> Vec<f64> {
        self.reference
            .iter()
            .zip(&self.measurement)
            .map(|(r, y)| r - y)
            .collect()
    }
}

/// A measurement this many times the reference's peak (plus one) means the
/// loop has run away: no tracking loop fts builds gets there while stable.
pub const DIVERGENCE_FACTOR: f64 = 1e6;

/// Where a run left the finite, bounded world, and in which signal.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the closed loop diverged at t = {time_s:.6} s (sample {sample}): {signal} = {value:e}{}",
    if value.is_finite() { " (beyond the divergence bound)" } else { "" }
)]
pub struct Divergence {
    /// 0-based sample.
    pub sample: usize,
    /// Its time, s.
    pub time_s: f64,
    /// Which signal: `measurement`, `command`, `feedforward` or `filtered reference`.
    pub signal: &'static str,
    /// Its value there.
    pub value: f64,
}

/// Runs `controller` on `plant` along `reference`; beyond its end the
/// reference is held at its last value for the controller's preview. A run
/// whose signals stop being finite, or whose measurement exceeds
/// [`DIVERGENCE_FACTOR`] times the reference's peak, stops there with a
/// [`Divergence`]: its metrics would be meaningless.
pub fn run<P: Plant>(
    plant: &mut P,
    controller: &mut RuntimeController,
    reference: &[f64],
) -> Result<Trace, Divergence> {
    run_learned(plant, controller, reference, &[])
}

/// [`run`] with a learned feedforward `learned[k]` (an ILC table; 0 past
/// its end) added to the loop's reference at sample `k`.
pub fn run_learned<P: Plant>(
    plant: &mut P,
    controller: &mut RuntimeController,
    reference: &[f64],
    learned: &[f64],
) -> Result<Trace, Divergence> {
    let mut trace = Trace::default();
    run_into(plant, controller, reference, learned, &mut trace)?;
    Ok(trace)
}

/// The first signal of a sample that is not finite, or a measurement beyond `bound`.
fn diverged(y: f64, rf: f64, uff: f64, u: f64, bound: f64) -> Option<(&'static str, f64)> {
    [
        ("measurement", y),
        ("filtered reference", rf),
        ("feedforward", uff),
        ("command", u),
    ]
    .into_iter()
    .find(|(_, v)| !v.is_finite())
    .or((y.abs() > bound).then_some(("measurement", y)))
}

/// [`run`] into an existing trace, reusing its buffers (no allocation when
/// they are already large enough): for repeated runs and benchmarks. On a
/// divergence the trace holds the samples up to and including it.
pub fn run_into<P: Plant>(
    plant: &mut P,
    controller: &mut RuntimeController,
    reference: &[f64],
    learned: &[f64],
    trace: &mut Trace,
) -> Result<(), Divergence> {
    let n = reference.len();
    let preview = controller.preview();
    let last = reference.last().copied().unwrap_or(0.0);
    trace.ts = plant.ts();
    trace.reference.clear();
    trace.reference.extend_from_slice(reference);
    for v in [
        &mut trace.filtered_reference,
        &mut trace.correction,
        &mut trace.feedforward,
        &mut trace.command,
        &mut trace.measurement,
        &mut trace.position,
    ] {
        v.clear();
        v.reserve(n);
    }
    let peak = reference.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let bound = DIVERGENCE_FACTOR * (1.0 + peak);
    for k in 0..n {
        let ahead = *reference.get(k + preview).unwrap_or(&last);
        trace.position.push(plant.true_output());
        let y = plant.measure();
        let f = learned.get(k).copied().unwrap_or(0.0);
        let s = controller.step_signals(ahead, y, f);
        let (rf, uff, u) = (s.filtered + s.correction, s.feedforward, s.command);
        trace.filtered_reference.push(rf);
        trace.correction.push(s.correction);
        trace.feedforward.push(uff);
        trace.command.push(u);
        trace.measurement.push(y);
        if let Some((signal, value)) = diverged(y, rf, uff, u, bound) {
            trace.reference.truncate(k + 1);
            return Err(Divergence {
                sample: k,
                time_s: k as f64 * trace.ts,
                signal,
                value,
            });
        }
        plant.advance(u);
    }
    Ok(())
}

/// Tracking figures over the evaluated window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingMetrics {
    /// `max |e|` over the window, reference units.
    pub max_abs_error: f64,
    /// RMS of `e` over the window.
    pub rms_error: f64,
    /// `100 max|e| / amplitude`.
    pub max_error_percent: f64,
    /// The amplitude used: half the peak-to-peak of the reference in the window.
    pub amplitude: f64,
    /// First sample of the window.
    pub start: usize,
    /// Samples in the window.
    pub samples: usize,
    /// Samples of the window where the command sat on a limit: the
    /// reference asked for more than the actuator can give.
    pub saturated_samples: usize,
}

/// The largest `|e|` over each whole period of `period` samples (may be
/// fractional: period `p` covers `round(p T) .. round((p + 1) T)`) from
/// sample `from` on: how a repetitive compensator's error contracts.
pub fn max_error_per_period(error: &[f64], from: usize, period: f64) -> Vec<f64> {
    if !(period.is_finite() && period >= 1.0) {
        return Vec::new();
    }
    let edge = |p: usize| from + (p as f64 * period).round() as usize;
    (0..)
        .map(|p| (edge(p), edge(p + 1)))
        .take_while(|&(_, end)| end <= error.len())
        .map(|(start, end)| error[start..end].iter().fold(0.0f64, |m, e| m.max(e.abs())))
        .collect()
}

/// Metrics over `trace[window]`; `limits` are the command limits, to count saturation.
pub fn metrics(
    trace: &Trace,
    window: std::ops::Range<usize>,
    limits: (f64, f64),
) -> TrackingMetrics {
    let n = trace.reference.len();
    let end = window.end.min(n);
    let start = window.start.min(end);
    let e: Vec<f64> = trace.error()[start..end].to_vec();
    let window = &trace.reference[start..end];
    let (lo, hi) = window
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &r| {
            (lo.min(r), hi.max(r))
        });
    let amplitude = if window.is_empty() {
        0.0
    } else {
        0.5 * (hi - lo)
    };
    let max_abs_error = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let rms_error = crate::ident::metrics::rms(&e);
    TrackingMetrics {
        max_abs_error,
        rms_error,
        max_error_percent: if amplitude > 0.0 {
            100.0 * max_abs_error / amplitude
        } else {
            f64::NAN
        },
        amplitude,
        start,
        samples: e.len(),
        saturated_samples: trace.command[start..end]
            .iter()
            .filter(|&&u| u <= limits.0 || u >= limits.1)
            .count(),
    }
}

/// One harmonic of a periodic tracking error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ErrorHarmonic {
    /// Multiple of the fundamental (1 = the fundamental).
    pub order: usize,
    /// Frequency, Hz.
    pub freq: f64,
    /// Peak amplitude, reference units.
    pub amplitude: f64,
}

/// The error's first `orders` harmonics of `fundamental_hz`: each the
/// amplitude `2/N |sum e_k e^{-j w k ts}|` over the longest part of `window`
/// that spans a whole number of the fundamental's periods (to the nearest
/// sample), where the harmonics are orthogonal to each other and to a
/// constant. `None` when the window holds less than one period.
pub fn error_harmonics(
    trace: &Trace,
    window: std::ops::Range<usize>,
    fundamental_hz: f64,
    orders: usize,
) -> Option<Vec<ErrorHarmonic>> {
    let ts = trace.ts;
    let periods = ((window.len() as f64) * fundamental_hz * ts).floor();
    let n = (periods / (fundamental_hz * ts)).round() as usize;
    if periods < 1.0 || n == 0 || n > window.len() {
        return None;
    }
    let start = window.start;
    let error: Vec<f64> = (start..start + n)
        .map(|k| trace.reference[k] - trace.measurement[k])
        .collect();
    Some(
        (1..=orders)
            .map(|order| {
                let w = 2.0 * std::f64::consts::PI * fundamental_hz * order as f64 * ts;
                let (c, s) = error.iter().enumerate().fold((0.0, 0.0), |(c, s), (i, e)| {
                    let phase = w * (start + i) as f64;
                    (c + e * phase.cos(), s + e * phase.sin())
                });
                ErrorHarmonic {
                    order,
                    freq: fundamental_hz * order as f64,
                    amplitude: 2.0 * c.hypot(s) / n as f64,
                }
            })
            .collect(),
    )
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn period_maxima_follow_fractional_edges() {
        let e: Vec<f64> = (0..12)
            .map(|k| if k % 2 == 0 { -(k as f64) } else { 0.5 })
            .collect();
        // From 1, periods of 2.5 samples: [1, 4), [4, 6), [6, 9), [9, 11).
        assert_eq!(max_error_per_period(&e, 1, 2.5), vec![2.0, 4.0, 8.0, 10.0]);
        assert!(max_error_per_period(&e, 0, 0.5).is_empty());
        assert!(max_error_per_period(&e, 20, 2.0).is_empty());
    }
    use crate::lti::DiscreteTf;
    use crate::runtime::{FeedbackSpec, PidSpec, RuntimeSpec};
    use crate::sim::ModelPlant;

    fn pid() -> RuntimeController {
        RuntimeController::new(&RuntimeSpec {
            zpetc: None,
            hysteresis: None,
            feedback: FeedbackSpec::Pid(PidSpec {
                kp: 0.02,
                ki: 0.15,
                kd: 0.0,
                output_min: 0.0,
                output_max: 10.0,
            }),
            repetitive: None,
        })
        .unwrap()
    }

    /// An unstable plant under a saturating PID: the measurement grows as
    /// 1.05^k; the run stops where it first exceeds the bound, and the
    /// trace ends there.
    pub fn divergence_stops_the_run_at_the_bound() {
        let g = DiscreteTf::new(vec![0.1], vec![1.0, -1.05], 1, 1e-4).unwrap();
        let mut plant = ModelPlant::new(&g, None, (0.0, 10.0), 0.0, 1).unwrap();
        let reference = vec![1.0; 5000];
        let d = run(&mut plant, &mut pid(), &reference).unwrap_err();
        assert_eq!(d.signal, "measurement");
        assert!(d.value.abs() > DIVERGENCE_FACTOR * 2.0, "{d}");
        assert!(d.sample > 100 && d.sample < 1000, "{d}");
        assert!((d.time_s - d.sample as f64 * 1e-4).abs() < 1e-15);
        // A stable plant runs to the end.
        let g = DiscreteTf::new(vec![0.1], vec![1.0, -0.5], 1, 1e-4).unwrap();
        let mut plant = ModelPlant::new(&g, None, (0.0, 10.0), 0.0, 1).unwrap();
        let trace = run(&mut plant, &mut pid(), &reference).unwrap();
        assert_eq!(trace.measurement.len(), 5000);
    }

    /// A constant plus three harmonics of 100 Hz at 10 kHz come back to
    /// rounding: the window spans whole periods, where they are orthogonal.
    pub fn error_harmonics_recover_a_known_periodic_error() {
        let ts = 1e-4;
        let w = 2.0 * std::f64::consts::PI * 100.0 * ts;
        let n = 1234;
        let measurement: Vec<f64> = (0..n)
            .map(|k| {
                let p = w * k as f64;
                -(0.2 + 0.3 * p.sin() + 0.1 * (2.0 * p).cos() + 0.05 * (3.0 * p + 1.0).sin())
            })
            .collect();
        let trace = Trace {
            ts,
            reference: vec![0.0; n],
            filtered_reference: vec![0.0; n],
            correction: vec![0.0; n],
            feedforward: vec![0.0; n],
            command: vec![0.0; n],
            position: measurement.clone(),
            measurement,
        };
        let h = error_harmonics(&trace, 17..n, 100.0, 4).unwrap();
        for (got, want) in h.iter().zip([0.3, 0.1, 0.05, 0.0]) {
            assert!((got.amplitude - want).abs() < 1e-12, "{got:?} vs {want}");
        }
        assert_eq!(h[2].freq, 300.0);
        assert!(error_harmonics(&trace, 0..50, 100.0, 3).is_none());
    }
}
