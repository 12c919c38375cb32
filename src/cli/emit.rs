//! `fts emit [--hysteresis inv.json] [--zpetc zpetc.json | --closed-loop cl.json]
//! (--pid-form parallel|li21 --kp KP --ki KI --kd KD [--pid-n N] | --ss K.json
//! [--c2d zoh|tustin] [--prewarp HZ] | --feedback none)
//! [--format json|c-header|c] [--c-header controller.h] -o controller.json`:
//! writes the `fts.controller/1` coefficient file (or its C header, or the
//! C runtime beside it) that a real-time loop consumes, with the SHA-256 of
//! every input file. The feedback controller is the one asked for and no
//! other: the PID (continuous parallel gains, discretised, or per-sample
//! \[Li21\] gains), a state-space controller (`fts.ss/1`, e.g. from
//! `fts mixsyn`, discretised at the loop's sample time when continuous), or
//! none (feedforward only).

use super::common::{bad, choice, name, read_input, remark, step_error, write_atomic};
use crate::ident::hysteresis::HysteresisModel;
use crate::io::controller_file::to_c_files;
use crate::io::controller_file::{
    C_RUNTIME_C, C_RUNTIME_H, parse_multiaxis, to_multiaxis_c_header,
};
use crate::io::controller_file::{ControllerFile, InputHash, Provenance, sha256_hex, to_c_header};
use crate::io::{hysteresis_json, zpetc_json};
use crate::lti::ss::StateSpace;
use crate::synth::zpetc::Zpetc;
use crate::workflow::controller::closed_loop_zpetc;
use crate::workflow::learning::RepetitiveFile;
use crate::workflow::{
    AntiWindup, BuildController, BuildInputs, Discretisation, NoFeedback, PidForm, SsController,
};
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// `fts.controller/1` JSON.
    Json,
    /// A C header with the same numbers.
    CHeader,
    /// The C runtime: `fts_controller.h` (numbers and loader),
    /// `fts_runtime.h` and `fts_runtime.c`, written into the -o directory.
    C,
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
    #[arg(long, value_parser = choice::<Discretisation>(), default_value = name(SsController::default().c2d), requires = "ss")]
    pub c2d: Discretisation,
    /// Tustin prewarp frequency, Hz (--c2d tustin only).
    #[arg(long, value_name = "HZ", requires = "ss")]
    pub prewarp: Option<f64>,
    /// What the state-space controller's states do while the command is saturated.
    #[arg(long, value_parser = choice::<AntiWindup>(), default_value = name(SsController::default().ss_anti_windup), requires = "ss")]
    pub ss_anti_windup: AntiWindup,
}

impl SsArgs {
    /// The library step these flags stand for (limits `output_min`/`output_max`).
    pub fn step(&self, limits: (Option<f64>, Option<f64>)) -> SsController {
        SsController {
            ts: None,
            c2d: self.c2d,
            prewarp: self.prewarp,
            ss_anti_windup: self.ss_anti_windup,
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
    /// Which form the PID gains are in (required with --kp/--ki/--kd).
    #[arg(long, value_parser = choice::<PidForm>(), conflicts_with = "ss")]
    pid_form: Option<PidForm>,
    /// PID proportional gain.
    #[arg(long, allow_hyphen_values = true)]
    kp: Option<f64>,
    /// PID integral gain: 1/s (--pid-form parallel) or per sample (li21). Default 0.
    #[arg(long, allow_hyphen_values = true)]
    ki: Option<f64>,
    /// PID derivative gain on the measurement: s (parallel) or per sample (li21). Default 0.
    #[arg(long, allow_hyphen_values = true)]
    kd: Option<f64>,
    /// Derivative filter bandwidth N, rad/s: Kd N s/(s + N) (--pid-form parallel only).
    #[arg(long, value_name = "N", conflicts_with = "ss")]
    pid_n: Option<f64>,
    /// `none`: no feedback controller (a feedforward-only file).
    #[arg(long, value_parser = choice::<NoFeedback>(), conflicts_with_all = ["kp", "ki", "kd", "pid_form", "pid_n", "ss"])]
    feedback: Option<NoFeedback>,
    #[command(flatten)]
    ss: SsArgs,
    /// Lowest command, V (PID default 0; a state-space controller has no limit unless given).
    #[arg(long, allow_hyphen_values = true)]
    output_min: Option<f64>,
    /// Highest command, V (PID default 10; a state-space controller has no limit unless given).
    #[arg(long, allow_hyphen_values = true)]
    output_max: Option<f64>,
    /// Plug-in repetitive compensator (`fts.repetitive/1`, from `fts repetitive`) added to the file; designed at the controller's sample time.
    #[arg(long, value_name = "RC.json")]
    repetitive: Option<PathBuf>,
    /// Sample time, s (taken from the ZPETC, closed-loop model or discrete --ss controller when given; they must agree).
    #[arg(long)]
    ts: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    format: Format,
    /// Also write the C header here (with --format json and -o).
    #[arg(long, value_name = "CONTROLLER.h", requires = "output")]
    c_header: Option<PathBuf>,
    /// Write here (default: stdout); a directory with --format c.
    #[arg(short = 'o', long = "out", value_name = "CONTROLLER.json")]
    output: Option<PathBuf>,
    /// A multi-axis controller file (`fts.multiaxis-controller/1`, from
    /// `fts contour -o`) to write again as JSON, as a C header or as the C
    /// runtime (`fts_multiaxis.h` + `fts_runtime.{h,c}`).
    #[arg(long, value_name = "K3.json", conflicts_with_all = [
        "hysteresis", "zpetc", "closed_loop", "pid_form", "kp", "ki", "kd", "pid_n",
        "feedback", "ss", "output_min", "output_max", "repetitive", "ts", "c_header",
    ])]
    multiaxis: Option<PathBuf>,
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

/// The library step these flags stand for.
fn step(args: &EmitArgs) -> BuildController {
    let ss = args.ss.step((args.output_min, args.output_max));
    BuildController {
        pid_form: args.pid_form,
        kp: args.kp,
        ki: args.ki,
        kd: args.kd,
        pid_n: args.pid_n,
        feedback: args.feedback,
        ts: args.ts,
        c2d: ss.c2d,
        prewarp: ss.prewarp,
        ss_anti_windup: ss.ss_anti_windup,
        output_min: args.output_min,
        output_max: args.output_max,
    }
}

/// The inverse hysteresis model of `--hysteresis`, warning when its output
/// is not the command's unit.
fn read_inverse(path: &Path, inputs: &mut Vec<InputHash>) -> anyhow::Result<HysteresisModel> {
    let (text, source) = hashed(path, "hysteresis_inverse", inputs)?;
    let file = hysteresis_json::parse_model(&text, &source)?;
    if file.output.unit != "V" && !file.output.unit.is_empty() {
        note!(
            "warning: {source}: the model's output unit is {:?}; the HC feedforward is added to a command in V",
            file.output.unit
        );
    }
    Ok(file.model)
}

/// The ZPETC of `--zpetc`, or built from `--closed-loop`.
fn read_filter(args: &EmitArgs, inputs: &mut Vec<InputHash>) -> anyhow::Result<Option<Zpetc>> {
    if let Some(p) = &args.zpetc {
        let (text, source) = hashed(p, "zpetc", inputs)?;
        Ok(Some(zpetc_json::parse_zpetc(&text, &source)?))
    } else if let Some(p) = &args.closed_loop {
        let (text, source) = hashed(p, "closed_loop", inputs)?;
        let model = super::common::parse_tf(&text, &source)?;
        Ok(Some(
            closed_loop_zpetc(&model, &source).map_err(step_error)?,
        ))
    } else {
        Ok(None)
    }
}

/// Warns when a continuous controller has poles no discretisation at `ts`
/// reproduces.
fn warn_fast_poles(sys: &StateSpace, ts: f64, source: &str) {
    let fast = SsController::poles_beyond_nyquist(sys, ts);
    if let Some((pole, hz)) = fast.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
        note!(
            "warning: {source}: {} continuous pole(s) beyond the Nyquist frequency {} Hz of ts = {ts} s, the fastest {}{:+}j rad/s ({hz:.4e} Hz); the discretised controller does not reproduce them: sample faster or reduce the controller",
            fast.len(),
            0.5 / ts,
            pole.re,
            pole.im
        );
    }
}

/// Builds the coefficient file from the arguments: every input read once
/// (and hashed), then the library step.
pub fn build(args: &EmitArgs) -> anyhow::Result<ControllerFile> {
    let mut inputs = Vec::new();
    let inverse = match &args.hysteresis {
        Some(p) => Some(read_inverse(p, &mut inputs)?),
        None => None,
    };
    let filter = read_filter(args, &mut inputs)?;
    let ss = match &args.ss.ss {
        Some(p) => {
            let (text, source) = hashed(p, "state_space", &mut inputs)?;
            Some((crate::io::ss_json::parse_system(&text, &source)?, source))
        }
        None => None,
    };
    let repetitive = match &args.repetitive {
        Some(p) => {
            let (text, source) = hashed(p, "repetitive", &mut inputs)?;
            Some((
                RepetitiveFile::parse(&text, &source).map_err(step_error)?,
                source,
            ))
        }
        None => None,
    };
    let report = step(args)
        .run(BuildInputs {
            hysteresis: inverse.as_ref(),
            zpetc: filter.as_ref(),
            ss: ss.as_ref().map(|(sys, source)| (sys, source.as_str())),
            repetitive: repetitive.as_ref().map(|(f, source)| (f, source.as_str())),
            provenance: Provenance {
                fts_version: env!("CARGO_PKG_VERSION").into(),
                inputs,
            },
        })
        .map_err(step_error)?;
    if let Some((sys, source)) = &ss {
        warn_fast_poles(sys, report.file.ts, source);
    }
    Ok(report.file)
}

pub fn run(args: EmitArgs) -> anyhow::Result<()> {
    if let Some(path) = &args.multiaxis {
        return run_multiaxis(&args, path);
    }
    let file = build(&args)?;
    let text = match args.format {
        Format::Json => file.to_json_string(),
        Format::CHeader => to_c_header(&file),
        Format::C => return write_c_runtime(&args, &file),
    };
    if let Some(h) = &args.c_header {
        if args.format != Format::Json {
            return Err(bad("--c-header goes with --format json"));
        }
        write_atomic(h, to_c_header(&file).as_bytes())?;
    }
    match &args.output {
        Some(path) => {
            write_atomic(path, text.as_bytes())?;
            remark(path, describe(&file));
        }
        None => say_part!("{text}"),
    }
    Ok(())
}

/// `--multiaxis`: the file read and checked, then written in `--format`.
fn run_multiaxis(args: &EmitArgs, path: &Path) -> anyhow::Result<()> {
    let source = path.display().to_string();
    let file = parse_multiaxis(&read_input(path)?, &source)?;
    let text = match args.format {
        Format::Json => file.to_json_string(),
        Format::CHeader => to_multiaxis_c_header(&file),
        Format::C => {
            let dir = output_dir(args)?;
            let files = [
                ("fts_multiaxis.h", to_multiaxis_c_header(&file)),
                ("fts_runtime.h", C_RUNTIME_H.to_owned()),
                ("fts_runtime.c", C_RUNTIME_C.to_owned()),
            ];
            for (name, text) in files {
                write_atomic(&dir.join(name), text.as_bytes())?;
            }
            remark(
                &dir.join("fts_runtime.c"),
                format!("ts {} s; compile with -ffp-contract=off", file.ts),
            );
            return Ok(());
        }
    };
    match &args.output {
        Some(out) => {
            write_atomic(out, text.as_bytes())?;
            remark(out, format!("three axes, ts {} s", file.ts));
        }
        None => say_part!("{text}"),
    }
    Ok(())
}

/// The -o directory of `--format c`, created if missing.
fn output_dir(args: &EmitArgs) -> anyhow::Result<&Path> {
    let Some(dir) = &args.output else {
        return Err(bad(
            "-o/--out: --format c writes three files; give the directory to write them into",
        ));
    };
    if dir.exists() && !dir.is_dir() {
        return Err(bad(format!(
            "-o/--out: {} is a file; --format c writes into a directory",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("{}: cannot create the directory: {e}", dir.display()))?;
    Ok(dir)
}

/// `--format c`: the three C files into the -o directory (created if
/// missing), each written atomically.
fn write_c_runtime(args: &EmitArgs, file: &ControllerFile) -> anyhow::Result<()> {
    // A missing -o is output_dir's error first; nothing is created before
    // the --c-header check.
    if args.output.is_some() && args.c_header.is_some() {
        return Err(bad("--c-header goes with --format json"));
    }
    let dir = output_dir(args)?;
    for (name, text) in to_c_files(file) {
        write_atomic(&dir.join(name), text.as_bytes())?;
    }
    remark(
        &dir.join("fts_runtime.c"),
        format!("{}; compile with -ffp-contract=off", describe(file)),
    );
    Ok(())
}

/// What a written controller file holds, for its `fts: wrote` line.
fn describe(file: &ControllerFile) -> String {
    format!(
        "{}, preview {} samples, ts {} s",
        file.stages_name(),
        file.preview(),
        file.ts
    )
}
