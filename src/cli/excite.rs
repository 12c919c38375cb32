//! `fts excite triangle|sine|sweep|multisine|five-leaf ... -o u.csv`: excitation
//! signals written as a `t,u` CSV (the time-series contract).

use super::common::{bad, choice, name, remark, write_atomic};
use crate::ident::excite::{self, ExciteError, SweepSpacing};
use crate::io::timeseries::{time_column, write_csv};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ExciteArgs {
    #[command(subcommand)]
    signal: Signal,
    /// Write the `t,u` CSV here (default: stdout).
    #[arg(short = 'o', long = "out", global = true, value_name = "U.csv")]
    output: Option<PathBuf>,
    /// Sample time, s.
    #[arg(long, global = true, default_value_t = 1e-4)]
    ts: f64,
}

#[derive(Debug, Subcommand)]
enum Signal {
    /// Triangle waves of several amplitudes (hysteresis identification, Li21).
    Triangle(TriangleArgs),
    /// A single sine.
    Sine(SineArgs),
    /// A sine sweep (chirp), 0-1000 Hz by default as in Li21.
    Sweep(SweepArgs),
    /// A Schroeder-phased multisine (Karagoz18), periodic.
    Multisine(MultisineArgs),
    /// The five-leaved trajectory z(t) = (50 - 10 t) sin(200 pi t) um of Li21 Eq. 13.
    FiveLeaf(FiveLeafArgs),
}

#[derive(Debug, Args)]
struct TriangleArgs {
    /// Peak amplitudes, played in order.
    #[arg(long, value_delimiter = ',', default_values_t = [10.0, 8.0, 6.0, 4.0, 2.0])]
    amplitudes: Vec<f64>,
    /// Triangle frequency, Hz.
    #[arg(long, default_value_t = 1.0)]
    freq: f64,
    /// Periods per amplitude.
    #[arg(long, default_value_t = 2)]
    cycles: usize,
    /// Constant added to every sample.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    offset: f64,
    /// Symmetric 0 -> A -> -A -> 0 instead of 0 -> A -> 0.
    #[arg(long)]
    bipolar: bool,
}

#[derive(Debug, Args)]
struct SineArgs {
    /// Peak amplitude.
    #[arg(long, default_value_t = 1.0)]
    amplitude: f64,
    /// Frequency, Hz.
    #[arg(long, default_value_t = 10.0)]
    freq: f64,
    /// Constant added.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    offset: f64,
    /// Length, s.
    #[arg(long, default_value_t = 1.0)]
    duration: f64,
}

#[derive(Debug, Args)]
struct SweepArgs {
    /// Start frequency, Hz.
    #[arg(long, default_value_t = 0.0)]
    f0: f64,
    /// End frequency, Hz.
    #[arg(long, default_value_t = 1000.0)]
    f1: f64,
    /// Length, s.
    #[arg(long, default_value_t = 1.0)]
    duration: f64,
    /// Peak amplitude.
    #[arg(long, default_value_t = 1.0)]
    amplitude: f64,
    /// Constant added.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    offset: f64,
    /// Frequency law.
    #[arg(long, value_parser = choice::<SweepSpacing>(), default_value = name(SweepSpacing::default()))]
    spacing: SweepSpacing,
}

#[derive(Debug, Args)]
struct MultisineArgs {
    /// Frequencies, Hz (rounded to multiples of 1/period).
    #[arg(long, value_delimiter = ',', required_unless_present = "lines")]
    freqs: Vec<f64>,
    /// Instead of --freqs: this many lines spread evenly from --fmin to --fmax.
    #[arg(long, conflicts_with = "freqs")]
    lines: Option<usize>,
    /// Lowest line with --lines, Hz.
    #[arg(long = "fmin", alias = "f-min", default_value_t = 10.0)]
    f_min: f64,
    /// Highest line with --lines, Hz.
    #[arg(long = "fmax", alias = "f-max", default_value_t = 1000.0)]
    f_max: f64,
    /// Period, s.
    #[arg(long, default_value_t = 0.1)]
    period: f64,
    /// Number of periods.
    #[arg(long, default_value_t = 10)]
    periods: usize,
    /// Peak of the record.
    #[arg(long, default_value_t = 1.0)]
    amplitude: f64,
    /// Constant added.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    offset: f64,
}

#[derive(Debug, Args)]
struct FiveLeafArgs {
    /// Length, s.
    #[arg(long, default_value_t = 1.0)]
    duration: f64,
    /// Factor on the published trajectory.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    scale: f64,
    /// Constant added.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    offset: f64,
}

fn to_bad(e: ExciteError) -> anyhow::Error {
    bad(format!("--{}: {}", e.field.replace('_', "-"), e.message))
}

pub fn run(args: ExciteArgs) -> anyhow::Result<()> {
    let ts = args.ts;
    let u = args.signal.samples(ts)?;
    let text = write_csv(&["t", "u"], &[&time_column(u.len(), ts), &u]);
    match &args.output {
        Some(path) => {
            write_atomic(path, text.as_bytes())?;
            remark(path, format!("{} samples, ts = {ts} s", u.len()));
        }
        None => say_part!("{text}"),
    }
    Ok(())
}

impl Signal {
    /// The signal's samples at sample time `ts`.
    fn samples(self, ts: f64) -> anyhow::Result<Vec<f64>> {
        match self {
            Signal::Triangle(a) => a.samples(ts).map_err(to_bad),
            Signal::Sine(a) => a.samples(ts).map_err(to_bad),
            Signal::Sweep(a) => a.samples(ts).map_err(to_bad),
            Signal::Multisine(a) => a.samples(ts),
            Signal::FiveLeaf(a) => a.samples(ts).map_err(to_bad),
        }
    }
}

impl TriangleArgs {
    fn samples(self, ts: f64) -> Result<Vec<f64>, ExciteError> {
        excite::triangle(&excite::TriangleParams {
            amplitudes: self.amplitudes,
            freq_hz: self.freq,
            cycles: self.cycles,
            ts,
            offset: self.offset,
            bipolar: self.bipolar,
        })
    }
}

impl SineArgs {
    fn samples(self, ts: f64) -> Result<Vec<f64>, ExciteError> {
        excite::sine(&excite::SineParams {
            amplitude: self.amplitude,
            freq_hz: self.freq,
            phase: 0.0,
            offset: self.offset,
            duration: self.duration,
            ts,
        })
    }
}

impl SweepArgs {
    fn samples(self, ts: f64) -> Result<Vec<f64>, ExciteError> {
        excite::sweep(&excite::SweepParams {
            f0: self.f0,
            f1: self.f1,
            duration: self.duration,
            amplitude: self.amplitude,
            offset: self.offset,
            ts,
            spacing: self.spacing,
        })
    }
}

impl MultisineArgs {
    /// The multisine; the lines it used (rounded to multiples of 1/period)
    /// are listed on stderr.
    fn samples(self, ts: f64) -> anyhow::Result<Vec<f64>> {
        let freqs_hz = match self.lines {
            Some(n) => multisine_lines(n, self.f_min, self.f_max, self.period, ts)?,
            None => self.freqs,
        };
        let (u, used) = excite::multisine(&excite::MultisineParams {
            freqs_hz,
            period: self.period,
            periods: self.periods,
            amplitude: self.amplitude,
            offset: self.offset,
            ts,
        })
        .map_err(to_bad)?;
        note!("multisine lines (Hz): {used:?}");
        Ok(u)
    }
}

impl FiveLeafArgs {
    fn samples(self, ts: f64) -> Result<Vec<f64>, ExciteError> {
        excite::five_leaf(&excite::FiveLeafParams {
            duration: self.duration,
            scale: self.scale,
            offset: self.offset,
            ts,
        })
    }
}

/// `--lines N` from `--fmin` to `--fmax`, checked before they are made:
/// at most the distinct lines a period holds below Nyquist.
fn multisine_lines(
    n: usize,
    f_min: f64,
    f_max: f64,
    period: f64,
    ts: f64,
) -> anyhow::Result<Vec<f64>> {
    if !(period.is_finite() && period > 0.0) {
        return Err(bad(format!(
            "--period: must be a positive number of seconds, got {period}"
        )));
    }
    let most = (period / ts / 2.0).floor();
    if n == 0 || (most.is_finite() && n as f64 > most.max(1.0)) {
        return Err(bad(format!(
            "--lines: {n} lines; a period of {period} s at ts = {ts} s holds from 1 to {most} distinct lines below Nyquist"
        )));
    }
    if n > 1 && f_min.partial_cmp(&f_max) != Some(std::cmp::Ordering::Less) {
        return Err(bad(format!(
            "--fmin/--fmax: expected fmin < fmax, got {f_min} and {f_max} Hz"
        )));
    }
    Ok(crate::lti::linspace(f_min, f_max, n))
}
