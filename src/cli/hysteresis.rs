//! `fts hysteresis invert model.json -o inv.json` and
//! `fts hysteresis apply model.json data.csv -o out.csv`.

use super::columns::LayoutArgs;
use super::common::{bad, open_input, print_json, read_input, write_atomic};
use crate::ident::hysteresis::{Fit, HysteresisModel, InverseError, analytic_inverse};
use crate::io::hysteresis_json::{ModelFile, model_to_string, parse_model};
use crate::io::timeseries::{ColumnRef, ReadParams, TimeColumn, read_table, write_csv};
use clap::{Args, Subcommand};
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(Debug, Subcommand)]
pub enum HysteresisCommand {
    /// Analytic inverse of a PI or MPI-deadzone model (symmetric play, positive partial sums).
    Invert(InvertArgs),
    /// Run a model on a signal (e.g. the inverse model on a reference: HC feedforward).
    Apply(ApplyArgs),
}

#[derive(Debug, Args)]
pub struct InvertArgs {
    /// Forward model (`fts.hysteresis/1`).
    #[arg(value_name = "MODEL.json")]
    model: PathBuf,
    /// Write the inverse model here.
    #[arg(short = 'o', long = "out", value_name = "INV.json")]
    out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct ApplyArgs {
    /// Model (`fts.hysteresis/1`).
    #[arg(value_name = "MODEL.json")]
    model: PathBuf,
    /// Signal to feed the model (CSV or whitespace .dat).
    #[arg(value_name = "DATA.csv")]
    data: PathBuf,
    /// Column that drives the model: header name, 1-based index or MAT variable.
    #[arg(long, value_name = "COL", default_value = "u", value_parser = super::columns::parse_column)]
    input_col: String,
    /// Column to compare the model output with (e.g. the measured `y`): prints the fit (docs/math.md §1.5).
    #[arg(long, value_name = "COL", value_parser = super::columns::parse_column)]
    compare_col: Option<String>,
    /// Time column to copy to the output (default: found by name, `t`, `time_ms`, ...).
    #[arg(long, value_name = "COL", value_parser = super::columns::parse_column)]
    time_col: Option<String>,
    #[command(flatten)]
    layout: LayoutArgs,
    /// Write `[t,]u,y` here (y = model output).
    #[arg(short = 'o', long = "out", value_name = "OUT.csv")]
    out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: HysteresisCommand) -> anyhow::Result<()> {
    match cmd {
        HysteresisCommand::Invert(args) => invert(args),
        HysteresisCommand::Apply(args) => apply(args),
    }
}

fn load(path: &Path) -> anyhow::Result<ModelFile> {
    let source = path.display().to_string();
    Ok(parse_model(&read_input(path)?, &source)?)
}

/// Grid of the round-trip check: a triangle over the forward model's input range.
const CHECK_POINTS: usize = 2001;

/// Self-check of an inverse: `max |u - P^-1[P[u]]|` on 0 -> +A -> -A -> +A/2
/// (around the input offset), A just above the largest threshold (the
/// range the model was identified on); returns the error and A.
fn round_trip_error(forward: &HysteresisModel, inverse: &HysteresisModel) -> (f64, f64) {
    let n = forward.operators() as f64;
    let amplitude = forward.thresholds.last().copied().unwrap_or(1.0) * n / (n - 1.0).max(1.0);
    let amplitude = if amplitude > 0.0 { amplitude } else { 1.0 };
    let mut u = vec![0.0];
    let mut last = 0.0;
    for target in [amplitude, -amplitude, 0.5 * amplitude] {
        for k in 1..=CHECK_POINTS / 3 {
            u.push(last + (target - last) * k as f64 / (CHECK_POINTS / 3) as f64);
        }
        last = target;
    }
    u.iter_mut().for_each(|x| *x += forward.input_offset);
    let back = inverse.simulate(&forward.simulate(&u));
    // A NaN anywhere is the result (f64::max would drop it).
    let error = u
        .iter()
        .zip(&back)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, |m, e| if e.is_nan() || e > m { e } else { m });
    (error, amplitude)
}

fn invert(args: InvertArgs) -> anyhow::Result<()> {
    let source = args.model.display().to_string();
    let forward = load(&args.model)?;
    // A loading-curve slope that is not positive is a fact about a valid
    // model (exit 1); a model of the wrong kind is a wrong input (exit 2).
    let inverse = analytic_inverse(&forward.model).map_err(|e| match e {
        InverseError::NotInvertible { .. } => anyhow::anyhow!("{source}: {e}"),
        _ => bad(format!("{source}: {e}")),
    })?;
    let (round_trip, amplitude) = round_trip_error(&forward.model, &inverse);
    // The inverse is exact in exact arithmetic; a round trip off by more than
    // round-off (1e-9 of the amplitude) means a model the formula does not
    // cover, so nothing is written (a NaN error fails too).
    let tolerance = 1e-9 * amplitude.max(forward.model.input_offset.abs());
    if round_trip.is_nan() || round_trip > tolerance {
        anyhow::bail!(
            "{source}: self-check failed: max |u - inverse(forward(u))| = {round_trip:.3e} on a triangle of amplitude {amplitude:.6} (tolerance {tolerance:.1e}); no inverse written"
        );
    }
    let file = ModelFile {
        model: inverse,
        input: forward.output.clone(),
        output: forward.input.clone(),
        fit: None,
        input_range: None,
    };
    if let Some(path) = &args.out {
        write_atomic(path, model_to_string(&file).as_bytes())?;
    }
    if args.json {
        return print_json(&json!({
            "mapping": file.mapping(),
            "thresholds": file.model.thresholds,
            "weights": file.model.weights,
            "cbrt_gain": file.model.cbrt_gain,
            "offset": file.model.offset,
            "input_offset": file.model.input_offset,
            "input_dead_zone": file.model.input_dead_zone.as_ref().map(|dz| json!({
                "thresholds": dz.thresholds,
                "weights": dz.weights,
            })),
            "round_trip_max_error": round_trip,
            "round_trip_amplitude": amplitude,
            "model_file": args.out.as_ref().map(|p| p.display().to_string()),
        }));
    }
    say!(
        "analytic inverse of {source} ({} -> {}), {} operators",
        forward.mapping(),
        file.mapping(),
        file.model.operators()
    );
    if let Some(dz) = &file.model.input_dead_zone {
        say!("input dead-zone stage (inverse of the output stage):");
        print_stage("j", "d'_j", "g'_j", &dz.thresholds, &dz.weights)?;
        say!("play stage:");
    }
    print_stage(
        "i",
        "r'_i",
        "w'_i",
        &file.model.thresholds,
        &file.model.weights,
    )?;
    say!(
        "check: max |u - inverse(forward(u))| = {round_trip:.3e} on a triangle of amplitude {amplitude:.6}"
    );
    Ok(())
}

/// One stage's table: index, threshold, weight.
fn print_stage(
    index: &str,
    threshold: &str,
    weight: &str,
    thresholds: &[f64],
    weights: &[f64],
) -> anyhow::Result<()> {
    say!("  {index:>3} {threshold:>14} {weight:>14}");
    for (i, (r, w)) in thresholds.iter().zip(weights).enumerate() {
        say!("  {i:>3} {r:>14.6} {w:>14.6}");
    }
    Ok(())
}

fn apply(args: ApplyArgs) -> anyhow::Result<()> {
    let model_file = load(&args.model)?;
    let source = args.data.display().to_string();
    let mut columns = vec![ColumnRef::parse(&args.input_col)];
    columns.extend(args.compare_col.as_deref().map(ColumnRef::parse));
    let params = ReadParams {
        columns,
        time: args
            .time_col
            .as_deref()
            .map_or(TimeColumn::Find, |c| TimeColumn::Given(ColumnRef::parse(c))),
        layout: args.layout.layout()?,
        min_rows: 1,
    };
    let mut table = read_table(open_input(&args.data)?, &source, &params)?;
    // A rate stage differentiates at its own ts (docs/math.md §1.7): a record
    // with another sample time would get wrong rates.
    if let (Some(rate), Some(timing)) = (&model_file.model.rate, &table.timing)
        && (timing.ts - rate.ts).abs() > 1e-6 * rate.ts
    {
        return Err(bad(format!(
            "{source}: the sample time of the record, {} s, is not the {} s of the model's rate stage",
            timing.ts, rate.ts
        )));
    }
    let measured = match args.compare_col {
        Some(_) => table.columns.pop(),
        None => None,
    };
    let u = table.columns.pop().unwrap_or_default();
    if let Some(excursion) = model_file.range_excursion(&u) {
        eprintln!("warning: {}: {source}: {excursion}", args.model.display());
    }
    // Allocation-free per-sample evaluation with explicit state, as a
    // real-time loop would run it.
    let model = &model_file.model;
    let mut state = model.new_state();
    let y: Vec<f64> = u.iter().map(|&x| model.step(&mut state, x)).collect();
    if let Some(k) = y.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!(
            "{}: the output overflows at sample {k} of {source} (input {}): the model's weights or offsets are too large for this input; check the model's units",
            args.model.display(),
            u[k]
        )));
    }
    if let Some(path) = &args.out {
        let csv = match &table.time {
            Some(t) => write_csv(&["t", "u", "y"], &[t, &u, &y]),
            None => write_csv(&["u", "y"], &[&u, &y]),
        };
        write_atomic(path, csv.as_bytes())?;
    }
    let (lo, hi) = y
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let fit = match &measured {
        Some(m) => Some(Fit::of(&y, m).ok_or_else(|| {
            bad(format!(
                "{source}: --compare-col: the column is constant; the fit is relative to its range"
            ))
        })?),
        None => None,
    };
    if args.json {
        let mut doc = json!({
            "samples": y.len(),
            "mapping": model_file.mapping(),
            "model": model.kind.name(),
            "output_min": lo,
            "output_max": hi,
            "output_file": args.out.as_ref().map(|p| p.display().to_string()),
        });
        if let (Some(f), Some(obj)) = (fit, doc.as_object_mut()) {
            obj.insert("fit_rms_percent".into(), json!(f.rms_percent));
            obj.insert("fit_max_percent".into(), json!(f.max_percent));
        }
        return print_json(&doc);
    }
    say!(
        "applied {} ({} {}, {}) to {} samples of {source}: output {lo:.6} .. {hi:.6} {}",
        args.model.display(),
        model.kind.name(),
        model.operator.name(),
        model_file.mapping(),
        y.len(),
        model_file.output.unit
    );
    if let Some(f) = fit {
        say!(
            "fit against {}: rms {:.4} %, max {:.4} % of its range",
            args.compare_col.as_deref().unwrap_or_default(),
            f.rms_percent,
            f.max_percent
        );
    }
    Ok(())
}
