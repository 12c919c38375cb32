//! Learning control as steps: the plug-in repetitive compensator designed
//! on a closed-loop model (`fts repetitive`, manifest kind `repetitive`)
//! and iterative learning control over repeated trials (`fts ilc`, in
//! [`super::ilc`]).

use super::{StepError, Validate, positive};
use crate::io::controller_file::RepetitiveBlock;
use crate::lti::DiscreteTf;
use crate::synth::repetitive::{
    self, QFilter, RepetitiveDesign, RepetitiveError, RepetitiveParams,
};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Settings of a repetitive design (`fts repetitive`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DesignRepetitive {
    /// Period in samples (may be fractional); or give `period_s` or `spindle_hz`.
    pub period: Option<f64>,
    /// Period in seconds.
    pub period_s: Option<f64>,
    /// Spindle frequency, Hz: the period is one revolution.
    pub spindle_hz: Option<f64>,
    /// Learning gain `k_r`; default 0.5 (\[Tang17\]).
    pub gain: f64,
    /// Phase lead in samples; default: the lead up to `max_lead` with the
    /// largest stability margin.
    pub lead: Option<usize>,
    /// Largest lead tried; default 20.
    pub max_lead: usize,
    /// Cutoff of the zero-phase low-pass Q, Hz; default a quarter of the
    /// sampling rate.
    pub q_cutoff: Option<f64>,
    /// One-sided taps of Q; default 8.
    pub q_taps: usize,
    /// Q's taps `[q0, q1, ..]` as given, instead of `q_cutoff`.
    pub q: Option<Vec<f64>>,
}

impl Default for DesignRepetitive {
    fn default() -> Self {
        Self {
            period: None,
            period_s: None,
            spindle_hz: None,
            gain: 0.5,
            lead: None,
            max_lead: 20,
            q_cutoff: None,
            q_taps: 8,
            q: None,
        }
    }
}

impl Validate for DesignRepetitive {
    fn validate(&self) -> Result<(), StepError> {
        let given = [
            self.period.is_some(),
            self.period_s.is_some(),
            self.spindle_hz.is_some(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            return Err(StepError::setting(
                "period",
                "give exactly one of `period` (samples), `period_s` or `spindle_hz`",
            ));
        }
        for (field, v) in [
            ("period", self.period),
            ("period_s", self.period_s),
            ("spindle_hz", self.spindle_hz),
            ("q_cutoff", self.q_cutoff),
        ] {
            if let Some(v) = v {
                positive(field, v)?;
            }
        }
        positive("gain", self.gain)?;
        if self.q.is_some() && self.q_cutoff.is_some() {
            return Err(StepError::setting(
                "q",
                "give `q` taps or `q_cutoff`, not both",
            ));
        }
        if self.q_taps == 0 || self.q_taps > crate::runtime::MAX_Q_HALF {
            return Err(StepError::setting(
                "q_taps",
                format!(
                    "{} taps each side; expected 1 to {}",
                    self.q_taps,
                    crate::runtime::MAX_Q_HALF
                ),
            ));
        }
        Ok(())
    }
}

/// A designed compensator, its coefficient block and its checks.
#[derive(Debug, Clone, PartialEq)]
pub struct RepetitiveReport {
    /// The design with its stability condition and harmonic attenuation.
    pub design: RepetitiveDesign,
    /// The block for the coefficient file.
    pub block: RepetitiveBlock,
}

impl DesignRepetitive {
    /// The period in samples at sample time `ts`.
    pub fn period_samples(&self, ts: f64) -> f64 {
        self.period
            .or(self.period_s.map(|p| p / ts))
            .or(self.spindle_hz.map(|f| 1.0 / (f * ts)))
            .unwrap_or(0.0)
    }

    /// Designs the compensator on the closed loop `model` (loop reference
    /// to output, at the runtime's sample time).
    pub fn run(&self, model: &DiscreteTf) -> Result<RepetitiveReport, StepError> {
        self.validate()?;
        let ts = model.ts();
        if let Some(f) = self.q_cutoff
            && f > 0.5 / ts
        {
            return Err(StepError::setting(
                "q_cutoff",
                format!("{f} Hz is beyond the Nyquist frequency {} Hz", 0.5 / ts),
            ));
        }
        let q = match (&self.q, self.q_cutoff) {
            (Some(taps), _) => QFilter::Taps(taps.clone()),
            (None, cutoff) => QFilter::LowPass {
                cutoff_hz: cutoff.unwrap_or(0.25 / ts),
                half_length: self.q_taps,
            },
        };
        let params = RepetitiveParams {
            q: Some(q),
            lead: self.lead,
            max_lead: self.max_lead,
            gain: self.gain,
            ..RepetitiveParams::new(self.period_samples(ts))
        };
        let design = repetitive::design(model, &params).map_err(|e| match e {
            RepetitiveError::Setting(m) => self.setting_error(&m, ts),
            e @ RepetitiveError::ConditionFails { .. } => {
                StepError::computation(format!("{e}; {}", self.remedy(model, &params)))
            }
            other => StepError::computation(other.to_string()),
        })?;
        let block = RepetitiveBlock {
            period: design.period,
            fraction: design.fraction,
            q: design.q.clone(),
            lead: design.lead,
            gain: design.gain,
        };
        Ok(RepetitiveReport { design, block })
    }
}

/// Divisors of the gain and of Q's cutoff tried by the remedy.
const REMEDY_STEPS: [f64; 6] = [2.0, 4.0, 8.0, 16.0, 32.0, 64.0];

impl DesignRepetitive {
    /// What meets Eq. (1) when the design fails it, found by designing:
    /// the largest lower gain, the highest lower Q cutoff, the lead scan in
    /// place of a fixed lead; and any trap pole of the model (an
    /// (almost) undamped resonance, docs/formats.md "Model checks"), which
    /// no setting here can mend.
    fn remedy(&self, model: &DiscreteTf, params: &RepetitiveParams) -> String {
        let passes = |p: RepetitiveParams| repetitive::design(model, &p).ok().map(|d| d.rho);
        let mut found = Vec::new();
        if let Some((k, rho)) = REMEDY_STEPS.iter().find_map(|d| {
            let k = params.gain / d;
            passes(RepetitiveParams {
                gain: k,
                ..params.clone()
            })
            .map(|r| (k, r))
        }) {
            found.push(format!("`gain` {k} (rho {rho:.3})"));
        }
        if let Some(QFilter::LowPass {
            cutoff_hz,
            half_length,
        }) = params.q
            && let Some((c, rho)) = REMEDY_STEPS.iter().find_map(|d| {
                let q = QFilter::LowPass {
                    cutoff_hz: cutoff_hz / d,
                    half_length,
                };
                passes(RepetitiveParams {
                    q: Some(q),
                    ..params.clone()
                })
                .map(|r| (cutoff_hz / d, r))
            })
        {
            found.push(format!("`q_cutoff` {c} Hz (rho {rho:.3})"));
        }
        if params.lead.is_some()
            && let Some(rho) = passes(RepetitiveParams {
                lead: None,
                ..params.clone()
            })
        {
            found.push(format!("the lead scan, without `lead` (rho {rho:.3})"));
        }
        let mut advice = if found.is_empty() {
            format!(
                "neither a gain nor a Q cutoff down to 1/{} of the given meets it",
                REMEDY_STEPS[REMEDY_STEPS.len() - 1]
            )
        } else {
            format!("each of these meets it: {}", found.join(", "))
        };
        for trap in crate::lti::model_check::trap_poles(model).unwrap_or_default() {
            advice.push_str(&format!(
                "; the model's {trap}: an (almost) undamped resonance that no identification data showed, which no setting here mends: design on a loop model identified from data reaching where Q passes (fts demo writes learning-model.json, swept to 4500 Hz)"
            ));
        }
        advice
    }

    /// The setting a design's refusal `key: message` is about: `q`, `gain`,
    /// `lead` when it was given, otherwise the period as it was given
    /// (`period`, `period_s` or `spindle_hz`, with its value and the
    /// period in samples it makes at `ts`).
    fn setting_error(&self, message: &str, ts: f64) -> StepError {
        let (key, rest) = message.split_once(": ").unwrap_or(("period", message));
        match key {
            "q" if self.q.is_some() => {
                let taps = self.q.iter().flatten().map(|x| super::fmt_value(*x));
                let taps: Vec<String> = taps.collect();
                StepError::setting("q", format!("{rest}, got {}", taps.join(",")))
            }
            "gain" => StepError::setting("gain", rest.to_string()),
            "lead" if self.lead.is_some() => StepError::setting(
                "lead",
                format!("{} samples: {rest}", self.lead.unwrap_or_default()),
            ),
            _ => {
                let v = super::fmt_value;
                let (field, given) = match (self.period_s, self.spindle_hz) {
                    (Some(s), _) => ("period_s", format!("{} s at ts {} s", v(s), v(ts))),
                    (_, Some(f)) => ("spindle_hz", format!("{} Hz at ts {} s", v(f), v(ts))),
                    _ => ("period", String::new()),
                };
                let samples = match self.period {
                    Some(p) => super::fmt_value(p),
                    None => super::fmt_about(self.period_samples(ts)),
                };
                let rest = rest.replace(
                    &format!("{} samples", self.period_samples(ts)),
                    &format!("{samples} samples"),
                );
                let message = match (given.is_empty(), rest.starts_with("a period")) {
                    (true, _) => rest,
                    (false, true) => format!("{given}: {rest}"),
                    (false, false) => format!("{given} is a period of {rest}"),
                };
                StepError::setting(field, message)
            }
        }
    }
}

impl RepetitiveReport {
    /// The design file (`fts.repetitive/1`, pretty JSON and a newline):
    /// what `fts repetitive -o` and the manifest's `repetitive` step write.
    pub fn file_text(&self) -> String {
        let mut text = serde_json::to_string_pretty(self).expect("a report serialises");
        text.push('\n');
        text
    }
}

impl fmt::Display for RepetitiveReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.design;
        writeln!(
            f,
            "repetitive compensator: period {} samples ({:.6} s, {:.3} Hz), Q {} taps each side (|Q| = 1/2 at {:.1} Hz), lead {} samples, gain {}",
            d.period as f64 + d.fraction,
            (d.period as f64 + d.fraction) * d.ts,
            1.0 / ((d.period as f64 + d.fraction) * d.ts),
            d.q.len() - 1,
            d.q_cutoff_hz,
            d.lead,
            d.gain
        )?;
        writeln!(
            f,
            "stability: max |Q (1 - k_r z^m T)| = {:.4} at {:.1} Hz (< 1: stable; margin {:.4}; the periodic error contracts at least this much per period)",
            d.rho,
            d.rho_at_hz,
            d.margin()
        )?;
        let scan: Vec<String> = d
            .lead_scan
            .iter()
            .map(|(m, r)| format!("{m}:{r:.3}"))
            .collect();
        if scan.len() > 1 {
            writeln!(f, "lead scan (m:rho): {}", scan.join(" "))?;
        }
        writeln!(
            f,
            "periodic error with / without the compensator, by harmonic:"
        )?;
        for h in d.harmonics.iter().take(10) {
            writeln!(
                f,
                "  {:>3}  {:>9.2} Hz  {:>10.3e}  ({:.1} dB)",
                h.harmonic,
                h.freq_hz,
                h.ratio,
                20.0 * h.ratio.max(1e-300).log10()
            )?;
        }
        if d.harmonics.len() > 10 {
            writeln!(f, "  ... {} harmonics below Nyquist", d.harmonics.len())?;
        }
        Ok(())
    }
}

impl Serialize for RepetitiveReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let d = &self.design;
        serde_json::json!({
            "format": REPETITIVE_FORMAT,
            "ts": d.ts,
            "period": d.period,
            "fraction": d.fraction,
            "q": d.q,
            "lead": d.lead,
            "gain": d.gain,
            "design": {
                "period_s": (d.period as f64 + d.fraction) * d.ts,
                "rho": d.rho,
                "rho_at_hz": d.rho_at_hz,
                "margin": d.margin(),
                "q_cutoff_hz": d.q_cutoff_hz,
                "lead_scan": d.lead_scan,
                "harmonics": d.harmonics,
            },
        })
        .serialize(s)
    }
}

/// The format tag of a repetitive design file.
pub const REPETITIVE_FORMAT: &str = "fts.repetitive/1";

/// A repetitive design file as read back: the block and its sample time
/// (the design's figures, written beside them, are for people).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct RepetitiveFile {
    /// Format tag.
    pub format: String,
    /// Sample time, s.
    pub ts: f64,
    /// The block's settings, at the top level of the file.
    #[serde(flatten)]
    pub block: RepetitiveBlock,
}

impl RepetitiveFile {
    /// Reads a design file (`fts.repetitive/1`); errors name `source` and
    /// the line or field.
    pub fn parse(text: &str, source: &str) -> Result<Self, StepError> {
        let file: RepetitiveFile = serde_json::from_str(text)
            .map_err(|e| StepError::input(format!("{source} line {}: {e}", e.line())))?;
        if file.format != REPETITIVE_FORMAT {
            return Err(StepError::input(format!(
                "{source} field 'format': expected \"{REPETITIVE_FORMAT}\", found {:?}",
                file.format
            )));
        }
        Ok(file)
    }

    /// The block for a loop sampled every `ts` s: a design made at another
    /// rate has a different period in samples, a different Q and a
    /// different lead, and is refused.
    pub fn block_at(&self, ts: f64, source: &str) -> Result<RepetitiveBlock, StepError> {
        if (self.ts - ts).abs() > 1e-9 * ts.abs() {
            return Err(StepError::input(format!(
                "{source} field 'ts': the compensator was designed for a {} s sample time, the loop runs at {ts} s; design it on a closed-loop model at the loop's rate",
                self.ts
            )));
        }
        self.check_block(ts, source)?;
        Ok(self.block.clone())
    }

    /// The block as a real-time loop would load it (period and lead within
    /// the runtime's memory, finite taps): a refusal names `source`, the
    /// file's key and its value.
    fn check_block(&self, ts: f64, source: &str) -> Result<(), StepError> {
        use crate::io::controller_file::{ControllerFile, Feedback, Provenance, Units};
        let file = ControllerFile {
            ts,
            units: Units::default(),
            zpetc: None,
            repetitive: Some(self.block.clone()),
            feedforward_table: None,
            hysteresis: None,
            feedback: Feedback::None,
            provenance: Provenance::default(),
        };
        crate::runtime::RuntimeController::new(&file.runtime_spec())
            .map(|_| ())
            .map_err(|e| {
                let field = crate::io::controller_file::runtime_field(&e);
                let key = field.trim_start_matches("repetitive.");
                let value = serde_json::to_value(&self.block)
                    .ok()
                    .and_then(|v| v.get(key).map(|x| format!(" {x}")))
                    .unwrap_or_default();
                StepError::input(format!(
                    "{source} field '{key}':{value}: the runtime refuses it ({e})"
                ))
            })
    }
}

pub use super::ilc::{Ilc, IlcReport, TrialRow};
