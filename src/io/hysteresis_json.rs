//! The `fts.hysteresis/1` file: an identified hysteresis model (docs/formats.md).
//!
//! ```json
//! {"format": "fts.hysteresis/1", "model": "mpi-cbrt", "operator": "play-lower",
//!  "mapping": "voltage->displacement",
//!  "input": {"quantity": "voltage", "unit": "V"},
//!  "output": {"quantity": "displacement", "unit": "um"},
//!  "thresholds": [...], "weights": [...], "cbrt_gain": -0.0197,
//!  "offset": 0.0, "input_offset": 0.0, "dead_zone": null, "fit": {...}}
//! ```

use super::InputError;
use super::serde_doc::{At, Object, from_value, parse_object, top};
use super::tf_json::MAX_COEFF_MAGNITUDE;
use crate::ident::hysteresis::{
    DeadZoneStage, HysteresisModel, Identified, IdentifyParams, ModelError, ModelKind,
    PlayOperator, RateStage,
};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// The format tag.
pub const HYSTERESIS_FORMAT: &str = "fts.hysteresis/1";

/// What a model's input or output signal is.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SignalInfo {
    /// Physical quantity, e.g. `voltage`, `displacement`.
    pub quantity: String,
    /// Unit, e.g. `V`, `um`.
    pub unit: String,
}

/// How well the model fitted the record it was identified on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitRecord {
    /// `100 rms(e) / range(y)` (docs/math.md §1.5).
    pub rms_percent: f64,
    /// `100 max|e| / range(y)`.
    pub max_percent: f64,
    /// Samples used.
    pub samples: usize,
    /// `ls`, `ls-invertible`, `gd`, or `analytic-inverse`.
    pub method: String,
    /// Condition number of the regression.
    pub condition_number: f64,
    /// Gradient iterations (0 for least squares).
    pub iterations: u64,
}

/// A model with its signal descriptions and fit record.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFile {
    /// The model.
    pub model: HysteresisModel,
    /// The model's input.
    pub input: SignalInfo,
    /// The model's output.
    pub output: SignalInfo,
    /// The fit achieved at identification, if recorded.
    pub fit: Option<FitRecord>,
    /// `[min, max]` of the input the model was identified on, if recorded
    /// (files written before it was, and analytic inverses, have none):
    /// beyond it the model extrapolates.
    pub input_range: Option<[f64; 2]>,
}

impl ModelFile {
    /// The file of an identified model, with its fit record: what
    /// `fts identify hysteresis`, `fts demo` and a pipeline step write.
    pub fn identified(
        identified: &Identified,
        params: &IdentifyParams,
        input: SignalInfo,
        output: SignalInfo,
    ) -> ModelFile {
        let info = &identified.info;
        ModelFile {
            model: identified.model.clone(),
            input,
            output,
            fit: Some(FitRecord {
                rms_percent: info.fit.rms_percent,
                max_percent: info.fit.max_percent,
                samples: info.fit.samples,
                method: params.method_name().into(),
                condition_number: info.condition_number,
                iterations: info.iterations,
            }),
            input_range: None,
        }
    }

    /// How far `u` leaves the identified input range, as a sentence naming
    /// the range and the excursion; `None` inside it or without a range.
    pub fn range_excursion(&self, u: &[f64]) -> Option<String> {
        let [lo, hi] = self.input_range?;
        let (min, max) = value_range(u)?;
        if min >= lo && max <= hi {
            return None;
        }
        let unit = &self.input.unit;
        let beyond = (lo - min).max(max - hi);
        Some(format!(
            "the input spans [{min}, {max}] {unit}, beyond the range [{lo}, {hi}] {unit} the model was identified on by up to {beyond} {unit}: the model extrapolates there"
        ))
    }
}

/// `(min, max)` of finite samples, `None` for none.
pub fn value_range(u: &[f64]) -> Option<(f64, f64)> {
    u.iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, &v| match acc {
            None => Some((v, v)),
            Some((a, b)) => Some((v.min(a), v.max(b))),
        })
}

impl ModelFile {
    /// `input->output`, e.g. `voltage->displacement`.
    pub fn mapping(&self) -> String {
        format!("{}->{}", self.input.quantity, self.output.quantity)
    }
}

#[derive(Serialize)]
struct DeadZoneDoc<'a> {
    thresholds: &'a [f64],
    weights: &'a [f64],
}

impl<'a> DeadZoneDoc<'a> {
    fn of(dz: &'a DeadZoneStage) -> Self {
        DeadZoneDoc {
            thresholds: &dz.thresholds,
            weights: &dz.weights,
        }
    }
}

#[derive(Serialize)]
struct RateDoc<'a> {
    ts: f64,
    rate_scale: f64,
    weights: &'a [f64],
    velocity_gain: f64,
}

#[derive(Serialize)]
struct Doc<'a> {
    format: &'static str,
    model: &'static str,
    operator: &'static str,
    mapping: String,
    input: &'a SignalInfo,
    output: &'a SignalInfo,
    thresholds: &'a [f64],
    weights: &'a [f64],
    cbrt_gain: f64,
    offset: f64,
    input_offset: f64,
    dead_zone: Option<DeadZoneDoc<'a>>,
    /// Written only for the analytic inverse of an MPI-deadzone model
    /// (docs/math.md §1.6).
    #[serde(skip_serializing_if = "Option::is_none")]
    input_dead_zone: Option<DeadZoneDoc<'a>>,
    /// Written only for a rate-dependent model (docs/math.md §1.7).
    #[serde(skip_serializing_if = "Option::is_none")]
    rate_dependent: Option<RateDoc<'a>>,
    fit: Option<&'a FitRecord>,
    /// Left out when unknown, so older files keep their bytes.
    #[serde(skip_serializing_if = "Option::is_none")]
    input_range: Option<[f64; 2]>,
}

/// The document (keys in documented order).
pub fn model_to_value(file: &ModelFile) -> Value {
    let m = &file.model;
    serde_json::to_value(Doc {
        format: HYSTERESIS_FORMAT,
        model: m.kind.name(),
        operator: m.operator.name(),
        mapping: file.mapping(),
        input: &file.input,
        output: &file.output,
        thresholds: &m.thresholds,
        weights: &m.weights,
        cbrt_gain: m.cbrt_gain,
        offset: m.offset,
        input_offset: m.input_offset,
        dead_zone: m.dead_zone.as_ref().map(DeadZoneDoc::of),
        input_dead_zone: m.input_dead_zone.as_ref().map(DeadZoneDoc::of),
        rate_dependent: m.rate.as_ref().map(|r| RateDoc {
            ts: r.ts,
            rate_scale: r.rate_scale,
            weights: &r.weights,
            velocity_gain: r.velocity_gain,
        }),
        fit: file.fit.as_ref(),
        input_range: file.input_range,
    })
    .expect("numbers serialise")
}

/// File text: pretty JSON with a trailing newline.
pub fn model_to_string(file: &ModelFile) -> String {
    let mut s = serde_json::to_string_pretty(&model_to_value(file)).expect("JSON serialises");
    s.push('\n');
    s
}

/// The most operators (or dead zones) a model file may have: applying a
/// model costs one play per operator and sample.
pub const MAX_OPERATORS: usize = 1024;

/// The `fts.hysteresis/1` document as read (after its `format`); unknown
/// keys are ignored, and `mapping` is informative (derived from
/// `input`/`output`).
#[derive(Deserialize)]
struct ModelDoc {
    model: String,
    operator: String,
    #[serde(default)]
    input: Option<Object<SignalDoc>>,
    #[serde(default)]
    output: Option<Object<SignalDoc>>,
    thresholds: Vec<f64>,
    weights: Vec<f64>,
    /// Absent or `null` reads as 0, as do `offset` and `input_offset`.
    #[serde(default)]
    cbrt_gain: Option<f64>,
    #[serde(default)]
    offset: Option<f64>,
    #[serde(default)]
    input_offset: Option<f64>,
    #[serde(default)]
    dead_zone: Option<Object<DeadZoneIn>>,
    /// Absent or `null` unless the model inverts an MPI-deadzone model.
    #[serde(default)]
    input_dead_zone: Option<Object<DeadZoneIn>>,
    /// Absent or `null` for a rate-independent model (every older file).
    #[serde(default)]
    rate_dependent: Option<Object<RateIn>>,
    #[serde(default)]
    fit: Option<Object<FitDoc>>,
    /// Absent or `null` in files written before it was recorded.
    #[serde(default)]
    input_range: Option<[f64; 2]>,
}

/// `input` or `output`; an absent or empty `quantity` reads as the default.
#[derive(Deserialize)]
struct SignalDoc {
    #[serde(default)]
    quantity: String,
    #[serde(default)]
    unit: String,
}

/// The `dead_zone` stage as read.
#[derive(Deserialize)]
struct DeadZoneIn {
    thresholds: Vec<f64>,
    weights: Vec<f64>,
}

/// The `rate_dependent` stage as read (docs/math.md §1.7).
#[derive(Deserialize)]
struct RateIn {
    ts: f64,
    rate_scale: f64,
    weights: Vec<f64>,
    /// Absent or `null` reads as 0.
    #[serde(default)]
    velocity_gain: Option<f64>,
}

/// The fit record as read: informative, so each field may be absent, and
/// `null` (as a non-finite number is written) reads as NaN.
#[derive(Deserialize)]
struct FitDoc {
    #[serde(default)]
    rms_percent: Option<f64>,
    #[serde(default)]
    max_percent: Option<f64>,
    #[serde(default)]
    samples: Option<u64>,
    #[serde(default)]
    method: Option<String>,
    #[serde(default)]
    condition_number: Option<f64>,
    #[serde(default)]
    iterations: Option<u64>,
}

/// A list of at most [`MAX_OPERATORS`] numbers, not empty, none subnormal
/// or beyond [`MAX_COEFF_MAGNITUDE`] (such a model overflows on ordinary
/// inputs).
fn check_bounded(values: &[f64], key: &str, at: At<'_>) -> Result<(), InputError> {
    if values.len() > MAX_OPERATORS {
        let message = format!(
            "{} values; at most {MAX_OPERATORS} are accepted",
            values.len()
        );
        return Err(at.err(key, message));
    }
    if values.is_empty() {
        return Err(at.err(key, "must not be empty"));
    }
    match values.iter().position(|&v| absurd(v) || !v.is_finite()) {
        Some(i) => Err(at.err(&format!("{key}[{i}]"), magnitude_message(values[i]))),
        None => Ok(()),
    }
}

fn absurd(v: f64) -> bool {
    v != 0.0 && (v.abs() < f64::MIN_POSITIVE || v.abs() > MAX_COEFF_MAGNITUDE)
}

fn magnitude_message(v: f64) -> String {
    if v.is_finite() {
        format!(
            "{v:e} is subnormal or beyond {MAX_COEFF_MAGNITUDE:e}; rescale the model (other units)"
        )
    } else {
        format!("expected a finite number, found {v}")
    }
}

/// A number that is 0 when absent, and neither subnormal nor absurd.
fn scalar(value: Option<f64>, key: &str, at: At<'_>) -> Result<f64, InputError> {
    match value {
        Some(x) if absurd(x) || !x.is_finite() => Err(at.err(key, magnitude_message(x))),
        x => Ok(x.unwrap_or(0.0)),
    }
}

impl SignalDoc {
    fn info(doc: Option<Object<SignalDoc>>, default_quantity: &str) -> SignalInfo {
        let doc = doc.map(|o| o.0).unwrap_or(SignalDoc {
            quantity: String::new(),
            unit: String::new(),
        });
        SignalInfo {
            quantity: if doc.quantity.is_empty() {
                default_quantity.into()
            } else {
                doc.quantity
            },
            unit: doc.unit,
        }
    }
}

impl FitDoc {
    fn record(self) -> FitRecord {
        FitRecord {
            rms_percent: self.rms_percent.unwrap_or(f64::NAN),
            max_percent: self.max_percent.unwrap_or(f64::NAN),
            samples: self.samples.unwrap_or(0) as usize,
            method: self.method.unwrap_or_default(),
            condition_number: self.condition_number.unwrap_or(f64::NAN),
            iterations: self.iterations.unwrap_or(0),
        }
    }
}

/// Parses and validates an `fts.hysteresis/1` document.
pub fn parse_model(text: &str, source: &str) -> Result<ModelFile, InputError> {
    let at = top(source);
    let doc: ModelDoc = from_value(parse_object(text, source, HYSTERESIS_FORMAT)?, at)?;
    let model = doc.model(at)?;
    model.validate().map_err(|e| {
        let field = match &e {
            ModelError::LengthMismatch { field, .. } => *field,
            ModelError::Thresholds { field, .. } => *field,
            ModelError::NonFinite { field } => *field,
            ModelError::Inconsistent(_) => "model",
        };
        at.err(field, e.to_string())
    })?;
    Ok(ModelFile {
        model,
        input: SignalDoc::info(doc.input, "input"),
        output: SignalDoc::info(doc.output, "output"),
        fit: doc.fit.map(|f| f.0.record()),
        input_range: input_range(doc.input_range, at)?,
    })
}

/// The identified input range as read: finite, `min <= max`.
fn input_range(range: Option<[f64; 2]>, at: At<'_>) -> Result<Option<[f64; 2]>, InputError> {
    match range {
        Some([lo, hi]) if !(lo.is_finite() && hi.is_finite() && lo <= hi) => Err(at.err(
            "input_range",
            format!("expected [min, max], finite with min <= max, found [{lo}, {hi}]"),
        )),
        other => Ok(other),
    }
}

/// The rate stage, its numbers bounded and its scales positive.
fn rate_stage(r: &RateIn, at: At<'_>) -> Result<RateStage, InputError> {
    let nested = At {
        source: at.source,
        path: "rate_dependent",
    };
    check_bounded(&r.weights, "weights", nested)?;
    for (key, v) in [("ts", r.ts), ("rate_scale", r.rate_scale)] {
        if absurd(v) || !(v.is_finite() && v > 0.0) {
            return Err(nested.err(key, format!("expected a positive number, found {v}")));
        }
    }
    Ok(RateStage {
        ts: r.ts,
        rate_scale: r.rate_scale,
        weights: r.weights.clone(),
        velocity_gain: scalar(r.velocity_gain, "velocity_gain", nested)?,
    })
}

impl ModelDoc {
    /// The model, its names known and its numbers bounded (not yet
    /// validated as a whole).
    fn model(&self, at: At<'_>) -> Result<HysteresisModel, InputError> {
        let kind = ModelKind::from_name(&self.model).ok_or_else(|| {
            let name = &self.model;
            let message = format!(
                "unknown model {name:?}; expected \"pi\", \"mpi-cbrt\" or \"mpi-deadzone\""
            );
            at.err("model", message)
        })?;
        let operator = PlayOperator::from_name(&self.operator).ok_or_else(|| {
            let name = &self.operator;
            let message =
                format!("unknown operator {name:?}; expected \"play-lower\" or \"play-symmetric\"");
            at.err("operator", message)
        })?;
        let dead_zone = dead_zone_stage(self.dead_zone.as_ref(), "dead_zone", at)?;
        let input_dead_zone =
            dead_zone_stage(self.input_dead_zone.as_ref(), "input_dead_zone", at)?;
        check_bounded(&self.thresholds, "thresholds", at)?;
        check_bounded(&self.weights, "weights", at)?;
        let rate = match &self.rate_dependent {
            Some(Object(r)) => Some(rate_stage(r, at)?),
            None => None,
        };
        Ok(HysteresisModel {
            kind,
            operator,
            thresholds: self.thresholds.clone(),
            weights: self.weights.clone(),
            cbrt_gain: scalar(self.cbrt_gain, "cbrt_gain", at)?,
            offset: scalar(self.offset, "offset", at)?,
            input_offset: scalar(self.input_offset, "input_offset", at)?,
            dead_zone,
            input_dead_zone,
            rate,
        })
    }
}

/// A dead-zone stage as read, its lists bounded.
fn dead_zone_stage(
    stage: Option<&Object<DeadZoneIn>>,
    path: &'static str,
    at: At<'_>,
) -> Result<Option<DeadZoneStage>, InputError> {
    let Some(Object(dz)) = stage else {
        return Ok(None);
    };
    let nested = At {
        source: at.source,
        path,
    };
    check_bounded(&dz.thresholds, "thresholds", nested)?;
    check_bounded(&dz.weights, "weights", nested)?;
    Ok(Some(DeadZoneStage {
        thresholds: dz.thresholds.clone(),
        weights: dz.weights.clone(),
    }))
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn file() -> ModelFile {
        ModelFile {
            model: HysteresisModel {
                kind: ModelKind::MpiDeadzone,
                operator: PlayOperator::Symmetric,
                thresholds: vec![0.0, 0.1 + 0.2],
                weights: vec![1.0 / 3.0, -2f64.sqrt()],
                cbrt_gain: 0.0,
                offset: -1.7,
                input_offset: 0.0,
                dead_zone: Some(DeadZoneStage {
                    thresholds: vec![0.0, 5.0],
                    weights: vec![1.0, 0.25],
                }),
                input_dead_zone: None,
                rate: None,
            },
            input: SignalInfo {
                quantity: "voltage".into(),
                unit: "V".into(),
            },
            output: SignalInfo {
                quantity: "displacement".into(),
                unit: "um".into(),
            },
            fit: Some(FitRecord {
                rms_percent: 1.5,
                max_percent: 4.0,
                samples: 100,
                method: "ls".into(),
                condition_number: 123.0,
                iterations: 0,
            }),
            input_range: Some([-150.0, 150.0]),
        }
    }

    /// An input beyond the identified range is named with the range and the
    /// excursion; inside it, or without a recorded range, nothing is said;
    /// a file without `input_range` still loads.
    pub fn an_input_beyond_the_identified_range_is_named() {
        let mut f = file();
        let note = f.range_excursion(&[0.0, 218.0, -20.0]).unwrap();
        assert!(note.contains("[-20, 218] V"), "{note}");
        assert!(note.contains("[-150, 150] V"), "{note}");
        assert!(note.contains("by up to 68 V"), "{note}");
        assert!(f.range_excursion(&[-150.0, 150.0]).is_none());
        let back = parse_model(&model_to_string(&f), "m.json").unwrap();
        assert_eq!(back.input_range, Some([-150.0, 150.0]));
        f.input_range = None;
        let text = model_to_string(&f);
        assert!(!text.contains("input_range"));
        assert!(
            parse_model(&text, "m.json")
                .unwrap()
                .range_excursion(&[1e3])
                .is_none()
        );
        let bad = text.replacen("\"fit\"", "\"input_range\": [2, 1], \"fit\"", 1);
        let e = parse_model(&bad, "m.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("input_range"));
    }

    pub fn round_trip_is_exact() {
        let f = file();
        let text = model_to_string(&f);
        assert!(text.contains("\"mapping\": \"voltage->displacement\""));
        assert_eq!(parse_model(&text, "m.json").unwrap(), f);
    }

    /// The analytic inverse of MPI-deadzone: a PI model with an input stage.
    pub fn input_dead_zone_round_trips() {
        let mut f = file();
        f.model.kind = ModelKind::Pi;
        f.model.input_dead_zone = f.model.dead_zone.take();
        let text = model_to_string(&f);
        assert!(text.contains("\"input_dead_zone\""), "{text}");
        assert_eq!(parse_model(&text, "m.json").unwrap(), f);
        // On an mpi-cbrt model the stage is refused by name.
        let bad = text.replace("\"model\": \"pi\"", "\"model\": \"mpi-cbrt\"");
        let e = parse_model(&bad, "m.json").unwrap_err();
        assert!(e.to_string().contains("input dead-zone stage"), "{e}");
    }

    pub fn operator_counts_and_magnitudes_are_bounded() {
        let many = format!(
            r#"{{"format": "fts.hysteresis/1", "model": "pi", "operator": "play-lower",
                "thresholds": [{}], "weights": [1]}}"#,
            (0..=MAX_OPERATORS)
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(",")
        );
        let e = parse_model(&many, "m.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("thresholds"), "{e}");
        assert!(e.message.contains("1025 values"), "{e}");
        let huge = r#"{"format": "fts.hysteresis/1", "model": "pi", "operator": "play-lower",
            "thresholds": [0, 1], "weights": [1, 1e300]}"#;
        let e = parse_model(huge, "m.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("weights[1]"), "{e}");
        let offset = r#"{"format": "fts.hysteresis/1", "model": "pi", "operator": "play-lower",
            "thresholds": [0], "weights": [1], "offset": 1e200}"#;
        let e = parse_model(offset, "m.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("offset"), "{e}");
    }

    /// Type errors name their path, inside nested objects too; an array
    /// where an object belongs is refused.
    pub fn errors_name_their_path() {
        let head = r#"{"format": "fts.hysteresis/1", "model": "mpi-deadzone", "operator": "play-lower", "thresholds": [0, 2], "weights": [1, 0.2]"#;
        for (tail, field, needle) in [
            (r#", "dead_zone": [[0], [1]]}"#, "dead_zone", "an object"),
            (
                r#", "dead_zone": {"thresholds": [0], "weights": ["x"]}}"#,
                "dead_zone.weights[0]",
                "a number",
            ),
            (
                r#", "input": {"quantity": 3}}"#,
                "input.quantity",
                "a string",
            ),
            (r#", "output": ["x", "um"]}"#, "output", "an object"),
            (r#", "offset": "x"}"#, "offset", "a number"),
        ] {
            let e = parse_model(&format!("{head}{tail}"), "h.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
    }

    pub fn mismatched_lengths_name_the_field() {
        let text = model_to_string(&file())
            .replace("\"weights\": [\n    0.3333333333333333,", "\"weights\": [");
        let e = parse_model(&text, "m.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("weights"), "{e}");
        assert!(e.to_string().contains("must match"), "{e}");
        let e = parse_model(
            r#"{"format": "fts.hysteresis/1", "model": "pi", "operator": "play-lower",
                "thresholds": [0, 2, 1], "weights": [1, 1, 1]}"#,
            "m.json",
        )
        .unwrap_err();
        assert!(e.to_string().contains("increase strictly"), "{e}");
        let e =
            parse_model(r#"{"format": "fts.hysteresis/2", "model": "pi"}"#, "m.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("format"));
    }
}
