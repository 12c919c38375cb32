//! `fts build` from a manifest (issue 6, item 3): identical bytes on every
//! run and in every folder; `--check` fails after an input changes and passes
//! after a rebuild; a failing step leaves every previous output intact;
//! manifest errors exit 2 naming the line and field.

use crate::common::cmd::{Assert, fts, predicate};
use fts::io::timeseries::{time_column, write_csv};
use fts::sim::experiment::{ExperimentParams, align_triangle_record, triangle_record};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Every file under `dir` (relative path -> bytes).
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// The test manifest: the controller is declared first, so the build order
/// comes from the dependencies, not from the file.
const MANIFEST: &str = r#"# test pipeline
[step.controller]
kind = "controller"
hysteresis = "models/inverse.json"
zpetc = "models/zpetc.json"
kp = 0.05
ki = 0.3
out = "out/controller.json"
header = "out/controller.h"

[step.zpetc]
kind = "zpetc"
tf = "plant.json"
rho = 0.95
out = "models/zpetc.json"

[step.inverse]
kind = "hysteresis"
data = "data/triangle.csv"
operators = 5
inverse = true
out = "models/inverse.json"
"#;

/// A project folder: the manifest, a measured-like triangle record (one
/// 10 V triangle on the virtual FTS) and the \[Li21\] closed-loop model.
fn project(dir: &Path) {
    std::fs::create_dir_all(dir.join("data")).unwrap();
    let params = ExperimentParams {
        triangle_amplitudes_v: vec![10.0],
        triangle_freq_hz: 5.0,
        ..ExperimentParams::default()
    };
    let (command, measured) = triangle_record(&params).unwrap();
    let (u, y) = align_triangle_record(&params, &command, &measured);
    let t = time_column(u.len(), params.plant.ts);
    std::fs::write(
        dir.join("data/triangle.csv"),
        write_csv(&["t", "u", "y"], &[&t, u, y]),
    )
    .unwrap();
    std::fs::copy(
        repo("fixtures/li21-closed-loop.json"),
        dir.join("plant.json"),
    )
    .unwrap();
    std::fs::write(dir.join("fts.toml"), MANIFEST).unwrap();
}

fn build(dir: &Path) -> Assert {
    fts()
        .current_dir(dir)
        .args(["build", "-f", "fts.toml"])
        .assert()
}

fn check(dir: &Path) -> Assert {
    fts().current_dir(dir).args(["build", "--check"]).assert()
}

/// Replaces the `y` value of data row `row` (1-based line `row + 1`).
fn edit_triangle(dir: &Path, line: usize, value: &str) {
    let p = dir.join("data/triangle.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut fields: Vec<&str> = lines[line - 1].split(',').collect();
    fields[2] = value;
    lines[line - 1] = fields.join(",");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
}

#[test]
fn builds_twice_to_identical_bytes_in_any_folder() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    project(a.path());
    build(a.path())
        .success()
        .stdout(predicate::str::contains("built").and(predicate::str::contains("3 built")));
    let first = snapshot(a.path());
    for f in [
        "models/inverse.json",
        "models/zpetc.json",
        "out/controller.json",
        "out/controller.h",
        "fts.lock",
    ] {
        assert!(first.contains_key(f), "{f} written");
    }
    // Provenance paths are relative to the manifest; no absolute path leaks.
    let controller = String::from_utf8(first["out/controller.json"].clone()).unwrap();
    assert!(controller.contains("\"file\": \"models/zpetc.json\""));
    let root = a.path().to_string_lossy().into_owned();
    for (name, bytes) in &first {
        assert!(
            !String::from_utf8_lossy(bytes).contains(&root),
            "{name} holds the absolute path"
        );
    }

    // Second run: nothing to do, nothing rewritten.
    build(a.path())
        .success()
        .stdout(predicate::str::contains("0 built, 3 up to date"));
    assert_eq!(snapshot(a.path()), first);
    // --force rebuilds everything to the same bytes.
    fts()
        .current_dir(a.path())
        .args(["build", "--force"])
        .assert()
        .success()
        .stdout(predicate::str::contains("3 built"));
    assert_eq!(snapshot(a.path()), first);

    // Another folder, invoked from elsewhere: the same bytes, lock included.
    project(b.path());
    fts()
        .args(["build", "-f"])
        .arg(b.path().join("fts.toml"))
        .assert()
        .success();
    assert_eq!(snapshot(b.path()), first);
}

#[test]
fn check_fails_after_an_input_changes_and_passes_after_rebuild() {
    let d = tempfile::tempdir().unwrap();
    project(d.path());
    // Nothing built yet: stale, exit 1.
    check(d.path())
        .code(1)
        .stderr(predicate::str::contains("never built"));
    assert!(
        !d.path().join("fts.lock").exists(),
        "--check writes nothing"
    );
    build(d.path()).success();
    check(d.path())
        .success()
        .stdout(predicate::str::contains("3 of 3 steps up to date"));

    edit_triangle(d.path(), 200, "3.25");
    let before = snapshot(d.path());
    check(d.path())
        .code(1)
        .stderr(
            predicate::str::contains("models/inverse.json")
                .and(predicate::str::contains("input data/triangle.csv changed"))
                .and(predicate::str::contains("out/controller.json")),
        )
        // A non-zero exit prints no result (docs/formats.md, Exit codes):
        // the stale steps are named on the error line.
        .stdout("");
    assert_eq!(snapshot(d.path()), before, "--check writes nothing");

    build(d.path())
        .success()
        .stdout(predicate::str::contains("2 built, 1 up to date"));
    check(d.path()).success();

    // A settings change is stale too.
    let m = std::fs::read_to_string(d.path().join("fts.toml")).unwrap();
    std::fs::write(
        d.path().join("fts.toml"),
        m.replace("ki = 0.3", "ki = 0.25"),
    )
    .unwrap();
    check(d.path())
        .code(1)
        .stderr(predicate::str::contains("settings").and(predicate::str::contains("controller")));
    build(d.path())
        .success()
        .stdout(predicate::str::contains("1 built, 2 up to date"));
    check(d.path()).success();
}

#[test]
fn hand_edited_or_deleted_outputs_are_detected_and_restored() {
    let d = tempfile::tempdir().unwrap();
    project(d.path());
    build(d.path()).success();
    let built = snapshot(d.path());
    let header = d.path().join("out/controller.h");
    let text = std::fs::read_to_string(&header).unwrap();
    std::fs::write(&header, text.replace("FTS_PID_KP", "FTS_PID_KP_EDITED")).unwrap();
    std::fs::remove_file(d.path().join("models/zpetc.json")).unwrap();
    check(d.path()).code(1).stderr(
        predicate::str::contains("output out/controller.h was modified").and(
            predicate::str::contains("output models/zpetc.json is missing"),
        ),
    );
    build(d.path()).success();
    assert_eq!(snapshot(d.path()), built);
}

#[test]
fn a_failing_step_leaves_previous_outputs_intact() {
    let d = tempfile::tempdir().unwrap();
    project(d.path());
    build(d.path()).success();
    let built = snapshot(d.path());

    // zpetc (declared before inverse) changes and rebuilds; inverse then
    // fails on a NaN; controller must not run. A failed build changes
    // nothing (docs/formats.md, Exit codes): not even the completed step's
    // output, nor the lock, and it prints no result.
    let m = std::fs::read_to_string(d.path().join("fts.toml")).unwrap();
    std::fs::write(
        d.path().join("fts.toml"),
        m.replace("rho = 0.95", "rho = 0.9"),
    )
    .unwrap();
    edit_triangle(d.path(), 50, "NaN");
    build(d.path()).code(2).stdout("").stderr(
        predicate::str::contains("fts.toml line 17, step \"inverse\"")
            .and(predicate::str::contains("data/triangle.csv line 50")),
    );
    let after = snapshot(d.path());
    for (f, bytes) in &built {
        if f != "fts.toml" && f != "data/triangle.csv" {
            assert_eq!(&after[f], bytes, "{f} untouched");
        }
    }
    assert!(
        after.keys().all(|k| !k.contains(".fts-")),
        "no temporary file left: {:?}",
        after.keys().collect::<Vec<_>>()
    );
    // The lock still describes the previous build.
    check(d.path()).code(1).stderr(
        predicate::str::contains("input data/triangle.csv changed")
            .and(predicate::str::contains("models/zpetc.json (")),
    );

    // Repair the record: the rebuild completes and everything is current.
    edit_triangle(
        d.path(),
        50,
        std::str::from_utf8(&built["data/triangle.csv"])
            .unwrap()
            .lines()
            .nth(49)
            .unwrap()
            .split(',')
            .nth(2)
            .unwrap(),
    );
    build(d.path())
        .success()
        .stdout(predicate::str::contains("0 built").not());
    check(d.path()).success();
    assert_ne!(
        snapshot(d.path())["models/zpetc.json"],
        built["models/zpetc.json"]
    );
    assert_eq!(
        snapshot(d.path())["models/inverse.json"],
        built["models/inverse.json"]
    );
}

fn manifest_error(text: &str, expected: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    project(d.path());
    std::fs::write(d.path().join("fts.toml"), text).unwrap();
    let mut stderr = predicate::str::contains("fts.toml line").boxed();
    for e in expected {
        stderr = stderr.and(predicate::str::contains(*e)).boxed();
    }
    build(d.path()).code(2).stderr(stderr);
    check(d.path()).code(2);
    assert!(!d.path().join("models").exists(), "nothing built");
    assert!(!d.path().join("fts.lock").exists());
}

#[test]
fn manifest_errors_name_the_line_and_field() {
    // A typo in a field name.
    manifest_error(
        &MANIFEST.replace("rho = 0.95", "roh = 0.95"),
        &["line 14", "step.zpetc.roh", "unknown field"],
    );
    // An input nobody writes and that does not exist.
    manifest_error(
        &MANIFEST.replace("tf = \"plant.json\"", "tf = \"models/plant.json\""),
        &["line 13", "step.zpetc.tf", "no step writes it"],
    );
    // A cycle.
    manifest_error(
        &MANIFEST.replace("tf = \"plant.json\"", "tf = \"out/controller.json\""),
        &["cycle", "controller -> zpetc -> controller"],
    );
    // An unknown kind, a wrong type, a missing field, TOML syntax.
    manifest_error(
        &MANIFEST.replace("kind = \"zpetc\"", "kind = \"zpetcc\""),
        &["line 12", "step.zpetc.kind", "unknown kind \"zpetcc\""],
    );
    manifest_error(
        &MANIFEST.replace("operators = 5", "operators = \"five\""),
        &["line 20", "step.inverse.operators", "whole number"],
    );
    manifest_error(
        &MANIFEST.replace("out = \"models/zpetc.json\"\n", ""),
        &["line 11", "step.zpetc.out", "missing"],
    );
    manifest_error(&MANIFEST.replace("kp = 0.05", "kp = = 0.05"), &["line 6"]);
    // Record options: an old column key, a bad delimiter, an absurd jitter.
    manifest_error(
        &MANIFEST.replace("operators = 5", "output = 2"),
        &["line 20", "step.inverse.output", "renamed", "'output_col'"],
    );
    manifest_error(
        &MANIFEST.replace("operators = 5", "delimiter = \"pipe\""),
        &["line 20", "step.inverse.delimiter", "\"semicolon\""],
    );
    manifest_error(
        &MANIFEST.replace("operators = 5", "time_jitter = 3"),
        &["line 20", "step.inverse.time_jitter", "[0, 1)"],
    );
    // Two steps writing one file.
    manifest_error(
        &MANIFEST.replace(
            "out = \"models/zpetc.json\"",
            "out = \"models/inverse.json\"",
        ),
        &["already written by step"],
    );
}

#[test]
fn missing_manifest_is_bad_usage() {
    let d = tempfile::tempdir().unwrap();
    fts()
        .current_dir(d.path())
        .arg("build")
        .assert()
        .code(2)
        .stderr(predicate::str::contains("fts.toml: cannot read"));
}

/// The shipped example (virtual experiment -> hysteresis -> sweep -> ARX/OE
/// -> ZPETC -> coefficient files) built in two folders: the same bytes.
#[test]
fn example_manifest_builds_identically_in_two_folders() {
    let example = repo("examples/pipeline/fts.toml");
    let mut snaps = Vec::new();
    for _ in 0..2 {
        let d = tempfile::tempdir().unwrap();
        std::fs::copy(&example, d.path().join("fts.toml")).unwrap();
        build(d.path())
            .success()
            .stdout(predicate::str::contains("6 built"));
        check(d.path()).success();
        snaps.push(snapshot(d.path()));
    }
    assert_eq!(snaps[0], snaps[1]);
    assert!(snaps[0].contains_key("out/controller.h"));
}

/// A real record (the SmartHysteresis piezo, headerless, columns 4 = V and
/// 3 = um, excitation from sample 16286): the manifest's column options give
/// the same model file, byte for byte, as `fts identify hysteresis`.
#[test]
fn real_record_step_matches_the_command_line() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("data")).unwrap();
    let dataset = repo("data/piezo-smarthysteresis/hysteresis_v_150_1hz.csv");
    std::fs::copy(&dataset, d.path().join("data/piezo.csv")).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (the vendored piezo record data/piezo-smarthysteresis is missing)",
            dataset.display()
        )
    });
    std::fs::write(
        d.path().join("fts.toml"),
        r#"[step.piezo]
kind = "hysteresis"
data = "data/piezo.csv"
no_header = true
input_col = 4
output_col = 3
start = 16286
model = "mpi-cbrt"
out = "piezo.json"
"#,
    )
    .unwrap();
    build(d.path()).success();
    fts()
        .current_dir(d.path())
        .args([
            "identify",
            "hysteresis",
            "data/piezo.csv",
            "--no-header",
            "--input-col",
            "4",
            "--output-col",
            "3",
            "--start",
            "16286",
            "--model",
            "mpi-cbrt",
            "-o",
            "cli.json",
        ])
        .assert()
        .success();
    assert_eq!(
        std::fs::read(d.path().join("piezo.json")).unwrap(),
        std::fs::read(d.path().join("cli.json")).unwrap()
    );
    check(d.path()).success();
}

/// A damaged lock file is bad input naming it; `--force` rebuilds past it.
/// `--json` prints one object with every step's status.
#[test]
fn damaged_lock_and_json_summary() {
    let d = tempfile::tempdir().unwrap();
    project(d.path());
    build(d.path()).success();
    let built = snapshot(d.path());
    std::fs::write(d.path().join("fts.lock"), "{not json").unwrap();
    build(d.path())
        .code(2)
        .stderr(predicate::str::contains("fts.lock").and(predicate::str::contains("--force")));
    let out = fts()
        .current_dir(d.path())
        .args(["build", "--force", "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).expect("one JSON object");
    assert_eq!(v["built"], 3);
    assert_eq!(v["steps"][2]["name"], "controller", "dependency order");
    assert_eq!(snapshot(d.path()), built);
    let out = fts()
        .current_dir(d.path())
        .args(["build", "--check", "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["up_to_date"], 3);
    assert_eq!(v["stale"], 0);
}

/// A step's outputs are committed all or none: when one of them cannot be
/// written, none is replaced and the step stays stale. Temporary files a
/// killed run left beside the outputs are removed by the next build.
#[test]
fn a_step_commits_all_its_outputs_or_none_and_stale_temps_go() {
    let d = tempfile::tempdir().unwrap();
    project(d.path());
    build(d.path()).success();
    // Temporary files named for a process that is gone (a killed run).
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    gone.wait().unwrap();
    let killed = |n: u32| format!(".fts-{}-killed{n}.tmp", gone.id());
    std::fs::write(d.path().join("models").join(killed(1)), "half").unwrap();
    std::fs::write(d.path().join(killed(2)), "half").unwrap();
    // A new PID gain changes both controller files; the header's path is
    // now a folder, so neither may be replaced.
    let text = std::fs::read_to_string(d.path().join("fts.toml")).unwrap();
    std::fs::write(
        d.path().join("fts.toml"),
        text.replace("kp = 0.05", "kp = 0.04"),
    )
    .unwrap();
    let json_before = std::fs::read(d.path().join("out/controller.json")).unwrap();
    std::fs::remove_file(d.path().join("out/controller.h")).unwrap();
    std::fs::create_dir(d.path().join("out/controller.h")).unwrap();
    build(d.path()).code(2).stderr(predicate::str::contains(
        "out/controller.h: cannot read: Is a directory",
    ));
    assert_eq!(
        std::fs::read(d.path().join("out/controller.json")).unwrap(),
        json_before
    );
    assert!(!d.path().join("models").join(killed(1)).exists());
    assert!(!d.path().join(killed(2)).exists());
    // With the folder gone, the step is rebuilt, both files together.
    std::fs::remove_dir(d.path().join("out/controller.h")).unwrap();
    check(d.path()).code(1);
    build(d.path()).success();
    check(d.path()).success();
    assert_ne!(
        std::fs::read(d.path().join("out/controller.json")).unwrap(),
        json_before
    );
}

/// A `repetitive` step and a controller step that takes its design: the
/// same bytes as `fts repetitive -o` and `fts emit --repetitive` by hand,
/// and `--check` passes after the build. A design made at another sample
/// time is refused by both, naming the design file's `ts` (exit 2).
#[test]
fn repetitive_step_matches_the_commands_and_checks_the_sample_time() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    std::fs::copy(repo("fixtures/li21-closed-loop.json"), dir.join("cl.json")).unwrap();
    std::fs::write(
        dir.join("fts.toml"),
        r#"
[step.rc]
kind = "repetitive"
tf = "cl.json"
spindle_hz = 100
q_cutoff = 1000
out = "rc.json"

[step.ctrl]
kind = "controller"
repetitive = "rc.json"
pid_form = "li21"
kp = 0.02
ki = 0.15
ts = 0.0001
out = "controller.json"
"#,
    )
    .unwrap();
    build(dir).success();
    check(dir).success();
    let by_hand = |args: &[&str]| fts().current_dir(dir).args(args).assert().success();
    by_hand(&[
        "repetitive",
        "--tf",
        "cl.json",
        "--spindle-hz",
        "100",
        "--q-cutoff",
        "1000",
        "-o",
        "rc2.json",
    ]);
    let emit = [
        "emit",
        "--repetitive",
        "rc.json",
        "--pid-form",
        "li21",
        "--kp",
        "0.02",
        "--ki",
        "0.15",
        "--ts",
        "0.0001",
        "-o",
        "controller2.json",
    ];
    by_hand(&emit);
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert_eq!(read("rc.json"), read("rc2.json"));
    let (built, emitted) = (read("controller.json"), read("controller2.json"));
    let block = |bytes: &[u8]| {
        let v: serde_json::Value = serde_json::from_slice(bytes).unwrap();
        v["blocks"]
            .as_array()
            .unwrap()
            .iter()
            .find(|b| b["type"] == "repetitive")
            .cloned()
            .expect("a repetitive block")
    };
    assert_eq!(block(&built), block(&emitted));
    assert_eq!(block(&built)["period"], 100);
    // At 1 ms the design's 0.1 ms sample time is refused.
    let mut wrong = emit;
    wrong[10] = "0.001";
    fts()
        .current_dir(dir)
        .args(wrong)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("rc.json field 'ts'"));
}

/// `kind = "ct"` (SRIVC on the scipy multisine record of
/// tests/data/ct-ident) and `kind = "mechanism"` (the bridge calculator)
/// write what `fts identify ct -o` and `fts mechanism bridge --json` write,
/// byte for byte; the bridge's ideal ratio is `cot(10 deg)` and the
/// identified model's denominator has the truth's order.
#[test]
fn ct_and_mechanism_steps_match_the_commands() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("data")).unwrap();
    std::fs::copy(
        repo("tests/data/ct-ident/zaxis-multisine.csv"),
        d.path().join("data/zaxis.csv"),
    )
    .unwrap();
    std::fs::write(
        d.path().join("fts.toml"),
        r#"[step.zaxis]
kind = "ct"
data = "data/zaxis.csv"
np = 3
nz = 1
period = 10
skip_periods = 2
out = "models/zaxis.json"

[step.amplifier]
kind = "mechanism"
calculator = "bridge"
angle_deg = 10
link_mm = 12
hinge = { width_mm = 8, length_mm = 1, thickness_mm = 0.3, radius_mm = 0 }
out = "mechanism/bridge.json"
"#,
    )
    .unwrap();
    build(d.path()).success();
    check(d.path()).success();
    fts()
        .current_dir(d.path())
        .args(["identify", "ct", "data/zaxis.csv", "--np", "3", "--nz", "1"])
        .args(["--period", "10", "--skip-periods", "2", "-o", "cli.json"])
        .assert()
        .success();
    let built = std::fs::read(d.path().join("models/zaxis.json")).unwrap();
    assert_eq!(built, std::fs::read(d.path().join("cli.json")).unwrap());
    let tf: serde_json::Value = serde_json::from_slice(&built).unwrap();
    assert_eq!(tf["den"].as_array().unwrap().len(), 4, "{tf}");
    let out = fts()
        .args([
            "mechanism",
            "bridge",
            "--angle-deg",
            "10",
            "--link-mm",
            "12",
        ])
        .args(["--hinge-width-mm", "8", "--hinge-length-mm", "1"])
        .args([
            "--hinge-thickness-mm",
            "0.3",
            "--hinge-radius-mm",
            "0",
            "--json",
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let built = std::fs::read(d.path().join("mechanism/bridge.json")).unwrap();
    assert_eq!(String::from_utf8(built.clone()), String::from_utf8(out));
    let v: serde_json::Value = serde_json::from_slice(&built).unwrap();
    let cot = 1.0 / 10f64.to_radians().tan();
    assert!((v["ideal"].as_f64().unwrap() - cot).abs() < 1e-12);
    let compliant = v["compliant"].as_f64().unwrap();
    assert!(compliant > 0.0 && compliant < cot, "{v}");
}

#[test]
fn ct_and_mechanism_manifest_errors_name_the_line_and_field() {
    let mech = "[step.m]\nkind = \"mechanism\"\ncalculator = \"bridge\"\nangle_deg = 10\nout = \"m.json\"\n";
    manifest_error(
        &mech.replace("calculator = \"bridge\"\n", ""),
        &["line 1", "step.m.calculator", "missing", "\"lever\""],
    );
    manifest_error(
        &mech.replace("\"bridge\"", "\"scissor\""),
        &["line 3", "step.m.calculator", "\"bridge\""],
    );
    manifest_error(
        &mech.replace("angle_deg = 10", "angle_deg = 95"),
        &["line 4", "step.m.angle_deg", "between 0 and 90"],
    );
    manifest_error(
        &mech.replace("angle_deg = 10", "angel_deg = 10"),
        &["line 4", "step.m.angel_deg", "unknown field"],
    );
    manifest_error(
        &mech.replace("angle_deg = 10", "hinge = { width_mm = 5 }"),
        &["line 1", "step.m.link_mm", "missing"],
    );
    let ct =
        "[step.p]\nkind = \"ct\"\ndata = \"data/triangle.csv\"\nnp = 2\nnz = 3\nout = \"p.json\"\n";
    manifest_error(ct, &["line 5", "step.p.nz"]);
    manifest_error(
        &ct.replace("np = 2\n", ""),
        &["step.p.np", "missing: the number of poles"],
    );
}

#[test]
fn a_nested_hinge_error_names_the_hinge() {
    manifest_error(
        "[step.m]\nkind = \"mechanism\"\ncalculator = \"lever\"\ninput_arm_mm = 10\n\nhinge = { width_mm = -5 }\nout = \"m.json\"\n",
        &["line 6", "step.m.hinge", "'width_mm'"],
    );
}
