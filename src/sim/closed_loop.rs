//! Closed-loop runs of a [`RuntimeController`] on a [`Plant`], and the
//! tracking metrics of [Li21] (max and RMS error, error in % of amplitude).

use super::Plant;
use crate::runtime::RuntimeController;

/// Everything recorded in a run, one entry per controller sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Sample time, s.
    pub ts: f64,
    /// Reference `r(k)`.
    pub reference: Vec<f64>,
    /// ZPETC-filtered reference `r_f(k)` (equal to `r` without ZPETC).
    pub filtered_reference: Vec<f64>,
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

/// Runs `controller` on `plant` along `reference`; beyond its end the
/// reference is held at its last value for the controller's preview.
pub fn run<P: Plant>(
    plant: &mut P,
    controller: &mut RuntimeController,
    reference: &[f64],
) -> Trace {
    let mut trace = Trace::default();
    run_into(plant, controller, reference, &mut trace);
    trace
}

/// [`run`] into an existing trace, reusing its buffers (no allocation when
/// they are already large enough): for repeated runs and benchmarks.
pub fn run_into<P: Plant>(
    plant: &mut P,
    controller: &mut RuntimeController,
    reference: &[f64],
    trace: &mut Trace,
) {
    let n = reference.len();
    let preview = controller.preview();
    let last = reference.last().copied().unwrap_or(0.0);
    trace.ts = plant.ts();
    trace.reference.clear();
    trace.reference.extend_from_slice(reference);
    for v in [
        &mut trace.filtered_reference,
        &mut trace.feedforward,
        &mut trace.command,
        &mut trace.measurement,
        &mut trace.position,
    ] {
        v.clear();
        v.reserve(n);
    }
    for k in 0..n {
        let ahead = *reference.get(k + preview).unwrap_or(&last);
        trace.position.push(plant.true_output());
        let y = plant.measure();
        let (rf, uff, u) = controller.step_traced(ahead, y);
        plant.advance(u);
        trace.filtered_reference.push(rf);
        trace.feedforward.push(uff);
        trace.command.push(u);
        trace.measurement.push(y);
    }
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
