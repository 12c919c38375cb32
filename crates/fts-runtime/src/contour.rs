//! The cross-coupled multi-axis step (\[Karagoz18\], docs/contouring.md):
//! three axis feedback controllers and, optionally, one copy per axis of a
//! cross-coupling controller acting on that axis's component of the
//! contour-error estimate. Each is the single-axis step's feedback stage
//! (the \[Li21\] PID, the filtered-derivative PID or a discrete state-space
//! block, with its limits and anti-windup): fixed capacity, no allocation,
//! the same arithmetic; `fts_multiaxis_step` in `fts_runtime.c` is its C
//! twin, operation for operation.
//!
//! Per sample, with `r` the reference point, `t` the unit tangent of the
//! path at `r` and `y` the measured positions:
//! `e = r - y`, `eps = e - (e . t) t` (Yeh & Hsu's estimate),
//! `u_i = K_i[r_i, y_i] + K_cc[0, -eps_i]`, each controller clamped to its
//! own limits. The axis controllers see the reference and the measurement
//! (a PID differentiates the measurement, as in the single-axis loop); a
//! coupling controller sees the reference 0 and the measurement `-eps_i`,
//! so that its error is `eps_i` and a PID's derivative acts on `eps_i`.
//! A disturbance-observer axis block is told the sum `u_i` it drove the
//! plant with, so that its observer does not take the coupling command for
//! a disturbance.

use crate::{Feedback, FeedbackSpec, RuntimeError};

/// Three axis controllers and the optional cross-coupling controllers.
#[derive(Debug, Clone)]
pub struct CrossCoupledStep {
    axes: [Feedback; 3],
    cross: Option<[Feedback; 3]>,
}

/// The contour-error estimate `e - (e . t) t` (`t` a unit vector).
#[inline]
pub fn contour_estimate(e: &[f64; 3], t: &[f64; 3]) -> [f64; 3] {
    let along = e[0] * t[0] + e[1] * t[1] + e[2] * t[2];
    [
        e[0] - along * t[0],
        e[1] - along * t[1],
        e[2] - along * t[2],
    ]
}

/// An axis needs a feedback controller.
fn controller(spec: &FeedbackSpec<'_>, field: &'static str) -> Result<Feedback, RuntimeError> {
    match spec {
        FeedbackSpec::None => Err(RuntimeError::Invalid { field }),
        spec => Feedback::new(spec),
    }
}

impl CrossCoupledStep {
    /// Loads the axis controllers (x, y, z) and, when given, one copy of the
    /// cross-coupling controller per axis; all start at rest. Refuses
    /// `FeedbackSpec::None` (field `axes.feedback` or `cross_coupling`).
    pub fn new(
        axes: [&FeedbackSpec<'_>; 3],
        cross: Option<&FeedbackSpec<'_>>,
    ) -> Result<Self, RuntimeError> {
        let field = "axes.feedback";
        let axes = [
            controller(axes[0], field)?,
            controller(axes[1], field)?,
            controller(axes[2], field)?,
        ];
        let cross = match cross {
            None => None,
            Some(spec) => {
                let c = controller(spec, "cross_coupling")?;
                Some([c.clone(), c.clone(), c])
            }
        };
        Ok(Self { axes, cross })
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        let blocks = self.axes.iter_mut().chain(self.cross.iter_mut().flatten());
        blocks.for_each(Feedback::reset);
    }

    /// Whether the coupling controllers are present.
    pub fn is_coupled(&self) -> bool {
        self.cross.is_some()
    }

    /// One sample: the commands of the three axes.
    #[inline]
    pub fn step(
        &mut self,
        reference: &[f64; 3],
        tangent: &[f64; 3],
        measurement: &[f64; 3],
    ) -> [f64; 3] {
        let e = [
            reference[0] - measurement[0],
            reference[1] - measurement[1],
            reference[2] - measurement[2],
        ];
        let eps = contour_estimate(&e, tangent);
        let mut u = [0.0; 3];
        for (i, k) in self.axes.iter_mut().enumerate() {
            u[i] = k.step(reference[i], measurement[i], 0.0).unwrap_or(0.0);
        }
        if let Some(cross) = &mut self.cross {
            for (i, k) in cross.iter_mut().enumerate() {
                u[i] += k.step(0.0, -eps[i], 0.0).unwrap_or(0.0);
            }
            for (k, u) in self.axes.iter_mut().zip(u) {
                k.applied(u);
            }
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{PidFilteredSpec, SsAntiWindup, StateSpaceSpec};

    /// A static gain `u = k e`: a state-space controller without states.
    fn gain(k: f64) -> FeedbackSpec<'static> {
        FeedbackSpec::StateSpace(ss_gain(k))
    }

    fn ss_gain(k: f64) -> StateSpaceSpec<'static> {
        StateSpaceSpec {
            a: &[],
            b: &[],
            c: &[],
            d: k,
            output_min: f64::NEG_INFINITY,
            output_max: f64::INFINITY,
            anti_windup: SsAntiWindup::None,
        }
    }

    #[test]
    fn commands_add_the_coupling_along_the_normal() {
        let (gx, gy, gz, gc) = (gain(1.0), gain(2.0), gain(3.0), gain(10.0));
        let mut step = CrossCoupledStep::new([&gx, &gy, &gz], Some(&gc)).unwrap();
        // e = (1, 2, 3); tangent along x: eps = (0, 2, 3).
        let u = step.step(&[1.0, 2.0, 3.0], &[1.0, 0.0, 0.0], &[0.0; 3]);
        assert_eq!(u, [1.0, 4.0 + 20.0, 9.0 + 30.0]);
        // Tangent (0, 0.6, 0.8): e.t = 3.6, eps = (1, -0.16, 0.12).
        let eps = contour_estimate(&[1.0, 2.0, 3.0], &[0.0, 0.6, 0.8]);
        assert!((eps[1] + 0.16).abs() < 1e-15 && (eps[2] - 0.12).abs() < 1e-15);
        let u = step.step(&[1.0, 2.0, 3.0], &[0.0, 0.6, 0.8], &[0.0; 3]);
        assert_eq!(
            u,
            [
                1.0 + 10.0 * eps[0],
                4.0 + 10.0 * eps[1],
                9.0 + 10.0 * eps[2]
            ]
        );
        let mut alone = CrossCoupledStep::new([&gx, &gy, &gz], None).unwrap();
        let u = alone.step(&[1.0, 2.0, 3.0], &[1.0, 0.0, 0.0], &[0.5; 3]);
        assert_eq!(u, [0.5, 3.0, 7.5]);
    }

    #[test]
    fn an_integrating_coupling_holds_state_until_reset() {
        // K_cc: x <- x + e, u = x (a summing integrator), one per axis.
        let integ = FeedbackSpec::StateSpace(StateSpaceSpec {
            a: &[1.0],
            b: &[1.0],
            c: &[1.0],
            ..ss_gain(0.0)
        });
        let zero = gain(0.0);
        let mut step = CrossCoupledStep::new([&zero, &zero, &zero], Some(&integ)).unwrap();
        let t = [1.0, 0.0, 0.0];
        for k in 0..3 {
            let u = step.step(&[0.0, 1.0, -2.0], &t, &[0.0; 3]);
            assert_eq!(u, [0.0, k as f64, -2.0 * k as f64]);
        }
        step.reset();
        assert_eq!(step.step(&[0.0, 1.0, -2.0], &t, &[0.0; 3]), [0.0; 3]);
    }

    #[test]
    fn a_coupling_pid_differentiates_the_estimate_and_none_is_refused() {
        // K_cc = kp e + I + kd (eps(k) - eps(k-1)) through its pole: with
        // the measurement -eps the derivative acts on eps, not on -eps.
        let pid = FeedbackSpec::PidFiltered(PidFilteredSpec {
            kp: 0.0,
            ki: 0.0,
            kd: 1.0,
            derivative_pole: 0.5,
            output_min: -1e9,
            output_max: 1e9,
        });
        let zero = gain(0.0);
        let mut step = CrossCoupledStep::new([&zero, &zero, &zero], Some(&pid)).unwrap();
        let t = [1.0, 0.0, 0.0];
        // eps_y: 0 (no kick on the first sample), then 2, then 2.
        assert_eq!(step.step(&[0.0; 3], &t, &[0.0; 3]), [0.0; 3]);
        assert_eq!(step.step(&[0.0, 2.0, 0.0], &t, &[0.0; 3])[1], 2.0);
        assert_eq!(step.step(&[0.0, 2.0, 0.0], &t, &[0.0; 3])[1], 1.0);
        let none = FeedbackSpec::None;
        let e = CrossCoupledStep::new([&zero, &none, &zero], None).unwrap_err();
        assert_eq!(
            e,
            RuntimeError::Invalid {
                field: "axes.feedback"
            }
        );
        let e = CrossCoupledStep::new([&zero; 3], Some(&none)).unwrap_err();
        assert_eq!(
            e,
            RuntimeError::Invalid {
                field: "cross_coupling"
            }
        );
    }
}
