//! The cross-coupled multi-axis step (\[Karagoz18\], docs/contouring.md):
//! three state-space axis controllers and, optionally, one copy per axis of
//! a cross-coupling controller acting on that axis's component of the
//! contour-error estimate. Fixed capacity, no allocation, the state-space
//! arithmetic of the single-axis step.
//!
//! Per sample, with `r` the reference point, `t` the unit tangent of the
//! path at `r` and `y` the measured positions:
//! `e = r - y`, `eps = e - (e . t) t`, `u_i = clamp(K_i[e_i]) + clamp(K_cc[eps_i])`
//! (each controller clamped to its own limits, infinite for none).

use crate::{RuntimeError, SsBlock, StateSpaceSpec, ss_block, ss_step};

/// Three axis controllers and the optional cross-coupling controllers.
#[derive(Debug, Clone)]
pub struct CrossCoupledStep {
    axes: [SsBlock; 3],
    cross: Option<[SsBlock; 3]>,
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

impl CrossCoupledStep {
    /// Loads the axis controllers (x, y, z) and, when given, one copy of the
    /// cross-coupling controller per axis; all start at rest.
    pub fn new(
        axes: [&StateSpaceSpec<'_>; 3],
        cross: Option<&StateSpaceSpec<'_>>,
    ) -> Result<Self, RuntimeError> {
        let axes = [ss_block(axes[0])?, ss_block(axes[1])?, ss_block(axes[2])?];
        let cross = match cross {
            None => None,
            Some(spec) => {
                let c = ss_block(spec)?;
                Some([c.clone(), c.clone(), c])
            }
        };
        Ok(Self { axes, cross })
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        let blocks = self.axes.iter_mut().chain(self.cross.iter_mut().flatten());
        blocks.for_each(|k| k.x = [0.0; crate::MAX_SS_ORDER]);
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
            u[i] = ss_step(k, e[i], 0.0);
        }
        if let Some(cross) = &mut self.cross {
            for (i, k) in cross.iter_mut().enumerate() {
                u[i] += ss_step(k, eps[i], 0.0);
            }
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SsAntiWindup;

    /// A static gain `u = k e`: a state-space controller without states.
    fn gain(k: f64) -> StateSpaceSpec<'static> {
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
        let integ = StateSpaceSpec {
            a: &[1.0],
            b: &[1.0],
            c: &[1.0],
            ..gain(0.0)
        };
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
}
