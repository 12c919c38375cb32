//! Iterative learning control as a step (`fts ilc`): trials of the
//! `simulate` loop with the learned feedforward of [`crate::synth::ilc`],
//! judged twice. Before the trials, a prediction: the convergence
//! condition with the model's error measured on a validation sweep of the
//! loop ([`crate::synth::ilc::robust`], Eq. 3). During them, the verdict:
//! the measured error of every trial against the best one so far; learning
//! that grows the error past [`Ilc::divergence_factor`] times its best
//! stops there.

use super::simulate::{Prepared, Simulate, SimulateInputs};
use super::{StepError, Validate, positive};
use crate::io::controller_file::{ControllerFile, FeedforwardTableBlock};
use crate::lti::DiscreteTf;
use crate::sim::closed_loop::{self, TrackingMetrics};
use crate::sim::reference::{self, Reference, ReferenceTiming};
use crate::synth::ilc::robust::{self, ModelError, RobustCheck};
use crate::synth::ilc::{self, IlcDesign, IlcParams};
use crate::synth::zpetc::Zpetc;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Learning gains tried when none is given, largest first.
pub const CANDIDATE_GAINS: [f64; 4] = [0.7, 0.5, 0.35, 0.25];

/// The largest Eq. (3) bound a chosen law may have: the predicted
/// contraction per trial where the learning is slowest, with room for what
/// the validation sweep cannot see (noise, the loop's nonlinearity).
pub const CHOSEN_RHO_LIMIT: f64 = 0.9;

/// Amplitude of the validation sweep, in the reference's units (um).
pub const VALIDATION_AMPLITUDE: f64 = 1.0;

/// Settings of iterative learning control (`fts ilc`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ilc {
    /// Trials after the first (which learns from nothing); default 10.
    pub trials: usize,
    /// Learning gain; default: chosen with `q_cutoff` (the largest of
    /// [`CANDIDATE_GAINS`] the model check passes at the chosen cutoff).
    pub gain: Option<f64>,
    /// Cutoff of the zero-phase Q, Hz; default: the highest (in steps of
    /// 1/40 of Nyquist, not below the reference's band) at which a gain of
    /// [`CANDIDATE_GAINS`] keeps Eq. (3) below [`CHOSEN_RHO_LIMIT`].
    pub q_cutoff: Option<f64>,
    /// One-sided taps of Q; default 32.
    pub q_taps: usize,
    /// A trial whose max error exceeds the best trial's by this factor
    /// stops the learning (measured divergence); default 2.
    pub divergence_factor: f64,
    /// Run every trial even when the model check fails or the measured
    /// error diverges (the report then says so); default false.
    pub allow_divergence: bool,
}

impl Default for Ilc {
    fn default() -> Self {
        Self {
            trials: 10,
            gain: None,
            q_cutoff: None,
            q_taps: IlcParams::default().q_half_length,
            divergence_factor: 2.0,
            allow_divergence: false,
        }
    }
}

impl Validate for Ilc {
    fn validate(&self) -> Result<(), StepError> {
        if self.trials == 0 || self.trials > 1000 {
            return Err(StepError::setting(
                "trials",
                format!("{}; expected 1 to 1000 trials", self.trials),
            ));
        }
        if let Some(gain) = self.gain {
            positive("gain", gain)?;
        }
        if let Some(cutoff) = self.q_cutoff {
            positive("q_cutoff", cutoff)?;
        }
        if self.q_taps == 0 || self.q_taps > 4096 {
            return Err(StepError::setting(
                "q_taps",
                format!("{}; expected 1 to 4096 taps each side", self.q_taps),
            ));
        }
        if !(self.divergence_factor.is_finite() && self.divergence_factor > 1.0) {
            return Err(StepError::setting(
                "divergence_factor",
                format!(
                    "{}; expected a factor above 1 (the error growth past the best trial that stops the learning)",
                    self.divergence_factor
                ),
            ));
        }
        Ok(())
    }
}

/// One trial's figures over the evaluated window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrialRow {
    /// Trial number; 0 ran without learned feedforward.
    pub trial: usize,
    /// Max |e|, reference units.
    pub max_error: f64,
    /// RMS error.
    pub rms_error: f64,
    /// Max |e| in % of the amplitude.
    pub max_error_percent: f64,
    /// Samples with the command on a limit.
    pub saturated_samples: usize,
}

impl From<(usize, TrackingMetrics)> for TrialRow {
    fn from((trial, m): (usize, TrackingMetrics)) -> Self {
        Self {
            trial,
            max_error: m.max_abs_error,
            rms_error: m.rms_error,
            max_error_percent: m.max_error_percent,
            saturated_samples: m.saturated_samples,
        }
    }
}

/// How the law was chosen and what it predicts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// Eq. (3) with the measured model error.
    pub check: RobustCheck,
    /// The model's measured error, worst below Q's cutoff `(Hz, delta)`.
    pub worst_error_in_band: Option<(f64, f64)>,
    /// The record the error was measured on.
    pub measured_on: String,
    /// The reference's band (99 % of its energy below), Hz.
    pub reference_band_hz: f64,
    /// Whether gain and cutoff were chosen (not given).
    pub chosen: bool,
}

/// The measured outcome of the trials.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Verdict {
    /// The trial with the smallest max error.
    pub best_trial: usize,
    /// The first trial whose error exceeded the best by the divergence
    /// factor, if any (only with `allow_divergence` do trials go on after it).
    pub diverged_at: Option<usize>,
    /// Last trial's max error over trial 0's.
    pub final_over_first: f64,
}

/// What the trials learned.
#[derive(Debug, Clone)]
pub struct IlcReport {
    /// The learning law and its nominal convergence check.
    pub design: IlcDesign,
    /// The prediction with the model's measured error.
    pub prediction: Prediction,
    /// The trials' measured verdict.
    pub verdict: Verdict,
    /// The reference's description.
    pub reference: String,
    /// Where the loop's models came from.
    pub models: String,
    /// Trial 0 (no learning) to the last.
    pub trials: Vec<TrialRow>,
    /// The controller with the last learned feedforward as its table.
    pub controller: ControllerFile,
    /// The last trial's trace.
    pub trace: closed_loop::Trace,
    /// The samples the figures are computed over.
    pub evaluated: std::ops::Range<usize>,
}

impl IlcReport {
    /// Whether a check failed and the run went on (`allow_divergence`):
    /// the model check's prediction or the measured trend.
    pub fn diverging(&self) -> bool {
        self.verdict.diverged_at.is_some()
            || !self.prediction.check.converges()
            || self.design.rho >= 1.0
    }
}

impl Ilc {
    /// Designs the law on `model` (or on the identified closed loop),
    /// checks it against the loop's measured response, and runs the trials
    /// of `simulate` on its plant; `note` hears warnings and the slow
    /// parts, `progress` each trial's figures as it ends.
    pub fn run(
        &self,
        simulate: &Simulate,
        inputs: SimulateInputs,
        model: Option<DiscreteTf>,
        note: &mut dyn FnMut(&str),
        progress: &mut dyn FnMut(&TrialRow),
    ) -> Result<IlcReport, StepError> {
        self.validate()?;
        let prepared = simulate.prepare(inputs, note)?;
        let model = model.or(prepared.closed_loop.clone()).ok_or_else(|| {
            StepError::setting(
                "closed_loop",
                "iterative learning needs the closed-loop model (`closed_loop` plant.json)",
            )
        })?;
        same_rate(&model, &prepared)?;
        below_nyquist(self.q_cutoff, &model)?;
        note("measuring the loop's response for the model check (validation sweep)...");
        let error = validation_error(simulate, &prepared, &model)?;
        let band = reference_band_hz(&prepared.reference, model.ts());
        let (design, prediction) = self.law(&model, &error, band, note)?;
        let mut rows: Vec<TrialRow> = Vec::with_capacity(self.trials + 1);
        let mut diverged_at = None;
        let (learned, trace) = design.run_trials(
            self.trials,
            prepared.reference.ramp_end,
            |trial, learned| {
                let trace = simulate.run_prepared(&prepared, 1000 + trial as u64, learned)?;
                let row = TrialRow::from((trial, metrics(&prepared, &trace)));
                progress(&row);
                rows.push(row);
                if diverged_at.is_none()
                    && let Some(message) = self.watch(&rows, &prediction)
                {
                    if !self.allow_divergence {
                        return Err(StepError::computation(message));
                    }
                    note(&format!(
                        "warning: {message}; going on (`allow_divergence`)"
                    ));
                    diverged_at = Some(trial);
                }
                Ok::<_, StepError>(trace)
            },
            closed_loop::Trace::error,
        )?;
        let mut controller = prepared.file.clone();
        controller.feedforward_table = Some(FeedforwardTableBlock {
            samples: learned_or_zero(&learned, prepared.reference.samples.len()),
        });
        Ok(IlcReport {
            design,
            prediction,
            verdict: verdict(&rows, diverged_at),
            reference: prepared.reference.label.clone(),
            models: prepared.models.clone(),
            trials: rows,
            controller,
            trace,
            evaluated: prepared.reference.evaluated(),
        })
    }

    /// The measured verdict on the trials so far: a message when the last
    /// one's error exceeds the best's by the divergence factor.
    fn watch(&self, rows: &[TrialRow], prediction: &Prediction) -> Option<String> {
        let errors: Vec<f64> = rows.iter().map(|r| r.max_error).collect();
        let d = ilc::last_diverged(&errors, self.divergence_factor)?;
        let (last, best) = (&rows[d.trial], &rows[d.best_trial]);
        Some(format!(
            "the learning diverges on the loop: trial {} has max error {:.4} ({:.3} %), {:.1} times trial {}'s {:.4} (divergence factor {}); the model check had predicted {} (max |Q| (|1 - a L G| + a |L G| delta) = {:.4} at {:.1} Hz); lower the learning gain or Q's cutoff, or give a closed-loop model measured over Q's band",
            last.trial,
            last.max_error,
            last.max_error_percent,
            d.ratio,
            best.trial,
            best.max_error,
            self.divergence_factor,
            if prediction.check.converges() {
                "convergence"
            } else {
                "divergence"
            },
            prediction.check.rho,
            prediction.check.at_hz,
        ))
    }

    /// The law: the given gain and cutoff, or the chosen ones; its nominal
    /// condition (Eq. 2) and its prediction (Eq. 3) must hold unless
    /// divergence is allowed.
    fn law(
        &self,
        model: &DiscreteTf,
        error: &ModelError,
        band: f64,
        note: &mut dyn FnMut(&str),
    ) -> Result<(IlcDesign, Prediction), StepError> {
        let learning = ilc::inversion(model, &IlcParams::default()).map_err(ilc_error)?;
        let (design, chosen) = match (self.gain, self.q_cutoff) {
            (Some(gain), Some(cutoff)) => (self.candidate(&learning, model, gain, cutoff)?, false),
            _ => (self.choose(&learning, model, error, band)?, true),
        };
        let check = robust::robust_check(&design, model, error);
        let prediction = Prediction {
            check,
            worst_error_in_band: error.worst_below(design.q_cutoff_hz),
            measured_on: error.source.clone(),
            reference_band_hz: band,
            chosen,
        };
        let failure = if design.rho >= 1.0 {
            Some(
                ilc::IlcError::Diverges {
                    rho: design.rho,
                    at_hz: design.rho_at_hz,
                }
                .to_string(),
            )
        } else if !check.converges() {
            Some(check.failure(error))
        } else {
            None
        };
        match failure {
            None => Ok((design, prediction)),
            Some(m) if self.allow_divergence => {
                note(&format!(
                    "warning: {m}; running anyway (`allow_divergence`): the error will grow"
                ));
                Ok((design, prediction))
            }
            Some(m) => Err(StepError::computation(m)),
        }
    }

    /// The law with this gain and cutoff on the inversion `learning`.
    fn candidate(
        &self,
        learning: &Zpetc,
        model: &DiscreteTf,
        gain: f64,
        cutoff: f64,
    ) -> Result<IlcDesign, StepError> {
        let nyquist = 0.5 / model.ts();
        if cutoff > nyquist {
            return Err(StepError::setting(
                "q_cutoff",
                format!("{cutoff} Hz is beyond the Nyquist frequency {nyquist} Hz"),
            ));
        }
        Ok(ilc::design_with_inversion(
            learning.clone(),
            model,
            &self.params(gain, cutoff),
        ))
    }

    /// The highest cutoff (not below the reference's band) and, there, the
    /// largest of [`CANDIDATE_GAINS`] whose Eq. (3) bound is at most
    /// [`CHOSEN_RHO_LIMIT`]; a given gain or cutoff is kept.
    fn choose(
        &self,
        learning: &Zpetc,
        model: &DiscreteTf,
        error: &ModelError,
        band: f64,
    ) -> Result<IlcDesign, StepError> {
        let nyquist = 0.5 / model.ts();
        let step = nyquist / 40.0;
        let cutoffs: Vec<f64> = match self.q_cutoff {
            Some(c) => vec![c],
            None => (1..=36)
                .rev()
                .map(|i| i as f64 * step)
                .filter(|c| *c >= band)
                .collect(),
        };
        let gains: Vec<f64> = self.gain.map_or(CANDIDATE_GAINS.to_vec(), |g| vec![g]);
        for &cutoff in &cutoffs {
            for &gain in &gains {
                let d = self.candidate(learning, model, gain, cutoff)?;
                if d.rho < 1.0 && robust::robust_check(&d, model, error).rho <= CHOSEN_RHO_LIMIT {
                    return Ok(d);
                }
            }
        }
        Err(StepError::computation(format!(
            "no learning law passes the model check: with gains {gains:?} and Q cutoffs from {:.0} Hz (the reference's band) up, max |Q| (|1 - a L G| + a |L G| delta) stays above {CHOSEN_RHO_LIMIT} with the model error measured on {}; give a closed-loop model that matches the loop over the reference's band",
            band, error.source
        )))
    }

    fn params(&self, gain: f64, cutoff: f64) -> IlcParams {
        IlcParams {
            gain,
            q_cutoff_hz: cutoff,
            q_half_length: self.q_taps,
            ..IlcParams::default()
        }
    }
}

fn ilc_error(e: ilc::IlcError) -> StepError {
    match e {
        ilc::IlcError::Setting(m) => StepError::setting("q_cutoff", m),
        other => StepError::computation(other.to_string()),
    }
}

/// A cutoff beyond the Nyquist frequency is refused before any work.
fn below_nyquist(cutoff: Option<f64>, model: &DiscreteTf) -> Result<(), StepError> {
    let nyquist = 0.5 / model.ts();
    match cutoff {
        Some(c) if c > nyquist => Err(StepError::setting(
            "q_cutoff",
            format!("{c} Hz is beyond the Nyquist frequency {nyquist} Hz"),
        )),
        _ => Ok(()),
    }
}

/// A model at another sample time than the loop's is refused.
fn same_rate(model: &DiscreteTf, prepared: &Prepared) -> Result<(), StepError> {
    let ts = prepared.plant.ts();
    if (model.ts() - ts).abs() > 1e-9 * ts {
        return Err(StepError::setting(
            "closed_loop",
            format!(
                "the closed-loop model's sample time is {} s, the loop runs at {ts} s; identify the closed loop at the loop's rate",
                model.ts()
            ),
        ));
    }
    Ok(())
}

/// The model's error on a validation sweep of the loop (0 to 0.45 of the
/// sampling rate, [`VALIDATION_AMPLITUDE`], 1 s) run like a trial: the
/// loop's reference against its measurement.
fn validation_error(
    simulate: &Simulate,
    prepared: &Prepared,
    model: &DiscreteTf,
) -> Result<ModelError, StepError> {
    let ts = model.ts();
    let f1 = 0.45 / ts;
    let timing = ReferenceTiming {
        ts,
        ..ReferenceTiming::default()
    }
    .with_preview(prepared.file.preview());
    let sweep = reference::sweep(VALIDATION_AMPLITUDE, 0.0, f1, simulate.offset, 1.0, &timing)
        .map_err(|e| StepError::setting(e.field, e.message))?;
    let window = sweep.evaluated();
    let validation = Prepared {
        reference: sweep,
        ..prepared.clone()
    };
    let trace = simulate.run_prepared(&validation, 999, &[])?;
    let source = format!("a {VALIDATION_AMPLITUDE} um 0-{f1:.0} Hz validation sweep of the loop");
    ModelError::measure(
        model,
        &trace.filtered_reference[window.clone()],
        &trace.measurement[window],
        source,
    )
    .map_err(|e| StepError::computation(format!("validation sweep: {e}")))
}

/// The frequency below which 99 % of the evaluated reference's energy
/// (about its mean) lies, Hz.
pub fn reference_band_hz(reference: &Reference, ts: f64) -> f64 {
    let x = &reference.samples[reference.evaluated()];
    if x.len() < 4 {
        return 0.0;
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let mut buf: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let fft = fts_kernels::fft::RealFft::new(buf.len());
    let mut spec = vec![crate::lti::c64::new(0.0, 0.0); fft.bins()];
    fft.process(&mut buf, &mut spec);
    let power: Vec<f64> = spec.iter().map(|c| c.norm_sqr()).collect();
    let total: f64 = power.iter().sum();
    let mut sum = 0.0;
    for (k, p) in power.iter().enumerate() {
        sum += p;
        if sum >= 0.99 * total {
            return k as f64 / (x.len() as f64 * ts);
        }
    }
    0.5 / ts
}

fn metrics(prepared: &Prepared, trace: &closed_loop::Trace) -> TrackingMetrics {
    closed_loop::metrics(
        trace,
        prepared.reference.evaluated(),
        prepared.file.command_limits(),
    )
}

fn verdict(rows: &[TrialRow], diverged_at: Option<usize>) -> Verdict {
    let best = rows
        .iter()
        .min_by(|a, b| a.max_error.total_cmp(&b.max_error))
        .map_or(0, |r| r.trial);
    let first = rows.first().map_or(f64::NAN, |r| r.max_error);
    let last = rows.last().map_or(f64::NAN, |r| r.max_error);
    Verdict {
        best_trial: best,
        diverged_at,
        final_over_first: last / first,
    }
}

/// The learned samples, or zeros when no trial learned.
fn learned_or_zero(learned: &[f64], n: usize) -> Vec<f64> {
    if learned.is_empty() {
        vec![0.0; n.max(1)]
    } else {
        learned.to_vec()
    }
}

impl fmt::Display for IlcReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.design;
        let p = &self.prediction;
        writeln!(
            f,
            "reference: {} (99 % of its energy below {:.0} Hz)",
            self.reference, p.reference_band_hz
        )?;
        writeln!(f, "models: {}", self.models)?;
        writeln!(
            f,
            "learning: f <- Q (f + {} L e), L = stable inversion of the closed-loop model (preview {} samples), Q zero-phase {} taps each side, cutoff {:.0} Hz{}",
            d.gain,
            d.learning.preview,
            d.q.len() - 1,
            d.q_cutoff_hz,
            if p.chosen {
                " (chosen by the model check)"
            } else {
                ""
            }
        )?;
        writeln!(
            f,
            "on the model alone: max |Q| |1 - a L G| = {:.4} at {:.1} Hz",
            d.rho, d.rho_at_hz
        )?;
        let worst = p
            .worst_error_in_band
            .map(|(hz, e)| format!("worst {:.1} % at {hz:.0} Hz below Q's cutoff", 100.0 * e))
            .unwrap_or_else(|| "not measured below Q's cutoff".into());
        writeln!(
            f,
            "prediction (model error measured on {}, coherence >= {}; {worst}; assumed {:.0} % where not measured): max |Q| (|1 - a L G| + a |L G| delta) = {:.4} at {:.1} Hz ({})",
            p.measured_on,
            robust::MIN_COHERENCE,
            100.0 * robust::ASSUMED_ELSEWHERE,
            p.check.rho,
            p.check.at_hz,
            if p.check.converges() {
                "< 1: predicted to converge"
            } else {
                ">= 1: predicted to DIVERGE"
            }
        )?;
        writeln!(f, "trial   max error   rms error   % of amplitude")?;
        for r in &self.trials {
            writeln!(
                f,
                "{:>5}   {:>9.4}   {:>9.4}   {:>8.3} %{}",
                r.trial,
                r.max_error,
                r.rms_error,
                r.max_error_percent,
                if r.saturated_samples > 0 {
                    format!("  ({} saturated samples)", r.saturated_samples)
                } else {
                    String::new()
                }
            )?;
        }
        let v = &self.verdict;
        match v.diverged_at {
            Some(t) => writeln!(
                f,
                "verdict (measured): DIVERGED at trial {t}; best trial {}; last / first max error {:.3}",
                v.best_trial, v.final_over_first
            ),
            None => writeln!(
                f,
                "verdict (measured): no trial above the best by the divergence factor; best trial {}; last / first max error {:.4}",
                v.best_trial, v.final_over_first
            ),
        }
    }
}

impl Serialize for IlcReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let d = &self.design;
        serde_json::json!({
            "reference": self.reference,
            "models": self.models,
            "design": {
                "gain": d.gain,
                "q_cutoff_hz": d.q_cutoff_hz,
                "q_taps": d.q.len() - 1,
                "preview": d.learning.preview,
                "rho": d.rho,
                "rho_at_hz": d.rho_at_hz,
                "converges": d.rho < 1.0,
                "tolerated_model_error": d.tolerated_model_error,
                "tolerated_at_hz": d.tolerated_at_hz,
            },
            "prediction": self.prediction,
            "verdict": self.verdict,
            "diverging": self.diverging(),
            "trials": self.trials,
        })
        .serialize(s)
    }
}
