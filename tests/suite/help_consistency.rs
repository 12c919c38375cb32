//! The command line speaks one vocabulary and teaches itself: one spelling
//! per concept across every command, an `Examples:` section in every help
//! whose lines parse and run, help that tells what the command writes, and
//! completions and manual pages generated from the same definition.

use crate::common::cmd::fts;
use std::collections::BTreeMap;
use std::path::Path;

/// Every (sub)command below the root with its path (`identify arx`), the
/// `help` pseudo-commands left out.
fn commands() -> Vec<(String, clap::Command)> {
    fn walk(cmd: &clap::Command, path: &str, out: &mut Vec<(String, clap::Command)>) {
        for sub in cmd.get_subcommands() {
            if sub.get_name() == "help" || sub.is_hide_set() {
                continue;
            }
            let p = match path {
                "" => sub.get_name().to_owned(),
                _ => format!("{path} {}", sub.get_name()),
            };
            out.push((p.clone(), sub.clone()));
            walk(sub, &p, out);
        }
    }
    let mut out = Vec::new();
    let mut root = fts::cli::command();
    root.build();
    walk(&root, "", &mut out);
    out
}

/// The long options a command shows in its help.
fn visible_longs(cmd: &clap::Command) -> Vec<String> {
    cmd.get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter_map(|a| a.get_long().map(str::to_owned))
        .filter(|l| l != "help" && l != "version")
        .collect()
}

/// Concept -> the canonical long option and the spellings it replaced
/// (still accepted as hidden aliases, with a deprecation warning).
const CONCEPTS: &[(&str, &str, &[&str])] = &[
    (
        "iteration limit",
        "max-iterations",
        &["max-iters", "maxiter", "max-iter", "iterations"],
    ),
    (
        "highest frequency",
        "fmax",
        &["plot-fmax", "f-max", "freq-max", "max-freq"],
    ),
    ("result file", "out", &["output", "out-file", "output-file"]),
    (
        "Welch segment",
        "segment",
        &["nperseg", "segment-len", "segment-length", "seg"],
    ),
    ("stage list", "stages", &["stage", "chain"]),
    ("frequency-response table", "bode", &["bode-csv", "frd"]),
];

#[test]
fn one_spelling_per_concept() {
    let mut wrong = Vec::new();
    for (path, cmd) in commands() {
        for long in visible_longs(&cmd) {
            for (concept, canonical, synonyms) in CONCEPTS {
                if synonyms.contains(&long.as_str()) {
                    wrong.push(format!("fts {path} --{long}: {concept} is --{canonical}"));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// `--plot-fmax` and `--fmax`, `--max_iters` and `--maxiters`: one concept.
fn normalised(long: &str) -> String {
    let stem = ["plot-"]
        .iter()
        .fold(long, |l, prefix| l.strip_prefix(prefix).unwrap_or(l));
    stem.replace(['-', '_'], "")
}

#[test]
fn no_two_spellings_of_one_name() {
    let mut by_stem: BTreeMap<String, BTreeMap<String, Vec<String>>> = BTreeMap::new();
    for (path, cmd) in commands() {
        for long in visible_longs(&cmd) {
            by_stem
                .entry(normalised(&long))
                .or_default()
                .entry(long)
                .or_default()
                .push(path.clone());
        }
    }
    // Different concepts whose names differ only by a hyphen.
    by_stem.remove("periods");
    let clashes: Vec<String> = by_stem
        .values()
        .filter(|spellings| spellings.len() > 1)
        .map(|spellings| format!("{spellings:?}"))
        .collect();
    assert!(clashes.is_empty(), "{}", clashes.join("\n"));
}

/// The `$ fts ...` lines of a command's help.
fn example_lines(cmd: &mut clap::Command) -> Option<Vec<String>> {
    let help = cmd.render_long_help().to_string();
    let (_, section) = help.split_once("Examples:\n")?;
    Some(
        section
            .lines()
            .map_while(|l| l.trim().strip_prefix("$ ").map(str::to_owned))
            .collect(),
    )
}

/// The top-level help's examples are the workflow's steps, each one of its
/// own command's examples (which the tests run there).
#[test]
fn top_level_examples_are_commands_own() {
    let mut root = fts::cli::command();
    let top = example_lines(&mut root).expect("an Examples: section in fts --help");
    assert!(top.len() >= 4, "{top:?}");
    let own: Vec<String> = commands()
        .into_iter()
        .flat_map(|(_, mut cmd)| example_lines(&mut cmd).unwrap_or_default())
        .collect();
    for line in &top {
        assert!(
            own.contains(line),
            "`{line}` is in no command's own examples"
        );
    }
}

#[test]
fn every_command_has_examples() {
    let missing: Vec<String> = commands()
        .into_iter()
        .filter(|(_, cmd)| example_lines(&mut cmd.clone()).is_none_or(|l| l.is_empty()))
        .map(|(path, _)| path)
        .collect();
    assert!(missing.is_empty(), "no Examples: section in {missing:?}");
}

/// A line's words and the file its stdout is redirected to (`> fts.bash`).
fn split(line: &str) -> (Vec<String>, Option<String>) {
    let (command, redirect) = match line.split_once(" > ") {
        Some((c, f)) => (c, Some(f.trim().to_owned())),
        None => (line, None),
    };
    (
        command.split_whitespace().map(str::to_owned).collect(),
        redirect,
    )
}

#[test]
fn every_example_parses() {
    for (path, mut cmd) in commands() {
        for line in example_lines(&mut cmd).unwrap_or_default() {
            let (words, _) = split(&line);
            if let Err(e) = fts::cli::command().try_get_matches_from(&words) {
                panic!("fts {path}: example `{line}` does not parse: {e}");
            }
        }
    }
}

/// A folder holding the repository's data folders (linked), where an
/// example's files are written.
fn workdir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["fixtures", "data", "tests", "examples"] {
        std::os::unix::fs::symlink(root.join(name), dir.path().join(name)).unwrap();
    }
    dir
}

/// Examples not run here: minutes each in a test build (demo, contour,
/// the structure scan), or no H2-solvable generalised plant among the
/// repository's files (h2; its options are checked by parsing).
const NOT_RUN: [&str; 4] = ["demo", "contour", "identify arx-struct", "h2"];

/// Every example runs (exit 0) from a fresh folder, each command's lines
/// in order, so a later line reads what an earlier one wrote.
#[test]
fn every_example_runs() {
    for (path, mut cmd) in commands() {
        if NOT_RUN.contains(&path.as_str()) {
            continue;
        }
        let dir = workdir();
        for line in example_lines(&mut cmd).unwrap_or_default() {
            let (words, redirect) = split(&line);
            let out = fts()
                .current_dir(dir.path())
                .args(&words[1..])
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "fts {path}: example `{line}` failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            if let Some(file) = redirect {
                std::fs::write(dir.path().join(file), &out.stdout).unwrap();
            }
        }
    }
}

#[test]
fn h2_help_lists_no_gamma_search_options() {
    let out = fts().args(["h2", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for option in ["--gamma", "--tol", "--backoff", "--pole-margin"] {
        assert!(!help.contains(option), "h2 --help lists {option}:\n{help}");
    }
    let out = fts().args(["hinf", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for option in [
        "--gamma-max",
        "--tol",
        "--backoff",
        "--pole-margin",
        "--eps",
    ] {
        assert!(help.contains(option), "hinf --help lacks {option}");
    }
}

/// The trace columns simulate's help names are the header it writes.
#[test]
fn simulate_help_names_the_trace_columns() {
    let out = fts().args(["simulate", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    let listed = help
        .split_once("Write the trace (")
        .and_then(|(_, rest)| rest.split_once(')'))
        .map(|(cols, _)| cols.split(", ").collect::<Vec<_>>())
        .expect("simulate --help names the trace columns");
    let dir = workdir();
    fts()
        .current_dir(dir.path())
        .args([
            "simulate",
            "--plant-tf",
            "fixtures/second-order-plant-zoh.json",
            "--stages",
            "pid",
            "--kp",
            "0.5",
            "--ki",
            "0.05",
            "--reference-file",
            "fixtures/step-input-disturbance.csv",
            "-o",
            "trace.csv",
        ])
        .assert()
        .success();
    let trace = std::fs::read_to_string(dir.path().join("trace.csv")).unwrap();
    let header: Vec<&str> = trace.lines().next().unwrap().split(',').collect();
    assert_eq!(listed, header);
    assert_eq!(header, fts::workflow::simulate::TRACE_COLUMNS);
}

#[test]
fn bash_completion_names_every_subcommand() {
    let out = fts().args(["completions", "bash"]).output().unwrap();
    assert!(out.status.success());
    let script = String::from_utf8_lossy(&out.stdout);
    for (path, _) in commands() {
        let name = path.rsplit(' ').next().unwrap();
        assert!(script.contains(name), "bash completion lacks {path}");
    }
}

#[test]
fn man_pages_render_one_per_subcommand() {
    let out = fts().arg("man").output().unwrap();
    assert!(out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stdout)
            .to_uppercase()
            .contains(".TH FTS ")
    );
    let dir = tempfile::tempdir().unwrap();
    let out = fts()
        .args(["man", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (path, _) in commands() {
        let name = format!("fts-{}", path.replace(' ', "-"));
        let page = std::fs::read_to_string(dir.path().join(format!("{name}.1")))
            .unwrap_or_else(|e| panic!("{name}.1: {e}"));
        let title = format!(".TH {} ", name.to_uppercase());
        assert!(page.to_uppercase().contains(&title), "{name}.1: no {title}");
    }
}

/// A result file is reported on stderr as `fts: wrote FILE`, never on stdout.
#[test]
fn wrote_lines_go_to_stderr() {
    let dir = workdir();
    let out = fts()
        .current_dir(dir.path())
        .args([
            "zpetc",
            "--tf",
            "fixtures/li21-closed-loop.json",
            "-o",
            "z.json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!stdout.contains("wrote"), "{stdout}");
    assert_eq!(String::from_utf8_lossy(&out.stderr), "fts: wrote z.json\n");
}

/// Each replaced spelling still works for one release, with one
/// deprecation line on stderr.
#[test]
fn old_spellings_work_with_a_warning() {
    let cases: &[(&[&str], &str, &str)] = &[
        (
            &[
                "response",
                "step",
                "fixtures/second-order-plant.json",
                "--csv",
                "r.csv",
            ],
            "--csv is deprecated; use -o/--out",
            "r.csv",
        ),
        (
            &[
                "tf",
                "info",
                "fixtures/li21-closed-loop.json",
                "--bode",
                "b.csv",
            ],
            "--bode is deprecated; use -o/--out",
            "b.csv",
        ),
        (
            &[
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
                "--plot",
                "b.svg",
                "--plot-fmax",
                "2",
            ],
            "--plot-fmax is deprecated; use --fmax",
            "b.svg",
        ),
        (
            &[
                "simulate",
                "--plant-tf",
                "fixtures/second-order-plant-zoh.json",
                "--controller",
                "pid",
                "--kp",
                "0.5",
                "--ki",
                "0.05",
                "--reference-file",
                "fixtures/step-input-disturbance.csv",
                "-o",
                "t.csv",
            ],
            "--controller pid is deprecated; use --stages pid",
            "t.csv",
        ),
    ];
    for (args, warning, file) in cases {
        let dir = workdir();
        let out = fts().current_dir(dir.path()).args(*args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {stderr}");
        let warnings: Vec<&str> = stderr
            .lines()
            .filter(|l| l.contains("deprecated"))
            .collect();
        assert_eq!(warnings, [format!("fts: warning: {warning}")], "{args:?}");
        assert!(dir.path().join(file).is_file(), "{args:?}: no {file}");
    }
    for old in [
        "fts identify hysteresis rec.csv --max-iters 5",
        "fts simulate --controller-file c.json",
    ] {
        let words: Vec<&str> = old.split_whitespace().collect();
        fts::cli::command().try_get_matches_from(words).unwrap();
    }
}

/// `--controller FILE` in simulate is the coefficient file, not stage names.
#[test]
fn simulate_controller_is_the_coefficient_file() {
    let m = fts::cli::command()
        .try_get_matches_from(["fts", "simulate", "--controller", "c.json"])
        .unwrap();
    let (_, sim) = m.subcommand().unwrap();
    assert_eq!(
        sim.get_one::<std::path::PathBuf>("controller_file")
            .unwrap(),
        std::path::Path::new("c.json")
    );
    assert!(sim.get_one::<String>("controller").is_none());
}
