//! Real FFTs of one length, planned once (rustfft's planner for `f64`).

use crate::c64;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::sync::Arc;

/// The forward real FFT of one length: `n` samples to `n / 2 + 1` bins,
/// unnormalised (`X_k = sum_t x_t e^{-2 pi i k t / n}`).
#[derive(Clone)]
pub struct RealFft {
    plan: Arc<dyn RealToComplex<f64>>,
}

impl RealFft {
    /// Plans the transform of `n` samples.
    pub fn new(n: usize) -> Self {
        RealFft {
            plan: RealFftPlanner::<f64>::new().plan_fft_forward(n),
        }
    }

    /// Samples per transform.
    pub fn len(&self) -> usize {
        self.plan.len()
    }

    /// Whether the transform is of no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bins per transform, `n / 2 + 1`.
    pub fn bins(&self) -> usize {
        self.len() / 2 + 1
    }

    /// Transforms `input` (length `n`, used as scratch) into `output`
    /// (length `n / 2 + 1`).
    ///
    /// # Panics
    /// When a buffer has the wrong length (a caller's bug).
    pub fn process(&self, input: &mut [f64], output: &mut [c64]) {
        self.plan
            .process(input, output)
            .expect("buffer lengths of the planned transform");
    }
}

/// The inverse real FFT of one length: `n / 2 + 1` bins to `n` samples,
/// unnormalised (the forward transform then this one multiplies by `n`).
#[derive(Clone)]
pub struct RealIfft {
    plan: Arc<dyn ComplexToReal<f64>>,
}

impl RealIfft {
    /// Plans the transform to `n` samples.
    pub fn new(n: usize) -> Self {
        RealIfft {
            plan: RealFftPlanner::<f64>::new().plan_fft_inverse(n),
        }
    }

    /// Transforms `input` (length `n / 2 + 1`, used as scratch; the
    /// imaginary parts of its first bin, and of its last for even `n`, must
    /// be zero) into `output` (length `n`).
    ///
    /// # Panics
    /// When a buffer has the wrong length or those imaginary parts are
    /// not zero (a caller's bug).
    pub fn process(&self, input: &mut [c64], output: &mut [f64]) {
        self.plan
            .process(input, output)
            .expect("buffer lengths and real end bins of the planned transform");
    }
}
