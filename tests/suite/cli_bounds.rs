//! Bounded work and traceless failures (issue #27 items 4 and 5;
//! docs/formats.md, Bounds and Exit codes): sizes a file or option asks for
//! are refused before the work, and a failed run leaves no result behind.

use crate::common::cmd::fts;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn base(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/bad_input/base")
        .join(name)
}

/// The base discrete plant (5 poles, 4 zeros) with another delay.
fn delayed_tf(dir: &Path, delay: usize) -> PathBuf {
    let text = std::fs::read_to_string(base("tf.json")).unwrap();
    let path = dir.join(format!("d{delay}.json"));
    std::fs::write(
        &path,
        text.replace("\"delay\": 5", &format!("\"delay\": {delay}")),
    )
    .unwrap();
    path
}

/// Every command that works on a state-space model, with its arguments
/// around the system file.
fn ss_commands(sys: &str) -> Vec<Vec<String>> {
    let list: Vec<Vec<&str>> = vec![
        vec!["loop", "--plant", sys, "--kp", "0.1"],
        vec!["loop", "--plant", "g.json", "--controller", sys],
        vec!["response", "step", sys],
        vec!["response", "step", "g.json", "--controller", sys],
        vec!["convert", sys, "--to", "ss", "-o", "out.json"],
        vec!["minreal", sys, "-o", "out.json"],
        vec!["balred", sys, "--order", "2", "-o", "out.json"],
        vec!["d2c", sys, "-o", "out.json"],
        vec!["ss-info", sys],
        vec!["c2d", sys, "--ts", "1e-4", "-o", "out.json"],
    ];
    list.into_iter()
        .map(|a| a.into_iter().map(String::from).collect())
        .collect()
}

/// A delay of 1000 or 100000 samples (the file format allows 1e6) is
/// refused by every state-space command in well under a second, exit 2
/// naming the field, the value and the bound; before, 100000 panicked on an
/// 80 GB matrix and 1000 ran past 300 s in `balred` and `ss-info`.
#[test]
fn long_delays_are_refused_before_any_state_matrix() {
    let d = tempfile::tempdir().unwrap();
    std::fs::copy(base("tf.json"), d.path().join("g.json")).unwrap();
    for delay in [1000, 100_000] {
        let sys = delayed_tf(d.path(), delay);
        let name = sys.file_name().unwrap().to_str().unwrap().to_string();
        for args in ss_commands(&name) {
            let start = Instant::now();
            let out = fts()
                .current_dir(d.path())
                .args(&args)
                .timeout(Duration::from_secs(30))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
            assert!(out.stdout.is_empty(), "{args:?}");
            for part in [
                name.as_str(),
                "'delay'",
                &delay.to_string(),
                "at most 200 states",
            ] {
                assert!(err.contains(part), "{args:?}: {err} lacks {part}");
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "{args:?} took {:?}",
                start.elapsed()
            );
            assert!(!d.path().join("out.json").exists(), "{args:?}");
        }
    }
}

/// Within the bound the realisation is exact: a delay of 150 samples on the
/// 5-pole plant is 154 states (`max(4 + 150, 5)`), and the state-space
/// commands answer in seconds.
#[test]
fn delays_within_the_bound_are_realised_in_seconds() {
    let d = tempfile::tempdir().unwrap();
    std::fs::copy(base("tf.json"), d.path().join("g.json")).unwrap();
    let sys = delayed_tf(d.path(), 150);
    let start = Instant::now();
    fts()
        .current_dir(d.path())
        .args(["convert", "d150.json", "--to", "ss", "-o", "ss.json"])
        .assert()
        .success();
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.path().join("ss.json")).unwrap()).unwrap();
    assert_eq!(v["a"].as_array().unwrap().len(), 154);
    let out = fts()
        .current_dir(d.path())
        .args(["loop", "--plant"])
        .arg(&sys)
        .args(["--kp", "0.01", "--json"])
        .timeout(Duration::from_secs(60))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // L = 0.01 G: the loop has the plant's 154 states and no more.
    assert_eq!(v["closed_loop_poles"].as_array().unwrap().len(), 154);
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{:?}",
        start.elapsed()
    );
}

/// `ss-info` and `balred` take at most 64 states: a 65-state file is
/// refused at once (exit 2 naming the file, the size and the bound).
#[test]
fn ss_info_and_balred_refuse_more_than_64_states() {
    let d = tempfile::tempdir().unwrap();
    let n = 65;
    let row = |i: usize| {
        let r: Vec<String> = (0..n)
            .map(|j| if i == j { "0.5".into() } else { "0".into() })
            .collect();
        format!("[{}]", r.join(","))
    };
    let a: Vec<String> = (0..n).map(row).collect();
    let text = format!(
        r#"{{"format":"fts.ss/1","ts":0.001,"a":[{}],"b":[{}],"c":[[{}]],"d":[[0]]}}"#,
        a.join(","),
        vec!["[1]"; n].join(","),
        vec!["1"; n].join(",")
    );
    std::fs::write(d.path().join("big.json"), text).unwrap();
    for args in [
        vec!["ss-info", "big.json"],
        vec!["balred", "big.json", "--order", "2"],
    ] {
        let out = fts().current_dir(d.path()).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        for part in ["big.json", "65 states", "at most 64 states"] {
            assert!(err.contains(part), "{args:?}: {err} lacks {part}");
        }
    }
}

fn ct_record() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ct-ident/zaxis-multisine.csv")
}

/// `identify ct --np 1000` ran past 300 s; it is refused (at most 20 poles),
/// as is a record too long for the poles and iterations asked
/// (samples x np x max_iterations at most 2e7).
#[test]
fn identify_ct_bounds_its_orders_and_work() {
    let out = fts()
        .args(["identify", "ct"])
        .arg(ct_record())
        .args(["--np", "1000", "--nz", "0"])
        .timeout(Duration::from_secs(30))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--np") && err.contains("1000") && err.contains("at most 20"),
        "{err}"
    );
    // 20,000 samples x 20 poles x 50 iterations = 2e7: at the bound; with
    // 51 iterations it is refused, naming both options.
    let out = fts()
        .args(["identify", "ct"])
        .arg(ct_record())
        .args(["--np", "20", "--nz", "0", "--max-iterations", "51"])
        .timeout(Duration::from_secs(30))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    for part in ["--np", "--max-iterations", "20400000", "20000000"] {
        assert!(err.contains(part), "{err} lacks {part}");
    }
}

/// A record with three corrupted cells (values of 1e40 where the signals
/// are of order 1e2): SRIVC's iterates then reach a denominator whose
/// companion matrix overflowed nalgebra's matrix exponential, which squared
/// u64::MAX times. Every iteration is now bounded: the command answers (a
/// model or exit 1) well within the timeout.
#[test]
fn a_record_with_corrupted_cells_returns_in_bounded_time() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(ct_record()).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for (row, col, value) in [(500, 2, "1e40"), (5000, 1, "-1e40"), (12000, 2, "1e40")] {
        let mut cells: Vec<&str> = lines[row].split(',').collect();
        cells[col] = value;
        lines[row] = cells.join(",");
    }
    std::fs::write(d.path().join("bad.csv"), lines.join("\n") + "\n").unwrap();
    let start = Instant::now();
    let out = fts()
        .current_dir(d.path())
        .args(["identify", "ct", "bad.csv", "--np", "2", "--nz", "0"])
        .timeout(Duration::from_secs(60))
        .output()
        .unwrap();
    let code = out.status.code();
    assert!(
        matches!(code, Some(0) | Some(1)),
        "{code:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(start.elapsed() < Duration::from_secs(60));
}

/// `c2d` of `a = -1e60` hung in the matrix exponential; now it is exact
/// (`e^(-1e60) = 0`), and `a = +1e60` (overflow) fails with exit 1.
#[test]
fn c2d_of_huge_entries_returns() {
    let d = tempfile::tempdir().unwrap();
    for (a, code) in [("-1e60", 0), ("1e60", 1)] {
        let text = format!(r#"{{"format":"fts.ss/1","a":[[{a}]],"b":[[1]],"c":[[1]],"d":[[0]]}}"#);
        std::fs::write(d.path().join("s.json"), text).unwrap();
        let out = fts()
            .current_dir(d.path())
            .args(["c2d", "s.json", "--ts", "1", "--json"])
            .timeout(Duration::from_secs(20))
            .output()
            .unwrap();
        assert_eq!(
            out.status.code(),
            Some(code),
            "{a}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        if code == 0 {
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            assert_eq!(v["system"]["a"][0][0].as_f64(), Some(0.0), "{v}");
        }
    }
}

/// `emit --format c -o d` with `d/fts_runtime.c` a folder wrote two files,
/// then exited 2; now it writes none.
#[test]
fn emit_into_a_folder_with_a_blocked_name_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("d/fts_runtime.c")).unwrap();
    let out = fts()
        .current_dir(d.path())
        .args([
            "emit", "--format", "c", "-o", "d", "--kp", "1", "--ts", "1e-4",
        ])
        .args(["--pid-form", "li21"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let names: Vec<_> = std::fs::read_dir(d.path().join("d"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("fts_runtime.c")]);
}

/// A stdout that cannot be written fails the run (exit 1) and undoes its
/// result file: a non-zero exit never leaves one behind.
#[test]
fn a_full_stdout_undoes_the_result_file() {
    let d = tempfile::tempdir().unwrap();
    std::fs::copy(base("tf.json"), d.path().join("g.json")).unwrap();
    std::fs::write(d.path().join("out.json"), "old").unwrap();
    let out = std::process::Command::new(crate::common::cmd::fts_path())
        .current_dir(d.path())
        .args(["convert", "g.json", "--to", "ss", "-o", "out.json"])
        .stdout(std::fs::File::create("/dev/full").unwrap())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(d.path().join("out.json")).unwrap(),
        "old"
    );
    let temps = temp_files(d.path());
    assert!(temps.is_empty(), "{temps:?}");
}

/// `fts ... 2> /dev/full` panicked (exit 101) on writing its error line or a
/// note; it now keeps its own exit code.
#[test]
fn a_full_stderr_never_panics() {
    let d = tempfile::tempdir().unwrap();
    std::fs::copy(base("tf.json"), d.path().join("g.json")).unwrap();
    let cases: Vec<(Vec<&str>, i32)> = vec![
        (vec!["tf", "info", "missing.json"], 2),
        (vec!["no-such-command"], 2),
        (vec!["loop", "--plant", "g.json"], 2),
        (
            vec![
                "emit",
                "--format",
                "c",
                "-o",
                "c",
                "--kp",
                "1",
                "--ts",
                "1e-4",
                "--pid-form",
                "li21",
            ],
            0,
        ),
        (
            vec![
                "excite",
                "sine",
                "--freq",
                "10",
                "--duration",
                "0.01",
                "-o",
                "u.csv",
            ],
            0,
        ),
    ];
    for (args, code) in cases {
        let out = std::process::Command::new(crate::common::cmd::fts_path())
            .current_dir(d.path())
            .args(&args)
            .stderr(std::fs::File::create("/dev/full").unwrap())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(code), "{args:?}");
    }
}

fn temp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".fts-") && n.ends_with(".tmp"))
        .collect()
}

/// SIGKILL at random times while `excite` writes a 30 MB CSV into a
/// folder of its own: the target is either absent or complete, and the
/// next run of any command anywhere (here `fts --version` in another
/// folder) removes every temporary file the killed runs left (their
/// journals name the folder; docs/formats.md "Exit codes").
#[test]
#[cfg(unix)]
fn killed_runs_leave_no_temporary_files_after_the_next_run() {
    use rand::{RngExt, SeedableRng};
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    let bin = crate::common::cmd::fts_path();
    // How long a whole run takes here, to spread the kills over it.
    let start = Instant::now();
    let args = [
        "excite",
        "sine",
        "--freq",
        "10",
        "--duration",
        "1",
        "--ts",
        "1e-6",
        "-o",
        "out/u.csv",
    ];
    let status = std::process::Command::new(&bin)
        .current_dir(d.path())
        .args(args)
        .stderr(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let full = std::fs::read(out.join("u.csv")).unwrap();
    let run = start.elapsed();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27);
    let mut stranded = 0;
    for _ in 0..50 {
        std::fs::remove_file(out.join("u.csv")).ok();
        let mut child = std::process::Command::new(&bin)
            .current_dir(d.path())
            .args(args)
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(run.mul_f64(rng.random_range(0.0..1.1)));
        child.kill().ok();
        child.wait().unwrap();
        if let Ok(bytes) = std::fs::read(out.join("u.csv")) {
            assert!(bytes == full, "a half-written target");
        }
        stranded += temp_files(&out).len();
        fts()
            .current_dir(elsewhere.path())
            .arg("--version")
            .assert()
            .success();
        let left = temp_files(&out);
        assert!(left.is_empty(), "left behind: {left:?}");
    }
    // The test is only meaningful if some kills landed mid-write.
    assert!(
        stranded > 0,
        "no kill landed while a temporary file existed"
    );
}
