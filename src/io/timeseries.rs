//! The time-series CSV contract of `shared/spec/interfaces.md`.
//!
//! One row per sample. Comma-separated files are parsed with the `csv` crate
//! (quoting, an empty first field as in the SmartHysteresis piezo record);
//! files without a comma on their first data line are split on whitespace
//! (DaISy `.dat`, MATLAB `save -ascii`). Lines starting with `#` and blank
//! lines are skipped. Columns are picked by header name or by 1-based index.

use super::InputError;

/// A column, by header name or by 1-based index.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ColumnRef {
    /// The header cell with this (trimmed, case-sensitive) text.
    Name(String),
    /// 1-based position among the fields of a line (an empty leading field counts).
    Index(usize),
}

impl ColumnRef {
    /// Parses the command-line form: digits are an index, anything else a name.
    pub fn parse(text: &str) -> Self {
        match text.trim().parse::<usize>() {
            Ok(i) => ColumnRef::Index(i),
            Err(_) => ColumnRef::Name(text.trim().to_owned()),
        }
    }
}

impl std::fmt::Display for ColumnRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ColumnRef::Name(n) => f.write_str(n),
            ColumnRef::Index(i) => write!(f, "column {i}"),
        }
    }
}

/// Whether the first data line is a header row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HeaderMode {
    /// A header if any non-empty field of the first line is not a number.
    #[default]
    Detect,
    /// The first line is a header.
    Present,
    /// There is no header (`--no-header`).
    Absent,
}

/// Relative jitter allowed between successive time steps (interfaces.md).
pub const UNIFORM_TIME_TOLERANCE: f64 = 1e-6;

/// Which columns to read.
#[derive(Debug, Clone)]
pub struct ReadParams {
    /// Data columns to return, in this order.
    pub columns: Vec<ColumnRef>,
    /// Optional time column; when present it must increase with uniform steps.
    pub time: Option<ColumnRef>,
    /// Header handling.
    pub header: HeaderMode,
    /// Fewer data rows than this is an error.
    pub min_rows: usize,
}

/// The columns that were read.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Data columns in the order requested.
    pub columns: Vec<Vec<f64>>,
    /// Display names of the columns (header text or `column N`).
    pub names: Vec<String>,
    /// The time column, if one was read.
    pub time: Option<Vec<f64>>,
    /// Sample time from the time column (mean step), if one was read.
    pub ts: Option<f64>,
    /// The 1-based line number of each data row.
    pub lines: Vec<usize>,
    /// Whether a header row was found.
    pub had_header: bool,
}

impl Table {
    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// Whether there are no data rows.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }
}

/// A single-input single-output record, the usual input of identification.
#[derive(Debug, Clone, PartialEq)]
pub struct IoData {
    /// Input signal `u`.
    pub input: Vec<f64>,
    /// Output signal `y`.
    pub output: Vec<f64>,
    /// Sample time in seconds, from the time column, if any.
    pub ts: Option<f64>,
    /// Display names of the input and output columns.
    pub input_name: String,
    /// Display name of the output column.
    pub output_name: String,
}

/// Column choice for an input/output record. Defaults (interfaces.md): `u`, `y`,
/// and `t` if the file has a header with such a column. A headerless file
/// without explicit columns reads column 1 as input and column 2 as output
/// (the DaISy convention).
#[derive(Debug, Clone, Default)]
pub struct IoColumns {
    /// `--input`; `None` means the default.
    pub input: Option<ColumnRef>,
    /// `--output`; `None` means the default.
    pub output: Option<ColumnRef>,
    /// `--time`; `None` means `t` when a header has it.
    pub time: Option<ColumnRef>,
    /// Header handling.
    pub header: HeaderMode,
}

struct RawLine {
    line: usize,
    fields: Vec<String>,
}

fn split_lines(text: &str, source: &str) -> Result<Vec<RawLine>, InputError> {
    let first_data = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'));
    let Some(first_data) = first_data else {
        return Err(InputError::new(
            source,
            "no data rows (the file is empty or all comments)",
        ));
    };
    let mut out = Vec::new();
    if first_data.contains(',') {
        // Comments and blank lines are removed by hand (keeping line numbers),
        // so the csv crate only sees data; `flexible` lets us report ragged
        // rows ourselves with a better message.
        for (idx, raw) in text.lines().enumerate() {
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let mut reader = csv::ReaderBuilder::new()
                .has_headers(false)
                .flexible(true)
                .from_reader(raw.as_bytes());
            let mut record = csv::StringRecord::new();
            match reader.read_record(&mut record) {
                Ok(true) => out.push(RawLine {
                    line: idx + 1,
                    fields: record.iter().map(|f| f.trim().to_owned()).collect(),
                }),
                Ok(false) => {}
                Err(e) => {
                    return Err(
                        InputError::new(source, format!("malformed CSV: {e}")).at_line(idx + 1)
                    );
                }
            }
        }
    } else {
        for (idx, raw) in text.lines().enumerate() {
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            out.push(RawLine {
                line: idx + 1,
                fields: trimmed.split_whitespace().map(str::to_owned).collect(),
            });
        }
    }
    Ok(out)
}

fn is_number(field: &str) -> bool {
    field.parse::<f64>().is_ok()
}

fn resolve(
    col: &ColumnRef,
    header: Option<&[String]>,
    source: &str,
) -> Result<(usize, String), InputError> {
    match col {
        ColumnRef::Index(0) => Err(InputError::new(source, "column indices are 1-based; 0 is not a column")),
        ColumnRef::Index(i) => {
            let name = header
                .and_then(|h| h.get(i - 1))
                .filter(|n| !n.is_empty())
                .cloned()
                .unwrap_or_else(|| format!("column {i}"));
            Ok((i - 1, name))
        }
        ColumnRef::Name(name) => match header {
            None => Err(InputError::new(
                source,
                format!("the file has no header row, so column '{name}' cannot be found by name; give a 1-based column index"),
            )
            .in_field(name.clone())),
            Some(h) => h
                .iter()
                .position(|c| c == name)
                .map(|i| (i, name.clone()))
                .ok_or_else(|| {
                    let have: Vec<&str> = h.iter().map(String::as_str).filter(|s| !s.is_empty()).collect();
                    InputError::new(
                        source,
                        format!("missing column '{name}' (the header has: {})", have.join(", ")),
                    )
                    .in_field(name.clone())
                    .at_line(0)
                }),
        },
    }
}

fn parse_cell(raw: &RawLine, index: usize, name: &str, source: &str) -> Result<f64, InputError> {
    let err = |msg: String| {
        InputError::new(source, msg)
            .at_line(raw.line)
            .in_field(name)
    };
    let Some(cell) = raw.fields.get(index) else {
        return Err(err(format!(
            "missing field: the line has {} fields, column {} was expected",
            raw.fields.len(),
            index + 1
        )));
    };
    if cell.is_empty() {
        return Err(err("empty cell".to_owned()));
    }
    let value: f64 = cell
        .parse()
        .map_err(|_| err(format!("not a number: {cell:?}")))?;
    if !value.is_finite() {
        return Err(err(format!("value must be finite, found {cell}")));
    }
    Ok(value)
}

/// Reads the requested columns of a time-series text.
pub fn read_table(text: &str, source: &str, params: &ReadParams) -> Result<Table, InputError> {
    let mut lines = split_lines(text, source)?;
    let had_header = match params.header {
        HeaderMode::Present => true,
        HeaderMode::Absent => false,
        HeaderMode::Detect => lines[0]
            .fields
            .iter()
            .any(|f| !f.is_empty() && !is_number(f)),
    };
    let header_line = if had_header {
        let h = lines.remove(0);
        Some(h)
    } else {
        None
    };
    let header = header_line.as_ref().map(|h| h.fields.as_slice());
    let fix_header_line = |mut e: InputError| {
        if e.line == Some(0) {
            e.line = header_line.as_ref().map(|h| h.line);
        }
        e
    };
    let mut picked = Vec::with_capacity(params.columns.len());
    for col in &params.columns {
        picked.push(resolve(col, header, source).map_err(fix_header_line)?);
    }
    let time_col = match &params.time {
        Some(t) => Some(resolve(t, header, source).map_err(fix_header_line)?),
        None => None,
    };

    if lines.len() < params.min_rows {
        return Err(InputError::new(
            source,
            format!(
                "too few data rows: {} found, at least {} needed",
                lines.len(),
                params.min_rows
            ),
        ));
    }

    let mut columns = vec![Vec::with_capacity(lines.len()); picked.len()];
    let mut time = time_col.as_ref().map(|_| Vec::with_capacity(lines.len()));
    for raw in &lines {
        for ((index, name), column) in picked.iter().zip(columns.iter_mut()) {
            column.push(parse_cell(raw, *index, name, source)?);
        }
        if let (Some((index, name)), Some(t)) = (&time_col, time.as_mut()) {
            let value = parse_cell(raw, *index, name, source)?;
            if let Some(&prev) = t.last()
                && value <= prev
            {
                return Err(InputError::new(
                    source,
                    format!("time must increase: {value} follows {prev}"),
                )
                .at_line(raw.line)
                .in_field(name.clone()));
            }
            t.push(value);
        }
    }

    let ts = match (&time, &time_col) {
        (Some(t), Some((_, name))) if t.len() >= 2 => {
            // Each step is compared with the first, so the error points at the
            // first line where the spacing changes.
            let first = t[1] - t[0];
            for (k, w) in t.windows(2).enumerate() {
                let step = w[1] - w[0];
                if ((step - first) / first).abs() > UNIFORM_TIME_TOLERANCE {
                    return Err(InputError::new(
                        source,
                        format!(
                            "non-uniform time: step {step:e} s differs from the first step {first:e} s by more than {UNIFORM_TIME_TOLERANCE:e} (relative); resample, or drop the time column and give --ts"
                        ),
                    )
                    .at_line(lines[k + 1].line)
                    .in_field(name.clone()));
                }
            }
            Some((t[t.len() - 1] - t[0]) / (t.len() - 1) as f64)
        }
        _ => None,
    };

    Ok(Table {
        columns,
        names: picked.into_iter().map(|(_, n)| n).collect(),
        time,
        ts,
        lines: lines.iter().map(|l| l.line).collect(),
        had_header,
    })
}

/// Reads an input/output record with the defaults of interfaces.md.
pub fn read_io(
    text: &str,
    source: &str,
    cols: &IoColumns,
    min_rows: usize,
) -> Result<IoData, InputError> {
    // Decide whether a header exists before picking defaults, since a headerless
    // file takes positional defaults.
    let has_header = match cols.header {
        HeaderMode::Present => true,
        HeaderMode::Absent => false,
        HeaderMode::Detect => {
            let lines = split_lines(text, source)?;
            lines[0]
                .fields
                .iter()
                .any(|f| !f.is_empty() && !is_number(f))
        }
    };
    let header_mode = if has_header {
        HeaderMode::Present
    } else {
        HeaderMode::Absent
    };
    let (default_in, default_out) = if has_header {
        (ColumnRef::Name("u".into()), ColumnRef::Name("y".into()))
    } else {
        (ColumnRef::Index(1), ColumnRef::Index(2))
    };
    let time = match (&cols.time, has_header) {
        (Some(t), _) => Some(t.clone()),
        (None, true) => {
            // `t` is used only when the header has it.
            let lines = split_lines(text, source)?;
            lines[0]
                .fields
                .iter()
                .any(|f| f == "t")
                .then(|| ColumnRef::Name("t".into()))
        }
        (None, false) => None,
    };
    let params = ReadParams {
        columns: vec![
            cols.input.clone().unwrap_or(default_in),
            cols.output.clone().unwrap_or(default_out),
        ],
        time,
        header: header_mode,
        min_rows,
    };
    let mut table = read_table(text, source, &params)?;
    let output = table.columns.pop().unwrap_or_default();
    let input = table.columns.pop().unwrap_or_default();
    let output_name = table.names.pop().unwrap_or_default();
    let input_name = table.names.pop().unwrap_or_default();
    Ok(IoData {
        input,
        output,
        ts: table.ts,
        input_name,
        output_name,
    })
}

/// Writes columns as CSV text with a header row. Floats use Rust's shortest
/// round-trip formatting, so reading the file back gives the same `f64`s.
/// All columns must have the same length.
pub fn write_csv(names: &[&str], columns: &[&[f64]]) -> String {
    use std::fmt::Write;
    let rows = columns.first().map_or(0, |c| c.len());
    debug_assert!(columns.iter().all(|c| c.len() == rows));
    let mut out = String::with_capacity(rows * columns.len() * 12 + 64);
    out.push_str(&names.join(","));
    out.push('\n');
    for k in 0..rows {
        for (j, c) in columns.iter().enumerate() {
            if j > 0 {
                out.push(',');
            }
            let _ = write!(out, "{}", c[k]);
        }
        out.push('\n');
    }
    out
}

/// Sample times `k * ts` for `n` samples (exact multiples, no accumulated drift).
pub fn time_column(n: usize, ts: f64) -> Vec<f64> {
    (0..n).map(|k| k as f64 * ts).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn io(text: &str, cols: &IoColumns) -> Result<IoData, InputError> {
        read_io(text, "f.csv", cols, 1)
    }

    #[test]
    fn header_names_and_time() {
        let d = io(
            "# comment\nt,u,y\n0,1,2\n0.5,3,4\n1.0,5,6\n",
            &IoColumns::default(),
        )
        .unwrap();
        assert_eq!(d.input, vec![1.0, 3.0, 5.0]);
        assert_eq!(d.output, vec![2.0, 4.0, 6.0]);
        assert_eq!(d.ts, Some(0.5));
    }

    #[test]
    fn whitespace_dat_headerless_defaults() {
        let d = io(
            "   6.41e+00\t   4.76e+00\t\n   3.41e+00\t 4.70e+00\t\n",
            &IoColumns::default(),
        )
        .unwrap();
        assert_eq!(d.input, vec![6.41, 3.41]);
        assert_eq!(d.output, vec![4.76, 4.70]);
        assert_eq!(d.ts, None);
    }

    #[test]
    fn empty_leading_field_counts_as_column_one() {
        let cols = IoColumns {
            input: Some(ColumnRef::Index(4)),
            output: Some(ColumnRef::Index(3)),
            ..Default::default()
        };
        let d = io(",0,-1.6,0\n,0.0002,-1.7,5\n", &cols).unwrap();
        assert_eq!(d.input, vec![0.0, 5.0]);
        assert_eq!(d.output, vec![-1.6, -1.7]);
    }

    #[test]
    fn errors_name_line_and_field() {
        let e = io("u,y\n1,2\n3,abc\n", &IoColumns::default()).unwrap_err();
        assert_eq!(e.line, Some(3));
        assert_eq!(e.field.as_deref(), Some("y"));
        assert!(e.to_string().contains("not a number"), "{e}");

        let e = io("u,y\n1,\n", &IoColumns::default()).unwrap_err();
        assert!(e.to_string().contains("empty cell"), "{e}");

        let e = io("u,y\n1,NaN\n", &IoColumns::default()).unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");

        let e = io("a,b\n1,2\n", &IoColumns::default()).unwrap_err();
        assert!(e.to_string().contains("missing column 'u'"), "{e}");
        assert_eq!(e.line, Some(1));

        let e = io("t,u,y\n0,1,2\n0,1,2\n", &IoColumns::default()).unwrap_err();
        assert!(e.to_string().contains("time must increase"), "{e}");
        assert_eq!(e.line, Some(3));

        let e = io("t,u,y\n0,1,2\n1,1,2\n2.5,1,2\n", &IoColumns::default()).unwrap_err();
        assert!(e.to_string().contains("non-uniform"), "{e}");
        assert_eq!(e.line, Some(4));

        let e = read_io("u,y\n1,2\n", "f.csv", &IoColumns::default(), 5).unwrap_err();
        assert!(
            e.to_string()
                .contains("too few data rows: 1 found, at least 5"),
            "{e}"
        );

        let e = io("1 2\n3\n", &IoColumns::default()).unwrap_err();
        assert_eq!(e.line, Some(2));
        assert!(e.to_string().contains("missing field"), "{e}");
    }

    #[test]
    fn write_then_read_is_exact() {
        let t = time_column(4, 1e-4);
        let u = [0.1 + 0.2, 1.0 / 3.0, -1e-300, 5.0];
        let text = write_csv(&["t", "u", "y"], &[&t, &u, &u]);
        let d = read_io(&text, "w.csv", &IoColumns::default(), 1).unwrap();
        assert_eq!(d.input, u);
        assert!((d.ts.unwrap() - 1e-4).abs() < 1e-18);
    }
}
