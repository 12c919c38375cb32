//! Rows of a text record, one at a time, without allocating per row.

use crate::io::InputError;
use std::io::BufRead;

/// The field separator of a text record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Delimiter {
    /// `,` (RFC 4180 quoting).
    Comma,
    /// `;` (European spreadsheet exports; a decimal comma is accepted).
    Semicolon,
    /// One tab between fields (empty fields allowed).
    Tab,
    /// Any run of spaces and tabs (DaISy `.dat`, MATLAB `save -ascii`).
    Whitespace,
}

impl Delimiter {
    /// The names accepted by [`Delimiter::from_name`].
    pub const NAMES: &'static str = "comma, semicolon, tab, whitespace";

    /// `comma`, `semicolon`, `tab` or `whitespace` (or the character itself).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "comma" | "," => Some(Self::Comma),
            "semicolon" | ";" => Some(Self::Semicolon),
            "tab" | "\t" | "\\t" => Some(Self::Tab),
            "whitespace" | "space" | " " => Some(Self::Whitespace),
            _ => None,
        }
    }

    /// The separator of a file whose header (or first data row) is `line`:
    /// a semicolon wins over a comma (which may then be a decimal comma),
    /// a comma over tabs and spaces. Tabs count as whitespace (a
    /// tab-separated file with a trailing tab, as DaISy writes, would
    /// otherwise grow an empty column) unless a tab-separated field holds a
    /// space, as a header name such as `time [ms]` does: then only tabs
    /// separate.
    pub fn sniff(line: &[u8]) -> Self {
        if line.contains(&b';') {
            Self::Semicolon
        } else if line.contains(&b',') {
            Self::Comma
        } else if line
            .trim_ascii()
            .split(|&b| b == b'\t')
            .any(|field| field.trim_ascii().contains(&b' '))
            && line.contains(&b'\t')
        {
            Self::Tab
        } else {
            Self::Whitespace
        }
    }

    /// The separator an Excel `sep=X` first line names: `None` when the line
    /// is no such line, `Some(Err(text))` when it names a separator that is
    /// not read.
    fn from_excel_line(line: &[u8]) -> Option<Result<Self, String>> {
        let line = line.strip_suffix(b"\n").unwrap_or(line);
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let sep = line.strip_prefix(b"sep=")?;
        let text = String::from_utf8_lossy(sep);
        Some(match sep {
            [b',' | b';' | b'\t' | b' '] => Ok(Self::from_name(&text).unwrap_or(Self::Comma)),
            _ => Err(format!(
                "the first line 'sep={text}' names a separator that is not read ({})",
                Self::NAMES
            )),
        })
    }

    fn byte(self) -> Option<u8> {
        match self {
            Self::Comma => Some(b','),
            Self::Semicolon => Some(b';'),
            Self::Tab => Some(b'\t'),
            Self::Whitespace => None,
        }
    }
}

/// The 1-based line of each data row, stored only where rows are not on
/// consecutive lines (comments, blank lines), so it costs nothing for a
/// plain file.
#[derive(Debug, Default)]
pub(super) struct LineMap {
    /// `(row, line)` where a run of consecutive lines starts.
    pub(super) runs: Vec<(usize, usize)>,
    pub(super) rows: usize,
    last_line: usize,
}

impl LineMap {
    pub(super) fn push(&mut self, line: usize) {
        if self.rows == 0 || line != self.last_line + 1 {
            self.runs.push((self.rows, line));
        }
        self.rows += 1;
        self.last_line = line;
    }

    pub(super) fn line(&self, row: usize) -> usize {
        let at = self.runs.partition_point(|&(r, _)| r <= row) - 1;
        let (start_row, start_line) = self.runs[at];
        start_line + (row - start_row)
    }
}

/// Rows of a text file, one at a time, with their fields as trimmed byte
/// slices in a reused buffer.
enum Rows<R: BufRead> {
    Delimited {
        reader: csv::Reader<std::io::Chain<std::io::Cursor<Vec<u8>>, R>>,
        record: csv::ByteRecord,
    },
    Whitespace {
        reader: R,
        pending: Option<Vec<u8>>,
        line: Vec<u8>,
        spans: Vec<(usize, usize)>,
        line_no: usize,
    },
}

pub(super) struct RowReader<'s, R: BufRead> {
    rows: Rows<R>,
    source: &'s str,
    pub(super) line: usize,
    pub(super) delimiter: Delimiter,
}

fn trim(bytes: &[u8]) -> &[u8] {
    bytes.trim_ascii()
}

fn is_skipped(line: &[u8]) -> bool {
    let t = trim(line);
    t.is_empty() || t[0] == b'#'
}

impl<'s, R: BufRead> RowReader<'s, R> {
    /// Reads up to the header line (`header_row`, 1-based, or else the
    /// first non-comment line), sniffs the separator from it and sets up the
    /// row reader; `None` when the file has no data line. An Excel `sep=X`
    /// first line names the separator (unless `forced`) and is skipped.
    /// Skipped lines stay in the count, so rows keep the line numbers of the
    /// file.
    pub(super) fn open(
        mut reader: R,
        source: &'s str,
        forced: Option<Delimiter>,
        header_row: Option<usize>,
    ) -> Result<Option<Self>, InputError> {
        let io_err = |e: std::io::Error| InputError::new(source, format!("cannot read: {e}"));
        // What the CSV reader sees first: an empty line for each skipped
        // line (so its line count stays the file's), then the header line.
        let mut preamble = Vec::new();
        let mut line_no = 0;
        let mut excel_sep = None;
        let first = loop {
            let start = preamble.len();
            if reader.read_until(b'\n', &mut preamble).map_err(io_err)? == 0 {
                return match header_row {
                    Some(h) => Err(InputError::new(
                        source,
                        format!("header row {h}: the file has only {line_no} lines"),
                    )),
                    None => Ok(None),
                };
            }
            line_no += 1;
            if line_no == 1 && preamble.starts_with(b"\xEF\xBB\xBF") {
                preamble.drain(..3); // UTF-8 byte order mark (spreadsheet exports)
            }
            let line = &preamble[start.min(preamble.len())..];
            if line_no == 1
                && let Some(sep) = Delimiter::from_excel_line(line)
            {
                excel_sep = Some(sep.map_err(|m| InputError::new(source, m).at_line(1))?);
            }
            let skipped = match header_row {
                Some(h) if line_no < h => true,
                Some(_) if is_skipped(line) => {
                    return Err(InputError::new(
                        source,
                        "the header row is blank or a comment, not column names",
                    )
                    .at_line(line_no));
                }
                _ => is_skipped(line) || (line_no == 1 && excel_sep.is_some()),
            };
            if !skipped {
                break start.min(preamble.len());
            }
            preamble.truncate(start);
            preamble.push(b'\n');
        };
        let delimiter = forced
            .or(excel_sep)
            .unwrap_or_else(|| Delimiter::sniff(&preamble[first..]));
        let rows = match delimiter.byte() {
            Some(byte) => Rows::Delimited {
                reader: csv::ReaderBuilder::new()
                    .has_headers(false)
                    .flexible(true)
                    .delimiter(byte)
                    .comment(Some(b'#'))
                    .buffer_capacity(1 << 16)
                    .from_reader(std::io::Read::chain(std::io::Cursor::new(preamble), reader)),
                record: csv::ByteRecord::new(),
            },
            None => Rows::Whitespace {
                reader,
                line: Vec::new(),
                pending: Some(preamble[first..].to_vec()),
                spans: Vec::new(),
                line_no: line_no - 1,
            },
        };
        Ok(Some(Self {
            rows,
            source,
            line: 0,
            delimiter,
        }))
    }

    /// Advances to the next data row; `false` at the end.
    pub(super) fn next(&mut self) -> Result<bool, InputError> {
        let source = self.source;
        match &mut self.rows {
            Rows::Delimited { reader, record } => loop {
                match reader.read_byte_record(record) {
                    Ok(false) => return Ok(false),
                    Ok(true) => {
                        self.line = record.position().map_or(0, |p| p.line() as usize);
                        if record.iter().any(|f| !trim(f).is_empty()) {
                            return Ok(true);
                        }
                    }
                    Err(e) => {
                        let line = e.position().map(|p| p.line() as usize);
                        let mut err = InputError::new(source, format!("malformed CSV: {e}"));
                        if let Some(line) = line {
                            err = err.at_line(line);
                        }
                        return Err(err);
                    }
                }
            },
            Rows::Whitespace {
                reader,
                pending,
                line,
                spans,
                line_no,
            } => loop {
                line.clear();
                if let Some(p) = pending.take() {
                    *line = p;
                } else if reader
                    .read_until(b'\n', line)
                    .map_err(|e| InputError::new(source, format!("cannot read: {e}")))?
                    == 0
                {
                    return Ok(false);
                }
                *line_no += 1;
                if is_skipped(line) {
                    continue;
                }
                spans.clear();
                let mut start = None;
                for (i, b) in line.iter().enumerate() {
                    match (b.is_ascii_whitespace(), start) {
                        (false, None) => start = Some(i),
                        (true, Some(s)) => {
                            spans.push((s, i));
                            start = None;
                        }
                        _ => {}
                    }
                }
                if let Some(s) = start {
                    spans.push((s, line.len()));
                }
                self.line = *line_no;
                return Ok(true);
            },
        }
    }

    pub(super) fn field_count(&self) -> usize {
        match &self.rows {
            Rows::Delimited { record, .. } => record.len(),
            Rows::Whitespace { spans, .. } => spans.len(),
        }
    }

    pub(super) fn field(&self, index: usize) -> Option<&[u8]> {
        match &self.rows {
            Rows::Delimited { record, .. } => record.get(index).map(trim),
            Rows::Whitespace { line, spans, .. } => spans.get(index).map(|&(a, b)| &line[a..b]),
        }
    }

    pub(super) fn fields_text(&self) -> Vec<String> {
        (0..self.field_count())
            .map(|i| String::from_utf8_lossy(self.field(i).unwrap_or_default()).into_owned())
            .collect()
    }

    pub(super) fn is_numeric_row(&self) -> bool {
        (0..self.field_count()).all(|i| {
            let f = self.field(i).unwrap_or_default();
            f.is_empty() || parse_number(f, self.delimiter).is_some()
        })
    }
}

/// Parses a number; in a semicolon file a decimal comma (`1,5`) is accepted.
pub(super) fn parse_number(field: &[u8], delimiter: Delimiter) -> Option<f64> {
    let text = std::str::from_utf8(field).ok()?;
    match text.parse::<f64>() {
        Ok(v) => Some(v),
        Err(_) if delimiter == Delimiter::Semicolon && field.len() <= 64 => {
            let mut buf = [0u8; 64];
            let buf = &mut buf[..field.len()];
            buf.copy_from_slice(field);
            let mut commas = 0;
            for b in buf.iter_mut() {
                if *b == b',' {
                    *b = b'.';
                    commas += 1;
                }
            }
            if commas != 1 || field.contains(&b'.') {
                return None;
            }
            std::str::from_utf8(buf).ok()?.parse().ok()
        }
        Err(_) => None,
    }
}
