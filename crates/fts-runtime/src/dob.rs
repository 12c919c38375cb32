//! The disturbance-observer (DOB) feedback block with friction
//! feedforward: \[Karagoz18\]'s adaptive robust axis controller in its
//! standard discrete form (Ohnishi 1987; Umeno & Hori 1991).
//!
//! With the nominal plant `P_n(z) = z^-d B(z^-1)/A(z^-1)` (`b_0 != 0`,
//! `d >= 1`), the observer's inverse `A/B` (delay dropped) and a unity-DC-gain
//! low-pass `Q(z)`, per sample `k`:
//!
//! `A` is given in powers of the backward difference `w = 1 - z^-1`,
//! `A = sum_j a_j w^j`, and applied as `sum_j a_j (Delta^j y)(k)` with the
//! differences formed by successive subtraction: at fast sampling the
//! plant's poles lie within `1e-6` of `z = 1`, where the coefficients of
//! `A` in powers of `z^-1` cannot be rounded without moving them (its
//! low-frequency gain, a product of the `1 - p_i`, falls below their
//! rounding), while the `a_j` (products and sums of the `1 - p_i` and
//! `p_i`) keep their relative accuracy.
//!
//! * `w(k) = (A/B)[y](k) - (u - u_f)(k - d)`, the input-equivalent
//!   disturbance seen `d` samples late, less the friction feedforward `u_f`
//!   already sent against it (so that matched feedforward leaves the
//!   observer nothing to estimate);
//! * `d_hat(k) = Q[w](k)`, its low-pass estimate;
//! * `v_ref(k) = (r(k) - r(k-1))/ts` (0 at the first sample), the
//!   reference velocity;
//! * `u_f(k) = Fc v_ref/(|v_ref| + v_eps) + Fv v_ref`, the friction
//!   feedforward (Coulomb through the smooth sign `v/(|v| + v_eps)`, plus
//!   viscous);
//! * `u(k) = clamp(u_ff + K[e] - d_hat + u_f)`, `e = r - y`: the outer
//!   controller `K` a state-space block ([`crate::StateSpaceSpec`], the
//!   same step, limits and anti-windup; e.g. a PID by Tustin) with
//!   `u_ff - d_hat + u_f` as its feedforward.
//!
//! The command actually applied (e.g. with a cross-coupling command added)
//! replaces `u(k)` in the observer's memory through [`DobBlock::applied`],
//! so that only the plant's disturbance, not a known command, is estimated.

use crate::{MAX_SS_ORDER, RuntimeError, SsBlock, StateSpaceSpec, finite, ss_block, ss_step};

/// Longest polynomial of a DOB filter (`Q` or the nominal inverse).
pub const MAX_DOB_LEN: usize = 16;
/// Longest command delay `d` of the nominal plant.
pub const MAX_DOB_DELAY: usize = 16;

/// A DOB feedback block's coefficients (borrowed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DobSpec<'a> {
    /// The outer controller on `e = r - y` (limits included).
    pub outer: StateSpaceSpec<'a>,
    /// `Q` numerator, ascending `z^-1`.
    pub q_num: &'a [f64],
    /// `Q` denominator, ascending `z^-1`, `q_den[0] != 0`.
    pub q_den: &'a [f64],
    /// The nominal inverse's numerator `A`, ascending powers of `1 - z^-1`.
    pub inverse_num: &'a [f64],
    /// The nominal inverse's denominator `B`, `inverse_den[0] != 0`.
    pub inverse_den: &'a [f64],
    /// The nominal plant's command delay `d`, 1 to [`MAX_DOB_DELAY`].
    pub delay: usize,
    /// Coulomb friction feedforward `Fc`, command units.
    pub coulomb: f64,
    /// Viscous friction feedforward `Fv`, command per reference unit/s.
    pub viscous: f64,
    /// Smoothing velocity `v_eps` of the sign, reference units/s, `> 0`.
    pub smoothing: f64,
    /// Sample time, s (for the reference velocity).
    pub ts: f64,
}

/// A filter `num/den` in transposed direct form II, fixed capacity.
#[derive(Debug, Clone)]
pub(crate) struct SmallFilter {
    order: usize,
    b: [f64; MAX_DOB_LEN],
    a: [f64; MAX_DOB_LEN],
    state: [f64; MAX_DOB_LEN],
}

impl SmallFilter {
    fn new(
        num_field: &'static str,
        den_field: &'static str,
        num: &[f64],
        den: &[f64],
    ) -> Result<Self, RuntimeError> {
        for (field, p) in [(num_field, num), (den_field, den)] {
            if p.is_empty() || p.len() > MAX_DOB_LEN {
                return Err(RuntimeError::BadLength {
                    field,
                    len: p.len(),
                    max: MAX_DOB_LEN,
                });
            }
            if p.iter().any(|v| !v.is_finite()) {
                return Err(RuntimeError::NonFinite { field });
            }
        }
        if den[0] == 0.0 {
            return Err(RuntimeError::Invalid { field: den_field });
        }
        // Normalised by a0 as lti::TdfFilter does.
        let a0 = den[0];
        let mut f = Self {
            order: num.len().max(den.len()) - 1,
            b: [0.0; MAX_DOB_LEN],
            a: [0.0; MAX_DOB_LEN],
            state: [0.0; MAX_DOB_LEN],
        };
        for (i, v) in num.iter().enumerate() {
            f.b[i] = v / a0;
        }
        for (i, v) in den.iter().enumerate() {
            f.a[i] = v / a0;
        }
        Ok(f)
    }

    /// One sample, the ZPETC block's arithmetic (`crate::tdf2`).
    #[inline]
    fn step(&mut self, x: f64) -> f64 {
        crate::tdf2(self.order, &self.b, &self.a, &mut self.state, x)
    }
}

/// The DOB block with its state.
#[derive(Debug, Clone)]
pub(crate) struct DobBlock {
    outer: SsBlock,
    q: SmallFilter,
    /// `a_j` of `A = sum_j a_j w^j`.
    difference: [f64; MAX_DOB_LEN],
    difference_len: usize,
    /// `(Delta^j y)(k-1)`, `j = 0 .. difference_len - 2`.
    differences: [f64; MAX_DOB_LEN],
    /// `1/B`.
    inverse: SmallFilter,
    delay: usize,
    /// The last `delay` commands less their friction feedforward,
    /// `commands[head]` the oldest.
    commands: [f64; MAX_DOB_DELAY],
    head: usize,
    /// The last step's friction feedforward.
    last_friction: f64,
    coulomb: f64,
    viscous: f64,
    smoothing: f64,
    rate: f64,
    previous_reference: f64,
    started: bool,
}

impl DobBlock {
    /// Checks and loads the block, at rest.
    pub(crate) fn new(s: &DobSpec<'_>) -> Result<Self, RuntimeError> {
        let outer = ss_block(&s.outer)?;
        let q = SmallFilter::new("dob.q_num", "dob.q_den", s.q_num, s.q_den)?;
        let mut difference = [0.0; MAX_DOB_LEN];
        let difference_len = s.inverse_num.len();
        if difference_len == 0 || difference_len > MAX_DOB_LEN {
            return Err(RuntimeError::BadLength {
                field: "dob.inverse_num",
                len: difference_len,
                max: MAX_DOB_LEN,
            });
        }
        if s.inverse_num.iter().any(|v| !v.is_finite()) {
            return Err(RuntimeError::NonFinite {
                field: "dob.inverse_num",
            });
        }
        difference[..difference_len].copy_from_slice(s.inverse_num);
        let inverse =
            SmallFilter::new("dob.inverse_den", "dob.inverse_den", &[1.0], s.inverse_den)?;
        if s.delay == 0 || s.delay > MAX_DOB_DELAY {
            return Err(RuntimeError::Invalid { field: "dob.delay" });
        }
        finite("dob.coulomb", s.coulomb)?;
        finite("dob.viscous", s.viscous)?;
        finite("dob.smoothing", s.smoothing)?;
        if s.smoothing <= 0.0 {
            return Err(RuntimeError::Invalid {
                field: "dob.smoothing",
            });
        }
        finite("dob.ts", s.ts)?;
        if s.ts <= 0.0 {
            return Err(RuntimeError::Invalid { field: "dob.ts" });
        }
        Ok(Self {
            outer,
            q,
            difference,
            difference_len,
            differences: [0.0; MAX_DOB_LEN],
            inverse,
            delay: s.delay,
            commands: [0.0; MAX_DOB_DELAY],
            head: 0,
            last_friction: 0.0,
            coulomb: s.coulomb,
            viscous: s.viscous,
            smoothing: s.smoothing,
            rate: 1.0 / s.ts,
            previous_reference: 0.0,
            started: false,
        })
    }

    /// Back to rest.
    pub(crate) fn reset(&mut self) {
        self.outer.x = [0.0; MAX_SS_ORDER];
        self.q.state = [0.0; MAX_DOB_LEN];
        self.inverse.state = [0.0; MAX_DOB_LEN];
        self.differences = [0.0; MAX_DOB_LEN];
        self.commands = [0.0; MAX_DOB_DELAY];
        self.head = 0;
        self.last_friction = 0.0;
        self.previous_reference = 0.0;
        self.started = false;
    }

    /// The command limits.
    pub(crate) fn limits(&self) -> (f64, f64) {
        (self.outer.output_min, self.outer.output_max)
    }

    /// The friction feedforward at reference velocity `v`.
    #[inline]
    fn friction(&self, v: f64) -> f64 {
        let abs = if v < 0.0 { -v } else { v };
        self.coulomb * (v / (abs + self.smoothing)) + self.viscous * v
    }

    /// `A[y](k) = sum_j a_j (Delta^j y)(k)`, `Delta^j y(k) = Delta^(j-1) y(k) - Delta^(j-1) y(k-1)`.
    #[inline]
    fn difference_step(&mut self, y: f64) -> f64 {
        let mut d = y;
        let mut acc = self.difference[0] * y;
        for j in 1..self.difference_len {
            let next = d - self.differences[j - 1];
            self.differences[j - 1] = d;
            d = next;
            acc += self.difference[j] * d;
        }
        acc
    }

    /// One command (module docs).
    #[inline]
    pub(crate) fn step(&mut self, reference: f64, measurement: f64, feedforward: f64) -> f64 {
        let previous = if self.started {
            self.previous_reference
        } else {
            reference
        };
        self.previous_reference = reference;
        self.started = true;
        let velocity = (reference - previous) * self.rate;
        let oldest = self.commands[self.head];
        let a_y = self.difference_step(measurement);
        let w = self.inverse.step(a_y) - oldest;
        let estimate = self.q.step(w);
        let friction = self.friction(velocity);
        let ff = feedforward - estimate + friction;
        let command = ss_step(&mut self.outer, reference - measurement, ff);
        self.last_friction = friction;
        self.commands[self.head] = command - friction;
        self.head = (self.head + 1) % self.delay;
        command
    }

    /// Replaces the last command in the observer's memory by the one
    /// actually applied.
    #[inline]
    pub(crate) fn applied(&mut self, command: f64) {
        let last = (self.head + self.delay - 1) % self.delay;
        self.commands[last] = command - self.last_friction;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FeedbackSpec, RuntimeController, RuntimeSpec, SsAntiWindup};

    const NO_GAIN: StateSpaceSpec<'static> = StateSpaceSpec {
        a: &[],
        b: &[],
        c: &[],
        d: 0.0,
        output_min: f64::NEG_INFINITY,
        output_max: f64::INFINITY,
        anti_windup: SsAntiWindup::None,
    };

    fn spec(delay: usize, smoothing: f64, q_den: &[f64]) -> DobSpec<'_> {
        DobSpec {
            outer: NO_GAIN,
            q_num: &[0.5],
            q_den,
            inverse_num: &[0.05, 0.95],
            inverse_den: &[0.2],
            delay,
            coulomb: 0.0,
            viscous: 0.0,
            smoothing,
            ts: 1e-3,
        }
    }

    fn load(s: DobSpec<'_>) -> Result<RuntimeController, RuntimeError> {
        RuntimeController::new(&RuntimeSpec {
            zpetc: None,
            hysteresis: None,
            feedback: FeedbackSpec::Dob(s),
            repetitive: None,
        })
    }

    #[test]
    fn bad_specs_are_refused_naming_the_field() {
        let q = [1.0, -0.5];
        assert!(load(spec(1, 1.0, &q)).is_ok());
        let field = |s| match load(s) {
            Err(RuntimeError::Invalid { field }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(spec(0, 1.0, &q)), "dob.delay");
        assert_eq!(field(spec(MAX_DOB_DELAY + 1, 1.0, &q)), "dob.delay");
        assert_eq!(field(spec(1, 0.0, &q)), "dob.smoothing");
        assert_eq!(field(spec(1, 1.0, &[0.0, 1.0])), "dob.q_den");
    }

    /// With a delay of 2 the observer compares `(A/B) y` with the command
    /// of two samples before, and the one it is told was applied.
    #[test]
    fn the_observer_uses_the_command_applied_delay_samples_late() {
        // Q = 1 (q_num = q_den = [1]): d_hat = (A/B) y - u(k - 2).
        let mut s = spec(2, 1.0, &[1.0]);
        s.q_num = &[1.0];
        s.inverse_num = &[1.0];
        s.inverse_den = &[1.0];
        let mut c = load(s).unwrap();
        // u = -d_hat = u(k - 2) - y.
        assert_eq!(c.step(0.0, 1.0), -1.0);
        assert_eq!(c.step(0.0, 2.0), -2.0);
        c.feedback.applied(5.0); // the plant got 5, not -2
        assert_eq!(c.step(0.0, 0.0), -1.0); // u(k-2) = -1
        assert_eq!(c.step(0.0, 0.0), 5.0); // u(k-2) = 5
    }
}
