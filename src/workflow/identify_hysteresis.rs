//! The hysteresis identification step: `fts identify hysteresis` and the
//! pipeline's `hysteresis` kind (docs/math.md §1.5; the inverse identified
//! directly as in \[Li21\], §1.6).

use super::{StepError, Validate, whole_number};
use crate::ident::hysteresis::gd::{GdState, Silent};
use crate::ident::hysteresis::{
    IdentifyError, IdentifyInfo, IdentifyParams, Method, ModelKind, PlayOperator, identify_observed,
};
use crate::io::hysteresis_json::{ModelFile, SignalInfo, model_to_value, value_range};
use crate::io::timeseries::{IoData, Timing};
use argmin::core::observers::Observe;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Model structure.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HysteresisModelKind {
    /// Classical Prandtl-Ishlinskii.
    Pi,
    /// PI plus a cube-root term (\[Li21\] Eq. 4).
    #[default]
    MpiCbrt,
    /// PI followed by one-sided dead-zone operators (\[Tang17\] Eq. 40-43).
    MpiDeadzone,
}

impl crate::workflow::Choices for HysteresisModelKind {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("pi", "Classical Prandtl–Ishlinskii"),
        ("mpi-cbrt", "PI plus a cube-root term (\\[Li21\\] Eq. 4)"),
        (
            "mpi-deadzone",
            "PI followed by one-sided dead-zone operators (\\[Tang17\\] Eq. 40-43)",
        ),
    ];
}

/// Play operator form.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlayOperatorChoice {
    /// One-sided play, output in [u - r, u] (\[Li21\]).
    PlayLower,
    /// Symmetric play, output in [u - r, u + r] (\[Tang17\]).
    PlaySymmetric,
}

impl crate::workflow::Choices for PlayOperatorChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "play-lower",
            "One-sided play, output in [u - r, u] (\\[Li21\\])",
        ),
        (
            "play-symmetric",
            "Symmetric play, output in [u - r, u + r] (\\[Tang17\\])",
        ),
    ];
}

/// Solver.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HysteresisMethod {
    /// Least squares by QR.
    #[default]
    Ls,
    /// L-BFGS gradient descent on the same cost.
    Gd,
}

impl crate::workflow::Choices for HysteresisMethod {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("ls", "Least squares by QR"),
        ("gd", "L-BFGS gradient descent on the same cost"),
    ];
}

/// `fts identify hysteresis`, pipeline kind `hysteresis`: a PI / MPI model
/// (or its inverse) from a voltage/displacement record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyHysteresis {
    /// Model structure; default mpi-cbrt.
    pub model: HysteresisModelKind,
    /// Play operator form; default play-lower for pi and mpi-cbrt,
    /// play-symmetric for mpi-deadzone.
    pub operator: Option<PlayOperatorChoice>,
    /// Play operators on the grid `r_i = i/N max|u|`; default 10.
    #[serde(deserialize_with = "whole_number")]
    pub operators: usize,
    /// Explicit play thresholds, strictly increasing; replace `operators`.
    pub thresholds: Option<Vec<f64>>,
    /// Dead-zone operators of mpi-deadzone; default 4.
    #[serde(deserialize_with = "whole_number")]
    pub dead_zone_operators: usize,
    /// Solver; default ls.
    pub method: HysteresisMethod,
    /// Keep every partial sum of the weights positive (ls only); default false.
    pub invertible: bool,
    /// Identify a constant output offset; default true.
    pub offset: bool,
    /// Identify the inverse directly: the recorded output drives the model;
    /// default false.
    pub inverse: bool,
    /// Rate-dependent weights `w_i + w1_i rho` (docs/math.md §1.7; pi and
    /// mpi-cbrt, least squares); the record needs a time column; default false.
    pub rate_dependent: bool,
    /// Iteration cap of each gradient solve (gd); default 2000. The old
    /// spelling `max_iters` is still read (deprecated).
    #[serde(alias = "max_iters")]
    pub max_iterations: u64,
    /// Quantity of the record's input column; default voltage.
    pub input_quantity: String,
    /// Unit of the record's input column; default V.
    pub input_unit: String,
    /// Quantity of the record's output column; default displacement.
    pub output_quantity: String,
    /// Unit of the record's output column; default um.
    pub output_unit: String,
}

impl Default for IdentifyHysteresis {
    fn default() -> Self {
        let d = IdentifyParams::default();
        IdentifyHysteresis {
            model: HysteresisModelKind::MpiCbrt,
            operator: None,
            operators: d.operators,
            thresholds: None,
            dead_zone_operators: d.dead_zone_operators,
            method: HysteresisMethod::Ls,
            invertible: d.invertible,
            offset: d.offset,
            inverse: false,
            rate_dependent: false,
            max_iterations: d.gd.max_iters,
            input_quantity: "voltage".into(),
            input_unit: "V".into(),
            output_quantity: "displacement".into(),
            output_unit: "um".into(),
        }
    }
}

impl Validate for IdentifyHysteresis {
    fn validate(&self) -> Result<(), StepError> {
        if self.invertible && self.method == HysteresisMethod::Gd {
            return Err(StepError::setting(
                "invertible",
                "the invertibility constraint needs `method` ls (gradient descent here is unconstrained)",
            ));
        }
        if self.rate_dependent {
            if self.model == HysteresisModelKind::MpiDeadzone {
                return Err(StepError::setting(
                    "rate_dependent",
                    "rate-dependent weights are for `model` pi or mpi-cbrt (mpi-deadzone is bilinear)",
                ));
            }
            if self.invertible {
                return Err(StepError::setting(
                    "rate_dependent",
                    "the invertibility constraint covers rate-independent weights only; drop `invertible`",
                ));
            }
        }
        Ok(())
    }
}

/// The record a hysteresis step identifies from (already read and cut).
#[derive(Debug, Clone, Copy)]
pub struct HysteresisInputs<'a> {
    /// The record.
    pub record: &'a IoData,
    /// Its name (a file path), for messages and the report.
    pub source: &'a str,
    /// Its first sample in the file (0-based data row), for the report.
    pub start: usize,
}

impl IdentifyHysteresis {
    /// The library's identification settings.
    pub fn params(&self) -> IdentifyParams {
        let mut params = IdentifyParams {
            kind: match self.model {
                HysteresisModelKind::Pi => ModelKind::Pi,
                HysteresisModelKind::MpiCbrt => ModelKind::MpiCbrt,
                HysteresisModelKind::MpiDeadzone => ModelKind::MpiDeadzone,
            },
            operator: self.operator.map(|o| match o {
                PlayOperatorChoice::PlayLower => PlayOperator::Lower,
                PlayOperatorChoice::PlaySymmetric => PlayOperator::Symmetric,
            }),
            operators: self.operators,
            thresholds: self.thresholds.clone(),
            dead_zone_operators: self.dead_zone_operators,
            offset: self.offset,
            method: match self.method {
                HysteresisMethod::Ls => Method::Ls,
                HysteresisMethod::Gd => Method::Gd,
            },
            invertible: self.invertible,
            ..Default::default()
        };
        params.gd.max_iters = self.max_iterations;
        params
    }

    /// Identifies the model.
    pub fn run(&self, inputs: HysteresisInputs<'_>) -> Result<HysteresisReport, StepError> {
        self.run_observed(inputs, Silent)
    }

    /// Identifies the model; `observer` sees every gradient iteration.
    pub fn run_observed<O>(
        &self,
        inputs: HysteresisInputs<'_>,
        observer: O,
    ) -> Result<HysteresisReport, StepError>
    where
        O: Observe<GdState> + Clone + 'static,
    {
        self.validate()?;
        let HysteresisInputs {
            record,
            source,
            start,
        } = inputs;
        let signal = |quantity: &str, unit: &str| SignalInfo {
            quantity: quantity.into(),
            unit: unit.into(),
        };
        let (file_in, file_out) = (
            signal(&self.input_quantity, &self.input_unit),
            signal(&self.output_quantity, &self.output_unit),
        );
        // [Li21] direct inverse: the displacement drives the model, the voltage is its output.
        let (u, y, model_in, model_out) = if self.inverse {
            (&record.output, &record.input, file_out, file_in)
        } else {
            (&record.input, &record.output, file_in, file_out)
        };
        let mut params = self.params();
        if self.rate_dependent {
            let ts = record.timing.as_ref().map(|t| t.ts).ok_or_else(|| {
                StepError::input(format!(
                    "{source}: a rate-dependent model needs the record's time column (the sample time of the rate)"
                ))
            })?;
            params.rate_ts = Some(ts);
        }
        let identified = identify_observed(u, y, &params, observer).map_err(|e| match e {
            IdentifyError::Solver(_) => StepError::computation(e.to_string()),
            IdentifyError::Thresholds(t) => StepError::setting("thresholds", t.to_string()),
            IdentifyError::InvalidParams(m) => StepError::input(m),
            other => StepError::input(format!("{source}: {other}")),
        })?;
        let mut file = ModelFile::identified(&identified, &params, model_in, model_out);
        file.input_range = value_range(u).map(|(lo, hi)| [lo, hi]);
        Ok(HysteresisReport {
            model_doc: model_doc(&file),
            fit: FitDoc {
                rms_percent: identified.info.fit.rms_percent,
                max_percent: identified.info.fit.max_percent,
                samples: identified.info.fit.samples,
            },
            method: params.method_name(),
            condition_number: identified.info.condition_number,
            iterations: identified.info.iterations,
            alternations: identified.info.alternations,
            cost: identified.info.cost,
            constraint_active: identified.info.constraint_active,
            inverse: self.inverse,
            source: source.to_string(),
            start,
            timing: record.timing.clone(),
            model_file: None,
            file,
            info: identified.info,
            model_input: u.clone(),
            model_output: y.clone(),
        })
    }
}

/// The model file's document without its format tag and fit record.
fn model_doc(file: &ModelFile) -> serde_json::Value {
    let mut value = model_to_value(file);
    if let Some(obj) = value.as_object_mut() {
        obj.remove("format");
        obj.remove("fit");
    }
    value
}

/// How well the model fits the record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FitDoc {
    /// `100 rms(e) / range(y)`.
    pub rms_percent: f64,
    /// `100 max|e| / range(y)`.
    pub max_percent: f64,
    /// Samples compared.
    pub samples: usize,
}

/// The identified model with its fit and how it was found. Serialised, the
/// model file's document (without `format`) plus these.
#[derive(Debug, Clone, Serialize)]
pub struct HysteresisReport {
    /// The model (`model`, `operator`, `mapping`, signals, thresholds, weights, ...).
    #[serde(flatten)]
    pub model_doc: serde_json::Value,
    /// The fit.
    pub fit: FitDoc,
    /// `ls`, `ls-invertible` or `gd`.
    pub method: &'static str,
    /// Condition number of the regression.
    pub condition_number: f64,
    /// Gradient iterations (0 for least squares).
    pub iterations: u64,
    /// Alternations (mpi-deadzone; 1 otherwise).
    pub alternations: usize,
    /// Final cost.
    pub cost: f64,
    /// Whether the invertibility constraint is active.
    pub constraint_active: bool,
    /// Whether the inverse was identified.
    pub inverse: bool,
    /// The record.
    pub source: String,
    /// Its first sample used.
    pub start: usize,
    /// Its time column.
    pub timing: Option<Timing>,
    /// Where the front end wrote the model file, if it did.
    pub model_file: Option<String>,
    /// The model file.
    #[serde(skip)]
    pub file: ModelFile,
    /// The identification's figures.
    #[serde(skip)]
    pub info: IdentifyInfo,
    /// The signal that drove the model.
    #[serde(skip)]
    pub model_input: Vec<f64>,
    /// The signal it was fitted to.
    #[serde(skip)]
    pub model_output: Vec<f64>,
}

impl fmt::Display for HysteresisReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let model = &self.file.model;
        let info = &self.info;
        writeln!(
            f,
            "{} model ({}), {} operators, {}: {} samples of {} from sample {}",
            model.kind.name(),
            model.operator.name(),
            model.operators(),
            self.file.mapping(),
            self.model_input.len(),
            self.source,
            self.start
        )?;
        writeln!(
            f,
            "fit: rms {:.4} %, max {:.4} % of the output range; condition number {:.3e}; {}{}",
            info.fit.rms_percent,
            info.fit.max_percent,
            info.condition_number,
            self.method,
            if self.method == "gd" {
                format!(", {} iterations", info.iterations)
            } else {
                String::new()
            }
        )?;
        if let Some(t) = &self.timing {
            writeln!(f, "{t}")?;
        }
        if model.kind == ModelKind::MpiDeadzone {
            writeln!(f, "alternations: {}", info.alternations)?;
        }
        writeln!(f, "  {:>3} {:>14} {:>14}", "i", "r_i", "w_i")?;
        for (i, (r, w)) in model.thresholds.iter().zip(&model.weights).enumerate() {
            writeln!(f, "  {i:>3} {r:>14.6} {w:>14.6}")?;
        }
        writeln!(
            f,
            "cbrt gain {:.6}, offset {:.6}",
            model.cbrt_gain, model.offset
        )?;
        if let Some(rate) = &model.rate {
            writeln!(
                f,
                "rate-dependent weights w_i + w1_i |s|, s = (du/dt)/{:.6e} (ts {:e} s):",
                rate.rate_scale, rate.ts
            )?;
            writeln!(f, "  {:>3} {:>14}", "i", "w1_i")?;
            for (i, w) in rate.weights.iter().enumerate() {
                writeln!(f, "  {i:>3} {w:>14.6}")?;
            }
            writeln!(f, "velocity gain {:.6}", rate.velocity_gain)?;
        }
        if let Some(dz) = &model.dead_zone {
            writeln!(f, "dead-zone stage:")?;
            writeln!(f, "  {:>3} {:>14} {:>14}", "j", "d_j", "g_j")?;
            for (j, (d, g)) in dz.thresholds.iter().zip(&dz.weights).enumerate() {
                writeln!(f, "  {j:>3} {d:>14.6} {g:>14.6}")?;
            }
        }
        if info.constraint_active {
            writeln!(
                f,
                "invertibility constraint active (some partial sums at their bound)"
            )?;
        }
        Ok(())
    }
}
