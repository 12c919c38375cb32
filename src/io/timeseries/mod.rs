//! Time-series records: the time-series contract of `docs/formats.md`.
//!
//! One row per sample, read in one streaming pass over a buffered reader:
//! memory grows with the columns kept, not with the file. Text files are
//! comma-, semicolon-, tab- or whitespace-separated; the separator is sniffed
//! from the header line (or the first data row; an Excel `sep=X` first line
//! names it) or forced with [`Layout::delimiter`]. A preamble above the
//! header is skipped with [`Layout::header_row`]. Lines are cut at the
//! separator (memchr); a line holding a quote is unquoted by `csv-core`
//! (RFC 4180: quoted separators and doubled quotes within the line; a
//! quoted field running past its line is refused), and an empty first field
//! counts (the SmartHysteresis piezo record). Whitespace files (DaISy
//! `.dat`, MATLAB `save -ascii`) are cut at runs of spaces and tabs. After
//! the first data row the file is read in blocks of whole lines, each cut
//! between the machine's cores; numbers are parsed from the bytes
//! (`fast-float2`, to the values `str::parse::<f64>` gives). Line ends are
//! `\n`, `\r\n` or a lone `\r` (classic Mac). Lines starting with `#`, blank
//! lines and lines of empty fields are skipped. A units row under the
//! header (`s,V,um`) is recognised.
//! MATLAB v5/v7 `.mat` files are recognised by their content and read by
//! variable name ([`super::mat`]).
//!
//! Columns are picked by header name or by 1-based index. A time column is
//! found by common names (`t`, `time`, `time_ms`, `t [s]`, `Time (us)`, …),
//! its unit taken from the name, the units row or [`Layout::time_unit`], and
//! converted to seconds. The sample time is the mean step; steps may deviate
//! from it by [`Layout::time_jitter`] of the step (DAQ exports print rounded
//! timestamps), and the jitter is reported in [`Timing`]. Larger deviations
//! (a gap, a glitch) and non-increasing time are refused with their line.

mod plain;
mod rows;
mod time;

use super::InputError;
pub use rows::Delimiter;
use rows::{LineMap, RowReader, parse_number};
use std::io::BufRead;
use time::time_unit;
pub use time::{DEFAULT_TIME_JITTER, TimeUnit, Timing, UnitSource, is_time_name};

/// A column, by header name or by 1-based index.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ColumnRef {
    /// The header cell (or MAT variable) with this trimmed, case-sensitive text.
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
    /// There is no header.
    Absent,
}

/// How a text record is laid out. The defaults detect everything.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Header handling (default: detect).
    pub header: HeaderMode,
    /// 1-based line number of the header line (default `None`: the first
    /// non-comment line); the lines above it (a DAQ preamble) are skipped.
    pub header_row: Option<usize>,
    /// Field separator (default `None`: sniffed from the first non-comment line).
    pub delimiter: Option<Delimiter>,
    /// Rows to skip after the header (or at the top without one); `None`
    /// detects one units row under a header.
    pub skip_rows: Option<usize>,
    /// Unit of the time column (default `None`: from its name or the units
    /// row, else seconds).
    pub time_unit: Option<TimeUnit>,
    /// Largest accepted deviation of a time step from the mean step, as a
    /// fraction of the mean step (default [`DEFAULT_TIME_JITTER`]).
    pub time_jitter: f64,
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            header: HeaderMode::Detect,
            header_row: None,
            delimiter: None,
            skip_rows: None,
            time_unit: None,
            time_jitter: DEFAULT_TIME_JITTER,
        }
    }
}

impl Layout {
    /// Checks the settings that do not depend on a file.
    pub fn validate(&self) -> Result<(), String> {
        match (self.header_row, self.header) {
            (Some(0), _) => {
                return Err("header row: line numbers are 1-based; 0 is not a line".into());
            }
            (Some(_), HeaderMode::Absent) => {
                return Err("header row: given for a file declared to have no header".into());
            }
            _ => {}
        }
        if !(self.time_jitter.is_finite() && self.time_jitter >= 0.0 && self.time_jitter < 1.0) {
            return Err(format!(
                "time jitter: expected a fraction of the step in [0, 1), got {}",
                self.time_jitter
            ));
        }
        Ok(())
    }
}

/// Which columns to read.
#[derive(Debug, Clone, Default)]
pub struct ReadParams {
    /// Data columns to return, in this order.
    pub columns: Vec<ColumnRef>,
    /// Time column, if any.
    pub time: TimeColumn,
    /// File layout.
    pub layout: Layout,
    /// Fewer data rows than this is an error.
    pub min_rows: usize,
}

/// Which column holds the time.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum TimeColumn {
    /// No time column is read.
    #[default]
    None,
    /// The first header cell with a common time name (`t`, `time`, `time_ms`,
    /// `t [s]`, …), if there is one.
    Find,
    /// This column; it must exist.
    Given(ColumnRef),
}

/// The columns that were read.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Data columns in the order requested.
    pub columns: Vec<Vec<f64>>,
    /// Display names of the columns (header text or `column N`).
    pub names: Vec<String>,
    /// Units of the columns, from a units row.
    pub units: Vec<Option<String>>,
    /// The time column in seconds, if one was read.
    pub time: Option<Vec<f64>>,
    /// Sample time and jitter of the time column.
    pub timing: Option<Timing>,
    /// Number of data rows.
    pub rows: usize,
    /// Whether a header row was found.
    pub had_header: bool,
    /// The separator used (`None` for a MAT file).
    pub delimiter: Option<Delimiter>,
}

impl Table {
    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.rows
    }

    /// Whether there are no data rows.
    pub fn is_empty(&self) -> bool {
        self.rows == 0
    }

    /// Sample time in seconds from the time column, if one was read.
    pub fn ts(&self) -> Option<f64> {
        self.timing.as_ref().map(|t| t.ts)
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
    /// Sample time and jitter of the time column, if any.
    pub timing: Option<Timing>,
    /// Display names of the input and output columns.
    pub input_name: String,
    /// Display name of the output column.
    pub output_name: String,
}

impl IoData {
    /// Keeps the rows `start..end` (0-based, `end` exclusive, default the
    /// end of the record). An empty or out-of-range request changes nothing
    /// and returns the number of rows, for the caller's message.
    pub fn keep_rows(&mut self, start: usize, end: Option<usize>) -> Result<(), usize> {
        let n = self.input.len();
        let end = end.unwrap_or(n);
        if end > n || start >= end {
            return Err(n);
        }
        for column in [&mut self.input, &mut self.output] {
            column.truncate(end);
            column.drain(..start);
        }
        Ok(())
    }
}

/// Column choice for an input/output record. Defaults: `u`, `y`, and a
/// time column found by its name. A headerless file without explicit
/// columns reads column 1 as input and column 2 as output (the DaISy
/// convention).
#[derive(Debug, Clone, Default)]
pub struct IoColumns {
    /// Input column; `None` means the default.
    pub input: Option<ColumnRef>,
    /// Output column; `None` means the default.
    pub output: Option<ColumnRef>,
    /// Time column; `None` looks for one by name.
    pub time: Option<ColumnRef>,
    /// File layout.
    pub layout: Layout,
}

fn resolve(
    col: &ColumnRef,
    header: Option<&[String]>,
    source: &str,
    header_line: Option<usize>,
) -> Result<(usize, String), InputError> {
    match col {
        ColumnRef::Index(0) => Err(InputError::new(
            source,
            "column indices are 1-based; 0 is not a column",
        )),
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
            Some(h) => h.iter().position(|c| c == name).map(|i| (i, name.clone())).ok_or_else(|| {
                let have: Vec<&str> = h.iter().map(String::as_str).filter(|s| !s.is_empty()).collect();
                let mut e = InputError::new(
                    source,
                    format!("missing column '{name}' (the header has: {})", have.join(", ")),
                )
                .in_field(name.clone());
                e.line = header_line;
                e
            }),
        },
    }
}

struct Cell<'a> {
    source: &'a str,
    line: usize,
    name: &'a str,
}

impl Cell<'_> {
    fn err(&self, msg: String) -> InputError {
        InputError::new(self.source, msg)
            .at_line(self.line)
            .in_field(self.name)
    }

    fn parse(
        &self,
        field: Option<&[u8]>,
        index: usize,
        count: usize,
        d: Delimiter,
    ) -> Result<f64, InputError> {
        let Some(cell) = field else {
            return Err(self.err(format!(
                "missing field: the line has {count} fields, column {} was expected",
                index + 1
            )));
        };
        if cell.is_empty() {
            return Err(self.err("empty cell".to_owned()));
        }
        let value = parse_number(cell, d).ok_or_else(|| {
            self.err(format!("not a number: {:?}", String::from_utf8_lossy(cell)))
        })?;
        if !value.is_finite() {
            return Err(self.err(format!(
                "value must be finite, found {}",
                String::from_utf8_lossy(cell)
            )));
        }
        Ok(value)
    }
}

/// The header row and the units row, as found.
struct Head {
    header: Option<Vec<String>>,
    header_line: Option<usize>,
    units: Option<Vec<String>>,
}

/// Reads the header, units and skipped rows; leaves the reader on the first
/// data row (`Ok(false)` when there is none).
fn read_head<R: BufRead>(
    rows: &mut RowReader<'_, R>,
    layout: &Layout,
) -> Result<(Head, bool), InputError> {
    let mut have = rows.next()?;
    let had_header = have
        && match layout.header {
            _ if layout.header_row.is_some() => true,
            HeaderMode::Present => true,
            HeaderMode::Absent => false,
            HeaderMode::Detect => !rows.is_numeric_row(),
        };
    let mut head = Head {
        header: None,
        header_line: None,
        units: None,
    };
    if had_header {
        head.header = Some(rows.fields_text());
        head.header_line = Some(rows.line);
        have = rows.next()?;
    }
    match layout.skip_rows {
        Some(n) => {
            for k in 0..n {
                if !have {
                    break;
                }
                if k == 0 && had_header && !rows.is_numeric_row() {
                    head.units = Some(rows.fields_text());
                }
                have = rows.next()?;
            }
        }
        None => {
            if have && had_header && !rows.is_numeric_row() {
                head.units = Some(rows.fields_text());
                have = rows.next()?;
            }
        }
    }
    Ok((head, have))
}

/// Reads the requested columns of a time-series record (text or MAT file).
pub fn read_table<R: BufRead>(
    reader: R,
    source: &str,
    params: &ReadParams,
) -> Result<Table, InputError> {
    read_table_with(
        reader,
        source,
        &params.layout,
        params.min_rows,
        &params.time,
        |_| params.columns.clone(),
    )
}

/// [`read_table`] with the data columns chosen once it is known whether the
/// file has a header (`pick(had_header)`).
fn read_table_with<R: BufRead>(
    mut reader: R,
    source: &str,
    layout: &Layout,
    min_rows: usize,
    time: &TimeColumn,
    pick: impl FnOnce(bool) -> Vec<ColumnRef>,
) -> Result<Table, InputError> {
    layout.validate().map_err(|m| InputError::new(source, m))?;
    let peek = reader
        .fill_buf()
        .map_err(|e| InputError::new(source, format!("cannot read: {e}")))?;
    if super::mat::is_mat(peek) {
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .map_err(|e| InputError::new(source, format!("cannot read: {e}")))?;
        return read_mat_table(&bytes, source, layout, min_rows, time, pick(true));
    }
    if let Some(reason) = super::mat::binary_reason(peek) {
        return Err(InputError::new(source, reason));
    }
    let Some(mut rows) = RowReader::open(reader, source, layout.delimiter, layout.header_row)?
    else {
        return Err(InputError::new(
            source,
            "no data rows (the file is empty or all comments)",
        ));
    };
    let (head, have) = read_head(&mut rows, layout)?;
    let plan = TextPlan::new(&head, layout, time, pick, source)?;
    let delimiter = rows.delimiter;
    let Samples {
        columns,
        time: t,
        lines,
    } = read_rows(rows, have, &plan, source)?;
    if lines.rows < min_rows {
        return Err(InputError::new(
            source,
            format!(
                "too few data rows: {} found, at least {min_rows} needed",
                lines.rows
            ),
        ));
    }
    let timing = match (&t, plan.time) {
        (Some(t), Some(tc)) if t.len() >= 2 => Some(
            Timing::measure(t, tc.name.clone(), tc.unit, layout.time_jitter).map_err(
                |(row, m)| {
                    InputError::new(source, m)
                        .at_line(lines.line(row))
                        .in_field(tc.name)
                },
            )?,
        ),
        _ => None,
    };
    Ok(Table {
        names: plan.columns.into_iter().map(|(_, n)| n).collect(),
        units: plan.units,
        columns,
        time: t,
        timing,
        rows: lines.rows,
        had_header: head.header.is_some(),
        delimiter: Some(delimiter),
    })
}

/// The time column of a text file: position, name and unit.
struct TimeSpec {
    index: usize,
    name: String,
    unit: (TimeUnit, UnitSource),
}

/// Where the requested columns sit in a text file, and their units.
struct TextPlan {
    columns: Vec<(usize, String)>,
    units: Vec<Option<String>>,
    time: Option<TimeSpec>,
}

impl TextPlan {
    fn new(
        head: &Head,
        layout: &Layout,
        time: &TimeColumn,
        pick: impl FnOnce(bool) -> Vec<ColumnRef>,
        source: &str,
    ) -> Result<Self, InputError> {
        let header = head.header.as_deref();
        let find = |c: &ColumnRef| resolve(c, header, source, head.header_line);
        let columns = pick(header.is_some())
            .iter()
            .map(find)
            .collect::<Result<Vec<_>, _>>()?;
        let time_col = match time {
            TimeColumn::None => None,
            TimeColumn::Given(c) => Some(find(c)?),
            TimeColumn::Find => header.and_then(|h| {
                let i = h.iter().position(|n| is_time_name(n))?;
                Some((i, h[i].clone()))
            }),
        };
        let unit_of = |i: usize| {
            let units = head.units.as_ref()?;
            units.get(i).filter(|u| !u.is_empty()).cloned()
        };
        let time = match time_col {
            Some((index, name)) => Some(TimeSpec {
                unit: time_unit(layout, &name, unit_of(index).as_deref(), source)?,
                index,
                name,
            }),
            None => None,
        };
        Ok(Self {
            units: columns.iter().map(|(i, _)| unit_of(*i)).collect(),
            columns,
            time,
        })
    }
}

impl TextPlan {
    /// The 0-based fields read from each row: the columns in order, then
    /// the time column if there is one.
    fn fields(&self) -> Vec<usize> {
        let columns = self.columns.iter().map(|(index, _)| *index);
        columns.chain(self.time.as_ref().map(|t| t.index)).collect()
    }
}

/// The parsed rows of a text file (or of a block of it).
struct Samples {
    columns: Vec<Vec<f64>>,
    /// The time column in seconds.
    time: Option<Vec<f64>>,
    lines: LineMap,
}

impl Samples {
    fn new(plan: &TextPlan) -> Self {
        Self {
            columns: vec![Vec::new(); plan.columns.len()],
            time: plan.time.as_ref().map(|_| Vec::new()),
            lines: LineMap::default(),
        }
    }

    /// Room for `rows` more rows.
    fn reserve(&mut self, rows: usize) {
        for column in self.columns.iter_mut().chain(self.time.as_mut()) {
            column.reserve(rows);
        }
    }

    /// Appends the rows of `part`, whose line numbers start `line_offset`
    /// lines later than it says.
    /// `part` comes back emptied, its memory kept.
    fn append(&mut self, mut part: Samples, line_offset: usize) -> Samples {
        for (all, more) in self.columns.iter_mut().zip(&mut part.columns) {
            all.extend_from_slice(more);
            more.clear();
        }
        if let (Some(all), Some(more)) = (self.time.as_mut(), part.time.as_mut()) {
            all.extend_from_slice(more);
            more.clear();
        }
        self.lines
            .append(std::mem::take(&mut part.lines), line_offset);
        part
    }

    /// Parses the planned fields of the row on `line`.
    fn push<'f>(
        &mut self,
        plan: &TextPlan,
        source: &str,
        line: usize,
        (count, delimiter): (usize, Delimiter),
        field: impl Fn(usize) -> Option<&'f [u8]>,
    ) -> Result<(), InputError> {
        let value = |index: usize, name: &str| {
            let cell = Cell { source, line, name };
            cell.parse(field(index), index, count, delimiter)
        };
        for ((index, name), column) in plan.columns.iter().zip(self.columns.iter_mut()) {
            column.push(value(*index, name)?);
        }
        if let (Some(tc), Some(t)) = (&plan.time, self.time.as_mut()) {
            t.push(value(tc.index, &tc.name)? * tc.unit.0.seconds());
        }
        self.lines.push(line);
        Ok(())
    }

    /// Appends a row of values read by the fast path, in the slots of
    /// [`TextPlan::fields`].
    fn push_values(&mut self, plan: &TextPlan, values: &[f64], line: usize) {
        for (column, &value) in self.columns.iter_mut().zip(values) {
            column.push(value);
        }
        if let (Some(tc), Some(t)) = (&plan.time, self.time.as_mut()) {
            t.push(values[self.columns.len()] * tc.unit.0.seconds());
        }
        self.lines.push(line);
    }
}

/// Parses the planned columns of every row from the current one on: the
/// current row as `rows` holds it, the rest of the file in blocks.
fn read_rows<R: BufRead>(
    rows: RowReader<'_, R>,
    have: bool,
    plan: &TextPlan,
    source: &str,
) -> Result<Samples, InputError> {
    let mut samples = Samples::new(plan);
    if !have {
        return Ok(samples);
    }
    let shape = (rows.field_count(), rows.delimiter);
    samples.push(plan, source, rows.line, shape, |i| rows.field(i))?;
    let delimiter = rows.delimiter;
    let rest = rows.into_rest();
    let mut blocks = Blocks {
        parser: LineParser {
            plan,
            source,
            delimiter,
        },
        reader: rest.reader,
        lines_read: rest.lines_read,
        workers: std::thread::available_parallelism().map_or(1, |n| n.get().min(8)),
    };
    blocks.read_into(&mut samples)?;
    Ok(samples)
}

/// Bytes read at a time; a block's whole lines are cut between threads.
const BLOCK_BYTES: usize = 1 << 23;
/// Blocks smaller than this are parsed on the calling thread.
const PARALLEL_BYTES: usize = 1 << 18;
/// The longest line read (a file without line ends is refused, not held).
const MAX_LINE_BYTES: usize = 1 << 26;

/// The rows after the first data row, read in blocks of whole lines.
struct Blocks<'a, R> {
    parser: LineParser<'a>,
    reader: rows::Input<R>,
    /// Lines before the first one in the blocks.
    lines_read: usize,
    workers: usize,
}

/// What parsing a line needs (shared by the threads of a block).
struct LineParser<'a> {
    plan: &'a TextPlan,
    source: &'a str,
    delimiter: Delimiter,
}

/// A block of the file in a buffer: whole lines up to `whole`, then the
/// start of a line that the next block finishes, up to `filled`.
struct Block {
    whole: usize,
    filled: usize,
    eof: bool,
}

impl<R: BufRead> Blocks<'_, R> {
    /// Reads the file block by block. Each block is cut into pieces of
    /// whole lines that the threads take in turn; this thread first reads
    /// the next block into the other buffer and appends the rows of the
    /// block before, then takes pieces too (so no core waits on another's
    /// share).
    fn read_into(&mut self, samples: &mut Samples) -> Result<(), InputError> {
        let Self {
            parser,
            reader,
            lines_read,
            workers,
        } = self;
        let (parser, workers) = (&*parser, *workers);
        let mut bufs = [vec![0u8; BLOCK_BYTES], vec![0u8; BLOCK_BYTES]];
        let mut next_line = *lines_read + 1;
        let first = next_line;
        let mut block = read_block(reader, &mut bufs[0], 0, parser.source, &|| first)?;
        // Parsed pieces not yet appended, with the file line of their first;
        // appended pieces, emptied, keep their memory for later pieces.
        let mut pending: Vec<(Samples, usize)> = Vec::new();
        let spent = std::sync::Mutex::new(Vec::new());
        for turn in 0.. {
            let [a, b] = &mut bufs;
            let (buf, spare) = if turn % 2 == 0 { (a, b) } else { (b, a) };
            let text = &buf[..block.whole];
            let queue = PieceQueue::new(cut_at_lines(text, workers * 4, PARALLEL_BYTES));
            let helpers = workers.min(queue.pieces.len()).saturating_sub(1);
            let (parsed, next) = std::thread::scope(|scope| {
                let (queue, spent) = (&queue, &spent);
                let handles: Vec<_> = (0..helpers)
                    .map(|_| scope.spawn(move || queue.parse(parser, spent)))
                    .collect();
                let next = (!block.eof).then(|| {
                    // A long line may have grown `buf` past `spare`.
                    let carry = block.filled - block.whole;
                    if spare.len() < carry {
                        spare.resize(carry, 0);
                    }
                    spare[..carry].copy_from_slice(&buf[block.whole..block.filled]);
                    let line = || next_line + count_lines(text);
                    read_block(reader, spare, carry, parser.source, &line)
                });
                for (part, line) in pending.drain(..) {
                    let part = samples.append(part, line);
                    spent.lock().unwrap_or_else(|p| p.into_inner()).push(part);
                }
                let mut parsed = queue.parse(parser, spent);
                for h in handles {
                    parsed.extend(h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)));
                }
                parsed.sort_unstable_by_key(|(index, _)| *index);
                (parsed, next)
            });
            for (_, piece) in parsed {
                let (part, lines) = piece.map_err(|mut e| {
                    e.line = e.line.map(|l| l + next_line);
                    e
                })?;
                pending.push((part, next_line));
                next_line += lines;
            }
            match next {
                Some(next) => block = next?,
                None => break,
            }
        }
        for (part, line) in pending {
            samples.append(part, line);
        }
        Ok(())
    }
}

/// The pieces of a block, taken by the threads one at a time.
struct PieceQueue<'t> {
    pieces: Vec<&'t [u8]>,
    taken: std::sync::atomic::AtomicUsize,
}

/// A parsed piece: its rows and its number of lines, or why it failed.
type Parsed = Result<(Samples, usize), InputError>;

impl<'t> PieceQueue<'t> {
    fn new(pieces: Vec<&'t [u8]>) -> Self {
        Self {
            pieces,
            taken: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// Parses pieces until none is left: each with its index. The rows go
    /// into emptied `spent` pieces where there are any.
    fn parse(
        &self,
        parser: &LineParser<'_>,
        spent: &std::sync::Mutex<Vec<Samples>>,
    ) -> Vec<(usize, Parsed)> {
        let mut parsed = Vec::new();
        loop {
            let index = self
                .taken
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let Some(piece) = self.pieces.get(index) else {
                return parsed;
            };
            let out = spent.lock().unwrap_or_else(|p| p.into_inner()).pop();
            let out = out.unwrap_or_else(|| Samples::new(parser.plan));
            parsed.push((index, parser.parse_piece(piece, out)));
        }
    }
}

/// Reads into `buf` after the `carried` bytes already at its front until
/// it is full or the input ends; grows `buf` only for a line longer than
/// it. `first_line` finds the line the block starts with (for the message).
fn read_block<R: BufRead>(
    reader: &mut rows::Input<R>,
    buf: &mut Vec<u8>,
    carried: usize,
    source: &str,
    first_line: &dyn Fn() -> usize,
) -> Result<Block, InputError> {
    let mut filled = carried;
    loop {
        if filled == buf.len() {
            if filled > MAX_LINE_BYTES {
                return Err(InputError::new(
                    source,
                    format!(
                        "line {} is longer than {MAX_LINE_BYTES} bytes",
                        first_line()
                    ),
                ));
            }
            buf.resize(filled + BLOCK_BYTES, 0);
        }
        let eof = loop {
            match std::io::Read::read(reader, &mut buf[filled..]) {
                Ok(0) => break true,
                Ok(n) => filled += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(InputError::new(source, format!("cannot read: {e}"))),
            }
            if filled == buf.len() {
                break false;
            }
        };
        let whole = match memchr::memrchr(b'\n', &buf[..filled]) {
            _ if eof => filled,
            Some(i) => i + 1,
            None => continue,
        };
        return Ok(Block { whole, filled, eof });
    }
}

impl LineParser<'_> {
    /// Parses the lines of `piece`, numbered from 0; the rows and the
    /// number of lines.
    fn parse_piece(&self, piece: &[u8], mut out: Samples) -> Result<(Samples, usize), InputError> {
        out.reserve(estimate_lines(piece));
        let lines = self.parse_lines(piece, &mut out)?;
        Ok((out, lines))
    }

    /// Parses the lines of `text` one by one into `out`, numbering them
    /// from 0; the number of lines.
    fn parse_lines(&self, text: &[u8], out: &mut Samples) -> Result<usize, InputError> {
        // A splitter of its own: a clone of csv-core's reader does not
        // unquote (csv-core 0.1.13), so each piece builds one.
        let mut split = rows::Split::new(self.delimiter);
        let mut fields = rows::Fields::default();
        let plain = plain::PlainLine::new(self.delimiter, &self.plan.fields());
        let mut values = vec![0.0; self.plan.columns.len() + 1];
        let mut start = 0;
        let mut line = 0;
        while start < text.len() {
            let fast = plain
                .as_ref()
                .and_then(|p| p.parse(&text[start..], &mut values));
            if let Some(len) = fast {
                out.push_values(self.plan, &values, line);
                start += len;
                line += 1;
                continue;
            }
            let end = memchr::memchr(b'\n', &text[start..]).map_or(text.len(), |i| start + i + 1);
            let row = rows::strip_line_end(&text[start..end]);
            let kept = split
                .split(row, &mut fields)
                .map_err(|m| InputError::new(self.source, m).at_line(line))?;
            if kept {
                let shape = (fields.len(), self.delimiter);
                out.push(self.plan, self.source, line, shape, |i| fields.get(row, i))?;
            }
            start = end;
            line += 1;
        }
        Ok(line)
    }
}

/// About the number of lines in `text` (a few more), from the lines in
/// its first 64 KiB: the vectors of a piece are sized once.
fn estimate_lines(text: &[u8]) -> usize {
    let sample = &text[..text.len().min(1 << 16)];
    let lines = count_lines(sample).max(1);
    (text.len() / sample.len().max(1) + 1) * lines * 21 / 20 + 16
}

/// Lines in `text`: its line ends, and one more for a last line without one.
fn count_lines(text: &[u8]) -> usize {
    memchr::memchr_iter(b'\n', text).count()
        + usize::from(!text.ends_with(b"\n") && !text.is_empty())
}

/// `text` cut into at most `parts` pieces of whole lines, none smaller
/// than `min_bytes` (so a small text is one piece).
fn cut_at_lines(text: &[u8], parts: usize, min_bytes: usize) -> Vec<&[u8]> {
    let parts = parts.clamp(1, (text.len() / min_bytes).max(1));
    let mut pieces = Vec::with_capacity(parts);
    let mut start = 0;
    for k in 1..parts {
        let target = (text.len() * k / parts).max(start);
        let Some(end) = memchr::memchr(b'\n', &text[target..]).map(|i| target + i + 1) else {
            break;
        };
        pieces.push(&text[start..end]);
        start = end;
    }
    if start < text.len() || pieces.is_empty() {
        pieces.push(&text[start..]);
    }
    pieces
}

/// The MAT-file counterpart of the text path: variables by name.
fn read_mat_table(
    bytes: &[u8],
    source: &str,
    layout: &Layout,
    min_rows: usize,
    time: &TimeColumn,
    columns: Vec<ColumnRef>,
) -> Result<Table, InputError> {
    use super::mat::{MatColumn, read_columns, variables};
    let by_name = |c: &ColumnRef| match c {
        ColumnRef::Name(n) => Ok(MatColumn::parse(n)),
        ColumnRef::Index(i) => Err(InputError::new(
            source,
            format!("a MAT file's variables are chosen by name, not by index {i}"),
        )),
    };
    let time_name = match time {
        TimeColumn::None => None,
        TimeColumn::Given(c) => Some(by_name(c).map(|_| c.to_string())?),
        TimeColumn::Find => variables(bytes, source)?
            .into_iter()
            .map(|v| v.name)
            .find(|n| is_time_name(n)),
    };
    let mut wanted = columns.iter().map(by_name).collect::<Result<Vec<_>, _>>()?;
    if let Some(name) = &time_name {
        wanted.push(MatColumn::parse(name));
    }
    let mut values = read_columns(bytes, source, &wanted)?;
    let t = time_name.as_ref().map(|_| values.pop().unwrap_or_default());
    let rows = values.first().or(t.as_ref()).map_or(0, Vec::len);
    if rows < min_rows {
        return Err(InputError::new(
            source,
            format!("too few samples: {rows} found, at least {min_rows} needed"),
        ));
    }
    let (t, timing) = match (t, time_name) {
        (Some(mut t), Some(name)) => {
            let unit = time_unit(layout, &name, None, source)?;
            for v in &mut t {
                *v *= unit.0.seconds();
            }
            let timing =
                Timing::measure(&t, name.clone(), unit, layout.time_jitter).map_err(|(k, m)| {
                    InputError::new(source, format!("sample {}: {m}", k + 1)).in_field(name)
                })?;
            (Some(t), Some(timing))
        }
        _ => (None, None),
    };
    Ok(Table {
        names: columns.iter().map(ToString::to_string).collect(),
        units: vec![None; columns.len()],
        columns: values,
        time: t,
        timing,
        rows,
        had_header: true,
        delimiter: None,
    })
}

/// Reads an input/output record: columns `u` and `y` (or 1 and 2 without a
/// header) unless chosen, and a time column found by name unless chosen.
pub fn read_io<R: BufRead>(
    reader: R,
    source: &str,
    cols: &IoColumns,
    min_rows: usize,
) -> Result<IoData, InputError> {
    let time = match &cols.time {
        Some(c) => TimeColumn::Given(c.clone()),
        None => TimeColumn::Find,
    };
    let pick = |had_header: bool| {
        let (default_in, default_out) = if had_header {
            (ColumnRef::Name("u".into()), ColumnRef::Name("y".into()))
        } else {
            (ColumnRef::Index(1), ColumnRef::Index(2))
        };
        vec![
            cols.input.clone().unwrap_or(default_in),
            cols.output.clone().unwrap_or(default_out),
        ]
    };
    let mut table = read_table_with(reader, source, &cols.layout, min_rows, &time, pick)?;
    let output = table.columns.pop().unwrap_or_default();
    let input = table.columns.pop().unwrap_or_default();
    let output_name = table.names.pop().unwrap_or_default();
    let input_name = table.names.pop().unwrap_or_default();
    Ok(IoData {
        input,
        output,
        ts: table.ts(),
        timing: table.timing,
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

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks;
