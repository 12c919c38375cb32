//! Contouring paths (\[Karagoz18\] Sec. 5): an inclined circle and a square,
//! traversed with jerk-limited S-curves along their length, and the contour
//! error of a point against them.
//!
//! Both paths lie in the plane spanned by `u1 = (1, 0, 0)` and
//! `u2 = (0, cos th, sin th)`, `th` the inclination about the x axis, and
//! start at the origin. The circle is one move along its circumference
//! (the tool never stops on it); the square is four moves, one per side,
//! each from rest to rest (a sharp corner can only be turned at rest).
//!
//! Contour error (docs/contouring.md):
//! * exact: the distance from the point to the whole path, from the
//!   geometry (circle: closed form; square: the nearest of its sides);
//! * the estimate used for control (Yeh & Hsu 2002, \[Karagoz18\]):
//!   `eps = e - (e . t) t`, `e = R - P` the tracking error and `t` the
//!   unit tangent at the reference point `R`.

use super::scurve::{SCurve, SCurveError, SCurveParams};
use serde::Serialize;
use std::f64::consts::PI;

/// A point or a direction in (x, y, z).
pub type Vec3 = [f64; 3];

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn add(a: Vec3, b: Vec3, s: f64) -> Vec3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// The shape and its size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum Shape {
    /// A circle of this diameter.
    Circle {
        /// Diameter (length unit of the path, e.g. um).
        diameter: f64,
    },
    /// A square of this side.
    Square {
        /// Side length.
        side: f64,
    },
}

/// A planar path through the origin, inclined about the x axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Path {
    /// Shape and size.
    pub shape: Shape,
    /// Inclination of the path's plane about the x axis, degrees.
    pub incline_deg: f64,
    /// In-plane unit vectors `u1`, `u2`.
    #[serde(skip)]
    axes: [Vec3; 2],
}

/// Why a path cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct PathError {
    /// The offending parameter.
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

impl Path {
    /// The path; its size must be positive and the inclination finite.
    pub fn new(shape: Shape, incline_deg: f64) -> Result<Self, PathError> {
        let (field, size) = match shape {
            Shape::Circle { diameter } => ("diameter", diameter),
            Shape::Square { side } => ("side", side),
        };
        if !(size.is_finite() && size > 0.0) {
            return Err(PathError {
                field,
                message: format!("expected a positive finite length, got {size}"),
            });
        }
        if !incline_deg.is_finite() {
            return Err(PathError {
                field: "incline",
                message: format!("expected a finite angle in degrees, got {incline_deg}"),
            });
        }
        let th = incline_deg.to_radians();
        Ok(Self {
            shape,
            incline_deg,
            axes: [[1.0, 0.0, 0.0], [0.0, th.cos(), th.sin()]],
        })
    }

    /// Lengths of the rest-to-rest moves the path is made of.
    pub fn moves(&self) -> Vec<f64> {
        match self.shape {
            Shape::Circle { diameter } => vec![PI * diameter],
            Shape::Square { side } => vec![side; 4],
        }
    }

    /// Total length.
    pub fn length(&self) -> f64 {
        self.moves().iter().sum()
    }

    /// Point and unit tangent at arc length `s` into move `m`.
    pub fn point_tangent(&self, m: usize, s: f64) -> (Vec3, Vec3) {
        let [u1, u2] = self.axes;
        match self.shape {
            Shape::Circle { diameter } => {
                // Centre at -r u1, so that the start (phi = 0) is the origin.
                let r = diameter / 2.0;
                let phi = s / r;
                let (sin, cos) = phi.sin_cos();
                let p = add(add([0.0; 3], u1, r * (cos - 1.0)), u2, r * sin);
                let t = add(add([0.0; 3], u1, -sin), u2, cos);
                (p, t)
            }
            Shape::Square { side } => {
                let corners = self.corners(side);
                let (a, b) = (corners[m % 4], corners[(m + 1) % 4]);
                let t = add(add([0.0; 3], b, 1.0), a, -1.0).map(|v| v / side);
                (add(a, t, s), t)
            }
        }
    }

    fn corners(&self, side: f64) -> [Vec3; 4] {
        let [u1, u2] = self.axes;
        let o = [0.0; 3];
        [
            o,
            add(o, u1, side),
            add(add(o, u1, side), u2, side),
            add(o, u2, side),
        ]
    }

    /// The exact contour error of `p`: its distance to the path.
    pub fn distance(&self, p: Vec3) -> f64 {
        let [u1, u2] = self.axes;
        match self.shape {
            Shape::Circle { diameter } => {
                let r = diameter / 2.0;
                let d = add(p, u1, r); // from the centre
                let (a, b) = (dot(d, u1), dot(d, u2));
                let out_of_plane = norm(add(add(d, u1, -a), u2, -b));
                ((a * a + b * b).sqrt() - r).hypot(out_of_plane)
            }
            Shape::Square { side } => {
                // One square root for the nearest side: sqrt is monotone
                // and correctly rounded, so this is the least of the four
                // distances bit for bit.
                let c = self.corners(side);
                (0..4)
                    .map(|k| segment_distance_squared(p, c[k], c[(k + 1) % 4]))
                    .fold(f64::INFINITY, f64::min)
                    .sqrt()
            }
        }
    }
}

/// Squared distance from `p` to the segment `[a, b]`.
fn segment_distance_squared(p: Vec3, a: Vec3, b: Vec3) -> f64 {
    let ab = add(b, a, -1.0);
    let ap = add(p, a, -1.0);
    let len2 = dot(ab, ab);
    let s = if len2 > 0.0 {
        (dot(ap, ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = add(ap, ab, -s);
    dot(d, d)
}

/// The contour-error estimate `eps = e - (e . t) t` (`t` a unit tangent).
pub fn contour_estimate(e: Vec3, t: Vec3) -> Vec3 {
    add(e, t, -dot(e, t))
}

/// Euclidean length of a vector.
pub fn length(v: Vec3) -> f64 {
    norm(v)
}

/// The reference at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSample {
    /// Reference point `R`.
    pub point: Vec3,
    /// Unit tangent at `R` (of the current move; at rest between moves, the
    /// next move's).
    pub tangent: Vec3,
    /// Speed along the path.
    pub speed: f64,
    /// Acceleration along the path.
    pub acceleration: f64,
}

/// A path traversed by S-curves, one per move.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trajectory {
    /// The path.
    pub path: Path,
    /// The planned moves, in order.
    pub moves: Vec<SCurve>,
}

/// Velocity, acceleration and jerk limits along the path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MotionLimits {
    /// Speed limit (length/s).
    pub velocity: f64,
    /// Acceleration limit (length/s^2).
    pub acceleration: f64,
    /// Jerk limit (length/s^3).
    pub jerk: f64,
}

impl Trajectory {
    /// Plans every move of `path` with `limits`.
    pub fn plan(path: Path, limits: MotionLimits) -> Result<Self, SCurveError> {
        let moves = path
            .moves()
            .into_iter()
            .map(|distance| {
                SCurve::plan(SCurveParams {
                    distance,
                    max_velocity: limits.velocity,
                    max_acceleration: limits.acceleration,
                    max_jerk: limits.jerk,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { path, moves })
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        self.moves.iter().map(SCurve::duration).sum()
    }

    /// The reference at time `t` (held at the end after the last move).
    pub fn at(&self, t: f64) -> PathSample {
        let mut start = 0.0;
        let last = self.moves.len() - 1;
        for (m, c) in self.moves.iter().enumerate() {
            let d = c.duration();
            if t < start + d || m == last {
                let motion = c.at(t - start);
                let (point, tangent) = self.path.point_tangent(m, motion.position);
                return PathSample {
                    point,
                    tangent,
                    speed: motion.velocity,
                    acceleration: motion.acceleration,
                };
            }
            start += d;
        }
        unreachable!("a trajectory has at least one move")
    }

    /// The moves whose requested velocity could not be reached (one line
    /// each, with the reachable peak), for reports.
    pub fn velocity_notes(&self) -> Vec<String> {
        let mut notes: Vec<String> = Vec::new();
        for (m, c) in self.moves.iter().enumerate() {
            if let Some(lim) = &c.limited {
                let text = lim.to_string();
                if !notes.iter().any(|n| n.ends_with(&text)) {
                    notes.push(format!("move {}: {text}", m + 1));
                }
            }
        }
        notes
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn circle() -> Path {
        Path::new(Shape::Circle { diameter: 5000.0 }, 45.0).unwrap()
    }

    fn square() -> Path {
        Path::new(Shape::Square { side: 5000.0 }, 45.0).unwrap()
    }

    /// A point offset from the path by `delta` along a direction normal to
    /// it is `delta` away, by the exact distance and by the estimate.
    pub fn a_known_normal_offset_is_the_known_distance() {
        let binormal = [0.0, -(PI / 4.0).sin(), (PI / 4.0).cos()];
        for path in [circle(), square()] {
            for (m, s) in [(0, 700.0), (0, 2100.0), (2, 3000.0)] {
                let m = m % path.moves().len();
                let (r, t) = path.point_tangent(m, s);
                // In-plane normal n = b x t, and the plane normal b.
                let n = [
                    binormal[1] * t[2] - binormal[2] * t[1],
                    binormal[2] * t[0] - binormal[0] * t[2],
                    binormal[0] * t[1] - binormal[1] * t[0],
                ];
                for (dir, delta) in [(n, 3.0), (n, -2.0), (binormal, 5.0), (binormal, -1.5)] {
                    let p = add(r, dir, delta);
                    let d = path.distance(p);
                    assert!(
                        (d - delta.abs()).abs() < 1e-9,
                        "{:?}: {d} vs {delta}",
                        path.shape
                    );
                    // e = R - P is normal to t: the estimate is exact.
                    let eps = contour_estimate(add(r, p, -1.0), t);
                    assert!((length(eps) - delta.abs()).abs() < 1e-9);
                }
            }
        }
    }

    pub fn a_tangential_offset_is_missed_by_the_estimate_only() {
        // On the circle, R + delta t lies sqrt(r^2 + delta^2) - r off the
        // path; the estimate sees no contour error at all.
        let path = circle();
        let (r, t) = path.point_tangent(0, 1234.0);
        let delta = 100.0;
        let p = add(r, t, delta);
        let want = (2500.0f64.powi(2) + delta * delta).sqrt() - 2500.0;
        assert!((path.distance(p) - want).abs() < 1e-9);
        assert!(length(contour_estimate(add(r, p, -1.0), t)) < 1e-12);
        // On a side of the square it is 0 both ways.
        let (r, t) = square().point_tangent(1, 2000.0);
        assert!(square().distance(add(r, t, delta)) < 1e-9);
    }

    pub fn paths_start_at_the_origin_and_close() {
        for path in [circle(), square()] {
            let n = path.moves().len();
            let (p0, _) = path.point_tangent(0, 0.0);
            let (p1, _) = path.point_tangent(n - 1, path.moves()[n - 1]);
            assert!(length(p0) < 1e-9 && length(p1) < 1e-9, "{p0:?} {p1:?}");
            // Every point lies in the inclined plane: y = z.
            let (p, t) = path.point_tangent(n - 1, 1000.0);
            assert!((p[1] - p[2]).abs() < 1e-9 && (length(t) - 1.0).abs() < 1e-12);
            assert!(path.distance(p) < 1e-9);
        }
        assert!((circle().length() - PI * 5000.0).abs() < 1e-9);
        assert_eq!(square().length(), 20000.0);
    }

    pub fn the_square_stops_at_every_corner() {
        let limits = MotionLimits {
            velocity: 30000.0,
            acceleration: 1500.0,
            jerk: 15000.0,
        };
        let traj = Trajectory::plan(square(), limits).unwrap();
        assert_eq!(traj.moves.len(), 4);
        let side = traj.moves[0].duration();
        for k in 1..=4 {
            let s = traj.at(k as f64 * side);
            assert!(s.speed.abs() < 1e-6, "{k}: {}", s.speed);
        }
        assert_eq!(traj.velocity_notes().len(), 1);
        assert!(traj.velocity_notes()[0].contains("2664.6"));
        let end = traj.at(traj.duration() + 1.0);
        assert!(length(end.point) < 1e-6);
    }
}
