//! The learning law's convergence condition with the model's error
//! measured, not assumed away.
//!
//! Eq. (2) of the parent module evaluates `|Q| |1 - a L G|` with `L` the
//! inversion of the model `G` itself, so `L G = 1` up to the inversion's
//! residual and the condition holds whatever the true loop is. Against the
//! true loop `G_0 = G (1 + D)` the error contracts when
//!
//! `rho_0 = max_w |Q| (|1 - a L G| + a |L G| delta(w)) < 1`,   `|D| <= delta`   (3)
//!
//! (Bristow et al. 2006, Sec. IV-C, the robust monotone-convergence
//! condition). `delta` is measured here: the empirical frequency response
//! of a record of the loop (Welch `H1`, [`crate::ident::freq::welch`]) against
//! the model's, with a two-sigma allowance for the estimate's own variance
//! (Bendat & Piersol, random error of `|H1|`: `sqrt(1 - g^2) / (|g| sqrt(2 n))`
//! for `n` segments and coherence `g^2`). Where the record says nothing (the
//! coherence is below [`MIN_COHERENCE`], or beyond its band) `delta` is
//! *assumed* to be [`ASSUMED_ELSEWHERE`]: a model whose magnitude is right
//! within a factor of two and whose phase is unknown; `Q` must then be
//! small there. The check is a prediction; the trials' measured errors are
//! the verdict.

use super::super::repetitive::q_response;
use super::IlcDesign;
use crate::ident::freq::{self, FreqResponse, WelchParams};
use crate::lti::{DiscreteTf, c64};
use serde::Serialize;
use std::f64::consts::PI;

/// Coherence below which a frequency of the record is not used.
pub const MIN_COHERENCE: f64 = 0.9;

/// Relative model error assumed where the record does not measure it.
pub const ASSUMED_ELSEWHERE: f64 = 1.0;

/// The model's relative error `|G_0 / G - 1|` as a record of the loop shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelError {
    /// `(Hz, delta)` at the record's coherent frequencies, the two-sigma
    /// allowance included.
    pub measured: Vec<(f64, f64)>,
    /// Frequency spacing of `measured`, Hz.
    pub resolution_hz: f64,
    /// The record it was measured on, for reports.
    pub source: String,
}

impl ModelError {
    /// Measures the error of `model` on the record `(u, y)` (the loop's
    /// reference and its output, one sample per `model.ts()`).
    pub fn measure(
        model: &DiscreteTf,
        u: &[f64],
        y: &[f64],
        source: impl Into<String>,
    ) -> Result<Self, freq::FreqError> {
        // The fixed eight-segment length, not one chosen for coherence: the
        // error bound wants the averaging of many segments on a clean sweep.
        let params = WelchParams {
            segment: Some(freq::default_segment(u.len().min(y.len()))),
            ..WelchParams::default()
        };
        let response = freq::welch(u, y, model.ts(), &params)?;
        Ok(Self::compare(model, &response, source.into()))
    }

    /// The error of `model` against a measured response.
    pub fn compare(model: &DiscreteTf, measured: &FreqResponse, source: String) -> Self {
        let n = measured.segments.max(1) as f64;
        let coherence = measured.coherence.as_deref().unwrap_or(&[]);
        let points = measured
            .freq_hz
            .iter()
            .zip(&measured.response)
            .zip(coherence)
            .filter(|((f, h), g2)| **f > 0.0 && h.re.is_finite() && **g2 >= MIN_COHERENCE)
            .map(|((f, h), g2)| {
                let g = model.response_at_hz(*f);
                let relative = (*h / g - c64::new(1.0, 0.0)).norm();
                let sigma = (1.0 - g2).sqrt() / (g2.sqrt() * (2.0 * n).sqrt());
                (*f, relative + 2.0 * sigma * (*h / g).norm())
            })
            .collect();
        let resolution_hz = measured.freq_hz.get(1).copied().unwrap_or(0.0);
        Self {
            measured: points,
            resolution_hz,
            source,
        }
    }

    /// `delta` at `hz` and whether it was measured there (within one bin
    /// of a coherent frequency; the larger neighbour is taken).
    pub fn at(&self, hz: f64) -> (f64, bool) {
        let i = self.measured.partition_point(|(f, _)| *f < hz);
        let near = |j: usize| {
            self.measured
                .get(j)
                .filter(|(f, _)| (f - hz).abs() <= self.resolution_hz)
                .map(|(_, d)| *d)
        };
        match (i.checked_sub(1).and_then(near), near(i)) {
            (None, None) => (ASSUMED_ELSEWHERE, false),
            (a, b) => (a.unwrap_or(0.0).max(b.unwrap_or(0.0)), true),
        }
    }

    /// The largest measured error below `hz`, and where.
    pub fn worst_below(&self, hz: f64) -> Option<(f64, f64)> {
        self.measured.iter().filter(|(f, _)| *f <= hz).fold(
            None,
            |w: Option<(f64, f64)>, &(f, d)| match w {
                Some((_, wd)) if wd >= d => w,
                _ => Some((f, d)),
            },
        )
    }
}

/// Eq. (3) evaluated with the measured model error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RobustCheck {
    /// `rho_0`, Eq. (3).
    pub rho: f64,
    /// Where it peaks, Hz.
    pub at_hz: f64,
    /// The model error used there.
    pub delta_at_peak: f64,
    /// Whether that error was measured (else assumed).
    pub measured_at_peak: bool,
    /// Highest frequency with a measured error, Hz (0 if none).
    pub measured_to_hz: f64,
}

impl RobustCheck {
    /// Whether Eq. (3) predicts monotone convergence.
    pub fn converges(&self) -> bool {
        self.rho < 1.0
    }

    /// The failed check in words, with what it measured and what it
    /// assumed (`error` is the model error it was evaluated with).
    pub fn failure(&self, error: &ModelError) -> String {
        format!(
            "the model check fails: max |Q| (|1 - a L G| + a |L G| delta) = {:.4} >= 1 at {:.1} Hz, where the model's relative error is {:.1} % ({} on {}); the learning would diverge on the loop. Lower Q's cutoff below where the model is wrong, or the learning gain",
            self.rho,
            self.at_hz,
            100.0 * self.delta_at_peak,
            if self.measured_at_peak {
                "measured"
            } else {
                "assumed: not measured"
            },
            error.source
        )
    }
}

/// Eq. (3) for `design` (made on `model`) on `points` frequencies up to
/// Nyquist.
pub fn robust_check(design: &IlcDesign, model: &DiscreteTf, error: &ModelError) -> RobustCheck {
    let points = design.rho_curve.len().max(16);
    let ts = model.ts();
    let mut check = RobustCheck {
        rho: 0.0,
        at_hz: 0.0,
        delta_at_peak: 0.0,
        measured_at_peak: false,
        measured_to_hz: error.measured.last().map_or(0.0, |p| p.0),
    };
    for i in 1..=points {
        let w = PI * i as f64 / points as f64;
        let hz = w / (2.0 * PI * ts);
        let lg = design.learning.response_at_omega(w) * model.response_at_omega(w);
        let q = q_response(&design.q, w).abs();
        let (delta, measured) = error.at(hz);
        // Eq. (3).
        let value =
            q * ((c64::new(1.0, 0.0) - design.gain * lg).norm() + design.gain * lg.norm() * delta);
        if value > check.rho {
            check.rho = value;
            check.at_hz = hz;
            check.delta_at_peak = delta;
            check.measured_at_peak = measured;
        }
    }
    check
}
