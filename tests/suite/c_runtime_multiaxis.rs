//! The multi-axis controller file runs the same commands everywhere
//! (docs/contouring.md "The runtime step"): the \[Karagoz18\] loop is
//! simulated (`fts::sim::contour`, through `fts_runtime::CrossCoupledStep`)
//! for 2e5 samples with every signal the step saw recorded; then
//! * the file written as JSON and read back drives a fresh Rust step over
//!   the recorded references, tangents and measurements: every command has
//!   the simulation's bits;
//! * `fts emit --multiaxis --format c` writes the C twin, compiled with the
//!   system C compiler (`$CC`, else `cc`) with `examples/c/fts_multiaxis_loop.c`:
//!   every command has the simulation's bits too.
//!
//! The file mixes every controller kind: a filtered parallel PID with
//! limits that the run reaches (anti-windup), the Tustin state-space
//! realisation of the Table 2 PID, a \[Li21\]-form PID, and a filtered PID
//! as the coupling. Without a C compiler the C half says so on stderr.

use crate::common::cc;

use crate::common::cmd::fts;
use fts::io::controller_file::{
    Feedback, MultiAxisControllerFile, ParallelPid, parse_multiaxis, to_multiaxis_c_header,
};
use fts::lti::ss::StateSpace;
use fts::runtime::PidSpec;
use fts::sim::contour::{
    AxisController, DobAxis, KARAGOZ18_AXIS_PID, KARAGOZ18_CC_PID, KARAGOZ18_PLANTS, LoopSample,
    MultiAxisLoop, controller_file, record,
};
use fts::sim::disturbance::Sine;
use fts::sim::path::{MotionLimits, Path as Geometry, Shape, Trajectory};
use std::path::{Path, PathBuf};
use std::process::Command;

const SAMPLES: usize = 200_000;
const TS: f64 = 1e-6;
/// The X command's limits: the run spends about 64 % of its samples on them.
const X_LIMIT: f64 = 0.5;

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn parallel(p: f64, i: f64, d: f64, n: f64, limit: f64) -> ParallelPid {
    ParallelPid {
        kp: p,
        ki: i,
        kd: d,
        n: Some(n),
        output_min: -limit,
        output_max: limit,
    }
}

fn file() -> MultiAxisControllerFile {
    let block = |f: Feedback| AxisController::Block {
        feedback: Box::new(f),
        ts: TS,
    };
    let x = block(Feedback::ParallelPid(parallel(
        1.0, 0.01, 0.0005, 100.0, X_LIMIT,
    )));
    let y = AxisController::Pid(KARAGOZ18_AXIS_PID[1]);
    let z = block(Feedback::Pid(PidSpec {
        kp: 1.0,
        ki: 0.01 * TS,
        kd: 0.0,
        output_min: -1e3,
        output_max: 1e3,
    }));
    let cc = block(Feedback::ParallelPid(parallel(
        0.4, 0.005, 0.0005, 100.0, 1e3,
    )));
    controller_file([&x, &y, &z], Some(&cc), TS, Default::default()).unwrap()
}

/// Three DOB axes (the Table 2 PIDs inside observers with friction
/// feedforward; Q at 2 kHz, so that its dynamics matter within the run)
/// and the Table 2 coupling.
fn dob_file() -> MultiAxisControllerFile {
    let axes = [0, 1, 2].map(|i| {
        let (num, den) = KARAGOZ18_PLANTS[i];
        AxisController::Dob(Box::new(DobAxis {
            pid: KARAGOZ18_AXIS_PID[i],
            nominal: StateSpace::from_tf(num, den, None).unwrap(),
            q_hz: 2000.0,
            q_order: 2,
            coulomb: 0.01,
            viscous: 1e-6,
            smoothing: 10.0,
        }))
    });
    let cc = AxisController::Pid(KARAGOZ18_CC_PID);
    controller_file(
        [&axes[0], &axes[1], &axes[2]],
        Some(&cc),
        TS,
        Default::default(),
    )
    .unwrap()
}

fn simulate(file: &MultiAxisControllerFile) -> Vec<LoopSample> {
    let disturbance = vec![Sine {
        amplitude: 100.0,
        freq_hz: 75.0 / (2.0 * std::f64::consts::PI),
        phase_deg: 0.0,
    }];
    let plants = KARAGOZ18_PLANTS.map(|(num, den)| {
        (
            StateSpace::from_tf(num, den, None).unwrap(),
            disturbance.clone(),
        )
    });
    let path = Geometry::new(Shape::Circle { diameter: 5000.0 }, 45.0).unwrap();
    let limits = MotionLimits {
        velocity: 30000.0,
        acceleration: 1.5e6,
        jerk: 1.5e9,
    };
    let traj = Trajectory::plan(path, limits).unwrap();
    let mut lp = MultiAxisLoop::from_file(plants, file.clone()).unwrap();
    record(&mut lp, &traj, SAMPLES)
}

fn assert_same_bits(name: &str, got: &[[f64; 3]], want: &[LoopSample]) {
    assert_eq!(got.len(), want.len(), "{name}: one command per sample");
    for (k, (a, b)) in got.iter().zip(want).enumerate() {
        for (i, (got, want)) in a.iter().zip(&b.command).enumerate() {
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{name}: u_{i} differs at sample {k}: {got:e} vs the simulation's {want:e}"
            );
        }
    }
}

fn compiler() -> Option<String> {
    cc::compiler("the multi-axis C step")
}

fn write_trace(path: &Path, rec: &[LoopSample]) {
    use std::fmt::Write;
    let mut s = String::from("x_ref,y_ref,z_ref,t_x,t_y,t_z,x,y,z\n");
    for r in rec {
        let v = [r.reference, r.tangent, r.measurement].concat();
        let row: Vec<String> = v.iter().map(f64::to_string).collect();
        let _ = writeln!(s, "{}", row.join(","));
    }
    std::fs::write(path, s).unwrap();
}

fn c_commands(cc: &str, dir: &Path, rec: &[LoopSample]) -> Vec<[f64; 3]> {
    let exe = dir.join("loop3");
    let out = Command::new(cc)
        .args(["-std=c99", "-O2", "-ffp-contract=off"])
        .args(["-Wall", "-Wextra", "-pedantic", "-Werror", "-I"])
        .arg(dir)
        .arg(repo("examples/c/fts_multiaxis_loop.c"))
        .arg(dir.join("fts_runtime.c"))
        .arg("-o")
        .arg(&exe)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{cc} failed:\n{stderr}");
    write_trace(&dir.join("trace.csv"), rec);
    let out = Command::new(&exe)
        .arg(dir.join("trace.csv"))
        .arg(dir.join("commands.csv"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "loop3 failed: {stderr}");
    let text = std::fs::read_to_string(dir.join("commands.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("k,u_x,u_y,u_z"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').skip(1).map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

#[test]
fn the_file_the_rust_step_and_the_c_step_give_the_simulations_commands() {
    let file = file();
    let rec = simulate(&file);
    // The X controller reached its limits (the anti-windup branch): its
    // own command is the step's without the coupling, from the same signals.
    let uncoupled = MultiAxisControllerFile {
        cross_coupling: None,
        ..file.clone()
    };
    let mut axes_only = uncoupled.runtime_step().unwrap();
    let saturated = rec
        .iter()
        .filter(|s| axes_only.step(&s.reference, &s.tangent, &s.measurement)[0].abs() == X_LIMIT)
        .count();
    assert!(
        saturated > 1000 && SAMPLES - saturated > 1000,
        "{saturated} of {SAMPLES} samples at the X limits: both branches must be run"
    );
    everywhere(&file, &rec);
    eprintln!("{SAMPLES} samples, {saturated} at the X limits");
}

#[test]
fn a_dob_file_gives_the_simulations_commands_in_rust_and_c() {
    let file = dob_file();
    assert!(file.axes.iter().all(|a| matches!(a, Feedback::Dob(_))));
    let rec = simulate(&file);
    everywhere(&file, &rec);
}

/// The file through JSON, the Rust step, `fts emit` and the C step: every
/// command has the simulation's bits.
fn everywhere(file: &MultiAxisControllerFile, rec: &[LoopSample]) {
    assert!(rec.iter().all(|s| s.command.iter().all(|u| u.is_finite())));

    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("controller-3axis.json");
    std::fs::write(&json, file.to_json_string()).unwrap();
    let back = parse_multiaxis(&std::fs::read_to_string(&json).unwrap(), "k.json").unwrap();
    assert_eq!(&back, file);
    let mut step = back.runtime_step().unwrap();
    let replayed: Vec<[f64; 3]> = rec
        .iter()
        .map(|s| step.step(&s.reference, &s.tangent, &s.measurement))
        .collect();
    assert_same_bits("the file's Rust step", &replayed, rec);

    // fts emit: the same header as the library writes, and the JSON again byte for byte.
    let header = fts()
        .args(["emit", "--format", "c-header", "--multiaxis"])
        .arg(&json)
        .output()
        .unwrap();
    assert!(header.status.success());
    assert_eq!(
        String::from_utf8(header.stdout).unwrap(),
        to_multiaxis_c_header(file)
    );
    let again = fts()
        .args(["emit", "--multiaxis"])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8(again.stdout).unwrap(),
        file.to_json_string()
    );

    let Some(cc) = compiler() else { return };
    let c_dir = dir.path().join("ctl");
    let emitted = fts()
        .args(["emit", "--format", "c", "--multiaxis"])
        .arg(&json)
        .arg("-o")
        .arg(&c_dir)
        .output()
        .unwrap();
    assert!(emitted.status.success(), "{emitted:?}");
    let c = c_commands(&cc, &c_dir, rec);
    assert_same_bits("the C step", &c, rec);
    eprintln!("{SAMPLES} samples: C, Rust and the simulation agree bit for bit");
}

#[test]
fn a_bad_multiaxis_file_is_refused_naming_the_field() {
    let mut doc: serde_json::Value = serde_json::from_str(&file().to_json_string()).unwrap();
    doc["axes"]["x"]["derivative_pole"] = serde_json::json!(2.0);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("k.json");
    std::fs::write(&path, doc.to_string()).unwrap();
    let out = fts()
        .args(["emit", "--multiaxis"])
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("axes.x.derivative_pole"), "{stderr}");
}

/// The multi-axis header and the example loop compile without a warning
/// as C99 (gcc, clang) and as C++ (g++, clang++), those installed.
#[test]
fn the_multiaxis_files_compile_warning_free_as_c99_and_cpp() {
    let dir = tempfile::tempdir().unwrap();
    let file = file();
    std::fs::write(
        dir.path().join("fts_multiaxis.h"),
        to_multiaxis_c_header(&file),
    )
    .unwrap();
    for (name, text) in [
        ("fts_runtime.h", fts::io::controller_file::C_RUNTIME_H),
        ("fts_runtime.c", fts::io::controller_file::C_RUNTIME_C),
    ] {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    for dialect in cc::DIALECTS {
        if !cc::installed(dialect.0) {
            continue;
        }
        for source in [
            repo("examples/c/fts_multiaxis_loop.c"),
            dir.path().join("fts_runtime.c"),
        ] {
            cc::assert_compiles_warning_free(dialect, &[], dir.path(), &source);
        }
    }
}
