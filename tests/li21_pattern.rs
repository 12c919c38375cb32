//! The \[Li21\] pattern on the virtual FTS with models identified honestly from
//! simulated measurements (math.md 4): at 500 Hz PID+HC+ZPEC is far better
//! than PID+HC; at 10 Hz hysteresis compensation does most of the work; the
//! five-leaved trajectory stays within the paper's 0.3 um.

use fts::sim::experiment::{ExperimentParams, run};

#[test]
fn li21_tracking_pattern() {
    let result = run(&ExperimentParams::default(), &mut |_| {}).unwrap();
    let get = |reference: &str, controller: &str| {
        result
            .table
            .iter()
            .find(|r| r.reference.contains(reference) && r.controller == controller)
            .unwrap_or_else(|| panic!("{reference} {controller} missing"))
            .metrics
            .max_abs_error
    };
    // 500 Hz: ZPEC at least halves the error of PID + HC (Li21: 0.39 vs 6.78 um).
    assert!(get("500 Hz", "pid+hc+zpec") < 0.5 * get("500 Hz", "pid+hc"));
    // 10 Hz: HC cuts the PID error by more than half (Li21: 0.064 vs 0.198 um)
    // and ZPEC adds little there (Li21: 0.085, slightly worse than HC alone).
    assert!(get("10 Hz", "pid+hc") < 0.5 * get("10 Hz", "pid"));
    assert!(get("10 Hz", "pid+hc+zpec") < 0.5 * get("10 Hz", "pid"));
    // 100 Hz: each stage helps.
    assert!(get("100 Hz", "pid+hc") < get("100 Hz", "pid"));
    assert!(get("100 Hz", "pid+hc+zpec") < get("100 Hz", "pid+hc"));
    // The 0-1000 Hz sweep: 12.5 % of the amplitude measured (docs/li21-experiment.md
    // says why not Li21's 10 %); 15 % catches a regression of the ZPETC (classical
    // ZPETC gave 48 %) without pinning the noise-level digits.
    let sweep = result
        .table
        .iter()
        .find(|r| r.reference.starts_with("sweep") && r.controller == "pid+hc+zpec")
        .unwrap()
        .metrics;
    assert!(sweep.max_error_percent < 15.0, "{sweep:?}");
    assert_eq!(sweep.saturated_samples, 0);
    // Five-leaved trajectory below 0.3 um with the full controller.
    assert!(get("five-leaf", "pid+hc+zpec") < 0.3);
    // The models were identified, not copied: the closed-loop model fits its sweep.
    assert!(result.models.closed_loop.arx_fit.simulation_percent > 80.0);
    assert!(result.models.inverse.info.fit.rms_percent < 2.0);
}
