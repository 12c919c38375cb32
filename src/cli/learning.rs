//! `fts repetitive --tf CL.json (--period N | --period-s S | --spindle-hz F)`
//! and `fts ilc [loop flags] [--trials N]`: flags into
//! [`DesignRepetitive`] and [`Ilc`], the files read and written here.

use super::common::{bad, print_report, read_input, step_error, write_atomic};
use super::simulate::LoopArgs;
use crate::io::plot;
use crate::lti::{DiscreteTf, TransferFunction};
use crate::workflow::learning::{DesignRepetitive, Ilc, IlcReport};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct RepetitiveArgs {
    /// Closed-loop model (`fts.tf/1`, discrete): loop reference to output, at the controller's rate; `--tf CL.json` or the first argument.
    #[arg(long = "tf", value_name = "CL.json", required_unless_present = "model")]
    tf: Option<PathBuf>,
    /// The closed-loop model given without `--tf`.
    #[arg(value_name = "CL.json", conflicts_with = "tf", hide = true)]
    model: Option<PathBuf>,
    /// Period in samples (fractional periods are interpolated).
    #[arg(long, value_name = "SAMPLES", group = "period_given")]
    period: Option<f64>,
    /// Period in seconds.
    #[arg(long, value_name = "SECONDS", group = "period_given")]
    period_s: Option<f64>,
    /// Spindle frequency, Hz: the period is one revolution.
    #[arg(long, value_name = "HZ", group = "period_given")]
    spindle_hz: Option<f64>,
    /// Learning gain k_r.
    #[arg(long, default_value_t = DesignRepetitive::default().gain)]
    gain: f64,
    /// Phase lead m, samples (default: the lead with the largest stability margin).
    #[arg(long)]
    lead: Option<usize>,
    /// Largest lead tried.
    #[arg(long, default_value_t = DesignRepetitive::default().max_lead)]
    max_lead: usize,
    /// Cutoff of the zero-phase low-pass Q, Hz (default: a quarter of the sampling rate).
    #[arg(long, value_name = "HZ", conflicts_with = "q")]
    q_cutoff: Option<f64>,
    /// One-sided taps of Q.
    #[arg(long, default_value_t = DesignRepetitive::default().q_taps)]
    q_taps: usize,
    /// Q's taps q0,q1,.. as given.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    q: Option<Vec<f64>>,
    /// Write the design (`fts.repetitive/1`) here.
    #[arg(short = 'o', long = "out", value_name = "RC.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

fn read_discrete(path: &Path, what: &str) -> anyhow::Result<DiscreteTf> {
    let source = path.display().to_string();
    match super::common::parse_tf(&read_input(path)?, &source)? {
        TransferFunction::Discrete(g) => Ok(g),
        _ => Err(bad(format!(
            "{source} field 'var': the {what} must be discrete (\"z^-1\")"
        ))),
    }
}

pub fn run_repetitive(args: RepetitiveArgs) -> anyhow::Result<()> {
    if args.period.is_none() && args.period_s.is_none() && args.spindle_hz.is_none() {
        return Err(bad(
            "give the period: --period SAMPLES, --period-s SECONDS or --spindle-hz HZ",
        ));
    }
    let step = DesignRepetitive {
        period: args.period,
        period_s: args.period_s,
        spindle_hz: args.spindle_hz,
        gain: args.gain,
        lead: args.lead,
        max_lead: args.max_lead,
        q_cutoff: args.q_cutoff,
        q_taps: args.q_taps,
        q: args.q.clone(),
    };
    let model = read_discrete(
        super::common::one_of(&args.tf, &args.model),
        "closed-loop model",
    )?;
    let report = step.run(&model).map_err(step_error)?;
    if let Some(path) = &args.output {
        write_atomic(path, report.file_text().as_bytes())?;
    }
    print_report(&report, args.json)?;
    Ok(())
}

#[derive(Debug, Args)]
pub struct IlcArgs {
    #[command(flatten)]
    run: LoopArgs,
    /// Learning trials after the first run.
    #[arg(long, default_value_t = Ilc::default().trials)]
    trials: usize,
    /// Learning gain a in f <- Q (f + a L e) (default: chosen with Q's cutoff by the model check).
    #[arg(long = "learning-gain", value_name = "A")]
    gain: Option<f64>,
    /// Cutoff of the zero-phase low-pass Q, Hz (default: the highest the model check passes, not below the reference's band).
    #[arg(long, value_name = "HZ")]
    q_cutoff: Option<f64>,
    /// One-sided taps of Q.
    #[arg(long, default_value_t = Ilc::default().q_taps)]
    q_taps: usize,
    /// Stop when a trial's max error exceeds the best trial's by this factor.
    #[arg(long, value_name = "FACTOR", default_value_t = Ilc::default().divergence_factor)]
    divergence_factor: f64,
    /// Run every trial and write the result even when the model check fails or the measured error diverges (exit 0, with a warning).
    #[arg(long)]
    allow_divergence: bool,
    /// Write the controller with the learned feedforward table (`fts.controller/1`) here.
    #[arg(short = 'o', long = "out", value_name = "CTRL.json")]
    output: Option<PathBuf>,
    /// Plot the error per trial and the last trial's error to this SVG.
    #[arg(long, value_name = "ILC.svg", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run_ilc(args: IlcArgs) -> anyhow::Result<()> {
    let step = Ilc {
        trials: args.trials,
        gain: args.gain,
        q_cutoff: args.q_cutoff,
        q_taps: args.q_taps,
        divergence_factor: args.divergence_factor,
        allow_divergence: args.allow_divergence,
    };
    let simulate = args.run.step()?;
    let inputs = args.run.inputs()?;
    let report = step
        .run(
            &simulate,
            inputs,
            None,
            &mut |message| note!("{message}"),
            &mut |row| {
                note!(
                    "trial {:>3}: max error {:.4} ({:.3} %)",
                    row.trial,
                    row.max_error,
                    row.max_error_percent
                )
            },
        )
        .map_err(step_error)?;
    if let Some(path) = &args.output {
        write_atomic(path, report.controller.to_json_string().as_bytes())?;
    }
    if let Some(path) = &args.plot {
        super::common::write_plot(path, |format| ilc_plot(&report, format))?;
    }
    print_report(&report, args.json)?;
    if report.diverging() {
        note!(
            "warning: a convergence check failed (see the prediction and the verdict); the result was written because --allow-divergence was given"
        );
    }
    Ok(())
}

/// Max and RMS error per trial (log scale) and the last trial's error, its
/// evaluated window shaded.
fn ilc_plot(report: &IlcReport, format: plot::PlotFormat) -> anyhow::Result<Vec<u8>> {
    let trials: Vec<f64> = report.trials.iter().map(|r| r.trial as f64).collect();
    let max: Vec<f64> = report.trials.iter().map(|r| r.max_error).collect();
    let rms: Vec<f64> = report.trials.iter().map(|r| r.rms_error).collect();
    let trace = &report.trace;
    let t: Vec<f64> = (0..trace.reference.len())
        .map(|k| k as f64 * trace.ts)
        .collect();
    let e = trace.error();
    let title = format!("ILC: error per trial, {}", report.reference);
    let window = (
        report.evaluated.start as f64 * trace.ts,
        report.evaluated.end.saturating_sub(1) as f64 * trace.ts,
        "evaluated",
    );
    Ok(plot::render(
        &[
            plot::Panel {
                log_y: true,
                ..plot::Panel::lines(
                    &title,
                    "trial",
                    "tracking error (um)",
                    vec![
                        plot::Series {
                            label: "max |e|",
                            x: &trials,
                            y: &max,
                        },
                        plot::Series {
                            label: "rms e",
                            x: &trials,
                            y: &rms,
                        },
                    ],
                )
            },
            plot::Panel {
                shade: Some(window),
                ..plot::Panel::lines(
                    "last trial's error",
                    "t (s)",
                    "e = r - y (um)",
                    vec![plot::Series {
                        label: "e",
                        x: &t,
                        y: &e,
                    }],
                )
            },
        ],
        format,
    )?)
}
