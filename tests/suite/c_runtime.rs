//! The C runtime (`fts emit --format c`) gives the Rust runtime's commands
//! bit for bit: each controller's three C files are compiled with the system
//! C compiler (`$CC`, else `cc`) together with the example loop
//! `examples/c/fts_loop.c`, run over a 1e5-sample reference and measurement
//! trace, and every r_f, c (repetitive output plus learned feedforward),
//! u_ff and u compared with `fts::runtime`'s `step_signals` as f64 bit
//! patterns, a learned feedforward table played by both sides. The files
//! also compile warning-free as C99 with gcc and clang and as C++ with g++
//! and clang++ (those installed).
//!
//! Without a C compiler the tests say so loudly on stderr and pass: CI
//! machines always have gcc.

use crate::common::cc;

use fts::io::controller_file::{
    ControllerFile, DobBlock, Feedback, FeedforwardTableBlock, HysteresisBlock, Inversion,
    ParallelPid, RateBlock, RepetitiveBlock, StateSpaceBlock, ZpetcBlock, parse_controller,
    to_c_files,
};
use fts::runtime::{PlayForm, RuntimeController, SsAntiWindup};
use std::path::{Path, PathBuf};
use std::process::Command;

const SAMPLES: usize = 100_000;

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn compiler() -> Option<String> {
    cc::compiler("the C runtime's bit-identity with the Rust step")
}

fn load(path: &str) -> ControllerFile {
    let text = std::fs::read_to_string(repo(path)).unwrap();
    parse_controller(&text, path).unwrap()
}

/// The demo's controller: PID + HC (MPI-cbrt, lower plays) + ZPETC whose
/// zero outside radius 1.25 is inverted by an 8-term anticausal series
/// (`fts demo`'s controller.json, committed).
fn demo_controller() -> ControllerFile {
    let f = load("tests/data/c_runtime/demo-controller.json");
    assert!(f.zpetc.as_ref().unwrap().num.len() > 10, "stable inversion");
    f
}

/// MPI-deadzone HC with symmetric plays, a ZPETC and the parallel-form PID
/// with a derivative filter.
fn deadzone_controller() -> ControllerFile {
    let mut f = demo_controller();
    f.hysteresis = Some(HysteresisBlock {
        model: "mpi-deadzone".into(),
        operator: PlayForm::Symmetric,
        thresholds: vec![0.0, 0.6, 1.2, 1.8, 2.4, 3.0, 3.6, 4.2],
        weights: vec![0.9, 0.12, -0.05, 0.08, 0.03, -0.02, 0.04, 0.01],
        cbrt_gain: 0.0,
        offset: 0.3,
        input_offset: 6.5,
        dead_zone_thresholds: vec![0.0, 0.5, 1.5, 3.0],
        dead_zone_weights: vec![0.8, 0.15, -0.1, 0.07],
        input_dead_zone_thresholds: vec![],
        input_dead_zone_weights: vec![],
        inversion: Inversion::Model,
        command_range: None,
        rate_dependent: None,
    });
    f.feedback = Feedback::ParallelPid(ParallelPid {
        kp: 0.05,
        ki: 900.0,
        kd: 2e-6,
        n: Some(20_000.0),
        output_min: -2.0,
        output_max: 2.5,
    });
    f
}

/// The analytic inverse of an MPI-deadzone model (docs/math.md §1.6): a PI
/// stage on symmetric plays behind an input dead-zone stage.
fn inverse_deadzone_controller() -> ControllerFile {
    let mut f = deadzone_controller();
    let h = f.hysteresis.as_mut().unwrap();
    h.model = "pi".into();
    h.input_dead_zone_thresholds = std::mem::take(&mut h.dead_zone_thresholds);
    h.input_dead_zone_weights = std::mem::take(&mut h.dead_zone_weights);
    // Round trip through the file format: the stage is written and read.
    let text = f.to_json_string();
    assert!(text.contains("input_dead_zone_weights"), "{text}");
    parse_controller(&text, "inverse-deadzone").unwrap()
}

/// The mixsyn example's 4-state controller, widened to 8 states by a
/// stable second block, with limits (conditional update) and a ZPETC.
fn state_space_controller() -> ControllerFile {
    let mut f = load("examples/mixsyn/controller.json");
    let k = f.state_space().unwrap().clone();
    f.zpetc = demo_controller().zpetc;
    f.feedback = Feedback::StateSpace(widen(&k, 8));
    f
}

/// `k` plus `n - order` decoupled stable states driven by the error and
/// seen by the output, limits set so that the command saturates.
fn widen(k: &StateSpaceBlock, n: usize) -> StateSpaceBlock {
    let m = k.order();
    let mut a = vec![0.0; n * n];
    for i in 0..m {
        for j in 0..m {
            a[i * n + j] = k.a[i * m + j];
        }
    }
    for i in m..n {
        a[i * n + i] = 0.9 - 0.05 * (i - m) as f64;
        if i + 1 < n {
            a[i * n + i + 1] = 0.1;
        }
    }
    let mut b = k.b.clone();
    let mut c = k.c.clone();
    for i in m..n {
        b.push(0.01 * (i as f64 + 1.0));
        c.push(0.02 * (i as f64 - 3.5));
    }
    StateSpaceBlock {
        a,
        b,
        c,
        d: k.d,
        output_min: Some(-3.0),
        output_max: Some(4.0),
        anti_windup: SsAntiWindup::ConditionalUpdate,
        discretisation: k.discretisation.clone(),
    }
}

/// Feedforward only: HC and ZPETC, no feedback block.
fn feedforward_controller() -> ControllerFile {
    let mut f = demo_controller();
    f.feedback = Feedback::None;
    f
}

/// The demo's controller with a repetitive compensator of a whole period
/// (`Q = 0.25 z + 0.5 + 0.25 z^-1`, phase lead 3) behind its ZPETC.
fn repetitive_controller() -> ControllerFile {
    let mut f = demo_controller();
    f.repetitive = Some(RepetitiveBlock {
        period: 100,
        fraction: 0.0,
        q: vec![0.5, 0.25],
        lead: 3,
        gain: 0.5,
    });
    f
}

/// A repetitive compensator of a fractional period (the interpolated
/// delay), a wider `Q` and a longer lead, in front of the 8-state
/// state-space controller and its ZPETC.
fn fractional_repetitive_controller() -> ControllerFile {
    let mut f = state_space_controller();
    f.repetitive = Some(RepetitiveBlock {
        period: 199,
        fraction: 0.37,
        q: vec![0.4, 0.2, 0.09],
        lead: 5,
        gain: 0.1,
    });
    f
}

/// A learned feedforward table shorter than the trace (so that its end,
/// after which it plays 0, is crossed), as `fts ilc` writes one.
fn table() -> FeedforwardTableBlock {
    let tau = std::f64::consts::TAU;
    FeedforwardTableBlock {
        samples: (0..60_000)
            .map(|k| {
                let t = k as f64 * 1e-4;
                0.3 * (tau * 50.0 * t + 0.4).sin() - 0.05 * (tau * 430.0 * t).cos()
            })
            .collect(),
    }
}

/// The deadzone controller (filtered PID) with a learned feedforward table.
fn table_controller() -> ControllerFile {
    let mut f = deadzone_controller();
    f.feedforward_table = Some(table());
    f
}

/// Feedforward only, with both learning blocks: the command is the
/// hysteresis inverse of r_f + v + f.
fn feedforward_learning_controller() -> ControllerFile {
    let mut f = feedforward_controller();
    f.repetitive = fractional_repetitive_controller().repetitive;
    f.feedforward_table = Some(table());
    f
}

/// A long deterministic trace: reference around the HC's range with three
/// tones and steps; measurement a lagging, noisy, offset copy with
/// excursions that drive every controller into its limits.
fn trace() -> Vec<(f64, f64)> {
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut y = 0.0;
    (0..SAMPLES)
        .map(|k| {
            let t = k as f64 * 1e-4;
            let tau = std::f64::consts::TAU;
            let step = if (k / 7000) % 3 == 1 { 2.5 } else { 0.0 };
            let r = 6.5
                + 4.0 * (tau * 50.0 * t).sin()
                + 1.5 * (tau * 430.0 * t).sin()
                + 0.3 * (tau * 2100.0 * t).sin()
                + step;
            let excursion = if (k / 5000) % 4 == 3 { 12.0 } else { 0.0 };
            y += 0.05 * (r - y);
            (r, y + 0.02 * noise() - excursion)
        })
        .collect()
}

fn write_trace(path: &Path, trace: &[(f64, f64)]) {
    use std::fmt::Write;
    let mut s = String::from("r,y\n");
    for (r, y) in trace {
        // Display is the shortest decimal that reads back to the same double.
        let _ = writeln!(s, "{r},{y}");
    }
    std::fs::write(path, s).unwrap();
}

/// The Rust runtime over `trace`, as the example loop runs it: the
/// reference `preview` samples ahead, the last value held beyond the end,
/// the learned feedforward table (if any) played from the first sample.
/// `[r_f, c, u_ff, u]` per sample.
fn rust_run(file: &ControllerFile, trace: &[(f64, f64)]) -> Vec<[f64; 4]> {
    let mut rt = RuntimeController::new(&file.runtime_spec()).unwrap();
    let mut table = file.feedforward_player();
    assert_eq!(table.is_some(), file.feedforward_table.is_some());
    let p = rt.preview();
    let last = trace.last().unwrap().0;
    (0..trace.len())
        .map(|k| {
            let ahead = trace.get(k + p).map_or(last, |s| s.0);
            let learned = table.as_mut().map_or(0.0, |t| t.next_sample());
            let s = rt.step_signals(ahead, trace[k].1, learned);
            [s.filtered, s.correction, s.feedforward, s.command]
        })
        .collect()
}

fn compile_loop(cc: &str, dir: &Path, file: &ControllerFile) -> PathBuf {
    for (name, text) in to_c_files(file) {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let exe = dir.join("fts_loop");
    let out = Command::new(cc)
        .args(["-std=c99", "-O2", "-ffp-contract=off"])
        .args(["-Wall", "-Wextra", "-pedantic", "-Werror"])
        .arg("-I")
        .arg(dir)
        .arg(repo("examples/c/fts_loop.c"))
        .arg(dir.join("fts_runtime.c"))
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{cc} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

fn c_run(exe: &Path, dir: &Path, trace_csv: &Path) -> Vec<[f64; 4]> {
    let commands = dir.join("commands.csv");
    let out = Command::new(exe)
        .arg(trace_csv)
        .arg(&commands)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "fts_loop failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&commands).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("k,r_f,c,u_ff,u"));
    lines
        .enumerate()
        .map(|(k, l)| {
            let v: Vec<&str> = l.split(',').collect();
            assert_eq!(v[0].parse::<usize>().unwrap(), k);
            [1, 2, 3, 4].map(|i| v[i].parse::<f64>().unwrap())
        })
        .collect()
}

fn assert_bit_identical(name: &str, file: &ControllerFile, limits_hit_at_least: usize) {
    let Some(cc) = compiler() else { return };
    let dir = tempfile::tempdir().unwrap();
    let trace = trace();
    let csv = dir.path().join("trace.csv");
    write_trace(&csv, &trace);
    let exe = compile_loop(&cc, dir.path(), file);
    let c = c_run(&exe, dir.path(), &csv);
    let rust = rust_run(file, &trace);
    assert_eq!(c.len(), SAMPLES, "{name}: one command per trace row");
    for (k, (a, b)) in c.iter().zip(&rust).enumerate() {
        for (i, signal) in ["r_f", "c", "u_ff", "u"].iter().enumerate() {
            assert_eq!(
                a[i].to_bits(),
                b[i].to_bits(),
                "{name}: {signal} differs at sample {k}: C {:e}, Rust {:e}",
                a[i],
                b[i]
            );
        }
    }
    // The comparison covered the saturated branches (anti-windup), not only
    // the linear ones.
    let (lo, hi) = file.command_limits();
    let at_limit = rust.iter().filter(|s| s[3] == lo || s[3] == hi).count();
    assert!(
        at_limit >= limits_hit_at_least,
        "{name}: only {at_limit} samples at the limits"
    );
    // With a learning block the correction was exercised, not left at 0.
    let corrected = rust.iter().filter(|s| s[1] != 0.0).count();
    if file.repetitive.is_some() || file.feedforward_table.is_some() {
        assert!(
            corrected >= SAMPLES / 2,
            "{name}: only {corrected} samples with a correction"
        );
    } else {
        assert_eq!(corrected, 0, "{name}");
    }
    assert!(rust.iter().all(|s| s.iter().all(|v| v.is_finite())));
    eprintln!(
        "{name}: {SAMPLES} samples bit-identical ({at_limit} at the limits, {corrected} corrected)"
    );
}

/// The 8-state controller inside a disturbance observer (delay 2, a
/// second-order `Q`, a third-order nominal inverse) with friction
/// feedforward and the ZPETC.
fn dob_controller() -> ControllerFile {
    let mut f = state_space_controller();
    let Feedback::StateSpace(outer) = f.feedback.clone() else {
        unreachable!("a state-space controller")
    };
    let (q_num, q_den) = fts::synth::dob::q_filter(500.0, 2, f.ts).unwrap();
    f.feedback = Feedback::Dob(DobBlock {
        outer,
        q_num,
        q_den,
        inverse_num: vec![1e-4, 0.03, 0.9, 0.05],
        inverse_den: vec![0.3, -0.1],
        delay: 2,
        coulomb: 0.05,
        viscous: 1e-4,
        smoothing: 5.0,
        design: "test".into(),
    });
    f
}

#[test]
fn dob_with_zpetc_is_bit_identical_in_c() {
    assert_bit_identical("DOB (state space 8)+ZPETC", &dob_controller(), 0);
}

#[test]
fn pid_hc_zpetc_with_stable_inversion_is_bit_identical_in_c() {
    assert_bit_identical("PID+HC+ZPETC", &demo_controller(), 1000);
}

#[test]
fn mpi_deadzone_symmetric_with_filtered_pid_is_bit_identical_in_c() {
    assert_bit_identical("MPI-deadzone+filtered PID", &deadzone_controller(), 1000);
}

/// HC with a rate stage: a forward MPI-cbrt model with rate weights and a
/// velocity term, evaluated directly (`solve == false`) or inverted per
/// sample on `[-10, 30]` (docs/math.md §1.6-1.7).
fn rate_controller(solve: bool) -> ControllerFile {
    let mut f = demo_controller();
    f.hysteresis = Some(HysteresisBlock {
        model: "mpi-cbrt".into(),
        operator: PlayForm::Lower,
        thresholds: vec![0.0, 2.0, 4.0, 6.0],
        weights: vec![0.9, 0.1, -0.05, 0.05],
        cbrt_gain: 0.2,
        offset: 0.1,
        input_offset: 0.3,
        dead_zone_thresholds: vec![],
        dead_zone_weights: vec![],
        input_dead_zone_thresholds: vec![],
        input_dead_zone_weights: vec![],
        inversion: if solve {
            Inversion::Solve
        } else {
            Inversion::Model
        },
        command_range: solve.then_some([-10.0, 30.0]),
        rate_dependent: Some(RateBlock {
            ts: 1e-4,
            rate_scale: 5e4,
            weights: vec![0.02, -0.01, 0.01, 0.005],
            velocity_gain: 0.01,
        }),
    });
    // Round trip through the file: the block is valid as written.
    parse_controller(&f.to_json_string(), "rate.json").unwrap()
}

#[test]
fn rate_dependent_hc_is_bit_identical_in_c() {
    assert_bit_identical("rate-dependent HC+ZPETC+PID", &rate_controller(false), 0);
}

#[test]
fn solved_forward_rate_model_is_bit_identical_in_c() {
    assert_bit_identical(
        "solved forward rate HC+ZPETC+PID",
        &rate_controller(true),
        0,
    );
}

#[test]
fn mpi_deadzone_inverse_input_stage_is_bit_identical_in_c() {
    assert_bit_identical(
        "PI with input dead zone+filtered PID",
        &inverse_deadzone_controller(),
        1000,
    );
}

#[test]
fn state_space_with_zpetc_is_bit_identical_in_c() {
    assert_bit_identical("state space (8)+ZPETC", &state_space_controller(), 1000);
}

#[test]
fn feedforward_only_is_bit_identical_in_c() {
    assert_bit_identical("HC+ZPETC, no feedback", &feedforward_controller(), 0);
}

#[test]
fn repetitive_with_pid_hc_zpetc_is_bit_identical_in_c() {
    assert_bit_identical("repetitive+PID+HC+ZPETC", &repetitive_controller(), 1000);
}

#[test]
fn fractional_repetitive_with_state_space_is_bit_identical_in_c() {
    assert_bit_identical(
        "repetitive (fractional)+state space (8)+ZPETC",
        &fractional_repetitive_controller(),
        1000,
    );
}

#[test]
fn learned_feedforward_table_is_bit_identical_in_c() {
    assert_bit_identical("table+MPI-deadzone+filtered PID", &table_controller(), 1000);
}

#[test]
fn feedforward_only_with_repetitive_and_table_is_bit_identical_in_c() {
    assert_bit_identical(
        "repetitive+table+HC+ZPETC, no feedback",
        &feedforward_learning_controller(),
        0,
    );
}

/// The generated files compile without a warning as C99 (gcc, clang) and as
/// C++ (g++, clang++), each compiler that is installed.
#[test]
fn c_files_compile_warning_free_as_c99_and_cpp() {
    if compiler().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for (i, file) in [
        demo_controller(),
        deadzone_controller(),
        inverse_deadzone_controller(),
        state_space_controller(),
        feedforward_controller(),
        repetitive_controller(),
        fractional_repetitive_controller(),
        table_controller(),
        feedforward_learning_controller(),
    ]
    .iter()
    .enumerate()
    {
        let sub = dir.path().join(format!("c{i}"));
        std::fs::create_dir(&sub).unwrap();
        for (name, text) in to_c_files(file) {
            std::fs::write(sub.join(name), text).unwrap();
        }
        let mut tried = 0;
        for dialect in cc::DIALECTS {
            if !cc::installed(dialect.0) {
                continue;
            }
            tried += 1;
            // fts_runtime.c is the same for every controller: once is enough.
            let runtime = (i == 0).then(|| sub.join("fts_runtime.c"));
            for source in std::iter::once(repo("examples/c/fts_loop.c")).chain(runtime) {
                cc::assert_compiles_warning_free(
                    dialect,
                    &["-O2", "-ffp-contract=off"],
                    &sub,
                    &source,
                );
            }
        }
        assert!(tried > 0);
    }
}

/// The C runtime refuses what the Rust one refuses, naming the same field.
#[test]
fn c_runtime_rejects_a_bad_spec_naming_the_field() {
    let Some(cc) = compiler() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut f = demo_controller();
    // Only the loader is exercised: a controller whose den[0] the header says is 0.
    let z: &mut ZpetcBlock = f.zpetc.as_mut().unwrap();
    z.den[0] = 0.0;
    for (name, text) in to_c_files(&f) {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let exe = compile_loop(&cc, dir.path(), &f);
    let csv = dir.path().join("trace.csv");
    write_trace(&csv, &trace()[..10]);
    let out = Command::new(&exe)
        .arg(&csv)
        .arg(dir.path().join("o.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("field zpetc.den: invalid value"), "{err}");
    let rust = RuntimeController::new(&f.runtime_spec()).unwrap_err();
    assert!(rust.to_string().starts_with("zpetc.den"), "{rust}");
}

/// A repetitive block that the runtime refuses is refused by the C runtime
/// with the same field; so is an empty learned table, by both players.
#[test]
fn c_runtime_rejects_a_bad_repetitive_block_naming_the_field() {
    let Some(cc) = compiler() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut f = repetitive_controller();
    // Q and the lead reach 1 + 3 samples ahead: the period must exceed 4.
    f.repetitive.as_mut().unwrap().period = 4;
    let exe = compile_loop(&cc, dir.path(), &f);
    let csv = dir.path().join("trace.csv");
    write_trace(&csv, &trace()[..10]);
    let out = Command::new(&exe)
        .arg(&csv)
        .arg(dir.path().join("o.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("field repetitive.period: invalid value"),
        "{err}"
    );
    let rust = RuntimeController::new(&f.runtime_spec()).unwrap_err();
    assert!(rust.to_string().starts_with("repetitive.period"), "{rust}");

    // An empty table: the header still declares a one-entry array, with
    // FTS_FF_TABLE_LEN 0, which fts_table_init refuses.
    let mut f = table_controller();
    f.feedforward_table.as_mut().unwrap().samples.clear();
    let sub = dir.path().join("empty");
    std::fs::create_dir(&sub).unwrap();
    let exe = compile_loop(&cc, &sub, &f);
    let out = Command::new(&exe)
        .arg(&csv)
        .arg(sub.join("o.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("field feedforward_table.samples: empty or beyond the runtime's capacity"),
        "{err}"
    );
    assert!(fts::runtime::FeedforwardTable::new(&[]).is_err());
}
