//! The pipeline manifest (`fts.toml`): named steps, each a `[step.NAME]`
//! table with a `kind`, validated into a [`Plan`] (steps in dependency
//! order). Every error names the manifest, the line and the field.

use super::hash::sha256_hex;
use crate::io::InputError;
use crate::io::timeseries::{
    ColumnRef, DEFAULT_TIME_JITTER, Delimiter, HeaderMode, IoColumns, Layout, TimeUnit,
};
use crate::workflow::identify_ct::IdentifyCt;
use crate::workflow::learning::DesignRepetitive;
use crate::workflow::mechanism::{Amplifier, Bridge, FlexureLoss, Hinge, Lever, Puu3Study};
use crate::workflow::{
    BuildController, C2d, DesignZpetc, H2, Hinf, IdentifyArx, IdentifyHysteresis, IdentifyOe,
    Mixsyn, StepError, Validate, VirtualSweep, VirtualTriangles, Weight,
};
use serde::Deserialize;
use serde::de::DeserializeOwned;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use toml::{Spanned, Value};

/// A file a step reads or writes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileRef {
    /// The manifest field that names it (`data`, `out`, `header`, ...).
    pub field: String,
    /// Path relative to the manifest's folder, normalised, with `/`
    /// separators: the key in the lock file and in provenance records.
    pub path: String,
    /// Manifest line of the field.
    pub line: usize,
}

/// Columns and sample range of a time-series input.
#[derive(Debug, Clone)]
pub struct ColumnSpec {
    /// Column choice.
    pub columns: IoColumns,
    /// First data row used (0-based).
    pub start: usize,
    /// One past the last data row used.
    pub end: Option<usize>,
}

/// `kind = "hysteresis"`: what `fts identify hysteresis` does.
#[derive(Debug, Clone)]
pub struct HysteresisSpec {
    /// Columns of the record.
    pub columns: ColumnSpec,
    /// The identification step.
    pub step: IdentifyHysteresis,
}

/// `kind = "arx"` / `kind = "oe"`: what `fts identify arx|oe` does.
#[derive(Debug, Clone)]
pub struct LinearSpec<T> {
    /// Columns of the record (and of the validation record, if any).
    pub columns: ColumnSpec,
    /// The identification step.
    pub step: T,
}

/// `kind = "mechanism"`: one of the `fts mechanism` calculators, chosen by
/// the field `calculator`.
#[derive(Debug, Clone)]
pub enum MechanismSpec {
    /// `calculator = "flexure-loss"`.
    FlexureLoss(FlexureLoss),
    /// `calculator = "hinge"`.
    Hinge(Hinge),
    /// `calculator = "3puu"`.
    Puu3(Puu3Study),
    /// `calculator = "lever"`.
    Lever(Lever),
    /// `calculator = "bridge"`.
    Bridge(Bridge),
    Amplifier(Amplifier),
}

/// What a step does.
#[derive(Debug, Clone)]
pub enum Action {
    /// Open-loop triangles on the embedded virtual FTS (`t,u,y` CSV, aligned
    /// for the plant's delay).
    VirtualTriangles(VirtualTriangles),
    /// Closed-loop sweep (PID, + HC with `hysteresis`) on the virtual FTS.
    VirtualSweep(VirtualSweep),
    /// Hysteresis identification.
    Hysteresis(Box<HysteresisSpec>),
    /// ARX identification.
    Arx(Box<LinearSpec<IdentifyArx>>),
    /// Output-error identification.
    Oe(Box<LinearSpec<IdentifyOe>>),
    /// Continuous-time identification (SRIVC).
    Ct(Box<LinearSpec<IdentifyCt>>),
    /// A mechanism calculator (its report as JSON).
    Mechanism(Box<MechanismSpec>),
    /// ZPETC design.
    Zpetc(DesignZpetc),
    /// Plug-in repetitive compensator designed on a closed-loop model.
    Repetitive(DesignRepetitive),
    /// Coefficient file: PID, state-space (an `ss` input) or no feedback.
    Controller(BuildController),
    /// A performance weight.
    Weight(Weight),
    /// Mixed-sensitivity H-infinity design.
    Mixsyn(Mixsyn),
    /// H-infinity synthesis on a generalised plant.
    Hinf(Hinf),
    /// H2 synthesis on a generalised plant.
    H2(H2),
    /// Discretisation of a continuous system.
    C2d(C2d),
    /// Multi-axis controller file (contouring with cross-coupled control).
    MultiAxis(crate::workflow::contour::BuildMultiAxis),
}

/// One validated step.
#[derive(Debug, Clone)]
pub struct Step {
    /// The table name (`[step.NAME]`).
    pub name: String,
    /// The `kind` string.
    pub kind: String,
    /// Manifest line of the step's table.
    pub line: usize,
    /// What it does.
    pub action: Action,
    /// Files it reads, in field order.
    pub inputs: Vec<FileRef>,
    /// Files it writes.
    pub outputs: Vec<FileRef>,
    /// SHA-256 of the step's canonical settings (its manifest table as
    /// sorted JSON, plus the fts version).
    pub settings_sha256: String,
    /// Manifest line of each field, for errors found while running.
    pub field_lines: BTreeMap<String, usize>,
}

impl Step {
    /// The manifest field an input path came from.
    pub fn input(&self, field: &str) -> Option<&FileRef> {
        self.inputs.iter().find(|f| f.field == field)
    }

    /// The output written for `field`.
    pub fn output(&self, field: &str) -> Option<&FileRef> {
        self.outputs.iter().find(|f| f.field == field)
    }
}

/// A manifest, validated: steps in an order where every step comes after
/// the steps whose outputs it reads.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The manifest file as given.
    pub manifest: PathBuf,
    /// The folder every path is relative to.
    pub base: PathBuf,
    /// The lock file (`<manifest stem>.lock` beside the manifest).
    pub lock: PathBuf,
    /// Steps in build order.
    pub steps: Vec<Step>,
}

impl Plan {
    /// Absolute-or-cwd-relative location of a manifest-relative path.
    pub fn locate(&self, rel: &str) -> PathBuf {
        if self.base == Path::new(".") {
            PathBuf::from(rel)
        } else {
            self.base.join(rel)
        }
    }

    /// The step that writes `path`, if any.
    pub fn producer(&self, path: &str) -> Option<&Step> {
        self.steps
            .iter()
            .find(|s| s.outputs.iter().any(|o| o.path == path))
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    #[serde(default)]
    step: BTreeMap<String, Spanned<BTreeMap<String, Spanned<Value>>>>,
}

/// A value for an error message: scalars as written, tables and lists by type.
fn shown(v: &Value) -> String {
    match v {
        Value::Integer(i) => i.to_string(),
        Value::Float(x) => x.to_string(),
        Value::Boolean(b) => b.to_string(),
        Value::String(s) => format!("{s:?}"),
        other => other.type_str().to_string(),
    }
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())]
        .bytes()
        .filter(|&b| b == b'\n')
        .count()
        + 1
}

/// Reads the fields of one step table.
struct Fields<'a> {
    source: &'a str,
    text: &'a str,
    step: &'a str,
    /// The table's line.
    line: usize,
    map: BTreeMap<String, Spanned<Value>>,
    /// Manifest line of each field.
    lines: BTreeMap<String, usize>,
    inputs: Vec<FileRef>,
    outputs: Vec<FileRef>,
}

impl<'a> Fields<'a> {
    fn new(
        source: &'a str,
        text: &'a str,
        step: &'a str,
        table: Spanned<BTreeMap<String, Spanned<Value>>>,
    ) -> Self {
        let line = line_of(text, table.span().start);
        let map = table.into_inner();
        let lines = map
            .iter()
            .map(|(k, v)| (k.clone(), line_of(text, v.span().start)))
            .collect();
        Fields {
            source,
            text,
            step,
            line,
            map,
            lines,
            inputs: Vec::new(),
            outputs: Vec::new(),
        }
    }

    /// Manifest line of `key`, or the table's when the key is absent.
    fn line_of_field(&self, key: &str) -> usize {
        self.lines.get(key).copied().unwrap_or(self.line)
    }

    /// A library step's settings error, naming its field and line.
    fn step_error(&self, e: StepError) -> InputError {
        match e {
            StepError::Input {
                field: Some(k),
                message,
            } => self.err(k, self.line_of_field(k), keys(&message)),
            other => self.step_err(self.line, keys(&other.to_string())),
        }
    }
    fn err(&self, key: &str, line: usize, message: impl Into<String>) -> InputError {
        InputError::new(self.source, message)
            .at_line(line)
            .in_field(format!("step.{}.{key}", self.step))
    }

    fn take(&mut self, key: &str) -> Option<(Value, usize)> {
        self.map.remove(key).map(|v| {
            let line = line_of(self.text, v.span().start);
            (v.into_inner(), line)
        })
    }

    fn f64_opt(&mut self, key: &str) -> Result<Option<f64>, InputError> {
        let Some((v, line)) = self.take(key) else {
            return Ok(None);
        };
        let x = match v {
            Value::Float(x) => x,
            Value::Integer(i) => i as f64,
            other => {
                return Err(self.err(
                    key,
                    line,
                    format!("expected a number, found {}", other.type_str()),
                ));
            }
        };
        if !x.is_finite() {
            return Err(self.err(key, line, format!("expected a finite number, got {x}")));
        }
        Ok(Some(x))
    }

    fn f64(&mut self, key: &str, default: f64) -> Result<f64, InputError> {
        Ok(self.f64_opt(key)?.unwrap_or(default))
    }

    fn line(&self, key: &str) -> usize {
        self.map
            .get(key)
            .map_or(0, |v| line_of(self.text, v.span().start))
    }

    fn u64_opt(&mut self, key: &str) -> Result<Option<u64>, InputError> {
        let Some((v, line)) = self.take(key) else {
            return Ok(None);
        };
        match v {
            Value::Integer(i) if i >= 0 => Ok(Some(i as u64)),
            other => Err(self.err(
                key,
                line,
                format!(
                    "expected a non-negative whole number, found {}",
                    match other {
                        Value::Integer(i) => i.to_string(),
                        o => o.type_str().to_string(),
                    }
                ),
            )),
        }
    }

    fn usize_opt(&mut self, key: &str) -> Result<Option<usize>, InputError> {
        Ok(self.u64_opt(key)?.map(|x| x as usize))
    }

    fn bool(&mut self, key: &str, default: bool) -> Result<bool, InputError> {
        match self.take(key) {
            None => Ok(default),
            Some((Value::Boolean(b), _)) => Ok(b),
            Some((other, line)) => Err(self.err(
                key,
                line,
                format!("expected true or false, found {}", other.type_str()),
            )),
        }
    }

    fn string_opt(&mut self, key: &str) -> Result<Option<(String, usize)>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some((Value::String(s), line)) => Ok(Some((s, line))),
            Some((other, line)) => Err(self.err(
                key,
                line,
                format!("expected a string, found {}", other.type_str()),
            )),
        }
    }

    fn choice<T: Copy>(
        &mut self,
        key: &str,
        options: &[(&str, T)],
    ) -> Result<Option<T>, InputError> {
        let Some((s, line)) = self.string_opt(key)? else {
            return Ok(None);
        };
        options
            .iter()
            .find(|(name, _)| *name == s)
            .map(|(_, v)| Some(*v))
            .ok_or_else(|| {
                let names: Vec<String> = options.iter().map(|(n, _)| format!("{n:?}")).collect();
                self.err(
                    key,
                    line,
                    format!("expected one of {}, got {s:?}", names.join(", ")),
                )
            })
    }

    fn column(&mut self, key: &str) -> Result<Option<ColumnRef>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some((Value::String(s), _)) => Ok(Some(ColumnRef::parse(&s))),
            Some((Value::Integer(i), _)) if i >= 1 => Ok(Some(ColumnRef::Index(i as usize))),
            Some((other, line)) => Err(self.err(
                key,
                line,
                format!(
                    "expected a column name or a 1-based column number, found {}",
                    shown(&other)
                ),
            )),
        }
    }

    fn columns(&mut self) -> Result<ColumnSpec, InputError> {
        for (old, new) in [
            ("input", "input_col"),
            ("output", "output_col"),
            ("time", "time_col"),
        ] {
            if let Some((_, line)) = self.take(old) {
                return Err(self.err(
                    old,
                    line,
                    format!("renamed: the column is chosen with '{new}'"),
                ));
            }
        }
        let delimiter = self.choice(
            "delimiter",
            &[
                ("comma", Delimiter::Comma),
                ("semicolon", Delimiter::Semicolon),
                ("tab", Delimiter::Tab),
                ("whitespace", Delimiter::Whitespace),
            ],
        )?;
        let time_unit = self.choice(
            "time_unit",
            &[
                ("s", TimeUnit::Seconds),
                ("ms", TimeUnit::Milliseconds),
                ("us", TimeUnit::Microseconds),
            ],
        )?;
        let jitter_line = self.line("time_jitter");
        let header_row_line = self.line("header_row");
        let layout = Layout {
            header: if self.bool("no_header", false)? {
                HeaderMode::Absent
            } else {
                HeaderMode::Detect
            },
            header_row: self.usize_opt("header_row")?,
            delimiter,
            skip_rows: self.usize_opt("skip_rows")?,
            time_unit,
            time_jitter: self.f64("time_jitter", DEFAULT_TIME_JITTER)?,
        };
        layout
            .validate()
            .map_err(|m| match m.strip_prefix("header row: ") {
                Some(m) => self.err("header_row", header_row_line, m.to_owned()),
                None => self.err("time_jitter", jitter_line, m),
            })?;
        let columns = IoColumns {
            input: self.column("input_col")?,
            output: self.column("output_col")?,
            time: self.column("time_col")?,
            layout,
        };
        let start = self.usize_opt("start")?.unwrap_or(0);
        let end = self.usize_opt("end")?;
        Ok(ColumnSpec {
            columns,
            start,
            end,
        })
    }

    fn path(&mut self, key: &str) -> Result<Option<FileRef>, InputError> {
        let Some((s, line)) = self.string_opt(key)? else {
            return Ok(None);
        };
        let path = normalise(&s).ok_or_else(|| {
            self.err(
                key,
                line,
                format!("expected a file path relative to the manifest, got {s:?}"),
            )
        })?;
        Ok(Some(FileRef {
            field: key.to_string(),
            path,
            line,
        }))
    }

    fn input(&mut self, key: &str, required: bool, step_line: usize) -> Result<(), InputError> {
        match self.path(key)? {
            Some(f) => self.inputs.push(f),
            None if required => {
                return Err(self.err(key, step_line, "missing: the input file of this step"));
            }
            None => {}
        }
        Ok(())
    }

    fn output(&mut self, key: &str, required: bool, step_line: usize) -> Result<(), InputError> {
        match self.path(key)? {
            Some(f) => self.outputs.push(f),
            None if required => {
                return Err(self.err(key, step_line, "missing: the file this step writes"));
            }
            None => {}
        }
        Ok(())
    }

    /// The remaining fields, deserialised into a library step and validated.
    /// An error names the field at fault: the one that fails on its own, or
    /// the one a validation error is about.
    fn typed<T: DeserializeOwned + Validate>(&mut self) -> Result<T, InputError> {
        self.typed_checked(|_: &T| Ok(()))
    }

    /// [`Self::typed`] with a `check` of the settings against the step's
    /// inputs first (its error is the more telling one).
    fn typed_checked<T: DeserializeOwned + Validate>(
        &mut self,
        check: impl Fn(&T) -> Result<(), StepError>,
    ) -> Result<T, InputError> {
        let table: toml::Table = std::mem::take(&mut self.map)
            .into_iter()
            .map(|(k, v)| (k, v.into_inner()))
            .collect();
        let settings: T = Value::Table(table.clone()).try_into().map_err(|e| {
            let alone_fails = |(k, v): &(&String, &Value)| {
                let one = toml::Table::from_iter([((*k).clone(), (*v).clone())]);
                Value::Table(one).try_into::<T>().is_err()
            };
            let message = e.to_string().trim().to_string();
            match table.iter().find(alone_fails) {
                Some((k, _)) => self.err(k, self.line_of_field(k), message),
                None => self.step_err(self.line, message),
            }
        })?;
        check(&settings)
            .and_then(|()| settings.validate())
            .map_err(|e| self.step_error(e))?;
        Ok(settings)
    }

    fn step_err(&self, line: usize, message: impl Into<String>) -> InputError {
        InputError::new(self.source, message)
            .at_line(line)
            .in_field(format!("step.{}", self.step))
    }

    /// Unknown fields are errors (a typo must not silently fall back to a default).
    fn finish(self) -> Result<(Vec<FileRef>, Vec<FileRef>), InputError> {
        if let Some((key, v)) = self.map.iter().next() {
            return Err(self.err(
                key,
                line_of(self.text, v.span().start),
                "unknown field for this kind of step",
            ));
        }
        Ok((self.inputs, self.outputs))
    }
}

/// A step's message with the settings it names written as manifest keys.
pub(crate) fn keys(message: &str) -> String {
    crate::workflow::render_settings(message, |k| format!("'{k}'"))
}

/// Lexically normalised relative path with `/` separators; `None` for an
/// empty or absolute path.
fn normalise(s: &str) -> Option<String> {
    let p = Path::new(s);
    if s.trim().is_empty() || p.is_absolute() || s.starts_with('/') || s.starts_with('\\') {
        return None;
    }
    let mut parts: Vec<String> = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if parts.last().is_some_and(|l| l != "..") {
                    parts.pop();
                } else {
                    parts.push("..".into());
                }
            }
            Component::Normal(n) => parts.push(n.to_string_lossy().replace('\\', "/")),
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    if parts.is_empty() || parts.last().is_some_and(|l| l == "..") {
        return None;
    }
    Some(parts.join("/"))
}

/// The step kinds, as listed in errors.
const KINDS: &str = "\"virtual-triangles\", \"virtual-sweep\", \"hysteresis\", \"arx\", \"oe\", \"ct\", \"zpetc\", \"repetitive\", \"controller\", \"weight\", \"mixsyn\", \"hinf\", \"h2\", \"c2d\", \"mechanism\", \"multiaxis\"";

/// The step table's canonical settings hash: the table as JSON (sorted
/// keys), the step name and the fts version.
fn settings_hash(name: &str, table: &BTreeMap<String, Spanned<Value>>) -> String {
    let plain: BTreeMap<&str, &Value> = table
        .iter()
        .map(|(k, v)| (k.as_str(), v.get_ref()))
        .collect();
    let canonical = serde_json::json!({
        "fts_version": env!("CARGO_PKG_VERSION"),
        "step": name,
        "settings": plain,
    });
    sha256_hex(canonical.to_string().as_bytes())
}

fn step(
    source: &str,
    text: &str,
    name: &str,
    table: Spanned<BTreeMap<String, Spanned<Value>>>,
) -> Result<Step, InputError> {
    let settings_sha256 = settings_hash(name, table.get_ref());
    let mut f = Fields::new(source, text, name, table);
    let (line, field_lines) = (f.line, f.lines.clone());
    let (kind, kind_line) = f
        .string_opt("kind")?
        .ok_or_else(|| f.err("kind", line, format!("missing: one of {KINDS}")))?;
    let action = match kind.as_str() {
        "virtual-triangles" => virtual_triangles(&mut f),
        "virtual-sweep" => virtual_sweep(&mut f),
        "hysteresis" => hysteresis(&mut f),
        "arx" => linear(&mut f).map(Action::Arx),
        "oe" => linear(&mut f).map(Action::Oe),
        "ct" => linear(&mut f).map(Action::Ct),
        "mechanism" => mechanism(&mut f),
        "zpetc" => zpetc(&mut f),
        "repetitive" => repetitive(&mut f),
        "controller" => controller(&mut f),
        "weight" => weight(&mut f),
        "mixsyn" => mixsyn(&mut f),
        "hinf" => synthesis(&mut f).map(Action::Hinf),
        "h2" => synthesis(&mut f).map(Action::H2),
        "c2d" => c2d(&mut f),
        "multiaxis" => multiaxis(&mut f),
        other => Err(f.err(
            "kind",
            kind_line,
            format!("unknown kind {other:?}; expected one of {KINDS}"),
        )),
    }?;
    let (inputs, outputs) = f.finish()?;
    Ok(Step {
        name: name.to_string(),
        kind,
        line,
        action,
        inputs,
        outputs,
        settings_sha256,
        field_lines,
    })
}

/// Declares a step's files: inputs and outputs, each `(field, required)`.
fn files(
    f: &mut Fields<'_>,
    inputs: &[(&str, bool)],
    outputs: &[(&str, bool)],
) -> Result<(), InputError> {
    let line = f.line;
    for &(key, required) in inputs {
        f.input(key, required, line)?;
    }
    for &(key, required) in outputs {
        f.output(key, required, line)?;
    }
    Ok(())
}

fn virtual_triangles(f: &mut Fields<'_>) -> Result<Action, InputError> {
    files(f, &[], &[("out", true)])?;
    Ok(Action::VirtualTriangles(f.typed()?))
}

fn virtual_sweep(f: &mut Fields<'_>) -> Result<Action, InputError> {
    files(f, &[("hysteresis", false)], &[("out", true)])?;
    Ok(Action::VirtualSweep(f.typed()?))
}

fn hysteresis(f: &mut Fields<'_>) -> Result<Action, InputError> {
    let columns = f.columns()?;
    files(f, &[("data", true)], &[("out", true)])?;
    let step = f.typed()?;
    Ok(Action::Hysteresis(Box::new(HysteresisSpec {
        columns,
        step,
    })))
}

fn linear<T: DeserializeOwned + Validate>(
    f: &mut Fields<'_>,
) -> Result<Box<LinearSpec<T>>, InputError> {
    let columns = f.columns()?;
    files(f, &[("data", true), ("validate", false)], &[("out", true)])?;
    let step = f.typed()?;
    Ok(Box::new(LinearSpec { columns, step }))
}

fn zpetc(f: &mut Fields<'_>) -> Result<Action, InputError> {
    files(f, &[("tf", true)], &[("out", true)])?;
    Ok(Action::Zpetc(f.typed()?))
}

/// `kind = "repetitive"`: what `fts repetitive --tf` does.
fn repetitive(f: &mut Fields<'_>) -> Result<Action, InputError> {
    files(f, &[("tf", true)], &[("out", true)])?;
    Ok(Action::Repetitive(f.typed()?))
}

/// `kind = "controller"`: what `fts emit` does, its input options as input
/// fields; it writes `out`, `header` or both.
fn controller(f: &mut Fields<'_>) -> Result<Action, InputError> {
    let inputs = ["hysteresis", "zpetc", "closed_loop", "ss", "repetitive"].map(|k| (k, false));
    files(f, &inputs, &[("out", false), ("header", false)])?;
    if f.outputs.is_empty() {
        return Err(f.err(
            "out",
            f.line,
            "missing: a controller step writes `out` (fts.controller/1 JSON), `header` (C header) or both",
        ));
    }
    let given = |field: &str| f.inputs.iter().find(|i| i.field == field);
    if let (Some(_), Some(cl)) = (given("zpetc"), given("closed_loop")) {
        return Err(f.err(
            "closed_loop",
            cl.line,
            "give one ZPETC: 'zpetc' (a filter) or 'closed_loop' (a model to build it from), not both",
        ));
    }
    let has_ss = f.inputs.iter().any(|i| i.field == "ss");
    legacy_pid_form(f, has_ss);
    let step = f.typed_checked(|s: &BuildController| s.feedback_kind(has_ss).map(|_| ()))?;
    Ok(Action::Controller(step))
}

/// Manifests written before `pid_form` existed gave \[Li21\] per-sample
/// gains without saying so: PID gains without a form (and without `ss` or
/// `feedback`) read as `pid_form = "li21"`. The settings hash is of the
/// table as written, so their lock entries stay valid.
fn legacy_pid_form(f: &mut Fields<'_>, has_ss: bool) {
    let given = |k: &str| f.map.contains_key(k);
    let gains = ["kp", "ki", "kd"].iter().any(|k| given(k));
    if gains && !has_ss && !given("pid_form") && !given("feedback") {
        let li21 = Spanned::new(0..0, Value::String("li21".into()));
        f.map.insert("pid_form".into(), li21);
        f.lines.insert("pid_form".into(), f.line);
    }
}

fn weight(f: &mut Fields<'_>) -> Result<Action, InputError> {
    files(f, &[], &[("out", true)])?;
    Ok(Action::Weight(f.typed()?))
}

fn mixsyn(f: &mut Fields<'_>) -> Result<Action, InputError> {
    let inputs = [("plant", true), ("ws", true), ("wu", false), ("wt", false)];
    files(f, &inputs, &[("out", true), ("augmented", false)])?;
    Ok(Action::Mixsyn(f.typed()?))
}

/// `hinf` and `h2`: a controller for a generalised plant.
fn synthesis<T: DeserializeOwned + Validate>(f: &mut Fields<'_>) -> Result<T, InputError> {
    files(f, &[("generalized", true)], &[("out", true)])?;
    f.typed()
}

/// `kind = "mechanism"`: `calculator` picks the `fts mechanism` command;
/// the other fields are its settings; `out` receives its JSON report.
fn mechanism(f: &mut Fields<'_>) -> Result<Action, InputError> {
    #[derive(Clone, Copy)]
    enum Which {
        FlexureLoss,
        Hinge,
        Puu3,
        Lever,
        Bridge,
        Amplifier,
    }
    let which = f
        .choice(
            "calculator",
            &[
                ("flexure-loss", Which::FlexureLoss),
                ("hinge", Which::Hinge),
                ("3puu", Which::Puu3),
                ("lever", Which::Lever),
                ("bridge", Which::Bridge),
                ("amplifier", Which::Amplifier),
            ],
        )?
        .ok_or_else(|| {
            f.err(
                "calculator",
                f.line,
                "missing: one of \"flexure-loss\", \"hinge\", \"3puu\", \"lever\", \"bridge\", \"amplifier\"",
            )
        })?;
    files(f, &[], &[("out", true)])?;
    let spec = match which {
        Which::FlexureLoss => MechanismSpec::FlexureLoss(f.typed()?),
        Which::Hinge => MechanismSpec::Hinge(f.typed()?),
        Which::Puu3 => MechanismSpec::Puu3(f.typed()?),
        Which::Lever => MechanismSpec::Lever(f.typed()?),
        Which::Bridge => MechanismSpec::Bridge(f.typed()?),
        Which::Amplifier => MechanismSpec::Amplifier(f.typed()?),
    };
    Ok(Action::Mechanism(Box::new(spec)))
}

fn c2d(f: &mut Fields<'_>) -> Result<Action, InputError> {
    files(f, &[("system", true)], &[("out", true)])?;
    Ok(Action::C2d(f.typed()?))
}

/// `kind = "multiaxis"`: the multi-axis controller file of `fts contour -o`
/// from per-axis controller systems `x`, `y`, `z` and `cross` (each
/// optional: the step's PID gains otherwise); writes `out`, `header` or both.
fn multiaxis(f: &mut Fields<'_>) -> Result<Action, InputError> {
    let inputs = ["x", "y", "z", "cross"].map(|k| (k, false));
    files(f, &inputs, &[("out", false), ("header", false)])?;
    if f.outputs.is_empty() {
        return Err(f.err(
            "out",
            f.line,
            "missing: a multiaxis step writes `out` (fts.multiaxis-controller/1 JSON), `header` (C header) or both",
        ));
    }
    multiaxis_contradictions(f)?;
    Ok(Action::MultiAxis(f.typed()?))
}

/// A controller file and the gains it replaces, or a coupling controller
/// with `coupled = false`, given together: one of them would be ignored
/// silently, so the step is refused naming both.
fn multiaxis_contradictions(f: &Fields<'_>) -> Result<(), InputError> {
    let given = |key: &str| f.inputs.iter().find(|r| r.field == key).map(|r| r.line);
    for (file, gains) in [
        ("x", "pid_x"),
        ("y", "pid_y"),
        ("z", "pid_z"),
        ("cross", "cross_coupling"),
    ] {
        if let (Some(file_line), Some(line)) = (given(file), f.lines.get(gains).copied())
            && f.map.contains_key(gains)
        {
            return Err(f.err(
                gains,
                line,
                format!(
                    "`{gains}` and the controller file `{file}` (line {file_line}) both set this controller; give one"
                ),
            ));
        }
    }
    let uncoupled = matches!(
        f.map.get("coupled").map(|v| v.get_ref()),
        Some(Value::Boolean(false))
    );
    for key in ["cross", "cross_coupling"] {
        let line = given(key).or_else(|| f.map.contains_key(key).then(|| f.line_of_field(key)));
        if let (true, Some(line)) = (uncoupled, line) {
            return Err(f.err(
                key,
                line,
                format!(
                    "`{key}` sets the cross-coupling controller, but `coupled = false` (line {}) writes none; give one",
                    f.line_of_field("coupled")
                ),
            ));
        }
    }
    Ok(())
}

/// Parses and validates a manifest. `source` names it in errors; `base` is
/// the folder its paths are relative to (used to check that inputs no step
/// produces exist).
pub fn parse_manifest(text: &str, manifest: &Path) -> Result<Plan, InputError> {
    let source = manifest.display().to_string();
    let base = match manifest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let steps = read_steps(text, &source)?;
    let lock_name = format!(
        "{}.lock",
        manifest
            .file_stem()
            .map_or_else(|| "fts".into(), |s| s.to_string_lossy())
    );
    let manifest_name = manifest
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let producer = producers(&steps, &source, [lock_name.as_str(), &manifest_name])?;
    let deps = dependencies(&steps, &producer, &base, &source)?;
    let order = build_order(&steps, &deps, &source)?;
    let mut slots: Vec<Option<Step>> = steps.into_iter().map(Some).collect();
    let steps = order
        .into_iter()
        .map(|i| slots[i].take().expect("each step once"))
        .collect();
    Ok(Plan {
        manifest: manifest.to_path_buf(),
        lock: if base == Path::new(".") {
            PathBuf::from(lock_name)
        } else {
            base.join(lock_name)
        },
        base,
        steps,
    })
}

/// The manifest's steps in declaration order, so independent steps run in
/// the order written.
fn read_steps(text: &str, source: &str) -> Result<Vec<Step>, InputError> {
    let raw: RawManifest = toml::from_str(text).map_err(|e| {
        let err = InputError::new(source, e.message().trim().to_string());
        match e.span() {
            Some(span) => err.at_line(line_of(text, span.start)),
            None => err,
        }
    })?;
    if raw.step.is_empty() {
        return Err(InputError::new(
            source,
            "no steps: a manifest declares at least one [step.NAME] table",
        ));
    }
    let mut steps = raw
        .step
        .into_iter()
        .map(|(name, table)| step(source, text, &name, table))
        .collect::<Result<Vec<_>, _>>()?;
    steps.sort_by_key(|s| s.line);
    Ok(steps)
}

/// Who writes what: the step writing each output path. Two steps writing
/// one file, or a step writing the manifest or its lock (`reserved`), are
/// errors.
fn producers<'a>(
    steps: &'a [Step],
    source: &str,
    reserved: [&str; 2],
) -> Result<BTreeMap<&'a str, usize>, InputError> {
    let mut producer: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, s) in steps.iter().enumerate() {
        for o in &s.outputs {
            let err = |m: String| {
                InputError::new(source, m)
                    .at_line(o.line)
                    .in_field(format!("step.{}.{}", s.name, o.field))
            };
            if reserved.contains(&o.path.as_str()) {
                return Err(err(format!(
                    "{:?} is the manifest or its lock file, not an output",
                    o.path
                )));
            }
            if let Some(&j) = producer.get(o.path.as_str()) {
                return Err(err(format!(
                    "{:?} is already written by step {:?} (line {})",
                    o.path, steps[j].name, steps[j].line
                )));
            }
            producer.insert(&o.path, i);
        }
    }
    Ok(producer)
}

/// The steps each step reads from; an input that no step writes must exist.
fn dependencies(
    steps: &[Step],
    producer: &BTreeMap<&str, usize>,
    base: &Path,
    source: &str,
) -> Result<Vec<BTreeSet<usize>>, InputError> {
    let mut deps: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); steps.len()];
    for (i, s) in steps.iter().enumerate() {
        for inp in &s.inputs {
            match producer.get(inp.path.as_str()) {
                Some(&j) => {
                    deps[i].insert(j);
                }
                None if !base.join(&inp.path).is_file() => {
                    return Err(InputError::new(
                        source,
                        format!(
                            "input {:?} does not exist (relative to {}) and no step writes it",
                            inp.path,
                            base.display()
                        ),
                    )
                    .at_line(inp.line)
                    .in_field(format!("step.{}.{}", s.name, inp.field)));
                }
                None => {}
            }
        }
    }
    Ok(deps)
}

/// A build order by Kahn's algorithm, ties in declaration order; a cycle is
/// an error naming its steps.
fn build_order(
    steps: &[Step],
    deps: &[BTreeSet<usize>],
    source: &str,
) -> Result<Vec<usize>, InputError> {
    let n = steps.len();
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    while order.len() < n {
        let Some(i) = (0..n).find(|&i| !done[i] && deps[i].iter().all(|&j| done[j])) else {
            return Err(cycle_error(steps, deps, &done, source));
        };
        done[i] = true;
        order.push(i);
    }
    Ok(order)
}

/// The cycle among the unfinished steps: follow unfinished dependencies
/// until a step repeats.
fn cycle_error(
    steps: &[Step],
    deps: &[BTreeSet<usize>],
    done: &[bool],
    source: &str,
) -> InputError {
    let mut path = vec![
        (0..steps.len())
            .find(|&i| !done[i])
            .expect("unfinished step"),
    ];
    loop {
        let last = *path.last().expect("non-empty");
        let next = *deps[last]
            .iter()
            .find(|&&j| !done[j])
            .expect("an unfinished step has an unfinished dependency");
        if let Some(pos) = path.iter().position(|&p| p == next) {
            let cycle = &path[pos..];
            let first = cycle[0];
            let mut names: Vec<&str> = cycle.iter().map(|&k| steps[k].name.as_str()).collect();
            names.push(&steps[first].name);
            return InputError::new(
                source,
                format!(
                    "the steps form a cycle: {} (each step reads a file the next one writes)",
                    names.join(" -> ")
                ),
            )
            .at_line(steps[first].line)
            .in_field(format!("step.{}", steps[first].name));
        }
        path.push(next);
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn normalises_paths() {
        assert_eq!(normalise("./a/b/../c.csv").as_deref(), Some("a/c.csv"));
        assert_eq!(
            normalise("../elsewhere/x.csv").as_deref(),
            Some("../elsewhere/x.csv")
        );
        assert_eq!(normalise("/abs.csv"), None);
        assert_eq!(normalise(""), None);
        assert_eq!(normalise("a/.."), None);
    }

    pub fn line_numbers() {
        assert_eq!(line_of("a\nb\nc", 0), 1);
        assert_eq!(line_of("a\nb\nc", 2), 2);
        assert_eq!(line_of("a\nb\nc", 4), 3);
    }
}
