//! Running a [`Plan`]: decide which steps are stale from the lock file,
//! rebuild them in dependency order with atomic writes, or only report
//! (`check`).

use super::hash::{Lock, LockEntry, sha256_hex};
use super::manifest::{
    Action, ColumnSpec, FileRef, HysteresisSpec, MechanismSpec, Plan, Step, keys, parse_manifest,
};
use crate::ident::hysteresis::HysteresisModel;
use crate::io::InputError;
use crate::io::controller_file::{
    ControllerFile, InputHash, MultiAxisControllerFile, Provenance, to_c_header,
    to_multiaxis_c_header,
};
use crate::io::hysteresis_json::{model_to_string, parse_model};
use crate::io::timeseries::{IoData, read_io};
use crate::io::{ss_json, tf_json, zpetc_json};
use crate::lti::TransferFunction;
use crate::lti::ss::StateSpace;
use crate::sim::contour::AxisController;
use crate::workflow::controller::closed_loop_zpetc;
use crate::workflow::identify::HysteresisInputs;
use crate::workflow::learning::{DesignRepetitive, RepetitiveFile};
use crate::workflow::robust::MixsynReport;
use crate::workflow::{
    BuildController, BuildInputs, DesignZpetc, LinearInputs, LinearReport, Mixsyn, MixsynInputs,
    Named, StepError,
};
use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Why a build or check stopped.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// Bad manifest, bad input file or bad settings (exit code 2).
    #[error("{0}")]
    BadInput(String),
    /// Anything else: a file cannot be written, a numerical breakdown (exit code 1).
    #[error("{0}")]
    Failure(String),
}

impl From<InputError> for PipelineError {
    fn from(e: InputError) -> Self {
        PipelineError::BadInput(e.to_string())
    }
}

/// What happened to a step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Status {
    /// Every recorded hash matches; nothing was run.
    UpToDate,
    /// Run; its outputs were written.
    Built,
    /// Out of date (`check` only); the reasons are in [`StepReport::reasons`].
    Stale,
}

impl Status {
    /// `up to date`, `built` or `stale`.
    pub fn label(&self) -> &'static str {
        match self {
            Status::UpToDate => "up to date",
            Status::Built => "built",
            Status::Stale => "stale",
        }
    }
}

/// One step's outcome.
#[derive(Debug, Clone)]
pub struct StepReport {
    /// Step name.
    pub name: String,
    /// Its kind.
    pub kind: String,
    /// Outcome.
    pub status: Status,
    /// Why it was (or would be) rebuilt: `never built`, `input data/sweep.csv changed`, ...
    /// (`` `force` `` when every step was rebuilt on request).
    pub reasons: Vec<String>,
    /// Its outputs (manifest-relative).
    pub outputs: Vec<String>,
    /// Seconds spent running it (0 when not run).
    pub seconds: f64,
}

/// Progress, reported as steps start and finish.
#[derive(Debug, Clone)]
pub enum Event<'a> {
    /// A stale step starts running.
    Start(&'a Step),
    /// A step is done (built, up to date or, in `check`, found stale).
    Done(&'a StepReport),
}

/// Reads and validates a manifest file.
pub fn load(manifest: &Path) -> Result<Plan, PipelineError> {
    let text = std::fs::read_to_string(manifest).map_err(|e| {
        PipelineError::BadInput(format!("{}: cannot read: {e}", manifest.display()))
    })?;
    Ok(parse_manifest(&text, manifest)?)
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// synced, then renamed over the target. On error the target is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    stage(path, bytes)?.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// Prefix and suffix of the temporary files outputs are staged in; the
/// name between is `<pid>-<random>`, so that a later run can tell a file a
/// killed run left (its process is gone) from one a running process is
/// still writing.
const TEMP_PREFIX: &str = ".fts-";
const TEMP_SUFFIX: &str = ".tmp";

/// The folder a path is written in (`.` for a bare file name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn temp_builder<'a>(prefix: &'a str) -> tempfile::Builder<'a, 'static> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(prefix).suffix(TEMP_SUFFIX);
    builder
}

/// Writes `bytes` to a synced temporary file beside `path`, to be renamed
/// over it (`persist`); dropped unpersisted, it is removed.
pub fn stage(path: &Path, bytes: &[u8]) -> std::io::Result<tempfile::NamedTempFile> {
    journal::record(folder_of(path));
    let prefix = format!("{TEMP_PREFIX}{}-", std::process::id());
    let mut builder = temp_builder(&prefix);
    // tempfile creates 0600 files; an output gets the usual 0644 (less the
    // umask), or keeps the mode of the file it replaces.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_or(0o644, |m| m.permissions().mode() & 0o7777);
        builder.permissions(std::fs::Permissions::from_mode(mode));
    }
    let mut tmp = builder.tempfile_in(folder_of(path))?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    Ok(tmp)
}

/// Keeps the current content of `path` under a temporary name beside it (a
/// hard link, else a copy), so that a multi-file commit can be undone.
pub fn keep_previous(path: &Path) -> std::io::Result<std::path::PathBuf> {
    journal::record(folder_of(path));
    let prefix = format!("{TEMP_PREFIX}{}-", std::process::id());
    let tmp = temp_builder(&prefix).tempfile_in(folder_of(path))?;
    let (file, name) = tmp.keep().map_err(|e| e.error)?;
    drop(file);
    // The unique name is reserved; the old file replaces the empty one.
    std::fs::remove_file(&name)?;
    if std::fs::hard_link(path, &name).is_err() {
        std::fs::copy(path, &name)?;
    }
    Ok(name)
}

/// Where a run's temporary files may be, so that any later run can remove
/// those a killed one stranded, wherever they are: before a run stages a
/// file in a folder it appends the folder's absolute path to its own
/// journal, `<temp dir>/fts-staging-<uid>/<pid>`, and removes the journal
/// when it ends; every run starts by sweeping the folders of the journals
/// whose process is gone ([`sweep_stranded`]).
mod journal {
    use std::io::Write;
    use std::path::{Path, PathBuf};
    use std::sync::Mutex;

    /// Folders this run has journalled.
    static RECORDED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

    fn folder() -> PathBuf {
        #[cfg(unix)]
        // SAFETY: getuid has no preconditions and cannot fail.
        let user = unsafe { libc::getuid() }.to_string();
        #[cfg(not(unix))]
        let user = std::env::var("USERNAME").unwrap_or_default();
        std::env::temp_dir().join(format!("fts-staging-{user}"))
    }

    fn own() -> PathBuf {
        folder().join(std::process::id().to_string())
    }

    /// Journals `dir` (once per run). Best effort: a journal that cannot be
    /// written leaves the folder to the sweep of the runs that write there.
    pub fn record(dir: &Path) {
        let Ok(dir) = std::path::absolute(dir) else {
            return;
        };
        let Ok(mut recorded) = RECORDED.lock() else {
            return;
        };
        if recorded.contains(&dir) {
            return;
        }
        let _ = std::fs::create_dir_all(folder());
        let line = format!("{}\n", dir.display());
        let written = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(own())
            .and_then(|mut f| f.write_all(line.as_bytes()).and_then(|()| f.sync_all()));
        if written.is_ok() {
            recorded.push(dir);
        }
    }

    /// Removes this run's journal (its temporary files are gone).
    pub fn close() {
        let _ = std::fs::remove_file(own());
    }

    /// The folders of the journals of ended runs, each journal removed.
    pub fn stranded() -> Vec<PathBuf> {
        let Ok(entries) = std::fs::read_dir(folder()) else {
            return Vec::new();
        };
        let mut dirs = Vec::new();
        for entry in entries.flatten() {
            let pid = entry
                .file_name()
                .to_str()
                .and_then(|n| n.parse::<u32>().ok());
            let ended = pid.is_some_and(|p| p != std::process::id() && !super::alive(p));
            if !ended {
                continue;
            }
            if let Ok(text) = std::fs::read_to_string(entry.path()) {
                dirs.extend(text.lines().map(PathBuf::from));
            }
            let _ = std::fs::remove_file(entry.path());
        }
        dirs.sort();
        dirs.dedup();
        dirs
    }
}

/// Removes the temporary files of every killed run, in whatever folder it
/// staged them (from the runs' journals).
pub fn sweep_stranded() {
    for dir in journal::stranded() {
        sweep_stale_temps(&dir);
    }
}

/// Ends this run's journal: call when its temporary files are gone.
pub fn close_journal() {
    journal::close();
}

/// Whether process `pid` still runs (a zombie counts as running).
fn alive(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else {
            return true;
        };
        // SAFETY: signal 0 only checks that the process exists.
        if unsafe { libc::kill(pid, 0) } == 0 {
            return true;
        }
        std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// The owner of a staged temporary file name, `.fts-<pid>-<random>.tmp`.
fn temp_owner(name: &str) -> Option<u32> {
    let inner = name.strip_prefix(TEMP_PREFIX)?.strip_suffix(TEMP_SUFFIX)?;
    inner.split_once('-')?.0.parse().ok()
}

/// Removes the temporary files in `dir` that a run killed mid-write left
/// (their process is gone); files of running processes are kept.
pub fn sweep_stale_temps(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temp_owner) else {
            continue;
        };
        if pid != std::process::id() && !alive(pid) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Removes temporary files that a killed run left beside the plan's outputs.
fn remove_stale_temps(plan: &Plan) {
    let outputs = plan.steps.iter().flat_map(|s| &s.outputs);
    let mut dirs: Vec<std::path::PathBuf> = outputs
        .map(|f| plan.locate(&f.path))
        .chain([plan.lock.clone()])
        .map(|p| folder_of(&p).to_path_buf())
        .collect();
    dirs.sort();
    dirs.dedup();
    for dir in dirs {
        sweep_stale_temps(&dir);
    }
}

fn read_lock(plan: &Plan) -> Result<(Lock, Option<String>), PipelineError> {
    match std::fs::read_to_string(&plan.lock) {
        Ok(text) => Ok((
            Lock::parse(&text, &plan.lock.display().to_string())?,
            Some(text),
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok((Lock::default(), None)),
        Err(e) => Err(PipelineError::BadInput(format!(
            "{}: cannot read: {e}",
            plan.lock.display()
        ))),
    }
}

/// Current SHA-256 of a file, `None` when it does not exist.
fn file_hash(path: &Path) -> Result<Option<String>, PipelineError> {
    match std::fs::read(path) {
        Ok(bytes) => Ok(Some(sha256_hex(&bytes))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(PipelineError::BadInput(format!(
            "{}: cannot read: {e}",
            path.display()
        ))),
    }
}

/// Why `step` is out of date against its lock entry (empty: up to date).
/// `pending` holds outputs of steps found stale earlier (check only).
fn stale_reasons(
    plan: &Plan,
    step: &Step,
    entry: Option<&LockEntry>,
    pending: &BTreeMap<String, String>,
    staged: &Staged,
) -> Result<Vec<String>, PipelineError> {
    let Some(entry) = entry else {
        return Ok(vec!["never built".into()]);
    };
    let mut reasons = Vec::new();
    if entry.kind != step.kind || entry.settings_sha256 != step.settings_sha256 {
        reasons.push(format!(
            "its settings in {} changed (or fts changed version)",
            plan.manifest.display()
        ));
    }
    for f in &step.inputs {
        if let Some(upstream) = pending.get(&f.path) {
            reasons.push(format!(
                "input {} is written by stale step {upstream:?}",
                f.path
            ));
            continue;
        }
        let path = plan.locate(&f.path);
        let now = match staged.get(&path) {
            Some(bytes) => Some(sha256_hex(bytes)),
            None => file_hash(&path)?,
        };
        match (now, entry.inputs.get(&f.path)) {
            (None, _) => reasons.push(format!("input {} is missing", f.path)),
            (Some(_), None) => reasons.push(format!("input {} is new", f.path)),
            (Some(now), Some(then)) if &now != then => {
                reasons.push(format!("input {} changed", f.path))
            }
            _ => {}
        }
    }
    for f in &step.outputs {
        match (
            file_hash(&plan.locate(&f.path))?,
            entry.outputs.get(&f.path),
        ) {
            (None, _) => reasons.push(format!("output {} is missing", f.path)),
            (Some(_), None) => reasons.push(format!("output {} is not in the lock file", f.path)),
            (Some(now), Some(then)) if &now != then => reasons.push(format!(
                "output {} was modified after it was built (edited by hand?)",
                f.path
            )),
            _ => {}
        }
    }
    Ok(reasons)
}

fn report(step: &Step, status: Status, reasons: Vec<String>, seconds: f64) -> StepReport {
    StepReport {
        name: step.name.clone(),
        kind: step.kind.clone(),
        status,
        reasons,
        outputs: step.outputs.iter().map(|o| o.path.clone()).collect(),
        seconds,
    }
}

/// Reports which steps are stale and why, writing nothing. A step whose
/// input comes from a stale step is stale too.
pub fn check(
    plan: &Plan,
    observer: &mut dyn FnMut(Event<'_>),
) -> Result<Vec<StepReport>, PipelineError> {
    let (lock, _) = read_lock(plan)?;
    let mut pending = BTreeMap::new();
    let mut reports = Vec::new();
    for step in &plan.steps {
        let reasons = stale_reasons(
            plan,
            step,
            lock.steps.get(&step.name),
            &pending,
            &Staged::new(),
        )?;
        let status = if reasons.is_empty() {
            Status::UpToDate
        } else {
            for o in &step.outputs {
                pending.insert(o.path.clone(), step.name.clone());
            }
            Status::Stale
        };
        let r = report(step, status, reasons, 0.0);
        observer(Event::Done(&r));
        reports.push(r);
    }
    Ok(reports)
}

/// The outputs of the steps built so far, by path, until the build commits.
type Staged = BTreeMap<std::path::PathBuf, Vec<u8>>;

/// Rebuilds every stale step (every step with `force`), in dependency order.
///
/// Outputs are held in memory (a later step reads its inputs from there)
/// and written together with the lock file only when every step has
/// succeeded: a failing build leaves every output and the lock exactly as
/// they were.
pub fn build(
    plan: &Plan,
    force: bool,
    observer: &mut dyn FnMut(Event<'_>),
) -> Result<Vec<StepReport>, PipelineError> {
    // With `force` an unreadable lock is simply replaced.
    let (old, old_text) = match read_lock(plan) {
        Err(_) if force => (Lock::default(), None),
        other => other?,
    };
    remove_stale_temps(plan);
    let names: BTreeSet<&str> = plan.steps.iter().map(|s| s.name.as_str()).collect();
    let mut lock = old.clone();
    lock.steps.retain(|name, _| names.contains(name.as_str()));
    let mut staged = Staged::new();
    let mut reports = Vec::new();
    for step in &plan.steps {
        let reasons = if force {
            vec!["`force`".to_string()]
        } else {
            let entry = old.steps.get(&step.name);
            stale_reasons(plan, step, entry, &BTreeMap::new(), &staged)?
        };
        if reasons.is_empty() {
            let r = report(step, Status::UpToDate, reasons, 0.0);
            observer(Event::Done(&r));
            reports.push(r);
            continue;
        }
        observer(Event::Start(step));
        let start = Instant::now();
        build_step(plan, step, &mut lock, &mut staged)?;
        let r = report(step, Status::Built, reasons, start.elapsed().as_secs_f64());
        observer(Event::Done(&r));
        reports.push(r);
    }
    // Entries of steps no longer in the manifest are dropped.
    let text = lock.to_json_string();
    if old_text.as_deref() != Some(text.as_str()) {
        staged.insert(plan.lock.clone(), text.into_bytes());
    }
    commit_all(staged)?;
    Ok(reports)
}

/// Builds one step: reads its inputs, runs it, holds its outputs, and
/// records it in the lock.
fn build_step(
    plan: &Plan,
    step: &Step,
    lock: &mut Lock,
    staged: &mut Staged,
) -> Result<(), PipelineError> {
    let (inputs, mut entry) = read_inputs(plan, step, staged)?;
    let outputs = execute(plan, step, &inputs).map_err(|e| {
        let prefix = format!(
            "{} line {}, step {:?} ({})",
            plan.manifest.display(),
            step.line,
            step.name,
            step.kind
        );
        match e {
            PipelineError::BadInput(m) => PipelineError::BadInput(format!("{prefix}: {m}")),
            PipelineError::Failure(m) => PipelineError::Failure(format!("{prefix}: {m}")),
        }
    })?;
    for (f, bytes) in outputs {
        entry.outputs.insert(f.path.clone(), sha256_hex(&bytes));
        staged.insert(plan.locate(&f.path), bytes);
    }
    lock.steps.insert(step.name.clone(), entry);
    Ok(())
}

/// A step's inputs by field, each read once (the bytes hashed are the bytes
/// used), and its lock entry with their hashes.
fn read_inputs(
    plan: &Plan,
    step: &Step,
    staged: &Staged,
) -> Result<(BTreeMap<String, Vec<u8>>, LockEntry), PipelineError> {
    let mut inputs = BTreeMap::new();
    let mut entry = LockEntry {
        kind: step.kind.clone(),
        settings_sha256: step.settings_sha256.clone(),
        ..LockEntry::default()
    };
    for f in &step.inputs {
        let path = plan.locate(&f.path);
        if let Some(bytes) = staged.get(&path) {
            entry.inputs.insert(f.path.clone(), sha256_hex(bytes));
            inputs.insert(f.field.clone(), bytes.clone());
            continue;
        }
        let bytes = std::fs::read(&path).map_err(|e| {
            PipelineError::BadInput(format!(
                "{} line {}, field 'step.{}.{}': cannot read {}: {e}",
                plan.manifest.display(),
                f.line,
                step.name,
                f.field,
                path.display()
            ))
        })?;
        entry.inputs.insert(f.path.clone(), sha256_hex(&bytes));
        inputs.insert(f.field.clone(), bytes);
    }
    Ok((inputs, entry))
}

/// Writes the build's files (outputs and lock) all or none: every changed
/// file is staged in a synced temporary file first; only when all are staged
/// are they renamed into place, each target's previous content kept until
/// all renames succeeded (and put back if one fails). Identical content is
/// not rewritten, so its time stamp stays.
fn commit_all(files: Staged) -> Result<(), PipelineError> {
    let cannot = |path: &Path, e: &dyn std::fmt::Display| {
        PipelineError::Failure(format!("{}: cannot write: {e}", path.display()))
    };
    let mut staged = Vec::new();
    for (path, bytes) in &files {
        if file_hash(path).ok().flatten().as_deref() == Some(sha256_hex(bytes).as_str()) {
            continue;
        }
        // Caught before anything is renamed, so the build stays all or none.
        if std::fs::symlink_metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(cannot(path, &"it exists and is not a regular file"));
        }
        let dir = folder_of(path);
        std::fs::create_dir_all(dir).map_err(|e| {
            PipelineError::Failure(format!("{}: cannot create: {e}", dir.display()))
        })?;
        staged.push((stage(path, bytes).map_err(|e| cannot(path, &e))?, path));
    }
    let mut done: Vec<(&Path, Option<std::path::PathBuf>)> = Vec::new();
    let undo = |done: Vec<(&Path, Option<std::path::PathBuf>)>| {
        for (target, previous) in done.into_iter().rev() {
            let _ = match previous {
                Some(p) => std::fs::rename(&p, target),
                None => std::fs::remove_file(target),
            };
        }
    };
    for (tmp, path) in staged {
        let previous = match path.is_file() {
            true => match keep_previous(path) {
                Ok(p) => Some(p),
                Err(e) => {
                    undo(done);
                    return Err(cannot(path, &e));
                }
            },
            false => None,
        };
        if let Err(e) = tmp.persist(path) {
            if let Some(p) = previous {
                let _ = std::fs::remove_file(p);
            }
            undo(done);
            return Err(cannot(path, &e.error));
        }
        done.push((path, previous));
    }
    for (_, previous) in done {
        if let Some(p) = previous {
            let _ = std::fs::remove_file(p);
        }
    }
    Ok(())
}

fn bad(m: impl Into<String>) -> PipelineError {
    PipelineError::BadInput(m.into())
}

fn source(plan: &Plan, f: &FileRef) -> String {
    plan.locate(&f.path).display().to_string()
}

fn read_record(
    bytes: &[u8],
    source: &str,
    spec: &super::manifest::ColumnSpec,
    min_rows: usize,
) -> Result<IoData, PipelineError> {
    let mut data = read_io(bytes, source, &spec.columns, min_rows)?;
    data.keep_rows(spec.start, spec.end).map_err(|n| {
        bad(format!(
            "{source}: sample range {}..{} (fields start/end) is empty or outside the {n} data rows",
            spec.start,
            spec.end.unwrap_or(n)
        ))
    })?;
    Ok(data)
}

/// A step's outputs: each file's bytes.
type Outputs = Vec<(FileRef, Vec<u8>)>;

/// The inputs of a running step: the bytes read for each field (hashed
/// once; the bytes hashed are the bytes used).
struct Inputs<'a> {
    plan: &'a Plan,
    step: &'a Step,
    bytes: &'a BTreeMap<String, Vec<u8>>,
}

impl Inputs<'_> {
    /// The bytes of the input `field` and its name for messages.
    fn bytes(&self, field: &str) -> Option<(&[u8], String)> {
        let f = self.step.input(field)?;
        let bytes = self.bytes.get(field)?;
        Some((bytes.as_slice(), source(self.plan, f)))
    }

    /// The input `field` as text.
    fn text(&self, field: &str) -> Result<Option<(&str, String)>, PipelineError> {
        self.bytes(field)
            .map(|(bytes, src)| match std::str::from_utf8(bytes) {
                Ok(text) => Ok((text, src)),
                Err(_) => Err(bad(format!("{src}: not UTF-8 text"))),
            })
            .transpose()
    }

    /// The system in the input file of `field`, with its name for messages.
    fn system(&self, field: &str) -> Result<Option<(StateSpace, String)>, PipelineError> {
        match self.text(field)? {
            Some((text, src)) => Ok(Some((ss_json::parse_system(text, &src)?, src))),
            None => Ok(None),
        }
    }

    /// A required system input (checked when the manifest was read).
    fn required_system(&self, field: &str) -> Result<(StateSpace, String), PipelineError> {
        self.system(field)?
            .ok_or_else(|| bad(format!("field '{field}' is required")))
    }

    /// The inverse hysteresis model of the input `field`, if given.
    fn hysteresis(&self, field: &str) -> Result<Option<HysteresisModel>, PipelineError> {
        match self.text(field)? {
            Some((text, src)) => Ok(Some(parse_model(text, &src)?.model)),
            None => Ok(None),
        }
    }

    /// The record of a data step and its validation record, read with the
    /// step's columns.
    fn linear(&self, columns: &ColumnSpec) -> Result<LinearInputs, PipelineError> {
        let (bytes, source) = self.bytes("data").expect("validated: data is required");
        let validation = match self.bytes("validate") {
            Some((vbytes, vsource)) => Some((read_record(vbytes, &vsource, columns, 2)?, vsource)),
            None => None,
        };
        Ok(LinearInputs {
            data: read_record(bytes, &source, columns, 2)?,
            source,
            validation,
        })
    }

    /// The provenance of a coefficient file: the given inputs among
    /// `(field, role)`, in that order, by their manifest-relative paths.
    fn provenance(&self, roles: &[(&str, &str)]) -> Provenance {
        let inputs = roles
            .iter()
            .filter_map(|&(field, role)| {
                let (f, bytes) = (self.step.input(field)?, self.bytes.get(field)?);
                Some(InputHash {
                    role: role.into(),
                    file: f.path.clone(),
                    sha256: sha256_hex(bytes),
                })
            })
            .collect();
        Provenance {
            fts_version: env!("CARGO_PKG_VERSION").into(),
            inputs,
        }
    }
}

/// Runs one step on its inputs' bytes; returns the bytes of every output
/// the manifest names (nothing is written here).
fn execute(
    plan: &Plan,
    step: &Step,
    bytes: &BTreeMap<String, Vec<u8>>,
) -> Result<Outputs, PipelineError> {
    let io = Inputs { plan, step, bytes };
    let err = |e: StepError| step_error(step, e);
    let ss_file = |sys: &StateSpace| ss_json::ss_to_string(sys).into_bytes();
    let files: Vec<(&str, Vec<u8>)> = match &step.action {
        Action::VirtualTriangles(s) => vec![("out", s.run().map_err(err)?.to_csv().into_bytes())],
        Action::VirtualSweep(s) => {
            let model = io.hysteresis("hysteresis")?;
            let record = s.run(model.as_ref()).map_err(err)?;
            vec![("out", record.to_csv().into_bytes())]
        }
        Action::Hysteresis(spec) => vec![("out", hysteresis(&io, spec)?)],
        Action::Arx(spec) => vec![(
            "out",
            tf_file(step, spec.step.run(io.linear(&spec.columns)?))?,
        )],
        Action::Oe(spec) => vec![(
            "out",
            tf_file(step, spec.step.run(io.linear(&spec.columns)?))?,
        )],
        Action::Ct(spec) => {
            let report = spec.step.run(io.linear(&spec.columns)?).map_err(err)?;
            let tf = report.transfer_function().map_err(err)?;
            vec![("out", tf_json::tf_to_string(&tf).into_bytes())]
        }
        Action::Mechanism(spec) => vec![("out", mechanism(spec).map_err(err)?)],
        Action::Zpetc(spec) => vec![("out", zpetc(&io, spec)?)],
        Action::Repetitive(spec) => vec![("out", repetitive(&io, spec)?)],
        Action::Controller(spec) => {
            let file = controller(&io, spec)?;
            vec![
                ("out", file.to_json_string().into_bytes()),
                ("header", to_c_header(&file).into_bytes()),
            ]
        }
        Action::Weight(w) => vec![("out", ss_file(&w.run().map_err(err)?.weight))],
        Action::Hinf(h) => {
            let (p, src) = io.required_system("generalized")?;
            vec![("out", ss_file(&h.run(&p, &src).map_err(err)?.result.k))]
        }
        Action::H2(h) => {
            let (p, src) = io.required_system("generalized")?;
            vec![("out", ss_file(&h.run(&p, &src).map_err(err)?.result.k))]
        }
        Action::C2d(c) => {
            let (sys, src) = io.required_system("system")?;
            vec![("out", ss_file(&c.run(&sys, &src).map_err(err)?.system))]
        }
        Action::MultiAxis(m) => {
            let file = multiaxis(&io, m)?;
            vec![
                ("out", file.to_json_string().into_bytes()),
                ("header", to_multiaxis_c_header(&file).into_bytes()),
            ]
        }
        Action::Mixsyn(m) => {
            let report = mixsyn(&io, m)?;
            vec![
                ("out", ss_file(report.controller())),
                ("augmented", ss_file(&report.augmented)),
            ]
        }
    };
    // Only the outputs the manifest names are written.
    Ok(files
        .into_iter()
        .filter_map(|(field, bytes)| step.output(field).map(|f| (f.clone(), bytes)))
        .collect())
}

/// A library step's error as the pipeline's, naming the field and its line.
fn step_error(step: &Step, e: StepError) -> PipelineError {
    match e {
        StepError::Input {
            field: Some(field),
            message,
        } => {
            let line = step.field_lines.get(field).copied().unwrap_or(step.line);
            bad(format!(
                "line {line}, field 'step.{}.{field}': {}",
                step.name,
                keys(&message)
            ))
        }
        StepError::Input {
            field: None,
            message,
        } => bad(keys(&message)),
        StepError::Computation(message) => PipelineError::Failure(keys(&message)),
    }
}

/// The `fts.tf/1` file of an identified linear model.
fn tf_file(step: &Step, report: Result<LinearReport, StepError>) -> Result<Vec<u8>, PipelineError> {
    let tf = report.map_err(|e| step_error(step, e))?.transfer_function();
    Ok(tf_json::tf_to_string(&tf).into_bytes())
}

fn hysteresis(io: &Inputs<'_>, spec: &HysteresisSpec) -> Result<Vec<u8>, PipelineError> {
    let (bytes, src) = io.bytes("data").expect("validated: data is required");
    let record = read_record(bytes, &src, &spec.columns, 1)?;
    let inputs = HysteresisInputs {
        record: &record,
        source: &src,
        start: spec.columns.start,
    };
    let report = spec.step.run(inputs).map_err(|e| step_error(io.step, e))?;
    Ok(model_to_string(&report.file).into_bytes())
}

/// A `mechanism` step's report, the JSON `fts mechanism ... --json` prints.
fn mechanism(spec: &MechanismSpec) -> Result<Vec<u8>, StepError> {
    fn json<T: serde::Serialize>(report: &T) -> Vec<u8> {
        // Through a `Value`, as the command's `--json` prints it (same bytes).
        let value = serde_json::to_value(report).expect("reports serialise");
        let mut text = serde_json::to_string_pretty(&value).expect("values serialise");
        text.push('\n');
        text.into_bytes()
    }
    Ok(match spec {
        MechanismSpec::FlexureLoss(s) => json(&s.run()?),
        MechanismSpec::Hinge(s) => json(&s.run()?),
        MechanismSpec::Puu3(s) => json(&s.run()?),
        MechanismSpec::Lever(s) => json(&s.run()?),
        MechanismSpec::Bridge(s) => json(&s.run()?),
        MechanismSpec::Amplifier(s) => json(&s.run()?),
    })
}

fn zpetc(io: &Inputs<'_>, spec: &DesignZpetc) -> Result<Vec<u8>, PipelineError> {
    let (text, src) = io.text("tf")?.expect("validated: tf is required");
    let model = tf_json::parse_tf(text, &src)?;
    let report = spec.run(&model, &src).map_err(|e| step_error(io.step, e))?;
    Ok(zpetc_json::zpetc_to_string(&report.filter).into_bytes())
}

/// A `repetitive` step: the compensator designed on the `tf` closed loop,
/// written as `fts repetitive -o` writes it.
fn repetitive(io: &Inputs<'_>, spec: &DesignRepetitive) -> Result<Vec<u8>, PipelineError> {
    let err = |e: StepError| step_error(io.step, e);
    let (text, src) = io.text("tf")?.expect("validated: tf is required");
    let TransferFunction::Discrete(model) = tf_json::parse_tf(text, &src)? else {
        return Err(err(StepError::input(format!(
            "{src} field 'var': the closed-loop model must be discrete (\"z^-1\")"
        ))));
    };
    let report = spec.run(&model).map_err(err)?;
    Ok(report.file_text().into_bytes())
}

/// The coefficient file of a `controller` step: inputs hashed in the order
/// `fts emit` records them.
fn controller(io: &Inputs<'_>, spec: &BuildController) -> Result<ControllerFile, PipelineError> {
    let err = |e: StepError| step_error(io.step, e);
    let provenance = io.provenance(&[
        ("hysteresis", "hysteresis_inverse"),
        ("zpetc", "zpetc"),
        ("closed_loop", "closed_loop"),
        ("ss", "state_space"),
        ("repetitive", "repetitive"),
    ]);
    let inverse = io.hysteresis("hysteresis")?;
    let filter = match (io.text("zpetc")?, io.text("closed_loop")?) {
        (Some((text, src)), _) => Some(zpetc_json::parse_zpetc(text, &src)?),
        (None, Some((text, src))) => {
            Some(closed_loop_zpetc(&tf_json::parse_tf(text, &src)?, &src).map_err(err)?)
        }
        (None, None) => None,
    };
    let ss = io.system("ss")?;
    let repetitive = match io.text("repetitive")? {
        Some((text, src)) => Some((RepetitiveFile::parse(text, &src).map_err(err)?, src)),
        None => None,
    };
    let report = spec
        .run(BuildInputs {
            hysteresis: inverse.as_ref(),
            zpetc: filter.as_ref(),
            ss: ss.as_ref().map(|(sys, src)| (sys, src.as_str())),
            repetitive: repetitive.as_ref().map(|(f, src)| (f, src.as_str())),
            provenance,
        })
        .map_err(err)?;
    Ok(report.file)
}

fn multiaxis(
    io: &Inputs<'_>,
    m: &crate::workflow::contour::BuildMultiAxis,
) -> Result<MultiAxisControllerFile, PipelineError> {
    let provenance = io.provenance(&[("x", "x"), ("y", "y"), ("z", "z"), ("cross", "cross")]);
    let controller = |field: &str| -> Result<_, PipelineError> {
        Ok(io
            .system(field)?
            .map(|(sys, _)| AxisController::StateSpace(Box::new(sys))))
    };
    let axes = [controller("x")?, controller("y")?, controller("z")?];
    m.run(axes, controller("cross")?, provenance)
        .map_err(|e| step_error(io.step, e))
}

fn mixsyn(io: &Inputs<'_>, m: &Mixsyn) -> Result<MixsynReport, PipelineError> {
    let ((g, src), ws) = (io.required_system("plant")?, io.required_system("ws")?);
    let (wu, wt) = (io.system("wu")?, io.system("wt")?);
    m.run(MixsynInputs {
        plant: &g,
        ws: Named::from(&ws),
        wu: wu.as_ref().map(Named::from),
        wt: wt.as_ref().map(Named::from),
        source: &src,
    })
    .map_err(|e| step_error(io.step, e))
}
