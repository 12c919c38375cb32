//! Zero phase error tracking control (Tomizuka 1987; [Li21] Eq. 6-10; math.md 3).
//!
//! For a closed loop `G_c = z^-d B_c / A_c`, the zeros of `B_c` are split into
//! those a feedforward filter may cancel (`B_a`: inside radius `rho` and well
//! damped) and the `s` others (`B_u`). The filter
//!
//! `G_z = z^(d+s) A_c B_u^* / (B_a B_u(1)^2)`   ([Li21] Eq. 8)
//!
//! makes `G_z G_c = B_u(z^-1) B_u(z) / B_u(1)^2`: real and non-negative on the
//! unit circle (zero phase) with unit DC gain. The advance `z^(d+s)` is a
//! preview carried as an integer: the causal part is run on the reference
//! `d+s` samples ahead.

use crate::lti::{DiscreteTf, Poly, RootsError, TdfFilter, c64, linspace};
use std::f64::consts::PI;

/// Settings of the zero classification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZpetcParams {
    /// Zeros with `|z| >= rho` are not cancelled: a cancelling pole that close
    /// to the unit circle makes a slowly decaying, model-sensitive filter.
    /// Default `0.95`; must lie in `(0, 1]`.
    pub rho: f64,
    /// Zeros whose cancelling pole would have an equivalent damping ratio
    /// below this are not cancelled. The ratio of a z-plane point is that of
    /// `s = ln(z)/Ts`: `zeta = -ln|z| / |ln z|`. It rejects lightly damped
    /// complex pairs and zeros near `-1` (the ringing sampling zeros); e.g.
    /// `z = -0.75` has `zeta = 0.091`. Default `0.1`; must lie in `[0, 1]`.
    pub min_damping: f64,
}

impl Default for ZpetcParams {
    fn default() -> Self {
        Self {
            rho: 0.95,
            min_damping: 0.1,
        }
    }
}

/// Why a zero was (not) cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZeroStatus {
    /// Cancelled by a pole of `G_z`.
    Cancelled,
    /// `|z| >= rho` (including zeros on or outside the unit circle).
    OutsideRadius,
    /// Inside `rho` but with damping below `min_damping`.
    PoorlyDamped,
}

impl ZeroStatus {
    /// Short label for summaries.
    pub fn label(self) -> &'static str {
        match self {
            ZeroStatus::Cancelled => "cancelled",
            ZeroStatus::OutsideRadius => "kept: |z| >= rho",
            ZeroStatus::PoorlyDamped => "kept: poorly damped",
        }
    }
}

/// One zero of the plant with its classification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClassifiedZero {
    /// The zero in the z-plane.
    pub zero: c64,
    /// `|z|`.
    pub magnitude: f64,
    /// Equivalent damping ratio `-ln|z| / |ln z|` (1 at the origin).
    pub damping: f64,
    /// The decision.
    pub status: ZeroStatus,
}

/// Why a ZPETC cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZpetcError {
    /// Bad settings.
    #[error("{0}")]
    InvalidParams(String),
    /// Zeros could not be computed.
    #[error("plant zeros: {0}")]
    Roots(#[from] RootsError),
    /// An uncancellable zero at `z = 1` makes `B_u(1) = 0`: the plant passes
    /// no DC and unit-DC normalisation is impossible.
    #[error("the plant has a zero at z = 1 (no DC gain); ZPETC cannot have unit DC gain")]
    ZeroAtDc,
}

/// A designed ZPETC filter: `G_z = z^preview num(z^-1)/den(z^-1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Zpetc {
    /// Causal numerator `A_c B_u^* / B_u(1)^2`, ascending `z^-1`.
    pub num: Poly,
    /// Causal denominator `B_a` (constant term 1), ascending `z^-1`.
    pub den: Poly,
    /// Reference look-ahead in samples, `d + s`.
    pub preview: usize,
    /// Sample time in seconds.
    pub ts: f64,
    /// Every zero of the plant with its classification.
    pub zeros: Vec<ClassifiedZero>,
    /// The settings used.
    pub params: ZpetcParams,
}

/// The self-check of a designed filter against its plant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZpetcCheck {
    /// Frequencies examined (uniform from 0 to Nyquist).
    pub points: usize,
    /// Largest `|arg(G_z G_c)|` in rad where `|G_z G_c|` is not negligible.
    pub max_phase_error_rad: f64,
    /// `G_z(1) G_c(1)`, which must be 1.
    pub dc_gain: f64,
    /// Largest relative deviation of `|G_z G_c|` from `|B_u(e^jw)|^2/B_u(1)^2`.
    pub max_magnitude_error: f64,
    /// Whether the causal filter is stable (all poles inside the unit circle).
    pub filter_stable: bool,
}

fn damping_ratio(z: c64) -> f64 {
    let r = z.norm();
    if r == 0.0 {
        return 1.0;
    }
    let ln = c64::new(r.ln(), z.arg());
    if ln.norm() == 0.0 {
        // z = 1: an integrator-like zero, neither damped nor oscillating.
        return 0.0;
    }
    -r.ln() / ln.norm()
}

/// Splits the zeros of `g` per `params`.
pub fn classify_zeros(
    g: &DiscreteTf,
    params: &ZpetcParams,
) -> Result<Vec<ClassifiedZero>, ZpetcError> {
    Ok(g.zeros()?
        .into_iter()
        .map(|zero| {
            let magnitude = zero.norm();
            let damping = damping_ratio(zero);
            let status = if magnitude >= params.rho {
                ZeroStatus::OutsideRadius
            } else if damping < params.min_damping {
                ZeroStatus::PoorlyDamped
            } else {
                ZeroStatus::Cancelled
            };
            ClassifiedZero {
                zero,
                magnitude,
                damping,
                status,
            }
        })
        .collect())
}

/// Designs the ZPETC of the closed loop `g` ([Li21] Eq. 8, or Eq. 10 when
/// every zero is cancellable).
pub fn design(g: &DiscreteTf, params: &ZpetcParams) -> Result<Zpetc, ZpetcError> {
    if !(params.rho > 0.0 && params.rho <= 1.0) {
        return Err(ZpetcError::InvalidParams(format!(
            "rho must lie in (0, 1], got {}",
            params.rho
        )));
    }
    if !(0.0..=1.0).contains(&params.min_damping) {
        return Err(ZpetcError::InvalidParams(format!(
            "min_damping must lie in [0, 1], got {}",
            params.min_damping
        )));
    }
    let zeros = classify_zeros(g, params)?;
    let b0 = g.num().coeffs()[0];
    let a_c = g.den();
    let kept: Vec<c64> = zeros
        .iter()
        .filter(|z| z.status != ZeroStatus::Cancelled)
        .map(|z| z.zero)
        .collect();

    let (num, den) = if kept.is_empty() {
        // [Li21] Eq. 10: G_z = z^d A_c / B_c, normalised so den[0] = 1.
        (a_c.scale(1.0 / b0), g.num().scale(1.0 / b0))
    } else {
        let cancelled: Vec<c64> = zeros
            .iter()
            .filter(|z| z.status == ZeroStatus::Cancelled)
            .map(|z| z.zero)
            .collect();
        let b_a = Poly::from_z_roots(&cancelled, 1.0);
        let b_u = Poly::from_z_roots(&kept, b0);
        let b_u_dc = b_u.sum();
        if b_u_dc == 0.0
            || (b_u_dc.abs() <= 1e-12 * b_u.coeffs().iter().map(|c| c.abs()).sum::<f64>())
        {
            return Err(ZpetcError::ZeroAtDc);
        }
        let num = a_c.mul(&b_u.reversed()).scale(1.0 / (b_u_dc * b_u_dc));
        (num, b_a)
    };
    Ok(Zpetc {
        num,
        den,
        preview: g.delay() + kept.len(),
        ts: g.ts(),
        zeros,
        params: *params,
    })
}

impl Zpetc {
    /// Zeros cancelled by the filter.
    pub fn cancelled_zeros(&self) -> impl Iterator<Item = &ClassifiedZero> {
        self.zeros
            .iter()
            .filter(|z| z.status == ZeroStatus::Cancelled)
    }

    /// Zeros left in the loop (the `s` of the preview `d + s`).
    pub fn uncancelled_zeros(&self) -> impl Iterator<Item = &ClassifiedZero> {
        self.zeros
            .iter()
            .filter(|z| z.status != ZeroStatus::Cancelled)
    }

    /// The non-causal response `G_z(e^{j omega}) = e^{j omega preview} num/den`.
    pub fn response_at_omega(&self, omega: f64) -> c64 {
        c64::from_polar(1.0, omega * self.preview as f64) * self.num.eval_unit_circle(omega)
            / self.den.eval_unit_circle(omega)
    }

    /// The causal part `num/den` as a running filter; feed it `r(k + preview)`.
    pub fn causal_filter(&self) -> TdfFilter {
        TdfFilter::from_coeffs(self.num.coeffs(), self.den.coeffs(), 0)
    }

    /// Applies the filter to a whole reference, using the preview: the output
    /// at `k` is the causal part driven by `r(k + preview)`; beyond the end the
    /// reference is held at its last value.
    pub fn apply(&self, reference: &[f64]) -> Vec<f64> {
        let mut filter = self.causal_filter();
        let last = reference.last().copied().unwrap_or(0.0);
        (0..reference.len())
            .map(|k| filter.step(*reference.get(k + self.preview).unwrap_or(&last)))
            .collect()
    }

    /// Checks zero phase, unit DC gain and the predicted magnitude of
    /// `G_z G_c` on `points` frequencies from 0 to Nyquist.
    pub fn check(&self, plant: &DiscreteTf, points: usize) -> Result<ZpetcCheck, ZpetcError> {
        let kept: Vec<c64> = self.uncancelled_zeros().map(|z| z.zero).collect();
        let b_u = Poly::from_z_roots(&kept, plant.num().coeffs()[0]);
        let b_u_dc2 = b_u.sum().powi(2);
        let omegas = linspace(0.0, PI, points.max(2));
        let products: Vec<(c64, f64)> = omegas
            .iter()
            .map(|&w| {
                let p = self.response_at_omega(w) * plant.response_at_omega(w);
                let expected = b_u.eval_unit_circle(w).norm_sqr() / b_u_dc2;
                (p, expected)
            })
            .collect();
        let scale = products.iter().fold(0.0f64, |m, (p, _)| m.max(p.norm()));
        let mut max_phase_error_rad = 0.0f64;
        let mut max_magnitude_error = 0.0f64;
        for (p, expected) in &products {
            if p.norm() > 1e-9 * scale {
                max_phase_error_rad = max_phase_error_rad.max(p.arg().abs());
            }
            max_magnitude_error = max_magnitude_error
                .max((p.norm() - expected).abs() / expected.max(1e-300).max(1e-9 * scale));
        }
        let dc = self.response_at_omega(0.0) * plant.response_at_omega(0.0);
        let filter_stable = self.den.z_roots()?.iter().all(|p| p.norm() < 1.0);
        Ok(ZpetcCheck {
            points: omegas.len(),
            max_phase_error_rad,
            dc_gain: dc.re,
            max_magnitude_error,
            filter_stable,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn li21() -> DiscreteTf {
        DiscreteTf::new(
            vec![4.154, -9.631, 10.23, -5.511, 1.154],
            vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
            5,
            1e-4,
        )
        .unwrap()
    }

    #[test]
    fn li21_all_zeros_cancelled_eq10() {
        let z = design(&li21(), &ZpetcParams::default()).unwrap();
        assert_eq!(z.preview, 5);
        assert_eq!(z.uncancelled_zeros().count(), 0);
        // reference-values.md: numerator A_c / 4.154, denominator B_c / 4.154.
        let num = [0.24073, -0.18902, 0.17571, -0.14781, 0.012412, 0.0082980];
        let den = [1.0, -2.31849, 2.46269, -1.32667, 0.277805];
        for (a, b) in z.num.coeffs().iter().zip(num) {
            assert!((a - b).abs() < 5e-6, "{a} vs {b}");
        }
        for (a, b) in z.den.coeffs().iter().zip(den) {
            assert!((a - b).abs() < 5e-6, "{a} vs {b}");
        }
        let check = z.check(&li21(), 2001).unwrap();
        assert!((check.dc_gain - 1.0).abs() < 1e-12);
        assert!(check.max_phase_error_rad < 1e-9);
        assert!(check.filter_stable);
    }

    #[test]
    fn unstable_zero_kept_and_phase_zero() {
        // B = (1 - 0.5 z^-1)(1 - 1.5 z^-1): 1.5 cannot be cancelled.
        let g = DiscreteTf::new(vec![1.0, -2.0, 0.75], vec![1.0, -0.3], 2, 1e-3).unwrap();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        assert_eq!(z.preview, 3);
        assert_eq!(z.uncancelled_zeros().count(), 1);
        let check = z.check(&g, 1001).unwrap();
        assert!(check.max_phase_error_rad < 1e-9, "{check:?}");
        assert!((check.dc_gain - 1.0).abs() < 1e-12);
        assert!(check.max_magnitude_error < 1e-9);
    }

    #[test]
    fn near_minus_one_zero_refused() {
        let g = DiscreteTf::new(vec![1.0, 0.8], vec![1.0, -0.5], 1, 1e-3).unwrap();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        assert_eq!(z.zeros[0].status, ZeroStatus::PoorlyDamped);
        let z = design(
            &g,
            &ZpetcParams {
                min_damping: 0.0,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(z.zeros[0].status, ZeroStatus::Cancelled);
    }

    #[test]
    fn bad_params_and_dc_zero() {
        let g = li21();
        assert!(matches!(
            design(
                &g,
                &ZpetcParams {
                    rho: 1.5,
                    ..Default::default()
                }
            ),
            Err(ZpetcError::InvalidParams(_))
        ));
        let g = DiscreteTf::new(vec![1.0, -1.0], vec![1.0, -0.5], 1, 1e-3).unwrap();
        assert_eq!(
            design(&g, &ZpetcParams::default()),
            Err(ZpetcError::ZeroAtDc)
        );
    }

    #[test]
    fn apply_tracks_through_plant() {
        // ZPETC followed by the plant reproduces a slow sine almost exactly.
        let g = li21();
        let z = design(&g, &ZpetcParams::default()).unwrap();
        let r: Vec<f64> = (0..4000)
            .map(|k| (2.0 * PI * 50.0 * k as f64 * 1e-4).sin())
            .collect();
        let y = crate::lti::lsim(&g, &z.apply(&r));
        let err = (1000..3900)
            .map(|k| (y[k] - r[k]).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
    }
}
