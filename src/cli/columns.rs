//! Column options shared by subcommands that read an input/output record
//! (the time-series contract of interfaces.md).

use super::common::bad;
use crate::io::timeseries::{ColumnRef, HeaderMode, IoColumns, IoData, read_io};
use clap::Args;

/// `--input/--output/--time/--no-header`: which columns of a time-series
/// file hold the record.
#[derive(Debug, Clone, Args)]
pub struct ColumnArgs {
    /// Input column: header name or 1-based index (default `u`, or column 1 without a header).
    #[arg(long, value_name = "COL")]
    pub input: Option<String>,
    /// Output column: header name or 1-based index (default `y`, or column 2 without a header).
    #[arg(long, value_name = "COL")]
    pub output: Option<String>,
    /// Time column (default `t` when the header has it); must be uniform.
    #[arg(long, value_name = "COL")]
    pub time: Option<String>,
    /// The file has no header row.
    #[arg(long)]
    pub no_header: bool,
}

impl ColumnArgs {
    /// The reader's column choice.
    pub fn columns(&self) -> IoColumns {
        IoColumns {
            input: self.input.as_deref().map(ColumnRef::parse),
            output: self.output.as_deref().map(ColumnRef::parse),
            time: self.time.as_deref().map(ColumnRef::parse),
            header: if self.no_header {
                HeaderMode::Absent
            } else {
                HeaderMode::Detect
            },
        }
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
    pub fn read(&self, text: &str, source: &str) -> anyhow::Result<IoData> {
        let mut data = read_io(text, source, &self.columns.columns(), 1)?;
        let n = data.input.len();
        let end = self.end.unwrap_or(n);
        if end > n || self.start >= end {
            return Err(bad(format!(
                "{source}: sample range {}..{end} is empty or outside the {n} data rows",
                self.start
            )));
        }
        data.input = data.input[self.start..end].to_vec();
        data.output = data.output[self.start..end].to_vec();
        Ok(data)
    }
}
