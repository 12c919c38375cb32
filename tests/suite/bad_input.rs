//! The bad-input campaigns as tables (`tests/data/bad_input/cases.toml`, and
//! `cases-*.toml` for the commands added since):
//! every case runs the `fts` binary in a fresh folder holding the valid
//! files of `tests/data/bad_input/base/` plus the case's own files, and
//! checks the contract of docs/formats.md "Exit codes":
//!
//! * the expected exit code (2 bad input, 1 computation), never a signal
//!   (a panic aborts with 101, an allocation failure with SIGABRT) and never
//!   a hang (each run is killed after [`TIMEOUT`]);
//! * stderr is exactly one line, starting `fts: error:` (usage errors too:
//!   clap's message and tip are joined on that line), holding every
//!   `expect` substring: the file, field or option and the value given;
//! * stdout is empty, and no file in the folder was created, changed or
//!   removed (results are written only on success).
//!
//! Each run's address space is capped at [`MEMORY_LIMIT`], so an unbounded
//! allocation fails the case instead of swapping the machine.

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(30);
const MEMORY_LIMIT: u64 = 4 << 30;
const MIN_CASES: usize = 200;
const MIN_NEW_CASES: usize = 500;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Table {
    case: Vec<Case>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    /// The command line after `fts`, split on whitespace (or a list).
    args: Args,
    /// Files written into the case's folder (beside the base files).
    #[serde(default)]
    files: BTreeMap<String, FileSpec>,
    /// Expected exit code.
    exit: i32,
    /// Substrings the error line must contain.
    expect: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Args {
    Line(String),
    List(Vec<String>),
}

impl Args {
    fn list(&self) -> Vec<String> {
        match self {
            Args::Line(l) => l.split_whitespace().map(str::to_owned).collect(),
            Args::List(v) => v.clone(),
        }
    }
}

/// A file's contents: literal text, a base file edited, or a generated text
/// `prefix + repeat * count + suffix` (for sizes beyond every bound).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum FileSpec {
    Text(String),
    Edited {
        from: String,
        #[serde(default)]
        replace: Vec<[String; 2]>,
        #[serde(default)]
        truncate: Option<usize>,
    },
    Generated {
        #[serde(default)]
        prefix: String,
        repeat: String,
        count: usize,
        #[serde(default)]
        suffix: String,
    },
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bad_input")
}

fn base_files() -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(data_dir().join("base"))
        .expect("base folder")
        .map(|e| {
            let e = e.expect("entry");
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).expect("base file"))
        })
        .collect()
}

fn contents(spec: &FileSpec, base: &BTreeMap<String, Vec<u8>>) -> Vec<u8> {
    match spec {
        FileSpec::Text(t) => t.clone().into_bytes(),
        FileSpec::Generated {
            prefix,
            repeat,
            count,
            suffix,
        } => format!("{prefix}{}{suffix}", repeat.repeat(*count)).into_bytes(),
        FileSpec::Edited {
            from,
            replace,
            truncate,
        } => {
            let mut bytes = base
                .get(from)
                .unwrap_or_else(|| panic!("no base file {from}"))
                .clone();
            for [old, new] in replace {
                let text = String::from_utf8(bytes).expect("replace needs a text file");
                assert!(text.contains(old.as_str()), "{from} has no {old:?}");
                bytes = text.replacen(old.as_str(), new, 1).into_bytes();
            }
            if let Some(n) = truncate {
                bytes.truncate(*n);
            }
            bytes
        }
    }
}

/// Every file of the folder with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read folder") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p.clone());
                out.insert(p, Vec::new());
            } else {
                out.insert(p.clone(), std::fs::read(&p).unwrap_or_default());
            }
        }
    }
    out
}

fn command(dir: &Path, args: &[String]) -> std::process::Command {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_fts"));
    cmd.args(args).current_dir(dir).env("NO_COLOR", "1");
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: setrlimit is async-signal-safe; nothing else runs between
        // fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let lim = libc::rlimit {
                    rlim_cur: MEMORY_LIMIT,
                    rlim_max: MEMORY_LIMIT,
                };
                libc::setrlimit(libc::RLIMIT_AS, &lim);
                Ok(())
            });
        }
    }
    cmd
}

/// Runs one case; `Err` describes every way it broke the contract.
fn run_case(index: usize, case: &Case, base: &BTreeMap<String, Vec<u8>>) -> Result<(), String> {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path();
    for (name, bytes) in base {
        std::fs::write(dir.join(name), bytes).expect("write base");
    }
    for (name, spec) in &case.files {
        std::fs::write(dir.join(name), contents(spec, base)).expect("write case file");
    }
    let before = snapshot(dir);
    let args = case.args.list();
    let started = Instant::now();
    let out = crate::common::cmd::Command::from_std(command(dir, &args))
        .timeout(TIMEOUT)
        .output()
        .expect("run fts");
    let elapsed = started.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let mut problems = Vec::new();
    match out.status.code() {
        Some(c) if c == case.exit => {}
        Some(c) => problems.push(format!("exit {c}, expected {}", case.exit)),
        None if elapsed >= TIMEOUT => problems.push(format!("hang: killed after {TIMEOUT:?}")),
        None => problems.push(format!("killed by a signal: {:?}", out.status)),
    }
    let lines: Vec<&str> = stderr.lines().collect();
    if lines.len() != 1 || !lines[0].starts_with("fts: error: ") {
        problems.push(format!("stderr is not one 'fts: error: ' line: {stderr:?}"));
    }
    for want in &case.expect {
        if !stderr.contains(want.as_str()) {
            problems.push(format!("message lacks {want:?}"));
        }
    }
    if !stdout.is_empty() {
        problems.push(format!("stdout not empty: {stdout:?}"));
    }
    if snapshot(dir) != before {
        problems.push("files in the folder were created, changed or removed".into());
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "case {index} `fts {}`: {}\n    stderr: {}",
            args.join(" "),
            problems.join("; "),
            stderr.trim_end()
        ))
    }
}

/// The first campaign: the commands of the first release.
#[test]
fn every_bad_input_is_refused_on_one_line_naming_the_culprit() {
    run_tables(&[data_dir().join("cases.toml")], MIN_CASES);
}

/// The second campaign: the commands added since (learning, responses,
/// conversions, reductions, contouring, mechanisms, continuous-time
/// identification, virtual records), one table per area in
/// `tests/data/bad_input/cases-*.toml`.
#[test]
fn every_bad_input_to_the_newer_commands_is_refused_the_same_way() {
    let mut tables: Vec<PathBuf> = std::fs::read_dir(data_dir())
        .expect("bad_input folder")
        .map(|e| e.expect("entry").path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("cases-") && n.ends_with(".toml"))
        })
        .collect();
    tables.sort();
    run_tables(&tables, MIN_NEW_CASES);
}

/// Runs every case of `tables` (only those whose file name contains
/// `FTS_BAD_INPUT_TABLE`, when set, and then without the count check).
fn run_tables(tables: &[PathBuf], min_cases: usize) {
    let filter = std::env::var("FTS_BAD_INPUT_TABLE").ok();
    let mut cases = Vec::new();
    for path in tables {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if filter.as_ref().is_some_and(|f| !name.contains(f.as_str())) {
            continue;
        }
        let text = std::fs::read_to_string(path).expect("case table");
        let table: Table =
            toml::from_str(&text).unwrap_or_else(|e| panic!("{name} does not parse: {e}"));
        cases.extend(table.case.into_iter().map(|c| (name.clone(), c)));
    }
    let base = base_files();
    let n = cases.len();
    assert!(filter.is_some() || n >= min_cases, "only {n} cases");
    let next = Mutex::new(0usize);
    let failures = Mutex::new(Vec::new());
    let started = Instant::now();
    let workers = std::thread::available_parallelism().map_or(2, |p| p.get().clamp(2, 8));
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let i = {
                        let mut g = next.lock().unwrap();
                        let i = *g;
                        *g += 1;
                        i
                    };
                    let Some((table, case)) = cases.get(i) else {
                        break;
                    };
                    if let Err(e) = run_case(i, case, &base) {
                        failures.lock().unwrap().push((i, format!("{table}: {e}")));
                    }
                }
            });
        }
    });
    let mut failures = failures.into_inner().unwrap();
    failures.sort();
    eprintln!(
        "bad-input suite: {n} cases in {:.1} s, {} failed",
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    let report: Vec<String> = failures.into_iter().map(|(_, e)| e).collect();
    assert!(report.is_empty(), "\n{}", report.join("\n"));
}
