//! `fts mechanism ...` steps (docs/mechanism.md): \[Li21\] Eq. 1 flexure
//! displacement loss, \[Li21\] Eq. 2 hinge stiffness, \[Tang17\] 3-PUU
//! kinematics, Jacobian, conditioning and Monte-Carlo workspace.

use super::{StepError, Validate, positive};
use crate::synth::mechanism::{
    HingeGeometry, Puu3, WorkspaceParams, condition_number, flexure_displacement, hinge_stiffness,
    workspace,
};
use serde::{Deserialize, Serialize};
use std::fmt;

/// \[Li21\] Eq. 1 inputs (stiffnesses in any one unit, e.g. N/um).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FlexureLoss {
    /// Actuator stiffness; default 200 (N/um, \[Li21\]).
    pub kp: f64,
    /// Flexure stiffness; default 11.6 (N/um, \[Li21\]).
    pub k: f64,
    /// Free stroke, um; default 10.
    pub dl0: f64,
}

impl Default for FlexureLoss {
    fn default() -> Self {
        FlexureLoss {
            kp: 200.0,
            k: 11.6,
            dl0: 10.0,
        }
    }
}

impl Validate for FlexureLoss {
    fn validate(&self) -> Result<(), StepError> {
        positive("kp", self.kp)?;
        positive("k", self.k)?;
        positive("dl0", self.dl0).map(|_| ())
    }
}

/// What [`FlexureLoss`] reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlexureLossReport {
    /// The inputs.
    pub inputs: FlexureLoss,
    /// Delivered displacement `dl0 kp/(kp + k)`, um.
    pub delivered_um: f64,
    /// Lost displacement, um.
    pub lost_um: f64,
}

impl FlexureLoss {
    /// Evaluates Eq. 1.
    pub fn run(&self) -> Result<FlexureLossReport, StepError> {
        self.validate()?;
        let (delivered_um, lost_um) = flexure_displacement(self.kp, self.k, self.dl0);
        Ok(FlexureLossReport {
            inputs: self.clone(),
            delivered_um,
            lost_um,
        })
    }
}

impl fmt::Display for FlexureLossReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        writeln!(
            f,
            "[Li21] Eq. 1: kp = {}, k = {}, free stroke {} um",
            i.kp, i.k, i.dl0
        )?;
        writeln!(
            f,
            "  delivered {:.4} um, lost {:.4} um ({:.2} %)",
            self.delivered_um,
            self.lost_um,
            100.0 * self.lost_um / i.dl0
        )
    }
}

/// \[Li21\] Eq. 2 inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Hinge {
    /// Young's modulus, GPa; default 206 (a handbook value for 65Mn spring
    /// steel, the paper's material; handbooks give 197-211).
    pub e_gpa: f64,
    /// Width `b` (out of plane), mm; required (the paper does not give it).
    pub width_mm: Option<f64>,
    /// Beam length `l`, mm; default 7 (\[Li21\]).
    pub length_mm: f64,
    /// Thickness `t`, mm; default 0.6.
    pub thickness_mm: f64,
    /// Fillet radius `R`, mm; default 2.
    pub radius_mm: f64,
}

impl Default for Hinge {
    fn default() -> Self {
        Hinge {
            e_gpa: 206.0,
            width_mm: None,
            length_mm: 7.0,
            thickness_mm: 0.6,
            radius_mm: 2.0,
        }
    }
}

impl Validate for Hinge {
    fn validate(&self) -> Result<(), StepError> {
        positive("e_gpa", self.e_gpa)?;
        let w = self.width_mm.ok_or_else(|| {
            StepError::setting(
                "width_mm",
                "missing: the hinge width b in mm ([Li21] does not give it)",
            )
        })?;
        positive("width_mm", w)?;
        positive("length_mm", self.length_mm)?;
        positive("thickness_mm", self.thickness_mm)?;
        if !(self.radius_mm.is_finite() && self.radius_mm >= 0.0) {
            return Err(StepError::setting(
                "radius_mm",
                format!("expected zero or more mm, got {}", self.radius_mm),
            ));
        }
        Ok(())
    }
}

/// What [`Hinge`] reports (stiffnesses in N m/rad).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HingeReport {
    /// The inputs.
    pub inputs: Hinge,
    /// `s = R/t`.
    pub s: f64,
    /// `f(s)`.
    pub f: f64,
    /// `E b t^3/(12 l)`, N m/rad.
    pub beam_nm_per_rad: f64,
    /// `E b R^2/(12 f)`, N m/rad.
    pub fillets_nm_per_rad: f64,
    /// The sum, N m/rad.
    pub stiffness_nm_per_rad: f64,
}

impl Hinge {
    /// Evaluates Eq. 2.
    pub fn run(&self) -> Result<HingeReport, StepError> {
        self.validate()?;
        let mm = 1e-3;
        let k = hinge_stiffness(&HingeGeometry {
            youngs_modulus: self.e_gpa * 1e9,
            width: self.width_mm.unwrap_or_default() * mm,
            length: self.length_mm * mm,
            thickness: self.thickness_mm * mm,
            radius: self.radius_mm * mm,
        });
        Ok(HingeReport {
            inputs: self.clone(),
            s: k.s,
            f: k.f,
            beam_nm_per_rad: k.beam,
            fillets_nm_per_rad: k.fillets,
            stiffness_nm_per_rad: k.total,
        })
    }
}

impl fmt::Display for HingeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        writeln!(
            f,
            "[Li21] Eq. 2: E = {} GPa, b = {} mm, l = {} mm, t = {} mm, R = {} mm",
            i.e_gpa,
            i.width_mm.unwrap_or_default(),
            i.length_mm,
            i.thickness_mm,
            i.radius_mm
        )?;
        writeln!(f, "  s = R/t = {:.4}, f(s) = {:.6}", self.s, self.f)?;
        writeln!(
            f,
            "  beam {:.4} + fillets {:.4} = {:.4} N m/rad",
            self.beam_nm_per_rad, self.fillets_nm_per_rad, self.stiffness_nm_per_rad
        )
    }
}

/// \[Tang17\] 3-PUU study: kinematics at a pose and the workspace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Puu3Study {
    /// Rod length `L`, mm; default 60.
    pub rod_mm: f64,
    /// Base joint radius `r`, mm; default 70.
    pub base_radius_mm: f64,
    /// Platform joint radius `r_a`, mm; default 27.
    pub platform_radius_mm: f64,
    /// Pose x from home, um; default 0.
    pub x_um: f64,
    /// Pose y from home, um; default 0.
    pub y_um: f64,
    /// Slider stroke, um; default 250 (\[Tang17\]: 0 < S_i < 0.25 mm).
    pub stroke_um: f64,
    /// Monte-Carlo samples; default 200000.
    pub samples: usize,
    /// Seed; default 1.
    pub seed: u64,
}

impl Default for Puu3Study {
    fn default() -> Self {
        let g = Puu3::default();
        Puu3Study {
            rod_mm: g.rod,
            base_radius_mm: g.base_radius,
            platform_radius_mm: g.platform_radius,
            x_um: 0.0,
            y_um: 0.0,
            stroke_um: 250.0,
            samples: 200_000,
            seed: 1,
        }
    }
}

impl Validate for Puu3Study {
    fn validate(&self) -> Result<(), StepError> {
        positive("rod_mm", self.rod_mm)?;
        positive("base_radius_mm", self.base_radius_mm)?;
        positive("platform_radius_mm", self.platform_radius_mm)?;
        positive("stroke_um", self.stroke_um)?;
        let d = self.base_radius_mm - self.platform_radius_mm;
        if d.abs() >= self.rod_mm {
            return Err(StepError::setting(
                "rod_mm",
                format!(
                    "a rod of {} mm cannot span the {d} mm between base and platform joints",
                    self.rod_mm
                ),
            ));
        }
        if !(1..=10_000_000).contains(&self.samples) {
            return Err(StepError::setting(
                "samples",
                "expected 1 to 10000000 samples",
            ));
        }
        for (field, v) in [("x_um", self.x_um), ("y_um", self.y_um)] {
            if !v.is_finite() {
                return Err(StepError::setting(field, "expected a finite number of um"));
            }
        }
        Ok(())
    }
}

/// What [`Puu3Study`] reports (lengths in um unless named).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Puu3Report {
    /// The inputs.
    pub inputs: Puu3Study,
    /// `J = dS/d(x, y, z)` at the pose, rows per slider.
    pub jacobian: [[f64; 3]; 3],
    /// Its 2-norm condition number.
    pub condition_number: f64,
    /// Slider displacements from home at the pose, um.
    pub slider_um: [f64; 3],
    /// Workspace `[min, max]` of x, y, z, um.
    pub workspace_um: [[f64; 2]; 3],
    /// Reachable samples.
    pub reachable: usize,
    /// \[Tang17\]'s measured workspace, um.
    pub paper_workspace_um: [[f64; 2]; 3],
    /// The reachable points, um (for the plot).
    #[serde(skip)]
    pub points: Vec<[f64; 3]>,
}

impl Puu3Study {
    /// Kinematics at the pose and the workspace.
    pub fn run(&self) -> Result<Puu3Report, StepError> {
        self.validate()?;
        let m = Puu3 {
            rod: self.rod_mm,
            base_radius: self.base_radius_mm,
            platform_radius: self.platform_radius_mm,
        };
        let (x, y) = (self.x_um * 1e-3, self.y_um * 1e-3);
        let unreachable = || StepError::setting("x_um", "the pose is out of the rods' reach");
        let jacobian = m.jacobian(x, y).ok_or_else(unreachable)?;
        let s = m.inverse(x, y, 0.0).ok_or_else(unreachable)?;
        let home = m.inverse(0.0, 0.0, 0.0).ok_or_else(unreachable)?;
        let ws = workspace(
            &m,
            &WorkspaceParams {
                stroke: self.stroke_um * 1e-3,
                samples: self.samples,
                seed: self.seed,
            },
        );
        if ws.points.is_empty() {
            return Err(StepError::computation(
                "no sampled pose is reachable within the stroke",
            ));
        }
        let to_um = |v: f64| v * 1e3;
        Ok(Puu3Report {
            inputs: self.clone(),
            jacobian,
            condition_number: condition_number(&jacobian),
            slider_um: [0, 1, 2].map(|i| to_um(s[i] - home[i])),
            workspace_um: ws.extent.map(|[a, b]| [to_um(a), to_um(b)]),
            reachable: ws.points.len(),
            paper_workspace_um: [[-85.0, 85.0], [-80.0, 80.0], [0.0, 120.0]],
            points: ws.points.iter().map(|p| p.map(to_um)).collect(),
        })
    }
}

impl fmt::Display for Puu3Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        writeln!(
            f,
            "[Tang17] 3-PUU: L = {} mm, r = {} mm, r_a = {} mm; pose x = {} um, y = {} um",
            i.rod_mm, i.base_radius_mm, i.platform_radius_mm, i.x_um, i.y_um
        )?;
        for (k, row) in self.jacobian.iter().enumerate() {
            writeln!(
                f,
                "  J row {}: [{:.4}, {:.4}, {:.4}]   slider {:+.3} um",
                k + 1,
                row[0],
                row[1],
                row[2],
                self.slider_um[k]
            )?;
        }
        writeln!(f, "  condition number {:.4}", self.condition_number)?;
        let w = &self.workspace_um;
        let p = &self.paper_workspace_um;
        writeln!(
            f,
            "  workspace (stroke {} um, {} of {} samples reachable, seed {}):",
            i.stroke_um, self.reachable, i.samples, i.seed
        )?;
        writeln!(
            f,
            "    x [{:.1}, {:.1}]  y [{:.1}, {:.1}]  z [{:.1}, {:.1}] um",
            w[0][0], w[0][1], w[1][0], w[1][1], w[2][0], w[2][1]
        )?;
        writeln!(
            f,
            "    paper (measured): x [{}, {}]  y [{}, {}]  z [{}, {}] um",
            p[0][0], p[0][1], p[1][0], p[1][1], p[2][0], p[2][1]
        )
    }
}
