//! Discretisation of continuous state-space systems.
//!
//! * Zero-order hold by Van Loan's block exponential (Van Loan 1978, IEEE TAC
//!   23(3)): `exp([A B; 0 0] T) = [Ad Bd; 0 I]`, computed with nalgebra's
//!   scaling-and-squaring Padé `exp()` (the one nalgebra routine we use).
//! * Tustin (bilinear) `s = alpha (z-1)/(z+1)`, `alpha = 2/T`, or with
//!   prewarping at `w` rad/s `alpha = w / tan(w T/2)` so that the responses
//!   match exactly at `w` (Franklin, Powell & Workman §6.3).
//! * The norm-preserving unit bilinear map `s = (z-1)/(z+1)` used to carry
//!   discrete H-infinity problems to continuous time and back.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::ss::{SsError, StateSpace, block2, inv, sub};
use faer::Mat;

/// Discretisation method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum C2dMethod {
    /// Zero-order hold on the input.
    Zoh,
    /// Tustin / bilinear, optionally prewarped at this frequency (rad/s).
    Tustin {
        /// Prewarp frequency in rad/s.
        prewarp: Option<f64>,
    },
}

/// Discretises a continuous system with sample time `ts`.
pub fn c2d(sys: &StateSpace, ts: f64, method: C2dMethod) -> Result<StateSpace, SsError> {
    if sys.is_discrete() {
        return Err(SsError::SampleTimeMismatch(sys.ts, Some(ts)));
    }
    if !(ts.is_finite() && ts > 0.0) {
        return Err(SsError::BadSampleTime(ts));
    }
    let (n, m) = (sys.nx(), sys.nu());
    match method {
        C2dMethod::Zoh => {
            let big = block2(&sys.a, &sys.b, &Mat::zeros(m, n), &Mat::zeros(m, m));
            let k = n + m;
            let e = expm(&nalgebra::DMatrix::from_fn(k, k, |i, j| big[(i, j)] * ts));
            let ef = Mat::from_fn(k, k, |i, j| e[(i, j)]);
            StateSpace::new(
                sub(&ef, 0, n, 0, n),
                sub(&ef, 0, n, n, k),
                sys.c.clone(),
                sys.d.clone(),
                Some(ts),
            )
        }
        C2dMethod::Tustin { prewarp } => {
            let alpha = match prewarp {
                None => 2.0 / ts,
                Some(w) => {
                    if !(w.is_finite() && w > 0.0 && w * ts < std::f64::consts::PI) {
                        return Err(SsError::BadPrewarp {
                            w,
                            nyquist: std::f64::consts::PI / ts,
                        });
                    }
                    w / (w * ts / 2.0).tan()
                }
            };
            let i = Mat::<f64>::identity(n, n);
            let e = inv(&(&i - &(&sys.a * (1.0 / alpha))))
                .ok_or_else(|| tustin_pole(sys, alpha, ts, prewarp))?;
            StateSpace::new(
                &e * &(&i + &(&sys.a * (1.0 / alpha))),
                &(&e * &sys.b) * (2.0 / alpha),
                &sys.c * &e,
                &sys.d + &(&(&sys.c * &e * &sys.b) * (1.0 / alpha)),
                Some(ts),
            )
        }
    }
}

/// `e^M` in bounded time: nalgebra's `exp()` picks its number of squarings
/// from norms of powers of `M` (up to `M^10`, and `|M|^27` after scaling),
/// which overflow to infinity once `||M||_1` passes about 1e30, and it then
/// squares `u64::MAX` times (a hang). Beyond `||M||_1 = 1e20` `M` is first
/// scaled by `2^-k` to 1-norm at most 1e20 (`k <= 1024` for any finite
/// `M`), exponentiated, and squared back `k` times (Higham 2005, SIAM J.
/// Matrix Anal. Appl. 26(4), scaling and squaring); below, nalgebra's
/// result is unchanged. A non-finite `M` gives a matrix of NaN, which every
/// caller refuses as a non-finite result.
pub fn expm(m: &nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64> {
    const SAFE_NORM: f64 = 1e20;
    if !m.iter().all(|x| x.is_finite()) {
        return nalgebra::DMatrix::from_element(m.nrows(), m.ncols(), f64::NAN);
    }
    // Column sums of |M| / 2 cannot overflow for finite entries... unless
    // there are many near f64::MAX: halve first, then compare with the half.
    let half_norm = (0..m.ncols())
        .map(|j| m.column(j).iter().map(|x| 0.5 * x.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    if !(half_norm > 0.5 * SAFE_NORM) {
        return m.exp();
    }
    let k = if half_norm.is_finite() {
        (2.0 * (half_norm / SAFE_NORM)).log2().ceil() as i32
    } else {
        1030
    };
    let scale = 2f64.powi(-(k / 2)) * 2f64.powi(-(k - k / 2));
    let mut e = (m * scale).exp();
    for _ in 0..k {
        // Settled (all zero) or overflowed: further squarings change nothing.
        if e.iter().all(|&x| x == 0.0) || !e.iter().all(|x| x.is_finite()) {
            break;
        }
        e = &e * &e;
    }
    e
}

/// The error for `I - A / alpha` singular: names the eigenvalue of `A`
/// nearest `alpha` (where the bilinear map is undefined).
fn tustin_pole(sys: &StateSpace, alpha: f64, ts: f64, prewarp: Option<f64>) -> SsError {
    let nearest = crate::lti::ss::eigvals(&sys.a)
        .ok()
        .and_then(|ev| {
            ev.into_iter().min_by(|x, y| {
                let d = |z: &crate::lti::c64| (z - alpha).norm();
                d(x).total_cmp(&d(y))
            })
        })
        .unwrap_or(crate::lti::c64::new(alpha, 0.0));
    SsError::TustinPole {
        eigenvalue: format!("{}{:+}j", nearest.re, nearest.im),
        alpha,
        ts,
        prewarp: prewarp.map_or(String::new(), |w| format!(", prewarped at {w} rad/s")),
        or_prewarp: prewarp.map_or(String::new(), |_| " or prewarp frequency".into()),
    }
}

/// Discrete system from a continuous one by `s = a (z-1)/(z+1)` with the
/// symmetric `sqrt(2a)` split; the inverse of
/// [`super::norms::bilinear_to_continuous`]. Norms and stability are preserved.
pub fn bilinear_to_discrete(sys: &StateSpace, alpha: f64, ts: f64) -> Result<StateSpace, SsError> {
    let n = sys.nx();
    let i = Mat::<f64>::identity(n, n);
    let a = &sys.a * (1.0 / alpha);
    let e = inv(&(&i - &a)).ok_or_else(|| tustin_pole(sys, alpha, ts, None))?;
    let r2 = (2.0 / alpha).sqrt();
    StateSpace::new(
        &e * &(&i + &a),
        &(&e * &sys.b) * r2,
        &(&sys.c * &e) * r2,
        &sys.d + &(&(&sys.c * &e * &sys.b) * (1.0 / alpha)),
        Some(ts),
    )
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::c64;
    use crate::lti::norms::bilinear_to_continuous;

    /// `expm` against closed forms where nalgebra's `exp()` hangs (norms
    /// beyond about 1e30), and unchanged below its scaling threshold.
    pub fn expm_is_bounded_and_exact_on_diagonal_and_rotation_matrices() {
        use nalgebra::DMatrix;
        let e = expm(&DMatrix::from_row_slice(2, 2, &[-1e60, 0.0, 0.0, -3e59]));
        assert_eq!(e.as_slice(), &[0.0, 0.0, 0.0, 0.0]);
        let e = expm(&DMatrix::from_row_slice(1, 1, &[1e60]));
        assert!(!e[(0, 0)].is_finite());
        let e = expm(&DMatrix::from_row_slice(1, 1, &[f64::NAN]));
        assert!(e[(0, 0)].is_nan());
        // A rotation by 1e40 rad: its angle is lost to rounding (1e40 *
        // 2^-52 rad) and the squarings amplify the error without limit, but
        // the call returns; a non-finite result is refused by every caller.
        let w = 1e40;
        let start = std::time::Instant::now();
        let e = expm(&DMatrix::from_row_slice(2, 2, &[0.0, w, -w, 0.0]));
        assert!(start.elapsed().as_secs() < 5);
        assert!(
            e.iter().all(|x| !x.is_finite() || x.abs() <= 1.0 + 1e-6),
            "{e}"
        );
        let m = DMatrix::from_row_slice(2, 2, &[-3.0, 1.0, 0.5, -2.0]);
        assert_eq!(expm(&m), m.exp());
    }

    pub fn tustin_at_an_eigenvalue_names_it() {
        // 1/(s - 20), T = 0.1: 2/T = 20 is the eigenvalue.
        let g = StateSpace::from_tf(&[1.0], &[1.0, -20.0], None).unwrap();
        let e = c2d(&g, 0.1, C2dMethod::Tustin { prewarp: None }).unwrap_err();
        let m = e.to_string();
        assert!(matches!(e, SsError::TustinPole { .. }), "{m}");
        assert!(
            m.contains("eigenvalue at 20+0j") && m.contains("ts = 1e-1"),
            "{m}"
        );
        let e = c2d(
            &g,
            0.1,
            C2dMethod::Tustin {
                prewarp: Some(40.0),
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("(0, pi/ts)"), "{e}");
    }

    pub fn zoh_of_first_order() {
        // 1/(s+1), T = 0.1: Ad = e^-0.1, Bd = 1 - e^-0.1.
        let g = StateSpace::from_tf(&[1.0], &[1.0, 1.0], None).unwrap();
        let d = c2d(&g, 0.1, C2dMethod::Zoh).unwrap();
        assert!((d.a[(0, 0)] - (-0.1f64).exp()).abs() < 1e-15);
        assert!((d.b[(0, 0)] * d.c[(0, 0)] - (1.0 - (-0.1f64).exp())).abs() < 1e-15);
    }

    pub fn tustin_prewarp_matches_at_the_frequency() {
        let g = StateSpace::from_tf(&[100.0], &[1.0, 2.0, 100.0], None).unwrap();
        let (ts, w) = (0.05, 10.0);
        let d = c2d(&g, ts, C2dMethod::Tustin { prewarp: Some(w) }).unwrap();
        let gc = g.freq_response(w).unwrap()[(0, 0)];
        let gd = d.freq_response(w).unwrap()[(0, 0)];
        assert!((gc - gd).norm() < 1e-12 * gc.norm(), "{gc} {gd}");
        let plain = c2d(&g, ts, C2dMethod::Tustin { prewarp: None }).unwrap();
        assert!((plain.dc_gain().unwrap()[(0, 0)] - 1.0).abs() < 1e-12);
    }

    pub fn unit_bilinear_round_trip() {
        let g = StateSpace::from_tf(&[1.0, 3.0], &[1.0, 2.0, 5.0], None).unwrap();
        let d = bilinear_to_discrete(&g, 7.0, 1.0).unwrap();
        let back = bilinear_to_continuous(&d, 7.0).unwrap();
        let s = c64::new(0.3, 1.7);
        let e = (g.eval(s).unwrap()[(0, 0)] - back.eval(s).unwrap()[(0, 0)]).norm();
        assert!(e < 1e-13);
    }
}
