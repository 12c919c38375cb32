//! Sample-by-sample filtering of `z^-d B(z^-1)/A(z^-1)` in transposed direct
//! form II, with the pure delay as a ring buffer. All memory is allocated at
//! construction; [`TdfFilter::step`] never allocates.

use super::tf::DiscreteTf;

/// A running filter with explicit state.
#[derive(Debug, Clone)]
pub struct TdfFilter {
    /// `b / a0`, padded to `order + 1`.
    b: Vec<f64>,
    /// `a / a0`, padded to `order + 1` (`a[0] = 1`).
    a: Vec<f64>,
    /// TDF-II state, length `order`.
    state: Vec<f64>,
    /// Delayed inputs `x(k-d) .. x(k-1)` as a ring.
    delay_line: Vec<f64>,
    delay_pos: usize,
}

impl TdfFilter {
    /// A filter of `g` with zero initial state.
    pub fn new(g: &DiscreteTf) -> Self {
        Self::from_coeffs(g.num().coeffs(), g.den().coeffs(), g.delay())
    }

    /// A filter of `z^-delay num/den` (ascending powers of `z^-1`, `den[0] != 0`).
    pub fn from_coeffs(num: &[f64], den: &[f64], delay: usize) -> Self {
        let a0 = den[0];
        let order = num.len().max(den.len()) - 1;
        let mut b = vec![0.0; order + 1];
        let mut a = vec![0.0; order + 1];
        for (dst, &src) in b.iter_mut().zip(num) {
            *dst = src / a0;
        }
        for (dst, &src) in a.iter_mut().zip(den) {
            *dst = src / a0;
        }
        Self {
            b,
            a,
            state: vec![0.0; order],
            delay_line: vec![0.0; delay],
            delay_pos: 0,
        }
    }

    /// Zeroes the state.
    pub fn reset(&mut self) {
        self.state.iter_mut().for_each(|s| *s = 0.0);
        self.delay_line.iter_mut().for_each(|s| *s = 0.0);
        self.delay_pos = 0;
    }

    /// One sample in, one sample out.
    #[inline]
    pub fn step(&mut self, input: f64) -> f64 {
        let x = if self.delay_line.is_empty() {
            input
        } else {
            let delayed = self.delay_line[self.delay_pos];
            self.delay_line[self.delay_pos] = input;
            self.delay_pos += 1;
            if self.delay_pos == self.delay_line.len() {
                self.delay_pos = 0;
            }
            delayed
        };
        let n = self.state.len();
        if n == 0 {
            return self.b[0] * x;
        }
        let y = self.b[0] * x + self.state[0];
        for i in 0..n - 1 {
            self.state[i] = self.b[i + 1] * x + self.state[i + 1] - self.a[i + 1] * y;
        }
        self.state[n - 1] = self.b[n] * x - self.a[n] * y;
        y
    }

    /// Filters a whole signal into `output` (same length).
    pub fn run(&mut self, input: &[f64], output: &mut [f64]) {
        for (x, y) in input.iter().zip(output.iter_mut()) {
            *y = self.step(*x);
        }
    }
}

/// Filters `input` through `g` from rest.
pub fn lsim(g: &DiscreteTf, input: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; input.len()];
    TdfFilter::new(g).run(input, &mut out);
    out
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn runtime_zpetc_block_matches_tdf_filter_bit_for_bit() {
        let num = [0.24, -0.19, 0.17, -0.15, 0.012, 0.008];
        let den = [1.0, -2.3, 2.46, -1.33, 0.28];
        let spec = crate::runtime::RuntimeSpec {
            zpetc: Some(crate::runtime::ZpetcSpec {
                preview: 5,
                num: &num,
                den: &den,
            }),
            hysteresis: None,
            feedback: crate::runtime::FeedbackSpec::Pid(crate::runtime::PidSpec {
                kp: 1.0,
                ki: 0.0,
                kd: 0.0,
                output_min: -1e9,
                output_max: 1e9,
            }),
            repetitive: None,
        };
        let mut rt = crate::runtime::RuntimeController::new(&spec).unwrap();
        let mut filter = TdfFilter::from_coeffs(&num, &den, 0);
        for k in 0..1000 {
            let r = (k as f64 * 0.01).sin();
            // With kp = 1 and x = 0 the command is r_f itself.
            let (rf, _, u) = rt.step_traced(r, 0.0);
            let expect = filter.step(r);
            assert_eq!(rf.to_bits(), expect.to_bits());
            assert_eq!(u.to_bits(), expect.to_bits());
        }
    }

    pub fn impulse_response_matches_difference_equation() {
        // y(k) = 0.5 y(k-1) + 2 u(k-2) + u(k-3)  <=>  z^-2 (2 + z^-1)/(1 - 0.5 z^-1)
        let g = DiscreteTf::new(vec![2.0, 1.0], vec![1.0, -0.5], 2, 1.0).unwrap();
        let mut u = vec![0.0; 8];
        u[0] = 1.0;
        let y = lsim(&g, &u);
        let mut expect = [0.0; 8];
        for k in 0..8 {
            let prev = if k > 0 { expect[k - 1] } else { 0.0 };
            let u2 = if k >= 2 { u[k - 2] } else { 0.0 };
            let u3 = if k >= 3 { u[k - 3] } else { 0.0 };
            expect[k] = 0.5 * prev + 2.0 * u2 + u3;
        }
        assert_eq!(y, expect);
    }

    pub fn step_response_settles_to_dc_gain() {
        let g = DiscreteTf::new(
            vec![4.154, -9.631, 10.23, -5.511, 1.154],
            vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
            5,
            1e-4,
        )
        .unwrap();
        let y = lsim(&g, &vec![1.0; 400]);
        assert!((y[399] - g.dc_gain()).abs() < 1e-12);
        assert!(y[..5].iter().all(|&v| v == 0.0));
    }
}
