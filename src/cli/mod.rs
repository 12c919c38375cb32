//! The `fts` command line. Raw flags are resolved into validated settings
//! before any work; every error prints on one line on stderr and maps to a
//! stable exit code:
//!
//! | code | meaning |
//! |---|---|
//! | 0 | success |
//! | 1 | any other failure (I/O while writing, numerical breakdown) |
//! | 2 | bad usage or bad input (the message names the file, line or field) |

/// `println!` for summaries: a stdout that cannot be written (`> /dev/full`)
/// returns an error (exit 1) instead of panicking; a closed pipe
/// (`fts ... | head`) ends the process quietly through the default SIGPIPE.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!($crate::cli::common::Out, $($t)*).map_err($crate::cli::common::stdout_error)?
    }};
}

/// A line on stderr (a note, a warning, the error): a stderr that cannot be
/// written (`2> /dev/full`) loses it instead of panicking, and the exit
/// code stays the command's own.
macro_rules! note {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// `print!` counterpart of `say!`.
macro_rules! say_part {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        write!($crate::cli::common::Out, $($t)*).map_err($crate::cli::common::stdout_error)?
    }};
}

mod bode;
mod build;
mod columns;
mod common;
mod contour;
mod convert;
mod demo;
mod ding22;
mod emit;
mod examples;
mod excite;
mod hysteresis;
mod identify;
mod identify_ct;
mod identify_hysteresis;
mod identify_linear;
mod learning;
pub(crate) mod loop_analysis;
pub(crate) mod manual;
mod mechanism;
pub(crate) mod names;
mod response;
mod robust;
mod simulate;
mod tf;
mod virtual_record;
mod zpetc;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

pub use common::BadInput;

/// Identification and control of piezo-driven fast tool servos.
#[derive(Debug, Parser)]
#[command(name = "fts", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Rebuild the outputs of a pipeline manifest (fts.toml) whose inputs changed; --check only reports.
    Build(build::BuildArgs),
    /// Run the whole Li21 pipeline on the embedded virtual FTS: identify, compensate, ZPETC, verify, emit.
    Demo(demo::DemoArgs),
    /// Generate an excitation signal (triangle, sine, sweep, multisine, five-leaf) as a t,u CSV.
    Excite(excite::ExciteArgs),
    /// Jerk-limited S-curve paths (Karagoz18 inclined circle, square) as a t,x,y,z CSV.
    Trajectory(contour::TrajectoryArgs),
    /// Three-axis contouring with cross-coupled control (Karagoz18): per-axis and contour errors.
    Contour(contour::ContourArgs),
    /// Record open-loop triangles or a closed-loop sweep on the embedded virtual FTS as a t,u,y CSV.
    #[command(subcommand)]
    Virtual(virtual_record::VirtualCommand),
    /// Identify a model from measured data.
    #[command(subcommand)]
    Identify(identify::IdentifyCommand),
    /// Use hysteresis models: analytic inverse, run on a signal.
    #[command(subcommand)]
    Hysteresis(hysteresis::HysteresisCommand),
    /// Write the controller coefficient file (fts.controller/1 JSON or C header) for a real-time loop.
    Emit(emit::EmitArgs),
    /// Simulate a closed loop (pid, pid+hc, pid+hc+zpec) on the virtual FTS or a plant model.
    Simulate(simulate::SimulateArgs),
    /// Build a zero phase error tracking (ZPETC) feedforward filter for a closed loop.
    Zpetc(zpetc::ZpetcArgs),
    /// Design a plug-in repetitive compensator on a closed-loop model, with its stability condition.
    Repetitive(learning::RepetitiveArgs),
    /// Iterative learning control: repeat a trajectory, learn its feedforward, write it as a table.
    Ilc(learning::IlcArgs),
    /// Empirical frequency response (Welch with coherence, or ETFE) of input/output data.
    Bode(bode::BodeArgs),
    /// Inspect transfer-function files.
    #[command(subcommand)]
    Tf(tf::TfCommand),
    /// H-infinity synthesis on a generalised plant (gamma bisection, central controller).
    Hinf(robust::HinfArgs),
    /// H2-optimal synthesis on a generalised plant.
    H2(robust::SynthArgs),
    /// Build a weighting function (W_s, W_t, makeweight) as fts.ss/1.
    Weight(robust::WeightArgs),
    /// Mixed-sensitivity H-infinity design (augw convention).
    Mixsyn(robust::MixsynArgs),
    /// Discretise a continuous system (ZOH or Tustin).
    C2d(robust::C2dArgs),
    /// Poles, zeros, stability, H2 and H-infinity norms of a system.
    SsInfo(robust::SsInfoArgs),
    /// Error budget: per-source PSD, cumulative amplitude spectrum, RMS.
    Budget(robust::BudgetArgs),
    /// Margins (gain, phase, delay, modulus), |S| |T| |KS| |GS| peaks, bandwidth and closed-loop poles of L = G K.
    Loop(loop_analysis::LoopArgs),
    /// Step or impulse response of a system or closed loop, with rise/settling time, overshoot and steady-state error.
    Response(response::ResponseArgs),
    /// Convert a model: state space to transfer functions (one per channel) or back.
    Convert(convert::ConvertArgs),
    /// Zeros, poles and gain (MATLAB zpk) of every channel of a model.
    Zpk(convert::ZpkArgs),
    /// Minimal realisation: remove uncontrollable and unobservable states (pole-zero cancellations).
    Minreal(convert::MinrealArgs),
    /// Balanced truncation of a stable model, with its Hankel singular values and error bound.
    Balred(convert::BalredArgs),
    /// The continuous model whose zero-order-hold discretisation is the given discrete one.
    D2c(convert::D2cArgs),
    /// Mechanism design formulas: flexure displacement loss, hinge stiffness (Li21), 3-PUU kinematics and workspace (Tang17).
    #[command(subcommand)]
    Mechanism(mechanism::MechanismCommand),
    /// Ding22 workflow: two-mass FTS, H2 design vs PID, error budget, structural sweep.
    Ding22(ding22::Ding22Args),
    /// Print the shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(manual::CompletionsArgs),
    /// Write the manual pages (fts.1, fts-identify-arx.1, ...) into --out DIR, or fts.1 to stdout.
    Man(manual::ManArgs),
}

/// Runs the command line and returns the process exit code.
pub fn main() -> ExitCode {
    let code = run_command_line();
    // Every temporary file of this run is renamed or removed by now.
    crate::pipeline::close_journal();
    code
}

fn run_command_line() -> ExitCode {
    // Temporary files of runs killed mid-write: wherever their journals
    // say they staged, in the working folder, and in each output's folder
    // when it is written.
    crate::pipeline::sweep_stranded();
    common::sweep(std::path::Path::new("."));
    if let Err(message) = reject_ambiguous_options(std::env::args_os().skip(1)) {
        note!("fts: error: {message}");
        return ExitCode::from(2);
    }
    let args = stages_from_old_controller(join_negative_values(std::env::args_os().collect()));
    if let Err(message) = reject_duplicate_outputs(&args) {
        note!("fts: error: {message}");
        return ExitCode::from(2);
    }
    let mut command = command();
    let parsed = command.try_get_matches_from_mut(&args).and_then(|m| {
        names::remember(&command, &m, &args);
        warn_deprecated(&m, &args);
        Cli::from_arg_matches(&m)
    });
    let cli = match parsed {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // Help and version go to stdout as clap renders them.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            note!("fts: {}", usage_error_line(&e.to_string()));
            return ExitCode::from(2);
        }
    };
    match run(cli).and_then(|()| finish()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            common::discard_outputs();
            common::discard_stdout();
            note!("fts: error: {}", common::one_line(&e));
            ExitCode::from(common::exit_code(&e))
        }
    }
}

/// A successful run's results: every staged file renamed into place, then
/// the summary printed; if stdout cannot take it, the files are put back,
/// so a non-zero exit never leaves a result behind.
fn finish() -> anyhow::Result<()> {
    let committed = common::commit_outputs()?;
    match common::flush_stdout() {
        Ok(()) => {
            committed.finish();
            common::report_written();
            Ok(())
        }
        Err(e) => {
            committed.undo();
            Err(e)
        }
    }
}

/// `--ts -1` must reach the option's own validation (which names it), not
/// read as an unknown flag `-1`.
/// Every help text ends with the unit convention.
const UNITS_NOTE: &str = "Units: frequencies in Hz unless an option says rad/s (e.g. --w0-rad), times in s, displacements in um, commands in V; discrete coefficients in ascending powers of z^-1.";

/// The command line as parsed, documented and completed: [`Cli`] with
/// every (sub)command's examples, units note and negative values.
pub fn command() -> clap::Command {
    decorate(Cli::command(), "")
}

/// Every (sub)command takes negative numbers as values, shows its examples
/// (`path` is its place in the tree: `identify arx`) and states the units.
fn decorate(cmd: clap::Command, path: &str) -> clap::Command {
    let path = match path {
        "" if cmd.get_name() == "fts" => String::new(),
        "" => cmd.get_name().to_owned(),
        _ => format!("{path} {}", cmd.get_name()),
    };
    let help = match examples::section(&path) {
        Some(examples) => format!("{examples}\n\n{UNITS_NOTE}"),
        None => UNITS_NOTE.to_owned(),
    };
    cmd.allow_negative_numbers(true)
        .after_help(help)
        .mut_subcommands(|sub| decorate(sub, &path))
}

/// `--ts -1e-4` as `--ts=-1e-4`: clap takes only plain negative decimals
/// (`-1`, `-0.5`) for values, and would read `-1e-4` or `-inf` as short
/// flags, so the option's own check (which names it) would never see them.
fn join_negative_values(args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut out: Vec<std::ffi::OsString> = Vec::with_capacity(args.len());
    for arg in args {
        let joined = match (out.last().and_then(|p| p.to_str()), arg.to_str()) {
            (Some(prev), Some(value))
                if prev.starts_with("--")
                    && prev.len() > 2
                    && !prev.contains('=')
                    && value.starts_with('-')
                    && value.parse::<f64>().is_ok() =>
            {
                Some(format!("{prev}={value}"))
            }
            _ => None,
        };
        match joined {
            Some(j) => *out.last_mut().expect("a previous argument") = j.into(),
            None => out.push(arg),
        }
    }
    out
}

/// Options that name a result file.
const OUTPUT_OPTIONS: [&str; 8] = [
    "-o",
    "--out",
    "--plot",
    "--plot-compare",
    "--c-header",
    "--csv",
    "--bode",
    "--augmented",
];

/// Two result options naming one file, or a result option naming a file
/// another argument names (an input), are refused before any work, so
/// nothing is computed, printed or written for a run that cannot finish.
fn reject_duplicate_outputs(args: &[std::ffi::OsString]) -> Result<(), String> {
    let mut seen: Vec<(&str, std::path::PathBuf, String)> = Vec::new();
    let mut others: Vec<std::path::PathBuf> = Vec::new();
    let mut iter = args.iter().skip(1).filter_map(|a| a.to_str()).peekable();
    while let Some(arg) = iter.next() {
        if arg == "--" {
            break;
        }
        let (name, value) = match arg.split_once('=') {
            Some((n, v)) if n.starts_with("--") => (n, Some(v.to_owned())),
            _ => (arg, None),
        };
        let Some(option) = OUTPUT_OPTIONS.iter().find(|o| **o == name) else {
            let path = std::path::Path::new(value.as_deref().unwrap_or(arg));
            if path.is_file() {
                others.push(common::output_identity(path));
            }
            continue;
        };
        let Some(value) = value.or_else(|| iter.next().map(str::to_owned)) else {
            continue;
        };
        let id = common::output_identity(std::path::Path::new(&value));
        if let Some((first, _, _)) = seen.iter().find(|(_, p, _)| *p == id) {
            return Err(format!(
                "{value}: two results of this run would be written to the same file ({first} and {option}); name another file"
            ));
        }
        seen.push((option, id, value));
    }
    match seen.iter().find(|(_, id, _)| others.contains(id)) {
        Some((option, _, value)) => Err(format!(
            "{value}: refusing to write a result onto an input of this run ({option}); nothing was computed; name another file"
        )),
        None => Ok(()),
    }
}

/// Spellings replaced by the one vocabulary of every command (hidden
/// aliases for one release): the command, the old option, the new one.
const DEPRECATED: &[(&str, &str, &str)] = &[
    ("identify hysteresis", "--max-iters", "--max-iterations"),
    ("identify oe", "--max-iter", "--max-iterations"),
    ("identify arx", "--plot-fmax", "--fmax"),
    ("identify oe", "--plot-fmax", "--fmax"),
    ("identify iv", "--plot-fmax", "--fmax"),
    ("identify arx-struct", "--plot-fmax", "--fmax"),
    ("budget", "--csv", "-o/--out"),
    ("response", "--csv", "-o/--out"),
    ("tf info", "--bode", "-o/--out"),
    ("excite multisine", "--f-min", "--fmin"),
    ("excite multisine", "--f-max", "--fmax"),
    ("simulate", "--controller-file", "--controller"),
    ("ilc", "--controller-file", "--controller"),
];

/// `simulate`/`ilc --controller pid+hc` (stage names, the old spelling of
/// `--stages`) as `--stages pid+hc`, with a deprecation warning;
/// `--controller FILE` (a path, or any existing file) is the coefficient
/// file and stays as it is.
fn stages_from_old_controller(mut args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let command = args
        .iter()
        .skip(1)
        .filter_map(|a| a.to_str())
        .find(|a| !a.starts_with('-'));
    if !matches!(command, Some("simulate" | "ilc")) {
        return args;
    }
    let is_stages = |v: &str| {
        !v.is_empty()
            && v.chars().all(|c| c.is_ascii_lowercase() || c == '+')
            && !std::path::Path::new(v).exists()
    };
    for i in 1..args.len() {
        let Some(arg) = args[i].to_str().map(str::to_owned) else {
            continue;
        };
        if arg == "--" {
            break;
        }
        let value = match arg.strip_prefix("--controller=") {
            Some(v) => Some(v.to_owned()),
            None if arg == "--controller" => {
                args.get(i + 1).and_then(|v| v.to_str()).map(str::to_owned)
            }
            None => None,
        };
        if let Some(value) = value.filter(|v| is_stages(v)) {
            note!("fts: warning: --controller {value} is deprecated; use --stages {value}");
            args[i] = match arg.contains('=') {
                true => format!("--stages={value}").into(),
                false => "--stages".into(),
            };
        }
    }
    args
}

/// One `fts: warning: --old is deprecated; use --new` line on stderr for
/// each old spelling on the command line.
fn warn_deprecated(matches: &clap::ArgMatches, args: &[std::ffi::OsString]) {
    let mut path = Vec::new();
    let mut m = matches;
    while let Some((name, sub)) = m.subcommand() {
        path.push(name);
        m = sub;
    }
    let path = path.join(" ");
    let words = args.iter().skip(1).filter_map(|a| a.to_str());
    for word in words.take_while(|w| *w != "--") {
        let name = word.split_once('=').map_or(word, |(name, _)| name);
        if let Some((_, old, new)) = DEPRECATED
            .iter()
            .find(|(c, old, _)| *c == path && *old == name)
        {
            note!("fts: warning: {old} is deprecated; use {new}");
        }
    }
}

/// A clap usage error on one line: its message and tips, without the usage
/// block and the pointer to `--help`.
fn usage_error_line(rendered: &str) -> String {
    rendered
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// `--input` and `--output` once named columns in some commands and files in
/// others. Both are refused with the option that is meant, so an old command
/// line never writes a result file called `y` or reads a column called
/// `model.json`.
fn reject_ambiguous_options(args: impl Iterator<Item = std::ffi::OsString>) -> Result<(), String> {
    for arg in args {
        let Some(arg) = arg.to_str() else { continue };
        if arg == "--" {
            break;
        }
        let name = arg.split_once('=').map_or(arg, |(name, _)| name);
        let hint = match name {
            "--output" => {
                "name the result file with -o/--out FILE, or the output column with --output-col COL (budget: --output-index N)"
            }
            "--input" => "name the input column with --input-col COL",
            "--time" => "name the time column with --time-col COL",
            _ => continue,
        };
        return Err(format!("{name} is ambiguous and not an option: {hint}"));
    }
    Ok(())
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Build(args) => build::run(args),
        Command::Demo(args) => demo::run(args),
        Command::Excite(args) => excite::run(args),
        Command::Virtual(cmd) => virtual_record::run(cmd),
        Command::Trajectory(args) => contour::run_trajectory(args),
        Command::Contour(args) => contour::run_contour(args),
        Command::Identify(cmd) => identify::run(cmd),
        Command::Hysteresis(cmd) => hysteresis::run(cmd),
        Command::Emit(args) => emit::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Zpetc(args) => zpetc::run(args),
        Command::Repetitive(args) => learning::run_repetitive(args),
        Command::Ilc(args) => learning::run_ilc(args),
        Command::Tf(cmd) => tf::run(cmd),
        Command::Bode(args) => bode::run(args),
        Command::Hinf(args) => robust::run_hinf(args),
        Command::H2(args) => robust::run_h2(args),
        Command::Weight(args) => robust::run_weight(args),
        Command::Mixsyn(args) => robust::run_mixsyn(args),
        Command::C2d(args) => robust::run_c2d(args),
        Command::SsInfo(args) => robust::run_ss_info(args),
        Command::Budget(args) => robust::run_budget(args),
        Command::Loop(args) => loop_analysis::run(args),
        Command::Response(args) => response::run(args),
        Command::Convert(args) => convert::run_convert(args),
        Command::Zpk(args) => convert::run_zpk(args),
        Command::Minreal(args) => convert::run_minreal(args),
        Command::Balred(args) => convert::run_balred(args),
        Command::D2c(args) => convert::run_d2c(args),
        Command::Ding22(args) => ding22::run(args),
        Command::Mechanism(cmd) => mechanism::run(cmd),
        Command::Completions(args) => manual::run_completions(args, command()),
        Command::Man(args) => manual::run_man(args, command()),
    }
}

/// Checks of this module's private parts (run by `tests/suite/checks.rs`).
#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use std::ffi::OsString;

    fn args(list: &[&str]) -> Vec<OsString> {
        list.iter().map(OsString::from).collect()
    }

    pub fn negative_values_reach_their_option() {
        let joined = join_negative_values(args(&[
            "fts", "excite", "--ts", "-1e-4", "--offset", "-inf", "-o", "-2", "--freq", "-x",
        ]));
        assert_eq!(
            joined,
            args(&[
                "fts",
                "excite",
                "--ts=-1e-4",
                "--offset=-inf",
                "-o",
                "-2",
                "--freq",
                "-x"
            ])
        );
    }

    pub fn one_file_named_by_two_result_options_is_refused() {
        let e = reject_duplicate_outputs(&args(&["fts", "zpetc", "-o", "z.json", "--plot=z.json"]))
            .unwrap_err();
        assert!(e.contains("(-o and --plot)"), "{e}");
        assert!(
            reject_duplicate_outputs(&args(&["fts", "zpetc", "-o", "z.json", "--plot", "z.svg"]))
                .is_ok()
        );
    }
}
