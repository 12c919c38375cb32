//! What a discrete model must not hide from the designs built on it
//! (docs/formats.md "Exit codes", "Model checks"):
//!
//! * a near pole-zero cancellation on the unit circle: a zero and a pole
//!   both within [`NEAR_CIRCLE`] of `|z| = 1` and of each other. The pair
//!   barely shows in the response, but a ZPETC keeps such a zero
//!   uncancelled and divides by `B_u(1)^2`: a pair at `z ~ 1` makes the
//!   filter's coefficients explode (docs/math.md §3);
//! * an (almost) undamped pole that no data can have supported: within
//!   [`NEAR_CIRCLE`] of the unit circle, with no zero beside it, and a gain
//!   there [`TRAP_GAIN_RATIO`] times the model's median gain. A fit puts
//!   such a pole where its data had no content (a sweep to 1 kHz says
//!   nothing about 5 kHz); a sampled physical system has no real pole near
//!   `z = -1` at all (`e^{s Ts}` is never negative real). A design that
//!   needs the loop there (a repetitive compensator's Q up to a quarter of
//!   the sampling rate, ILC) then answers to the artefact.

use super::{DiscreteTf, RootsError, c64, linspace};
use std::f64::consts::PI;

/// Distance to the unit circle (and between the pair) that counts as on it.
pub const NEAR_CIRCLE: f64 = 1e-3;

/// Gain at a pole over the model's median gain that makes it a trap (60 dB).
pub const TRAP_GAIN_RATIO: f64 = 1e3;

/// A zero and the pole beside it, both near the unit circle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CirclePair {
    /// The zero (upper half plane for a complex pair).
    pub zero: c64,
    /// The pole nearest it.
    pub pole: c64,
}

/// An (almost) undamped pole with a gain far above the model's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrapPole {
    /// The pole (upper half plane for a complex pair).
    pub pole: c64,
    /// Its frequency, Hz.
    pub freq_hz: f64,
    /// `|G|` at that frequency.
    pub gain: f64,
    /// The median of `|G|` over 0..Nyquist.
    pub median_gain: f64,
}

/// The near pole-zero cancellations on the unit circle of `g`, each zero
/// with its nearest pole (each pole used once).
pub fn unit_circle_pairs(g: &DiscreteTf) -> Result<Vec<CirclePair>, RootsError> {
    let mut poles = g.poles()?;
    let mut out = Vec::new();
    for z in g.zeros()? {
        if z.im < 0.0 || (z.norm() - 1.0).abs() > NEAR_CIRCLE {
            continue;
        }
        let nearest = poles
            .iter()
            .enumerate()
            .map(|(j, p)| (j, (z - p).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((j, d)) = nearest
            && d <= NEAR_CIRCLE
        {
            out.push(CirclePair {
                zero: z,
                pole: poles.swap_remove(j),
            });
        }
    }
    Ok(out)
}

/// The poles of `g` that are traps (see the module notes).
pub fn trap_poles(g: &DiscreteTf) -> Result<Vec<TrapPole>, RootsError> {
    let zeros = g.zeros()?;
    let mut gains: Vec<f64> = linspace(0.0, PI, 513)
        .iter()
        .map(|&w| g.response_at_omega(w).norm())
        .collect();
    gains.sort_by(f64::total_cmp);
    let median_gain = gains[gains.len() / 2];
    let mut out = Vec::new();
    for p in g.poles()? {
        let near = p.norm() < 1.0 && 1.0 - p.norm() <= NEAR_CIRCLE;
        let paired = zeros.iter().any(|z| (z - p).norm() <= NEAR_CIRCLE);
        if p.im < 0.0 || !near || paired {
            continue;
        }
        let w = p.arg().abs();
        let gain = g.response_at_omega(w).norm();
        // A NaN gain counts as a trap.
        let ordinary = gain < TRAP_GAIN_RATIO * median_gain;
        if !ordinary {
            out.push(TrapPole {
                pole: p,
                freq_hz: w / (2.0 * PI * g.ts()),
                gain,
                median_gain,
            });
        }
    }
    Ok(out)
}

/// Every failed model check of `g` as a sentence: what `fts tf info` and
/// the identification commands print as warnings beside the model.
pub fn warnings(g: &DiscreteTf) -> Vec<String> {
    let mut out: Vec<String> = unit_circle_pairs(g)
        .unwrap_or_default()
        .iter()
        .map(|p| {
            format!(
                "near pole-zero cancellation on the unit circle: {p}; a ZPETC keeps such a zero uncancelled: fts minreal removes the pair (fts zpetc names the command when its self-check fails)"
            )
        })
        .collect();
    out.extend(trap_poles(g).unwrap_or_default().iter().map(|t| {
        format!(
            "trap pole: {t}; an (almost) undamped resonance that no data showed (a design needing the model there, fts repetitive, answers to it)"
        )
    }));
    out
}

/// `re+imj` with six decimals (as `fts tf info` prints roots).
fn fmt_root(z: c64) -> String {
    if z.im == 0.0 {
        format!("{:.6}", z.re)
    } else {
        format!("{:.6}{:+.6}j", z.re, z.im)
    }
}

impl std::fmt::Display for CirclePair {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "zero {} with pole {} (|z - p| = {:.1e}, 1 - |p| = {:.1e})",
            fmt_root_precise(self.zero),
            fmt_root_precise(self.pole),
            (self.zero - self.pole).norm(),
            1.0 - self.pole.norm()
        )
    }
}

/// Roots within 1e-6 of the circle need more than six decimals to tell
/// the zero from the pole.
fn fmt_root_precise(z: c64) -> String {
    if (z.norm() - 1.0).abs() < 1e-4 {
        if z.im == 0.0 {
            format!("{}", z.re)
        } else {
            format!("{}{:+}j", z.re, z.im)
        }
    } else {
        fmt_root(z)
    }
}

impl std::fmt::Display for TrapPole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pole {} (1 - |p| = {:.1e}) gives a gain of {:.3e} at {:.1} Hz, {:.1e} times the model's median gain",
            fmt_root(self.pole),
            1.0 - self.pole.norm(),
            self.gain,
            self.freq_hz,
            self.gain / self.median_gain
        )
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::Poly;

    fn tf(zeros: &[c64], poles: &[c64]) -> DiscreteTf {
        let num = Poly::from_z_roots(zeros, 0.5);
        let den = Poly::from_z_roots(poles, 1.0);
        DiscreteTf::new(num.into_coeffs(), den.into_coeffs(), 1, 1e-4).unwrap()
    }

    pub fn a_pair_at_one_is_found_and_a_distant_one_is_not() {
        let r = |x: f64| c64::new(x, 0.0);
        let g = tf(&[r(1.0 - 1e-7), r(-0.3)], &[r(1.0 - 2e-7), r(0.6)]);
        let pairs = unit_circle_pairs(&g).unwrap();
        assert_eq!(pairs.len(), 1);
        assert!((pairs[0].zero.re - (1.0 - 1e-7)).abs() < 1e-9);
        assert!((pairs[0].pole.re - (1.0 - 2e-7)).abs() < 1e-9);
        // 5e-4 apart but 3e-3 inside the circle: not on it.
        let g = tf(&[r(0.9965), r(-0.3)], &[r(0.997), r(0.6)]);
        assert!(unit_circle_pairs(&g).unwrap().is_empty());
        // On the circle but 2e-3 apart: not a pair.
        let g = tf(&[r(0.9999)], &[r(0.9979), r(0.6)]);
        assert!(unit_circle_pairs(&g).unwrap().is_empty());
    }

    pub fn an_undamped_pole_near_minus_one_is_a_trap() {
        // 1/(1 + 0.999999 z^-1) peaks at 1e6 at Nyquist; its median gain is
        // about 0.7 (1/|1 + e^{-jw}| = 1/(2 cos(w/2)) at w = pi/2).
        let r = |x: f64| c64::new(x, 0.0);
        let g = tf(&[r(0.2)], &[r(-0.999999), r(0.5)]);
        let traps = trap_poles(&g).unwrap();
        assert_eq!(traps.len(), 1);
        assert!((traps[0].freq_hz - 5000.0).abs() < 1e-6);
        // |G(-1)| = 0.5 * 1.2 / (1e-6 * 1.5)
        assert!(
            (traps[0].gain / 4e5 - 1.0).abs() < 1e-6,
            "{}",
            traps[0].gain
        );
        // A damped pole there (1 - |p| = 0.01) is no trap, nor a pair.
        let g = tf(&[r(0.2)], &[r(-0.99), r(0.5)]);
        assert!(trap_poles(&g).unwrap().is_empty());
        let g = tf(&[r(-0.9999995)], &[r(-0.999999), r(0.5)]);
        assert!(trap_poles(&g).unwrap().is_empty());
    }
}
