//! The plug-in repetitive compensator (Tomizuka, Tsao & Chew 1989; Inoue
//! 1981), allocation-free with a fixed-capacity memory.
//!
//! With the tracking error `e(k) = r(k) - x(k)` it adds to the loop's
//! reference (ahead of the inverse hysteresis and the feedback controller)
//!
//! `v(k) = Q(z) [ v(k - N) + k_r e(k - N + m) ]`                  (1)
//!
//! i.e. `v = R e` with `R(z) = k_r Q(z) z^(m - N) / (1 - Q(z) z^-N)`: the
//! internal model `1/(1 - z^-N)` of every signal of period `N` samples,
//! robustified by the zero-phase low-pass `Q(z) = q_0 + sum_i q_i (z^i + z^-i)`,
//! with learning gain `k_r` and phase lead `z^m` against the loop's lag.
//! A period that is not a whole number of samples, `N = N0 + f`, reads the
//! memory through the linear-interpolation fractional delay
//! `z^-N ~ (1 - f) z^-N0 + f z^-(N0 + 1)`.
//!
//! Equation (1) is computed through the memory signal
//! `d(j) = v(j) + k_r e(j + m)`, completed at sample `j + m` when `e(j + m)`
//! is measured, so that `v(k) = sum_{i=-h}^{h} q_|i| D(k - i - N0)` with
//! `D(j) = (1 - f) d(j) + f d(j - 1)`: one ring of `d` holds everything
//! older than `m` samples, and a short ring of `v` the last `m` outputs.
//! Both the non-causal `Q` and the lead are realisable because `N0 > h + m`.

use crate::RuntimeError;

/// Capacity of the repetitive memory, samples: a period of up to
/// `MAX_PERIOD - h - 2` samples (`h` the half-length of `Q`), so more than
/// a 1 s period at 16 kHz.
pub const MAX_PERIOD: usize = 16_384;
/// Most one-sided taps of the zero-phase filter `Q` (`q_1 .. q_h`).
pub const MAX_Q_HALF: usize = 32;
/// Most samples of phase lead `m`.
pub const MAX_LEAD: usize = 255;
/// Most samples of ZPETC preview the repetitive block can delay the
/// reference by to form its error `r(k) - x(k)`.
pub const MAX_RC_PREVIEW: usize = 1023;

const LEAD_RING: usize = MAX_LEAD + 1;
const REFERENCE_RING: usize = MAX_RC_PREVIEW + 1;

/// A repetitive block's coefficients (borrowed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepetitiveSpec<'a> {
    /// Whole samples of the period, `N0`.
    pub period: usize,
    /// Fractional part of the period, `f` in `[0, 1)`.
    pub fraction: f64,
    /// Zero-phase filter taps `[q_0, q_1, .., q_h]`: `Q(z) = q_0 + sum q_i (z^i + z^-i)`.
    pub q: &'a [f64],
    /// Phase lead `m`, samples.
    pub lead: usize,
    /// Learning gain `k_r`.
    pub gain: f64,
}

/// The repetitive block with its memory.
#[derive(Debug, Clone)]
pub(crate) struct RepetitiveBlock {
    period: usize,
    fraction: f64,
    half: usize,
    q: [f64; MAX_Q_HALF + 1],
    lead: usize,
    gain: f64,
    /// `d(j)` at `j mod MAX_PERIOD`.
    memory: [f64; MAX_PERIOD],
    /// `v(j)` at `j mod LEAD_RING`.
    outputs: [f64; LEAD_RING],
    /// `r(j + preview)` as passed, at `j mod REFERENCE_RING`.
    references: [f64; REFERENCE_RING],
    /// Samples stepped, modulo `MAX_PERIOD` (every ring's length divides it).
    k: usize,
    /// Whether a sample has been stepped since the last reset.
    started: bool,
}

// Every ring length is a power of two no longer than the memory, so one
// counter modulo `MAX_PERIOD` indexes them all.
const _: () = assert!(
    MAX_PERIOD.is_power_of_two()
        && LEAD_RING.is_power_of_two()
        && REFERENCE_RING.is_power_of_two()
        && LEAD_RING <= MAX_PERIOD
        && REFERENCE_RING <= MAX_PERIOD
);

impl RepetitiveBlock {
    /// Checks the specification against the capacities; `preview` is the
    /// ZPETC's look-ahead, undone to form the error.
    pub(crate) fn new(spec: &RepetitiveSpec<'_>, preview: usize) -> Result<Self, RuntimeError> {
        let mut q = [0.0; MAX_Q_HALF + 1];
        let taps = crate::copy_into("repetitive.q", spec.q, &mut q)?;
        let half = taps - 1;
        crate::finite("repetitive.gain", spec.gain)?;
        crate::finite("repetitive.fraction", spec.fraction)?;
        if !(0.0..1.0).contains(&spec.fraction) {
            return Err(RuntimeError::Invalid {
                field: "repetitive.fraction",
            });
        }
        if spec.lead > MAX_LEAD {
            return Err(RuntimeError::BadLength {
                field: "repetitive.lead",
                len: spec.lead,
                max: MAX_LEAD,
            });
        }
        // Q and the lead reach `half + lead` samples ahead inside the
        // period; one more keeps v(k) from depending on itself.
        if spec.period <= half + spec.lead {
            return Err(RuntimeError::Invalid {
                field: "repetitive.period",
            });
        }
        if spec.period + half + 2 > MAX_PERIOD {
            return Err(RuntimeError::BadLength {
                field: "repetitive.period",
                len: spec.period,
                max: MAX_PERIOD - half - 2,
            });
        }
        if preview > MAX_RC_PREVIEW {
            return Err(RuntimeError::BadLength {
                field: "repetitive.preview",
                len: preview,
                max: MAX_RC_PREVIEW,
            });
        }
        Ok(Self {
            period: spec.period,
            fraction: spec.fraction,
            half,
            q,
            lead: spec.lead,
            gain: spec.gain,
            memory: [0.0; MAX_PERIOD],
            outputs: [0.0; LEAD_RING],
            references: [0.0; REFERENCE_RING],
            k: 0,
            started: false,
        })
    }

    /// Back to rest: memory, outputs and reference delay cleared.
    pub(crate) fn reset(&mut self) {
        self.memory = [0.0; MAX_PERIOD];
        self.outputs = [0.0; LEAD_RING];
        self.references = [0.0; REFERENCE_RING];
        self.k = 0;
        self.started = false;
    }

    /// The reference `r(k)` from `r(k + preview)`: a delay line, filled
    /// with the first value passed so a loop that starts mid-stroke does
    /// not learn a step that was never asked for.
    #[inline]
    pub(crate) fn delayed_reference(&mut self, reference_ahead: f64, preview: usize) -> f64 {
        if !self.started {
            self.references = [reference_ahead; REFERENCE_RING];
            self.started = true;
        }
        let now = self.k % REFERENCE_RING;
        self.references[now] = reference_ahead;
        self.references[(now + REFERENCE_RING - preview) % REFERENCE_RING]
    }

    /// `D(j) = (1 - f) d(j) + f d(j - 1)` with `j = k + offset - MAX_PERIOD`.
    #[inline(always)]
    fn delayed(&self, index: usize) -> f64 {
        let d = self.memory[index % MAX_PERIOD];
        if self.fraction == 0.0 {
            d
        } else {
            let older = self.memory[(index + MAX_PERIOD - 1) % MAX_PERIOD];
            (1.0 - self.fraction) * d + self.fraction * older
        }
    }

    /// One sample: returns `v(k)`, Eq. (1), then completes `d(k - m)` with
    /// the error `e(k)`. The sum runs over `i = -h .. h` in that order and
    /// reads `d` no later than `k - m - 1` (the period exceeds `h + m`).
    #[inline]
    pub(crate) fn step(&mut self, error: f64) -> f64 {
        let k = self.k;
        let h = self.half;
        let mut acc = 0.0;
        for i in 0..=2 * h {
            let tap = h.abs_diff(i);
            // k - (i - h) - N0, shifted by a whole memory to stay unsigned.
            let index = k + MAX_PERIOD + h - i - self.period;
            acc += self.q[tap] * self.delayed(index);
        }
        self.outputs[k % LEAD_RING] = acc;
        // d(k - m) = v(k - m) + k_r e(k); v(j) for j < 0 is 0 (the rings start at rest).
        let m = self.lead;
        let v_lead = self.outputs[(k + LEAD_RING - m) % LEAD_RING];
        self.memory[(k + MAX_PERIOD - m) % MAX_PERIOD] = v_lead + self.gain * error;
        self.k = (k + 1) % MAX_PERIOD;
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// Eq. (1) on whole arrays, written independently of the rings:
    /// `s(j) = v(j) + k_r e(j + m)`, `v(k) = sum_i q_|i| ((1-f) s(k-i-N0) + f s(k-i-N0-1))`,
    /// every signal 0 before sample 0.
    fn reference_outputs(spec: &RepetitiveSpec<'_>, e: &[f64]) -> Vec<f64> {
        let h = spec.q.len() as isize - 1;
        let n0 = spec.period as isize;
        let m = spec.lead as isize;
        let mut v = vec![0.0; e.len()];
        let at = |x: &[f64], j: isize| if j < 0 { 0.0 } else { x[j as usize] };
        for k in 0..e.len() as isize {
            let s = |v: &[f64], j: isize| at(v, j) + spec.gain * at(e, j + m);
            let mut acc = 0.0;
            for i in -h..=h {
                let j = k - i - n0;
                let q = spec.q[i.unsigned_abs()];
                let d = if spec.fraction == 0.0 {
                    s(&v, j)
                } else {
                    (1.0 - spec.fraction) * s(&v, j) + spec.fraction * s(&v, j - 1)
                };
                acc += q * d;
            }
            v[k as usize] = acc;
        }
        v
    }

    fn run(spec: &RepetitiveSpec<'_>, e: &[f64]) -> Vec<f64> {
        let mut block = RepetitiveBlock::new(spec, 0).unwrap();
        e.iter().map(|&x| block.step(x)).collect()
    }

    #[test]
    fn matches_the_equation_bit_for_bit_across_the_ring_wrap() {
        let q = [0.5, 0.2, 0.05];
        let e: Vec<f64> = (0..3 * MAX_PERIOD)
            .map(|k| (k as f64 * 0.013).sin() + 0.3 * (k as f64 * 0.29).cos())
            .collect();
        for (period, fraction, lead) in
            [(100, 0.0, 3), (100, 0.37, 5), (7, 0.0, 2), (2000, 0.5, 40)]
        {
            let spec = RepetitiveSpec {
                period,
                fraction,
                q: &q,
                lead,
                gain: 0.45,
            };
            let a = run(&spec, &e);
            let b = reference_outputs(&spec, &e);
            for (k, (x, y)) in a.iter().zip(&b).enumerate() {
                assert_eq!(
                    x.to_bits(),
                    y.to_bits(),
                    "period {period} f {fraction} k {k}"
                );
            }
        }
    }

    /// With `Q = 1`, `m = 0`, `k_r = 1` and a constant error the block is
    /// the pure internal model `v(k) = v(k - N) + e(k - N)`: it climbs one
    /// step per period, `v(k) = floor(k / N)`.
    #[test]
    fn the_internal_model_integrates_once_per_period() {
        let spec = RepetitiveSpec {
            period: 10,
            fraction: 0.0,
            q: &[1.0],
            lead: 0,
            gain: 1.0,
        };
        let v = run(&spec, &[1.0; 95]);
        for (k, x) in v.iter().enumerate() {
            assert_eq!(*x, (k / 10) as f64, "k {k}");
        }
    }

    #[test]
    fn refuses_what_does_not_fit() {
        let spec = |period, q: &'static [f64], lead, fraction| RepetitiveSpec {
            period,
            fraction,
            q,
            lead,
            gain: 0.5,
        };
        let err = |s: RepetitiveSpec<'_>| RepetitiveBlock::new(&s, 0).unwrap_err();
        assert_eq!(
            err(spec(4, &[0.5, 0.25], 3, 0.0)),
            RuntimeError::Invalid {
                field: "repetitive.period"
            }
        );
        assert!(matches!(
            err(spec(MAX_PERIOD, &[1.0], 0, 0.0)),
            RuntimeError::BadLength {
                field: "repetitive.period",
                ..
            }
        ));
        assert_eq!(
            err(spec(100, &[1.0], 0, 1.0)),
            RuntimeError::Invalid {
                field: "repetitive.fraction"
            }
        );
        assert!(matches!(
            err(spec(1000, &[1.0], MAX_LEAD + 1, 0.0)),
            RuntimeError::BadLength {
                field: "repetitive.lead",
                ..
            }
        ));
        let ok = spec(MAX_PERIOD - 2, &[1.0], 0, 0.0);
        assert!(RepetitiveBlock::new(&ok, 0).is_ok());
        assert!(RepetitiveBlock::new(&ok, MAX_RC_PREVIEW + 1).is_err());
    }
}
