//! `fts mechanism flexure-loss|hinge|3puu`: the mechanism design formulas
//! (docs/mechanism.md). The steps are the library's
//! ([`crate::workflow::mechanism`]); this file turns flags into them,
//! renders the reports and draws the workspace.

use super::common::{bad, print_report, step_error, write_atomic};
use crate::io::plot::{Panel, Series, Style, panels_svg};
use crate::workflow::Validate;
use crate::workflow::mechanism::{FlexureLoss, Hinge, Puu3Report, Puu3Study};
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
    #[arg(long, value_name = "WORKSPACE.svg")]
    plot: Option<PathBuf>,
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
        write_atomic(path, workspace_svg(&report)?.as_bytes())?;
    }
    print_report(&report, a.json)?;
    if let (false, Some(path)) = (a.json, &a.plot) {
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// The reachable poses seen from above (x-y) and from the side (x-z).
fn workspace_svg(r: &Puu3Report) -> anyhow::Result<String> {
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
    panels_svg(&[top, side]).map_err(|e| bad(format!("--plot: {e}")))
}
