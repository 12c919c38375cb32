//! Step and impulse responses of a continuous system known exactly at any
//! time, and step figures that cannot miss a peak (docs/responses.md §2).
//!
//! A uniform grid undersamples any mode faster than its step: a system
//! with a 691 s mode beside a 1 ms one, simulated on 2001 points over the
//! slow mode's decay, shows no trace of a 363 % overshoot 1.5 ms after the
//! step. Here the response is instead known exactly on a dyadic lattice of
//! times `t = k 2^m0`:
//!
//! * `x(t + h) = Phi(h) x(t) + Gamma(h) u`, `[Phi Gamma; 0 I] = exp([A B;
//!   0 0] h)` (Van Loan 1978, the ZOH of [`super::c2d`], exact for a
//!   constant input), is tabulated for every `h = 2^m`, `m0 <= m <= m1`, so
//!   `x(t)` at any lattice time is a product over the binary digits of `t`;
//! * a scan with steps that resolve every mode still alive (step at most
//!   `0.2/|p|` while `e^{Re(p) t} > 1e-9`, doubling once the fast modes have
//!   decayed) brackets every extremum and crossing;
//! * each extremum is refined by bisection on the sign of `dy/dt = C (A x +
//!   B u)` (step) or `C A x` (impulse) down to 2^-40 of the scan step, and
//!   each crossing of a level (10 %, 90 %, the 2 % band) by bisection on
//!   `y - level`; every figure is the value of the exact response at a
//!   lattice time that was evaluated, so `peak = |y(peak_time)|`.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c2d::{C2dMethod, c2d};
use super::c64;
use super::response::{NoStepInfo, ResponseKind, StepInfo};
use super::ss::{SsError, StateSpace};

/// Lattice levels below the finest scan step: a bracket of two steps is
/// halved this many times (the peak time to 2^-40 of a step).
const REFINE_LEVELS: i32 = 40;
/// A mode is resolved while `e^{Re(p) t}` exceeds `e^-LN_DEAD` (1e-9).
const LN_DEAD: f64 = 20.72;
/// The scan step of a mode `p`: `STEP_PER_MODE / |p|`, rounded down to a
/// power of two (31 to 63 steps per period of an oscillation).
const STEP_PER_MODE: f64 = 0.2;
/// The most scan steps, and the most scanned values (steps x channels).
pub const MAX_SCAN_STEPS: usize = 4_000_000;
/// See [`MAX_SCAN_STEPS`].
pub const MAX_SCAN_VALUES: usize = 4_000_000;
/// The most arithmetic (multiply-adds, estimated) the tables and the scan
/// may take; a larger system gets the sampled figures with a warning.
pub const MAX_WORK: f64 = 2e10;

/// The exact response of one kind of a continuous system on the lattice
/// `k 2^m0`: `Phi(2^m)`, `Gamma(2^m)` for `m0 <= m < m0 + levels`.
pub struct Lattice {
    kind: ResponseKind,
    n: usize,
    nu: usize,
    ny: usize,
    m0: i32,
    /// Row-major `Phi(2^m)` per level.
    phi: Vec<Vec<f64>>,
    /// `Gamma(2^m)` per level, column-major (`n` per input).
    gamma: Vec<Vec<f64>>,
    /// Row-major `C`, `C A`; `C B` and `D` row-major `ny x nu`.
    c: Vec<f64>,
    ca: Vec<f64>,
    cb: Vec<f64>,
    d: Vec<f64>,
    /// Initial state per input, column-major (`B` for an impulse, else 0).
    x0: Vec<f64>,
}

fn rows(m: &faer::Mat<f64>) -> Vec<f64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

fn cols(m: &faer::Mat<f64>) -> Vec<f64> {
    (0..m.ncols())
        .flat_map(|j| (0..m.nrows()).map(move |i| m[(i, j)]))
        .collect()
}

/// `y = M x` for row-major `M` (`r x x.len()`).
fn matvec(m: &[f64], x: &[f64], y: &mut [f64]) {
    let n = x.len();
    for (i, yi) in y.iter_mut().enumerate() {
        *yi = m[i * n..(i + 1) * n]
            .iter()
            .zip(x)
            .map(|(p, q)| p * q)
            .sum();
    }
}

impl Lattice {
    /// Tables for lattice times `t = k 2^m0` up to `2^(m1 + 1)`.
    fn new(sys: &StateSpace, kind: ResponseKind, m0: i32, m1: i32) -> Result<Self, SsError> {
        let sys = sys.balanced();
        let (n, nu, ny) = (sys.nx(), sys.nu(), sys.ny());
        let mut phi = Vec::new();
        let mut gamma = Vec::new();
        for m in m0..=m1 {
            let d = c2d(&sys, 2f64.powi(m), C2dMethod::Zoh)?;
            if !(d.a.is_all_finite() && d.b.is_all_finite()) {
                return Err(SsError::IllPosed);
            }
            phi.push(rows(&d.a));
            gamma.push(cols(&d.b));
        }
        let x0 = match kind {
            ResponseKind::Impulse => cols(&sys.b),
            ResponseKind::Step => vec![0.0; n * nu],
        };
        Ok(Self {
            kind,
            n,
            nu,
            ny,
            m0,
            phi,
            gamma,
            c: rows(&sys.c),
            ca: rows(&(&sys.c * &sys.a)),
            cb: rows(&(&sys.c * &sys.b)),
            d: rows(&sys.d),
            x0,
        })
    }

    /// The lattice unit `2^m0` in seconds.
    pub fn unit(&self) -> f64 {
        2f64.powi(self.m0)
    }

    /// The lattice time nearest `t`.
    pub fn snap(&self, t: f64) -> f64 {
        (t / self.unit()).round() * self.unit()
    }

    /// `x <- Phi(2^m) x + Gamma(2^m) u` for the state `x` of input `j`.
    fn advance(&self, level: usize, j: usize, x: &mut [f64], tmp: &mut [f64]) {
        matvec(&self.phi[level], x, tmp);
        if self.kind == ResponseKind::Step {
            let g = &self.gamma[level][j * self.n..(j + 1) * self.n];
            for (t, gi) in tmp.iter_mut().zip(g) {
                *t += gi;
            }
        }
        x.copy_from_slice(tmp);
    }

    /// The state for input `j` at the lattice time `t`, from the binary
    /// digits of `t` (`Phi` and `Gamma` of a sum of steps compose exactly).
    fn state(&self, t: f64, j: usize) -> Vec<f64> {
        let n = self.n;
        let mut x = self.x0[j * n..(j + 1) * n].to_vec();
        let mut tmp = vec![0.0; n];
        let mut rest = t;
        for level in (0..self.phi.len()).rev() {
            let h = 2f64.powi(self.m0 + level as i32);
            if rest >= h {
                self.advance(level, j, &mut x, &mut tmp);
                rest -= h;
            }
        }
        x
    }

    /// `y` and `dy/dt` of output `i` for the state `x` of input `j`.
    fn output(&self, i: usize, j: usize, x: &[f64]) -> (f64, f64) {
        let n = self.n;
        let dot = |m: &[f64]| -> f64 {
            m[i * n..(i + 1) * n]
                .iter()
                .zip(x)
                .map(|(p, q)| p * q)
                .sum()
        };
        let (cx, cax) = (dot(&self.c), dot(&self.ca));
        match self.kind {
            ResponseKind::Step => (cx + self.d[i * self.nu + j], cax + self.cb[i * self.nu + j]),
            ResponseKind::Impulse => (cx, cax),
        }
    }

    /// `y(t)` and `dy/dt` of channel `(i, j)` at the lattice time `t`.
    pub fn eval(&self, i: usize, j: usize, t: f64) -> (f64, f64) {
        self.output(i, j, &self.state(t, j))
    }

    /// Every output for every input at the lattice time `t`
    /// (`[i][j]`).
    pub fn sample(&self, t: f64) -> Vec<Vec<f64>> {
        let xs: Vec<Vec<f64>> = (0..self.nu).map(|j| self.state(t, j)).collect();
        (0..self.ny)
            .map(|i| (0..self.nu).map(|j| self.output(i, j, &xs[j]).0).collect())
            .collect()
    }
}

/// The scan steps: at time `t` the step is `2^level`, at most the step of
/// every mode still alive, doubling (one doubling a step, on a multiple of
/// the doubled step) as the fast modes die out.
struct Schedule {
    /// `(death time, level)` of each mode, by death time.
    modes: Vec<(f64, i32)>,
    /// The smallest level among `modes[k..]`.
    suffix_min: Vec<i32>,
    idx: usize,
    t: f64,
    level: i32,
    top: i32,
}

impl Schedule {
    fn new(poles: &[c64], scale: f64, top: i32) -> Self {
        let mut modes: Vec<(f64, i32)> = poles
            .iter()
            .filter(|p| p.norm() > 0.0)
            .map(|p| {
                let level = (scale * STEP_PER_MODE / p.norm()).log2().floor() as i32;
                (LN_DEAD / p.re.abs().max(f64::MIN_POSITIVE), level.min(top))
            })
            .collect();
        modes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut suffix_min = vec![top; modes.len() + 1];
        for k in (0..modes.len()).rev() {
            suffix_min[k] = suffix_min[k + 1].min(modes[k].1);
        }
        let level = suffix_min[0];
        Self {
            modes,
            suffix_min,
            idx: 0,
            t: 0.0,
            level,
            top,
        }
    }

    /// The finest level the schedule uses.
    fn finest(&self) -> i32 {
        self.suffix_min[0]
    }

    /// The level of the next step from the current time (which it advances).
    fn next_level(&mut self) -> i32 {
        while self.idx < self.modes.len() && self.modes[self.idx].0 <= self.t {
            self.idx += 1;
        }
        let target = self.suffix_min[self.idx].min(self.top);
        if self.level < target && (self.t / 2f64.powi(self.level + 1)).fract() == 0.0 {
            self.level += 1;
        }
        self.t += 2f64.powi(self.level);
        self.level
    }

    /// Steps to reach `end`, stopping at `limit`.
    fn count(mut self, end: f64, limit: usize) -> usize {
        let mut k = 0;
        while self.t < end && k <= limit {
            self.next_level();
            k += 1;
        }
        k
    }
}

/// An upper bound of a smooth function on `[0, h]` from its values and
/// slopes at both ends, `(p, m)`: the largest value `v` of the cubic
/// Hermite interpolant plus a tenth of its excess over the larger end (the
/// interpolant errs by `h^4 max|p^(4)|/384`; for a sinusoid sampled at 8 or
/// more points a period that is under 2 % of the excess) and a rounding
/// allowance.
fn hermite_bound(h: f64, (p0, m0): (f64, f64), (p1, m1): (f64, f64)) -> f64 {
    let slope = (p1 - p0) / h;
    let c2 = (3.0 * slope - 2.0 * m0 - m1) / h;
    let c3 = (m0 + m1 - 2.0 * slope) / (h * h);
    let p = |x: f64| p0 + x * (m0 + x * (c2 + x * c3));
    // p'(x) = m0 + 2 c2 x + 3 c3 x^2 = 0 in [0, h].
    let ends = p0.max(p1);
    let mut v = ends;
    let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, m0);
    let roots = if qa.abs() * h <= 1e-12 * (qb.abs() + qc.abs() / h) {
        [-qc / qb, f64::NAN]
    } else {
        let disc = (qb * qb - 4.0 * qa * qc).max(0.0).sqrt();
        [(-qb + disc) / (2.0 * qa), (-qb - disc) / (2.0 * qa)]
    };
    for x in roots {
        if x.is_finite() && (0.0..=h).contains(&x) {
            v = v.max(p(x));
        }
    }
    v + 0.1 * (v - ends) + 1e-12 * (v.abs() + ends.abs())
}

/// One channel's scan: the samples `(t_k, y_k)` (exact values at lattice
/// times) and the exact response to refine them with.
struct Trace<'a> {
    lat: &'a Lattice,
    i: usize,
    j: usize,
    t: &'a [f64],
    y: Vec<f64>,
    /// `dy/dt` at the samples.
    dy: Vec<f64>,
}

impl Trace<'_> {
    fn eval(&self, t: f64) -> (f64, f64) {
        self.lat.eval(self.i, self.j, t)
    }

    /// An upper bound of `s y` on `[t_k, t_k+1]` ([`hermite_bound`]).
    fn bound(&self, k: usize, s: f64) -> f64 {
        hermite_bound(
            self.t[k + 1] - self.t[k],
            (s * self.y[k], s * self.dy[k]),
            (s * self.y[k + 1], s * self.dy[k + 1]),
        )
    }

    /// The intervals `[t_k, t_k+1]` of `k0..=k1` where `s dy/dt` turns from
    /// positive to not (a local maximum of `s y` inside), with their bounds.
    fn maxima(&self, k0: usize, k1: usize, s: f64) -> impl Iterator<Item = (usize, f64)> + '_ {
        (k0..k1)
            .filter(move |&k| s * self.dy[k] > 0.0 && !(s * self.dy[k + 1] > 0.0))
            .map(move |k| (k, self.bound(k, s)))
    }

    /// The largest `s y` on `[t_k, t_k+1]`, where `s dy/dt` changes sign:
    /// bisection on that sign, keeping the best value evaluated (so the
    /// result is `(t, y(t))` of an evaluated time). It stops early once the
    /// bracket's bound cannot exceed `floor` (the caller needs no more).
    fn refine_max(&self, k: usize, s: f64, floor: f64) -> (f64, f64) {
        let mut lo = (self.t[k], s * self.y[k], s * self.dy[k]);
        let mut hi = (self.t[k + 1], s * self.y[k + 1], s * self.dy[k + 1]);
        let mut best = if lo.1 >= hi.1 {
            (lo.0, lo.1)
        } else {
            (hi.0, hi.1)
        };
        for _ in 0..(REFINE_LEVELS + 4) {
            let mid = 0.5 * (lo.0 + hi.0);
            if !(mid > lo.0 && mid < hi.0) || hi.0 - lo.0 < 2.0 * self.lat.unit() {
                // Converged on the root of dy/dt: near a flat top the best
                // value evaluated is a matter of rounding, the root is not.
                let end = if lo.1 >= hi.1 { lo } else { hi };
                if end.1 >= best.1 - 1e-12 * best.1.abs() {
                    best = (end.0, end.1);
                }
                break;
            }
            if hermite_bound(hi.0 - lo.0, (lo.1, lo.2), (hi.1, hi.2)) <= floor.max(best.1) {
                break;
            }
            let (ym, dm) = self.eval(mid);
            let m = (mid, s * ym, s * dm);
            if m.1 > best.1 {
                best = (mid, m.1);
            }
            if m.2 > 0.0 {
                lo = m;
            } else if m.2 < 0.0 {
                hi = m;
            } else {
                break;
            }
        }
        (best.0, s * best.1)
    }

    /// The largest `s y` over samples `k0..=k1` and the extrema between
    /// them, as `(t, y)`: local maxima refined in decreasing order of their
    /// bounds until no bound beats the best value found.
    fn extreme(&self, k0: usize, k1: usize, s: f64) -> (f64, f64) {
        let mut best = (self.t[k0], self.y[k0]);
        for k in k0..=k1 {
            if s * self.y[k] > s * best.1 {
                best = (self.t[k], self.y[k]);
            }
        }
        let floor = s * best.1;
        let mut cands: Vec<(usize, f64)> = self.maxima(k0, k1, s).filter(|c| c.1 > floor).collect();
        cands.sort_by(|a, b| b.1.total_cmp(&a.1));
        for (k, bound) in cands {
            if bound <= s * best.1 {
                break;
            }
            let (t, y) = self.refine_max(k, s, s * best.1);
            if s * y > s * best.1 {
                best = (t, y);
            }
        }
        best
    }

    /// Bisection of `[a, b]` with `g(a) < 0 <= g(b)` down to the lattice
    /// unit: the first evaluated time with `g >= 0`, and `y` there.
    fn crossing(&self, a: (f64, f64), b: (f64, f64), g: impl Fn(f64) -> f64) -> (f64, f64) {
        let (mut lo, mut hi) = (a.0, b);
        for _ in 0..(REFINE_LEVELS + 30) {
            let mid = 0.5 * (lo + hi.0);
            if !(mid > lo && mid < hi.0) || hi.0 - lo < 2.0 * self.lat.unit() {
                break;
            }
            let (ym, _) = self.eval(mid);
            if g(ym) >= 0.0 {
                hi = (mid, ym);
            } else {
                lo = mid;
            }
        }
        hi
    }

    /// The first time in `[0, t_k1]` at which `s (y - level) >= 0`.
    fn first_crossing(&self, k1: usize, s: f64, level: f64) -> Option<(f64, f64)> {
        let g = |y: f64| s * (y - level);
        let first = (0..=k1).find(|&k| g(self.y[k]) >= 0.0);
        if first == Some(0) {
            return Some((self.t[0], self.y[0]));
        }
        let end = first.unwrap_or(k1);
        // A local maximum may reach the level between two samples before.
        let early = self
            .maxima(0, end, s)
            .filter(|&(_, bound)| bound >= s * level)
            .map(|(k, _)| (k, self.refine_max(k, s, s * level)))
            .find(|(_, (_, y))| g(*y) >= 0.0);
        let (a, b) = match (early, first) {
            (Some((k, peak)), _) => ((self.t[k], self.y[k]), peak),
            (None, Some(k)) => ((self.t[k - 1], self.y[k - 1]), (self.t[k], self.y[k])),
            (None, None) => return None,
        };
        Some(self.crossing(a, b, g))
    }

    /// The time after which `|y - y_f| <= band` up to `t_k1` (`None` when
    /// `y(t_k1)` is outside the band).
    fn settling(&self, k1: usize, y_f: f64, band: f64) -> Option<f64> {
        let out = |y: f64| (y - y_f).abs() - band;
        if out(self.y[k1]) >= 0.0 {
            return None;
        }
        let last = (0..k1).rev().find(|&k| out(self.y[k]) >= 0.0);
        // The latest extremum after the last sample outside that leaves
        // the band between samples.
        let from = last.unwrap_or(0);
        let mut outside = last.map(|k| (self.t[k], self.y[k]));
        for s in [1.0, -1.0] {
            let edge = s * y_f + band;
            let found = self
                .maxima(from, k1, s)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .filter(|&(_, bound)| bound >= edge)
                .map(|(k, _)| self.refine_max(k, s, edge))
                .find(|&(_, y)| out(y) >= 0.0);
            if let Some((t, y)) = found
                && outside.is_none_or(|o| t > o.0)
            {
                outside = Some((t, y));
            }
        }
        let Some(a) = outside else {
            return Some(self.t[0]);
        };
        let next = (0..=k1).find(|&k| self.t[k] > a.0)?;
        let b = (self.t[next], self.y[next]);
        Some(self.crossing(a, b, |y| -out(y)).0)
    }

    /// Step figures over `[0, t_k1]` towards `y_f` (the definitions of
    /// [`super::response::step_info`], with crossing times instead of
    /// first samples).
    fn step_info(&self, k1: usize, y_f: f64) -> Result<StepInfo, NoStepInfo> {
        if !y_f.is_finite() {
            return Err(NoStepInfo::Unstable);
        }
        if y_f == 0.0 {
            return Err(NoStepInfo::ZeroDcGain);
        }
        let s = y_f.signum();
        let t10 = self.first_crossing(k1, s, 0.1 * y_f);
        let t90 = self.first_crossing(k1, s, 0.9 * y_f);
        let rise_time = t10.zip(t90).map(|(a, b)| b.0 - a.0);
        let after = t90.map(|(t90, y90)| {
            let k0 = (0..=k1).find(|&k| self.t[k] >= t90).unwrap_or(k1);
            let hi = self.extreme(k0, k1, 1.0).1.max(y90).max(y_f);
            let lo = self.extreme(k0, k1, -1.0).1.min(y90).min(y_f);
            (lo, hi)
        });
        let os = self.extreme(0, k1, s);
        let dy = os.1.abs() - y_f.abs();
        let us = self.extreme(0, k1, -s);
        let peak = if os.1.abs() >= us.1.abs() { os } else { us };
        // The band is 2 % of the peak error max |y - y_f| (MATLAB
        // `stepinfo`), reached at the largest or the smallest value.
        let peak_error = (os.1 - y_f).abs().max((us.1 - y_f).abs());
        let band = super::response::SETTLING_THRESHOLD * peak_error;
        Ok(StepInfo {
            rise_time,
            settling_time: self.settling(k1, y_f, band),
            settling_min: after.map(|a| a.0),
            settling_max: after.map(|a| a.1),
            overshoot: if dy > 0.0 {
                (100.0 * dy / y_f).abs()
            } else {
                0.0
            },
            undershoot: if s * us.1 < 0.0 {
                -100.0 * us.1 / y_f
            } else {
                0.0
            },
            peak: peak.1.abs(),
            peak_time: peak.0,
            steady_state: y_f,
            steady_state_error: 1.0 - y_f,
        })
    }

    /// The largest `|y|` over `[0, t_k1]`, as `(t, y)`.
    fn peak(&self, k1: usize) -> (f64, f64) {
        let a = self.extreme(0, k1, 1.0);
        let b = self.extreme(0, k1, -1.0);
        if a.1.abs() >= b.1.abs() { a } else { b }
    }
}

/// One channel's exact figures.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelFigures {
    /// Step figures over the horizon (`None` for an impulse response).
    pub info: Option<Result<StepInfo, NoStepInfo>>,
    /// The same over the whole search (to tell what the horizon cut off).
    pub info_searched: Option<Result<StepInfo, NoStepInfo>>,
    /// The largest `|y|` over the horizon, `(t, y)`.
    pub peak: (f64, f64),
    /// The same over the whole search.
    pub peak_searched: (f64, f64),
    /// `y` at the end of the horizon.
    pub end: f64,
    /// The times the figures name (peak, 10 % and 90 % crossings, settling).
    pub marks: Vec<f64>,
}

/// The exact figures of every channel of a stable continuous system.
pub struct ExactFigures {
    /// The horizon of the figures in seconds (the one asked for, unless
    /// the search budget cut it short).
    pub horizon: f64,
    /// How far the search went (at least the horizon, at most twice the
    /// default duration when that is longer).
    pub searched_to: f64,
    /// The search was cut short of twice the default duration by
    /// [`MAX_SCAN_STEPS`] / [`MAX_SCAN_VALUES`].
    pub cut_short: bool,
    /// Figures per output and input.
    pub channels: Vec<Vec<ChannelFigures>>,
    /// The exact response, to sample at any lattice time.
    pub lattice: Lattice,
}

/// Why there are no exact figures.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExactError {
    /// The system is too large for the tables within [`MAX_WORK`].
    #[error("{0} states and {1} inputs are too many for the exact figures")]
    TooLarge(usize, usize),
    /// The system is not a stable continuous one.
    #[error("the exact figures need a stable continuous system")]
    NotStableContinuous,
    /// Eigenvalues or a matrix exponential failed.
    #[error("{0}")]
    Ss(#[from] SsError),
}

/// Exact figures of `sys` (continuous, stable) over `[0, horizon]`, the
/// search extended to `search` seconds when longer (docs/responses.md §2).
pub fn exact_figures(
    sys: &StateSpace,
    kind: ResponseKind,
    horizon: f64,
    search: f64,
) -> Result<ExactFigures, ExactError> {
    if sys.is_discrete() || !sys.is_stable()? {
        return Err(ExactError::NotStableContinuous);
    }
    let poles = sys.poles()?;
    let (n, nu, ny) = (sys.nx(), sys.nu(), sys.ny());
    let channels = (ny * nu).max(1);
    let mut end = search.max(horizon);
    let top = end.log2().floor() as i32;
    let max_steps = MAX_SCAN_STEPS.min(MAX_SCAN_VALUES / channels);
    // Coarsen the steps up to 4x (8 to 16 steps a period still bracket
    // every extremum), then cut the search short.
    let steps = |scale: f64| Schedule::new(&poles, scale, top).count(end, max_steps);
    let (scale, mut count) = [1.0, 2.0, 4.0]
        .into_iter()
        .map(|s| (s, steps(s)))
        .find(|&(_, k)| k <= max_steps)
        .unwrap_or((4.0, max_steps + 1));
    let mut cut_short = false;
    if count > max_steps {
        let mut sch = Schedule::new(&poles, scale, top);
        for _ in 0..max_steps {
            sch.next_level();
        }
        end = sch.t;
        count = max_steps;
        cut_short = true;
    }
    // The lattice resolves the finest step and the horizon itself.
    let finest = Schedule::new(&poles, scale, top)
        .finest()
        .min(horizon.log2().floor() as i32);
    let (m0, m1) = (finest - REFINE_LEVELS, top.max(finest));
    let levels = (m1 - m0 + 1) as f64;
    let k = (n + nu) as f64;
    let work = levels * 20.0 * k * k * k + count as f64 * ((n * n + n * ny) * nu) as f64;
    if work > MAX_WORK {
        return Err(ExactError::TooLarge(n, nu));
    }
    let lattice = Lattice::new(sys, kind, m0, m1)?;
    let end = lattice.snap(end);
    let horizon = lattice.snap(horizon).min(end);
    let (t, mut ys) = scan(&lattice, &poles, scale, top, &[horizon, end]);
    let k_h = t.iter().position(|&x| x == horizon).unwrap_or(t.len() - 1);
    let y_f = sys.dc_gain()?;
    let channels = (0..ny)
        .map(|i| {
            (0..nu)
                .map(|j| {
                    let (y, dy) = std::mem::take(&mut ys[i * nu + j]).into_iter().unzip();
                    let tr = Trace {
                        lat: &lattice,
                        i,
                        j,
                        t: &t,
                        y,
                        dy,
                    };
                    channel(&tr, kind, k_h, y_f[(i, j)])
                })
                .collect()
        })
        .collect();
    Ok(ExactFigures {
        horizon,
        searched_to: end,
        cut_short,
        channels,
        lattice,
    })
}

fn channel(tr: &Trace<'_>, kind: ResponseKind, k_h: usize, y_f: f64) -> ChannelFigures {
    let last = tr.t.len() - 1;
    let (info, info_searched) = match kind {
        ResponseKind::Step => (Some(tr.step_info(k_h, y_f)), Some(tr.step_info(last, y_f))),
        ResponseKind::Impulse => (None, None),
    };
    let peak = tr.peak(k_h);
    let mut marks = vec![peak.0];
    if let Some(Ok(s)) = &info {
        let sgn = y_f.signum();
        for level in [0.1, 0.9] {
            if let Some((t, _)) = tr.first_crossing(k_h, sgn, level * y_f) {
                marks.push(t);
            }
        }
        marks.extend(s.settling_time);
    }
    ChannelFigures {
        info,
        info_searched,
        peak,
        peak_searched: tr.peak(last),
        end: tr.y[k_h],
        marks,
    }
}

/// The scan: sample times (lattice times, with every time of `insert`)
/// and the output of every channel (`i nu + j`) and its derivative at
/// each, up to the last of `insert`.
fn scan(
    lat: &Lattice,
    poles: &[c64],
    scale: f64,
    top: i32,
    insert: &[f64],
) -> (Vec<f64>, Vec<Vec<(f64, f64)>>) {
    let end = insert.iter().copied().fold(0.0, f64::max);
    let mut sch = Schedule::new(poles, scale, top);
    let mut pending: Vec<f64> = insert.to_vec();
    pending.sort_by(|a, b| b.total_cmp(a));
    let (n, nu, ny) = (lat.n, lat.nu, lat.ny);
    let mut xs: Vec<Vec<f64>> = (0..nu)
        .map(|j| lat.x0[j * n..(j + 1) * n].to_vec())
        .collect();
    let mut tmp = vec![0.0; n];
    let mut times = Vec::new();
    let mut ys = vec![Vec::new(); ny * nu];
    let record = |ys: &mut Vec<Vec<(f64, f64)>>, xs: &[Vec<f64>]| {
        for i in 0..ny {
            for (j, x) in xs.iter().enumerate() {
                ys[i * nu + j].push(lat.output(i, j, x));
            }
        }
    };
    times.push(0.0);
    record(&mut ys, &xs);
    loop {
        let t0 = sch.t;
        let level = sch.next_level();
        let t1 = sch.t;
        // Times to insert before the next sample (evaluated afresh).
        while let Some(&p) = pending.last() {
            if p >= t1 {
                break;
            }
            pending.pop();
            if p > t0 {
                times.push(p);
                let fresh: Vec<Vec<f64>> = (0..nu).map(|j| lat.state(p, j)).collect();
                record(&mut ys, &fresh);
            }
        }
        if t1 > end {
            break;
        }
        let li = (level - lat.m0) as usize;
        for (j, x) in xs.iter_mut().enumerate() {
            lat.advance(li, j, x, &mut tmp);
        }
        times.push(t1);
        record(&mut ys, &xs);
        if t1 >= end {
            break;
        }
    }
    (times, ys)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    /// The state at a lattice time, composed from the binary digits of the
    /// time, equals the one-step ZOH over the whole time.
    pub fn lattice_state_is_the_zoh_over_the_whole_time() {
        let g = StateSpace::from_tf(&[2.0, 3.0], &[1.0, 0.5, 4.0, 1.0], None).unwrap();
        let lat = Lattice::new(&g, ResponseKind::Step, -30, 4).unwrap();
        for t in [0.375, 1.0 + 2f64.powi(-30), 13.0625] {
            let direct = c2d(&g, t, C2dMethod::Zoh).unwrap();
            let want = (&direct.c * &direct.b)[(0, 0)] + direct.d[(0, 0)];
            let got = lat.eval(0, 0, t).0;
            assert!(
                (got - want).abs() < 1e-12 * want.abs().max(1.0),
                "{t}: {got} vs {want}"
            );
        }
    }

    /// A first-order lag has its closed-form figures: no overshoot, rise
    /// ln 9, settling ln 50 (no grid error at all).
    pub fn first_order_figures_are_the_closed_form() {
        let g = StateSpace::from_tf(&[1.0], &[1.0, 1.0], None).unwrap();
        let f = exact_figures(&g, ResponseKind::Step, 10.0, 20.0).unwrap();
        let s = f.channels[0][0].info.clone().unwrap().unwrap();
        assert!((s.rise_time.unwrap() - 9f64.ln()).abs() < 1e-12, "{s:?}");
        assert!(
            (s.settling_time.unwrap() - 50f64.ln()).abs() < 1e-12,
            "{s:?}"
        );
        assert_eq!(s.overshoot, 0.0);
        assert!((s.peak - (1.0 - (-10f64).exp())).abs() < 1e-12);
    }
}
