//! `fts identify hysteresis data.csv [--model pi|mpi-cbrt|mpi-deadzone]
//! [--operator play-lower|play-symmetric] [--operators N] [--method ls|gd]
//! [--inverse] [-o model.json] [--json] [--plot loop.svg]`
//!
//! The step is the library's ([`IdentifyHysteresis`]); this file turns
//! flags into it, reads the record, writes the model and the plot and
//! renders the report.

use super::columns::IoColumnArgs;
use super::common::{choice, name, print_report, step_error, write_atomic, write_plot};
use crate::ident::hysteresis::gd::GdState;
use crate::io::hysteresis_json::{ModelFile, SignalInfo, model_to_string};
use crate::io::plot::{PlotFormat, Series, stacked_charts};
use crate::workflow::Validate;
use crate::workflow::identify::{
    HysteresisInputs, HysteresisMethod, HysteresisModelKind, IdentifyHysteresis, PlayOperatorChoice,
};
use argmin::core::observers::Observe;
use argmin::core::{Error as ArgminError, KV};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct HysteresisArgs {
    /// Input/output record (CSV or whitespace .dat).
    #[arg(value_name = "DATA.csv")]
    data: PathBuf,
    #[command(flatten)]
    columns: IoColumnArgs,
    /// Model structure.
    #[arg(long, value_parser = choice::<HysteresisModelKind>(), default_value = name(IdentifyHysteresis::default().model))]
    model: HysteresisModelKind,
    /// Play operator form (default: play-lower for pi and mpi-cbrt, play-symmetric for mpi-deadzone).
    #[arg(long, value_parser = choice::<PlayOperatorChoice>())]
    operator: Option<PlayOperatorChoice>,
    /// Number of play operators on the grid r_i = i/N max|u|.
    #[arg(long, value_name = "N", default_value_t = IdentifyHysteresis::default().operators, value_parser = parse_operators)]
    operators: usize,
    /// Explicit play thresholds (comma-separated, strictly increasing); replaces --operators.
    #[arg(
        long,
        value_name = "R0,R1,..",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    thresholds: Option<Vec<f64>>,
    /// Dead-zone operators of mpi-deadzone.
    #[arg(long, value_name = "M", default_value_t = IdentifyHysteresis::default().dead_zone_operators, value_parser = parse_operators)]
    dead_zone_operators: usize,
    /// Solver.
    #[arg(long, value_parser = choice::<HysteresisMethod>(), default_value = name(IdentifyHysteresis::default().method))]
    method: HysteresisMethod,
    /// Keep every partial sum of the weights positive (an invertible model); ls only.
    #[arg(long)]
    invertible: bool,
    /// Do not identify a constant output offset (manifest: `offset = false`).
    #[arg(long)]
    no_offset: bool,
    /// Identify the inverse model directly: the recorded output is the model input (\[Li21\]).
    #[arg(long)]
    inverse: bool,
    /// Rate-dependent weights w_i + w1_i |du/dt|/scale (pi, mpi-cbrt; the record needs a time column).
    #[arg(long)]
    rate_dependent: bool,
    /// Iteration cap of each gradient solve (--method gd).
    #[arg(long = "max-iterations", alias = "max-iters", value_name = "N", default_value_t = IdentifyHysteresis::default().max_iterations)]
    max_iterations: u64,
    /// Quantity of the record's input column.
    #[arg(long, default_value_t = IdentifyHysteresis::default().input_quantity)]
    input_quantity: String,
    /// Unit of the record's input column.
    #[arg(long, default_value_t = IdentifyHysteresis::default().input_unit)]
    input_unit: String,
    /// Quantity of the record's output column.
    #[arg(long, default_value_t = IdentifyHysteresis::default().output_quantity)]
    output_quantity: String,
    /// Unit of the record's output column.
    #[arg(long, default_value_t = IdentifyHysteresis::default().output_unit)]
    output_unit: String,
    /// Write the model (`fts.hysteresis/1`) here.
    #[arg(short = 'o', long = "out", value_name = "MODEL.json")]
    out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Draw the measured and model loops and the error over time (SVG).
    #[arg(long, value_name = "LOOP.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
}

impl HysteresisArgs {
    /// The step these flags describe.
    pub fn step(&self) -> IdentifyHysteresis {
        IdentifyHysteresis {
            model: self.model,
            operator: self.operator,
            operators: self.operators,
            thresholds: self.thresholds.clone(),
            dead_zone_operators: self.dead_zone_operators,
            method: self.method,
            invertible: self.invertible,
            offset: !self.no_offset,
            inverse: self.inverse,
            rate_dependent: self.rate_dependent,
            max_iterations: self.max_iterations,
            input_quantity: self.input_quantity.clone(),
            input_unit: self.input_unit.clone(),
            output_quantity: self.output_quantity.clone(),
            output_unit: self.output_unit.clone(),
        }
    }
}

/// Drives an indicatif bar from argmin's iterations (stderr; hidden when
/// stderr is not a terminal).
#[derive(Clone)]
struct ProgressObserver {
    bar: ProgressBar,
}

impl Observe<GdState> for ProgressObserver {
    fn observe_iter(&mut self, state: &GdState, _kv: &KV) -> Result<(), ArgminError> {
        self.bar.inc(1);
        self.bar.set_message(format!(
            "cost above the residual floor {:.3e}",
            state.get_best_cost()
        ));
        Ok(())
    }
}

pub fn run(args: HysteresisArgs) -> anyhow::Result<()> {
    let step = args.step();
    step.validate().map_err(step_error)?;
    let source = args.data.display().to_string();
    let record = args.columns.read(&args.data)?;
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} gradient descent: {pos} iterations, {msg}")
            .expect("valid template"),
    );
    let inputs = HysteresisInputs {
        record: &record,
        source: &source,
        start: args.columns.start,
    };
    let mut report = step
        .run_observed(inputs, ProgressObserver { bar: bar.clone() })
        .map_err(step_error)?;
    bar.finish_and_clear();
    if let Some(path) = &args.out {
        write_atomic(path, model_to_string(&report.file).as_bytes())?;
        report.model_file = Some(path.display().to_string());
    }
    if let Some(path) = &args.plot {
        let (u, y) = (&report.model_input, &report.model_output);
        let y_model = report.file.model.simulate(u);
        write_plot(path, |f| loop_plot(&report.file, u, y, &y_model, f))?;
    }
    print_report(&report, args.json)?;
    Ok(())
}

/// At most this many points per curve in the SVG (the loop is decimated evenly).
const PLOT_POINTS: usize = 4000;

fn decimate(x: &[f64]) -> Vec<f64> {
    let step = x.len().div_ceil(PLOT_POINTS).max(1);
    x.iter().step_by(step).copied().collect()
}

fn loop_plot(
    file: &ModelFile,
    u: &[f64],
    y: &[f64],
    y_model: &[f64],
    format: PlotFormat,
) -> anyhow::Result<Vec<u8>> {
    let (ud, yd, md) = (decimate(u), decimate(y), decimate(y_model));
    let err: Vec<f64> = y_model.iter().zip(y).map(|(a, b)| a - b).collect();
    let ed = decimate(&err);
    let step = u.len().div_ceil(PLOT_POINTS).max(1);
    let k: Vec<f64> = (0..ed.len()).map(|i| (i * step) as f64).collect();
    let label = |s: &SignalInfo| {
        if s.unit.is_empty() {
            s.quantity.clone()
        } else {
            format!("{} ({})", s.quantity, s.unit)
        }
    };
    let (xl, yl) = (label(&file.input), label(&file.output));
    let title = format!(
        "{} {} loop ({})",
        file.model.kind.name(),
        file.model.operator.name(),
        file.mapping()
    );
    let err_label = format!("model - measured, {}", file.output.unit);
    let image = stacked_charts(
        &[
            (
                title.as_str(),
                xl.as_str(),
                yl.as_str(),
                vec![
                    Series {
                        label: "measured",
                        x: &ud,
                        y: &yd,
                    },
                    Series {
                        label: "model",
                        x: &ud,
                        y: &md,
                    },
                ],
            ),
            (
                "error over time",
                "sample",
                err_label.as_str(),
                vec![Series {
                    label: "error",
                    x: &k,
                    y: &ed,
                }],
            ),
        ],
        format,
    )?;
    Ok(image)
}

/// `--operators`, `--dead-zone-operators`: from 1 to the most a model file holds.
fn parse_operators(text: &str) -> Result<usize, String> {
    let max = crate::io::hysteresis_json::MAX_OPERATORS;
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!("expected a whole number from 1 to {max}")),
    }
}
