//! Workflows as typed steps: one struct per command (`fts weight`,
//! `fts mixsyn`, `fts hinf`, `fts h2`, `fts c2d`, the state-space feedback
//! of `fts emit`), shared by the command line and the pipeline manifest.
//!
//! Each step is `serde::Deserialize` (unknown keys refused, missing keys
//! take the [`Default`]), has `validate()` (settings alone) and `run(...)`
//! (settings plus already-parsed inputs; no file-system I/O), and returns a
//! `Serialize` report whose `Display` is the human summary. A command only
//! turns its flags into the step and renders the report; a manifest step
//! deserialises into the same type, so a key means what the flag means.

pub mod controller;
pub mod convert;
pub mod response;
pub mod robust;

pub use controller::{
    AntiWindup, ControllerInputs, ControllerReport, Discretisation, SsController,
};
pub use robust::{
    C2d, C2dMethodChoice, C2dReport, H2, H2Report, Hinf, HinfReport, Mixsyn, MixsynInputs,
    MixsynReport, Weight, WeightReport, WeightShape,
};

/// `[re, im]` pairs, the JSON form of complex numbers in reports.
pub fn complex_pairs<'a>(
    values: impl IntoIterator<Item = &'a crate::lti::c64>,
) -> serde_json::Value {
    serde_json::Value::Array(
        values
            .into_iter()
            .map(|z| serde_json::json!([z.re, z.im]))
            .collect(),
    )
}

/// A complex number for people: `0.547500+0.674800j`.
pub fn fmt_complex(z: crate::lti::c64) -> String {
    if z.im == 0.0 {
        format!("{:.6}", z.re)
    } else {
        format!("{:.6}{:+.6}j", z.re, z.im)
    }
}

/// Why a step failed: its settings or inputs are at fault (`Input`), or the
/// computation broke down on valid input (`Computation`). Messages name the
/// setting (`field`) as a manifest key, never as a command-line flag; the
/// caller renders it (`--prewarp` or `field 'step.k.prewarp'`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// Bad settings or bad input data.
    #[error("{message}")]
    Input {
        /// The setting concerned, if one is.
        field: Option<&'static str>,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A numerical breakdown or another failure on valid input.
    #[error("{0}")]
    Computation(String),
}

impl StepError {
    /// Bad value of the setting `field`.
    pub fn setting(field: &'static str, message: impl Into<String>) -> Self {
        StepError::Input {
            field: Some(field),
            message: message.into(),
        }
    }

    /// Bad input not tied to one setting (e.g. an input file's content).
    pub fn input(message: impl Into<String>) -> Self {
        StepError::Input {
            field: None,
            message: message.into(),
        }
    }

    /// The computation failed.
    pub fn computation(message: impl Into<String>) -> Self {
        StepError::Computation(message.into())
    }
}

/// Settings that can be checked before any input is read.
pub trait Validate {
    /// Checks the settings alone.
    fn validate(&self) -> Result<(), StepError>;
}

/// `x` must be a finite positive number.
pub(crate) fn positive(field: &'static str, x: f64) -> Result<f64, StepError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(StepError::setting(
            field,
            format!("expected a positive number, got {x}"),
        ))
    }
}
