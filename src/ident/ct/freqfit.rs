//! Continuous transfer function from frequency-response data.
//!
//! Cost: `V = sum_k w_k |G_k - e^(-s_k tau) B(s_k)/A(s_k)|^2`, `s_k = j w_k`.
//! 1. Levy (1959): minimise `sum w_k |A(s_k) G_k e^(s_k tau) - B(s_k)|^2`,
//!    linear in the coefficients (`A` monic).
//! 2. Sanathanan & Koerner (1963): the same divided by `|A_prev(s_k)|^2`,
//!    iterated; its fixed point removes Levy's `|A|^2` weighting (and is the
//!    minimiser of `V` on noise-free data).
//! 3. Levenberg–Marquardt on `V` itself with the analytic Jacobian
//!    `dG/da_i = -B s^(n-i)/A^2`, `dG/db_j = s^(m-j)/A`: the nonlinear
//!    least-squares estimate (what `tfest` refines to).
//!
//! `w_k` is 1 (uniform) or the log-frequency width of each point's cell, so
//! that a linear FFT grid does not let the decades with most bins dominate.

use super::{CtError, CtModel, check_delay, check_orders, eval};
use crate::ident::ls::{LstsqParams, lstsq};
use crate::lti::c64;
use faer::Mat;

/// Weights of the frequency points.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum FreqWeighting {
    /// Every point counts the same.
    #[default]
    Uniform,
    /// Each point weighted by the width of its cell in `log f`.
    LogFrequency,
    /// Each point weighted by `1/|G_k|^2`: relative errors, so the decades
    /// where the response is small (above a resonance) count as much as
    /// those where it is large.
    Relative,
    /// Both: log-frequency cell width over `|G_k|^2`.
    LogRelative,
}

/// Settings of [`freq_fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct FreqFitParams {
    /// Poles.
    pub np: usize,
    /// Zeros (`<= np`).
    pub nz: usize,
    /// Known input delay, s. Default 0.
    pub delay: f64,
    /// Point weights. Default uniform.
    pub weighting: FreqWeighting,
    /// Sanathanan–Koerner iteration cap. Default 30.
    pub sk_iterations: usize,
    /// Levenberg–Marquardt iteration cap. Default 100.
    pub nls_iterations: usize,
}

impl FreqFitParams {
    /// Defaults for the given orders.
    pub fn new(np: usize, nz: usize) -> FreqFitParams {
        FreqFitParams {
            np,
            nz,
            delay: 0.0,
            weighting: FreqWeighting::Uniform,
            sk_iterations: 30,
            nls_iterations: 100,
        }
    }
}

/// The estimate with its diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct FreqFitEstimate {
    /// The model (delay as given).
    pub model: CtModel,
    /// Sanathanan–Koerner iterations run.
    pub sk_iterations: usize,
    /// Levenberg–Marquardt iterations run.
    pub nls_iterations: usize,
    /// Whether the refinement stopped on a vanishing relative cost change.
    pub converged: bool,
    /// Weighted cost `V` at the estimate.
    pub cost: f64,
    /// Fit to the data, percent ([`super::freq_fit_percent`]).
    pub fit_percent: f64,
}

/// The scaled problem: `s_k / w_s`, delay-compensated data, sqrt weights.
struct Problem {
    p: Vec<c64>,
    g: Vec<c64>,
    sw: Vec<f64>,
    n: usize,
    m: usize,
}

/// Fits `e^(-s tau) B(s)/A(s)` to `response` at `freq_hz`.
pub fn freq_fit(
    freq_hz: &[f64],
    response: &[c64],
    p: &FreqFitParams,
) -> Result<FreqFitEstimate, CtError> {
    check_orders(p.np, p.nz)?;
    check_delay(p.delay)?;
    check_data(freq_hz, response, p.np + p.nz + 1)?;
    let omega: Vec<f64> = freq_hz
        .iter()
        .map(|f| 2.0 * std::f64::consts::PI * f)
        .collect();
    // Scale by the geometric mean of the band: coefficients of order one.
    let ws = (omega.iter().map(|w| w.ln()).sum::<f64>() / omega.len() as f64).exp();
    let prob = Problem {
        p: omega.iter().map(|w| c64::new(0.0, w / ws)).collect(),
        g: omega
            .iter()
            .zip(response)
            .map(|(w, g)| g * c64::new(0.0, w * p.delay).exp())
            .collect(),
        sw: weights(freq_hz, response, p.weighting)
            .iter()
            .map(|w| w.sqrt())
            .collect(),
        n: p.np,
        m: p.nz,
    };
    let mut theta = linearised(&prob, None)?;
    let mut sk_iterations = 0;
    while sk_iterations < p.sk_iterations {
        sk_iterations += 1;
        let next = linearised(&prob, Some(&theta))?;
        let change = super::rel_change(&next, &theta);
        theta = next;
        if change < 1e-12 {
            break;
        }
    }
    let (theta, nls_iterations, converged) = levenberg_marquardt(&prob, theta, p.nls_iterations);
    let cost = cost(&prob, &theta);
    let mut model = split(&theta, prob.n).unscaled(ws);
    model.delay = p.delay;
    let fit_percent = super::freq_fit_percent(&model, freq_hz, response);
    Ok(FreqFitEstimate {
        model,
        sk_iterations,
        nls_iterations,
        converged,
        cost,
        fit_percent,
    })
}

fn check_data(freq_hz: &[f64], response: &[c64], unknowns: usize) -> Result<(), CtError> {
    if freq_hz.len() != response.len() {
        return Err(CtError::Data(format!(
            "{} frequencies but {} response values",
            freq_hz.len(),
            response.len()
        )));
    }
    if let Some(i) = freq_hz.iter().position(|f| !(f.is_finite() && *f > 0.0)) {
        return Err(CtError::Data(format!(
            "frequency {} (point {}) is not a positive number of Hz",
            freq_hz[i],
            i + 1
        )));
    }
    if let Some(i) = response
        .iter()
        .position(|g| !(g.re.is_finite() && g.im.is_finite()))
    {
        return Err(CtError::Data(format!(
            "response point {} is not finite",
            i + 1
        )));
    }
    if 2 * freq_hz.len() < unknowns {
        return Err(CtError::Data(format!(
            "{} frequency points give {} real equations for {unknowns} unknowns",
            freq_hz.len(),
            2 * freq_hz.len()
        )));
    }
    Ok(())
}

/// Point weights, normalised to sum to the number of points.
fn weights(freq_hz: &[f64], response: &[c64], kind: FreqWeighting) -> Vec<f64> {
    let k = freq_hz.len();
    let log = matches!(
        kind,
        FreqWeighting::LogFrequency | FreqWeighting::LogRelative
    );
    let relative = matches!(kind, FreqWeighting::Relative | FreqWeighting::LogRelative);
    let raw: Vec<f64> = (0..k)
        .map(|i| {
            let cell = if log && k >= 2 {
                log_cell(freq_hz, i)
            } else {
                1.0
            };
            let mag2 = response[i].norm_sqr().max(f64::MIN_POSITIVE);
            if relative { cell / mag2 } else { cell }
        })
        .collect();
    let total: f64 = raw.iter().sum();
    raw.iter().map(|w| w * k as f64 / total).collect()
}

/// Width in `ln f` of point `i`'s cell (half way to each neighbour).
fn log_cell(freq_hz: &[f64], i: usize) -> f64 {
    let k = freq_hz.len();
    let l = |j: usize| freq_hz[j].ln();
    let lo = if i == 0 {
        l(0) - (l(1) - l(0)) / 2.0
    } else {
        (l(i - 1) + l(i)) / 2.0
    };
    let hi = if i + 1 == k {
        l(k - 1) + (l(k - 1) - l(k - 2)) / 2.0
    } else {
        (l(i) + l(i + 1)) / 2.0
    };
    (hi - lo).abs().max(f64::MIN_POSITIVE)
}

/// `theta = [a_1..a_n, b_0..b_m]` as a scaled model (no delay).
fn split(theta: &[f64], n: usize) -> CtModel {
    let mut den = vec![1.0];
    den.extend_from_slice(&theta[..n]);
    CtModel {
        den,
        num: theta[n..].to_vec(),
        delay: 0.0,
    }
}

/// Levy (`prev = None`) or one Sanathanan–Koerner step: rows
/// `[p^(n-1) G .. G, -p^m .. -1] theta = -p^n G`, divided by `A_prev(p)`.
fn linearised(prob: &Problem, prev: Option<&[f64]>) -> Result<Vec<f64>, CtError> {
    let (n, m, k) = (prob.n, prob.m, prob.p.len());
    let cols = n + m + 1;
    let mut phi = Mat::<f64>::zeros(2 * k, cols);
    let mut rhs = vec![0.0; 2 * k];
    for (i, (&p, &g)) in prob.p.iter().zip(&prob.g).enumerate() {
        let scale = match prev {
            Some(theta) => prob.sw[i] / eval(&split(theta, n).den, p),
            None => c64::new(prob.sw[i], 0.0),
        };
        for c in 0..cols {
            let v = if c < n {
                p.powi((n - 1 - c) as i32) * g
            } else {
                -p.powi((m - (c - n)) as i32)
            };
            let v = v * scale;
            phi[(2 * i, c)] = v.re;
            phi[(2 * i + 1, c)] = v.im;
        }
        let r = -p.powi(n as i32) * g * scale;
        rhs[2 * i] = r.re;
        rhs[2 * i + 1] = r.im;
    }
    lstsq(phi.as_ref(), &rhs, &LstsqParams::default())
        .map(|s| s.theta)
        .map_err(|e| CtError::Numerical(format!("frequency-domain linear fit: {e}")))
}

/// Weighted residuals `sw (G - B/A)`, real and imaginary parts interleaved.
fn residuals(prob: &Problem, theta: &[f64]) -> Vec<f64> {
    let model = split(theta, prob.n);
    let mut r = Vec::with_capacity(2 * prob.p.len());
    for ((&p, &g), &sw) in prob.p.iter().zip(&prob.g).zip(&prob.sw) {
        let e = (g - eval(&model.num, p) / eval(&model.den, p)) * sw;
        r.push(e.re);
        r.push(e.im);
    }
    r
}

fn cost(prob: &Problem, theta: &[f64]) -> f64 {
    residuals(prob, theta).iter().map(|r| r * r).sum()
}

/// Jacobian of [`residuals`]: `d r/d a_i = sw B p^(n-i)/A^2`, `d r/d b_j = -sw p^(m-j)/A`.
fn jacobian(prob: &Problem, theta: &[f64]) -> Mat<f64> {
    let (n, m) = (prob.n, prob.m);
    let model = split(theta, n);
    let mut j = Mat::<f64>::zeros(2 * prob.p.len(), n + m + 1);
    for (i, (&p, &sw)) in prob.p.iter().zip(&prob.sw).enumerate() {
        let (a, b) = (eval(&model.den, p), eval(&model.num, p));
        for c in 0..n + m + 1 {
            let d = if c < n {
                b * p.powi((n - 1 - c) as i32) / (a * a)
            } else {
                -p.powi((m - (c - n)) as i32) / a
            };
            j[(2 * i, c)] = sw * d.re;
            j[(2 * i + 1, c)] = sw * d.im;
        }
    }
    j
}

/// Levenberg–Marquardt (Marquardt's diagonal scaling). Returns the
/// parameters, the iterations and whether the relative cost change vanished.
fn levenberg_marquardt(
    prob: &Problem,
    mut theta: Vec<f64>,
    max_iter: usize,
) -> (Vec<f64>, usize, bool) {
    let mut mu = 1e-3;
    let mut v = cost(prob, &theta);
    for it in 1..=max_iter {
        let j = jacobian(prob, &theta);
        let r = residuals(prob, &theta);
        let jtj = j.transpose() * &j;
        let jtr = j.transpose() * Mat::from_fn(r.len(), 1, |i, _| r[i]);
        let mut improved = false;
        while mu < 1e12 {
            let mut lhs = jtj.clone();
            for d in 0..lhs.nrows() {
                lhs[(d, d)] += mu * jtj[(d, d)].max(f64::MIN_POSITIVE);
            }
            let Some(step) = crate::lti::ss::solve(&lhs, &jtr) else {
                mu *= 10.0;
                continue;
            };
            let trial: Vec<f64> = theta
                .iter()
                .enumerate()
                .map(|(i, t)| t - step[(i, 0)])
                .collect();
            let vt = cost(prob, &trial);
            if vt.is_finite() && vt <= v {
                let rel = (v - vt) / v.max(f64::MIN_POSITIVE);
                theta = trial;
                v = vt;
                mu = (mu / 10.0).max(1e-12);
                improved = true;
                if rel < 1e-14 || v == 0.0 {
                    return (theta, it, true);
                }
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            // No step lowers the cost: a (local) minimum to working precision.
            return (theta, it, true);
        }
    }
    (theta, max_iter, false)
}
