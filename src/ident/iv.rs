//! Instrumental-variable estimation of `z^-nk B/A` (simplified refined IV,
//! Young's SRIV; Söderström & Stoica, *System Identification*, ch. 8).
//!
//! Why: with measurement noise on `y`, the ARX regressor `-y(k-i)` is
//! correlated with the equation error `A v`, so least squares is biased (on
//! the \[Li21\] closed loop, white noise of 1e-3 on `y` moves `a1` from -0.785
//! to about -0.47). IV replaces `-y(k-i)` in the *instrument* by `-x(k-i)`,
//! the noise-free simulated output of the previous estimate: the instruments
//! are correlated with the regressors but not with the noise, so
//! `sum zeta(k) (y(k) - phi(k)^T theta) = 0` has the true `theta` as its
//! solution in the limit. Each iteration also prefilters `y, u, x` with
//! `1/A` of the previous estimate, which whitens the equation error of an
//! output-error system and makes the estimate close to the OE optimum (SRIV).
//!
//! Iterations: `theta_0` = ARX; `theta_{i+1}` solves
//! `(Z_f^T Phi_f) theta = Z_f^T y_f`, until the relative change is below
//! `tolerance`. Covariance `lambda M^-1 (Z_f^T Z_f) M^-T` with `M = Z_f^T Phi_f`,
//! `lambda` the variance of the simulation residual.

use super::arx::{ArxParams, Orders, arx, singular_hint};
use super::linear::{Criteria, IdentError, PolyModel, check_signals, filter_ab, stabilize};
use super::ls::{DEFAULT_BLOCK_ROWS, triangularize};
use faer::Mat;

/// Settings of [`iv`].
#[derive(Debug, Clone)]
pub struct IvParams {
    /// `[na nb nk]`.
    pub orders: Orders,
    /// Sample time (seconds), stored in the model; default 1.
    pub ts: f64,
    /// Maximum IV iterations after the ARX start (default 20).
    pub max_iterations: usize,
    /// Stop when `||theta_new - theta|| <= tolerance ||theta||` (default 1e-10).
    pub tolerance: f64,
    /// Prefilter by `1/A` of the previous estimate (SRIV; default true).
    /// Without it this is the basic IV with simulated-output instruments.
    pub prefilter: bool,
}

impl IvParams {
    /// Defaults for the given orders.
    pub fn new(orders: Orders) -> Self {
        IvParams {
            orders,
            ts: 1.0,
            max_iterations: 20,
            tolerance: 1e-10,
            prefilter: true,
        }
    }
}

/// The IV estimate with its diagnostics.
#[derive(Debug, Clone)]
pub struct IvEstimate {
    /// `z^-nk B/A`.
    pub model: PolyModel,
    /// Standard deviations of `a1 ..`.
    pub std_a: Vec<f64>,
    /// Standard deviations of `b0 ..`.
    pub std_b: Vec<f64>,
    /// Variance of the simulation residual `y - B/A u`.
    pub noise_variance: f64,
    /// Criteria from the simulation residual (output-error loss).
    pub criteria: Criteria,
    /// Condition number of `M = Z^T Phi` at the last iteration.
    pub condition_number: f64,
    /// Iterations done.
    pub iterations: usize,
    /// Whether the relative change fell below the tolerance.
    pub converged: bool,
}

#[derive(Clone)]
struct IvStep {
    theta: Vec<f64>,
    cond: f64,
    cov_unscaled: Mat<f64>,
}

fn iv_step(
    u: &[f64],
    y: &[f64],
    prev: &PolyModel,
    o: Orders,
    prefilter: bool,
) -> Result<IvStep, IdentError> {
    let x = prev.simulate(u);
    let (yf, uf, xf) = if prefilter {
        let a = &prev.a;
        (
            filter_ab(&[1.0], a, 0, y),
            filter_ab(&[1.0], a, 0, u),
            filter_ab(&[1.0], a, 0, &x),
        )
    } else {
        (y.to_vec(), u.to_vec(), x)
    };
    let d = o.params();
    let start = o.memory();
    let rows = y.len().saturating_sub(start);
    // With Z = Q_z R_z (QR of the instruments), the IV equations
    // Z^T Phi theta = Z^T y are R_z^T (Q_z^T Phi) theta = R_z^T Q_z^T y, i.e.
    // (Q_z^T Phi) theta = Q_z^T y. Both blocks come out of one streaming QR of
    // [Z | Phi | y]: the top-right blocks of its triangle. Solving this
    // d x d system instead of M = Z^T Phi avoids squaring the conditioning,
    // and the covariance M^-1 Z^T Z M^-T collapses to (R_zphi^T R_zphi)^-1.
    let tri = triangularize(2 * d + 1, rows, DEFAULT_BLOCK_ROWS, |j, s, out| {
        let k0 = start + s;
        let len = out.len();
        let (which, jj) = if j < d {
            (0, j)
        } else if j < 2 * d {
            (1, j - d)
        } else {
            (2, 0)
        };
        match which {
            2 => out.copy_from_slice(&yf[k0..k0 + len]),
            _ if jj < o.na => {
                let src = if which == 0 { &xf } else { &yf };
                let lag = jj + 1;
                for (o, v) in out.iter_mut().zip(&src[k0 - lag..k0 - lag + len]) {
                    *o = -v;
                }
            }
            _ => {
                let lag = o.nk + (jj - o.na);
                out.copy_from_slice(&uf[k0 - lag..k0 - lag + len]);
            }
        }
    });
    let m = Mat::<f64>::from_fn(d, d, |i, j| tri.r[(i, d + j)]);
    let rhs = Mat::<f64>::from_fn(d, 1, |i, _| tri.r[(i, 2 * d)]);
    let sv = fts_kernels::dense::singular_values(m.as_ref()).unwrap_or_else(|_| vec![0.0; d]);
    let smax = sv.first().copied().unwrap_or(0.0);
    let smin = sv.last().copied().unwrap_or(0.0);
    let cond = if smin > 0.0 {
        smax / smin
    } else {
        f64::INFINITY
    };
    // Rank policy of `ident::ls`: the condition number with unit-norm
    // columns must stay below 1 / rank_tol.
    let rank_tol = crate::ident::ls::LstsqParams::default().rank_tol;
    let norms: Vec<f64> = (0..d)
        .map(|j| (0..d).map(|i| m[(i, j)].powi(2)).sum::<f64>().sqrt())
        .collect();
    let rank = if norms.iter().all(|&n| n > 0.0 && n.is_finite()) {
        let scaled = Mat::<f64>::from_fn(d, d, |i, j| m[(i, j)] / norms[j]);
        let ssv =
            fts_kernels::dense::singular_values(scaled.as_ref()).unwrap_or_else(|_| vec![0.0; d]);
        let top = ssv.first().copied().unwrap_or(0.0);
        ssv.iter().filter(|&&s| s > rank_tol * top).count()
    } else {
        0
    };
    if rank < d || !smax.is_finite() {
        return Err(IdentError::Singular {
            rank,
            params: d,
            cond,
            hint: singular_hint(u, o.nb),
        });
    }
    let qr = fts_kernels::dense::ColPivQrSolver::new(m.as_ref());
    let theta_m = qr.solve(rhs.as_ref());
    let theta = (0..d).map(|i| theta_m[(i, 0)]).collect();
    // (M^T M)^-1 = M^-1 M^-T.
    let minv = qr.solve(Mat::<f64>::identity(d, d).as_ref());
    let cov = &minv * minv.transpose();
    Ok(IvStep {
        theta,
        cond,
        cov_unscaled: cov,
    })
}

fn model_from(theta: &[f64], o: Orders, ts: f64) -> PolyModel {
    let mut a = vec![1.0];
    a.extend_from_slice(&theta[..o.na]);
    PolyModel {
        a,
        b: theta[o.na..].to_vec(),
        nk: o.nk,
        ts,
    }
}

/// Estimates `z^-nk B/A` by iterated (refined) instrumental variables.
pub fn iv(u: &[f64], y: &[f64], params: &IvParams) -> Result<IvEstimate, IdentError> {
    // arx() below refuses a constant input, after the orders.
    check_signals(u, y)?;
    let o = params.orders;
    let mut ap = ArxParams::new(o);
    ap.ts = params.ts;
    let start = arx(u, y, &ap)?;
    let mut model = start.model;
    model.a = stabilize(&model.a);
    let mut theta: Vec<f64> = model.a[1..].iter().chain(&model.b).copied().collect();
    let mut iterations = 0;
    let mut converged = o.na == 0; // an FIR model is ARX = IV
    let mut last: Option<IvStep> = None;
    // Simulation loss (initial conditions fitted) of an iterate: the IV
    // iteration is not a descent method, so on hard data (short records of
    // lightly damped systems) it can wander; the best iterate is returned.
    let sim_loss = |m: &PolyModel| {
        let s = m.simulate_fit_ic(u, y);
        y.iter().zip(&s).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / y.len() as f64
    };
    let mut best: Option<(f64, PolyModel, Option<IvStep>)> = None;
    while !converged && iterations < params.max_iterations {
        let step = iv_step(u, y, &model, o, params.prefilter)?;
        iterations += 1;
        let change: f64 = step
            .theta
            .iter()
            .zip(&theta)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let norm: f64 = theta.iter().map(|v| v * v).sum::<f64>().sqrt();
        theta = step.theta.clone();
        let mut next = model_from(&theta, o, params.ts);
        // The instruments of the next step are simulated through 1/A: keep A
        // stable (reflecting an unstable root keeps |A(e^jw)| up to a gain).
        next.a = stabilize(&next.a);
        model = next;
        converged = change <= params.tolerance * norm.max(f64::MIN_POSITIVE);
        let l = sim_loss(&model);
        if l.is_finite() && best.as_ref().is_none_or(|b| l < b.0) {
            best = Some((l, model.clone(), Some(step.clone())));
        }
        last = Some(step);
    }
    if !converged && let Some((_, m, step)) = best {
        model = m;
        last = step;
    }
    let sim = model.simulate_fit_ic(u, y);
    let resid: Vec<f64> = y.iter().zip(&sim).map(|(a, b)| a - b).collect();
    let rows = resid.len();
    let d = o.params();
    if rows <= d {
        return Err(IdentError::TooShort {
            samples: y.len(),
            rows,
            needed: d.saturating_add(1),
            params: d,
            orders: o.to_string(),
        });
    }
    let sse: f64 = resid.iter().map(|e| e * e).sum();
    let lambda = sse / (rows - d) as f64;
    let (sd, cond) = match &last {
        Some(step) => (
            (0..d)
                .map(|i| (lambda * step.cov_unscaled[(i, i)].max(0.0)).sqrt())
                .collect::<Vec<f64>>(),
            step.cond,
        ),
        None => {
            let s = start.std_a.iter().chain(&start.std_b).copied().collect();
            (s, start.condition_number)
        }
    };
    Ok(IvEstimate {
        std_a: sd[..o.na].to_vec(),
        std_b: sd[o.na..].to_vec(),
        model,
        noise_variance: lambda,
        criteria: Criteria::new(sse / rows as f64, rows, d),
        condition_number: cond,
        iterations,
        converged,
    })
}
