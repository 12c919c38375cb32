//! Model conversions on the command line:
//!
//! * `fts convert SYS.json --to ss|tf [-o OUT.json] [--json]`
//! * `fts zpk SYS.json [--json]`
//! * `fts minreal SYS.json [--tol T] [-o OUT.json] [--json]`
//! * `fts balred SYS.json --order N [-o OUT.json] [--json]`
//! * `fts d2c SYS.json [-o OUT.json] [--json]`
//!
//! `SYS.json` is `fts.tf/1` or `fts.ss/1`. A MIMO state space converted to
//! transfer functions is written as one `fts.tf/1` file per channel,
//! `OUT.y<i>u<j>.json` (1-based) beside `OUT.json`.

use super::common::{bad, choice, print_report, step_error, write_atomic};
use super::loop_analysis::read_loop_system;
use crate::io::{ss_json, tf_json};
use crate::workflow::Validate;
use crate::workflow::convert::{Balred, Convert, ConvertReport, D2c, Form, Minreal, ZpkStep};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// The model (`fts.tf/1` or `fts.ss/1`).
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Target form.
    #[arg(long, value_parser = choice::<Form>())]
    to: Form,
    /// Write the result here (a MIMO system to tf: one file per channel, `OUT.y<i>u<j>.json`).
    #[arg(short = 'o', long = "out", value_name = "OUT.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct ZpkArgs {
    /// The model (`fts.tf/1` or `fts.ss/1`).
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct MinrealArgs {
    /// The model (`fts.tf/1` or `fts.ss/1`).
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Relative tolerance of the rank decisions.
    #[arg(long, default_value_t = Minreal::default().tol)]
    tol: f64,
    /// Write the minimal model here (`fts.tf/1` when the input was one, else `fts.ss/1`).
    #[arg(short = 'o', long = "out", value_name = "OUT.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct BalredArgs {
    /// The model (`fts.tf/1` or `fts.ss/1`, stable, continuous or discrete).
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// States to keep.
    #[arg(long, value_name = "N")]
    order: usize,
    /// Accept a reduction whose error exceeds the Hankel-singular-value bound (inaccurate Gramians).
    #[arg(long)]
    allow_degradation: bool,
    /// Write the reduced model (`fts.ss/1`) here.
    #[arg(short = 'o', long = "out", value_name = "OUT.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct D2cArgs {
    /// The discrete model (`fts.tf/1` or `fts.ss/1`), taken as a ZOH discretisation.
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Write the continuous model (`fts.ss/1`) here.
    #[arg(short = 'o', long = "out", value_name = "OUT.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// `OUT.y<i>u<j>.json` beside `OUT.json`.
fn channel_path(out: &Path, i: usize, j: usize) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or("out".into(), |s| s.to_string_lossy().to_string());
    let ext = out
        .extension()
        .map_or("json".into(), |s| s.to_string_lossy().to_string());
    out.with_file_name(format!("{stem}.y{i}u{j}.{ext}"))
}

/// `fts convert`.
pub fn run_convert(args: ConvertArgs) -> anyhow::Result<()> {
    let step = Convert { to: args.to };
    step.validate().map_err(step_error)?;
    let source = args.input.display().to_string();
    let model = read_loop_system(&args.input)?;
    let report = step.run(&model, &source).map_err(step_error)?;
    if let Some(out) = &args.output {
        match &report {
            ConvertReport::Ss(sys) => write_atomic(out, ss_json::ss_to_string(sys).as_bytes())?,
            ConvertReport::Tf(tfs) => {
                let siso = tfs.len() == 1 && tfs[0].len() == 1;
                for (i, row) in tfs.iter().enumerate() {
                    for (j, t) in row.iter().enumerate() {
                        let Some(t) = t else {
                            if siso {
                                return Err(bad(format!(
                                    "{source}: the transfer function is identically zero; fts.tf/1 has no zero model"
                                )));
                            }
                            continue;
                        };
                        let path = if siso {
                            out.clone()
                        } else {
                            channel_path(out, i + 1, j + 1)
                        };
                        write_atomic(&path, tf_json::tf_to_string(t).as_bytes())?;
                    }
                }
            }
        }
    }
    print_report(&report, args.json)
}

/// `fts zpk`.
pub fn run_zpk(args: ZpkArgs) -> anyhow::Result<()> {
    let source = args.input.display().to_string();
    let model = read_loop_system(&args.input)?;
    let report = ZpkStep {}.run(&model, &source).map_err(step_error)?;
    print_report(&report, args.json)
}

/// `fts minreal`.
pub fn run_minreal(args: MinrealArgs) -> anyhow::Result<()> {
    let step = Minreal { tol: args.tol };
    step.validate().map_err(step_error)?;
    let source = args.input.display().to_string();
    let model = read_loop_system(&args.input)?;
    let report = step.run(&model, &source).map_err(step_error)?;
    if let Some(out) = &args.output {
        let text = match &report.tf {
            Some(t) => tf_json::tf_to_string(t),
            None => ss_json::ss_to_string(&report.system),
        };
        write_atomic(out, text.as_bytes())?;
    }
    print_report(&report, args.json)
}

/// `fts balred`.
pub fn run_balred(args: BalredArgs) -> anyhow::Result<()> {
    let step = Balred {
        order: Some(args.order),
        allow_degradation: args.allow_degradation,
    };
    step.validate().map_err(step_error)?;
    let source = args.input.display().to_string();
    let model = read_loop_system(&args.input)?;
    let report = step.run(&model, &source).map_err(step_error)?;
    if let Some(out) = &args.output {
        write_atomic(out, ss_json::ss_to_string(&report.system).as_bytes())?;
    }
    print_report(&report, args.json)
}

/// `fts d2c`.
pub fn run_d2c(args: D2cArgs) -> anyhow::Result<()> {
    let source = args.input.display().to_string();
    let model = read_loop_system(&args.input)?;
    let report = D2c {}.run(&model, &source).map_err(step_error)?;
    if let Some(out) = &args.output {
        write_atomic(out, ss_json::ss_to_string(&report.system).as_bytes())?;
    }
    print_report(&report, args.json)
}
