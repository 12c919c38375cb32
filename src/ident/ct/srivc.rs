//! SRIVC: simplified refined instrumental variable estimation of a
//! continuous-time transfer function from sampled data (Young & Jakeman
//! 1980, "Refined instrumental variable methods of time-series analysis:
//! Part III, extensions", Int. J. Control 31; the algorithm as in Garnier,
//! Mensler & Richard 2003, Int. J. Control 76, §3.2).
//!
//! With `A y = B u(t - tau)` and a prefilter `1/A_hat(p)`, every signal is
//! replaced by its filtered derivatives `x_f^(i) = p^i / A_hat(p) x`, and
//! `y_f^(n) = -a_1 y_f^(n-1) - ... - a_n y_f + b_0 u_f^(m) + ... + b_m u_f`
//! is solved by instrumental variables, the instruments being the same
//! filtered derivatives of the noise-free output `B_hat/A_hat u`. The
//! estimate updates `A_hat` and the next iteration refilters. The filters are
//! sampled exactly for a zero-order-hold input (module `zoh`), so the true
//! parameters are an exact fixed point of the iteration on noise-free data.
//! The first `A_hat` comes from state-variable filter least squares
//! (`A_hat = (p + 1)^n` in time scaled by a cutoff `w_c`), tried at several
//! cutoffs, the best simulation fit kept.

use super::zoh::DelayedFilter;
use super::{CtError, CtModel, check_delay, check_orders, rel_change, stabilised};
use crate::ident::ls::{LstsqParams, lstsq};
use faer::Mat;

/// Settings of [`srivc`].
#[derive(Debug, Clone, PartialEq)]
pub struct SrivcParams {
    /// Poles (degree of `A`).
    pub np: usize,
    /// Zeros (degree of `B`, `<= np`).
    pub nz: usize,
    /// Sample time, s.
    pub ts: f64,
    /// Known input delay, s. Default 0.
    pub delay: f64,
    /// State-variable-filter cutoff of the start estimate, Hz. Default
    /// `None`: six cutoffs log-spaced over `[0.002, 0.2] / ts` are tried.
    pub svf_cutoff_hz: Option<f64>,
    /// SRIVC iteration cap. Default 50.
    pub max_iterations: usize,
    /// Converged when the relative parameter change is below this. Default 1e-10.
    pub tolerance: f64,
}

impl SrivcParams {
    /// Defaults for the given orders and sample time.
    pub fn new(np: usize, nz: usize, ts: f64) -> SrivcParams {
        SrivcParams {
            np,
            nz,
            ts,
            delay: 0.0,
            svf_cutoff_hz: None,
            max_iterations: 50,
            tolerance: 1e-10,
        }
    }

    fn cutoffs_hz(&self) -> Vec<f64> {
        match self.svf_cutoff_hz {
            Some(f) => vec![f],
            None => (0..6)
                .map(|i| 0.002 / self.ts * 100f64.powf(i as f64 / 5.0))
                .collect(),
        }
    }
}

/// One start cutoff tried.
#[derive(Debug, Clone, PartialEq)]
pub struct SvfTrial {
    /// Cutoff, Hz.
    pub cutoff_hz: f64,
    /// Simulation fit of the SRIVC result from it, percent (NaN when it failed).
    pub fit_percent: f64,
    /// SRIVC iterations.
    pub iterations: usize,
    /// Whether they converged.
    pub converged: bool,
}

/// The estimate with its diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct SrivcEstimate {
    /// The model (delay as given).
    pub model: CtModel,
    /// Iterations of the kept run.
    pub iterations: usize,
    /// Whether the kept run converged.
    pub converged: bool,
    /// The start cutoff of the kept run, Hz.
    pub svf_cutoff_hz: f64,
    /// Simulation fit on the estimation data, percent.
    pub fit_percent: f64,
    /// Every start tried.
    pub trials: Vec<SvfTrial>,
}

/// Identifies `e^(-s tau) B(s)/A(s)` from `u`, `y` sampled every `ts`.
pub fn srivc(u: &[f64], y: &[f64], p: &SrivcParams) -> Result<SrivcEstimate, CtError> {
    check_orders(p.np, p.nz)?;
    check_delay(p.delay)?;
    if !(p.ts.is_finite() && p.ts > 0.0) {
        return Err(CtError::Setting {
            field: "ts",
            message: format!("expected a positive sample time, got {}", p.ts),
        });
    }
    crate::ident::linear::check_signals(u, y).map_err(|e| CtError::Data(e.to_string()))?;
    let mut best: Option<SrivcEstimate> = None;
    let mut trials = Vec::new();
    let mut last_error = None;
    for fc in p.cutoffs_hz() {
        match run_from(u, y, p, fc) {
            Ok(est) => {
                trials.push(trial(&est));
                if best.as_ref().is_none_or(|b| better(&est, b)) {
                    best = Some(est);
                }
            }
            Err(e) => {
                trials.push(SvfTrial {
                    cutoff_hz: fc,
                    fit_percent: f64::NAN,
                    iterations: 0,
                    converged: false,
                });
                last_error = Some(e);
            }
        }
    }
    let mut best = best.ok_or_else(|| last_error.expect("at least one cutoff tried"))?;
    best.trials = trials;
    Ok(best)
}

fn trial(e: &SrivcEstimate) -> SvfTrial {
    SvfTrial {
        cutoff_hz: e.svf_cutoff_hz,
        fit_percent: e.fit_percent,
        iterations: e.iterations,
        converged: e.converged,
    }
}

/// Stable before unstable, then the better fit. Starts that converge to
/// the same model fit alike up to rounding: a fit better by less than
/// [`FIT_TIE_PERCENT`] does not displace the start tried first, so the
/// choice does not hang on the last bits of the fit's sums.
fn better(a: &SrivcEstimate, b: &SrivcEstimate) -> bool {
    let (sa, sb) = (a.model.is_stable(), b.model.is_stable());
    if sa != sb {
        return sa;
    }
    a.fit_percent > b.fit_percent + FIT_TIE_PERCENT || b.fit_percent.is_nan()
}

/// Fits (in percent) closer than this are one fit to [`better`].
const FIT_TIE_PERCENT: f64 = 1e-6;

/// SVF least squares then SRIVC, in time scaled by `w = 2 pi fc`.
fn run_from(u: &[f64], y: &[f64], p: &SrivcParams, fc: f64) -> Result<SrivcEstimate, CtError> {
    let w = 2.0 * std::f64::consts::PI * fc;
    let (h, delay) = (w * p.ts, w * p.delay);
    let svf = binomial_monic(p.np);
    let start = regression(&svf, u, y, None, p, h, delay)?;
    let mut theta = start;
    let (mut iterations, mut converged) = (0, false);
    while iterations < p.max_iterations {
        iterations += 1;
        let model = model_of(&theta, p, delay);
        let den = stabilised(&model.den);
        let instrument = super::zoh::simulate(&model.num, &den, h, delay, u);
        let next = regression(&den, u, y, Some(&instrument), p, h, delay)?;
        let change = rel_change(&next, &theta);
        theta = next;
        if change < p.tolerance {
            converged = true;
            break;
        }
    }
    let model = model_of(&theta, p, delay).unscaled(w);
    let fit_percent = super::time_fit_percent(&model, u, y, p.ts);
    Ok(SrivcEstimate {
        model,
        iterations,
        converged,
        svf_cutoff_hz: fc,
        fit_percent,
        trials: Vec::new(),
    })
}

/// `(p + 1)^n`, descending.
fn binomial_monic(n: usize) -> Vec<f64> {
    (0..n).fold(vec![1.0], |acc, _| {
        let mut next = acc.clone();
        next.push(0.0);
        for i in 1..next.len() {
            next[i] += acc[i - 1];
        }
        next
    })
}

/// `theta = [a_1..a_n, b_0..b_m]` as a model in scaled time.
fn model_of(theta: &[f64], p: &SrivcParams, delay: f64) -> CtModel {
    let mut den = vec![1.0];
    den.extend_from_slice(&theta[..p.np]);
    CtModel {
        den,
        num: theta[p.np..].to_vec(),
        delay,
    }
}

/// One filtered regression with prefilter `1/F`: least squares when
/// `instrument` is `None`, instrumental variables otherwise.
fn regression(
    f: &[f64],
    u: &[f64],
    y: &[f64],
    instrument: Option<&[f64]>,
    p: &SrivcParams,
    h: f64,
    delay: f64,
) -> Result<Vec<f64>, CtError> {
    let n = p.np;
    let plain = DelayedFilter::new(f, h, 0.0);
    let yf = plain.derivatives(y);
    let uf = DelayedFilter::new(f, h, delay).derivatives(u);
    let xf = instrument.map(|x| plain.derivatives(x));
    let rows = u.len();
    let cols = n + p.nz + 1;
    // Column c: -D^(n-1-c) of y (c < n), then D^(m-j) of u.
    let column = |d: &[f64], uf: &[f64], k: usize, c: usize| -> f64 {
        if c < n {
            -d[k * (n + 1) + n - 1 - c]
        } else {
            uf[k * (n + 1) + p.nz - (c - n)]
        }
    };
    let phi = Mat::from_fn(rows, cols, |k, c| column(&yf, &uf, k, c));
    let target: Vec<f64> = (0..rows).map(|k| yf[k * (n + 1) + n]).collect();
    match xf {
        None => lstsq(phi.as_ref(), &target, &LstsqParams::default())
            .map(|s| s.theta)
            .map_err(|e| CtError::Numerical(format!("state-variable-filter least squares: {e}"))),
        Some(xf) => {
            let zeta = Mat::from_fn(rows, cols, |k, c| column(&xf, &uf, k, c));
            iv_solve(&zeta, &phi, &target)
        }
    }
}

/// `theta = (Z^T Phi)^-1 Z^T t`, the normal matrix equilibrated by the
/// column norms of `Z` and `Phi` before its LU solve (the raw matrix spans
/// many decades when the poles do).
fn iv_solve(zeta: &Mat<f64>, phi: &Mat<f64>, target: &[f64]) -> Result<Vec<f64>, CtError> {
    let cols = phi.ncols();
    let norm = |m: &Mat<f64>, c: usize| m.col(c).norm_l2().max(f64::MIN_POSITIVE);
    let dz: Vec<f64> = (0..cols).map(|c| 1.0 / norm(zeta, c)).collect();
    let dp: Vec<f64> = (0..cols).map(|c| 1.0 / norm(phi, c)).collect();
    let m = zeta.transpose() * phi;
    let scaled = Mat::from_fn(cols, cols, |i, j| dz[i] * m[(i, j)] * dp[j]);
    let t = Mat::from_fn(target.len(), 1, |k, _| target[k]);
    let zt = zeta.transpose() * &t;
    let rhs = Mat::from_fn(cols, 1, |i, _| dz[i] * zt[(i, 0)]);
    let x = fts_kernels::dense::lu_solve(scaled.as_ref(), rhs.as_ref());
    let theta: Vec<f64> = (0..cols).map(|i| dp[i] * x[(i, 0)]).collect();
    if theta.iter().all(|v| v.is_finite()) {
        Ok(theta)
    } else {
        Err(CtError::Numerical(
            "SRIVC: the instrumental-variable matrix is singular (the input does not excite every parameter)".into(),
        ))
    }
}
