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
use super::tf_json::{MAX_COEFF_MAGNITUDE, check_format, get_f64_array, get_str};
use crate::ident::hysteresis::{
    DeadZoneStage, HysteresisModel, Identified, IdentifyParams, ModelKind, PlayOperator,
};
use serde::Serialize;
use serde_json::{Map, Value};

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
        }
    }

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
    fit: Option<&'a FitRecord>,
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
        dead_zone: m.dead_zone.as_ref().map(|dz| DeadZoneDoc {
            thresholds: &dz.thresholds,
            weights: &dz.weights,
        }),
        fit: file.fit.as_ref(),
    })
    .expect("numbers serialise")
}

/// File text: pretty JSON with a trailing newline.
pub fn model_to_string(file: &ModelFile) -> String {
    let mut s = serde_json::to_string_pretty(&model_to_value(file)).expect("JSON serialises");
    s.push('\n');
    s
}

fn err(source: &str, field: &str, message: impl Into<String>) -> InputError {
    InputError::new(source, message).in_field(field)
}

/// The most operators (or dead zones) a model file may have: applying a
/// model costs one play per operator and sample.
pub const MAX_OPERATORS: usize = 1024;

/// A bounded list of numbers, none subnormal or beyond
/// [`MAX_COEFF_MAGNITUDE`] (such a model overflows on ordinary inputs).
fn get_bounded_array(
    obj: &Map<String, Value>,
    source: &str,
    key: &str,
) -> Result<Vec<f64>, InputError> {
    if let Some(Value::Array(a)) = obj.get(key)
        && a.len() > MAX_OPERATORS
    {
        return Err(err(
            source,
            key,
            format!("{} values; at most {MAX_OPERATORS} are accepted", a.len()),
        ));
    }
    let values = get_f64_array(obj, source, key)?;
    check_magnitude(source, key, &values)?;
    Ok(values)
}

fn check_magnitude(source: &str, key: &str, values: &[f64]) -> Result<(), InputError> {
    let absurd =
        |v: f64| v != 0.0 && (v.abs() < f64::MIN_POSITIVE || v.abs() > MAX_COEFF_MAGNITUDE);
    match values.iter().position(|&v| absurd(v)) {
        Some(i) => Err(err(
            source,
            &format!("{key}[{i}]"),
            format!(
                "{:e} is subnormal or beyond {MAX_COEFF_MAGNITUDE:e}; rescale the model (other units)",
                values[i]
            ),
        )),
        None => Ok(()),
    }
}

fn get_number(obj: &Map<String, Value>, source: &str, key: &str) -> Result<f64, InputError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(0.0),
        Some(v) => {
            let x = v
                .as_f64()
                .filter(|x| x.is_finite())
                .ok_or_else(|| err(source, key, format!("expected a finite number, found {v}")))?;
            check_magnitude(source, key, &[x]).map_err(|mut e| {
                e.field = Some(key.to_owned());
                e
            })?;
            Ok(x)
        }
    }
}

fn signal(
    obj: &Map<String, Value>,
    source: &str,
    key: &str,
    default_quantity: &str,
) -> Result<SignalInfo, InputError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(SignalInfo {
            quantity: default_quantity.into(),
            unit: String::new(),
        }),
        Some(Value::Object(o)) => {
            let text = |k: &str| match o.get(k) {
                None => Ok(String::new()),
                Some(Value::String(s)) => Ok(s.clone()),
                Some(_) => Err(err(source, &format!("{key}.{k}"), "expected a string")),
            };
            let quantity = text("quantity")?;
            Ok(SignalInfo {
                quantity: if quantity.is_empty() {
                    default_quantity.into()
                } else {
                    quantity
                },
                unit: text("unit")?,
            })
        }
        Some(_) => Err(err(
            source,
            key,
            "expected an object {\"quantity\": ..., \"unit\": ...}",
        )),
    }
}

/// Parses and validates an `fts.hysteresis/1` document. Unknown fields are
/// ignored; `mapping` is informative (it is derived from `input`/`output`).
pub fn parse_model(text: &str, source: &str) -> Result<ModelFile, InputError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| InputError::new(source, format!("invalid JSON: {e}")).at_line(e.line()))?;
    let obj = value
        .as_object()
        .ok_or_else(|| InputError::new(source, "expected a JSON object"))?;
    check_format(obj, source, HYSTERESIS_FORMAT)?;
    let kind_name = get_str(obj, source, "model")?;
    let kind = ModelKind::from_name(kind_name).ok_or_else(|| {
        err(
            source,
            "model",
            format!(
                "unknown model {kind_name:?}; expected \"pi\", \"mpi-cbrt\" or \"mpi-deadzone\""
            ),
        )
    })?;
    let op_name = get_str(obj, source, "operator")?;
    let operator = PlayOperator::from_name(op_name).ok_or_else(|| {
        err(
            source,
            "operator",
            format!("unknown operator {op_name:?}; expected \"play-lower\" or \"play-symmetric\""),
        )
    })?;
    let dead_zone = match obj.get("dead_zone") {
        None | Some(Value::Null) => None,
        Some(Value::Object(dz)) => {
            // Errors name the nested field, e.g. `dead_zone.weights[2]`.
            let nested = |key: &str| {
                get_bounded_array(dz, source, key).map_err(|mut e| {
                    e.field = e.field.map(|f| format!("dead_zone.{f}"));
                    e
                })
            };
            Some(DeadZoneStage {
                thresholds: nested("thresholds")?,
                weights: nested("weights")?,
            })
        }
        Some(_) => {
            return Err(err(
                source,
                "dead_zone",
                "expected null or an object {\"thresholds\": [...], \"weights\": [...]}",
            ));
        }
    };
    let model = HysteresisModel {
        kind,
        operator,
        thresholds: get_bounded_array(obj, source, "thresholds")?,
        weights: get_bounded_array(obj, source, "weights")?,
        cbrt_gain: get_number(obj, source, "cbrt_gain")?,
        offset: get_number(obj, source, "offset")?,
        input_offset: get_number(obj, source, "input_offset")?,
        dead_zone,
    };
    model.validate().map_err(|e| {
        let field = match &e {
            crate::ident::hysteresis::ModelError::LengthMismatch { field, .. } => *field,
            crate::ident::hysteresis::ModelError::Thresholds { field, .. } => *field,
            crate::ident::hysteresis::ModelError::NonFinite { field } => *field,
            crate::ident::hysteresis::ModelError::Inconsistent(_) => "model",
        };
        err(source, field, e.to_string())
    })?;
    let fit = match obj.get("fit") {
        Some(Value::Object(f)) => {
            let num = |k: &str| f.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN);
            Some(FitRecord {
                rms_percent: num("rms_percent"),
                max_percent: num("max_percent"),
                samples: f.get("samples").and_then(Value::as_u64).unwrap_or(0) as usize,
                method: f
                    .get("method")
                    .and_then(Value::as_str)
                    .unwrap_or("")
                    .to_owned(),
                condition_number: num("condition_number"),
                iterations: f.get("iterations").and_then(Value::as_u64).unwrap_or(0),
            })
        }
        _ => None,
    };
    Ok(ModelFile {
        model,
        input: signal(obj, source, "input", "input")?,
        output: signal(obj, source, "output", "output")?,
        fit,
    })
}

#[cfg(test)]
mod tests {
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
        }
    }

    #[test]
    fn round_trip_is_exact() {
        let f = file();
        let text = model_to_string(&f);
        assert!(text.contains("\"mapping\": \"voltage->displacement\""));
        assert_eq!(parse_model(&text, "m.json").unwrap(), f);
    }

    #[test]
    fn operator_counts_and_magnitudes_are_bounded() {
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

    #[test]
    fn mismatched_lengths_name_the_field() {
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
