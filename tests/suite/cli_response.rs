//! `fts response`, the conversion commands and `fts simulate --reference
//! step` from the outside: results, files, bounds and exit codes.

use crate::common::cmd::{Command, fts, json_of, predicate};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn json_out(cmd: &mut Command) -> Value {
    json_of(cmd.arg("--json"))
}

const SECOND_ORDER: &str = r#"{"format": "fts.tf/1", "var": "s", "num": [9], "den": [1, 1.8, 9]}"#;
const MIMO: &str = r#"{"format": "fts.ss/1", "ts": null,
  "a": [[-1, 0.5, 0], [-0.5, -2, 1], [0, 0, -3]], "b": [[1, 0], [0.3, 1], [0, 2]],
  "c": [[1, 0, 0.5], [0.2, 1, 0]], "d": [[0, 0], [0.1, 0]]}"#;

#[test]
fn step_of_a_second_order_system_has_the_closed_form_overshoot() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(dir.path(), "g.json", SECOND_ORDER);
    let csv = dir.path().join("s.csv");
    let v = json_out(
        fts()
            .args(["response", "step"])
            .arg(&g)
            .args(["--duration", "10", "--points", "100001", "-o"])
            .arg(&csv),
    );
    let info = &v["channels"][0]["step_info"];
    // zeta = 0.3: overshoot 100 exp(-pi zeta / sqrt(1 - zeta^2)) = 37.2326 %.
    let os = 100.0 * (-std::f64::consts::PI * 0.3 / (1.0f64 - 0.09).sqrt()).exp();
    assert!(
        (info["overshoot"].as_f64().unwrap() - os).abs() < 1e-4,
        "{info}"
    );
    assert_eq!(info["steady_state"].as_f64().unwrap(), 1.0);
    assert_eq!(v["samples"], 100001);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("t,y\n0,0\n"));
    assert_eq!(text.lines().count(), 100002);
}

#[test]
fn closed_loop_with_pid_gains_and_with_a_controller_file_agree() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(
        dir.path(),
        "g.json",
        r#"{"format": "fts.tf/1", "var": "s", "num": [1], "den": [1, 4, 3]}"#,
    );
    // 4 + 3/s = (4 s + 3)/s.
    let k = write(
        dir.path(),
        "k.json",
        r#"{"format": "fts.tf/1", "var": "s", "num": [4, 3], "den": [1, 0]}"#,
    );
    let a = json_out(fts().args(["response", "step"]).arg(&g).args([
        "--kp",
        "4",
        "--ki",
        "3",
        "--duration",
        "10",
    ]));
    let b = json_out(
        fts()
            .args(["response", "step"])
            .arg(&g)
            .arg("--controller")
            .arg(&k)
            .args(["--duration", "10"]),
    );
    assert_eq!(a["closed_loop"], true);
    let (x, y) = (
        &a["channels"][0]["step_info"],
        &b["channels"][0]["step_info"],
    );
    for key in ["rise_time", "settling_time", "overshoot", "peak"] {
        let (p, q) = (x[key].as_f64().unwrap(), y[key].as_f64().unwrap());
        assert!(
            (p - q).abs() <= 1e-9 * p.abs().max(1.0),
            "{key}: {p} vs {q}"
        );
    }
    // Integral action: no steady-state error.
    assert!(x["steady_state_error"].as_f64().unwrap().abs() < 1e-12);
}

/// docs/responses.md §1 "Unstable systems": exit 1, one error line,
/// nothing on stdout and no file written, whatever outputs were asked for.
#[test]
fn unstable_system_exits_1_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(
        dir.path(),
        "u.json",
        r#"{"format": "fts.tf/1", "var": "s", "num": [1], "den": [1, -1]}"#,
    );
    let csv = dir.path().join("u.csv");
    let svg = dir.path().join("u.svg");
    for kind in ["step", "impulse"] {
        for json in [false, true] {
            let mut cmd = fts();
            cmd.args(["response", kind])
                .arg(&g)
                .args(["--duration", "2", "-o"])
                .arg(&csv)
                .arg("--plot")
                .arg(&svg);
            if json {
                cmd.arg("--json");
            }
            let out = cmd.assert().code(1).stdout("").get_output().stderr.clone();
            let err = String::from_utf8(out).unwrap();
            assert_eq!(err.lines().count(), 1, "{err}");
            assert!(
                err.starts_with("fts: error: ") && err.contains("unstable"),
                "{err}"
            );
            assert!(!csv.exists() && !svg.exists());
        }
    }
}

const STIFF: &str = r#"{"format":"fts.tf/1","var":"s","num":[5000.01,51.0,10000.0],"den":[1.0,100.01,1000001.0,10000.0]}"#;
const LIGHT: &str = r#"{"format":"fts.tf/1","var":"s","num":[1],"den":[1,0.002,1]}"#;

/// Issue #27: with the defaults, the stiff system's 363 % overshoot at
/// 1.52 ms is reported (python-control: 0 %), the default grid holds the
/// peak sample itself, and no warning is printed. Reference values:
/// tests/data/responses/exact_figures.json (mpmath).
#[test]
fn stiff_step_reports_the_fast_peak_with_the_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(dir.path(), "stiff.json", STIFF);
    let csv = dir.path().join("s.csv");
    let out = fts()
        .args(["response", "step"])
        .arg(&g)
        .arg("-o")
        .arg(&csv)
        .arg("--json")
        .assert()
        .success()
        .stderr(format!("fts: wrote {}\n", csv.display()))
        .get_output()
        .stdout
        .clone();
    let v: Value = serde_json::from_slice(&out).unwrap();
    let info = &v["channels"][0]["step_info"];
    let f = |k: &str| info[k].as_f64().unwrap();
    assert!((f("overshoot") - 363.347533166807).abs() < 1e-6, "{info}");
    assert!((f("peak") - 4.633475331668071).abs() < 1e-9, "{info}");
    assert!((f("peak_time") - 1.522682169e-3).abs() < 1e-9, "{info}");
    // MATLAB's band: 2 % of the peak error max |y - 1| = 4.959 (the undershoot).
    assert!((f("settling_time") - 231.0799496565).abs() < 1e-6, "{info}");
    assert_eq!(v["grid"], "composite");
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<(f64, f64)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let (t, y) = l.split_once(',').unwrap();
            (t.parse().unwrap(), y.parse().unwrap())
        })
        .collect();
    assert_eq!(rows.len() as u64, v["samples"].as_u64().unwrap());
    assert!(rows.windows(2).all(|w| w[0].0 < w[1].0), "times increase");
    let top = rows.iter().fold(0.0f64, |m, r| m.max(r.1.abs()));
    assert_eq!(top, f("peak"), "the CSV holds the peak sample");
}

/// 1/(s^2 + 0.002 s + 1): 99.686 % at pi s (python-control: 96.6 % at
/// 34.5 s), a rise of about 1.02 s (not 0).
#[test]
fn lightly_damped_step_has_its_closed_form_peak_and_a_rise() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(dir.path(), "light.json", LIGHT);
    let v = json_out(fts().args(["response", "step"]).arg(&g));
    let info = &v["channels"][0]["step_info"];
    let zeta = 0.001f64;
    let wd = (1.0 - zeta * zeta).sqrt();
    let pi = std::f64::consts::PI;
    let os = 100.0 * (-zeta * pi / wd).exp();
    assert!(
        (info["overshoot"].as_f64().unwrap() - os).abs() < 1e-8,
        "{info}"
    );
    assert!(
        (info["peak_time"].as_f64().unwrap() - pi / wd).abs() < 1e-8,
        "{info}"
    );
    let rise = info["rise_time"].as_f64().unwrap();
    assert!((rise - 1.0203861238316254).abs() < 1e-8, "{info}");
}

fn warnings(args: &[&str], file: &str) -> (Value, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let g = write(dir.path(), "g.json", file);
    let out = fts()
        .args(["response"])
        .arg(args[0])
        .arg(&g)
        .args(&args[1..])
        .arg("--json")
        .assert()
        .success()
        .get_output()
        .clone();
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    (v, err.lines().map(str::to_owned).collect())
}

/// docs/responses.md §2 "Warnings": a uniform grid too coarse for the
/// fast mode, a duration shorter than the settling or the peak, an impulse
/// response cut before it decays: one stderr line each, `warning: `, the
/// option named; the figures stay exact.
#[test]
fn truncating_options_are_warned_about() {
    let (v, w) = warnings(&["step", "--points", "2001"], STIFF);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("warning: ") && w[0].contains("--points 2001"),
        "{w:?}"
    );
    assert!(
        w[0].contains("too coarse") && w[0].contains("4.633475"),
        "{w:?}"
    );
    assert_eq!(v["grid"], "uniform");
    assert_eq!(v["samples"], 2001);
    assert!((v["channels"][0]["step_info"]["overshoot"].as_f64().unwrap() - 363.3475).abs() < 1e-3);

    let (v, w) = warnings(&["step", "--duration", "100"], STIFF);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("--duration 100 s ends before the response settles"),
        "{w:?}"
    );
    assert!(w[0].contains("231.0799"), "{w:?}");
    assert!(v["channels"][0]["step_info"]["settling_time"].is_null());

    // 1/(s^2 + 0.4 s + 1) peaks at 3.2 s: cut at 2 s.
    let (_, w) = warnings(
        &["step", "--duration", "2"],
        r#"{"format":"fts.tf/1","var":"s","num":[1],"den":[1,0.4,1]}"#,
    );
    assert!(
        w.iter().any(|l| l.contains("ends before the peak")),
        "{w:?}"
    );

    let (v, w) = warnings(&["impulse", "--duration", "10"], LIGHT);
    assert!(
        w.iter()
            .any(|l| l.contains("ends before the impulse response decays")),
        "{w:?}"
    );
    assert!(
        (v["channels"][0]["peak"].as_f64().unwrap() - 0.99843).abs() < 1e-3,
        "{v}"
    );

    // The rise of the lightly damped system (1.02 s) spans a third of a
    // 3.45 s step: the samples do not show it.
    let (_, w) = warnings(&["step", "--points", "2001"], LIGHT);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("--points 2001"), "{w:?}");
}

#[test]
fn sizes_are_bounded_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(dir.path(), "g.json", SECOND_ORDER);
    let li21 = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/li21-closed-loop.json");
    for (sys, args, culprit) in [
        (&g, vec!["--points", "2000000"], "--points"),
        (&g, vec!["--points", "1"], "--points"),
        (&g, vec!["--duration", "-1"], "--duration"),
        (&li21, vec!["--duration", "1e6"], "--duration"),
        (&li21, vec!["--points", "100"], "--points"),
    ] {
        fts()
            .args(["response", "step"])
            .arg(sys)
            .args(&args)
            .assert()
            .code(2)
            .stderr(predicate::str::starts_with(format!(
                "fts: error: {culprit}"
            )));
    }
}

#[test]
fn mimo_to_tf_writes_one_readable_file_per_channel() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(dir.path(), "m.json", MIMO);
    let out = dir.path().join("m-tf.json");
    let v = json_out(
        fts()
            .arg("convert")
            .arg(&m)
            .args(["--to", "tf", "-o"])
            .arg(&out),
    );
    assert_eq!(v["channels"].as_array().unwrap().len(), 4);
    for (i, j) in [(1, 1), (1, 2), (2, 1), (2, 2)] {
        let p = dir.path().join(format!("m-tf.y{i}u{j}.json"));
        // Each channel file is a model the other commands read: its step's
        // final value is the channel's DC gain, as in the MIMO response.
        let one = json_out(
            fts()
                .args(["response", "step"])
                .arg(&p)
                .args(["--duration", "30"]),
        );
        let all = json_out(
            fts()
                .args(["response", "step"])
                .arg(&m)
                .args(["--duration", "30"]),
        );
        let ch = all["channels"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["output"] == i && c["input"] == j)
            .unwrap()
            .clone();
        let (a, b) = (
            one["channels"][0]["step_info"]["steady_state"]
                .as_f64()
                .unwrap(),
            ch["step_info"]["steady_state"].as_f64().unwrap(),
        );
        assert!((a - b).abs() < 1e-9, "y{i}u{j}: {a} vs {b}");
    }
}

#[test]
fn conversions_refuse_what_they_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let li21 = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/li21-closed-loop.json");
    fts()
        .arg("d2c")
        .arg(&li21)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("negative real axis"));
    let g = write(dir.path(), "g.json", SECOND_ORDER);
    fts()
        .arg("d2c")
        .arg(&g)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("already continuous"));
    let m = write(dir.path(), "m.json", MIMO);
    fts()
        .arg("balred")
        .arg(&m)
        .args(["--order", "5"])
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with("fts: error: --order"));
    let u = write(
        dir.path(),
        "u.json",
        r#"{"format": "fts.tf/1", "var": "s", "num": [1], "den": [1, -1]}"#,
    );
    fts()
        .arg("balred")
        .arg(&u)
        .args(["--order", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("unstable"));
}

#[test]
fn c2d_then_d2c_gives_the_model_back() {
    let dir = tempfile::tempdir().unwrap();
    let g = write(dir.path(), "g.json", SECOND_ORDER);
    let gd = dir.path().join("gd.json");
    let gc = dir.path().join("gc.json");
    fts()
        .arg("c2d")
        .arg(&g)
        .args(["--ts", "0.01", "-o"])
        .arg(&gd)
        .assert()
        .success();
    fts()
        .arg("d2c")
        .arg(&gd)
        .arg("-o")
        .arg(&gc)
        .assert()
        .success();
    let z = json_out(fts().arg("zpk").arg(&gc));
    let poles = z["channels"][0]["poles"].as_array().unwrap();
    // s^2 + 1.8 s + 9: -0.9 +- j sqrt(8.19).
    for p in poles {
        assert!((p[0].as_f64().unwrap() + 0.9).abs() < 1e-9, "{p}");
        assert!(
            (p[1].as_f64().unwrap().abs() - 8.19f64.sqrt()).abs() < 1e-9,
            "{p}"
        );
    }
    assert!((z["channels"][0]["gain"].as_f64().unwrap() - 9.0).abs() < 1e-8);
}

#[test]
fn simulate_step_reports_step_figures() {
    let v = json_out(fts().args([
        "simulate",
        "--stages",
        "pid",
        "--reference",
        "step",
        "--amplitude",
        "2",
    ]));
    let step = &v["step"];
    assert!(step["info"]["rise_time"].as_f64().unwrap() > 0.0, "{step}");
    assert!(
        step["steady_state_error"].as_f64().unwrap().abs() < 0.05,
        "{step}"
    );
    assert_eq!(v["reference"], "step 2 um from 7 um at 0.01 s");
    fts()
        .args([
            "simulate",
            "--stages",
            "pid",
            "--reference",
            "step",
            "--step-time",
            "1",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("step-time"));
}

/// The mixed-sensitivity controller of examples/mixsyn spans poles from
/// 0.2 to 5e7 rad/s: its reduction reports the Hankel singular values and
/// bound of the system (the near-integrator's 15808 among them), and its DC
/// gain moves by no more than the bound.
#[test]
fn balred_of_the_mixsyn_controller_reports_a_true_bound() {
    let k = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mixsyn/K.json");
    let dir = tempfile::tempdir().unwrap();
    let kr = dir.path().join("kr.json");
    let v = json_out(
        fts()
            .arg("balred")
            .arg(&k)
            .args(["--order", "3", "-o"])
            .arg(&kr),
    );
    let hsv: Vec<f64> = serde_json::from_value(v["hankel_singular_values"].clone()).unwrap();
    assert!((hsv[2] - 15808.44).abs() < 1.0, "{hsv:?}");
    let bound = v["error_bound"].as_f64().unwrap();
    assert!((bound - 2.0 * hsv[3]).abs() < 1e-9 * bound, "{v}");
    let dc = |path: &Path| {
        let text = std::fs::read_to_string(path).unwrap();
        let sys = fts::io::ss_json::parse_system(&text, "k").unwrap();
        sys.dc_gain().unwrap()[(0, 0)]
    };
    let (before, after) = (dc(&k), dc(&kr));
    assert!(before.abs() > 3e4, "{before}");
    assert!(
        (before - after).abs() <= bound * (1.0 + 1e-5),
        "{before} -> {after}, bound {bound}"
    );
}
