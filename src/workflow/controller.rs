//! The coefficient file with a state-space feedback controller: what
//! `fts emit --ss K.json [--c2d ...] [--prewarp ...]` writes.

use super::robust::prewarp_rad;
use super::{StepError, Validate, positive};
use crate::ident::hysteresis::HysteresisModel;
use crate::io::controller_file::{ControllerFile, Feedback, Provenance, StateSpaceBlock};
use crate::lti::c2d::{C2dMethod, c2d};
use crate::lti::ss::StateSpace;
use crate::runtime::{MAX_SS_ORDER, SsAntiWindup};
use crate::sim::experiment::build_controller;
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
    /// The loop's sample time: the ZPETC's, the `ts` setting and a discrete
    /// controller's, which must agree when more than one is given.
    pub fn sample_time(&self, zpetc_ts: Option<f64>, ss_ts: Option<f64>) -> Result<f64, StepError> {
        let candidates = [
            (zpetc_ts, "the ZPETC's"),
            (self.ts, "the ts setting's"),
            (ss_ts, "the state-space controller's"),
        ];
        let mut chosen: Option<(f64, &str)> = None;
        for (candidate, name) in candidates {
            match (chosen, candidate) {
                (Some((a, from)), Some(b)) if (a - b).abs() > 1e-12 * a => {
                    return Err(StepError::setting(
                        "ts",
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
                "missing: the sample time is needed when no ZPETC or discrete controller is given",
            )
        })?;
        positive("ts", ts)
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

    /// Builds the coefficient file.
    pub fn run(&self, inputs: ControllerInputs<'_>) -> Result<ControllerReport, StepError> {
        self.validate()?;
        let ts = self.sample_time(inputs.zpetc.map(|z| z.ts), inputs.ss.ts)?;
        let block = self.block(inputs.ss, ts, inputs.ss_source)?;
        let stages = Stages {
            feedback: FeedbackKind::StateSpace,
            hysteresis_compensation: inputs.hysteresis.is_some(),
            zpetc: inputs.zpetc.is_some(),
        };
        let file = build_controller(
            stages,
            ts,
            Feedback::StateSpace(block),
            inputs.hysteresis,
            inputs.zpetc,
            inputs.provenance,
        )
        .map_err(StepError::input)?;
        Ok(ControllerReport { file })
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
        if let (Some(lo), Some(hi)) = (self.output_min, self.output_max)
            && lo >= hi
        {
            return Err(StepError::setting(
                "output_max",
                format!("output_max ({hi}) must exceed output_min ({lo})"),
            ));
        }
        Ok(())
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
