//! `fts identify arx|oe|iv|arx-struct` and `fts bode` end to end: the DaISy
//! records, the \[Li21\] closed loop, and every bad input exiting with code 2,
//! naming the problem and leaving no output file.

use crate::common::cmd::{fts, json_of, predicate};
use crate::common::unit_uniform;
use fts::ident::excite::{SweepParams, SweepSpacing, sweep};
use fts::ident::linear::filter_ab;
use serde_json::Value;
use std::path::{Path, PathBuf};

const LI21_B: [f64; 5] = [4.154, -9.631, 10.23, -5.511, 1.154];
const LI21_A: [f64; 6] = [1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447];

fn dataset(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(rel)
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Only the inputs are left in the folder (no result, no temporary file).
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

/// `t,u,y` CSV of the \[Li21\] closed loop driven by a 0-1 kHz sweep, with
/// white measurement noise of standard deviation `noise` on `y`.
fn li21_csv(n: usize, noise: f64) -> String {
    let ts = 1e-4;
    let u = sweep(&SweepParams {
        f0: 0.0,
        f1: 1000.0,
        duration: n as f64 * ts,
        amplitude: 1.0,
        offset: 0.0,
        ts,
        spacing: SweepSpacing::Linear,
    })
    .unwrap();
    let y = filter_ab(&LI21_B, &LI21_A, 5, &u);
    let mut uni = unit_uniform(0x1234_5678);
    let mut out = String::from("t,u,y\n");
    for k in 0..u.len() {
        let e = (0..12).map(|_| uni()).sum::<f64>() - 6.0;
        // 17 significant digits: the CSV round-trips f64 exactly.
        out.push_str(&format!(
            "{:.17e},{:.17e},{:.17e}\n",
            k as f64 * ts,
            u[k],
            y[k] + noise * e
        ));
    }
    out
}

#[test]
fn dryer_arx_223_delay_and_validation_fit() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plant.json");
    let dryer = dataset("daisy-hairdryer/dryer.dat");
    let v = json_of(
        fts()
            .args(["identify", "arx"])
            .arg(&dryer)
            .args([
                "--ts",
                "0.08",
                "--detrend",
                "mean",
                "--split",
                "0.5",
                "--na",
                "2",
                "--nb",
                "2",
                "--nk",
                "3",
                "--json",
                "-o",
            ])
            .arg(&out),
    );
    assert_eq!(v["delay"], 3);
    assert_eq!(v["ts"], 0.08);
    let den = floats(&v["den"]);
    let num = floats(&v["num"]);
    assert_eq!(den.len(), 3);
    assert_eq!(num.len(), 2);
    // Stable second-order lag with a positive gain near 0.92.
    assert!(
        (den[1] + 1.2765).abs() < 1e-3 && (den[2] - 0.3967).abs() < 1e-3,
        "{den:?}"
    );
    assert!(
        (num[0] - 0.0652).abs() < 1e-3 && (num[1] - 0.0452).abs() < 1e-3,
        "{num:?}"
    );
    let fit = v["fit_percent"].as_f64().unwrap();
    let val = v["validation_fit_percent"].as_f64().unwrap();
    assert!((85.0..92.0).contains(&fit), "estimation fit {fit}");
    assert!((85.0..93.0).contains(&val), "validation fit {val}");
    assert!(v["prediction_fit_percent"].as_f64().unwrap() > fit);
    for key in [
        "std_den",
        "std_num",
        "loss",
        "fpe",
        "aic",
        "condition_number",
        "whiteness",
    ] {
        assert!(!v[key].is_null(), "{key}");
    }
    // The file is an fts.tf/1 with the same numbers.
    let file: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(file["format"], "fts.tf/1");
    assert_eq!(file["den"], v["den"]);
    assert_eq!(file["delay"], 3);
}

#[test]
fn dryer_structure_selection_estimates_three_samples_delay() {
    let v = json_of(
        fts()
            .args(["identify", "arx-struct"])
            .arg(dataset("daisy-hairdryer/dryer.dat"))
            .args([
                "--ts",
                "0.08",
                "--detrend",
                "mean",
                "--split",
                "0.5",
                "--na",
                "1:4",
                "--nb",
                "1:4",
                "--nk",
                "0:6",
                "--json",
            ]),
    );
    assert_eq!(v["delay_estimate"], 3);
    assert_eq!(v["rows"].as_array().unwrap().len(), 4 * 4 * 7);
    assert!(v["validation_fit_percent"].as_f64().unwrap() > 85.0);
}

#[test]
fn robot_arm_structure_selection_fits_well() {
    let v = json_of(
        fts()
            .args(["identify", "arx-struct"])
            .arg(dataset("daisy-robot-arm/robot_arm.dat"))
            .args([
                "--ts", "1", "--split", "0.5", "--na", "2:10", "--nb", "2:10", "--nk", "0:2",
                "--json",
            ]),
    );
    assert!(
        v["validation_fit_percent"].as_f64().unwrap() > 90.0,
        "{}",
        v["recommended"]
    );
}

#[test]
fn li21_noise_free_csv_recovered_and_ts_from_time_column() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "sweep.csv", &li21_csv(6000, 0.0));
    let v = json_of(
        fts()
            .args(["identify", "arx"])
            .arg(&data)
            .args(["--na", "5", "--nb", "5", "--nk", "5", "--json"]),
    );
    assert_eq!(v["delay"], 5);
    assert!((v["ts"].as_f64().unwrap() - 1e-4).abs() < 1e-12);
    for (x, t) in floats(&v["den"]).iter().zip(LI21_A) {
        assert!((x - t).abs() < 1e-9, "{x} vs {t}");
    }
    for (x, t) in floats(&v["num"]).iter().zip(LI21_B) {
        assert!((x - t).abs() < 1e-9, "{x} vs {t}");
    }
    assert!(v["fit_percent"].as_f64().unwrap() > 99.999);
}

#[test]
fn output_noise_arx_flagged_oe_and_iv_summaries() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "sweep.csv", &li21_csv(10_000, 1e-3));
    let arx = json_of(
        fts()
            .args(["identify", "arx"])
            .arg(&data)
            .args(["--na", "5", "--nb", "5", "--nk", "5", "--json"]),
    );
    // Measurement noise makes the ARX residual coloured; the summary says so.
    assert_eq!(arx["whiteness"]["white"], false);
    assert!(arx["notes"][0].as_str().unwrap().contains("not white"));
    let svg = dir.path().join("bode.svg");
    let cmp = dir.path().join("compare.svg");
    let oe = json_of(
        fts()
            .args(["identify", "oe"])
            .arg(&data)
            .args(["--nb", "5", "--nf", "5", "--nk", "5", "--json", "--plot"])
            .arg(&svg)
            .arg("--plot-compare")
            .arg(&cmp),
    );
    assert!(
        std::fs::read_to_string(&cmp)
            .unwrap()
            .contains("simulation fit")
    );
    assert_eq!(oe["converged"], true);
    assert_eq!(oe["orders"]["nf"], 5);
    assert!(oe["fit_percent"].as_f64().unwrap() > 99.8);
    // OE residuals are the white measurement noise.
    assert_eq!(oe["whiteness"]["white"], true);
    assert!((oe["noise_variance"].as_f64().unwrap() / 1e-6 - 1.0).abs() < 0.1);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("coherence"));
    let iv = json_of(
        fts()
            .args(["identify", "iv"])
            .arg(&data)
            .args(["--na", "5", "--nb", "5", "--nk", "5", "--json"]),
    );
    assert!(iv["fit_percent"].as_f64().unwrap() > 99.8);
    // Human summary of OE names the method and the residual test.
    fts()
        .args(["identify", "oe"])
        .arg(&data)
        .args(["--nb", "5", "--nf", "5", "--nk", "5"])
        .assert()
        .success()
        .stdout(predicate::str::contains("Levenberg-Marquardt"))
        .stdout(predicate::str::contains("residuals: white"));
}

/// A model that misses the input's effect at lag 4 leaves it in the
/// residuals; the cross-correlation test must name lag 4 (the residual at
/// sample k against the input at k - 4), however many leading samples the
/// predictor skips.
#[test]
fn residual_cross_correlation_names_the_missed_lag() {
    let dir = tempfile::tempdir().unwrap();
    let mut unit = unit_uniform(0x2545_f491);
    let mut uni = move || unit() - 0.5;
    let n = 20_000;
    let u: Vec<f64> = (0..n).map(|_| uni()).collect();
    let mut text = String::from("u,y\n");
    for k in 0..n {
        let late = if k >= 4 { 0.8 * u[k - 4] } else { 0.0 };
        let y = if k >= 1 { 0.5 * u[k - 1] } else { 0.0 } + late + 0.01 * uni();
        text.push_str(&format!("{},{}\n", u[k], y));
    }
    let data = write(dir.path(), "late.csv", &text);
    // An FIR model of lags 1 and 2: memory nb + nk - 1 = 2, so the first
    // residual is sample 2 (the residual tests had paired it with the
    // input of sample 0 and reported lag 2).
    let arx = json_of(
        fts()
            .args(["identify", "arx"])
            .arg(&data)
            .args(["--na", "0", "--nb", "2", "--nk", "1", "--ts", "1", "--json"]),
    );
    let outside: Vec<i64> = arx["whiteness"]["crosscorr_outside"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap())
        .collect();
    assert_eq!(outside, [4], "{}", arx["whiteness"]);
    assert_eq!(arx["whiteness"]["independent"], false);
}

#[test]
fn auto_structure_and_validate_file() {
    let dir = tempfile::tempdir().unwrap();
    let est = write(dir.path(), "est.csv", &li21_csv(3000, 0.0));
    let val = write(dir.path(), "val.csv", &li21_csv(2000, 0.0));
    let v = json_of(
        fts()
            .args(["identify", "arx", "--auto", "--json"])
            .arg(&est)
            .arg("--validate")
            .arg(&val),
    );
    assert!(v["validation_fit_percent"].as_f64().unwrap() > 99.9);
    assert_eq!(v["selection"]["rule"], "validation_loss");
}

#[test]
fn bode_prints_and_writes_the_empirical_response() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "sweep.csv", &li21_csv(20_000, 1e-3));
    let csv = dir.path().join("resp.csv");
    let v = json_of(
        fts()
            .arg("bode")
            .arg(&data)
            .args(["--json", "--fmax", "1000", "-o"])
            .arg(&csv),
    );
    assert_eq!(v["method"], "welch");
    assert!(v["mean_coherence"].as_f64().unwrap() > 0.9);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("freq_hz,magnitude,magnitude_db,phase_deg,coherence,re,im"));
    // DC gain of Li21 is 0.9503: the lowest excited bins are close to it.
    let mag = floats(&v["magnitude"]);
    assert!((mag[2] - 0.95).abs() < 0.05, "{}", mag[2]);
    fts()
        .arg("bode")
        .arg(&data)
        .args(["--method", "etfe", "--fmax", "500"])
        .assert()
        .success()
        .stdout(predicate::str::contains("ETFE estimate"));
}

fn bad_run(dir: &Path, data: &Path, extra: &[&str], expect: &str) {
    let out = dir.join("plant.json");
    fts()
        .args(["identify", "arx"])
        .arg(data)
        .args(extra)
        .arg("-o")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(expect));
    assert!(!out.exists(), "no output file on bad input");
}

#[test]
fn bad_inputs_exit_2_and_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let orders = ["--na", "2", "--nb", "2", "--nk", "1"];
    let short = write(d, "short.csv", "t,u,y\n0,1,2\n1,2,3\n2,3,1\n3,1,2\n");
    bad_run(d, &short, &orders, "too few samples for the model orders");
    let mut text = String::from("t,u,y\n");
    for k in 0..50 {
        text.push_str(&format!("{k},1.5,{}\n", (k as f64 * 0.3).sin()));
    }
    let constant = write(d, "constant.csv", &text);
    bad_run(d, &constant, &orders, "input is constant");
    let nan = write(d, "nan.csv", "t,u,y\n0,1,2\n1,NaN,3\n2,3,1\n");
    bad_run(d, &nan, &orders, "nan.csv line 3, field 'u'");
    let missing = write(d, "missing.csv", "t,u,z\n0,1,2\n1,2,3\n");
    bad_run(d, &missing, &orders, "missing column 'y'");
    let jitter = write(d, "jitter.csv", "t,u,y\n0,1,2\n1,2,3\n2.5,3,1\n3.5,1,1\n");
    bad_run(
        d,
        &jitter,
        &orders,
        "jitter.csv line 4, field 't': time step 1.5e0 s",
    );
    let dat = write(d, "plain.dat", "1 2\n3 4\n5 6\n");
    bad_run(d, &dat, &orders, "give --ts");
    bad_run(
        d,
        &constant,
        &["--na", "2", "--nb", "0", "--nk", "1"],
        "nb must be at least 1",
    );
    bad_run(
        d,
        &constant,
        &["--na", "1", "--nb", "1", "--nk", "1", "--split", "1.5"],
        "--split",
    );
    bad_run(d, &dir.path().join("absent.csv"), &orders, "cannot read");
    let mut o2 = orders.to_vec();
    o2.extend(["--ts", "0.5"]);
    bad_run(d, &constant, &o2, "but --ts is 0.5 s");
    let mut text2 = String::from("t,u,y\n");
    for k in 0..50 {
        text2.push_str(&format!("{},{},{}\n", 2.0 * k as f64, k % 3, k % 5));
    }
    let other_ts = write(d, "other_ts.csv", &text2);
    let mut o3 = orders.to_vec();
    o3.extend(["--validate", other_ts.to_str().unwrap()]);
    bad_run(d, &constant, &o3, "differs from the estimation data");
    fts()
        .args(["identify", "oe"])
        .arg(&constant)
        .args(["--nb", "2", "--nf", "2", "--nk", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("input is constant"));
    fts()
        .arg("bode")
        .arg(&constant)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("no power"));
    fts()
        .arg("bode")
        .arg(&short)
        .args(["--overlap", "1.5"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("overlap"));
    fts()
        .args(["identify", "arx-struct"])
        .arg(&constant)
        .args(["--na", "3:1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--na"));
    // A constant input is refused before any rule is applied; a varying
    // one reaches the rule's own check.
    fts()
        .args(["identify", "arx-struct"])
        .arg(&constant)
        .args(["--na", "1", "--nb", "1", "--nk", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("input is constant"));
    let varying = write(
        d,
        "varying.csv",
        &(0..50)
            .map(|k| {
                format!(
                    "{k},{},{}\n",
                    (k * 7919 % 13) as f64,
                    (k as f64 * 0.3).sin()
                )
            })
            .fold(String::from("t,u,y\n"), |acc, row| acc + &row),
    );
    fts()
        .args(["identify", "arx-struct"])
        .arg(&varying)
        .args(["--na", "1", "--nb", "1", "--nk", "1", "--rule", "fit"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("needs validation data"));
    assert_only(
        d,
        &[
            "short.csv",
            "constant.csv",
            "nan.csv",
            "missing.csv",
            "jitter.csv",
            "plain.dat",
            "other_ts.csv",
            "varying.csv",
        ],
    );
}

/// The DaISy robot arm's `(u, y)` columns, the first `n` rows.
fn robot_arm(n: usize) -> (Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(dataset("daisy-robot-arm/robot_arm.dat")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .map(|l| l.split_whitespace().map(|v| v.parse().unwrap()).collect())
        .take(n)
        .collect();
    (
        rows.iter().map(|r| r[0]).collect(),
        rows.iter().map(|r| r[1]).collect(),
    )
}

#[test]
fn robot_arm_welch_default_segment_is_coherent_and_matches_scipy() {
    use fts::ident::freq::{WelchParams, median_coherence, welch};
    // A lightly damped arm under a swept sine: 64-sample segments leave a
    // median coherence near 0.07; the length chosen from the record must
    // show the data as the good data they are.
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/welch/robot_arm_coherence.json"),
        )
        .unwrap(),
    )
    .unwrap();
    for case in reference["cases"].as_array().unwrap() {
        let n = case["samples"].as_u64().unwrap() as usize;
        let (u, y) = robot_arm(n);
        let chosen = welch(&u, &y, 1.0, &WelchParams::default()).unwrap();
        let median = median_coherence(&chosen);
        assert!(median >= 0.7, "{n} samples: median coherence {median}");
        // Against scipy.signal.coherence at every candidate length.
        let scipy = case["median_coherence_excited"].as_object().unwrap();
        for (length, want) in scipy {
            let params = WelchParams {
                segment: Some(length.parse().unwrap()),
                ..WelchParams::default()
            };
            let got = median_coherence(&welch(&u, &y, 1.0, &params).unwrap());
            let want = want.as_f64().unwrap();
            assert!(
                (got - want).abs() < 1e-9,
                "{n}/{length}: {got} vs scipy {want}"
            );
        }
        // The chosen length is scipy's best.
        let best = scipy
            .iter()
            .max_by(|a, b| a.1.as_f64().unwrap().total_cmp(&b.1.as_f64().unwrap()))
            .unwrap();
        assert_eq!(chosen.segment_len.to_string(), *best.0, "{n} samples");
    }
}

#[test]
fn identify_plot_says_its_welch_segment_and_takes_segment() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("bode.png");
    let run = |extra: &[&str]| {
        let out = fts()
            .args(["identify", "arx"])
            .arg(dataset("daisy-robot-arm/robot_arm.dat"))
            .args([
                "--ts", "1", "--split", "0.5", "--na", "4", "--nb", "4", "--nk", "0",
            ])
            .arg("--plot")
            .arg(&png)
            .args(extra)
            .assert()
            .success()
            .get_output()
            .stderr
            .clone();
        String::from_utf8(out).unwrap()
    };
    let chosen = run(&[]);
    assert!(
        chosen.contains("Welch 3 x 256 samples (chosen for coherence), median coherence 0.81"),
        "{chosen}"
    );
    let given = run(&["--segment", "64"]);
    assert!(
        given.contains("Welch 15 x 64 samples, median coherence 0.07"),
        "{given}"
    );
}
