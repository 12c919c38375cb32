//! `fts mechanism flexure-loss|hinge|3puu|lever|bridge|amplifier`: the mechanism design formulas
//! (docs/mechanism.md). The steps are the library's
//! ([`crate::workflow::mechanism`]); this file turns flags into them,
//! renders the reports and draws the workspace.

use super::common::{bad, print_report, step_error, write_plot};
use crate::io::plot::{Panel, PlotFormat, Series, Style, render};
use crate::workflow::Validate;
use crate::workflow::mechanism::{
    Amplifier, Bridge, FlexureLoss, Hinge, Lever, Puu3Report, Puu3Study, TANG17_AMPLIFICATION,
};
use crate::workflow::puu3::{ControlMode, JointModel, Puu3Track};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Subcommand)]
pub enum MechanismCommand {
    /// [Li21] Eq. 1: displacement delivered and lost through a flexure in series with the actuator.
    FlexureLoss(FlexureArgs),
    /// [Li21] Eq. 2: rotational stiffness of a straight-beam flexure hinge with circular fillets.
    Hinge(HingeArgs),
    /// [Tang17] 3-PUU parallel FTS: inverse kinematics, Jacobian, conditioning, Monte-Carlo workspace.
    #[command(name = "3puu")]
    Puu3(Puu3Args),
    /// [Tang17] 3-PUU three-axis control: task reference -> inverse kinematics -> three joint loops (joint or task space) -> forward kinematics.
    #[command(name = "3puu-track")]
    Puu3Track(Puu3TrackArgs),
    /// Lever amplifier: L_out/L_in, with a leaf-hinge pivot, and the output arm for a target ratio.
    Lever(LeverArgs),
    /// Bridge-type amplifier: cot(angle), with compliant hinges, and the angle for a target ratio.
    Bridge(BridgeArgs),
    /// A bridge driving a lever by compliance matrices: each stage's ratio, the overall ratio, the angle for a target.
    Amplifier(AmplifierArgs),
}

/// A leaf hinge (all optional: without --hinge-width-mm there is no hinge).
/// Each flag's id is the hinge's setting, so the hinge's errors name it.
#[derive(Debug, Args)]
pub struct HingeFlags {
    /// Hinge width b, mm: gives the pivot/hinges their compliance (the profile's, segments in series).
    #[arg(id = "width_mm", long = "hinge-width-mm")]
    hinge_width_mm: Option<f64>,
    /// Hinge length l, mm.
    #[arg(id = "length_mm", long = "hinge-length-mm", default_value_t = Hinge::default().length_mm)]
    hinge_length_mm: f64,
    /// Hinge thickness t, mm.
    #[arg(id = "thickness_mm", long = "hinge-thickness-mm", default_value_t = Hinge::default().thickness_mm)]
    hinge_thickness_mm: f64,
    /// Hinge fillet radius R, mm.
    #[arg(id = "radius_mm", long = "hinge-radius-mm", default_value_t = Hinge::default().radius_mm)]
    hinge_radius_mm: f64,
    /// Young's modulus, GPa.
    #[arg(long, default_value_t = Hinge::default().e_gpa)]
    e_gpa: f64,
}

impl HingeFlags {
    /// The hinge, checked here so that an error names its own `--hinge-*`
    /// option (the step's error, nested, would name `hinge`).
    fn hinge(&self) -> anyhow::Result<Option<Hinge>> {
        let Some(w) = self.hinge_width_mm else {
            return Ok(None);
        };
        let h = Hinge {
            e_gpa: self.e_gpa,
            width_mm: Some(w),
            length_mm: self.hinge_length_mm,
            thickness_mm: self.hinge_thickness_mm,
            radius_mm: self.hinge_radius_mm,
        };
        h.validate().map_err(step_error)?;
        Ok(Some(h))
    }
}

#[derive(Debug, Args)]
pub struct LeverArgs {
    /// Pivot to input point, mm.
    #[arg(long)]
    input_arm_mm: f64,
    /// Pivot to output point, mm (without it: only the arm for --target-ratio).
    #[arg(long)]
    output_arm_mm: Option<f64>,
    #[command(flatten)]
    hinge: HingeFlags,
    /// Actuator stiffness, N/um ([Li21] Eq. 1 against the lever's input stiffness).
    #[arg(long)]
    kp: Option<f64>,
    /// Actuator free stroke, um.
    #[arg(long, default_value_t = Lever::default().dl0)]
    dl0: f64,
    /// Target ratio of the inverse ([Tang17]'s measured 3.87).
    #[arg(long, default_value_t = TANG17_AMPLIFICATION)]
    target_ratio: f64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct BridgeArgs {
    /// Link angle to the input axis, deg (without it: only the angle for --target-ratio).
    #[arg(long)]
    angle_deg: Option<f64>,
    /// Link length between hinge centres, mm (needed with a hinge).
    #[arg(long)]
    link_mm: Option<f64>,
    #[command(flatten)]
    hinge: HingeFlags,
    /// Target ratio of the inverse ([Tang17]'s measured 3.87).
    #[arg(long, default_value_t = TANG17_AMPLIFICATION)]
    target_ratio: f64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct AmplifierArgs {
    /// Bridge link angle to the input axis, deg (without it: only the angle for --target-ratio).
    #[arg(long)]
    angle_deg: Option<f64>,
    /// Bridge: distance between the hinge centres, mm.
    #[arg(long)]
    link_mm: f64,
    /// Lever: pivot to input (driven by the bridge), mm.
    #[arg(long)]
    input_arm_mm: f64,
    /// Lever: pivot to output (the tool), mm.
    #[arg(long)]
    output_arm_mm: f64,
    /// The bridge's hinges, also the lever's pivot (--hinge-width-mm required).
    #[command(flatten)]
    hinge: HingeFlags,
    /// Actuator stiffness, N/um ([Li21] Eq. 1 against the chain's input stiffness).
    #[arg(long)]
    kp: Option<f64>,
    /// Actuator free stroke, um.
    #[arg(long, default_value_t = Amplifier::default().dl0)]
    dl0: f64,
    /// Overall ratio the inverse aims at ([Tang17]'s measured 3.87).
    #[arg(long, default_value_t = TANG17_AMPLIFICATION)]
    target_ratio: f64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct FlexureArgs {
    /// Actuator stiffness (N/um or any unit shared with --k).
    #[arg(long, default_value_t = FlexureLoss::default().kp)]
    kp: f64,
    /// Flexure stiffness.
    #[arg(long, default_value_t = FlexureLoss::default().k)]
    k: f64,
    /// Free stroke of the actuator, um.
    #[arg(long, default_value_t = FlexureLoss::default().dl0)]
    dl0: f64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct HingeArgs {
    /// Young's modulus, GPa (default: 65Mn spring steel, handbook value).
    #[arg(long, default_value_t = Hinge::default().e_gpa)]
    e_gpa: f64,
    /// Hinge width b (out of plane), mm.
    #[arg(long)]
    width_mm: f64,
    /// Beam length l, mm.
    #[arg(long, default_value_t = Hinge::default().length_mm)]
    length_mm: f64,
    /// Thickness t, mm.
    #[arg(long, default_value_t = Hinge::default().thickness_mm)]
    thickness_mm: f64,
    /// Fillet radius R, mm.
    #[arg(long, default_value_t = Hinge::default().radius_mm)]
    radius_mm: f64,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct Puu3Args {
    /// Rod length L, mm.
    #[arg(long, default_value_t = Puu3Study::default().rod_mm)]
    rod_mm: f64,
    /// Base joint radius r, mm.
    #[arg(long, default_value_t = Puu3Study::default().base_radius_mm)]
    base_radius_mm: f64,
    /// Platform joint radius r_a, mm.
    #[arg(long, default_value_t = Puu3Study::default().platform_radius_mm)]
    platform_radius_mm: f64,
    /// Pose x from home, um.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    x_um: f64,
    /// Pose y from home, um.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    y_um: f64,
    /// Slider stroke, um.
    #[arg(long, default_value_t = Puu3Study::default().stroke_um)]
    stroke_um: f64,
    /// Monte-Carlo samples of the workspace.
    #[arg(long, default_value_t = Puu3Study::default().samples)]
    samples: usize,
    /// Seed of the sampling.
    #[arg(long, default_value_t = Puu3Study::default().seed)]
    seed: u64,
    /// Draw the reachable poses (x-y and x-z projections) as SVG.
    #[arg(long, value_name = "WORKSPACE.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// How the three loops are closed.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum ModeArg {
    /// Decoupled per-joint PIDs on the slider errors.
    Joint,
    /// PIDs on the task-space errors, mapped to the joint commands by J = dS/dp.
    Task,
}

/// What each joint is.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum JointsArg {
    /// The joint plant (--plant) under the PID.
    Plant,
    /// Ideal (unit) joint loops: each slider is at its reference (--mode joint).
    Ideal,
}

#[derive(Debug, Args)]
pub struct Puu3TrackArgs {
    /// Where the loops are closed.
    #[arg(long, value_enum, default_value = "joint")]
    mode: ModeArg,
    /// The joints: the plant under the PID, or ideal (unit) loops.
    #[arg(long, value_enum, default_value = "plant")]
    joints: JointsArg,
    /// Joint plant (`fts.virtual-fts/1`; default: [Tang17]'s, fixtures/tang17-3puu.json).
    #[arg(long, value_name = "FTS.json")]
    plant: Option<PathBuf>,
    /// PID proportional gain, V/um (default: [Tang17]'s Kp 0.01).
    #[arg(long, default_value_t = Puu3Track::default().kp, allow_hyphen_values = true)]
    kp: f64,
    /// PID integral gain per sample, V/um ([Tang17]'s Ki 60 /s at Ts 1 ms).
    #[arg(long, default_value_t = Puu3Track::default().ki, allow_hyphen_values = true)]
    ki: f64,
    /// PID derivative gain per sample, V/um, on the measurement ([Tang17]'s Kd 1e-5 s at Ts 1 ms).
    #[arg(long, default_value_t = Puu3Track::default().kd, allow_hyphen_values = true)]
    kd: f64,
    /// Centre of the profile from home, um: x,y,z.
    #[arg(long, value_delimiter = ',', default_values_t = Puu3Track::default().center_um, allow_hyphen_values = true)]
    center_um: Vec<f64>,
    /// Amplitudes ax,ay,az, um: x = cx + ax cos(2 pi f t), y = cy + ay sin, z = cz + az sin.
    #[arg(long, value_delimiter = ',', default_values_t = Puu3Track::default().amplitude_um, allow_hyphen_values = true)]
    amplitude_um: Vec<f64>,
    /// Profile frequency, Hz.
    #[arg(long, default_value_t = Puu3Track::default().freq)]
    freq: f64,
    /// Profile length, s.
    #[arg(long, default_value_t = Puu3Track::default().duration)]
    duration: f64,
    /// Errors are evaluated from this long into the profile, s.
    #[arg(long, default_value_t = Puu3Track::default().settle)]
    settle: f64,
    /// Slider displacement at home, um.
    #[arg(long, default_value_t = Puu3Track::default().home_um)]
    home_um: f64,
    /// Slider travel allowed either side of home, um.
    #[arg(long, default_value_t = Puu3Track::default().travel_um)]
    travel_um: f64,
    /// Write the trace (t, task reference and pose, slider references and measurements, commands) here.
    #[arg(short = 'o', long = "out", value_name = "TRACE.csv")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: MechanismCommand) -> anyhow::Result<()> {
    match cmd {
        MechanismCommand::FlexureLoss(a) => {
            let step = FlexureLoss {
                kp: a.kp,
                k: a.k,
                dl0: a.dl0,
            };
            print_report(&step.run().map_err(step_error)?, a.json)
        }
        MechanismCommand::Hinge(a) => {
            let step = Hinge {
                e_gpa: a.e_gpa,
                width_mm: Some(a.width_mm),
                length_mm: a.length_mm,
                thickness_mm: a.thickness_mm,
                radius_mm: a.radius_mm,
            };
            print_report(&step.run().map_err(step_error)?, a.json)
        }
        MechanismCommand::Puu3(a) => run_puu3(a),
        MechanismCommand::Puu3Track(a) => run_puu3_track(a),
        MechanismCommand::Lever(a) => {
            let step = Lever {
                input_arm_mm: Some(a.input_arm_mm),
                output_arm_mm: a.output_arm_mm,
                hinge: a.hinge.hinge()?,
                kp: a.kp,
                dl0: a.dl0,
                target_ratio: a.target_ratio,
            };
            print_report(&step.run().map_err(step_error)?, a.json)
        }
        MechanismCommand::Amplifier(a) => {
            let hinge = a.hinge.hinge()?;
            if hinge.is_none() {
                return Err(bad(
                    "--hinge-width-mm: missing: the chain's hinges need a width",
                ));
            }
            let step = Amplifier {
                angle_deg: a.angle_deg,
                link_mm: Some(a.link_mm),
                hinge,
                input_arm_mm: Some(a.input_arm_mm),
                output_arm_mm: Some(a.output_arm_mm),
                pivot: None,
                kp: a.kp,
                dl0: a.dl0,
                target_ratio: a.target_ratio,
            };
            print_report(&step.run().map_err(step_error)?, a.json)
        }
        MechanismCommand::Bridge(a) => {
            let step = Bridge {
                angle_deg: a.angle_deg,
                link_mm: a.link_mm,
                hinge: a.hinge.hinge()?,
                target_ratio: a.target_ratio,
            };
            print_report(&step.run().map_err(step_error)?, a.json)
        }
    }
}

fn run_puu3(a: Puu3Args) -> anyhow::Result<()> {
    let step = Puu3Study {
        rod_mm: a.rod_mm,
        base_radius_mm: a.base_radius_mm,
        platform_radius_mm: a.platform_radius_mm,
        x_um: a.x_um,
        y_um: a.y_um,
        stroke_um: a.stroke_um,
        samples: a.samples,
        seed: a.seed,
    };
    step.validate().map_err(step_error)?;
    let report = step.run().map_err(step_error)?;
    if let Some(path) = &a.plot {
        write_plot(path, |f| workspace_plot(&report, f))?;
    }
    print_report(&report, a.json)?;
    Ok(())
}

/// The reachable poses seen from above (x-y) and from the side (x-z).
fn workspace_plot(r: &Puu3Report, format: PlotFormat) -> anyhow::Result<Vec<u8>> {
    let col = |i: usize| -> Vec<f64> { r.points.iter().map(|p| p[i]).collect() };
    let (x, y, z) = (col(0), col(1), col(2));
    let title = format!(
        "3-PUU workspace, stroke {} um (seed {})",
        r.inputs.stroke_um, r.inputs.seed
    );
    let top = Panel {
        title: &title,
        x_label: "x (um)",
        y_label: "y (um)",
        series: vec![(
            Series {
                label: "reachable pose",
                x: &x,
                y: &y,
            },
            Style::Faint,
        )],
        ..Panel::default()
    };
    let side = Panel {
        title: "side view",
        x_label: "x (um)",
        y_label: "z (um)",
        series: vec![(
            Series {
                label: "reachable pose",
                x: &x,
                y: &z,
            },
            Style::Faint,
        )],
        ..Panel::default()
    };
    render(&[top, side], format).map_err(|e| bad(format!("--plot: {e}")))
}

/// The three values x,y,z of `option`.
fn three(option: &str, v: &[f64]) -> anyhow::Result<[f64; 3]> {
    match v {
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(bad(format!(
            "{option}: expected three values x,y,z, got {}",
            v.len()
        ))),
    }
}

fn run_puu3_track(a: Puu3TrackArgs) -> anyhow::Result<()> {
    let plant = match &a.plant {
        Some(path) => Some(super::simulate::read_virtual_params(path)?),
        None => None,
    };
    let step = Puu3Track {
        mode: match a.mode {
            ModeArg::Joint => ControlMode::Joint,
            ModeArg::Task => ControlMode::Task,
        },
        joints: match a.joints {
            JointsArg::Plant => JointModel::Plant,
            JointsArg::Ideal => JointModel::Ideal,
        },
        plant,
        kp: a.kp,
        ki: a.ki,
        kd: a.kd,
        center_um: three("--center-um", &a.center_um)?,
        amplitude_um: three("--amplitude-um", &a.amplitude_um)?,
        freq: a.freq,
        duration: a.duration,
        settle: a.settle,
        home_um: a.home_um,
        travel_um: a.travel_um,
        ..Puu3Track::default()
    };
    let report = step.run().map_err(step_error)?;
    if let Some(path) = &a.output {
        super::common::write_atomic(path, report.trace_csv().as_bytes())?;
    }
    print_report(&report, a.json)?;
    Ok(())
}
