//! Output-error identification `y(k) = z^-nk B(q)/F(q) u(k) + v(k)` by
//! Levenberg–Marquardt (MATLAB `oe(data, [nb nf nk])`).
//!
//! The loss is the simulation error `V = 1/N sum (y - y_hat)^2` with
//! `y_hat = z^-nk B/F u` from rest. It is not linear in `F`, so it is
//! minimised iteratively (Ljung, *System Identification*, 10.2). The
//! gradient of the simulated output is two filtered signals:
//! `d y_hat(k)/d b_i = u_F(k - nk - i)`, `d y_hat(k)/d f_i = -y_F(k - i)`
//! with `u_F = u/F`, `y_F = y_hat/F`, so one Jacobian costs two filters.
//!
//! Each iteration reduces `[J | e]` by the streaming QR of
//! [`super::ls`] once (`||J d - e||^2 = ||R11 d - r12||^2 + r22^2`),
//! then tries damped steps `min ||R11 d - r12||^2 + mu ||D d||^2` (Marquardt
//! scaling `D` = column norms of `J`) by the QR of the small stacked matrix
//! `[R11; sqrt(mu) D]`; never the normal equations. A step is accepted when
//! it lowers the loss and keeps `F` stable (an unstable `F` has no
//! meaningful simulation). argmin has no LM (its Gauss–Newton needs the
//! nalgebra backend), so this small solver is written here; progress goes
//! to a caller-supplied observer, never to the terminal.
//!
//! The start is the IV estimate (consistent under output noise, so LM starts
//! near the optimum) or ARX, with unstable roots of `F` reflected.

use super::arx::{ArxParams, Orders, arx};
use super::iv::{IvParams, iv};
use super::linear::{
    Criteria, IdentError, PolyModel, check_excited, check_signals, filter_ab, stabilize,
};
use super::ls::{DEFAULT_BLOCK_ROWS, solve_triangle, std_devs, triangularize};

/// Where the iteration starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OeStart {
    /// Whichever of IV and ARX simulates the data better (default): IV is
    /// consistent under output noise, but on short records of lightly
    /// damped systems its iteration can wander while ARX is close.
    #[default]
    Best,
    /// Refined IV: consistent under output noise.
    Iv,
    /// Plain ARX: biased under output noise.
    Arx,
}

/// Settings of [`oe`].
#[derive(Debug, Clone)]
pub struct OeParams {
    /// `nb`, `nf` (as `na`) and `nk`.
    pub orders: Orders,
    /// Sample time (seconds); default 1.
    pub ts: f64,
    /// Start estimate (default [`OeStart::Best`]).
    pub start: OeStart,
    /// Estimate the initial conditions together with the model (default
    /// true, MATLAB `InitialCondition = 'estimate'`): the simulation then
    /// starts from the state that fits the record, so a record that begins
    /// mid-motion does not bias `B/F` through the start-up transient. They
    /// enter as weights `c_j` of `h(k - j)`, `h` the impulse response of
    /// `1/F`, `j < max(nf, nb + nk - 1)`.
    pub estimate_initial: bool,
    /// Maximum LM iterations (default 100).
    pub max_iterations: usize,
    /// Stop when the relative loss decrease of an accepted step is below
    /// this (default 1e-10).
    pub tolerance: f64,
    /// Initial damping `mu` (default 1e-4).
    pub initial_damping: f64,
}

impl OeParams {
    /// Defaults for `[nb nf nk]` given as `Orders { na: nf, nb, nk }`.
    pub fn new(orders: Orders) -> Self {
        OeParams {
            orders,
            ts: 1.0,
            start: OeStart::Best,
            estimate_initial: true,
            max_iterations: 100,
            tolerance: 1e-10,
            initial_damping: 1e-4,
        }
    }
}

/// What the observer sees after each iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OeProgress {
    /// Iteration number (1-based).
    pub iteration: usize,
    /// Loss `V` after the iteration.
    pub loss: f64,
    /// Damping in use.
    pub damping: f64,
    /// Norm of the accepted step (0 when none was found).
    pub step_norm: f64,
}

/// The OE estimate with its diagnostics.
#[derive(Debug, Clone)]
pub struct OeEstimate {
    /// `z^-nk B/F` (`a` holds `F`).
    pub model: PolyModel,
    /// Estimated initial conditions (see [`OeParams::estimate_initial`];
    /// empty when not estimated). `model.simulate_ic(u, ic)` reproduces the
    /// fitted output.
    pub initial_conditions: Vec<f64>,
    /// Standard deviations of `f1 .. f_nf`.
    pub std_f: Vec<f64>,
    /// Standard deviations of `b0 ..`.
    pub std_b: Vec<f64>,
    /// `||e||^2 / (N - d)`.
    pub noise_variance: f64,
    /// Loss and criteria of the simulation error.
    pub criteria: Criteria,
    /// Condition number of the Jacobian at the optimum.
    pub condition_number: f64,
    /// Loss of the start estimate.
    pub start_loss: f64,
    /// LM iterations done.
    pub iterations: usize,
    /// Whether a stopping tolerance was met (otherwise the iteration cap).
    pub converged: bool,
}

/// Model and initial conditions as one parameter vector `[f, b, c]`.
fn theta_of(m: &PolyModel, ic: &[f64]) -> Vec<f64> {
    m.a[1..].iter().chain(&m.b).chain(ic).copied().collect()
}

fn model_of(theta: &[f64], o: Orders, ts: f64) -> (PolyModel, Vec<f64>) {
    let mut a = vec![1.0];
    a.extend_from_slice(&theta[..o.na]);
    let d = o.params();
    (
        PolyModel {
            a,
            b: theta[o.na..d].to_vec(),
            nk: o.nk,
            ts,
        },
        theta[d..].to_vec(),
    )
}

fn loss_of(m: &PolyModel, ic: &[f64], u: &[f64], y: &[f64]) -> (f64, Vec<f64>) {
    let sim = m.simulate_ic(u, ic);
    let sse: f64 = y.iter().zip(&sim).map(|(a, b)| (a - b).powi(2)).sum();
    (sse / y.len() as f64, sim)
}

/// Triangle of `[J | e]` with `J = d y_hat / d [f, b, c]`, `e = y - y_hat`.
fn jacobian_triangle(
    m: &PolyModel,
    nic: usize,
    u: &[f64],
    y: &[f64],
    sim: &[f64],
) -> super::ls::Triangle {
    let na = m.na();
    let d = na + m.nb();
    let uf = filter_ab(&[1.0], &m.a, 0, u);
    let yf = filter_ab(&[1.0], &m.a, 0, sim);
    let mut imp = vec![0.0; y.len()];
    if let Some(first) = imp.first_mut() {
        *first = 1.0;
    }
    let h = filter_ab(&[1.0], &m.a, 0, &imp);
    let nk = m.nk;
    triangularize(d + nic + 1, y.len(), DEFAULT_BLOCK_ROWS, |j, s, out| {
        // Shifted copy `sign * src(k - lag)`, zero before the record.
        let shifted = |out: &mut [f64], src: &[f64], lag: usize, sign: f64| {
            for (r, o) in out.iter_mut().enumerate() {
                let k = s + r;
                *o = if k >= lag { sign * src[k - lag] } else { 0.0 };
            }
        };
        if j < na {
            shifted(out, &yf, j + 1, -1.0);
        } else if j < d {
            shifted(out, &uf, nk + j - na, 1.0);
        } else if j < d + nic {
            shifted(out, &h, j - d, 1.0);
        } else {
            for (r, o) in out.iter_mut().enumerate() {
                *o = y[s + r] - sim[s + r];
            }
        }
    })
}

/// Output-error estimate of `z^-nk B/F` (orders: `na` is `nf`).
pub fn oe(
    u: &[f64],
    y: &[f64],
    params: &OeParams,
    observer: &mut dyn FnMut(&OeProgress),
) -> Result<OeEstimate, IdentError> {
    check_signals(u, y)?;
    let o = params.orders;
    o.check()?;
    check_excited(u)?;
    let n = y.len();
    let d = o.params();
    let nic = if params.estimate_initial {
        o.memory().min(n / 4)
    } else {
        0
    };
    // Each candidate start, stabilised, with its fitted initial conditions.
    let prepare = |mut m: PolyModel| {
        m.a = stabilize(&m.a);
        let mut ic = if nic > 0 {
            m.initial_conditions(u, y)
        } else {
            Vec::new()
        };
        ic.resize(nic, 0.0);
        let (l, _) = loss_of(&m, &ic, u, y);
        (m, ic, l)
    };
    let arx_start = || {
        let mut p = ArxParams::new(o);
        p.ts = params.ts;
        arx(u, y, &p).map(|e| prepare(e.model))
    };
    let iv_start = || {
        let mut p = IvParams::new(o);
        p.ts = params.ts;
        iv(u, y, &p).map(|e| prepare(e.model))
    };
    let (mut model, mut ic, _) = match params.start {
        OeStart::Iv => iv_start()?,
        OeStart::Arx => arx_start()?,
        OeStart::Best => {
            let a = arx_start()?;
            match iv_start() {
                Ok(i) if i.2 <= a.2 || !a.2.is_finite() => i,
                _ => a,
            }
        }
    };
    if n <= d.saturating_add(nic) {
        return Err(IdentError::TooShort {
            samples: n,
            rows: n,
            needed: d.saturating_add(nic).saturating_add(1),
            params: d,
            orders: o.to_string(),
        });
    }
    let (mut loss, mut sim) = loss_of(&model, &ic, u, y);
    let start_loss = loss;
    let dt = d + nic;
    let mut mu = params.initial_damping;
    let mut iterations = 0;
    let mut converged = false;
    while iterations < params.max_iterations {
        iterations += 1;
        let tri = jacobian_triangle(&model, nic, u, y, &sim);
        let theta = theta_of(&model, &ic);
        let scale: Vec<f64> = (0..dt)
            .map(|j| {
                (0..=j)
                    .map(|i| tri.r[(i, j)].powi(2))
                    .sum::<f64>()
                    .sqrt()
                    .max(f64::MIN_POSITIVE)
            })
            .collect();
        let mut accepted = None;
        for _ in 0..30 {
            // Damped step from [R11; sqrt(mu) D] d = [r12; 0].
            let sq = mu.sqrt();
            let small = triangularize(dt + 1, 2 * dt, 2 * dt, |j, s, out| {
                for (r, o) in out.iter_mut().enumerate() {
                    let i = s + r;
                    *o = if i < dt {
                        if i <= j { tri.r[(i, j)] } else { 0.0 }
                    } else if j == i - dt {
                        sq * scale[j]
                    } else {
                        0.0
                    };
                }
            });
            let Ok(step) = solve_triangle(&small) else {
                mu *= 10.0;
                continue;
            };
            let trial: Vec<f64> = theta.iter().zip(&step.theta).map(|(a, b)| a + b).collect();
            let (cand, cand_ic) = model_of(&trial, o, params.ts);
            if cand.is_stable() {
                let (l, s) = loss_of(&cand, &cand_ic, u, y);
                if l.is_finite() && l < loss {
                    let norm = step.theta.iter().map(|v| v * v).sum::<f64>().sqrt();
                    accepted = Some((cand, cand_ic, l, s, norm));
                    break;
                }
            }
            mu *= 10.0;
            if mu > 1e12 {
                break;
            }
        }
        match accepted {
            Some((cand, cand_ic, l, s, norm)) => {
                let rel = (loss - l) / loss.max(f64::MIN_POSITIVE);
                model = cand;
                ic = cand_ic;
                loss = l;
                sim = s;
                mu = (mu / 10.0).max(1e-12);
                observer(&OeProgress {
                    iteration: iterations,
                    loss,
                    damping: mu,
                    step_norm: norm,
                });
                let tnorm = theta.iter().map(|v| v * v).sum::<f64>().sqrt();
                if rel < params.tolerance || norm <= 1e-12 * (1.0 + tnorm) {
                    converged = true;
                    break;
                }
            }
            None => {
                // No descent direction left at any damping: a (local) minimum.
                observer(&OeProgress {
                    iteration: iterations,
                    loss,
                    damping: mu,
                    step_norm: 0.0,
                });
                converged = true;
                break;
            }
        }
    }
    let tri = jacobian_triangle(&model, nic, u, y, &sim);
    let sse = loss * n as f64;
    // The initial conditions are parameters too: they use up degrees of
    // freedom and their uncertainty widens that of B and F.
    let lambda = sse / (n - dt) as f64;
    let (sd, cond) = match solve_triangle(&tri) {
        Ok(sol) => (std_devs(&sol.r_inv, lambda), sol.condition_number),
        Err(_) => (vec![f64::NAN; dt], f64::INFINITY),
    };
    Ok(OeEstimate {
        std_f: sd[..o.na].to_vec(),
        std_b: sd[o.na..d].to_vec(),
        model,
        initial_conditions: ic,
        noise_variance: lambda,
        criteria: Criteria::new(loss, n, d),
        condition_number: cond,
        start_loss,
        iterations,
        converged,
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::linear::filter_ab;
    use crate::ident::testutil::{chirp, noise};
    use crate::lti::{DiscreteTf, linspace};

    /// Max relative error of the model's frequency response against the
    /// truth on 0..=1000 Hz.
    fn max_rel_err(m: &PolyModel, truth: &DiscreteTf) -> f64 {
        let g = m.tf().unwrap();
        linspace(0.0, 1000.0, 201)
            .iter()
            .map(|&f| {
                let t = truth.response_at_hz(f);
                (g.response_at_hz(f) - t).norm() / t.norm()
            })
            .fold(0.0, f64::max)
    }

    pub fn output_noise_biases_arx_but_not_iv_or_oe() {
        // [Li21] Eq. 11 driven by a 0-1 kHz sweep (Ts = 1e-4 s), white
        // measurement noise of std 1e-3 on y (the scenario).
        let b = vec![4.154, -9.631, 10.23, -5.511, 1.154];
        let a = vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447];
        let truth = DiscreteTf::new(b.clone(), a.clone(), 5, 1e-4).unwrap();
        let n = 20_000;
        let u = chirp(n, 1e-4, 1000.0);
        let clean = filter_ab(&b, &a, 5, &u);
        let v = noise(n, 21);
        let y: Vec<f64> = clean.iter().zip(&v).map(|(c, e)| c + 1e-3 * e).collect();
        let o = Orders::new(5, 5, 5);

        let mut ap = ArxParams::new(o);
        ap.ts = 1e-4;
        let est_arx = arx(&u, &y, &ap).unwrap();
        let arx_err = max_rel_err(&est_arx.model, &truth);
        // ARX is biased: a1 is pulled far from -0.785, by many times the
        // standard deviation ARX itself reports.
        let z = (est_arx.model.a[1] - a[1]) / est_arx.std_a[0];
        assert!(
            (est_arx.model.a[1] - a[1]).abs() > 0.1,
            "ARX a1 {}",
            est_arx.model.a[1]
        );
        assert!(z.abs() > 10.0, "ARX a1 bias only {z} std devs");
        // ... and its residual test says so.
        let e = crate::ident::arx::arx_residuals(&est_arx.model, &u, &y, est_arx.start);
        assert!(!crate::ident::linear::whiteness(&e, &u[est_arx.start..], 25).white);
        eprintln!(
            "ARX a1 {} ({z:.0} std devs off), max rel err 0-1 kHz {arx_err}",
            est_arx.model.a[1]
        );

        let mut ip = IvParams::new(o);
        ip.ts = 1e-4;
        let est_iv = iv(&u, &y, &ip).unwrap();
        let iv_err = max_rel_err(&est_iv.model, &truth);
        assert!(iv_err < 0.01, "IV max rel err {iv_err}");

        let mut op = OeParams::new(o);
        op.ts = 1e-4;
        let mut seen = 0;
        let est_oe = oe(&u, &y, &op, &mut |_| seen += 1).unwrap();
        let oe_err = max_rel_err(&est_oe.model, &truth);
        assert!(oe_err < 0.01, "OE max rel err {oe_err}");
        assert!(est_oe.converged && seen > 0);
        // OE residual variance is the measurement noise variance.
        assert!((est_oe.noise_variance / 1e-6 - 1.0).abs() < 0.05);
        eprintln!(
            "ARX a1 {:.4} max err {:.2} %; IV a1 {:.5} err {:.3} %; OE a1 {:.5} err {:.3} % ({} it)",
            est_arx.model.a[1],
            100.0 * arx_err,
            est_iv.model.a[1],
            100.0 * iv_err,
            est_oe.model.a[1],
            100.0 * oe_err,
            est_oe.iterations
        );
    }

    pub fn oe_from_arx_start_converges_too() {
        // A second-order system with output noise, started from the biased
        // ARX estimate: LM still reaches the truth.
        let (b, a) = (vec![0.5, 0.3], vec![1.0, -1.5, 0.7]);
        let n = 4000;
        let u = noise(n, 5);
        let clean = filter_ab(&b, &a, 1, &u);
        let y: Vec<f64> = clean
            .iter()
            .zip(noise(n, 6))
            .map(|(c, e)| c + 0.3 * e)
            .collect();
        let mut p = OeParams::new(Orders::new(2, 2, 1));
        p.start = OeStart::Arx;
        let est = oe(&u, &y, &p, &mut |_| {}).unwrap();
        for (x, t) in est.model.a.iter().zip(&a).skip(1) {
            assert!((x - t).abs() < 0.02, "{x} vs {t}");
        }
        for (i, (x, t)) in est.model.b.iter().zip(&b).enumerate() {
            assert!((x - t).abs() < 4.0 * est.std_b[i], "{x} vs {t}");
        }
        assert!(est.criteria.loss < est.start_loss);
    }

    pub fn broadband_output_noise_arx_coefficients_biased_oe_iv_not() {
        // Same plant and noise level, white input over the whole band: now
        // every coefficient is identifiable, ARX's bias exceeds its own
        // standard deviations many times over, IV and OE land within a few.
        let b = vec![4.154, -9.631, 10.23, -5.511, 1.154];
        let a = vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447];
        let n = 20_000;
        let u = noise(n, 31);
        let clean = filter_ab(&b, &a, 5, &u);
        let y: Vec<f64> = clean
            .iter()
            .zip(noise(n, 32))
            .map(|(c, e)| c + 1e-3 * e)
            .collect();
        let o = Orders::new(5, 5, 5);
        let est_arx = arx(&u, &y, &ArxParams::new(o)).unwrap();
        let est_iv = iv(&u, &y, &IvParams::new(o)).unwrap();
        let est_oe = oe(&u, &y, &OeParams::new(o), &mut |_| {}).unwrap();
        let z = |x: f64, t: f64, s: f64| (x - t) / s;
        let z_arx = z(est_arx.model.a[1], a[1], est_arx.std_a[0]);
        let z_iv = z(est_iv.model.a[1], a[1], est_iv.std_a[0]);
        let z_oe = z(est_oe.model.a[1], a[1], est_oe.std_f[0]);
        eprintln!(
            "broadband: ARX a1 {:.5} (z {z_arx:.1}), IV a1 {:.5} (z {z_iv:.1}), OE a1 {:.5} (z {z_oe:.1})",
            est_arx.model.a[1], est_iv.model.a[1], est_oe.model.a[1]
        );
        assert!(z_arx.abs() > 10.0);
        for i in 0..5 {
            assert!(z(est_oe.model.a[i + 1], a[i + 1], est_oe.std_f[i]).abs() < 4.0);
            assert!(z(est_oe.model.b[i], b[i], est_oe.std_b[i]).abs() < 4.0);
            assert!(z(est_iv.model.a[i + 1], a[i + 1], est_iv.std_a[i]).abs() < 4.0);
        }
    }

    pub fn oe_and_iv_std_devs_match_monte_carlo_spread() {
        // Output-error data, 200 realisations: OE (the maximum-likelihood
        // estimator here) and IV report standard deviations that match the
        // observed spread (within the ~5 % sampling error of 200 runs; SRIV
        // converges to the OE optimum here, so the two agree).
        let (b, a) = (vec![0.5, 0.3], vec![1.0, -1.5, 0.7]);
        let n = 1000;
        let u = noise(n, 200);
        let clean = filter_ab(&b, &a, 1, &u);
        let runs = 200;
        let o = Orders::new(2, 2, 1);
        let (mut oe_a1, mut iv_a1) = (Vec::new(), Vec::new());
        let (mut oe_sd, mut iv_sd) = (0.0, 0.0);
        for r in 0..runs {
            let y: Vec<f64> = clean
                .iter()
                .zip(noise(n, 5000 + r))
                .map(|(c, e)| c + 0.2 * e)
                .collect();
            let fo = oe(&u, &y, &OeParams::new(o), &mut |_| {}).unwrap();
            let fi = iv(&u, &y, &IvParams::new(o)).unwrap();
            oe_a1.push(fo.model.a[1]);
            iv_a1.push(fi.model.a[1]);
            oe_sd += fo.std_f[0] / runs as f64;
            iv_sd += fi.std_a[0] / runs as f64;
        }
        let spread = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (
                m,
                (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt(),
            )
        };
        let (m_oe, s_oe) = spread(&oe_a1);
        let (m_iv, s_iv) = spread(&iv_a1);
        eprintln!(
            "OE a1 mean {m_oe:.5} sd {s_oe:.5} (reported {oe_sd:.5}); IV a1 mean {m_iv:.5} sd {s_iv:.5} (reported {iv_sd:.5})"
        );
        assert!(
            (0.8..1.25).contains(&(s_oe / oe_sd)),
            "OE {s_oe} vs {oe_sd}"
        );
        assert!(
            (0.8..1.25).contains(&(s_iv / iv_sd)),
            "IV {s_iv} vs {iv_sd}"
        );
        // Unbiased: the mean is within 4 standard errors of the truth.
        assert!((m_oe - a[1]).abs() < 4.0 * s_oe / (runs as f64).sqrt());
        assert!((m_iv - a[1]).abs() < 4.0 * s_iv / (runs as f64).sqrt());
    }
}

/// The outcome of [`refine_arx`]: the output-error model tried from an ARX
/// estimate, and whether it replaces it.
#[derive(Debug, Clone)]
pub struct OeRefinement {
    /// The OE estimate, when the iteration ran (`None`: it failed).
    pub oe: Option<OeEstimate>,
    /// Its simulation and prediction fits on the record.
    pub oe_fit: Option<super::linear::Fits>,
    /// The ARX model's fits on the record.
    pub arx_fit: super::linear::Fits,
    /// Whether the OE model is kept instead of the ARX model.
    pub chosen: bool,
    /// Which model was kept and why, in words.
    pub reason: String,
}

/// ARX, then an output-error refinement of the same orders kept only when
/// it is stable, realisable and simulates the record better than the ARX
/// model: what `fts demo` and a pipeline `arx` step with `refine_oe` do.
pub fn refine_arx(arx_model: &PolyModel, u: &[f64], y: &[f64], params: &OeParams) -> OeRefinement {
    use super::linear::{NoiseModel, fits};
    let arx_fit = fits(arx_model, NoiseModel::Arx, u, y);
    let mut out = OeRefinement {
        oe: None,
        oe_fit: None,
        arx_fit,
        chosen: false,
        reason: String::from("ARX kept: the output-error refinement did not converge"),
    };
    let Ok(o) = oe(u, y, params, &mut |_| {}) else {
        return out;
    };
    let f = fits(&o.model, NoiseModel::OutputError, u, y);
    out.reason = match o.model.tf() {
        Err(e) => format!("ARX kept: the OE model is unusable ({e})"),
        Ok(_) if !o.model.is_stable() => String::from("ARX kept: the OE model is unstable"),
        Ok(_) if f.simulation_percent > arx_fit.simulation_percent => {
            out.chosen = true;
            format!(
                "OE chosen: simulation fit {:.2} % against ARX {:.2} %",
                f.simulation_percent, arx_fit.simulation_percent
            )
        }
        Ok(_) => format!(
            "ARX kept: OE did not improve the simulation fit ({:.2} % against {:.2} %)",
            f.simulation_percent, arx_fit.simulation_percent
        ),
    };
    out.oe = Some(o);
    out.oe_fit = Some(f);
    out
}
