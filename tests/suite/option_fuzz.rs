//! Bounded fuzzing of the newer commands' option sets, through the `fts`
//! binary: each run gives one to three options of one command values drawn
//! from a pool of hostile ones (0, negatives, 1e308, NaN, inf, overflowing
//! integers, text, lists, missing and wrong files), with the command's
//! valid inputs from `tests/data/bad_input/base/` and `tests/data/ilc/`.
//! (`fts ding22` is left out: one run re-synthesises its controller, tens of
//! seconds in a debug build; its options are in `cases-options.toml`.)
//! Every run must keep the contract of docs/formats.md "Exit codes":
//!
//! * exit 0, 1 or 2, never a signal (a panic exits 101) nor a hang
//!   ([`TIMEOUT`]);
//! * on a non-zero exit the last stderr line starts `fts: error: `, no
//!   line mentions a panic, stdout is empty and no file in the folder was
//!   created or changed;
//! * on exit 0 nothing but the named outputs was created.
//!
//! The runs are seeded ([`SEED`]), so CI sees the same ones every time.

use crate::common::cmd::fts;
use rand::{RngExt, SeedableRng};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const SEED: u64 = 27;
/// Runs per command.
const RUNS: usize = 24;
const TIMEOUT: Duration = Duration::from_secs(60);

/// Values any option may be given.
const VALUES: &[&str] = &[
    "0",
    "-1",
    "-0",
    "0.5",
    "3",
    "1e308",
    "-1e308",
    "1e-320",
    "NaN",
    "inf",
    "1e999",
    "18446744073709551616",
    "99999999",
    "abc",
    "",
    "1,2,3",
    "2:1",
    "tf.json",
    "missing.json",
    "data.csv",
    ".",
];

/// A command: its fixed arguments and the options fuzzed.
struct Target {
    args: &'static [&'static str],
    options: &'static [&'static str],
}

const ILC_FILES: &[&str] = &[
    "ilc",
    "--hysteresis",
    "ilc-inverse-hysteresis.json",
    "--zpetc",
    "ilc-zpetc.json",
    "--closed-loop",
    "ilc-closed-loop.json",
    "--trials",
    "2",
];

const TARGETS: &[Target] = &[
    Target {
        args: ILC_FILES,
        options: &[
            "--trials",
            "--learning-gain",
            "--q-cutoff",
            "--q-taps",
            "--divergence-factor",
            "--reference",
            "--amplitude",
            "--freq",
            "--f1",
            "--offset",
            "--duration",
            "--scale",
            "--seed",
            "--kp",
            "--ki",
            "--output-min",
            "--output-max",
            "--output-disturbance",
        ],
    },
    Target {
        args: &["repetitive", "--tf", "tf.json", "--period", "100"],
        options: &[
            "--period",
            "--gain",
            "--lead",
            "--max-lead",
            "--q-cutoff",
            "--q-taps",
            "--q",
        ],
    },
    Target {
        args: &["response", "step", "tf.json"],
        options: &[
            "--controller",
            "--kp",
            "--ki",
            "--kd",
            "--tf-derivative",
            "--duration",
            "--points",
        ],
    },
    Target {
        args: &["response", "impulse", "ctf.json"],
        options: &["--kp", "--ki", "--duration", "--points"],
    },
    Target {
        args: &["convert", "tf.json", "--to", "ss"],
        options: &["--to"],
    },
    Target {
        args: &["minreal", "tf.json"],
        options: &["--tol"],
    },
    Target {
        args: &["balred", "ctf.json", "--order", "1"],
        options: &["--order"],
    },
    Target {
        args: &["trajectory", "circle"],
        options: &[
            "--size",
            "--incline",
            "--velocity",
            "--acceleration",
            "--jerk",
            "--ts",
        ],
    },
    Target {
        args: &["contour", "circle", "--no-baseline"],
        options: &[
            "--size",
            "--velocity",
            "--acceleration",
            "--jerk",
            "--ts",
            "--settle",
            "--output-disturbance",
            "--pid-x",
            "--cc",
        ],
    },
    Target {
        args: &["virtual", "sweep", "--duration", "0.2"],
        options: &[
            "--seed",
            "--kp",
            "--ki",
            "--kd",
            "--output-min",
            "--output-max",
            "--amplitude",
            "--offset",
            "--duration",
            "--f1",
        ],
    },
    Target {
        args: &["virtual", "triangles"],
        options: &["--seed", "--amplitudes", "--freq"],
    },
    Target {
        args: &["identify", "ct", "data.csv", "--np", "2", "--nz", "0"],
        options: &[
            "--np",
            "--nz",
            "--delay",
            "--ts",
            "--detrend",
            "--split",
            "--svf-cutoff",
            "--max-iterations",
            "--time-unit",
        ],
    },
    Target {
        args: &["loop", "--plant", "tf.json", "--kp", "0.02", "--ki", "0.15"],
        options: &[
            "--kp",
            "--ki",
            "--kd",
            "--tf-derivative",
            "--points-per-decade",
            "--fmin",
            "--fmax",
        ],
    },
];

fn data(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(path)
}

/// The folder every run starts from: the bad-input base files and the
/// learning fixtures.
fn base() -> BTreeMap<String, Vec<u8>> {
    let mut files: BTreeMap<String, Vec<u8>> = std::fs::read_dir(data("bad_input/base"))
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    for name in ["inverse-hysteresis.json", "zpetc.json", "closed-loop.json"] {
        files.insert(
            format!("ilc-{name}"),
            std::fs::read(data(&format!("ilc/{name}"))).unwrap(),
        );
    }
    files
}

fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let bytes = std::fs::read(&p).unwrap_or_default();
            (p, bytes)
        })
        .collect()
}

/// One run; `Err` says how it broke the contract.
fn run(args: &[String], files: &BTreeMap<String, Vec<u8>>) -> Result<(), String> {
    let tmp = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(tmp.path().join(name), bytes).unwrap();
    }
    let before = snapshot(tmp.path());
    let started = Instant::now();
    let out = fts()
        .args(args)
        .current_dir(tmp.path())
        .env("NO_COLOR", "1")
        .timeout(TIMEOUT)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut problems = Vec::new();
    match out.status.code() {
        Some(0) => {
            // Only the named outputs may appear (none are named here).
            if snapshot(tmp.path()) != before {
                problems.push("files changed on success without an output option".into());
            }
        }
        Some(1 | 2) => {
            let last = stderr.lines().last().unwrap_or("");
            if !last.starts_with("fts: error: ") {
                problems.push(format!("last stderr line is not an error: {last:?}"));
            }
            if !out.stdout.is_empty() {
                problems.push("stdout not empty on failure".into());
            }
            if snapshot(tmp.path()) != before {
                problems.push("files changed on failure".into());
            }
        }
        Some(c) => problems.push(format!("exit {c}")),
        None if started.elapsed() >= TIMEOUT => problems.push("hang".into()),
        None => problems.push(format!("signal: {:?}", out.status)),
    }
    if stderr.contains("panicked") {
        problems.push("panic".into());
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "`fts {}`: {}\n    stderr: {}",
            args.join(" "),
            problems.join("; "),
            stderr.trim_end()
        ))
    }
}

#[test]
fn the_newer_commands_keep_the_exit_contract_under_hostile_options() {
    let files = base();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    let mut cases = Vec::new();
    for target in TARGETS {
        for _ in 0..RUNS {
            let mut args: Vec<String> = target.args.iter().map(|s| s.to_string()).collect();
            for _ in 0..rng.random_range(1..=3usize) {
                let option = target.options[rng.random_range(0..target.options.len())];
                let value = VALUES[rng.random_range(0..VALUES.len())];
                args.push(option.to_string());
                args.push(value.to_string());
            }
            cases.push(args);
        }
    }
    let started = Instant::now();
    let next = std::sync::Mutex::new(0usize);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                loop {
                    let i = {
                        let mut g = next.lock().unwrap();
                        *g += 1;
                        *g - 1
                    };
                    let Some(args) = cases.get(i) else { break };
                    if let Err(e) = run(args, &files) {
                        failures.lock().unwrap().push(e);
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    eprintln!(
        "option fuzz: {} runs in {:.1} s, {} broke the contract",
        cases.len(),
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}
