//! The coefficient file a real-time loop reads: what `fts emit` and the
//! manifest's `controller` kind write. [`BuildController`] is the whole
//! step (PID in either form, a state-space controller, or no feedback,
//! after an optional ZPETC and inverse hysteresis feedforward);
//! [`SsController`] is its state-space part, shared with `fts simulate`.

use super::learning::RepetitiveFile;
use super::robust::prewarp_rad;
use super::{Choices, StepError, Validate, positive};
use crate::ident::hysteresis::HysteresisModel;
use crate::io::controller_file::{
    ControllerFile, Feedback, ParallelPid, Provenance, StateSpaceBlock, parse_controller,
};
use crate::lti::TransferFunction;
use crate::lti::c2d::{C2dMethod, c2d};
use crate::lti::ss::StateSpace;
use crate::runtime::{MAX_SS_ORDER, PidSpec, SsAntiWindup};
use crate::sim::experiment::{DEFAULT_PID, build_controller};
use crate::synth::composite::{FeedbackKind, Stages};
use crate::synth::zpetc::Zpetc;
use serde::{Deserialize, Serialize};
use std::fmt;

/// How a continuous controller is discretised at the loop's sample time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Discretisation {
    /// Tustin (bilinear), optionally prewarped.
    #[default]
    Tustin,
    /// Zero-order hold.
    Zoh,
}

/// What the controller's states do while the command is saturated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AntiWindup {
    /// Hold the states while the command is saturated and their update
    /// would push it further out.
    #[default]
    ConditionalUpdate,
    /// Clamp the command only.
    None,
}

/// A `fts.controller/1` file whose feedback is a state-space controller
/// (SISO, error in, command out), optionally after a ZPETC and an inverse
/// hysteresis feedforward.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SsController {
    /// Loop sample time, s; default: the ZPETC's or the discrete
    /// controller's (all that are given must agree).
    pub ts: Option<f64>,
    /// Discretisation of a continuous controller; default tustin.
    pub c2d: Discretisation,
    /// Tustin prewarp frequency, Hz; default none.
    pub prewarp: Option<f64>,
    /// State handling under saturation; default conditional-update.
    pub ss_anti_windup: AntiWindup,
    /// Lowest command, V; default no limit.
    pub output_min: Option<f64>,
    /// Highest command, V; default no limit.
    pub output_max: Option<f64>,
}

/// What [`SsController::run`] combines.
#[derive(Debug, Clone)]
pub struct ControllerInputs<'a> {
    /// The feedback controller (continuous or discrete).
    pub ss: &'a StateSpace,
    /// Its name (a file path), for messages.
    pub ss_source: &'a str,
    /// Inverse hysteresis model for the feedforward, if any.
    pub hysteresis: Option<&'a HysteresisModel>,
    /// ZPETC pre-filter, if any.
    pub zpetc: Option<&'a Zpetc>,
    /// Version and input hashes recorded in the file.
    pub provenance: Provenance,
}

impl SsController {
    /// The whole step with these settings and a state-space feedback.
    fn build_step(&self) -> BuildController {
        BuildController {
            ts: self.ts,
            c2d: self.c2d,
            prewarp: self.prewarp,
            ss_anti_windup: self.ss_anti_windup,
            output_min: self.output_min,
            output_max: self.output_max,
            ..BuildController::default()
        }
    }

    /// The loop's sample time: the ZPETC's, the `ts` setting and a discrete
    /// controller's, which must agree when more than one is given.
    pub fn sample_time(&self, zpetc_ts: Option<f64>, ss_ts: Option<f64>) -> Result<f64, StepError> {
        self.build_step().sample_time(zpetc_ts, ss_ts)
    }

    fn method(&self, ts: f64) -> Result<(C2dMethod, String), StepError> {
        match (self.c2d, self.prewarp) {
            (Discretisation::Zoh, None) => Ok((C2dMethod::Zoh, "zoh".to_owned())),
            (Discretisation::Zoh, Some(_)) => Err(StepError::setting(
                "prewarp",
                "applies to the tustin discretisation only",
            )),
            (Discretisation::Tustin, None) => {
                Ok((C2dMethod::Tustin { prewarp: None }, "tustin".to_owned()))
            }
            (Discretisation::Tustin, Some(f)) => Ok((
                C2dMethod::Tustin {
                    prewarp: Some(prewarp_rad(f, ts)?),
                },
                format!("tustin prewarp {f} Hz"),
            )),
        }
    }

    /// Poles of a continuous controller beyond the Nyquist frequency of
    /// `ts` (`|s| > pi / ts`), each with its frequency in Hz: no
    /// discretisation at `ts` reproduces them (Tustin folds them towards
    /// `z = -1`, ZOH aliases them), so the emitted controller differs from
    /// the designed one there. Empty for a discrete controller.
    pub fn poles_beyond_nyquist(sys: &StateSpace, ts: f64) -> Vec<(crate::lti::c64, f64)> {
        if sys.is_discrete() || ts.is_nan() || ts <= 0.0 {
            return Vec::new();
        }
        let nyquist_rad = std::f64::consts::PI / ts;
        sys.poles()
            .unwrap_or_default()
            .into_iter()
            .filter(|p| p.norm() > nyquist_rad)
            .map(|p| (p, p.norm() / (2.0 * std::f64::consts::PI)))
            .collect()
    }

    /// The feedback block of `sys` at sample time `ts`, discretised when
    /// continuous (`source` names `sys` in messages).
    pub fn block(
        &self,
        sys: &StateSpace,
        ts: f64,
        source: &str,
    ) -> Result<StateSpaceBlock, StepError> {
        let (discrete, label) = if sys.is_discrete() {
            if self.prewarp.is_some() {
                return Err(StepError::setting(
                    "prewarp",
                    format!("{source} is already discrete; nothing to discretise"),
                ));
            }
            (sys.clone(), "given".to_owned())
        } else {
            let (method, label) = self.method(ts)?;
            // Diagonal power-of-two scaling: exact, input-output unchanged, and
            // the coefficients the loop multiplies are of comparable size.
            let d = c2d(sys, ts, method)
                .map_err(|e| StepError::input(format!("{source}: discretisation: {e}")))?
                .balanced();
            (d, label)
        };
        let mut block = StateSpaceBlock::from_discrete(&discrete, ts, &label)
            .map_err(|e| StepError::input(format!("{source}: {e}")))?;
        if block.order() > MAX_SS_ORDER {
            return Err(StepError::input(format!(
                "{source}: {} states, the runtime takes at most {MAX_SS_ORDER} (MAX_SS_ORDER); reduce it first (mixsyn's order setting)",
                block.order(),
            )));
        }
        block.output_min = self.output_min;
        block.output_max = self.output_max;
        block.anti_windup = match self.ss_anti_windup {
            AntiWindup::ConditionalUpdate => SsAntiWindup::ConditionalUpdate,
            AntiWindup::None => SsAntiWindup::None,
        };
        Ok(block)
    }

    /// Builds the coefficient file ([`BuildController`] with this feedback).
    pub fn run(&self, inputs: ControllerInputs<'_>) -> Result<ControllerReport, StepError> {
        self.validate()?;
        self.build_step().run(BuildInputs {
            hysteresis: inputs.hysteresis,
            zpetc: inputs.zpetc,
            ss: Some((inputs.ss, inputs.ss_source)),
            repetitive: None,
            provenance: inputs.provenance,
        })
    }
}

impl Validate for SsController {
    fn validate(&self) -> Result<(), StepError> {
        if let Some(ts) = self.ts {
            positive("ts", ts)?;
        }
        if self.c2d == Discretisation::Zoh && self.prewarp.is_some() {
            return Err(StepError::setting(
                "prewarp",
                "applies to the tustin discretisation only",
            ));
        }
        super::check_limit_order(self.output_min, self.output_max)
    }
}

impl Choices for Discretisation {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("tustin", "Tustin (bilinear), optionally prewarped"),
        ("zoh", "Zero-order hold"),
    ];
}

impl Choices for AntiWindup {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "conditional-update",
            "Hold the states while the command is saturated and their update would push it further out",
        ),
        ("none", "Clamp the command only"),
    ];
}

impl Choices for PidForm {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "parallel",
            "Continuous parallel form: `kp`, `ki` in 1/s, `kd` in s (MATLAB `pid(Kp, Ki, Kd, 1/N)`), discretised by backward Euler at the loop's sample time; the file records both",
        ),
        ("li21", "\\[Li21\\] Eq. 5 gains per sample, used as given"),
    ];
}

impl Choices for NoFeedback {
    const CHOICES: &'static [(&'static str, &'static str)] = &[(
        "none",
        "No feedback controller: a feedforward-only file (ZPETC and/or HC)",
    )];
}

/// Which form PID gains are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PidForm {
    /// Continuous parallel form: `kp`, `ki` in 1/s, `kd` in s (MATLAB
    /// `pid(Kp, Ki, Kd, 1/N)`), discretised by backward Euler at the loop's
    /// sample time; the file records both.
    Parallel,
    /// \[Li21\] Eq. 5 gains per sample, used as given.
    Li21,
}

/// The one value of the `feedback` setting: say that a file has no
/// feedback controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NoFeedback {
    /// No feedback controller: a feedforward-only file (ZPETC and/or HC).
    None,
}

/// The coefficient file of `fts emit` and of the manifest's `controller`
/// kind: an optional ZPETC and inverse hysteresis feedforward, then the
/// feedback asked for and no other: a PID (`pid_form` with gains), the
/// state-space controller given as input, or none (`feedback`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BuildController {
    /// Which form the PID gains are in; no default, required with gains
    /// (per-sample gains read as continuous ones are `1/ts` times off).
    pub pid_form: Option<PidForm>,
    /// PID proportional gain; 0 when only other gains are given.
    pub kp: Option<f64>,
    /// PID integral gain: 1/s (parallel) or per sample (li21); default 0.
    pub ki: Option<f64>,
    /// PID derivative gain on the measurement: s (parallel) or per sample
    /// (li21); default 0.
    pub kd: Option<f64>,
    /// Derivative filter bandwidth `N`, rad/s (parallel only); default none.
    pub pid_n: Option<f64>,
    /// `none`: no feedback controller (a feedforward-only file).
    pub feedback: Option<NoFeedback>,
    /// Loop sample time, s; default: the ZPETC's or the discrete state-space
    /// controller's (all that are given must agree).
    pub ts: Option<f64>,
    /// Discretisation of a continuous state-space controller; default tustin.
    pub c2d: Discretisation,
    /// Tustin prewarp frequency, Hz (state-space controller only); default none.
    pub prewarp: Option<f64>,
    /// State handling under saturation (state-space controller only);
    /// default conditional-update.
    pub ss_anti_windup: AntiWindup,
    /// Lowest command, V; default 0 with a PID ([`DEFAULT_PID`]), no limit
    /// with a state-space controller.
    pub output_min: Option<f64>,
    /// Highest command, V; default 10 with a PID, no limit with a
    /// state-space controller.
    pub output_max: Option<f64>,
}

/// What [`BuildController::run`] combines: the inputs already parsed.
#[derive(Debug, Clone)]
pub struct BuildInputs<'a> {
    /// Inverse hysteresis model for the feedforward, if any.
    pub hysteresis: Option<&'a HysteresisModel>,
    /// ZPETC pre-filter (given, or designed by [`closed_loop_zpetc`]), if any.
    pub zpetc: Option<&'a Zpetc>,
    /// State-space feedback controller and its name (a file path), if any.
    pub ss: Option<(&'a StateSpace, &'a str)>,
    /// Plug-in repetitive compensator (a `fts repetitive` design) and its
    /// name, if any; its sample time must be the controller's.
    pub repetitive: Option<(&'a RepetitiveFile, &'a str)>,
    /// Version and input hashes recorded in the file.
    pub provenance: Provenance,
}

/// The ZPETC built from a closed-loop model with default settings (what a
/// `closed_loop` input stands for); `source` names the model.
pub fn closed_loop_zpetc(model: &TransferFunction, source: &str) -> Result<Zpetc, StepError> {
    let TransferFunction::Discrete(g) = model else {
        return Err(StepError::input(format!(
            "{source} field 'var': the closed-loop model must be discrete"
        )));
    };
    // The design and its self-check (docs/formats.md "Self-checks").
    super::zpetc::DesignZpetc::default()
        .design(g, source)
        .map(|r| r.filter)
}

/// Without any feedback setting: the three ways to say which feedback.
const NO_FEEDBACK_GIVEN: &str = "no feedback controller given: PID gains (`pid_form` parallel|li21 `kp` .. `ki` .. [`kd` ..]), a state-space controller (`ss` K.json), or `feedback` none for a feedforward-only file";

impl BuildController {
    fn gains_given(&self) -> bool {
        self.kp.is_some() || self.ki.is_some() || self.kd.is_some()
    }

    fn pid_given(&self) -> bool {
        self.gains_given() || self.pid_form.is_some() || self.pid_n.is_some()
    }

    /// The state-space part of these settings.
    pub fn ss_step(&self) -> SsController {
        SsController {
            ts: self.ts,
            c2d: self.c2d,
            prewarp: self.prewarp,
            ss_anti_windup: self.ss_anti_windup,
            output_min: self.output_min,
            output_max: self.output_max,
        }
    }

    /// The command limits: as given, a PID's defaulting to [`DEFAULT_PID`]'s.
    fn limits(&self) -> (Option<f64>, Option<f64>) {
        if self.pid_given() {
            (
                Some(self.output_min.unwrap_or(DEFAULT_PID.output_min)),
                Some(self.output_max.unwrap_or(DEFAULT_PID.output_max)),
            )
        } else {
            (self.output_min, self.output_max)
        }
    }

    /// The loop's sample time: the ZPETC's, the `ts` setting and a discrete
    /// state-space controller's, which must agree when more than one is given.
    pub fn sample_time(&self, zpetc_ts: Option<f64>, ss_ts: Option<f64>) -> Result<f64, StepError> {
        let candidates = [
            (zpetc_ts, "zpetc", "the ZPETC's"),
            (self.ts, "ts", "`ts`"),
            (ss_ts, "ss", "the `ss` controller's"),
        ];
        let mut chosen: Option<(f64, &str)> = None;
        for (candidate, key, name) in candidates {
            match (chosen, candidate) {
                (Some((a, from)), Some(b)) if (a - b).abs() > 1e-12 * a => {
                    return Err(StepError::setting(
                        key,
                        format!("{name} sample time {b} s disagrees with {from} {a} s"),
                    ));
                }
                (None, Some(b)) => chosen = Some((b, name)),
                _ => {}
            }
        }
        let (ts, _) = chosen.ok_or_else(|| {
            StepError::setting(
                "ts",
                "the sample time is needed when no ZPETC, closed-loop model or discrete controller is given",
            )
        })?;
        positive_seconds(ts)
    }

    /// Which feedback the settings and the inputs ask for (`has_ss`: a
    /// state-space controller is given), refusing two at once or none.
    pub fn feedback_kind(&self, has_ss: bool) -> Result<FeedbackKind, StepError> {
        match (has_ss, self.feedback, self.pid_given()) {
            (true, Some(_), _) => Err(StepError::setting(
                "feedback",
                "`feedback` none and the state-space controller `ss` exclude each other",
            )),
            (true, None, true) => Err(StepError::setting(
                self.first_pid_key(),
                "PID settings and the state-space controller `ss` exclude each other",
            )),
            (true, None, false) => Ok(FeedbackKind::StateSpace),
            (false, None, false) => Err(StepError::setting("pid_form", NO_FEEDBACK_GIVEN)),
            (false, _, _) if self.prewarp.is_some() => Err(StepError::setting(
                "prewarp",
                "goes with a state-space controller `ss`",
            )),
            (false, Some(NoFeedback::None), _) => Ok(FeedbackKind::None),
            (false, None, true) => Ok(FeedbackKind::Pid),
        }
    }

    fn first_pid_key(&self) -> &'static str {
        [
            ("pid_form", self.pid_form.is_some()),
            ("kp", self.kp.is_some()),
            ("ki", self.ki.is_some()),
            ("kd", self.kd.is_some()),
        ]
        .into_iter()
        .find_map(|(key, given)| given.then_some(key))
        .unwrap_or("pid_n")
    }

    /// The PID settings, each checked where it is named: the form stated,
    /// the gains finite, the limits finite and ordered.
    fn validate_pid(&self) -> Result<(), StepError> {
        let Some(form) = self.pid_form else {
            if self.gains_given() {
                return Err(StepError::setting(
                    "pid_form",
                    "say which form the PID gains are in: parallel (Kp, Ki in 1/s, Kd in s, as MATLAB's pid) or li21 (gains per sample)",
                ));
            }
            return Ok(());
        };
        if !self.gains_given() {
            return Err(StepError::setting(
                "kp",
                "`pid_form` given without any PID gain",
            ));
        }
        let pid = self.parallel_pid();
        for (key, value) in [("kp", pid.kp), ("ki", pid.ki), ("kd", pid.kd)] {
            if !value.is_finite() {
                return Err(StepError::setting(
                    key,
                    format!("expected a finite gain, got {value}"),
                ));
            }
        }
        self.validate_limits()?;
        match form {
            PidForm::Li21 if self.pid_n.is_some() => Err(StepError::setting(
                "pid_n",
                "the derivative filter goes with `pid_form` parallel",
            )),
            PidForm::Li21 => Ok(()),
            PidForm::Parallel => pid
                .validate()
                .map_err(|(key, m)| StepError::setting(if key == "n" { "pid_n" } else { key }, m)),
        }
    }

    fn validate_limits(&self) -> Result<(), StepError> {
        let (lo, hi) = self.limits();
        let finite = |x: Option<f64>| x.is_none_or(f64::is_finite);
        let ordered = match (lo, hi) {
            (Some(lo), Some(hi)) => lo < hi,
            _ => true,
        };
        if finite(lo) && finite(hi) && ordered {
            return Ok(());
        }
        let shown = |x: Option<f64>| x.map_or_else(|| "none".to_owned(), |x| x.to_string());
        Err(StepError::setting(
            "output_max",
            format!(
                "`output_min`/`output_max`: expected finite limits with min < max, got {} and {}",
                shown(lo),
                shown(hi)
            ),
        ))
    }

    /// The gains as a parallel-form PID (absent gains 0).
    fn parallel_pid(&self) -> ParallelPid {
        let (lo, hi) = self.limits();
        ParallelPid {
            kp: self.kp.unwrap_or(0.0),
            ki: self.ki.unwrap_or(0.0),
            kd: self.kd.unwrap_or(0.0),
            n: self.pid_n,
            output_min: lo.unwrap_or(DEFAULT_PID.output_min),
            output_max: hi.unwrap_or(DEFAULT_PID.output_max),
        }
    }

    /// The PID block the settings describe (validated).
    fn pid(&self) -> Feedback {
        let pid = self.parallel_pid();
        match self.pid_form {
            Some(PidForm::Parallel) => Feedback::ParallelPid(pid),
            _ => Feedback::Pid(PidSpec {
                kp: pid.kp,
                ki: pid.ki,
                kd: pid.kd,
                output_min: pid.output_min,
                output_max: pid.output_max,
            }),
        }
    }

    /// The feedback block of `kind` at sample time `ts`.
    fn feedback(
        &self,
        kind: FeedbackKind,
        ts: f64,
        inputs: &BuildInputs<'_>,
    ) -> Result<Feedback, StepError> {
        match (kind, inputs.ss) {
            (FeedbackKind::StateSpace, Some((sys, source))) => {
                Ok(Feedback::StateSpace(self.ss_step().block(sys, ts, source)?))
            }
            (FeedbackKind::None, _) if inputs.hysteresis.is_none() && inputs.zpetc.is_none() => {
                Err(StepError::setting(
                    "feedback",
                    "`feedback` none: a feedforward-only controller needs `hysteresis`, `zpetc` or `closed_loop`",
                ))
            }
            (FeedbackKind::None, _) => Ok(Feedback::None),
            _ => Ok(self.pid()),
        }
    }

    /// Builds the coefficient file.
    pub fn run(&self, inputs: BuildInputs<'_>) -> Result<ControllerReport, StepError> {
        let ts = self.sample_time(
            inputs.zpetc.map(|z| z.ts),
            inputs.ss.and_then(|(sys, _)| sys.ts),
        )?;
        self.validate()?;
        let kind = self.feedback_kind(inputs.ss.is_some())?;
        let feedback = self.feedback(kind, ts, &inputs)?;
        let stages = Stages {
            feedback: kind,
            hysteresis_compensation: inputs.hysteresis.is_some(),
            zpetc: inputs.zpetc.is_some(),
        };
        let mut file = build_controller(
            stages,
            ts,
            feedback,
            inputs.hysteresis,
            inputs.zpetc,
            inputs.provenance,
        )
        .map_err(StepError::input)?;
        if let Some((design, source)) = inputs.repetitive {
            file.repetitive = Some(design.block_at(ts, source)?);
            // Checked as a real-time loop would load it (capacity, taps).
            file = parse_controller(&file.to_json_string(), source)
                .map_err(|e| StepError::input(e.to_string()))?;
        }
        Ok(ControllerReport { file })
    }
}

impl Validate for BuildController {
    fn validate(&self) -> Result<(), StepError> {
        if let Some(ts) = self.ts {
            positive_seconds(ts)?;
        }
        if self.feedback.is_some() {
            if self.pid_given() {
                return Err(StepError::setting(
                    self.first_pid_key(),
                    "PID settings and `feedback` none exclude each other",
                ));
            }
            if self.output_min.is_some() || self.output_max.is_some() {
                return Err(StepError::setting(
                    "output_min",
                    "`output_min`/`output_max`: a feedforward-only controller (`feedback` none) has no command limits; clamp in the loop",
                ));
            }
        }
        self.validate_pid()?;
        self.validate_limits()?;
        if self.c2d == Discretisation::Zoh && self.prewarp.is_some() {
            return Err(StepError::setting(
                "prewarp",
                "applies to the tustin discretisation only",
            ));
        }
        Ok(())
    }
}

/// `ts` must be a finite positive number of seconds.
fn positive_seconds(ts: f64) -> Result<f64, StepError> {
    if ts.is_finite() && ts > 0.0 {
        Ok(ts)
    } else {
        Err(StepError::setting(
            "ts",
            format!("expected a positive number of seconds, got {ts}"),
        ))
    }
}

/// The coefficient file.
#[derive(Debug, Clone)]
pub struct ControllerReport {
    /// The file (`to_json_string`, `to_c_header` give its bytes).
    pub file: ControllerFile,
}

impl Serialize for ControllerReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        serde_json::json!({
            "stages": self.file.stages_name(),
            "preview": self.file.preview(),
            "ts": self.file.ts,
        })
        .serialize(s)
    }
}

impl fmt::Display for ControllerReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}, preview {} samples, ts {} s",
            self.file.stages_name(),
            self.file.preview(),
            self.file.ts
        )
    }
}
