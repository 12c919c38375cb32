//! The controller coefficient file `fts.controller/1` and its C header form
//! (docs/formats.md).
//!
//! The JSON lists the blocks in signal order (ZPETC pre-filter, inverse
//! hysteresis feedforward, PID), each with every coefficient the real-time
//! loop needs, plus units, sample time, preview and provenance (fts version,
//! SHA-256 of each input file). The document types are in `document.rs`
//! (serde, every key known, an error naming its path such as
//! `blocks[2].a[1][0]`); keys are written in alphabetical order and floats
//! in the shortest form that parses back to the same `f64`, so regenerating
//! from the same inputs gives the same bytes. The C header
//! ([`to_c_header`], `c_header.rs`) carries the same numbers (shortest
//! round-trip decimal literals, exact under a correctly rounded `strtod`),
//! and [`parse_c_header`] reads them back for the four-way consistency test.

mod c_header;
mod document;
pub(crate) mod multiaxis;

pub use c_header::{C_RUNTIME_C, C_RUNTIME_H, parse_c_header, to_c_files, to_c_header};
pub use multiaxis::{
    MULTIAXIS_FORMAT, MultiAxisControllerFile, parse_multiaxis, to_multiaxis_c_header,
};

use super::InputError;
use super::tf_json::check_format;
use crate::runtime::{
    FeedbackSpec, FeedforwardTable, HysteresisSpec, PidFilteredSpec, PidSpec, PlayForm,
    RepetitiveSpec, RuntimeSpec, SsAntiWindup, StateSpaceSpec, ZpetcSpec,
};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::fmt::Write;

/// The format tag.
pub const CONTROLLER_FORMAT: &str = "fts.controller/1";

/// Units of the loop's signals.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InputHash {
    /// What it was used for (`zpetc`, `hysteresis_inverse`, ...).
    pub role: String,
    /// The file name as given.
    pub file: String,
    /// SHA-256 of its bytes, lower-case hex.
    pub sha256: String,
}

/// Where the coefficients came from.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Provenance {
    /// The fts version that wrote the file.
    pub fts_version: String,
    /// Hashes of the inputs.
    pub inputs: Vec<InputHash>,
}

/// ZPETC pre-filter block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZpetcBlock {
    /// Samples of reference look-ahead.
    pub preview: usize,
    /// Causal numerator, ascending `z^-1`.
    pub num: Vec<f64>,
    /// Causal denominator, ascending `z^-1`.
    pub den: Vec<f64>,
}

/// Plug-in repetitive compensator block (`fts repetitive`; the runtime's
/// `RepetitiveSpec`): `v(k) = Q(z) [v(k - N) + k_r e(k - N + m)]` on the
/// tracking error `e = r - y`, added to the loop's reference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RepetitiveBlock {
    /// Whole samples of the period `N0`.
    pub period: usize,
    /// Fractional part of the period, in `[0, 1)`.
    #[serde(default)]
    pub fraction: f64,
    /// Zero-phase low-pass taps `[q_0, q_1, .., q_h]`.
    pub q: Vec<f64>,
    /// Phase lead `m`, samples.
    pub lead: usize,
    /// Learning gain `k_r`.
    pub gain: f64,
}

impl RepetitiveBlock {
    /// The period in samples, `N0 + f`.
    pub fn period_samples(&self) -> f64 {
        self.period as f64 + self.fraction
    }
}

/// Learned feedforward table block (`fts ilc`): `f(k)` added to the loop's
/// reference at controller sample `k` of a run, 0 past its end.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedforwardTableBlock {
    /// `f(0), f(1), ..`, reference units.
    pub samples: Vec<f64>,
}

/// Inverse hysteresis feedforward block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HysteresisBlock {
    /// Model kind name (`pi`, `mpi-cbrt`, `mpi-deadzone`), for people.
    #[serde(default)]
    pub model: String,
    /// Play operator form.
    #[serde(with = "document::OperatorName")]
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
    #[serde(default)]
    pub dead_zone_thresholds: Vec<f64>,
    /// Dead-zone weights.
    #[serde(default)]
    pub dead_zone_weights: Vec<f64>,
    /// Input dead-zone thresholds: only in the analytic inverse of an
    /// MPI-deadzone model (docs/math.md §1.6); not written when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub input_dead_zone_thresholds: Vec<f64>,
    /// Input dead-zone weights.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub input_dead_zone_weights: Vec<f64>,
    /// How the block's model gives `u_ff`: `"model"` (default) evaluates
    /// it (it is an inverse model); `"solve"` inverts it per sample (it is
    /// the forward model, docs/math.md §1.6) on `command_range`.
    #[serde(default, skip_serializing_if = "Inversion::is_model")]
    pub inversion: Inversion,
    /// `[lo, hi]`, the bracket of the per-sample solve (with `"solve"` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command_range: Option<[f64; 2]>,
    /// Rate-dependent stage as in `fts.hysteresis/1` (docs/math.md §1.7).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_dependent: Option<RateBlock>,
}

/// How a hysteresis block yields `u_ff` (the block's `inversion`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Inversion {
    /// `u_ff = Y(r_f)`: the model is an inverse model.
    #[default]
    Model,
    /// `Y(u_ff) = r_f` solved per sample: the model is the forward model.
    Solve,
}

impl Inversion {
    fn is_model(&self) -> bool {
        *self == Inversion::Model
    }
}

/// The rate-dependent stage of a hysteresis block (docs/math.md §1.7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RateBlock {
    /// Sample time the model runs at, s.
    pub ts: f64,
    /// Input rate at which `|s| = 1`, input units per second.
    pub rate_scale: f64,
    /// Rate weights `w1_i`, one per play operator.
    pub weights: Vec<f64>,
    /// Velocity gain `g`.
    pub velocity_gain: f64,
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

/// The disturbance-observer block (`type: "dob"`, \[Karagoz18\]'s
/// adaptive robust axis controller; `fts_runtime::DobSpec`,
/// `synth::dob`): the outer controller on the error as a state-space block
/// (e.g. a PID by Tustin; its limits are the block's), the observer's `Q`
/// and nominal inverse `A/B` (`A` in powers of `1 - z^-1`) with the
/// nominal delay `d`, and the friction feedforward `Fc v/(|v| + v_eps) + Fv v`
/// on the reference velocity.
#[derive(Debug, Clone, PartialEq)]
pub struct DobBlock {
    /// The outer controller.
    pub outer: StateSpaceBlock,
    /// `Q` numerator, ascending `z^-1`.
    pub q_num: Vec<f64>,
    /// `Q` denominator.
    pub q_den: Vec<f64>,
    /// Nominal inverse numerator `A` (the nominal plant's denominator),
    /// ascending powers of `1 - z^-1`.
    pub inverse_num: Vec<f64>,
    /// Nominal inverse denominator `B` (the nominal plant's numerator
    /// without its delay), ascending `z^-1`.
    pub inverse_den: Vec<f64>,
    /// The nominal plant's delay `d`, samples.
    pub delay: usize,
    /// Coulomb friction feedforward `Fc`, command units.
    pub coulomb: f64,
    /// Viscous friction feedforward `Fv`, command per (reference unit/s).
    pub viscous: f64,
    /// Smoothing velocity `v_eps` of the sign, reference units/s.
    pub smoothing: f64,
    /// How the filters were made, for people; not used by the loop.
    pub design: String,
}

impl DobBlock {
    /// The block of the observer `filters` (`synth::dob::design`) around
    /// `outer`, with the friction feedforward `(Fc, Fv, v_eps)` and the
    /// design note.
    pub fn from_filters(
        outer: StateSpaceBlock,
        filters: crate::synth::dob::DobFilters,
        (coulomb, viscous, smoothing): (f64, f64, f64),
        design: String,
    ) -> Self {
        DobBlock {
            outer,
            q_num: filters.q_num,
            q_den: filters.q_den,
            inverse_num: filters.inverse_num,
            inverse_den: filters.inverse_den,
            delay: filters.delay,
            coulomb,
            viscous,
            smoothing,
            design,
        }
    }

    /// The runtime's coefficients at `ts` (absent limits infinite).
    pub fn runtime_spec(&self, ts: f64) -> crate::runtime::DobSpec<'_> {
        let k = &self.outer;
        crate::runtime::DobSpec {
            outer: StateSpaceSpec {
                a: &k.a,
                b: &k.b,
                c: &k.c,
                d: k.d,
                output_min: k.output_min.unwrap_or(f64::NEG_INFINITY),
                output_max: k.output_max.unwrap_or(f64::INFINITY),
                anti_windup: k.anti_windup,
            },
            q_num: &self.q_num,
            q_den: &self.q_den,
            inverse_num: &self.inverse_num,
            inverse_den: &self.inverse_den,
            delay: self.delay,
            coulomb: self.coulomb,
            viscous: self.viscous,
            smoothing: self.smoothing,
            ts,
        }
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

    /// The per-sample coefficients of [`Self::discretise`] and, with a
    /// derivative filter, its pole.
    fn per_sample(&self, ts: f64) -> (PidSpec, Option<f64>) {
        match self.discretise(ts) {
            FeedbackSpec::PidFiltered(d) => (
                PidSpec {
                    kp: d.kp,
                    ki: d.ki,
                    kd: d.kd,
                    output_min: d.output_min,
                    output_max: d.output_max,
                },
                Some(d.derivative_pole),
            ),
            FeedbackSpec::Pid(d) => (d, None),
            _ => unreachable!("a PID discretises to a PID"),
        }
    }

    /// The loop's coefficients at sample time `ts` by backward Euler,
    /// `s = (1 - z^-1)/Ts`: `ki Ts` per sample; without a filter the \[Li21\]
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
    /// The \[Li21\] PID, gains per sample.
    Pid(PidSpec),
    /// A PID given in continuous parallel form, discretised.
    ParallelPid(ParallelPid),
    /// A discrete state-space controller.
    StateSpace(StateSpaceBlock),
    /// A PID with a disturbance observer and friction feedforward.
    Dob(DobBlock),
}

impl Feedback {
    /// The runtime's coefficients at sample time `ts` (a parallel PID
    /// discretised, absent state-space limits infinite).
    pub fn runtime_spec(&self, ts: f64) -> FeedbackSpec<'_> {
        match self {
            Feedback::None => FeedbackSpec::None,
            Feedback::Pid(p) => FeedbackSpec::Pid(*p),
            Feedback::ParallelPid(p) => p.discretise(ts),
            Feedback::StateSpace(k) => FeedbackSpec::StateSpace(StateSpaceSpec {
                a: &k.a,
                b: &k.b,
                c: &k.c,
                d: k.d,
                output_min: k.output_min.unwrap_or(f64::NEG_INFINITY),
                output_max: k.output_max.unwrap_or(f64::INFINITY),
                anti_windup: k.anti_windup,
            }),
            Feedback::Dob(d) => FeedbackSpec::Dob(d.runtime_spec(ts)),
        }
    }
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
            HysteresisModel, ModelError, ModelKind, PlayOperator, RateStage,
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
            dead_zone: stage(&self.dead_zone_thresholds, &self.dead_zone_weights),
            input_dead_zone: stage(
                &self.input_dead_zone_thresholds,
                &self.input_dead_zone_weights,
            ),
            rate: self.rate_dependent.as_ref().map(|r| RateStage {
                ts: r.ts,
                rate_scale: r.rate_scale,
                weights: r.weights.clone(),
                velocity_gain: r.velocity_gain,
            }),
        };
        self.validate_inversion(&model, &err)?;
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

    /// `"solve"` needs a finite ordered `command_range` and nothing else
    /// does; a model to be solved must be strictly increasing from every
    /// state for the root to be unique (checked as far as its
    /// coefficients show it: docs/math.md §1.6).
    fn validate_inversion(
        &self,
        model: &crate::ident::hysteresis::HysteresisModel,
        err: &dyn Fn(&str, String) -> InputError,
    ) -> Result<(), InputError> {
        match (self.inversion, self.command_range) {
            (Inversion::Model, None) => Ok(()),
            (Inversion::Model, Some(_)) => Err(err(
                "command_range",
                "is used with \"inversion\": \"solve\" only".into(),
            )),
            (Inversion::Solve, None) => Err(err(
                "command_range",
                "\"inversion\": \"solve\" needs \"command_range\": [lo, hi]".into(),
            )),
            (Inversion::Solve, Some([lo, hi])) => {
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(err(
                        "command_range",
                        format!("expected finite [lo, hi] with lo < hi, found [{lo}, {hi}]"),
                    ));
                }
                crate::ident::hysteresis::check_solvable(model).map_err(|m| err("inversion", m))
            }
        }
    }

    /// The runtime's solve bracket (`None` unless `"solve"`).
    pub fn solve_bracket(&self) -> Option<(f64, f64)> {
        match (self.inversion, self.command_range) {
            (Inversion::Solve, Some([lo, hi])) => Some((lo, hi)),
            _ => None,
        }
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
            dead_zone_thresholds: lists(&m.dead_zone).0,
            dead_zone_weights: lists(&m.dead_zone).1,
            input_dead_zone_thresholds: lists(&m.input_dead_zone).0,
            input_dead_zone_weights: lists(&m.input_dead_zone).1,
            inversion: Inversion::Model,
            command_range: None,
            rate_dependent: m.rate.as_ref().map(|r| RateBlock {
                ts: r.ts,
                rate_scale: r.rate_scale,
                weights: r.weights.clone(),
                velocity_gain: r.velocity_gain,
            }),
        }
    }

    /// The block that inverts the forward model `m` per sample on
    /// `[lo, hi]` (docs/math.md §1.6).
    pub fn solving(m: &crate::ident::hysteresis::HysteresisModel, lo: f64, hi: f64) -> Self {
        Self {
            inversion: Inversion::Solve,
            command_range: Some([lo, hi]),
            ..Self::from_model(m)
        }
    }
}

/// A dead-zone stage from the block's two lists (none when both are empty;
/// a length mismatch is left to the model's validation).
fn stage(thresholds: &[f64], weights: &[f64]) -> Option<crate::ident::hysteresis::DeadZoneStage> {
    (!thresholds.is_empty() || !weights.is_empty()).then(|| {
        crate::ident::hysteresis::DeadZoneStage {
            thresholds: thresholds.to_vec(),
            weights: weights.to_vec(),
        }
    })
}

/// The two lists of an optional dead-zone stage (empty without one).
fn lists(stage: &Option<crate::ident::hysteresis::DeadZoneStage>) -> (Vec<f64>, Vec<f64>) {
    stage
        .as_ref()
        .map(|d| (d.thresholds.clone(), d.weights.clone()))
        .unwrap_or_default()
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
    /// Optional plug-in repetitive compensator.
    pub repetitive: Option<RepetitiveBlock>,
    /// Optional learned feedforward table.
    pub feedforward_table: Option<FeedforwardTableBlock>,
    /// Optional HC feedforward.
    pub hysteresis: Option<HysteresisBlock>,
    /// The feedback controller (PID or state space).
    pub feedback: Feedback,
    /// Provenance.
    pub provenance: Provenance,
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
                input_dead_zone_thresholds: &h.input_dead_zone_thresholds,
                input_dead_zone_weights: &h.input_dead_zone_weights,
                rate_weights: h.rate_dependent.as_ref().map_or(&[], |r| &r.weights),
                rate_ts: h.rate_dependent.as_ref().map_or(0.0, |r| r.ts),
                rate_scale: h.rate_dependent.as_ref().map_or(0.0, |r| r.rate_scale),
                velocity_gain: h.rate_dependent.as_ref().map_or(0.0, |r| r.velocity_gain),
                solve: h.solve_bracket(),
            }),
            feedback: self.feedback.runtime_spec(self.ts),
            repetitive: self.repetitive.as_ref().map(|r| RepetitiveSpec {
                period: r.period,
                fraction: r.fraction,
                q: &r.q,
                lead: r.lead,
                gain: r.gain,
            }),
        }
    }

    /// A player of the learned feedforward table, when there is one.
    pub fn feedforward_player(&self) -> Option<FeedforwardTable<'_>> {
        self.feedforward_table
            .as_ref()
            .and_then(|t| FeedforwardTable::new(&t.samples).ok())
    }

    /// This controller with `samples` as its learned feedforward table
    /// (none when `samples` is empty).
    pub fn with_feedforward(&self, samples: &[f64]) -> Self {
        Self {
            feedforward_table: (!samples.is_empty()).then(|| FeedforwardTableBlock {
                samples: samples.to_vec(),
            }),
            ..self.clone()
        }
    }

    /// The learned feedforward samples (empty without a table).
    pub fn learned_feedforward(&self) -> &[f64] {
        self.feedforward_table
            .as_ref()
            .map_or(&[], |t| t.samples.as_slice())
    }

    /// The command limits `(min, max)`; infinite where the state-space
    /// block has none.
    pub fn command_limits(&self) -> (f64, f64) {
        self.runtime_spec().feedback.limits()
    }

    /// The per-sample \[Li21\] PID, when the feedback controller is one.
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
                Feedback::Dob(_) => FeedbackKind::Dob,
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
        if self.repetitive.is_some() {
            v.push("repetitive");
        }
        if self.feedforward_table.is_some() {
            v.push("feedforward_table");
        }
        if self.hysteresis.is_some() {
            v.push("hysteresis_inverse");
        }
        v.push(match self.feedback {
            Feedback::None => "no_feedback",
            Feedback::Pid(_) | Feedback::ParallelPid(_) => "pid",
            Feedback::StateSpace(_) => "state_space",
            Feedback::Dob(_) => "dob",
        });
        v
    }

    /// The JSON document (keys in the documented order).
    /// The JSON document. Its objects are `serde_json` maps, so the file's
    /// keys are in alphabetical order at every level.
    pub fn to_value(&self) -> Value {
        serde_json::to_value(self.document()).expect("serialisable")
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
        let invalid = |e: crate::runtime::RuntimeError| {
            InputError::new(source, e.to_string()).in_field(runtime_field(&e))
        };
        if let Some(t) = &self.feedforward_table {
            FeedforwardTable::new(&t.samples).map_err(invalid)?;
        }
        crate::runtime::RuntimeController::new(&self.runtime_spec())
            .map(|_| ())
            .map_err(invalid)
    }
}

pub(crate) fn runtime_field(e: &crate::runtime::RuntimeError) -> &'static str {
    use crate::runtime::RuntimeError::*;
    match e {
        BadLength { field, .. }
        | OrderTooHigh { field, .. }
        | LengthMismatch { field }
        | NonFinite { field }
        | Invalid { field } => field,
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
    document::read(value, source)
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

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use serde_json::json;

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
                input_dead_zone_thresholds: vec![],
                input_dead_zone_weights: vec![],
                inversion: Inversion::Model,
                command_range: None,
                rate_dependent: None,
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
            repetitive: None,
            feedforward_table: None,
        }
    }

    pub fn sha256_known_vector() {
        // FIPS 180-2 example "abc".
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    pub fn json_round_trip_is_exact_and_stable() {
        let f = sample();
        let text = f.to_json_string();
        let back = parse_controller(&text, "c.json").unwrap();
        assert_eq!(back, f);
        assert_eq!(back.to_json_string(), text);
    }

    pub fn c_header_carries_the_same_numbers() {
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

    pub fn refuses_bad_files() {
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

    /// One file per feedback form, with and without the optional blocks.
    fn every_kind() -> Vec<ControllerFile> {
        let ts = 1e-4;
        let state_space = |limits: Option<(f64, f64)>, anti_windup| StateSpaceBlock {
            a: vec![0.5, 0.1, -0.2, 0.25],
            b: vec![1.0, -2.0 / 3.0],
            c: vec![0.1, 3e-7],
            d: 0.2,
            output_min: limits.map(|l| l.0),
            output_max: limits.map(|l| l.1),
            anti_windup,
            discretisation: "tustin prewarp 1000 Hz".into(),
        };
        let parallel = |n| ParallelPid {
            kp: 0.02,
            ki: 1500.0,
            kd: 6e-5,
            n,
            output_min: -1.0,
            output_max: 10.0,
        };
        let mut dead_zone = sample();
        if let Some(h) = &mut dead_zone.hysteresis {
            h.model = "mpi-deadzone".into();
            h.operator = PlayForm::Symmetric;
            h.cbrt_gain = 0.0;
            h.dead_zone_thresholds = vec![0.0, 0.5];
            h.dead_zone_weights = vec![1.0, 0.25];
        }
        let feedbacks = [
            Feedback::ParallelPid(parallel(Some(2000.0))),
            Feedback::ParallelPid(parallel(None)),
            Feedback::StateSpace(state_space(None, SsAntiWindup::ConditionalUpdate)),
            Feedback::StateSpace(state_space(Some((0.0, 10.0)), SsAntiWindup::None)),
            Feedback::None,
        ];
        let mut files = vec![sample(), dead_zone];
        for feedback in feedbacks {
            files.push(ControllerFile {
                ts,
                feedback: feedback.clone(),
                ..sample()
            });
            files.push(ControllerFile {
                zpetc: None,
                feedback,
                ..sample()
            });
        }
        files
    }

    pub fn every_block_kind_round_trips_byte_identically() {
        for f in every_kind() {
            let text = f.to_json_string();
            let back = parse_controller(&text, "c.json").unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert_eq!(back, f);
            assert_eq!(back.to_json_string(), text);
        }
    }

    pub fn c_header_carries_every_block_kind() {
        // The header has no model name, units or provenance.
        let numbers = |h: &Option<HysteresisBlock>| {
            h.clone().map(|h| HysteresisBlock {
                model: String::new(),
                ..h
            })
        };
        for f in every_kind() {
            let back = parse_c_header(&to_c_header(&f), "c.h").unwrap();
            assert_eq!(back.ts, f.ts);
            assert_eq!(back.zpetc, f.zpetc);
            assert_eq!(numbers(&back.hysteresis), numbers(&f.hysteresis));
            assert_eq!(back.feedback, f.feedback);
        }
    }

    fn error_of(f: &ControllerFile, edit: impl Fn(&mut Value)) -> InputError {
        let mut doc: Value = serde_json::from_str(&f.to_json_string()).unwrap();
        edit(&mut doc);
        parse_controller(&doc.to_string(), "controller.json").unwrap_err()
    }

    pub fn a_type_error_deep_in_a_block_names_its_path() {
        let ss = &every_kind()[6];
        assert!(ss.state_space().is_some());
        let e = error_of(ss, |d| d["blocks"][2]["a"][1][0] = json!("x"));
        assert_eq!(
            e.to_string(),
            "controller.json field 'blocks[2].a[1][0]': expected a number, found string \"x\""
        );
        let e = error_of(&sample(), |d| d["blocks"][1]["weights"][2] = json!([1.0]));
        assert_eq!(e.field.as_deref(), Some("blocks[1].weights[2]"), "{e}");
        let e = error_of(&sample(), |d| d["blocks"][0]["preview"] = json!(-1));
        assert_eq!(e.field.as_deref(), Some("blocks[0].preview"), "{e}");
        assert!(e.message.contains("non-negative whole number"), "{e}");
        let e = error_of(&sample(), |d| d["units"]["command"] = json!(5));
        assert_eq!(e.field.as_deref(), Some("units.command"), "{e}");
    }

    pub fn unknown_and_missing_keys_are_named() {
        let parallel = &every_kind()[2];
        type Edit<'a> = &'a dyn Fn(&mut Value);
        let cases: [(Edit, &str, &str); 6] = [
            (
                &|d| d["blocks"][1]["gain"] = json!(1.0),
                "blocks[1].gain",
                "unknown key",
            ),
            (
                &|d| d["blocks"][2]["continuous"]["ts"] = json!(1.0),
                "blocks[2].continuous.ts",
                "unknown key",
            ),
            (&|d| d["extra"] = json!(1.0), "extra", "unknown key"),
            (
                &|d| d["provenance"]["inputs"][0]["size"] = json!(3),
                "provenance.inputs[0].size",
                "unknown key",
            ),
            (
                &|d| {
                    d["blocks"][2].as_object_mut().unwrap().remove("kd");
                },
                "blocks[2].kd",
                "missing",
            ),
            (
                &|d| {
                    d["blocks"][2]["continuous"]
                        .as_object_mut()
                        .unwrap()
                        .remove("ki");
                },
                "blocks[2].continuous.ki",
                "missing",
            ),
        ];
        for (edit, field, message) in cases {
            let e = error_of(parallel, edit);
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.message.starts_with(message), "{e}");
        }
    }

    pub fn derived_fields_are_checked_against_the_blocks() {
        let parallel = &every_kind()[2];
        let e = error_of(parallel, |d| d["blocks"][2]["kd"] = json!(1.0));
        assert_eq!(e.field.as_deref(), Some("blocks[2].kd"), "{e}");
        let e = error_of(parallel, |d| {
            d["blocks"][2]
                .as_object_mut()
                .unwrap()
                .remove("derivative_pole");
        });
        assert_eq!(e.field.as_deref(), Some("blocks[2].derivative_pole"), "{e}");
        let e = error_of(&sample(), |d| {
            d["blocks"][2]["continuous"] = json!({"kp": 1.0, "ki": 1.0, "kd": 0.0});
        });
        assert_eq!(e.field.as_deref(), Some("blocks[2].continuous"), "{e}");
        let ss = &every_kind()[6];
        let e = error_of(ss, |d| d["blocks"][2]["states"] = json!(3));
        assert_eq!(e.field.as_deref(), Some("blocks[2].states"), "{e}");
        let e = error_of(ss, |d| d["blocks"][2]["input"] = json!("reference"));
        assert_eq!(e.field.as_deref(), Some("blocks[2].input"), "{e}");
    }
}
