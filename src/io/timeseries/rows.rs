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

    /// Appends the rows of `other`, whose lines are numbered
    /// `line_offset` lower than they are in the file.
    pub(super) fn append(&mut self, other: LineMap, line_offset: usize) {
        for (row, line) in other.runs {
            let line = line + line_offset;
            // A run that goes on from this map's last line is no new run.
            if !(row == 0 && self.rows > 0 && line == self.last_line + 1) {
                self.runs.push((self.rows + row, line));
            }
        }
        if other.rows > 0 {
            self.rows += other.rows;
            self.last_line = other.last_line + line_offset;
        }
    }

    pub(super) fn line(&self, row: usize) -> usize {
        let at = self.runs.partition_point(|&(r, _)| r <= row) - 1;
        let (start_row, start_line) = self.runs[at];
        start_line + (row - start_row)
    }
}

/// How a line is cut into fields.
pub(super) enum Split {
    /// One separator byte; a line holding a quote is unquoted by csv-core
    /// (RFC 4180: quoted separators, doubled quotes).
    Delimited {
        byte: u8,
        quoted: Box<csv_core::Reader>,
    },
    /// Runs of spaces and tabs.
    Whitespace,
}

/// The fields of one line: byte spans of the line itself or, for a line
/// with quotes, of its unquoted text.
#[derive(Default)]
pub(super) struct Fields {
    spans: Vec<(usize, usize)>,
    unquoted: Vec<u8>,
    ends: Vec<usize>,
    from_unquoted: bool,
}

impl Fields {
    pub(super) fn len(&self) -> usize {
        self.spans.len()
    }

    /// Field `index`, trimmed.
    pub(super) fn get<'a>(&'a self, line: &'a [u8], index: usize) -> Option<&'a [u8]> {
        let text = if self.from_unquoted {
            &self.unquoted[..]
        } else {
            line
        };
        self.spans.get(index).map(|&(a, b)| trim(&text[a..b]))
    }

    fn all_empty(&self, line: &[u8]) -> bool {
        (0..self.len()).all(|i| self.get(line, i).is_none_or(<[u8]>::is_empty))
    }
}

impl Split {
    pub(super) fn new(delimiter: Delimiter) -> Self {
        match delimiter.byte() {
            Some(byte) => Self::Delimited {
                byte,
                quoted: Box::new(csv_core::ReaderBuilder::new().delimiter(byte).build()),
            },
            None => Self::Whitespace,
        }
    }

    /// Cuts `line` (without its line end) into `fields`; `Ok(false)` for a
    /// line to skip (blank, a comment, or only empty fields).
    pub(super) fn split(&mut self, line: &[u8], fields: &mut Fields) -> Result<bool, String> {
        if is_skipped(line) {
            return Ok(false);
        }
        fields.spans.clear();
        fields.from_unquoted = false;
        match self {
            Self::Whitespace => {
                let mut start = None;
                for (i, b) in line.iter().enumerate() {
                    match (b.is_ascii_whitespace(), start) {
                        (false, None) => start = Some(i),
                        (true, Some(s)) => {
                            fields.spans.push((s, i));
                            start = None;
                        }
                        _ => {}
                    }
                }
                if let Some(s) = start {
                    fields.spans.push((s, line.len()));
                }
                Ok(true)
            }
            Self::Delimited { byte, quoted } => {
                if memchr::memchr(b'"', line).is_some() {
                    unquote(quoted, line, fields)?;
                } else {
                    let mut start = 0;
                    for end in memchr::memchr_iter(*byte, line) {
                        fields.spans.push((start, end));
                        start = end + 1;
                    }
                    fields.spans.push((start, line.len()));
                }
                Ok(!fields.all_empty(line))
            }
        }
    }
}

/// The fields of a line with quotes, by csv-core.
fn unquote(reader: &mut csv_core::Reader, line: &[u8], fields: &mut Fields) -> Result<(), String> {
    use csv_core::ReadRecordResult::{End, InputEmpty, Record};
    if line.iter().filter(|&&b| b == b'"').count() % 2 == 1 {
        return Err("malformed CSV: a quoted field does not end on its line".into());
    }
    reader.reset();
    fields.unquoted.resize(line.len(), 0);
    fields.ends.resize(line.len() + 1, 0);
    let (mut input, mut nout, mut nend) = (line, 0, 0);
    loop {
        let (result, nin, o, e) = reader.read_record(
            input,
            &mut fields.unquoted[nout..],
            &mut fields.ends[nend..],
        );
        input = &input[nin..];
        nout += o;
        nend += e;
        match result {
            InputEmpty => {}
            Record | End => break,
            _ => return Err("malformed CSV: a field could not be read".into()),
        }
    }
    let mut start = 0;
    for &end in &fields.ends[..nend] {
        fields.spans.push((start, end));
        start = end;
    }
    fields.from_unquoted = true;
    Ok(())
}

/// The text source: the reader itself, or the whole input in memory with
/// classic Mac line ends (a lone `\r`) turned into `\n`.
pub(super) enum Input<R> {
    Stream(R),
    Memory(std::io::Cursor<Vec<u8>>),
}

impl<R: BufRead> std::io::Read for Input<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Self::Stream(r) => r.read(buf),
            Self::Memory(c) => c.read(buf),
        }
    }
}

impl<R: BufRead> BufRead for Input<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        match self {
            Self::Stream(r) => r.fill_buf(),
            Self::Memory(c) => c.fill_buf(),
        }
    }

    fn consume(&mut self, amount: usize) {
        match self {
            Self::Stream(r) => r.consume(amount),
            Self::Memory(c) => c.consume(amount),
        }
    }
}

impl<R: BufRead> Input<R> {
    /// `reader`, read whole and translated when its first buffer has a lone
    /// `\r` line end.
    fn new(mut reader: R) -> std::io::Result<Self> {
        let peek = reader.fill_buf()?;
        let lone_cr = peek.windows(2).any(|w| w[0] == b'\r' && w[1] != b'\n');
        if !lone_cr {
            return Ok(Self::Stream(reader));
        }
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut reader, &mut bytes)?;
        let mut out = Vec::with_capacity(bytes.len());
        for (i, &b) in bytes.iter().enumerate() {
            out.push(if b == b'\r' && bytes.get(i + 1) != Some(&b'\n') {
                b'\n'
            } else {
                b
            });
        }
        Ok(Self::Memory(std::io::Cursor::new(out)))
    }
}

/// Rows of a text file, one at a time, with their fields as trimmed byte
/// slices of a reused line buffer.
pub(super) struct RowReader<'s, R: BufRead> {
    reader: Input<R>,
    pending: Option<Vec<u8>>,
    text: Vec<u8>,
    fields: Fields,
    split: Split,
    line_no: usize,
    source: &'s str,
    pub(super) line: usize,
    pub(super) delimiter: Delimiter,
}

/// What follows the rows read one at a time: the source and the number of
/// lines consumed.
pub(super) struct Rest<R> {
    pub(super) reader: Input<R>,
    pub(super) lines_read: usize,
}

fn trim(bytes: &[u8]) -> &[u8] {
    bytes.trim_ascii()
}

fn is_skipped(line: &[u8]) -> bool {
    let t = trim(line);
    t.is_empty() || t[0] == b'#'
}

/// `line` without its `\n` or `\r\n`.
pub(super) fn strip_line_end(line: &[u8]) -> &[u8] {
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    line.strip_suffix(b"\r").unwrap_or(line)
}

impl<'s, R: BufRead> RowReader<'s, R> {
    /// Reads up to the header line (`header_row`, 1-based, or else the
    /// first non-comment line), sniffs the separator from it and sets up the
    /// row reader; `None` when the file has no data line. An Excel `sep=X`
    /// first line names the separator (unless `forced`) and is skipped.
    /// Skipped lines stay in the count, so rows keep the line numbers of the
    /// file.
    pub(super) fn open(
        reader: R,
        source: &'s str,
        forced: Option<Delimiter>,
        header_row: Option<usize>,
    ) -> Result<Option<Self>, InputError> {
        let io_err = |e: std::io::Error| InputError::new(source, format!("cannot read: {e}"));
        let mut reader = Input::new(reader).map_err(io_err)?;
        let mut line = Vec::new();
        let mut line_no = 0;
        let mut excel_sep = None;
        loop {
            line.clear();
            if reader.read_until(b'\n', &mut line).map_err(io_err)? == 0 {
                return match header_row {
                    Some(h) => Err(InputError::new(
                        source,
                        format!("header row {h}: the file has only {line_no} lines"),
                    )),
                    None => Ok(None),
                };
            }
            line_no += 1;
            if line_no == 1 && line.starts_with(b"\xEF\xBB\xBF") {
                line.drain(..3); // UTF-8 byte order mark (spreadsheet exports)
            }
            if line_no == 1
                && let Some(sep) = Delimiter::from_excel_line(&line)
            {
                excel_sep = Some(sep.map_err(|m| InputError::new(source, m).at_line(1))?);
            }
            let skipped = match header_row {
                Some(h) if line_no < h => true,
                Some(_) if is_skipped(&line) => {
                    return Err(InputError::new(
                        source,
                        "the header row is blank or a comment, not column names",
                    )
                    .at_line(line_no));
                }
                _ => is_skipped(&line) || (line_no == 1 && excel_sep.is_some()),
            };
            if !skipped {
                break;
            }
        }
        let delimiter = forced
            .or(excel_sep)
            .unwrap_or_else(|| Delimiter::sniff(&line));
        Ok(Some(Self {
            reader,
            pending: Some(line),
            text: Vec::new(),
            fields: Fields::default(),
            split: Split::new(delimiter),
            line_no: line_no - 1,
            source,
            line: 0,
            delimiter,
        }))
    }

    /// Advances to the next data row; `false` at the end.
    pub(super) fn next(&mut self) -> Result<bool, InputError> {
        let source = self.source;
        loop {
            self.text.clear();
            if let Some(p) = self.pending.take() {
                self.text = p;
            } else if self
                .reader
                .read_until(b'\n', &mut self.text)
                .map_err(|e| InputError::new(source, format!("cannot read: {e}")))?
                == 0
            {
                return Ok(false);
            }
            self.line_no += 1;
            let line = strip_line_end(&self.text);
            let kept = self
                .split
                .split(line, &mut self.fields)
                .map_err(|m| InputError::new(source, m).at_line(self.line_no))?;
            if kept {
                self.line = self.line_no;
                return Ok(true);
            }
        }
    }

    /// The rest of the file, for reading in blocks.
    pub(super) fn into_rest(self) -> Rest<R> {
        debug_assert!(self.pending.is_none());
        Rest {
            reader: self.reader,
            lines_read: self.line_no,
        }
    }

    pub(super) fn field_count(&self) -> usize {
        self.fields.len()
    }

    pub(super) fn field(&self, index: usize) -> Option<&[u8]> {
        self.fields.get(strip_line_end(&self.text), index)
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
/// The text is read as Rust's `str::parse::<f64>` reads it (the same
/// correctly rounded values; tested), by `fast-float2` straight from the
/// bytes.
pub(super) fn parse_number(field: &[u8], delimiter: Delimiter) -> Option<f64> {
    match fast_float2::parse::<f64, _>(field) {
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
            fast_float2::parse(&*buf).ok()
        }
        Err(_) => None,
    }
}
