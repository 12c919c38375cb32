//! `fts bode DATA [--method auto|periodic|welch|etfe] [-o response.csv] [--plot bode.svg] [--json]`:
//! the empirical frequency response of an input/output record.

use super::common::{bad, print_report, write_atomic};
use super::identify_linear::{DataArgs, empirical_plot, prepare};
use crate::ident::freq::{
    Empirical, EmpiricalParams, EstimateKind, Estimator, FreqResponse, WelchParams,
    empirical_response,
};
use crate::ident::periodic::period_in_samples;
use crate::lti::c64;
use crate::workflow::Prepared;
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Averaged over whole periods when the input repeats, Welch otherwise.
    Auto,
    /// Averaged over whole periods of the input (`--period`, or found in the input).
    Periodic,
    /// Welch-averaged cross spectra `H1 = P_yu/P_uu` with coherence.
    Welch,
    /// Empirical transfer-function estimate `Y/U` over the whole record.
    Etfe,
}

#[derive(Debug, Args)]
pub struct BodeArgs {
    #[command(flatten)]
    data: DataArgs,
    /// Estimator.
    #[arg(long, value_enum, default_value_t = Method::Auto)]
    method: Method,
    /// Welch segment length in samples (default: the power of two of best median coherence, 64..N/2); with `auto`, uses Welch even for a repeating input.
    #[arg(long, value_name = "N", conflicts_with = "period")]
    segment: Option<usize>,
    /// Period of the input in seconds (default: found in the input when it repeats).
    #[arg(long, value_name = "S", value_parser = super::common::parse_positive)]
    period: Option<f64>,
    /// Whole periods dropped as transient before averaging.
    #[arg(long, value_name = "K", default_value_t = 1)]
    skip_periods: usize,
    /// Welch overlap fraction in [0, 1).
    #[arg(long, default_value_t = 0.5)]
    overlap: f64,
    /// Write the table (freq_hz, magnitude, magnitude_db, phase_deg, coherence, re, im) to this CSV.
    #[arg(short = 'o', long = "out", value_name = "RESPONSE.csv")]
    out: Option<PathBuf>,
    /// Draw magnitude, phase and coherence to this SVG.
    #[arg(long, value_name = "BODE.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Upper frequency of the printed table and the plot in Hz (default Nyquist).
    #[arg(long, value_name = "HZ", value_parser = super::common::parse_positive)]
    fmax: Option<f64>,
    /// Rows of the printed table.
    #[arg(long, default_value_t = 20)]
    rows: usize,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(a: BodeArgs) -> anyhow::Result<()> {
    if a.data.validate.is_some() || a.data.split.is_some() {
        return Err(bad("fts bode: --validate and --split do not apply"));
    }
    let p = prepare(&a.data)?;
    let h = estimate(&a, &p)?;
    let nyq = 0.5 / p.ts;
    let fmax = a.fmax.unwrap_or(nyq).min(nyq);
    if let Some(path) = &a.out {
        write_atomic(path, response_csv(&h.response).as_bytes())?;
    }
    if let Some(path) = &a.plot {
        empirical_plot(
            path,
            &format!("empirical response of {}", p.source),
            &h,
            fmax,
        )?;
    }
    let report = BodeReport::new(&p, &h, fmax, a.rows);
    print_report(&report, a.json)?;
    Ok(())
}

/// The empirical response of the prepared record by the chosen estimator.
fn estimate(a: &BodeArgs, p: &Prepared) -> anyhow::Result<Empirical> {
    let params = EmpiricalParams {
        estimator: match a.method {
            Method::Auto => Estimator::Auto,
            Method::Periodic => Estimator::Periodic,
            Method::Welch => Estimator::Welch,
            Method::Etfe => Estimator::Etfe,
        },
        welch: WelchParams {
            segment: a.segment,
            overlap: a.overlap,
        },
        period: a
            .period
            .map(|s| period_in_samples(s, p.ts).map_err(|m| bad(format!("--period: {m}"))))
            .transpose()?,
        skip_periods: a.skip_periods,
    };
    empirical_response(&p.est.u, &p.est.y, p.ts, &params)
        .map_err(|e| bad(format!("{}: {e}", p.source)))
}

/// The whole response as CSV: `freq_hz, magnitude, magnitude_db,
/// phase_deg, coherence, re, im`.
fn response_csv(h: &FreqResponse) -> String {
    let phase = h.phase_deg_unwrapped();
    let mut s = String::from("freq_hz,magnitude,magnitude_db,phase_deg,coherence,re,im\n");
    for (i, f) in h.freq_hz.iter().enumerate() {
        let v = h.response[i];
        if !v.re.is_finite() {
            continue; // no input power at this bin
        }
        let coherence = h.coherence.as_ref().map(|c| c[i].to_string());
        s.push_str(&format!(
            "{f},{},{},{},{},{},{}\n",
            v.norm(),
            20.0 * v.norm().log10(),
            phase[i],
            coherence.unwrap_or_default(),
            v.re,
            v.im
        ));
    }
    s
}

/// What `fts bode` reports: the estimate's resolution and its response up
/// to `fmax` (`--json`), and a table of about `rows` of those frequencies
/// (the summary).
#[derive(Debug, Serialize)]
struct BodeReport {
    method: &'static str,
    ts: f64,
    segments: usize,
    segment_len: usize,
    resolution_hz: f64,
    mean_coherence: Option<f64>,
    freq_hz: Vec<f64>,
    magnitude: Vec<f64>,
    phase_deg: Vec<f64>,
    coherence: Option<Vec<f64>>,
    /// `Welch`, `ETFE` or `Period-average`.
    #[serde(skip)]
    estimator: &'static str,
    /// `segment(s)` or `period(s)`.
    #[serde(skip)]
    unit: &'static str,
    /// The record's name.
    #[serde(skip)]
    source: String,
    /// Samples of the record.
    #[serde(skip)]
    samples: usize,
    /// The table's rows: frequency, response, phase, coherence.
    #[serde(skip)]
    rows: Vec<(f64, c64, f64, Option<f64>)>,
}

impl BodeReport {
    fn new(p: &Prepared, emp: &Empirical, fmax: f64, rows: usize) -> Self {
        let h = &emp.response;
        let phase = h.phase_deg_unwrapped();
        // Bins without input power (NaN) carry nothing to report.
        let idx: Vec<usize> = (0..h.freq_hz.len())
            .filter(|&i| h.freq_hz[i] <= fmax && h.response[i].re.is_finite())
            .collect();
        let stride = (idx.len() / rows.max(1)).max(1);
        let coherence = h
            .coherence
            .as_ref()
            .map(|c| idx.iter().map(|&i| c[i]).collect::<Vec<_>>());
        let table = idx.iter().step_by(stride).map(|&i| {
            let coherence = h.coherence.as_ref().map(|c| c[i]);
            (h.freq_hz[i], h.response[i], phase[i], coherence)
        });
        let (method, estimator, unit) = match emp.kind {
            EstimateKind::Welch { .. } => ("welch", "Welch", "segment(s)"),
            EstimateKind::Etfe => ("etfe", "ETFE", "segment(s)"),
            EstimateKind::Periodic { .. } => ("periodic", "Period-average", "period(s)"),
        };
        Self {
            method,
            ts: p.ts,
            segments: h.segments,
            segment_len: h.segment_len,
            resolution_hz: 1.0 / (h.segment_len as f64 * p.ts),
            mean_coherence: coherence
                .as_ref()
                .map(|v| v.iter().sum::<f64>() / v.len().max(1) as f64),
            freq_hz: idx.iter().map(|&i| h.freq_hz[i]).collect(),
            magnitude: idx.iter().map(|&i| h.response[i].norm()).collect(),
            phase_deg: idx.iter().map(|&i| phase[i]).collect(),
            coherence,
            estimator,
            unit,
            source: p.source.clone(),
            samples: p.est.y.len(),
            rows: table.collect(),
        }
    }
}

impl std::fmt::Display for BodeReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} estimate of {} ({} samples, Ts = {} s): {} {} of {} samples, resolution {:.4} Hz{}",
            self.estimator,
            self.source,
            self.samples,
            self.ts,
            self.segments,
            self.unit,
            self.segment_len,
            self.resolution_hz,
            self.mean_coherence
                .map(|c| format!(", mean coherence {c:.3}"))
                .unwrap_or_default()
        )?;
        writeln!(
            f,
            "  {:>12} {:>12} {:>10} {:>11} {:>9}",
            "freq (Hz)", "magnitude", "dB", "phase (deg)", "coherence"
        )?;
        for (freq, v, phase, coherence) in &self.rows {
            writeln!(
                f,
                "  {:>12.4} {:>12.6} {:>10.3} {:>11.2} {:>9}",
                freq,
                v.norm(),
                20.0 * v.norm().log10(),
                phase,
                coherence
                    .map(|c| format!("{c:.3}"))
                    .unwrap_or_else(|| "-".into())
            )?;
        }
        Ok(())
    }
}
