//! The `fts.tf/1` transfer-function file (docs/formats.md).
//!
//! Floats are written by `serde_json` (shortest representation that parses
//! back to the same `f64`, via `ryu`) and read with its `float_roundtrip`
//! parser, so a write/read cycle is bit-exact.

use super::InputError;
use super::serde_doc::{At, from_value, parse_object, top};
use crate::lti::{ContinuousTf, DiscreteTf, TfError, TransferFunction};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Number, Value};

/// The format tag this module reads and writes.
pub const TF_FORMAT: &str = "fts.tf/1";

/// The most coefficients a polynomial in a file may have (the runtime's
/// filter capacity): roots and responses stay fast and bounded.
pub const MAX_COEFFS: usize = 512;

/// The largest input delay in a file, samples (100 s at 10 kHz).
pub const MAX_DELAY: u64 = 1_000_000;

/// The largest coefficient magnitude accepted; beyond it (and for subnormal
/// values, which make root finding crawl) the model is refused as absurd
/// rather than computed with.
pub const MAX_COEFF_MAGNITUDE: f64 = 1e100;

/// Refuses polynomials that are too long or hold absurd coefficients.
pub(crate) fn check_coeffs(source: &str, field: &str, c: &[f64]) -> Result<(), InputError> {
    if c.len() > MAX_COEFFS {
        return Err(field_err(
            source,
            field,
            &format!(
                "{} coefficients; at most {MAX_COEFFS} are accepted",
                c.len()
            ),
        ));
    }
    let absurd =
        |v: f64| v != 0.0 && (v.abs() < f64::MIN_POSITIVE || v.abs() > MAX_COEFF_MAGNITUDE);
    if let Some(i) = c.iter().position(|&v| v.is_finite() && absurd(v)) {
        return Err(field_err(
            source,
            field,
            &format!(
                "coefficient {i} = {:e} is subnormal or beyond {MAX_COEFF_MAGNITUDE:e}; rescale the model (e.g. time in ms, gain in other units)",
                c[i]
            ),
        ));
    }
    Ok(())
}

/// Refuses an empty polynomial, a non-finite coefficient (naming it, e.g.
/// `num[3]`) and what [`check_coeffs`] refuses.
pub(crate) fn check_poly(source: &str, field: &str, c: &[f64]) -> Result<(), InputError> {
    if c.is_empty() {
        return Err(field_err(source, field, "must not be empty"));
    }
    if let Some(i) = c.iter().position(|v| !v.is_finite()) {
        let message = format!("expected a finite number, found {}", c[i]);
        return Err(field_err(source, &format!("{field}[{i}]"), &message));
    }
    check_coeffs(source, field, c)
}

/// The `fts.tf/1` document as read (after its `format`); unknown keys are
/// ignored.
#[derive(Deserialize)]
struct TfDoc {
    var: String,
    /// Required when discrete.
    #[serde(default)]
    ts: Option<f64>,
    num: Vec<f64>,
    den: Vec<f64>,
    /// Any number here; checked as a whole number of samples when discrete,
    /// as seconds >= 0 (the input delay) when continuous.
    #[serde(default)]
    delay: Option<Number>,
}

/// Parses an `fts.tf/1` document. Unknown fields are ignored; an unknown
/// `format` is an error.
pub fn parse_tf(text: &str, source: &str) -> Result<TransferFunction, InputError> {
    parse_tf_noted(text, source).map(|(g, _)| g)
}

/// [`parse_tf`], with the sentence stating a conversion the reader made (a
/// `"var": "z"` file in descending powers of `z`), for the reader's caller
/// to pass on.
pub fn parse_tf_noted(
    text: &str,
    source: &str,
) -> Result<(TransferFunction, Option<String>), InputError> {
    let at = top(source);
    let doc: TfDoc = from_value(parse_object(text, source, TF_FORMAT)?, at)?;
    check_poly(source, "num", &doc.num)?;
    check_poly(source, "den", &doc.den)?;
    match doc.var.as_str() {
        "z^-1" => Ok((doc.discrete(at)?, None)),
        "z" => {
            let file_delay = doc.delay.is_some();
            let g = doc.descending_z_to_ascending(at)?.discrete(at)?;
            let note = descending_z_note(&g, file_delay);
            Ok((g, note))
        }
        "s" => Ok((doc.continuous(at)?, None)),
        other => Err(at.err(
            "var",
            format!("expected \"z^-1\" or \"z\" (discrete) or \"s\" (continuous), found {other:?}"),
        )),
    }
}

/// The sentence stating how a `"var": "z"` file was read.
fn descending_z_note(g: &TransferFunction, file_delay: bool) -> Option<String> {
    let TransferFunction::Discrete(g) = g else {
        return None;
    };
    Some(format!(
        "\"var\": \"z\" (descending powers of z) read as ascending powers of z^-1 with delay {} (the relative degree{})",
        g.delay(),
        if file_delay {
            " plus the file's delay"
        } else {
            ""
        }
    ))
}

/// Strips leading zeros of a descending-power polynomial (they do not
/// change its degree's meaning, only pad it).
fn strip_leading_zeros(c: &[f64]) -> &[f64] {
    let first = c.iter().position(|&v| v != 0.0).unwrap_or(c.len());
    &c[first..]
}

impl TfDoc {
    /// `"var": "z"`: `num(z)/den(z)` in descending powers of `z`. Divided
    /// through by `z^deg(den)`, the coefficients read unchanged as ascending
    /// powers of `z^-1`, and the relative degree `deg(den) - deg(num)`
    /// becomes the delay (added to a `delay` the file gives). An improper
    /// model (`deg(num) > deg(den)`) is not causal and is refused.
    fn descending_z_to_ascending(mut self, at: At<'_>) -> Result<Self, InputError> {
        let num = strip_leading_zeros(&self.num).to_vec();
        let den = strip_leading_zeros(&self.den).to_vec();
        if num.is_empty() || den.is_empty() {
            return Ok(Self {
                var: "z^-1".into(),
                ..self
            }); // refused as z^-1
        }
        let (m, n) = (num.len() - 1, den.len() - 1);
        if m > n {
            return Err(at.err(
                "num",
                format!(
                    "degree {m} in z above the denominator's degree {n} (\"var\": \"z\", descending powers): the model is improper, not causal"
                ),
            ));
        }
        let given = match &self.delay {
            None => 0,
            Some(d) => d.as_u64().ok_or_else(|| {
                at.err("delay", "expected a non-negative whole number of samples")
            })?,
        };
        self.delay = Some(Number::from(given.saturating_add((n - m) as u64)));
        self.num = num;
        self.den = den;
        self.var = "z^-1".into();
        Ok(self)
    }

    fn discrete(self, at: At<'_>) -> Result<TransferFunction, InputError> {
        let ts = self.ts.ok_or_else(|| {
            at.err(
                "ts",
                "missing: a discrete transfer function (\"var\": \"z^-1\") needs its sample time",
            )
        })?;
        let delay = match &self.delay {
            None => 0,
            Some(n) => match n.as_u64() {
                Some(d) if d <= MAX_DELAY => d as usize,
                Some(d) => {
                    let message = format!("{d} samples; at most {MAX_DELAY} are accepted");
                    return Err(at.err("delay", message));
                }
                None => {
                    let message = "expected a non-negative whole number of samples";
                    return Err(at.err("delay", message));
                }
            },
        };
        DiscreteTf::new(self.num, self.den, delay, ts)
            .map(TransferFunction::Discrete)
            .map_err(|e| tf_err(e, at))
    }

    /// `"var": "s"`: the delay is the input delay in seconds,
    /// `G(s) = e^{-s delay} num(s)/den(s)` (docs/formats.md `fts.tf/1`).
    fn continuous(self, at: At<'_>) -> Result<TransferFunction, InputError> {
        let delay = match &self.delay {
            None => 0.0,
            Some(n) => n.as_f64().filter(|d| *d >= 0.0).ok_or_else(|| {
                at.err(
                    "delay",
                    "expected the input delay in seconds, a number >= 0 (\"var\": \"s\")",
                )
            })?,
        };
        ContinuousTf::new(self.num, self.den)
            .and_then(|g| g.with_delay(delay))
            .map(TransferFunction::Continuous)
            .map_err(|e| tf_err(e, at))
    }
}

/// A model the constructors refuse, naming the field at fault.
fn tf_err(e: TfError, at: At<'_>) -> InputError {
    let field = match &e {
        TfError::BadDenominator(_) => "den",
        TfError::NonFinite { which, .. } => which,
        TfError::BadSampleTime(_) => "ts",
        TfError::ZeroNumerator => "num",
        TfError::BadDelay(_) | TfError::Delayed(_) => "delay",
    };
    at.err(field, e.to_string())
}

#[derive(Serialize)]
struct DiscreteDoc<'a> {
    format: &'static str,
    var: &'static str,
    ts: f64,
    num: &'a [f64],
    den: &'a [f64],
    delay: usize,
}

#[derive(Serialize)]
struct ContinuousDoc<'a> {
    format: &'static str,
    var: &'static str,
    num: &'a [f64],
    den: &'a [f64],
    /// Seconds; left out when 0, so files without a delay keep their bytes.
    #[serde(skip_serializing_if = "is_zero")]
    delay: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// The `fts.tf/1` document for `g` as a JSON value (keys in the documented order).
pub fn tf_to_value(g: &TransferFunction) -> Value {
    let result = match g {
        TransferFunction::Discrete(d) => serde_json::to_value(DiscreteDoc {
            format: TF_FORMAT,
            var: "z^-1",
            ts: d.ts(),
            num: d.num().coeffs(),
            den: d.den().coeffs(),
            delay: d.delay(),
        }),
        TransferFunction::Continuous(c) => serde_json::to_value(ContinuousDoc {
            format: TF_FORMAT,
            var: "s",
            num: c.num(),
            den: c.den(),
            delay: c.delay(),
        }),
    };
    result.expect("plain numbers and strings always serialise")
}

/// The `fts.tf/1` file text (pretty JSON with a trailing newline).
pub fn tf_to_string(g: &TransferFunction) -> String {
    let mut s = serde_json::to_string_pretty(&tf_to_value(g)).expect("JSON value serialises");
    s.push('\n');
    s
}

fn field_err(source: &str, field: &str, message: &str) -> InputError {
    InputError::new(source, message).in_field(field)
}

/// Checks the `format` field against `expected` (shared by every fts JSON reader).
pub fn check_format(
    obj: &Map<String, Value>,
    source: &str,
    expected: &str,
) -> Result<(), InputError> {
    match obj.get("format") {
        Some(Value::String(f)) if f == expected => Ok(()),
        Some(Value::String(f)) => Err(field_err(
            source,
            "format",
            &format!("unsupported format {f:?}; this fts reads {expected:?}"),
        )),
        Some(_) => Err(field_err(source, "format", "expected a string")),
        None => Err(field_err(
            source,
            "format",
            &format!("missing; expected \"format\": {expected:?}"),
        )),
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    const LI21: &str = r#"{
      "format": "fts.tf/1", "var": "z^-1", "ts": 0.0001,
      "num": [4.154, -9.631, 10.23, -5.511, 1.154],
      "den": [1, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
      "delay": 5, "comment": "ignored"
    }"#;

    /// Sizes and magnitudes a user controls are bounded before any work: each
    /// refusal names the field.
    pub fn absurd_models_are_refused_naming_the_field() {
        let doc = |num: &str, den: &str, delay: &str| {
            format!(
                r#"{{"format": "fts.tf/1", "var": "z^-1", "ts": 1e-4, "num": {num}, "den": {den}, "delay": {delay}}}"#
            )
        };
        let long = format!("[1{}]", ", 0.001".repeat(MAX_COEFFS));
        for (text, field, needle) in [
            (doc("[1]", "[1e-320, 1]", "0"), "den", "subnormal"),
            (doc("[1e200]", "[1, 0.5]", "0"), "num", "beyond 1e100"),
            (
                doc("[1]", "[1, 0.5]", "1000000000000"),
                "delay",
                "at most 1000000",
            ),
            (
                doc("[1]", &long, "0"),
                "den",
                "513 coefficients; at most 512",
            ),
        ] {
            let e = parse_tf(&text, "g.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.to_string().contains(needle), "{e}");
        }
        // At the bounds, accepted.
        let edge = format!("[1{}]", ", 0.001".repeat(MAX_COEFFS - 1));
        assert!(parse_tf(&doc("[1e100]", &edge, "1000000"), "g.json").is_ok());
    }

    pub fn reads_interfaces_example() {
        let TransferFunction::Discrete(g) = parse_tf(LI21, "p.json").unwrap() else {
            panic!("discrete expected")
        };
        assert_eq!(g.delay(), 5);
        assert_eq!(g.ts(), 1e-4);
        assert_eq!(g.num().coeffs()[2], 10.23);
    }

    pub fn round_trip_is_bit_exact() {
        // The writer's floats parse back to the same bits, extremes included.
        let extreme = DiscreteTf::new(
            vec![0.1 + 0.2, 1.0 / 3.0, -2.0f64.sqrt(), 1e-300, 5e-324],
            vec![1.0, std::f64::consts::PI, f64::MAX],
            3,
            1e-4,
        )
        .unwrap();
        let text = tf_to_string(&TransferFunction::Discrete(extreme.clone()));
        let doc: Value = serde_json::from_str(&text).unwrap();
        let bits = |v: &Value| -> Vec<u64> {
            v.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap().to_bits())
                .collect()
        };
        let want = |c: &[f64]| -> Vec<u64> { c.iter().map(|x| x.to_bits()).collect() };
        assert_eq!(bits(&doc["num"]), want(extreme.num().coeffs()));
        assert_eq!(bits(&doc["den"]), want(extreme.den().coeffs()));
        // A model with subnormal or huge coefficients is refused on reading.
        assert_eq!(
            parse_tf(&text, "x").unwrap_err().field.as_deref(),
            Some("num")
        );

        let g = DiscreteTf::new(
            vec![
                0.1 + 0.2,
                1.0 / 3.0,
                -2.0f64.sqrt(),
                1e-300,
                f64::MIN_POSITIVE,
            ],
            vec![1.0, std::f64::consts::PI, 1e100],
            3,
            1e-4,
        )
        .unwrap();
        let text = tf_to_string(&TransferFunction::Discrete(g.clone()));
        let TransferFunction::Discrete(back) = parse_tf(&text, "x").unwrap() else {
            panic!()
        };
        for (a, b) in g.num().coeffs().iter().zip(back.num().coeffs()) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        for (a, b) in g.den().coeffs().iter().zip(back.den().coeffs()) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        assert_eq!(tf_to_string(&TransferFunction::Discrete(back)), text);
    }

    pub fn errors_name_the_field() {
        let e = parse_tf(r#"{"format":"fts.tf/2"}"#, "p.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("format"));
        let e = parse_tf(
            r#"{"format":"fts.tf/1","var":"z^-1","num":[1],"den":[1]}"#,
            "p.json",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("ts"));
        let e = parse_tf(
            r#"{"format":"fts.tf/1","var":"z^-1","ts":1,"num":[1,"x"],"den":[1]}"#,
            "p.json",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("num[1]"));
        let e = parse_tf(
            r#"{"format":"fts.tf/1","var":"z^-1","ts":1,"num":[1],"den":[0,1]}"#,
            "p.json",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("den"));
        let e = parse_tf("{\n\"format\": ", "p.json").unwrap_err();
        assert_eq!(e.line, Some(2));
        let e = parse_tf(
            r#"{"format":"fts.tf/1","var":"z^-1","ts":1,"num":[1],"den":[1],"delay":-1}"#,
            "p.json",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("delay"));
        let e = parse_tf(
            r#"{"format":"fts.tf/1","var":"z^-1","ts":"fast","num":[1],"den":[1]}"#,
            "p.json",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("ts"));
        assert!(e.message.contains("found string \"fast\""), "{e}");
        for bad in ["-2", "\"2\"", "-1e-9"] {
            let doc =
                format!(r#"{{"format":"fts.tf/1","var":"s","num":[1],"den":[1],"delay":{bad}}}"#);
            let e = parse_tf(&doc, "p.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some("delay"), "{bad}");
        }
    }

    pub fn a_continuous_delay_survives_the_file() {
        // identify ct --delay 0.0001 writes it; every reader sees it.
        let doc = r#"{"format":"fts.tf/1","var":"s","num":[2],"den":[1,3],"delay":0.0001}"#;
        let g = parse_tf(doc, "g.json").unwrap();
        let TransferFunction::Continuous(c) = &g else {
            panic!("continuous")
        };
        assert_eq!(c.delay(), 1e-4);
        let text = tf_to_string(&g);
        assert!(text.contains("\"delay\": 0.0001"), "{text}");
        assert_eq!(parse_tf(&text, "g.json").unwrap(), g);
        // Without a delay the file keeps its old bytes: no `delay` key.
        let plain = TransferFunction::Continuous(c.rational());
        assert!(!tf_to_string(&plain).contains("delay"));
    }
    /// `num(z)/den(z)` evaluated directly at `z = e^{j omega}` from the
    /// descending coefficients (Horner in `z`), independent of the reader.
    fn descending_at(num: &[f64], den: &[f64], omega: f64) -> crate::lti::c64 {
        let z = crate::lti::c64::from_polar(1.0, omega);
        let horner = |c: &[f64]| {
            c.iter()
                .fold(crate::lti::c64::new(0.0, 0.0), |acc, &v| acc * z + v)
        };
        horner(num) / horner(den)
    }

    /// MATLAB's descending-power discrete TF (`"var": "z"`) is read as the
    /// same system: its frequency response equals the direct evaluation of
    /// `num(z)/den(z)` at several frequencies, the relative degree becomes
    /// the delay, leading zeros are dropped, and an improper model is refused
    /// naming `num`.
    pub fn a_descending_z_file_is_the_same_system() {
        for (num, den, delay) in [
            (vec![0.0, 0.5, 0.3], vec![1.0, -1.2, 0.5, 0.1], 2),
            (vec![2.0, -1.0], vec![1.0, -0.9], 0),
            (vec![0.0, 0.0, 1.0], vec![0.0, 1.0, -0.5, 0.25], 2),
        ] {
            let text = format!(
                r#"{{"format": "fts.tf/1", "var": "z", "ts": 0.001, "num": {num:?}, "den": {den:?}}}"#
            );
            let TransferFunction::Discrete(g) = parse_tf(&text, "g.json").unwrap() else {
                panic!("discrete expected");
            };
            assert_eq!(g.delay(), delay, "{text}");
            for omega in [0.0, 0.1, 0.7, 1.9, 3.0] {
                let (got, want) = (g.response_at_omega(omega), descending_at(&num, &den, omega));
                assert!(
                    (got - want).norm() <= 1e-12 * want.norm(),
                    "{text} at {omega}: {got} vs {want}"
                );
            }
            let note = parse_tf_noted(&text, "g.json").unwrap().1.unwrap();
            assert!(note.contains(&format!("delay {delay}")), "{note}");
        }
        let improper = r#"{"format": "fts.tf/1", "var": "z", "ts": 0.001, "num": [1, 0, 1], "den": [0, 1, 0.5]}"#;
        let e = parse_tf(improper, "g.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("num"));
        assert!(e.to_string().contains("improper"), "{e}");
        assert!(parse_tf_noted(LI21, "li21.json").unwrap().1.is_none());
    }
}
