//! Weighting functions for mixed-sensitivity design (first order, SISO).
//!
//! * MATLAB-style `makeweight(dc, (w_c, mag), hf)`:
//!   `W(s) = (hf s + a dc)/(s + a)` with `|W(j w_c)| = mag`, i.e.
//!   `a = w_c sqrt((mag^2 - hf^2)/(dc^2 - mag^2))`.
//! * Performance weight `W_s = (s/M + w0)/(s + w0 A)` [Karagoz18 Eq. 7],
//!   the form of Skogestad & Postlethwaite Eq. 2.105 `W_P`.
//! * Complementary weight `W_t = (s + w0/M)/(A s + w0)` [Karagoz18 Eq. 8].

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::lti::ss::StateSpace;
use thiserror::Error;

/// Bad weight parameters.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{0}")]
pub struct WeightError(pub String);

fn pos(x: f64, name: &str) -> Result<f64, WeightError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(WeightError(format!(
            "{name} must be a positive finite number, got {x}"
        )))
    }
}

/// First-order `makeweight(dc, [wc, mag], hf)`; `mag` strictly between `dc` and `hf`.
pub fn makeweight(dc: f64, wc: f64, mag: f64, hf: f64) -> Result<StateSpace, WeightError> {
    let (dc, wc, mag, hf) = (
        pos(dc, "dcgain")?,
        pos(wc, "freq")?,
        pos(mag, "mag")?,
        pos(hf, "hfgain")?,
    );
    if !((dc < mag && mag < hf) || (dc > mag && mag > hf)) {
        return Err(WeightError(format!(
            "makeweight: the gain {mag} at the crossover must lie strictly between the DC gain {dc} and the HF gain {hf}"
        )));
    }
    let a = wc * ((mag * mag - hf * hf) / (dc * dc - mag * mag)).sqrt();
    StateSpace::from_tf(&[hf, a * dc], &[1.0, a], None).map_err(|e| WeightError(e.to_string()))
}

/// `W_s = (s/M + w0)/(s + w0 A)`.
pub fn ws(m: f64, w0: f64, a: f64) -> Result<StateSpace, WeightError> {
    let (m, w0, a) = (pos(m, "M")?, pos(w0, "w0")?, pos(a, "A")?);
    StateSpace::from_tf(&[1.0 / m, w0], &[1.0, w0 * a], None)
        .map_err(|e| WeightError(e.to_string()))
}

/// `W_t = (s + w0/M)/(A s + w0)`.
pub fn wt(m: f64, w0: f64, a: f64) -> Result<StateSpace, WeightError> {
    let (m, w0, a) = (pos(m, "M")?, pos(w0, "w0")?, pos(a, "A")?);
    StateSpace::from_tf(&[1.0, w0 / m], &[a, w0], None).map_err(|e| WeightError(e.to_string()))
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn makeweight_hits_its_three_gains() {
        let w = makeweight(100.0, 10.0, 1.0, 0.1).unwrap();
        assert!((w.dc_gain().unwrap()[(0, 0)] - 100.0).abs() < 1e-9);
        assert!((w.sigma_at(10.0) - 1.0).abs() < 1e-12);
        assert!((w.sigma_at(1e9) - 0.1).abs() < 1e-6);
        assert!(makeweight(1.0, 10.0, 2.0, 0.5).is_err());
    }

    pub fn karagoz_weights() {
        let s = ws(2.0, 160.0, 0.001).unwrap();
        assert!((s.dc_gain().unwrap()[(0, 0)] - 1000.0).abs() < 1e-9);
        let t = wt(2.0, 160.0, 0.001).unwrap();
        assert!((t.dc_gain().unwrap()[(0, 0)] - 0.5).abs() < 1e-12);
        assert!((t.d[(0, 0)] - 1000.0).abs() < 1e-9);
    }
}
