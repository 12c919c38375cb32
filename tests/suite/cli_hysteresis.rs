//! `fts identify hysteresis`, `fts hysteresis invert|apply` end to end: happy
//! paths, and every bad input exits with code 2, names the problem, never
//! panics, and leaves no output file.

use crate::common::cmd::{fts, predicate};
use fts::ident::hysteresis::operators::uniform_thresholds;
use fts::ident::hysteresis::{HysteresisModel, ModelKind, PlayOperator};
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// Nothing but the inputs is left in the folder.
fn assert_only(dir: &Path, expected: &[&str]) {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut expected: Vec<String> = expected.iter().map(|s| s.to_string()).collect();
    expected.sort();
    assert_eq!(names, expected);
}

/// Triangles of several amplitudes through a known symmetric-play PI model
/// with an offset, as a `t,u,y` CSV.
fn record() -> (String, HysteresisModel, Vec<f64>) {
    let mut u = vec![0.0];
    let mut last = 0.0;
    for a in [4.0, 10.0, 7.0, 2.0, 8.5] {
        for target in [a, -a, 0.0] {
            for k in 1..=60 {
                u.push(last + (target - last) * k as f64 / 60.0);
            }
            last = target;
        }
    }
    let truth = HysteresisModel {
        kind: ModelKind::Pi,
        operator: PlayOperator::Symmetric,
        thresholds: uniform_thresholds(6, 10.0),
        weights: vec![0.8, 0.2, -0.1, 0.15, 0.05, 0.1],
        cbrt_gain: 0.0,
        offset: 0.5,
        input_offset: 0.0,
        dead_zone: None,
        input_dead_zone: None,
        rate: None,
    };
    let y = truth.simulate(&u);
    let mut csv = String::from("t,u,y\n");
    for (k, (a, b)) in u.iter().zip(&y).enumerate() {
        csv.push_str(&format!("{},{a},{b}\n", k as f64 * 1e-3));
    }
    (csv, truth, u)
}

#[test]
fn identify_json_model_file_plot_then_invert_and_apply() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, truth, u) = record();
    let data = write(dir.path(), "data.csv", &csv);
    let model = dir.path().join("model.json");
    let svg = dir.path().join("loop.svg");
    let out = fts()
        .args(["identify", "hysteresis"])
        .arg(&data)
        .args([
            "--model",
            "pi",
            "--operator",
            "play-symmetric",
            "--operators",
            "6",
            "--json",
            "-o",
        ])
        .arg(&model)
        .arg("--plot")
        .arg(&svg)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).expect("exactly one JSON object");
    // docs/formats.md fields.
    let weights: Vec<f64> = serde_json::from_value(v["weights"].clone()).unwrap();
    let thresholds: Vec<f64> = serde_json::from_value(v["thresholds"].clone()).unwrap();
    assert_eq!(thresholds, truth.thresholds);
    for (a, b) in weights.iter().zip(&truth.weights) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
    assert_eq!(v["cbrt_gain"], 0.0);
    assert!(v["fit"]["rms_percent"].as_f64().unwrap() < 1e-9);
    assert!(v["fit"]["max_percent"].as_f64().unwrap() < 1e-9);
    assert!(v["condition_number"].as_f64().unwrap() > 1.0);
    assert_eq!(v["iterations"], 0);
    assert_eq!(v["mapping"], "voltage->displacement");
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("\"format\": \"fts.hysteresis/1\""));
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));

    // Analytic inverse, then apply it to the forward output: u comes back.
    let inv = dir.path().join("inv.json");
    fts()
        .args(["hysteresis", "invert"])
        .arg(&model)
        .arg("-o")
        .arg(&inv)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "check: max |u - inverse(forward(u))|",
        ));
    let inv_text = std::fs::read_to_string(&inv).unwrap();
    assert!(inv_text.contains("\"mapping\": \"displacement->voltage\""));

    let applied = dir.path().join("u_back.csv");
    fts()
        .args(["hysteresis", "apply"])
        .arg(&inv)
        .arg(&data)
        .args(["--input-col", "y", "--time-col", "t", "-o"])
        .arg(&applied)
        .assert()
        .success();
    let back = std::fs::read_to_string(&applied).unwrap();
    let mut lines = back.lines();
    assert_eq!(lines.next(), Some("t,u,y"));
    for (line, want) in lines.zip(&u) {
        let got: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!((got - want).abs() < 1e-8, "{got} vs {want}");
    }
}

/// The analytic inverse of MPI-deadzone (docs/math.md §1.6): `invert` writes
/// a PI model with an input dead-zone stage, and applying it to the forward
/// model's output gives the input back.
#[test]
fn mpi_deadzone_inverts_analytically_and_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "dz.json",
        r#"{"format": "fts.hysteresis/1", "model": "mpi-deadzone", "operator": "play-symmetric",
            "thresholds": [0.0, 1.0, 2.0, 3.0], "weights": [0.9, 0.2, -0.1, 0.15],
            "offset": 0.4, "input_offset": -0.3,
            "dead_zone": {"thresholds": [0.0, 1.0, 2.5], "weights": [1.1, -0.3, 0.2]}}"#,
    );
    let (csv, _, u) = record();
    write(d, "data.csv", &csv);
    fts()
        .current_dir(d)
        .args([
            "hysteresis",
            "apply",
            "dz.json",
            "data.csv",
            "-o",
            "fwd.csv",
        ])
        .assert()
        .success();
    let out = fts()
        .current_dir(d)
        .args([
            "hysteresis",
            "invert",
            "dz.json",
            "-o",
            "inv.json",
            "--json",
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert!(v["round_trip_max_error"].as_f64().unwrap() < 1e-12);
    // d'_j = D[d_j]: 0, 1.1, 1.1 * 2.5 - 0.3 * 1.5 = 2.3; g'_0 = 1/1.1.
    let dz = &v["input_dead_zone"];
    let dt: Vec<f64> = serde_json::from_value(dz["thresholds"].clone()).unwrap();
    for (got, want) in dt.iter().zip([0.0, 1.1, 2.3]) {
        assert!((got - want).abs() < 1e-12, "{dt:?}");
    }
    assert!((dz["weights"][0].as_f64().unwrap() - 1.0 / 1.1).abs() < 1e-15);
    assert!(
        std::fs::read_to_string(d.join("inv.json"))
            .unwrap()
            .contains("\"input_dead_zone\"")
    );
    fts()
        .current_dir(d)
        .args([
            "hysteresis",
            "apply",
            "inv.json",
            "fwd.csv",
            "--input-col",
            "y",
        ])
        .args(["-o", "back.csv"])
        .assert()
        .success();
    let back = std::fs::read_to_string(d.join("back.csv")).unwrap();
    let mut n = 0;
    for (line, want) in back.lines().skip(1).zip(&u) {
        let got: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        n += 1;
    }
    assert_eq!(n, u.len());
}

/// A nearly flat dead-zone stage (G_1 = 1e-12) inverts on paper, but the
/// inverse amplifies round-off 1e12 times: the self-check fails, exit 1,
/// nothing written.
#[test]
fn invert_self_check_fails_on_an_ill_conditioned_stage() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "flat.json",
        r#"{"format": "fts.hysteresis/1", "model": "mpi-deadzone", "operator": "play-symmetric",
            "thresholds": [0.0, 1.0, 2.0], "weights": [1.0, 0.2, 0.1],
            "dead_zone": {"thresholds": [0.0, 1.5], "weights": [1.0, -0.999999999999]}}"#,
    );
    fts()
        .current_dir(d)
        .args(["hysteresis", "invert", "flat.json", "-o", "inv.json"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("flat.json: self-check failed"))
        .stderr(predicate::str::contains("no inverse written"));
    assert_only(d, &["flat.json"]);
}

#[test]
fn gd_reports_iterations_and_inverse_swaps_signals() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, _, _) = record();
    let data = write(dir.path(), "data.csv", &csv);
    let out = fts()
        .args(["identify", "hysteresis"])
        .arg(&data)
        .args(["--method", "gd", "--inverse", "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert!(v["iterations"].as_u64().unwrap() > 0);
    assert_eq!(v["mapping"], "displacement->voltage");
    assert_eq!(v["model"], "mpi-cbrt");
    assert!(v["cbrt_gain"].is_number());
}

#[test]
fn li21_fixture_applies() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "x.csv", "u\n0\n4.8385\n9.677\n4.8385\n0\n");
    fts()
        .args(["hysteresis", "apply"])
        .arg(fixture("li21-inverse-mpi.json"))
        .arg(&data)
        .arg("--json")
        .assert()
        .success()
        .stdout(predicate::str::contains("\"output_max\": 1.96473"));
}

/// Runs a failing command; checks exit 2, the message, and that no file but
/// the inputs is left.
fn assert_bad(dir: &Path, inputs: &[&str], args: &[&str], message: &str) {
    fts()
        .current_dir(dir)
        .args(args)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(message))
        .stderr(predicate::str::contains("panicked").not());
    assert_only(dir, inputs);
}

#[test]
fn bad_inputs_exit_2_name_the_problem_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (csv, _, _) = record();
    write(d, "data.csv", &csv);
    let constant: String = std::iter::once("u,y\n".to_string())
        .chain((0..100).map(|k| format!("2.5,{k}\n")))
        .collect();
    write(d, "constant.csv", &constant);
    write(d, "short.csv", "u,y\n0,0\n1,1\n2,3\n1,2\n");
    write(d, "nan.csv", "u,y\n0,0\n1,NaN\n2,3\n");
    let model = fixture("li21-inverse-mpi.json");
    let mismatched = std::fs::read_to_string(&model)
        .unwrap()
        .replace("\"weights\": [0.29, ", "\"weights\": [");
    write(d, "mismatched.json", &mismatched);
    let inputs = [
        "data.csv",
        "constant.csv",
        "short.csv",
        "nan.csv",
        "mismatched.json",
    ];
    let id = |file: &'static str| vec!["identify", "hysteresis", file, "-o", "m.json"];

    assert_bad(
        d,
        &inputs,
        &id("constant.csv"),
        "the input is constant (2.5)",
    );
    assert_bad(d, &inputs, &id("short.csv"), "too few samples: 4");
    assert_bad(d, &inputs, &id("nan.csv"), "nan.csv line 3, field 'y'");
    let mut args = id("data.csv");
    args.extend(["--thresholds", "0,2,1"]);
    assert_bad(
        d,
        &inputs,
        &args,
        "--thresholds: thresholds must increase strictly: threshold 2 (1)",
    );
    let mut args = id("data.csv");
    args.extend(["--method", "gd", "--invertible"]);
    assert_bad(d, &inputs, &args, "needs --method ls");
    assert_bad(
        d,
        &inputs,
        &["identify", "hysteresis", "missing.csv", "-o", "m.json"],
        "missing.csv: cannot read",
    );
    assert_bad(
        d,
        &inputs,
        &[
            "hysteresis",
            "apply",
            "mismatched.json",
            "data.csv",
            "-o",
            "o.csv",
        ],
        "mismatched.json field 'weights': 'weights' has 9 entries but 'thresholds' has 10",
    );
    assert_bad(
        d,
        &inputs,
        &["hysteresis", "invert", "mismatched.json", "-o", "i.json"],
        "'weights' has 9 entries",
    );
    // The Li21 model is MPI-cbrt on the lower play: no analytic inverse.
    let li21 = model.to_str().unwrap();
    assert_bad(
        d,
        &inputs,
        &["hysteresis", "invert", li21, "-o", "i.json"],
        "no closed-form inverse",
    );
    let mut args = id("data.csv");
    args.extend(["--start", "5000"]);
    assert_bad(d, &inputs, &args, "sample range 5000..");
}

/// A PI model whose loading curve turns down (partial sum W_1 = 1 - 1.5 < 0)
/// is valid but has no inverse: exit 1, one line naming the partial sum, no
/// file written.
#[test]
fn invert_refuses_a_non_increasing_loading_curve_with_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "h.json",
        r#"{"format": "fts.hysteresis/1", "model": "pi", "operator": "play-symmetric",
            "thresholds": [0.0, 1.0, 2.0], "weights": [1.0, -1.5, 0.2]}"#,
    );
    fts()
        .current_dir(d)
        .args(["hysteresis", "invert", "h.json", "-o", "inv.json"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "h.json: partial sum W_1 = -0.5 of the weights is not positive",
        ))
        .stderr(predicate::str::contains("panicked").not());
    assert!(!d.join("inv.json").exists());
}

/// `--rate-dependent` (docs/math.md §1.7): the model file carries the rate
/// stage, `apply` reads it back and reproduces the identification fit; the
/// analytic inverse and the runtime's HC refuse it.
#[test]
fn rate_dependent_model_round_trips_and_is_refused_where_unsupported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ok = |args: &[&str]| {
        let out = fts().current_dir(d).args(args).assert().success();
        String::from_utf8(out.get_output().stdout.clone()).unwrap()
    };
    ok(&[
        "virtual",
        "triangles",
        "--freq",
        "5,200",
        "--amplitudes",
        "10,5",
        "--rate-coefficient",
        "1",
        "-o",
        "r.csv",
    ]);
    let text = ok(&[
        "identify",
        "hysteresis",
        "r.csv",
        "--model",
        "pi",
        "--rate-dependent",
        "--json",
        "-o",
        "rd.json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&text).unwrap();
    let rms = report["fit"]["rms_percent"].as_f64().unwrap();
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("rd.json")).unwrap()).unwrap();
    assert_eq!(
        model["rate_dependent"]["weights"].as_array().unwrap().len(),
        10
    );
    assert_eq!(model["rate_dependent"]["ts"].as_f64().unwrap(), 1e-4);
    let applied: serde_json::Value = serde_json::from_str(&ok(&[
        "hysteresis",
        "apply",
        "rd.json",
        "r.csv",
        "--compare-col",
        "y",
        "--json",
    ]))
    .unwrap();
    let again = applied["fit_rms_percent"].as_f64().unwrap();
    assert!((again - rms).abs() <= 1e-9 * rms, "{again} vs {rms}");
    fts()
        .current_dir(d)
        .args(["hysteresis", "invert", "rd.json", "-o", "inv.json"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("rate-dependent weights"));
    fts()
        .current_dir(d)
        .args([
            "emit",
            "--hysteresis",
            "rd.json",
            "--kp",
            "0.05",
            "--ki",
            "0.3",
            "--ts",
            "1e-4",
            "--pid-form",
            "li21",
            "-o",
            "c.json",
        ])
        .assert()
        .success();
    // The runtime's HC block carries the rate stage.
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("c.json")).unwrap()).unwrap();
    let hc = &c["blocks"][0];
    assert_eq!(hc["type"], "hysteresis_inverse");
    assert_eq!(
        hc["rate_dependent"]["weights"].as_array().unwrap().len(),
        10
    );
    assert!(!d.join("inv.json").exists());
    // mpi-deadzone has no rate stage: a setting error naming it.
    fts()
        .current_dir(d)
        .args([
            "identify",
            "hysteresis",
            "r.csv",
            "--model",
            "mpi-deadzone",
            "--rate-dependent",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--rate-dependent"));
}

/// A model records the input range it was identified on (`input_range`),
/// and `hysteresis apply` warns, naming that range and the excursion, when
/// an input leaves it (issue #31): ±15 V on a model identified on ±10 V.
#[test]
fn apply_warns_beyond_the_identified_input_range() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, _, u) = record();
    let data = write(dir.path(), "data.csv", &csv);
    let model = dir.path().join("model.json");
    fts()
        .args(["identify", "hysteresis"])
        .arg(&data)
        .args(["--model", "pi", "--operator", "play-symmetric"])
        .args(["--operators", "6", "-o"])
        .arg(&model)
        .assert()
        .success();
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(doc["input_range"], serde_json::json!([-10.0, 10.0]));
    let apply = |record: &Path| {
        let out = fts()
            .args(["hysteresis", "apply"])
            .arg(&model)
            .arg(record)
            .args(["--input-col", "u"])
            .assert()
            .success()
            .get_output()
            .clone();
        String::from_utf8(out.stderr).unwrap()
    };
    assert_eq!(apply(&data), "", "inside the range nothing is said");
    let mut wide = String::from("u\n");
    for v in &u {
        wide.push_str(&format!("{}\n", 1.5 * v));
    }
    let wide = write(dir.path(), "wide.csv", &wide);
    let warning = apply(&wide);
    assert_eq!(warning.lines().count(), 1, "{warning}");
    for needle in [
        "warning:",
        "wide.csv",
        "[-15, 15] V",
        "[-10, 10] V",
        "by up to 5 V",
    ] {
        assert!(warning.contains(needle), "{needle:?} not in {warning}");
    }
}
