//! The `fts.controller/1` JSON as serde document types, and their checked
//! conversion to and from [`ControllerFile`].
//!
//! The ZPETC and hysteresis blocks, the units and the provenance are the
//! library's own types; the feedback blocks have document forms
//! ([`PidDoc`], [`StateSpaceDoc`]) because the file spells them differently
//! from the runtime (per-sample and continuous PID gains side by side,
//! matrices as arrays of rows).
//!
//! Blocks are written through the internally tagged [`Block`]. They are
//! read by dispatching on their `type` here rather than through serde's
//! tagged-enum support, which buffers a block before reading it and so
//! loses the path of an error inside it (dtolnay/path-to-error#1); read this
//! way a type error names its place, e.g. `blocks[2].a[1][0]`.

use super::{
    ControllerFile, DobBlock, Feedback, FeedforwardTableBlock, HysteresisBlock,
    PARALLEL_PID_DISCRETISATION, ParallelPid, Provenance, RepetitiveBlock, StateSpaceBlock, Units,
    ZpetcBlock,
};
use crate::io::InputError;
use crate::io::serde_doc::{At, from_value};
use crate::io::zpetc_json::MAX_PREVIEW;
use crate::runtime::{PidSpec, PlayForm, SsAntiWindup};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// The whole file; `B` is [`Block`] when writing and the still unread
/// [`Value`] of each block when reading.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Document<B> {
    format: String,
    ts: f64,
    /// Derived from the ZPETC block on write; checked against it on read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    preview: Option<u64>,
    units: Units,
    blocks: Vec<B>,
    #[serde(default)]
    provenance: Provenance,
}

/// One block, tagged by its `type`, in signal order.
#[derive(Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub(super) enum Block<'a> {
    Zpetc(&'a ZpetcBlock),
    Repetitive(&'a RepetitiveBlock),
    FeedforwardTable(&'a FeedforwardTableBlock),
    HysteresisInverse(&'a HysteresisBlock),
    Pid(PidDoc),
    StateSpace(StateSpaceDoc),
    Dob(DobDoc),
    NoFeedback(NoFeedbackDoc),
}

/// A `dob` block: the outer controller as a `state_space` block's body
/// under `outer`, the observer's filters and the friction feedforward.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DobDoc {
    outer: StateSpaceDoc,
    q_num: Vec<f64>,
    q_den: Vec<f64>,
    inverse_num: Vec<f64>,
    inverse_den: Vec<f64>,
    delay: usize,
    coulomb: f64,
    viscous: f64,
    smoothing: f64,
    #[serde(default)]
    design: String,
}

impl DobDoc {
    fn new(d: &DobBlock, ts: f64) -> Self {
        Self {
            outer: StateSpaceDoc::new(&d.outer, ts),
            q_num: d.q_num.clone(),
            q_den: d.q_den.clone(),
            inverse_num: d.inverse_num.clone(),
            inverse_den: d.inverse_den.clone(),
            delay: d.delay,
            coulomb: d.coulomb,
            viscous: d.viscous,
            smoothing: d.smoothing,
            design: d.design.clone(),
        }
    }
}

/// The block type names in signal order; `pid`, `state_space` and
/// `no_feedback` (from [`FIRST_FEEDBACK`] on) are alternatives at the same
/// place in the chain.
const ORDER: [&str; 8] = [
    "zpetc",
    "repetitive",
    "feedforward_table",
    "hysteresis_inverse",
    "pid",
    "state_space",
    "dob",
    "no_feedback",
];

/// Where the feedback alternatives start in [`ORDER`].
const FIRST_FEEDBACK: usize = 4;

/// `{"type": "no_feedback"}`: nothing besides its tag.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct NoFeedbackDoc {}

/// A `pid` block: `li21` gains per sample, or `parallel` continuous gains
/// with the per-sample coefficients they discretise to beside them.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PidDoc {
    #[serde(default)]
    form: PidForm,
    kp: f64,
    ki: f64,
    kd: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    derivative_pole: Option<f64>,
    output_min: f64,
    output_max: f64,
    #[serde(default)]
    anti_windup: PidAntiWindup,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    continuous: Option<ContinuousPid>,
}

#[derive(Serialize, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum PidForm {
    #[default]
    Li21,
    Parallel,
}

/// The only anti-windup the PID has; named in the file for people.
#[derive(Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
enum PidAntiWindup {
    #[default]
    ConditionalIntegration,
}

/// The continuous gains of a parallel-form PID.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContinuousPid {
    kp: f64,
    ki: f64,
    kd: f64,
    /// Written as `null` when unfiltered.
    #[serde(default)]
    n: Option<f64>,
    #[serde(default)]
    discretisation: PidDiscretisation,
}

#[derive(Serialize, Deserialize, Default)]
enum PidDiscretisation {
    #[default]
    #[serde(rename = "backward-euler")]
    BackwardEuler,
}

/// A `state_space` block: matrices as arrays of rows, as in `fts.ss/1`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct StateSpaceDoc {
    ts: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    input: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    output: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    states: Option<u64>,
    #[serde(default = "given")]
    discretisation: String,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    output_min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    output_max: Option<f64>,
    #[serde(default = "conditional_update", with = "AntiWindupName")]
    anti_windup: SsAntiWindup,
}

fn given() -> String {
    "given".into()
}

fn conditional_update() -> SsAntiWindup {
    SsAntiWindup::ConditionalUpdate
}

/// The file's names of [`SsAntiWindup`].
#[derive(Serialize, Deserialize)]
#[serde(remote = "SsAntiWindup", rename_all = "kebab-case")]
enum AntiWindupName {
    None,
    ConditionalUpdate,
}

/// The file's names of [`PlayForm`].
#[derive(Serialize, Deserialize)]
#[serde(remote = "PlayForm")]
pub(super) enum OperatorName {
    #[serde(rename = "play-lower")]
    Lower,
    #[serde(rename = "play-symmetric")]
    Symmetric,
}

/// The name the file gives `form`.
pub(super) fn operator_name(form: PlayForm) -> &'static str {
    match form {
        PlayForm::Lower => "play-lower",
        PlayForm::Symmetric => "play-symmetric",
    }
}

/// The name the file gives `a`.
pub(super) fn anti_windup_name(a: SsAntiWindup) -> &'static str {
    match a {
        SsAntiWindup::None => "none",
        SsAntiWindup::ConditionalUpdate => "conditional-update",
    }
}

impl ControllerFile {
    /// The document this file is written as.
    pub(super) fn document(&self) -> Document<Block<'_>> {
        let mut blocks = Vec::new();
        if let Some(z) = &self.zpetc {
            blocks.push(Block::Zpetc(z));
        }
        if let Some(r) = &self.repetitive {
            blocks.push(Block::Repetitive(r));
        }
        if let Some(t) = &self.feedforward_table {
            blocks.push(Block::FeedforwardTable(t));
        }
        if let Some(h) = &self.hysteresis {
            blocks.push(Block::HysteresisInverse(h));
        }
        blocks.push(match &self.feedback {
            Feedback::None => Block::NoFeedback(NoFeedbackDoc {}),
            Feedback::Pid(p) => Block::Pid(PidDoc::li21(p)),
            Feedback::ParallelPid(p) => Block::Pid(PidDoc::parallel(p, self.ts)),
            Feedback::StateSpace(k) => Block::StateSpace(StateSpaceDoc::new(k, self.ts)),
            Feedback::Dob(d) => Block::Dob(DobDoc::new(d, self.ts)),
        });
        Document {
            format: super::CONTROLLER_FORMAT.to_owned(),
            ts: self.ts,
            preview: Some(self.preview() as u64),
            units: self.units.clone(),
            blocks,
            provenance: self.provenance.clone(),
        }
    }
}

/// Reads and checks a document whose `format` has been checked.
pub(super) fn read(value: Value, source: &str) -> Result<ControllerFile, InputError> {
    let top = At { source, path: "" };
    let doc: Document<Value> = from_value(value, top)?;
    let mut chain = Chain::default();
    let mut stages = Stages::default();
    for (i, block) in doc.blocks.into_iter().enumerate() {
        let path = format!("blocks[{i}]");
        let at = At {
            source,
            path: &path,
        };
        stages.read_block(block, &mut chain, at, doc.ts)?;
    }
    let file = ControllerFile {
        ts: doc.ts,
        units: doc.units,
        zpetc: stages.zpetc,
        repetitive: stages.repetitive,
        feedforward_table: stages.feedforward_table,
        hysteresis: stages.hysteresis,
        feedback: stages.feedback.ok_or_else(|| {
            top.err(
                "blocks",
                "missing block \"pid\" or \"state_space\" (or \"no_feedback\" for a feedforward-only controller): every controller ends with its feedback stage",
            )
        })?,
        provenance: doc.provenance,
    };
    check_whole(&file, doc.preview, top)?;
    file.validate(source)?;
    Ok(file)
}

/// What only the whole file can show: a feedforward-only file has a
/// feedforward block, and the declared preview is the ZPETC block's.
fn check_whole(file: &ControllerFile, preview: Option<u64>, at: At<'_>) -> Result<(), InputError> {
    if file.feedback == Feedback::None && file.zpetc.is_none() && file.hysteresis.is_none() {
        return Err(at.err(
            "blocks",
            "a \"no_feedback\" controller needs a feedforward block (\"zpetc\" or \"hysteresis_inverse\")",
        ));
    }
    match preview {
        Some(p) if p != file.preview() as u64 => Err(at.err(
            "preview",
            format!(
                "declares preview {p} but its ZPETC block has {}",
                file.preview()
            ),
        )),
        _ => Ok(()),
    }
}

/// The blocks read so far.
#[derive(Default)]
struct Stages {
    zpetc: Option<ZpetcBlock>,
    repetitive: Option<RepetitiveBlock>,
    feedforward_table: Option<FeedforwardTableBlock>,
    hysteresis: Option<HysteresisBlock>,
    feedback: Option<Feedback>,
}

impl Stages {
    fn read_block(
        &mut self,
        block: Value,
        chain: &mut Chain,
        at: At<'_>,
        ts: f64,
    ) -> Result<(), InputError> {
        let (kind, rest) = split_type(block, at)?;
        chain.admit(&kind).map_err(|m| at.err("type", m))?;
        match kind.as_str() {
            "zpetc" => self.zpetc = Some(zpetc(from_value(rest, at)?, at)?),
            "repetitive" => self.repetitive = Some(from_value(rest, at)?),
            "feedforward_table" => {
                let t: FeedforwardTableBlock = from_value(rest, at)?;
                not_empty(&t.samples, "samples", at)?;
                self.feedforward_table = Some(t);
            }
            "hysteresis_inverse" => self.hysteresis = Some(hysteresis(from_value(rest, at)?, at)?),
            "pid" => self.feedback = Some(from_value::<PidDoc>(rest, at)?.feedback(ts, at)?),
            "state_space" => {
                let k = from_value::<StateSpaceDoc>(rest, at)?.block(ts, at)?;
                self.feedback = Some(Feedback::StateSpace(k));
            }
            "dob" => self.feedback = Some(dob(from_value(rest, at)?, ts, at)?),
            _ => {
                from_value::<NoFeedbackDoc>(rest, at)?;
                self.feedback = Some(Feedback::None);
            }
        }
        Ok(())
    }
}

/// A block's `type` and the rest of it.
fn split_type(block: Value, at: At<'_>) -> Result<(String, Value), InputError> {
    let Value::Object(mut map) = block else {
        return Err(at.err("", "expected an object"));
    };
    match map.remove("type") {
        Some(Value::String(kind)) => Ok((kind, Value::Object(map))),
        Some(_) => Err(at.err("type", "expected a string")),
        None => Err(at.err("type", "missing")),
    }
}

/// Keeps the blocks in signal order with exactly one feedback block.
#[derive(Default)]
struct Chain {
    last_rank: Option<usize>,
    feedback: Option<String>,
}

impl Chain {
    fn admit(&mut self, kind: &str) -> Result<(), String> {
        let is_feedback = ORDER[FIRST_FEEDBACK..].contains(&kind);
        if let Some(first) = &self.feedback
            && is_feedback
        {
            return Err(format!(
                "a second feedback block {kind:?} after {first:?}: exactly one of \"pid\", \"state_space\", \"dob\" and \"no_feedback\" is allowed"
            ));
        }
        let rank = ORDER
            .iter()
            .position(|k| *k == kind)
            .map(|r| r.min(FIRST_FEEDBACK));
        let Some(rank) = rank else {
            return Err(format!(
                "unknown block type {kind:?}; known blocks, in signal order: {}",
                ORDER.join(", ")
            ));
        };
        if self.last_rank.is_some_and(|r| r >= rank) {
            return Err(format!(
                "block {kind:?} is out of order or repeated; blocks must appear in signal order: {}",
                ORDER.join(", ")
            ));
        }
        self.last_rank = Some(rank);
        if is_feedback {
            self.feedback = Some(kind.to_owned());
        }
        Ok(())
    }
}

fn not_empty(values: &[f64], key: &str, at: At<'_>) -> Result<(), InputError> {
    if values.is_empty() {
        return Err(at.err(key, "must not be empty"));
    }
    Ok(())
}

fn zpetc(z: ZpetcBlock, at: At<'_>) -> Result<ZpetcBlock, InputError> {
    if z.preview as u64 > MAX_PREVIEW {
        return Err(at.err(
            "preview",
            format!(
                "{} samples of preview; at most {MAX_PREVIEW} are accepted",
                z.preview
            ),
        ));
    }
    not_empty(&z.num, "num", at)?;
    not_empty(&z.den, "den", at)?;
    Ok(z)
}

fn hysteresis(h: HysteresisBlock, at: At<'_>) -> Result<HysteresisBlock, InputError> {
    not_empty(&h.thresholds, "thresholds", at)?;
    not_empty(&h.weights, "weights", at)?;
    h.validate(at.source, at.path)?;
    Ok(h)
}

impl PidDoc {
    fn li21(p: &PidSpec) -> Self {
        Self {
            form: PidForm::Li21,
            kp: p.kp,
            ki: p.ki,
            kd: p.kd,
            derivative_pole: None,
            output_min: p.output_min,
            output_max: p.output_max,
            anti_windup: PidAntiWindup::ConditionalIntegration,
            continuous: None,
        }
    }

    fn parallel(p: &ParallelPid, ts: f64) -> Self {
        let (spec, pole) = p.per_sample(ts);
        Self {
            form: PidForm::Parallel,
            derivative_pole: pole,
            continuous: Some(ContinuousPid {
                kp: p.kp,
                ki: p.ki,
                kd: p.kd,
                n: p.n,
                discretisation: PidDiscretisation::BackwardEuler,
            }),
            ..Self::li21(&spec)
        }
    }

    /// The feedback stage, the parallel form checked against its
    /// continuous gains.
    fn feedback(self, ts: f64, at: At<'_>) -> Result<Feedback, InputError> {
        if self.form == PidForm::Li21 {
            if self.continuous.is_some() {
                return Err(at.err(
                    "continuous",
                    "only a parallel-form PID has continuous gains",
                ));
            }
            if self.derivative_pole.is_some() {
                return Err(at.err(
                    "derivative_pole",
                    "only a filtered parallel-form PID has a derivative pole",
                ));
            }
            return Ok(Feedback::Pid(PidSpec {
                kp: self.kp,
                ki: self.ki,
                kd: self.kd,
                output_min: self.output_min,
                output_max: self.output_max,
            }));
        }
        let Some(c) = &self.continuous else {
            return Err(at.err(
                "continuous",
                "missing: a parallel-form PID records its continuous gains",
            ));
        };
        let pid = ParallelPid {
            kp: c.kp,
            ki: c.ki,
            kd: c.kd,
            n: c.n,
            output_min: self.output_min,
            output_max: self.output_max,
        };
        pid.validate()
            .map_err(|(k, m)| at.err(&format!("continuous.{k}"), m))?;
        self.check_per_sample(&pid, ts, at)?;
        Ok(Feedback::ParallelPid(pid))
    }

    /// The per-sample coefficients written beside a parallel PID's
    /// continuous gains must be their discretisation (to 1e-12 relative): a
    /// hand edit of one and not the other is refused rather than guessed at.
    fn check_per_sample(&self, pid: &ParallelPid, ts: f64, at: At<'_>) -> Result<(), InputError> {
        let (spec, pole) = pid.per_sample(ts);
        let mut expected = vec![
            ("kp", self.kp, spec.kp),
            ("ki", self.ki, spec.ki),
            ("kd", self.kd, spec.kd),
        ];
        match (self.derivative_pole, pole) {
            (Some(got), Some(want)) => expected.push(("derivative_pole", got, want)),
            (None, Some(_)) => return Err(at.err("derivative_pole", "missing")),
            (Some(_), None) => {
                return Err(at.err(
                    "derivative_pole",
                    "an unfiltered PID (continuous.n null) has no derivative pole",
                ));
            }
            (None, None) => {}
        }
        for (key, got, want) in expected {
            if (got - want).abs() > 1e-12 * want.abs().max(1e-300) {
                return Err(at.err(
                    key,
                    format!(
                        "{got} is not the {PARALLEL_PID_DISCRETISATION} discretisation of the continuous gains at ts = {ts} s ({want}); edit the continuous gains and re-emit"
                    ),
                ));
            }
        }
        Ok(())
    }
}

impl StateSpaceDoc {
    fn new(k: &StateSpaceBlock, ts: f64) -> Self {
        let n = k.order();
        Self {
            ts,
            input: Some("error".into()),
            output: Some("command".into()),
            states: Some(n as u64),
            discretisation: k.discretisation.clone(),
            a: (0..n).map(|i| k.a[i * n..(i + 1) * n].to_vec()).collect(),
            b: k.b.iter().map(|v| vec![*v]).collect(),
            c: vec![k.c.clone()],
            d: vec![vec![k.d]],
            output_min: k.output_min,
            output_max: k.output_max,
            anti_windup: k.anti_windup,
        }
    }

    /// The block, its matrices checked to fit together and its sample time
    /// to be the file's.
    fn block(self, file_ts: f64, at: At<'_>) -> Result<StateSpaceBlock, InputError> {
        let ts = self.ts;
        if (ts - file_ts).abs() > 1e-12 * file_ts {
            return Err(at.err(
                "ts",
                format!(
                    "the state-space controller runs at {ts} s but the file's sample time is {file_ts} s; only discrete controllers at the loop's rate are allowed (fts emit --ss discretises a continuous one)"
                ),
            ));
        }
        for (key, got, want) in [
            ("input", &self.input, "error"),
            ("output", &self.output, "command"),
        ] {
            if let Some(got) = got
                && got != want
            {
                return Err(at.err(key, format!("expected {want:?}, found {got:?}")));
            }
        }
        let (c, d) = self.check_shapes(at)?;
        Ok(StateSpaceBlock {
            b: self.b.iter().map(|r| r[0]).collect(),
            a: self.a.concat(),
            c,
            d,
            output_min: self.output_min,
            output_max: self.output_max,
            anti_windup: self.anti_windup,
            discretisation: self.discretisation,
        })
    }

    /// `A` `n x n`, `B` `n x 1`, `C` `1 x n` (`[]` when `n = 0`), `D` `1 x 1`,
    /// and `states` (when given) `n`; returns `C` and `D`.
    fn check_shapes(&self, at: At<'_>) -> Result<(Vec<f64>, f64), InputError> {
        let n = self.a.len();
        if let Some((i, row)) = self.a.iter().enumerate().find(|(_, r)| r.len() != n) {
            return Err(at.err(
                &format!("a[{i}]"),
                format!(
                    "A must be square: {n} rows but row {i} has {} entries",
                    row.len()
                ),
            ));
        }
        if self.b.len() != n || self.b.iter().any(|r| r.len() != 1) {
            return Err(at.err(
                "b",
                format!("B must be {n} x 1 (one row of one number per state of A)"),
            ));
        }
        let c = match self.c.as_slice() {
            [row] if row.len() == n => row.clone(),
            [] if n == 0 => Vec::new(),
            _ => {
                return Err(at.err(
                    "c",
                    format!("C must be 1 x {n} (one row with one number per state of A)"),
                ));
            }
        };
        let d = match self.d.as_slice() {
            [row] if row.len() == 1 => row[0],
            _ => return Err(at.err("d", "D must be 1 x 1 ([[d]])")),
        };
        if let Some(states) = self.states
            && states != n as u64
        {
            return Err(at.err(
                "states",
                format!("declares {states} states but A is {n} x {n}"),
            ));
        }
        Ok((c, d))
    }
}

/// A feedback stage alone as a tagged block (`pid` or `state_space`), as
/// the multi-axis file writes its axis and coupling controllers.
pub(super) fn feedback_block(feedback: &Feedback, ts: f64) -> Block<'static> {
    match feedback {
        Feedback::None => Block::NoFeedback(NoFeedbackDoc {}),
        Feedback::Pid(p) => Block::Pid(PidDoc::li21(p)),
        Feedback::ParallelPid(p) => Block::Pid(PidDoc::parallel(p, ts)),
        Feedback::StateSpace(k) => Block::StateSpace(StateSpaceDoc::new(k, ts)),
        Feedback::Dob(d) => Block::Dob(DobDoc::new(d, ts)),
    }
}

/// A `dob` block, checked as the runtime loads it (the field named).
fn dob(doc: DobDoc, ts: f64, at: At<'_>) -> Result<Feedback, InputError> {
    let outer_at = At {
        source: at.source,
        path: &format!("{}.outer", at.path),
    };
    let d = DobBlock {
        outer: doc.outer.block(ts, outer_at)?,
        q_num: doc.q_num,
        q_den: doc.q_den,
        inverse_num: doc.inverse_num,
        inverse_den: doc.inverse_den,
        delay: doc.delay,
        coulomb: doc.coulomb,
        viscous: doc.viscous,
        smoothing: doc.smoothing,
        design: doc.design,
    };
    let spec = crate::runtime::FeedbackSpec::Dob(d.runtime_spec(ts));
    if let Err(e) = crate::runtime::RuntimeController::new(&crate::runtime::RuntimeSpec {
        zpetc: None,
        hysteresis: None,
        feedback: spec,
        repetitive: None,
    }) {
        let key = super::runtime_field(&e).replace("state_space.", "outer.");
        return Err(at.err(key.trim_start_matches("dob."), e.to_string()));
    }
    Ok(Feedback::Dob(d))
}

/// Reads one `pid` or `state_space` block at `at` (the file's `ts`),
/// checked as the single-axis file checks it.
pub(super) fn read_feedback(block: Value, at: At<'_>, ts: f64) -> Result<Feedback, InputError> {
    let (kind, rest) = split_type(block, at)?;
    match kind.as_str() {
        "pid" => from_value::<PidDoc>(rest, at)?.feedback(ts, at),
        "state_space" => Ok(Feedback::StateSpace(
            from_value::<StateSpaceDoc>(rest, at)?.block(ts, at)?,
        )),
        "dob" => dob(from_value(rest, at)?, ts, at),
        other => Err(at.err(
            "type",
            format!("expected \"pid\", \"state_space\" or \"dob\", found {other:?}"),
        )),
    }
}
