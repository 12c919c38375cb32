//! The `fts.ss/1` state-space file (docs/formats.md):
//! `{"format":"fts.ss/1","ts":null,"a":[[..]],"b":[[..]],"c":[[..]],"d":[[..]]}`,
//! row-major, `ts` null/absent for continuous time. Floats round-trip exactly
//! (serde_json `float_roundtrip`).

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::InputError;
use super::tf_json::{MAX_COEFF_MAGNITUDE, check_format};
use crate::lti::ss::StateSpace;
use faer::Mat;
use serde_json::{Map, Value, json};

/// The format tag this module reads and writes.
pub const SS_FORMAT: &str = "fts.ss/1";

/// The most states a file may have: eigenvalues, Riccati and Lyapunov
/// solutions of a system this size stay within seconds.
pub const MAX_STATES: usize = 512;

/// The most inputs or outputs a file may have.
pub const MAX_CHANNELS: usize = 64;

fn field_err(source: &str, field: &str, message: impl Into<String>) -> InputError {
    InputError::new(source, message).in_field(field)
}

/// A finite entry that is subnormal or beyond [`MAX_COEFF_MAGNITUDE`]: such
/// systems are refused as absurd, as in `fts.tf/1` files.
fn absurd(x: f64) -> bool {
    x.is_finite() && x != 0.0 && (x.abs() < f64::MIN_POSITIVE || x.abs() > MAX_COEFF_MAGNITUDE)
}

/// Reads a rectangular matrix (array of rows). `ncols_if_empty` gives the
/// column count of a matrix with no rows (e.g. `b` of a static gain).
fn get_matrix(
    obj: &Map<String, Value>,
    source: &str,
    key: &str,
) -> Result<(Vec<Vec<f64>>, Option<usize>), InputError> {
    let rows = match obj.get(key) {
        Some(Value::Array(a)) => a,
        Some(_) => {
            return Err(field_err(
                source,
                key,
                "expected an array of rows (arrays of numbers)",
            ));
        }
        None => return Err(field_err(source, key, "missing")),
    };
    if rows.len() > MAX_STATES {
        return Err(field_err(
            source,
            key,
            format!(
                "{} rows; at most {MAX_STATES} (states) are accepted",
                rows.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(rows.len());
    let mut ncols = None;
    for (i, r) in rows.iter().enumerate() {
        let Value::Array(r) = r else {
            return Err(field_err(
                source,
                &format!("{key}[{i}]"),
                "expected a row (array of numbers)",
            ));
        };
        if r.len() > MAX_STATES {
            return Err(field_err(
                source,
                &format!("{key}[{i}]"),
                format!(
                    "{} entries; at most {MAX_STATES} (states) are accepted",
                    r.len()
                ),
            ));
        }
        let mut row = Vec::with_capacity(r.len());
        for (j, v) in r.iter().enumerate() {
            match v.as_f64() {
                Some(x) if absurd(x) => {
                    return Err(field_err(
                        source,
                        &format!("{key}[{i}][{j}]"),
                        format!(
                            "{x:e} is subnormal or beyond {MAX_COEFF_MAGNITUDE:e}; rescale the system (e.g. time in ms, gains in other units)"
                        ),
                    ));
                }
                Some(x) if x.is_finite() => row.push(x),
                _ => {
                    return Err(field_err(
                        source,
                        &format!("{key}[{i}][{j}]"),
                        format!("expected a finite number, found {v}"),
                    ));
                }
            }
        }
        if let Some(nc) = ncols
            && nc != row.len()
        {
            return Err(field_err(
                source,
                &format!("{key}[{i}]"),
                format!("row has {} entries, earlier rows have {nc}", row.len()),
            ));
        }
        ncols = Some(row.len());
        out.push(row);
    }
    Ok((out, ncols))
}

/// Parses an `fts.ss/1` document.
pub fn parse_ss(text: &str, source: &str) -> Result<StateSpace, InputError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| InputError::new(source, format!("invalid JSON: {e}")).at_line(e.line()))?;
    let obj = value
        .as_object()
        .ok_or_else(|| InputError::new(source, "expected a JSON object"))?;
    check_format(obj, source, SS_FORMAT)?;
    let ts = match obj.get("ts") {
        None | Some(Value::Null) => None,
        Some(Value::Number(n)) => {
            let t = n.as_f64().unwrap_or(f64::NAN);
            if !(t.is_finite() && t > 0.0) {
                return Err(field_err(
                    source,
                    "ts",
                    "expected a positive number of seconds (or null for continuous time)",
                ));
            }
            Some(t)
        }
        Some(_) => {
            return Err(field_err(
                source,
                "ts",
                "expected a number of seconds or null",
            ));
        }
    };
    let (a, an) = get_matrix(obj, source, "a")?;
    let (b, bn) = get_matrix(obj, source, "b")?;
    let (c, cn) = get_matrix(obj, source, "c")?;
    let (d, dn) = get_matrix(obj, source, "d")?;
    let n = a.len();
    if let Some(k) = an
        && k != n
    {
        return Err(field_err(
            source,
            "a",
            format!("A must be square: {n} rows of {k} entries"),
        ));
    }
    let ny = d.len();
    if ny == 0 {
        return Err(field_err(
            source,
            "d",
            "must have one row per output (at least one output)",
        ));
    }
    let nu = dn.unwrap_or(0);
    if nu == 0 {
        return Err(field_err(
            source,
            "d",
            "must have one column per input (at least one input)",
        ));
    }
    if ny > MAX_CHANNELS || nu > MAX_CHANNELS {
        return Err(field_err(
            source,
            "d",
            format!("{ny} outputs x {nu} inputs; at most {MAX_CHANNELS} of each are accepted"),
        ));
    }
    if b.len() != n {
        return Err(field_err(
            source,
            "b",
            format!("B must have {n} rows (the states of A), found {}", b.len()),
        ));
    }
    if n > 0 && bn != Some(nu) {
        return Err(field_err(
            source,
            "b",
            format!(
                "B must have {nu} columns (the inputs, as in D), found {}",
                bn.unwrap_or(0)
            ),
        ));
    }
    if c.len() != ny {
        return Err(field_err(
            source,
            "c",
            format!(
                "C must have {ny} rows (the outputs, as in D), found {}",
                c.len()
            ),
        ));
    }
    if n > 0 && cn != Some(n) {
        return Err(field_err(
            source,
            "c",
            format!(
                "C must have {n} columns (the states of A), found {}",
                cn.unwrap_or(0)
            ),
        ));
    }
    let mk = |rows: &Vec<Vec<f64>>, r: usize, k: usize| {
        Mat::from_fn(r, k, |i, j| if k == 0 { 0.0 } else { rows[i][j] })
    };
    StateSpace::new(
        mk(&a, n, n),
        mk(&b, n, nu),
        mk(&c, ny, n),
        mk(&d, ny, nu),
        ts,
    )
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

#[cfg(test)]
mod tests {
    #[test]
    fn sizes_and_magnitudes_are_bounded() {
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

    #[test]
    fn reads_interfaces_example_and_round_trips() {
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

    #[test]
    fn static_gain_round_trips() {
        let g = StateSpace::gain(Mat::from_fn(2, 3, |i, j| (i + j) as f64), None);
        let back = parse_ss(&ss_to_string(&g), "x").unwrap();
        assert_eq!((back.nx(), back.nu(), back.ny()), (0, 3, 2));
    }

    #[test]
    fn errors_name_the_field() {
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
