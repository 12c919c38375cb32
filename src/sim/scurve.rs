//! Jerk-limited rest-to-rest motion (the 7-segment "S-curve"): a distance
//! `L` covered with `|v| <= v_max`, `|a| <= a_max`, `|j| <= j_max`, starting
//! and ending at rest with zero acceleration.
//!
//! Segments (durations `Tj, Ta, Tj, Tv, Tj, Ta, Tj`, jerks `+j, 0, -j, 0,
//! -j, 0, +j`): jerk up to the peak acceleration, hold it, jerk down to the
//! peak velocity, cruise, and the mirror image to stop (Biagiotti &
//! Melchiorri, *Trajectory Planning for Automatic Machines and Robots*,
//! 2008, §3.4, rest-to-rest case). Accelerating from rest to `v` takes
//! `2 Tj + Ta` and covers `v (2 Tj + Ta) / 2` (the profile is symmetric, so
//! the mean velocity is `v/2`):
//!
//! * `v j >= a^2`: the acceleration limit is reached, `Tj = a/j`,
//!   `Ta = v/a - a/j`, distance `v (v/a + a/j) / 2`;
//! * otherwise: `Tj = sqrt(v/j)`, `Ta = 0`, peak acceleration `sqrt(v j)`,
//!   distance `v sqrt(v/j)`.
//!
//! When twice that distance exceeds `L`, `v_max` cannot be reached: the peak
//! velocity is lowered to the one whose acceleration and deceleration cover
//! exactly `L` (the cruise vanishes) and the plan says so
//! ([`SCurve::limited`]).

use serde::Serialize;

/// Limits of a rest-to-rest move (one length unit throughout, e.g. um).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SCurveParams {
    /// Distance to cover, > 0.
    pub distance: f64,
    /// Velocity limit, > 0 (length/s).
    pub max_velocity: f64,
    /// Acceleration limit, > 0 (length/s^2).
    pub max_acceleration: f64,
    /// Jerk limit, > 0 (length/s^3).
    pub max_jerk: f64,
}

/// Why the limits cannot be planned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct SCurveError {
    /// The offending parameter (`distance`, `max_velocity`, ...).
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

/// Why the requested velocity was not reached.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VelocityLimit {
    /// The velocity asked for.
    pub requested: f64,
    /// The highest velocity reachable on the distance with the acceleration
    /// and jerk limits: the plan's peak.
    pub reachable: f64,
    /// The distance accelerating to `requested` and stopping again would need.
    pub distance_needed: f64,
    /// The distance available.
    pub distance: f64,
}

impl std::fmt::Display for VelocityLimit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "velocity {} cannot be reached: accelerating to it and stopping needs {:.6} but the move is {}; the peak velocity reachable with these acceleration and jerk limits is {:.6}",
            self.requested, self.distance_needed, self.distance, self.reachable
        )
    }
}

/// A planned move: its segment durations and peak values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SCurve {
    /// The limits it was planned with.
    pub params: SCurveParams,
    /// Durations of the 7 segments, s.
    pub segments: [f64; 7],
    /// Peak velocity of the plan.
    pub peak_velocity: f64,
    /// Peak acceleration of the plan.
    pub peak_acceleration: f64,
    /// Set when `max_velocity` could not be reached on the distance.
    pub limited: Option<VelocityLimit>,
    /// Position, velocity and acceleration at the start of each segment.
    #[serde(skip)]
    starts: [[f64; 3]; 7],
}

/// Position, velocity, acceleration and jerk at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Position along the move, 0 to `distance`.
    pub position: f64,
    /// Velocity.
    pub velocity: f64,
    /// Acceleration.
    pub acceleration: f64,
    /// Jerk.
    pub jerk: f64,
}

fn check(field: &'static str, v: f64) -> Result<(), SCurveError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SCurveError {
            field,
            message: format!("expected a positive finite number, got {v}"),
        })
    }
}

/// `(Tj, Ta)` of the acceleration from rest to `v`.
fn accel_times(v: f64, a: f64, j: f64) -> (f64, f64) {
    if v * j >= a * a {
        (a / j, v / a - a / j)
    } else {
        ((v / j).sqrt(), 0.0)
    }
}

/// Distance covered accelerating from rest to `v` (mean velocity `v/2`).
fn accel_distance(v: f64, a: f64, j: f64) -> f64 {
    let (tj, ta) = accel_times(v, a, j);
    0.5 * v * (2.0 * tj + ta)
}

/// The peak velocity whose acceleration and deceleration cover exactly `l`.
fn reachable_velocity(l: f64, a: f64, j: f64) -> f64 {
    // Acceleration limit reached: v^2/a + v a/j = l.
    let v = 0.5 * a * (-a / j + (a * a / (j * j) + 4.0 * l / a).sqrt());
    if v * j >= a * a {
        v
    } else {
        // Not reached: 2 v sqrt(v/j) = l.
        (l * l * j / 4.0).cbrt()
    }
}

const JERKS: [f64; 7] = [1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0];

impl SCurve {
    /// Plans the move; a velocity limit that the distance does not allow is
    /// lowered and recorded in [`SCurve::limited`].
    pub fn plan(params: SCurveParams) -> Result<Self, SCurveError> {
        check("distance", params.distance)?;
        check("max_velocity", params.max_velocity)?;
        check("max_acceleration", params.max_acceleration)?;
        check("max_jerk", params.max_jerk)?;
        let (l, a, j) = (params.distance, params.max_acceleration, params.max_jerk);
        let needed = 2.0 * accel_distance(params.max_velocity, a, j);
        let (v, limited) = if needed <= l {
            (params.max_velocity, None)
        } else {
            let v = reachable_velocity(l, a, j);
            let limit = VelocityLimit {
                requested: params.max_velocity,
                reachable: v,
                distance_needed: needed,
                distance: l,
            };
            (v, Some(limit))
        };
        let (tj, ta) = accel_times(v, a, j);
        let mut tv = ((l - 2.0 * accel_distance(v, a, j)) / v).max(0.0);
        if limited.is_some() {
            tv = 0.0; // rounding residue: the peak was chosen to leave no cruise
        }
        let segments = [tj, ta, tj, tv, tj, ta, tj];
        let starts = integrate_starts(&segments, j);
        Ok(Self {
            params,
            segments,
            peak_velocity: v,
            peak_acceleration: j * tj,
            limited,
            starts,
        })
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        self.segments.iter().sum()
    }

    /// The motion at time `t` (s); before 0 at rest at 0, after the end at
    /// rest at `distance`.
    pub fn at(&self, t: f64) -> Motion {
        let rest = |position| Motion {
            position,
            velocity: 0.0,
            acceleration: 0.0,
            jerk: 0.0,
        };
        if t <= 0.0 {
            return rest(0.0);
        }
        let mut t0 = 0.0;
        for (k, &d) in self.segments.iter().enumerate() {
            if t < t0 + d {
                let [p, v, a] = self.starts[k];
                let jerk = JERKS[k] * self.params.max_jerk;
                let tau = t - t0;
                return Motion {
                    position: p + tau * (v + tau * (a / 2.0 + tau * jerk / 6.0)),
                    velocity: v + tau * (a + tau * jerk / 2.0),
                    acceleration: a + tau * jerk,
                    jerk,
                };
            }
            t0 += d;
        }
        rest(self.params.distance)
    }
}

/// Exact integration of the piecewise-constant jerk: `[p, v, a]` at the
/// start of every segment.
fn integrate_starts(segments: &[f64; 7], j: f64) -> [[f64; 3]; 7] {
    let mut starts = [[0.0; 3]; 7];
    let [mut p, mut v, mut a] = [0.0; 3];
    for k in 0..7 {
        starts[k] = [p, v, a];
        let (d, jk) = (segments[k], JERKS[k] * j);
        p += d * (v + d * (a / 2.0 + d * jk / 6.0));
        v += d * (a + d * jk / 2.0);
        a += d * jk;
    }
    starts
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn params(distance: f64, v: f64, a: f64, j: f64) -> SCurveParams {
        SCurveParams {
            distance,
            max_velocity: v,
            max_acceleration: a,
            max_jerk: j,
        }
    }

    /// Position and velocity at the end of every segment, from the left and
    /// from the right, and the final state.
    fn assert_continuous_and_ends_at_rest(c: &SCurve) {
        let mut t = 0.0;
        for d in c.segments {
            t += d;
            let (l, r) = (c.at(t - 1e-9), c.at(t + 1e-9));
            let tol = 1e-6 * (1.0 + c.peak_velocity);
            assert!((l.position - r.position).abs() < tol, "{t}: {l:?} {r:?}");
            assert!((l.velocity - r.velocity).abs() < tol, "{t}: {l:?} {r:?}");
            assert!(
                (l.acceleration - r.acceleration).abs() < 1e-6 * (1.0 + c.peak_acceleration),
                "{t}"
            );
        }
        let end = c.at(c.duration() - 1e-12);
        assert!((end.position - c.params.distance).abs() < 1e-9 * c.params.distance);
        assert!(end.velocity.abs() < 1e-9 * c.peak_velocity);
        assert!(end.acceleration.abs() < 1e-6 * c.peak_acceleration);
    }

    /// Sampled limits, and the peak velocity reached at mid-move.
    fn assert_limits(c: &SCurve) {
        let p = c.params;
        let n = 20_000;
        for k in 0..=n {
            let m = c.at(c.duration() * k as f64 / n as f64);
            assert!(m.velocity <= p.max_velocity * (1.0 + 1e-12) && m.velocity >= -1e-12);
            assert!(m.acceleration.abs() <= p.max_acceleration * (1.0 + 1e-12));
            assert!(m.jerk.abs() <= p.max_jerk);
            assert!(m.position >= -1e-12 && m.position <= p.distance * (1.0 + 1e-12));
        }
        let mid = c.at(c.duration() / 2.0);
        assert!((mid.velocity - c.peak_velocity).abs() < 1e-9 * c.peak_velocity);
        assert!((mid.position - p.distance / 2.0).abs() < 1e-9 * p.distance);
    }

    pub fn full_profile_has_the_closed_form_durations() {
        // L = 100, v = 10, a = 20, j = 200: Tj = a/j = 0.1, Ta = v/a - a/j = 0.4,
        // acceleration covers v (v/a + a/j)/2 = 3, cruise (100 - 6)/10 = 9.4.
        let c = SCurve::plan(params(100.0, 10.0, 20.0, 200.0)).unwrap();
        let want = [0.1, 0.4, 0.1, 9.4, 0.1, 0.4, 0.1];
        for (s, w) in c.segments.iter().zip(want) {
            assert!((s - w).abs() < 1e-12, "{:?}", c.segments);
        }
        assert!(c.limited.is_none());
        assert_eq!(c.peak_velocity, 10.0);
        assert!((c.peak_acceleration - 20.0).abs() < 1e-12);
        assert_continuous_and_ends_at_rest(&c);
        assert_limits(&c);
    }

    pub fn acceleration_limit_not_reached() {
        // v j = 10 < a^2 = 400: Tj = sqrt(v/j) = sqrt(0.1), Ta = 0, peak a = sqrt(v j).
        let c = SCurve::plan(params(100.0, 10.0, 20.0, 1.0)).unwrap();
        let tj = 10f64.sqrt();
        assert!((c.segments[0] - tj).abs() < 1e-12 && c.segments[1] == 0.0);
        assert!((c.peak_acceleration - 10f64.sqrt()).abs() < 1e-12);
        // Acceleration covers v sqrt(v/j) = 10 sqrt(10).
        let cruise = (100.0 - 2.0 * 10.0 * tj) / 10.0;
        assert!((c.segments[3] - cruise).abs() < 1e-12);
        assert_continuous_and_ends_at_rest(&c);
        assert_limits(&c);
    }

    pub fn karagoz_velocity_is_out_of_reach_on_a_5_mm_side() {
        // 30 mm/s with 1.5 mm/s^2 (and 15 mm/s^3) on 5 mm, in um: the cruise
        // vanishes; v^2/a + v a/j = L gives the reachable peak.
        let (l, a, j) = (5000.0, 1500.0, 15000.0);
        let c = SCurve::plan(params(l, 30000.0, a, j)).unwrap();
        let lim = c.limited.clone().expect("limited");
        let v = 0.5 * a * (-a / j + (a * a / (j * j) + 4.0 * l / a).sqrt());
        assert!(
            (c.peak_velocity - v).abs() < 1e-9 * v,
            "{}",
            c.peak_velocity
        );
        assert!((v - 2664.64).abs() < 0.01, "{v}"); // about 2.66 mm/s
        assert_eq!(lim.reachable, c.peak_velocity);
        // Reaching 30 mm/s needs v (v/a + a/j) = 30000 (20 + 0.1) um.
        assert!((lim.distance_needed - 30000.0 * 20.1).abs() < 1e-6);
        assert!(c.segments[3].abs() < 1e-9);
        assert!(lim.to_string().contains("cannot be reached"));
        assert_continuous_and_ends_at_rest(&c);
        assert_limits(&c);
    }

    pub fn short_move_without_the_acceleration_limit() {
        // Tiny distance: the peak acceleration stays below a_max, v = (L^2 j/4)^(1/3).
        let c = SCurve::plan(params(1.0, 100.0, 50.0, 100.0)).unwrap();
        let v = (1.0f64 * 100.0 / 4.0).cbrt();
        assert!((c.peak_velocity - v).abs() < 1e-12);
        assert!(c.peak_acceleration < 50.0);
        assert!(c.segments[1] == 0.0 && c.segments[3] < 1e-12);
        assert_continuous_and_ends_at_rest(&c);
        assert_limits(&c);
    }

    pub fn bad_limits_name_their_field() {
        let e = SCurve::plan(params(1.0, 0.0, 1.0, 1.0)).unwrap_err();
        assert_eq!(e.field, "max_velocity");
        let e = SCurve::plan(params(f64::NAN, 1.0, 1.0, 1.0)).unwrap_err();
        assert_eq!(e.field, "distance");
    }
}
