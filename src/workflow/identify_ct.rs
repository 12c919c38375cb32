//! Continuous-time identification steps (docs/identify-ct.md):
//! `fts identify ct` (SRIVC from an input/output record) and
//! `fts identify ct-frd` (Levy / Sanathanan–Koerner / Levenberg–Marquardt
//! from a frequency response), both reporting fit % in the time and the
//! frequency domain where the data allow.

use super::identify::{LinearInputs, Prepared, RecordSettings};
use super::{StepError, Validate, fmt_complex, positive, some_whole_number, whole_number};
use crate::ident::ct::{
    CtError, CtModel, FreqData, FreqFitParams, FreqWeighting, SrivcParams, SvfTrial, freq_fit,
    freq_fit_percent, periodic_frf, srivc, time_fit_percent,
};
use crate::ident::data::Detrend;
use crate::ident::freq::{WelchParams, welch};
use crate::ident::periodic::period_in_samples;
use crate::lti::{TransferFunction, c64};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Least coherence of a Welch bin used for the frequency-domain fit when
/// the record is not periodic.
pub const MIN_COHERENCE: f64 = 0.9;

/// `fts identify ct`: `e^(-s delay) B(s)/A(s)` by SRIVC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyCt {
    /// Sample time, s; default the record's time column.
    pub ts: Option<f64>,
    /// Trend removed from each record; default none.
    pub detrend: Detrend,
    /// Estimate on this leading fraction, validate on the rest; default none.
    pub split: Option<f64>,
    /// Poles (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub np: Option<usize>,
    /// Zeros, at most `np` (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nz: Option<usize>,
    /// Known input delay, s; default 0.
    pub delay: f64,
    /// Start-estimate filter cutoff, Hz; default: six tried over [0.002, 0.2]/Ts.
    pub svf_cutoff_hz: Option<f64>,
    /// SRIVC iteration cap; default 50.
    #[serde(deserialize_with = "whole_number")]
    pub max_iterations: usize,
    /// Period of a periodic (multisine) input, s: the frequency fit uses the
    /// response at its lines; default none (Welch bins of coherence >= 0.9).
    pub period: Option<f64>,
    /// Whole periods skipped as transient before averaging; default 1.
    #[serde(deserialize_with = "whole_number")]
    pub skip_periods: usize,
    /// Welch segment length, samples, of the aperiodic record's estimate;
    /// default chosen from the record ([`crate::ident::freq::choose_segment`]).
    #[serde(deserialize_with = "some_whole_number")]
    pub segment: Option<usize>,
}

impl Default for IdentifyCt {
    fn default() -> Self {
        IdentifyCt {
            ts: None,
            detrend: Detrend::None,
            split: None,
            np: None,
            nz: None,
            delay: 0.0,
            svf_cutoff_hz: None,
            max_iterations: SrivcParams::new(1, 0, 1.0).max_iterations,
            period: None,
            skip_periods: 1,
            segment: None,
        }
    }
}

/// The most poles a continuous model is identified with: beyond, the
/// powers of `s` in the regression span more than the float range over any
/// useful band (docs/formats.md, Bounds).
pub const MAX_CT_POLES: usize = 20;

/// The most SRIVC work, samples x poles x iterations: each of the 6 start
/// cutoffs runs up to `max_iterations` filter passes of O(samples x np);
/// 20,000 samples at 8 poles and 50 iterations (8e6) take about 15 s, at
/// 16 poles (1.6e7) about 30 s (docs/formats.md, Bounds).
pub const MAX_SRIVC_WORK: usize = 20_000_000;

fn orders(np: Option<usize>, nz: Option<usize>) -> Result<(usize, usize), StepError> {
    let np = np.ok_or_else(|| StepError::setting("np", "missing: the number of poles"))?;
    if np > MAX_CT_POLES {
        return Err(StepError::setting(
            "np",
            format!("{np} poles; at most {MAX_CT_POLES} (docs/formats.md, Bounds)"),
        ));
    }
    let nz = nz.ok_or_else(|| StepError::setting("nz", "missing: the number of zeros"))?;
    crate::ident::ct::check_orders(np, nz).map_err(ct_err(""))?;
    Ok((np, nz))
}

fn check_delay(delay: f64) -> Result<(), StepError> {
    crate::ident::ct::check_delay(delay).map_err(ct_err(""))
}

/// Settings errors name their field; data errors their source.
fn ct_err(source: &str) -> impl Fn(CtError) -> StepError + '_ {
    move |e| match e {
        CtError::Setting { field, message } => StepError::setting(field, message),
        CtError::Data(m) => StepError::input(format!("{source}: {m}")),
        CtError::Numerical(m) => StepError::computation(format!("{source}: {m}")),
    }
}

impl Validate for IdentifyCt {
    fn validate(&self) -> Result<(), StepError> {
        RecordSettings {
            ts: self.ts,
            detrend: self.detrend,
            split: self.split,
        }
        .validate()?;
        orders(self.np, self.nz)?;
        check_delay(self.delay)?;
        if let Some(f) = self.svf_cutoff_hz {
            positive("svf_cutoff_hz", f)?;
        }
        if let Some(p) = self.period {
            positive("period", p)?;
        }
        if self.max_iterations == 0 {
            return Err(StepError::setting(
                "max_iterations",
                "at least one iteration",
            ));
        }
        Ok(())
    }
}

impl IdentifyCt {
    /// Identifies the model and its fits.
    pub fn run(&self, inputs: LinearInputs) -> Result<CtReport, StepError> {
        self.validate()?;
        let settings = RecordSettings {
            ts: self.ts,
            detrend: self.detrend,
            split: self.split,
        };
        let prep = settings.prepare(inputs)?;
        let (np, nz) = orders(self.np, self.nz)?;
        let samples = prep.est.u.len();
        let work = samples
            .saturating_mul(np)
            .saturating_mul(self.max_iterations);
        if work > MAX_SRIVC_WORK {
            return Err(StepError::setting(
                "np",
                format!(
                    "{np} poles and {} `max_iterations` on {samples} samples: samples x poles x iterations = {work} exceeds {MAX_SRIVC_WORK} (docs/formats.md, Bounds); decimate or shorten the record, or lower `np` or `max_iterations`",
                    self.max_iterations
                ),
            ));
        }
        let mut p = SrivcParams::new(np, nz, prep.ts);
        p.delay = self.delay;
        p.svf_cutoff_hz = self.svf_cutoff_hz;
        p.max_iterations = self.max_iterations;
        let est = srivc(&prep.est.u, &prep.est.y, &p).map_err(ct_err(&prep.source))?;
        let freq = self.empirical_response(&prep)?;
        let mut report = CtReport::new(est.model, "srivc", &prep.source);
        report.samples = Some(prep.est.u.len());
        report.ts = Some(prep.ts);
        report.time_fit_percent = Some(est.fit_percent);
        report.freq_points = freq.freq_hz.len();
        report.freq_source = Some(self.freq_source());
        report.freq_data = freq.clone();
        if freq.freq_hz.len() >= 2 {
            report.freq_fit_percent = Some(zoh_fit_percent(&report.model, &freq, prep.ts));
        } else {
            report.freq_source = Some(format!(
                "{}: fewer than 2 usable points, no frequency-domain fit (give `period` for a periodic input)",
                self.freq_source()
            ));
        }
        report.iterations = est.iterations;
        report.converged = est.converged;
        report.svf_cutoff_hz = Some(est.svf_cutoff_hz);
        report.trials = est.trials.iter().map(TrialDoc::from).collect();
        if let Some(v) = &prep.val {
            report.validation_time_fit_percent =
                Some(time_fit_percent(&report.model, &v.u, &v.y, prep.ts));
        }
        Ok(report)
    }

    fn freq_source(&self) -> String {
        match self.period {
            Some(p) => format!(
                "periodic record, period {p} s, {} skipped",
                self.skip_periods
            ),
            None => format!("Welch estimate, bins of coherence >= {MIN_COHERENCE}"),
        }
    }

    /// The record's own frequency response: at the lines of its period, or
    /// Welch's at the coherent bins.
    fn empirical_response(&self, prep: &Prepared) -> Result<FreqData, StepError> {
        let (u, y) = (&prep.est.u, &prep.est.y);
        if let Some(period) = self.period {
            let samples = period_in_samples(period, prep.ts)
                .map_err(|message| StepError::setting("period", message))?;
            return periodic_frf(u, y, prep.ts, samples, self.skip_periods)
                .map_err(ct_err(&prep.source));
        }
        let params = WelchParams {
            segment: self.segment,
            ..WelchParams::default()
        };
        let h = welch(u, y, prep.ts, &params)
            .map_err(|e| StepError::input(format!("{}: {e}", prep.source)))?;
        let coherence = h.coherence.clone().unwrap_or_default();
        let keep: Vec<usize> = (1..h.freq_hz.len())
            .filter(|&k| coherence.get(k).is_some_and(|c| *c >= MIN_COHERENCE))
            .collect();
        Ok(FreqData {
            freq_hz: keep.iter().map(|&k| h.freq_hz[k]).collect(),
            response: keep.iter().map(|&k| h.response[k]).collect(),
        })
    }
}

/// MATLAB `compare` fit of the model's sampled (ZOH) response against a
/// response measured from sampled records.
fn zoh_fit_percent(model: &CtModel, data: &FreqData, ts: f64) -> f64 {
    let model_resp: Vec<c64> = data
        .freq_hz
        .iter()
        .map(|f| model.zoh_response_at_hz(*f, ts))
        .collect();
    let n = data.response.len() as f64;
    let mean = data.response.iter().sum::<c64>() / n;
    let err: f64 = data
        .response
        .iter()
        .zip(&model_resp)
        .map(|(g, m)| (g - m).norm_sqr())
        .sum();
    let dev: f64 = data.response.iter().map(|g| (g - mean).norm_sqr()).sum();
    100.0 * (1.0 - (err / dev).sqrt())
}

/// Point weighting of `fts identify ct-frd`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WeightingChoice {
    /// Every point the same.
    #[default]
    Uniform,
    /// Each point by its cell's width in log frequency.
    Log,
    /// Each point by `1/|G|^2` (relative errors).
    Relative,
    /// Log-frequency width over `|G|^2`.
    #[serde(rename = "log-relative")]
    LogRelative,
}

impl crate::workflow::Choices for WeightingChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("uniform", "Every frequency point counts the same"),
        (
            "log",
            "Each point weighted by its width in log frequency (a linear FFT grid does not let the upper decades dominate)",
        ),
        (
            "relative",
            "Each point weighted by 1/|G|^2: relative errors, so small responses above a resonance count",
        ),
        (
            "log-relative",
            "Both: log-frequency width over |G|^2 (a Bode-plot fit)",
        ),
    ];
}

/// `fts identify ct-frd`: `e^(-s delay) B(s)/A(s)` from a frequency response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyCtFrd {
    /// Poles (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub np: Option<usize>,
    /// Zeros, at most `np` (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nz: Option<usize>,
    /// Known input delay, s; default 0.
    pub delay: f64,
    /// Point weighting; default uniform.
    pub weighting: WeightingChoice,
    /// Lowest frequency used, Hz; default all.
    pub fmin: Option<f64>,
    /// Highest frequency used, Hz; default all.
    pub fmax: Option<f64>,
}

impl Default for IdentifyCtFrd {
    fn default() -> Self {
        IdentifyCtFrd {
            np: None,
            nz: None,
            delay: 0.0,
            weighting: WeightingChoice::Uniform,
            fmin: None,
            fmax: None,
        }
    }
}

impl Validate for IdentifyCtFrd {
    fn validate(&self) -> Result<(), StepError> {
        orders(self.np, self.nz)?;
        check_delay(self.delay)?;
        for (field, v) in [("fmin", self.fmin), ("fmax", self.fmax)] {
            if let Some(v) = v {
                positive(field, v)?;
            }
        }
        if let (Some(lo), Some(hi)) = (self.fmin, self.fmax)
            && lo >= hi
        {
            return Err(StepError::setting(
                "fmax",
                format!("the band is empty: fmax ({hi} Hz) must exceed fmin ({lo} Hz)"),
            ));
        }
        Ok(())
    }
}

impl IdentifyCtFrd {
    /// Fits the model to `data` (read from `source`).
    pub fn run(&self, data: &FreqData, source: &str) -> Result<CtReport, StepError> {
        self.validate()?;
        let (np, nz) = orders(self.np, self.nz)?;
        let keep: Vec<usize> = (0..data.freq_hz.len())
            .filter(|&i| {
                let f = data.freq_hz[i];
                self.fmin.is_none_or(|lo| f >= lo) && self.fmax.is_none_or(|hi| f <= hi)
            })
            .collect();
        let f: Vec<f64> = keep.iter().map(|&i| data.freq_hz[i]).collect();
        let g: Vec<c64> = keep.iter().map(|&i| data.response[i]).collect();
        let mut p = FreqFitParams::new(np, nz);
        p.delay = self.delay;
        p.weighting = match self.weighting {
            WeightingChoice::Uniform => FreqWeighting::Uniform,
            WeightingChoice::Log => FreqWeighting::LogFrequency,
            WeightingChoice::Relative => FreqWeighting::Relative,
            WeightingChoice::LogRelative => FreqWeighting::LogRelative,
        };
        let est = freq_fit(&f, &g, &p).map_err(ct_err(source))?;
        let mut report = CtReport::new(est.model, "sk+nls", source);
        report.freq_fit_percent = Some(freq_fit_percent(&report.model, &f, &g));
        report.freq_points = f.len();
        report.freq_source = Some(format!("{source}, weighting {}", self.weighting.name()));
        report.freq_data = FreqData {
            freq_hz: f.clone(),
            response: g.clone(),
        };
        report.iterations = est.sk_iterations + est.nls_iterations;
        report.converged = est.converged;
        report.sk_iterations = Some(est.sk_iterations);
        Ok(report)
    }
}

impl WeightingChoice {
    fn name(self) -> &'static str {
        match self {
            WeightingChoice::Uniform => "uniform",
            WeightingChoice::Log => "log",
            WeightingChoice::Relative => "relative",
            WeightingChoice::LogRelative => "log-relative",
        }
    }
}

/// One start estimate SRIVC tried.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialDoc {
    /// State-variable-filter cutoff, Hz.
    pub cutoff_hz: f64,
    /// Simulation fit of its SRIVC result, % (null when it failed).
    pub fit_percent: Option<f64>,
    /// Iterations.
    pub iterations: usize,
    /// Converged.
    pub converged: bool,
}

impl From<&SvfTrial> for TrialDoc {
    fn from(t: &SvfTrial) -> Self {
        TrialDoc {
            cutoff_hz: t.cutoff_hz,
            fit_percent: t.fit_percent.is_finite().then_some(t.fit_percent),
            iterations: t.iterations,
            converged: t.converged,
        }
    }
}

/// What the continuous-time steps report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CtReport {
    /// `srivc` or `sk+nls`.
    pub method: &'static str,
    /// The data's name.
    pub source: String,
    /// Poles.
    pub np: usize,
    /// Zeros.
    pub nz: usize,
    /// Numerator, descending powers of s.
    pub num: Vec<f64>,
    /// Denominator (monic), descending powers of s.
    pub den: Vec<f64>,
    /// Input delay, s (not part of the written `fts.tf/1` file).
    pub delay_s: f64,
    /// Poles, `[re, im]` (rad/s).
    #[serde(serialize_with = "pairs")]
    pub poles: Vec<c64>,
    /// Zeros, `[re, im]` (rad/s).
    #[serde(serialize_with = "pairs")]
    pub zeros: Vec<c64>,
    /// Gain at s = 0.
    pub dc_gain: f64,
    /// Every pole in the open left half plane.
    pub stable: bool,
    /// Simulation (NRMSE) fit on the estimation record, %.
    pub time_fit_percent: Option<f64>,
    /// Simulation fit on the validation record, %.
    pub validation_time_fit_percent: Option<f64>,
    /// MATLAB `compare` fit on the frequency response, %.
    pub freq_fit_percent: Option<f64>,
    /// Frequency points of that fit.
    pub freq_points: usize,
    /// Where the frequency response came from.
    pub freq_source: Option<String>,
    /// Estimation samples (time data).
    pub samples: Option<usize>,
    /// Sample time, s (time data).
    pub ts: Option<f64>,
    /// Iterations (SRIVC; or Sanathanan–Koerner plus Levenberg–Marquardt).
    pub iterations: usize,
    /// Whether the iteration converged.
    pub converged: bool,
    /// Sanathanan–Koerner iterations (frequency data).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sk_iterations: Option<usize>,
    /// SRIVC's kept start cutoff, Hz.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub svf_cutoff_hz: Option<f64>,
    /// Every SRIVC start tried.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub trials: Vec<TrialDoc>,
    /// The model.
    #[serde(skip)]
    pub model: CtModel,
    /// The frequency response the frequency-domain fit is against.
    #[serde(skip)]
    pub freq_data: FreqData,
}

fn pairs<S: serde::Serializer>(v: &[c64], s: S) -> Result<S::Ok, S::Error> {
    super::complex_pairs(v).serialize(s)
}

impl CtReport {
    fn new(model: CtModel, method: &'static str, source: &str) -> CtReport {
        let zeros = crate::lti::roots_descending(&model.num).unwrap_or_default();
        let dc_gain =
            model.num.last().copied().unwrap_or(0.0) / model.den.last().copied().unwrap_or(1.0);
        CtReport {
            method,
            source: source.to_string(),
            np: model.den.len() - 1,
            nz: model.num.len() - 1,
            num: model.num.clone(),
            den: model.den.clone(),
            delay_s: model.delay,
            poles: model.poles(),
            zeros,
            dc_gain,
            stable: model.is_stable(),
            time_fit_percent: None,
            validation_time_fit_percent: None,
            freq_fit_percent: None,
            freq_points: 0,
            freq_source: None,
            samples: None,
            ts: None,
            iterations: 0,
            converged: false,
            sk_iterations: None,
            svf_cutoff_hz: None,
            trials: Vec::new(),
            model,
            freq_data: FreqData {
                freq_hz: Vec::new(),
                response: Vec::new(),
            },
        }
    }

    /// The model `e^{-s delay} B(s)/A(s)`, as its `fts.tf/1` file holds it.
    pub fn transfer_function(&self) -> Result<TransferFunction, StepError> {
        self.model
            .tf()
            .and_then(|g| g.with_delay(self.model.delay))
            .map(TransferFunction::Continuous)
            .map_err(|e| StepError::computation(format!("{}: {e}", self.source)))
    }

    /// The model's response at `f` Hz as the data see it: the ZOH-sampled
    /// response for time records, `G(j 2 pi f)` for frequency data.
    pub fn model_response_at_hz(&self, f: f64) -> c64 {
        match self.ts {
            Some(ts) => self.model.zoh_response_at_hz(f, ts),
            None => self.model.response_at_hz(f),
        }
    }

    /// Problems a user must not miss: unstable model, no convergence.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if !self.stable {
            w.push("the identified model is unstable (a pole in the right half plane)".into());
        }
        if !self.converged {
            w.push(format!(
                "the iteration did not converge in {} iterations",
                self.iterations
            ));
        }
        w
    }
}

fn poly_line(c: &[f64]) -> String {
    c.iter()
        .map(|v| format!("{v:.6e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn percent(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.2} %"))
}

impl fmt::Display for CtReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "continuous {} model, {} poles / {} zeros, from {}",
            self.method.to_uppercase(),
            self.np,
            self.nz,
            self.source
        )?;
        writeln!(f, "  num (s^{}..s^0): {}", self.nz, poly_line(&self.num))?;
        writeln!(f, "  den (s^{}..s^0): {}", self.np, poly_line(&self.den))?;
        if self.delay_s > 0.0 {
            writeln!(
                f,
                "  input delay {} s (reported; the fts.tf/1 file holds B/A)",
                self.delay_s
            )?;
        }
        let poles: Vec<String> = self.poles.iter().map(|p| fmt_complex(*p)).collect();
        writeln!(f, "  poles (rad/s): {}", poles.join(", "))?;
        writeln!(
            f,
            "  DC gain {:.6e}, {}",
            self.dc_gain,
            if self.stable { "stable" } else { "UNSTABLE" }
        )?;
        writeln!(
            f,
            "  fit: time domain {} (validation {}), frequency domain {} over {} points",
            percent(self.time_fit_percent),
            percent(self.validation_time_fit_percent),
            percent(self.freq_fit_percent),
            self.freq_points
        )?;
        if let Some(s) = &self.freq_source {
            writeln!(f, "  frequency response: {s}")?;
        }
        write!(
            f,
            "  {} iterations, {}",
            self.iterations,
            if self.converged {
                "converged"
            } else {
                "NOT converged"
            }
        )?;
        if let Some(fc) = self.svf_cutoff_hz {
            write!(
                f,
                " (start filter {fc:.4} Hz of {} tried)",
                self.trials.len()
            )?;
        }
        writeln!(f)
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn settings_deserialise_with_defaults_and_bad_ones_name_their_key() {
        let s: IdentifyCt = toml::from_str("np = 3\nnz = 1\nperiod = 0.1").unwrap();
        assert_eq!(s.skip_periods, 1);
        assert_eq!(s.max_iterations, 50);
        assert!(s.validate().is_ok());
        let bad: IdentifyCt = toml::from_str("np = 2\nnz = 3").unwrap();
        let e = bad.validate().unwrap_err();
        assert!(
            matches!(
                e,
                StepError::Input {
                    field: Some("nz"),
                    ..
                }
            ),
            "{e:?}"
        );
        let missing = IdentifyCt::default().validate().unwrap_err();
        assert!(matches!(
            missing,
            StepError::Input {
                field: Some("np"),
                ..
            }
        ));
        let f: IdentifyCtFrd =
            toml::from_str("np = 2\nnz = 0\nweighting = \"log-relative\"").unwrap();
        assert_eq!(f.weighting, WeightingChoice::LogRelative);
        assert!(toml::from_str::<IdentifyCtFrd>("np = 2\nnz = 0\nweight = 1").is_err());
    }

    /// A noise-free frequency response of a second-order system: the fit is
    /// exact and the report's DC gain and poles are the system's.
    pub fn frd_step_reports_the_exact_model() {
        let truth = CtModel {
            num: vec![4.0e4],
            den: vec![1.0, 40.0, 1.0e4],
            delay: 0.0,
        };
        let freq_hz: Vec<f64> = (1..=60).map(|i| i as f64 * 1.0).collect();
        let response = freq_hz.iter().map(|f| truth.response_at_hz(*f)).collect();
        let step = IdentifyCtFrd {
            np: Some(2),
            nz: Some(0),
            ..IdentifyCtFrd::default()
        };
        let r = step.run(&FreqData { freq_hz, response }, "test").unwrap();
        assert!((r.dc_gain - 4.0).abs() < 1e-9, "{}", r.dc_gain);
        assert!(r.freq_fit_percent.unwrap() > 99.99999);
        assert!(r.stable && r.warnings().is_empty());
        let p = r.poles.iter().find(|p| p.im > 0.0).unwrap();
        assert!((p.re + 20.0).abs() < 1e-7 && (p.im - (1.0e4f64 - 400.0).sqrt()).abs() < 1e-7);
    }
}
