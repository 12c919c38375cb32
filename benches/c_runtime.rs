//! The C runtime's step beside the Rust step, same controllers, same run:
//! PID + HC (10 operators) + ZPETC (5/4) and an 8-state state-space
//! controller. The C side is `fts emit --format c`'s files plus
//! `benches/c/bench_step.c`, compiled with `$CC` (default `gcc`) `-O2
//! -ffp-contract=off`; the Rust side is `fts::runtime` with the same
//! reference and measurement, both summing the commands so that no step is
//! optimised away. Prints ns per sample and the C/Rust ratio (target: the C
//! step within 1.5x of the Rust one).
//!
//!     cargo bench --bench c_runtime

use fts::io::controller_file::{
    ControllerFile, Feedback, HysteresisBlock, Provenance, StateSpaceBlock, Units, ZpetcBlock,
    to_c_files,
};
use fts::runtime::{PidSpec, PlayForm, RuntimeController, SsAntiWindup};
use std::hint::black_box;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

const STEPS: usize = 20_000_000;

fn pid_hc_zpetc() -> ControllerFile {
    ControllerFile {
        ts: 1e-4,
        units: Units::default(),
        zpetc: Some(ZpetcBlock {
            preview: 5,
            num: vec![0.24073, -0.18902, 0.17571, -0.14781, 0.012412, 0.008298],
            den: vec![1.0, -2.31849, 2.46269, -1.32667, 0.277805],
        }),
        hysteresis: Some(HysteresisBlock {
            model: "mpi-cbrt".into(),
            operator: PlayForm::Lower,
            thresholds: (0..10).map(|i| i as f64 * 0.9677).collect(),
            weights: vec![
                0.29, -0.063, 0.0075, -0.0267, -0.0015, -0.0215, 0.021, -0.0253, 0.0115, -0.047,
            ],
            cbrt_gain: -0.0197,
            offset: 0.0,
            input_offset: 0.0,
            dead_zone_thresholds: vec![],
            dead_zone_weights: vec![],
            input_dead_zone_thresholds: vec![],
            input_dead_zone_weights: vec![],
            inversion: Default::default(),
            command_range: None,
            rate_dependent: None,
        }),
        feedback: Feedback::Pid(PidSpec {
            kp: 0.05,
            ki: 0.3,
            kd: 0.0,
            output_min: 0.0,
            output_max: 10.0,
        }),
        provenance: Provenance::default(),
        repetitive: None,
        feedforward_table: None,
    }
}

/// The 8-state controller of `benches/runtime.rs`, alone.
fn state_space8() -> ControllerFile {
    let order = 8;
    let a = (0..order * order)
        .map(|k| {
            let (i, j) = (k / order, k % order);
            if i == j {
                0.9 - 0.05 * i as f64
            } else {
                0.01 / (1.0 + (i as f64 - j as f64).abs())
            }
        })
        .collect();
    ControllerFile {
        ts: 1e-4,
        units: Units::default(),
        zpetc: None,
        hysteresis: None,
        feedback: Feedback::StateSpace(StateSpaceBlock {
            a,
            b: (0..order).map(|i| 0.1 * (i + 1) as f64).collect(),
            c: (0..order).map(|i| 1.0 - 0.1 * i as f64).collect(),
            d: 0.05,
            output_min: Some(-10.0),
            output_max: Some(10.0),
            anti_windup: SsAntiWindup::ConditionalUpdate,
            discretisation: "given".into(),
        }),
        provenance: Provenance::default(),
        repetitive: None,
        feedforward_table: None,
    }
}

fn rust_ns(file: &ControllerFile) -> f64 {
    let mut rt = RuntimeController::new(&file.runtime_spec()).unwrap();
    let refs: Vec<f64> = (0..4096)
        .map(|k| 5.0 + 4.0 * (k as f64 * 0.03).sin())
        .collect();
    let mut acc = 0.0;
    for i in 0..100_000 {
        acc += rt.step(refs[i & 4095], refs[i & 4095] - 0.01);
    }
    let t = Instant::now();
    for i in 0..STEPS {
        let r = black_box(refs[i & 4095]);
        acc += rt.step(r, r - 0.01);
    }
    let ns = t.elapsed().as_nanos() as f64 / STEPS as f64;
    black_box(acc);
    ns
}

fn c_ns(cc: &str, dir: &Path, file: &ControllerFile) -> Result<f64, String> {
    for (name, text) in to_c_files(file) {
        std::fs::write(dir.join(name), text).map_err(|e| e.to_string())?;
    }
    let exe = dir.join("bench_step");
    // The bench crate lives in crates/fts-bench; the sources at the top.
    let driver = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../benches/c/bench_step.c");
    let out = Command::new(cc)
        .args([
            "-std=c99",
            "-O2",
            "-ffp-contract=off",
            "-D_POSIX_C_SOURCE=199309L",
        ])
        .arg("-I")
        .arg(dir)
        .arg(&driver)
        .arg(dir.join("fts_runtime.c"))
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .map_err(|e| format!("{cc}: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let out = Command::new(&exe)
        .arg(STEPS.to_string())
        .output()
        .map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.split_whitespace()
        .next()
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| format!("unexpected output {text:?}"))
}

fn main() {
    // `cargo test --benches` runs this with --bench absent: stay quick then.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let cc = std::env::var("CC").unwrap_or_else(|_| "gcc".into());
    let dir = tempfile::tempdir().unwrap();
    println!("controller step, ns per sample ({STEPS} steps each; C: {cc} -O2 -ffp-contract=off)");
    println!(
        "{:<28} {:>10} {:>10} {:>8}",
        "controller", "Rust", "C", "C/Rust"
    );
    for (name, file) in [
        ("pid+hc10+zpetc5_4", pid_hc_zpetc()),
        ("state-space order 8", state_space8()),
    ] {
        let rust = rust_ns(&file);
        match c_ns(&cc, dir.path(), &file) {
            Ok(c) => println!("{name:<28} {rust:>10.2} {c:>10.2} {:>8.2}", c / rust),
            Err(e) => println!("{name:<28} {rust:>10.2}  C not measured: {e}"),
        }
    }
}
