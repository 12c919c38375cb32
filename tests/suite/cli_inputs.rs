//! Time bases, units and settings read, never assumed (docs/formats.md
//! "Time series (input)", `fts.tf/1`, "Exit codes"): one test per way an
//! input used to be ignored or misread.

use crate::common::cmd::Command;
use serde_json::Value;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn fts(dir: &Path) -> Command {
    let mut c = crate::common::cmd::fts();
    c.current_dir(dir);
    c
}

fn base(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/bad_input/base")
        .join(name)
}

/// Exit 2 (or `code`), one stderr line holding every `want`, no stdout.
fn refused(cmd: &mut Command, code: i32, want: &[&str]) -> String {
    let out = cmd.output().unwrap();
    let err = String::from_utf8(out.stderr).expect("the message is text");
    assert_eq!(out.status.code(), Some(code), "{err}");
    assert!(out.stdout.is_empty());
    assert_eq!(err.lines().count(), 1, "{err}");
    for w in want {
        assert!(err.contains(w), "{err:?} lacks {w:?}");
    }
    err
}

/// The `--json` summary of a run that must succeed.
fn success_json(out: std::process::Output) -> Value {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    serde_json::from_slice(&out.stdout).unwrap()
}

/// A CSV column by name.
fn column(csv: &str, name: &str) -> Vec<f64> {
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let i = head.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| l.split(',').nth(i).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn a_reference_file_plays_at_its_own_time_base() {
    // An 8 Hz sine sampled every 1 ms, run by a 0.1 ms loop: the loop sees
    // 8 Hz (resampled), not 80 Hz (one row per loop sample).
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("t,r\n");
    for k in 0..=250 {
        let t = k as f64 * 1e-3;
        text += &format!("{t:.3},{:.12}\n", 7.0 + 2.0 * (2.0 * PI * 8.0 * t).sin());
    }
    std::fs::write(dir.path().join("ref.csv"), text).unwrap();
    let out = fts(dir.path())
        .args(["simulate", "--stages", "pid", "--reference-file", "ref.csv"])
        .args(["-o", "trace.csv", "--json"])
        .output()
        .unwrap();
    let v = success_json(out);
    assert_eq!(v["evaluated_samples"], 2501, "0.25 s at 0.1 ms");
    let start = v["evaluated_from_s"].as_f64().unwrap();
    let trace = std::fs::read_to_string(dir.path().join("trace.csv")).unwrap();
    let (t, r) = (column(&trace, "t"), column(&trace, "r"));
    // Linear interpolation of the 1 ms samples: error <= dt^2/8 max|r''|
    // = 1e-6/8 * 2 (2 pi 8)^2 = 6.3e-4 um.
    let worst = t
        .iter()
        .zip(&r)
        .filter(|(t, _)| **t >= start && **t <= start + 0.25)
        .map(|(t, r)| (r - 7.0 - 2.0 * (2.0 * PI * 8.0 * (t - start)).sin()).abs())
        .fold(0.0, f64::max);
    assert!(worst < 6.4e-4, "{worst}");
    assert!(v["reference"].as_str().unwrap().contains("resampled"));
}

#[test]
fn a_reference_file_too_long_for_the_loop_is_refused_naming_its_time_column() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ref.csv"), "time,r\n0,1\n1000000,2\n").unwrap();
    let mut cmd = fts(dir.path());
    cmd.args(["simulate", "--stages", "pid", "--reference-file", "ref.csv"]);
    refused(&mut cmd, 2, &["ref.csv", "'time'", "samples"]);
}

/// `1000 e^{-s tau}/(s + 100)` under `C = 1`: `|L| = 1` at
/// `w = sqrt(1000^2 - 100^2)`, phase margin `180 - atan(w/100) - w tau`.
fn delayed_phase_margin(tau: f64) -> f64 {
    let w = (1000.0f64.powi(2) - 100.0f64.powi(2)).sqrt();
    180.0 - (w / 100.0).atan().to_degrees() - (w * tau).to_degrees()
}

#[test]
fn a_continuous_delay_survives_the_model_file_and_loop_honours_it() {
    let dir = tempfile::tempdir().unwrap();
    let tau = 1e-3;
    let doc = format!(
        r#"{{"format": "fts.tf/1", "var": "s", "num": [1000], "den": [1, 100], "delay": {tau}}}"#
    );
    std::fs::write(dir.path().join("g.json"), doc).unwrap();
    let out = fts(dir.path())
        .args(["loop", "--plant", "g.json", "--kp", "1", "--json"])
        .output()
        .unwrap();
    let v = success_json(out);
    let pm = v["phase_margin"]["phase_margin_deg"].as_f64().unwrap();
    assert!((pm - delayed_phase_margin(tau)).abs() < 1e-6, "{pm}");
    assert!((pm - delayed_phase_margin(0.0)).abs() > 50.0);
    assert_eq!(v["closed_loop_stable"], true);
    // A reader that works on a state-space realisation refuses it by name.
    let mut cmd = fts(dir.path());
    cmd.args(["response", "step", "g.json"]);
    refused(&mut cmd, 2, &["g.json", "delay", "0.001"]);
    let mut cmd = fts(dir.path());
    cmd.args(["c2d", "g.json", "--ts", "1e-4"]);
    refused(&mut cmd, 2, &["g.json", "delay"]);
}

#[test]
fn identify_writes_its_delay_into_the_model_file() {
    let dir = tempfile::tempdir().unwrap();
    let frd = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ct-ident/zaxis-frd.csv");
    // A fit that passes its checks (a failed one writes nothing).
    let out = fts(dir.path())
        .args(["identify", "ct-frd"])
        .arg(&frd)
        .args([
            "--np", "2", "--nz", "0", "--delay", "0.0001", "-o", "g.json",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let file: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("g.json")).unwrap()).unwrap();
    assert_eq!(file["var"], "s");
    assert_eq!(file["delay"], 0.0001);
}

#[test]
fn plot_writes_the_format_its_extension_names() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(base("tf.json"), dir.path().join("g.json")).unwrap();
    let args = ["loop", "--plant", "g.json", "--kp", "0.001", "--plot"];
    fts(dir.path()).args(args).arg("l.png").assert().success();
    fts(dir.path()).args(args).arg("l.svg").assert().success();
    let png = std::fs::read(dir.path().join("l.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"));
    let svg = std::fs::read_to_string(dir.path().join("l.svg")).unwrap();
    assert!(svg.starts_with("<svg"));
    for bad in ["l.pdf", "l", "l.jpg"] {
        let mut cmd = fts(dir.path());
        cmd.args(args).arg(bad);
        refused(&mut cmd, 2, &["--plot", ".svg, .png"]);
        assert!(!dir.path().join(bad).exists());
    }
}

#[test]
fn a_binary_record_is_refused_in_one_clean_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(base("v4.mat"), dir.path().join("v4.mat")).unwrap();
    let mut cmd = fts(dir.path());
    cmd.args(["identify", "ct", "v4.mat", "--np", "2", "--nz", "0"]);
    let err = refused(&mut cmd, 2, &["v4.mat", "MATLAB v4"]);
    assert!(
        err.len() < 300 && !err.trim_end().chars().any(char::is_control),
        "{err:?}"
    );
    std::fs::write(
        dir.path().join("bin.csv"),
        b"t,u,y\n0,1,2\n\x00\x01\x02\xff\n",
    )
    .unwrap();
    let mut cmd = fts(dir.path());
    cmd.args(["bode", "bin.csv"]);
    let err = refused(&mut cmd, 2, &["bin.csv", "binary"]);
    assert!(!err.trim_end().chars().any(char::is_control), "{err:?}");
}

#[test]
fn a_frequency_response_row_that_cannot_be_is_refused_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    for (row, field) in [
        ("-5,1,0", "freq_hz"),
        ("inf,1,0", "freq_hz"),
        ("5,inf,0", "re"),
    ] {
        let text = format!("freq_hz,re,im\n1,1,-0.1\n2,0.9,-0.3\n{row}\n10,0.1,-0.5\n");
        std::fs::write(dir.path().join("h.csv"), text).unwrap();
        let mut cmd = fts(dir.path());
        cmd.args(["identify", "ct-frd", "h.csv", "--np", "1", "--nz", "0"]);
        refused(&mut cmd, 2, &["h.csv line 4", field]);
    }
}

#[test]
fn a_zero_amplitude_is_refused_and_a_constant_reference_prints_no_nan() {
    let dir = tempfile::tempdir().unwrap();
    let mut cmd = fts(dir.path());
    cmd.args(["simulate", "--stages", "pid", "--amplitude", "0"]);
    refused(&mut cmd, 2, &["--amplitude", "0"]);
    std::fs::write(dir.path().join("r.csv"), "r\n7\n7\n7\n7\n").unwrap();
    let out = fts(dir.path())
        .args(["simulate", "--stages", "pid", "--reference-file", "r.csv"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(!text.contains("NaN") && text.contains("constant"), "{text}");
}

#[test]
fn the_pid_command_limits_are_settable_on_a_model_plant() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(base("tf.json"), dir.path().join("g.json")).unwrap();
    fts(dir.path())
        .args(["simulate", "--stages", "pid", "--plant-tf", "g.json"])
        .args(["--output-min", "1", "--output-max", "4", "-o", "t.csv"])
        .assert()
        .success();
    let u = column(
        &std::fs::read_to_string(dir.path().join("t.csv")).unwrap(),
        "u",
    );
    let (lo, hi) = u
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    // This loop oscillates, so it reaches both limits: they were applied.
    assert_eq!((lo, hi), (1.0, 4.0));
    let mut cmd = fts(dir.path());
    cmd.args([
        "simulate",
        "--stages",
        "pid",
        "--output-min",
        "5",
        "--output-max",
        "5",
    ]);
    refused(&mut cmd, 2, &["--output-max", "5"]);
}

#[test]
fn a_multiaxis_step_with_a_file_and_gains_for_one_axis_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(base("K.json"), dir.path().join("K.json")).unwrap();
    let manifest = "[step.m]\nkind = \"multiaxis\"\nx = \"K.json\"\npid_x = [1, 0.01, 0.0005, 100]\nout = \"k3.json\"\n";
    std::fs::write(dir.path().join("fts.toml"), manifest).unwrap();
    let mut cmd = fts(dir.path());
    cmd.args(["build", "-f", "fts.toml"]);
    refused(&mut cmd, 2, &["fts.toml line 4", "pid_x", "`x` (line 3)"]);
    assert!(!dir.path().join("k3.json").exists());
}

#[test]
fn a_virtual_sweep_whose_loop_oscillates_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut cmd = fts(dir.path());
    cmd.args(["virtual", "sweep", "--kp", "5", "-o", "s.csv"]);
    refused(&mut cmd, 1, &["does not track", "limit cycle"]);
    assert!(!dir.path().join("s.csv").exists());
    // The [Li21] gains track: the same sweep is written.
    fts(dir.path())
        .args(["virtual", "sweep", "--duration", "0.2", "-o", "s.csv"])
        .assert()
        .success();
}

/// docs/contouring.md "The loop": `fts contour --output-min/--output-max`
/// clamp every controller fts builds (as the runtime clamps each block);
/// the limits are written into `-o`, the run counts the samples at a
/// limit, and replaying the written file gives the same errors.
#[test]
fn contour_command_limits_are_applied_written_and_replayed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| -> Value {
        let out = fts(dir.path())
            .args([
                "contour",
                "circle",
                "--ts",
                "1e-5",
                "--no-baseline",
                "--json",
            ])
            .args(extra)
            .output()
            .unwrap();
        success_json(out)
    };
    let free = run(&[]);
    let limited = run(&["--output-min", "-5", "--output-max", "5", "-o", "k3.json"]);
    assert_eq!(free["errors_um"]["limited_samples"], 0);
    let n = limited["errors_um"]["limited_samples"].as_u64().unwrap();
    assert!(n > 1000, "{limited}");
    let rms = |v: &Value| v["errors_um"]["rms"]["contour"].as_f64().unwrap();
    assert!((rms(&limited) - rms(&free)).abs() > 1e-3 * rms(&free));
    let file: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("k3.json")).unwrap())
            .unwrap();
    for axis in ["x", "y", "z"] {
        assert_eq!(file["axes"][axis]["output_min"], -5.0);
        assert_eq!(file["axes"][axis]["output_max"], 5.0);
    }
    let replay = fts(dir.path())
        .args([
            "contour",
            "circle",
            "--controller",
            "k3.json",
            "--no-baseline",
            "--json",
        ])
        .output()
        .unwrap();
    let replay = success_json(replay);
    assert_eq!(rms(&replay), rms(&limited));
    let mut cmd = fts(dir.path());
    cmd.args([
        "contour",
        "circle",
        "--output-min",
        "1",
        "--output-max",
        "-1",
    ]);
    refused(
        &mut cmd,
        2,
        &["--output-max (-1) must exceed --output-min (1)"],
    );
}

/// docs/learning.md "Disturbances": `file:PATH` with a time column plays
/// the samples at their times: an 8 Hz sine recorded every 1 ms acts in the
/// 0.1 ms loop as `sines:1@8` does (within the chords' error), not as an
/// 80 Hz one; a file with only a time column is refused naming it.
#[test]
fn a_disturbance_file_plays_at_its_own_time_base() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("time_ms,d\n");
    for k in 0..=1000 {
        let t = k as f64 * 1e-3;
        csv += &format!("{k},{}\n", (2.0 * PI * 8.0 * t).sin());
    }
    std::fs::write(dir.path().join("d.csv"), csv).unwrap();
    std::fs::write(dir.path().join("t.csv"), "t\n0\n1\n").unwrap();
    let max_error = |spec: &str| {
        let out = fts(dir.path())
            .args(["simulate", "--stages", "pid", "--reference", "sine"])
            .args(["--amplitude", "0.001", "--duration", "0.5", "--json"])
            .args(["--output-disturbance", spec])
            .output()
            .unwrap();
        success_json(out)["max_abs_error"].as_f64().unwrap()
    };
    let (file, sines) = (max_error("file:d.csv"), max_error("sines:1@8"));
    assert!((file - sines).abs() < 2e-3 * sines, "{file} vs {sines}");
    let mut cmd = fts(dir.path());
    cmd.args(["simulate", "--output-disturbance", "file:t.csv"]);
    refused(&mut cmd, 2, &["t.csv", "column 2"]);
}
