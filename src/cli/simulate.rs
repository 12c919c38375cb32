//! `fts simulate --stages pid|pid+hc|pid+zpec|pid+hc+zpec|ss[+hc][+zpec]|dob[+hc][+zpec] [--ss K.json] [--reference ...]`:
//! flags into [`Simulate`] (a closed-loop tracking run through the runtime
//! controller step, fed by the coefficient file fts emits or by one built
//! from the stages exactly as `fts emit` builds it); the files read here, the
//! trace and plot written, the report rendered.

use super::common::{
    bad, choice, name, open_input, print_report, read_input, step_error, write_atomic,
};
use crate::ident::hysteresis::HysteresisModel;
use crate::io::controller_file::RepetitiveBlock;
use crate::io::controller_file::{InputHash, Provenance, parse_controller, sha256_hex};
use crate::io::timeseries::{ColumnRef, ReadParams, TimeColumn, read_table};
use crate::io::{hysteresis_json, plot, zpetc_json};
use crate::lti::TransferFunction;
use crate::lti::ss::StateSpace;
use crate::sim::disturbance::Disturbance;
use crate::sim::virtual_fts::VirtualFtsParams;
use crate::synth::zpetc::{self as zpetc_mod, Zpetc, ZpetcParams};
use crate::workflow::contour::DobSettings;
use crate::workflow::learning::RepetitiveFile;
use crate::workflow::{
    ReferenceShape, SimController, SimPlant, Simulate, SimulateInputs, SimulateReport, StageModels,
};
use clap::Args;
use std::path::{Path, PathBuf};

/// The loop a run drives: controller, reference, plant and disturbances
/// (shared by `fts simulate` and `fts ilc`).
#[derive(Debug, Args)]
pub struct LoopArgs {
    /// Controller stages: pid, pid+hc, pid+zpec, pid+hc+zpec, or ss, ss+hc, ss+zpec, ss+hc+zpec
    /// with --ss (default: pid+hc+zpec, or ss with --ss).
    #[arg(id = "controller", long = "stages", value_name = "STAGES")]
    controller: Option<String>,
    #[command(flatten)]
    ss: super::emit::SsArgs,
    /// Lowest command of the feedback controller (PID or --ss), V (default: the virtual FTS amplifier's 0; a --ss controller on --plant-tf: none).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "controller_file")]
    output_min: Option<f64>,
    /// Highest command of the feedback controller (PID or --ss), V (default: the virtual FTS amplifier's 10; a --ss controller on --plant-tf: none).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "controller_file")]
    output_max: Option<f64>,
    /// Reference trajectory.
    #[arg(long, value_parser = choice::<ReferenceShape>(), default_value = name(Simulate::default().reference))]
    reference: ReferenceShape,
    /// Reference samples from a CSV instead (column `r`, or `--reference-column`); a time column (`t`, `time`, `time_ms`, ...) is read and the samples resampled to the controller rate, without one a row is one controller period.
    #[arg(long, value_name = "REF.csv", conflicts_with = "reference")]
    reference_file: Option<PathBuf>,
    /// Column of --reference-file (header name or 1-based index).
    #[arg(long, default_value = "r", value_parser = super::columns::parse_column)]
    reference_column: String,
    /// Amplitude of the sine or sweep, um.
    #[arg(long, default_value_t = Simulate::default().amplitude)]
    amplitude: f64,
    /// Sine frequency, Hz.
    #[arg(long, default_value_t = Simulate::default().freq)]
    freq: f64,
    /// Sweep end frequency, Hz.
    #[arg(long, default_value_t = Simulate::default().f1)]
    f1: f64,
    /// Centre of the reference, um (mid-stroke of the embedded plant).
    #[arg(long, default_value_t = Simulate::default().offset, allow_hyphen_values = true)]
    offset: f64,
    /// Length of the reference, s (default: sine 20 periods and at least 0.2 s; sweep 2 s; five-leaf 1 s; step 0.1 s).
    #[arg(long)]
    duration: Option<f64>,
    /// Time of the step into the evaluated part, s (--reference step).
    #[arg(long, value_name = "SECONDS", default_value_t = Simulate::default().step_time)]
    step_time: f64,
    /// Scale of the five-leaved trajectory (Eq. 13 as printed spans +-50 um).
    #[arg(long, default_value_t = Simulate::default().scale, allow_hyphen_values = true)]
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
    /// HC by per-sample inversion: --hysteresis is the *forward* model, and
    /// the HC block solves Y(u) = r_f each sample on the command range.
    #[arg(long, requires = "hysteresis")]
    hc_solve: bool,
    /// ZPETC filter (`fts.zpetc/1`); default: identified from the virtual FTS.
    #[arg(long, value_name = "ZPETC.json")]
    zpetc: Option<PathBuf>,
    /// Closed-loop model (`fts.tf/1`): the ZPETC is built from it unless --zpetc is given, and `fts ilc` learns with it.
    #[arg(long, value_name = "CL.json")]
    closed_loop: Option<PathBuf>,
    /// A complete coefficient file (`fts.controller/1`) instead of stages and models.
    #[arg(id = "controller_file", long = "controller", alias = "controller-file", value_name = "CTRL.json", conflicts_with_all = ["hysteresis", "zpetc", "closed_loop", "ss", "controller"])]
    controller_file: Option<PathBuf>,
    /// PID proportional gain (V/um).
    #[arg(long, default_value_t = Simulate::default().kp, allow_hyphen_values = true)]
    kp: f64,
    /// PID integral gain per sample (V/um).
    #[arg(long, default_value_t = Simulate::default().ki, allow_hyphen_values = true)]
    ki: f64,
    /// PID derivative gain per sample (V/um), on the measurement.
    #[arg(long, default_value_t = Simulate::default().kd, allow_hyphen_values = true)]
    kd: f64,
    /// Plug-in repetitive compensator (`fts.repetitive/1`, from `fts repetitive`) added to the stages.
    #[arg(long, value_name = "RC.json", conflicts_with = "controller_file")]
    repetitive: Option<PathBuf>,
    /// Disturbance added to the plant's output, um: sines:A@HZ[@DEG],.. | spindle:A@HZ[,h2,h3,..] | file:PATH (a CSV's first non-time column, played at its time column's times, else one row per controller period).
    #[arg(long, value_name = "SPEC")]
    output_disturbance: Option<String>,
    /// Disturbance added to the command at the plant's input, V (same forms as --output-disturbance).
    #[arg(long, value_name = "SPEC")]
    input_disturbance: Option<String>,
    /// Q cut-off of a `dob` controller's disturbance observer, Hz [1000].
    #[arg(
        id = "dob.q_hz",
        long = "dob-q-hz",
        value_name = "HZ",
        conflicts_with = "controller_file"
    )]
    dob_q_hz: Option<f64>,
    /// Q order (binomial low-pass) [2].
    #[arg(
        id = "dob.q_order",
        long = "dob-q-order",
        value_name = "R",
        conflicts_with = "controller_file"
    )]
    dob_q_order: Option<usize>,
    /// Coulomb friction feedforward Fc of a `dob` controller, V [0].
    #[arg(
        id = "dob.coulomb",
        long = "dob-coulomb",
        value_name = "FC",
        allow_hyphen_values = true,
        conflicts_with = "controller_file"
    )]
    dob_coulomb: Option<f64>,
    /// Viscous friction feedforward Fv of a `dob` controller, V per um/s [0].
    #[arg(
        id = "dob.viscous",
        long = "dob-viscous",
        value_name = "FV",
        allow_hyphen_values = true,
        conflicts_with = "controller_file"
    )]
    dob_viscous: Option<f64>,
    /// Smoothing velocity of the feedforward's sign v/(|v| + v_eps), um/s [10].
    #[arg(
        id = "dob.smoothing",
        long = "dob-smoothing",
        value_name = "UM/S",
        conflicts_with = "controller_file"
    )]
    dob_smoothing: Option<f64>,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub(super) run: LoopArgs,
    /// Write the trace (t, r, r_f, u_ff, u, y, e) here.
    #[arg(short = 'o', long = "out", value_name = "TRACE.csv")]
    output: Option<PathBuf>,
    /// Write the coefficient file the run executed (`fts.controller/1`)
    /// here; `--controller` replays it.
    #[arg(long, value_name = "CTRL.json")]
    controller_out: Option<PathBuf>,
    /// Plot reference, measurement and error to this SVG.
    #[arg(long, value_name = "TRACK.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

impl LoopArgs {
    /// The library step these flags stand for.
    pub(super) fn step(&self) -> anyhow::Result<Simulate> {
        Ok(Simulate {
            controller: self.controller.clone(),
            reference: self.reference,
            amplitude: self.amplitude,
            freq: self.freq,
            f1: self.f1,
            offset: self.offset,
            duration: self.duration,
            step_time: self.step_time,
            scale: self.scale,
            seed: self.seed,
            kp: self.kp,
            ki: self.ki,
            kd: self.kd,
            output_min: self.output_min,
            output_max: self.output_max,
            c2d: self.ss.c2d,
            prewarp: self.ss.prewarp,
            ss_anti_windup: self.ss.ss_anti_windup,
            output_disturbance: read_disturbance("--output-disturbance", &self.output_disturbance)?,
            input_disturbance: read_disturbance("--input-disturbance", &self.input_disturbance)?,
            dob: self.dob(),
            hc_solve: self.hc_solve,
        })
    }

    fn dob(&self) -> DobSettings {
        let d = DobSettings::default();
        DobSettings {
            q_hz: self.dob_q_hz.unwrap_or(d.q_hz),
            q_order: self.dob_q_order.unwrap_or(d.q_order),
            coulomb: self.dob_coulomb.unwrap_or(d.coulomb),
            viscous: self.dob_viscous.unwrap_or(d.viscous),
            smoothing: self.dob_smoothing.unwrap_or(d.smoothing),
        }
    }

    /// The plant, the controller and the reference samples these flags name.
    pub(super) fn inputs(&self) -> anyhow::Result<SimulateInputs> {
        let plant = read_plant(self)?;
        Ok(SimulateInputs {
            controller: read_controller(self, plant.ts())?,
            reference_samples: read_reference(self, plant.ts())?,
            plant,
        })
    }
}

/// A `--*-disturbance` spec; `file:PATH` reads a CSV's first column that
/// is not its time column. With a time column (`t`, `time`, `time_ms`, ..)
/// the samples are played at their times (interpolated at the loop's);
/// without one, a row is one loop period.
fn read_disturbance(flag: &str, spec: &Option<String>) -> anyhow::Result<Option<Disturbance>> {
    let Some(spec) = spec else {
        return Ok(None);
    };
    if let Some(path) = spec.strip_prefix("file:") {
        return read_disturbance_file(Path::new(path)).map(Some);
    }
    Disturbance::parse(spec)
        .map(Some)
        .map_err(|e| bad(format!("invalid value '{spec}' for '{flag} <SPEC>': {e}")))
}

fn read_disturbance_file(path: &Path) -> anyhow::Result<Disturbance> {
    let source = path.display().to_string();
    let read = |column: usize| -> anyhow::Result<_> {
        let params = ReadParams {
            columns: vec![ColumnRef::Index(column)],
            time: TimeColumn::Find,
            min_rows: 1,
            ..ReadParams::default()
        };
        Ok(read_table(open_input(path)?, &source, &params)?)
    };
    let mut table = read(1)?;
    let time_first = table.timing.as_ref().map(|t| &t.column) == table.names.first();
    if time_first {
        table = read(2)?;
    }
    let values = table.columns.into_iter().next().unwrap_or_default();
    let d = Disturbance::Samples {
        values,
        time_s: table.time,
    };
    d.validate().map_err(|e| bad(format!("{source}: {e}")))?;
    Ok(d)
}

/// The linear model of `--plant-tf` (behind `--plant-hysteresis`), else the
/// virtual FTS of `--plant` or the embedded one.
fn read_plant(args: &LoopArgs) -> anyhow::Result<SimPlant> {
    let Some(path) = &args.plant_tf else {
        return Ok(SimPlant::Virtual(virtual_params(args)?));
    };
    let source = path.display().to_string();
    let TransferFunction::Discrete(tf) = super::common::parse_tf(&read_input(path)?, &source)?
    else {
        return Err(bad(format!(
            "{source} field 'var': the plant model must be discrete (\"z^-1\")"
        )));
    };
    let hysteresis = match &args.plant_hysteresis {
        Some(p) => Some(read_hysteresis(p)?),
        None => None,
    };
    Ok(SimPlant::Model {
        tf,
        hysteresis,
        source,
    })
}

fn read_hysteresis(path: &Path) -> anyhow::Result<HysteresisModel> {
    let source = path.display().to_string();
    Ok(hysteresis_json::parse_model(&read_input(path)?, &source)?.model)
}

fn virtual_params(args: &LoopArgs) -> anyhow::Result<VirtualFtsParams> {
    match &args.plant {
        Some(path) => read_virtual_params(path),
        None => Ok(VirtualFtsParams::default_plant()),
    }
}

/// A virtual FTS parameter file (`fts.virtual-fts/1`), checked; errors
/// name the file and the field.
pub(super) fn read_virtual_params(path: &std::path::Path) -> anyhow::Result<VirtualFtsParams> {
    let source = path.display().to_string();
    let p: VirtualFtsParams = serde_json::from_str(&read_input(path)?)
        .map_err(|e| bad(format!("{source} line {}: {e}", e.line())))?;
    p.validate()
        .map_err(|e| bad(format!("{source} field '{}': {}", e.field, e.message)))?;
    Ok(p)
}

/// Reference samples from `--reference-file` at the loop's sample time
/// `ts`, with their description. A time column (found by its name, as in
/// every record: `t`, `time`, `time_ms`, ...) is read and the samples are
/// resampled onto the loop's grid; without one, a row is one loop period.
fn read_reference(args: &LoopArgs, ts: f64) -> anyhow::Result<Option<(Vec<f64>, String)>> {
    let Some(path) = &args.reference_file else {
        return Ok(None);
    };
    let source = path.display().to_string();
    let params = ReadParams {
        columns: vec![ColumnRef::parse(&args.reference_column)],
        time: TimeColumn::Find,
        min_rows: 2,
        ..ReadParams::default()
    };
    let table = read_table(open_input(path)?, &source, &params)?;
    let column = table.names.first().cloned().unwrap_or_default();
    let samples = table.columns.into_iter().next().unwrap_or_default();
    let (Some(t), Some(timing)) = (table.time, table.timing) else {
        let label = format!(
            "reference {source} (column {column}, no time column: one row per {ts} s loop period)"
        );
        return Ok(Some((samples, label)));
    };
    let resampled = crate::sim::reference::resample_linear(&t, &samples, ts)
        .map_err(|m| bad(format!("{source} column '{}': {m}", timing.column)))?;
    let label = format!(
        "reference {source} (column {column}, time column '{}' every {} s, resampled to the loop's {ts} s)",
        timing.column, timing.ts
    );
    Ok(Some((resampled, label)))
}

fn read_zpetc(args: &LoopArgs) -> anyhow::Result<Option<Zpetc>> {
    if let Some(path) = &args.zpetc {
        let source = path.display().to_string();
        return Ok(Some(zpetc_json::parse_zpetc(&read_input(path)?, &source)?));
    }
    if let Some(path) = &args.closed_loop {
        let source = path.display().to_string();
        let TransferFunction::Discrete(g) = super::common::parse_tf(&read_input(path)?, &source)?
        else {
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

/// `--controller`, or the models of the stages (`--ss`, `--hysteresis`,
/// `--zpetc`/`--closed-loop`).
fn read_controller(args: &LoopArgs, ts: f64) -> anyhow::Result<SimController> {
    if let Some(path) = &args.controller_file {
        let source = path.display().to_string();
        let file = parse_controller(&read_input(path)?, &source)?;
        return Ok(SimController::File { file, source });
    }
    let mut provenance = Provenance {
        fts_version: env!("CARGO_PKG_VERSION").into(),
        inputs: Vec::new(),
    };
    let ss = match &args.ss.ss {
        Some(path) => Some(read_ss(path, &mut provenance)?),
        None => None,
    };
    let hysteresis = match &args.hysteresis {
        Some(path) => Some(read_hysteresis(path)?),
        None => None,
    };
    let repetitive = match &args.repetitive {
        Some(path) => Some(read_repetitive(path, ts)?),
        None => None,
    };
    Ok(SimController::Stages(StageModels {
        ss,
        hysteresis,
        zpetc: read_zpetc(args)?,
        repetitive,
        nominal: None,
        closed_loop: read_closed_loop(args)?,
        provenance,
    }))
}

/// A `fts.repetitive/1` design file's block, for a loop sampled every `ts` s.
pub(super) fn read_repetitive(path: &Path, ts: f64) -> anyhow::Result<RepetitiveBlock> {
    let source = path.display().to_string();
    RepetitiveFile::parse(&read_input(path)?, &source)
        .and_then(|file| file.block_at(ts, &source))
        .map_err(step_error)
}

/// The `--closed-loop` model, when given.
fn read_closed_loop(args: &LoopArgs) -> anyhow::Result<Option<crate::lti::DiscreteTf>> {
    let Some(path) = &args.closed_loop else {
        return Ok(None);
    };
    let source = path.display().to_string();
    match super::common::parse_tf(&read_input(path)?, &source)? {
        TransferFunction::Discrete(g) => Ok(Some(g)),
        _ => Err(bad(format!(
            "{source} field 'var': the closed-loop model must be discrete (\"z^-1\")"
        ))),
    }
}

/// Reads a `--ss` controller and records its hash.
fn read_ss(path: &Path, provenance: &mut Provenance) -> anyhow::Result<(StateSpace, String)> {
    let text = read_input(path)?;
    let source = path.display().to_string();
    provenance.inputs.push(InputHash {
        role: "state_space".into(),
        file: path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default(),
        sha256: sha256_hex(text.as_bytes()),
    });
    let sys = crate::io::ss_json::parse_system(&text, &source)?;
    Ok((sys, source))
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    let inputs = args.run.inputs()?;
    let report = args
        .run
        .step()?
        .run_observed(inputs, &mut |note| note!("{note}"))
        .map_err(step_error)?;
    write_outputs(&args, &report)?;
    print_report(&report, args.json)?;
    Ok(())
}

/// The trace CSV and the plot, where asked for.
fn write_outputs(args: &SimulateArgs, report: &SimulateReport) -> anyhow::Result<()> {
    if let Some(path) = &args.output {
        write_atomic(path, report.trace_csv().as_bytes())?;
    }
    if let Some(path) = &args.controller_out {
        write_atomic(path, report.file.to_json_string().as_bytes())?;
    }
    if let Some(path) = &args.plot {
        write_plot(path, report)?;
    }
    Ok(())
}

/// Reference, measurement and error over time, the evaluated window shaded.
fn write_plot(path: &Path, report: &SimulateReport) -> anyhow::Result<()> {
    let (trace, reference) = (&report.trace, &report.reference);
    let (t, error) = (&report.times(), &trace.error());
    let title = format!("{} tracking {}", report.file.stages_name(), reference.label);
    // The evaluated window, shaded: the metrics come from there only.
    let ts = trace.ts;
    let window = Some((
        reference.evaluate_from as f64 * ts,
        reference.evaluate_to.saturating_sub(1) as f64 * ts,
        "evaluated window (metrics)",
    ));
    let mut panels = vec![
        plot::Panel {
            shade: window,
            ..plot::Panel::lines(
                &title,
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
            )
        },
        plot::Panel {
            shade: window,
            ..plot::Panel::lines(
                "tracking error",
                "t (s)",
                "e = r - y (um)",
                vec![plot::Series {
                    label: "e",
                    x: t,
                    y: error,
                }],
            )
        },
    ];
    let periods = report.periods.as_deref().unwrap_or_default();
    let period_numbers: Vec<f64> = (1..=periods.len()).map(|p| p as f64).collect();
    if !periods.is_empty() {
        panels.push(plot::Panel {
            log_y: true,
            ..plot::Panel::lines(
                "repetitive compensator: convergence",
                "period (from the run's start, lead-in included)",
                "max |e| over the period (um)",
                vec![plot::Series {
                    label: "max |e|",
                    x: &period_numbers,
                    y: periods,
                }],
            )
        });
    }
    // The trace is sampled: each value held until the next sample.
    for panel in panels.iter_mut().take(2) {
        for (_, style) in panel.series.iter_mut() {
            *style = plot::Style::Stairs;
        }
    }
    super::common::write_plot(path, |f| Ok(plot::render(&panels, f)?))
}
