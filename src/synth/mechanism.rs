//! Mechanism design formulas (docs/mechanism.md):
//!
//! * \[Li21\] Eq. 1, displacement lost in the flexure: the actuator (stiffness
//!   `k_p`) in series with the flexure (`k`) delivers `dL0 k_p/(k_p + k)`.
//! * \[Li21\] Eq. 2, rotational stiffness of a straight-beam flexure hinge with
//!   circular fillets: `K = E b t^3/(12 l) + E b R^2/(12 f(s))`, `s = R/t`.
//! * \[Tang17\] Eq. 2-7, the 3-PUU parallel FTS: inverse kinematics, its
//!   Jacobian `J = dS/d(x, y, z)`, conditioning, and the workspace by
//!   seeded Monte-Carlo sampling.
//! * Displacement amplifiers (\[Tang17\] measures 3.87, FEA 4.1, for its
//!   amplifier without giving its geometry): the lever (ideal
//!   `L_out/L_in`, and with a compliant pivot) and one limb of the
//!   bridge-type amplifier (ideal `cot(alpha)`, and with compliant hinges),
//!   pseudo-rigid-body models whose derivation is in docs/mechanism.md,
//!   with their inverses (the arm ratio or angle giving a target ratio).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// \[Li21\] Eq. 1: what the actuator's free stroke `dl0` becomes through a
/// flexure of stiffness `k` (same unit as `kp`): `(delivered, lost)`.
pub fn flexure_displacement(kp: f64, k: f64, dl0: f64) -> (f64, f64) {
    let delivered = dl0 * kp / (kp + k);
    (delivered, dl0 - delivered)
}

/// The `f(s)` of \[Li21\] Eq. 2, `s = R/t`:
/// `12 s^4 (2s+1)/(4s+1)^(5/2) atan(sqrt(4s+1)) + 2 s^3 (6s^2+4s+1)/((4s+1)^2 (2s+1))`.
pub fn li21_f(s: f64) -> f64 {
    let q = 4.0 * s + 1.0;
    12.0 * s.powi(4) * (2.0 * s + 1.0) / q.powf(2.5) * q.sqrt().atan()
        + 2.0 * s.powi(3) * (6.0 * s * s + 4.0 * s + 1.0) / (q * q * (2.0 * s + 1.0))
}

/// A straight-beam flexure hinge with circular fillets (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HingeGeometry {
    /// Young's modulus, Pa.
    pub youngs_modulus: f64,
    /// Width `b` (out of plane), m.
    pub width: f64,
    /// Beam length `l`, m.
    pub length: f64,
    /// Thickness `t`, m.
    pub thickness: f64,
    /// Fillet radius `R`, m.
    pub radius: f64,
}

/// The two terms of \[Li21\] Eq. 2 and their sum, N m/rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HingeStiffness {
    /// `E b t^3 / (12 l)`, the straight beam.
    pub beam: f64,
    /// `E b R^2 / (12 f(s))`, the fillets.
    pub fillets: f64,
    /// `s = R/t`.
    pub s: f64,
    /// `f(s)`.
    pub f: f64,
    /// The sum.
    pub total: f64,
}

/// \[Li21\] Eq. 2.
pub fn hinge_stiffness(g: &HingeGeometry) -> HingeStiffness {
    let HingeGeometry {
        youngs_modulus: e,
        width: b,
        length: l,
        thickness: t,
        radius: r,
    } = *g;
    let beam = e * b * t.powi(3) / (12.0 * l);
    let s = r / t;
    let f = li21_f(s);
    let fillets = if r > 0.0 {
        e * b * r * r / (12.0 * f)
    } else {
        0.0
    };
    HingeStiffness {
        beam,
        fillets,
        s,
        f,
        total: beam + fillets,
    }
}

/// Axial stiffness `E b t / l` of a straight leaf hinge (N/m; the fillets of
/// \[Li21\] Eq. 2 are left out, which makes it a lower bound).
pub fn leaf_axial_stiffness(g: &HingeGeometry) -> f64 {
    g.youngs_modulus * g.width * g.thickness / g.length
}

/// A first-class lever (pivot between input and output) on a flexure
/// pivot: arms in m, pivot stiffnesses `k_rot` (N m/rad) and `k_trans`
/// (N/m, along the input force; `f64::INFINITY` for a fixed pivot).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lever {
    /// Pivot to input point, m.
    pub input_arm: f64,
    /// Pivot to output point, m.
    pub output_arm: f64,
    /// Rotational stiffness of the pivot, N m/rad.
    pub k_rot: f64,
    /// Translational stiffness of the pivot along the force, N/m.
    pub k_trans: f64,
}

/// What a lever or a bridge limb amplifies, unloaded output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Amplification {
    /// The rigid-body (kinematic) ratio.
    pub ideal: f64,
    /// The ratio with the hinges' compliance.
    pub compliant: f64,
    /// Stiffness the actuator sees at the input, N/m.
    pub input_stiffness: f64,
}

impl Lever {
    /// Force `F` at the input, output free: the pivot turns by
    /// `theta = F L_in / k_rot` and moves by `delta = F / k_trans` along
    /// `F`, so `x_in = theta L_in + delta`, `x_out = theta L_out - delta`
    /// and `R = (L_in L_out/k_rot - 1/k_trans) / (L_in^2/k_rot + 1/k_trans)`
    /// (`L_out/L_in` for a rigid pivot).
    pub fn amplification(&self) -> Amplification {
        let (li, lo) = (self.input_arm, self.output_arm);
        let (cr, ct) = (1.0 / self.k_rot, 1.0 / self.k_trans);
        let input_compliance = li * li * cr + ct;
        Amplification {
            ideal: lo / li,
            compliant: (li * lo * cr - ct) / input_compliance,
            input_stiffness: 1.0 / input_compliance,
        }
    }

    /// The output arm that gives `ratio` with this input arm and pivot
    /// (the lever formula solved for `L_out`).
    pub fn output_arm_for(&self, ratio: f64) -> f64 {
        let li = self.input_arm;
        let (cr, ct) = (1.0 / self.k_rot, 1.0 / self.k_trans);
        (ratio * (li * li * cr + ct) + ct) / (li * cr)
    }
}

/// One limb of a symmetric bridge-type amplifier: a rigid link of length
/// `link` (m) at `angle` (rad) to the input axis between two identical
/// hinges (axial `k_axial` N/m, rotational `k_rot` N m/rad), input and
/// output blocks guided (they translate without turning). The input block
/// moves `x` along the input axis, the output block `y` across it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BridgeLimb {
    /// Link angle to the input axis, rad.
    pub angle: f64,
    /// Link length between the hinges, m.
    pub link: f64,
    /// Axial stiffness of one hinge, N/m.
    pub k_axial: f64,
    /// Rotational stiffness of one hinge, N m/rad.
    pub k_rot: f64,
}

impl BridgeLimb {
    /// Stiffness of the limb along the link (two hinges in series) and
    /// across it (both hinges bend by the link's rotation `v/l`:
    /// `2 (1/2) k_rot (v/l)^2`), N/m.
    fn along_across(&self) -> (f64, f64) {
        (
            0.5 * self.k_axial,
            2.0 * self.k_rot / (self.link * self.link),
        )
    }

    /// The elongation `u = x cos a - y sin a` and the transverse motion
    /// `v = x sin a + y cos a` of the link store `(k_a u^2 + k_t v^2)/2`;
    /// the free output takes the `y` that minimises it:
    /// `R = y/x = sin a cos a (k_a - k_t) / (k_a sin^2 a + k_t cos^2 a)`,
    /// `cot a` for rigid links (`k_t -> 0` or `k_a -> inf`), and the input
    /// stiffness `k_a k_t / (k_a sin^2 a + k_t cos^2 a)`.
    pub fn amplification(&self) -> Amplification {
        let (ka, kt) = self.along_across();
        let (s, c) = self.angle.sin_cos();
        let den = ka * s * s + kt * c * c;
        Amplification {
            ideal: c / s,
            compliant: s * c * (ka - kt) / den,
            input_stiffness: ka * kt / den,
        }
    }

    /// The largest compliant ratio over all angles and the angle (rad)
    /// that gives it: with `u = tan a`, `R = u (k_a - k_t)/(k_a u^2 + k_t)`
    /// peaks at `u = sqrt(k_t/k_a)` with `(k_a - k_t)/(2 sqrt(k_a k_t))`.
    pub fn peak(&self) -> (f64, f64) {
        let (ka, kt) = self.along_across();
        (
            (ka - kt) / (2.0 * (ka * kt).sqrt()),
            (kt / ka).sqrt().atan(),
        )
    }

    /// The angles (rad, smaller first) at which the compliant ratio equals
    /// `ratio`: the roots of `k_a R u^2 - (k_a - k_t) u + k_t R = 0`,
    /// `u = tan a`; `None` above the peak.
    pub fn angles_for(&self, ratio: f64) -> Option<(f64, f64)> {
        let (ka, kt) = self.along_across();
        let b = ka - kt;
        let disc = b * b - 4.0 * ka * kt * ratio * ratio;
        if !(disc >= 0.0 && ratio > 0.0 && b > 0.0) {
            return None;
        }
        let big = (b + disc.sqrt()) / (2.0 * ka * ratio);
        // The product of the roots is k_t/k_a: the small one without cancellation.
        let small = kt / (ka * big);
        Some((small.atan(), big.atan()))
    }
}

/// The link angle (rad) at which a rigid bridge amplifies by `ratio`:
/// `cot a = ratio`.
pub fn ideal_bridge_angle(ratio: f64) -> f64 {
    (1.0 / ratio).atan()
}

/// The 3-PUU geometry of \[Tang17\] (any length unit, the same throughout).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Puu3 {
    /// Rod length `L`.
    pub rod: f64,
    /// Base joint circle radius `r`.
    pub base_radius: f64,
    /// Platform joint circle radius `r_a`.
    pub platform_radius: f64,
}

impl Default for Puu3 {
    /// \[Tang17\]: `L = 60`, `r = 70`, `r_a = 27` (mm).
    fn default() -> Self {
        Puu3 {
            rod: 60.0,
            base_radius: 70.0,
            platform_radius: 27.0,
        }
    }
}

/// Angles of the three base joints: 0, 120, 240 deg (the printed `C_2` of
/// \[Tang17\] has a sign typo).
pub const JOINT_ANGLES_DEG: [f64; 3] = [0.0, 120.0, 240.0];

impl Puu3 {
    /// The horizontal offsets `(d cos th_i - x, d sin th_i - y)`, `d = r - r_a`.
    fn offsets(&self, x: f64, y: f64) -> [(f64, f64); 3] {
        let d = self.base_radius - self.platform_radius;
        JOINT_ANGLES_DEG.map(|a| {
            let th = a.to_radians();
            (d * th.cos() - x, d * th.sin() - y)
        })
    }

    /// \[Tang17\] Eq. 2-4: slider positions
    /// `S_i = z - sqrt(L^2 - (d cos th_i - x)^2 - (d sin th_i - y)^2)`;
    /// `None` when a rod cannot reach.
    pub fn inverse(&self, x: f64, y: f64, z: f64) -> Option<[f64; 3]> {
        let o = self.offsets(x, y);
        let mut s = [0.0; 3];
        for (i, (dx, dy)) in o.iter().enumerate() {
            let h2 = self.rod * self.rod - dx * dx - dy * dy;
            if h2.is_nan() || h2 <= 0.0 {
                return None;
            }
            s[i] = z - h2.sqrt();
        }
        Some(s)
    }

    /// \[Tang17\] Eq. 5-7: `J = dS/d(x, y, z)`, row i
    /// `[dx_i/h_i, dy_i/h_i, 1]` with `(dx_i, dy_i)` the offsets and
    /// `h_i` the rod's vertical extent. `None` when a rod cannot reach.
    pub fn jacobian(&self, x: f64, y: f64) -> Option<[[f64; 3]; 3]> {
        let o = self.offsets(x, y);
        let mut j = [[0.0; 3]; 3];
        for (i, (dx, dy)) in o.iter().enumerate() {
            let h2 = self.rod * self.rod - dx * dx - dy * dy;
            if h2.is_nan() || h2 <= 0.0 {
                return None;
            }
            let h = h2.sqrt();
            // `+ 0.0` turns a -0 (a joint on the x axis) into 0.
            j[i] = [-dx / h + 0.0, -dy / h + 0.0, 1.0];
        }
        Some(j)
    }
}

impl Puu3 {
    /// Forward kinematics: the pose `(x, y, z)` whose slider positions
    /// ([`Puu3::inverse`]) are `s`, by Newton's method on
    /// `S(p) - s = 0` with the Jacobian of \[Tang17\] Eq. 5-7, started at
    /// `(0, 0, mean(s) + h_0)` (`h_0` the rods' vertical extent at home).
    /// Stops at a step below `1e-13 L`; `None` when a rod cannot reach on
    /// the way, the Jacobian is singular or 50 steps do not converge.
    pub fn forward(&self, s: [f64; 3]) -> Option<[f64; 3]> {
        let d = self.base_radius - self.platform_radius;
        let h0 = (self.rod * self.rod - d * d).sqrt();
        let mut p = [0.0, 0.0, s.iter().sum::<f64>() / 3.0 + h0];
        for _ in 0..50 {
            let f = self.inverse(p[0], p[1], p[2])?;
            let j = self.jacobian(p[0], p[1])?;
            let step = solve3(&j, [f[0] - s[0], f[1] - s[1], f[2] - s[2]])?;
            for (pi, di) in p.iter_mut().zip(step) {
                *pi -= di;
            }
            if step.iter().all(|v| v.abs() <= 1e-13 * self.rod) {
                return Some(p);
            }
        }
        None
    }
}

/// `m x = b` for a 3x3 `m` (LU with partial pivoting); `None` when `m` is
/// singular or the result is not finite.
pub fn solve3(m: &[[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let a = nalgebra::Matrix3::from_fn(|i, k| m[i][k]);
    let x = a.lu().solve(&nalgebra::Vector3::from(b))?;
    let x = [x[0], x[1], x[2]];
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// 2-norm condition number of a 3x3 matrix (singular values by faer).
pub fn condition_number(m: &[[f64; 3]; 3]) -> f64 {
    let a = faer::Mat::from_fn(3, 3, |i, j| m[i][j]);
    match fts_kernels::dense::singular_values(a.as_ref()) {
        Ok(s) if s[2] > 0.0 => s[0] / s[2],
        _ => f64::INFINITY,
    }
}

/// Seeded Monte-Carlo workspace settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkspaceParams {
    /// Slider stroke: `0 <= S_i - S_i(home) <= stroke`.
    pub stroke: f64,
    /// Samples drawn.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
}

/// The reachable poses found and the box around them.
#[derive(Debug, Clone, PartialEq)]
pub struct Workspace {
    /// Reachable `(x, y, z)`, relative to the home pose.
    pub points: Vec<[f64; 3]>,
    /// `[min, max]` of x, y and z.
    pub extent: [[f64; 2]; 3],
    /// Samples drawn.
    pub samples: usize,
}

/// Draws poses uniformly in the box `|x|, |y| <= stroke`,
/// `z in [-0.05, 1.05] stroke` around home (it holds every reachable pose:
/// the home Jacobian's rows need `|x| <= stroke/1.54`, `|y| <= stroke/1.78`,
/// and `z` leaves `[0, stroke]` only by the rods' second-order
/// `(x^2 + y^2)/(2 h)`, under 0.1 % of the stroke at micrometre strokes)
/// and keeps those whose slider displacements from home all lie in
/// `[0, stroke]`: the workspace of \[Tang17\] §2. The kinematics do not
/// depend on the home height, so home is `z = 0`.
pub fn workspace(m: &Puu3, p: &WorkspaceParams) -> Workspace {
    let home = m.inverse(0.0, 0.0, 0.0).expect("home pose reachable");
    let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
    let half = p.stroke;
    let mut points = Vec::new();
    for _ in 0..p.samples {
        let x = rng.random_range(-half..=half);
        let y = rng.random_range(-half..=half);
        let z = rng.random_range(-0.05 * p.stroke..=1.05 * p.stroke);
        if let Some(s) = m.inverse(x, y, z)
            && s.iter()
                .zip(&home)
                .all(|(si, hi)| (0.0..=p.stroke).contains(&(si - hi)))
        {
            points.push([x, y, z]);
        }
    }
    let mut extent = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
    for q in &points {
        for (e, v) in extent.iter_mut().zip(q) {
            e[0] = e[0].min(*v);
            e[1] = e[1].max(*v);
        }
    }
    Workspace {
        points,
        extent,
        samples: p.samples,
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    /// The lever against its limits (pin pivot: `L_out/L_in`), Clapeyron's
    /// theorem (the work `F x_in / 2` equals the energy stored in the
    /// pivot) and its inverse.
    pub fn lever_limits_energy_and_inverse() {
        let pin = Lever {
            input_arm: 0.01,
            output_arm: 0.0387,
            k_rot: 1e-12,
            k_trans: f64::INFINITY,
        };
        let a = pin.amplification();
        assert!((a.ideal - 3.87).abs() < 1e-12 && (a.compliant - 3.87).abs() < 1e-9);
        let l = Lever {
            k_rot: 35.0,
            k_trans: 2e8,
            ..pin
        };
        let a = l.amplification();
        assert!(a.compliant < a.ideal);
        // Force F: theta = F L_in/k_rot, delta = F/k_trans.
        let f = 1.0;
        let (theta, delta) = (f * l.input_arm / l.k_rot, f / l.k_trans);
        let x_in = f / a.input_stiffness;
        let stored = 0.5 * l.k_rot * theta * theta + 0.5 * l.k_trans * delta * delta;
        assert!((0.5 * f * x_in / stored - 1.0).abs() < 1e-12);
        let x_out = theta * l.output_arm - delta;
        assert!((x_out / x_in / a.compliant - 1.0).abs() < 1e-12);
        let arm = l.output_arm_for(3.87);
        let back = Lever {
            output_arm: arm,
            ..l
        };
        assert!((back.amplification().compliant - 3.87).abs() < 1e-12);
    }

    /// The bridge limb: rigid links give `cot(a)`; the compliant ratio
    /// equals the free output of the limb's 2x2 stiffness matrix, built
    /// here by rotating `diag(k_a, k_t)` (an independent route); the peak
    /// and the inverse roots reproduce themselves.
    pub fn bridge_limb_limits_stiffness_matrix_peak_and_inverse() {
        let a = 10f64.to_radians();
        let rigid = BridgeLimb {
            angle: a,
            link: 0.01,
            k_axial: 1e30,
            k_rot: 1.0,
        };
        let r = rigid.amplification();
        assert!((r.compliant / r.ideal - 1.0).abs() < 1e-12, "{r:?}");
        assert!((r.ideal - 1.0 / a.tan()).abs() < 1e-12);
        let limb = BridgeLimb {
            k_axial: 1.7e8,
            k_rot: 35.0,
            ..rigid
        };
        let (ka, kt) = (
            0.5 * limb.k_axial,
            2.0 * limb.k_rot / (limb.link * limb.link),
        );
        // u = c x - s y, v = s x + c y, i.e. (u, v) = T (x, y) with
        // T = [c -s; s c]: the limb's stiffness in (x, y) is T' diag(ka, kt) T.
        let (s, c) = a.sin_cos();
        let kxy = -ka * c * s + kt * s * c;
        let kyy = ka * s * s + kt * c * c;
        let kxx = ka * c * c + kt * s * s;
        // Free output: K_yx x + K_yy y = 0; input stiffness: Schur complement.
        let ratio = -kxy / kyy;
        let k_in = kxx - kxy * kxy / kyy;
        let got = limb.amplification();
        assert!(
            (got.compliant / ratio - 1.0).abs() < 1e-12,
            "{got:?} {ratio}"
        );
        assert!((got.input_stiffness / k_in - 1.0).abs() < 1e-9);
        let (peak, at) = limb.peak();
        let at_peak = BridgeLimb { angle: at, ..limb }.amplification().compliant;
        assert!((at_peak / peak - 1.0).abs() < 1e-12);
        for da in [-1e-3, 1e-3] {
            let near = BridgeLimb {
                angle: at + da,
                ..limb
            };
            assert!(near.amplification().compliant < peak);
        }
        let (lo, hi) = limb.angles_for(3.87).unwrap();
        assert!(lo < at && at < hi);
        for ang in [lo, hi] {
            let r = BridgeLimb { angle: ang, ..limb }.amplification().compliant;
            assert!((r - 3.87).abs() < 1e-9, "{r}");
        }
        assert!(limb.angles_for(peak * 1.01).is_none());
        // Tang17's 3.87 needs acot(3.87) = 14.488203 deg with rigid links (python math).
        assert!((ideal_bridge_angle(3.87).to_degrees() - 14.488203).abs() < 1e-6);
    }

    pub fn li21_eq1_loses_0_55_um_of_10() {
        let (delivered, lost) = flexure_displacement(200.0, 11.6, 10.0);
        assert!((lost - 0.5482).abs() < 1e-4, "{lost}");
        assert_eq!(format!("{lost:.2}"), "0.55");
        assert!((delivered + lost - 10.0).abs() < 1e-12);
    }

    /// `f(s)` at the Li21 design `s = 2/0.6` against the value numpy
    /// computes from the same printed formula (22.976318924585193), and the
    /// straight-beam limit `R -> 0`.
    pub fn li21_eq2_f_and_its_limits() {
        assert!((li21_f(2.0 / 0.6) - 22.976318924585193).abs() < 1e-12);
        let g = HingeGeometry {
            youngs_modulus: 2e11,
            width: 0.01,
            length: 0.007,
            thickness: 6e-4,
            radius: 0.0,
        };
        let k = hinge_stiffness(&g);
        assert_eq!(k.total, 2e11 * 0.01 * 6e-4f64.powi(3) / (12.0 * 0.007));
    }

    /// \[Tang17\] home pose: `d = 43`, `h = sqrt(60^2 - 43^2)`, rows
    /// `[-d/h, 0, 1]`, `[d/(2h), -+ d sqrt(3)/(2h), 1]` = `[-1.0276, 0, 1]`,
    /// `[0.5138, -+0.8899, 1]`.
    pub fn tang17_home_jacobian_has_the_published_rows() {
        let j = Puu3::default().jacobian(0.0, 0.0).unwrap();
        let published = [
            [-1.0276, 0.0, 1.0],
            [0.5138, -0.8899, 1.0],
            [0.5138, 0.8899, 1.0],
        ];
        for (row, pub_row) in j.iter().zip(&published) {
            for (a, b) in row.iter().zip(pub_row) {
                assert!((a - b).abs() < 5e-5, "{row:?} vs {pub_row:?}");
            }
        }
    }

    /// The Jacobian is the derivative of the inverse kinematics (central
    /// differences at an off-home pose).
    /// Forward kinematics undo the inverse ones to ~1e-12 (mm) over the
    /// micrometre workspace and beyond, and `solve3` against a known
    /// product.
    pub fn forward_kinematics_invert_the_inverse() {
        let m = Puu3::default();
        let home = m.inverse(0.0, 0.0, 0.0).unwrap();
        let back = m.forward(home).unwrap();
        assert!(back.iter().all(|v| v.abs() < 1e-12), "{back:?}");
        for &(x, y, z) in &[
            (0.08, -0.085, 0.12),
            (-0.075, 0.06, 0.0),
            (1.5, 2.0, -3.0),
            (5.0, -4.0, 10.0),
        ] {
            let s = m.inverse(x, y, z).unwrap();
            let p = m.forward(s).unwrap();
            for (a, b) in p.iter().zip([x, y, z]) {
                assert!((a - b).abs() < 1e-12, "{p:?} vs {:?}", (x, y, z));
            }
        }
        let j = m.jacobian(0.01, -0.02).unwrap();
        let x = [0.3, -1.2, 2.5];
        let b: Vec<f64> = j
            .iter()
            .map(|r| r.iter().zip(&x).map(|(a, b)| a * b).sum())
            .collect();
        let got = solve3(&j, [b[0], b[1], b[2]]).unwrap();
        assert!(got.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-12));
        assert!(solve3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]], x).is_none());
    }

    pub fn jacobian_is_the_derivative_of_the_inverse_kinematics() {
        let m = Puu3::default();
        let (x, y, z, h) = (0.07, -0.05, 42.0, 1e-6);
        let j = m.jacobian(x, y).unwrap();
        for (axis, delta) in [(0, [h, 0.0, 0.0]), (1, [0.0, h, 0.0]), (2, [0.0, 0.0, h])] {
            let plus = m.inverse(x + delta[0], y + delta[1], z + delta[2]).unwrap();
            let minus = m.inverse(x - delta[0], y - delta[1], z - delta[2]).unwrap();
            for i in 0..3 {
                let fd = (plus[i] - minus[i]) / (2.0 * h);
                assert!(
                    (fd - j[i][axis]).abs() < 1e-7,
                    "J[{i}][{axis}] {} vs {fd}",
                    j[i][axis]
                );
            }
        }
    }

    /// Every sampled pose reaches the stroke limits no further than the
    /// linearised bound allows: pure z up to the stroke, and the x extent
    /// within `stroke / (1.0276 + 0.5138)` (the stroke shared by rows 1
    /// and 2 of J).
    pub fn workspace_respects_the_linearised_bounds() {
        let w = workspace(
            &Puu3::default(),
            &WorkspaceParams {
                stroke: 0.25,
                samples: 200_000,
                seed: 1,
            },
        );
        assert!(!w.points.is_empty());
        let [ex, ey, ez] = w.extent;
        assert!(ez[0] >= 0.0 && ez[1] <= 0.25 + 1e-12, "{ez:?}");
        let x_bound = 0.25 / (1.0276 + 0.5138);
        assert!(
            ex[1] <= x_bound * 1.01 && ex[0] >= -x_bound * 1.01,
            "{ex:?} vs {x_bound}"
        );
        assert!(ex[1] > 0.9 * x_bound, "sampling too sparse: {ex:?}");
        let y_bound = 0.25 / (2.0 * 0.8899);
        assert!(
            ey[1] <= y_bound * 1.01 && ey[1] > 0.9 * y_bound,
            "{ey:?} vs {y_bound}"
        );
    }
}
