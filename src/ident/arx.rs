//! ARX identification by QR least squares (docs/math.md §2).
//!
//! Model `A(q) y(k) = B(q) u(k - nk) + e(k)` with
//! `A = 1 + a1 q^-1 + .. + a_na q^-na`, `B = b0 + .. + b_{nb-1} q^-(nb-1)`;
//! regression `y(k) = phi(k)^T theta + e(k)`,
//! `phi(k) = [-y(k-1) .. -y(k-na), u(k-nk) .. u(k-nk-nb+1)]`,
//! `theta = [a1 .. a_na, b0 .. b_{nb-1}]`, over the rows
//! `k = n0 .. N-1`, `n0 = max(na, nb + nk - 1)` (every regressor measured, as
//! MATLAB `arx` does). The regression is reduced by a streaming Householder
//! QR ([`super::ls`]); never by the normal equations.
//!
//! Parameter covariance `P = lambda (Phi^T Phi)^-1 = lambda R^-1 R^-T` with
//! `lambda = ||e||^2 / (N - d)` (the unbiased noise variance), standard
//! deviations `sqrt(diag P)`: valid when `e` is white (equation-error
//! noise). With coloured or output noise ARX is biased and the residual test
//! says so ([`super::linear::whiteness`]).
//!
//! The reported loss is MATLAB's: `||e||^2` of the rows divided by all `N`
//! samples, since MATLAB treats the regressors before row `n0` as estimated
//! initial conditions whose prediction errors are zero (its `arx` sets
//! `LossFcn = V (N - n0 - d) / N`, `V` the noise variance above).

use super::linear::{Criteria, IdentError, PolyModel, check_excited, check_signals};
use super::ls::{DEFAULT_BLOCK_ROWS, solve_triangle, std_devs, triangularize_halves};

/// Orders of a polynomial model: `na` poles, `nb` numerator coefficients,
/// `nk` samples of input delay (MATLAB `[na nb nk]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Orders {
    /// Number of `A` coefficients after the leading 1.
    pub na: usize,
    /// Number of `B` coefficients (at least 1).
    pub nb: usize,
    /// Input delay in samples (0 allowed: direct feedthrough).
    pub nk: usize,
}

impl Orders {
    /// `[na nb nk]`.
    pub fn new(na: usize, nb: usize, nk: usize) -> Self {
        Orders { na, nb, nk }
    }

    /// Number of parameters `na + nb`.
    pub fn params(&self) -> usize {
        // Saturating: absurd orders must reach the data-length check, not overflow.
        self.na.saturating_add(self.nb)
    }

    /// Refuses orders without input (`nb = 0`) or whose model could not be written as an `fts.tf/1`
    /// file (at most [`crate::io::tf_json::MAX_COEFFS`] coefficients per
    /// polynomial, a delay of at most [`crate::io::tf_json::MAX_DELAY`]):
    /// checked before any work, since the regression's memory grows with
    /// `(na + nb)^2`.
    pub fn check(&self) -> Result<(), IdentError> {
        use crate::io::tf_json::{MAX_COEFFS, MAX_DELAY};
        if self.nb == 0 {
            return Err(IdentError::BadStructure(
                "nb must be at least 1 (a model without input)".into(),
            ));
        }
        let too_big = [
            ("na", self.na, MAX_COEFFS - 1),
            ("nb", self.nb, MAX_COEFFS),
            ("nk", self.nk, MAX_DELAY as usize),
        ]
        .into_iter()
        .find(|&(_, v, max)| v > max);
        match too_big {
            Some((name, v, max)) => Err(IdentError::BadStructure(format!(
                "{name} = {v} is beyond the largest accepted, {max}"
            ))),
            None => Ok(()),
        }
    }

    /// Past samples each regression row needs: `max(na, nb + nk - 1)`.
    pub fn memory(&self) -> usize {
        self.na
            .max(self.nb.saturating_add(self.nk).saturating_sub(1))
    }
}

impl std::fmt::Display for Orders {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{} {} {}]", self.na, self.nb, self.nk)
    }
}

/// Settings of [`arx`].
#[derive(Debug, Clone)]
pub struct ArxParams {
    /// Model orders.
    pub orders: Orders,
    /// Sample time in seconds (stored in the model; default 1).
    pub ts: f64,
    /// First regression row. Default `None`: [`Orders::memory`]. Structure
    /// selection sets it to the largest memory of its grid so that every
    /// candidate is scored on the same rows.
    pub start: Option<usize>,
    /// Rows per QR block (default [`DEFAULT_BLOCK_ROWS`]); only speed depends on it.
    pub block_rows: usize,
}

impl ArxParams {
    /// Defaults for the given orders: `ts = 1`, rows from the model memory,
    /// default block size.
    pub fn new(orders: Orders) -> Self {
        ArxParams {
            orders,
            ts: 1.0,
            start: None,
            block_rows: DEFAULT_BLOCK_ROWS,
        }
    }
}

/// The estimate with its diagnostics.
#[derive(Debug, Clone)]
pub struct ArxEstimate {
    /// `z^-nk B/A`.
    pub model: PolyModel,
    /// Standard deviations of `a1 .. a_na`.
    pub std_a: Vec<f64>,
    /// Standard deviations of `b0 .. b_{nb-1}`.
    pub std_b: Vec<f64>,
    /// `lambda = ||e||^2 / (rows - d)`, the unbiased noise variance of the
    /// regression (MATLAB `NoiseVariance`; it scales the standard deviations).
    pub noise_variance: f64,
    /// Sum of squared residuals `||e||^2` over the regression rows.
    pub residual_sum_squares: f64,
    /// Loss and information criteria as MATLAB's `arx` reports them: the
    /// regression rows' `||e||^2` over all `N` samples (the first `start`
    /// prediction errors are those of estimated initial conditions, zero), and
    /// `N` samples in FPE, AIC and BIC (docs/identify-linear.md).
    pub criteria: Criteria,
    /// Condition number of the regressor matrix `Phi` (`sigma_max/sigma_min`).
    pub condition_number: f64,
    /// First regression row used.
    pub start: usize,
}

/// Why the regressor matrix is singular, in the user's terms.
pub(crate) fn singular_hint(u: &[f64], nb: usize) -> String {
    let first = u.first().copied().unwrap_or(0.0);
    if u.iter().all(|&v| v == first) {
        "the input is constant: it excites no dynamics (persistently exciting of order 1 only), so B cannot be separated from A; use a sweep, multisine or random input".into()
    } else {
        format!(
            "the input is not persistently exciting of order {nb}, or the orders are too high for the data (a pole-zero cancellation or an output that is exactly predictable); lower na/nb or use a richer input"
        )
    }
}

/// Estimates an ARX model of the given orders from input `u` and output `y`.
pub fn arx(u: &[f64], y: &[f64], params: &ArxParams) -> Result<ArxEstimate, IdentError> {
    check_signals(u, y)?;
    let o = params.orders;
    o.check()?;
    check_excited(u)?;
    let n = y.len();
    let d = o.params();
    let start = params.start.unwrap_or(0).max(o.memory());
    let rows = n.saturating_sub(start);
    // At least one more row than parameters, so that the noise variance
    // (and the standard deviations) exist.
    if rows <= d {
        return Err(IdentError::TooShort {
            samples: n,
            rows,
            needed: d.saturating_add(1),
            params: d,
            orders: o.to_string(),
        });
    }
    let (na, nk) = (o.na, o.nk);
    let tri = triangularize_halves(d + 1, rows, params.block_rows, |j, s, out| {
        let k0 = start + s;
        let len = out.len();
        if j < na {
            let src = &y[k0 - (j + 1)..k0 - (j + 1) + len];
            for (o, v) in out.iter_mut().zip(src) {
                *o = -v;
            }
        } else if j < d {
            let lag = nk + (j - na);
            out.copy_from_slice(&u[k0 - lag..k0 - lag + len]);
        } else {
            out.copy_from_slice(&y[k0..k0 + len]);
        }
    });
    let sol = solve_triangle(&tri).map_err(|e| {
        let (rank, cond) = e.rank_and_condition();
        IdentError::Singular {
            rank,
            params: d,
            cond,
            hint: singular_hint(u, o.nb),
        }
    })?;
    let sse = sol.residual_norm.powi(2);
    let lambda = sse / (rows - d) as f64;
    let sd = std_devs(&sol.r_inv, lambda);
    let mut a = vec![1.0];
    a.extend_from_slice(&sol.theta[..na]);
    Ok(ArxEstimate {
        model: PolyModel {
            a,
            b: sol.theta[na..].to_vec(),
            nk,
            ts: params.ts,
        },
        std_a: sd[..na].to_vec(),
        std_b: sd[na..].to_vec(),
        noise_variance: lambda,
        residual_sum_squares: sse,
        criteria: Criteria::new(sse / n as f64, n, d),
        condition_number: sol.condition_number,
        start,
    })
}

/// Equation errors `e(k) = A(q) y(k) - B(q) u(k - nk)` for `k >= start`
/// (the ARX residuals, which are also its one-step prediction errors).
pub fn arx_residuals(model: &PolyModel, u: &[f64], y: &[f64], start: usize) -> Vec<f64> {
    (start.min(y.len())..y.len())
        .map(|k| {
            let mut e = y[k];
            for (i, a) in model.a.iter().enumerate().skip(1) {
                if k >= i {
                    e += a * y[k - i];
                }
            }
            for (i, b) in model.b.iter().enumerate() {
                if k >= model.nk + i {
                    e -= b * u[k - model.nk - i];
                }
            }
            e
        })
        .collect()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::linear::filter_ab;
    use crate::ident::testutil::{chirp, noise};

    fn li21() -> (Vec<f64>, Vec<f64>) {
        (
            vec![4.154, -9.631, 10.23, -5.511, 1.154],
            vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
        )
    }

    pub fn noise_free_li21_recovered_to_1e9() {
        let (b, a) = li21();
        let u = chirp(20_000, 1e-4, 1000.0);
        let y = filter_ab(&b, &a, 5, &u);
        let mut p = ArxParams::new(Orders::new(5, 5, 5));
        p.ts = 1e-4;
        let est = arx(&u, &y, &p).unwrap();
        for (x, t) in est.model.a.iter().zip(&a) {
            assert!((x - t).abs() < 1e-9, "a {x} vs {t}");
        }
        for (x, t) in est.model.b.iter().zip(&b) {
            assert!((x - t).abs() < 1e-9, "b {x} vs {t}");
        }
        assert!(est.criteria.loss < 1e-20);
    }

    pub fn equation_error_noise_estimates_within_std_devs() {
        // A y = B u + e with white e: ARX is the maximum-likelihood estimator,
        // unbiased; each estimate lies within 3.5 of its own standard
        // deviations of the truth (a 2e-4 two-sided event per coefficient).
        let (b, a) = li21();
        let n = 20_000;
        let u = chirp(n, 1e-4, 1000.0);
        let e: Vec<f64> = noise(n, 7).iter().map(|v| 0.05 * v).collect();
        let yu = filter_ab(&b, &a, 5, &u);
        let ye = filter_ab(&[1.0], &a, 0, &e);
        let y: Vec<f64> = yu.iter().zip(&ye).map(|(p, q)| p + q).collect();
        let est = arx(&u, &y, &ArxParams::new(Orders::new(5, 5, 5))).unwrap();
        for i in 0..5 {
            let z = (est.model.a[i + 1] - a[i + 1]) / est.std_a[i];
            assert!(z.abs() < 3.5, "a{} z = {z}", i + 1);
            let z = (est.model.b[i] - b[i]) / est.std_b[i];
            assert!(z.abs() < 3.5, "b{i} z = {z}");
        }
        assert!((est.noise_variance / 0.0025 - 1.0).abs() < 0.05);
    }

    /// The report as MATLAB's `arx` defines it, recomputed from the returned
    /// model's residuals: the rows' squared errors over all `N` samples, `N`
    /// in FPE / AIC / BIC, the noise variance over `rows - d`, and MATLAB's
    /// own relation `LossFcn = NoiseVariance (N - n0 - d) / N`.
    pub fn criteria_are_matlab_arx_report() {
        let n = 300;
        let u: Vec<f64> = noise(n, 21).iter().map(|v| v.signum()).collect();
        let e = noise(n, 22);
        let (a, b) = ([1.0, -1.5, 0.7], [1.0, 0.5]);
        let yu = filter_ab(&b, &a, 1, &u);
        let ye = filter_ab(&[1.0], &a, 0, &e);
        let y: Vec<f64> = yu.iter().zip(&ye).map(|(p, q)| p + q).collect();
        let est = arx(&u, &y, &ArxParams::new(Orders::new(2, 2, 1))).unwrap();
        assert_eq!(est.start, 2);
        let sse: f64 = arx_residuals(&est.model, &u, &y, est.start)
            .iter()
            .map(|v| v * v)
            .sum();
        let close = |x: f64, want: f64| (x - want).abs() <= 1e-12 * want.abs();
        let (nf, d) = (n as f64, 4.0);
        let mse = sse / nf;
        assert!(close(est.residual_sum_squares, sse));
        assert!(close(est.criteria.mse, mse) && close(est.criteria.loss, mse));
        assert_eq!((est.criteria.samples, est.criteria.params), (n, 4));
        assert!(close(est.criteria.fpe, mse * (nf + d) / (nf - d)));
        let aic = nf * mse.ln() + 2.0 * d + nf * ((2.0 * std::f64::consts::PI).ln() + 1.0);
        assert!(close(est.criteria.aic, aic));
        assert!(close(est.criteria.bic, aic - 2.0 * d + d * nf.ln()));
        assert!(close(est.noise_variance, sse / (nf - 2.0 - d)));
        assert!(close(
            est.criteria.loss,
            est.noise_variance * (nf - 2.0 - d) / nf
        ));
    }

    pub fn errors() {
        let u = vec![1.0; 30];
        let y: Vec<f64> = (0..30).map(|k| k as f64).collect();
        // A constant input is refused whatever the orders: with nb = 1 the
        // regression is full rank (the input acts as an offset) and would
        // otherwise return a meaningless model.
        for nb in [1, 2] {
            let e = arx(&u, &y, &ArxParams::new(Orders::new(2, nb, 1))).unwrap_err();
            assert!(matches!(e, IdentError::ConstantInput { .. }), "{e}");
            assert!(e.to_string().contains("input is constant"), "{e}");
        }
        let jittery: Vec<f64> = (0..30).map(|k| ((k * 7919) % 13) as f64).collect();
        for orders in [
            Orders::new(512, 1, 1),
            Orders::new(1, 513, 1),
            Orders::new(1, 1, 1_000_001),
        ] {
            let e = arx(&jittery, &y, &ArxParams::new(orders)).unwrap_err();
            assert!(matches!(e, IdentError::BadStructure(_)), "{e}");
            assert!(e.to_string().contains("beyond the largest accepted"), "{e}");
        }
        let e = arx(&y[..5], &y[..5], &ArxParams::new(Orders::new(2, 2, 1))).unwrap_err();
        assert!(matches!(e, IdentError::TooShort { .. }), "{e}");
        let mut bad = y.clone();
        bad[3] = f64::NAN;
        let e = arx(&y, &bad, &ArxParams::new(Orders::new(1, 1, 1))).unwrap_err();
        assert_eq!(
            e,
            IdentError::NonFinite {
                signal: "output",
                index: 3
            }
        );
    }

    pub fn reported_std_devs_match_monte_carlo_spread() {
        // 200 noise realisations of A y = B u + e: the spread of the
        // estimates must match the standard deviations ARX reports (the
        // sample std of a std over 200 runs is good to about 5 %).
        let (b, a) = (vec![0.5, 0.3], vec![1.0, -1.5, 0.7]);
        let n = 1000;
        let u = noise(n, 100);
        let yu = filter_ab(&b, &a, 1, &u);
        let runs = 200;
        let mut est = vec![Vec::new(); 4];
        let mut reported = [0.0; 4];
        for r in 0..runs {
            let e: Vec<f64> = noise(n, 1000 + r).iter().map(|v| 0.1 * v).collect();
            let ye = filter_ab(&[1.0], &a, 0, &e);
            let y: Vec<f64> = yu.iter().zip(&ye).map(|(p, q)| p + q).collect();
            let fit = arx(&u, &y, &ArxParams::new(Orders::new(2, 2, 1))).unwrap();
            let th = [
                fit.model.a[1],
                fit.model.a[2],
                fit.model.b[0],
                fit.model.b[1],
            ];
            let sd = [fit.std_a[0], fit.std_a[1], fit.std_b[0], fit.std_b[1]];
            for i in 0..4 {
                est[i].push(th[i]);
                reported[i] += sd[i] / runs as f64;
            }
        }
        for i in 0..4 {
            let m = est[i].iter().sum::<f64>() / runs as f64;
            let sd =
                (est[i].iter().map(|v| (v - m).powi(2)).sum::<f64>() / (runs - 1) as f64).sqrt();
            let ratio = sd / reported[i];
            assert!(
                (0.8..1.25).contains(&ratio),
                "param {i}: empirical {sd} vs reported {}",
                reported[i]
            );
        }
    }
}
