//! The `fts.zpetc/1` file: a designed ZPETC filter (docs/formats.md).
//!
//! ```json
//! {"format": "fts.zpetc/1", "var": "z^-1", "ts": 0.0001,
//!  "num": [...], "den": [...], "preview": 5,
//!  "cancelled_zeros": [[re, im], ...], "uncancelled_zeros": [[re, im], ...],
//!  "rho": 0.95, "min_damping": 0.1,
//!  "inverted_zeros": [[re, im], ...], "series_terms": 20,
//!  "stable_inversion": {"min_radius": 1.25, "tolerance": 1e-9, "max_terms": 1000}}
//! ```
//! The last three keys appear only when the filter inverts zeros by the
//! anticausal series; older files without them read as classical ZPETC.
//! `G_z = z^preview num(z^-1) / den(z^-1)`: the causal part `num/den` runs on
//! the reference `preview` samples ahead.

use super::InputError;
use super::tf_json::{check_format, get_f64_array, get_str};
use crate::lti::{Poly, c64};
use crate::synth::zpetc::{ClassifiedZero, StableInversion, ZeroStatus, Zpetc, ZpetcParams};
use serde_json::{Value, json};

/// The longest preview a file may declare, samples: the longest input delay
/// of a model file plus the runtime's filter capacity.
pub const MAX_PREVIEW: u64 = super::tf_json::MAX_DELAY + crate::runtime::MAX_FILTER_LEN as u64;

/// A `preview` field: a whole number of samples up to [`MAX_PREVIEW`].
pub(crate) fn read_preview(
    value: Option<&Value>,
    source: &str,
    field: &str,
) -> Result<usize, InputError> {
    match value.and_then(Value::as_u64) {
        Some(p) if p <= MAX_PREVIEW => Ok(p as usize),
        Some(p) => Err(InputError::new(
            source,
            format!("{p} samples of preview; at most {MAX_PREVIEW} are accepted"),
        )
        .in_field(field)),
        None => Err(
            InputError::new(source, "expected a non-negative whole number of samples")
                .in_field(field),
        ),
    }
}

/// The format tag.
pub const ZPETC_FORMAT: &str = "fts.zpetc/1";

fn pairs<'a>(zeros: impl Iterator<Item = &'a ClassifiedZero>) -> Value {
    Value::Array(zeros.map(|z| json!([z.zero.re, z.zero.im])).collect())
}

/// The `fts.zpetc/1` document (keys in documented order).
pub fn zpetc_to_value(z: &Zpetc) -> Value {
    // serde_json's default map is ordered by key; build the object by hand in
    // the documented order through a serialisable struct instead.
    #[derive(serde::Serialize)]
    struct Doc<'a> {
        format: &'static str,
        var: &'static str,
        ts: f64,
        num: &'a [f64],
        den: &'a [f64],
        preview: usize,
        cancelled_zeros: Value,
        uncancelled_zeros: Value,
        rho: f64,
        min_damping: f64,
        #[serde(skip_serializing_if = "Option::is_none")]
        inverted_zeros: Option<Value>,
        #[serde(skip_serializing_if = "Option::is_none")]
        series_terms: Option<usize>,
        #[serde(skip_serializing_if = "Option::is_none")]
        stable_inversion: Option<Value>,
    }
    serde_json::to_value(Doc {
        format: ZPETC_FORMAT,
        var: "z^-1",
        ts: z.ts,
        num: z.num.coeffs(),
        den: z.den.coeffs(),
        preview: z.preview,
        cancelled_zeros: pairs(z.cancelled_zeros()),
        uncancelled_zeros: pairs(z.uncancelled_zeros()),
        rho: z.params.rho,
        min_damping: z.params.min_damping,
        inverted_zeros: z
            .params
            .stable_inversion
            .map(|_| pairs(z.series_inverted_zeros())),
        series_terms: z.params.stable_inversion.map(|_| z.series_terms),
        stable_inversion: z.params.stable_inversion.map(|si| {
            json!({"min_radius": si.min_radius, "tolerance": si.tolerance, "max_terms": si.max_terms})
        }),
    })
    .expect("numbers serialise")
}

/// File text: pretty JSON with a trailing newline.
pub fn zpetc_to_string(z: &Zpetc) -> String {
    let mut s = serde_json::to_string_pretty(&zpetc_to_value(z)).expect("JSON value serialises");
    s.push('\n');
    s
}

fn zero_list(
    obj: &serde_json::Map<String, Value>,
    source: &str,
    key: &str,
) -> Result<Vec<c64>, InputError> {
    let bad = |msg: &str| InputError::new(source, msg).in_field(key);
    match obj.get(key) {
        None => Ok(Vec::new()),
        Some(Value::Array(items)) => items
            .iter()
            .map(|v| match v.as_array().map(|a| a.as_slice()) {
                Some([re, im]) => match (re.as_f64(), im.as_f64()) {
                    (Some(re), Some(im)) if re.is_finite() && im.is_finite() => {
                        Ok(c64::new(re, im))
                    }
                    _ => Err(bad("each zero must be [re, im] with finite numbers")),
                },
                _ => Err(bad("each zero must be [re, im]")),
            })
            .collect(),
        Some(_) => Err(bad("expected an array of [re, im] pairs")),
    }
}

/// Parses an `fts.zpetc/1` document.
pub fn parse_zpetc(text: &str, source: &str) -> Result<Zpetc, InputError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| InputError::new(source, format!("invalid JSON: {e}")).at_line(e.line()))?;
    let obj = value
        .as_object()
        .ok_or_else(|| InputError::new(source, "expected a JSON object"))?;
    check_format(obj, source, ZPETC_FORMAT)?;
    if get_str(obj, source, "var")? != "z^-1" {
        return Err(
            InputError::new(source, "a ZPETC filter is discrete: expected \"z^-1\"")
                .in_field("var"),
        );
    }
    let ts = obj
        .get("ts")
        .and_then(Value::as_f64)
        .filter(|t| t.is_finite() && *t > 0.0);
    let ts = ts.ok_or_else(|| {
        InputError::new(source, "expected a positive number of seconds").in_field("ts")
    })?;
    let num = get_f64_array(obj, source, "num")?;
    let den = get_f64_array(obj, source, "den")?;
    super::tf_json::check_coeffs(source, "num", &num)?;
    super::tf_json::check_coeffs(source, "den", &den)?;
    if den[0] == 0.0 {
        return Err(InputError::new(source, "den[0] must be non-zero").in_field("den"));
    }
    let preview = read_preview(obj.get("preview"), source, "preview")?;
    let defaults = ZpetcParams::default();
    let params = ZpetcParams {
        rho: obj
            .get("rho")
            .and_then(Value::as_f64)
            .unwrap_or(defaults.rho),
        min_damping: obj
            .get("min_damping")
            .and_then(Value::as_f64)
            .unwrap_or(defaults.min_damping),
        stable_inversion: match obj.get("stable_inversion") {
            None | Some(Value::Null) => None,
            Some(Value::Object(si)) => {
                let field = |key: &str, fallback: f64| -> Result<f64, InputError> {
                    match si.get(key) {
                        None => Ok(fallback),
                        Some(v) => {
                            v.as_f64()
                                .filter(|x| x.is_finite() && *x > 0.0)
                                .ok_or_else(|| {
                                    InputError::new(source, "expected a positive number")
                                        .in_field(format!("stable_inversion.{key}"))
                                })
                        }
                    }
                };
                let d = StableInversion::default();
                Some(StableInversion {
                    min_radius: field("min_radius", d.min_radius)?,
                    tolerance: field("tolerance", d.tolerance)?,
                    max_terms: field("max_terms", d.max_terms as f64)? as usize,
                })
            }
            Some(_) => {
                return Err(InputError::new(
                    source,
                    "expected an object {min_radius, tolerance, max_terms} or null",
                )
                .in_field("stable_inversion"));
            }
        },
    };
    let classify = |zero: c64, status| ClassifiedZero {
        zero,
        magnitude: zero.norm(),
        damping: f64::NAN,
        status,
    };
    let mut zeros: Vec<ClassifiedZero> = zero_list(obj, source, "cancelled_zeros")?
        .into_iter()
        .map(|z| classify(z, ZeroStatus::Cancelled))
        .collect();
    for z in zero_list(obj, source, "inverted_zeros")? {
        zeros.push(classify(z, ZeroStatus::InvertedBySeries));
    }
    let series_terms = match obj.get("series_terms") {
        None => 0,
        Some(v) => v.as_u64().ok_or_else(|| {
            InputError::new(source, "expected a non-negative whole number").in_field("series_terms")
        })? as usize,
    };
    for z in zero_list(obj, source, "uncancelled_zeros")? {
        let status = if z.norm() >= params.rho {
            ZeroStatus::OutsideRadius
        } else {
            ZeroStatus::PoorlyDamped
        };
        zeros.push(classify(z, status));
    }
    Ok(Zpetc {
        num: Poly::new(num),
        den: Poly::new(den),
        preview,
        series_terms,
        ts,
        zeros,
        params,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::DiscreteTf;
    use crate::synth::zpetc::design;

    #[test]
    fn round_trip_is_exact() {
        let g = DiscreteTf::new(vec![1.0, -2.0, 0.75], vec![1.0, -0.3], 2, 1e-3).unwrap();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        let text = zpetc_to_string(&z);
        let back = parse_zpetc(&text, "z.json").unwrap();
        assert_eq!(back.num, z.num);
        assert_eq!(back.den, z.den);
        assert_eq!(back.preview, z.preview);
        assert_eq!(zpetc_to_string(&back), text);
    }
    /// A preview beyond what fts can produce is refused on reading, naming
    /// the field, before anything is sized by it.
    #[test]
    fn an_absurd_preview_is_refused() {
        let g = DiscreteTf::new(vec![1.0, -2.0, 0.75], vec![1.0, -0.3], 2, 1e-3).unwrap();
        let text = zpetc_to_string(&design(&g, &ZpetcParams::default()).unwrap());
        let mut doc: Value = serde_json::from_str(&text).unwrap();
        doc["preview"] = Value::from(1_000_000_000_000u64);
        let e = parse_zpetc(&doc.to_string(), "z.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("preview"), "{e}");
        assert!(e.to_string().contains("at most 1000512"), "{e}");
        doc["preview"] = Value::from(MAX_PREVIEW);
        assert_eq!(
            parse_zpetc(&doc.to_string(), "z.json").unwrap().preview as u64,
            MAX_PREVIEW
        );
    }

    #[test]
    fn round_trip_with_stable_inversion() {
        let g = DiscreteTf::new(vec![1.0, -2.0, 0.75], vec![1.0, -0.3], 2, 1e-3).unwrap();
        let params = ZpetcParams {
            stable_inversion: Some(StableInversion::default()),
            ..Default::default()
        };
        let z = design(&g, &params).unwrap();
        assert_eq!(z.series_inverted_zeros().count(), 1);
        let text = zpetc_to_string(&z);
        assert!(text.contains("\"inverted_zeros\""));
        let back = parse_zpetc(&text, "z.json").unwrap();
        assert_eq!(back.num, z.num);
        assert_eq!(back.preview, z.preview);
        assert_eq!(back.series_terms, z.series_terms);
        assert_eq!(back.params, z.params);
        assert_eq!(back.series_inverted_zeros().count(), 1);
        assert_eq!(zpetc_to_string(&back), text);
        // Classical files carry none of the new keys.
        let classical = zpetc_to_string(&design(&g, &ZpetcParams::default()).unwrap());
        assert!(!classical.contains("inverted_zeros") && !classical.contains("series_terms"));
    }
}
