//! Running a [`Plan`]: decide which steps are stale from the lock file,
//! rebuild them in dependency order with atomic writes, or only report
//! (`check`).

use super::hash::{Lock, LockEntry, sha256_hex};
use super::manifest::{Action, ColumnSpec, FileRef, Plan, Step, keys, parse_manifest};
use crate::io::InputError;
use crate::io::controller_file::{ControllerFile, InputHash, Provenance, to_c_header};
use crate::io::hysteresis_json::{model_to_string, parse_model};
use crate::io::timeseries::{IoData, read_io, time_column, write_csv};
use crate::io::{ss_json, tf_json, zpetc_json};
use crate::lti::ss::StateSpace;
use crate::sim::experiment::{
    align_triangle_record, build_controller, sweep_record, triangle_record,
};
use crate::synth::composite::Stages;
use crate::workflow::identify::HysteresisInputs;
use crate::workflow::{ControllerInputs, LinearInputs, MixsynInputs, SsController, StepError};
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

/// Prefix and suffix of the temporary files outputs are staged in.
const TEMP_PREFIX: &str = ".fts-";
const TEMP_SUFFIX: &str = ".tmp";

/// Writes `bytes` to a synced temporary file beside `path`, to be renamed
/// over it (`persist`); dropped unpersisted, it is removed.
fn stage(path: &Path, bytes: &[u8]) -> std::io::Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(TEMP_PREFIX).suffix(TEMP_SUFFIX);
    // tempfile creates 0600 files; an output gets the usual 0644 (less the
    // umask), or keeps the mode of the file it replaces.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_or(0o644, |m| m.permissions().mode() & 0o7777);
        builder.permissions(std::fs::Permissions::from_mode(mode));
    }
    let mut tmp = builder.tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    Ok(tmp)
}

/// Removes temporary files that a killed run left beside the plan's outputs.
fn remove_stale_temps(plan: &Plan) {
    let outputs = plan.steps.iter().flat_map(|s| &s.outputs);
    let mut dirs: Vec<std::path::PathBuf> = outputs
        .map(|f| plan.locate(&f.path))
        .chain([plan.lock.clone()])
        .map(|p| match p.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        })
        .collect();
    dirs.sort();
    dirs.dedup();
    for dir in dirs {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if name.starts_with(TEMP_PREFIX) && name.ends_with(TEMP_SUFFIX) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
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
        match (file_hash(&plan.locate(&f.path))?, entry.inputs.get(&f.path)) {
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
        let reasons = stale_reasons(plan, step, lock.steps.get(&step.name), &pending)?;
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

/// Rebuilds every stale step (every step with `force`), in dependency order.
///
/// Each output is written atomically, and only after the whole step has
/// succeeded; the lock file is rewritten (atomically) after each completed
/// step. A failing step therefore leaves its previous outputs, the outputs
/// of the steps after it and their lock entries exactly as they were.
pub fn build(
    plan: &Plan,
    force: bool,
    observer: &mut dyn FnMut(Event<'_>),
) -> Result<Vec<StepReport>, PipelineError> {
    // With --force an unreadable lock is simply replaced; entries of steps
    // not yet rebuilt are kept, so a failure still leaves it accurate.
    let (old, old_text) = match read_lock(plan) {
        Err(_) if force => (Lock::default(), None),
        other => other?,
    };
    remove_stale_temps(plan);
    let names: BTreeSet<&str> = plan.steps.iter().map(|s| s.name.as_str()).collect();
    let mut lock = old.clone();
    lock.steps.retain(|name, _| names.contains(name.as_str()));
    let write_lock = |lock: &Lock| -> Result<(), PipelineError> {
        write_atomic(&plan.lock, lock.to_json_string().as_bytes()).map_err(|e| {
            PipelineError::Failure(format!("{}: cannot write: {e}", plan.lock.display()))
        })
    };
    let mut reports = Vec::new();
    for step in &plan.steps {
        let reasons = if force {
            vec!["--force".to_string()]
        } else {
            stale_reasons(plan, step, old.steps.get(&step.name), &BTreeMap::new())?
        };
        if reasons.is_empty() {
            let r = report(step, Status::UpToDate, reasons, 0.0);
            observer(Event::Done(&r));
            reports.push(r);
            continue;
        }
        observer(Event::Start(step));
        let start = Instant::now();
        // Inputs are read once: the bytes hashed are the bytes used.
        let mut inputs = BTreeMap::new();
        let mut entry = LockEntry {
            kind: step.kind.clone(),
            settings_sha256: step.settings_sha256.clone(),
            ..LockEntry::default()
        };
        for f in &step.inputs {
            let path = plan.locate(&f.path);
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
        commit_outputs(plan, &outputs, &mut entry)?;
        lock.steps.insert(step.name.clone(), entry);
        write_lock(&lock)?;
        let r = report(step, Status::Built, reasons, start.elapsed().as_secs_f64());
        observer(Event::Done(&r));
        reports.push(r);
    }
    // Entries of steps no longer in the manifest are dropped.
    let text = lock.to_json_string();
    if old_text.as_deref() != Some(text.as_str()) {
        write_lock(&lock)?;
    }
    Ok(reports)
}

/// Writes a step's outputs all or none: every changed output is staged in a
/// synced temporary file first, and only when all are staged are they
/// renamed into place (the lock is written after, by the caller). Identical
/// content is not rewritten, so its time stamp stays.
fn commit_outputs(
    plan: &Plan,
    outputs: &[(FileRef, Vec<u8>)],
    entry: &mut LockEntry,
) -> Result<(), PipelineError> {
    let mut staged = Vec::new();
    for (f, bytes) in outputs {
        let path = plan.locate(&f.path);
        let hash = sha256_hex(bytes);
        if file_hash(&path).ok().flatten().as_deref() != Some(hash.as_str()) {
            // Caught before anything is renamed, so the step stays all or none.
            if std::fs::symlink_metadata(&path).is_ok_and(|m| !m.is_file()) {
                return Err(PipelineError::Failure(format!(
                    "{}: cannot write: it exists and is not a regular file",
                    path.display()
                )));
            }
            if let Some(dir) = path.parent()
                && !dir.as_os_str().is_empty()
            {
                std::fs::create_dir_all(dir).map_err(|e| {
                    PipelineError::Failure(format!("{}: cannot create: {e}", dir.display()))
                })?;
            }
            let tmp = stage(&path, bytes).map_err(|e| {
                PipelineError::Failure(format!("{}: cannot write: {e}", path.display()))
            })?;
            staged.push((tmp, path));
        }
        entry.outputs.insert(f.path.clone(), hash);
    }
    for (tmp, path) in staged {
        tmp.persist(&path).map_err(|e| {
            PipelineError::Failure(format!("{}: cannot write: {}", path.display(), e.error))
        })?;
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

/// The record of a linear step and its validation record, read with the
/// step's columns.
fn linear_inputs<'a>(
    columns: &ColumnSpec,
    bytes_of: impl Fn(&str) -> Option<(&'a [u8], String)>,
) -> Result<LinearInputs, PipelineError> {
    let (bytes, source) = bytes_of("data").expect("validated: data is required");
    let validation = match bytes_of("validate") {
        Some((vbytes, vsource)) => Some((read_record(vbytes, &vsource, columns, 2)?, vsource)),
        None => None,
    };
    Ok(LinearInputs {
        data: read_record(bytes, &source, columns, 2)?,
        source,
        validation,
    })
}

/// Runs one step on its inputs' bytes; returns every output's bytes (nothing
/// is written here).
fn execute(
    plan: &Plan,
    step: &Step,
    inputs: &BTreeMap<String, Vec<u8>>,
) -> Result<Vec<(FileRef, Vec<u8>)>, PipelineError> {
    let out = |field: &str| step.output(field).cloned();
    let bytes_of = |field: &str| -> Option<(&[u8], String)> {
        let f = step.input(field)?;
        inputs.get(field).map(|t| (t.as_slice(), source(plan, f)))
    };
    let text_of = |field: &str| -> Result<Option<(&str, String)>, PipelineError> {
        bytes_of(field)
            .map(|(bytes, src)| match std::str::from_utf8(bytes) {
                Ok(text) => Ok((text, src)),
                Err(_) => Err(bad(format!("{src}: not UTF-8 text"))),
            })
            .transpose()
    };
    let mut files: Vec<(Option<FileRef>, Vec<u8>)> = Vec::new();
    match &step.action {
        Action::VirtualTriangles(p) => {
            let (command, measured) = triangle_record(p).map_err(|e| bad(e.to_string()))?;
            let (u, y) = align_triangle_record(p, &command, &measured);
            let t = time_column(u.len(), p.plant.ts);
            files.push((
                out("out"),
                write_csv(&["t", "u", "y"], &[&t, u, y]).into_bytes(),
            ));
        }
        Action::VirtualSweep(p) => {
            let model = match text_of("hysteresis")? {
                Some((text, src)) => Some(parse_model(text, &src)?.model),
                None => None,
            };
            let (r, y) = sweep_record(p, model.as_ref()).map_err(|e| bad(e.to_string()))?;
            let t = time_column(r.len(), p.plant.ts);
            files.push((
                out("out"),
                write_csv(&["t", "u", "y"], &[&t, &r, &y]).into_bytes(),
            ));
        }
        Action::Hysteresis(spec) => {
            let (bytes, src) = bytes_of("data").expect("validated: data is required");
            let record = read_record(bytes, &src, &spec.columns, 1)?;
            let inputs = HysteresisInputs {
                record: &record,
                source: &src,
                start: spec.columns.start,
            };
            let report = spec.step.run(inputs).map_err(|e| step_error(step, e))?;
            files.push((out("out"), model_to_string(&report.file).into_bytes()));
        }
        Action::Arx(spec) => {
            let inputs = linear_inputs(&spec.columns, bytes_of)?;
            let report = spec.step.run(inputs).map_err(|e| step_error(step, e))?;
            let tf = tf_json::tf_to_string(&report.transfer_function());
            files.push((out("out"), tf.into_bytes()));
        }
        Action::Oe(spec) => {
            let inputs = linear_inputs(&spec.columns, bytes_of)?;
            let report = spec.step.run(inputs).map_err(|e| step_error(step, e))?;
            let tf = tf_json::tf_to_string(&report.transfer_function());
            files.push((out("out"), tf.into_bytes()));
        }
        Action::Zpetc(spec) => {
            let (text, src) = text_of("tf")?.expect("validated: tf is required");
            let model = tf_json::parse_tf(text, &src)?;
            let filter = spec
                .run(&model, &src)
                .map_err(|e| step_error(step, e))?
                .filter;
            files.push((
                out("out"),
                zpetc_json::zpetc_to_string(&filter).into_bytes(),
            ));
        }
        Action::Weight(_)
        | Action::Mixsyn(_)
        | Action::Hinf(_)
        | Action::H2(_)
        | Action::C2d(_)
        | Action::SsController(_) => {
            return robust(plan, step, inputs);
        }
        Action::Controller(spec) => {
            let mut provenance = Provenance {
                fts_version: env!("CARGO_PKG_VERSION").into(),
                inputs: Vec::new(),
            };
            let mut hashed =
                |field: &str, role: &str| -> Result<Option<(&str, String)>, PipelineError> {
                    let Some(f) = step.input(field) else {
                        return Ok(None);
                    };
                    let Some(bytes) = inputs.get(field) else {
                        return Ok(None);
                    };
                    provenance.inputs.push(InputHash {
                        role: role.into(),
                        file: f.path.clone(),
                        sha256: sha256_hex(bytes),
                    });
                    let src = source(plan, f);
                    std::str::from_utf8(bytes)
                        .map(|text| Some((text, src.clone())))
                        .map_err(|_| bad(format!("{src}: not UTF-8 text")))
                };
            let inverse = match hashed("hysteresis", "hysteresis_inverse")? {
                Some((text, src)) => Some(parse_model(text, &src)?.model),
                None => None,
            };
            let filter = match hashed("zpetc", "zpetc")? {
                Some((text, src)) => Some(zpetc_json::parse_zpetc(text, &src)?),
                None => None,
            };
            let ts = match (filter.as_ref().map(|f| f.ts), spec.ts) {
                (Some(a), Some(b)) if (a - b).abs() > 1e-12 * a => {
                    return Err(bad(format!(
                        "field 'ts' ({b}) disagrees with the ZPETC's sample time {a}"
                    )));
                }
                (Some(a), _) => a,
                (None, Some(b)) if b > 0.0 => b,
                _ => {
                    return Err(bad(
                        "field 'ts': a positive sample time is needed when no zpetc is given",
                    ));
                }
            };
            let stages = Stages {
                feedback: crate::synth::composite::FeedbackKind::Pid,
                hysteresis_compensation: inverse.is_some(),
                zpetc: filter.is_some(),
            };
            let file = build_controller(
                stages,
                ts,
                spec.pid,
                inverse.as_ref(),
                filter.as_ref(),
                provenance,
            )
            .map_err(bad)?;
            if let Some(f) = out("out") {
                files.push((Some(f), file.to_json_string().into_bytes()));
            }
            if let Some(f) = out("header") {
                files.push((Some(f), to_c_header(&file).into_bytes()));
            }
        }
    }
    Ok(files
        .into_iter()
        .filter_map(|(f, b)| f.map(|f| (f, b)))
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

/// The system in the input file of `field`, with its name for messages.
fn system_input(
    plan: &Plan,
    step: &Step,
    inputs: &BTreeMap<String, Vec<u8>>,
    field: &str,
) -> Result<Option<(StateSpace, String)>, PipelineError> {
    let (Some(f), Some(bytes)) = (step.input(field), inputs.get(field)) else {
        return Ok(None);
    };
    let src = source(plan, f);
    let text = std::str::from_utf8(bytes).map_err(|_| bad(format!("{src}: not UTF-8 text")))?;
    Ok(Some((ss_json::parse_system(text, &src)?, src)))
}

/// Runs a robust-control step (a typed library step) on its inputs' bytes.
fn robust(
    plan: &Plan,
    step: &Step,
    inputs: &BTreeMap<String, Vec<u8>>,
) -> Result<Vec<(FileRef, Vec<u8>)>, PipelineError> {
    let system = |field: &str| -> Result<(StateSpace, String), PipelineError> {
        system_input(plan, step, inputs, field)?
            .ok_or_else(|| bad(format!("field '{field}' is required")))
    };
    let optional = |field: &str| system_input(plan, step, inputs, field);
    let err = |e: StepError| step_error(step, e);
    let ss_file = |sys: &StateSpace| ss_json::ss_to_string(sys).into_bytes();
    let mut files: Vec<(&str, Vec<u8>)> = Vec::new();
    match &step.action {
        Action::Weight(w) => files.push(("out", ss_file(&w.run().map_err(err)?.weight))),
        Action::Hinf(h) => {
            let (p, src) = system("generalized")?;
            files.push(("out", ss_file(&h.run(&p, &src).map_err(err)?.result.k)));
        }
        Action::H2(h) => {
            let (p, src) = system("generalized")?;
            files.push(("out", ss_file(&h.run(&p, &src).map_err(err)?.result.k)));
        }
        Action::C2d(c) => {
            let (sys, src) = system("system")?;
            files.push(("out", ss_file(&c.run(&sys, &src).map_err(err)?.system)));
        }
        Action::Mixsyn(m) => {
            let ((g, src), (ws, _)) = (system("plant")?, system("ws")?);
            let (wu, wt) = (optional("wu")?, optional("wt")?);
            let report = m
                .run(MixsynInputs {
                    plant: &g,
                    ws: &ws,
                    wu: wu.as_ref().map(|w| &w.0),
                    wt: wt.as_ref().map(|w| &w.0),
                    source: &src,
                })
                .map_err(err)?;
            files.push(("out", ss_file(report.controller())));
            files.push(("augmented", ss_file(&report.augmented)));
        }
        Action::SsController(c) => {
            let file = ss_controller(plan, step, c, inputs)?;
            files.push(("out", file.to_json_string().into_bytes()));
            files.push(("header", to_c_header(&file).into_bytes()));
        }
        _ => unreachable!("robust() is called for robust-control steps only"),
    }
    // Only the outputs the manifest names are written.
    Ok(files
        .into_iter()
        .filter_map(|(field, bytes)| step.output(field).map(|f| (f.clone(), bytes)))
        .collect())
}

/// The coefficient file of a `controller` step with a state-space `ss`:
/// inputs hashed in the order `fts emit` records them.
fn ss_controller(
    plan: &Plan,
    step: &Step,
    spec: &SsController,
    inputs: &BTreeMap<String, Vec<u8>>,
) -> Result<ControllerFile, PipelineError> {
    let mut provenance = Provenance {
        fts_version: env!("CARGO_PKG_VERSION").into(),
        inputs: Vec::new(),
    };
    let mut texts = BTreeMap::new();
    for (field, role) in [
        ("hysteresis", "hysteresis_inverse"),
        ("zpetc", "zpetc"),
        ("ss", "state_space"),
    ] {
        let (Some(f), Some(bytes)) = (step.input(field), inputs.get(field)) else {
            continue;
        };
        provenance.inputs.push(InputHash {
            role: role.into(),
            file: f.path.clone(),
            sha256: sha256_hex(bytes),
        });
        let src = source(plan, f);
        let text = std::str::from_utf8(bytes).map_err(|_| bad(format!("{src}: not UTF-8 text")))?;
        texts.insert(field, (text, src));
    }
    let inverse = match texts.get("hysteresis") {
        Some((text, src)) => Some(parse_model(text, src)?.model),
        None => None,
    };
    let filter = match texts.get("zpetc") {
        Some((text, src)) => Some(zpetc_json::parse_zpetc(text, src)?),
        None => None,
    };
    let (ss_text, ss_src) = texts.get("ss").expect("validated: ss is required");
    let k = ss_json::parse_system(ss_text, ss_src)?;
    let report = spec
        .run(ControllerInputs {
            ss: &k,
            ss_source: ss_src,
            hysteresis: inverse.as_ref(),
            zpetc: filter.as_ref(),
            provenance,
        })
        .map_err(|e| step_error(step, e))?;
    Ok(report.file)
}
