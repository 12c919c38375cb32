//! `fts zpetc` and `fts tf info` end to end: happy paths, and every bad input
//! exits with code 2, names the problem, never panics, and leaves no output.

use crate::common::cmd::{fts, predicate};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
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

#[test]
fn zpetc_li21_summary_json_and_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("zpetc.json");
    let svg = dir.path().join("bode.svg");
    fts()
        .args(["zpetc", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .arg("-o")
        .arg(&out)
        .arg("--plot")
        .arg(&svg)
        .assert()
        .success()
        .stdout(predicate::str::contains("preview: 5 samples"))
        .stdout(predicate::str::contains("cancelled"))
        .stdout(predicate::str::contains(
            "DC gain of G_z G_c = 1.000000000000",
        ));
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(written.contains("\"format\": \"fts.zpetc/1\""));
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));

    let assert = fts()
        .args(["zpetc", "--json", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&assert.get_output().stdout).unwrap();
    assert_eq!(v["preview"], 5);
    assert_eq!(v["num"].as_array().unwrap().len(), 6);
    assert_eq!(v["den"].as_array().unwrap().len(), 5);
    assert_eq!(v["cancelled_zeros"].as_array().unwrap().len(), 4);
    assert_eq!(v["uncancelled_zeros"].as_array().unwrap().len(), 0);
    assert!((v["check"]["dc_gain"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    // Regeneration is byte-identical.
    let out2 = dir.path().join("again.json");
    fts()
        .args(["zpetc", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .arg("-o")
        .arg(&out2)
        .assert()
        .success();
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&out2).unwrap());
}

#[test]
fn zpetc_rho_keeps_zeros_and_extends_preview() {
    let assert = fts()
        .args(["zpetc", "--json", "--rho", "0.8", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&assert.get_output().stdout).unwrap();
    // The pair at |z| = 0.869 is kept: preview d + s = 5 + 2.
    assert_eq!(v["preview"], 7);
    assert_eq!(v["uncancelled_zeros"].as_array().unwrap().len(), 2);
    assert!(v["check"]["max_phase_error_rad"].as_f64().unwrap() < 1e-9);
}

#[test]
fn zpetc_stable_inversion_of_an_outside_zero() {
    // B = 1 - 2 z^-1 + 0.75 z^-2 = (1 - 0.5 z^-1)(1 - 1.5 z^-1): 1.5 is
    // inverted by the series; the product G_z G_c is then 1 to ~1e-9.
    let dir = tempfile::tempdir().unwrap();
    let plant = write(
        dir.path(),
        "g.json",
        r#"{"format":"fts.tf/1","var":"z^-1","ts":0.001,"num":[1,-2,0.75],"den":[1,-0.3],"delay":2}"#,
    );
    let assert = fts()
        .args([
            "zpetc",
            "--json",
            "--stable-inversion",
            "--series-tol",
            "1e-9",
            "--tf",
        ])
        .arg(&plant)
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&assert.get_output().stdout).unwrap();
    assert_eq!(v["inverted_zeros"].as_array().unwrap().len(), 1);
    assert_eq!(v["uncancelled_zeros"].as_array().unwrap().len(), 0);
    let terms = v["series_terms"].as_u64().unwrap();
    // ln(1e-9) / ln(1/1.5) = 51.1 terms.
    assert!((50..=56).contains(&terms), "{terms}");
    assert_eq!(v["preview"].as_u64().unwrap(), 2 + 1 + terms);
    assert!((v["check"]["dc_gain"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!(v["check"]["max_phase_error_rad"].as_f64().unwrap() < 1e-7);
    // The summary names the treatment; a radius of 1 or less is refused.
    fts()
        .args(["zpetc", "--stable-inversion", "--tf"])
        .arg(&plant)
        .assert()
        .success()
        .stdout(predicate::str::contains("inverted: anticausal series"));
    fts()
        .args(["zpetc", "--stable-inversion", "0.9", "--tf"])
        .arg(&plant)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "--stable-inversion: expected a radius above 1",
        ));
}

#[test]
fn tf_info_reports_poles_zeros_and_bode_csv() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("bode.csv");
    fts()
        .args(["tf", "info"])
        .arg(fixture("li21-closed-loop.json"))
        .arg("--bode")
        .arg(&csv)
        .assert()
        .success()
        .stdout(predicate::str::contains("DC gain: 0.950256"))
        .stdout(predicate::str::contains("poles (stable, exact test)"));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("freq_hz,magnitude,magnitude_db,phase_deg,re,im\n"));
    assert_eq!(text.lines().count(), 1002);
    let assert = fts()
        .args(["tf", "info", "--json", "--freq", "500"])
        .arg(fixture("li21-closed-loop.json"))
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&assert.get_output().stdout).unwrap();
    let phase = v["response"][0]["phase_deg"].as_f64().unwrap();
    assert!((phase + 74.58).abs() < 0.01, "{phase}");
    assert_eq!(v["stable"], true);
}

#[test]
fn tf_info_continuous() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "gxx.json",
        r#"{"format":"fts.tf/1","var":"s","num":[56930,1389],"den":[1,0.2268,0.002058]}"#,
    );
    fts()
        .args(["tf", "info"])
        .arg(&p)
        .assert()
        .success()
        .stdout(predicate::str::contains("continuous"));
    // The default frequencies reach the 1 kHz the help promises.
    let assert = fts()
        .args(["tf", "info", "--json"])
        .arg(&p)
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&assert.get_output().stdout).unwrap();
    let last = v["response"].as_array().unwrap().last().unwrap()["freq_hz"].as_f64();
    assert_eq!(last, Some(1000.0), "{v}");
}

/// Each case: file content, expected message fragment.
const BAD_PLANTS: &[(&str, &str)] = &[
    ("{not json", "invalid JSON"),
    (
        r#"{"format":"fts.tf/9","var":"z^-1","ts":1e-4,"num":[1],"den":[1]}"#,
        "field 'format'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","num":[1],"den":[1]}"#,
        "field 'ts'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":-1,"num":[1],"den":[1]}"#,
        "field 'ts'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":1e-4,"num":[1,"a"],"den":[1]}"#,
        "field 'num[1]'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":1e-4,"num":[1],"den":[0,1]}"#,
        "field 'den'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":1e-4,"num":[],"den":[1]}"#,
        "field 'num'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":1e-4,"num":[0,0],"den":[1]}"#,
        "field 'num'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":1e-4,"num":[1],"den":[1],"delay":1.5}"#,
        "field 'delay'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"w","ts":1e-4,"num":[1],"den":[1]}"#,
        "field 'var'",
    ),
    (
        r#"{"format":"fts.tf/1","var":"s","num":[1],"den":[1,1]}"#,
        "continuous",
    ),
    (
        r#"{"format":"fts.tf/1","var":"z^-1","ts":1e-4,"num":[1,-1],"den":[1,-0.5]}"#,
        "zero at z = 1",
    ),
    (r#"[1,2]"#, "expected a JSON object"),
];

#[test]
fn zpetc_bad_inputs_exit_2_and_write_nothing() {
    for (i, (content, fragment)) in BAD_PLANTS.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        let plant = write(dir.path(), "plant.json", content);
        fts()
            .args(["zpetc", "--tf"])
            .arg(&plant)
            .arg("-o")
            .arg(dir.path().join("out.json"))
            .arg("--plot")
            .arg(dir.path().join("out.svg"))
            .assert()
            .code(2)
            .stdout(predicate::str::is_empty())
            .stderr(predicate::str::contains("plant.json"))
            .stderr(predicate::str::contains(*fragment))
            .stderr(predicate::str::contains("panicked").not());
        assert_only(dir.path(), &["plant.json"]);
        let _ = i;
    }
}

#[test]
fn usage_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    fts()
        .args(["zpetc", "--tf"])
        .arg(dir.path().join("missing.json"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("missing.json"));
    fts()
        .args(["zpetc", "--rho", "1.5", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("rho"));
    fts().args(["zpetc"]).assert().code(2);
    fts().args(["no-such-command"]).assert().code(2);
    fts()
        .args(["zpetc", "--rho", "abc", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .assert()
        .code(2);
    // Output into a folder that does not exist: a failure to write (exit 1), no panic.
    fts()
        .args(["zpetc", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .arg("-o")
        .arg(dir.path().join("no/such/dir/z.json"))
        .assert()
        .code(1)
        .stderr(predicate::str::contains("panicked").not());
}

#[test]
fn failed_run_keeps_previous_output() {
    // Atomic writes: a good result exists; a later bad run must not touch it.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("z.json");
    fts()
        .args(["zpetc", "--tf"])
        .arg(fixture("li21-closed-loop.json"))
        .arg("-o")
        .arg(&out)
        .assert()
        .success();
    let before = std::fs::read(&out).unwrap();
    let bad = write(dir.path(), "bad.json", "{");
    fts()
        .args(["zpetc", "--tf"])
        .arg(&bad)
        .arg("-o")
        .arg(&out)
        .assert()
        .code(2);
    assert_eq!(std::fs::read(&out).unwrap(), before);
    assert_only(dir.path(), &["z.json", "bad.json"]);
}

#[test]
fn excite_writes_csv_and_rejects_bad_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep.csv");
    fts()
        .args(["excite", "sweep", "--duration", "0.01", "-o"])
        .arg(&out)
        .assert()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("t,u\n"));
    assert_eq!(text.lines().count(), 101);
    fts()
        .args(["excite", "sweep", "--f1", "6000", "-o"])
        .arg(dir.path().join("x.csv"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--f1"));
    assert_only(dir.path(), &["sweep.csv"]);
}
