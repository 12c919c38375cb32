//! `fts virtual triangles|sweep ... [-o OUT.csv]`: records of the embedded
//! virtual FTS as `t,u,y` CSV, the manifest's `virtual-triangles` and
//! `virtual-sweep` steps: open-loop triangles (command V, displacement um,
//! aligned for the plant's delay) and the closed-loop sweep with the PID
//! (+ HC with `--hysteresis`; filtered reference and measurement, um).

use super::common::{read_input, remark, step_error, write_atomic};
use crate::io::hysteresis_json;
use crate::workflow::{VirtualRecord, VirtualSweep, VirtualTriangles};
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};

#[derive(Debug, Subcommand)]
pub enum VirtualCommand {
    /// Open-loop triangle waves: command (V) and displacement (um), aligned for the plant's delay.
    Triangles(TrianglesArgs),
    /// Closed-loop 0..f1 sweep with the Li21 PID (+ HC with --hysteresis): filtered reference and measurement (um).
    Sweep(SweepArgs),
}

#[derive(Debug, Args)]
pub struct TrianglesArgs {
    /// Noise seed of the virtual FTS.
    #[arg(long, default_value_t = VirtualTriangles::default().seed)]
    seed: u64,
    /// Peak amplitudes of the command, V, played in order.
    #[arg(long, value_delimiter = ',', default_values_t = VirtualTriangles::default().amplitudes)]
    amplitudes: Vec<f64>,
    /// Triangle frequencies, Hz, played in order (all amplitudes at each).
    #[arg(long, value_delimiter = ',', default_values_t = VirtualTriangles::default().freq)]
    freq: Vec<f64>,
    /// Rate dependence of the plant's loop: alpha (1 + c |dv/dt| / ref); 0 = rate independent.
    #[arg(long, value_name = "C", default_value_t = VirtualTriangles::default().rate_coefficient, allow_hyphen_values = true)]
    rate_coefficient: f64,
    /// Reference voltage rate of the rate dependence, V/s (amplifier output).
    #[arg(long, value_name = "V/S", default_value_t = VirtualTriangles::default().rate_reference, allow_hyphen_values = true)]
    rate_reference: f64,
    /// Write the `t,u,y` CSV here (default: stdout).
    #[arg(short = 'o', long = "out", value_name = "OUT.csv")]
    output: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Inverse hysteresis model for the HC feedforward (`fts.hysteresis/1`); without it, PID alone.
    #[arg(long, value_name = "INV.json")]
    hysteresis: Option<PathBuf>,
    /// Noise seed of the virtual FTS.
    #[arg(long, default_value_t = VirtualSweep::default().seed)]
    seed: u64,
    /// PID proportional gain, V/um.
    #[arg(long, default_value_t = VirtualSweep::default().kp, allow_hyphen_values = true)]
    kp: f64,
    /// PID integral gain, V/um per sample.
    #[arg(long, default_value_t = VirtualSweep::default().ki, allow_hyphen_values = true)]
    ki: f64,
    /// PID derivative gain, V/um per sample.
    #[arg(long, default_value_t = VirtualSweep::default().kd, allow_hyphen_values = true)]
    kd: f64,
    /// Lowest command, V.
    #[arg(long, default_value_t = VirtualSweep::default().output_min, allow_hyphen_values = true)]
    output_min: f64,
    /// Highest command, V.
    #[arg(long, default_value_t = VirtualSweep::default().output_max, allow_hyphen_values = true)]
    output_max: f64,
    /// Sweep amplitude, um.
    #[arg(long, default_value_t = VirtualSweep::default().amplitude)]
    amplitude: f64,
    /// Centre of the sweep, um.
    #[arg(long, default_value_t = VirtualSweep::default().offset, allow_hyphen_values = true)]
    offset: f64,
    /// Sweep length, s.
    #[arg(long, default_value_t = VirtualSweep::default().duration)]
    duration: f64,
    /// Highest sweep frequency, Hz.
    #[arg(long, default_value_t = VirtualSweep::default().f1)]
    f1: f64,
    /// Write the `t,u,y` CSV here (default: stdout).
    #[arg(short = 'o', long = "out", value_name = "OUT.csv")]
    output: Option<PathBuf>,
}

pub fn run(cmd: VirtualCommand) -> anyhow::Result<()> {
    match cmd {
        VirtualCommand::Triangles(args) => {
            let step = VirtualTriangles {
                seed: args.seed,
                amplitudes: args.amplitudes,
                freq: args.freq,
                rate_coefficient: args.rate_coefficient,
                rate_reference: args.rate_reference,
            };
            write_record(&step.run().map_err(step_error)?, args.output.as_deref())
        }
        VirtualCommand::Sweep(args) => sweep(args),
    }
}

fn sweep(args: SweepArgs) -> anyhow::Result<()> {
    let step = VirtualSweep {
        seed: args.seed,
        kp: args.kp,
        ki: args.ki,
        kd: args.kd,
        output_min: args.output_min,
        output_max: args.output_max,
        amplitude: args.amplitude,
        offset: args.offset,
        duration: args.duration,
        f1: args.f1,
    };
    let model = match &args.hysteresis {
        Some(path) => {
            let text = read_input(path)?;
            Some(hysteresis_json::parse_model(&text, &path.display().to_string())?.model)
        }
        None => None,
    };
    let record = step.run(model.as_ref()).map_err(step_error)?;
    write_record(&record, args.output.as_deref())
}

/// The CSV to `path`, or to stdout.
fn write_record(record: &VirtualRecord, path: Option<&Path>) -> anyhow::Result<()> {
    let text = record.to_csv();
    match path {
        Some(path) => {
            write_atomic(path, text.as_bytes())?;
            remark(
                path,
                format!("{} samples, ts = {} s", record.u.len(), record.ts),
            );
            Ok(())
        }
        None => {
            say_part!("{text}");
            Ok(())
        }
    }
}
