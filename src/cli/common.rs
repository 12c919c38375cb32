//! What every subcommand shares: reading inputs, atomic writes, JSON on
//! stdout, and the mapping from errors to exit codes.

use crate::io::InputError;
use anyhow::Context;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A bad-usage or bad-input error (exit code 2) that is not an [`InputError`].
#[derive(Debug)]
pub struct BadInput(pub String);

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// Shorthand: an exit-2 error with this message.
pub fn bad(message: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(BadInput(message.into()))
}

/// Exit code 2 when any error in the chain is about the input, otherwise 1.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    if e.chain()
        .any(|c| c.is::<BadInput>() || c.is::<InputError>())
    {
        2
    } else {
        1
    }
}

/// The error and its causes on one line.
pub fn one_line(e: &anyhow::Error) -> String {
    e.chain()
        .map(|c| c.to_string().replace('\n', " "))
        .collect::<Vec<_>>()
        .join(": ")
}

/// The files this run has read and written: a result is never written onto
/// an input of the same run, nor onto another of its results.
struct RunFiles {
    inputs: Vec<PathBuf>,
    outputs: Vec<PathBuf>,
}

static RUN_FILES: Mutex<RunFiles> = Mutex::new(RunFiles {
    inputs: Vec::new(),
    outputs: Vec::new(),
});

/// A path's identity: the canonical path of the file, or of its folder
/// joined with its name when it does not exist yet.
fn identity(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (parent.canonicalize(), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// The identity under which an output path is compared with others.
pub fn output_identity(path: &Path) -> PathBuf {
    identity(path)
}

fn note_input(path: &Path) {
    if let Ok(mut files) = RUN_FILES.lock() {
        files.inputs.push(identity(path));
    }
}

/// Refuses an output path that is an input or an earlier output of this run,
/// or an existing thing that is not a regular file (a symlink, a device, a
/// folder); records it otherwise.
fn claim_output(path: &Path) -> anyhow::Result<()> {
    if let Ok(meta) = std::fs::symlink_metadata(path)
        && !meta.file_type().is_file()
    {
        return Err(bad(format!(
            "{}: refusing to write a result onto something that is not a regular file (a link, a device or a folder); name another file",
            path.display()
        )));
    }
    let id = identity(path);
    let mut files = RUN_FILES
        .lock()
        .map_err(|_| anyhow::anyhow!("output registry poisoned"))?;
    if files.inputs.contains(&id) {
        return Err(bad(format!(
            "{}: refusing to write a result onto an input of this run; name another file",
            path.display()
        )));
    }
    if files.outputs.contains(&id) {
        return Err(bad(format!(
            "{}: two results of this run would be written to the same file; name another file",
            path.display()
        )));
    }
    files.outputs.push(id);
    Ok(())
}

/// Reads a whole input file; a missing or unreadable input is bad input.
pub fn read_input(path: &Path) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| bad(format!("{}: cannot read: {e}", path.display())))?;
    note_input(path);
    Ok(text)
}

/// Opens an input file for streaming; a missing or unreadable input (or a
/// folder) is bad input.
pub fn open_input(path: &Path) -> anyhow::Result<std::io::BufReader<std::fs::File>> {
    let cannot = |e: &dyn std::fmt::Display| bad(format!("{}: cannot read: {e}", path.display()));
    let file = std::fs::File::open(path).map_err(|e| cannot(&e))?;
    if file.metadata().map_err(|e| cannot(&e))?.is_dir() {
        return Err(cannot(&"is a folder, not a file"));
    }
    note_input(path);
    Ok(std::io::BufReader::with_capacity(1 << 16, file))
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// flushed and synced, then renamed over the target. On any error the target
/// is untouched and the temporary file is removed. A path that is an input or
/// an earlier result of this run, or not a regular file, is refused (exit 2).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    claim_output(path)?;
    crate::pipeline::write_atomic(path, bytes)
        .with_context(|| format!("{}: cannot write the output atomically", path.display()))
}

/// Writes several results all or none: each path is claimed as by
/// [`write_atomic`], every file is staged before any is renamed into place,
/// so a folder that cannot be written leaves the others unwritten too.
pub fn write_atomic_all(files: &[(&Path, &[u8])]) -> anyhow::Result<()> {
    for (path, _) in files {
        claim_output(path)?;
    }
    crate::pipeline::write_atomic_all(files).map_err(|(k, e)| {
        anyhow::anyhow!(
            "{}: cannot write the output atomically: {e}",
            files[k].0.display()
        )
    })
}

/// The most frequency points a command evaluates (checked before any work,
/// so a mistyped count is an error, not an allocation abort).
pub const MAX_POINTS: usize = 1_000_000;

/// `--points`: a whole number from 2 to [`MAX_POINTS`].
pub fn parse_points(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if (2..=MAX_POINTS).contains(&n) => Ok(n),
        _ => Err(format!("expected a whole number from 2 to {MAX_POINTS}")),
    }
}

/// A positive finite number (a frequency, a gain): clap names the option
/// and the value given when it is not.
pub fn parse_positive(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err("expected a positive finite number".into()),
    }
}

/// The error of a failed write to stdout (exit 1).
pub fn stdout_error(e: std::io::Error) -> anyhow::Error {
    anyhow::anyhow!("cannot write to stdout: {e}")
}

/// Prints exactly one JSON object on stdout (the `--json` contract).
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)
        .map_err(std::io::Error::from)
        .map_err(stdout_error)?;
    writeln!(out).map_err(stdout_error)?;
    Ok(())
}

/// The JSON and text forms of complex numbers, shared with the library's reports.
pub use crate::workflow::{complex_pairs, fmt_complex};

/// A step's error as a command's: a setting is named by its flag
/// (`--prewarp`), bad input exits 2 and a failed computation 1.
pub fn step_error(e: crate::workflow::StepError) -> anyhow::Error {
    use crate::workflow::StepError;
    match e {
        StepError::Input {
            field: Some(field),
            message,
        } => {
            // A message that names its flag already reads as is.
            let message = flags(&message);
            if message.contains(&flag(field)) {
                bad(message)
            } else {
                bad(format!("{}: {message}", flag(field)))
            }
        }
        StepError::Input {
            field: None,
            message,
        } => bad(flags(&message)),
        StepError::Computation(message) => anyhow::anyhow!(flags(&message)),
    }
}

/// The flag of a step's setting: `max_iterations` is `--max-iterations`.
fn flag(field: &str) -> String {
    format!("--{}", field.replace('_', "-"))
}

/// A step's message with the settings it names written as flags.
pub fn flags(message: &str) -> String {
    crate::workflow::render_settings(message, flag)
}

/// Prints a step's report: serialised with `--json`, else its summary.
pub fn print_report<R: serde::Serialize + std::fmt::Display>(
    report: &R,
    json: bool,
) -> anyhow::Result<()> {
    if json {
        print_json(&serde_json::to_value(report)?)
    } else {
        say_part!("{report}");
        Ok(())
    }
}

/// The value parser of a setting with a library vocabulary
/// (`value_parser = choice::<T>()`): a value is read as the manifest reads
/// it (serde), and `--help` and the error for a bad value list the choices
/// with their help (settings it names rendered as flags).
pub fn choice<T>() -> impl clap::builder::TypedValueParser<Value = T>
where
    T: crate::workflow::Choices + serde::de::DeserializeOwned + Clone + Send + Sync,
{
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    use serde::de::value::{Error, StrDeserializer};
    let values = T::CHOICES.iter().map(|&(name, help)| match help {
        "" => PossibleValue::new(name),
        help => PossibleValue::new(name).help(flags(help)),
    });
    PossibleValuesParser::new(values).map(|name: String| {
        T::deserialize(StrDeserializer::<Error>::new(&name)).expect("a listed choice deserialises")
    })
}

/// The name of a library setting's value, for `default_value`.
pub fn name<T: crate::workflow::Choices + serde::Serialize>(value: T) -> &'static str {
    value.name()
}
