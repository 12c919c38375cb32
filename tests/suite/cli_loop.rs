//! `fts loop` from the outside.

use crate::common::cmd::{fts, predicate};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(name)
}

fn json_of(args: &[&str], files: &[&Path]) -> Value {
    let mut cmd = fts();
    cmd.arg("loop");
    let mut files = files.iter();
    for a in args {
        if *a == "@" {
            cmd.arg(files.next().unwrap());
        } else {
            cmd.arg(a);
        }
    }
    crate::common::cmd::json_of(cmd.arg("--json"))
}

#[test]
fn virtual_fts_pid_summary_and_json() {
    let g = data("tests/data/loop/virtual-fts-linear.json");
    fts()
        .args(["loop", "--plant"])
        .arg(&g)
        .args(["--kp", "0.02", "--ki", "0.15"])
        .assert()
        .success()
        .stdout(
            predicate::str::contains("gain margin:     2.598")
                .and(predicate::str::contains("[Li21] per-sample form"))
                .and(predicate::str::contains("closed loop:     stable"))
                .and(predicate::str::contains("Hz")),
        );
    let v = json_of(&["--plant", "@", "--kp", "0.02", "--ki", "0.15"], &[&g]);
    assert_eq!(v["closed_loop_stable"], true);
    assert_eq!(v["ts"], 1e-4);
    assert_eq!(v["diagnostics"]["gain_crossovers"], 3);
    let gm = v["gain_margin"]["gain_margin"].as_f64().unwrap();
    // python-control: 2.598164676694277 (tests/data/loop/cases.json, vfts_pid).
    assert!((gm - 2.598164676694277).abs() < 1e-6 * gm);
    assert!(v["delay_margin"]["delay_margin_samples"].as_f64().unwrap() > 2.0);
}

#[test]
fn pid_flags_equal_the_same_controller_file() {
    let dir = tempfile::tempdir().unwrap();
    let g = data("fixtures/second-order-plant.json");
    // 1 + 2000/s + 1e-4 * 2e4 s/(s + 2e4) = (3 s^2 + 22000 s + 4e7) / (s^2 + 2e4 s).
    let k = write(
        dir.path(),
        "k.json",
        r#"{"format":"fts.tf/1","var":"s","num":[3,22000,40000000],"den":[1,20000,0]}"#,
    );
    let a = json_of(
        &[
            "--plant",
            "@",
            "--kp",
            "1",
            "--ki",
            "2000",
            "--kd",
            "1e-4",
            "--tf-derivative",
            "20000",
        ],
        &[&g],
    );
    let b = json_of(&["--plant", "@", "--controller", "@"], &[&g, &k]);
    for key in ["phase_margin", "modulus_margin", "peak_t"] {
        for field in ["freq_hz", "phase_margin_deg", "value"] {
            if let (Some(x), Some(y)) = (a[key][field].as_f64(), b[key][field].as_f64()) {
                assert!((x - y).abs() <= 1e-9 * x.abs(), "{key}.{field}: {x} vs {y}");
            }
        }
    }
    assert!(a["gain_margin"].is_null(), "no phase crossover");
}

#[test]
fn state_space_controller_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    // G = 1/(s (s + 1)) as fts.ss/1, K = 2 as a static gain.
    let g = write(
        dir.path(),
        "g.json",
        r#"{"format":"fts.ss/1","ts":null,"a":[[-1,0],[1,0]],"b":[[1],[0]],"c":[[0,1]],"d":[[0]]}"#,
    );
    let k = write(
        dir.path(),
        "k.json",
        r#"{"format":"fts.ss/1","ts":null,"a":[],"b":[],"c":[[]],"d":[[2]]}"#,
    );
    let svg = dir.path().join("bode.svg");
    let v = json_of(
        &["--plant", "@", "--controller", "@", "--plot", "@"],
        &[&g, &k, &svg],
    );
    // |L| = 1 at w^4 + w^2 - 4 = 0.
    let w = ((17f64.sqrt() - 1.0) / 2.0).sqrt();
    let f = v["phase_margin"]["freq_hz"].as_f64().unwrap();
    assert!((f * 2.0 * std::f64::consts::PI - w).abs() < 1e-12 * w);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"));
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let g = data("fixtures/second-order-plant.json");
    let gd = data("fixtures/second-order-plant-zoh.json");
    let broken = write(dir.path(), "bad.json", r#"{"format":"fts.tf/1","var":"s"}"#);
    let cases: Vec<Vec<std::ffi::OsString>> = vec![
        vec!["--plant".into(), g.clone().into()],
        vec![
            "--plant".into(),
            g.clone().into(),
            "--kd".into(),
            "1".into(),
        ],
        vec![
            "--plant".into(),
            gd.clone().into(),
            "--kp".into(),
            "1".into(),
            "--tf-derivative".into(),
            "100".into(),
        ],
        vec![
            "--plant".into(),
            g.clone().into(),
            "--controller".into(),
            gd.clone().into(),
        ],
        vec!["--plant".into(), broken.into(), "--kp".into(), "1".into()],
        vec![
            "--plant".into(),
            g.clone().into(),
            "--kp".into(),
            "0".into(),
        ],
        vec![
            "--plant".into(),
            g.into(),
            "--kp".into(),
            "1".into(),
            "--fmin".into(),
            "-3".into(),
        ],
    ];
    for args in cases {
        let out = fts()
            .arg("loop")
            .args(&args)
            .assert()
            .code(2)
            .get_output()
            .clone();
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(err.starts_with("fts: error: "), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(out.stdout.is_empty());
    }
}

#[test]
fn docs_worked_example_is_the_output() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/loop.md")).unwrap();
    let start = doc
        .find("$ fts loop --plant tests/data/loop/virtual-fts-linear.json")
        .unwrap();
    let block = &doc[start..];
    let block = &block[block.find('\n').unwrap() + 1..block.find("```").unwrap()];
    let out = fts()
        .current_dir(root)
        .args([
            "loop",
            "--plant",
            "tests/data/loop/virtual-fts-linear.json",
            "--kp",
            "0.02",
            "--ki",
            "0.15",
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    // The page's run also draws the plot; its `fts: wrote` line is stderr.
    let block = block.trim_end_matches("fts: wrote loop.svg\n");
    assert_eq!(String::from_utf8(out).unwrap(), block);
}

#[test]
fn mixsyn_example_controller() {
    let g = data("examples/mixsyn/plant.json");
    let k = data("examples/mixsyn/K.json");
    let v = json_of(&["--plant", "@", "--controller", "@"], &[&g, &k]);
    assert_eq!(v["closed_loop_stable"], true);
    assert_eq!(v["diagnostics"]["gain_crossovers"], 1);
    let pm = v["phase_margin"]["phase_margin_deg"].as_f64().unwrap();
    let f = v["phase_margin"]["freq_hz"].as_f64().unwrap();
    assert!(
        (pm - 90.00).abs() < 0.01 && (f - 1006.5).abs() < 0.1,
        "{pm} {f}"
    );
    let mm = v["modulus_margin"]["value"].as_f64().unwrap();
    assert!((mm - 1.000).abs() < 1e-3, "{mm}");
}
