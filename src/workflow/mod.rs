//! Workflows as typed steps: one struct per command (`fts weight`,
//! `fts mixsyn`, `fts hinf`, `fts h2`, `fts c2d`, `fts emit`,
//! `fts virtual triangles|sweep`, `fts ding22`, ...), shared by the command
//! line and the pipeline manifest.
//!
//! Each step is `serde::Deserialize` (unknown keys refused, missing keys
//! take the [`Default`]), has `validate()` (settings alone) and `run(...)`
//! (settings plus already-parsed inputs; no file-system I/O), and returns a
//! `Serialize` report whose `Display` is the human summary. A command only
//! turns its flags into the step and renders the report; a manifest step
//! deserialises into the same type, so a key means what the flag means.

pub mod contour;
pub mod controller;
pub mod convert;
pub mod ding22;
pub mod experiment;
pub mod identify;
pub mod identify_ct;
mod identify_hysteresis;
pub mod ilc;
pub mod learning;
pub mod mechanism;
pub mod puu3;
pub mod response;
pub mod robust;
pub mod simulate;
pub mod zpetc;

pub use contour::{
    Contour, ContourInputs, ContourReport, MakeTrajectory, PathShape, TrajectoryReport,
    TrajectorySettings,
};
pub use controller::{
    AntiWindup, BuildController, BuildInputs, ControllerInputs, ControllerReport, Discretisation,
    NoFeedback, PidForm, SsController,
};
pub use ding22::{Ding22Report, Ding22Study};
pub use experiment::{VirtualRecord, VirtualSweep, VirtualTriangles};
pub use identify::{
    ArxStruct, IdentifyArx, IdentifyHysteresis, IdentifyIv, IdentifyOe, LinearInputs, LinearReport,
    Prepared, SelectionRuleChoice, StructReport,
};
pub use robust::{
    C2d, C2dMethodChoice, C2dReport, H2, H2Report, Hinf, HinfReport, Mixsyn, MixsynInputs,
    MixsynReport, Named, Weight, WeightReport, WeightShape,
};
pub use simulate::{
    ReferenceShape, SimController, SimPlant, Simulate, SimulateInputs, SimulateReport, StageModels,
};
pub use zpetc::{DesignZpetc, ZpetcReport};

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

/// A number as a person reads it back: as typed (shortest round trip)
/// from 1e-4 to 1e9, in scientific notation beyond (`1e300`, not three
/// hundred digits).
pub fn fmt_value(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A computed magnitude (a sample count, a duration) to 4 significant
/// digits, in scientific notation beyond 1e9.
pub fn fmt_about(x: f64) -> String {
    if x.is_finite() && x.abs() < 1e9 && x.abs() >= 1e-4 {
        let digits = (3 - x.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{x:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else if x == 0.0 || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:.3e}")
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

/// A message with the settings it names written as the front end calls
/// them: library messages write a setting as `` `key` `` (its manifest
/// key); `name` turns the key into `--key` or `'key'`.
pub fn render_settings(message: &str, name: impl Fn(&str) -> String) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(open) = rest.find('`') {
        let Some(len) = rest[open + 1..].find('`') else {
            break;
        };
        let key = &rest[open + 1..open + 1 + len];
        out.push_str(&rest[..open]);
        if key.starts_with(|c: char| c.is_ascii_lowercase())
            && key
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
        {
            out.push_str(&name(key));
        } else {
            out.push_str(&rest[open..open + len + 2]);
        }
        rest = &rest[open + len + 2..];
    }
    out.push_str(rest);
    out
}

/// Deserialises a count (`operators = 10`), refusing anything but a
/// non-negative whole number with a message that says so.
pub(crate) fn whole_number<'de, D: serde::Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    struct Whole;
    impl serde::de::Visitor<'_> for Whole {
        type Value = usize;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a non-negative whole number")
        }
        fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<usize, E> {
            usize::try_from(v)
                .map_err(|_| E::invalid_value(serde::de::Unexpected::Unsigned(v), &self))
        }
        fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<usize, E> {
            usize::try_from(v)
                .map_err(|_| E::invalid_value(serde::de::Unexpected::Signed(v), &self))
        }
    }
    d.deserialize_any(Whole)
}

/// [`whole_number`] for an optional count (absent: `None`).
pub(crate) fn some_whole_number<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<usize>, D::Error> {
    whole_number(d).map(Some)
}

/// A setting with a fixed vocabulary: each value's name, as a manifest
/// writes it (its serde name) and the command line takes it, with one line
/// of help. Front ends list the choices from here.
pub trait Choices: Sized + 'static {
    /// `(name, help)` of every value, in the order they are listed.
    const CHOICES: &'static [(&'static str, &'static str)];

    /// The name of `self` (its serde name).
    fn name(&self) -> &'static str
    where
        Self: serde::Serialize,
    {
        let value = serde_json::to_value(self).expect("a unit variant serialises");
        Self::CHOICES
            .iter()
            .find(|(name, _)| value == *name)
            .map(|(name, _)| *name)
            .expect("every value is listed in CHOICES")
    }
}

impl Choices for crate::ident::data::Detrend {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("none", "Keep the data as they are"),
        ("mean", "Remove each signal's mean"),
        ("linear", "Remove each signal's least-squares line"),
    ];
}

impl Choices for crate::lti::response::ResponseKind {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "step",
            "Unit step at t = 0, with rise/settling time, overshoot and steady-state error",
        ),
        (
            "impulse",
            "Unit impulse at t = 0 (a unit-area pulse 1/ts for discrete systems)",
        ),
    ];
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
            format!("expected a positive number, got {}", fmt_value(x)),
        ))
    }
}

/// Command limits `output_min`, `output_max` (either may be absent): each
/// given one finite (`expected` says what, e.g. "a finite command in V"),
/// and the lower below the upper. The one check of every step that clamps
/// a controller's command.
pub(crate) fn check_command_limits(
    min: Option<f64>,
    max: Option<f64>,
    expected: &str,
) -> Result<(), StepError> {
    for (field, v) in [("output_min", min), ("output_max", max)] {
        if let Some(v) = v.filter(|v| !v.is_finite()) {
            return Err(StepError::setting(
                field,
                format!("expected {expected}, got {}", fmt_value(v)),
            ));
        }
    }
    check_limit_order(min, max)
}

/// `output_min` below `output_max` when both are given.
pub(crate) fn check_limit_order(min: Option<f64>, max: Option<f64>) -> Result<(), StepError> {
    match (min, max) {
        (Some(lo), Some(hi)) if lo >= hi => Err(StepError::setting(
            "output_max",
            format!(
                "`output_max` ({}) must exceed `output_min` ({})",
                fmt_value(hi),
                fmt_value(lo)
            ),
        )),
        _ => Ok(()),
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn settings_in_messages_are_named_as_the_front_end_calls_them() {
        let m = "data.csv: no time column; give `ts` SECONDS or `max_iterations`";
        assert_eq!(
            render_settings("`k2` must be positive", |k| format!("--{k}")),
            "--k2 must be positive"
        );
        assert_eq!(
            render_settings(m, |k| format!("--{}", k.replace('_', "-"))),
            "data.csv: no time column; give --ts SECONDS or --max-iterations"
        );
        assert_eq!(
            render_settings(m, |k| format!("'{k}'")),
            "data.csv: no time column; give 'ts' SECONDS or 'max_iterations'"
        );
        // Not a key (spaces, capitals, unmatched): left as written.
        for m in ["use `fts identify oe`", "`A` and `", "a ` b", "`2a`"] {
            assert_eq!(render_settings(m, |_| "X".into()), m);
        }
    }

    pub fn numbers_are_printed_for_people() {
        assert_eq!(fmt_value(-1.0), "-1");
        assert_eq!(fmt_value(0.001), "0.001");
        assert_eq!(fmt_value(1e300), "1e300");
        assert_eq!(fmt_value(1e-9), "1e-9");
        assert_eq!(fmt_value(f64::NAN), "NaN");
        assert_eq!(fmt_about(79510282.4), "79510282");
        assert_eq!(fmt_about(6.5731), "6.573");
        assert_eq!(fmt_about(2.5066e299), "2.507e299");
        assert!(fmt_about(1.0 / 3.0 * 1e300).len() < 12);
    }

    /// Every listed name deserialises to a value whose name it is.
    fn names_round_trip<T: Choices + serde::Serialize + serde::de::DeserializeOwned>() {
        for (name, _) in T::CHOICES {
            let value: T = serde_json::from_value(serde_json::json!(name)).unwrap();
            assert_eq!(value.name(), *name);
        }
    }

    pub fn choices_are_the_serde_names() {
        names_round_trip::<crate::ident::data::Detrend>();
        names_round_trip::<crate::lti::response::ResponseKind>();
        names_round_trip::<crate::ident::excite::SweepSpacing>();
        names_round_trip::<Discretisation>();
        names_round_trip::<contour::PathShape>();
        names_round_trip::<AntiWindup>();
        names_round_trip::<PidForm>();
        names_round_trip::<NoFeedback>();
        names_round_trip::<WeightShape>();
        names_round_trip::<C2dMethodChoice>();
        names_round_trip::<convert::Form>();
        names_round_trip::<SelectionRuleChoice>();
        names_round_trip::<identify::OeStartChoice>();
        names_round_trip::<identify::InitialChoice>();
        names_round_trip::<identify_hysteresis::HysteresisModelKind>();
        names_round_trip::<identify_hysteresis::PlayOperatorChoice>();
        names_round_trip::<identify_hysteresis::HysteresisMethod>();
    }

    #[derive(Debug, serde::Deserialize)]
    struct Count {
        #[serde(deserialize_with = "whole_number")]
        n: usize,
    }

    pub fn counts_are_whole_numbers() {
        let n: Count = toml::from_str("n = 7").unwrap();
        assert_eq!(n.n, 7);
        for bad in ["n = -1", "n = \"five\"", "n = 1.5"] {
            let e = toml::from_str::<Count>(bad).unwrap_err().to_string();
            assert!(e.contains("non-negative whole number"), "{bad}: {e}");
        }
    }
}
