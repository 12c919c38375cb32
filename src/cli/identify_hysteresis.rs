//! `fts identify hysteresis data.csv [--model pi|mpi-cbrt|mpi-deadzone]
//! [--operator play-lower|play-symmetric] [--operators N] [--method ls|gd]
//! [--inverse] [-o model.json] [--json] [--plot loop.svg]`

use super::columns::IoColumnArgs;
use super::common::{bad, print_json, write_atomic};
use crate::ident::hysteresis::gd::GdState;
use crate::ident::hysteresis::{
    Identified, IdentifyError, IdentifyParams, Method, ModelKind, PlayOperator, identify_observed,
};
use crate::io::hysteresis_json::{
    FitRecord, ModelFile, SignalInfo, model_to_string, model_to_value,
};
use crate::io::plot::{Series, stacked_charts_svg};
use argmin::core::observers::Observe;
use argmin::core::{Error as ArgminError, KV};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ModelArg {
    /// Classical Prandtl–Ishlinskii.
    Pi,
    /// PI plus a cube-root term ([Li21] Eq. 4).
    MpiCbrt,
    /// PI followed by one-sided dead-zone operators ([Tang17] Eq. 40-43).
    MpiDeadzone,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum OperatorArg {
    /// One-sided play, output in [u - r, u] ([Li21]).
    PlayLower,
    /// Symmetric play, output in [u - r, u + r] ([Tang17]).
    PlaySymmetric,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum MethodArg {
    /// Least squares by QR.
    Ls,
    /// L-BFGS gradient descent on the same cost.
    Gd,
}

#[derive(Debug, Args)]
pub struct HysteresisArgs {
    /// Input/output record (CSV or whitespace .dat).
    #[arg(value_name = "DATA.csv")]
    data: PathBuf,
    #[command(flatten)]
    columns: IoColumnArgs,
    /// Model structure.
    #[arg(long, value_enum, default_value_t = ModelArg::MpiCbrt)]
    model: ModelArg,
    /// Play operator form (default: play-lower for pi and mpi-cbrt, play-symmetric for mpi-deadzone).
    #[arg(long, value_enum)]
    operator: Option<OperatorArg>,
    /// Number of play operators on the grid r_i = i/N max|u|.
    #[arg(long, value_name = "N", default_value_t = 10, value_parser = parse_operators)]
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
    #[arg(long, value_name = "M", default_value_t = 4, value_parser = parse_operators)]
    dead_zone_operators: usize,
    /// Solver.
    #[arg(long, value_enum, default_value_t = MethodArg::Ls)]
    method: MethodArg,
    /// Keep every partial sum of the weights positive (an invertible model); ls only.
    #[arg(long)]
    invertible: bool,
    /// Do not identify a constant output offset.
    #[arg(long)]
    no_offset: bool,
    /// Identify the inverse model directly: the recorded output is the model input ([Li21]).
    #[arg(long)]
    inverse: bool,
    /// Iteration cap of each gradient solve (--method gd).
    #[arg(long, value_name = "N", default_value_t = 2000)]
    max_iters: u64,
    /// Quantity of the record's input column.
    #[arg(long, default_value = "voltage")]
    input_quantity: String,
    /// Unit of the record's input column.
    #[arg(long, default_value = "V")]
    input_unit: String,
    /// Quantity of the record's output column.
    #[arg(long, default_value = "displacement")]
    output_quantity: String,
    /// Unit of the record's output column.
    #[arg(long, default_value = "um")]
    output_unit: String,
    /// Write the model (`fts.hysteresis/1`) here.
    #[arg(short = 'o', long = "out", value_name = "MODEL.json")]
    out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Draw the measured and model loops and the error over time (SVG).
    #[arg(long, value_name = "LOOP.svg")]
    plot: Option<PathBuf>,
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
        self.bar
            .set_message(format!("cost {:.6e}", state.get_best_cost()));
        Ok(())
    }
}

fn identify_error(source: &str, e: IdentifyError) -> anyhow::Error {
    match e {
        IdentifyError::Solver(_) => anyhow::Error::new(e),
        // Problems with the options, not with the data file.
        IdentifyError::Thresholds(t) => bad(format!("--thresholds: {t}")),
        IdentifyError::InvalidParams(m) => bad(m),
        other => bad(format!("{source}: {other}")),
    }
}

pub fn run(args: HysteresisArgs) -> anyhow::Result<()> {
    let source = args.data.display().to_string();
    let record = args.columns.read(&args.data)?;
    let (file_in, file_out) = (
        SignalInfo {
            quantity: args.input_quantity.clone(),
            unit: args.input_unit.clone(),
        },
        SignalInfo {
            quantity: args.output_quantity.clone(),
            unit: args.output_unit.clone(),
        },
    );
    // [Li21] direct inverse: the displacement drives the model, the voltage is its output.
    let (u, y, model_in, model_out) = if args.inverse {
        (&record.output, &record.input, file_out, file_in)
    } else {
        (&record.input, &record.output, file_in, file_out)
    };
    let kind = match args.model {
        ModelArg::Pi => ModelKind::Pi,
        ModelArg::MpiCbrt => ModelKind::MpiCbrt,
        ModelArg::MpiDeadzone => ModelKind::MpiDeadzone,
    };
    let mut params = IdentifyParams {
        kind,
        operator: args.operator.map(|o| match o {
            OperatorArg::PlayLower => PlayOperator::Lower,
            OperatorArg::PlaySymmetric => PlayOperator::Symmetric,
        }),
        operators: args.operators,
        thresholds: args.thresholds.clone(),
        dead_zone_operators: args.dead_zone_operators,
        offset: !args.no_offset,
        method: match args.method {
            MethodArg::Ls => Method::Ls,
            MethodArg::Gd => Method::Gd,
        },
        invertible: args.invertible,
        ..Default::default()
    };
    params.gd.max_iters = args.max_iters;

    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} gradient descent: {pos} iterations, {msg}")
            .expect("valid template"),
    );
    let identified = identify_observed(u, y, &params, ProgressObserver { bar: bar.clone() })
        .map_err(|e| identify_error(&source, e))?;
    bar.finish_and_clear();
    let Identified { model, info } = &identified;

    let method = match (params.method, params.invertible) {
        (Method::Gd, _) => "gd",
        (Method::Ls, true) => "ls-invertible",
        (Method::Ls, false) => "ls",
    };
    let file = ModelFile {
        model: model.clone(),
        input: model_in,
        output: model_out,
        fit: Some(FitRecord {
            rms_percent: info.fit.rms_percent,
            max_percent: info.fit.max_percent,
            samples: info.fit.samples,
            method: method.into(),
            condition_number: info.condition_number,
            iterations: info.iterations,
        }),
    };
    if let Some(path) = &args.out {
        write_atomic(path, model_to_string(&file).as_bytes())?;
    }
    if let Some(path) = &args.plot {
        let y_model = model.simulate(u);
        write_atomic(path, loop_plot(&file, u, y, &y_model)?.as_bytes())?;
    }

    if args.json {
        let mut value = model_to_value(&file);
        let obj = value.as_object_mut().expect("object");
        obj.remove("format");
        obj.insert(
            "fit".into(),
            json!({
                "rms_percent": info.fit.rms_percent,
                "max_percent": info.fit.max_percent,
                "samples": info.fit.samples,
            }),
        );
        obj.insert("method".into(), json!(method));
        obj.insert("condition_number".into(), json!(info.condition_number));
        obj.insert("iterations".into(), json!(info.iterations));
        obj.insert("alternations".into(), json!(info.alternations));
        obj.insert("cost".into(), json!(info.cost));
        obj.insert("constraint_active".into(), json!(info.constraint_active));
        obj.insert("inverse".into(), json!(args.inverse));
        obj.insert("source".into(), json!(source));
        obj.insert("start".into(), json!(args.columns.start));
        obj.insert("timing".into(), serde_json::to_value(&record.timing)?);
        obj.insert(
            "model_file".into(),
            json!(args.out.as_ref().map(|p| p.display().to_string())),
        );
        return print_json(&value);
    }

    say!(
        "{} model ({}), {} operators, {}: {} samples of {source} from sample {}",
        model.kind.name(),
        model.operator.name(),
        model.operators(),
        file.mapping(),
        u.len(),
        args.columns.start
    );
    say!(
        "fit: rms {:.4} %, max {:.4} % of the output range; condition number {:.3e}; {}{}",
        info.fit.rms_percent,
        info.fit.max_percent,
        info.condition_number,
        method,
        match params.method {
            Method::Gd => format!(", {} iterations", info.iterations),
            Method::Ls => String::new(),
        }
    );
    if let Some(t) = &record.timing {
        say!("{t}");
    }
    if model.kind == ModelKind::MpiDeadzone {
        say!("alternations: {}", info.alternations);
    }
    say!("  {:>3} {:>14} {:>14}", "i", "r_i", "w_i");
    for (i, (r, w)) in model.thresholds.iter().zip(&model.weights).enumerate() {
        say!("  {i:>3} {r:>14.6} {w:>14.6}");
    }
    say!(
        "cbrt gain {:.6}, offset {:.6}",
        model.cbrt_gain,
        model.offset
    );
    if let Some(dz) = &model.dead_zone {
        say!("dead-zone stage:");
        say!("  {:>3} {:>14} {:>14}", "j", "d_j", "g_j");
        for (j, (d, g)) in dz.thresholds.iter().zip(&dz.weights).enumerate() {
            say!("  {j:>3} {d:>14.6} {g:>14.6}");
        }
    }
    if info.constraint_active {
        say!("invertibility constraint active (some partial sums at their bound)");
    }
    for path in args.out.iter().chain(&args.plot) {
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// At most this many points per curve in the SVG (the loop is decimated evenly).
const PLOT_POINTS: usize = 4000;

fn decimate(x: &[f64]) -> Vec<f64> {
    let step = x.len().div_ceil(PLOT_POINTS).max(1);
    x.iter().step_by(step).copied().collect()
}

fn loop_plot(file: &ModelFile, u: &[f64], y: &[f64], y_model: &[f64]) -> anyhow::Result<String> {
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
    let svg = stacked_charts_svg(&[
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
    ])?;
    Ok(svg)
}

/// `--operators`, `--dead-zone-operators`: from 1 to the most a model file holds.
fn parse_operators(text: &str) -> Result<usize, String> {
    let max = crate::io::hysteresis_json::MAX_OPERATORS;
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!("expected a whole number from 1 to {max}")),
    }
}
