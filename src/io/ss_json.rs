//! The `fts.ss/1` state-space file (docs/formats.md):
//! `{"format":"fts.ss/1","ts":null,"a":[[..]],"b":[[..]],"c":[[..]],"d":[[..]]}`,
//! row-major, `ts` null/absent for continuous time. Floats round-trip exactly
//! (serde_json `float_roundtrip`).

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::InputError;
use super::serde_doc::{At, from_value, parse_object, top};
use super::tf_json::MAX_COEFF_MAGNITUDE;
use crate::lti::ss::StateSpace;
use faer::Mat;
use serde::Deserialize;
use serde_json::{Map, Value, json};

/// The format tag this module reads and writes.
pub const SS_FORMAT: &str = "fts.ss/1";

/// The most states a file may have: eigenvalues, Riccati and Lyapunov
/// solutions of a system this size stay within seconds.
pub const MAX_STATES: usize = 512;

/// The most inputs or outputs a file may have.
pub const MAX_CHANNELS: usize = 64;

/// A finite entry that is subnormal or beyond [`MAX_COEFF_MAGNITUDE`]: such
/// systems are refused as absurd, as in `fts.tf/1` files.
fn absurd(x: f64) -> bool {
    x.is_finite() && x != 0.0 && (x.abs() < f64::MIN_POSITIVE || x.abs() > MAX_COEFF_MAGNITUDE)
}

/// The `fts.ss/1` document as read (after its `format`); unknown keys are
/// ignored.
#[derive(Deserialize)]
struct SsDoc {
    /// Absent or `null` for continuous time.
    #[serde(default)]
    ts: Option<f64>,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
}

/// Checks a matrix read as an array of rows: at most [`MAX_STATES`] rows of
/// at most as many entries, all finite and not absurd, all rows the same
/// length. Returns that length (`None` with no rows).
fn check_matrix(rows: &[Vec<f64>], key: &str, at: At<'_>) -> Result<Option<usize>, InputError> {
    if rows.len() > MAX_STATES {
        let message = format!(
            "{} rows; at most {MAX_STATES} (states) are accepted",
            rows.len()
        );
        return Err(at.err(key, message));
    }
    let mut ncols = None;
    for (i, row) in rows.iter().enumerate() {
        let row_key = format!("{key}[{i}]");
        if row.len() > MAX_STATES {
            let message = format!(
                "{} entries; at most {MAX_STATES} (states) are accepted",
                row.len()
            );
            return Err(at.err(&row_key, message));
        }
        for (j, &x) in row.iter().enumerate() {
            let message = if absurd(x) {
                format!(
                    "{x:e} is subnormal or beyond {MAX_COEFF_MAGNITUDE:e}; rescale the system (e.g. time in ms, gains in other units)"
                )
            } else if !x.is_finite() {
                format!("expected a finite number, found {x}")
            } else {
                continue;
            };
            return Err(at.err(&format!("{row_key}[{j}]"), message));
        }
        if let Some(nc) = ncols
            && nc != row.len()
        {
            let message = format!("row has {} entries, earlier rows have {nc}", row.len());
            return Err(at.err(&row_key, message));
        }
        ncols = Some(row.len());
    }
    Ok(ncols)
}

/// The dimensions of a system: states, inputs, outputs.
struct Dims {
    n: usize,
    nu: usize,
    ny: usize,
}

impl SsDoc {
    /// Checks each matrix, then that their shapes agree.
    fn dims(&self, at: At<'_>) -> Result<Dims, InputError> {
        let an = check_matrix(&self.a, "a", at)?;
        let bn = check_matrix(&self.b, "b", at)?;
        let cn = check_matrix(&self.c, "c", at)?;
        let dn = check_matrix(&self.d, "d", at)?;
        let n = self.a.len();
        if let Some(k) = an
            && k != n
        {
            return Err(at.err("a", format!("A must be square: {n} rows of {k} entries")));
        }
        let dims = Dims {
            n,
            nu: dn.unwrap_or(0),
            ny: self.d.len(),
        };
        check_d(&dims, at)?;
        let (nu, ny) = (dims.nu, dims.ny);
        let found = |cols: Option<usize>| cols.unwrap_or(0);
        if self.b.len() != n {
            let message = format!(
                "B must have {n} rows (the states of A), found {}",
                self.b.len()
            );
            return Err(at.err("b", message));
        }
        if n > 0 && bn != Some(nu) {
            let message = format!(
                "B must have {nu} columns (the inputs, as in D), found {}",
                found(bn)
            );
            return Err(at.err("b", message));
        }
        if self.c.len() != ny {
            let message = format!(
                "C must have {ny} rows (the outputs, as in D), found {}",
                self.c.len()
            );
            return Err(at.err("c", message));
        }
        if n > 0 && cn != Some(n) {
            let message = format!(
                "C must have {n} columns (the states of A), found {}",
                found(cn)
            );
            return Err(at.err("c", message));
        }
        Ok(dims)
    }
}

/// `d` has at least one and at most [`MAX_CHANNELS`] outputs and inputs.
fn check_d(dims: &Dims, at: At<'_>) -> Result<(), InputError> {
    let (ny, nu) = (dims.ny, dims.nu);
    if ny == 0 {
        return Err(at.err("d", "must have one row per output (at least one output)"));
    }
    if nu == 0 {
        return Err(at.err("d", "must have one column per input (at least one input)"));
    }
    if ny > MAX_CHANNELS || nu > MAX_CHANNELS {
        let message =
            format!("{ny} outputs x {nu} inputs; at most {MAX_CHANNELS} of each are accepted");
        return Err(at.err("d", message));
    }
    Ok(())
}

/// Parses an `fts.ss/1` document.
pub fn parse_ss(text: &str, source: &str) -> Result<StateSpace, InputError> {
    let at = top(source);
    let doc: SsDoc = from_value(parse_object(text, source, SS_FORMAT)?, at)?;
    if let Some(t) = doc.ts
        && !(t.is_finite() && t > 0.0)
    {
        let message = "expected a positive number of seconds (or null for continuous time)";
        return Err(at.err("ts", message));
    }
    let Dims { n, nu, ny } = doc.dims(at)?;
    let mk = |rows: &Vec<Vec<f64>>, r: usize, k: usize| {
        Mat::from_fn(r, k, |i, j| if k == 0 { 0.0 } else { rows[i][j] })
    };
    let (a, b) = (mk(&doc.a, n, n), mk(&doc.b, n, nu));
    StateSpace::new(a, b, mk(&doc.c, ny, n), mk(&doc.d, ny, nu), doc.ts)
        .map_err(|e| InputError::new(source, e.to_string()))
}

fn rows(m: &Mat<f64>) -> Value {
    Value::Array(
        (0..m.nrows())
            .map(|i| Value::Array((0..m.ncols()).map(|j| json!(m[(i, j)])).collect()))
            .collect(),
    )
}

/// Parses an `fts.ss/1` file, or an `fts.tf/1` file realised in
/// controllable canonical form (a discrete one with its delay as states).
pub fn parse_system(text: &str, source: &str) -> Result<StateSpace, InputError> {
    use crate::lti::TransferFunction;
    let format = serde_json::from_str::<Value>(text)
        .ok()
        .and_then(|v| v.get("format").and_then(|f| f.as_str().map(str::to_owned)));
    if format.as_deref() != Some(super::tf_json::TF_FORMAT) {
        return parse_ss(text, source);
    }
    let sys = match super::tf_json::parse_tf(text, source)? {
        TransferFunction::Continuous(c) if c.delay() != 0.0 => {
            return Err(InputError::new(
                source,
                format!(
                    "an input delay of {} s, which no state-space model holds; this command works on one (`fts loop`, `fts tf info` and `fts convert --to tf` read the delay)",
                    c.delay()
                ),
            )
            .in_field("delay"));
        }
        TransferFunction::Continuous(c) => StateSpace::from_continuous_tf(&c),
        TransferFunction::Discrete(d) => crate::lti::margins::discrete_tf_to_ss(&d),
    };
    sys.map_err(|e| InputError::new(source, e.to_string()))
}

/// The document as a JSON value (keys: format, ts, a, b, c, d).
pub fn ss_to_value(sys: &StateSpace) -> Value {
    let mut m = Map::new();
    m.insert("format".into(), json!(SS_FORMAT));
    m.insert("ts".into(), sys.ts.map_or(Value::Null, |t| json!(t)));
    m.insert("a".into(), rows(&sys.a));
    m.insert("b".into(), rows(&sys.b));
    m.insert("c".into(), rows(&sys.c));
    m.insert("d".into(), rows(&sys.d));
    Value::Object(m)
}

/// The file text: one matrix row per line, trailing newline.
pub fn ss_to_string(sys: &StateSpace) -> String {
    let v = ss_to_value(sys);
    let mut s = String::from("{\n");
    s.push_str(&format!("  \"format\": \"{SS_FORMAT}\",\n"));
    s.push_str(&format!("  \"ts\": {},\n", v["ts"]));
    for (k, key) in ["a", "b", "c", "d"].iter().enumerate() {
        let arr = v[*key].as_array().expect("rows");
        s.push_str(&format!("  \"{key}\": ["));
        for (i, r) in arr.iter().enumerate() {
            if i > 0 {
                s.push(',');
            }
            s.push_str("\n    ");
            s.push_str(&r.to_string());
        }
        if !arr.is_empty() {
            s.push_str("\n  ");
        }
        s.push(']');
        s.push_str(if k < 3 { ",\n" } else { "\n" });
    }
    s.push_str("}\n");
    s
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    pub fn sizes_and_magnitudes_are_bounded() {
        let rows = |n: usize| format!("[{}]", vec!["[0]"; n].join(","));
        let big = format!(
            r#"{{"format":"fts.ss/1","a":{},"b":[],"c":[[]],"d":[[1]]}}"#,
            rows(MAX_STATES + 1)
        );
        let e = parse_ss(&big, "s.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("a"), "{e}");
        assert!(e.message.contains("513 rows"), "{e}");
        let wide = format!(
            r#"{{"format":"fts.ss/1","a":[],"b":[],"c":[[]],"d":[[{}]]}}"#,
            vec!["0"; MAX_CHANNELS + 1].join(",")
        );
        let e = parse_ss(&wide, "s.json").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("d"), "{e}");
        for (value, field) in [("1e308", "a[0][0]"), ("1e-310", "a[0][0]")] {
            let text =
                format!(r#"{{"format":"fts.ss/1","a":[[{value}]],"b":[[1]],"c":[[1]],"d":[[0]]}}"#);
            let e = parse_ss(&text, "s.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
        }
    }

    use super::*;

    const EX: &str = r#"{"format": "fts.ss/1", "ts": null,
     "a": [[0, 1], [-2, -3]], "b": [[0], [1]], "c": [[1, 0]], "d": [[0]]}"#;

    /// Type errors name their path as the checks after them do.
    pub fn errors_name_their_path() {
        let doc = |a: &str, ts: &str| {
            format!(
                r#"{{"format": "fts.ss/1", "ts": {ts}, "a": {a}, "b": [[0], [1]], "c": [[1, 0]], "d": [[0]]}}"#
            )
        };
        for (a, ts, field, needle) in [
            (
                "[[0, 1], [-2, \"x\"]]",
                "null",
                "a[1][1]",
                "expected a number",
            ),
            ("[[0, 1], 5]", "null", "a[1]", "expected an array"),
            ("[[0, 1], [2]]", "null", "a[1]", "earlier rows have 2"),
            ("[[0, 1], [2, 3]]", "\"x\"", "ts", "expected a number"),
            ("[[0, 1], [2, 3]]", "-1", "ts", "positive"),
        ] {
            let e = parse_ss(&doc(a, ts), "s.json").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.message.contains(needle), "{e}");
        }
    }

    pub fn reads_interfaces_example_and_round_trips() {
        let g = parse_ss(EX, "g.json").unwrap();
        assert_eq!((g.nx(), g.nu(), g.ny()), (2, 1, 1));
        assert_eq!(g.a[(1, 0)], -2.0);
        let mut h = g.clone();
        h.a[(0, 0)] = 0.1 + 0.2;
        h.ts = Some(1e-4);
        let text = ss_to_string(&h);
        let back = parse_ss(&text, "x").unwrap();
        assert_eq!(back.a[(0, 0)].to_bits(), (0.1f64 + 0.2).to_bits());
        assert_eq!(back.ts, Some(1e-4));
        assert_eq!(ss_to_string(&back), text);
    }

    pub fn static_gain_round_trips() {
        let g = StateSpace::gain(Mat::from_fn(2, 3, |i, j| (i + j) as f64), None);
        let back = parse_ss(&ss_to_string(&g), "x").unwrap();
        assert_eq!((back.nx(), back.nu(), back.ny()), (0, 3, 2));
    }

    pub fn errors_name_the_field() {
        let bad = |t: &str| parse_ss(t, "p.json").unwrap_err().field;
        assert_eq!(
            bad(r#"{"format":"fts.ss/1","a":[[1,2]],"b":[[1]],"c":[[1]],"d":[[0]]}"#).as_deref(),
            Some("a")
        );
        assert_eq!(
            bad(r#"{"format":"fts.ss/1","a":[[1]],"b":[[1,2]],"c":[[1]],"d":[[0]]}"#).as_deref(),
            Some("b")
        );
        assert_eq!(
            bad(r#"{"format":"fts.ss/1","a":[[1]],"b":[[1]],"c":[[1,3]],"d":[[0]]}"#).as_deref(),
            Some("c")
        );
        assert_eq!(
            bad(r#"{"format":"fts.ss/1","a":[[1]],"b":[[1]],"c":[[1]],"d":[[0, "x"]]}"#).as_deref(),
            Some("d[0][1]")
        );
        assert_eq!(
            bad(r#"{"format":"fts.ss/1","ts":-1,"a":[[1]],"b":[[1]],"c":[[1]],"d":[[0]]}"#)
                .as_deref(),
            Some("ts")
        );
        assert_eq!(bad(r#"{"format":"fts.ss/2"}"#).as_deref(), Some("format"));
    }
}
