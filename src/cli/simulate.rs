//! `fts simulate --controller pid|pid+hc|pid+zpec|pid+hc+zpec|ss[+hc][+zpec] [--ss K.json] [--reference ...]`:
//! a closed-loop tracking run through the runtime controller step, fed by the
//! coefficient file fts emits (`--controller-file`) or by one built from the
//! arguments exactly as `fts emit` builds it.

use super::common::{bad, print_json, read_input, write_atomic};
use crate::io::controller_file::{ControllerFile, Feedback, Provenance, parse_controller};
use crate::io::{hysteresis_json, plot, tf_json, zpetc_json};
use crate::lti::{DiscreteTf, TransferFunction};
use crate::runtime::{PidSpec, RuntimeController};
use crate::sim::experiment::{self, ExperimentParams};
use crate::sim::reference::{self, Reference, ReferenceTiming};
use crate::sim::virtual_fts::{VirtualFts, VirtualFtsParams};
use crate::sim::{ModelPlant, Plant, closed_loop};
use crate::synth::composite::{FeedbackKind, Stages};
use crate::synth::zpetc::{self as zpetc_mod, Zpetc, ZpetcParams};
use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ReferenceKind {
    Sine,
    Sweep,
    FiveLeaf,
    /// A step of --amplitude from --offset at --step-time, with rise/settling time and overshoot.
    Step,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Controller stages: pid, pid+hc, pid+zpec, pid+hc+zpec, or ss, ss+hc, ss+zpec, ss+hc+zpec
    /// with --ss (default: pid+hc+zpec, or ss with --ss).
    #[arg(long)]
    controller: Option<String>,
    #[command(flatten)]
    ss: super::emit::SsArgs,
    /// Lowest command of a --ss controller, V (default: the virtual FTS amplifier's; none with --plant-tf).
    #[arg(long, allow_hyphen_values = true, requires = "ss")]
    output_min: Option<f64>,
    /// Highest command of a --ss controller, V (default: the virtual FTS amplifier's; none with --plant-tf).
    #[arg(long, allow_hyphen_values = true, requires = "ss")]
    output_max: Option<f64>,
    /// Reference trajectory.
    #[arg(long, value_enum, default_value_t = ReferenceKind::Sine)]
    reference: ReferenceKind,
    /// Reference samples from a CSV instead (column `r`, or `--reference-column`), at the controller rate.
    #[arg(long, value_name = "REF.csv", conflicts_with = "reference")]
    reference_file: Option<PathBuf>,
    /// Column of --reference-file (header name or 1-based index).
    #[arg(long, default_value = "r")]
    reference_column: String,
    /// Amplitude of the sine or sweep, um.
    #[arg(long, default_value_t = 5.0)]
    amplitude: f64,
    /// Sine frequency, Hz.
    #[arg(long, default_value_t = 100.0)]
    freq: f64,
    /// Sweep end frequency, Hz.
    #[arg(long, default_value_t = 1000.0)]
    f1: f64,
    /// Centre of the reference, um (mid-stroke of the embedded plant).
    #[arg(long, default_value_t = 7.0, allow_hyphen_values = true)]
    offset: f64,
    /// Length of the reference, s (default: sine 20 periods and at least 0.2 s; sweep 2 s; five-leaf 1 s; step 0.1 s).
    #[arg(long)]
    duration: Option<f64>,
    /// Time of the step into the evaluated part, s (--reference step).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.01)]
    step_time: f64,
    /// Scale of the five-leaved trajectory (Eq. 13 as printed spans +-50 um).
    #[arg(long, default_value_t = 0.1, allow_hyphen_values = true)]
    scale: f64,
    /// Virtual FTS parameters (`fts.virtual-fts/1`; default: the embedded plant).
    #[arg(long, value_name = "FTS.json")]
    plant: Option<PathBuf>,
    /// A linear plant model (`fts.tf/1`, discrete) to run instead of a virtual FTS.
    #[arg(long, value_name = "PLANT.json", conflicts_with = "plant")]
    plant_tf: Option<PathBuf>,
    /// Forward hysteresis model (`fts.hysteresis/1`) in front of --plant-tf.
    #[arg(long, value_name = "MODEL.json", requires = "plant_tf")]
    plant_hysteresis: Option<PathBuf>,
    /// Noise seed of the plant.
    #[arg(long)]
    seed: Option<u64>,
    /// Inverse hysteresis model for HC (`fts.hysteresis/1`); default: identified from the virtual FTS.
    #[arg(long, value_name = "INV.json")]
    hysteresis: Option<PathBuf>,
    /// ZPETC filter (`fts.zpetc/1`); default: identified from the virtual FTS.
    #[arg(long, value_name = "ZPETC.json", conflicts_with = "closed_loop")]
    zpetc: Option<PathBuf>,
    /// Closed-loop model (`fts.tf/1`) to build the ZPETC from.
    #[arg(long, value_name = "CL.json")]
    closed_loop: Option<PathBuf>,
    /// A complete coefficient file (`fts.controller/1`) instead of stages and models.
    #[arg(long, value_name = "CTRL.json", conflicts_with_all = ["hysteresis", "zpetc", "closed_loop", "ss", "controller"])]
    controller_file: Option<PathBuf>,
    /// PID proportional gain (V/um).
    #[arg(long, default_value_t = crate::sim::experiment::DEFAULT_PID.kp, allow_hyphen_values = true)]
    kp: f64,
    /// PID integral gain per sample (V/um).
    #[arg(long, default_value_t = crate::sim::experiment::DEFAULT_PID.ki, allow_hyphen_values = true)]
    ki: f64,
    /// PID derivative gain per sample (V/um), on the measurement.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    kd: f64,
    /// Write the trace (t, r, u, y, e) here.
    #[arg(short = 'o', long = "out", value_name = "TRACE.csv")]
    output: Option<PathBuf>,
    /// Plot reference, measurement and error to this SVG.
    #[arg(long, value_name = "TRACK.svg")]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

fn virtual_params(args: &SimulateArgs) -> anyhow::Result<VirtualFtsParams> {
    let mut p = match &args.plant {
        None => VirtualFtsParams::default_plant(),
        Some(path) => {
            let source = path.display().to_string();
            let p: VirtualFtsParams = serde_json::from_str(&read_input(path)?)
                .map_err(|e| bad(format!("{source} line {}: {e}", e.line())))?;
            p.validate()
                .map_err(|e| bad(format!("{source} field '{}': {}", e.field, e.message)))?;
            p
        }
    };
    if let Some(seed) = args.seed {
        p.seed = seed;
    }
    Ok(p)
}

/// The reference; its tail covers the controller's preview.
fn build_reference(args: &SimulateArgs, ts: f64, preview: usize) -> anyhow::Result<Reference> {
    let timing = ReferenceTiming {
        ts,
        ..ReferenceTiming::default()
    }
    .with_preview(preview);
    let excite_err = |e: crate::ident::excite::ExciteError| {
        bad(format!("--{}: {}", e.field.replace('_', "-"), e.message))
    };
    if let Some(path) = &args.reference_file {
        let source = path.display().to_string();
        use crate::io::timeseries::{ColumnRef, ReadParams, read_table};
        let params = ReadParams {
            columns: vec![ColumnRef::parse(&args.reference_column)],
            min_rows: 2,
            ..ReadParams::default()
        };
        let table = read_table(super::common::open_input(path)?, &source, &params)?;
        let samples = table.columns.into_iter().next().unwrap_or_default();
        return Ok(reference::from_samples(
            samples,
            &timing,
            format!("reference {source}"),
        ));
    }
    match args.reference {
        ReferenceKind::Sine => {
            // The default duration is 20 periods: without a positive
            // frequency there is none, and the frequency is the culprit.
            let duration = match args.duration {
                Some(d) => d,
                None if args.freq.is_finite() && args.freq > 0.0 => (20.0 / args.freq).max(0.2),
                None => {
                    return Err(bad(format!(
                        "--freq: expected a positive frequency in Hz for a sine reference, got {} (or give --duration)",
                        args.freq
                    )));
                }
            };
            reference::sine(args.amplitude, args.freq, args.offset, duration, &timing)
                .map_err(excite_err)
        }
        ReferenceKind::Sweep => reference::sweep(
            args.amplitude,
            0.0,
            args.f1,
            args.offset,
            args.duration.unwrap_or(2.0),
            &timing,
        )
        .map_err(excite_err),
        ReferenceKind::Step => reference::step(
            args.amplitude,
            args.offset,
            args.step_time,
            args.duration.unwrap_or(0.1),
            &timing,
        )
        .map_err(excite_err),
        ReferenceKind::FiveLeaf => reference::five_leaf(
            args.scale,
            args.offset,
            args.duration.unwrap_or(1.0),
            &timing,
        )
        .map_err(excite_err),
    }
}

fn read_zpetc(args: &SimulateArgs) -> anyhow::Result<Option<Zpetc>> {
    if let Some(path) = &args.zpetc {
        let source = path.display().to_string();
        return Ok(Some(zpetc_json::parse_zpetc(&read_input(path)?, &source)?));
    }
    if let Some(path) = &args.closed_loop {
        let source = path.display().to_string();
        let TransferFunction::Discrete(g) = tf_json::parse_tf(&read_input(path)?, &source)? else {
            return Err(bad(format!(
                "{source} field 'var': the closed-loop model must be discrete (\"z^-1\")"
            )));
        };
        return Ok(Some(
            zpetc_mod::design(&g, &ZpetcParams::default())
                .map_err(|e| bad(format!("{source}: {e}")))?,
        ));
    }
    Ok(None)
}

/// The coefficient file to run, and a note on where its models came from.
fn controller(
    args: &SimulateArgs,
    plant: &VirtualFtsParams,
    ts: f64,
    model_plant: bool,
) -> anyhow::Result<(ControllerFile, String)> {
    if let Some(path) = &args.controller_file {
        let source = path.display().to_string();
        let file = parse_controller(&read_input(path)?, &source)?;
        if (file.ts - ts).abs() > 1e-12 * ts {
            return Err(bad(format!(
                "{source} field 'ts': {} s, but the plant runs at {ts} s",
                file.ts
            )));
        }
        return Ok((file, format!("coefficient file {source}")));
    }
    let default = if args.ss.ss.is_some() {
        "ss"
    } else {
        "pid+hc+zpec"
    };
    let stages = Stages::parse(args.controller.as_deref().unwrap_or(default))
        .map_err(|e| bad(format!("--controller: {e}")))?;
    let mut inputs = Vec::new();
    let feedback = match (stages.feedback, &args.ss.ss) {
        (FeedbackKind::Pid | FeedbackKind::None, Some(_)) => {
            return Err(bad(format!(
                "--controller {}: --ss gives a state-space controller; use --controller ss[+hc][+zpec]",
                stages.name()
            )));
        }
        (FeedbackKind::StateSpace, None) => {
            return Err(bad(format!(
                "--controller {}: needs the controller (--ss K.json)",
                stages.name()
            )));
        }
        (FeedbackKind::StateSpace, Some(path)) => {
            if stages.zpetc && args.zpetc.is_none() && args.closed_loop.is_none() {
                return Err(bad(format!(
                    "--controller {}: give the ZPETC of this loop (--zpetc or --closed-loop); the one fts identifies is for the PID loop",
                    stages.name()
                )));
            }
            let limits = if model_plant {
                (args.output_min, args.output_max)
            } else {
                (
                    args.output_min.or(Some(plant.amplifier.input_min_v)),
                    args.output_max.or(Some(plant.amplifier.input_max_v)),
                )
            };
            Some(super::emit::read_ss_block(
                &args.ss,
                path,
                ts,
                limits,
                &mut inputs,
            )?)
        }
        (FeedbackKind::None, None) => {
            if stages.zpetc && args.zpetc.is_none() && args.closed_loop.is_none() {
                return Err(bad(format!(
                    "--controller {}: give the ZPETC of the loop it feeds (--zpetc or --closed-loop); the one fts identifies is for its PID loop",
                    stages.name()
                )));
            }
            None
        }
        (FeedbackKind::Pid, None) => None,
    };
    for (name, value) in [("--kp", args.kp), ("--ki", args.ki), ("--kd", args.kd)] {
        if !value.is_finite() {
            return Err(bad(format!("{name}: expected a finite gain, got {value}")));
        }
    }
    let pid = PidSpec {
        kp: args.kp,
        ki: args.ki,
        kd: args.kd,
        output_min: plant.amplifier.input_min_v,
        output_max: plant.amplifier.input_max_v,
    };
    let mut inverse = match &args.hysteresis {
        Some(path) => {
            let source = path.display().to_string();
            Some(hysteresis_json::parse_model(&read_input(path)?, &source)?.model)
        }
        None => None,
    };
    let mut zpetc = read_zpetc(args)?;
    let need_models =
        (stages.hysteresis_compensation && inverse.is_none()) || (stages.zpetc && zpetc.is_none());
    let mut origin = match &args.ss.ss {
        Some(p) => format!("state-space controller {}, models from files", p.display()),
        None => String::from("models from files"),
    };
    if need_models {
        if args.plant_tf.is_some() {
            return Err(bad(format!(
                "--controller {}: with --plant-tf, give the models too (--hysteresis for hc, --zpetc or --closed-loop for zpec)",
                stages.name()
            )));
        }
        eprintln!(
            "identifying HC and ZPETC models from the virtual FTS (simulated measurements only)..."
        );
        let params = ExperimentParams {
            plant: plant.clone(),
            seed: plant.seed,
            pid,
            ..ExperimentParams::default()
        };
        let models = experiment::identify_models(&params, &mut |_| {})?;
        origin = format!(
            "models identified from the virtual FTS: inverse {} fit {:.2} % rms, closed loop {} [{} {} {}] simulation fit {:.1} %",
            models.inverse.model.kind.name(),
            models.inverse.info.fit.rms_percent,
            models.closed_loop.method,
            params.orders.na,
            params.orders.nb,
            params.orders.nk,
            models.closed_loop.arx_fit.simulation_percent
        );
        inverse = inverse.or(Some(models.inverse.model));
        zpetc = zpetc.or(Some(models.zpetc));
    }
    let file = experiment::build_controller(
        stages,
        ts,
        match (feedback, stages.feedback) {
            (Some(k), _) => Feedback::StateSpace(k),
            (None, FeedbackKind::None) => Feedback::None,
            (None, _) => Feedback::Pid(pid),
        },
        inverse.as_ref(),
        zpetc.as_ref(),
        Provenance {
            fts_version: env!("CARGO_PKG_VERSION").into(),
            inputs,
        },
    )
    .map_err(bad)?;
    Ok((file, origin))
}

fn run_on<P: Plant>(
    plant: &mut P,
    file: &ControllerFile,
    reference: &Reference,
    plant_model: Option<(&DiscreteTf, &str)>,
) -> anyhow::Result<closed_loop::Trace> {
    let mut rt = RuntimeController::new(&file.runtime_spec())
        .map_err(|e| bad(format!("controller: {e}")))?;
    closed_loop::run(plant, &mut rt, &reference.samples)
        .map_err(|d| anyhow::anyhow!("{d}; {}", likely_cause(file, plant_model)))
}

/// Why a loop most likely diverged, from the stability of the models it is
/// made of: an unstable ZPETC denominator runs away on its own; an unstable
/// plant needs a controller that stabilises it; otherwise the feedback
/// controller destabilises the plant.
fn likely_cause(file: &ControllerFile, plant_model: Option<(&DiscreteTf, &str)>) -> String {
    let unstable = |num: Vec<f64>, den: &[f64]| {
        DiscreteTf::new(num, den.to_vec(), 0, file.ts).is_ok_and(|g| g.is_stable() == Ok(false))
    };
    if let Some(z) = &file.zpetc
        && unstable(vec![1.0], &z.den)
    {
        return "likely cause: the ZPETC filter's denominator has a root outside the unit circle"
            .into();
    }
    if let Some((g, source)) = plant_model
        && g.is_stable() == Ok(false)
    {
        return format!(
            "likely cause: the plant model {source} is unstable and the feedback controller does not stabilise it"
        );
    }
    "likely cause: the feedback controller destabilises the plant (check the loop's margins)".into()
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    let vparams = virtual_params(&args)?;
    let (trace, file, origin, reference) = if let Some(path) = &args.plant_tf {
        let source = path.display().to_string();
        let TransferFunction::Discrete(g) = tf_json::parse_tf(&read_input(path)?, &source)? else {
            return Err(bad(format!(
                "{source} field 'var': the plant model must be discrete (\"z^-1\")"
            )));
        };
        let hysteresis = match &args.plant_hysteresis {
            Some(p) => {
                Some(hysteresis_json::parse_model(&read_input(p)?, &p.display().to_string())?.model)
            }
            None => None,
        };
        let (file, origin) = controller(&args, &vparams, g.ts(), true)?;
        let reference = build_reference(&args, g.ts(), file.preview())?;
        let mut plant = ModelPlant::new(
            &g,
            hysteresis,
            file.command_limits(),
            0.0,
            args.seed.unwrap_or(1),
        )
        .map_err(|e| bad(format!("{source}: {e}")))?;
        (
            run_on(&mut plant, &file, &reference, Some((&g, &source)))?,
            file,
            origin,
            reference,
        )
    } else {
        let (file, origin) = controller(&args, &vparams, vparams.ts, false)?;
        let reference = build_reference(&args, vparams.ts, file.preview())?;
        let mut plant = VirtualFts::new(vparams.clone()).map_err(|e| bad(format!("plant: {e}")))?;
        (
            run_on(&mut plant, &file, &reference, None)?,
            file,
            origin,
            reference,
        )
    };
    let limits = file.command_limits();
    let m = closed_loop::metrics(&trace, reference.evaluated(), limits);
    let error = trace.error();
    let t: Vec<f64> = (0..trace.reference.len())
        .map(|k| k as f64 * trace.ts)
        .collect();

    if let Some(path) = &args.output {
        let text = crate::io::timeseries::write_csv(
            &["t", "r", "r_f", "u_ff", "u", "y", "e"],
            &[
                &t,
                &trace.reference,
                &trace.filtered_reference,
                &trace.feedforward,
                &trace.command,
                &trace.measurement,
                &error,
            ],
        );
        write_atomic(path, text.as_bytes())?;
    }
    if let Some(path) = &args.plot {
        write_plot(path, &t, &trace, &error, &reference, &file)?;
    }
    let controller_name = file.stages_name();
    let evaluated_from_s = m.start as f64 * trace.ts;
    let step = step_figures(&args, &trace, &reference);
    if args.json {
        return print_json(&json!({
            "step": step.as_ref().map(|s| match s {
                Ok(s) => json!(s),
                Err(e) => json!({"no_step_info": e.to_string()}),
            }),
            "controller": controller_name,
            "reference": reference.label,
            "max_abs_error": m.max_abs_error,
            "rms_error": m.rms_error,
            "max_error_percent": m.max_error_percent,
            "amplitude": m.amplitude,
            "evaluated_from_s": evaluated_from_s,
            "evaluated_samples": m.samples,
            "saturated_samples": m.saturated_samples,
            "preview": file.preview(),
            "ts": trace.ts,
            "models": origin,
        }));
    }
    say!("controller: {controller_name} ({origin})");
    say!(
        "reference: {}, evaluated from t = {evaluated_from_s:.3} s ({} samples; lead-in and settling excluded)",
        reference.label,
        m.samples
    );
    say!(
        "tracking error: max {:.4} um, rms {:.4} um, max {:.2} % of the {:.3} um amplitude",
        m.max_abs_error,
        m.rms_error,
        m.max_error_percent,
        m.amplitude
    );
    match &step {
        Some(Ok(s)) => {
            let i = &s.info;
            let opt = |x: Option<f64>, none: &str| {
                x.map_or(none.to_string(), |v| format!("{:.3} ms", v * 1e3))
            };
            say!(
                "step: rise (10-90 %) {}, settling (2 %) {}, overshoot {:.2} %, undershoot {:.2} %, steady-state error {:.4} um",
                opt(i.rise_time, "not reached"),
                opt(i.settling_time, "not settled"),
                i.overshoot,
                i.undershoot,
                s.steady_state_error
            );
        }
        Some(Err(e)) => say!("step: no figures: {e}"),
        None => {}
    }
    if m.saturated_samples > 0 {
        say!(
            "warning: the command sat on its limits ({} .. {} V) for {} samples: the reference leaves the actuator's range or the loop overshoots",
            limits.0,
            limits.1,
            m.saturated_samples
        );
    }
    for p in [&args.output, &args.plot].into_iter().flatten() {
        say!("wrote {}", p.display());
    }
    Ok(())
}

/// The step figures of a `--reference step` run (`None` for other references).
fn step_figures(
    args: &SimulateArgs,
    trace: &closed_loop::Trace,
    reference: &Reference,
) -> Option<Result<reference::StepTracking, crate::lti::response::NoStepInfo>> {
    if args.reference_file.is_some() || !matches!(args.reference, ReferenceKind::Step) {
        return None;
    }
    let at = reference.evaluate_from + (args.step_time / trace.ts).round() as usize;
    Some(reference::step_tracking(
        &trace.measurement,
        trace.ts,
        at,
        reference.evaluate_to,
        args.offset,
        args.amplitude,
    ))
}

fn write_plot(
    path: &Path,
    t: &[f64],
    trace: &closed_loop::Trace,
    error: &[f64],
    reference: &Reference,
    file: &ControllerFile,
) -> anyhow::Result<()> {
    let title = format!("{} tracking {}", file.stages_name(), reference.label);
    let svg = plot::stacked_charts_svg(&[
        (
            title.as_str(),
            "t (s)",
            "displacement (um)",
            vec![
                plot::Series {
                    label: "reference r",
                    x: t,
                    y: &trace.reference,
                },
                plot::Series {
                    label: "measurement y",
                    x: t,
                    y: &trace.measurement,
                },
            ],
        ),
        (
            "tracking error",
            "t (s)",
            "e = r - y (um)",
            vec![plot::Series {
                label: "e",
                x: t,
                y: error,
            }],
        ),
    ])?;
    write_atomic(path, svg.as_bytes())
}
