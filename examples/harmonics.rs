//! Where the PID + HC + ZPEC tracking error of the \[Li21\] experiment comes
//! from (docs/li21-experiment.md): 5 um sines through the identified loop,
//! their error split into the fundamental and the 2nd/3rd harmonics, and the
//! 0-1000 Hz sweep with and without the virtual FTS's hysteresis.
//!
//!     cargo run --release --example harmonics

use fts::io::controller_file::{ControllerFile, Provenance};
use fts::sim::experiment::{ExperimentParams, build_controller, identify_models, track};
use fts::sim::reference::{self, ReferenceTiming};
use fts::synth::composite::Stages;
use std::f64::consts::PI;

/// Amplitude of the `f` Hz component of `e` (least squares over whole periods
/// is what the window approximates; the window spans many periods).
fn component(e: &[f64], f: f64, ts: f64, start: usize) -> f64 {
    let (mut c, mut s) = (0.0, 0.0);
    for (k, v) in e.iter().enumerate() {
        let w = 2.0 * PI * f * ts * (start + k) as f64;
        c += v * w.cos();
        s += v * w.sin();
    }
    2.0 * (c * c + s * s).sqrt() / e.len() as f64
}

/// The identified PID + HC + ZPEC controller and references timed for its preview.
fn full_controller(
    params: &ExperimentParams,
) -> Result<(ControllerFile, ReferenceTiming), Box<dyn std::error::Error>> {
    let models = identify_models(params, &mut |_| {})?;
    let controller = build_controller(
        Stages::parse("pid+hc+zpec")?,
        params.plant.ts,
        params.pid,
        Some(&models.inverse.model),
        Some(&models.zpetc),
        Provenance::default(),
    )?;
    let timing = ReferenceTiming {
        ts: params.plant.ts,
        ..ReferenceTiming::default()
    }
    .with_preview(models.zpetc.preview);
    Ok((controller, timing))
}

fn sweep_error(params: &ExperimentParams) -> Result<f64, Box<dyn std::error::Error>> {
    let (controller, timing) = full_controller(params)?;
    let sweep = reference::sweep(5.0, 0.0, 1000.0, params.offset, 2.0, &timing)?;
    Ok(track(params, 77, &controller, &sweep)?.1.max_error_percent)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let params = ExperimentParams::default();
    let ts = params.plant.ts;
    let (controller, timing) = full_controller(&params)?;
    println!("5 um sines, PID + HC + ZPEC: max error and its components (um)");
    println!("  freq     max   fundamental   2nd harm.   3rd harm.");
    for f in [100.0, 300.0, 500.0, 700.0, 1000.0] {
        let sine = reference::sine(5.0, f, params.offset, (40.0 / f).max(0.2), &timing)?;
        let (trace, metrics) = track(&params, 78, &controller, &sine)?;
        let window = sine.evaluated();
        let e: Vec<f64> = trace.error()[window.clone()].to_vec();
        println!(
            "  {f:>4} Hz {:>6.3} {:>11.3} {:>11.3} {:>11.3}",
            metrics.max_abs_error,
            component(&e, f, ts, window.start),
            component(&e, 2.0 * f, ts, window.start),
            component(&e, 3.0 * f, ts, window.start),
        );
    }
    println!(
        "0-1000 Hz sweep, 5 um: {:.1} % of the amplitude",
        sweep_error(&params)?
    );
    let mut linear = ExperimentParams::default();
    linear.plant.piezo.alpha = 0.0;
    linear.plant.piezo.quadratic_um_per_v2 = 0.0;
    println!(
        "the same with the plant's hysteresis switched off: {:.2} %",
        sweep_error(&linear)?
    );
    Ok(())
}
