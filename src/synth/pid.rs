//! PID controllers.
//!
//! * [`Li21Pid`]: the positional form of \[Li21\] Eq. 5 with derivative on the
//!   measurement, `u(k) = u_ff(k) + Kp e(k) + Ki sum_{i<=k} e(i) - Kd (x(k) - x(k-1))`,
//!   output limits and anti-windup by conditional integration (the integral
//!   is frozen while the output is saturated and the error pushes further
//!   into saturation), so that a long saturation does not store charge.
//! * [`ParallelPid`]: `C(s) = P + I/s + D N s/(s + N)` (\[Karagoz18\] Table 2),
//!   discretised by Tustin or backward Euler into a `DiscreteTf`.

use crate::lti::DiscreteTf;

/// Gains of the \[Li21\] discrete PID (per sample: `Ki` multiplies the plain
/// sum of errors, `Kd` the plain difference of measurements).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain, command units per reference unit.
    pub kp: f64,
    /// Integral gain per sample.
    pub ki: f64,
    /// Derivative gain per sample (on the measurement).
    pub kd: f64,
}

/// Output range of the controller, e.g. the amplifier's 0-10 V.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputLimits {
    /// Lowest command.
    pub min: f64,
    /// Highest command.
    pub max: f64,
}

/// Why gains or limits are unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct PidError(pub String);

impl PidGains {
    /// All gains finite.
    pub fn validate(&self) -> Result<(), PidError> {
        if [self.kp, self.ki, self.kd].iter().all(|g| g.is_finite()) {
            Ok(())
        } else {
            Err(PidError("PID gains must be finite numbers".into()))
        }
    }
}

impl OutputLimits {
    /// `min < max`, both finite.
    pub fn validate(&self) -> Result<(), PidError> {
        if self.min.is_finite() && self.max.is_finite() && self.min < self.max {
            Ok(())
        } else {
            Err(PidError(format!(
                "output limits must be finite with min < max, got [{}, {}]",
                self.min, self.max
            )))
        }
    }
}

/// The \[Li21\] Eq. 5 PID with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct Li21Pid {
    gains: PidGains,
    limits: OutputLimits,
    integral: f64,
    previous_measurement: Option<f64>,
}

impl Li21Pid {
    /// A controller at rest.
    pub fn new(gains: PidGains, limits: OutputLimits) -> Result<Self, PidError> {
        gains.validate()?;
        limits.validate()?;
        Ok(Self {
            gains,
            limits,
            integral: 0.0,
            previous_measurement: None,
        })
    }

    /// The gains.
    pub fn gains(&self) -> PidGains {
        self.gains
    }

    /// The limits.
    pub fn limits(&self) -> OutputLimits {
        self.limits
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.previous_measurement = None;
    }

    /// One command from the reference, the measurement and a feedforward.
    /// The arithmetic is the runtime step's ([`crate::runtime::pid_step`]),
    /// so the two cannot differ by a rounding.
    #[inline]
    pub fn step(&mut self, reference: f64, measurement: f64, feedforward: f64) -> f64 {
        crate::runtime::pid_step(
            &self.spec(),
            &mut self.integral,
            &mut self.previous_measurement,
            reference,
            measurement,
            feedforward,
        )
    }

    /// The runtime block coefficients of this controller.
    pub fn spec(&self) -> crate::runtime::PidSpec {
        crate::runtime::PidSpec {
            kp: self.gains.kp,
            ki: self.gains.ki,
            kd: self.gains.kd,
            output_min: self.limits.min,
            output_max: self.limits.max,
        }
    }
}

/// How to map `s` to `z`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Discretization {
    /// `s = (2/Ts)(1 - z^-1)/(1 + z^-1)`.
    Tustin,
    /// `s = (1 - z^-1)/Ts`.
    BackwardEuler,
}

/// `C(s) = P + I/s + D N s/(s + N)` (\[Karagoz18\] Table 2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParallelPid {
    /// Proportional gain.
    pub p: f64,
    /// Integral gain (1/s).
    pub i: f64,
    /// Derivative gain (s).
    pub d: f64,
    /// Derivative filter pole, rad/s.
    pub n: f64,
}

impl ParallelPid {
    /// The discrete controller `C(z)` on a common denominator
    /// `(1 - z^-1)(a0 + a1 z^-1)`.
    pub fn discretize(&self, ts: f64, method: Discretization) -> Result<DiscreteTf, PidError> {
        if ![self.p, self.i, self.d, self.n]
            .iter()
            .all(|v| v.is_finite())
            || self.n <= 0.0
        {
            return Err(PidError("P, I, D must be finite and N positive".into()));
        }
        if !(ts.is_finite() && ts > 0.0) {
            return Err(PidError("sample time must be positive".into()));
        }
        // Each term as (num, den) in ascending z^-1 over den_f = (f0 + f1 z^-1).
        let (int_num, f0, f1, der_num): ([f64; 2], f64, f64, [f64; 2]) = match method {
            Discretization::Tustin => {
                let k = 2.0 / ts;
                // I/s = I ts/2 (1 + z^-1)/(1 - z^-1)
                // D N s/(s + N) = D N k (1 - z^-1) / ((k + N) + (N - k) z^-1)
                (
                    [self.i * ts / 2.0, self.i * ts / 2.0],
                    k + self.n,
                    self.n - k,
                    [self.d * self.n * k, -self.d * self.n * k],
                )
            }
            Discretization::BackwardEuler => {
                let k = 1.0 / ts;
                // I/s = I ts / (1 - z^-1)
                // D N s/(s + N) = D N k (1 - z^-1) / ((k + N) - k z^-1)
                (
                    [self.i * ts, 0.0],
                    k + self.n,
                    -k,
                    [self.d * self.n * k, -self.d * self.n * k],
                )
            }
        };
        // Common denominator (1 - z^-1)(f0 + f1 z^-1).
        let den = [f0, f1 - f0, -f1];
        // P * den + int_num * (f0 + f1 z^-1) + der_num * (1 - z^-1).
        let mut num = [self.p * den[0], self.p * den[1], self.p * den[2]];
        num[0] += int_num[0] * f0;
        num[1] += int_num[0] * f1 + int_num[1] * f0;
        num[2] += int_num[1] * f1;
        num[0] += der_num[0];
        num[1] += der_num[1] - der_num[0];
        num[2] += -der_num[1];
        DiscreteTf::new(num.to_vec(), den.to_vec(), 0, ts).map_err(|e| PidError(e.to_string()))
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::c64;

    pub fn li21_pid_difference_equation() {
        let mut pid = Li21Pid::new(
            PidGains {
                kp: 2.0,
                ki: 0.5,
                kd: 1.0,
            },
            OutputLimits {
                min: -100.0,
                max: 100.0,
            },
        )
        .unwrap();
        // k = 0: e = 1, integral 0.5, no derivative: u = 2 + 0.5 = 2.5
        assert_eq!(pid.step(1.0, 0.0, 0.0), 2.5);
        // k = 1: x = 0.25, e = 0.75, integral 0.875, derivative 0.25:
        // u = 1.5 + 0.875 - 0.25 + ff 0.1 = 2.225
        assert!((pid.step(1.0, 0.25, 0.1) - 2.225).abs() < 1e-15);
    }

    pub fn anti_windup_freezes_integral() {
        let limits = OutputLimits {
            min: 0.0,
            max: 10.0,
        };
        let mut pid = Li21Pid::new(
            PidGains {
                kp: 0.0,
                ki: 1.0,
                kd: 0.0,
            },
            limits,
        )
        .unwrap();
        for _ in 0..100 {
            assert_eq!(pid.step(100.0, 0.0, 0.0), 10.0);
        }
        // The integral stopped at 10 while saturated: one negative error
        // brings the command below the limit at once.
        assert!(pid.step(0.0, 1.0, 0.0) < 10.0);
    }

    pub fn parallel_pid_matches_continuous_at_low_frequency() {
        let c = ParallelPid {
            p: 1.0,
            i: 0.01,
            d: 0.0005,
            n: 100.0,
        };
        for method in [Discretization::Tustin, Discretization::BackwardEuler] {
            let k = c.discretize(1e-4, method).unwrap();
            for f in [1.0, 10.0, 50.0] {
                let s = c64::new(0.0, 2.0 * std::f64::consts::PI * f);
                let cont = c.p + c.i / s + c.d * c.n * s / (s + c.n);
                let disc = k.response_at_hz(f);
                assert!(
                    (cont - disc).norm() < 1e-3 * cont.norm(),
                    "{method:?} {f}: {cont} vs {disc}"
                );
            }
        }
    }
}
