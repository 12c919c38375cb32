//! The command line and the pipeline run the same library steps: for each
//! step kind, `fts <command> ... -o OUT` and a one-step manifest with the
//! same settings write byte-identical files, and a failing step exits with
//! the same code from both.
//!
//! Add a kind by adding a row to `CASES` (and to `FAILURES`).

use crate::common::cmd::fts;
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// One step kind: the command (its data file is `data.<ext>` in the
/// working folder, its output `cli.<ext>`), the manifest table's settings
/// (besides `kind`, `data` and `out`), and the record it reads.
struct Case {
    kind: &'static str,
    command: &'static [&'static str],
    settings: &'static str,
    record: &'static str,
}

const DRYER: &str = "data/daisy-hairdryer/dryer.dat";
const PIEZO: &str = "data/piezo-smarthysteresis/hysteresis_v_150_1hz.csv";

const CASES: &[Case] = &[
    Case {
        kind: "arx",
        command: &[
            "identify",
            "arx",
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
        ],
        settings: "ts = 0.08\ndetrend = \"mean\"\nsplit = 0.5\nna = 2\nnb = 2\nnk = 3\n",
        record: DRYER,
    },
    Case {
        kind: "arx",
        command: &[
            "identify",
            "arx",
            "--ts",
            "0.08",
            "--detrend",
            "linear",
            "--na",
            "4",
            "--nb",
            "2",
            "--nk",
            "3",
            "--refine-oe",
        ],
        settings: "ts = 0.08\ndetrend = \"linear\"\nna = 4\nnb = 2\nnk = 3\nrefine_oe = true\n",
        record: DRYER,
    },
    Case {
        kind: "arx",
        command: &[
            "identify", "arx", "--ts", "0.08", "--split", "0.6", "--auto", "--rule", "aic",
        ],
        settings: "ts = 0.08\nsplit = 0.6\nauto = true\nrule = \"aic\"\n",
        record: DRYER,
    },
    Case {
        kind: "oe",
        command: &[
            "identify",
            "oe",
            "--ts",
            "0.08",
            "--detrend",
            "mean",
            "--nb",
            "2",
            "--nf",
            "2",
            "--nk",
            "3",
            "--start-estimate",
            "arx",
            "--initial",
            "zero",
            "--max-iterations",
            "20",
        ],
        settings: "ts = 0.08\ndetrend = \"mean\"\nnb = 2\nnf = 2\nnk = 3\nstart_estimate = \"arx\"\ninitial = \"zero\"\nmax_iterations = 20\n",
        record: DRYER,
    },
    Case {
        kind: "hysteresis",
        command: &[
            "identify",
            "hysteresis",
            "--no-header",
            "--input-col",
            "4",
            "--output-col",
            "3",
            "--start",
            "16286",
            "--end",
            "40000",
            "--model",
            "pi",
            "--operators",
            "6",
            "--invertible",
            "--inverse",
            "--output-unit",
            "nm",
        ],
        settings: "no_header = true\ninput_col = 4\noutput_col = 3\nstart = 16286\nend = 40000\nmodel = \"pi\"\noperators = 6\ninvertible = true\ninverse = true\noutput_unit = \"nm\"\n",
        record: PIEZO,
    },
    Case {
        kind: "hysteresis",
        command: &[
            "identify",
            "hysteresis",
            "--no-header",
            "--input-col",
            "4",
            "--output-col",
            "3",
            "--start",
            "16286",
            "--end",
            "30000",
            "--method",
            "gd",
            "--max-iterations",
            "25",
            "--no-offset",
        ],
        settings: "no_header = true\ninput_col = 4\noutput_col = 3\nstart = 16286\nend = 30000\nmethod = \"gd\"\nmax_iterations = 25\noffset = false\n",
        record: PIEZO,
    },
];

fn extension(record: &str) -> &str {
    Path::new(record)
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("csv")
}

/// Runs the command and the one-step manifest in a fresh folder; returns
/// the two output files' bytes.
fn both(case: &Case) -> (Vec<u8>, Vec<u8>) {
    let d = tempfile::tempdir().unwrap();
    let data = format!("data.{}", extension(case.record));
    std::fs::copy(repo(case.record), d.path().join(&data)).unwrap();
    let mut cli = fts();
    cli.current_dir(d.path())
        .args(&case.command[..2])
        .arg(&data)
        .args(&case.command[2..])
        .args(["-o", "cli.json"]);
    cli.assert().success();
    let manifest = format!(
        "[step.one]\nkind = \"{}\"\ndata = \"{data}\"\nout = \"built.json\"\n{}",
        case.kind, case.settings
    );
    std::fs::write(d.path().join("fts.toml"), manifest).unwrap();
    fts().current_dir(d.path()).arg("build").assert().success();
    let read = |name: &str| std::fs::read(d.path().join(name)).unwrap();
    (read("cli.json"), read("built.json"))
}

#[test]
fn command_and_one_step_manifest_write_identical_files() {
    for case in CASES {
        let (cli, built) = both(case);
        assert!(!cli.is_empty(), "{}: empty output", case.kind);
        assert!(
            cli == built,
            "{} {:?}: the command and the manifest differ\n--- command\n{}\n--- manifest\n{}",
            case.kind,
            case.command,
            String::from_utf8_lossy(&cli),
            String::from_utf8_lossy(&built)
        );
    }
}

/// A failing step: the same code from the command line and `fts build`,
/// and both messages name the culprit.
struct Failure {
    kind: &'static str,
    command: &'static [&'static str],
    settings: &'static str,
    record: &'static str,
    code: i32,
    culprit: &'static str,
}

const CONSTANT: &str = "t,u,y\n0,1.5,0\n1,1.5,1\n2,1.5,2\n3,1.5,3\n4,1.5,4\n5,1.5,5\n6,1.5,6\n7,1.5,0\n8,1.5,1\n9,1.5,2\n10,1.5,3\n11,1.5,4\n";

const FAILURES: &[Failure] = &[
    Failure {
        kind: "arx",
        command: &["identify", "arx", "--na", "2", "--nb", "2", "--nk", "1"],
        settings: "na = 2\nnb = 2\nnk = 1\n",
        record: CONSTANT,
        code: 2,
        culprit: "input is constant",
    },
    Failure {
        kind: "arx",
        command: &[
            "identify", "arx", "--ts", "0.5", "--na", "2", "--nb", "2", "--nk", "1",
        ],
        settings: "ts = 0.5\nna = 2\nnb = 2\nnk = 1\n",
        record: CONSTANT,
        code: 2,
        culprit: "ts",
    },
    Failure {
        kind: "oe",
        command: &["identify", "oe", "--nb", "0", "--nf", "1", "--nk", "1"],
        settings: "nb = 0\nnf = 1\nnk = 1\n",
        record: CONSTANT,
        code: 2,
        culprit: "nb must be at least 1",
    },
    Failure {
        kind: "hysteresis",
        command: &["identify", "hysteresis", "--method", "gd", "--invertible"],
        settings: "method = \"gd\"\ninvertible = true\n",
        record: CONSTANT,
        code: 2,
        culprit: "invertib",
    },
    Failure {
        kind: "hysteresis",
        command: &["identify", "hysteresis", "--thresholds", "2,1"],
        settings: "thresholds = [2, 1]\n",
        record: CONSTANT,
        code: 2,
        culprit: "thresholds",
    },
];

#[test]
fn a_failing_step_exits_with_the_same_code_from_both_front_ends() {
    for f in FAILURES {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("data.csv"), f.record).unwrap();
        let cli = fts()
            .current_dir(d.path())
            .args(&f.command[..2])
            .arg("data.csv")
            .args(&f.command[2..])
            .args(["-o", "cli.json"])
            .assert()
            .code(f.code)
            .get_output()
            .clone();
        let manifest = format!(
            "[step.one]\nkind = \"{}\"\ndata = \"data.csv\"\nout = \"built.json\"\n{}",
            f.kind, f.settings
        );
        std::fs::write(d.path().join("fts.toml"), manifest).unwrap();
        let built = fts()
            .current_dir(d.path())
            .arg("build")
            .assert()
            .code(f.code)
            .get_output()
            .clone();
        for (front, out) in [("command", &cli), ("build", &built)] {
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                err.contains(f.culprit),
                "{} {:?} ({front}): {err:?} does not name {:?}",
                f.kind,
                f.command,
                f.culprit
            );
        }
        assert!(!d.path().join("cli.json").exists());
        assert!(!d.path().join("built.json").exists());
    }
}

/// A step kind without a record: the command's arguments (it writes
/// `cli.<ext>`), the manifest table's settings and input fields (besides
/// `kind` and `out`), and the repository files both read, copied into the
/// working folder under the names the arguments use.
struct FileCase {
    kind: &'static str,
    command: &'static [&'static str],
    settings: &'static str,
    files: &'static [(&'static str, &'static str)],
    ext: &'static str,
}

const CLOSED_LOOP: (&str, &str) = ("cl.json", "fixtures/li21-closed-loop.json");
const INVERSE: (&str, &str) = ("inv.json", "fixtures/li21-inverse-mpi.json");

const FILE_CASES: &[FileCase] = &[
    FileCase {
        kind: "controller",
        command: &[
            "emit",
            "--closed-loop",
            "cl.json",
            "--hysteresis",
            "inv.json",
            "--pid-form",
            "li21",
            "--kp",
            "0.05",
            "--ki",
            "0.3",
            "--output-max",
            "8",
        ],
        settings: "closed_loop = \"cl.json\"\nhysteresis = \"inv.json\"\npid_form = \"li21\"\nkp = 0.05\nki = 0.3\noutput_max = 8\n",
        files: &[CLOSED_LOOP, INVERSE],
        ext: "json",
    },
    FileCase {
        kind: "controller",
        command: &[
            "emit",
            "--pid-form",
            "parallel",
            "--kp",
            "0.02",
            "--ki",
            "1500",
            "--kd",
            "2e-6",
            "--pid-n",
            "2000",
            "--ts",
            "1e-4",
            "--output-min",
            "-1",
        ],
        settings: "pid_form = \"parallel\"\nkp = 0.02\nki = 1500\nkd = 2e-6\npid_n = 2000\nts = 1e-4\noutput_min = -1\n",
        files: &[],
        ext: "json",
    },
    FileCase {
        kind: "controller",
        command: &["emit", "--closed-loop", "cl.json", "--feedback", "none"],
        settings: "closed_loop = \"cl.json\"\nfeedback = \"none\"\n",
        files: &[CLOSED_LOOP],
        ext: "json",
    },
    FileCase {
        kind: "virtual-triangles",
        command: &[
            "virtual",
            "triangles",
            "--seed",
            "3",
            "--amplitudes",
            "6,3",
            "--freq",
            "5",
        ],
        settings: "seed = 3\namplitudes = [6, 3]\nfreq = 5\n",
        files: &[],
        ext: "csv",
    },
    FileCase {
        kind: "virtual-sweep",
        command: &[
            "virtual",
            "sweep",
            "--hysteresis",
            "inv.json",
            "--seed",
            "2",
            "--kp",
            "0.03",
            "--amplitude",
            "1.5",
            "--duration",
            "0.2",
            "--f1",
            "500",
        ],
        settings: "hysteresis = \"inv.json\"\nseed = 2\nkp = 0.03\namplitude = 1.5\nduration = 0.2\nf1 = 500\n",
        files: &[INVERSE],
        ext: "csv",
    },
];

/// Runs a file case's command and its one-step manifest in a fresh folder,
/// expecting `code` from both; returns the two runs' stderr and the
/// output files (absent when the run failed).
fn both_files(case: &FileCase, code: i32) -> [(String, Option<Vec<u8>>); 2] {
    let d = tempfile::tempdir().unwrap();
    for (name, path) in case.files {
        std::fs::copy(repo(path), d.path().join(name)).unwrap();
    }
    let (cli_out, built_out) = (format!("cli.{}", case.ext), format!("built.{}", case.ext));
    let manifest = format!(
        "[step.one]\nkind = \"{}\"\nout = \"{built_out}\"\n{}",
        case.kind, case.settings
    );
    std::fs::write(d.path().join("fts.toml"), manifest).unwrap();
    let run = |args: &[&str], out: &str| {
        let output = fts()
            .current_dir(d.path())
            .args(args)
            .assert()
            .code(code)
            .get_output()
            .clone();
        let err = String::from_utf8_lossy(&output.stderr).into_owned();
        (err, std::fs::read(d.path().join(out)).ok())
    };
    let mut command = case.command.to_vec();
    command.extend(["-o", cli_out.as_str()]);
    [run(&command, &cli_out), run(&["build"], &built_out)]
}

#[test]
fn commands_without_a_record_and_their_manifest_steps_write_identical_files() {
    for case in FILE_CASES {
        let [(_, cli), (_, built)] = both_files(case, 0);
        let (cli, built) = (cli.unwrap(), built.unwrap());
        assert!(!cli.is_empty(), "{}: empty output", case.kind);
        assert!(
            cli == built,
            "{} {:?}: the command and the manifest differ\n--- command\n{}\n--- manifest\n{}",
            case.kind,
            case.command,
            String::from_utf8_lossy(&cli),
            String::from_utf8_lossy(&built)
        );
    }
}

#[test]
fn failing_steps_without_a_record_exit_alike_from_both_front_ends() {
    let failures: &[(FileCase, &str)] = &[
        (
            FileCase {
                kind: "controller",
                command: &[
                    "emit",
                    "--closed-loop",
                    "cl.json",
                    "--pid-form",
                    "li21",
                    "--kp",
                    "1",
                    "--ts",
                    "1e-3",
                ],
                settings: "closed_loop = \"cl.json\"\npid_form = \"li21\"\nkp = 1\nts = 1e-3\n",
                files: &[CLOSED_LOOP],
                ext: "json",
            },
            "sample time 0.001 s disagrees with the ZPETC's 0.0001 s",
        ),
        (
            FileCase {
                kind: "controller",
                command: &["emit", "--pid-form", "li21", "--ts", "1e-4"],
                settings: "pid_form = \"li21\"\nts = 1e-4\n",
                files: &[],
                ext: "json",
            },
            "given without any PID gain",
        ),
        (
            FileCase {
                kind: "virtual-sweep",
                command: &["virtual", "sweep", "--duration", "1e9"],
                settings: "duration = 1e9\n",
                files: &[],
                ext: "csv",
            },
            "duration",
        ),
    ];
    for (case, culprit) in failures {
        for (front, (err, out)) in ["command", "build"].iter().zip(both_files(case, 2)) {
            assert!(err.contains(culprit), "{} ({front}): {err:?}", case.kind);
            assert!(out.is_none(), "{} ({front}) wrote a file", case.kind);
        }
    }
}

/// A controller step asks for one feedback: errors name the field at fault
/// and its line, before any input is read.
#[test]
fn a_controller_step_names_the_feedback_setting_at_fault() {
    let cases = [
        (
            "ts = 1e-4\n",
            "field 'step.c.pid_form': no feedback controller given",
        ),
        (
            "ss = \"K.json\"\nkp = 1\n",
            "line 5, field 'step.c.kp': PID settings and the state-space controller 'ss' exclude each other",
        ),
        (
            "feedback = \"none\"\nkp = 1\n",
            "line 5, field 'step.c.kp': PID settings and 'feedback' none exclude each other",
        ),
        (
            "zpetc = \"K.json\"\nclosed_loop = \"K.json\"\nkp = 1\n",
            "line 5, field 'step.c.closed_loop'",
        ),
        (
            "pid_form = \"li21\"\nkp = 1\npid_n = 100\nts = 1e-4\n",
            "line 6, field 'step.c.pid_n': the derivative filter goes with 'pid_form' parallel",
        ),
    ];
    for (settings, culprit) in cases {
        let d = tempfile::tempdir().unwrap();
        std::fs::copy(repo("examples/mixsyn/K.json"), d.path().join("K.json")).unwrap();
        let manifest = format!("[step.c]\nkind = \"controller\"\nout = \"c.json\"\n{settings}");
        std::fs::write(d.path().join("fts.toml"), manifest).unwrap();
        let out = fts()
            .current_dir(d.path())
            .arg("build")
            .assert()
            .code(2)
            .get_output()
            .clone();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(culprit), "{settings:?}: {err}");
    }
}
