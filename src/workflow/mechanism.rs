//! `fts mechanism ...` steps (docs/mechanism.md): \[Li21\] Eq. 1 flexure
//! displacement loss, \[Li21\] Eq. 2 hinge stiffness, \[Tang17\] 3-PUU
//! kinematics, Jacobian, conditioning and Monte-Carlo workspace, and the
//! lever and bridge-type amplifiers with their inverses (the arm ratio and
//! the angle that give \[Tang17\]'s measured 3.87).

use super::{StepError, Validate, positive};
use crate::synth::compliance::{
    BridgeChain, ChainAmplification, LeverChain, Mat3, TwoPort, chain_amplification,
    hinge_compliance,
};
use crate::synth::mechanism::{
    Amplification, BridgeLimb, HingeGeometry, Lever as LeverModel, Puu3, WorkspaceParams,
    condition_number, flexure_displacement, hinge_stiffness, ideal_bridge_angle, workspace,
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
    /// The sum, N m/rad (Eq. 2 as printed).
    pub stiffness_nm_per_rad: f64,
    /// The beam and the fillets in series, `1/C_thetatheta` of the profile
    /// (beam theory; what the lever and bridge use), N m/rad.
    pub series_nm_per_rad: f64,
    /// Axial stiffness of the whole profile, `1/C_xx`, N/um.
    pub axial_n_per_um: f64,
    /// Transverse stiffness at the free end (rotation free), `1/C_yy`, N/um.
    pub transverse_n_per_um: f64,
}

impl Hinge {
    /// Evaluates Eq. 2.
    pub fn run(&self) -> Result<HingeReport, StepError> {
        self.validate()?;
        let k = hinge_stiffness(&self.geometry());
        let c = self.compliance();
        Ok(HingeReport {
            inputs: self.clone(),
            s: k.s,
            f: k.f,
            beam_nm_per_rad: k.beam,
            fillets_nm_per_rad: k.fillets,
            stiffness_nm_per_rad: k.total,
            series_nm_per_rad: 1.0 / c[2][2],
            axial_n_per_um: 1e-6 / c[0][0],
            transverse_n_per_um: 1e-6 / c[1][1],
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
            "  beam {:.4} + fillets {:.4} = {:.4} N m/rad (Eq. 2 as printed: stiffnesses added)",
            self.beam_nm_per_rad, self.fillets_nm_per_rad, self.stiffness_nm_per_rad
        )?;
        writeln!(
            f,
            "  in series (beam theory: compliances added): {:.4} N m/rad",
            self.series_nm_per_rad
        )?;
        writeln!(
            f,
            "  whole profile: axial {:.3} N/um, transverse {:.5} N/um at the free end",
            self.axial_n_per_um, self.transverse_n_per_um
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
                return Err(StepError::setting(
                    field,
                    format!(
                        "expected a finite number of um, got {}",
                        super::fmt_value(v)
                    ),
                ));
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
        let unreachable = || {
            StepError::setting(
                "x_um",
                format!(
                    "the pose x = {} um, y = {} um is out of the rods' reach (`rod_mm` {} mm)",
                    super::fmt_value(self.x_um),
                    super::fmt_value(self.y_um),
                    super::fmt_value(self.rod_mm)
                ),
            )
        };
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
            paper_workspace_um: [[-80.0, 80.0], [-85.0, 85.0], [0.0, 120.0]],
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

/// \[Tang17\]'s measured amplification of its displacement amplifier (FEA
/// 4.1; the paper gives no geometry): the default target of the inverses.
pub const TANG17_AMPLIFICATION: f64 = 3.87;

impl Hinge {
    /// The geometry in SI units (width 0 when missing: validate first).
    fn geometry(&self) -> HingeGeometry {
        let mm = 1e-3;
        HingeGeometry {
            youngs_modulus: self.e_gpa * 1e9,
            width: self.width_mm.unwrap_or_default() * mm,
            length: self.length_mm * mm,
            thickness: self.thickness_mm * mm,
            radius: self.radius_mm * mm,
        }
    }

    /// The profile's compliance at its free end (`synth::compliance`).
    fn compliance(&self) -> Mat3 {
        hinge_compliance(&self.geometry())
    }

    /// Rotational (N m/rad) and axial (N/m) stiffness of the whole profile,
    /// its segments in series: `1/C_thetatheta`, `1/C_xx`.
    fn stiffnesses(&self) -> (f64, f64) {
        let c = self.compliance();
        (1.0 / c[2][2], 1.0 / c[0][0])
    }
}

/// A nested hinge's settings error, named under `hinge`.
fn check_hinge(h: &Hinge) -> Result<(), StepError> {
    h.validate().map_err(|e| match e {
        StepError::Input {
            field: Some(f),
            message,
        } => StepError::setting("hinge", format!("`{f}`: {message}")),
        other => other,
    })
}

/// A bridge angle, when given, strictly between 0 and 90 deg.
fn check_angle(angle_deg: Option<f64>) -> Result<(), StepError> {
    match angle_deg {
        Some(a) if !(a > 0.0 && a < 90.0) => Err(StepError::setting(
            "angle_deg",
            format!("expected an angle strictly between 0 and 90 deg, got {a}"),
        )),
        _ => Ok(()),
    }
}

fn target_ratio(x: f64) -> Result<f64, StepError> {
    positive("target_ratio", x)
}

/// A lever amplifier: first-class lever on a leaf-hinge pivot whose axis
/// lies along the input force (docs/mechanism.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Lever {
    /// Pivot to input point, mm; required.
    pub input_arm_mm: Option<f64>,
    /// Pivot to output point, mm; without it only the inverse is answered.
    pub output_arm_mm: Option<f64>,
    /// The pivot hinge (its profile's rotational and axial stiffness, the
    /// segments in series); without it the pivot is a pin (ideal lever).
    pub hinge: Option<Hinge>,
    /// Actuator stiffness, N/um: with it, \[Li21\] Eq. 1 gives the stroke the
    /// lever's input stiffness lets through.
    pub kp: Option<f64>,
    /// Actuator free stroke, um; default 10.
    pub dl0: f64,
    /// Ratio the inverse aims at; default 3.87 (\[Tang17\], measured).
    pub target_ratio: f64,
}

impl Default for Lever {
    fn default() -> Self {
        Lever {
            input_arm_mm: None,
            output_arm_mm: None,
            hinge: None,
            kp: None,
            dl0: 10.0,
            target_ratio: TANG17_AMPLIFICATION,
        }
    }
}

impl Validate for Lever {
    fn validate(&self) -> Result<(), StepError> {
        let li = self.input_arm_mm.ok_or_else(|| {
            StepError::setting("input_arm_mm", "missing: the pivot-to-input distance in mm")
        })?;
        positive("input_arm_mm", li)?;
        if let Some(lo) = self.output_arm_mm {
            positive("output_arm_mm", lo)?;
        }
        if let Some(h) = &self.hinge {
            check_hinge(h)?;
        }
        if let Some(kp) = self.kp {
            positive("kp", kp)?;
            if self.hinge.is_none() {
                return Err(StepError::setting(
                    "kp",
                    "needs a pivot hinge (its width): a pin-jointed lever has no input stiffness",
                ));
            }
        }
        positive("dl0", self.dl0)?;
        target_ratio(self.target_ratio).map(|_| ())
    }
}

/// What [`Lever`] reports (ratios dimensionless, stiffnesses N/um).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeverReport {
    /// The inputs.
    pub inputs: Lever,
    /// `L_out/L_in` (with the output arm).
    pub ideal: Option<f64>,
    /// With the compliant pivot (with the output arm and the hinge).
    pub compliant: Option<f64>,
    /// By the compliance-matrix method (the pivot's full in-plane
    /// compliance: its length's bending and shear-free transverse terms).
    pub compliance_matrix: Option<f64>,
    /// Pivot stiffnesses: rotational N m/rad, along the force N/um.
    pub pivot_k_rot_nm_per_rad: Option<f64>,
    pub pivot_k_trans_n_per_um: Option<f64>,
    /// Stiffness the actuator sees, N/um (with the hinge).
    pub input_stiffness_n_per_um: Option<f64>,
    /// \[Li21\] Eq. 1: the input stroke delivered against that stiffness,
    /// and the output stroke, um (with `kp` and the output arm).
    pub delivered_input_um: Option<f64>,
    pub output_stroke_um: Option<f64>,
    /// Output arm giving `target_ratio`: ideal, and with the pivot, mm.
    pub output_arm_for_target_ideal_mm: f64,
    pub output_arm_for_target_compliant_mm: Option<f64>,
}

impl Lever {
    /// Evaluates the lever and its inverse.
    pub fn run(&self) -> Result<LeverReport, StepError> {
        self.validate()?;
        let mm = 1e-3;
        let li = self.input_arm_mm.unwrap_or_default();
        let model = self.hinge.as_ref().map(|h| {
            let (k_rot, k_trans) = h.stiffnesses();
            LeverModel {
                input_arm: li * mm,
                output_arm: self.output_arm_mm.unwrap_or(li) * mm,
                k_rot,
                k_trans,
            }
        });
        let amp: Option<Amplification> = match (&model, self.output_arm_mm) {
            (Some(m), Some(_)) => Some(m.amplification()),
            _ => None,
        };
        let input_stiffness = model.map(|m| m.amplification().input_stiffness * 1e-6);
        let delivered = self
            .kp
            .zip(input_stiffness)
            .map(|(kp, k)| flexure_displacement(kp, k, self.dl0).0);
        let compliant = amp.map(|a| a.compliant);
        let chain = self
            .hinge
            .as_ref()
            .zip(self.output_arm_mm)
            .and_then(|(h, lo)| lever_chain(h, li, lo).map(|p| p.ratio()));
        Ok(LeverReport {
            inputs: self.clone(),
            ideal: self.output_arm_mm.map(|lo| lo / li),
            compliant,
            compliance_matrix: chain,
            pivot_k_rot_nm_per_rad: model.map(|m| m.k_rot),
            pivot_k_trans_n_per_um: model.map(|m| m.k_trans * 1e-6),
            input_stiffness_n_per_um: input_stiffness,
            delivered_input_um: delivered.filter(|_| compliant.is_some()),
            output_stroke_um: delivered.zip(compliant).map(|(d, r)| d * r),
            output_arm_for_target_ideal_mm: self.target_ratio * li,
            output_arm_for_target_compliant_mm: model
                .map(|m| m.output_arm_for(self.target_ratio) / mm),
        })
    }
}

fn opt(x: Option<f64>, digits: usize) -> String {
    x.map_or("-".into(), |v| format!("{v:.digits$}"))
}

impl fmt::Display for LeverReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        writeln!(
            f,
            "Lever (first class, leaf-hinge pivot): L_in = {} mm, L_out = {} mm",
            i.input_arm_mm.unwrap_or_default(),
            opt(i.output_arm_mm, 3)
        )?;
        if let (Some(kr), Some(kt)) = (self.pivot_k_rot_nm_per_rad, self.pivot_k_trans_n_per_um) {
            writeln!(
                f,
                "  pivot: {kr:.4} N m/rad, {kt:.3} N/um along the force (the profile in series)"
            )?;
        }
        writeln!(
            f,
            "  ratio: ideal {}, with the compliant pivot {}; input stiffness {} N/um",
            opt(self.ideal, 4),
            opt(self.compliant, 4),
            opt(self.input_stiffness_n_per_um, 4)
        )?;
        if let Some(c) = self.compliance_matrix {
            writeln!(f, "  compliance-matrix method: ratio {c:.4}")?;
        }
        if let (Some(d), Some(o)) = (self.delivered_input_um, self.output_stroke_um) {
            writeln!(
                f,
                "  [Li21] Eq. 1, kp = {} N/um, free stroke {} um: input {d:.4} um, output {o:.4} um",
                i.kp.unwrap_or_default(),
                i.dl0
            )?;
        }
        writeln!(
            f,
            "  for a ratio of {}: L_out = {:.3} mm ideal, {} mm with the pivot",
            i.target_ratio,
            self.output_arm_for_target_ideal_mm,
            opt(self.output_arm_for_target_compliant_mm, 3)
        )
    }
}

/// One limb of a symmetric bridge-type amplifier (docs/mechanism.md): the
/// ratio of the output blocks' separation to the actuator's elongation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Bridge {
    /// Link angle to the input axis, deg; without it only the inverse is answered.
    pub angle_deg: Option<f64>,
    /// Link length between the hinge centres, mm (with the hinge).
    pub link_mm: Option<f64>,
    /// The two identical hinges of a link; without them the links are rigid
    /// on pins (ideal `cot(angle)`).
    pub hinge: Option<Hinge>,
    /// Ratio the inverse aims at; default 3.87 (\[Tang17\], measured).
    pub target_ratio: f64,
}

impl Default for Bridge {
    fn default() -> Self {
        Bridge {
            angle_deg: None,
            link_mm: None,
            hinge: None,
            target_ratio: TANG17_AMPLIFICATION,
        }
    }
}

impl Validate for Bridge {
    fn validate(&self) -> Result<(), StepError> {
        check_angle(self.angle_deg)?;
        if let Some(h) = &self.hinge {
            check_hinge(h)?;
            let l = self.link_mm.ok_or_else(|| {
                StepError::setting("link_mm", "missing: the hinge-to-hinge link length in mm")
            })?;
            positive("link_mm", l)?;
        } else if let Some(l) = self.link_mm {
            positive("link_mm", l)?;
        }
        target_ratio(self.target_ratio).map(|_| ())
    }
}

/// What [`Bridge`] reports (angles in deg, stiffnesses N/um).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BridgeReport {
    /// The inputs.
    pub inputs: Bridge,
    /// `cot(angle)` (with the angle).
    pub ideal: Option<f64>,
    /// With the hinges' compliance (with the angle and the hinge).
    pub compliant: Option<f64>,
    /// By the compliance-matrix method (leaf hinges along the link, their
    /// full in-plane compliance).
    pub compliance_matrix: Option<f64>,
    /// Hinge stiffnesses: rotational N m/rad, axial N/um.
    pub hinge_k_rot_nm_per_rad: Option<f64>,
    pub hinge_k_axial_n_per_um: Option<f64>,
    /// Stiffness the actuator sees, N/um (with the angle and the hinge).
    pub input_stiffness_n_per_um: Option<f64>,
    /// The angle at which a rigid bridge gives `target_ratio`: `acot`.
    pub angle_for_target_ideal_deg: f64,
    /// The angles at which the compliant limb gives it (none above its peak).
    pub angles_for_target_compliant_deg: Option<(f64, f64)>,
    /// The compliant limb's largest ratio and its angle, deg.
    pub peak_ratio: Option<f64>,
    pub peak_angle_deg: Option<f64>,
}

impl Bridge {
    /// Evaluates the limb and the inverses.
    pub fn run(&self) -> Result<BridgeReport, StepError> {
        self.validate()?;
        let angle = self.angle_deg.map(f64::to_radians);
        let limb = self.hinge.as_ref().map(|h| {
            let (k_rot, k_axial) = h.stiffnesses();
            BridgeLimb {
                angle: angle.unwrap_or(std::f64::consts::FRAC_PI_4),
                link: self.link_mm.unwrap_or_default() * 1e-3,
                k_axial,
                k_rot,
            }
        });
        let amp = limb.filter(|_| angle.is_some()).map(|l| l.amplification());
        let deg = |(a, b): (f64, f64)| (a.to_degrees(), b.to_degrees());
        let chain = self.hinge.as_ref().zip(angle).and_then(|(h, a)| {
            bridge_chain(h, a, self.link_mm.unwrap_or_default()).map(|p| p.ratio())
        });
        Ok(BridgeReport {
            inputs: self.clone(),
            ideal: angle.map(|a| 1.0 / a.tan()),
            compliant: amp.map(|a| a.compliant),
            compliance_matrix: chain,
            hinge_k_rot_nm_per_rad: limb.map(|l| l.k_rot),
            hinge_k_axial_n_per_um: limb.map(|l| l.k_axial * 1e-6),
            input_stiffness_n_per_um: amp.map(|a| a.input_stiffness * 1e-6),
            angle_for_target_ideal_deg: ideal_bridge_angle(self.target_ratio).to_degrees(),
            angles_for_target_compliant_deg: limb
                .and_then(|l| l.angles_for(self.target_ratio))
                .map(deg),
            peak_ratio: limb.map(|l| l.peak().0),
            peak_angle_deg: limb.map(|l| l.peak().1.to_degrees()),
        })
    }
}

impl fmt::Display for BridgeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        writeln!(
            f,
            "Bridge-type amplifier (one limb; output separation / actuator elongation): angle {} deg, link {} mm",
            opt(i.angle_deg, 3),
            opt(i.link_mm, 3)
        )?;
        if let (Some(kr), Some(ka)) = (self.hinge_k_rot_nm_per_rad, self.hinge_k_axial_n_per_um) {
            writeln!(
                f,
                "  hinge: {kr:.4} N m/rad, {ka:.3} N/um axial (the profile in series)"
            )?;
        }
        writeln!(
            f,
            "  ratio: ideal cot(angle) {}, with compliant hinges {}; input stiffness {} N/um",
            opt(self.ideal, 4),
            opt(self.compliant, 4),
            opt(self.input_stiffness_n_per_um, 4)
        )?;
        if let Some(c) = self.compliance_matrix {
            writeln!(f, "  compliance-matrix method: ratio {c:.4}")?;
        }
        if let (Some(p), Some(a)) = (self.peak_ratio, self.peak_angle_deg) {
            writeln!(f, "  compliant limb: at most {p:.4}, at {a:.3} deg")?;
        }
        let compliant = match (self.angles_for_target_compliant_deg, self.peak_ratio) {
            (Some((a, b)), _) => format!("{a:.3} or {b:.3} deg with the hinges"),
            (None, Some(_)) => "unreachable with the hinges".into(),
            (None, None) => "-".into(),
        };
        writeln!(
            f,
            "  for a ratio of {}: angle {:.3} deg ideal (acot), {compliant}",
            i.target_ratio, self.angle_for_target_ideal_deg
        )
    }
}

/// The lever as a compliance-matrix two-port (arms in mm).
fn lever_chain(pivot: &Hinge, input_arm_mm: f64, output_arm_mm: f64) -> Option<TwoPort> {
    LeverChain {
        input_arm: input_arm_mm * 1e-3,
        output_arm: output_arm_mm * 1e-3,
        hinge: pivot.compliance(),
    }
    .two_port()
}

/// The bridge as a compliance-matrix two-port (angle in rad, link in mm).
fn bridge_chain(hinge: &Hinge, angle: f64, link_mm: f64) -> Option<TwoPort> {
    BridgeChain {
        angle,
        link: link_mm * 1e-3,
        hinge: hinge.compliance(),
        hinge_length: hinge.geometry().profile_length(),
    }
    .two_port()
}

/// A bridge-type amplifier driving a lever, by the compliance-matrix
/// method (docs/mechanism.md "The amplifier chain"): each stage a two-port,
/// the bridge loaded by the lever's input stiffness.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Amplifier {
    /// Bridge link angle to the input axis, deg; without it only the
    /// inverse is answered.
    pub angle_deg: Option<f64>,
    /// Bridge: distance between the hinge centres, mm; required.
    pub link_mm: Option<f64>,
    /// The bridge's hinges; required.
    pub hinge: Option<Hinge>,
    /// Lever: pivot to input (where the bridge drives it), mm; required.
    pub input_arm_mm: Option<f64>,
    /// Lever: pivot to output (the tool), mm; required.
    pub output_arm_mm: Option<f64>,
    /// The lever's pivot hinge; default: the bridge's hinge.
    pub pivot: Option<Hinge>,
    /// Actuator stiffness, N/um: with it, \[Li21\] Eq. 1 gives the
    /// elongation the chain's input stiffness lets through.
    pub kp: Option<f64>,
    /// Actuator free stroke, um; default 10.
    pub dl0: f64,
    /// Overall ratio the inverse aims at; default 3.87 (\[Tang17\], measured).
    pub target_ratio: f64,
}

impl Default for Amplifier {
    fn default() -> Self {
        Amplifier {
            angle_deg: None,
            link_mm: None,
            hinge: None,
            input_arm_mm: None,
            output_arm_mm: None,
            pivot: None,
            kp: None,
            dl0: 10.0,
            target_ratio: TANG17_AMPLIFICATION,
        }
    }
}

fn required(name: &'static str, x: Option<f64>, what: &str) -> Result<f64, StepError> {
    let v = x.ok_or_else(|| StepError::setting(name, format!("missing: {what}")))?;
    positive(name, v)
}

impl Validate for Amplifier {
    fn validate(&self) -> Result<(), StepError> {
        check_angle(self.angle_deg)?;
        required(
            "link_mm",
            self.link_mm,
            "the bridge's hinge-to-hinge length in mm",
        )?;
        required(
            "input_arm_mm",
            self.input_arm_mm,
            "the lever's pivot-to-input distance in mm",
        )?;
        required(
            "output_arm_mm",
            self.output_arm_mm,
            "the lever's pivot-to-output distance in mm",
        )?;
        let hinge = self.hinge.as_ref().ok_or_else(|| {
            StepError::setting(
                "hinge",
                "missing: the bridge's hinges (width, length, thickness, radius)",
            )
        })?;
        check_hinge(hinge)?;
        if let Some(p) = &self.pivot {
            check_hinge(p).map_err(|e| rename(e, "hinge", "pivot"))?;
        }
        if let Some(kp) = self.kp {
            positive("kp", kp)?;
        }
        positive("dl0", self.dl0)?;
        target_ratio(self.target_ratio).map(|_| ())
    }
}

fn rename(e: StepError, from: &str, to: &'static str) -> StepError {
    match e {
        StepError::Input {
            field: Some(f),
            message,
        } if f == from => StepError::setting(to, message),
        other => other,
    }
}

/// What [`Amplifier`] reports (ratios dimensionless, stiffnesses N/um).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AmplifierReport {
    /// The inputs.
    pub inputs: Amplifier,
    /// Bridge: `cot(angle)`, the pseudo-rigid-body limb, the compliance
    /// matrices (free output).
    pub bridge_ideal: Option<f64>,
    pub bridge_prb: Option<f64>,
    pub bridge_free: Option<f64>,
    /// Bridge ratio loaded by the lever's input stiffness.
    pub bridge_loaded: Option<f64>,
    /// Lever: `L_out/L_in` and the compliance matrices (output free).
    pub lever_ideal: f64,
    pub lever: f64,
    /// Bridge loaded times lever.
    pub overall: Option<f64>,
    /// Stiffness the actuator sees through the chain, N/um.
    pub input_stiffness_n_per_um: Option<f64>,
    /// \[Li21\] Eq. 1 with `kp`: delivered elongation and tool stroke, um.
    pub delivered_input_um: Option<f64>,
    pub output_stroke_um: Option<f64>,
    /// The chain's largest overall ratio over the bridge angle, and where, deg.
    pub peak_ratio: f64,
    pub peak_angle_deg: f64,
    /// The bridge angle above the peak giving `target_ratio`, deg.
    pub angle_for_target_deg: Option<f64>,
}

impl Amplifier {
    fn chain_at(&self, angle: f64, lever: &TwoPort) -> Option<ChainAmplification> {
        let hinge = self.hinge.as_ref()?;
        let bridge = bridge_chain(hinge, angle, self.link_mm.unwrap_or_default())?;
        Some(chain_amplification(&bridge, lever))
    }

    /// Evaluates the chain and the inverse.
    pub fn run(&self) -> Result<AmplifierReport, StepError> {
        self.validate()?;
        let (li, lo) = (
            self.input_arm_mm.unwrap_or_default(),
            self.output_arm_mm.unwrap_or_default(),
        );
        let hinge = self.hinge.clone().unwrap_or_default();
        let pivot = self.pivot.as_ref().unwrap_or(&hinge);
        let lever = lever_chain(pivot, li, lo).ok_or_else(singular)?;
        let angle = self.angle_deg.map(f64::to_radians);
        let chain = match angle {
            Some(a) => Some(self.chain_at(a, &lever).ok_or_else(singular)?),
            None => None,
        };
        let prb = angle.map(|a| {
            let (k_rot, k_axial) = hinge.stiffnesses();
            let link = self.link_mm.unwrap_or_default() * 1e-3;
            BridgeLimb {
                angle: a,
                link,
                k_axial,
                k_rot,
            }
            .amplification()
            .compliant
        });
        let overall_at = |a: f64| self.chain_at(a, &lever).map_or(0.0, |c| c.overall);
        let (peak_angle, peak) = peak_over_angle(overall_at);
        let input_stiffness = chain.map(|c| c.input_stiffness * 1e-6);
        let delivered = self
            .kp
            .zip(input_stiffness)
            .map(|(kp, k)| flexure_displacement(kp, k, self.dl0).0);
        Ok(AmplifierReport {
            inputs: self.clone(),
            bridge_ideal: angle.map(|a| 1.0 / a.tan()),
            bridge_prb: prb,
            bridge_free: chain.map(|c| c.bridge),
            bridge_loaded: chain.map(|c| c.bridge_loaded),
            lever_ideal: lo / li,
            lever: lever.ratio(),
            overall: chain.map(|c| c.overall),
            input_stiffness_n_per_um: input_stiffness,
            delivered_input_um: delivered,
            output_stroke_um: delivered.zip(chain).map(|(d, c)| d * c.overall),
            peak_ratio: peak,
            peak_angle_deg: peak_angle.to_degrees(),
            angle_for_target_deg: angle_above_peak(overall_at, peak_angle, peak, self.target_ratio)
                .map(f64::to_degrees),
        })
    }
}

fn singular() -> StepError {
    StepError::computation("the amplifier's compliance matrix is singular for this geometry")
}

/// The largest value of `ratio(angle)` on a 0.05 deg grid over (0, 89] deg,
/// refined by golden-section search: `(angle, ratio)` in rad.
fn peak_over_angle(ratio: impl Fn(f64) -> f64) -> (f64, f64) {
    let step = 0.05f64.to_radians();
    let (best, _) = (1..=1780)
        .map(|i| i as f64 * step)
        .map(|a| (a, ratio(a)))
        .fold(
            (step, f64::NEG_INFINITY),
            |b, a| if a.1 > b.1 { a } else { b },
        );
    let (mut lo, mut hi) = ((best - step).max(1e-6), best + step);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..60 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if ratio(a) > ratio(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let at = 0.5 * (lo + hi);
    (at, ratio(at))
}

/// The angle above the peak where `ratio` falls to `target` (bisection:
/// the ratio decreases from the peak towards 90 deg), or `None`.
fn angle_above_peak(
    ratio: impl Fn(f64) -> f64,
    peak_at: f64,
    peak: f64,
    target: f64,
) -> Option<f64> {
    let mut hi = 89.0f64.to_radians();
    if target > peak || ratio(hi) > target {
        return None;
    }
    let mut lo = peak_at;
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if ratio(mid) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

impl fmt::Display for AmplifierReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        writeln!(
            f,
            "Bridge into lever (compliance matrices): angle {} deg, link {} mm; lever {} : {} mm",
            opt(i.angle_deg, 3),
            opt(i.link_mm, 3),
            opt(i.input_arm_mm, 3),
            opt(i.output_arm_mm, 3)
        )?;
        writeln!(
            f,
            "  bridge: ideal {}, pseudo-rigid-body {}, compliance matrices {} free, {} loaded by the lever",
            opt(self.bridge_ideal, 4),
            opt(self.bridge_prb, 4),
            opt(self.bridge_free, 4),
            opt(self.bridge_loaded, 4)
        )?;
        writeln!(
            f,
            "  lever: ideal {:.4}, compliance matrices {:.4}",
            self.lever_ideal, self.lever
        )?;
        writeln!(
            f,
            "  overall {}; input stiffness {} N/um",
            opt(self.overall, 4),
            opt(self.input_stiffness_n_per_um, 4)
        )?;
        if let (Some(d), Some(o)) = (self.delivered_input_um, self.output_stroke_um) {
            writeln!(
                f,
                "  [Li21] Eq. 1, kp = {} N/um, free stroke {} um: elongation {d:.4} um, tool {o:.4} um",
                i.kp.unwrap_or_default(),
                i.dl0
            )?;
        }
        writeln!(
            f,
            "  over the bridge angle: at most {:.4}, at {:.3} deg",
            self.peak_ratio, self.peak_angle_deg
        )?;
        writeln!(
            f,
            "  for an overall ratio of {}: angle {} deg",
            i.target_ratio,
            self.angle_for_target_deg
                .map_or("unreachable".into(), |a| format!("{a:.3}"))
        )
    }
}
