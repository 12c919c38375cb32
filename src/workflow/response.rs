//! `fts response step|impulse`: the time response of a system, or of the
//! closed loop it makes with a controller, with the step-response figures
//! of MATLAB `stepinfo` (docs/responses.md).

use super::fmt_complex;
use super::{StepError, Validate, positive};
use crate::lti::c64;
use crate::lti::response::{
    self, MAX_RESPONSE_SAMPLES, NoStepInfo, ResponseKind, StepInfo, TimeGrid, TimeResponse,
};
use crate::lti::ss::StateSpace;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Default number of grid points of a continuous response.
pub const DEFAULT_POINTS: usize = 2001;

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
    fn grid(&self, sys: &StateSpace) -> Result<TimeGrid, StepError> {
        let duration = match self.duration {
            Some(d) => d,
            None => response::default_duration(sys)
                .map_err(|e| StepError::computation(format!("poles: {e}")))?,
        };
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
        let grid = self.grid(&sys)?;
        let resp = response::time_response(&sys, self.kind, &grid).map_err(|e| match e {
            response::ResponseError::BadGrid(m) => StepError::setting("duration", m),
            response::ResponseError::Ss(e) => StepError::computation(format!("{source}: {e}")),
        })?;
        let comp = |e: crate::lti::ss::SsError| StepError::computation(format!("{source}: {e}"));
        let poles = sys.poles().map_err(comp)?;
        let stable = sys.is_stable().map_err(comp)?;
        let info = match self.kind {
            ResponseKind::Step => Some(response::step_info_of(&sys, &resp).map_err(comp)?),
            ResponseKind::Impulse => None,
        };
        Ok(ResponseReport {
            closed_loop: inputs.controller.is_some(),
            ts: sys.ts,
            poles,
            stable,
            info,
            response: resp,
        })
    }
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
    /// Whether they are all strictly stable.
    pub stable: bool,
    /// Step figures per output and input (`None` for an impulse response).
    pub info: Option<Vec<Vec<Result<StepInfo, NoStepInfo>>>>,
    /// The samples.
    pub response: TimeResponse,
}

/// Fewer samples than this within the rise of a continuous response make
/// its figures grid-bound: the report says so.
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
    #[serde(skip_serializing_if = "Option::is_none")]
    warning: Option<String>,
}

#[derive(Serialize)]
struct ReportJson<'a> {
    kind: ResponseKind,
    closed_loop: bool,
    ts: Option<f64>,
    dt: f64,
    samples: usize,
    duration: f64,
    stable: bool,
    poles: serde_json::Value,
    channels: Vec<ChannelJson<'a>>,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    impulse_drops_d: bool,
}

impl ResponseReport {
    /// `(output, input)` of every channel, 0-based, outputs first.
    pub fn channels(&self) -> Vec<(usize, usize)> {
        let r = &self.response;
        (0..r.y.len())
            .flat_map(|i| (0..r.y[i].len()).map(move |j| (i, j)))
            .collect()
    }

    /// The sample time of a discrete system, `None` when continuous.
    fn ts(&self) -> Option<f64> {
        self.ts
    }

    /// A continuous response whose rise spans fewer than
    /// [`MIN_RISE_SAMPLES`] grid steps: its figures are set by the grid.
    pub fn coarse_grid(&self, i: usize, j: usize) -> Option<String> {
        let info = self.info.as_ref()?[i][j].as_ref().ok()?;
        let rise = info.rise_time?;
        let dt = self.response.grid.dt;
        (self.ts.is_none() && rise < MIN_RISE_SAMPLES * dt).then(|| {
            format!(
                "the rise spans {:.0} grid steps of {dt:.3e} s: the figures are only as fine as the grid; shorten the duration or add points",
                rise / dt
            )
        })
    }
}

impl Serialize for ResponseReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let g = &self.response.grid;
        let channels = self
            .channels()
            .into_iter()
            .map(|(i, j)| {
                let info = self.info.as_ref().map(|m| &m[i][j]);
                ChannelJson {
                    output: i + 1,
                    input: j + 1,
                    final_sample: *self.response.y[i][j].last().unwrap_or(&f64::NAN),
                    step_info: info.and_then(|r| r.as_ref().ok()),
                    no_step_info: info.and_then(|r| r.as_ref().err()).map(|e| e.to_string()),
                    warning: self.coarse_grid(i, j),
                }
            })
            .collect();
        ReportJson {
            kind: self.response.kind,
            closed_loop: self.closed_loop,
            ts: self.ts(),
            dt: g.dt,
            samples: g.n,
            duration: g.time(g.n - 1),
            stable: self.stable,
            poles: super::complex_pairs(&self.poles),
            channels,
            impulse_drops_d: self.response.impulse_drops_d,
        }
        .serialize(s)
    }
}

fn opt(x: Option<f64>, unit: &str, none: &str) -> String {
    x.map_or(none.to_string(), |v| format!("{v:.6} {unit}"))
}

impl fmt::Display for ResponseReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let g = &self.response.grid;
        let what = match self.response.kind {
            ResponseKind::Step => "step",
            ResponseKind::Impulse => "impulse",
        };
        let of = if self.closed_loop {
            "closed loop G K / (1 + G K)"
        } else {
            "system"
        };
        writeln!(
            f,
            "{what} response of the {of}: {} samples, dt = {} s, 0 .. {:.6} s; {}",
            g.n,
            g.dt,
            g.time(g.n - 1),
            if self.stable { "stable" } else { "UNSTABLE" }
        )?;
        if !self.stable {
            let worst = self.poles.iter().max_by(|a, b| {
                let key = |z: &&c64| if self.ts().is_some() { z.norm() } else { z.re };
                key(a).total_cmp(&key(b))
            });
            if let Some(p) = worst {
                writeln!(f, "  rightmost pole {}", fmt_complex(*p))?;
            }
        }
        if self.response.impulse_drops_d {
            writeln!(
                f,
                "  note: D != 0, the Dirac part D delta(t) at t = 0 is not in the samples"
            )?;
        }
        for (i, j) in self.channels() {
            let y = &self.response.y[i][j];
            writeln!(
                f,
                "output {} <- input {}: final sample {:.6}",
                i + 1,
                j + 1,
                y.last().copied().unwrap_or(f64::NAN)
            )?;
            let Some(info) = self.info.as_ref().map(|m| &m[i][j]) else {
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
                        "  peak                 {:.6} at {:.6} s",
                        s.peak, s.peak_time
                    )?;
                    writeln!(f, "  final value (DC)     {:.6}", s.steady_state)?;
                    writeln!(f, "  steady-state error   {:.6}", s.steady_state_error)?;
                    if let Some(w) = self.coarse_grid(i, j) {
                        writeln!(f, "  warning: {w}")?;
                    }
                }
            }
        }
        Ok(())
    }
}
