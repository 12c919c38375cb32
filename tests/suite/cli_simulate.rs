//! `fts simulate` and `fts emit` end to end, and their bad inputs.

use crate::common::cmd::{fts, json_of, predicate};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

#[test]
fn simulate_default_identifies_models_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace.csv");
    let svg = dir.path().join("track.svg");
    let v = json_of(
        fts()
            .args([
                "simulate",
                "--stages",
                "pid+hc+zpec",
                "--reference",
                "sine",
                "--amplitude",
                "5",
                "--freq",
                "100",
                "--json",
                "-o",
            ])
            .arg(&trace)
            .arg("--plot")
            .arg(&svg),
    );
    for key in ["max_abs_error", "rms_error", "max_error_percent"] {
        assert!(v[key].as_f64().unwrap().is_finite(), "{key}");
    }
    assert_eq!(v["controller"], "pid+hc+zpec");
    assert!(
        v["models"]
            .as_str()
            .unwrap()
            .contains("identified from the virtual FTS")
    );
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(text.starts_with("t,r,r_f,u_ff,u,y,e\n"));
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));
}

#[test]
fn emit_then_simulate_from_the_coefficient_file() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("controller.json");
    let header = dir.path().join("controller.h");
    for (format, out) in [("json", &json), ("c-header", &header)] {
        fts()
            .args([
                "emit",
                "--pid-form",
                "li21",
                "--kp",
                "0.02",
                "--ki",
                "0.15",
                "--hysteresis",
            ])
            .arg(fixture("li21-inverse-mpi.json"))
            .arg("--closed-loop")
            .arg(fixture("li21-closed-loop.json"))
            .args(["--format", format, "-o"])
            .arg(out)
            .assert()
            .success();
    }
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(text.contains("\"format\": \"fts.controller/1\""));
    assert!(text.contains("\"sha256\""));
    let h = std::fs::read_to_string(&header).unwrap();
    assert!(h.contains("#define FTS_PREVIEW 5"));
    // Byte-identical regeneration.
    let again = dir.path().join("again.json");
    fts()
        .args([
            "emit",
            "--pid-form",
            "li21",
            "--kp",
            "0.02",
            "--ki",
            "0.15",
            "--hysteresis",
        ])
        .arg(fixture("li21-inverse-mpi.json"))
        .arg("--closed-loop")
        .arg(fixture("li21-closed-loop.json"))
        .arg("-o")
        .arg(&again)
        .assert()
        .success();
    assert_eq!(
        std::fs::read(&json).unwrap(),
        std::fs::read(&again).unwrap()
    );
    // The simulation runs exactly this file.
    let v = json_of(
        fts()
            .args(["simulate", "--json", "--freq", "10", "--controller"])
            .arg(&json),
    );
    assert_eq!(v["controller"], "pid+hc+zpec");
    assert_eq!(v["preview"], 5);
}

#[test]
fn bad_coefficient_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.json");
    fts()
        .args([
            "emit",
            "--pid-form",
            "li21",
            "--kp",
            "0.02",
            "--ki",
            "0.15",
            "--hysteresis",
        ])
        .arg(fixture("li21-inverse-mpi.json"))
        .arg("--closed-loop")
        .arg(fixture("li21-closed-loop.json"))
        .arg("-o")
        .arg(&good)
        .assert()
        .success();
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&good).unwrap()).unwrap();
    let cases: Vec<(serde_json::Value, &str)> = vec![
        (
            {
                let mut d = doc.clone();
                d["format"] = "fts.controller/9".into();
                d
            },
            "unsupported format",
        ),
        (
            {
                let mut d = doc.clone();
                d["blocks"].as_array_mut().unwrap().pop();
                d
            },
            "missing block \"pid\"",
        ),
        (
            {
                let mut d = doc.clone();
                d["blocks"][2]["ki"] = "NaN".into();
                d
            },
            "blocks[2].ki",
        ),
        (
            {
                let mut d = doc.clone();
                d["blocks"][1]["weights"].as_array_mut().unwrap().pop();
                d
            },
            "field 'blocks[1].weights'",
        ),
        (
            {
                let mut d = doc.clone();
                d["blocks"][0]["den"] = serde_json::json!([0.0, 1.0]);
                d
            },
            "zpetc.den",
        ),
    ];
    for (i, (bad, fragment)) in cases.into_iter().enumerate() {
        let p = dir.path().join(format!("bad{i}.json"));
        std::fs::write(&p, bad.to_string()).unwrap();
        let trace = dir.path().join(format!("trace{i}.csv"));
        fts()
            .args(["simulate", "--controller"])
            .arg(&p)
            .arg("-o")
            .arg(&trace)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(format!("bad{i}.json")))
            .stderr(predicate::str::contains(fragment))
            .stderr(predicate::str::contains("panicked").not());
        assert!(!trace.exists());
    }
}

#[test]
fn bad_controller_and_reference_options() {
    fts()
        .args(["simulate", "--stages", "pid+zpec+hc"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "valid controllers: pid, pid+hc, pid+zpec, pid+hc+zpec",
        ));
    fts()
        .args([
            "simulate",
            "--stages",
            "pid",
            "--reference",
            "sweep",
            "--f1",
            "9000",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--f1"));
    // A reference beyond the stroke is reported, not silently clipped.
    fts()
        .args([
            "simulate",
            "--stages",
            "pid",
            "--amplitude",
            "9",
            "--freq",
            "10",
        ])
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "warning: the command sat on its limits",
        ));
}

/// A loop that runs away is an error (exit 1) naming when and the likely
/// cause, never a table of zeros or NaN; no trace is written.
#[test]
fn a_diverging_loop_is_reported_with_its_time_and_cause() {
    let dir = tempfile::tempdir().unwrap();
    let plant = dir.path().join("unstable.json");
    std::fs::write(
        &plant,
        r#"{"format": "fts.tf/1", "var": "z^-1", "ts": 0.0001,
            "num": [0.1], "den": [1, -1.05], "delay": 1}"#,
    )
    .unwrap();
    let trace = dir.path().join("trace.csv");
    let out = fts()
        .args(["simulate", "--stages", "pid", "--plant-tf"])
        .arg(&plant)
        .args(["--reference", "sine", "--freq", "100", "--json", "-o"])
        .arg(&trace)
        .assert()
        .code(1)
        .stdout("")
        .get_output()
        .clone();
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("the closed loop diverged at t = "), "{err}");
    assert!(err.contains("unstable.json is unstable"), "{err}");
    assert!(!trace.exists());
}

/// `fts emit` adds no feedback controller the user did not ask for: without
/// one it exits 2 listing the choices, and PID gains need their form.
#[test]
fn emit_adds_no_unrequested_feedback_controller() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.json");
    let base = |extra: &[&str]| {
        let mut c = fts();
        c.arg("emit")
            .arg("--closed-loop")
            .arg(fixture("li21-closed-loop.json"))
            .args(extra)
            .arg("-o")
            .arg(&out);
        c
    };
    base(&[])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--feedback none"));
    base(&["--kp", "0.02", "--ki", "1500"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--pid-form"));
    base(&["--pid-form", "li21", "--pid-n", "100", "--kp", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--pid-n"));
    assert!(!out.exists());
    // Continuous gains become per-sample ones by backward Euler: Ki Ts, Kd/Ts.
    base(&[
        "--pid-form",
        "parallel",
        "--kp",
        "0.02",
        "--ki",
        "1500",
        "--kd",
        "2e-6",
    ])
    .assert()
    .success();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let pid = &v["blocks"][1];
    assert_eq!(pid["form"], "parallel");
    assert!((pid["ki"].as_f64().unwrap() - 1500.0 * 1e-4).abs() < 1e-15);
    assert!((pid["kd"].as_f64().unwrap() - 2e-6 / 1e-4).abs() < 1e-15);
    assert_eq!(pid["continuous"]["ki"], 1500.0);
}

/// A feedforward-only ZPETC file run on the closed loop it inverts tracks
/// exactly: the ZPETC cancels all of this closed loop's zeros and poles
/// (none outside the unit circle), so r_f through G is r delayed by nothing.
#[test]
fn feedforward_only_zpetc_on_its_closed_loop_tracks_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ff.json");
    fts()
        .arg("emit")
        .arg("--closed-loop")
        .arg(fixture("li21-closed-loop.json"))
        .args(["--feedback", "none", "-o"])
        .arg(&out)
        .assert()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("\"type\": \"no_feedback\""), "{text}");
    let v = json_of(
        fts()
            .args(["simulate", "--json", "--freq", "100", "--controller"])
            .arg(&out)
            .arg("--plant-tf")
            .arg(fixture("li21-closed-loop.json")),
    );
    assert_eq!(v["controller"], "zpec");
    let max = v["max_abs_error"].as_f64().unwrap_or(f64::NAN);
    assert!(max < 1e-9, "{v}");
}

/// `fts simulate --stages dob` on fixtures/second-order-plant-zoh.json
/// holding 5 um while a 0.5 V step enters at the plant input at 0.5 s
/// (fixtures/step-input-disturbance.csv): max |e| with `--controller`.
fn dob_run(controller: &str, extra: &[&str]) -> serde_json::Value {
    let data = fixture("step-input-disturbance.csv");
    let disturbance = format!("file:{}", data.display());
    let mut cmd = fts();
    cmd.arg("simulate")
        .arg("--plant-tf")
        .arg(fixture("second-order-plant-zoh.json"))
        .args(["--kp", "0.5", "--ki", "0.05", "--dob-q-hz", "2000"])
        .args(["--controller", controller])
        .arg("--reference-file")
        .arg(&data)
        .args(["--input-disturbance", &disturbance])
        .args(extra)
        .arg("--json");
    json_of(&mut cmd)
}

#[test]
fn simulate_dob_rejects_a_step_input_disturbance_far_better_than_the_pid() {
    let pid = dob_run("pid", &[])["max_abs_error"].as_f64().unwrap();
    let dob = dob_run("dob", &[])["max_abs_error"].as_f64().unwrap();
    // The same PID gains; the observer cancels the disturbance within
    // about 1/(2 pi 2000 Hz) instead of the PID's integral settling.
    assert!(pid > 0.3, "pid {pid}");
    assert!(dob < pid / 4.0, "dob {dob} vs pid {pid}");
}

#[test]
fn simulate_dob_replays_from_its_controller_file_to_the_last_digit() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("dob.json");
    let built = dob_run("dob", &["--controller-out", file.to_str().unwrap()]);
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("\"type\": \"dob\""), "{text}");
    let data = fixture("step-input-disturbance.csv");
    let replayed = json_of(
        fts()
            .arg("simulate")
            .arg("--plant-tf")
            .arg(fixture("second-order-plant-zoh.json"))
            .arg("--controller")
            .arg(&file)
            .arg("--reference-file")
            .arg(&data)
            .arg("--input-disturbance")
            .arg(format!("file:{}", data.display()))
            .arg("--json"),
    );
    assert_eq!(replayed["controller"], "dob");
    for key in ["max_abs_error", "rms_error"] {
        assert_eq!(built[key], replayed[key], "{key}");
    }
}

/// `--hc-solve` (docs/math.md §1.6): HC by inverting the forward model per
/// sample gives the loop the analytic inverse gives (a symmetric-play PI
/// with positive partial sums: the per-sample root is the analytic
/// inverse's output to rounding), and both beat the PID alone. Without an
/// hc stage the option is refused, exit 2.
#[test]
fn simulate_hc_solve_matches_the_analytic_inverse() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fts()
        .current_dir(d)
        .args(["virtual", "triangles", "-o", "tri.csv"])
        .assert()
        .success();
    fts()
        .current_dir(d)
        .args(["identify", "hysteresis", "tri.csv", "--model", "pi"])
        .args([
            "--operator",
            "play-symmetric",
            "--invertible",
            "-o",
            "fwd.json",
        ])
        .assert()
        .success();
    fts()
        .current_dir(d)
        .args(["hysteresis", "invert", "fwd.json", "-o", "inv.json"])
        .assert()
        .success();
    let run = |extra: &[&str]| {
        json_of(
            fts()
                .current_dir(d)
                .args(["simulate", "--freq", "10", "--json"])
                .args(extra),
        )["rms_error"]
            .as_f64()
            .unwrap()
    };
    let analytic = run(&["--stages", "pid+hc", "--hysteresis", "inv.json"]);
    let solved = run(&[
        "--stages",
        "pid+hc",
        "--hysteresis",
        "fwd.json",
        "--hc-solve",
    ]);
    let pid = run(&["--stages", "pid"]);
    assert!((solved - analytic).abs() < 1e-6, "{solved} vs {analytic}");
    assert!(solved < pid / 5.0, "{solved} vs PID {pid}");
    fts()
        .current_dir(d)
        .args([
            "simulate",
            "--stages",
            "pid",
            "--hysteresis",
            "fwd.json",
            "--hc-solve",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--hc-solve"));
}
