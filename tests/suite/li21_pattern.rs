//! The \[Li21\] pattern on the virtual FTS with models identified honestly from
//! simulated measurements (math.md 4): at 500 Hz PID+HC+ZPEC is far better
//! than PID+HC; at 10 Hz hysteresis compensation does most of the work; the
//! five-leaved trajectory stays within the paper's 0.3 um. With iterative
//! learning control on top (step 5), the sweep ends below 1 % of the
//! amplitude and the five-leaved trajectory below 0.05 um within 10
//! trials (issue 16).

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
    // [Li21] Eq. 8's filter on the same model (docs/li21-experiment.md, the
    // Eq.8 column): its phase-only cancellation of the zero outside the
    // unit circle leaves |G_z G_c| = |B_u|^2/B_u(1)^2 != 1, so it is worse
    // than the exact inversion at 500 Hz and on the sweep (measured 0.526
    // against 0.313 um, 37 % against 12.5 %), alike at 10 Hz.
    let eq8 = fts::sim::experiment::EQ8_STAGES;
    assert!(get("500 Hz", eq8) > 1.3 * get("500 Hz", "pid+hc+zpec"));
    assert!((get("10 Hz", eq8) / get("10 Hz", "pid+hc+zpec") - 1.0).abs() < 0.1);
    let sweep_eq8 = result
        .table
        .iter()
        .find(|r| r.reference.starts_with("sweep") && r.controller == eq8)
        .unwrap()
        .metrics;
    assert!(sweep_eq8.max_error_percent > 2.0 * sweep.max_error_percent);
    // Five-leaved trajectory below 0.3 um with the full controller.
    assert!(get("five-leaf", "pid+hc+zpec") < 0.3);
    // Step 5: ILC designed on the identified wide-band model, 10 trials.
    let learning = result.learning.as_ref().expect("step 5 runs by default");
    assert!(learning.design.rho < 1.0, "{}", learning.design.rho);
    assert_eq!(learning.trials_run(), 10);
    let trials = |name: &str| {
        &learning
            .references
            .iter()
            .find(|r| r.reference.starts_with(name))
            .unwrap_or_else(|| panic!("{name} not learned"))
            .trials
    };
    // Trial 0 is the PID + HC + ZPEC loop again (fresh noise): the same figure.
    let sweep_trials = trials("sweep");
    assert!((sweep_trials[0].max_error_percent - sweep.max_error_percent).abs() < 0.5);
    let last = sweep_trials.last().unwrap();
    assert!(last.max_error_percent < 1.0, "{last:?}");
    assert_eq!(last.saturated_samples, 0);
    let five_leaf = trials("five-leaf").last().unwrap();
    assert!(five_leaf.max_abs_error < 0.05, "{five_leaf:?}");
    // Every reference ends at least 5 times below its unlearned error, and
    // the table's +ILC row is the last trial.
    for r in &learning.references {
        let (first, last) = (r.trials[0], *r.trials.last().unwrap());
        assert!(
            last.max_abs_error < 0.2 * first.max_abs_error,
            "{}: {first:?} {last:?}",
            r.reference
        );
        assert_eq!(get(&r.reference, "pid+hc+zpec+ilc"), last.max_abs_error);
    }
    let model = result.models.learning.as_ref().unwrap();
    assert!(model.model.chosen_fit().simulation_percent > 90.0);
    // The models were identified, not copied: the closed-loop model fits its sweep.
    assert!(result.models.closed_loop.arx_fit.simulation_percent > 80.0);
    assert!(result.models.inverse.info.fit.rms_percent < 2.0);
}
