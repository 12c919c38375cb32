//! `fts emit [--hysteresis inv.json] [--zpetc zpetc.json | --closed-loop cl.json]
//! (--kp KP --ki KI --kd KD | --ss K.json [--c2d zoh|tustin] [--prewarp HZ])
//! [--format json|c-header] [--c-header controller.h] -o controller.json`:
//! writes the `fts.controller/1` coefficient file (or its C header) that a
//! real-time loop consumes, with the SHA-256 of every input file. The
//! feedback controller is the PID, or a state-space controller (`fts.ss/1`,
//! e.g. from `fts mixsyn`), discretised at the loop's sample time when it is
//! continuous.

use super::common::{bad, read_input, step_error, write_atomic};
use crate::io::controller_file::{ControllerFile, InputHash, Provenance, sha256_hex, to_c_header};
use crate::io::controller_file::{Feedback, StateSpaceBlock};
use crate::io::{hysteresis_json, tf_json, zpetc_json};
use crate::lti::TransferFunction;
use crate::runtime::PidSpec;
use crate::sim::experiment::build_controller;
use crate::synth::composite::{FeedbackKind, Stages};
use crate::synth::zpetc::{self, ZpetcParams};
use crate::workflow::{AntiWindup, Discretisation, SsController};
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// `fts.controller/1` JSON.
    Json,
    /// A C header with the same numbers.
    CHeader,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum C2dChoice {
    /// Tustin (bilinear), optionally prewarped.
    Tustin,
    /// Zero-order hold.
    Zoh,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AntiWindupChoice {
    /// Hold the states while the command is saturated and their update
    /// would push it further out.
    ConditionalUpdate,
    /// Clamp the command only.
    None,
}

/// A state-space feedback controller given as a file (shared by `fts emit`
/// and `fts simulate`).
#[derive(Debug, Args)]
pub struct SsArgs {
    /// State-space feedback controller (`fts.ss/1` or `fts.tf/1`, SISO, error in,
    /// command out, u = K (r - y)) instead of the PID, e.g. from `fts mixsyn`.
    #[arg(long, value_name = "K.json", conflicts_with_all = ["kp", "ki", "kd"])]
    pub ss: Option<PathBuf>,
    /// How a continuous --ss controller is discretised at the loop's sample time.
    #[arg(long, value_enum, default_value_t = C2dChoice::Tustin, requires = "ss")]
    pub c2d: C2dChoice,
    /// Tustin prewarp frequency, Hz (--c2d tustin only).
    #[arg(long, value_name = "HZ", requires = "ss")]
    pub prewarp: Option<f64>,
    /// What the state-space controller's states do while the command is saturated.
    #[arg(long, value_enum, default_value_t = AntiWindupChoice::ConditionalUpdate, requires = "ss")]
    pub ss_anti_windup: AntiWindupChoice,
}

/// The sample time of a discrete `--ss` controller, if it is one.
pub fn ss_sample_time(args: &SsArgs) -> anyhow::Result<Option<f64>> {
    match &args.ss {
        Some(p) => Ok(super::robust::read_system(p)?.ts),
        None => Ok(None),
    }
}

/// Reads `--ss`, discretises it at `ts` when continuous, and makes the block
/// (limits `output_min`/`output_max`, `None` for none). The file's hash goes in `inputs`.
pub fn read_ss_block(
    args: &SsArgs,
    path: &Path,
    ts: f64,
    limits: (Option<f64>, Option<f64>),
    inputs: &mut Vec<InputHash>,
) -> anyhow::Result<StateSpaceBlock> {
    let (text, source) = hashed(path, "state_space", inputs)?;
    let sys = crate::io::ss_json::parse_system(&text, &source)?;
    let block = args
        .step(limits)
        .block(&sys, ts, &source)
        .map_err(step_error)?;
    let fast = SsController::poles_beyond_nyquist(&sys, ts);
    if let Some((pole, hz)) = fast.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
        eprintln!(
            "warning: {source}: {} continuous pole(s) beyond the Nyquist frequency {} Hz of ts = {ts} s, the fastest {}{:+}j rad/s ({hz:.4e} Hz); the discretised controller does not reproduce them: sample faster or reduce the controller",
            fast.len(),
            0.5 / ts,
            pole.re,
            pole.im
        );
    }
    Ok(block)
}

impl SsArgs {
    /// The library step these flags stand for (limits `output_min`/`output_max`).
    pub fn step(&self, limits: (Option<f64>, Option<f64>)) -> SsController {
        SsController {
            ts: None,
            c2d: match self.c2d {
                C2dChoice::Tustin => Discretisation::Tustin,
                C2dChoice::Zoh => Discretisation::Zoh,
            },
            prewarp: self.prewarp,
            ss_anti_windup: match self.ss_anti_windup {
                AntiWindupChoice::ConditionalUpdate => AntiWindup::ConditionalUpdate,
                AntiWindupChoice::None => AntiWindup::None,
            },
            output_min: limits.0,
            output_max: limits.1,
        }
    }
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
    #[command(flatten)]
    ss: SsArgs,
    /// Lowest command, V (PID default 0; a state-space controller has no limit unless given).
    #[arg(long, allow_hyphen_values = true)]
    output_min: Option<f64>,
    /// Highest command, V (PID default 10; a state-space controller has no limit unless given).
    #[arg(long, allow_hyphen_values = true)]
    output_max: Option<f64>,
    /// Sample time, s (taken from the ZPETC, closed-loop model or discrete --ss controller when given; they must agree).
    #[arg(long)]
    ts: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    format: Format,
    /// Also write the C header here (with --format json and -o).
    #[arg(long, value_name = "CONTROLLER.h", requires = "output")]
    c_header: Option<PathBuf>,
    /// Write here (default: stdout).
    #[arg(short = 'o', long = "out", value_name = "CONTROLLER.json")]
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
    let mut ts = filter.as_ref().map(|f| f.ts);
    let mut ts_from = "the ZPETC's";
    for (candidate, name) in [
        (args.ts, "--ts"),
        (ss_sample_time(&args.ss)?, "the --ss controller's"),
    ] {
        match (ts, candidate) {
            (Some(a), Some(b)) if (a - b).abs() > 1e-12 * a => {
                return Err(bad(format!(
                    "{name} sample time {b} s disagrees with {ts_from} {a} s"
                )));
            }
            (None, Some(b)) => {
                ts = Some(b);
                ts_from = name;
            }
            _ => {}
        }
    }
    let Some(ts) = ts else {
        return Err(bad(
            "--ts: the sample time is needed when no ZPETC, closed-loop model or discrete controller is given",
        ));
    };
    if !(ts.is_finite() && ts > 0.0) {
        return Err(bad(format!(
            "--ts: expected a positive number of seconds, got {ts}"
        )));
    }
    let (feedback, kind) = match &args.ss.ss {
        Some(path) => (
            Feedback::StateSpace(read_ss_block(
                &args.ss,
                path,
                ts,
                (args.output_min, args.output_max),
                &mut inputs,
            )?),
            FeedbackKind::StateSpace,
        ),
        None => (Feedback::Pid(pid_from_flags(args)?), FeedbackKind::Pid),
    };
    let stages = Stages {
        feedback: kind,
        hysteresis_compensation: inverse.is_some(),
        zpetc: filter.is_some(),
    };
    build_controller(
        stages,
        ts,
        feedback,
        inverse.as_ref(),
        filter.as_ref(),
        Provenance {
            fts_version: env!("CARGO_PKG_VERSION").into(),
            inputs,
        },
    )
    .map_err(bad)
}

/// The PID block from its flags, each checked where it is named: the gains
/// finite, the limits finite and ordered.
fn pid_from_flags(args: &EmitArgs) -> anyhow::Result<PidSpec> {
    for (name, value) in [("--kp", args.kp), ("--ki", args.ki), ("--kd", args.kd)] {
        if !value.is_finite() {
            return Err(bad(format!("{name}: expected a finite gain, got {value}")));
        }
    }
    let (lo, hi) = (
        args.output_min.unwrap_or(0.0),
        args.output_max.unwrap_or(10.0),
    );
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(bad(format!(
            "--output-min/--output-max: expected finite limits with min < max, got {lo} and {hi}"
        )));
    }
    Ok(PidSpec {
        kp: args.kp,
        ki: args.ki,
        kd: args.kd,
        output_min: lo,
        output_max: hi,
    })
}

pub fn run(args: EmitArgs) -> anyhow::Result<()> {
    let file = build(&args)?;
    let text = match args.format {
        Format::Json => file.to_json_string(),
        Format::CHeader => to_c_header(&file),
    };
    if let Some(h) = &args.c_header {
        if args.format != Format::Json {
            return Err(bad("--c-header goes with --format json"));
        }
        write_atomic(h, to_c_header(&file).as_bytes())?;
        eprintln!("wrote {}", h.display());
    }
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
        None => say_part!("{text}"),
    }
    Ok(())
}
