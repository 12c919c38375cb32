//! `fts identify arx|oe|iv|arx-struct DATA ...`: linear models from
//! input/output records (docs/math.md §2). The steps, with the record
//! preparation and the diagnostics, are the library's
//! ([`crate::workflow::identify`]); this file turns flags into them, reads
//! the records and renders the reports and plots.
//!
//! Column options (`--input-col`, `--output-col`, `--time-col`, the layout
//! options) are shared with every record-reading command (`columns.rs`); the
//! result file is `-o/--out FILE`.

use super::columns::ColumnArgs;
use super::common::{bad, choice, name, print_report, step_error, write_atomic, write_plot};
use crate::ident::data::Detrend;
use crate::ident::freq::{
    Empirical, EmpiricalParams, EstimateKind, FreqResponse, WelchParams, empirical_response,
};
use crate::ident::periodic::period_in_samples;
use crate::io::plot::{PlotFormat, Series, stacked_charts};
use crate::io::tf_json;
use crate::lti::Bode;
use crate::workflow::identify::{
    ArxStruct, IdentifyArx, IdentifyIv, IdentifyOe, InitialChoice, LinearInputs, LinearProgress,
    LinearReport, OeStartChoice, Prepared, RecordSettings, SelectionRuleChoice,
};
use crate::workflow::{StepError, Validate};
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};

#[derive(Debug, Subcommand)]
pub enum IdentifyLinear {
    /// ARX model `A y = B u(k-nk) + e` by QR least squares.
    Arx(ArxArgs),
    /// Output-error model `y = B/F u(k-nk) + e` by Levenberg-Marquardt (unbiased under measurement noise).
    Oe(OeArgs),
    /// Instrumental-variable estimate of `B/A` (refined IV; unbiased under measurement noise).
    Iv(IvArgs),
    /// ARX structure selection over ranges of na, nb, nk (AIC, FPE, MDL, validation loss) and delay estimate.
    ArxStruct(StructArgs),
}

/// Data options shared by every linear identification command.
#[derive(Debug, Args)]
pub struct DataArgs {
    /// Input/output record (CSV or whitespace-separated, e.g. DaISy .dat).
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    #[command(flatten)]
    pub columns: ColumnArgs,
    /// Sample time in seconds (required when the file has no time column).
    #[arg(long, value_name = "SECONDS")]
    pub ts: Option<f64>,
    /// Remove a trend from each data set (estimation and validation separately, as MATLAB's example does).
    #[arg(long, value_parser = choice::<Detrend>(), default_value = name(Detrend::default()))]
    pub detrend: Detrend,
    /// Validation record (same columns).
    #[arg(long, value_name = "OTHER.csv", conflicts_with = "split")]
    pub validate: Option<PathBuf>,
    /// Use the first FRACTION of the record for estimation, the rest for validation.
    #[arg(long, value_name = "FRACTION")]
    pub split: Option<f64>,
}

impl DataArgs {
    /// The record preparation settings.
    pub(crate) fn settings(&self) -> RecordSettings {
        RecordSettings {
            ts: self.ts,
            detrend: self.detrend,
            split: self.split,
        }
    }

    /// Reads the record and the validation record.
    pub(crate) fn inputs(&self) -> anyhow::Result<LinearInputs> {
        let validation = match &self.validate {
            Some(path) => Some((self.columns.read(path, 2)?, path.display().to_string())),
            None => None,
        };
        Ok(LinearInputs {
            data: self.columns.read(&self.data, 2)?,
            source: self.data.display().to_string(),
            validation,
        })
    }
}

/// Reads, splits and detrends the data as the options say.
pub fn prepare(d: &DataArgs) -> anyhow::Result<Prepared> {
    d.settings().prepare(d.inputs()?).map_err(step_error)
}

/// Output options shared by the model-producing commands.
#[derive(Debug, Args)]
pub struct OutArgs {
    /// Write the model (`fts.tf/1`) here.
    #[arg(short = 'o', long = "out", value_name = "PLANT.json")]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Draw the model's Bode plot against the empirical estimate with coherence (averaged over whole periods when the input repeats, Welch otherwise).
    #[arg(long, value_name = "BODE.svg|png", value_parser = super::common::plot_path)]
    pub plot: Option<PathBuf>,
    /// Upper frequency of the plot in Hz (default Nyquist).
    #[arg(long = "fmax", alias = "plot-fmax", value_name = "HZ", value_parser = super::common::parse_positive)]
    pub plot_fmax: Option<f64>,
    /// Welch segment length of the plot's empirical estimate, in samples (default: the power of two of best median coherence, 64..N/2); uses Welch even for a repeating input.
    #[arg(long, value_name = "N", requires = "plot", conflicts_with = "period")]
    pub segment: Option<usize>,
    /// Period of the input in seconds for the plot's period-synchronous average (default: found in the input when it repeats).
    #[arg(long, value_name = "S", requires = "plot", value_parser = super::common::parse_positive)]
    pub period: Option<f64>,
    /// Whole periods dropped as transient before averaging.
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub skip_periods: usize,
    /// Draw measured vs simulated output (MATLAB `compare`) and the error, on the validation data when given.
    #[arg(long, value_name = "COMPARE.svg|png", value_parser = super::common::plot_path)]
    pub plot_compare: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct ArxArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of poles (A coefficients after the leading 1).
    #[arg(long, required_unless_present = "auto")]
    pub na: Option<usize>,
    /// Number of B coefficients.
    #[arg(long, required_unless_present = "auto")]
    pub nb: Option<usize>,
    /// Input delay in samples.
    #[arg(long, required_unless_present = "auto")]
    pub nk: Option<usize>,
    /// Choose na, nb, nk by structure selection (grid 1..10 x 1..10 x 0..10; validation loss when validation data exist, otherwise MDL).
    #[arg(long)]
    pub auto: bool,
    /// Selection rule for --auto.
    #[arg(long, value_parser = choice::<SelectionRuleChoice>(), default_value = name(SelectionRuleChoice::default()), requires = "auto")]
    pub rule: SelectionRuleChoice,
    /// Also fit an output-error model of the same orders and keep it when it simulates the estimation data better (as `fts demo` does).
    #[arg(long)]
    pub refine_oe: bool,
    #[command(flatten)]
    pub out: OutArgs,
}

#[derive(Debug, Args)]
pub struct OeArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of B coefficients.
    #[arg(long)]
    pub nb: usize,
    /// Number of F coefficients after the leading 1 (poles).
    #[arg(long, visible_alias = "na")]
    pub nf: usize,
    /// Input delay in samples.
    #[arg(long)]
    pub nk: usize,
    /// Start estimate of the iteration (manifest key `start_estimate`).
    #[arg(long, visible_alias = "start", value_parser = choice::<OeStartChoice>(), default_value = name(IdentifyOe::default().start_estimate))]
    pub start_estimate: OeStartChoice,
    /// Initial conditions of the simulation: estimated with the model (MATLAB default) or zero.
    #[arg(long, value_parser = choice::<InitialChoice>(), default_value = name(IdentifyOe::default().initial))]
    pub initial: InitialChoice,
    /// Maximum Levenberg-Marquardt iterations.
    #[arg(long, alias = "max-iter", default_value_t = IdentifyOe::default().max_iterations)]
    pub max_iterations: usize,
    #[command(flatten)]
    pub out: OutArgs,
}

#[derive(Debug, Args)]
pub struct IvArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of poles.
    #[arg(long)]
    pub na: usize,
    /// Number of B coefficients.
    #[arg(long)]
    pub nb: usize,
    /// Input delay in samples.
    #[arg(long)]
    pub nk: usize,
    #[command(flatten)]
    pub out: OutArgs,
}

#[derive(Debug, Args)]
pub struct StructArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Range of na: `LO:HI`, a list `1,2,4`, or one value.
    #[arg(long, default_value_t = ArxStruct::default().na)]
    pub na: String,
    /// Range of nb.
    #[arg(long, default_value_t = ArxStruct::default().nb)]
    pub nb: String,
    /// Range of nk.
    #[arg(long, default_value_t = ArxStruct::default().nk)]
    pub nk: String,
    /// Rows of the table to print (best first by the rule).
    #[arg(long, default_value_t = ArxStruct::default().top)]
    pub top: usize,
    /// Which structure to recommend (and write with -o).
    #[arg(long, value_parser = choice::<SelectionRuleChoice>(), default_value = name(SelectionRuleChoice::default()))]
    pub rule: SelectionRuleChoice,
    /// Write the recommended model (`fts.tf/1`) here.
    #[arg(short = 'o', long = "out", value_name = "PLANT.json")]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
}

impl ArxArgs {
    /// The step these flags describe.
    pub fn step(&self) -> IdentifyArx {
        let s = self.data.settings();
        IdentifyArx {
            ts: s.ts,
            detrend: s.detrend,
            split: s.split,
            na: self.na,
            nb: self.nb,
            nk: self.nk,
            auto: self.auto,
            rule: self.rule,
            refine_oe: self.refine_oe,
        }
    }
}

impl OeArgs {
    /// The step these flags describe.
    pub fn step(&self) -> IdentifyOe {
        let s = self.data.settings();
        IdentifyOe {
            ts: s.ts,
            detrend: s.detrend,
            split: s.split,
            nb: Some(self.nb),
            nf: Some(self.nf),
            nk: Some(self.nk),
            start_estimate: self.start_estimate,
            initial: self.initial,
            max_iterations: self.max_iterations,
        }
    }
}

impl IvArgs {
    /// The step these flags describe.
    pub fn step(&self) -> IdentifyIv {
        let s = self.data.settings();
        IdentifyIv {
            ts: s.ts,
            detrend: s.detrend,
            split: s.split,
            na: Some(self.na),
            nb: Some(self.nb),
            nk: Some(self.nk),
        }
    }
}

impl StructArgs {
    /// The step these flags describe.
    pub fn step(&self) -> ArxStruct {
        let s = self.data.settings();
        ArxStruct {
            ts: s.ts,
            detrend: s.detrend,
            split: s.split,
            na: self.na.clone(),
            nb: self.nb.clone(),
            nk: self.nk.clone(),
            top: self.top,
            rule: self.rule,
        }
    }
}

pub fn run(cmd: IdentifyLinear) -> anyhow::Result<()> {
    match cmd {
        IdentifyLinear::Arx(a) => {
            let step = a.step();
            step.validate().map_err(step_error)?;
            let inputs = a.data.inputs()?;
            let report = observed(|observe| step.run_observed(inputs, observe))?;
            if let Some(s) = &report.details.selection {
                note!(
                    "structure selection over {} candidates chose {} (rule {})",
                    s.candidates,
                    report.orders,
                    s.rule
                );
            }
            finish(&report, &a.out)
        }
        IdentifyLinear::Oe(a) => {
            let step = a.step();
            step.validate().map_err(step_error)?;
            let inputs = a.data.inputs()?;
            let report = observed(|observe| step.run_observed(inputs, observe))?;
            finish(&report, &a.out)
        }
        IdentifyLinear::Iv(a) => {
            let step = a.step();
            step.validate().map_err(step_error)?;
            let report = step.run(a.data.inputs()?).map_err(step_error)?;
            finish(&report, &a.out)
        }
        IdentifyLinear::ArxStruct(a) => run_struct(a),
    }
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
fn progress_bar() -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(0);
    bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
    bar
}

/// Runs a step with its progress shown on a bar, cleared once it is done.
fn observed<R>(
    run: impl FnOnce(&mut dyn FnMut(LinearProgress)) -> Result<R, StepError>,
) -> anyhow::Result<R> {
    let bar = progress_bar();
    let report = run(&mut |p| show(&bar, p)).map_err(step_error)?;
    bar.finish_and_clear();
    Ok(report)
}

fn show(bar: &indicatif::ProgressBar, p: LinearProgress) {
    match p {
        LinearProgress::Oe(pr) => {
            bar.set_message(format!(
                "OE iteration {}: loss {:.6e}, damping {:.1e}",
                pr.iteration, pr.loss, pr.damping
            ));
            bar.tick();
        }
        LinearProgress::Search { done, total } => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
    }
}

fn run_struct(a: StructArgs) -> anyhow::Result<()> {
    let step = a.step();
    step.validate().map_err(step_error)?;
    let inputs = a.data.inputs()?;
    let report = observed(|observe| step.run_observed(inputs, observe))?;
    warn_grid_edges(&report.grid_edges);
    if let Some(path) = &a.out {
        write_atomic(
            path,
            tf_json::tf_to_string(&report.transfer_function()).as_bytes(),
        )?;
    }
    print_report(&report, a.json)?;
    Ok(())
}

/// The searched structure on an edge of its grid, said on stderr.
fn warn_grid_edges(edges: &[String]) {
    for edge in edges {
        eprintln!("warning: {edge}");
    }
}

/// Writes the model and the plots, then prints the report.
fn finish(r: &LinearReport, out: &OutArgs) -> anyhow::Result<()> {
    let p = &r.prepared;
    warn_grid_edges(&r.grid_edges);
    if let Some(path) = &out.out {
        write_atomic(
            path,
            tf_json::tf_to_string(&r.transfer_function()).as_bytes(),
        )?;
    }
    if let Some(path) = &out.plot {
        let emp = plot_estimate(p, out)?;
        let fmax = out.plot_fmax.unwrap_or(0.5 / p.ts).min(0.5 / p.ts);
        let title = format!("{} {} of {}", r.method.to_uppercase(), r.orders, p.source);
        let how = emp.summary();
        eprintln!("{}: --plot: {how}", p.source);
        write_plot(path, |f| {
            bode_plot(&title, &how, Some(&r.tf), &emp, fmax, f)
        })?;
    }
    if let Some(path) = &out.plot_compare {
        write_plot(path, |f| compare_plot(r, f))?;
    }
    print_report(r, out.json)?;
    Ok(())
}

/// Measured vs simulated output and the error (MATLAB `compare`), on the
/// validation record when there is one.
fn compare_plot(r: &LinearReport, format: PlotFormat) -> anyhow::Result<Vec<u8>> {
    let p = &r.prepared;
    let rec = p.val.as_ref().unwrap_or(&p.est);
    let sim = r.model.simulate_fit_ic(&rec.u, &rec.y);
    // The record's own time axis: a validation part continues the estimation part.
    let t: Vec<f64> = (0..rec.y.len())
        .map(|k| (rec.first_sample + k) as f64 * p.ts)
        .collect();
    let err: Vec<f64> = rec.y.iter().zip(&sim).map(|(a, b)| a - b).collect();
    let fit = crate::ident::metrics::nrmse_fit_percent(&rec.y, &sim);
    let title = format!(
        "{} {}: simulation fit {fit:.2} % on {}",
        r.method.to_uppercase(),
        r.orders,
        rec.label
    );
    Ok(stacked_charts(
        &[
            (
                title.as_str(),
                "time (s)",
                "output (record units)",
                vec![
                    Series {
                        label: "measured",
                        x: &t,
                        y: &rec.y,
                    },
                    Series {
                        label: "simulated (initial state fitted)",
                        x: &t,
                        y: &sim,
                    },
                ],
            ),
            (
                "",
                "time (s)",
                "measured - simulated (record units)",
                vec![Series {
                    label: "simulation error",
                    x: &t,
                    y: &err,
                }],
            ),
        ],
        format,
    )?)
}

/// The plot's empirical estimate of the estimation record, by the
/// `--segment`/`--period` options.
fn plot_estimate(p: &Prepared, out: &OutArgs) -> anyhow::Result<Empirical> {
    let params = EmpiricalParams {
        welch: WelchParams {
            segment: out.segment,
            ..WelchParams::default()
        },
        period: out
            .period
            .map(|s| period_in_samples(s, p.ts).map_err(|m| bad(format!("--period: {m}"))))
            .transpose()?,
        skip_periods: out.skip_periods,
        ..EmpiricalParams::default()
    };
    empirical_response(&p.est.u, &p.est.y, p.ts, &params)
        .map_err(|e| bad(format!("{}: --plot: {e}", p.source)))
}

/// Coherence below which an empirical point is drawn faint: there the
/// output is mostly not the linear response to the input (noise, leakage,
/// nonlinearity), and the estimate's variance is large.
const TRUSTED_COHERENCE: f64 = 0.8;

/// The empirical response split for drawing: trusted points (coherence at
/// least [`TRUSTED_COHERENCE`], or no coherence known) and the rest, each
/// NaN where the other has a point so that lines break at the gaps. The
/// phase is unwrapped along the trusted points only; an untrusted point's
/// phase is put on the branch nearest the last trusted one.
struct EmpiricalCurves {
    freq: Vec<f64>,
    mag_trusted: Vec<f64>,
    mag_faint: Vec<f64>,
    phase_trusted: Vec<f64>,
    phase_faint: Vec<f64>,
    coherence: Vec<f64>,
}

impl EmpiricalCurves {
    fn new(emp: &FreqResponse, fmax: f64) -> Self {
        let mut c = EmpiricalCurves {
            freq: Vec::new(),
            mag_trusted: Vec::new(),
            mag_faint: Vec::new(),
            phase_trusted: Vec::new(),
            phase_faint: Vec::new(),
            coherence: Vec::new(),
        };
        let mut last_phase: Option<f64> = None;
        for (i, (&f, h)) in emp.freq_hz.iter().zip(&emp.response).enumerate() {
            // 0 Hz has no place on a log axis; NaN bins had no input power.
            if f <= 0.0 || f > fmax || !h.re.is_finite() {
                continue;
            }
            let coh = emp.coherence.as_ref().map(|c| c[i]);
            let trusted = coh.is_none_or(|g| g >= TRUSTED_COHERENCE);
            let mag = 20.0 * h.norm().log10();
            let raw = h.arg().to_degrees();
            let phase = match last_phase {
                Some(p) => raw + 360.0 * ((p - raw) / 360.0).round(),
                None => raw,
            };
            if trusted {
                last_phase = Some(phase);
            }
            let none = (f64::NAN, f64::NAN);
            let (keep, drop) = if trusted {
                ((mag, phase), none)
            } else {
                (none, (mag, phase))
            };
            c.freq.push(f);
            c.mag_trusted.push(keep.0);
            c.phase_trusted.push(keep.1);
            c.mag_faint.push(drop.0);
            c.phase_faint.push(drop.1);
            c.coherence.push(coh.unwrap_or(f64::NAN));
        }
        c
    }
}

/// Model vs empirical Bode (magnitude, phase) and coherence, stacked, on a
/// logarithmic frequency axis; points of low coherence drawn faint.
fn bode_plot(
    title: &str,
    estimate: &str,
    model: Option<&crate::lti::DiscreteTf>,
    empirical: &Empirical,
    fmax: f64,
    format: PlotFormat,
) -> anyhow::Result<Vec<u8>> {
    use crate::io::plot::{Panel, Style, render};
    let emp = &empirical.response;
    let e = EmpiricalCurves::new(emp, fmax);
    let lowest = e
        .freq
        .first()
        .copied()
        .unwrap_or(fmax / 1e3)
        .max(fmax * 1e-5);
    let grid = crate::lti::logspace(lowest, fmax, 1001);
    let mb = model.map(|g| Bode::from_fn(&grid, |f| g.response_at_hz(f)));
    let mmag = mb.as_ref().map(|b| b.magnitude_db());
    let faint_label = format!("empirical, coherence < {TRUSTED_COHERENCE}");
    let series = |mag: bool| {
        let (trusted, faint) = if mag {
            (&e.mag_trusted, &e.mag_faint)
        } else {
            (&e.phase_trusted, &e.phase_faint)
        };
        let mut v = vec![
            (
                Series {
                    label: match empirical.kind {
                        EstimateKind::Welch { .. } => "empirical (Welch H1)",
                        EstimateKind::Periodic { .. } => "empirical (period average)",
                        EstimateKind::Etfe => "empirical (ETFE)",
                    },
                    x: &e.freq,
                    y: trusted,
                },
                Style::Line,
            ),
            (
                Series {
                    label: &faint_label,
                    x: &e.freq,
                    y: faint,
                },
                Style::Faint,
            ),
        ];
        if let (Some(b), Some(m)) = (&mb, &mmag) {
            let y = if mag { m } else { &b.phase_deg };
            v.push((
                Series {
                    label: "model",
                    x: &b.freq_hz,
                    y,
                },
                Style::Line,
            ));
        }
        v
    };
    let mut panels = vec![
        Panel {
            series: series(true),
            log_x: true,
            ..Panel::lines(title, "frequency (Hz)", "magnitude (dB)", vec![])
        },
        Panel {
            series: series(false),
            log_x: true,
            ..Panel::lines("", "frequency (Hz)", "phase (deg)", vec![])
        },
    ];
    if emp.coherence.is_some() {
        panels.push(Panel {
            log_x: true,
            ..Panel::lines(
                estimate,
                "frequency (Hz)",
                "coherence (1)",
                vec![Series {
                    label: "coherence |P_yu|^2/(P_uu P_yy)",
                    x: &e.freq,
                    y: &e.coherence,
                }],
            )
        });
    }
    Ok(render(&panels, format)?)
}

/// Used by `fts bode`: the empirical response of a prepared record.
pub fn empirical_plot(path: &Path, title: &str, emp: &Empirical, fmax: f64) -> anyhow::Result<()> {
    let how = emp.summary();
    write_plot(path, |f| bode_plot(title, &how, None, emp, fmax, f))
}
