//! Continuous-time transfer-function identification (what MATLAB `tfest`
//! does), docs/identify-ct.md:
//!
//! * [`srivc`]: from sampled input/output records by the simplified refined
//!   instrumental variable method for continuous-time models (Young &
//!   Jakeman 1980; Garnier, Mensler & Richard 2003), started from a
//!   state-variable-filter least-squares estimate;
//! * [`freq_fit`]: from frequency-response data by Levy's linearised fit,
//!   Sanathanan–Koerner iterations and a Levenberg–Marquardt refinement of
//!   the nonlinear least-squares cost on the complex response, with an
//!   optional log-frequency weighting;
//! * fit percentages in both domains ([`time_fit_percent`], simulated at the
//!   record's samples with a zero-order-hold input, and
//!   [`freq_fit_percent`], MATLAB `compare` for frequency-response data).
//!
//! Models are `G(s) = e^(-s tau) B(s)/A(s)`, `A` monic, coefficients in
//! descending powers of `s`, `tau` in seconds. Internally time is scaled by a
//! frequency `w_s` (`p = s / w_s`) so that the coefficients are of order one.

mod freqfit;
mod srivc;
pub(crate) mod zoh;

pub use freqfit::{FreqFitEstimate, FreqFitParams, FreqWeighting, freq_fit};
pub use srivc::{SrivcEstimate, SrivcParams, SvfTrial, srivc};

use crate::ident::periodic::{PeriodicParams, periodic_response};
use crate::lti::{ContinuousTf, c64};

/// Why a continuous-time model cannot be identified.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CtError {
    /// Bad settings (the field is named).
    #[error("{field}: {message}")]
    Setting {
        /// The setting.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// Bad data.
    #[error("{0}")]
    Data(String),
    /// A numerical breakdown (singular regression, no convergence).
    #[error("{0}")]
    Numerical(String),
}

/// `e^(-s delay) num(s)/den(s)`, `den` monic, descending powers of `s`.
#[derive(Debug, Clone, PartialEq)]
pub struct CtModel {
    /// Numerator, descending powers of `s` (`nz + 1` coefficients).
    pub num: Vec<f64>,
    /// Denominator, monic, descending powers of `s` (`np + 1` coefficients).
    pub den: Vec<f64>,
    /// Input delay, s.
    pub delay: f64,
}

impl CtModel {
    /// The rational part as a [`ContinuousTf`] (the delay is separate).
    pub fn tf(&self) -> Result<ContinuousTf, crate::lti::TfError> {
        ContinuousTf::new(self.num.clone(), self.den.clone())
    }

    /// Frequency response at `f` Hz, delay included.
    pub fn response_at_hz(&self, f: f64) -> c64 {
        let s = c64::new(0.0, 2.0 * std::f64::consts::PI * f);
        eval(&self.num, s) / eval(&self.den, s) * (-s * self.delay).exp()
    }

    /// Output at the samples of `u` (sample time `ts`), the input held
    /// between samples (ZOH) and the model at rest at `t = 0`.
    pub fn simulate(&self, u: &[f64], ts: f64) -> Vec<f64> {
        // Scale time by 1/ts so the discretisation works on h = 1.
        let scaled = self.scaled(1.0 / ts);
        zoh::simulate(&scaled.num, &scaled.den, 1.0, self.delay / ts, u)
    }

    /// Response at `f` Hz of the model sampled every `ts` with a ZOH input
    /// (its exact discrete equivalent, delay included): what the frequency
    /// response of sampled records measures.
    pub fn zoh_response_at_hz(&self, f: f64, ts: f64) -> c64 {
        let scaled = self.scaled(1.0 / ts);
        zoh::response(
            &scaled.num,
            &scaled.den,
            1.0,
            self.delay / ts,
            2.0 * std::f64::consts::PI * f * ts,
        )
    }

    /// Roots of the denominator.
    pub fn poles(&self) -> Vec<c64> {
        crate::lti::roots_descending(&self.den).unwrap_or_default()
    }

    /// Whether every pole is in the open left half plane.
    pub fn is_stable(&self) -> bool {
        let poles = self.poles();
        poles.len() + 1 == self.den.len() && poles.iter().all(|p| p.re < 0.0)
    }

    /// The same model in the scaled variable `p = s / w` (delay in scaled
    /// time `w tau`): `a_i -> a_i / w^i`, `b_j -> b_j w^(m - j - n)`.
    pub(crate) fn scaled(&self, w: f64) -> CtModel {
        let (n, m) = (self.den.len() - 1, self.num.len() - 1);
        CtModel {
            den: scale_coeffs(&self.den, w, 0),
            num: scale_coeffs(&self.num, w, n as i32 - m as i32),
            delay: self.delay * w,
        }
    }

    /// The inverse of [`CtModel::scaled`].
    pub(crate) fn unscaled(&self, w: f64) -> CtModel {
        self.scaled(1.0 / w)
    }
}

/// `c_i / w^(i + extra)`.
fn scale_coeffs(c: &[f64], w: f64, extra: i32) -> Vec<f64> {
    c.iter()
        .enumerate()
        .map(|(i, v)| v / w.powi(i as i32 + extra))
        .collect()
}

/// `||a - b|| / ||b||`.
pub(crate) fn rel_change(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let s: f64 = b.iter().map(|x| x * x).sum();
    (d / s.max(f64::MIN_POSITIVE)).sqrt()
}

/// Horner evaluation, descending powers.
pub(crate) fn eval(c: &[f64], s: c64) -> c64 {
    c.iter().fold(c64::new(0.0, 0.0), |acc, &x| acc * s + x)
}

/// Reflects roots in the closed right half plane into the left (and nudges
/// roots on the axis to `-1e-6 |r|`), keeping the monic polynomial real.
pub(crate) fn stabilised(den: &[f64]) -> Vec<f64> {
    let Ok(roots) = crate::lti::roots_descending(den) else {
        return den.to_vec();
    };
    if roots.iter().all(|r| r.re < 0.0) {
        return den.to_vec();
    }
    let mirrored: Vec<c64> = roots
        .iter()
        .map(|r| {
            let re = -r.re.abs();
            c64::new(
                if re == 0.0 {
                    -1e-6 * r.norm().max(1e-6)
                } else {
                    re
                },
                r.im,
            )
        })
        .collect();
    crate::lti::ss::poly_from_roots(&mirrored)
}

/// Time-domain fit, percent: NRMSE (MATLAB `compare`) of the model's
/// simulated output against `y`.
pub fn time_fit_percent(model: &CtModel, u: &[f64], y: &[f64], ts: f64) -> f64 {
    crate::ident::metrics::nrmse_fit_percent(y, &model.simulate(u, ts))
}

/// Frequency-domain fit, percent, as MATLAB `compare` for frequency-response
/// data: `100 (1 - ||G - G_hat|| / ||G - mean(G)||)` over the complex values.
pub fn freq_fit_percent(model: &CtModel, freq_hz: &[f64], response: &[c64]) -> f64 {
    let n = response.len() as f64;
    let mean = response.iter().sum::<c64>() / n;
    let err: f64 = freq_hz
        .iter()
        .zip(response)
        .map(|(f, g)| (g - model.response_at_hz(*f)).norm_sqr())
        .sum();
    let dev: f64 = response.iter().map(|g| (g - mean).norm_sqr()).sum();
    100.0 * (1.0 - (err / dev).sqrt())
}

/// A frequency response on its own grid (the lines a periodic input excites).
#[derive(Debug, Clone, PartialEq)]
pub struct FreqData {
    /// Frequencies, Hz, increasing, positive.
    pub freq_hz: Vec<f64>,
    /// Complex response at each.
    pub response: Vec<c64>,
}

/// The frequency response of a periodic record at the lines its input
/// excites: [`crate::ident::periodic::periodic_response`] (averaged over
/// whole periods of `period` samples after skipping the first `skip` as
/// transient), without the unexcited bins.
pub fn periodic_frf(
    u: &[f64],
    y: &[f64],
    ts: f64,
    period: usize,
    skip: usize,
) -> Result<FreqData, CtError> {
    let params = PeriodicParams { period, skip };
    let h = periodic_response(u, y, ts, &params).map_err(|e| CtError::Data(e.to_string()))?;
    let (freq_hz, response) = h
        .freq_hz
        .iter()
        .zip(&h.response)
        .filter(|(_, g)| g.re.is_finite())
        .map(|(f, g)| (*f, *g))
        .unzip();
    Ok(FreqData { freq_hz, response })
}

/// Checks orders: `1 <= np`, `nz <= np`.
pub(crate) fn check_orders(np: usize, nz: usize) -> Result<(), CtError> {
    if np == 0 {
        return Err(CtError::Setting {
            field: "np",
            message: format!("at least one pole, got {np}"),
        });
    }
    if nz > np {
        return Err(CtError::Setting {
            field: "nz",
            message: format!("{nz} zeros for {np} poles: the model must be proper (nz <= np)"),
        });
    }
    Ok(())
}

/// Checks a delay in seconds.
pub(crate) fn check_delay(delay: f64) -> Result<(), CtError> {
    if delay.is_finite() && delay >= 0.0 {
        Ok(())
    } else {
        Err(CtError::Setting {
            field: "delay",
            message: format!("expected a delay of zero or more seconds, got {delay}"),
        })
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks;
