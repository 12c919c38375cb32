//! The controller coefficient file `fts.controller/1` and its C header form
//! (docs/formats.md).
//!
//! The JSON lists the blocks in signal order (ZPETC pre-filter, inverse
//! hysteresis feedforward, PID), each with every coefficient the real-time
//! loop needs, plus units, sample time, preview and provenance (fts version,
//! SHA-256 of each input file). Keys are written in a fixed order and floats
//! in the shortest form that parses back to the same `f64`, so regenerating
//! from the same inputs gives the same bytes. The C header carries the same
//! numbers (shortest round-trip decimal literals, exact under a correctly
//! rounded `strtod`), and [`parse_c_header`] reads them back for the
//! four-way consistency test.

use super::InputError;
use super::tf_json::{check_format, get_f64_array, get_str};
use crate::runtime::{
    FeedbackSpec, HysteresisSpec, PidFilteredSpec, PidSpec, PlayForm, RuntimeSpec, SsAntiWindup,
    StateSpaceSpec, ZpetcSpec,
};
use serde_json::{Map, Value, json};
use std::fmt::Write;

/// The format tag.
pub const CONTROLLER_FORMAT: &str = "fts.controller/1";

/// Units of the loop's signals.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Units {
    /// Reference (and ZPETC output), e.g. `um`.
    pub reference: String,
    /// Measurement, e.g. `um`.
    pub measurement: String,
    /// Command, e.g. `V`.
    pub command: String,
}

impl Default for Units {
    fn default() -> Self {
        Self {
            reference: "um".into(),
            measurement: "um".into(),
            command: "V".into(),
        }
    }
}

/// One input file the coefficients were made from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputHash {
    /// What it was used for (`zpetc`, `hysteresis_inverse`, ...).
    pub role: String,
    /// The file name as given.
    pub file: String,
    /// SHA-256 of its bytes, lower-case hex.
    pub sha256: String,
}

/// Where the coefficients came from.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Provenance {
    /// The fts version that wrote the file.
    pub fts_version: String,
    /// Hashes of the inputs.
    pub inputs: Vec<InputHash>,
}

/// ZPETC pre-filter block.
#[derive(Debug, Clone, PartialEq)]
pub struct ZpetcBlock {
    /// Samples of reference look-ahead.
    pub preview: usize,
    /// Causal numerator, ascending `z^-1`.
    pub num: Vec<f64>,
    /// Causal denominator, ascending `z^-1`.
    pub den: Vec<f64>,
}

/// Inverse hysteresis feedforward block.
#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisBlock {
    /// Model kind name (`pi`, `mpi-cbrt`, `mpi-deadzone`), for people.
    pub model: String,
    /// Play operator form.
    pub operator: PlayForm,
    /// Play thresholds.
    pub thresholds: Vec<f64>,
    /// Play weights.
    pub weights: Vec<f64>,
    /// Cube-root gain.
    pub cbrt_gain: f64,
    /// Output offset.
    pub offset: f64,
    /// Input offset.
    pub input_offset: f64,
    /// Dead-zone thresholds (empty without an output stage).
    pub dead_zone_thresholds: Vec<f64>,
    /// Dead-zone weights.
    pub dead_zone_weights: Vec<f64>,
}

/// Discrete state-space feedback controller block (SISO, error in, command
/// out): `v = C x + D e`, `x <- A x + B e`, `u = clamp(u_ff + v)`,
/// `e = r_f - y`. Its sample time is the file's.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpaceBlock {
    /// `A`, `n x n`, row-major.
    pub a: Vec<f64>,
    /// `B`, `n x 1`.
    pub b: Vec<f64>,
    /// `C`, `1 x n`.
    pub c: Vec<f64>,
    /// `D`.
    pub d: f64,
    /// Lowest command; `None`: no limit.
    pub output_min: Option<f64>,
    /// Highest command; `None`: no limit.
    pub output_max: Option<f64>,
    /// State handling under saturation.
    pub anti_windup: SsAntiWindup,
    /// How the coefficients were made (`given`, `zoh`, `tustin`,
    /// `tustin prewarp 1000 Hz`), for people; not used by the loop.
    pub discretisation: String,
}

impl StateSpaceBlock {
    /// Number of states.
    pub fn order(&self) -> usize {
        self.b.len()
    }

    /// The block of a discrete SISO [`crate::lti::ss::StateSpace`] whose
    /// sample time is `ts` (checked to 1e-12 relative).
    pub fn from_discrete(
        k: &crate::lti::ss::StateSpace,
        ts: f64,
        discretisation: &str,
    ) -> Result<Self, String> {
        if k.nu() != 1 || k.ny() != 1 {
            return Err(format!(
                "the controller must be SISO (error in, command out); it has {} inputs and {} outputs",
                k.nu(),
                k.ny()
            ));
        }
        match k.ts {
            Some(t) if (t - ts).abs() <= 1e-12 * ts => {}
            Some(t) => {
                return Err(format!(
                    "the controller's sample time {t} s differs from the loop's {ts} s"
                ));
            }
            None => return Err("the controller is continuous; discretise it first".into()),
        }
        let n = k.nx();
        let mut a = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                a.push(k.a[(i, j)]);
            }
        }
        Ok(Self {
            a,
            b: (0..n).map(|i| k.b[(i, 0)]).collect(),
            c: (0..n).map(|j| k.c[(0, j)]).collect(),
            d: k.d[(0, 0)],
            output_min: None,
            output_max: None,
            anti_windup: SsAntiWindup::ConditionalUpdate,
            discretisation: discretisation.to_owned(),
        })
    }

    /// The block as an [`crate::lti::ss::StateSpace`] with sample time `ts`.
    pub fn to_state_space(&self, ts: f64) -> Result<crate::lti::ss::StateSpace, String> {
        let n = self.order();
        if self.a.len() != n * n || self.c.len() != n {
            return Err("inconsistent dimensions".into());
        }
        crate::lti::ss::StateSpace::new(
            faer::Mat::from_fn(n, n, |i, j| self.a[i * n + j]),
            faer::Mat::from_fn(n, 1, |i, _| self.b[i]),
            faer::Mat::from_fn(1, n, |_, j| self.c[j]),
            faer::Mat::from_fn(1, 1, |_, _| self.d),
            Some(ts),
        )
        .map_err(|e| e.to_string())
    }
}

/// A PID given in the continuous parallel form
/// `C(s) = Kp + Ki/s + Kd s` or, with a derivative filter,
/// `Kp + Ki/s + Kd N s/(s + N)` (MATLAB `pid(Kp, Ki, Kd, 1/N)`), run by the
/// loop after backward-Euler discretisation at the file's sample time,
/// derivative on the measurement (docs/formats.md "PID forms").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParallelPid {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain, 1/s.
    pub ki: f64,
    /// Derivative gain, s.
    pub kd: f64,
    /// Derivative filter bandwidth `N`, rad/s; `None`: unfiltered.
    pub n: Option<f64>,
    /// Lowest command.
    pub output_min: f64,
    /// Highest command.
    pub output_max: f64,
}

/// The name of the discretisation [`ParallelPid::discretise`] uses.
pub const PARALLEL_PID_DISCRETISATION: &str = "backward-euler";

impl ParallelPid {
    /// Checks the gains where they are named (`kp`, `ki`, `kd`, `n`).
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (name, v) in [("kp", self.kp), ("ki", self.ki), ("kd", self.kd)] {
            if !v.is_finite() {
                return Err((name, format!("expected a finite gain, got {v}")));
            }
        }
        if let Some(n) = self.n
            && !(n.is_finite() && n > 0.0)
        {
            return Err((
                "n",
                format!("expected a positive derivative filter bandwidth in rad/s, got {n}"),
            ));
        }
        Ok(())
    }

    /// The loop's coefficients at sample time `ts` by backward Euler,
    /// `s = (1 - z^-1)/Ts`: `ki Ts` per sample; without a filter the [Li21]
    /// form with `kd = Kd/Ts`; with one, `pole = 1/(1 + N Ts)` and
    /// `kd = Kd N pole` (docs/formats.md "PID forms").
    pub fn discretise(&self, ts: f64) -> FeedbackSpec<'static> {
        match self.n {
            None => FeedbackSpec::Pid(PidSpec {
                kp: self.kp,
                ki: self.ki * ts,
                kd: self.kd / ts,
                output_min: self.output_min,
                output_max: self.output_max,
            }),
            Some(n) => {
                let pole = 1.0 / (1.0 + n * ts);
                FeedbackSpec::PidFiltered(PidFilteredSpec {
                    kp: self.kp,
                    ki: self.ki * ts,
                    kd: self.kd * n * pole,
                    derivative_pole: pole,
                    output_min: self.output_min,
                    output_max: self.output_max,
                })
            }
        }
    }
}

/// The feedback stage of a controller file: at most one controller.
#[derive(Debug, Clone, PartialEq)]
pub enum Feedback {
    /// None: a feedforward-only controller (`no_feedback` block); the
    /// command is the last block's output.
    None,
    /// The [Li21] PID, gains per sample.
    Pid(PidSpec),
    /// A PID given in continuous parallel form, discretised.
    ParallelPid(ParallelPid),
    /// A discrete state-space controller.
    StateSpace(StateSpaceBlock),
}

impl From<PidSpec> for Feedback {
    fn from(p: PidSpec) -> Self {
        Feedback::Pid(p)
    }
}

impl From<StateSpaceBlock> for Feedback {
    fn from(k: StateSpaceBlock) -> Self {
        Feedback::StateSpace(k)
    }
}

fn anti_windup_name(a: SsAntiWindup) -> &'static str {
    match a {
        SsAntiWindup::None => "none",
        SsAntiWindup::ConditionalUpdate => "conditional-update",
    }
}

impl ZpetcBlock {
    /// The block of a designed ZPETC filter.
    pub fn from_zpetc(z: &crate::synth::zpetc::Zpetc) -> Self {
        Self {
            preview: z.preview,
            num: z.num.coeffs().to_vec(),
            den: z.den.coeffs().to_vec(),
        }
    }
}

impl HysteresisBlock {
    /// Checks the block as strictly as a model file is checked: a known
    /// `model`, strictly increasing non-negative thresholds, one finite
    /// weight per threshold, parts that match the model kind.
    fn validate(&self, source: &str, field: &str) -> Result<(), InputError> {
        use crate::ident::hysteresis::{
            DeadZoneStage, HysteresisModel, ModelError, ModelKind, PlayOperator,
        };
        let err = |key: &str, msg: String| {
            InputError::new(source, msg).in_field(format!("{field}.{key}"))
        };
        let kind = ModelKind::from_name(&self.model).ok_or_else(|| {
            err(
                "model",
                format!(
                    "expected \"pi\", \"mpi-cbrt\" or \"mpi-deadzone\", found {:?}",
                    self.model
                ),
            )
        })?;
        let model = HysteresisModel {
            kind,
            operator: match self.operator {
                PlayForm::Lower => PlayOperator::Lower,
                PlayForm::Symmetric => PlayOperator::Symmetric,
            },
            thresholds: self.thresholds.clone(),
            weights: self.weights.clone(),
            cbrt_gain: self.cbrt_gain,
            offset: self.offset,
            input_offset: self.input_offset,
            dead_zone: (!self.dead_zone_thresholds.is_empty()).then(|| DeadZoneStage {
                thresholds: self.dead_zone_thresholds.clone(),
                weights: self.dead_zone_weights.clone(),
            }),
        };
        model.validate().map_err(|e| {
            let key = match &e {
                ModelError::LengthMismatch { field, .. }
                | ModelError::Thresholds { field, .. }
                | ModelError::NonFinite { field } => field.replace("dead_zone.", "dead_zone_"),
                ModelError::Inconsistent(_) => "model".to_owned(),
            };
            err(&key, e.to_string())
        })
    }

    /// The block of an (inverse) hysteresis model.
    pub fn from_model(m: &crate::ident::hysteresis::HysteresisModel) -> Self {
        use crate::ident::hysteresis::PlayOperator;
        Self {
            model: m.kind.name().to_owned(),
            operator: match m.operator {
                PlayOperator::Lower => PlayForm::Lower,
                PlayOperator::Symmetric => PlayForm::Symmetric,
            },
            thresholds: m.thresholds.clone(),
            weights: m.weights.clone(),
            cbrt_gain: m.cbrt_gain,
            offset: m.offset,
            input_offset: m.input_offset,
            dead_zone_thresholds: m
                .dead_zone
                .as_ref()
                .map(|d| d.thresholds.clone())
                .unwrap_or_default(),
            dead_zone_weights: m
                .dead_zone
                .as_ref()
                .map(|d| d.weights.clone())
                .unwrap_or_default(),
        }
    }
}

/// A whole controller as written to and read from the file.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerFile {
    /// Sample time, s.
    pub ts: f64,
    /// Signal units.
    pub units: Units,
    /// Optional ZPETC.
    pub zpetc: Option<ZpetcBlock>,
    /// Optional HC feedforward.
    pub hysteresis: Option<HysteresisBlock>,
    /// The feedback controller (PID or state space).
    pub feedback: Feedback,
    /// Provenance.
    pub provenance: Provenance,
}

fn operator_name(form: PlayForm) -> &'static str {
    match form {
        PlayForm::Lower => "play-lower",
        PlayForm::Symmetric => "play-symmetric",
    }
}

impl ControllerFile {
    /// Borrowed coefficients for [`crate::runtime::RuntimeController::new`].
    pub fn runtime_spec(&self) -> RuntimeSpec<'_> {
        RuntimeSpec {
            zpetc: self.zpetc.as_ref().map(|z| ZpetcSpec {
                preview: z.preview,
                num: &z.num,
                den: &z.den,
            }),
            hysteresis: self.hysteresis.as_ref().map(|h| HysteresisSpec {
                form: h.operator,
                thresholds: &h.thresholds,
                weights: &h.weights,
                cbrt_gain: h.cbrt_gain,
                offset: h.offset,
                input_offset: h.input_offset,
                dead_zone_thresholds: &h.dead_zone_thresholds,
                dead_zone_weights: &h.dead_zone_weights,
            }),
            feedback: match &self.feedback {
                Feedback::None => FeedbackSpec::None,
                Feedback::Pid(p) => FeedbackSpec::Pid(*p),
                Feedback::ParallelPid(p) => p.discretise(self.ts),
                Feedback::StateSpace(k) => FeedbackSpec::StateSpace(StateSpaceSpec {
                    a: &k.a,
                    b: &k.b,
                    c: &k.c,
                    d: k.d,
                    output_min: k.output_min.unwrap_or(f64::NEG_INFINITY),
                    output_max: k.output_max.unwrap_or(f64::INFINITY),
                    anti_windup: k.anti_windup,
                }),
            },
        }
    }

    /// The command limits `(min, max)`; infinite where the state-space
    /// block has none.
    pub fn command_limits(&self) -> (f64, f64) {
        self.runtime_spec().feedback.limits()
    }

    /// The per-sample [Li21] PID, when the feedback controller is one.
    pub fn pid(&self) -> Option<&PidSpec> {
        match &self.feedback {
            Feedback::Pid(p) => Some(p),
            _ => None,
        }
    }

    /// The state-space controller, when the feedback controller is one.
    pub fn state_space(&self) -> Option<&StateSpaceBlock> {
        match &self.feedback {
            Feedback::StateSpace(k) => Some(k),
            _ => None,
        }
    }

    /// The stages in the `--controller` grammar.
    pub fn stages(&self) -> crate::synth::composite::Stages {
        use crate::synth::composite::FeedbackKind;
        crate::synth::composite::Stages {
            feedback: match self.feedback {
                Feedback::None => FeedbackKind::None,
                Feedback::Pid(_) | Feedback::ParallelPid(_) => FeedbackKind::Pid,
                Feedback::StateSpace(_) => FeedbackKind::StateSpace,
            },
            hysteresis_compensation: self.hysteresis.is_some(),
            zpetc: self.zpetc.is_some(),
        }
    }

    /// Samples of reference look-ahead the loop must supply.
    pub fn preview(&self) -> usize {
        self.zpetc.as_ref().map_or(0, |z| z.preview)
    }

    /// The controller in the `--controller` grammar, e.g. `pid+hc+zpec`.
    pub fn stages_name(&self) -> String {
        self.stages().name().to_owned()
    }

    /// Names of the blocks in signal order, e.g. `zpetc, hysteresis_inverse, pid`.
    pub fn block_names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.zpetc.is_some() {
            v.push("zpetc");
        }
        if self.hysteresis.is_some() {
            v.push("hysteresis_inverse");
        }
        v.push(match self.feedback {
            Feedback::None => "no_feedback",
            Feedback::Pid(_) | Feedback::ParallelPid(_) => "pid",
            Feedback::StateSpace(_) => "state_space",
        });
        v
    }

    /// The JSON document (keys in the documented order).
    pub fn to_value(&self) -> Value {
        // serde_json's Map keeps keys sorted unless built from a struct; the
        // ordered document is built through serde's struct serialisation.
        #[derive(serde::Serialize)]
        struct Doc<'a> {
            format: &'static str,
            ts: f64,
            preview: usize,
            units: UnitsDoc<'a>,
            blocks: Vec<Value>,
            provenance: ProvDoc<'a>,
        }
        #[derive(serde::Serialize)]
        struct UnitsDoc<'a> {
            reference: &'a str,
            measurement: &'a str,
            command: &'a str,
        }
        #[derive(serde::Serialize)]
        struct ProvDoc<'a> {
            fts_version: &'a str,
            inputs: Vec<InputDoc<'a>>,
        }
        #[derive(serde::Serialize)]
        struct InputDoc<'a> {
            role: &'a str,
            file: &'a str,
            sha256: &'a str,
        }
        #[derive(serde::Serialize)]
        struct ZDoc<'a> {
            r#type: &'static str,
            preview: usize,
            num: &'a [f64],
            den: &'a [f64],
        }
        #[derive(serde::Serialize)]
        struct HDoc<'a> {
            r#type: &'static str,
            model: &'a str,
            operator: &'static str,
            thresholds: &'a [f64],
            weights: &'a [f64],
            cbrt_gain: f64,
            offset: f64,
            input_offset: f64,
            dead_zone_thresholds: &'a [f64],
            dead_zone_weights: &'a [f64],
        }
        #[derive(serde::Serialize)]
        struct PDoc {
            r#type: &'static str,
            form: &'static str,
            kp: f64,
            ki: f64,
            kd: f64,
            output_min: f64,
            output_max: f64,
            anti_windup: &'static str,
        }
        #[derive(serde::Serialize)]
        struct ParDoc {
            r#type: &'static str,
            form: &'static str,
            kp: f64,
            ki: f64,
            kd: f64,
            #[serde(skip_serializing_if = "Option::is_none")]
            derivative_pole: Option<f64>,
            output_min: f64,
            output_max: f64,
            anti_windup: &'static str,
            continuous: ContDoc,
        }
        #[derive(serde::Serialize)]
        struct ContDoc {
            kp: f64,
            ki: f64,
            kd: f64,
            n: Option<f64>,
            discretisation: &'static str,
        }
        #[derive(serde::Serialize)]
        struct NoneDoc {
            r#type: &'static str,
        }
        #[derive(serde::Serialize)]
        struct SDoc<'a> {
            r#type: &'static str,
            ts: f64,
            input: &'static str,
            output: &'static str,
            states: usize,
            discretisation: &'a str,
            a: Vec<&'a [f64]>,
            b: Vec<[f64; 1]>,
            c: [&'a [f64]; 1],
            d: [[f64; 1]; 1],
            #[serde(skip_serializing_if = "Option::is_none")]
            output_min: Option<f64>,
            #[serde(skip_serializing_if = "Option::is_none")]
            output_max: Option<f64>,
            anti_windup: &'static str,
        }
        let mut blocks = Vec::new();
        if let Some(z) = &self.zpetc {
            blocks.push(
                serde_json::to_value(ZDoc {
                    r#type: "zpetc",
                    preview: z.preview,
                    num: &z.num,
                    den: &z.den,
                })
                .expect("serialisable"),
            );
        }
        if let Some(h) = &self.hysteresis {
            blocks.push(
                serde_json::to_value(HDoc {
                    r#type: "hysteresis_inverse",
                    model: &h.model,
                    operator: operator_name(h.operator),
                    thresholds: &h.thresholds,
                    weights: &h.weights,
                    cbrt_gain: h.cbrt_gain,
                    offset: h.offset,
                    input_offset: h.input_offset,
                    dead_zone_thresholds: &h.dead_zone_thresholds,
                    dead_zone_weights: &h.dead_zone_weights,
                })
                .expect("serialisable"),
            );
        }
        blocks.push(match &self.feedback {
            Feedback::None => serde_json::to_value(NoneDoc {
                r#type: "no_feedback",
            })
            .expect("serialisable"),
            Feedback::ParallelPid(p) => {
                let (kp, ki, kd, pole) = match p.discretise(self.ts) {
                    FeedbackSpec::PidFiltered(d) => (d.kp, d.ki, d.kd, Some(d.derivative_pole)),
                    FeedbackSpec::Pid(d) => (d.kp, d.ki, d.kd, None),
                    _ => unreachable!("a PID discretises to a PID"),
                };
                serde_json::to_value(ParDoc {
                    r#type: "pid",
                    form: "parallel",
                    kp,
                    ki,
                    kd,
                    derivative_pole: pole,
                    output_min: p.output_min,
                    output_max: p.output_max,
                    anti_windup: "conditional-integration",
                    continuous: ContDoc {
                        kp: p.kp,
                        ki: p.ki,
                        kd: p.kd,
                        n: p.n,
                        discretisation: PARALLEL_PID_DISCRETISATION,
                    },
                })
                .expect("serialisable")
            }
            Feedback::Pid(p) => serde_json::to_value(PDoc {
                r#type: "pid",
                form: "li21",
                kp: p.kp,
                ki: p.ki,
                kd: p.kd,
                output_min: p.output_min,
                output_max: p.output_max,
                anti_windup: "conditional-integration",
            })
            .expect("serialisable"),
            Feedback::StateSpace(k) => {
                let n = k.order();
                serde_json::to_value(SDoc {
                    r#type: "state_space",
                    ts: self.ts,
                    input: "error",
                    output: "command",
                    states: n,
                    discretisation: &k.discretisation,
                    a: (0..n).map(|i| &k.a[i * n..(i + 1) * n]).collect(),
                    b: k.b.iter().map(|v| [*v]).collect(),
                    c: [&k.c],
                    d: [[k.d]],
                    output_min: k.output_min,
                    output_max: k.output_max,
                    anti_windup: anti_windup_name(k.anti_windup),
                })
                .expect("serialisable")
            }
        });
        serde_json::to_value(Doc {
            format: CONTROLLER_FORMAT,
            ts: self.ts,
            preview: self.preview(),
            units: UnitsDoc {
                reference: &self.units.reference,
                measurement: &self.units.measurement,
                command: &self.units.command,
            },
            blocks,
            provenance: ProvDoc {
                fts_version: &self.provenance.fts_version,
                inputs: self
                    .provenance
                    .inputs
                    .iter()
                    .map(|i| InputDoc {
                        role: &i.role,
                        file: &i.file,
                        sha256: &i.sha256,
                    })
                    .collect(),
            },
        })
        .expect("serialisable")
    }

    /// The file text: pretty JSON with a trailing newline.
    pub fn to_json_string(&self) -> String {
        let mut s = serde_json::to_string_pretty(&self.to_value()).expect("serialisable");
        s.push('\n');
        s
    }

    /// Checks that the file would load into the runtime.
    pub fn validate(&self, source: &str) -> Result<(), InputError> {
        if !(self.ts.is_finite() && self.ts > 0.0) {
            return Err(
                InputError::new(source, "expected a positive number of seconds").in_field("ts"),
            );
        }
        crate::runtime::RuntimeController::new(&self.runtime_spec())
            .map(|_| ())
            .map_err(|e| InputError::new(source, e.to_string()).in_field(runtime_field(&e)))
    }
}

fn runtime_field(e: &crate::runtime::RuntimeError) -> &'static str {
    use crate::runtime::RuntimeError::*;
    match e {
        BadLength { field, .. }
        | OrderTooHigh { field, .. }
        | LengthMismatch { field }
        | NonFinite { field }
        | Invalid { field } => field,
    }
}

fn num(obj: &Map<String, Value>, source: &str, key: &str, block: &str) -> Result<f64, InputError> {
    match obj.get(key) {
        Some(v) => v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            InputError::new(source, format!("expected a finite number, found {v}"))
                .in_field(format!("{block}.{key}"))
        }),
        None => Err(InputError::new(source, "missing").in_field(format!("{block}.{key}"))),
    }
}

fn block_array(
    obj: &Map<String, Value>,
    source: &str,
    key: &str,
    block: &str,
) -> Result<Vec<f64>, InputError> {
    get_f64_array(obj, source, key).map_err(|mut e| {
        e.field = e.field.map(|f| format!("{block}.{f}"));
        e
    })
}

fn optional_array(
    obj: &Map<String, Value>,
    source: &str,
    key: &str,
    block: &str,
) -> Result<Vec<f64>, InputError> {
    match obj.get(key) {
        None => Ok(Vec::new()),
        Some(Value::Array(a)) if a.is_empty() => Ok(Vec::new()),
        Some(_) => block_array(obj, source, key, block),
    }
}

/// Parses and validates an `fts.controller/1` document.
pub fn parse_controller(text: &str, source: &str) -> Result<ControllerFile, InputError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| InputError::new(source, format!("invalid JSON: {e}")).at_line(e.line()))?;
    let obj = value
        .as_object()
        .ok_or_else(|| InputError::new(source, "expected a JSON object"))?;
    check_format(obj, source, CONTROLLER_FORMAT)?;
    let ts = num(obj, source, "ts", "file").map_err(|e| e.in_field("ts"))?;
    let units = match obj.get("units").and_then(Value::as_object) {
        Some(u) => Units {
            reference: get_str(u, source, "reference")?.to_owned(),
            measurement: get_str(u, source, "measurement")?.to_owned(),
            command: get_str(u, source, "command")?.to_owned(),
        },
        None => return Err(InputError::new(source, "missing units object").in_field("units")),
    };
    let blocks = match obj.get("blocks") {
        Some(Value::Array(b)) => b,
        _ => return Err(InputError::new(source, "expected an array of blocks").in_field("blocks")),
    };
    let order = [
        "zpetc",
        "hysteresis_inverse",
        "pid",
        "state_space",
        "no_feedback",
    ];
    let is_feedback = |k: &str| k == "pid" || k == "state_space" || k == "no_feedback";
    let mut last_rank = None;
    let mut file = ControllerFile {
        ts,
        units,
        zpetc: None,
        hysteresis: None,
        feedback: Feedback::Pid(PidSpec {
            kp: 0.0,
            ki: 0.0,
            kd: 0.0,
            output_min: 0.0,
            output_max: 0.0,
        }),
        provenance: Provenance::default(),
    };
    let mut feedback_seen: Option<&str> = None;
    for (i, b) in blocks.iter().enumerate() {
        let field = format!("blocks[{i}]");
        let b = b
            .as_object()
            .ok_or_else(|| InputError::new(source, "expected an object").in_field(field.clone()))?;
        let kind = get_str(b, source, "type").map_err(|e| e.in_field(format!("{field}.type")))?;
        if let Some(first) = feedback_seen
            && is_feedback(kind)
        {
            return Err(InputError::new(
                source,
                format!(
                    "a second feedback block {kind:?} after {first:?}: exactly one of \"pid\", \"state_space\" and \"no_feedback\" is allowed"
                ),
            )
            .in_field(format!("{field}.type")));
        }
        // pid, state_space and no_feedback are alternatives at the same place in the chain.
        let rank = order
            .iter()
            .position(|k| *k == kind)
            .map(|r| r.min(2))
            .ok_or_else(|| {
                InputError::new(
                    source,
                    format!(
                        "unknown block type {kind:?}; known blocks, in signal order: {}",
                        order.join(", ")
                    ),
                )
                .in_field(format!("{field}.type"))
            })?;
        if last_rank.is_some_and(|r| r >= rank) {
            return Err(InputError::new(
                source,
                format!(
                    "block {kind:?} is out of order or repeated; blocks must appear in signal order: {}",
                    order.join(", ")
                ),
            )
            .in_field(format!("{field}.type")));
        }
        last_rank = Some(rank);
        match kind {
            "zpetc" => {
                let preview = super::zpetc_json::read_preview(
                    b.get("preview"),
                    source,
                    &format!("{field}.preview"),
                )?;
                file.zpetc = Some(ZpetcBlock {
                    preview,
                    num: block_array(b, source, "num", &field)?,
                    den: block_array(b, source, "den", &field)?,
                });
            }
            "hysteresis_inverse" => {
                let operator = match get_str(b, source, "operator")
                    .map_err(|e| e.in_field(format!("{field}.operator")))?
                {
                    "play-lower" => PlayForm::Lower,
                    "play-symmetric" => PlayForm::Symmetric,
                    other => {
                        return Err(InputError::new(
                            source,
                            format!(
                                "expected \"play-lower\" or \"play-symmetric\", found {other:?}"
                            ),
                        )
                        .in_field(format!("{field}.operator")));
                    }
                };
                let block = HysteresisBlock {
                    model: b
                        .get("model")
                        .and_then(Value::as_str)
                        .unwrap_or("")
                        .to_owned(),
                    operator,
                    thresholds: block_array(b, source, "thresholds", &field)?,
                    weights: block_array(b, source, "weights", &field)?,
                    cbrt_gain: num(b, source, "cbrt_gain", &field)?,
                    offset: num(b, source, "offset", &field)?,
                    input_offset: num(b, source, "input_offset", &field)?,
                    dead_zone_thresholds: optional_array(
                        b,
                        source,
                        "dead_zone_thresholds",
                        &field,
                    )?,
                    dead_zone_weights: optional_array(b, source, "dead_zone_weights", &field)?,
                };
                block.validate(source, &field)?;
                file.hysteresis = Some(block);
            }
            "state_space" => {
                file.feedback = Feedback::StateSpace(parse_state_space(b, source, &field, ts)?);
                feedback_seen = Some("state_space");
            }
            "no_feedback" => {
                file.feedback = Feedback::None;
                feedback_seen = Some("no_feedback");
            }
            _ => {
                file.feedback = parse_pid(b, source, &field, ts)?;
                feedback_seen = Some("pid");
            }
        }
    }
    if feedback_seen.is_none() {
        return Err(InputError::new(
            source,
            "missing block \"pid\" or \"state_space\" (or \"no_feedback\" for a feedforward-only controller): every controller ends with its feedback stage",
        )
        .in_field("blocks"));
    }
    if file.feedback == Feedback::None && file.zpetc.is_none() && file.hysteresis.is_none() {
        return Err(InputError::new(
            source,
            "a \"no_feedback\" controller needs a feedforward block (\"zpetc\" or \"hysteresis_inverse\")",
        )
        .in_field("blocks"));
    }
    if let Some(p) = obj.get("preview") {
        let declared = p.as_u64();
        if declared != Some(file.preview() as u64) {
            return Err(InputError::new(
                source,
                format!(
                    "declares preview {p} but its ZPETC block has {}",
                    file.preview()
                ),
            )
            .in_field("preview"));
        }
    }
    if let Some(prov) = obj.get("provenance").and_then(Value::as_object) {
        file.provenance.fts_version = prov
            .get("fts_version")
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_owned();
        if let Some(Value::Array(inputs)) = prov.get("inputs") {
            for i in inputs {
                let s = |k: &str| i.get(k).and_then(Value::as_str).unwrap_or("").to_owned();
                file.provenance.inputs.push(InputHash {
                    role: s("role"),
                    file: s("file"),
                    sha256: s("sha256"),
                });
            }
        }
    }
    file.validate(source)?;
    Ok(file)
}

/// A `pid` block: `form` `li21` (gains per sample; the default) or
/// `parallel` (continuous gains under `continuous`, the per-sample
/// coefficients beside them checked against their discretisation).
fn parse_pid(
    b: &Map<String, Value>,
    source: &str,
    field: &str,
    ts: f64,
) -> Result<Feedback, InputError> {
    let output_min = num(b, source, "output_min", field)?;
    let output_max = num(b, source, "output_max", field)?;
    match b.get("form").and_then(Value::as_str).unwrap_or("li21") {
        "li21" => Ok(Feedback::Pid(PidSpec {
            kp: num(b, source, "kp", field)?,
            ki: num(b, source, "ki", field)?,
            kd: num(b, source, "kd", field)?,
            output_min,
            output_max,
        })),
        "parallel" => {
            let cont_field = format!("{field}.continuous");
            let cont = b
                .get("continuous")
                .and_then(Value::as_object)
                .ok_or_else(|| {
                    InputError::new(
                        source,
                        "missing: a parallel-form PID records its continuous gains",
                    )
                    .in_field(cont_field.clone())
                })?;
            let n = match cont.get("n") {
                None | Some(Value::Null) => None,
                Some(_) => Some(num(cont, source, "n", &cont_field)?),
            };
            if let Some(d) = cont.get("discretisation")
                && d.as_str() != Some(PARALLEL_PID_DISCRETISATION)
            {
                return Err(InputError::new(
                    source,
                    format!("expected \"{PARALLEL_PID_DISCRETISATION}\", found {d}"),
                )
                .in_field(format!("{cont_field}.discretisation")));
            }
            let pid = ParallelPid {
                kp: num(cont, source, "kp", &cont_field)?,
                ki: num(cont, source, "ki", &cont_field)?,
                kd: num(cont, source, "kd", &cont_field)?,
                n,
                output_min,
                output_max,
            };
            pid.validate().map_err(|(k, m)| {
                InputError::new(source, m).in_field(format!("{cont_field}.{k}"))
            })?;
            check_parallel_coefficients(b, source, field, &pid, ts)?;
            Ok(Feedback::ParallelPid(pid))
        }
        other => Err(InputError::new(
            source,
            format!("unknown PID form {other:?}; expected \"li21\" or \"parallel\""),
        )
        .in_field(format!("{field}.form"))),
    }
}

/// The per-sample coefficients written beside a parallel PID's continuous
/// gains must be their discretisation (to 1e-12 relative): a hand edit of
/// one and not the other is refused rather than guessed at.
fn check_parallel_coefficients(
    b: &Map<String, Value>,
    source: &str,
    field: &str,
    pid: &ParallelPid,
    ts: f64,
) -> Result<(), InputError> {
    let (kp, ki, kd, pole) = match pid.discretise(ts) {
        FeedbackSpec::PidFiltered(d) => (d.kp, d.ki, d.kd, Some(d.derivative_pole)),
        FeedbackSpec::Pid(d) => (d.kp, d.ki, d.kd, None),
        _ => unreachable!("a PID discretises to a PID"),
    };
    let mut expected = vec![("kp", kp), ("ki", ki), ("kd", kd)];
    if let Some(p) = pole {
        expected.push(("derivative_pole", p));
    }
    for (key, want) in expected {
        let got = num(b, source, key, field)?;
        if (got - want).abs() > 1e-12 * want.abs().max(1e-300) {
            return Err(InputError::new(
                source,
                format!(
                    "{got} is not the {PARALLEL_PID_DISCRETISATION} discretisation of the continuous gains at ts = {ts} s ({want}); edit the continuous gains and re-emit"
                ),
            )
            .in_field(format!("{field}.{key}")));
        }
    }
    Ok(())
}

/// A matrix as an array of rows; every entry finite; field names like
/// `blocks[2].a[1][0]`.
fn matrix(
    obj: &Map<String, Value>,
    source: &str,
    key: &str,
    block: &str,
) -> Result<Vec<Vec<f64>>, InputError> {
    let here = |f: String, m: String| InputError::new(source, m).in_field(f);
    let rows = match obj.get(key) {
        Some(Value::Array(a)) => a,
        Some(_) => {
            return Err(here(
                format!("{block}.{key}"),
                "expected an array of rows (arrays of numbers)".into(),
            ));
        }
        None => return Err(here(format!("{block}.{key}"), "missing".into())),
    };
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            let Value::Array(r) = r else {
                return Err(here(
                    format!("{block}.{key}[{i}]"),
                    "expected a row (array of numbers)".into(),
                ));
            };
            r.iter()
                .enumerate()
                .map(|(j, v)| {
                    v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                        here(
                            format!("{block}.{key}[{i}][{j}]"),
                            format!("expected a finite number, found {v}"),
                        )
                    })
                })
                .collect()
        })
        .collect()
}

fn parse_state_space(
    b: &Map<String, Value>,
    source: &str,
    field: &str,
    file_ts: f64,
) -> Result<StateSpaceBlock, InputError> {
    let err = |key: &str, m: String| InputError::new(source, m).in_field(format!("{field}.{key}"));
    let ts = num(b, source, "ts", field)?;
    if (ts - file_ts).abs() > 1e-12 * file_ts {
        return Err(err(
            "ts",
            format!(
                "the state-space controller runs at {ts} s but the file's sample time is {file_ts} s; only discrete controllers at the loop's rate are allowed (fts emit --ss discretises a continuous one)"
            ),
        ));
    }
    for (key, want) in [("input", "error"), ("output", "command")] {
        if let Some(v) = b.get(key)
            && v.as_str() != Some(want)
        {
            return Err(err(key, format!("expected \"{want}\", found {v}")));
        }
    }
    let a = matrix(b, source, "a", field)?;
    let n = a.len();
    for (i, row) in a.iter().enumerate() {
        if row.len() != n {
            return Err(err(
                &format!("a[{i}]"),
                format!(
                    "A must be square: {n} rows but row {i} has {} entries",
                    row.len()
                ),
            ));
        }
    }
    let bm = matrix(b, source, "b", field)?;
    if bm.len() != n || bm.iter().any(|r| r.len() != 1) {
        return Err(err(
            "b",
            format!("B must be {n} x 1 (one row of one number per state of A)"),
        ));
    }
    let cm = matrix(b, source, "c", field)?;
    let c: Vec<f64> = match cm.as_slice() {
        [row] if row.len() == n => row.clone(),
        [] if n == 0 => Vec::new(),
        _ => {
            return Err(err(
                "c",
                format!("C must be 1 x {n} (one row with one number per state of A)"),
            ));
        }
    };
    let dm = matrix(b, source, "d", field)?;
    let d = match dm.as_slice() {
        [row] if row.len() == 1 => row[0],
        _ => return Err(err("d", "D must be 1 x 1 ([[d]])".into())),
    };
    if let Some(v) = b.get("states")
        && v.as_u64() != Some(n as u64)
    {
        return Err(err(
            "states",
            format!("declares {v} states but A is {n} x {n}"),
        ));
    }
    let limit = |key: &str| -> Result<Option<f64>, InputError> {
        match b.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(_) => num(b, source, key, field).map(Some),
        }
    };
    let anti_windup = match b.get("anti_windup") {
        None => SsAntiWindup::ConditionalUpdate,
        Some(v) => match v.as_str() {
            Some("conditional-update") => SsAntiWindup::ConditionalUpdate,
            Some("none") => SsAntiWindup::None,
            _ => {
                return Err(err(
                    "anti_windup",
                    format!("expected \"conditional-update\" or \"none\", found {v}"),
                ));
            }
        },
    };
    Ok(StateSpaceBlock {
        a: a.concat(),
        b: bm.iter().map(|r| r[0]).collect(),
        c,
        d,
        output_min: limit("output_min")?,
        output_max: limit("output_max")?,
        anti_windup,
        discretisation: b
            .get("discretisation")
            .and_then(Value::as_str)
            .unwrap_or("given")
            .to_owned(),
    })
}

fn c_array(out: &mut String, name: &str, values: &[f64]) {
    let _ = writeln!(out, "#define {name}_LEN {}", values.len());
    let _ = write!(
        out,
        "static const double {name}[{}] = {{",
        values.len().max(1)
    );
    if values.is_empty() {
        out.push_str(" 0.0");
    }
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        let _ = write!(out, " {}", c_double(*v));
    }
    out.push_str(" };\n");
}

/// Shortest round-trip decimal in C syntax (always with an exponent, so the
/// literal is a double).
fn c_double(v: f64) -> String {
    format!("{v:e}")
}

/// The C header with the same numbers as the JSON.
pub fn to_c_header(file: &ControllerFile) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "/* {CONTROLLER_FORMAT} coefficients, generated by fts {}; do not edit.\n * Blocks in signal order: {}.\n * Units: reference {}, measurement {}, command {}.",
        file.provenance.fts_version,
        file.block_names().join(", "),
        file.units.reference,
        file.units.measurement,
        file.units.command
    );
    for i in &file.provenance.inputs {
        let _ = writeln!(out, " * input {} ({}): sha256 {}", i.role, i.file, i.sha256);
    }
    out.push_str(" */\n#ifndef FTS_CONTROLLER_H\n#define FTS_CONTROLLER_H\n\n");
    let _ = writeln!(out, "#define FTS_CONTROLLER_FORMAT \"{CONTROLLER_FORMAT}\"");
    let _ = writeln!(out, "#define FTS_TS {}", c_double(file.ts));
    let _ = writeln!(out, "#define FTS_PREVIEW {}", file.preview());
    if let Some(z) = &file.zpetc {
        out.push_str("\n/* ZPETC pre-filter: run num/den on r(k + FTS_PREVIEW). */\n#define FTS_HAS_ZPETC 1\n");
        c_array(&mut out, "FTS_ZPETC_NUM", &z.num);
        c_array(&mut out, "FTS_ZPETC_DEN", &z.den);
    } else {
        out.push_str("\n#define FTS_HAS_ZPETC 0\n");
    }
    if let Some(h) = &file.hysteresis {
        let _ = writeln!(
            out,
            "\n/* Inverse hysteresis ({}, {}): u_ff = OFFSET + CBRT_GAIN cbrt(x) + Out[sum_i W_i F_i[x]], x = r_f - INPUT_OFFSET. */\n#define FTS_HAS_HYSTERESIS 1\n#define FTS_HYST_SYMMETRIC_PLAY {}",
            h.model,
            operator_name(h.operator),
            u8::from(h.operator == PlayForm::Symmetric)
        );
        c_array(&mut out, "FTS_HYST_THRESHOLDS", &h.thresholds);
        c_array(&mut out, "FTS_HYST_WEIGHTS", &h.weights);
        let _ = writeln!(out, "#define FTS_HYST_CBRT_GAIN {}", c_double(h.cbrt_gain));
        let _ = writeln!(out, "#define FTS_HYST_OFFSET {}", c_double(h.offset));
        let _ = writeln!(
            out,
            "#define FTS_HYST_INPUT_OFFSET {}",
            c_double(h.input_offset)
        );
        c_array(
            &mut out,
            "FTS_HYST_DEAD_ZONE_THRESHOLDS",
            &h.dead_zone_thresholds,
        );
        c_array(&mut out, "FTS_HYST_DEAD_ZONE_WEIGHTS", &h.dead_zone_weights);
    } else {
        out.push_str("\n#define FTS_HAS_HYSTERESIS 0\n");
    }
    match &file.feedback {
        Feedback::None => {
            out.push_str("\n/* No feedback controller: the command is the last block's output (u_ff with a hysteresis block, else r_f), unclamped. */\n#define FTS_HAS_FEEDBACK 0\n#define FTS_HAS_PID 0\n#define FTS_HAS_STATE_SPACE 0\n");
        }
        Feedback::ParallelPid(p) => {
            let (spec, pole) = match p.discretise(file.ts) {
                FeedbackSpec::PidFiltered(d) => (
                    PidSpec {
                        kp: d.kp,
                        ki: d.ki,
                        kd: d.kd,
                        output_min: d.output_min,
                        output_max: d.output_max,
                    },
                    d.derivative_pole,
                ),
                FeedbackSpec::Pid(d) => (d, 0.0),
                _ => unreachable!("a PID discretises to a PID"),
            };
            let _ = writeln!(
                out,
                "\n/* PID, continuous parallel form C(s) = KP + KI/s + KD N s/(s + N) (N absent: KD s), {PARALLEL_PID_DISCRETISATION} at FTS_TS, derivative on the measurement:\n *   d(k) = DERIVATIVE_POLE d(k-1) + KD (x(k) - x(k-1)); u = u_ff + KP e + KI sum(e) - d(k), clamped,\n *   conditional-integration anti-windup. FTS_PID_KP/KI/KD/DERIVATIVE_POLE are the per-sample coefficients. */\n#define FTS_HAS_FEEDBACK 1\n#define FTS_HAS_PID 1\n#define FTS_HAS_STATE_SPACE 0\n#define FTS_PID_FORM_PARALLEL 1\n#define FTS_PID_FILTERED {}",
                u8::from(p.n.is_some())
            );
            for (name, v) in [
                ("FTS_PID_CONTINUOUS_KP", p.kp),
                ("FTS_PID_CONTINUOUS_KI", p.ki),
                ("FTS_PID_CONTINUOUS_KD", p.kd),
                ("FTS_PID_CONTINUOUS_N", p.n.unwrap_or(0.0)),
                ("FTS_PID_KP", spec.kp),
                ("FTS_PID_KI", spec.ki),
                ("FTS_PID_KD", spec.kd),
                ("FTS_PID_DERIVATIVE_POLE", pole),
                ("FTS_PID_OUTPUT_MIN", spec.output_min),
                ("FTS_PID_OUTPUT_MAX", spec.output_max),
            ] {
                let _ = writeln!(out, "#define {name} {}", c_double(v));
            }
        }
        Feedback::Pid(p) => {
            let _ = writeln!(
                out,
                "\n/* PID ([Li21] Eq. 5): u = u_ff + KP e + KI sum(e) - KD (x(k) - x(k-1)), clamped, conditional-integration anti-windup. */\n#define FTS_HAS_FEEDBACK 1\n#define FTS_HAS_PID 1\n#define FTS_HAS_STATE_SPACE 0\n#define FTS_PID_FORM_PARALLEL 0\n#define FTS_PID_FILTERED 0\n#define FTS_PID_DERIVATIVE_POLE 0e0"
            );
            for (name, v) in [
                ("FTS_PID_KP", p.kp),
                ("FTS_PID_KI", p.ki),
                ("FTS_PID_KD", p.kd),
                ("FTS_PID_OUTPUT_MIN", p.output_min),
                ("FTS_PID_OUTPUT_MAX", p.output_max),
            ] {
                let _ = writeln!(out, "#define {name} {}", c_double(v));
            }
        }
        Feedback::StateSpace(k) => {
            let label = k
                .discretisation
                .replace("*/", "* /")
                .replace(['"', '\\', '\n'], " ");
            let _ = writeln!(
                out,
                "\n/* State-space feedback controller ({}), e = r_f - x:\n *   v = C x + D e (states before the update); x <- A x + B e;\n *   u = clamp(u_ff + v, OUTPUT_MIN, OUTPUT_MAX).\n * A is FTS_SS_NX x FTS_SS_NX row-major, B FTS_SS_NX x 1, C 1 x FTS_SS_NX.\n * Anti-windup {}: {} */\n#define FTS_HAS_FEEDBACK 1\n#define FTS_HAS_PID 0\n#define FTS_HAS_STATE_SPACE 1\n#define FTS_SS_NX {}\n#define FTS_SS_CONDITIONAL_UPDATE {}",
                label,
                anti_windup_name(k.anti_windup),
                match k.anti_windup {
                    SsAntiWindup::None => "states are not corrected while the command is clamped",
                    SsAntiWindup::ConditionalUpdate =>
                        "x is held when u_ff + v is beyond a limit and C (x+ - x) points further out",
                },
                k.order(),
                u8::from(k.anti_windup == SsAntiWindup::ConditionalUpdate)
            );
            let _ = writeln!(out, "#define FTS_SS_DISCRETISATION \"{label}\"");
            c_array(&mut out, "FTS_SS_A", &k.a);
            c_array(&mut out, "FTS_SS_B", &k.b);
            c_array(&mut out, "FTS_SS_C", &k.c);
            let _ = writeln!(out, "#define FTS_SS_D {}", c_double(k.d));
            for (name, v) in [("OUTPUT_MIN", k.output_min), ("OUTPUT_MAX", k.output_max)] {
                match v {
                    Some(v) => {
                        let _ = writeln!(
                            out,
                            "#define FTS_SS_HAS_{name} 1\n#define FTS_SS_{name} {}",
                            c_double(v)
                        );
                    }
                    None => {
                        let _ = writeln!(out, "#define FTS_SS_HAS_{name} 0");
                    }
                }
            }
        }
    }
    out.push_str("\n#endif /* FTS_CONTROLLER_H */\n");
    out
}

/// `fts_runtime.h`, the C99 runtime's interface (docs/formats.md "C runtime").
pub const C_RUNTIME_H: &str = include_str!("../../crates/fts-runtime/c/fts_runtime.h");
/// `fts_runtime.c`, the C99 twin of the `fts-runtime` step.
pub const C_RUNTIME_C: &str = include_str!("../../crates/fts-runtime/c/fts_runtime.c");

/// The three files of `fts emit --format c`, `(name, text)`:
/// `fts_controller.h` (the numbers of [`to_c_header`] plus
/// `fts_controller_init`, which loads them into an `fts_controller`),
/// `fts_runtime.h` and `fts_runtime.c` (the step).
pub fn to_c_files(file: &ControllerFile) -> [(&'static str, String); 3] {
    let header = to_c_header(file);
    let body = header
        .strip_suffix("\n#endif /* FTS_CONTROLLER_H */\n")
        .expect("to_c_header ends with its guard");
    let mut out = String::from(body);
    out.push_str(&c_loader(file));
    out.push_str("\n#endif /* FTS_CONTROLLER_H */\n");
    [
        ("fts_controller.h", out),
        ("fts_runtime.h", C_RUNTIME_H.to_owned()),
        ("fts_runtime.c", C_RUNTIME_C.to_owned()),
    ]
}

/// `fts_controller_init`: the `fts_spec` of the arrays above, then `fts_init`.
fn c_loader(file: &ControllerFile) -> String {
    let mut decl = String::from("    fts_spec spec;\n");
    let mut body = String::from("    spec.zpetc = NULL;\n    spec.hysteresis = NULL;\n");
    if file.zpetc.is_some() {
        decl.push_str("    fts_zpetc_spec zpetc;\n");
        body.push_str(
            "    zpetc.preview = FTS_PREVIEW;\n    zpetc.num = FTS_ZPETC_NUM;\n    zpetc.num_len = FTS_ZPETC_NUM_LEN;\n    zpetc.den = FTS_ZPETC_DEN;\n    zpetc.den_len = FTS_ZPETC_DEN_LEN;\n    spec.zpetc = &zpetc;\n",
        );
    }
    if let Some(h) = &file.hysteresis {
        decl.push_str("    fts_hysteresis_spec hysteresis;\n");
        let form = match h.operator {
            PlayForm::Lower => "FTS_PLAY_LOWER",
            PlayForm::Symmetric => "FTS_PLAY_SYMMETRIC",
        };
        let _ = write!(
            body,
            "    hysteresis.form = {form};\n    hysteresis.thresholds = FTS_HYST_THRESHOLDS;\n    hysteresis.thresholds_len = FTS_HYST_THRESHOLDS_LEN;\n    hysteresis.weights = FTS_HYST_WEIGHTS;\n    hysteresis.weights_len = FTS_HYST_WEIGHTS_LEN;\n    hysteresis.cbrt_gain = FTS_HYST_CBRT_GAIN;\n    hysteresis.offset = FTS_HYST_OFFSET;\n    hysteresis.input_offset = FTS_HYST_INPUT_OFFSET;\n    hysteresis.dead_zone_thresholds = FTS_HYST_DEAD_ZONE_THRESHOLDS;\n    hysteresis.dead_zone_thresholds_len = FTS_HYST_DEAD_ZONE_THRESHOLDS_LEN;\n    hysteresis.dead_zone_weights = FTS_HYST_DEAD_ZONE_WEIGHTS;\n    hysteresis.dead_zone_weights_len = FTS_HYST_DEAD_ZONE_WEIGHTS_LEN;\n    spec.hysteresis = &hysteresis;\n"
        );
    }
    let pid = |kind: &str| {
        format!(
            "    spec.feedback = {kind};\n    spec.pid.kp = FTS_PID_KP;\n    spec.pid.ki = FTS_PID_KI;\n    spec.pid.kd = FTS_PID_KD;\n    spec.pid.derivative_pole = FTS_PID_DERIVATIVE_POLE;\n    spec.pid.output_min = FTS_PID_OUTPUT_MIN;\n    spec.pid.output_max = FTS_PID_OUTPUT_MAX;\n"
        )
    };
    let no_pid = "    spec.pid.kp = 0.0;\n    spec.pid.ki = 0.0;\n    spec.pid.kd = 0.0;\n    spec.pid.derivative_pole = 0.0;\n    spec.pid.output_min = 0.0;\n    spec.pid.output_max = 0.0;\n";
    let no_ss = "    spec.ss.n = 0;\n    spec.ss.a = NULL;\n    spec.ss.b = NULL;\n    spec.ss.c = NULL;\n    spec.ss.d = 0.0;\n    spec.ss.output_min = -fts_infinity();\n    spec.ss.output_max = fts_infinity();\n    spec.ss.conditional_update = 0;\n";
    match &file.feedback {
        Feedback::None => {
            body.push_str("    spec.feedback = FTS_FEEDBACK_NONE;\n");
            body.push_str(no_pid);
            body.push_str(no_ss);
        }
        Feedback::Pid(_) => {
            body.push_str(&pid("FTS_FEEDBACK_PID"));
            body.push_str(no_ss);
        }
        Feedback::ParallelPid(p) => {
            body.push_str(&pid(if p.n.is_some() {
                "FTS_FEEDBACK_PID_FILTERED"
            } else {
                "FTS_FEEDBACK_PID"
            }));
            body.push_str(no_ss);
        }
        Feedback::StateSpace(k) => {
            body.push_str("    spec.feedback = FTS_FEEDBACK_STATE_SPACE;\n");
            body.push_str(no_pid);
            let _ = write!(
                body,
                "    spec.ss.n = FTS_SS_NX;\n    spec.ss.a = FTS_SS_A;\n    spec.ss.b = FTS_SS_B;\n    spec.ss.c = FTS_SS_C;\n    spec.ss.d = FTS_SS_D;\n    spec.ss.output_min = {};\n    spec.ss.output_max = {};\n    spec.ss.conditional_update = FTS_SS_CONDITIONAL_UPDATE;\n",
                if k.output_min.is_some() {
                    "FTS_SS_OUTPUT_MIN"
                } else {
                    "-fts_infinity()"
                },
                if k.output_max.is_some() {
                    "FTS_SS_OUTPUT_MAX"
                } else {
                    "fts_infinity()"
                },
            );
        }
    }
    format!(
        "\n/* The step: fts_runtime.h / fts_runtime.c (compile with -ffp-contract=off). */\n#include <stddef.h>\n#include \"fts_runtime.h\"\n\n/* Loads the coefficients above into *ctl, at rest. FTS_OK, or the reason with\n * *field (when field is not NULL) naming the offending list. */\nstatic inline fts_status fts_controller_init(fts_controller *ctl, const char **field)\n{{\n{decl}{body}    return fts_init(ctl, &spec, field);\n}}\n"
    )
}

/// Reads back a header written by [`to_c_header`] (for consistency tests and
/// for checking a header that a build system vendored).
pub fn parse_c_header(text: &str, source: &str) -> Result<ControllerFile, InputError> {
    let mut defines: Map<String, Value> = Map::new();
    let mut arrays: Map<String, Value> = Map::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("#define ") {
            let mut parts = rest.splitn(2, ' ');
            let (Some(name), Some(value)) = (parts.next(), parts.next()) else {
                continue;
            };
            defines.insert(name.to_owned(), Value::String(value.trim().to_owned()));
        } else if let Some(rest) = line.strip_prefix("static const double ") {
            let name = rest.split('[').next().unwrap_or("").to_owned();
            let body = rest
                .split_once('{')
                .and_then(|(_, b)| b.split_once('}'))
                .map(|(b, _)| b)
                .ok_or_else(|| InputError::new(source, "malformed array").at_line(n + 1))?;
            let values: Result<Vec<f64>, _> =
                body.split(',').map(|v| v.trim().parse::<f64>()).collect();
            let values = values.map_err(|_| {
                InputError::new(source, "malformed number")
                    .at_line(n + 1)
                    .in_field(name.clone())
            })?;
            let len_key = format!("{name}_LEN");
            let len: usize = defines
                .get(&len_key)
                .and_then(Value::as_str)
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| {
                    InputError::new(source, "array without its _LEN define").in_field(name.clone())
                })?;
            arrays.insert(name, json!(values[..len.min(values.len())].to_vec()));
        }
    }
    let d = |k: &str| -> Result<f64, InputError> {
        defines
            .get(k)
            .and_then(Value::as_str)
            .and_then(|s| s.parse::<f64>().ok())
            .ok_or_else(|| InputError::new(source, "missing or not a number").in_field(k))
    };
    let a = |k: &str| -> Vec<f64> {
        arrays
            .get(k)
            .and_then(Value::as_array)
            .map(|v| v.iter().filter_map(Value::as_f64).collect())
            .unwrap_or_default()
    };
    let flag = |k: &str| defines.get(k).and_then(Value::as_str) == Some("1");
    let format = defines
        .get("FTS_CONTROLLER_FORMAT")
        .and_then(Value::as_str)
        .unwrap_or("");
    if format != format!("\"{CONTROLLER_FORMAT}\"") {
        return Err(
            InputError::new(source, format!("not an {CONTROLLER_FORMAT} header"))
                .in_field("FTS_CONTROLLER_FORMAT"),
        );
    }
    let file = ControllerFile {
        ts: d("FTS_TS")?,
        units: Units::default(),
        zpetc: if flag("FTS_HAS_ZPETC") {
            Some(ZpetcBlock {
                preview: d("FTS_PREVIEW")? as usize,
                num: a("FTS_ZPETC_NUM"),
                den: a("FTS_ZPETC_DEN"),
            })
        } else {
            None
        },
        hysteresis: if flag("FTS_HAS_HYSTERESIS") {
            Some(HysteresisBlock {
                model: String::new(),
                operator: if flag("FTS_HYST_SYMMETRIC_PLAY") {
                    PlayForm::Symmetric
                } else {
                    PlayForm::Lower
                },
                thresholds: a("FTS_HYST_THRESHOLDS"),
                weights: a("FTS_HYST_WEIGHTS"),
                cbrt_gain: d("FTS_HYST_CBRT_GAIN")?,
                offset: d("FTS_HYST_OFFSET")?,
                input_offset: d("FTS_HYST_INPUT_OFFSET")?,
                dead_zone_thresholds: a("FTS_HYST_DEAD_ZONE_THRESHOLDS"),
                dead_zone_weights: a("FTS_HYST_DEAD_ZONE_WEIGHTS"),
            })
        } else {
            None
        },
        feedback: if flag("FTS_HAS_STATE_SPACE") {
            let nx = d("FTS_SS_NX")?;
            let k = StateSpaceBlock {
                a: a("FTS_SS_A"),
                b: a("FTS_SS_B"),
                c: a("FTS_SS_C"),
                d: d("FTS_SS_D")?,
                output_min: if flag("FTS_SS_HAS_OUTPUT_MIN") {
                    Some(d("FTS_SS_OUTPUT_MIN")?)
                } else {
                    None
                },
                output_max: if flag("FTS_SS_HAS_OUTPUT_MAX") {
                    Some(d("FTS_SS_OUTPUT_MAX")?)
                } else {
                    None
                },
                anti_windup: if flag("FTS_SS_CONDITIONAL_UPDATE") {
                    SsAntiWindup::ConditionalUpdate
                } else {
                    SsAntiWindup::None
                },
                discretisation: defines
                    .get("FTS_SS_DISCRETISATION")
                    .and_then(Value::as_str)
                    .map(|v| v.trim_matches('"').to_owned())
                    .unwrap_or_default(),
            };
            if nx != k.order() as f64 {
                return Err(InputError::new(
                    source,
                    format!("FTS_SS_NX is {nx} but FTS_SS_B has {} entries", k.order()),
                )
                .in_field("FTS_SS_NX"));
            }
            Feedback::StateSpace(k)
        } else if defines.get("FTS_HAS_FEEDBACK").and_then(Value::as_str) == Some("0") {
            Feedback::None
        } else if flag("FTS_PID_FORM_PARALLEL") {
            Feedback::ParallelPid(ParallelPid {
                kp: d("FTS_PID_CONTINUOUS_KP")?,
                ki: d("FTS_PID_CONTINUOUS_KI")?,
                kd: d("FTS_PID_CONTINUOUS_KD")?,
                n: if flag("FTS_PID_FILTERED") {
                    Some(d("FTS_PID_CONTINUOUS_N")?)
                } else {
                    None
                },
                output_min: d("FTS_PID_OUTPUT_MIN")?,
                output_max: d("FTS_PID_OUTPUT_MAX")?,
            })
        } else {
            Feedback::Pid(PidSpec {
                kp: d("FTS_PID_KP")?,
                ki: d("FTS_PID_KI")?,
                kd: d("FTS_PID_KD")?,
                output_min: d("FTS_PID_OUTPUT_MIN")?,
                output_max: d("FTS_PID_OUTPUT_MAX")?,
            })
        },
        provenance: Provenance::default(),
    };
    file.validate(source)?;
    Ok(file)
}

/// SHA-256 of `bytes` as lower-case hex (provenance of input files).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(bytes);
    let mut s = String::with_capacity(64);
    for b in digest {
        let _ = write!(s, "{b:02x}");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ControllerFile {
        ControllerFile {
            ts: 1e-4,
            units: Units::default(),
            zpetc: Some(ZpetcBlock {
                preview: 5,
                num: vec![0.2407318247472316, -0.18902262879152626, 0.1 + 0.2],
                den: vec![1.0, -2.3184882041405874],
            }),
            hysteresis: Some(HysteresisBlock {
                model: "mpi-cbrt".into(),
                operator: PlayForm::Lower,
                thresholds: vec![0.0, 0.9677, 1.9354],
                weights: vec![0.29, -0.063, 1.0 / 3.0],
                cbrt_gain: -0.0197,
                offset: 0.0,
                input_offset: 0.0,
                dead_zone_thresholds: vec![],
                dead_zone_weights: vec![],
            }),
            feedback: Feedback::Pid(PidSpec {
                kp: 0.05,
                ki: 0.3,
                kd: 0.0,
                output_min: 0.0,
                output_max: 10.0,
            }),
            provenance: Provenance {
                fts_version: "0.1.0".into(),
                inputs: vec![InputHash {
                    role: "zpetc".into(),
                    file: "zpetc.json".into(),
                    sha256: sha256_hex(b"abc"),
                }],
            },
        }
    }

    #[test]
    fn sha256_known_vector() {
        // FIPS 180-2 example "abc".
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn json_round_trip_is_exact_and_stable() {
        let f = sample();
        let text = f.to_json_string();
        let back = parse_controller(&text, "c.json").unwrap();
        assert_eq!(back, f);
        assert_eq!(back.to_json_string(), text);
    }

    #[test]
    fn c_header_carries_the_same_numbers() {
        let f = sample();
        let header = to_c_header(&f);
        let back = parse_c_header(&header, "c.h").unwrap();
        assert_eq!(back.zpetc, f.zpetc);
        assert_eq!(back.feedback, f.feedback);
        let (h0, h1) = (back.hysteresis.unwrap(), f.hysteresis.unwrap());
        assert_eq!(h0.thresholds, h1.thresholds);
        assert_eq!(h0.weights, h1.weights);
        assert_eq!(h0.cbrt_gain.to_bits(), h1.cbrt_gain.to_bits());
    }

    #[test]
    fn refuses_bad_files() {
        let good = sample().to_json_string();
        let doc: Value = serde_json::from_str(&good).unwrap();
        let edit = |f: &dyn Fn(&mut Value)| {
            let mut d = doc.clone();
            f(&mut d);
            d.to_string()
        };
        let cases: Vec<(String, &str)> = vec![
            (edit(&|d| d["format"] = json!("fts.controller/2")), "format"),
            (
                edit(&|d| d["blocks"][2]["type"] = json!("pidx")),
                "blocks[2].type",
            ),
            (
                edit(&|d| d["blocks"][2]["kp"] = json!("NaN")),
                "blocks[2].kp",
            ),
            (
                edit(&|d| d["blocks"][0]["num"][1] = json!(null)),
                "blocks[0].num[1]",
            ),
            (
                edit(&|d| {
                    d["blocks"][1]["weights"].as_array_mut().unwrap().pop();
                }),
                "blocks[1].weights",
            ),
            // Checked as strictly as the model file it came from.
            (
                edit(&|d| {
                    let t = d["blocks"][1]["thresholds"].as_array_mut().unwrap();
                    t.swap(0, 1);
                }),
                "blocks[1].thresholds",
            ),
            (
                edit(&|d| d["blocks"][1]["model"] = json!("preisach")),
                "blocks[1].model",
            ),
            (edit(&|d| d["preview"] = json!(4)), "preview"),
            (
                edit(&|d| d["blocks"][2]["output_min"] = json!(20.0)),
                "pid.output_min",
            ),
        ];
        for (text, field) in cases {
            let e = parse_controller(&text, "c.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
        }
        // Missing PID block.
        let mut f: Value = serde_json::from_str(&good).unwrap();
        f["blocks"].as_array_mut().unwrap().pop();
        let e = parse_controller(&f.to_string(), "c.json").unwrap_err();
        assert!(e.to_string().contains("missing block \"pid\" or"), "{e}");
        // Mis-ordered blocks.
        let mut f: Value = serde_json::from_str(&good).unwrap();
        f["blocks"].as_array_mut().unwrap().swap(0, 1);
        let e = parse_controller(&f.to_string(), "c.json").unwrap_err();
        assert!(e.to_string().contains("signal order"), "{e}");
    }
}
