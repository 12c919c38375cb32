//! `fts emit [--hysteresis inv.json] [--zpetc zpetc.json | --closed-loop cl.json]
//! --kp KP --ki KI --kd KD [--format json|c-header] -o controller.json`:
//! writes the `fts.controller/1` coefficient file (or its C header) that a
//! real-time loop consumes, with the SHA-256 of every input file.

use super::common::{bad, read_input, write_atomic};
use crate::io::controller_file::{ControllerFile, InputHash, Provenance, sha256_hex, to_c_header};
use crate::io::{hysteresis_json, tf_json, zpetc_json};
use crate::lti::TransferFunction;
use crate::runtime::PidSpec;
use crate::sim::experiment::build_controller;
use crate::synth::composite::Stages;
use crate::synth::zpetc::{self, ZpetcParams};
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// `fts.controller/1` JSON.
    Json,
    /// A C header with the same numbers.
    CHeader,
}

#[derive(Debug, Args)]
pub struct EmitArgs {
    /// Inverse hysteresis model for the HC feedforward (`fts.hysteresis/1`).
    #[arg(long, value_name = "INV.json")]
    hysteresis: Option<PathBuf>,
    /// ZPETC filter (`fts.zpetc/1`).
    #[arg(long, value_name = "ZPETC.json", conflicts_with = "closed_loop")]
    zpetc: Option<PathBuf>,
    /// Closed-loop model (`fts.tf/1`) to build the ZPETC from, with default settings.
    #[arg(long, value_name = "CL.json")]
    closed_loop: Option<PathBuf>,
    /// PID proportional gain.
    #[arg(long, default_value_t = crate::sim::experiment::DEFAULT_PID.kp, allow_hyphen_values = true)]
    kp: f64,
    /// PID integral gain per sample.
    #[arg(long, default_value_t = crate::sim::experiment::DEFAULT_PID.ki, allow_hyphen_values = true)]
    ki: f64,
    /// PID derivative gain per sample (on the measurement).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    kd: f64,
    /// Lowest command, V.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    output_min: f64,
    /// Highest command, V.
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    output_max: f64,
    /// Sample time, s (taken from the ZPETC or closed-loop model when given; they must agree).
    #[arg(long)]
    ts: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    format: Format,
    /// Write here (default: stdout).
    #[arg(
        short = 'o',
        long = "out",
        visible_alias = "output",
        value_name = "CONTROLLER.json"
    )]
    output: Option<PathBuf>,
}

/// Reads an input and records its hash under `role`.
fn hashed(
    path: &Path,
    role: &str,
    inputs: &mut Vec<InputHash>,
) -> anyhow::Result<(String, String)> {
    let text = read_input(path)?;
    inputs.push(InputHash {
        role: role.into(),
        file: path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default(),
        sha256: sha256_hex(text.as_bytes()),
    });
    Ok((text, path.display().to_string()))
}

/// Builds the coefficient file from the arguments.
pub fn build(args: &EmitArgs) -> anyhow::Result<ControllerFile> {
    let mut inputs = Vec::new();
    let inverse = match &args.hysteresis {
        Some(p) => {
            let (text, source) = hashed(p, "hysteresis_inverse", &mut inputs)?;
            let file = hysteresis_json::parse_model(&text, &source)?;
            if file.output.unit != "V" && !file.output.unit.is_empty() {
                eprintln!(
                    "warning: {source}: the model's output unit is {:?}; the HC feedforward is added to a command in V",
                    file.output.unit
                );
            }
            Some(file.model)
        }
        None => None,
    };
    let filter = if let Some(p) = &args.zpetc {
        let (text, source) = hashed(p, "zpetc", &mut inputs)?;
        Some(zpetc_json::parse_zpetc(&text, &source)?)
    } else if let Some(p) = &args.closed_loop {
        let (text, source) = hashed(p, "closed_loop", &mut inputs)?;
        let TransferFunction::Discrete(g) = tf_json::parse_tf(&text, &source)? else {
            return Err(bad(format!(
                "{source} field 'var': the closed-loop model must be discrete"
            )));
        };
        Some(
            zpetc::design(&g, &ZpetcParams::default())
                .map_err(|e| bad(format!("{source}: {e}")))?,
        )
    } else {
        None
    };
    let ts = match (filter.as_ref().map(|f| f.ts), args.ts) {
        (Some(a), Some(b)) if (a - b).abs() > 1e-12 * a => {
            return Err(bad(format!(
                "--ts {b} disagrees with the ZPETC's sample time {a}"
            )));
        }
        (Some(a), _) => a,
        (None, Some(b)) => b,
        (None, None) => {
            return Err(bad(
                "--ts: the sample time is needed when no ZPETC or closed-loop model is given",
            ));
        }
    };
    if !(ts.is_finite() && ts > 0.0) {
        return Err(bad(format!(
            "--ts: expected a positive number of seconds, got {ts}"
        )));
    }
    let stages = Stages {
        hysteresis_compensation: inverse.is_some(),
        zpetc: filter.is_some(),
    };
    let pid = PidSpec {
        kp: args.kp,
        ki: args.ki,
        kd: args.kd,
        output_min: args.output_min,
        output_max: args.output_max,
    };
    build_controller(
        stages,
        ts,
        pid,
        inverse.as_ref(),
        filter.as_ref(),
        Provenance {
            fts_version: env!("CARGO_PKG_VERSION").into(),
            inputs,
        },
    )
    .map_err(bad)
}

pub fn run(args: EmitArgs) -> anyhow::Result<()> {
    let file = build(&args)?;
    let text = match args.format {
        Format::Json => file.to_json_string(),
        Format::CHeader => to_c_header(&file),
    };
    match &args.output {
        Some(path) => {
            write_atomic(path, text.as_bytes())?;
            eprintln!(
                "wrote {} ({}, preview {} samples, ts {} s)",
                path.display(),
                file.stages_name(),
                file.preview(),
                file.ts
            );
        }
        None => print!("{text}"),
    }
    Ok(())
}
