//! Records as users have them: time columns with units and DAQ jitter,
//! semicolon exports with a units row, MATLAB `.mat` files; every layout of
//! the same numbers gives byte-identical models, and every bad record exits 2
//! with one line naming the file, line and field.

use crate::common::cmd::{Command, fts, json_of};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

const PIEZO: &str = "data/piezo-smarthysteresis/hysteresis_v_150_1hz.csv";

/// Runs `cmd`, expects exit 2 with exactly one stderr line containing every
/// `needle`, and returns that line.
fn fails_with(cmd: &mut Command, needles: &[&str]) -> String {
    let out = cmd.assert().code(2).get_output().clone();
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in {err}");
    }
    err
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The hair-dryer record as comma CSV (s), comma CSV with `time_ms`, a
/// semicolon export with a units row and decimal commas, and a MATLAB v5
/// file (tests/data/records/make_records.py): the same numbers, so the same
/// model to the byte; the time column's unit is read from each layout.
#[test]
fn every_layout_of_the_dryer_record_gives_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let mut models = Vec::new();
    for (file, unit, unit_from) in [
        ("dryer.csv", "s", "default"),
        ("dryer-ms.csv", "ms", "name"),
        ("dryer-semicolon.csv", "s", "units-row"),
        ("dryer.mat", "s", "default"),
    ] {
        let out = dir.path().join(format!("{file}.json"));
        let j = json_of(
            fts()
                .args(["identify", "arx"])
                .arg(repo(&format!("tests/data/records/{file}")))
                .args(["--na", "2", "--nb", "2", "--nk", "3", "--json", "-o"])
                .arg(&out),
        );
        let timing = &j["timing"];
        assert_eq!(timing["unit"], unit, "{file}: {timing}");
        assert_eq!(timing["unit_from"], unit_from, "{file}: {timing}");
        let ts = timing["ts"].as_f64().unwrap();
        assert!((ts - 0.08).abs() < 1e-12, "{file}: Ts {ts}");
        assert_eq!(j["samples"], 1000, "{file}");
        models.push((file, std::fs::read(&out).unwrap()));
    }
    for (file, bytes) in &models[1..] {
        assert!(
            bytes == &models[0].1,
            "{file} gives another model than dryer.csv"
        );
    }
    // And the same coefficients as the original whitespace .dat with --ts.
    let j = json_of(
        fts()
            .args(["identify", "arx"])
            .arg(repo("data/daisy-hairdryer/dryer.dat"))
            .args([
                "--ts", "0.08", "--na", "2", "--nb", "2", "--nk", "3", "--json",
            ]),
    );
    let from_csv: Value = serde_json::from_slice(&models[0].1).unwrap();
    assert_eq!(j["num"], from_csv["num"]);
    assert_eq!(j["den"], from_csv["den"]);
}

/// The SmartHysteresis record's own time column steps by 1.9998e-4 and
/// 2.0001e-4 s (printed precision): it is accepted, Ts is 2e-4 s, the jitter
/// is reported, and the models equal those made without it or with `--ts`.
#[test]
fn the_piezo_time_column_is_read_with_its_jitter() {
    let dir = tempfile::tempdir().unwrap();
    let hyst = |time: bool, out: &Path| {
        let mut cmd = fts();
        cmd.args(["identify", "hysteresis"])
            .arg(repo(PIEZO))
            .args(["--no-header", "--input-col", "4", "--output-col", "3"])
            .args(["--start", "16286", "--json", "-o"])
            .arg(out);
        if time {
            cmd.args(["--time-col", "2"]);
        }
        json_of(&mut cmd)
    };
    let (a, b) = (dir.path().join("a.json"), dir.path().join("b.json"));
    let j = hyst(true, &a);
    let timing = &j["timing"];
    let ts = timing["ts"].as_f64().unwrap();
    assert!((ts - 2e-4).abs() < 1e-15, "{timing}");
    let max = timing["max_jitter"].as_f64().unwrap();
    let rms = timing["rms_jitter"].as_f64().unwrap();
    assert!(max > 1e-9 && max < 1e-7, "{timing}");
    assert!(rms > 0.0 && rms <= max, "{timing}");
    assert_eq!(hyst(false, &b)["timing"], Value::Null);
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());

    let arx = |extra: &[&str], out: &Path| {
        fts()
            .args(["identify", "arx"])
            .arg(repo(PIEZO))
            .args(["--no-header", "--input-col", "4", "--output-col", "3"])
            .args(["--na", "2", "--nb", "2", "--nk", "1", "-o"])
            .arg(out)
            .args(extra)
            .assert()
            .success();
        std::fs::read(out).unwrap()
    };
    let with_time = arx(&["--time-col", "2"], &dir.path().join("c.json"));
    let with_ts = arx(&["--ts", "2e-4"], &dir.path().join("d.json"));
    assert_eq!(with_time, with_ts);

    // A tolerance tighter than the record's jitter refuses it, naming where.
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(repo(PIEZO))
            .args(["--no-header", "--input-col", "4", "--output-col", "3"])
            .args(["--time-col", "2", "--time-jitter", "1e-6"])
            .args(["--na", "2", "--nb", "2", "--nk", "1"]),
        &[
            "hysteresis_v_150_1hz.csv line ",
            "field 'column 2'",
            "jitter",
        ],
    );
}

#[test]
fn time_units_come_from_the_header_or_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("time_ms,u,y\n");
    let mut plain = String::from("time,u,y\n");
    for k in 0..200 {
        let u = ((k * 7919) % 13) as f64 - 6.0;
        text.push_str(&format!("{},{u},{}\n", k as f64 * 0.1, 0.5 * u));
        plain.push_str(&format!("{},{u},{}\n", k as f64 * 0.1, 0.5 * u));
    }
    let ms = write(dir.path(), "ms.csv", &text);
    let j = json_of(fts().args(["bode"]).arg(&ms).arg("--json"));
    let ts = j["ts"].as_f64().unwrap();
    assert!((ts - 1e-4).abs() < 1e-16, "time_ms read as {ts} s");

    let plain = write(dir.path(), "plain.csv", &plain);
    let j = json_of(
        fts()
            .args(["bode"])
            .arg(&plain)
            .args(["--time-unit", "ms", "--json"]),
    );
    assert!((j["ts"].as_f64().unwrap() - 1e-4).abs() < 1e-16);
}

#[test]
fn bad_records_exit_2_naming_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let semi = write(d, "semi.csv", "t;u;y\ns;V;um\n0;1,5;2\n0,1;x;3\n0,2;1;2\n");
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&semi)
            .args(["--na", "1", "--nb", "1", "--nk", "1"]),
        &["semi.csv line 4, field 'u': not a number"],
    );
    let mut gap = String::from("t,u,y\n");
    for k in 0..50 {
        let t = if k < 30 { k as f64 } else { k as f64 + 4.0 };
        gap.push_str(&format!("{t},{},{}\n", k % 3, k % 5));
    }
    let gap = write(d, "gap.csv", &gap);
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&gap)
            .args(["--na", "1", "--nb", "1", "--nk", "1"]),
        &["gap.csv line 32, field 't'", "a gap in the record"],
    );
    let back = write(d, "back.csv", "t,u,y\n0,1,2\n1,1,2\n0.5,1,2\n");
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&back)
            .args(["--na", "1", "--nb", "1", "--nk", "1"]),
        &["back.csv line 4, field 't': time must increase"],
    );
    let unit = write(d, "unit.csv", "t [min],u,y\n0,1,2\n1,1,2\n");
    fails_with(
        fts().args(["bode"]).arg(&unit),
        &["unit.csv field 't [min]': unknown time unit 'min'"],
    );
    fails_with(
        fts().args(["bode"]).arg(&semi).args(["--time-jitter", "2"]),
        &["--time-jitter"],
    );
    fails_with(
        fts()
            .args(["bode"])
            .arg(&semi)
            .args(["--delimiter", "pipe"]),
        &["--delimiter"],
    );
}

/// `--output` named a column in some commands and a file in others: it is
/// refused with the option that is meant, and nothing is written.
#[test]
fn ambiguous_options_are_refused_with_the_right_name() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.json");
    let err = fails_with(
        fts()
            .args(["identify", "oe"])
            .arg(repo("tests/data/records/dryer.csv"))
            .args(["--nb", "2", "--nf", "2", "--nk", "3", "--output"])
            .arg(&model),
        &["--output", "-o/--out FILE", "--output-col COL"],
    );
    assert!(!model.exists(), "{err}");
    fails_with(
        fts().args(["zpetc", "--tf", "x.json", "--output=z.json"]),
        &["-o/--out FILE"],
    );
    fails_with(
        fts().args(["identify", "hysteresis", "x.csv", "--input", "3"]),
        &["--input-col COL"],
    );
    fails_with(
        fts().args(["hysteresis", "apply", "m.json", "x.csv", "--time", "t"]),
        &["--time-col COL"],
    );
}

#[test]
fn mat_file_errors_name_the_variable() {
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(repo("tests/data/records/dryer.mat"))
            .args([
                "--output-col",
                "pos_um",
                "--na",
                "1",
                "--nb",
                "1",
                "--nk",
                "1",
            ]),
        &["dryer.mat", "pos_um"],
    );
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(repo("tests/data/records/dryer.mat"))
            .args(["--output-col", "2", "--na", "1", "--nb", "1", "--nk", "1"]),
        &["dryer.mat", "by name"],
    );
}

/// A result never replaces an input of the same run, another result of the
/// run, or anything that is not a regular file.
#[test]
fn results_never_replace_inputs_or_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d.csv");
    std::fs::copy(repo("tests/data/records/dryer.csv"), &data).unwrap();
    let before = std::fs::read(&data).unwrap();
    let arx = ["--na", "2", "--nb", "2", "--nk", "3"];
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&data)
            .args(arx)
            .arg("-o")
            .arg(&data),
        &["d.csv: refusing to write a result onto an input of this run"],
    );
    // The same file by another spelling of its path.
    let other = dir.path().join(".").join("d.csv");
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&data)
            .args(arx)
            .arg("-o")
            .arg(&other),
        &["refusing to write a result onto an input"],
    );
    assert_eq!(
        std::fs::read(&data).unwrap(),
        before,
        "the input is untouched"
    );

    let model = dir.path().join("m.json");
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&data)
            .args(arx)
            .arg("-o")
            .arg(&model)
            .arg("--plot")
            .arg(&model),
        &["two results of this run would be written to the same file"],
    );
    #[cfg(unix)]
    {
        let target = dir.path().join("elsewhere.json");
        std::fs::write(&target, "keep").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        fails_with(
            fts()
                .args(["identify", "arx"])
                .arg(&data)
                .args(arx)
                .arg("-o")
                .arg(&link),
            &["link.json: refusing to write a result onto something that is not a regular file"],
        );
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
    }
}

/// A negative number reaches the option's own check, which names it.
#[test]
fn negative_numbers_reach_validation() {
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(repo("data/daisy-hairdryer/dryer.dat"))
            .args(["--ts", "-1", "--na", "2", "--nb", "2", "--nk", "3"]),
        &["--ts: expected a positive number of seconds, got -1"],
    );
}

/// Orders at the top of the integer range are refused as too large for the
/// data (exit 2), never an overflow panic.
#[test]
fn absurd_orders_are_refused_not_a_panic() {
    let max = u64::MAX.to_string();
    let data = repo("data/daisy-hairdryer/dryer.dat");
    for (cmd, orders) in [
        ("arx", ["--na", "2", "--nb", "2", "--nk", max.as_str()]),
        ("arx", ["--na", max.as_str(), "--nb", "2", "--nk", "1"]),
        ("arx", ["--na", "2", "--nb", max.as_str(), "--nk", "1"]),
        ("oe", ["--nf", max.as_str(), "--nb", "2", "--nk", "1"]),
        ("oe", ["--nf", "2", "--nb", "2", "--nk", max.as_str()]),
        ("iv", ["--na", "2", "--nb", max.as_str(), "--nk", "1"]),
        ("iv", ["--na", "2", "--nb", "2", "--nk", max.as_str()]),
    ] {
        fails_with(
            fts()
                .args(["identify", cmd])
                .arg(&data)
                .args(["--ts", "0.08"])
                .args(orders),
            &[
                "dryer.dat: invalid model structure",
                max.as_str(),
                "beyond the largest accepted",
            ],
        );
    }
}

/// A stdout that cannot be written (`> /dev/full`) is an error, exit 1 with
/// one line, not a panic.
#[cfg(target_os = "linux")]
#[test]
fn an_unwritable_stdout_exits_1_with_one_line() {
    let bin = crate::common::cmd::fts_path();
    for args in [
        vec![
            "excite",
            "sine",
            "--freq",
            "10",
            "--amplitude",
            "1",
            "--duration",
            "0.01",
        ],
        vec!["tf", "info", "fixtures/li21-closed-loop.json"],
        vec!["zpetc", "--tf", "fixtures/li21-closed-loop.json", "--json"],
        vec![
            "weight", "--kind", "ws", "--m", "2", "--w0", "160", "--a", "0.001",
        ],
        vec![
            "identify",
            "arx",
            "data/daisy-hairdryer/dryer.dat",
            "--ts",
            "0.08",
            "--na",
            "2",
            "--nb",
            "2",
            "--nk",
            "3",
        ],
    ] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = std::process::Command::new(&bin)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&args)
            .stdout(full)
            .output()
            .unwrap();
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains("cannot write to stdout"), "{args:?}: {err}");
    }
}

/// Sizes are refused before any work, naming the option that is the
/// culprit (not the duration they make too long).
#[test]
fn oversized_requests_name_their_option() {
    for (args, needle) in [
        (
            vec![
                "excite",
                "sweep",
                "--f0",
                "0",
                "--f1",
                "100",
                "--duration",
                "99999",
            ],
            "--duration: the signal would have 1.000e9 samples",
        ),
        (
            vec![
                "excite",
                "triangle",
                "--amplitudes",
                "1",
                "--freq",
                "1",
                "--cycles",
                "4000000000",
            ],
            "--cycles:",
        ),
        (
            vec![
                "excite",
                "multisine",
                "--period",
                "1",
                "--periods",
                "100000000",
                "--freqs",
                "10",
            ],
            "--periods:",
        ),
        (
            vec![
                "excite",
                "sine",
                "--freq",
                "10",
                "--amplitude",
                "1",
                "--duration",
                "1",
                "--ts",
                "1e-300",
            ],
            "--ts: sample time must be",
        ),
        (
            vec![
                "simulate",
                "--stages",
                "pid",
                "--reference",
                "sine",
                "--freq",
                "0",
                "--amplitude",
                "1",
            ],
            "--freq: expected a positive frequency",
        ),
        (
            vec!["simulate", "--stages", "pid", "--duration", "99999"],
            "--duration:",
        ),
        (
            vec![
                "tf",
                "info",
                "fixtures/li21-closed-loop.json",
                "--points",
                "1000000000",
            ],
            "--points",
        ),
    ] {
        fails_with(
            fts().current_dir(env!("CARGO_MANIFEST_DIR")).args(&args),
            &[needle],
        );
    }
}

/// `fts emit` checks its PID flags where they are named, not in the file it
/// would have written.
#[test]
fn emit_names_a_bad_gain_or_limit() {
    let dir = tempfile::tempdir().unwrap();
    let zpetc = dir.path().join("z.json");
    fts()
        .args(["zpetc", "--tf"])
        .arg(repo("fixtures/li21-closed-loop.json"))
        .arg("-o")
        .arg(&zpetc)
        .assert()
        .success();
    let out = dir.path().join("c.json");
    for (flags, needle) in [
        (vec!["--kp", "NaN"], "--kp: expected a finite gain, got NaN"),
        (vec!["--kd", "inf"], "--kd: expected a finite gain, got inf"),
        (
            vec!["--kp", "0.02", "--output-min", "5", "--output-max", "1"],
            "min < max, got 5 and 1",
        ),
    ] {
        fails_with(
            fts()
                .arg("emit")
                .arg("--zpetc")
                .arg(&zpetc)
                .args(["--pid-form", "li21"])
                .args(&flags)
                .arg("-o")
                .arg(&out),
            &[needle],
        );
        assert!(!out.exists());
    }
}

/// The dryer record (tests/data/records/dryer.csv) rewritten with `map`.
fn dryer_as(dir: &Path, name: &str, map: impl Fn(&str) -> String) -> PathBuf {
    let csv = std::fs::read_to_string(repo("tests/data/records/dryer.csv")).unwrap();
    write(dir, name, &map(&csv))
}

/// The ARX model file of `fts identify arx FILE EXTRA...` (orders 2 2 3).
fn arx_model(file: &Path, extra: &[&str], out: &Path) -> Vec<u8> {
    fts()
        .args(["identify", "arx"])
        .arg(file)
        .args(["--na", "2", "--nb", "2", "--nk", "3", "-o"])
        .arg(out)
        .args(extra)
        .assert()
        .success();
    std::fs::read(out).unwrap()
}

/// Records as instruments write them (issue #31): a tab-separated file whose
/// header names hold spaces, a DAQ preamble above the header skipped with
/// `--header-row`, and an Excel `sep=,` first line each give the model of
/// the plain CSV to the byte.
#[test]
fn instrument_layouts_of_the_dryer_record_give_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plain = arx_model(
        &repo("tests/data/records/dryer.csv"),
        &[],
        &d.join("plain.json"),
    );
    let tab = dryer_as(d, "tab.txt", |csv| {
        csv.replacen("t,u,y", "time [s],drive voltage,position", 1)
            .replace(',', "\t")
    });
    let named = ["--input-col", "drive voltage", "--output-col", "position"];
    assert_eq!(arx_model(&tab, &named, &d.join("tab.json")), plain);
    let preamble = dryer_as(d, "daq.csv", |csv| {
        format!("Instrument: DAQ 9000, serial 17\nDate: 2026-11-28\n\n{csv}")
    });
    assert_eq!(
        arx_model(&preamble, &["--header-row", "4"], &d.join("daq.json")),
        plain
    );
    let excel = dryer_as(d, "excel.csv", |csv| format!("sep=,\r\n{csv}"));
    assert_eq!(arx_model(&excel, &[], &d.join("excel.json")), plain);
    // The same semicolon export, its `sep=;` line overriding nothing else.
    let semi = dryer_as(d, "excel-semi.csv", |csv| {
        format!("sep=;\n{}", csv.replace(',', ";"))
    });
    assert_eq!(arx_model(&semi, &[], &d.join("semi.json")), plain);
}

/// A preamble keeps the file's line numbers in errors, and without
/// `--header-row` the preamble is not taken for column names silently.
#[test]
fn a_preamble_keeps_the_files_line_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bad = write(
        d,
        "daq.csv",
        "Instrument: DAQ 9000\nDate: 2026-11-28\n\nt,u,y\n0,1,2\n1,x,3\n2,3,4\n",
    );
    let arx = |extra: &[&str]| {
        let mut cmd = fts();
        cmd.args(["identify", "arx"])
            .arg(&bad)
            .args(["--na", "1", "--nb", "1", "--nk", "1"])
            .args(extra);
        cmd
    };
    fails_with(
        &mut arx(&["--header-row", "4"]),
        &["daq.csv line 6, field 'u': not a number"],
    );
    fails_with(&mut arx(&[]), &["daq.csv"]);
    let tab = write(
        d,
        "tab.txt",
        "time [ms]\tdrive\tposition\n0\t1\t2\n1\t2\n2\t3\t4\n",
    );
    fails_with(
        fts()
            .args(["identify", "arx"])
            .arg(&tab)
            .args(["--input-col", "drive", "--output-col", "position"])
            .args(["--na", "1", "--nb", "1", "--nk", "1"]),
        &["tab.txt line 3, field 'position'", "the line has 2 fields"],
    );
}

/// A structure search whose choice lies on an edge of its grid says so on
/// stderr and in the JSON report, naming the edge and the option that
/// widens it (issue #31): the dryer's delay is 3 samples, so a delay range
/// 0..2 is chosen at its top; with the delay inside 0..6 nothing is said.
#[test]
fn a_structure_search_says_when_its_choice_is_on_the_grid_edge() {
    let dryer = repo("tests/data/records/dryer.csv");
    let search = |nk: &str| {
        let out = fts()
            .args(["identify", "arx-struct"])
            .arg(&dryer)
            .args(["--na", "2", "--nb", "2", "--nk", nk, "--json"])
            .assert()
            .success()
            .get_output()
            .clone();
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        (report, String::from_utf8(out.stderr).unwrap())
    };
    let (report, stderr) = search("0:2");
    assert_eq!(report["recommended"]["nk"], 2, "{report}");
    for needle in [
        "warning: nk = 2 lies on the upper edge of the searched range 0..2",
        "--nk LO:HI",
    ] {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
    }
    assert!(report["grid_edges"][0].as_str().unwrap().contains("nk = 2"));
    let (report, stderr) = search("0:6");
    assert_eq!(report["recommended"]["nk"], 3, "{report}");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(report.get("grid_edges").is_none(), "{report}");
}
