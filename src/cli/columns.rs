//! Column and layout options shared by subcommands that read a time-series
//! record (the time-series contract of docs/formats.md).

use super::common::{bad, open_input};
use crate::io::timeseries::{
    ColumnRef, DEFAULT_TIME_JITTER, Delimiter, HeaderMode, IoColumns, IoData, Layout, TimeUnit,
    read_io,
};
use clap::Args;
use std::path::Path;

/// `--no-header/--header-row/--delimiter/--skip-rows/--time-unit/--time-jitter`: how a
/// record file is laid out. Everything is detected when not given.
#[derive(Debug, Clone, Args)]
pub struct LayoutArgs {
    /// The file has no header row (default: detected).
    #[arg(long)]
    pub no_header: bool,
    /// 1-based line number of the header line; the lines above it (a DAQ preamble) are skipped.
    #[arg(long, value_name = "LINE", conflicts_with = "no_header")]
    pub header_row: Option<usize>,
    /// Field separator: comma, semicolon, tab or whitespace (default: an Excel `sep=X` first line, else sniffed from the header line).
    #[arg(long, value_name = "SEP", value_parser = parse_delimiter)]
    pub delimiter: Option<Delimiter>,
    /// Rows to skip after the header, e.g. units or descriptions (default: one units row is detected).
    #[arg(long, value_name = "N")]
    pub skip_rows: Option<usize>,
    /// Unit of the time column: s, ms or us (default: from its name, `time_ms`, `t [ms]`, or a units row; else s).
    #[arg(long, value_name = "UNIT", value_parser = parse_time_unit)]
    pub time_unit: Option<TimeUnit>,
    /// Largest accepted deviation of a time step from the mean step, as a fraction of the step.
    #[arg(long, value_name = "FRACTION", default_value_t = DEFAULT_TIME_JITTER)]
    pub time_jitter: f64,
}

/// A column option's value (`--input-col 4`, `--time-col t`, `--input-col
/// data:4`): what is wrong with the value itself is refused here, so that
/// the message names the option and the value (a 0 or negative index, a
/// blank name); a column the file lacks is reported by the reader.
pub fn parse_column(text: &str) -> Result<String, String> {
    let trimmed = text.trim();
    if trimmed.is_empty() {
        return Err("expected a header name, a 1-based column index or a MAT variable".into());
    }
    if let Ok(i) = trimmed.parse::<i64>()
        && i < 1
    {
        return Err(format!("column indices are 1-based; {i} is not a column"));
    }
    Ok(text.to_owned())
}

fn parse_delimiter(text: &str) -> Result<Delimiter, String> {
    Delimiter::from_name(text).ok_or_else(|| format!("expected one of {}", Delimiter::NAMES))
}

fn parse_time_unit(text: &str) -> Result<TimeUnit, String> {
    TimeUnit::from_name(text).ok_or_else(|| format!("expected one of {}", TimeUnit::NAMES))
}

impl LayoutArgs {
    /// The reader's layout, validated.
    pub fn layout(&self) -> anyhow::Result<Layout> {
        let layout = Layout {
            header: if self.no_header {
                HeaderMode::Absent
            } else {
                HeaderMode::Detect
            },
            header_row: self.header_row,
            delimiter: self.delimiter,
            skip_rows: self.skip_rows,
            time_unit: self.time_unit,
            time_jitter: self.time_jitter,
        };
        layout.validate().map_err(|m| {
            let m = m.replacen("time jitter", "time-jitter", 1);
            bad(format!("--{}", m.replacen("header row", "header-row", 1)))
        })?;
        Ok(layout)
    }
}

/// `--input-col/--output-col/--time-col` and the layout: which columns of a
/// record file (or variables of a MAT file) hold the record.
#[derive(Debug, Clone, Args)]
pub struct ColumnArgs {
    /// Input column: header name, 1-based index or MAT variable (default `u`, or column 1 without a header).
    #[arg(long, value_name = "COL", value_parser = parse_column)]
    pub input_col: Option<String>,
    /// Output column: header name, 1-based index or MAT variable (default `y`, or column 2 without a header).
    #[arg(long, value_name = "COL", value_parser = parse_column)]
    pub output_col: Option<String>,
    /// Time column (default: found by name, `t`, `time`, `time_ms`, `t [s]`, ...).
    #[arg(long, value_name = "COL", value_parser = parse_column)]
    pub time_col: Option<String>,
    #[command(flatten)]
    pub layout: LayoutArgs,
}

impl ColumnArgs {
    /// The reader's column choice.
    pub fn columns(&self) -> anyhow::Result<IoColumns> {
        Ok(IoColumns {
            input: self.input_col.as_deref().map(ColumnRef::parse),
            output: self.output_col.as_deref().map(ColumnRef::parse),
            time: self.time_col.as_deref().map(ColumnRef::parse),
            layout: self.layout.layout()?,
        })
    }

    /// Reads an input/output record from a file.
    pub fn read(&self, path: &Path, min_rows: usize) -> anyhow::Result<IoData> {
        let columns = self.columns()?;
        Ok(read_io(
            open_input(path)?,
            &path.display().to_string(),
            &columns,
            min_rows,
        )?)
    }
}

/// [`ColumnArgs`] plus a sample range.
#[derive(Debug, Clone, Args)]
pub struct IoColumnArgs {
    #[command(flatten)]
    pub columns: ColumnArgs,
    /// First sample used (0-based row index among the data rows), e.g. where
    /// the excitation starts.
    #[arg(long, value_name = "SAMPLE", default_value_t = 0)]
    pub start: usize,
    /// One past the last sample used (default: the end of the record).
    #[arg(long, value_name = "SAMPLE")]
    pub end: Option<usize>,
}

impl IoColumnArgs {
    /// Reads the record and cuts it to `start..end`.
    pub fn read(&self, path: &Path) -> anyhow::Result<IoData> {
        let mut data = self.columns.read(path, 1)?;
        data.keep_rows(self.start, self.end).map_err(|n| {
            bad(format!(
                "{}: sample range {}..{} is empty or outside the {n} data rows",
                path.display(),
                self.start,
                self.end.unwrap_or(n)
            ))
        })?;
        Ok(data)
    }
}
