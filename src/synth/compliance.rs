//! The compliance-matrix method for planar flexure mechanisms
//! (docs/mechanism.md, "Compliance matrices"): the in-plane compliance of a
//! corner-filleted leaf hinge integrated along its profile (Euler-Bernoulli
//! beam, Castigliano), carried between frames by the planar adjoint, added
//! along serial chains; and the two amplifiers of an FTS built from it, the
//! bridge-type amplifier and the lever, as two-ports (ratio, input and
//! output stiffness) that chain into an overall amplification.
//!
//! Tang17 (its Eq. 18-44) analyses its amplifier the same way; its printed
//! equations are not in this project's material, so this module derives
//! the method from beam theory, and docs/mechanism.md says so.

use super::mechanism::HingeGeometry;

/// A 3x3 matrix over the planar twist/wrench `(x, y, theta)` / `(F_x, F_y, M)`.
pub type Mat3 = [[f64; 3]; 3];

/// Where a hinge's free end sits and which way its axis points (rad, from
/// the global x axis towards y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Position of the free end, m.
    pub origin: [f64; 2],
    /// Direction of the hinge axis (fixed end towards free end), rad.
    pub angle: f64,
}

/// Gauss-Legendre nodes and weights on [-1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// `int_a^b f`, composite 8-point Gauss-Legendre on `pieces` panels.
fn integrate(a: f64, b: f64, pieces: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / pieces as f64;
    (0..pieces)
        .map(|i| {
            let mid = a + (i as f64 + 0.5) * h;
            GL8.iter()
                .map(|&(x, w)| w * f(mid + 0.5 * h * x))
                .sum::<f64>()
                * 0.5
                * h
        })
        .sum()
}

impl HingeGeometry {
    /// Length of the whole profile, the straight beam and both fillets, m.
    pub fn profile_length(&self) -> f64 {
        self.length + 2.0 * self.radius
    }

    /// Thickness at `s` along the profile (0 at the fixed end): a fillet
    /// of radius `R` on each side at both ends, `t + 2 (R - sqrt(R^2 - d^2))`
    /// with `d` the distance from where the straight part begins.
    pub fn thickness_at(&self, s: f64) -> f64 {
        let (r, l, t) = (self.radius, self.length, self.thickness);
        let d = if s < r {
            r - s
        } else if s > r + l {
            s - r - l
        } else {
            0.0
        };
        t + 2.0 * (r - (r * r - d * d).max(0.0).sqrt())
    }
}

/// The hinge's compliance at its free end in its own frame (x along the
/// axis), fixed end clamped, by Castigliano's theorem on the profile
/// (`A = b t(s)`, `I = b t(s)^3/12`, shear neglected):
/// `C_xx = int ds/(E A)`, `C_yy = int (L-s)^2 ds/(E I)`,
/// `C_ytheta = int (L-s) ds/(E I)`, `C_thetatheta = int ds/(E I)`.
/// The segments of the profile add in series: the rotational stiffness is
/// `1/C_thetatheta`, not \[Li21\] Eq. 2's sum of the two stiffnesses.
pub fn hinge_compliance(g: &HingeGeometry) -> Mat3 {
    let (e, b) = (g.youngs_modulus, g.width);
    let total = g.profile_length();
    let ei = |s: f64| e * b * g.thickness_at(s).powi(3) / 12.0;
    let ea = |s: f64| e * b * g.thickness_at(s);
    let (r, l) = (g.radius, g.length);
    // The fillets in the angle `phi` of their arc (`d = R sin phi`), where
    // the integrands are smooth: in `d` the thickness has an unbounded
    // slope where the fillet meets the block.
    let seg = |f: &dyn Fn(f64) -> f64| {
        let fillets = integrate(0.0, std::f64::consts::FRAC_PI_2, 16, |phi| {
            let d = r * phi.sin();
            (f(r - d) + f(r + l + d)) * r * phi.cos()
        });
        fillets + integrate(r, r + l, 4, f)
    };
    let cxx = seg(&|s| 1.0 / ea(s));
    let cyy = seg(&|s| (total - s).powi(2) / ei(s));
    let cyt = seg(&|s| (total - s) / ei(s));
    let ctt = seg(&|s| 1.0 / ei(s));
    [[cxx, 0.0, 0.0], [0.0, cyy, cyt], [0.0, cyt, ctt]]
}

/// The map from a wrench at `point` (global axes) to the wrench at the
/// frame's origin in the frame's axes: shift the moment, rotate the force.
/// The frame's free-end twist `C A w` carries back as `A^T C A w`
/// (contragredience: virtual work is frame-independent).
fn wrench_map(frame: &Frame, point: [f64; 2]) -> Mat3 {
    let (s, c) = frame.angle.sin_cos();
    let (dx, dy) = (point[0] - frame.origin[0], point[1] - frame.origin[1]);
    // Moment about the frame origin of a force at `point`: M + dx F_y - dy F_x.
    let shift = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-dy, dx, 1.0]];
    let rotate = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
    mul(&rotate, &shift)
}

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn transpose(a: &Mat3) -> Mat3 {
    let mut t = [[0.0; 3]; 3];
    for (i, row) in a.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            t[j][i] = *v;
        }
    }
    t
}

/// Compliance between two points of the body a serial chain of hinges
/// carries: the twist at `at` per unit wrench at `load` (global axes),
/// `sum_i A_i(at)^T C_i A_i(load)`.
pub fn chain_compliance(chain: &[(Frame, Mat3)], at: [f64; 2], load: [f64; 2]) -> Mat3 {
    let mut total = [[0.0; 3]; 3];
    for (frame, c) in chain {
        let m = mul(
            &transpose(&wrench_map(frame, at)),
            &mul(c, &wrench_map(frame, load)),
        );
        for (t, r) in total.iter_mut().zip(m) {
            for (a, b) in t.iter_mut().zip(r) {
                *a += b;
            }
        }
    }
    total
}

fn inverse(a: &Mat3) -> Option<Mat3> {
    let cof = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]
    };
    let det: f64 = (0..3).map(|j| a[0][j] * cof(0, j)).sum();
    if !(det.is_normal()) {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = cof(j, i) / det;
        }
    }
    Some(inv)
}

/// A linear two-port: the stiffness in (input displacement, output
/// displacement), each positive along its own working direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoPort {
    /// `[[k_ii, k_io], [k_io, k_oo]]`, N/m.
    pub stiffness: [[f64; 2]; 2],
}

impl TwoPort {
    /// Output over input with the output free: `-k_io/k_oo`.
    pub fn ratio(&self) -> f64 {
        -self.stiffness[0][1] / self.stiffness[1][1]
    }

    /// Output over input with a spring `k_load` (N/m) at the output.
    pub fn loaded_ratio(&self, k_load: f64) -> f64 {
        -self.stiffness[0][1] / (self.stiffness[1][1] + k_load)
    }

    /// Stiffness at the input with a spring `k_load` at the output (0: free).
    pub fn input_stiffness(&self, k_load: f64) -> f64 {
        let [[kii, kio], [_, koo]] = self.stiffness;
        kii - kio * kio / (koo + k_load)
    }

    /// Stiffness at the output with the input held.
    pub fn output_stiffness(&self) -> f64 {
        self.stiffness[1][1]
    }
}

/// One limb of a symmetric bridge-type amplifier with leaf hinges along
/// the link: hinge centres `link` apart at `angle` to the input axis,
/// input and output blocks guided (no rotation; the input block moves
/// along the input axis only, the output block across it only).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BridgeChain {
    /// Link angle to the input axis, rad.
    pub angle: f64,
    /// Distance between the hinge centres, m (hinge 1's start to hinge
    /// 2's start: the same for hinges of equal length).
    pub link: f64,
    /// Each hinge's compliance in its own frame, and its profile length, m.
    pub hinge: Mat3,
    pub hinge_length: f64,
}

impl BridgeChain {
    /// The bridge as a two-port in (actuator elongation, output blocks'
    /// separation): four limbs, each block moving half of either, store
    /// `4 (1/2) [e/2, s/2] K [e/2, s/2]^T`, so the limb's stiffness in
    /// (input block along the axis, output block towards the axis) is the
    /// bridge's in (e, s).
    pub fn two_port(&self) -> Option<TwoPort> {
        let (s, c) = self.angle.sin_cos();
        // From the input block at the origin the link runs inwards and up,
        // along (-cos a, sin a); the output block is at its far end.
        let dir = [-c, s];
        let along = |d: f64| [dir[0] * d, dir[1] * d];
        // Hinge 1 spans [0, L_h] from the input block, hinge 2
        // [link, link + L_h]; each frame sits at its hinge's far end.
        let lh = self.hinge_length;
        let axis = s.atan2(-c);
        let chain = [
            (
                Frame {
                    origin: along(lh),
                    angle: axis,
                },
                self.hinge,
            ),
            (
                Frame {
                    origin: along(self.link + lh),
                    angle: axis,
                },
                self.hinge,
            ),
        ];
        let out = along(self.link + lh);
        let k = inverse(&chain_compliance(&chain, out, out))?;
        // Output block's twist relative to the input block's translation
        // carried rigidly to it: (-x, -y_towards_axis, 0) for an input x
        // outwards and an output y towards the axis.
        Some(TwoPort {
            stiffness: [[k[0][0], k[0][1]], [k[1][0], k[1][1]]],
        })
    }
}

/// A first-class lever on a leaf-hinge pivot: the hinge stands on the
/// frame along the input force, the rigid arm across its free end, the
/// input `input_arm` to one side, the output `output_arm` to the other.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverChain {
    /// Pivot to input point, m.
    pub input_arm: f64,
    /// Pivot to output point, m.
    pub output_arm: f64,
    /// The pivot hinge's compliance in its own frame.
    pub hinge: Mat3,
}

impl LeverChain {
    /// The lever as a two-port in (input displacement along the force,
    /// output displacement opposite to it): the 2x2 compliance of the two
    /// points along the force direction, inverted.
    pub fn two_port(&self) -> Option<TwoPort> {
        let pivot = [(
            Frame {
                origin: [0.0, 0.0],
                angle: std::f64::consts::FRAC_PI_2,
            },
            self.hinge,
        )];
        let (pin, pout) = ([-self.input_arm, 0.0], [self.output_arm, 0.0]);
        let cy = |a: [f64; 2], b: [f64; 2]| chain_compliance(&pivot, a, b)[1][1];
        // The output's positive direction is -y: flip the cross terms.
        let (cii, cio, coo) = (cy(pin, pin), -cy(pin, pout), cy(pout, pout));
        let det = cii * coo - cio * cio;
        if !(det.is_normal() && det > 0.0) {
            return None;
        }
        Some(TwoPort {
            stiffness: [[coo / det, -cio / det], [-cio / det, cii / det]],
        })
    }
}

/// Bridge into lever: the bridge's output loaded by the lever's input
/// stiffness (output free), times the lever's free ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainAmplification {
    /// The bridge's free ratio.
    pub bridge: f64,
    /// The bridge's ratio loaded by the lever.
    pub bridge_loaded: f64,
    /// The lever's free ratio.
    pub lever: f64,
    /// `bridge_loaded * lever`.
    pub overall: f64,
    /// Stiffness the actuator sees through the whole chain, N/m.
    pub input_stiffness: f64,
}

/// The overall amplification of a bridge driving a lever.
pub fn chain_amplification(bridge: &TwoPort, lever: &TwoPort) -> ChainAmplification {
    let k_lever = lever.input_stiffness(0.0);
    let bridge_loaded = bridge.loaded_ratio(k_lever);
    ChainAmplification {
        bridge: bridge.ratio(),
        bridge_loaded,
        lever: lever.ratio(),
        overall: bridge_loaded * lever.ratio(),
        input_stiffness: bridge.input_stiffness(k_lever),
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::super::mechanism::{BridgeLimb, Lever, li21_f};
    use super::*;

    fn li21_hinge(radius: f64) -> HingeGeometry {
        HingeGeometry {
            youngs_modulus: 206e9,
            width: 0.01,
            length: 0.007,
            thickness: 6e-4,
            radius,
        }
    }

    /// With no fillets the integrals are a cantilever's closed forms:
    /// `l/(E b t)`, `4 l^3/(E b t^3)`, `6 l^2/(E b t^3)`, `12 l/(E b t^3)`.
    pub fn a_straight_leaf_is_a_cantilever() {
        let g = li21_hinge(0.0);
        let c = hinge_compliance(&g);
        let (e, b, l, t) = (g.youngs_modulus, g.width, g.length, g.thickness);
        let ebt3 = e * b * t.powi(3);
        let expect = [
            (c[0][0], l / (e * b * t)),
            (c[1][1], 4.0 * l.powi(3) / ebt3),
            (c[1][2], 6.0 * l * l / ebt3),
            (c[2][1], 6.0 * l * l / ebt3),
            (c[2][2], 12.0 * l / ebt3),
        ];
        for (got, want) in expect {
            assert!((got / want - 1.0).abs() < 1e-12, "{got} vs {want}");
        }
    }

    /// The rotational compliance of the filleted profile is the straight
    /// part's `12 l/(E b t^3)` plus the two fillets' `12 f(s)/(E b R^2)`:
    /// [Li21] Eq. 2's fillet term is exactly the fillets' compliance
    /// (closed form against quadrature), so the stiffnesses combine in
    /// series (4.4996 N m/rad at the Li21 design with b = 10 mm), not as
    /// Eq. 2's sum (35.1830).
    pub fn fillets_add_in_series_with_the_beam() {
        let g = li21_hinge(0.002);
        let c = hinge_compliance(&g);
        let (e, b, l, t, r) = (g.youngs_modulus, g.width, g.length, g.thickness, g.radius);
        let closed = 12.0 * l / (e * b * t.powi(3)) + 12.0 * li21_f(r / t) / (e * b * r * r);
        assert!(
            (c[2][2] / closed - 1.0).abs() < 1e-9,
            "{} vs {closed}",
            c[2][2]
        );
        let series = 1.0 / c[2][2];
        assert!((series - 4.4996).abs() < 1e-4, "{series}");
        let parallel = super::super::mechanism::hinge_stiffness(&g).total;
        assert!((parallel - 35.1830).abs() < 1e-4, "{parallel}");
        // The fillets stiffen every entry: less compliance than the bare beam
        // stretched over the whole profile.
        let bare = hinge_compliance(&HingeGeometry {
            length: g.profile_length(),
            radius: 0.0,
            ..g
        });
        for i in 0..3 {
            assert!(c[i][i] < bare[i][i]);
        }
    }

    /// Hinges as points (axial and rotational compliance only) make the
    /// compliance-matrix bridge the pseudo-rigid-body limb of
    /// `mechanism::BridgeLimb`, derived independently from its stored energy.
    pub fn point_hinges_give_the_pseudo_rigid_body_bridge() {
        let (ka, kr) = (1.7e8, 35.0);
        let point = [[1.0 / ka, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0 / kr]];
        for deg in [3.0, 10.0, 14.488, 30.0, 60.0] {
            let a = f64::to_radians(deg);
            let chain = BridgeChain {
                angle: a,
                link: 0.012,
                hinge: point,
                hinge_length: 0.0,
            }
            .two_port()
            .unwrap();
            let prb = BridgeLimb {
                angle: a,
                link: 0.012,
                k_axial: ka,
                k_rot: kr,
            }
            .amplification();
            assert!(
                (chain.ratio() / prb.compliant - 1.0).abs() < 1e-9,
                "{deg}: {} vs {}",
                chain.ratio(),
                prb.compliant
            );
            let k_in = chain.input_stiffness(0.0);
            assert!((k_in / prb.input_stiffness - 1.0).abs() < 1e-9);
        }
    }

    /// The same for the lever: a point pivot gives `mechanism::Lever`.
    pub fn a_point_pivot_gives_the_pseudo_rigid_body_lever() {
        let (kt, kr) = (1.7e8, 4.5);
        let point = [[1.0 / kt, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0 / kr]];
        let chain = LeverChain {
            input_arm: 0.005,
            output_arm: 0.01935,
            hinge: point,
        }
        .two_port()
        .unwrap();
        let prb = Lever {
            input_arm: 0.005,
            output_arm: 0.01935,
            k_rot: kr,
            k_trans: kt,
        }
        .amplification();
        assert!((chain.ratio() / prb.compliant - 1.0).abs() < 1e-12);
        assert!((chain.input_stiffness(0.0) / prb.input_stiffness - 1.0).abs() < 1e-12);
    }

    /// A real hinge: the two-port is symmetric positive definite, the ratio
    /// tends to `cot a` as the hinges' axial compliance vanishes, and the
    /// chain's overall ratio is the stages' product when the lever is soft.
    pub fn real_hinges_rigid_limit_and_chaining() {
        let g = HingeGeometry {
            youngs_modulus: 206e9,
            width: 0.008,
            length: 0.001,
            thickness: 3e-4,
            radius: 0.0005,
        };
        let c = hinge_compliance(&g);
        let bridge = |hinge: Mat3| BridgeChain {
            angle: 10f64.to_radians(),
            link: 0.012,
            hinge,
            hinge_length: g.profile_length(),
        };
        let port = bridge(c).two_port().unwrap();
        let [[a, b], [b2, d]] = port.stiffness;
        assert!((b / b2 - 1.0).abs() < 1e-9 && a > 0.0 && a * d > b * b);
        let mut stiff_axial = c;
        stiff_axial[0][0] *= 1e-9;
        let near_rigid = bridge(stiff_axial).two_port().unwrap().ratio();
        let cot = 1.0 / 10f64.to_radians().tan();
        assert!(
            (near_rigid / cot - 1.0).abs() < 1e-6,
            "{near_rigid} vs {cot}"
        );
        assert!(port.ratio() < near_rigid);
        let lever = LeverChain {
            input_arm: 0.005,
            output_arm: 0.01,
            hinge: c,
        }
        .two_port()
        .unwrap();
        let chain = chain_amplification(&port, &lever);
        assert!(chain.bridge_loaded < chain.bridge);
        assert!((chain.overall - chain.bridge_loaded * chain.lever).abs() < 1e-15);
        assert!(chain.input_stiffness > port.input_stiffness(0.0));
    }
}
