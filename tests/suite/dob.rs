//! The disturbance-observer (DOB) block with friction feedforward
//! (\[Karagoz18\]'s adaptive robust controller; `fts_runtime::DobSpec`,
//! `fts::synth::dob`, docs/contouring.md):
//! * the runtime step against the library's independent state-space
//!   simulation of the block's linear part (1e-12);
//! * a step input disturbance is rejected with the closed form
//!   `d - d_hat = p^k` (first-order `Q`, nominal model = plant, delay 1);
//! * matched friction feedforward cancels the plant's friction: the
//!   tracking error is the friction-free run's to rounding;
//! * on the \[Karagoz18\] axes with Coulomb + viscous friction and the
//!   100 um disturbance, DOB + friction feedforward axes give a lower
//!   contour RMS than PID-CC in the same conditions (circle and square).

use fts::runtime::{
    DobSpec, FeedbackSpec, RuntimeController, RuntimeSpec, SsAntiWindup, StateSpaceSpec,
};
use fts::synth::dob::{q_filter, reference_commands};
use fts::workflow::contour::{AxisKind, Contour, ContourInputs, DobSettings, PathShape};

const NO_GAIN: StateSpaceSpec<'static> = StateSpaceSpec {
    a: &[],
    b: &[],
    c: &[],
    d: 0.0,
    output_min: f64::NEG_INFINITY,
    output_max: f64::INFINITY,
    anti_windup: SsAntiWindup::None,
};

fn controller(spec: DobSpec<'_>) -> RuntimeController {
    RuntimeController::new(&RuntimeSpec {
        zpetc: None,
        hysteresis: None,
        feedback: FeedbackSpec::Dob(spec),
        repetitive: None,
    })
    .unwrap()
}

/// The plant `y(k+1) = a y(k) + b u(k)`, i.e. `z^-1 b/(1 - a z^-1)`:
/// nominal `A = 1 - a z^-1 = (1 - a) + a w`, `B = b`, delay 1.
const PLANT_A: f64 = 0.95;
const PLANT_B: f64 = 0.2;

#[test]
fn the_runtime_step_is_the_librarys_linear_simulation() {
    let ts = 1e-3;
    let (q_num, q_den) = q_filter(50.0, 2, ts).unwrap();
    // Outer controller: a PI in state space, 0.3 + 0.05/(1 - z^-1).
    let outer = StateSpaceSpec {
        a: &[1.0],
        b: &[1.0],
        c: &[0.05],
        d: 0.35,
        ..NO_GAIN
    };
    let inverse_num = [1.0 - PLANT_A, PLANT_A];
    let spec = DobSpec {
        outer,
        q_num: &q_num,
        q_den: &q_den,
        inverse_num: &inverse_num,
        inverse_den: &[PLANT_B],
        delay: 1,
        coulomb: 0.0,
        viscous: 0.0,
        smoothing: 1.0,
        ts,
    };
    let n = 400;
    let reference: Vec<f64> = (0..n).map(|k| (k as f64 * 0.03).sin()).collect();
    let measurement: Vec<f64> = (0..n)
        .map(|k| 0.8 * (k as f64 * 0.03 - 0.2).sin() + 0.1 * (k as f64 * 0.7).cos())
        .collect();
    let want = reference_commands(&spec, ts, &reference, &measurement).unwrap();
    let mut c = controller(spec);
    let mut worst = 0.0f64;
    for k in 0..n {
        let u = c.step(reference[k], measurement[k]);
        worst = worst.max((u - want[k]).abs() / want[k].abs().max(1.0));
    }
    assert!(worst < 1e-12, "runtime vs library: {worst:e}");
    // And the reset puts it back at rest.
    c.reset();
    assert!((c.step(reference[0], measurement[0]) - want[0]).abs() < 1e-15);
}

/// A unit step at the plant input from sample 0, no outer controller
/// (`u = -d_hat`), `Q = (1 - p)/(1 - p z^-1)`: the observer sees
/// `(A/B) y - z^-1 u = z^-1 d`, so `d_hat = Q z^-1 d` and the residual at
/// the plant's input is `d - d_hat = p^k`.
#[test]
fn a_step_input_disturbance_decays_with_q() {
    let ts = 1e-4;
    let (q_num, q_den) = q_filter(200.0, 1, ts).unwrap();
    let p = -q_den[1];
    let inverse_num = [1.0 - PLANT_A, PLANT_A];
    let mut c = controller(DobSpec {
        outer: NO_GAIN,
        q_num: &q_num,
        q_den: &q_den,
        inverse_num: &inverse_num,
        inverse_den: &[PLANT_B],
        delay: 1,
        coulomb: 0.0,
        viscous: 0.0,
        smoothing: 1.0,
        ts,
    });
    let mut y = 0.0;
    for k in 0..2000 {
        let u = c.step(0.0, y);
        let residual = u + 1.0;
        assert!(
            (residual - p.powi(k)).abs() < 1e-12,
            "k = {k}: {residual} vs p^k = {}",
            p.powi(k)
        );
        y = PLANT_A * y + PLANT_B * (u + 1.0);
    }
}

/// `Fc v/(|v| + v_eps) + Fv v` at the plant input, `v` the reference's
/// backward difference: with the feedforward's parameters the same, the
/// run is the friction-free one to rounding; without the feedforward it
/// is not.
#[test]
fn matched_friction_feedforward_cancels_the_friction() {
    let ts = 1e-3;
    let (fc, fv, eps) = (0.4, 0.02, 0.5);
    let (q_num, q_den) = q_filter(20.0, 2, ts).unwrap();
    let inverse_num = [1.0 - PLANT_A, PLANT_A];
    let outer = StateSpaceSpec {
        a: &[1.0],
        b: &[1.0],
        c: &[0.02],
        d: 0.5,
        ..NO_GAIN
    };
    let run = |ff: (f64, f64), friction: (f64, f64)| -> Vec<f64> {
        let mut c = controller(DobSpec {
            outer,
            q_num: &q_num,
            q_den: &q_den,
            inverse_num: &inverse_num,
            inverse_den: &[PLANT_B],
            delay: 1,
            coulomb: ff.0,
            viscous: ff.1,
            smoothing: eps,
            ts,
        });
        let (mut y, mut previous) = (0.0, 0.0);
        (0..3000)
            .map(|k| {
                let r = (k as f64 * 2e-3).sin() * 3.0;
                let v = if k == 0 { 0.0 } else { (r - previous) / ts };
                previous = r;
                let u = c.step(r, y);
                let e = r - y;
                let f = friction.0 * (v / (v.abs() + eps)) + friction.1 * v;
                y = PLANT_A * y + PLANT_B * (u - f);
                e
            })
            .collect()
    };
    let clean = run((0.0, 0.0), (0.0, 0.0));
    let cancelled = run((fc, fv), (fc, fv));
    let uncompensated = run((0.0, 0.0), (fc, fv));
    let diff = |a: &[f64]| {
        a.iter()
            .zip(&clean)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
    };
    assert!(diff(&cancelled) < 1e-12, "{:e}", diff(&cancelled));
    assert!(diff(&uncompensated) > 1e-3, "{:e}", diff(&uncompensated));
}

/// PID-CC and ARC-CC (DOB + friction feedforward) on the \[Karagoz18\]
/// axes at 30 mm/s, with the 100 um disturbance and friction at every
/// plant input: the contour RMS of each, in um.
fn contour_rms(shape: PathShape, axes: AxisKind) -> [f64; 4] {
    let mut c = Contour {
        axis_controller: axes,
        baseline: false,
        friction_coulomb: 0.02,
        friction_viscous: 2e-6,
        dob: DobSettings {
            q_hz: 5000.0,
            coulomb: 0.02,
            viscous: 2e-6,
            ..DobSettings::default()
        },
        ..Contour::default()
    };
    c.trajectory.shape = shape;
    c.trajectory.acceleration = 1.5e6;
    c.trajectory.jerk = 1.5e9;
    let m = c.run(&ContourInputs::default()).unwrap().main.run.metrics;
    [m.rms_axis[0], m.rms_axis[1], m.rms_axis[2], m.rms_contour]
}

#[test]
fn dob_with_friction_feedforward_beats_pid_cc_on_the_circle_and_the_square() {
    for shape in [PathShape::Circle, PathShape::Square] {
        let pid = contour_rms(shape, AxisKind::Pid);
        let arc = contour_rms(shape, AxisKind::Dob);
        eprintln!("{shape:?}: PID-CC {pid:?}, ARC-CC {arc:?}");
        assert!(
            arc[3] < 0.95 * pid[3],
            "{shape:?}: contour RMS {} (DOB + FF) vs {} (PID-CC)",
            arc[3],
            pid[3]
        );
    }
}

/// The manifest's `multiaxis` step writes `dob` axes on request, whose
/// file reads back to the same controllers.
#[test]
fn the_multiaxis_step_writes_dob_axes() {
    use fts::io::controller_file::{Feedback, parse_multiaxis};
    use fts::workflow::contour::BuildMultiAxis;
    let step = BuildMultiAxis {
        axis_controller: AxisKind::Dob,
        ..BuildMultiAxis::default()
    };
    let file = step
        .run([None, None, None], None, Default::default())
        .unwrap();
    assert!(file.axes.iter().all(|a| matches!(a, Feedback::Dob(_))));
    assert!(matches!(file.cross_coupling, Some(Feedback::StateSpace(_))));
    let back = parse_multiaxis(&file.to_json_string(), "k.json").unwrap();
    assert_eq!(back, file);
    let bad = BuildMultiAxis {
        axis_controller: AxisKind::Dob,
        dob: DobSettings {
            q_hz: 1e9,
            ..DobSettings::default()
        },
        ..BuildMultiAxis::default()
    };
    assert!(
        bad.run([None, None, None], None, Default::default())
            .is_err()
    );
}
