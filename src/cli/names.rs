//! The one place that names options (docs/formats.md "Exit codes"): a
//! step's setting `field` is the clap id of the argument that sets it (the
//! Args struct's field of the same name, or an explicit `id = "field"` where
//! the flag is spelled otherwise, e.g. `--learning-gain` for `gain`), and an
//! error names that argument as the user typed it (`--shape` when the alias
//! was typed, `--kind` otherwise). A setting this command has no argument
//! for is named as the setting (`'field'`), never as a flag the command does
//! not have.

use crate::workflow::StepError;
use clap::{ArgMatches, Command};
use std::ffi::OsString;
use std::sync::OnceLock;

/// The running command's clap definition and the words of its command line.
#[derive(Debug, Clone)]
pub struct Names {
    /// The leaf (sub)command that runs: `fts mechanism hinge`'s `hinge`.
    command: Command,
    /// The command line after joining negative values (`--ts=-1`).
    words: Vec<String>,
}

static CURRENT: OnceLock<Names> = OnceLock::new();

/// Remembers the command that runs, for [`current`]; called once by `main`.
pub fn remember(root: &Command, matches: &ArgMatches, args: &[OsString]) {
    let _ = CURRENT.set(Names::new(root, matches, args));
}

/// The running command's names, once `main` has parsed the command line.
pub fn current() -> Option<&'static Names> {
    CURRENT.get()
}

/// The running command's names, or (before `main` has parsed a command
/// line) a command with no options, which names every setting `'field'`.
fn names() -> &'static Names {
    static NONE: OnceLock<Names> = OnceLock::new();
    current().unwrap_or_else(|| {
        NONE.get_or_init(|| Names {
            command: Command::new("fts"),
            words: Vec::new(),
        })
    })
}

/// A step's error message as this run's command names things (see
/// [`Names::message`]).
pub fn message(e: &StepError) -> String {
    names().message(e)
}

/// The option that sets `field` in this run's command, as typed (see
/// [`Names::setting`]): for messages the command line writes itself.
pub fn option(field: &str) -> String {
    names().setting(field)
}

fn quoted(field: &str) -> String {
    format!("'{field}'")
}

impl Names {
    /// The leaf subcommand of `matches` in `root`, with the command line.
    pub fn new(root: &Command, matches: &ArgMatches, args: &[OsString]) -> Self {
        let mut command = root;
        let mut m = matches;
        while let Some((name, sub)) = m.subcommand() {
            match command.find_subcommand(name) {
                Some(c) => command = c,
                None => break,
            }
            m = sub;
        }
        Names {
            command: command.clone(),
            words: args
                .iter()
                .map(|a| a.to_string_lossy().into_owned())
                .collect(),
        }
    }

    /// The command's clap definition.
    #[cfg(feature = "checks")]
    pub fn command(&self) -> &Command {
        &self.command
    }

    /// The argument that sets `field`: the one whose id is the field.
    fn arg(&self, field: &str) -> Option<&clap::Arg> {
        self.command
            .get_arguments()
            .find(|a| a.get_id().as_str() == field)
    }

    /// `field` as this command names it: its flag as typed (an alias when
    /// the user typed the alias, the long name otherwise), `<VALUE>` for a
    /// positional argument, or `'field'` when the command has no argument
    /// for it.
    pub fn setting(&self, field: &str) -> String {
        let Some(arg) = self.arg(field) else {
            return quoted(field);
        };
        if let Some(typed) = self.typed(arg) {
            return typed;
        }
        match (arg.get_long(), arg.get_short()) {
            (Some(long), _) => format!("--{long}"),
            (None, Some(short)) => format!("-{short}"),
            (None, None) => {
                let name = arg
                    .get_value_names()
                    .and_then(|v| v.first())
                    .map_or_else(|| field.to_uppercase(), |n| n.to_string());
                format!("<{name}>")
            }
        }
    }

    /// The spelling of `arg` on the command line (the last one typed).
    fn typed(&self, arg: &clap::Arg) -> Option<String> {
        let longs: Vec<&str> = arg
            .get_long()
            .into_iter()
            .chain(arg.get_all_aliases().unwrap_or_default())
            .collect();
        let shorts: Vec<char> = arg
            .get_short()
            .into_iter()
            .chain(arg.get_all_short_aliases().unwrap_or_default())
            .collect();
        let mut found = None;
        for word in self.words.iter().skip(1) {
            if word == "--" {
                break;
            }
            if let Some(rest) = word.strip_prefix("--") {
                let name = rest.split_once('=').map_or(rest, |(n, _)| n);
                if longs.contains(&name) {
                    found = Some(format!("--{name}"));
                }
            } else if let Some(c) = word.strip_prefix('-').and_then(|r| r.chars().next())
                && shorts.contains(&c)
            {
                found = Some(format!("-{c}"));
            }
        }
        found
    }

    /// A step's error as one message: its settings (`` `key` ``) named as
    /// this command names them, led by the option of the setting at fault
    /// unless the message names it already.
    pub fn message(&self, e: &StepError) -> String {
        match e {
            StepError::Input {
                field: Some(field),
                message,
            } => {
                let message = self.render(message);
                let option = self.setting(field);
                if message.contains(&option) {
                    message
                } else {
                    format!("{option}: {message}")
                }
            }
            StepError::Input {
                field: None,
                message,
            }
            | StepError::Computation(message) => self.render(message),
        }
    }

    /// `message` with its settings (`` `key` ``) named as this command names them.
    pub fn render(&self, message: &str) -> String {
        crate::workflow::render_settings(message, |k| self.setting(k))
    }

    /// Every `--name` in `message` that is not an option of this command
    /// (nor `--help`/`--version`): a message must never name a flag the
    /// user cannot type here.
    #[cfg(feature = "checks")]
    pub fn foreign_flags(&self, message: &str) -> Vec<String> {
        flags_in(message)
            .into_iter()
            .filter(|f| {
                let name = &f[2..];
                !self.command.get_arguments().any(|a| {
                    a.get_long() == Some(name)
                        || a.get_all_aliases().unwrap_or_default().contains(&name)
                }) && name != "help"
                    && name != "version"
            })
            .collect()
    }
}

/// The `--name` words of a message (a name is letters, digits and dashes).
#[cfg(feature = "checks")]
pub fn flags_in(message: &str) -> Vec<String> {
    let mut out = Vec::new();
    let bytes = message.as_bytes();
    let mut i = 0;
    while let Some(at) = message[i..].find("--") {
        let start = i + at;
        let before_ok =
            start == 0 || !(bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'-');
        let mut end = start + 2;
        while end < bytes.len() && (bytes[end].is_ascii_alphanumeric() || bytes[end] == b'-') {
            end += 1;
        }
        let name = message[start + 2..end].trim_end_matches('-');
        if before_ok && name.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push(format!("--{name}"));
        }
        i = end.max(start + 2);
    }
    out
}

/// Checks of this module's private parts (run by `tests/suite/checks.rs`).
#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::workflow as w;
    use clap::CommandFactory;
    use serde::Serialize;

    /// The leaf command at `path` (`["mechanism", "hinge"]`).
    fn leaf(path: &[&str]) -> Command {
        let mut root = super::super::Cli::command();
        root.build();
        let mut cmd = &root;
        for p in path {
            cmd = cmd
                .find_subcommand(p)
                .unwrap_or_else(|| panic!("no subcommand {p}"));
        }
        cmd.clone()
    }

    fn names(path: &[&str], line: &[&str]) -> Names {
        let mut root = super::super::Cli::command();
        let args: Vec<OsString> = ["fts"]
            .iter()
            .chain(path)
            .chain(line)
            .map(OsString::from)
            .collect();
        let m = root.try_get_matches_from_mut(&args).expect("a valid line");
        Names::new(&root, &m, &args)
    }

    /// A step's settings: its serialised keys, those of `trajectory` inside.
    fn settings<T: Serialize>(step: &T) -> Vec<String> {
        let mut out = Vec::new();
        let value = serde_json::to_value(step).expect("a step serialises");
        let mut stack = vec![value];
        while let Some(serde_json::Value::Object(map)) = stack.pop() {
            for (k, v) in map {
                if k == "trajectory" {
                    stack.push(v);
                } else {
                    out.push(k);
                }
            }
        }
        out
    }

    /// Settings a command sets by other means than an option of that name:
    /// (command, setting, why).
    const NOT_OPTIONS: &[(&str, &str, &str)] = &[
        (
            "mechanism lever",
            "hinge",
            "the --hinge-* options, checked alone",
        ),
        (
            "mechanism bridge",
            "hinge",
            "the --hinge-* options, checked alone",
        ),
        (
            "mechanism amplifier",
            "hinge",
            "the --hinge-* options, checked alone",
        ),
        (
            "mechanism amplifier",
            "pivot",
            "the manifest's own table; the command uses the bridge's hinge",
        ),
        ("contour", "dob", "the --dob-* options"),
        ("simulate", "dob", "the --dob-* options"),
        ("ilc", "dob", "the --dob-* options"),
        ("ding22", "pid", "--no-pid"),
        ("trajectory", "shape", "the positional <SHAPE>"),
        ("contour", "shape", "the positional <SHAPE>"),
        ("contour", "baseline", "--no-baseline"),
        ("contour", "trace_points", "fixed on the command line"),
    ];

    /// Every command with the steps it runs.
    fn commands() -> Vec<(Vec<&'static str>, Vec<String>)> {
        let s = |path: &[&'static str], keys: Vec<String>| (path.to_vec(), keys);
        vec![
            s(
                &["repetitive"],
                settings(&w::learning::DesignRepetitive::default()),
            ),
            s(
                &["ilc"],
                [
                    settings(&w::learning::Ilc::default()),
                    settings(&w::Simulate::default()),
                ]
                .concat(),
            ),
            s(&["simulate"], settings(&w::Simulate::default())),
            s(&["response"], settings(&w::response::Response::default())),
            s(&["convert"], settings(&w::convert::Convert::default())),
            s(&["minreal"], settings(&w::convert::Minreal::default())),
            s(&["balred"], settings(&w::convert::Balred::default())),
            s(&["trajectory"], settings(&w::MakeTrajectory::default())),
            s(&["contour"], settings(&w::Contour::default())),
            s(
                &["virtual", "triangles"],
                settings(&w::VirtualTriangles::default()),
            ),
            s(&["virtual", "sweep"], settings(&w::VirtualSweep::default())),
            s(
                &["mechanism", "flexure-loss"],
                settings(&w::mechanism::FlexureLoss::default()),
            ),
            s(
                &["mechanism", "hinge"],
                settings(&w::mechanism::Hinge::default()),
            ),
            s(
                &["mechanism", "3puu"],
                settings(&w::mechanism::Puu3Study::default()),
            ),
            s(
                &["mechanism", "lever"],
                settings(&w::mechanism::Lever::default()),
            ),
            s(
                &["mechanism", "bridge"],
                settings(&w::mechanism::Bridge::default()),
            ),
            s(
                &["mechanism", "amplifier"],
                settings(&w::mechanism::Amplifier::default()),
            ),
            s(
                &["identify", "ct"],
                settings(&w::identify_ct::IdentifyCt::default()),
            ),
            s(
                &["identify", "ct-frd"],
                settings(&w::identify_ct::IdentifyCtFrd::default()),
            ),
            s(&["ding22"], settings(&w::Ding22Study::default())),
            s(&["emit"], settings(&w::BuildController::default())),
            s(&["hinf"], settings(&w::Hinf::default())),
            s(&["h2"], settings(&w::H2::default())),
            s(&["weight"], settings(&w::Weight::default())),
            s(&["mixsyn"], settings(&w::Mixsyn::default())),
            s(&["c2d"], settings(&w::C2d::default())),
            s(&["zpetc"], settings(&w::DesignZpetc::default())),
        ]
    }

    /// Every setting of every command's steps is an argument's id there
    /// (so an error about it names that option), or is listed as set by
    /// other means.
    pub fn every_setting_is_the_id_of_an_option_of_its_command() {
        let mut missing = Vec::new();
        for (path, keys) in commands() {
            let cmd = leaf(&path);
            let name = path.join(" ");
            for key in keys {
                let known = cmd.get_arguments().any(|a| a.get_id().as_str() == key)
                    || NOT_OPTIONS.iter().any(|(c, k, _)| *c == name && *k == key);
                if !known {
                    missing.push(format!("fts {name}: {key}"));
                }
            }
        }
        assert!(
            missing.is_empty(),
            "settings without an option:\n{}",
            missing.join("\n")
        );
    }

    /// A command with no arguments matched: the words typed after it.
    fn typed(path: &[&str], words: &[&str]) -> Names {
        Names {
            command: leaf(path),
            words: ["fts"]
                .iter()
                .chain(path)
                .chain(words)
                .map(|w| w.to_string())
                .collect(),
        }
    }

    /// No message about any setting of a command names a flag the command
    /// does not have: each setting renders as its option, or as `'field'`.
    pub fn messages_name_only_flags_of_their_command() {
        for (path, keys) in commands() {
            let names = typed(&path, &[]);
            for key in &keys {
                for e in [
                    StepError::setting(leak(key), format!("bad; see `{key}` and `ts`")),
                    StepError::input(format!("give `{key}` or `max_iterations`")),
                    StepError::computation(format!("`{key}` failed")),
                ] {
                    let m = names.message(&e);
                    let foreign = names.foreign_flags(&m);
                    assert!(
                        foreign.is_empty(),
                        "fts {}: {m:?} names {foreign:?}",
                        path.join(" ")
                    );
                }
            }
        }
    }

    fn leak(s: &str) -> &'static str {
        Box::leak(s.to_owned().into_boxed_str())
    }

    pub fn a_setting_is_named_as_typed() {
        let e = StepError::setting("gain", "expected a positive number, got -1");
        assert_eq!(
            typed(&["ilc"], &["--learning-gain=-1"]).message(&e),
            "--learning-gain: expected a positive number, got -1"
        );
        let shape = StepError::setting("shape", "bad");
        assert_eq!(
            typed(&["weight"], &["--shape", "ws"]).message(&shape),
            "--shape: bad"
        );
        assert_eq!(
            typed(&["weight"], &["--kind", "ws"]).message(&shape),
            "--kind: bad"
        );
        assert_eq!(typed(&["weight"], &[]).message(&shape), "--kind: bad");
        let cc = StepError::setting("cross_coupling", "bad");
        assert_eq!(typed(&["contour"], &["circle"]).message(&cc), "--cc: bad");
        let w = StepError::setting("width_mm", "bad");
        assert_eq!(
            typed(&["mechanism", "lever"], &[]).message(&w),
            "--hinge-width-mm: bad"
        );
        assert_eq!(
            typed(&["mechanism", "hinge"], &[]).message(&w),
            "--width-mm: bad"
        );
        let out = StepError::setting("output", "bad");
        assert_eq!(typed(&["zpk"], &["-o", "x"]).message(&out), "'output': bad");
        assert_eq!(typed(&["convert"], &["-o", "x"]).message(&out), "-o: bad");
        // No flag for it here: named as the setting, not as a made-up flag.
        let k = StepError::setting("trace_points", "see `ts` and `trace_points`");
        assert_eq!(
            typed(&["contour"], &["circle"]).message(&k),
            "see --ts and 'trace_points'"
        );
        let shape = StepError::setting("shape", "bad");
        assert_eq!(typed(&["trajectory"], &[]).message(&shape), "<SHAPE>: bad");
    }

    pub fn flags_are_found_in_messages() {
        assert_eq!(
            flags_in("--a-b: x --c=1, (--d) a--e --- --F -- x"),
            vec!["--a-b", "--c", "--d"]
        );
    }

    pub fn the_leaf_command_is_remembered() {
        let n = names(&["mechanism", "hinge"], &["--width-mm", "2"]);
        assert_eq!(n.command().get_name(), "hinge");
    }
}
