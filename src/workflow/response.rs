//! `fts response step|impulse`: the time response of a system, or of the
//! closed loop it makes with a controller, with the step-response figures
//! of MATLAB `stepinfo` (docs/responses.md): exact for a continuous system
//! (`lti::exact_response`), from the samples of a discrete one.

use super::fmt_complex;
use super::{StepError, Validate, positive};
use crate::lti::c64;
use crate::lti::exact_response::{ExactError, ExactFigures, exact_figures};
use crate::lti::response::{
    self, MAX_RESPONSE_SAMPLES, NoStepInfo, ResponseKind, StepInfo, TimeGrid, TimeResponse,
};
use crate::lti::ss::{SsError, StateSpace};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Default number of grid points of a continuous response.
pub const DEFAULT_POINTS: usize = 2001;
/// The shortest `duration`, seconds (a nanosecond: far below any mode an
/// FTS has, and the exact figures' time lattice stays in normal floats).
pub const MIN_DURATION: f64 = 1e-9;
/// The longest `duration`, seconds (about 32 years; beyond it `A t`
/// overflows the matrix exponential of a fast system).
pub const MAX_DURATION: f64 = 1e9;

/// The step: which response, over how long, on how many points.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Response {
    /// Step (default) or impulse.
    pub kind: ResponseKind,
    /// Horizon in seconds; default from the slowest pole
    /// ([`response::default_duration`]).
    pub duration: Option<f64>,
    /// Grid points of a continuous response (default 2001); a discrete
    /// system runs at its sample time and refuses this setting.
    pub points: Option<usize>,
}

/// What the step runs on.
#[derive(Debug, Clone, Copy)]
pub struct ResponseInputs<'a> {
    /// The system `G` (any number of inputs and outputs without a controller).
    pub system: &'a StateSpace,
    /// A controller `K`: the response is then the closed loop `G K / (1 + G K)`.
    pub controller: Option<&'a StateSpace>,
}

impl Validate for Response {
    fn validate(&self) -> Result<(), StepError> {
        if let Some(d) = self.duration {
            positive("duration", d)?;
            if !(MIN_DURATION..=MAX_DURATION).contains(&d) {
                return Err(StepError::setting(
                    "duration",
                    format!("expected {MIN_DURATION:e} to {MAX_DURATION:e} seconds, got {d}"),
                ));
            }
        }
        if let Some(n) = self.points
            && !(2..=MAX_RESPONSE_SAMPLES).contains(&n)
        {
            return Err(StepError::setting(
                "points",
                format!("expected a whole number from 2 to {MAX_RESPONSE_SAMPLES}, got {n}"),
            ));
        }
        Ok(())
    }
}

impl Response {
    fn duration(&self, sys: &StateSpace) -> Result<f64, StepError> {
        match self.duration {
            Some(d) => Ok(d),
            None => response::default_duration(sys)
                .map_err(|e| StepError::computation(format!("poles: {e}"))),
        }
    }

    fn grid(&self, sys: &StateSpace, duration: f64) -> Result<TimeGrid, StepError> {
        let grid = match sys.ts {
            Some(_) if self.points.is_some() => {
                return Err(StepError::setting(
                    "points",
                    "a discrete system runs at its own sample time: give the duration only",
                ));
            }
            Some(ts) => TimeGrid::discrete(duration, ts),
            None => TimeGrid::continuous(duration, self.points.unwrap_or(DEFAULT_POINTS)),
        };
        grid.map_err(|e| StepError::setting("duration", e.to_string()))
    }

    /// Computes the response of `inputs` (`source` names them in messages).
    /// An unstable system is a computation failure: it has no figures and
    /// its samples diverge (docs/responses.md §1).
    pub fn run(
        &self,
        inputs: ResponseInputs<'_>,
        source: &str,
    ) -> Result<ResponseReport, StepError> {
        self.validate()?;
        let sys = match inputs.controller {
            None => inputs.system.clone(),
            Some(k) => closed_loop(inputs.system, k, source)?,
        };
        let comp = |e: crate::lti::ss::SsError| StepError::computation(format!("{source}: {e}"));
        let poles = sys.poles().map_err(comp)?;
        let stable = sys.is_stable().map_err(comp)?;
        let what = if inputs.controller.is_some() {
            "closed loop"
        } else {
            "system"
        };
        let duration = self.duration(&sys)?;
        let grid = self.grid(&sys, duration)?;
        // The grid's bounds are bad input, checked before stability.
        let culprit = if self.points.is_some() {
            "points"
        } else {
            "duration"
        };
        let resp = response::time_response(&sys, self.kind, &grid).map_err(|e| match e {
            response::ResponseError::BadGrid(m) => StepError::setting(culprit, m),
            response::ResponseError::Ss(e) => comp(e),
        })?;
        if !stable {
            return Err(StepError::computation(unstable_message(
                source, what, &poles, sys.ts,
            )));
        }
        let search = 2.0 * response::default_duration(&sys).map_err(comp)?;
        let mut report = ResponseReport {
            closed_loop: inputs.controller.is_some(),
            ts: sys.ts,
            poles,
            stable,
            info: None,
            grid,
            composite: false,
            t: grid.times(),
            y: resp.y.clone(),
            kind: self.kind,
            impulse_drops_d: resp.impulse_drops_d,
            warnings: Vec::new(),
            peaks: Vec::new(),
        };
        report.peaks = report
            .y
            .iter()
            .map(|row| row.iter().map(|y| sampled_peak(&report.t, y)).collect())
            .collect();
        if sys.is_discrete() {
            self.discrete_figures(&sys, &resp, search, &mut report)
                .map_err(comp)?;
        } else {
            self.continuous_figures(&sys, &resp, search, &mut report)
                .map_err(comp)?;
        }
        Ok(report)
    }

    /// Figures of a discrete system from its samples (exact at its own
    /// sample times), and what a longer run shows that the horizon cuts off.
    fn discrete_figures(
        &self,
        sys: &StateSpace,
        resp: &TimeResponse,
        search: f64,
        report: &mut ResponseReport,
    ) -> Result<(), SsError> {
        let grid = resp.grid;
        let horizon = grid.time(grid.n - 1);
        let ts = grid.dt;
        let longer = (search > horizon)
            .then(|| {
                TimeGrid::discrete(search.min(ts * (MAX_RESPONSE_SAMPLES - 1) as f64), ts).ok()
            })
            .flatten()
            .filter(|g| g.n > grid.n)
            .and_then(|g| response::time_response(sys, self.kind, &g).ok());
        let step_info = |r: &TimeResponse| match self.kind {
            ResponseKind::Step => response::step_info_of(sys, r).map(Some),
            ResponseKind::Impulse => Ok(None),
        };
        let info = step_info(resp)?;
        // The longer run's figures, once for every channel.
        let far = match &longer {
            Some(l) => Some((l, step_info(l)?)),
            None => None,
        };
        for (i, j) in report.channels() {
            let here = sampled_peak(&resp.grid.times(), &resp.y[i][j]);
            let (far_info, far_peak) = match &far {
                Some((l, far_info)) => (
                    far_info.as_ref().map(|m| m[i][j].clone()),
                    sampled_peak(&l.grid.times(), &l.y[i][j]),
                ),
                None => (info.as_ref().map(|m| m[i][j].clone()), here),
            };
            let ch = Channel {
                info: info.as_ref().map(|m| m[i][j].clone()),
                info_searched: far_info,
                peak: here,
                peak_searched: far_peak,
                end: *resp.y[i][j].last().unwrap_or(&f64::NAN),
                searched_to: longer
                    .as_ref()
                    .map_or(horizon, |l| l.grid.time(l.grid.n - 1)),
            };
            let label = report.label(i, j);
            report
                .warnings
                .extend(self.horizon_warnings(&label, horizon, &ch));
        }
        report.info = info;
        Ok(())
    }

    /// Exact figures of a continuous system (lti::exact_response), the
    /// samples completed by the times they name unless `points` was given,
    /// and the warnings about what the horizon or the grid miss.
    fn continuous_figures(
        &self,
        sys: &StateSpace,
        resp: &TimeResponse,
        search: f64,
        report: &mut ResponseReport,
    ) -> Result<(), SsError> {
        let grid = resp.grid;
        let horizon = grid.time(grid.n - 1);
        let exact = match exact_figures(sys, self.kind, horizon, search) {
            Ok(e) => e,
            Err(ExactError::Ss(e)) => return Err(e),
            Err(e) => {
                report.warnings.push(format!(
                    "{e}: the figures are read from the {} samples and may miss what happens between them; give `points` to sample finer",
                    grid.n
                ));
                if self.kind == ResponseKind::Step {
                    report.info = Some(response::step_info_of(sys, resp)?);
                }
                return Ok(());
            }
        };
        if exact.cut_short || exact.horizon < horizon * (1.0 - 1e-9) {
            report.warnings.push(format!(
                "lightly damped modes: the figures were searched up to {:.6e} s only ({} steps at most)",
                exact.searched_to,
                crate::lti::exact_response::MAX_SCAN_STEPS
            ));
        }
        let mut infos = Vec::new();
        for (i, row) in exact.channels.iter().enumerate() {
            let mut info_row = Vec::new();
            for (j, c) in row.iter().enumerate() {
                let ch = Channel {
                    info: c.info.clone(),
                    info_searched: c.info_searched.clone(),
                    peak: c.peak,
                    peak_searched: c.peak_searched,
                    end: c.end,
                    searched_to: exact.searched_to,
                };
                let label = report.label(i, j);
                report
                    .warnings
                    .extend(self.horizon_warnings(&label, horizon, &ch));
                if self.points.is_some() {
                    report
                        .warnings
                        .extend(self.grid_warning(&label, report, i, j, &ch));
                }
                info_row.push(c.info.clone());
                report.peaks[i][j] = c.peak;
            }
            infos.push(info_row);
        }
        if self.kind == ResponseKind::Step {
            report.info = Some(
                infos
                    .into_iter()
                    .map(|r| {
                        r.into_iter()
                            .map(|x| x.unwrap_or(Err(NoStepInfo::Unstable)))
                            .collect()
                    })
                    .collect(),
            );
        }
        if self.points.is_none() {
            complete_samples(report, &exact);
        }
        Ok(())
    }

    /// What the horizon cuts off: the settling, a later peak, or (impulse)
    /// a response that has not decayed.
    fn horizon_warnings(&self, label: &str, horizon: f64, c: &Channel) -> Vec<String> {
        let by = match self.duration {
            Some(_) => "`duration`",
            None => "the default duration",
        };
        let mut out = Vec::new();
        if let (Some(Ok(here)), Some(Ok(far))) = (&c.info, &c.info_searched) {
            match (here.settling_time, far.settling_time) {
                (None, Some(ts)) => out.push(format!(
                    "{label}{by} {horizon} s ends before the response settles: it stays within 2 % of its peak error |y - y_final| only from {ts:.6} s; the settling time is not reported"
                )),
                (None, None) => out.push(format!(
                    "{label}the response has not settled within 2 % of its peak error |y - y_final| by {:.6e} s",
                    c.searched_to
                )),
                _ => {}
            }
        }
        // A later extremum beyond the final value (a step's monotone
        // approach ends at the search end, which is no peak).
        let floor = match &c.info {
            Some(Ok(s)) => c.peak.1.abs().max(s.steady_state.abs()),
            _ => c.peak.1.abs(),
        };
        if c.peak_searched.0 < c.searched_to && c.peak_searched.1.abs() > floor * (1.0 + 1e-6) {
            out.push(format!(
                "{label}{by} {horizon} s ends before the peak: the response reaches {:.6} at {:.6} s",
                c.peak_searched.1, c.peak_searched.0
            ));
        }
        if self.kind == ResponseKind::Impulse && c.end.abs() > 0.02 * c.peak.1.abs() {
            out.push(format!(
                "{label}{by} {horizon} s ends before the impulse response decays: it is still at {:.2} % of its peak",
                100.0 * c.end.abs() / c.peak.1.abs()
            ));
        }
        out
    }

    /// A uniform grid of `points` that misses the peak by more than 1 %,
    /// or puts fewer than [`MIN_RISE_SAMPLES`] steps in the rise.
    fn grid_warning(
        &self,
        label: &str,
        report: &ResponseReport,
        i: usize,
        j: usize,
        c: &Channel,
    ) -> Option<String> {
        let dt = report.grid.dt;
        let n = report.grid.n;
        let fastest = report.poles.iter().map(|p| p.norm()).fold(0.0, f64::max);
        let (ts, ys) = sampled_peak(&report.t, &report.y[i][j]);
        if c.peak.1.abs() - ys.abs() > 0.01 * c.peak.1.abs() {
            return Some(format!(
                "{label}`points` {n} (dt = {dt:.3e} s) is too coarse for the fastest mode (|p| = {fastest:.4e} rad/s, 1/|p| = {:.3e} s): the samples peak at {ys:.6} at {ts:.6} s, the response at {:.6} at {:.6} s; the figures are exact, the samples (CSV, plot) are not: give more points or a shorter duration",
                1.0 / fastest,
                c.peak.1,
                c.peak.0
            ));
        }
        let rise = c.info.as_ref()?.as_ref().ok()?.rise_time?;
        // A rise of 0 is a jump through the feedthrough D: no grid shows more.
        (rise > 0.0 && rise < MIN_RISE_SAMPLES * dt).then(|| {
            format!(
                "{label}`points` {n} (dt = {dt:.3e} s) puts {:.1} samples in the rise ({rise:.6e} s): the samples (CSV, plot) do not show it; the figures are exact: give more points or a shorter duration",
                rise / dt
            )
        })
    }
}

/// The figures of one channel the warnings compare.
struct Channel {
    info: Option<Result<StepInfo, NoStepInfo>>,
    info_searched: Option<Result<StepInfo, NoStepInfo>>,
    peak: (f64, f64),
    peak_searched: (f64, f64),
    end: f64,
    searched_to: f64,
}

/// The first largest `|y|` of samples, as `(t, y)`.
fn sampled_peak(t: &[f64], y: &[f64]) -> (f64, f64) {
    let mut best = (t[0], y[0]);
    for (&tk, &yk) in t.iter().zip(y) {
        if yk.abs() > best.1.abs() {
            best = (tk, yk);
        }
    }
    best
}

/// Log-spaced times per decade added to the default grid.
pub const LOG_POINTS_PER_DECADE: f64 = 20.0;

/// The default continuous grid: the uniform one, plus times spaced
/// logarithmically from a twentieth of the fastest pole's time scale to the
/// horizon ([`LOG_POINTS_PER_DECADE`] a decade) and the times the figures
/// name, all exact values of the response (docs/responses.md §1).
fn complete_samples(report: &mut ResponseReport, exact: &ExactFigures) {
    let horizon = report.grid.time(report.grid.n - 1);
    let fastest = report.poles.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let mut extra: Vec<f64> = exact
        .channels
        .iter()
        .flatten()
        .flat_map(|c| c.marks.iter().copied())
        .collect();
    if fastest > 0.0 {
        let lo = 0.05 / fastest;
        let decades = (horizon / lo).log10();
        let count = (decades * LOG_POINTS_PER_DECADE).ceil().max(0.0) as usize;
        extra.extend((0..count).map(|k| lo * 10f64.powf(k as f64 / LOG_POINTS_PER_DECADE)));
    }
    let mut extra: Vec<f64> = extra
        .into_iter()
        .map(|t| exact.lattice.snap(t))
        .filter(|&t| t > 0.0 && t < horizon)
        .collect();
    extra.sort_by(f64::total_cmp);
    extra.dedup();
    let values: Vec<Vec<Vec<f64>>> = extra.iter().map(|&t| exact.lattice.sample(t)).collect();
    let mut merged: Vec<(f64, usize, usize)> = (0..report.t.len())
        .map(|k| (report.t[k], 0, k))
        .chain((0..extra.len()).map(|k| (extra[k], 1, k)))
        .collect();
    merged.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    merged.dedup_by(|b, a| a.0 == b.0);
    let pick = |&(_, src, k): &(f64, usize, usize), i: usize, j: usize| match src {
        0 => report.y[i][j][k],
        _ => values[k][i][j],
    };
    let y = (0..report.y.len())
        .map(|i| {
            (0..report.y[i].len())
                .map(|j| merged.iter().map(|m| pick(m, i, j)).collect())
                .collect()
        })
        .collect();
    report.t = merged.iter().map(|m| m.0).collect();
    report.y = y;
    report.composite = true;
}

fn unstable_message(source: &str, what: &str, poles: &[c64], ts: Option<f64>) -> String {
    let key = |z: &c64| if ts.is_some() { z.norm() } else { z.re };
    let worst = poles
        .iter()
        .max_by(|a, b| key(a).total_cmp(&key(b)))
        // `+ 0.0` turns an integrator's -0 into 0.
        .map_or(String::new(), |p| {
            format!(" (pole {})", fmt_complex(c64::new(p.re + 0.0, p.im + 0.0)))
        });
    format!(
        "{source}: the {what} is unstable{worst}: its response diverges, with no final value and no figures; nothing is written"
    )
}

fn closed_loop(g: &StateSpace, k: &StateSpace, source: &str) -> Result<StateSpace, StepError> {
    for (sys, which) in [(g, "plant"), (k, "controller")] {
        if sys.nu() != 1 || sys.ny() != 1 {
            return Err(StepError::input(format!(
                "{source}: a closed loop needs a SISO {which}, it has {} outputs and {} inputs",
                sys.ny(),
                sys.nu()
            )));
        }
    }
    response::closed_loop(g, k).map_err(|e| StepError::input(format!("{source}: closed loop: {e}")))
}

/// The response and its figures.
#[derive(Debug, Clone)]
pub struct ResponseReport {
    /// Whether this is the closed loop from reference to output.
    pub closed_loop: bool,
    /// Sample time of a discrete system, `None` when continuous.
    pub ts: Option<f64>,
    /// Poles of the simulated system.
    pub poles: Vec<c64>,
    /// Whether they are all strictly stable (always, in a report: an
    /// unstable system fails the step).
    pub stable: bool,
    /// Step figures per output and input (`None` for an impulse response).
    pub info: Option<Vec<Vec<Result<StepInfo, NoStepInfo>>>>,
    /// Step or impulse.
    pub kind: ResponseKind,
    /// The uniform grid (`points` over the horizon, or the sample time).
    pub grid: TimeGrid,
    /// Whether the samples are the uniform grid completed by log-spaced
    /// times and the times the figures name (the default continuous grid).
    pub composite: bool,
    /// Sample times, increasing.
    pub t: Vec<f64>,
    /// Samples, outputs x inputs x times.
    pub y: Vec<Vec<Vec<f64>>>,
    /// A continuous impulse response with `D != 0` omits the Dirac `D delta(t)`.
    pub impulse_drops_d: bool,
    /// What the horizon or the grid miss, one line each (settings as
    /// `` `key` ``).
    pub warnings: Vec<String>,
    /// The largest `|y|` of each channel over the horizon, `(t, y)`: exact
    /// for a continuous system, the largest sample of a discrete one.
    pub peaks: Vec<Vec<(f64, f64)>>,
}

/// Fewer samples than this within the rise of a continuous response on a
/// uniform grid of `points`: the samples do not show it, a warning says so.
pub const MIN_RISE_SAMPLES: f64 = 10.0;

#[derive(Serialize)]
struct ChannelJson<'a> {
    output: usize,
    input: usize,
    final_sample: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    step_info: Option<&'a StepInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    no_step_info: Option<String>,
    /// An impulse response's largest `|y|` and its time.
    #[serde(skip_serializing_if = "Option::is_none")]
    peak: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    peak_time: Option<f64>,
}

#[derive(Serialize)]
struct ReportJson<'a> {
    kind: ResponseKind,
    closed_loop: bool,
    ts: Option<f64>,
    grid: &'static str,
    dt: f64,
    samples: usize,
    duration: f64,
    stable: bool,
    poles: serde_json::Value,
    channels: Vec<ChannelJson<'a>>,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    impulse_drops_d: bool,
    warnings: &'a [String],
}

impl ResponseReport {
    /// `(output, input)` of every channel, 0-based, outputs first.
    pub fn channels(&self) -> Vec<(usize, usize)> {
        (0..self.y.len())
            .flat_map(|i| (0..self.y[i].len()).map(move |j| (i, j)))
            .collect()
    }

    /// `"output i <- input j: "` (1-based) for a MIMO system, else empty.
    fn label(&self, i: usize, j: usize) -> String {
        if self.channels().len() == 1 {
            String::new()
        } else {
            format!("output {} <- input {}: ", i + 1, j + 1)
        }
    }

    fn grid_name(&self) -> &'static str {
        match (self.ts, self.composite) {
            (Some(_), _) => "sample time",
            (None, true) => "composite",
            (None, false) => "uniform",
        }
    }
}

impl Serialize for ResponseReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let impulse = self.kind == ResponseKind::Impulse;
        let channels = self
            .channels()
            .into_iter()
            .map(|(i, j)| {
                let info = self.info.as_ref().map(|m| &m[i][j]);
                ChannelJson {
                    output: i + 1,
                    input: j + 1,
                    final_sample: *self.y[i][j].last().unwrap_or(&f64::NAN),
                    step_info: info.and_then(|r| r.as_ref().ok()),
                    no_step_info: info.and_then(|r| r.as_ref().err()).map(|e| e.to_string()),
                    peak: impulse.then(|| self.peaks[i][j].1.abs()),
                    peak_time: impulse.then(|| self.peaks[i][j].0),
                }
            })
            .collect();
        ReportJson {
            kind: self.kind,
            closed_loop: self.closed_loop,
            ts: self.ts,
            grid: self.grid_name(),
            dt: self.grid.dt,
            samples: self.t.len(),
            duration: *self.t.last().unwrap_or(&0.0),
            stable: self.stable,
            poles: super::complex_pairs(&self.poles),
            channels,
            impulse_drops_d: self.impulse_drops_d,
            warnings: &self.warnings,
        }
        .serialize(s)
    }
}

/// Six decimals, or six significant digits below 1e-3 (a rise in
/// microseconds is not "0.000000").
fn num(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-3 {
        format!("{v:.6e}")
    } else {
        format!("{v:.6}")
    }
}

fn opt(x: Option<f64>, unit: &str, none: &str) -> String {
    x.map_or(none.to_string(), |v| format!("{} {unit}", num(v)))
}

impl fmt::Display for ResponseReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.kind {
            ResponseKind::Step => "step",
            ResponseKind::Impulse => "impulse",
        };
        let of = if self.closed_loop {
            "closed loop G K / (1 + G K)"
        } else {
            "system"
        };
        let grid = match (self.ts, self.composite) {
            (Some(ts), _) => format!("{} samples at ts = {ts} s", self.t.len()),
            (None, true) => format!(
                "{} samples ({} uniform, dt = {} s, with log-spaced and figure times)",
                self.t.len(),
                self.grid.n,
                self.grid.dt
            ),
            (None, false) => format!("{} samples, dt = {} s", self.t.len(), self.grid.dt),
        };
        writeln!(
            f,
            "{what} response of the {of}: {grid}, 0 .. {:.6} s; {}",
            self.t.last().copied().unwrap_or(0.0),
            if self.stable { "stable" } else { "UNSTABLE" }
        )?;
        if self.impulse_drops_d {
            writeln!(
                f,
                "  note: D != 0, the Dirac part D delta(t) at t = 0 is not in the samples"
            )?;
        }
        for (i, j) in self.channels() {
            let y = &self.y[i][j];
            writeln!(
                f,
                "output {} <- input {}: final sample {:.6}",
                i + 1,
                j + 1,
                y.last().copied().unwrap_or(f64::NAN)
            )?;
            let Some(info) = self.info.as_ref().map(|m| &m[i][j]) else {
                let (t, p) = self.peaks[i][j];
                writeln!(f, "  peak |y|             {:.6} at {} s", p.abs(), num(t))?;
                continue;
            };
            match info {
                Err(e) => writeln!(f, "  no step figures: {e}")?,
                Ok(s) => {
                    writeln!(
                        f,
                        "  rise time (10-90 %)  {}",
                        opt(s.rise_time, "s", "not reached")
                    )?;
                    writeln!(
                        f,
                        "  settling time (2 %)  {}",
                        opt(s.settling_time, "s", "not settled within the horizon")
                    )?;
                    writeln!(f, "  overshoot            {:.6} %", s.overshoot)?;
                    writeln!(f, "  undershoot           {:.6} %", s.undershoot)?;
                    writeln!(
                        f,
                        "  peak                 {:.6} at {} s",
                        s.peak,
                        num(s.peak_time)
                    )?;
                    writeln!(f, "  final value (DC)     {:.6}", s.steady_state)?;
                    writeln!(f, "  steady-state error   {:.6}", s.steady_state_error)?;
                }
            }
        }
        Ok(())
    }
}
