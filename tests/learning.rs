//! Repetitive and iterative learning control on a linear plant whose
//! closed loop is known exactly: `P = 0.2 z^-1 / (1 - 0.8 z^-1)` under the
//! \[Li21\] PID `kp 0.3, ki 0.1` (derivative 0), `T = P C / (1 + P C)` with
//! `C = kp + ki / (1 - z^-1)`.

use fts::io::controller_file::RepetitiveBlock;
use fts::lti::DiscreteTf;
use fts::sim::disturbance::Disturbance;
use fts::workflow::learning::{DesignRepetitive, Ilc};
use fts::workflow::{
    ReferenceShape, SimController, SimPlant, Simulate, SimulateInputs, StageModels,
};

const TS: f64 = 1e-4;

fn plant() -> DiscreteTf {
    DiscreteTf::new(vec![0.2], vec![1.0, -0.8], 1, TS).unwrap()
}

/// The loop reference to output, exactly.
fn closed_loop() -> DiscreteTf {
    let (kp, ki) = (0.3, 0.1);
    let c = DiscreteTf::new(vec![kp + ki, -kp], vec![1.0, -1.0], 0, TS).unwrap();
    let one = DiscreteTf::new(vec![1.0], vec![1.0], 0, TS).unwrap();
    plant().series(&c).feedback(&one)
}

fn simulate(disturbance: Option<Disturbance>) -> Simulate {
    // A sine at 100 Hz is spindle-synchronous too (a turned part's profile).
    let freq = if disturbance.is_some() { 100.0 } else { 37.0 };
    Simulate {
        controller: Some("pid".into()),
        reference: ReferenceShape::Sine,
        amplitude: 1.0,
        freq,
        offset: 5.0,
        duration: Some(0.4),
        kp: 0.3,
        ki: 0.1,
        kd: 0.0,
        output_disturbance: disturbance,
        ..Simulate::default()
    }
}

fn inputs(repetitive: Option<RepetitiveBlock>) -> SimulateInputs {
    SimulateInputs {
        plant: SimPlant::Model {
            tf: plant(),
            hysteresis: None,
            source: "P".into(),
        },
        controller: SimController::Stages(StageModels {
            repetitive,
            ..StageModels::default()
        }),
        reference_samples: None,
    }
}

/// A 100 Hz spindle-synchronous disturbance of 1 (with 2nd and 3rd
/// harmonics) on the output: the repetitive compensator designed on `T`
/// removes it at least 20 times better than the loop alone.
#[test]
fn repetitive_control_rejects_a_spindle_disturbance() {
    let d = Disturbance::parse("spindle:1@100,0.5,0.25").unwrap();
    let design = DesignRepetitive {
        spindle_hz: Some(100.0),
        q_cutoff: Some(2000.0),
        q_taps: 16,
        ..DesignRepetitive::default()
    }
    .run(&closed_loop())
    .unwrap();
    assert!(design.design.rho < 1.0);
    // Eq. (2) predicts removal at the harmonics Q passes.
    assert!(
        design.design.harmonics[0].ratio < 1e-2,
        "{:?}",
        design.design.harmonics[0]
    );
    let without = simulate(Some(d.clone())).run(inputs(None)).unwrap();
    let with = simulate(Some(d))
        .run(inputs(Some(design.block.clone())))
        .unwrap();
    let (a, b) = (without.metrics.rms_error, with.metrics.rms_error);
    assert!(
        a > 0.1,
        "the disturbance shows without the compensator: {a}"
    );
    assert!(a / b > 20.0, "rms {a} without, {b} with");
}

/// The design refuses a gain for which the stability condition fails,
/// naming the condition.
#[test]
fn repetitive_design_refuses_a_failing_condition() {
    let e = DesignRepetitive {
        spindle_hz: Some(100.0),
        gain: 3.0,
        ..DesignRepetitive::default()
    }
    .run(&closed_loop())
    .unwrap_err();
    assert!(e.to_string().contains("stability condition fails"), "{e}");
}

/// ILC with the exact closed loop: the error of a repeated sine falls by
/// orders of magnitude within five trials, monotonically.
#[test]
fn ilc_converges_on_the_exact_model() {
    let report = Ilc {
        trials: 5,
        q_cutoff: 4000.0,
        ..Ilc::default()
    }
    .run(
        &simulate(None),
        inputs(None),
        Some(closed_loop()),
        &mut |_| {},
        &mut |_| {},
    )
    .unwrap();
    let e: Vec<f64> = report.trials.iter().map(|t| t.max_error).collect();
    assert!(e[0] > 0.01, "{e:?}");
    assert!(e[5] < e[0] * 1e-3, "{e:?}");
    // Monotonic (to round-off once converged).
    assert!(e.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-6)), "{e:?}");
    let table = report.controller.feedforward_table.as_ref().unwrap();
    assert_eq!(table.samples.len(), report.trace.reference.len());
}

/// A learning gain beyond 2 fails the convergence condition: refused,
/// and when run anyway the error grows from trial to trial as predicted.
#[test]
fn ilc_refuses_a_diverging_law_and_diverges_when_forced() {
    let ilc = Ilc {
        trials: 3,
        gain: 2.6,
        q_cutoff: 4000.0,
        ..Ilc::default()
    };
    let e = ilc
        .run(
            &simulate(None),
            inputs(None),
            Some(closed_loop()),
            &mut |_| {},
            &mut |_| {},
        )
        .unwrap_err();
    assert!(e.to_string().contains("convergence condition fails"), "{e}");
    let forced = Ilc {
        allow_divergence: true,
        ..ilc
    }
    .run(
        &simulate(None),
        inputs(None),
        Some(closed_loop()),
        &mut |_| {},
        &mut |_| {},
    )
    .unwrap();
    assert!(forced.diverging);
    let e: Vec<f64> = forced.trials.iter().map(|t| t.max_error).collect();
    // rho = |1 - 2.6| = 1.6 per trial where Q passes.
    assert!(e[3] > 2.0 * e[1], "{e:?}");
}
