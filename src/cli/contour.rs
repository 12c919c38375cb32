//! `fts trajectory` and `fts contour` (docs/contouring.md): the \[Karagoz18\]
//! paths as `t,x,y,z` tables, and the three-axis loop with cross-coupled
//! control of the contour error.

use super::common::{bad, choice, print_report, read_input, step_error, write_atomic, write_plot};
use super::names::option;
use crate::io::controller_file::{CONTROLLER_FORMAT, Feedback, parse_controller, parse_multiaxis};
use crate::io::ss_json::parse_system;
use crate::sim::contour::AxisController;
use crate::sim::disturbance::Disturbance;
use crate::workflow::Validate;
use crate::workflow::contour::{
    AxisKind, Contour, ContourInputs, DobSettings, MakeTrajectory, PathShape, PidGains4,
    TrajectorySettings,
};
use clap::Args;
use std::path::PathBuf;

/// The path and its motion limits.
#[derive(Debug, Args)]
pub struct PathArgs {
    /// The path.
    #[arg(value_parser = choice::<PathShape>())]
    shape: PathShape,
    /// Diameter of the circle or side of the square, um [5000].
    #[arg(long, value_name = "UM")]
    size: Option<f64>,
    /// Inclination of the path's plane about the x axis, degrees [45].
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    incline: Option<f64>,
    /// Velocity limit along the path, um/s [30000].
    #[arg(long, value_name = "UM/S")]
    velocity: Option<f64>,
    /// Acceleration limit, um/s^2 [1500].
    #[arg(long, value_name = "UM/S2")]
    acceleration: Option<f64>,
    /// Jerk limit, um/s^3 [15000].
    #[arg(long, value_name = "UM/S3")]
    jerk: Option<f64>,
    /// Refuse (exit 2) a velocity limit the moves cannot reach, instead of
    /// planning with the reachable peak.
    #[arg(long)]
    strict: bool,
}

impl PathArgs {
    fn settings(&self) -> TrajectorySettings {
        let d = TrajectorySettings::default();
        TrajectorySettings {
            shape: self.shape,
            size: self.size.unwrap_or(d.size),
            incline: self.incline.unwrap_or(d.incline),
            velocity: self.velocity.unwrap_or(d.velocity),
            acceleration: self.acceleration.unwrap_or(d.acceleration),
            jerk: self.jerk.unwrap_or(d.jerk),
            strict: self.strict,
        }
    }
}

#[derive(Debug, Args)]
pub struct TrajectoryArgs {
    #[command(flatten)]
    path: PathArgs,
    /// Sample time of the table, s.
    #[arg(long, default_value_t = 1e-3)]
    ts: f64,
    /// Write `t,x,y,z,speed` (s, um, um/s) here.
    #[arg(short = 'o', long = "out", value_name = "TRAJ.csv")]
    output: Option<PathBuf>,
    /// Write an SVG of the path's projections and speed here.
    #[arg(long, value_name = "FILE.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// `fts trajectory`.
pub fn run_trajectory(args: TrajectoryArgs) -> anyhow::Result<()> {
    let step = MakeTrajectory {
        trajectory: args.path.settings(),
        ts: args.ts,
    };
    step.validate().map_err(step_error)?;
    let report = step.run().map_err(step_error)?;
    if let Some(path) = &args.output {
        write_atomic(path, report.csv().as_bytes())?;
    }
    if let Some(path) = &args.plot {
        write_plot(path, |f| Ok(report.plot(f)?))?;
    }
    print_report(&report, args.json)
}

#[derive(Debug, Args)]
pub struct ContourArgs {
    #[command(flatten)]
    path: PathArgs,
    /// Loop sample time, s (continuous plants by ZOH, controllers by Tustin) [1e-6].
    #[arg(long)]
    ts: Option<f64>,
    /// Time simulated after the trajectory ends, s.
    #[arg(long, default_value_t = 0.0)]
    settle: f64,
    /// X plant, command -> um (`fts.tf/1` or `fts.ss/1`) [Karagoz18 Eq. 2].
    #[arg(long, value_name = "G.json")]
    plant_x: Option<PathBuf>,
    /// Y plant [Karagoz18 Eq. 3].
    #[arg(long, value_name = "G.json")]
    plant_y: Option<PathBuf>,
    /// Z plant [Karagoz18 Eq. 4].
    #[arg(long, value_name = "G.json")]
    plant_z: Option<PathBuf>,
    /// X controller (u = K e), replacing --pid-x: `fts.ss/1` or `fts.tf/1`
    /// (continuous by Tustin, e.g. from `fts mixsyn`), or the feedback block
    /// of an `fts.controller/1` file at --ts.
    #[arg(long, value_name = "K.json")]
    controller_x: Option<PathBuf>,
    /// Y controller, replacing --pid-y.
    #[arg(long, value_name = "K.json")]
    controller_y: Option<PathBuf>,
    /// Z controller, replacing --pid-z.
    #[arg(long, value_name = "K.json")]
    controller_z: Option<PathBuf>,
    /// Cross-coupling controller, replacing the --cc PID (the same kinds of file).
    #[arg(long, value_name = "K.json", conflicts_with_all = ["cross_coupling", "no_cc"])]
    cc_controller: Option<PathBuf>,
    /// All four controllers from a multi-axis file (`fts.multiaxis-controller/1`,
    /// e.g. written by -o), run at its sample time.
    #[arg(long, value_name = "K3.json", conflicts_with_all = [
        "controller_x", "controller_y", "controller_z", "cc_controller",
        "pid_x", "pid_y", "pid_z", "cross_coupling", "ts",
    ])]
    controller: Option<PathBuf>,
    /// Write the controllers the run executed as a multi-axis controller file
    /// (`fts.multiaxis-controller/1`; `fts emit --multiaxis` makes C of it).
    #[arg(short = 'o', long = "out", value_name = "K3.json")]
    output: Option<PathBuf>,
    /// X PID P,I,D,N of P + I/s + D N s/(s+N) [1,0.01,0.0005,100].
    #[arg(
        long,
        value_name = "P,I,D,N",
        value_delimiter = ',',
        allow_hyphen_values = true,
        conflicts_with = "controller_x"
    )]
    pid_x: Option<Vec<f64>>,
    /// Y PID [1.5,0.01,0.0005,100].
    #[arg(
        long,
        value_name = "P,I,D,N",
        value_delimiter = ',',
        allow_hyphen_values = true,
        conflicts_with = "controller_y"
    )]
    pid_y: Option<Vec<f64>>,
    /// Z PID [1,0.01,0.0005,100].
    #[arg(
        long,
        value_name = "P,I,D,N",
        value_delimiter = ',',
        allow_hyphen_values = true,
        conflicts_with = "controller_z"
    )]
    pid_z: Option<Vec<f64>>,
    /// Cross-coupling PID on the contour-error estimate [0.4,0.005,0.0005,100].
    #[arg(
        id = "cross_coupling",
        long = "cc",
        value_name = "P,I,D,N",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    cc: Option<Vec<f64>>,
    /// No cross-coupling (the axes alone).
    #[arg(long, conflicts_with = "cross_coupling")]
    no_cc: bool,
    /// Lowest command of every controller fts builds here (the PIDs and the
    /// --controller-x/y/z, --cc-controller systems; a controller file's
    /// block keeps its own limits) [none].
    #[arg(long, allow_hyphen_values = true, conflicts_with = "controller")]
    output_min: Option<f64>,
    /// Highest command of those controllers [none].
    #[arg(long, allow_hyphen_values = true, conflicts_with = "controller")]
    output_max: Option<f64>,
    /// Skip the run without cross-coupling.
    #[arg(long)]
    no_baseline: bool,
    /// Sines added at every plant output, um: sines:A@HZ[@PHASE_DEG],..
    /// [100 um at 75 rad/s].
    #[arg(long, value_name = "SPEC")]
    output_disturbance: Option<String>,
    /// No output disturbance.
    #[arg(long, conflicts_with = "output_disturbance")]
    no_disturbance: bool,
    /// Write the thinned trace (t, references, positions, contour errors) here.
    #[arg(long, value_name = "TRACE.csv")]
    csv: Option<PathBuf>,
    /// Write an SVG of the path, the axis errors and the contour error here.
    #[arg(long, value_name = "FILE.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// What the axis PIDs run as: `pid` alone, or `dob`, inside a
    /// disturbance observer with friction feedforward ([Karagoz18] ARC).
    #[arg(long, value_parser = choice::<AxisKind>(), conflicts_with = "controller")]
    axis_controller: Option<AxisKind>,
    /// Q cut-off of the disturbance observer, Hz [1000].
    #[arg(id = "dob.q_hz", long = "dob-q-hz", value_name = "HZ")]
    dob_q_hz: Option<f64>,
    /// Q order (binomial low-pass) [2].
    #[arg(id = "dob.q_order", long = "dob-q-order", value_name = "R")]
    dob_q_order: Option<usize>,
    /// Coulomb friction feedforward Fc of dob axes, command units [0].
    #[arg(
        id = "dob.coulomb",
        long = "dob-coulomb",
        value_name = "FC",
        allow_hyphen_values = true
    )]
    dob_coulomb: Option<f64>,
    /// Viscous friction feedforward Fv of dob axes, command per um/s [0].
    #[arg(
        id = "dob.viscous",
        long = "dob-viscous",
        value_name = "FV",
        allow_hyphen_values = true
    )]
    dob_viscous: Option<f64>,
    /// Smoothing velocity of the feedforward's sign v/(|v| + v_eps), um/s [10].
    #[arg(id = "dob.smoothing", long = "dob-smoothing", value_name = "UM/S")]
    dob_smoothing: Option<f64>,
    /// Coulomb friction Fc at every plant input (u - Fc sign(v) - Fv v), command units [0].
    #[arg(long, value_name = "FC", allow_hyphen_values = true)]
    friction_coulomb: Option<f64>,
    /// Viscous friction Fv at every plant input, command per um/s [0].
    #[arg(long, value_name = "FV", allow_hyphen_values = true)]
    friction_viscous: Option<f64>,
}

/// `P,I,D,N` of the option of setting `field` (four numbers), or the default.
fn gains(field: &str, v: &Option<Vec<f64>>, default: PidGains4) -> anyhow::Result<PidGains4> {
    match v.as_deref() {
        None => Ok(default),
        Some(&[p, i, d, n]) => Ok([p, i, d, n]),
        Some(g) => Err(bad(format!(
            "{}: expected four numbers P,I,D,N, got {}",
            option(field),
            g.len()
        ))),
    }
}

impl ContourArgs {
    fn step(&self) -> anyhow::Result<Contour> {
        let d = Contour::default();
        let disturbance = match (&self.output_disturbance, self.no_disturbance) {
            (_, true) => None,
            (None, false) => d.output_disturbance.clone(),
            (Some(spec), false) => Some(
                Disturbance::parse(spec)
                    .map_err(|e| bad(format!("{}: {e}", option("output_disturbance"))))?,
            ),
        };
        let cc = self
            .cc
            .as_ref()
            .map(|_| gains("cross_coupling", &self.cc, [0.0; 4]))
            .transpose()?;
        Ok(Contour {
            trajectory: self.path.settings(),
            ts: self.ts.unwrap_or(d.ts),
            settle: self.settle,
            pid_x: gains("pid_x", &self.pid_x, d.pid_x)?,
            pid_y: gains("pid_y", &self.pid_y, d.pid_y)?,
            pid_z: gains("pid_z", &self.pid_z, d.pid_z)?,
            cross_coupling: if self.no_cc {
                None
            } else {
                cc.or(d.cross_coupling)
            },
            baseline: !self.no_baseline,
            output_disturbance: disturbance,
            output_min: self.output_min,
            output_max: self.output_max,
            trace_points: d.trace_points,
            axis_controller: self.axis_controller.unwrap_or(d.axis_controller),
            dob: DobSettings {
                q_hz: self.dob_q_hz.unwrap_or(d.dob.q_hz),
                q_order: self.dob_q_order.unwrap_or(d.dob.q_order),
                coulomb: self.dob_coulomb.unwrap_or(d.dob.coulomb),
                viscous: self.dob_viscous.unwrap_or(d.dob.viscous),
                smoothing: self.dob_smoothing.unwrap_or(d.dob.smoothing),
            },
            friction_coulomb: self.friction_coulomb.unwrap_or(d.friction_coulomb),
            friction_viscous: self.friction_viscous.unwrap_or(d.friction_viscous),
        })
    }

    fn inputs(&self) -> anyhow::Result<ContourInputs> {
        let mut inputs = ContourInputs::default();
        let plants = [&self.plant_x, &self.plant_y, &self.plant_z];
        let controllers = [&self.controller_x, &self.controller_y, &self.controller_z];
        for i in 0..3 {
            if let Some(path) = plants[i] {
                inputs.plants[i] = read_system(path)?;
            }
            if let Some(path) = controllers[i] {
                inputs.controllers[i] = Some(read_controller(path)?);
            }
        }
        if let Some(path) = &self.cc_controller {
            inputs.cross = Some(read_controller(path)?);
        }
        Ok(inputs)
    }
}

fn read_system(path: &std::path::Path) -> anyhow::Result<crate::lti::ss::StateSpace> {
    let text = read_input(path)?;
    Ok(parse_system(&text, &path.display().to_string())?)
}

/// A system file, or the feedback block of an `fts.controller/1` file.
fn read_controller(path: &std::path::Path) -> anyhow::Result<(AxisController, String)> {
    let text = read_input(path)?;
    let source = path.display().to_string();
    let is_controller_file = serde_json::from_str::<serde_json::Value>(&text)
        .is_ok_and(|v| v["format"] == CONTROLLER_FORMAT);
    if !is_controller_file {
        let sys = parse_system(&text, &source)?;
        return Ok((AxisController::StateSpace(Box::new(sys)), source));
    }
    let file = parse_controller(&text, &source)?;
    if file.block_names().len() != 1 || file.feedback == Feedback::None {
        return Err(bad(format!(
            "{source}: a contour axis takes a feedback controller alone; this file has {}",
            file.block_names().join(", ")
        )));
    }
    let name = format!("{source} ({})", file.block_names()[0]);
    let block = AxisController::Block {
        feedback: Box::new(file.feedback),
        ts: file.ts,
    };
    Ok((block, name))
}

/// The four controllers of a multi-axis file, as inputs and settings.
fn multiaxis_inputs(
    path: &std::path::Path,
    step: &mut Contour,
    inputs: &mut ContourInputs,
) -> anyhow::Result<()> {
    let source = path.display().to_string();
    let file = parse_multiaxis(&read_input(path)?, &source)?;
    let block = |f: &Feedback| AxisController::Block {
        feedback: Box::new(f.clone()),
        ts: file.ts,
    };
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        inputs.controllers[i] = Some((block(&file.axes[i]), format!("{source} axes.{axis}")));
    }
    step.ts = file.ts;
    match &file.cross_coupling {
        Some(cc) => inputs.cross = Some((block(cc), format!("{source} cross_coupling"))),
        None => step.cross_coupling = None,
    }
    Ok(())
}

/// `fts contour`.
pub fn run_contour(args: ContourArgs) -> anyhow::Result<()> {
    let mut step = args.step()?;
    let mut inputs = args.inputs()?;
    if let Some(path) = &args.controller {
        multiaxis_inputs(path, &mut step, &mut inputs)?;
    }
    step.validate().map_err(step_error)?;
    let report = step.run(&inputs).map_err(step_error)?;
    if let Some(path) = &args.output {
        write_atomic(path, report.main.controller.to_json_string().as_bytes())?;
    }
    if let Some(path) = &args.csv {
        write_atomic(path, report.trace_csv().as_bytes())?;
    }
    if let Some(path) = &args.plot {
        write_plot(path, |f| Ok(report.plot(f)?))?;
    }
    print_report(&report, args.json)
}
