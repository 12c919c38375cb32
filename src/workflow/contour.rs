//! Multi-axis contouring (\[Karagoz18\], docs/contouring.md): `fts trajectory`
//! (the inclined circle or the square traversed by jerk-limited S-curves, as
//! a `t,x,y,z` table) and `fts contour` (three axes with their own
//! controllers, the sinusoidal output disturbance, and cross-coupled control
//! of the contour-error estimate, against the same axes without it). The
//! numerical work is [`crate::sim::scurve`], [`crate::sim::path`] and
//! [`crate::sim::contour`]. Lengths are um, times s.

use super::{Choices, StepError, Validate, positive, whole_number};
use crate::io::controller_file::MultiAxisControllerFile;
use crate::io::plot::{Panel, PlotError, PlotFormat, Series, render};
use crate::lti::ss::StateSpace;
use crate::sim::contour::{
    AXES, AxisController, AxisLoop, AxisSetup, CommandLimits, ContourError, ContourMetrics,
    ContourRun, DobAxis, Friction, KARAGOZ18_AXIS_PID, KARAGOZ18_CC_PID, KARAGOZ18_PLANTS,
    MultiAxisLoop, run,
};
use crate::sim::disturbance::{Disturbance, Sine};
use crate::sim::path::{MotionLimits, Path, Shape, Trajectory};
use crate::synth::pid::ParallelPid;
use serde::{Deserialize, Serialize, Serializer};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::fmt;

/// Which path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PathShape {
    /// The inclined circle (size = diameter).
    #[default]
    Circle,
    /// The square (size = side), stopping at every corner.
    Square,
}

impl Choices for PathShape {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "circle",
            "Circle of diameter `size`, one S-curve along its circumference",
        ),
        (
            "square",
            "Square of side `size`, one S-curve per side (at rest at every corner)",
        ),
    ];
}

/// What runs each axis built from its PID gains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisKind {
    /// The PID alone (\[Karagoz18\] PID-CC).
    #[default]
    Pid,
    /// The PID inside a disturbance observer with friction feedforward
    /// (\[Karagoz18\] ARC-CC, `synth::dob`).
    Dob,
}

impl Choices for AxisKind {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("pid", "The axis PID alone ([Karagoz18] PID-CC)"),
        (
            "dob",
            "The axis PID inside a disturbance observer with friction feedforward ([Karagoz18] ARC-CC)",
        ),
    ];
}

/// The disturbance observer and friction feedforward of `dob` axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DobSettings {
    /// `Q` cut-off, Hz; default 1000.
    pub q_hz: f64,
    /// `Q` order (binomial); default 2.
    #[serde(deserialize_with = "whole_number")]
    pub q_order: usize,
    /// Coulomb friction feedforward `Fc`, command units; default 0.
    pub coulomb: f64,
    /// Viscous friction feedforward `Fv`, command per um/s; default 0.
    pub viscous: f64,
    /// Smoothing velocity `v_eps` of the feedforward's sign, um/s; default 10.
    pub smoothing: f64,
}

impl Default for DobSettings {
    fn default() -> Self {
        Self {
            q_hz: 1000.0,
            q_order: 2,
            coulomb: 0.0,
            viscous: 0.0,
            smoothing: 10.0,
        }
    }
}

impl DobSettings {
    /// Each setting in range at sample time `ts`.
    pub(crate) fn validate(&self, ts: f64) -> Result<(), StepError> {
        crate::synth::dob::q_filter(1.0 / (4.0 * ts), self.q_order, ts)
            .map_err(|e| StepError::setting("dob.q_order", e))?;
        crate::synth::dob::q_filter(self.q_hz, self.q_order, ts)
            .map_err(|e| StepError::setting("dob.q_hz", e))?;
        for (field, v) in [("dob.coulomb", self.coulomb), ("dob.viscous", self.viscous)] {
            if !v.is_finite() {
                return Err(StepError::setting(
                    field,
                    format!("expected a finite number, got {}", super::fmt_value(v)),
                ));
            }
        }
        positive("dob.smoothing", self.smoothing).map(|_| ())
    }

    fn name(&self, pid: PidGains4) -> String {
        format!(
            "DOB (Q order {} at {} Hz) + {}, friction feedforward Fc {} Fv {} (v_eps {} um/s)",
            self.q_order,
            self.q_hz,
            pid_name(pid),
            self.coulomb,
            self.viscous,
            self.smoothing
        )
    }
}

/// The path and how it is traversed; defaults are \[Karagoz18\]'s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrajectorySettings {
    /// Circle or square; default circle.
    pub shape: PathShape,
    /// Diameter of the circle or side of the square, um; default 5000.
    pub size: f64,
    /// Inclination of the path's plane about the x axis, degrees; default 45.
    pub incline: f64,
    /// Velocity limit along the path, um/s; default 30000.
    pub velocity: f64,
    /// Acceleration limit, um/s^2; default 1500.
    pub acceleration: f64,
    /// Jerk limit, um/s^3; default 15000 (an assumption: the paper gives none).
    pub jerk: f64,
    /// Refuse a velocity limit the moves cannot reach (default: plan with
    /// the reachable peak and say so).
    pub strict: bool,
}

impl Default for TrajectorySettings {
    fn default() -> Self {
        Self {
            shape: PathShape::Circle,
            size: 5000.0,
            incline: 45.0,
            velocity: 30000.0,
            acceleration: 1500.0,
            jerk: 15000.0,
            strict: false,
        }
    }
}

impl TrajectorySettings {
    /// Plans the trajectory.
    pub fn plan(&self) -> Result<Trajectory, StepError> {
        let shape = match self.shape {
            PathShape::Circle => Shape::Circle {
                diameter: self.size,
            },
            PathShape::Square => Shape::Square { side: self.size },
        };
        let path = Path::new(shape, self.incline).map_err(|e| {
            let field = if e.field == "incline" {
                "incline"
            } else {
                "size"
            };
            StepError::setting(field, e.message)
        })?;
        let limits = MotionLimits {
            velocity: self.velocity,
            acceleration: self.acceleration,
            jerk: self.jerk,
        };
        let traj = Trajectory::plan(path, limits).map_err(|e| {
            let field = match e.field {
                "max_velocity" => "velocity",
                "max_acceleration" => "acceleration",
                "max_jerk" => "jerk",
                _ => "size",
            };
            StepError::setting(field, e.message)
        })?;
        if self.strict
            && let Some(note) = traj.velocity_notes().first()
        {
            return Err(StepError::setting("velocity", note.clone()));
        }
        Ok(traj)
    }
}

/// `fts trajectory`: the path sampled at `ts`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MakeTrajectory {
    /// The path and its limits.
    pub trajectory: TrajectorySettings,
    /// Sample time of the table, s; default 1e-3.
    pub ts: f64,
}

impl Default for MakeTrajectory {
    fn default() -> Self {
        Self {
            trajectory: TrajectorySettings::default(),
            ts: 1e-3,
        }
    }
}

/// The most rows a trajectory table may have.
pub const MAX_ROWS: usize = 10_000_000;

impl TrajectorySettings {
    /// The setting to blame for a sampled path of too many samples: the
    /// count grows with `size` and falls with each limit and with `ts`, so
    /// of these the one furthest from its default toward more samples
    /// (`default_ts` is the command's). Returns the field and its value as
    /// typed, with its unit.
    fn culprit(&self, ts: f64, default_ts: f64) -> (&'static str, String) {
        let d = TrajectorySettings::default();
        let v = |x: f64, unit: &str| format!("{} {unit}", super::fmt_value(x));
        let candidates = [
            ("size", self.size / d.size, v(self.size, "um")),
            (
                "velocity",
                d.velocity / self.velocity,
                v(self.velocity, "um/s"),
            ),
            (
                "acceleration",
                d.acceleration / self.acceleration,
                v(self.acceleration, "um/s^2"),
            ),
            ("jerk", d.jerk / self.jerk, v(self.jerk, "um/s^3")),
            ("ts", default_ts / ts, v(ts, "s")),
        ];
        let (field, _, value) = candidates
            .into_iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("five candidates");
        (field, value)
    }
}

/// Samples of a path of `duration` s at `ts`, at most [`MAX_ROWS`]; beyond,
/// the error names the setting that made it long ([`TrajectorySettings::culprit`]).
fn sample_count(settings: &TrajectorySettings, duration: f64, ts: f64) -> Result<usize, StepError> {
    let n = (duration / ts).ceil() + 1.0;
    if n > MAX_ROWS as f64 {
        let (field, value) = settings.culprit(ts, MakeTrajectory::default().ts);
        return Err(StepError::setting(
            field,
            format!(
                "{value} makes the table {} samples (a path of {} s at ts {} s); at most {MAX_ROWS} are written",
                super::fmt_about(n),
                super::fmt_about(duration),
                super::fmt_value(ts)
            ),
        ));
    }
    Ok(n as usize)
}

impl Validate for MakeTrajectory {
    fn validate(&self) -> Result<(), StepError> {
        positive("ts", self.ts)?;
        let traj = self.trajectory.plan()?;
        sample_count(&self.trajectory, traj.duration(), self.ts).map(|_| ())
    }
}

impl MakeTrajectory {
    /// Plans and samples the trajectory.
    pub fn run(&self) -> Result<TrajectoryReport, StepError> {
        self.validate()?;
        let trajectory = self.trajectory.plan()?;
        let n = sample_count(&self.trajectory, trajectory.duration(), self.ts)?;
        let mut samples = TrajectoryTable::default();
        for k in 0..n {
            let t = k as f64 * self.ts;
            let s = trajectory.at(t);
            samples.t.push(t);
            for i in 0..3 {
                samples.xyz[i].push(s.point[i]);
            }
            samples.speed.push(s.speed);
        }
        Ok(TrajectoryReport {
            trajectory,
            ts: self.ts,
            samples,
        })
    }
}

/// Sampled reference: time, position per axis, speed along the path.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrajectoryTable {
    /// Time, s.
    pub t: Vec<f64>,
    /// x, y, z, um.
    pub xyz: [Vec<f64>; 3],
    /// Speed along the path, um/s.
    pub speed: Vec<f64>,
}

/// The planned and sampled trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryReport {
    /// The plan: path and moves.
    pub trajectory: Trajectory,
    /// Sample time of the table, s.
    pub ts: f64,
    /// The table.
    pub samples: TrajectoryTable,
}

fn moves_json(traj: &Trajectory) -> Value {
    Value::Array(
        traj.moves
            .iter()
            .map(|c| {
                json!({
                    "distance_um": c.params.distance,
                    "segments_s": c.segments,
                    "duration_s": c.duration(),
                    "peak_velocity_um_s": c.peak_velocity,
                    "peak_acceleration_um_s2": c.peak_acceleration,
                    "velocity_reached": c.limited.is_none(),
                })
            })
            .collect(),
    )
}

fn trajectory_json(traj: &Trajectory) -> Value {
    let p = &traj.path;
    let (shape, size) = match p.shape {
        Shape::Circle { diameter } => ("circle", diameter),
        Shape::Square { side } => ("square", side),
    };
    let c = &traj.moves[0].params;
    json!({
        "shape": shape, "size_um": size, "incline_deg": p.incline_deg,
        "length_um": p.length(), "duration_s": traj.duration(),
        "limits": {"velocity_um_s": c.max_velocity, "acceleration_um_s2": c.max_acceleration,
            "jerk_um_s3": c.max_jerk},
        "moves": moves_json(traj),
        "notes": traj.velocity_notes(),
    })
}

impl Serialize for TrajectoryReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut v = trajectory_json(&self.trajectory);
        v["ts"] = json!(self.ts);
        v["samples"] = json!(self.samples.t.len());
        v.serialize(s)
    }
}

fn shape_text(shape: Shape) -> String {
    match shape {
        Shape::Circle { diameter } => format!("circle of diameter {diameter} um"),
        Shape::Square { side } => format!("square of side {side} um"),
    }
}

fn write_trajectory(f: &mut fmt::Formatter<'_>, traj: &Trajectory) -> fmt::Result {
    let c = &traj.moves[0];
    writeln!(
        f,
        "path: {}, inclined {} deg, length {:.3} um, {} move(s), {:.6} s",
        shape_text(traj.path.shape),
        traj.path.incline_deg,
        traj.path.length(),
        traj.moves.len(),
        traj.duration()
    )?;
    let [tj, ta, _, tv, ..] = c.segments;
    writeln!(
        f,
        "each move: jerk {tj:.6} s, constant acceleration {ta:.6} s, cruise {tv:.6} s; peak velocity {:.4} um/s, peak acceleration {:.4} um/s^2",
        c.peak_velocity, c.peak_acceleration
    )?;
    for note in traj.velocity_notes() {
        writeln!(f, "note: {note}")?;
    }
    Ok(())
}

impl fmt::Display for TrajectoryReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_trajectory(f, &self.trajectory)?;
        writeln!(f, "{} samples at ts = {} s", self.samples.t.len(), self.ts)
    }
}

impl TrajectoryReport {
    /// The table as CSV: `t,x,y,z,speed` (s, um, um/s).
    pub fn csv(&self) -> String {
        let s = &self.samples;
        crate::io::timeseries::write_csv(
            &["t", "x", "y", "z", "speed"],
            &[&s.t, &s.xyz[0], &s.xyz[1], &s.xyz[2], &s.speed],
        )
    }

    /// The path's x-y and y-z projections and the speed along it.
    pub fn svg(&self) -> Result<String, PlotError> {
        let bytes = self.plot(PlotFormat::Svg)?;
        Ok(String::from_utf8(bytes).expect("the SVG backend writes UTF-8"))
    }

    /// [`Self::svg`] in `format`.
    pub fn plot(&self, format: PlotFormat) -> Result<Vec<u8>, PlotError> {
        let s = &self.samples;
        let line = |label, x, y| Series { label, x, y };
        render(
            &[
                Panel::lines(
                    "path, x-y projection",
                    "x (um)",
                    "y (um)",
                    vec![line("reference", &s.xyz[0], &s.xyz[1])],
                )
                .with_equal_aspect(),
                Panel::lines(
                    "path, y-z projection",
                    "y (um)",
                    "z (um)",
                    vec![line("reference", &s.xyz[1], &s.xyz[2])],
                )
                .with_equal_aspect(),
                Panel::lines(
                    "speed along the path",
                    "t (s)",
                    "speed (um/s)",
                    vec![line("speed", &s.t, &s.speed)],
                ),
            ],
            format,
        )
    }
}

/// PID gains `[P, I, D, N]` of `P + I/s + D N s/(s + N)`.
pub type PidGains4 = [f64; 4];

fn pid_of(g: PidGains4) -> ParallelPid {
    ParallelPid {
        p: g[0],
        i: g[1],
        d: g[2],
        n: g[3],
    }
}

fn gains_of(p: ParallelPid) -> PidGains4 {
    [p.p, p.i, p.d, p.n]
}

/// The \[Karagoz18\] disturbance: 100 um at 75 rad/s at every plant output.
pub fn karagoz18_disturbance() -> Disturbance {
    Disturbance::Sines {
        components: vec![Sine {
            amplitude: 100.0,
            freq_hz: 75.0 / (2.0 * PI),
            phase_deg: 0.0,
        }],
    }
}

/// `fts contour`: three axes on a trajectory, with and without
/// cross-coupled control. Defaults are \[Karagoz18\] Table 2 and Sec. 5.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Contour {
    /// The path and its limits.
    pub trajectory: TrajectorySettings,
    /// Sample time of the loop, s; default 1e-6 (docs/contouring.md: the
    /// printed Y loop has a delay margin of 5.7 us).
    pub ts: f64,
    /// Time simulated after the trajectory ends, s; default 0.
    pub settle: f64,
    /// X axis PID `[P, I, D, N]` (used unless a controller file is given);
    /// default `[1, 0.01, 0.0005, 100]`.
    pub pid_x: PidGains4,
    /// Y axis PID; default `[1.5, 0.01, 0.0005, 100]`.
    pub pid_y: PidGains4,
    /// Z axis PID; default `[1, 0.01, 0.0005, 100]`.
    pub pid_z: PidGains4,
    /// Cross-coupling PID on the contour-error estimate (`None`: none);
    /// default `[0.4, 0.005, 0.0005, 100]`.
    pub cross_coupling: Option<PidGains4>,
    /// Also run the same axes without cross-coupling; default true.
    pub baseline: bool,
    /// Sines added at every plant output, um; default 100 um at 75 rad/s.
    pub output_disturbance: Option<Disturbance>,
    /// Lowest command of every controller fts builds here (the PIDs and
    /// `--x`/`--y`/`--z`/`--cc` systems; a controller file's block keeps
    /// its own limits); default none, as \[Karagoz18\] simulates.
    pub output_min: Option<f64>,
    /// Highest command of those controllers; default none.
    pub output_max: Option<f64>,
    /// Points kept in the trace for plots and CSV; default 20000.
    #[serde(deserialize_with = "whole_number")]
    pub trace_points: usize,
    /// What the PID gains run as: `pid` or `dob`; default pid.
    pub axis_controller: AxisKind,
    /// The observer and friction feedforward of `dob` axes.
    pub dob: DobSettings,
    /// Coulomb friction `Fc` at every plant's input, command units:
    /// `u_eff = u - Fc sign(v) - Fv v`; default 0.
    pub friction_coulomb: f64,
    /// Viscous friction `Fv` at every plant's input, command per um/s; default 0.
    pub friction_viscous: f64,
}

impl Default for Contour {
    fn default() -> Self {
        Self {
            trajectory: TrajectorySettings::default(),
            ts: 1e-6,
            settle: 0.0,
            pid_x: gains_of(KARAGOZ18_AXIS_PID[0]),
            pid_y: gains_of(KARAGOZ18_AXIS_PID[1]),
            pid_z: gains_of(KARAGOZ18_AXIS_PID[2]),
            cross_coupling: Some(gains_of(KARAGOZ18_CC_PID)),
            baseline: true,
            output_disturbance: Some(karagoz18_disturbance()),
            output_min: None,
            output_max: None,
            trace_points: 20_000,
            axis_controller: AxisKind::Pid,
            dob: DobSettings::default(),
            friction_coulomb: 0.0,
            friction_viscous: 0.0,
        }
    }
}

/// The plants and any controller files, per axis.
#[derive(Debug, Clone, PartialEq)]
pub struct ContourInputs {
    /// Command to position (um), continuous or discrete at `ts`.
    pub plants: [StateSpace; 3],
    /// Controllers replacing the PIDs (a state-space or transfer-function
    /// system, or a controller file's block), with the name to report.
    pub controllers: [Option<(AxisController, String)>; 3],
    /// A controller replacing the cross-coupling PID (used when
    /// `cross_coupling` is set), with the name to report.
    pub cross: Option<(AxisController, String)>,
}

/// The \[Karagoz18\] Eq. 2-4 plants, continuous.
pub fn karagoz18_plants() -> [StateSpace; 3] {
    KARAGOZ18_PLANTS.map(|(num, den)| {
        StateSpace::from_tf(num, den, None).expect("the published plants are proper")
    })
}

impl Default for ContourInputs {
    fn default() -> Self {
        Self {
            plants: karagoz18_plants(),
            controllers: [None, None, None],
            cross: None,
        }
    }
}

fn check_pid(field: &'static str, g: PidGains4) -> Result<(), StepError> {
    if g.iter().all(|v| v.is_finite()) && g[3] > 0.0 {
        Ok(())
    } else {
        Err(StepError::setting(
            field,
            format!(
                "expected P,I,D,N finite with N > 0 (rad/s), got {}",
                g.map(super::fmt_value).join(",")
            ),
        ))
    }
}

impl Validate for Contour {
    fn validate(&self) -> Result<(), StepError> {
        positive("ts", self.ts)?;
        if !(self.settle.is_finite() && self.settle >= 0.0) {
            return Err(StepError::setting(
                "settle",
                format!(
                    "expected seconds >= 0, got {}",
                    super::fmt_value(self.settle)
                ),
            ));
        }
        check_pid("pid_x", self.pid_x)?;
        check_pid("pid_y", self.pid_y)?;
        check_pid("pid_z", self.pid_z)?;
        if let Some(g) = self.cross_coupling {
            check_pid("cross_coupling", g)?;
        }
        command_limits(self.output_min, self.output_max)?;
        self.sines()?;
        if self.axis_controller == AxisKind::Dob {
            self.dob.validate(self.ts)?;
        }
        for (field, v) in [
            ("friction_coulomb", self.friction_coulomb),
            ("friction_viscous", self.friction_viscous),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(StepError::setting(
                    field,
                    format!("expected a finite number >= 0, got {}", super::fmt_value(v)),
                ));
            }
        }
        let traj = self.trajectory.plan()?;
        let n = (traj.duration() + self.settle) / self.ts;
        if n > 1e9 {
            let (field, value) = if self.settle > traj.duration() {
                ("settle", format!("{} s", super::fmt_value(self.settle)))
            } else {
                self.trajectory.culprit(self.ts, Contour::default().ts)
            };
            return Err(StepError::setting(
                field,
                format!(
                    "{value} makes the run {} samples ({} s at ts {} s); at most 1e9 are simulated",
                    super::fmt_about(n),
                    super::fmt_about(traj.duration() + self.settle),
                    super::fmt_value(self.ts)
                ),
            ));
        }
        Ok(())
    }
}

/// The command limits `output_min` < `output_max`, each finite.
fn command_limits(min: Option<f64>, max: Option<f64>) -> Result<CommandLimits, StepError> {
    super::check_command_limits(min, max, "a finite command")?;
    Ok(CommandLimits { min, max })
}

/// `PID P + I/s + D N s/(s + N)`.
fn pid_name(g: PidGains4) -> String {
    format!(
        "PID {} + {}/s + {} {} s/(s + {})",
        g[0], g[1], g[2], g[3], g[3]
    )
}

fn contour_error(e: ContourError) -> StepError {
    match e {
        ContourError::Setup(m) => StepError::input(m),
        other => StepError::computation(other.to_string()),
    }
}

/// A run with the closed-loop pole radii of its axes.
#[derive(Debug, Clone, PartialEq)]
pub struct AxesRun {
    /// Figures and trace.
    pub run: ContourRun,
    /// Each axis's own closed loop.
    pub axis_loops: [AxisLoop; 3],
    /// The controllers as the multi-axis file the run executed.
    pub controller: MultiAxisControllerFile,
}

impl Contour {
    fn sines(&self) -> Result<Vec<Sine>, StepError> {
        match &self.output_disturbance {
            None => Ok(Vec::new()),
            Some(Disturbance::Sines { components }) => {
                Disturbance::Sines {
                    components: components.clone(),
                }
                .validate()
                .map_err(|e| StepError::setting("output_disturbance", e.0))?;
                Ok(components.clone())
            }
            Some(_) => Err(StepError::setting(
                "output_disturbance",
                "contour takes a sum of sines (sines:A@F,..)",
            )),
        }
    }

    /// The controller of PID gains `g` on `plant` (its own nominal model
    /// for a DOB), named in `name`.
    fn pid_axis(&self, g: PidGains4, plant: &StateSpace, name: &mut String) -> AxisController {
        match self.axis_controller {
            AxisKind::Pid => {
                *name = pid_name(g);
                AxisController::Pid(pid_of(g))
            }
            AxisKind::Dob => {
                *name = self.dob.name(g);
                AxisController::Dob(Box::new(DobAxis {
                    pid: pid_of(g),
                    nominal: plant.clone(),
                    q_hz: self.dob.q_hz,
                    q_order: self.dob.q_order,
                    coulomb: self.dob.coulomb,
                    viscous: self.dob.viscous,
                    smoothing: self.dob.smoothing,
                }))
            }
        }
    }

    fn axes(&self, inputs: &ContourInputs) -> Result<([AxisSetup; 3], [String; 3]), StepError> {
        let sines = self.sines()?;
        let pids = [self.pid_x, self.pid_y, self.pid_z];
        let mut names: [String; 3] = Default::default();
        let axes = std::array::from_fn(|i| {
            let controller = match &inputs.controllers[i] {
                Some((k, name)) => {
                    names[i] = name.clone();
                    k.clone()
                }
                None => {
                    let g = pids[i];
                    self.pid_axis(g, &inputs.plants[i], &mut names[i])
                }
            };
            AxisSetup {
                plant: inputs.plants[i].clone(),
                controller,
                disturbance: sines.clone(),
                friction: Friction {
                    coulomb: self.friction_coulomb,
                    viscous: self.friction_viscous,
                },
            }
        });
        Ok((axes, names))
    }

    fn simulate(
        &self,
        axes: &[AxisSetup; 3],
        cc: Option<&AxisController>,
        traj: &Trajectory,
    ) -> Result<AxesRun, StepError> {
        let limits = command_limits(self.output_min, self.output_max)?;
        let mut lp = MultiAxisLoop::new(axes, cc, self.ts, limits).map_err(contour_error)?;
        let run = run(&mut lp, traj, self.settle, self.trace_points).map_err(contour_error)?;
        Ok(AxesRun {
            run,
            axis_loops: lp.axis_loops,
            controller: lp.file,
        })
    }

    /// Runs the axes with cross-coupling (when set) and, with `baseline`,
    /// the same axes without it.
    pub fn run(&self, inputs: &ContourInputs) -> Result<ContourReport, StepError> {
        self.validate()?;
        let trajectory = self.trajectory.plan()?;
        let (axes, controllers) = self.axes(inputs)?;
        let cc = match (self.cross_coupling, &inputs.cross) {
            (None, _) => None,
            (Some(_), Some((k, _))) => Some(k.clone()),
            (Some(g), None) => Some(AxisController::Pid(pid_of(g))),
        };
        let cross_name = match (&cc, &inputs.cross) {
            (Some(_), Some((_, name))) => Some(name.clone()),
            (Some(_), None) => self.cross_coupling.map(pid_name),
            (None, _) => None,
        };
        let started = std::time::Instant::now();
        let main = self.simulate(&axes, cc.as_ref(), &trajectory)?;
        let baseline = match (&cc, self.baseline) {
            (Some(_), true) => Some(self.simulate(&axes, None, &trajectory)?.run),
            _ => None,
        };
        Ok(ContourReport {
            trajectory,
            ts: self.ts,
            controllers,
            cross_coupling: cross_name,
            disturbance: self.sines()?,
            limits: command_limits(self.output_min, self.output_max)?,
            main,
            baseline,
            seconds: started.elapsed().as_secs_f64(),
            friction: Friction {
                coulomb: self.friction_coulomb,
                viscous: self.friction_viscous,
            },
        })
    }
}

/// The multi-axis controller file without a run (the manifest's
/// `multiaxis` step): each axis's controller (a system, by Tustin, or the
/// Table 2 PID), the cross-coupling controller, at `ts`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BuildMultiAxis {
    /// Sample time, s; default 1e-6.
    pub ts: f64,
    /// X PID `P, I, D, N` used without an X controller; default Table 2.
    pub pid_x: PidGains4,
    /// Y PID; default Table 2.
    pub pid_y: PidGains4,
    /// Z PID; default Table 2.
    pub pid_z: PidGains4,
    /// Cross-coupling PID used without a coupling controller; default Table 2.
    pub cross_coupling: PidGains4,
    /// Write the coupling (false: uncoupled axes); default true.
    pub coupled: bool,
    /// Lowest command of every controller written; default none.
    pub output_min: Option<f64>,
    /// Highest command of every controller written; default none.
    pub output_max: Option<f64>,
    /// What the PID gains are written as: `pid` or `dob` (with the
    /// \[Karagoz18\] Eq. 2-4 plants as the observers' nominal models);
    /// default pid.
    pub axis_controller: AxisKind,
    /// The observer and friction feedforward of `dob` axes.
    pub dob: DobSettings,
}

impl Default for BuildMultiAxis {
    fn default() -> Self {
        let c = Contour::default();
        Self {
            ts: c.ts,
            pid_x: c.pid_x,
            pid_y: c.pid_y,
            pid_z: c.pid_z,
            cross_coupling: gains_of(KARAGOZ18_CC_PID),
            coupled: true,
            output_min: None,
            output_max: None,
            axis_controller: AxisKind::Pid,
            dob: DobSettings::default(),
        }
    }
}

impl Validate for BuildMultiAxis {
    fn validate(&self) -> Result<(), StepError> {
        positive("ts", self.ts)?;
        check_pid("pid_x", self.pid_x)?;
        check_pid("pid_y", self.pid_y)?;
        check_pid("pid_z", self.pid_z)?;
        check_pid("cross_coupling", self.cross_coupling)?;
        if self.axis_controller == AxisKind::Dob {
            self.dob.validate(self.ts)?;
        }
        command_limits(self.output_min, self.output_max).map(|_| ())
    }
}

impl BuildMultiAxis {
    /// The file of `controllers` (`None`: that axis's PID) and `cross`
    /// (`None`: the coupling PID), with `provenance`.
    pub fn run(
        &self,
        controllers: [Option<AxisController>; 3],
        cross: Option<AxisController>,
        provenance: crate::io::controller_file::Provenance,
    ) -> Result<MultiAxisControllerFile, StepError> {
        self.validate()?;
        let pids = [self.pid_x, self.pid_y, self.pid_z];
        let plants = karagoz18_plants();
        let as_contour = Contour {
            axis_controller: self.axis_controller,
            dob: self.dob.clone(),
            ..Contour::default()
        };
        let axes: [AxisController; 3] = std::array::from_fn(|i| {
            controllers[i]
                .clone()
                .unwrap_or_else(|| as_contour.pid_axis(pids[i], &plants[i], &mut String::new()))
        });
        let cross = self
            .coupled
            .then(|| cross.unwrap_or_else(|| AxisController::Pid(pid_of(self.cross_coupling))));
        let mut file = crate::sim::contour::controller_file(
            [&axes[0], &axes[1], &axes[2]],
            cross.as_ref(),
            self.ts,
            command_limits(self.output_min, self.output_max)?,
        )
        .map_err(contour_error)?;
        file.provenance = provenance;
        Ok(file)
    }
}

/// What a contouring run found.
#[derive(Debug, Clone, PartialEq)]
pub struct ContourReport {
    /// The trajectory followed.
    pub trajectory: Trajectory,
    /// Loop sample time, s.
    pub ts: f64,
    /// Each axis's controller, described.
    pub controllers: [String; 3],
    /// The cross-coupling controller, described, if any.
    pub cross_coupling: Option<String>,
    /// The output disturbance of every axis.
    pub disturbance: Vec<Sine>,
    /// The command limits of the controllers fts built.
    pub limits: CommandLimits,
    /// The run (with cross-coupling when set).
    pub main: AxesRun,
    /// The same axes without cross-coupling.
    pub baseline: Option<ContourRun>,
    /// Wall-clock time of the simulations, s.
    pub seconds: f64,
    /// Friction at every plant's input.
    pub friction: Friction,
}

fn metrics_json(m: &ContourMetrics) -> Value {
    json!({
        "rms": {"x": m.rms_axis[0], "y": m.rms_axis[1], "z": m.rms_axis[2],
            "contour": m.rms_contour, "contour_estimate": m.rms_estimate},
        "max": {"x": m.max_axis[0], "y": m.max_axis[1], "z": m.max_axis[2],
            "contour": m.max_contour, "contour_estimate": m.max_estimate},
        "samples": m.samples,
        "limited_samples": m.limited_samples,
    })
}

impl ContourReport {
    /// The command limits and how often the run met them; the axes'
    /// stability above is that of the linear loops.
    fn write_limits(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let CommandLimits { min, max } = self.limits;
        if min.is_none() && max.is_none() {
            return Ok(());
        }
        let bound = |v: Option<f64>| v.map_or("none".to_owned(), super::fmt_value);
        let m = &self.main.run.metrics;
        writeln!(
            f,
            "command limits {} .. {} on every controller fts built: {} of {} samples ({:.2} %) at or beyond a limit{}",
            bound(min),
            bound(max),
            m.limited_samples,
            m.samples,
            100.0 * m.limited_samples as f64 / m.samples.max(1) as f64,
            if m.limited_samples > 0 {
                " (the stability above is the linear loops'; the run is the limited one)"
            } else {
                ""
            }
        )
    }

    /// Baseline contour RMS over the run's (exact and estimate), when both exist.
    pub fn improvement(&self) -> Option<(f64, f64)> {
        let (b, m) = (&self.baseline.as_ref()?.metrics, &self.main.run.metrics);
        Some((
            b.rms_contour / m.rms_contour,
            b.rms_estimate / m.rms_estimate,
        ))
    }

    fn axes_json(&self) -> Value {
        Value::Array(
            (0..3)
                .map(|i| {
                    let l = self.main.axis_loops[i];
                    json!({"axis": AXES[i], "controller": self.controllers[i],
                    "closed_loop_pole_radius": l.pole_radius,
                    "least_damping": l.least_damping, "least_damped_hz": l.least_damped_hz})
                })
                .collect(),
        )
    }
}

impl Serialize for ContourReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let improvement = self.improvement().map(
            |(exact, est)| json!({"contour_rms_ratio": exact, "contour_estimate_rms_ratio": est}),
        );
        json!({
            "trajectory": trajectory_json(&self.trajectory),
            "ts": self.ts,
            "axes": self.axes_json(),
            "cross_coupling": self.cross_coupling,
            "disturbance_um": self.disturbance,
            "output_min": self.limits.min,
            "output_max": self.limits.max,
            "errors_um": metrics_json(&self.main.run.metrics),
            "baseline_errors_um": self.baseline.as_ref().map(|b| metrics_json(&b.metrics)),
            "improvement": improvement,
            "friction_coulomb": self.friction.coulomb,
            "friction_viscous": self.friction.viscous,
            "seconds": self.seconds,
        })
        .serialize(s)
    }
}

fn write_metrics(f: &mut fmt::Formatter<'_>, label: &str, m: &ContourMetrics) -> fmt::Result {
    let a = |v: [f64; 3]| format!("{:>10.4} {:>10.4} {:>10.4}", v[0], v[1], v[2]);
    writeln!(
        f,
        "{label:<22} RMS {} {:>10.4} {:>10.4}",
        a(m.rms_axis),
        m.rms_contour,
        m.rms_estimate
    )?;
    writeln!(
        f,
        "{:<22} max {} {:>10.4} {:>10.4}",
        "",
        a(m.max_axis),
        m.max_contour,
        m.max_estimate
    )
}

impl fmt::Display for ContourReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_trajectory(f, &self.trajectory)?;
        writeln!(
            f,
            "loop: ts = {} s (plants ZOH, controllers Tustin), {} samples, {:.2} s",
            self.ts, self.main.run.metrics.samples, self.seconds
        )?;
        for d in &self.disturbance {
            writeln!(
                f,
                "output disturbance on every axis: {} um at {:.6} Hz ({:.4} rad/s)",
                d.amplitude,
                d.freq_hz,
                2.0 * PI * d.freq_hz
            )?;
        }
        if self.friction != Friction::default() {
            writeln!(
                f,
                "friction at every plant input: Fc {} sign(v) + Fv {} v (v in um/s)",
                self.friction.coulomb, self.friction.viscous
            )?;
        }
        for ((axis, controller), l) in AXES
            .iter()
            .zip(&self.controllers)
            .zip(&self.main.axis_loops)
        {
            writeln!(
                f,
                "axis {axis}: {controller}; closed loop stable, least damped pole zeta {:.4} at {:.3} Hz",
                l.least_damping, l.least_damped_hz
            )?;
        }
        writeln!(
            f,
            "errors (um)                   e_x        e_y        e_z    contour   estimate"
        )?;
        if let Some(cc) = &self.cross_coupling {
            writeln!(f, "cross-coupling: {cc}")?;
        }
        self.write_limits(f)?;
        let label = match self.cross_coupling {
            Some(_) => "with CCC",
            None => "no cross-coupling",
        };
        write_metrics(f, label, &self.main.run.metrics)?;
        if let Some(b) = &self.baseline {
            write_metrics(f, "without CCC", &b.metrics)?;
        }
        if let Some((exact, est)) = self.improvement() {
            let verdict = if exact > 1.0 {
                "lowers"
            } else {
                "does NOT lower"
            };
            writeln!(
                f,
                "cross-coupling {verdict} the contour error: RMS ratio without/with {exact:.4} (exact), {est:.4} (estimate)"
            )?;
        }
        Ok(())
    }
}

/// `r + gain (p - r)` in the path's plane: `(q . u1, q . u2)` with
/// `u1 = (1, 0, 0)`, `u2 = (0, cos th, sin th)`.
fn in_plane(
    reference: &[Vec<f64>; 3],
    position: &[Vec<f64>; 3],
    gain: f64,
    th: f64,
) -> [Vec<f64>; 2] {
    let q = |i: usize, k: usize| reference[i][k] + gain * (position[i][k] - reference[i][k]);
    let n = reference[0].len().min(position[0].len());
    [
        (0..n).map(|k| q(0, k)).collect(),
        (0..n)
            .map(|k| q(1, k) * th.cos() + q(2, k) * th.sin())
            .collect(),
    ]
}

impl ContourReport {
    /// The magnification (1, 2 or 5 times a power of ten, putting the
    /// largest contour error at up to 15 % of the path's size) and the
    /// in-plane reference, positions and positions without CCC.
    fn in_plane_magnified(&self) -> (f64, Vec<[Vec<f64>; 2]>) {
        let t = &self.main.run.trace;
        let largest = std::iter::once(&self.main.run.metrics)
            .chain(self.baseline.as_ref().map(|b| &b.metrics))
            .map(|m| m.max_contour)
            .fold(0.0, f64::max);
        let size = match self.trajectory.path.shape {
            Shape::Circle { diameter } => diameter,
            Shape::Square { side } => side,
        };
        let raw = 0.15 * size / largest.max(1e-300);
        let decade = 10f64.powf(raw.log10().floor());
        let step = [5.0, 2.0, 1.0].into_iter().find(|m| m * decade <= raw);
        let gain = (step.unwrap_or(1.0) * decade).max(1.0);
        let th = self.trajectory.path.incline_deg.to_radians();
        let mut out = vec![in_plane(&t.reference, &t.reference, 0.0, th)];
        out.push(in_plane(&t.reference, &t.position, gain, th));
        if let Some(b) = &self.baseline {
            out.push(in_plane(&t.reference, &b.trace.position, gain, th));
        }
        (gain, out)
    }

    /// The thinned trace as CSV: `t, x_ref, y_ref, z_ref, x, y, z, contour,
    /// contour_estimate` (s, um), then `x_nocc, y_nocc, z_nocc,
    /// contour_nocc, contour_estimate_nocc` with a baseline.
    pub fn trace_csv(&self) -> String {
        let t = &self.main.run.trace;
        let mut names = vec![
            "t",
            "x_ref",
            "y_ref",
            "z_ref",
            "x",
            "y",
            "z",
            "contour",
            "contour_estimate",
        ];
        let mut cols: Vec<&[f64]> = vec![&t.t];
        cols.extend(t.reference.iter().map(Vec::as_slice));
        cols.extend(t.position.iter().map(Vec::as_slice));
        cols.extend([t.contour.as_slice(), t.estimate.as_slice()]);
        if let Some(b) = &self.baseline {
            names.extend([
                "x_nocc",
                "y_nocc",
                "z_nocc",
                "contour_nocc",
                "contour_estimate_nocc",
            ]);
            cols.extend(b.trace.position.iter().map(Vec::as_slice));
            cols.extend([b.trace.contour.as_slice(), b.trace.estimate.as_slice()]);
        }
        crate::io::timeseries::write_csv(&names, &cols)
    }

    /// Path projections (reference and actual), tracking errors per axis
    /// and the contour error (with and without cross-coupling).
    pub fn svg(&self) -> Result<String, PlotError> {
        let bytes = self.plot(PlotFormat::Svg)?;
        Ok(String::from_utf8(bytes).expect("the SVG backend writes UTF-8"))
    }

    /// [`Self::svg`] in `format`.
    pub fn plot(&self, format: PlotFormat) -> Result<Vec<u8>, PlotError> {
        let t = &self.main.run.trace;
        let errors: Vec<Vec<f64>> = (0..3)
            .map(|i| {
                t.reference[i]
                    .iter()
                    .zip(&t.position[i])
                    .map(|(r, y)| r - y)
                    .collect()
            })
            .collect();
        let line = |label, x, y| Series { label, x, y };
        let projection = |a: usize, b: usize| {
            let mut s = vec![
                line("reference", &t.reference[a], &t.reference[b]),
                line("position", &t.position[a], &t.position[b]),
            ];
            if let Some(base) = &self.baseline {
                s.push(line(
                    "position without CCC",
                    &base.trace.position[a],
                    &base.trace.position[b],
                ));
            }
            s
        };
        let mut contour = vec![
            line("distance to the path", &t.t, &t.contour),
            line("estimate |e - (e.t) t|", &t.t, &t.estimate),
        ];
        if let Some(base) = &self.baseline {
            contour.push(line(
                "distance, without CCC",
                &base.trace.t,
                &base.trace.contour,
            ));
        }
        let (gain, plane) = self.in_plane_magnified();
        let plane_title = format!("path in its own plane, errors magnified {gain}x");
        let mut in_plane = vec![line("reference", &plane[0][0], &plane[0][1])];
        let labels = ["position", "position without CCC"];
        for (label, p) in labels.into_iter().zip(&plane[1..]) {
            in_plane.push(line(label, &p[0], &p[1]));
        }
        render(
            &[
                Panel::lines(
                    &plane_title,
                    "along x (um)",
                    "along the inclined axis (um)",
                    in_plane,
                )
                .with_equal_aspect(),
                Panel::lines("path, x-y projection", "x (um)", "y (um)", projection(0, 1))
                    .with_equal_aspect(),
                Panel::lines("path, y-z projection", "y (um)", "z (um)", projection(1, 2))
                    .with_equal_aspect(),
                Panel::lines(
                    "tracking error per axis",
                    "t (s)",
                    "e (um)",
                    vec![
                        line("e_x", &t.t, &errors[0]),
                        line("e_y", &t.t, &errors[1]),
                        line("e_z", &t.t, &errors[2]),
                    ],
                ),
                Panel::lines("contour error", "t (s)", "contour error (um)", contour),
            ],
            format,
        )
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn settings_deserialise_with_their_defaults() {
        let s: Contour = toml::from_str("").unwrap();
        assert_eq!(s, Contour::default());
        let s: Contour =
            toml::from_str("ts = 1e-5\npid_y = [2, 0, 0, 50]\n[trajectory]\nshape = \"square\"")
                .unwrap();
        assert_eq!(s.pid_y, [2.0, 0.0, 0.0, 50.0]);
        assert_eq!(s.trajectory.shape, PathShape::Square);
        assert!(toml::from_str::<Contour>("tss = 1").is_err());
        let t: MakeTrajectory = toml::from_str("ts = 0.01").unwrap();
        assert_eq!(t.trajectory, TrajectorySettings::default());
    }

    pub fn an_unreachable_velocity_is_said_and_refused_when_strict() {
        let mut step = MakeTrajectory {
            ts: 0.01,
            ..MakeTrajectory::default()
        };
        step.trajectory.shape = PathShape::Square;
        let report = step.run().unwrap();
        assert!(
            report
                .to_string()
                .contains("note: move 1: velocity 30000 cannot be reached"),
            "{report}"
        );
        let v = serde_json::to_value(&report).unwrap();
        assert_eq!(v["moves"].as_array().map(Vec::len), Some(4));
        assert_eq!(v["moves"][0]["velocity_reached"], json!(false));
        step.trajectory.strict = true;
        let e = step.run().unwrap_err();
        assert!(
            matches!(
                e,
                StepError::Input {
                    field: Some("velocity"),
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("2664.6"), "{e}");
        assert!(report.csv().starts_with("t,x,y,z,speed\n0,0,0,0,0\n"));
    }

    pub fn in_plane_coordinates_are_along_u1_and_the_inclined_u2() {
        // th = 30 deg: u2 = (0, cos, sin). The reference (0, 2 cos, 2 sin)
        // is at (0, 2); a position 0.1 further along u2 shows 10x at 1.
        let th = 30f64.to_radians();
        let (c, s) = (th.cos(), th.sin());
        let r = [vec![3.0, 0.0], vec![0.0, 2.0 * c], vec![0.0, 2.0 * s]];
        let p = [vec![3.0, 0.0], vec![0.0, 2.1 * c], vec![0.0, 2.1 * s]];
        let q = in_plane(&r, &p, 10.0, th);
        assert_eq!(q[0], vec![3.0, 0.0]);
        assert!(
            (q[1][0]).abs() < 1e-15 && (q[1][1] - 3.0).abs() < 1e-12,
            "{q:?}"
        );
        let q = in_plane(&r, &p, 0.0, th);
        assert!((q[1][1] - 2.0).abs() < 1e-15);
    }

    pub fn bad_settings_name_their_key() {
        let bad = Contour {
            pid_x: [1.0, 0.0, 0.0, 0.0],
            ..Contour::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(StepError::Input {
                field: Some("pid_x"),
                ..
            })
        ));
        let mut bad = Contour::default();
        bad.trajectory.jerk = -1.0;
        assert!(matches!(
            bad.validate(),
            Err(StepError::Input {
                field: Some("jerk"),
                ..
            })
        ));
        let bad = Contour {
            output_disturbance: Some(Disturbance::Samples {
                values: vec![1.0],
                time_s: None,
            }),
            ..Contour::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(StepError::Input {
                field: Some("output_disturbance"),
                ..
            })
        ));
    }

    /// A table too long blames the setting that made it long, with the
    /// value as typed (docs/formats.md "Naming options").
    pub fn a_table_too_long_names_the_setting_that_made_it_so() {
        let field = |f: &dyn Fn(&mut MakeTrajectory)| {
            let mut step = MakeTrajectory::default();
            f(&mut step);
            match step.validate() {
                Err(StepError::Input {
                    field: Some(k),
                    message,
                }) => (k, message),
                other => panic!("{other:?}"),
            }
        };
        let (k, m) = field(&|s| s.trajectory.size = 1e300);
        assert_eq!(k, "size");
        assert!(
            m.starts_with("1e300 um makes the table 1.047e299 samples"),
            "{m}"
        );
        assert_eq!(
            field(&|s| s.trajectory.acceleration = 1e-300).0,
            "acceleration"
        );
        assert_eq!(field(&|s| s.trajectory.jerk = 1e-300).0, "jerk");
        assert_eq!(field(&|s| s.trajectory.velocity = 1e-300).0, "velocity");
        let (k, m) = field(&|s| s.ts = 1e-12);
        assert_eq!(k, "ts");
        assert!(m.starts_with("1e-12 s makes the table"), "{m}");
        let mut run = Contour {
            settle: 1e9,
            ..Contour::default()
        };
        assert!(matches!(
            run.validate(),
            Err(StepError::Input {
                field: Some("settle"),
                ..
            })
        ));
        run.settle = 0.0;
        run.trajectory.size = 1e12;
        assert!(matches!(
            run.validate(),
            Err(StepError::Input {
                field: Some("size"),
                ..
            })
        ));
    }
}
