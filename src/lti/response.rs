//! Step and impulse responses of state-space systems on a uniform time
//! grid, and the step-response figures of MATLAB `stepinfo` /
//! python-control `step_info` read from samples (docs/responses.md). The
//! figures `fts response` reports for a continuous system come from the
//! response itself instead ([`super::exact_response`]): samples miss what
//! happens between them.
//!
//! A continuous system is discretised exactly for a piecewise-constant
//! input by the zero-order hold ([`super::c2d`], Van Loan's block
//! exponential) at the grid step, so a step response is exact at every
//! grid point (python-control's `forced_response` does the same). A
//! discrete system runs at its own sample time.
//!
//! Impulse responses follow python-control and MATLAB: a continuous impulse
//! is the free response from `x(0) = B` (the Dirac part `D delta(t)` is
//! not representable and is left out; [`TimeResponse::impulse_drops_d`]
//! says so); a discrete impulse is the unit-area pulse `u[0] = 1/ts`.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c2d::{C2dMethod, c2d};
use super::ss::{SsError, StateSpace};
use serde::Serialize;

/// The most samples of one response (the grid length).
pub const MAX_RESPONSE_SAMPLES: usize = 1_000_000;
/// The most stored values of a response: samples x outputs x inputs.
pub const MAX_RESPONSE_VALUES: usize = 20_000_000;

/// Step or impulse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ResponseKind {
    /// Unit step applied at `t = 0`.
    #[default]
    Step,
    /// Unit impulse at `t = 0` (unit-area pulse `1/ts` for discrete systems).
    Impulse,
}

/// Why a response cannot be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResponseError {
    /// A grid setting is out of range.
    #[error("{0}")]
    BadGrid(String),
    /// Discretisation or eigenvalues failed.
    #[error("{0}")]
    Ss(#[from] SsError),
}

/// A uniform time grid `t_k = k dt`, `k = 0..n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeGrid {
    /// Step in seconds (the sample time of a discrete system).
    pub dt: f64,
    /// Number of samples, at least 2.
    pub n: usize,
}

impl TimeGrid {
    /// The grid of `n` points from 0 to `t_final` (continuous systems;
    /// `numpy.linspace(0, t_final, n)`).
    pub fn continuous(t_final: f64, n: usize) -> Result<Self, ResponseError> {
        if !(t_final.is_finite() && t_final > 0.0) {
            return Err(ResponseError::BadGrid(format!(
                "the duration must be a positive number of seconds, got {t_final}"
            )));
        }
        check_samples(n)?;
        Ok(Self {
            dt: t_final / (n - 1) as f64,
            n,
        })
    }

    /// Samples `0, ts, ..` up to and including the first one at or beyond
    /// `t_final` (discrete systems; python-control rounds the same way).
    pub fn discrete(t_final: f64, ts: f64) -> Result<Self, ResponseError> {
        if !(t_final.is_finite() && t_final > 0.0) {
            return Err(ResponseError::BadGrid(format!(
                "the duration must be a positive number of seconds, got {t_final}"
            )));
        }
        let steps = (t_final / ts - 1e-9).ceil().max(1.0);
        if !(steps < MAX_RESPONSE_SAMPLES as f64) {
            return Err(ResponseError::BadGrid(format!(
                "{t_final} s at ts = {ts} s is {steps} samples, more than {MAX_RESPONSE_SAMPLES}"
            )));
        }
        Ok(Self {
            dt: ts,
            n: steps as usize + 1,
        })
    }

    /// The time of sample `k` (`k dt`; the last point of a continuous
    /// grid is `t_final` up to rounding, as in numpy).
    pub fn time(&self, k: usize) -> f64 {
        k as f64 * self.dt
    }

    /// All sample times.
    pub fn times(&self) -> Vec<f64> {
        (0..self.n).map(|k| self.time(k)).collect()
    }
}

fn check_samples(n: usize) -> Result<(), ResponseError> {
    if (2..=MAX_RESPONSE_SAMPLES).contains(&n) {
        Ok(())
    } else {
        Err(ResponseError::BadGrid(format!(
            "the number of samples must be from 2 to {MAX_RESPONSE_SAMPLES}, got {n}"
        )))
    }
}

/// A default horizon in seconds: long enough for the slowest stable mode to
/// decay to 0.1 % (`ln(1000)/|Re p|`, python-control's rule without its
/// modal-relevance filter), 5 cycles of an undamped mode, at least 5 time
/// constants of nothing (a static gain: 1 s), and five times longer with
/// an integrator.
pub fn default_duration(sys: &StateSpace) -> Result<f64, SsError> {
    let poles = sys.poles()?;
    let ln1000 = 1000f64.ln();
    let mut t: f64 = 0.0;
    let mut integrator = false;
    for p in &poles {
        // Continuous-time equivalent of a discrete pole: ln(z)/ts.
        let s = match sys.ts {
            None => *p,
            Some(ts) if p.norm() > 0.0 => p.ln() / ts,
            Some(_) => continue,
        };
        if s.norm() < 1e-12 {
            integrator = true;
        } else if s.re.abs() < 1e-9 * s.norm() {
            t = t.max(5.0 * 2.0 * std::f64::consts::PI / s.im.abs());
        } else {
            t = t.max(ln1000 / s.re.abs());
        }
    }
    if t == 0.0 {
        t = sys.ts.map_or(1.0, |ts| 20.0 * ts);
    }
    Ok(if integrator { 5.0 * t } else { t })
}

/// A simulated response: `y[i][j][k]` is output `i` at sample `k` for the
/// step or impulse on input `j`.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeResponse {
    /// Step or impulse.
    pub kind: ResponseKind,
    /// The grid.
    pub grid: TimeGrid,
    /// Outputs x inputs x samples.
    pub y: Vec<Vec<Vec<f64>>>,
    /// A continuous impulse response with `D != 0` omits the Dirac `D delta(t)`.
    pub impulse_drops_d: bool,
}

/// `M` as row-major `Vec` for the inner loop.
fn rows(m: &faer::Mat<f64>) -> Vec<f64> {
    let mut v = Vec::with_capacity(m.nrows() * m.ncols());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            v.push(m[(i, j)]);
        }
    }
    v
}

/// The discrete system that is simulated: `sys` itself when discrete, its
/// exact ZOH discretisation at the grid step when continuous.
fn discrete_for(sys: &StateSpace, grid: &TimeGrid) -> Result<StateSpace, SsError> {
    match sys.ts {
        Some(_) => Ok(sys.clone()),
        None => c2d(sys, grid.dt, C2dMethod::Zoh),
    }
}

/// Step or impulse response of `sys` on `grid` (for a discrete system the
/// grid step must be its sample time).
pub fn time_response(
    sys: &StateSpace,
    kind: ResponseKind,
    grid: &TimeGrid,
) -> Result<TimeResponse, ResponseError> {
    check_samples(grid.n)?;
    if let Some(ts) = sys.ts
        && (grid.dt - ts).abs() > 1e-12 * ts
    {
        return Err(ResponseError::BadGrid(format!(
            "a discrete system runs at its sample time {ts} s, not {} s",
            grid.dt
        )));
    }
    let values = grid
        .n
        .saturating_mul(sys.ny().max(1))
        .saturating_mul(sys.nu().max(1));
    if values > MAX_RESPONSE_VALUES {
        return Err(ResponseError::BadGrid(format!(
            "{} samples x {} outputs x {} inputs is more than {MAX_RESPONSE_VALUES} values",
            grid.n,
            sys.ny(),
            sys.nu()
        )));
    }
    let d = discrete_for(sys, grid)?;
    let mut y = vec![Vec::with_capacity(sys.nu()); sys.ny()];
    for j in 0..sys.nu() {
        let channel = simulate_input(&d, sys, kind, j, grid.n);
        for (i, yi) in channel.into_iter().enumerate() {
            y[i].push(yi);
        }
    }
    let impulse_drops_d =
        kind == ResponseKind::Impulse && !sys.is_discrete() && sys.d.norm_max() != 0.0;
    Ok(TimeResponse {
        kind,
        grid: *grid,
        y,
        impulse_drops_d,
    })
}

/// Response of every output to input `j`: `x[k+1] = Ad x[k] + Bd u[k]`,
/// `y[k] = C x[k] + D u[k]`, `x[0] = 0`. Step: `u[k] = 1`. Impulse:
/// continuous `x[0] = B e_j`, `u = 0`; discrete `u[0] = 1/ts`.
fn simulate_input(
    d: &StateSpace,
    orig: &StateSpace,
    kind: ResponseKind,
    j: usize,
    n: usize,
) -> Vec<Vec<f64>> {
    let (nx, ny) = (d.nx(), d.ny());
    let a = rows(&d.a);
    let c = rows(&d.c);
    let bd: Vec<f64> = (0..nx).map(|r| d.b[(r, j)]).collect();
    let dj: Vec<f64> = (0..ny).map(|i| d.d[(i, j)]).collect();
    let mut x = vec![0.0; nx];
    let mut next = vec![0.0; nx];
    let u_at = |k: usize| -> f64 {
        match (kind, orig.ts) {
            (ResponseKind::Step, _) => 1.0,
            (ResponseKind::Impulse, Some(ts)) if k == 0 => 1.0 / ts,
            (ResponseKind::Impulse, _) => 0.0,
        }
    };
    if kind == ResponseKind::Impulse && orig.ts.is_none() {
        for (r, xr) in x.iter_mut().enumerate() {
            *xr = orig.b[(r, j)];
        }
    }
    let mut y = vec![Vec::with_capacity(n); ny];
    for k in 0..n {
        let u = u_at(k);
        for i in 0..ny {
            let row = &c[i * nx..(i + 1) * nx];
            let v: f64 = row.iter().zip(&x).map(|(p, q)| p * q).sum();
            y[i].push(v + dj[i] * u);
        }
        if k + 1 == n {
            break;
        }
        for (r, nr) in next.iter_mut().enumerate() {
            let row = &a[r * nx..(r + 1) * nx];
            *nr = row.iter().zip(&x).map(|(p, q)| p * q).sum::<f64>() + bd[r] * u;
        }
        std::mem::swap(&mut x, &mut next);
    }
    y
}

/// The closed loop from reference to output, `T = G K (I + G K)^-1`
/// (negative unity feedback around `G K`; the controller `K` acts on the
/// error `r - y`). Continuous or discrete, the two at one sample time.
pub fn closed_loop(g: &StateSpace, k: &StateSpace) -> Result<StateSpace, SsError> {
    let l = k.series(g)?;
    let unity = faer::Mat::<f64>::identity(l.ny(), l.ny());
    l.feedback(&StateSpace::gain(unity, l.ts))
}

/// The step-response figures of one channel (MATLAB `stepinfo`'s
/// definitions; docs/responses.md §2). Times in seconds,
/// overshoot and undershoot in percent of the final value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepInfo {
    /// From the first sample at 10 % to the first at 90 % of the final value;
    /// `None` when 90 % is not reached within the horizon.
    pub rise_time: Option<f64>,
    /// First sample (time) after which `|y - y_final|` stays within 2 % of
    /// its peak `max |y - y_final|` (MATLAB `stepinfo`); `None` when it
    /// has not settled by the end of the horizon.
    pub settling_time: Option<f64>,
    /// Smallest value after the rise (from the 90 % sample on), with the final value.
    pub settling_min: Option<f64>,
    /// Largest value after the rise, with the final value.
    pub settling_max: Option<f64>,
    /// Percent above the final value (0 when it never goes beyond).
    pub overshoot: f64,
    /// Percent of the final value reached on the opposite side (0 when never).
    pub undershoot: f64,
    /// Largest `|y|`.
    pub peak: f64,
    /// Time of the peak.
    pub peak_time: f64,
    /// The final value: the DC gain of the channel.
    pub steady_state: f64,
    /// `1 - steady_state`: the tracking error left by a unit step when the
    /// channel maps a reference to the output it should follow.
    pub steady_state_error: f64,
}

/// Why a channel has no step-response figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoStepInfo {
    /// A pole on or outside the stability boundary: no final value to settle to.
    Unstable,
    /// The DC gain is zero: 10/90 % and 2 % of zero are undefined.
    ZeroDcGain,
}

impl std::fmt::Display for NoStepInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NoStepInfo::Unstable => "unstable: no final value, no settling",
            NoStepInfo::ZeroDcGain => "zero DC gain: rise and settling are undefined",
        })
    }
}

/// Step-response figures of `y` (a step response sampled at `t`) towards
/// the final value `y_final`, as MATLAB `stepinfo` defines them for a
/// model (initial offset `y_init = 0`, the value before the step) and
/// computes them from samples (no interpolation between samples): rise
/// from the first sample at 10 % to the first at 90 % of `y_final`;
/// settling at the sample after the last one where `|y - y_final|`
/// exceeds [`SETTLING_THRESHOLD`] of its peak `max |y - y_final|` ("the
/// time it takes for the error e(t) = |y(t) - yfinal| ... to fall below 2%
/// of the peak value of e(t)", MATLAB R2021a `stepinfo` reference; its
/// discrete MIMO example prints 2.8 s and 3.6 s, tested below);
/// overshoot and undershoot in percent of `|y_final|`. python-control
/// `step_info` takes the band as 2 % of `y_final` instead.
pub fn step_info(t: &[f64], y: &[f64], y_final: f64) -> Result<StepInfo, NoStepInfo> {
    if !y_final.is_finite() {
        return Err(NoStepInfo::Unstable);
    }
    if y_final == 0.0 {
        return Err(NoStepInfo::ZeroDcGain);
    }
    let sgn = y_final.signum();
    let first_at = |frac: f64| y.iter().position(|&v| sgn * (v - frac * y_final) >= 0.0);
    let (lo, hi) = (first_at(0.1), first_at(0.9));
    let rise_time = lo.zip(hi).map(|(l, h)| t[h] - t[l]);
    // Settled from the sample after the last one outside the band, 2 % of
    // the peak error (MATLAB `stepinfo`).
    let band = SETTLING_THRESHOLD * peak_error(y, y_final);
    let settled = y
        .iter()
        .rposition(|&v| (v - y_final).abs() > band)
        .map_or(0, |k| k + 1);
    let settling_time = (settled < t.len()).then(|| t[settled]);
    let after_rise = hi.map(|h| &y[h..]);
    let settling_min = after_rise.map(|s| s.iter().copied().fold(y_final, f64::min));
    let settling_max = after_rise.map(|s| s.iter().copied().fold(y_final, f64::max));
    let y_os = y.iter().map(|v| sgn * v).fold(f64::NEG_INFINITY, f64::max);
    let dy = y_os.abs() - y_final.abs();
    let overshoot = if dy > 0.0 {
        (100.0 * dy / y_final).abs()
    } else {
        0.0
    };
    // argmin of sgn*y (first occurrence, as numpy).
    let us_idx = argbest(y, |v| -sgn * v);
    let undershoot = if sgn * y[us_idx] < 0.0 {
        -100.0 * y[us_idx] / y_final
    } else {
        0.0
    };
    let peak_idx = argbest(y, f64::abs);
    Ok(StepInfo {
        rise_time,
        settling_time,
        settling_min,
        settling_max,
        overshoot,
        undershoot,
        peak: y[peak_idx].abs(),
        peak_time: t[peak_idx],
        steady_state: y_final,
        steady_state_error: 1.0 - y_final,
    })
}

/// MATLAB `stepinfo`'s default `SettlingTimeThreshold`: the response has
/// settled once `|y - y_final|` stays within this fraction of its peak
/// `max |y - y_final|`.
pub const SETTLING_THRESHOLD: f64 = 0.02;

/// `max |y - y_final|` over the samples: the peak error the settling band
/// is a fraction of.
pub fn peak_error(y: &[f64], y_final: f64) -> f64 {
    y.iter().map(|v| (v - y_final).abs()).fold(0.0, f64::max)
}

/// Index of the first largest `key(y[k])`.
fn argbest(y: &[f64], key: impl Fn(f64) -> f64) -> usize {
    let mut best = 0;
    for (k, &v) in y.iter().enumerate() {
        if key(v) > key(y[best]) {
            best = k;
        }
    }
    best
}

/// Step-response figures of every channel of `sys` from its step response
/// `resp` (outputs x inputs). The final value is the DC gain, as
/// python-control takes it for a system; an unstable system (a pole with
/// `Re >= 0`, or `|z| >= 1`) has none.
pub fn step_info_of(
    sys: &StateSpace,
    resp: &TimeResponse,
) -> Result<Vec<Vec<Result<StepInfo, NoStepInfo>>>, SsError> {
    let stable = sys.is_stable()?;
    let dc = if stable { Some(sys.dc_gain()?) } else { None };
    let t = resp.grid.times();
    Ok(resp
        .y
        .iter()
        .enumerate()
        .map(|(i, yi)| {
            yi.iter()
                .enumerate()
                .map(|(j, y)| match &dc {
                    Some(dc) => step_info(&t, y, dc[(i, j)]),
                    None => Err(NoStepInfo::Unstable),
                })
                .collect()
        })
        .collect())
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn first_order_step_is_exact_at_the_samples() {
        // 1/(s+1): y(t) = 1 - e^-t; rise 10-90 % between samples of a fine grid.
        let g = StateSpace::from_tf(&[1.0], &[1.0, 1.0], None).unwrap();
        let grid = TimeGrid::continuous(10.0, 10_001).unwrap();
        let r = time_response(&g, ResponseKind::Step, &grid).unwrap();
        for k in [0, 1, 500, 10_000] {
            let t = grid.time(k);
            assert!((r.y[0][0][k] - (1.0 - (-t).exp())).abs() < 1e-11);
        }
        let info = step_info_of(&g, &r).unwrap()[0][0].clone().unwrap();
        // ln 9 = 2.1972 s between 10 % and 90 %, ln 50 = 3.912 s to 2 %.
        assert!((info.rise_time.unwrap() - 9f64.ln()).abs() < 2e-3);
        assert!((info.settling_time.unwrap() - 50f64.ln()).abs() < 2e-3);
        assert_eq!(info.overshoot, 0.0);
        assert!((info.steady_state - 1.0).abs() < 1e-15);
    }

    /// MATLAB's `stepinfo` reference example "Step-Response
    /// Characteristics of MIMO System": `ss(A,B,C,D,0.2)` with the matrices
    /// below. The page prints `S(2,1)`: RiseTime 0.4000, SettlingTime
    /// 2.8000, SettlingMin -0.6724, SettlingMax -0.5188, Overshoot 24.6476,
    /// Undershoot 11.1224, Peak 0.6724, PeakTime 1; and 3.6 s to settle for
    /// `S(1,2)`. A band of 2 % of the final value gives 3.0 s and 3.8 s.
    pub fn matlab_discrete_mimo_example() {
        let m = |r: usize, c: usize, v: &[f64]| faer::Mat::from_fn(r, c, |i, j| v[i * c + j]);
        let sys = StateSpace::new(
            m(2, 2, &[0.68, -0.34, 0.34, 0.68]),
            m(2, 2, &[0.18, -0.05, 0.04, 0.11]),
            m(2, 2, &[0.0, -1.53, -1.12, -1.10]),
            m(2, 2, &[0.0, 0.0, 0.06, -0.37]),
            Some(0.2),
        )
        .unwrap();
        let grid = TimeGrid::discrete(40.0, 0.2).unwrap();
        let r = time_response(&sys, ResponseKind::Step, &grid).unwrap();
        let info = step_info_of(&sys, &r).unwrap();
        let s21 = info[1][0].clone().unwrap();
        let close = |got: f64, want: f64, digits: f64| (got - want).abs() <= 0.5 * digits;
        assert!(close(s21.rise_time.unwrap(), 0.4, 1e-4), "{s21:?}");
        assert!(close(s21.settling_time.unwrap(), 2.8, 1e-4), "{s21:?}");
        assert!(close(s21.settling_min.unwrap(), -0.6724, 1e-4), "{s21:?}");
        assert!(close(s21.settling_max.unwrap(), -0.5188, 1e-4), "{s21:?}");
        assert!(close(s21.overshoot, 24.6476, 1e-4), "{s21:?}");
        assert!(close(s21.undershoot, 11.1224, 1e-4), "{s21:?}");
        assert!(close(s21.peak, 0.6724, 1e-4), "{s21:?}");
        assert!(close(s21.peak_time, 1.0, 1e-4), "{s21:?}");
        let s12 = info[0][1].clone().unwrap();
        assert!(close(s12.settling_time.unwrap(), 3.6, 1e-4), "{s12:?}");
    }

    pub fn second_order_overshoot_matches_the_closed_form() {
        // wn^2/(s^2 + 2 zeta wn s + wn^2): overshoot 100 exp(-pi zeta/sqrt(1-zeta^2)).
        let (wn, zeta) = (3.0f64, 0.3f64);
        let g = StateSpace::from_tf(&[wn * wn], &[1.0, 2.0 * zeta * wn, wn * wn], None).unwrap();
        let grid = TimeGrid::continuous(20.0, 200_001).unwrap();
        let r = time_response(&g, ResponseKind::Step, &grid).unwrap();
        let info = step_info_of(&g, &r).unwrap()[0][0].clone().unwrap();
        let os = 100.0 * (-std::f64::consts::PI * zeta / (1.0 - zeta * zeta).sqrt()).exp();
        assert!(
            (info.overshoot - os).abs() < 1e-6,
            "{} {os}",
            info.overshoot
        );
        let tp = std::f64::consts::PI / (wn * (1.0 - zeta * zeta).sqrt());
        assert!((info.peak_time - tp).abs() < 1e-4);
    }

    pub fn unstable_and_zero_dc_have_no_figures() {
        let g = StateSpace::from_tf(&[1.0], &[1.0, -1.0], None).unwrap();
        let grid = TimeGrid::continuous(1.0, 11).unwrap();
        let r = time_response(&g, ResponseKind::Step, &grid).unwrap();
        assert!((r.y[0][0][10] - (1f64.exp() - 1.0)).abs() < 1e-12);
        assert_eq!(
            step_info_of(&g, &r).unwrap()[0][0],
            Err(NoStepInfo::Unstable)
        );
        let h = StateSpace::from_tf(&[1.0, 0.0], &[1.0, 1.0], None).unwrap();
        let r = time_response(&h, ResponseKind::Step, &grid).unwrap();
        assert_eq!(
            step_info_of(&h, &r).unwrap()[0][0],
            Err(NoStepInfo::ZeroDcGain)
        );
    }

    pub fn discrete_impulse_is_a_unit_area_pulse() {
        // 1/(1 - 0.5 z^-1) at ts = 0.1: h[k] = 0.5^k / ts.
        let g = StateSpace::from_tf(&[1.0, 0.0], &[1.0, -0.5], Some(0.1)).unwrap();
        let grid = TimeGrid::discrete(1.0, 0.1).unwrap();
        assert_eq!(grid.n, 11);
        let r = time_response(&g, ResponseKind::Impulse, &grid).unwrap();
        for k in 0..11 {
            assert!((r.y[0][0][k] - 0.5f64.powi(k as i32) / 0.1).abs() < 1e-12);
        }
    }

    pub fn grids_are_bounded() {
        assert!(TimeGrid::continuous(1.0, MAX_RESPONSE_SAMPLES + 1).is_err());
        assert!(TimeGrid::continuous(1.0, 1).is_err());
        assert!(TimeGrid::discrete(1e3, 1e-6).is_err());
        assert!(TimeGrid::continuous(f64::NAN, 10).is_err());
    }
}
