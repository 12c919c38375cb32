//! Error budget of a closed loop driven by independent white-noise sources
//! (Ding22 Eq. 7-10, docs/math.md §5): the disturbance shaping filters sit inside
//! the system, whose inputs are unit-intensity white noises and whose chosen
//! output is the error. Per source `PSD_i(f) = 2 |T_i(j 2 pi f)|^2`
//! (one-sided, units^2/Hz), total = sum over the uncorrelated sources,
//! cumulative amplitude spectrum `CAS(f) = sqrt(int_0^f PSD)`, and
//! `RMS = CAS(f_max)`. For a stable strictly proper loop and a grid wide
//! enough, `RMS^2 -> ||T||_2^2` (Parseval), which the tests check.

use crate::lti::norms::{NormError, h2_norm};
use crate::lti::ss::{StateSpace, sub};

/// The budget on a frequency grid.
#[derive(Debug, Clone)]
pub struct ErrorBudget {
    /// Frequencies in Hz (ascending).
    pub freq_hz: Vec<f64>,
    /// One-sided PSD of each source's contribution (`psd[source][k]`).
    pub psd: Vec<Vec<f64>>,
    /// Sum over sources.
    pub total_psd: Vec<f64>,
    /// Cumulative amplitude spectrum of the total.
    pub cas: Vec<f64>,
    /// RMS contribution of each source over the grid.
    pub rms_per_source: Vec<f64>,
    /// Total RMS (`CAS` at the last frequency).
    pub rms: f64,
}

/// Trapezoidal cumulative integral.
fn cumulative(f: &[f64], y: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(f.len());
    let mut acc = 0.0;
    for k in 0..f.len() {
        if k > 0 {
            acc += 0.5 * (y[k] + y[k - 1]) * (f[k] - f[k - 1]);
        }
        out.push(acc);
    }
    out
}

/// Budget of output `output` of `cl` over `freq_hz` (ascending, starting at or near 0).
pub fn error_budget(cl: &StateSpace, output: usize, freq_hz: &[f64]) -> Option<ErrorBudget> {
    if output >= cl.ny()
        || freq_hz.len() < 2
        || freq_hz.windows(2).any(|w| w[1] <= w[0] || w[1].is_nan())
    {
        return None;
    }
    let ns = cl.nu();
    let mut psd = vec![Vec::with_capacity(freq_hz.len()); ns];
    for &f in freq_hz {
        let g = cl.freq_response(2.0 * std::f64::consts::PI * f).ok()?;
        for (i, p) in psd.iter_mut().enumerate() {
            p.push(2.0 * g[(output, i)].norm_sqr());
        }
    }
    let total_psd: Vec<f64> = (0..freq_hz.len())
        .map(|k| psd.iter().map(|p| p[k]).sum())
        .collect();
    let cas: Vec<f64> = cumulative(freq_hz, &total_psd)
        .into_iter()
        .map(f64::sqrt)
        .collect();
    let rms_per_source = psd
        .iter()
        .map(|p| cumulative(freq_hz, p).last().copied().unwrap_or(0.0).sqrt())
        .collect();
    let rms = *cas.last()?;
    Some(ErrorBudget {
        freq_hz: freq_hz.to_vec(),
        psd,
        total_psd,
        cas,
        rms_per_source,
        rms,
    })
}

impl ErrorBudget {
    /// Cumulative amplitude spectrum of each source alone (`cas[source][k]`).
    pub fn cas_per_source(&self) -> Vec<Vec<f64>> {
        self.psd
            .iter()
            .map(|p| {
                cumulative(&self.freq_hz, p)
                    .into_iter()
                    .map(f64::sqrt)
                    .collect()
            })
            .collect()
    }
}

/// Exact per-source RMS of output `output` over all frequencies: the H2 norm
/// of each column `T_i` (Gramians, no grid). With the one-sided PSD
/// `2 |T_i|^2` of [`error_budget`], `RMS_i^2 = int_0^inf PSD_i df = ||T_i||_2^2`,
/// and for uncorrelated sources `sum_i RMS_i^2 = ||T||_2^2`.
pub fn exact_rms_per_source(cl: &StateSpace, output: usize) -> Result<Vec<f64>, NormError> {
    let n = cl.nx();
    (0..cl.nu())
        .map(|i| {
            let col = StateSpace::new(
                cl.a.clone(),
                sub(&cl.b, 0, n, i, i + 1),
                sub(&cl.c, output, output + 1, 0, n),
                sub(&cl.d, output, output + 1, i, i + 1),
                cl.ts,
            )?;
            h2_norm(&col)
        })
        .collect()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::norms::h2_norm;
    use crate::lti::ss::hcat;

    pub fn rms_matches_the_h2_norm() {
        // Two sources: 1/(s+1) and 10/(s^2 + s + 100); RMS^2 = sum of H2^2.
        let g1 = StateSpace::from_tf(&[1.0], &[1.0, 1.0], None).unwrap();
        let g2 = StateSpace::from_tf(&[10.0], &[1.0, 1.0, 100.0], None).unwrap();
        let both = g1.append(&g2).unwrap();
        // Sum the two outputs: y = y1 + y2 (inputs stay separate).
        let sum = StateSpace::new(
            both.a.clone(),
            both.b.clone(),
            hcat(&g1.c, &g2.c),
            hcat(&g1.d, &g2.d),
            None,
        )
        .unwrap();
        let f: Vec<f64> = (0..200_001).map(|k| k as f64 * 0.01).collect();
        let b = error_budget(&sum, 0, &f).unwrap();
        let h1 = h2_norm(&g1).unwrap();
        let h2 = h2_norm(&g2).unwrap();
        // 2e-3: the grid stops at 2 kHz, where 1/(s+1)'s tail still holds ~1e-4 of its power.
        assert!(
            (b.rms_per_source[0] / h1 - 1.0).abs() < 2e-3,
            "{} {h1}",
            b.rms_per_source[0]
        );
        assert!((b.rms_per_source[1] / h2 - 1.0).abs() < 2e-3);
        assert!((b.rms / (h1 * h1 + h2 * h2).sqrt() - 1.0).abs() < 2e-3);
        assert!(b.cas.windows(2).all(|w| w[1] >= w[0]));
    }
}
