//! What every subcommand shares: reading inputs, atomic writes, JSON on
//! stdout, and the mapping from errors to exit codes.

use crate::io::InputError;
use crate::io::plot::PlotFormat;
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
    let line = e
        .chain()
        .map(|c| c.to_string().replace('\n', " "))
        .collect::<Vec<_>>()
        .join(": ");
    printable(&line)
}

/// `text` with every control character (a binary file's bytes quoted in a
/// message, a stray carriage return) written as an escape such as `\u{0}`:
/// a message is one line of text whatever it quotes.
pub fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
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

/// The value parser of every `--plot`-like option: the file's extension
/// must name a format fts draws ([`PlotFormat::from_path`]), checked before
/// any work, so the message names the option and the extensions accepted.
pub fn plot_path(text: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(text);
    PlotFormat::from_path(&path)?;
    Ok(path)
}

/// Renders a plot in the format `path`'s extension names and writes it
/// atomically: the one way every `--plot` file is written.
pub fn write_plot(
    path: &Path,
    draw: impl FnOnce(PlotFormat) -> anyhow::Result<Vec<u8>>,
) -> anyhow::Result<()> {
    let format =
        PlotFormat::from_path(path).map_err(|m| bad(format!("{}: {m}", path.display())))?;
    write_atomic(path, &draw(format)?)
}

/// Results of this run staged in synced temporary files beside their
/// targets, renamed into place together only when the whole command has
/// succeeded ([`commit_outputs`]); dropped (so removed) on any failure.
static STAGED: Mutex<Vec<(tempfile::NamedTempFile, PathBuf)>> = Mutex::new(Vec::new());

/// Folders already swept of stale temporary files in this run.
static SWEPT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporary files a killed run left in `dir` (once per run).
pub fn sweep(dir: &Path) {
    let id = identity(dir);
    if let Ok(mut swept) = SWEPT.lock() {
        if swept.contains(&id) {
            return;
        }
        swept.push(id);
    }
    crate::pipeline::sweep_stale_temps(dir);
}

/// Stages `bytes` for `path`: written to a synced temporary file in the
/// same folder now, renamed over the target by [`commit_outputs`] once the
/// command has succeeded, so a failed run leaves every target as it was and
/// a multi-file result is committed together. A path that is an input or
/// an earlier result of this run, or not a regular file, is refused (exit 2).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    claim_output(path)?;
    sweep(crate::pipeline::folder_of(path));
    let tmp = crate::pipeline::stage(path, bytes)
        .with_context(|| format!("{}: cannot write the output atomically", path.display()))?;
    STAGED
        .lock()
        .map_err(|_| anyhow::anyhow!("output registry poisoned"))?
        .push((tmp, path.to_path_buf()));
    if let Ok(mut written) = WRITTEN.lock() {
        written.push((path.to_path_buf(), None));
    }
    Ok(())
}

/// Removes every staged result (the command failed).
pub fn discard_outputs() {
    if let Ok(mut staged) = STAGED.lock() {
        staged.clear();
    }
    if let Ok(mut written) = WRITTEN.lock() {
        written.clear();
    }
}

/// The result files of this run with a remark each may carry, reported on
/// stderr once the run has succeeded ([`report_written`]): stdout holds
/// only results, and a failed run reports no file.
static WRITTEN: Mutex<Vec<(PathBuf, Option<String>)>> = Mutex::new(Vec::new());

/// Adds a remark to the `fts: wrote` line of a file staged by
/// [`write_atomic`] (`fts: wrote t.csv (4000 samples, ts = 1e-4 s)`).
pub fn remark(path: &Path, text: String) {
    if let Ok(mut written) = WRITTEN.lock()
        && let Some(entry) = written.iter_mut().find(|(p, _)| p == path)
    {
        entry.1 = Some(text);
    }
}

/// Prints `fts: wrote FILE` on stderr for every result file of the run,
/// the one way every command reports its files; three or more files in one
/// folder (a run's folder of results) on one line, `fts: wrote DIR: a, b, c`.
pub fn report_written() {
    let written = WRITTEN.lock().map(|mut w| std::mem::take(&mut *w));
    for line in written_lines(&written.unwrap_or_default()) {
        note!("fts: wrote {line}");
    }
}

/// The `fts: wrote` lines (without the prefix) of `files`, in order.
fn written_lines(files: &[(PathBuf, Option<String>)]) -> Vec<String> {
    let folder = |p: &Path| p.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut lines = Vec::new();
    let mut done = vec![false; files.len()];
    for (i, (path, _)) in files.iter().enumerate() {
        if done[i] {
            continue;
        }
        let dir = folder(path);
        let group: Vec<usize> = (i..files.len())
            .filter(|&j| !done[j] && folder(&files[j].0) == dir)
            .collect();
        let remarks: Vec<&str> = group
            .iter()
            .filter_map(|&j| files[j].1.as_deref())
            .collect();
        let remark = match remarks.is_empty() {
            true => String::new(),
            false => format!(" ({})", remarks.join("; ")),
        };
        if group.len() >= 3 && !dir.as_os_str().is_empty() {
            let names: Vec<String> = group
                .iter()
                .map(|&j| {
                    files[j]
                        .0
                        .file_name()
                        .unwrap_or_default()
                        .to_string_lossy()
                        .into_owned()
                })
                .collect();
            lines.push(format!("{}: {}{remark}", dir.display(), names.join(", ")));
            group.iter().for_each(|&j| done[j] = true);
        } else {
            lines.push(format!(
                "{}{}",
                path.display(),
                files[i]
                    .1
                    .as_deref()
                    .map(|r| format!(" ({r})"))
                    .unwrap_or_default()
            ));
            done[i] = true;
        }
    }
    lines
}

/// The committed results: each target with the temporary copy of what it
/// held before (`None`: it did not exist), until [`Committed::finish`].
pub struct Committed(Vec<(PathBuf, Option<PathBuf>)>);

impl Committed {
    /// Puts every target back as it was (a later step of the run failed).
    pub fn undo(self) {
        for (target, previous) in self.0.into_iter().rev() {
            let _ = match previous {
                Some(p) => std::fs::rename(&p, &target),
                None => std::fs::remove_file(&target),
            };
        }
    }

    /// Keeps the new results and removes the copies of the old ones.
    pub fn finish(self) {
        for (_, previous) in self.0 {
            if let Some(p) = previous {
                let _ = std::fs::remove_file(p);
            }
        }
    }
}

/// Renames every staged result over its target, together: each target is
/// checked again (still a regular file or absent), its previous content is
/// kept under a temporary name, and any failure puts back every target
/// already replaced.
pub fn commit_outputs() -> anyhow::Result<Committed> {
    let staged = std::mem::take(
        &mut *STAGED
            .lock()
            .map_err(|_| anyhow::anyhow!("output registry poisoned"))?,
    );
    let mut done = Committed(Vec::with_capacity(staged.len()));
    for (tmp, target) in staged {
        match replace(tmp, &target) {
            Ok(previous) => done.0.push((target, previous)),
            Err(e) => {
                done.undo();
                return Err(e);
            }
        }
    }
    Ok(done)
}

/// Renames `tmp` over `target`, first keeping what `target` held.
fn replace(tmp: tempfile::NamedTempFile, target: &Path) -> anyhow::Result<Option<PathBuf>> {
    let cannot = |e: &dyn std::fmt::Display| {
        anyhow::anyhow!(
            "{}: cannot write the output atomically: {e}",
            target.display()
        )
    };
    let previous = match std::fs::symlink_metadata(target) {
        Ok(m) if m.is_file() => {
            Some(crate::pipeline::keep_previous(target).map_err(|e| cannot(&e))?)
        }
        Ok(_) => return Err(cannot(&"it is no longer a regular file")),
        Err(_) => None,
    };
    if let Err(e) = tmp.persist(target) {
        if let Some(p) = previous {
            let _ = std::fs::remove_file(p);
        }
        return Err(cannot(&e.error));
    }
    Ok(previous)
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

/// What this run prints on stdout, held until it has succeeded: a failed
/// run prints no result.
static STDOUT: Mutex<Vec<u8>> = Mutex::new(Vec::new());

/// The run's stdout (held in memory; [`flush_stdout`] writes it).
pub struct Out;

impl Write for Out {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        STDOUT
            .lock()
            .map_err(|_| std::io::Error::other("stdout buffer poisoned"))?
            .extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Writes what the run printed to the real stdout.
pub fn flush_stdout() -> anyhow::Result<()> {
    let text = std::mem::take(
        &mut *STDOUT
            .lock()
            .map_err(|_| anyhow::anyhow!("stdout buffer poisoned"))?,
    );
    let mut out = std::io::stdout().lock();
    out.write_all(&text).map_err(stdout_error)?;
    out.flush().map_err(stdout_error)
}

/// Forgets what the run printed (it failed).
pub fn discard_stdout() {
    if let Ok(mut text) = STDOUT.lock() {
        text.clear();
    }
}

/// Prints exactly one JSON object on stdout (the `--json` contract).
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    let mut out = Out;
    serde_json::to_writer_pretty(&mut out, value)
        .map_err(std::io::Error::from)
        .map_err(stdout_error)?;
    writeln!(out).map_err(stdout_error)?;
    Ok(())
}

/// The JSON and text forms of complex numbers, shared with the library's reports.
pub use crate::workflow::{complex_pairs, fmt_complex};

/// A step's error as a command's: a setting is named by the option that
/// sets it, as typed ([`super::names`]); bad input exits 2 and a failed
/// computation 1.
pub fn step_error(e: crate::workflow::StepError) -> anyhow::Error {
    let message = super::names::message(&e);
    match e {
        crate::workflow::StepError::Input { .. } => bad(message),
        crate::workflow::StepError::Computation(_) => anyhow::anyhow!(message),
    }
}

/// A help text with the settings it names written as flags (`max_iterations`
/// is `--max-iterations`): help is built before any command line is parsed.
fn help_flags(message: &str) -> String {
    crate::workflow::render_settings(message, |field| format!("--{}", field.replace('_', "-")))
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
        help => PossibleValue::new(name).help(help_flags(help)),
    });
    PossibleValuesParser::new(values).map(|name: String| {
        T::deserialize(StrDeserializer::<Error>::new(&name)).expect("a listed choice deserialises")
    })
}

/// The name of a library setting's value, for `default_value`.
pub fn name<T: crate::workflow::Choices + serde::Serialize>(value: T) -> &'static str {
    value.name()
}

/// Reads an `fts.tf/1` document, stating on stderr a conversion the reader
/// made (a `"var": "z"` file in descending powers of `z`).
pub fn parse_tf(text: &str, source: &str) -> Result<crate::lti::TransferFunction, InputError> {
    let (g, note) = crate::io::tf_json::parse_tf_noted(text, source)?;
    if let Some(note) = note {
        eprintln!("note: {source}: {note}");
    }
    Ok(g)
}

/// The file given either as an option or as the positional argument (clap
/// requires exactly one of them).
pub fn one_of<'a>(option: &'a Option<PathBuf>, positional: &'a Option<PathBuf>) -> &'a Path {
    option
        .as_deref()
        .or(positional.as_deref())
        .expect("clap requires one of the two")
}
