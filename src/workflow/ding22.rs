//! The \[Ding22\] study (docs/math.md §5): what `fts ding22` does. On the
//! lumped two-mass FTS with the W1-W3 disturbance filters: the H2-optimal
//! controller, a PID baseline tuned for the same cost, the error budget
//! (per-source PSD, cumulative amplitude spectrum, RMS) and, optionally, a
//! structural sweep of the flexure that re-synthesises at every point. The
//! numerical work is [`crate::synth::ding22`].

use super::{StepError, Validate, positive, whole_number};
use crate::io::plot::{PlotError, PlotFormat, Series, line_chart_log_x};
use crate::io::ss_json;
use crate::lti::logspace;
use crate::synth::budget::ErrorBudget;
use crate::synth::ding22::{
    Design, Ding22Error, Ding22Problem, Ding22Weights, Evaluation, PidBaseline, SOURCES,
    SensedBody, Sweep, TwoMassParams, budget, design, sweep, tune_pid,
};
use crate::synth::genplant::SynthError;
use serde::{Deserialize, Serialize, Serializer};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::fmt;
use std::time::Instant;

/// Settings of the study; every parameter defaults to \[Ding22\] Table 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ding22Study {
    /// `m1 + m2`, kg; default 0.074.
    pub m12: f64,
    /// Flexure stiffness, N/m; default 21965.
    pub k2: f64,
    /// Flexure damping, N s/m; default 2.28.
    pub c2: f64,
    /// Tool mass, kg; default 0.008.
    pub m4: f64,
    /// Tool interface stiffness, N/m; default 56285.
    pub k4: f64,
    /// Tool interface damping, N s/m; default 6.18.
    pub c4: f64,
    /// Body the sensor (and the tool) sits on; default moving-body (`m12`, as
    /// \[Ding22\] describes), `m4` the flexible mass.
    pub sensor: SensorChoice,
    /// Gain of W1, the sensor noise, m; default 1.36e-6.
    pub sensor_noise: f64,
    /// Gain of W2, the current-loop force noise, N; default 1.64e-7.
    pub current_noise: f64,
    /// Gain of W3, the base vibration, m; default 2.83e-9.
    pub base_noise: f64,
    /// `w_b` of `W_e`, Hz; default 1100.
    pub wb_hz: Option<f64>,
    /// Re-synthesise over a log-spaced grid, `k2=LO:HI:N,c2=LO:HI:N`
    /// (either part may be left out: that parameter stays fixed); the
    /// report is for the best point. Default: no sweep.
    pub sweep: Option<String>,
    /// Highest frequency of the budget, Hz; default 1e5.
    pub fmax: f64,
    /// Log-spaced points of the budget grid (extra points are added around
    /// lightly damped poles); default 3000.
    #[serde(deserialize_with = "whole_number")]
    pub points: usize,
    /// Tune and report the PID baseline; default true.
    pub pid: bool,
}

/// Where `fts ding22` senses (`sensor`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum SensorChoice {
    /// The moving body `m12 = m1 + m2` (collocated with the force).
    #[default]
    #[serde(rename = "moving-body")]
    MovingBody,
    /// The flexible mass `m4` (non-collocated).
    #[serde(rename = "m4")]
    M4,
}

impl crate::workflow::Choices for SensorChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "moving-body",
            "Sensor and tool on m12 = m1 + m2, as Ding22 describes (collocated with the force)",
        ),
        (
            "m4",
            "Sensor and tool on the flexible mass m4 (non-collocated; fts's earlier reading)",
        ),
    ];
}

impl SensorChoice {
    fn name(self) -> &'static str {
        match self {
            SensorChoice::MovingBody => "moving-body",
            SensorChoice::M4 => "m4",
        }
    }
}

impl Default for Ding22Study {
    fn default() -> Self {
        let m = TwoMassParams::default();
        let w = Ding22Weights::default();
        Self {
            m12: m.m12,
            k2: m.k2,
            c2: m.c2,
            m4: m.m4,
            k4: m.k4,
            c4: m.c4,
            sensor: SensorChoice::MovingBody,
            sensor_noise: w.sensor_noise,
            current_noise: w.current_noise,
            base_noise: w.base_noise,
            wb_hz: None,
            sweep: None,
            fmax: 1e5,
            points: 3000,
            pid: true,
        }
    }
}

impl Validate for Ding22Study {
    fn validate(&self) -> Result<(), StepError> {
        self.prepare().map(|_| ())
    }
}

/// The swept `k2` and `c2` values (`None`: not swept).
pub type SweepAxes = (Option<Vec<f64>>, Option<Vec<f64>>);

/// Parses `k2=LO:HI:N,c2=LO:HI:N` into log-spaced axes.
pub fn parse_sweep(spec: &str) -> Result<SweepAxes, StepError> {
    let usage = "expected `sweep` k2=LO:HI:N,c2=LO:HI:N (log-spaced, 0 < LO <= HI, N >= 1)";
    if spec.trim().is_empty() {
        return Err(sweep_error(format!("empty specification; {usage}")));
    }
    let (mut k2, mut c2) = (None, None);
    for item in spec.split(',') {
        let (name, range) = item
            .split_once('=')
            .ok_or_else(|| sweep_error(format!("'{item}' has no '='; {usage}")))?;
        let values = sweep_axis(item, range, usage)?;
        let slot = match name.trim() {
            "k2" => &mut k2,
            "c2" => &mut c2,
            other => {
                return Err(sweep_error(format!(
                    "unknown parameter '{other}' (k2 and c2 can be swept)"
                )));
            }
        };
        if slot.is_some() {
            return Err(sweep_error(format!("'{}' given twice", name.trim())));
        }
        *slot = Some(values);
    }
    Ok((k2, c2))
}

/// A message about the `sweep` setting.
fn sweep_error(message: String) -> StepError {
    StepError::input(format!("`sweep`: {message}"))
}

/// One axis, `LO:HI:N` of the item `name=LO:HI:N`.
fn sweep_axis(item: &str, range: &str, usage: &str) -> Result<Vec<f64>, StepError> {
    let parts: Vec<&str> = range.split(':').collect();
    if parts.len() != 3 {
        return Err(sweep_error(format!("'{item}': {usage}")));
    }
    let number = |which: &str, text: &str| {
        text.trim()
            .parse::<f64>()
            .map_err(|_| sweep_error(format!("'{item}': {which} '{text}' is not a number")))
    };
    let lo = number("LO", parts[0])?;
    let hi = number("HI", parts[1])?;
    let n: usize = parts[2].trim().parse().map_err(|_| {
        sweep_error(format!(
            "'{item}': N '{}' is not a positive integer",
            parts[2]
        ))
    })?;
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) || n == 0 || n > 1000 {
        return Err(sweep_error(format!(
            "'{item}': need 0 < LO <= HI (finite) and 1 <= N <= 1000"
        )));
    }
    if n == 1 && hi != lo {
        return Err(sweep_error(format!("'{item}': N = 1 needs LO = HI")));
    }
    Ok(if n == 1 {
        vec![lo]
    } else {
        logspace(lo, hi, n)
    })
}

/// `k2 must be ...` as `` `k2` must be ...``: a parameter message names its
/// setting.
fn setting_named(message: &str) -> String {
    let name_len = message
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(0);
    if name_len > 0 && message[name_len..].starts_with(" must") {
        format!("`{}`{}", &message[..name_len], &message[name_len..])
    } else {
        message.to_owned()
    }
}

fn step_error(e: Ding22Error) -> StepError {
    match e {
        Ding22Error::Param(m) => StepError::input(setting_named(&m)),
        Ding22Error::Synth(SynthError::Numerical(m)) | Ding22Error::Numerical(m) => {
            StepError::computation(format!("ding22: numerical failure: {m}"))
        }
        Ding22Error::Synth(other) => StepError::input(format!("ding22: {other}")),
    }
}

/// The PID baseline: its gains, figures and budget.
#[derive(Debug, Clone)]
pub struct PidComparison {
    /// The tuned gains.
    pub gains: PidBaseline,
    /// Its closed-loop figures.
    pub evaluation: Evaluation,
    /// Its error budget, on the grid of the H2 design's.
    pub budget: ErrorBudget,
}

/// The structural sweep and how long it took.
#[derive(Debug, Clone)]
pub struct SweepRun {
    /// RMS and cost at every grid point, and the best point.
    pub sweep: Sweep,
    /// Wall-clock time of the sweep, s.
    pub seconds: f64,
}

/// What the study found: the design at the (best) flexure, its budget, the
/// PID baseline and the sweep.
#[derive(Debug, Clone)]
pub struct Ding22Report {
    /// The H2 design, with the problem it solves.
    pub design: Design,
    /// Wall-clock time of the synthesis, s.
    pub synthesis_seconds: f64,
    /// Highest frequency of the budget, Hz.
    pub fmax: f64,
    /// The H2 design's error budget.
    pub budget: ErrorBudget,
    /// The PID baseline (`None` when not asked for).
    pub pid: Option<PidComparison>,
    /// The sweep (`None` when not asked for).
    pub sweep: Option<SweepRun>,
}

impl Ding22Study {
    /// The problem and the swept axes, in that order of checking.
    fn prepare(&self) -> Result<(Ding22Problem, Option<SweepAxes>), StepError> {
        if !(self.fmax.is_finite() && self.fmax > 1e-3) {
            return Err(StepError::setting(
                "fmax",
                format!("must be above 1e-3 Hz, got {}", super::fmt_value(self.fmax)),
            ));
        }
        if self.points < 2 {
            return Err(StepError::setting(
                "points",
                format!("expected at least 2 points, got {}", self.points),
            ));
        }
        self.check_weights()?;
        let problem = self.problem()?;
        let axes = self.sweep.as_deref().map(parse_sweep).transpose()?;
        Ok((problem, axes))
    }

    /// The noise levels and `wb_hz`, named by their settings (the weights'
    /// own check names `W1`.. and takes `w_b` in rad/s).
    fn check_weights(&self) -> Result<(), StepError> {
        positive("sensor_noise", self.sensor_noise)?;
        for (field, v) in [
            ("current_noise", self.current_noise),
            ("base_noise", self.base_noise),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(StepError::setting(
                    field,
                    format!("expected a finite number >= 0, got {}", super::fmt_value(v)),
                ));
            }
        }
        match self.wb_hz {
            Some(x) => positive("wb_hz", x).map(|_| ()),
            None => Ok(()),
        }
    }

    fn problem(&self) -> Result<Ding22Problem, StepError> {
        let mech = TwoMassParams {
            m12: self.m12,
            k2: self.k2,
            c2: self.c2,
            m4: self.m4,
            k4: self.k4,
            c4: self.c4,
            sensor: match self.sensor {
                SensorChoice::MovingBody => SensedBody::MovingBody,
                SensorChoice::M4 => SensedBody::ToolMass,
            },
        };
        let mut w = Ding22Weights {
            sensor_noise: self.sensor_noise,
            current_noise: self.current_noise,
            base_noise: self.base_noise,
            ..Ding22Weights::default()
        };
        if let Some(x) = self.wb_hz {
            w.wb = 2.0 * PI * x;
        }
        Ding22Problem::new(mech, w).map_err(step_error)
    }

    /// Runs the study.
    pub fn run(&self) -> Result<Ding22Report, StepError> {
        self.run_with_progress(&mut |_, _| {})
    }

    /// Runs the study; `progress(done, total)` after each point of the sweep.
    pub fn run_with_progress(
        &self,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Ding22Report, StepError> {
        let (mut problem, axes) = self.prepare()?;
        let swept = match axes {
            None => None,
            Some((k2, c2)) => {
                let k2 = k2.unwrap_or_else(|| vec![problem.mech.k2]);
                let c2 = c2.unwrap_or_else(|| vec![problem.mech.c2]);
                let started = Instant::now();
                let s = sweep(&problem, &k2, &c2, progress).map_err(step_error)?;
                let seconds = started.elapsed().as_secs_f64();
                problem = problem.with_flexure(s.k2[s.best.0], s.c2[s.best.1]);
                Some(SweepRun { sweep: s, seconds })
            }
        };
        let started = Instant::now();
        let design = design(&problem).map_err(step_error)?;
        let synthesis_seconds = started.elapsed().as_secs_f64();
        let budget = self.budget(&design.optimal)?;
        let pid = if self.pid {
            Some(self.pid_baseline(&problem)?)
        } else {
            None
        };
        Ok(Ding22Report {
            design,
            synthesis_seconds,
            fmax: self.fmax,
            budget,
            pid,
            sweep: swept,
        })
    }

    fn budget(&self, e: &Evaluation) -> Result<ErrorBudget, StepError> {
        budget(e, self.fmax, self.points).map_err(step_error)
    }

    fn pid_baseline(&self, problem: &Ding22Problem) -> Result<PidComparison, StepError> {
        let (gains, evaluation) = tune_pid(problem).map_err(step_error)?;
        let budget = self.budget(&evaluation)?;
        Ok(PidComparison {
            gains,
            evaluation,
            budget,
        })
    }
}

const NM: f64 = 1e9;

impl Ding22Report {
    /// The mechanics of the design (the best point of a sweep).
    pub fn mechanics(&self) -> TwoMassParams {
        self.design.problem.mech
    }

    /// The body sensed.
    pub fn settings_sensor(&self) -> SensorChoice {
        match self.mechanics().sensor {
            SensedBody::MovingBody => SensorChoice::MovingBody,
            SensedBody::ToolMass => SensorChoice::M4,
        }
    }

    /// The two undamped modes, Hz.
    pub fn natural_frequencies_hz(&self) -> [f64; 2] {
        let wn = self.mechanics().natural_frequencies();
        [wn[0] / (2.0 * PI), wn[1] / (2.0 * PI)]
    }

    /// The H2 design's budget as CSV: `freq_hz`, `psd_w*`, `psd_total`,
    /// `cas_w*`, `cas_total`.
    pub fn budget_csv(&self) -> String {
        let b = &self.budget;
        let cas = b.cas_per_source();
        let mut out = String::from("freq_hz");
        for i in 0..b.psd.len() {
            out.push_str(&format!(",psd_w{}", i + 1));
        }
        out.push_str(",psd_total");
        for i in 0..b.psd.len() {
            out.push_str(&format!(",cas_w{}", i + 1));
        }
        out.push_str(",cas_total\n");
        for k in 0..b.freq_hz.len() {
            out.push_str(&format!("{}", b.freq_hz[k]));
            for p in &b.psd {
                out.push_str(&format!(",{}", p[k]));
            }
            out.push_str(&format!(",{}", b.total_psd[k]));
            for c in &cas {
                out.push_str(&format!(",{}", c[k]));
            }
            out.push_str(&format!(",{}\n", b.cas[k]));
        }
        out
    }

    /// An SVG of the cumulative amplitude spectra (per source and total,
    /// and the PID's total).
    pub fn budget_svg(&self) -> Result<String, PlotError> {
        let bytes = self.budget_plot(PlotFormat::Svg)?;
        Ok(String::from_utf8(bytes).expect("the SVG backend writes UTF-8"))
    }

    /// [`Self::budget_svg`] in `format`.
    pub fn budget_plot(&self, format: PlotFormat) -> Result<Vec<u8>, PlotError> {
        let b = &self.budget;
        let pid = self.pid.as_ref().map(|p| &p.budget);
        let nm = |v: &[f64]| v.iter().map(|x| x * NM).collect::<Vec<f64>>();
        let cas: Vec<Vec<f64>> = b.cas_per_source().iter().map(|c| nm(c)).collect();
        let total = nm(&b.cas);
        let pid_total = pid.map(|p| nm(&p.cas));
        let mut series: Vec<Series<'_>> = SOURCES
            .iter()
            .zip(&cas)
            .map(|(label, y)| Series {
                label,
                x: &b.freq_hz,
                y,
            })
            .collect();
        series.push(Series {
            label: "total (H2)",
            x: &b.freq_hz,
            y: &total,
        });
        if let (Some(p), Some(y)) = (pid, pid_total.as_ref()) {
            series.push(Series {
                label: "total (PID)",
                x: &p.freq_hz,
                y,
            });
        }
        line_chart_log_x(
            "Ding22 error budget: cumulative amplitude spectrum",
            "frequency (Hz)",
            "CAS (nm)",
            &series,
            format,
        )
    }

    fn h2_json(&self) -> Value {
        let h2 = &self.design.h2;
        json!({
            "closed_loop_h2_norm": h2.h2_norm,
            "stable": h2.stable,
            "riccati_residuals": {"x": h2.x_residual, "y": h2.y_residual},
            "controller_order": h2.k.nx(),
            "controller": ss_json::ss_to_value(&h2.k),
            "synthesis_seconds": self.synthesis_seconds,
        })
    }
}

fn eval_json(e: &Evaluation) -> Value {
    json!({
        "stable": e.stable,
        "h2_cost": e.cost,
        "rms_m": e.rms,
        "rms_per_source_m": e.rms_per_source,
        "u_rms_n": e.u_rms,
        "bandwidth_hz": e.bandwidth_hz,
    })
}

fn pid_json(p: &PidComparison) -> Value {
    let g = &p.gains;
    let mut v = eval_json(&p.evaluation);
    v["gains"] = json!({"kp": g.kp, "ki": g.ki, "kd": g.kd, "tau": g.tau});
    v
}

fn sweep_json(run: &SweepRun) -> Value {
    let s = &run.sweep;
    let (i, j) = s.best;
    json!({
        "k2": s.k2, "c2": s.c2, "rms_m": s.rms, "h2_cost": s.cost,
        "best": {"k2": s.k2[i], "c2": s.c2[j], "rms_m": s.rms[i][j], "index": [i, j]},
        "interior": s.interior,
        "seconds": run.seconds,
    })
}

impl Serialize for Ding22Report {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let m = self.mechanics();
        let b = &self.budget;
        let mut v = json!({
            "mechanics": {"m12": m.m12, "k2": m.k2, "c2": m.c2, "m4": m.m4, "k4": m.k4, "c4": m.c4,
                "sensor": self.settings_sensor().name(),
                "natural_frequencies_hz": self.natural_frequencies_hz()},
            "sources": SOURCES,
            "h2": self.h2_json(),
            "optimal": eval_json(&self.design.optimal),
            "budget": {"fmax_hz": self.fmax, "grid_points": b.freq_hz.len(),
                "grid_rms_m": b.rms, "grid_rms_per_source_m": b.rms_per_source},
            "pid": self.pid.as_ref().map(pid_json),
        });
        if let Some(run) = &self.sweep {
            v["sweep"] = sweep_json(run);
        }
        v.serialize(s)
    }
}

/// One design's figures: cost, RMS, force, bandwidth, and the RMS per source.
fn write_evaluation(f: &mut fmt::Formatter<'_>, label: &str, e: &Evaluation) -> fmt::Result {
    writeln!(
        f,
        "{label}: H2 cost {:.6e}, RMS error {:.4} nm, force RMS {:.4e} N, bandwidth {:.1} Hz",
        e.cost,
        e.rms * NM,
        e.u_rms,
        e.bandwidth_hz
    )?;
    for (name, r) in SOURCES.iter().zip(&e.rms_per_source) {
        writeln!(
            f,
            "    {name:<26} {:>12.4} nm ({:5.1}% of the power)",
            r * NM,
            100.0 * r * r / (e.rms * e.rms).max(1e-300)
        )?;
    }
    Ok(())
}

/// The sweep's RMS table, its best point and its time.
fn write_sweep(f: &mut fmt::Formatter<'_>, run: &SweepRun) -> fmt::Result {
    let s = &run.sweep;
    writeln!(f, "RMS error (nm), rows k2 (N/m), columns c2 (N s/m):")?;
    write!(f, "{:>12}", "k2 \\ c2")?;
    for c in &s.c2 {
        write!(f, " {c:>11.4e}")?;
    }
    writeln!(f)?;
    for (i, k) in s.k2.iter().enumerate() {
        write!(f, "{k:>12.4e}")?;
        for (j, r) in s.rms[i].iter().enumerate() {
            let mark = if (i, j) == s.best { "*" } else { " " };
            write!(f, " {:>10.4}{mark}", r * NM)?;
        }
        writeln!(f)?;
    }
    let (i, j) = s.best;
    writeln!(
        f,
        "best: k2 = {:.6e} N/m, c2 = {:.6e} N s/m, RMS {:.4} nm ({})",
        s.k2[i],
        s.c2[j],
        s.rms[i][j] * NM,
        if s.interior {
            "interior optimum of the grid"
        } else {
            "on the grid edge: the optimum may lie outside the grid"
        }
    )?;
    writeln!(
        f,
        "sweep: {} syntheses in {:.2} s; the report below is for the best point\n",
        s.k2.len() * s.c2.len(),
        run.seconds
    )
}

impl fmt::Display for Ding22Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(run) = &self.sweep {
            write_sweep(f, run)?;
        }
        let m = self.mechanics();
        let [f1, f2] = self.natural_frequencies_hz();
        let h2 = &self.design.h2;
        writeln!(
            f,
            "two-mass plant: m12 = {} kg, k2 = {} N/m, c2 = {} N s/m, m4 = {} kg, k4 = {} N/m, c4 = {} N s/m",
            m.m12, m.k2, m.c2, m.m4, m.k4, m.c4
        )?;
        writeln!(
            f,
            "sensor and tool on {}; undamped modes {f1:.2} Hz and {f2:.2} Hz",
            match self.settings_sensor() {
                SensorChoice::MovingBody => "the moving body m12 (x1)",
                SensorChoice::M4 => "the flexible mass m4 (x4)",
            }
        )?;
        writeln!(
            f,
            "H2 controller: {} states, closed loop {}, Riccati residual X {:.1e}, Y {:.1e}, {:.1} ms",
            h2.k.nx(),
            if h2.stable { "stable" } else { "UNSTABLE" },
            h2.x_residual,
            h2.y_residual,
            self.synthesis_seconds * 1e3
        )?;
        write_evaluation(f, "H2 optimal", &self.design.optimal)?;
        if let Some(p) = &self.pid {
            let g = &p.gains;
            writeln!(
                f,
                "PID baseline (tuned for the same H2 cost): kp {:.4e}, ki {:.4e}, kd {:.4e}, tau {:.4e}",
                g.kp, g.ki, g.kd, g.tau
            )?;
            write_evaluation(f, "PID", &p.evaluation)?;
        }
        writeln!(
            f,
            "budget grid: {} points to {} Hz, CAS(fmax) = {:.4} nm (exact RMS {:.4} nm)",
            self.budget.freq_hz.len(),
            self.fmax,
            self.budget.rms * NM,
            self.design.optimal.rms * NM
        )
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn sweep_spec() {
        let (k, c) = parse_sweep("k2=1e4:1e6:3,c2=1:100:3").unwrap();
        let k = k.unwrap();
        assert_eq!(k.len(), 3);
        assert!((k[1] - 1e5).abs() < 1e-6);
        assert_eq!(c.unwrap().len(), 3);
        let (k, c) = parse_sweep("c2=2:2:1").unwrap();
        assert!(k.is_none() && c == Some(vec![2.0]));
        for s in [
            "",
            "k2",
            "k2=1:2",
            "k2=-1:2:3",
            "k2=2:1:3",
            "k2=1:2:0",
            "m4=1:2:3",
            "k2=1:2:x",
            "k2=1:1:1,k2=1:1:1",
            "k2=1:2:1",
        ] {
            assert!(parse_sweep(s).is_err(), "{s}");
        }
    }

    pub fn settings_deserialise_with_their_defaults() {
        let s: Ding22Study = toml::from_str("").unwrap();
        assert_eq!(s, Ding22Study::default());
        let s: Ding22Study = toml::from_str("k2 = 3e4\npid = false").unwrap();
        assert_eq!(s.k2, 3e4);
        assert!(!s.pid);
        assert!(toml::from_str::<Ding22Study>("k3 = 1").is_err());
    }

    pub fn bad_settings_name_their_key() {
        let bad = Ding22Study {
            m12: -1.0,
            ..Ding22Study::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert_eq!(e, "`m12` must be a positive finite number, got -1");
        let bad = Ding22Study {
            fmax: 0.0,
            ..Ding22Study::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(StepError::Input {
                field: Some("fmax"),
                ..
            })
        ));
    }

    pub fn the_study_reports_the_design_and_its_budget() {
        let step = Ding22Study {
            points: 200,
            pid: false,
            ..Ding22Study::default()
        };
        let report = step.run().unwrap();
        assert!(report.design.h2.stable);
        assert!(report.pid.is_none() && report.sweep.is_none());
        let v = serde_json::to_value(&report).unwrap();
        assert_eq!(v["pid"], Value::Null);
        assert!(
            report
                .to_string()
                .starts_with("two-mass plant: m12 = 0.074 kg")
        );
        assert!(report.budget_csv().starts_with("freq_hz,psd_w1,"));
    }
}
