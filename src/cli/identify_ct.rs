//! `fts identify ct DATA --np N --nz M [--delay S] [--period S]` (SRIVC from
//! an input/output record) and `fts identify ct-frd RESPONSE.csv --np N
//! --nz M [--delay S] [--weighting uniform|log]` (from a frequency
//! response, e.g. `fts bode -o`'s CSV). The steps are the library's
//! ([`crate::workflow::identify_ct`]); this file reads the files, writes the
//! continuous `fts.tf/1` model and renders the report. An unstable or
//! unconverged model is written and reported, then exits 1.

use super::common::{bad, choice, name, print_report, read_input, step_error, write_atomic};
use super::identify_linear::DataArgs;
use crate::ident::ct::FreqData;
use crate::io::plot::{PlotFormat, bode};
use crate::io::tf_json;
use crate::lti::Bode;
use crate::lti::c64;
use crate::workflow::Validate;
use crate::workflow::identify_ct::{CtReport, IdentifyCt, IdentifyCtFrd, WeightingChoice};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct CtArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of poles.
    #[arg(long)]
    pub np: usize,
    /// Number of zeros (at most --np).
    #[arg(long)]
    pub nz: usize,
    /// Known input delay in seconds (any value, not only whole samples).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0)]
    pub delay: f64,
    /// Period of a periodic (multisine) input, s: the frequency-domain fit uses its lines (default: Welch bins of coherence >= 0.9).
    #[arg(long, value_name = "SECONDS")]
    pub period: Option<f64>,
    /// Whole periods skipped as transient before averaging (with --period).
    #[arg(long, default_value_t = IdentifyCt::default().skip_periods)]
    pub skip_periods: usize,
    /// Welch segment length in samples, without --period (default: the power of two of best median coherence, 64..N/2).
    #[arg(long, value_name = "N", conflicts_with = "period")]
    pub segment: Option<usize>,
    /// Cutoff of the start estimate's state-variable filter, Hz (default: six tried over [0.002, 0.2]/Ts, best fit kept).
    #[arg(id = "svf_cutoff_hz", long = "svf-cutoff", value_name = "HZ")]
    pub svf_cutoff: Option<f64>,
    /// SRIVC iteration cap.
    #[arg(long, default_value_t = IdentifyCt::default().max_iterations)]
    pub max_iterations: usize,
    #[command(flatten)]
    pub out: CtOut,
}

#[derive(Debug, Args)]
pub struct CtFrdArgs {
    /// Frequency response CSV with a header naming `freq_hz`, `re` and `im` (what `fts bode -o` writes).
    #[arg(value_name = "RESPONSE.csv")]
    pub response: PathBuf,
    /// Number of poles.
    #[arg(long)]
    pub np: usize,
    /// Number of zeros (at most --np).
    #[arg(long)]
    pub nz: usize,
    /// Known input delay in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0)]
    pub delay: f64,
    /// Weighting of the frequency points.
    #[arg(long, value_parser = choice::<WeightingChoice>(), default_value = name(WeightingChoice::default()))]
    pub weighting: WeightingChoice,
    /// Lowest frequency used, Hz.
    #[arg(long, value_name = "HZ")]
    pub fmin: Option<f64>,
    /// Highest frequency used, Hz.
    #[arg(long, value_name = "HZ")]
    pub fmax: Option<f64>,
    #[command(flatten)]
    pub out: CtOut,
}

#[derive(Debug, Args)]
pub struct CtOut {
    /// Write the model (`fts.tf/1`, continuous; the delay is in the report only) here.
    #[arg(short = 'o', long = "out", value_name = "PLANT.json")]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Draw the model's Bode plot over the frequency response it was fitted or compared to.
    #[arg(long, value_name = "BODE.svg|png", value_parser = super::common::plot_path)]
    pub plot: Option<PathBuf>,
}

impl CtArgs {
    /// The step these flags describe.
    pub fn step(&self) -> IdentifyCt {
        let s = self.data.settings();
        IdentifyCt {
            ts: s.ts,
            detrend: s.detrend,
            split: s.split,
            np: Some(self.np),
            nz: Some(self.nz),
            delay: self.delay,
            svf_cutoff_hz: self.svf_cutoff,
            max_iterations: self.max_iterations,
            period: self.period,
            skip_periods: self.skip_periods,
            segment: self.segment,
        }
    }
}

/// `fts identify ct`.
pub fn run(a: CtArgs) -> anyhow::Result<()> {
    let step = a.step();
    step.validate().map_err(step_error)?;
    let report = step.run(a.data.inputs()?).map_err(step_error)?;
    finish(&report, &a.out)
}

/// `fts identify ct-frd`.
pub fn run_frd(a: CtFrdArgs) -> anyhow::Result<()> {
    let step = IdentifyCtFrd {
        np: Some(a.np),
        nz: Some(a.nz),
        delay: a.delay,
        weighting: a.weighting,
        fmin: a.fmin,
        fmax: a.fmax,
    };
    step.validate().map_err(step_error)?;
    let data = read_response(&a.response)?;
    let source = a.response.display().to_string();
    let report = step.run(&data, &source).map_err(step_error)?;
    finish(&report, &a.out)
}

fn finish(r: &CtReport, out: &CtOut) -> anyhow::Result<()> {
    // The plot is drawn before anything is written: a record it cannot be
    // drawn from fails the run with no file written.
    let plot = match &out.plot {
        Some(path) => {
            let format = PlotFormat::from_path(path).map_err(|m| bad(format!("--plot: {m}")))?;
            Some((path, bode_plot(r, format)?))
        }
        None => None,
    };
    if let Some(path) = &out.out {
        let tf = r.transfer_function().map_err(step_error)?;
        write_atomic(path, tf_json::tf_to_string(&tf).as_bytes())?;
    }
    if let Some((path, image)) = &plot {
        write_atomic(path, image)?;
    }
    print_report(r, out.json)?;
    let warnings = r.warnings();
    if !warnings.is_empty() {
        anyhow::bail!("{}", warnings.join("; "));
    }
    Ok(())
}

/// Measured response and model on the data's frequencies.
fn bode_plot(r: &CtReport, format: PlotFormat) -> anyhow::Result<Vec<u8>> {
    let data = &r.freq_data;
    if data.freq_hz.len() < 2 {
        return Err(bad(format!(
            "--plot: {}: no frequency response to draw (give --period for a periodic record)",
            r.source
        )));
    }
    let lookup = |f: f64| {
        let i = data.freq_hz.iter().position(|x| *x == f).unwrap_or(0);
        data.response[i]
    };
    let measured = Bode::from_fn(&data.freq_hz, lookup);
    let model = Bode::from_fn(&data.freq_hz, |f| r.model_response_at_hz(f));
    let title = format!(
        "continuous {} model of {}",
        r.method.to_uppercase(),
        r.source
    );
    bode(
        &title,
        &[("measured", &measured), ("model", &model)],
        format,
    )
    .map_err(|e| bad(format!("--plot: {e}")))
}

/// Reads `freq_hz`, `re`, `im` columns (by header name); rows with an
/// empty or NaN value (no input power) are skipped, a bad number is an error
/// naming its line.
/// One row of a frequency-response table (docs/formats.md, `identify
/// ct-frd`): `None` for a row to skip, the DC row `fts bode -o` writes
/// (0 Hz) and a bin without an estimate (an empty or NaN `re` or `im`);
/// a frequency that is missing, not a number, negative or infinite, and an
/// infinite response, are errors naming the field.
fn response_row(
    rec: &csv::StringRecord,
    [cf, cr, ci]: [usize; 3],
    err: &dyn Fn(&str, String) -> anyhow::Error,
) -> anyhow::Result<Option<(f64, c64)>> {
    let num = |c: usize, name: &str| -> anyhow::Result<f64> {
        let field = rec.get(c).unwrap_or("");
        if field.is_empty() {
            return Ok(f64::NAN);
        }
        field
            .parse::<f64>()
            .map_err(|_| err(name, format!("not a number: {field:?}")))
    };
    let (f, re, im) = (num(cf, "freq_hz")?, num(cr, "re")?, num(ci, "im")?);
    if !(f.is_finite() && f >= 0.0) {
        let given = rec.get(cf).unwrap_or("");
        let given = if given.is_empty() {
            "an empty cell"
        } else {
            given
        };
        return Err(err(
            "freq_hz",
            format!("expected a frequency >= 0 Hz, got {given}"),
        ));
    }
    for (name, v) in [("re", re), ("im", im)] {
        if v.is_infinite() {
            return Err(err(name, format!("expected a finite response, got {v}")));
        }
    }
    if f == 0.0 || re.is_nan() || im.is_nan() {
        return Ok(None);
    }
    Ok(Some((f, c64::new(re, im))))
}

fn read_response(path: &Path) -> anyhow::Result<FreqData> {
    let text = read_input(path)?;
    let src = path.display();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header = rdr
        .headers()
        .map_err(|e| bad(format!("{src}: {e}")))?
        .clone();
    let col = |name: &str| {
        header.iter().position(|h| h == name).ok_or_else(|| {
            bad(format!(
                "{src}: no column named '{name}' in the header (expected freq_hz, re, im)"
            ))
        })
    };
    let (cf, cr, ci) = (col("freq_hz")?, col("re")?, col("im")?);
    let mut data = FreqData {
        freq_hz: Vec::new(),
        response: Vec::new(),
    };
    for rec in rdr.records() {
        let rec = rec.map_err(|e| bad(format!("{src}: {e}")))?;
        let line = rec.position().map_or(0, |p| p.line());
        if let Some((f, h)) = response_row(&rec, [cf, cr, ci], &|field, m| {
            bad(format!("{src} line {line}, field '{field}': {m}"))
        })? {
            data.freq_hz.push(f);
            data.response.push(h);
        }
    }
    if data.freq_hz.is_empty() {
        return Err(bad(format!(
            "{src}: no row with a positive frequency and a response (rows at 0 Hz or with an empty or NaN re/im are skipped)"
        )));
    }
    Ok(data)
}
