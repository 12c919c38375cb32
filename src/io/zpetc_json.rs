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
use super::serde_doc::{At, Object, from_value, parse_object, top};
use super::tf_json::check_poly;
use crate::lti::{Poly, c64};
use crate::synth::zpetc::{ClassifiedZero, StableInversion, ZeroStatus, Zpetc, ZpetcParams};
use serde::Deserialize;
use serde_json::{Value, json};

/// The longest preview a file may declare, samples: the longest input delay
/// of a model file plus the runtime's filter capacity.
pub const MAX_PREVIEW: u64 = super::tf_json::MAX_DELAY + crate::runtime::MAX_FILTER_LEN as u64;

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

/// The `fts.zpetc/1` document as read (after its `format`); unknown keys
/// are ignored.
#[derive(Deserialize)]
struct ZpetcDoc {
    var: String,
    ts: f64,
    num: Vec<f64>,
    den: Vec<f64>,
    preview: u64,
    #[serde(default)]
    cancelled_zeros: Vec<[f64; 2]>,
    #[serde(default)]
    uncancelled_zeros: Vec<[f64; 2]>,
    /// `null` (as a NaN is written) reads as the default.
    #[serde(default)]
    rho: Option<f64>,
    #[serde(default)]
    min_damping: Option<f64>,
    #[serde(default)]
    inverted_zeros: Vec<[f64; 2]>,
    #[serde(default)]
    series_terms: u64,
    #[serde(default)]
    stable_inversion: Option<Object<StableInversionDoc>>,
}

/// `stable_inversion`: each key defaults to [`StableInversion::default`].
#[derive(Deserialize)]
#[serde(default)]
struct StableInversionDoc {
    min_radius: f64,
    tolerance: f64,
    max_terms: f64,
}

impl Default for StableInversionDoc {
    fn default() -> Self {
        let d = StableInversion::default();
        Self {
            min_radius: d.min_radius,
            tolerance: d.tolerance,
            max_terms: d.max_terms as f64,
        }
    }
}

impl StableInversionDoc {
    fn read(&self, at: At<'_>) -> Result<StableInversion, InputError> {
        let positive = |key: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(at.err(key, "expected a positive number"))
            }
        };
        Ok(StableInversion {
            min_radius: positive("min_radius", self.min_radius)?,
            tolerance: positive("tolerance", self.tolerance)?,
            max_terms: positive("max_terms", self.max_terms)? as usize,
        })
    }
}

/// Parses an `fts.zpetc/1` document.
pub fn parse_zpetc(text: &str, source: &str) -> Result<Zpetc, InputError> {
    let at = top(source);
    let doc: ZpetcDoc = from_value(parse_object(text, source, ZPETC_FORMAT)?, at)?;
    doc.zpetc(at)
}

impl ZpetcDoc {
    /// The filter, once every field is checked.
    fn zpetc(self, at: At<'_>) -> Result<Zpetc, InputError> {
        if self.var != "z^-1" {
            return Err(at.err("var", "a ZPETC filter is discrete: expected \"z^-1\""));
        }
        if !(self.ts.is_finite() && self.ts > 0.0) {
            return Err(at.err("ts", "expected a positive number of seconds"));
        }
        check_poly(at.source, "num", &self.num)?;
        check_poly(at.source, "den", &self.den)?;
        if self.den[0] == 0.0 {
            return Err(at.err("den", "den[0] must be non-zero"));
        }
        if self.preview > MAX_PREVIEW {
            let p = self.preview;
            let message = format!("{p} samples of preview; at most {MAX_PREVIEW} are accepted");
            return Err(at.err("preview", message));
        }
        let defaults = ZpetcParams::default();
        let params = ZpetcParams {
            rho: self.rho.unwrap_or(defaults.rho),
            min_damping: self.min_damping.unwrap_or(defaults.min_damping),
            stable_inversion: match &self.stable_inversion {
                Some(Object(si)) => Some(si.read(At {
                    source: at.source,
                    path: "stable_inversion",
                })?),
                None => None,
            },
        };
        let zeros = self.zeros(at, params.rho)?;
        Ok(Zpetc {
            num: Poly::new(self.num),
            den: Poly::new(self.den),
            preview: self.preview as usize,
            series_terms: self.series_terms as usize,
            ts: self.ts,
            zeros,
            params,
        })
    }

    /// The listed zeros, classified: cancelled, inverted by the series, then
    /// the uncancelled ones (outside `rho` or poorly damped).
    fn zeros(&self, at: At<'_>, rho: f64) -> Result<Vec<ClassifiedZero>, InputError> {
        let classify = |zero: c64, status| ClassifiedZero {
            zero,
            magnitude: zero.norm(),
            damping: f64::NAN,
            status,
        };
        let lists = [
            ("cancelled_zeros", &self.cancelled_zeros),
            ("inverted_zeros", &self.inverted_zeros),
            ("uncancelled_zeros", &self.uncancelled_zeros),
        ];
        let mut zeros = Vec::new();
        for (key, list) in lists {
            for (i, &[re, im]) in list.iter().enumerate() {
                if !(re.is_finite() && im.is_finite()) {
                    let message = "each zero must be [re, im] with finite numbers";
                    return Err(at.err(&format!("{key}[{i}]"), message));
                }
                let zero = c64::new(re, im);
                let status = match key {
                    "cancelled_zeros" => ZeroStatus::Cancelled,
                    "inverted_zeros" => ZeroStatus::InvertedBySeries,
                    _ if zero.norm() >= rho => ZeroStatus::OutsideRadius,
                    _ => ZeroStatus::PoorlyDamped,
                };
                zeros.push(classify(zero, status));
            }
        }
        Ok(zeros)
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::DiscreteTf;
    use crate::synth::zpetc::design;

    pub fn round_trip_is_exact() {
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
    pub fn an_absurd_preview_is_refused() {
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

    /// Each error names its path, from serde's type errors as from the
    /// checks after them.
    pub fn errors_name_their_path() {
        let head =
            r#"{"format": "fts.zpetc/1", "var": "z^-1", "ts": 1e-4, "den": [1], "preview": 1"#;
        for (tail, field, needle) in [
            (r#", "num": [1, "a"]}"#, "num[1]", "expected a number"),
            (r#", "num": []}"#, "num", "must not be empty"),
            (
                r#", "num": [1], "cancelled_zeros": [[1]]}"#,
                "cancelled_zeros[0]",
                "length 2",
            ),
            (
                r#", "num": [1], "stable_inversion": {"tolerance": -1}}"#,
                "stable_inversion.tolerance",
                "positive",
            ),
            (
                r#", "num": [1], "series_terms": null}"#,
                "series_terms",
                "found null",
            ),
            (
                r#", "num": [1], "stable_inversion": [2]}"#,
                "stable_inversion",
                "an object",
            ),
        ] {
            let e = parse_zpetc(&format!("{head}{tail}"), "z.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
    }

    pub fn round_trip_with_stable_inversion() {
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
