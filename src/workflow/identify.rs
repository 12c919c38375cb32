//! Identification steps: linear models (ARX, OE, IV, ARX structure
//! selection) from an input/output record with its preparation and
//! diagnostics (docs/math.md §2), and hysteresis models (docs/math.md §1.5).
//! What `fts identify ...` runs and the pipeline's `arx`, `oe` and
//! `hysteresis` steps deserialise into.

use super::{StepError, Validate, fmt_complex, some_whole_number, whole_number};
use crate::ident::arx::{ArxParams, Orders, arx};
use crate::ident::data::{Detrend, detrend, split_point};
use crate::ident::iv::{IvParams, iv};
use crate::ident::linear::{
    Criteria, Fits, IdentError, NoiseModel, PolyModel, Whiteness, fits, fits_and_residuals,
    whiteness,
};
use crate::ident::oe::{OeParams, OeProgress, OeStart, oe, refine_arx};
use crate::ident::structure::{
    SelectionRule, StructParams, StructRow, StructSearch, arx_struct_observed, delay_estimate,
};
use crate::io::tf_json;
use crate::io::timeseries::{IoData, Timing};
use crate::lti::{DiscreteTf, TransferFunction, c64};
use serde::{Deserialize, Serialize, Serializer};
use std::fmt;

pub use super::identify_hysteresis::{
    HysteresisInputs, HysteresisMethod, HysteresisModelKind, HysteresisReport, IdentifyHysteresis,
    PlayOperatorChoice,
};

/// Lags of the residual tests (MATLAB `resid` default).
const RESID_LAGS: usize = 25;

// ------------------------------------------------------- record preparation

/// One prepared record.
#[derive(Debug, Clone)]
pub struct Record {
    /// Input, detrended.
    pub u: Vec<f64>,
    /// Output, detrended.
    pub y: Vec<f64>,
    /// What it is, for people (`dryer.dat samples 1..500`).
    pub label: String,
    /// Index of its first sample in the file it came from: a validation
    /// part of a split record starts where the estimation part ends.
    pub first_sample: usize,
}

/// Estimation and (optional) validation records, detrended, with `ts`.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Estimation record.
    pub est: Record,
    /// Validation record.
    pub val: Option<Record>,
    /// Sample time, s.
    pub ts: f64,
    /// The estimation record's time column, when it has one.
    pub timing: Option<Timing>,
    /// Trend removed.
    pub detrend: Detrend,
    /// The estimation record's name.
    pub source: String,
}

/// The records a linear step identifies from (already read).
#[derive(Debug, Clone)]
pub struct LinearInputs {
    /// Estimation record.
    pub data: IoData,
    /// Its name (a file path), for messages.
    pub source: String,
    /// Validation record and its name, if any.
    pub validation: Option<(IoData, String)>,
}

/// How a record becomes a [`Prepared`] one: the settings every linear step
/// shares.
#[derive(Debug, Clone, Copy)]
pub struct RecordSettings {
    /// Sample time, s (default: the time column's).
    pub ts: Option<f64>,
    /// Trend removal.
    pub detrend: Detrend,
    /// Fraction of the record used for estimation, the rest validates.
    pub split: Option<f64>,
}

impl Validate for RecordSettings {
    fn validate(&self) -> Result<(), StepError> {
        if let Some(ts) = self.ts
            && !(ts.is_finite() && ts > 0.0)
        {
            return Err(StepError::setting(
                "ts",
                format!("expected a positive number of seconds, got {ts}"),
            ));
        }
        if let Some(f) = self.split
            && !(f > 0.0 && f < 1.0)
        {
            return Err(StepError::setting(
                "split",
                format!("expected a fraction strictly between 0 and 1, got {f}"),
            ));
        }
        Ok(())
    }
}

impl RecordSettings {
    /// The sample time: `ts` when set (checked against a time column, which
    /// may deviate by its jitter tolerance), else the time column's mean step.
    fn sample_time(&self, timing: Option<&Timing>, source: &str) -> Result<f64, StepError> {
        match (timing, self.ts) {
            (Some(t), Some(ts)) if ((t.ts - ts) / ts).abs() > t.tolerance.max(1e-6) => {
                Err(StepError::setting(
                    "ts",
                    format!(
                        "{source}: the time column '{}' gives a sample time of {} s but `ts` is {ts} s",
                        t.column, t.ts
                    ),
                ))
            }
            (_, Some(ts)) => Ok(ts),
            (Some(t), None) => Ok(t.ts),
            (None, None) => Err(StepError::setting(
                "ts",
                format!(
                    "{source}: no time column, so the sample time is unknown; give `ts` SECONDS"
                ),
            )),
        }
    }

    /// Splits (or pairs with the validation record) and detrends.
    pub fn prepare(&self, inputs: LinearInputs) -> Result<Prepared, StepError> {
        self.validate()?;
        let LinearInputs {
            data: io,
            source,
            validation,
        } = inputs;
        let timing = io.timing.clone();
        let ts = self.sample_time(timing.as_ref(), &source)?;
        let record = |u: Vec<f64>, y: Vec<f64>, label: String, first_sample: usize| Record {
            u,
            y,
            label,
            first_sample,
        };
        let (mut est, mut val) = match (validation, self.split) {
            (Some((v, vsource)), _) => {
                if let Some(vt) = &v.timing
                    && ((vt.ts - ts) / ts).abs() > vt.tolerance.max(1e-6)
                {
                    return Err(StepError::input(format!(
                        "{vsource}: sample time {} s differs from the estimation data's {ts} s",
                        vt.ts
                    )));
                }
                let est = record(io.input, io.output, source.clone(), 0);
                (est, Some(record(v.input, v.output, vsource, 0)))
            }
            (None, Some(f)) => {
                let n = io.input.len();
                let k = split_point(n, f);
                if k < 2 || n - k < 2 {
                    return Err(StepError::setting(
                        "split",
                        format!(
                            "{source}: `split` {f} leaves {k} estimation and {} validation samples",
                            n - k
                        ),
                    ));
                }
                let (ue, uv) = io.input.split_at(k);
                let (ye, yv) = io.output.split_at(k);
                (
                    record(
                        ue.to_vec(),
                        ye.to_vec(),
                        format!("{source} samples 1..{k}"),
                        0,
                    ),
                    Some(record(
                        uv.to_vec(),
                        yv.to_vec(),
                        format!("{source} samples {}..{n}", k + 1),
                        k,
                    )),
                )
            }
            (None, None) => (record(io.input, io.output, source.clone(), 0), None),
        };
        for r in std::iter::once(&mut est).chain(val.as_mut()) {
            detrend(&mut r.u, self.detrend);
            detrend(&mut r.y, self.detrend);
        }
        Ok(Prepared {
            est,
            val,
            ts,
            timing,
            detrend: self.detrend,
            source,
        })
    }
}

/// Identification errors: everything about the data or the structure is
/// bad input and names the record; a numerical breakdown is the computation's.
fn ident_err(source: &str) -> impl Fn(IdentError) -> StepError + '_ {
    move |e| match e {
        IdentError::Numerical(_) => StepError::computation(format!("{source}: {e}")),
        other => StepError::input(format!("{source}: {other}")),
    }
}

/// An order setting that must be given.
fn required(field: &'static str, value: Option<usize>) -> Result<usize, StepError> {
    value.ok_or_else(|| {
        StepError::setting(
            field,
            "missing: this kind of step needs it (a whole number)",
        )
    })
}

/// What a linear step reports while it runs.
#[derive(Debug, Clone, Copy)]
pub enum LinearProgress {
    /// An output-error iteration finished.
    Oe(OeProgress),
    /// Structure search: `done` of `total` candidates estimated.
    Search {
        /// Candidates estimated.
        done: usize,
        /// Candidates in all.
        total: usize,
    },
}

// ------------------------------------------------------------- choices

/// Which structure a selection recommends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SelectionRuleChoice {
    /// Validation loss when validation data exist, otherwise MDL.
    #[default]
    Auto,
    /// Minimum one-step prediction loss on the validation data.
    Loss,
    /// Maximum simulation fit on the validation data.
    Fit,
    /// Minimum AIC on the estimation data.
    Aic,
    /// Minimum FPE on the estimation data.
    Fpe,
    /// Minimum MDL on the estimation data.
    Mdl,
}

impl crate::workflow::Choices for SelectionRuleChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "auto",
            "Validation loss when validation data exist, otherwise MDL",
        ),
        (
            "loss",
            "Minimum one-step prediction loss on the validation data (MATLAB arxstruc/selstruc)",
        ),
        ("fit", "Maximum simulation fit on the validation data"),
        ("aic", "Minimum AIC on the estimation data"),
        ("fpe", "Minimum FPE on the estimation data"),
        ("mdl", "Minimum MDL on the estimation data"),
    ];
}

impl SelectionRuleChoice {
    /// The rule's name in reports, given whether validation data exist.
    fn name(self, validated: bool) -> &'static str {
        match (self, validated) {
            (Self::Auto, true) | (Self::Loss, _) => "validation_loss",
            (Self::Auto, false) | (Self::Mdl, _) => "mdl",
            (Self::Fit, _) => "validation_fit",
            (Self::Aic, _) => "aic",
            (Self::Fpe, _) => "fpe",
        }
    }

    /// The structure the rule picks, with the rule's name; a validation rule
    /// without validation data is a bad setting.
    fn pick(self, s: &StructSearch) -> Result<(Orders, &'static str), StepError> {
        let name = self.name(s.best_validation.is_some());
        let rule = match self {
            Self::Auto => SelectionRule::Auto,
            Self::Loss => SelectionRule::ValidationLoss,
            Self::Fit => SelectionRule::ValidationFit,
            Self::Aic => SelectionRule::Aic,
            Self::Fpe => SelectionRule::Fpe,
            Self::Mdl => SelectionRule::Mdl,
        };
        s.pick(rule).map(|o| (o, name)).ok_or_else(|| {
            StepError::setting(
                "rule",
                format!(
                    "`rule` {name} needs validation data: give `validate` FILE or `split` FRACTION"
                ),
            )
        })
    }
}

/// Start of the output-error iteration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OeStartChoice {
    /// Whichever of IV and ARX simulates the data better.
    #[default]
    Best,
    /// Refined instrumental variables.
    Iv,
    /// Least-squares ARX.
    Arx,
}

impl crate::workflow::Choices for OeStartChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("best", "Whichever of IV and ARX simulates the data better"),
        ("iv", "Refined instrumental variables"),
        ("arx", "Least-squares ARX"),
    ];
}

/// Initial conditions of the output-error simulation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InitialChoice {
    /// Estimated with the model (MATLAB default).
    #[default]
    Estimate,
    /// From rest.
    Zero,
}

impl crate::workflow::Choices for InitialChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "estimate",
            "Estimate the initial state together with B and F",
        ),
        ("zero", "Start the simulation from rest"),
    ];
}

// ---------------------------------------------------------------- steps

/// `fts identify arx`, pipeline kind `arx`: ARX `A y = B u(k-nk) + e` by
/// QR least squares, orders given or chosen by structure selection.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyArx {
    /// Sample time, s; default the record's time column.
    pub ts: Option<f64>,
    /// Trend removed from each record; default none.
    pub detrend: Detrend,
    /// Estimate on this leading fraction, validate on the rest; default none.
    pub split: Option<f64>,
    /// Poles (A coefficients after the leading 1); required unless `auto`.
    #[serde(deserialize_with = "some_whole_number")]
    pub na: Option<usize>,
    /// B coefficients; required unless `auto`.
    #[serde(deserialize_with = "some_whole_number")]
    pub nb: Option<usize>,
    /// Input delay, samples; required unless `auto`.
    #[serde(deserialize_with = "some_whole_number")]
    pub nk: Option<usize>,
    /// Choose the orders by structure selection (na, nb 1..10, nk 0..10); default false.
    pub auto: bool,
    /// Selection rule under `auto`; default auto.
    pub rule: SelectionRuleChoice,
    /// Try an output-error model of the same orders and keep it when it
    /// simulates the record better (what `fts demo` does); default false.
    pub refine_oe: bool,
}

/// `fts identify oe`, pipeline kind `oe`: output error `y = B/F u(k-nk) + e`
/// by Levenberg-Marquardt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyOe {
    /// Sample time, s; default the record's time column.
    pub ts: Option<f64>,
    /// Trend removed from each record; default none.
    pub detrend: Detrend,
    /// Estimate on this leading fraction, validate on the rest; default none.
    pub split: Option<f64>,
    /// B coefficients (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nb: Option<usize>,
    /// F coefficients after the leading 1, the poles (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nf: Option<usize>,
    /// Input delay, samples (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nk: Option<usize>,
    /// Start estimate of the iteration; default best. (Not `start`, which
    /// in a manifest is the record's first sample.)
    pub start_estimate: OeStartChoice,
    /// Initial conditions of the simulation; default estimate.
    pub initial: InitialChoice,
    /// Levenberg-Marquardt iteration cap; default 100.
    #[serde(deserialize_with = "whole_number")]
    pub max_iterations: usize,
}

impl Default for IdentifyOe {
    fn default() -> Self {
        IdentifyOe {
            ts: None,
            detrend: Detrend::None,
            split: None,
            nb: None,
            nf: None,
            nk: None,
            start_estimate: OeStartChoice::Best,
            initial: InitialChoice::Estimate,
            max_iterations: OeParams::new(Orders::new(1, 1, 1)).max_iterations,
        }
    }
}

/// `fts identify iv`: refined instrumental-variable estimate of `B/A`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyIv {
    /// Sample time, s; default the record's time column.
    pub ts: Option<f64>,
    /// Trend removed from each record; default none.
    pub detrend: Detrend,
    /// Estimate on this leading fraction, validate on the rest; default none.
    pub split: Option<f64>,
    /// Poles (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub na: Option<usize>,
    /// B coefficients (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nb: Option<usize>,
    /// Input delay, samples (required).
    #[serde(deserialize_with = "some_whole_number")]
    pub nk: Option<usize>,
}

/// `fts identify arx-struct`: ARX structure selection over ranges of
/// orders, with a delay estimate and the recommended model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArxStruct {
    /// Sample time, s; default the record's time column.
    pub ts: Option<f64>,
    /// Trend removed from each record; default none.
    pub detrend: Detrend,
    /// Estimate on this leading fraction, validate on the rest; default none.
    pub split: Option<f64>,
    /// Range of na: `LO:HI`, a list `1,2,4` or one value; default `1:10`.
    pub na: String,
    /// Range of nb; default `1:10`.
    pub nb: String,
    /// Range of nk; default `0:10`.
    pub nk: String,
    /// Rows of the printed table, best first; default 15.
    #[serde(deserialize_with = "whole_number")]
    pub top: usize,
    /// Which structure to recommend; default auto.
    pub rule: SelectionRuleChoice,
}

impl Default for ArxStruct {
    fn default() -> Self {
        ArxStruct {
            ts: None,
            detrend: Detrend::None,
            split: None,
            na: "1:10".into(),
            nb: "1:10".into(),
            nk: "0:10".into(),
            top: 15,
            rule: SelectionRuleChoice::Auto,
        }
    }
}

macro_rules! record_settings {
    ($($t:ty),*) => {$(
        impl $t {
            /// The record preparation settings.
            pub fn record(&self) -> RecordSettings {
                RecordSettings { ts: self.ts, detrend: self.detrend, split: self.split }
            }
        }
    )*};
}
record_settings!(IdentifyArx, IdentifyOe, IdentifyIv, ArxStruct);

impl Validate for IdentifyArx {
    fn validate(&self) -> Result<(), StepError> {
        self.record().validate()?;
        if !self.auto {
            self.orders()?;
        }
        Ok(())
    }
}

impl Validate for IdentifyOe {
    fn validate(&self) -> Result<(), StepError> {
        self.record().validate()?;
        self.orders().map(|_| ())
    }
}

impl Validate for IdentifyIv {
    fn validate(&self) -> Result<(), StepError> {
        self.record().validate()?;
        self.orders().map(|_| ())
    }
}

impl Validate for ArxStruct {
    fn validate(&self) -> Result<(), StepError> {
        self.record().validate()?;
        self.grid(1.0).map(|_| ())
    }
}

/// One estimate, before its diagnostics.
struct Estimate {
    method: &'static str,
    orders: OrdersDoc,
    model: PolyModel,
    std_den: Vec<f64>,
    std_num: Vec<f64>,
    criteria: Criteria,
    noise_variance: f64,
    condition_number: f64,
    noise: NoiseModel,
    details: MethodDetails,
}

fn arx_estimate(
    est: crate::ident::arx::ArxEstimate,
    o: Orders,
    details: MethodDetails,
) -> Estimate {
    Estimate {
        method: "arx",
        orders: OrdersDoc::Arx {
            na: o.na,
            nb: o.nb,
            nk: o.nk,
        },
        model: est.model,
        std_den: est.std_a,
        std_num: est.std_b,
        criteria: est.criteria,
        noise_variance: est.noise_variance,
        condition_number: est.condition_number,
        noise: NoiseModel::Arx,
        details,
    }
}

/// An output-error estimate of orders `o` (`o.na` is `nf`).
fn oe_estimate(est: crate::ident::oe::OeEstimate, o: Orders, start: OeStartChoice) -> Estimate {
    let note = format!(
        "Levenberg-Marquardt: {} iterations, {}, loss {:.6e} -> {:.6e} from the {} start",
        est.iterations,
        converged_word(est.converged),
        est.start_loss,
        est.criteria.loss,
        match start {
            OeStartChoice::Best => "best of IV/ARX",
            OeStartChoice::Iv => "IV",
            OeStartChoice::Arx => "ARX",
        }
    );
    Estimate {
        method: "oe",
        orders: OrdersDoc::Oe {
            nb: o.nb,
            nf: o.na,
            nk: o.nk,
        },
        details: MethodDetails {
            iterations: Some(est.iterations),
            converged: Some(est.converged),
            start_loss: Some(est.start_loss),
            initial_conditions: Some(est.initial_conditions),
            note: Some(note),
            ..MethodDetails::default()
        },
        model: est.model,
        std_den: est.std_f,
        std_num: est.std_b,
        criteria: est.criteria,
        noise_variance: est.noise_variance,
        condition_number: est.condition_number,
        noise: NoiseModel::OutputError,
    }
}

fn converged_word(converged: bool) -> &'static str {
    if converged {
        "converged"
    } else {
        "NOT converged (iteration cap)"
    }
}

/// Structure search over `sp`, progress reported.
fn search(
    p: &Prepared,
    sp: &StructParams,
    progress: &mut dyn FnMut(LinearProgress),
) -> Result<StructSearch, StepError> {
    arx_struct_observed(
        &p.est.u,
        &p.est.y,
        p.val.as_ref().map(|v| (&v.u[..], &v.y[..])),
        sp,
        &mut |done, total| progress(LinearProgress::Search { done, total }),
    )
    .map_err(ident_err(&p.source))
}

impl IdentifyArx {
    fn orders(&self) -> Result<Orders, StepError> {
        Ok(Orders::new(
            required("na", self.na)?,
            required("nb", self.nb)?,
            required("nk", self.nk)?,
        ))
    }

    /// Identifies the model (no progress reports).
    pub fn run(&self, inputs: LinearInputs) -> Result<LinearReport, StepError> {
        self.run_observed(inputs, &mut |_| {})
    }

    /// Identifies the model, reporting the structure search's progress.
    pub fn run_observed(
        &self,
        inputs: LinearInputs,
        progress: &mut dyn FnMut(LinearProgress),
    ) -> Result<LinearReport, StepError> {
        self.validate()?;
        let p = self.record().prepare(inputs)?;
        let mut ap = ArxParams::new(Orders::new(0, 1, 0));
        let mut details = MethodDetails::default();
        let mut edges = Vec::new();
        ap.orders = if self.auto {
            let sp = StructParams {
                ts: p.ts,
                ..Default::default()
            };
            let s = search(&p, &sp, progress)?;
            let (o, rule) = self.rule.pick(&s)?;
            ap.start = Some(s.start);
            details.selection = Some(Selection::of(&s, rule));
            edges = grid_edges(o, &sp, |name| {
                format!("`fts identify arx-struct --{name} LO:HI`, whose grid --auto searches")
            });
            o
        } else {
            self.orders()?
        };
        ap.ts = p.ts;
        let est = arx(&p.est.u, &p.est.y, &ap).map_err(ident_err(&p.source))?;
        if !self.refine_oe {
            let mut report = LinearReport::new(p, arx_estimate(est, ap.orders, details))?;
            report.grid_edges = edges;
            return Ok(report);
        }
        let mut op = OeParams::new(ap.orders);
        op.ts = p.ts;
        let refined = refine_arx(&est.model, &p.est.u, &p.est.y, &op);
        let doc = RefinementDoc {
            chosen: if refined.chosen { "oe" } else { "arx" },
            reason: refined.reason.clone(),
            arx_fit_percent: refined.arx_fit.simulation_percent,
            oe_fit_percent: refined.oe_fit.map(|f| f.simulation_percent),
        };
        let chosen = match refined.oe {
            Some(o) if refined.chosen => oe_estimate(o, ap.orders, OeStartChoice::Best),
            _ => arx_estimate(est, ap.orders, details),
        };
        let mut report = LinearReport::new(p, chosen)?;
        report.refinement = Some(doc);
        report.grid_edges = edges;
        Ok(report)
    }
}

impl IdentifyOe {
    fn orders(&self) -> Result<Orders, StepError> {
        Ok(Orders::new(
            required("nf", self.nf)?,
            required("nb", self.nb)?,
            required("nk", self.nk)?,
        ))
    }

    /// Identifies the model (no progress reports).
    pub fn run(&self, inputs: LinearInputs) -> Result<LinearReport, StepError> {
        self.run_observed(inputs, &mut |_| {})
    }

    /// Identifies the model, reporting each iteration.
    pub fn run_observed(
        &self,
        inputs: LinearInputs,
        progress: &mut dyn FnMut(LinearProgress),
    ) -> Result<LinearReport, StepError> {
        self.validate()?;
        let p = self.record().prepare(inputs)?;
        let o = self.orders()?;
        let mut op = OeParams::new(o);
        op.ts = p.ts;
        op.max_iterations = self.max_iterations;
        op.start = match self.start_estimate {
            OeStartChoice::Best => OeStart::Best,
            OeStartChoice::Iv => OeStart::Iv,
            OeStartChoice::Arx => OeStart::Arx,
        };
        op.estimate_initial = self.initial == InitialChoice::Estimate;
        let est = oe(&p.est.u, &p.est.y, &op, &mut |pr| {
            progress(LinearProgress::Oe(*pr))
        })
        .map_err(ident_err(&p.source))?;
        LinearReport::new(p, oe_estimate(est, o, self.start_estimate))
    }
}

impl IdentifyIv {
    fn orders(&self) -> Result<Orders, StepError> {
        Ok(Orders::new(
            required("na", self.na)?,
            required("nb", self.nb)?,
            required("nk", self.nk)?,
        ))
    }

    /// Identifies the model.
    pub fn run(&self, inputs: LinearInputs) -> Result<LinearReport, StepError> {
        self.validate()?;
        let p = self.record().prepare(inputs)?;
        let o = self.orders()?;
        let mut ip = IvParams::new(o);
        ip.ts = p.ts;
        let est = iv(&p.est.u, &p.est.y, &ip).map_err(ident_err(&p.source))?;
        let note = format!(
            "refined IV: {} iterations, {}",
            est.iterations,
            converged_word(est.converged)
        );
        let e = Estimate {
            method: "iv",
            orders: OrdersDoc::Arx {
                na: o.na,
                nb: o.nb,
                nk: o.nk,
            },
            model: est.model,
            std_den: est.std_a,
            std_num: est.std_b,
            criteria: est.criteria,
            noise_variance: est.noise_variance,
            condition_number: est.condition_number,
            noise: NoiseModel::OutputError,
            details: MethodDetails {
                iterations: Some(est.iterations),
                converged: Some(est.converged),
                note: Some(note),
                ..MethodDetails::default()
            },
        };
        LinearReport::new(p, e)
    }
}

/// Parses `LO:HI`, `A,B,C` or `N`.
fn parse_range(text: &str, name: &'static str) -> Result<Vec<usize>, StepError> {
    let err = || {
        StepError::setting(
            name,
            format!("expected LO:HI, a comma list or a number, got {text:?}"),
        )
    };
    let t = text.trim();
    let v: Vec<usize> = if let Some((lo, hi)) = t.split_once(':') {
        let lo: usize = lo.trim().parse().map_err(|_| err())?;
        let hi: usize = hi.trim().parse().map_err(|_| err())?;
        if lo > hi || hi - lo > 200 {
            return Err(err());
        }
        (lo..=hi).collect()
    } else {
        t.split(',')
            .map(|s| s.trim().parse::<usize>().map_err(|_| err()))
            .collect::<Result<_, _>>()?
    };
    if v.is_empty() {
        return Err(err());
    }
    Ok(v)
}

/// Where a structure chosen by a search sits on an edge of the searched
/// grid: an order or delay at the top of its range (or at the bottom of a
/// range that starts above the smallest sensible value, 1 for `na`/`nb`, 0
/// for `nk`) may be a corner of the grid rather than the optimum. One
/// sentence per edge, naming the range and `widen(name)`, the setting that
/// widens it.
fn grid_edges(o: Orders, sp: &StructParams, widen: impl Fn(&str) -> String) -> Vec<String> {
    let axes = [
        ("na", o.na, &sp.na, 1),
        ("nb", o.nb, &sp.nb, 1),
        ("nk", o.nk, &sp.nk, 0),
    ];
    let mut edges = Vec::new();
    for (name, value, range, floor) in axes {
        let (Some(&lo), Some(&hi)) = (range.iter().min(), range.iter().max()) else {
            continue;
        };
        let edge = if hi > lo && value == hi {
            "upper"
        } else if hi > lo && value == lo && lo > floor {
            "lower"
        } else {
            continue;
        };
        edges.push(format!(
            "{name} = {value} lies on the {edge} edge of the searched range {lo}..{hi}: the best structure may lie beyond it; widen the range with {}",
            widen(name)
        ));
    }
    edges
}

impl ArxStruct {
    fn grid(&self, ts: f64) -> Result<StructParams, StepError> {
        Ok(StructParams {
            na: parse_range(&self.na, "na")?,
            nb: parse_range(&self.nb, "nb")?,
            nk: parse_range(&self.nk, "nk")?,
            ts,
        })
    }

    /// Searches the grid and estimates the recommended structure.
    pub fn run_observed(
        &self,
        inputs: LinearInputs,
        progress: &mut dyn FnMut(LinearProgress),
    ) -> Result<StructReport, StepError> {
        self.validate()?;
        let p = self.record().prepare(inputs)?;
        let sp = self.grid(p.ts)?;
        let s = search(&p, &sp, progress)?;
        let nk_lo = *sp.nk.iter().min().unwrap_or(&0);
        let nk_hi = *sp.nk.iter().max().unwrap_or(&0);
        // One ARX fit per delay from the lowest to the highest: only for a
        // span as short as a LO:HI range may be.
        let delay = (nk_hi - nk_lo <= 200)
            .then(|| delay_estimate(&p.est.u, &p.est.y, 2, 2, nk_lo..=nk_hi).ok())
            .flatten();
        let (best, rule) = self.rule.pick(&s)?;
        let mut ap = ArxParams::new(best);
        ap.ts = p.ts;
        ap.start = Some(s.start);
        let est = arx(&p.est.u, &p.est.y, &ap).map_err(ident_err(&p.source))?;
        let tf = est.model.tf().map_err(ident_err(&p.source))?;
        let val_fit = p
            .val
            .as_ref()
            .map(|v| fits(&est.model, NoiseModel::Arx, &v.u, &v.y).simulation_percent);
        let fit = fits(&est.model, NoiseModel::Arx, &p.est.u, &p.est.y).simulation_percent;
        let grid_edges = grid_edges(best, &sp, |name| format!("--{name} LO:HI"));
        Ok(StructReport {
            grid_edges,
            model_doc: tf_json::tf_to_value(&TransferFunction::Discrete(tf.clone())),
            recommended: best,
            rule,
            best_validation: s.best_validation,
            best_validation_fit: s.best_validation_fit,
            best_aic: s.best_aic,
            best_fpe: s.best_fpe,
            best_mdl: s.best_mdl,
            delay_estimate: delay.as_ref().map(|d| d.0),
            delay_losses: delay.map(|d| d.1),
            validation_fit_percent: val_fit,
            fit_percent: fit,
            skipped: s
                .skipped
                .iter()
                .map(|(orders, reason)| Skipped {
                    orders: *orders,
                    reason: reason.clone(),
                })
                .collect(),
            rows: s.rows,
            tf,
            nk_range: (nk_lo, nk_hi),
            top: self.top,
            prepared: p,
        })
    }
}

// -------------------------------------------------------------- reports

/// The orders as reported: `[na nb nk]`, or `[nb nf nk]` for OE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum OrdersDoc {
    /// ARX and IV.
    Arx {
        /// Poles.
        na: usize,
        /// B coefficients.
        nb: usize,
        /// Delay.
        nk: usize,
    },
    /// Output error.
    Oe {
        /// B coefficients.
        nb: usize,
        /// Poles.
        nf: usize,
        /// Delay.
        nk: usize,
    },
}

impl fmt::Display for OrdersDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            OrdersDoc::Arx { na, nb, nk } => write!(f, "{}", Orders::new(na, nb, nk)),
            OrdersDoc::Oe { nb, nf, nk } => write!(f, "[nb nf nk] = [{nb} {nf} {nk}]"),
        }
    }
}

/// Fit figures on one record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FitsDoc {
    /// Simulation fit, %, initial conditions estimated.
    pub simulation_fit_percent: f64,
    /// Simulation fit from rest, %.
    pub simulation_fit_zero_ic_percent: f64,
    /// One-step prediction fit, %.
    pub prediction_fit_percent: f64,
    /// Mean squared one-step prediction error.
    pub prediction_mse: f64,
}

impl From<&Fits> for FitsDoc {
    fn from(f: &Fits) -> Self {
        FitsDoc {
            simulation_fit_percent: f.simulation_percent,
            simulation_fit_zero_ic_percent: f.simulation_zero_ic_percent,
            prediction_fit_percent: f.prediction_percent,
            prediction_mse: f.prediction_mse,
        }
    }
}

/// Fits and residual tests on the validation record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationDoc {
    /// The fits.
    #[serde(flatten)]
    pub fits: FitsDoc,
    /// The record.
    pub data: String,
    /// Residual tests on it.
    pub whiteness: Whiteness,
}

/// How the structure was chosen (`auto`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Selection {
    /// Candidates estimated.
    pub candidates: usize,
    /// The rule that chose.
    pub rule: &'static str,
    /// Minimum AIC.
    pub best_aic: Orders,
    /// Minimum FPE.
    pub best_fpe: Orders,
    /// Minimum MDL.
    pub best_mdl: Orders,
    /// Minimum validation loss.
    pub best_validation: Option<Orders>,
    /// Maximum validation fit.
    pub best_validation_fit: Option<Orders>,
}

impl Selection {
    fn of(s: &StructSearch, rule: &'static str) -> Self {
        Selection {
            candidates: s.rows.len(),
            rule,
            best_aic: s.best_aic,
            best_fpe: s.best_fpe,
            best_mdl: s.best_mdl,
            best_validation: s.best_validation,
            best_validation_fit: s.best_validation_fit,
        }
    }
}

/// What only some methods report.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct MethodDetails {
    /// ARX with `auto`: the structure selection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub selection: Option<Selection>,
    /// IV, OE: iterations done.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations: Option<usize>,
    /// IV, OE: whether a stopping tolerance was met.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub converged: Option<bool>,
    /// OE: loss of the start estimate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_loss: Option<f64>,
    /// OE: estimated initial conditions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_conditions: Option<Vec<f64>>,
    /// The iterations in words, for the summary.
    #[serde(skip)]
    pub note: Option<String>,
}

/// ARX with `refine_oe`: which model was kept and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefinementDoc {
    /// `arx` or `oe`.
    pub chosen: &'static str,
    /// Why, in words.
    pub reason: String,
    /// Simulation fit of the ARX model, %.
    pub arx_fit_percent: f64,
    /// Simulation fit of the OE model, % (when the iteration ran).
    pub oe_fit_percent: Option<f64>,
}

fn pairs<S: Serializer>(values: &[c64], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(values.iter().map(|z| [z.re, z.im]))
}

/// An identified linear model with its diagnostics: fits on the estimation
/// and validation records, criteria, standard deviations, residual tests,
/// poles and zeros. Serialised, the model's `fts.tf/1` document plus these.
#[derive(Debug, Clone, Serialize)]
pub struct LinearReport {
    /// The model's `fts.tf/1` document (`format`, `var`, `ts`, `num`, `den`, `delay`).
    #[serde(flatten)]
    pub model_doc: serde_json::Value,
    /// `arx`, `oe` or `iv`.
    pub method: &'static str,
    /// The orders.
    pub orders: OrdersDoc,
    /// Simulation fit on the estimation record, %.
    pub fit_percent: f64,
    /// Prediction fit on the estimation record, %.
    pub prediction_fit_percent: f64,
    /// Fits on the estimation record.
    pub estimation: FitsDoc,
    /// Fits and residual tests on the validation record.
    pub validation: Option<ValidationDoc>,
    /// Simulation fit on the validation record, %.
    pub validation_fit_percent: Option<f64>,
    /// Standard deviations of the denominator coefficients after the 1.
    pub std_den: Vec<f64>,
    /// Standard deviations of the numerator coefficients.
    pub std_num: Vec<f64>,
    /// Loss.
    pub loss: f64,
    /// Mean squared error.
    pub mse: f64,
    /// Akaike's final prediction error.
    pub fpe: f64,
    /// AIC.
    pub aic: f64,
    /// Normalised AIC.
    pub naic: f64,
    /// Small-sample corrected AIC (MATLAB `AICc`).
    pub aicc: f64,
    /// Bayesian information criterion (MATLAB `BIC`).
    pub bic: f64,
    /// Rissanen's MDL.
    pub mdl: f64,
    /// Estimated noise variance.
    pub noise_variance: f64,
    /// Condition number of the regression.
    pub condition_number: f64,
    /// Estimation samples.
    pub samples: usize,
    /// The estimation record's time column.
    pub timing: Option<Timing>,
    /// Trend removed.
    pub detrend: Detrend,
    /// Residual tests on the estimation record.
    pub whiteness: Whiteness,
    /// Whether every pole is inside the unit circle.
    pub stable: bool,
    /// Poles, `[re, im]`.
    #[serde(serialize_with = "pairs")]
    pub poles: Vec<c64>,
    /// Zeros, `[re, im]`.
    #[serde(serialize_with = "pairs")]
    pub zeros: Vec<c64>,
    /// Gain at z = 1.
    pub dc_gain: f64,
    /// What the residual tests say about the noise model.
    pub notes: Vec<&'static str>,
    /// Failed model checks (docs/formats.md "Model checks"), printed as
    /// warnings beside the model written.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// `auto`: the chosen structure on an edge of the searched grid, one
    /// sentence per edge (printed as warnings).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub grid_edges: Vec<String>,
    /// Method-specific figures.
    #[serde(flatten)]
    pub details: MethodDetails,
    /// ARX with `refine_oe`: the refinement's outcome.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refinement: Option<RefinementDoc>,
    /// The model.
    #[serde(skip)]
    pub model: PolyModel,
    /// Its transfer function.
    #[serde(skip)]
    pub tf: DiscreteTf,
    /// The records it was identified and validated on.
    #[serde(skip)]
    pub prepared: Prepared,
    #[serde(skip)]
    noise: NoiseModel,
}

impl LinearReport {
    /// The diagnostics of an estimate on its records.
    fn new(p: Prepared, e: Estimate) -> Result<LinearReport, StepError> {
        let tf = e.model.tf().map_err(ident_err(&p.source))?;
        let (model, noise) = (&e.model, e.noise);
        // The residual tests pair each residual with the input of its sample.
        let tested = |u: &[f64], y: &[f64]| {
            let r = fits_and_residuals(model, noise, u, y);
            (r.fits, whiteness(&r.residuals, &u[r.start..], RESID_LAGS))
        };
        let (est_fits, white) = tested(&p.est.u, &p.est.y);
        let val = p.val.as_ref().map(|v| {
            let (fits, white) = tested(&v.u, &v.y);
            (v, fits, white)
        });
        let val_fits = val.as_ref().map(|(_, f, _)| *f);
        let validation = val.map(|(v, f, whiteness)| ValidationDoc {
            fits: (&f).into(),
            data: v.label.clone(),
            whiteness,
        });
        let notes = match (noise, white.white) {
            (_, true) => vec![],
            (NoiseModel::Arx, false) => vec![
                "ARX residuals are not white: the noise is not equation error 1/A e, so the ARX estimate is biased; use `fts identify oe` or `fts identify iv`, or raise the orders",
            ],
            (NoiseModel::OutputError, false) => vec![
                "residuals are not white: the measurement noise is coloured (the B/F estimate stays consistent, its standard deviations are optimistic)",
            ],
        };
        Ok(LinearReport {
            model_doc: tf_json::tf_to_value(&TransferFunction::Discrete(tf.clone())),
            method: e.method,
            orders: e.orders,
            fit_percent: est_fits.simulation_percent,
            prediction_fit_percent: est_fits.prediction_percent,
            estimation: (&est_fits).into(),
            validation,
            validation_fit_percent: val_fits.map(|f| f.simulation_percent),
            std_den: e.std_den,
            std_num: e.std_num,
            loss: e.criteria.loss,
            mse: e.criteria.mse,
            fpe: e.criteria.fpe,
            aic: e.criteria.aic,
            naic: e.criteria.naic,
            aicc: e.criteria.aicc,
            bic: e.criteria.bic,
            mdl: e.criteria.mdl,
            noise_variance: e.noise_variance,
            condition_number: e.condition_number,
            samples: p.est.y.len(),
            timing: p.timing.clone(),
            detrend: p.detrend,
            whiteness: white,
            stable: e.model.is_stable(),
            poles: tf.poles().unwrap_or_default(),
            zeros: tf.zeros().unwrap_or_default(),
            dc_gain: tf.dc_gain(),
            notes,
            warnings: crate::lti::model_check::warnings(&tf),
            grid_edges: Vec::new(),
            details: e.details,
            refinement: None,
            tf,
            model: e.model,
            prepared: p,
            noise,
        })
    }

    /// The model as an `fts.tf/1` transfer function.
    pub fn transfer_function(&self) -> TransferFunction {
        TransferFunction::Discrete(self.tf.clone())
    }
}

fn poly_string(c: &[f64], sd: &[f64], skip_first_sd: bool) -> String {
    let mut out = String::new();
    for (i, v) in c.iter().enumerate() {
        let idx = if skip_first_sd {
            i.checked_sub(1)
        } else {
            Some(i)
        };
        let term = match idx.and_then(|k| sd.get(k)) {
            Some(s) => format!("{:.6} (±{:.2e})", v.abs(), s),
            None => format!("{:.6}", v.abs()),
        };
        if i == 0 {
            if v.is_sign_negative() {
                out.push('-');
            }
        } else {
            out.push_str(if v.is_sign_negative() { " - " } else { " + " });
        }
        out.push_str(&term);
        if i > 0 {
            out.push_str(&format!(" z^-{i}"));
        }
    }
    out
}

fn detrend_name(d: Detrend) -> &'static str {
    match d {
        Detrend::None => "none",
        Detrend::Mean => "mean",
        Detrend::Linear => "linear",
    }
}

fn fits_line(f: &FitsDoc) -> String {
    format!(
        "simulation {:.2} % (zero IC {:.2} %), one-step prediction {:.2} %",
        f.simulation_fit_percent, f.simulation_fit_zero_ic_percent, f.prediction_fit_percent
    )
}

impl fmt::Display for LinearReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.prepared;
        writeln!(
            f,
            "{} {} from {} ({} samples, Ts = {} s, detrend {})",
            self.method.to_uppercase(),
            self.orders,
            p.est.label,
            self.samples,
            p.ts,
            detrend_name(p.detrend)
        )?;
        if let Some(t) = &p.timing {
            writeln!(f, "  {t}")?;
        }
        let den_name = if self.noise == NoiseModel::OutputError {
            "F"
        } else {
            "A"
        };
        let m = &self.model;
        writeln!(
            f,
            "  {den_name}(z^-1) = {}",
            poly_string(&m.a, &self.std_den, true)
        )?;
        writeln!(
            f,
            "  B(z^-1) = {}    (input delay z^-{})",
            poly_string(&m.b, &self.std_num, false),
            m.nk
        )?;
        writeln!(
            f,
            "  loss {:.6e}  FPE {:.6e}  AIC {:.4} (nAIC {:.4}, AICc {:.4})  BIC {:.4}  MDL {:.6e}  cond(Phi) {:.3e}",
            self.loss,
            self.fpe,
            self.aic,
            self.naic,
            self.aicc,
            self.bic,
            self.mdl,
            self.condition_number
        )?;
        if let Some(note) = &self.details.note {
            writeln!(f, "  {note}")?;
        }
        if let Some(r) = &self.refinement {
            writeln!(f, "  output-error refinement: {}", r.reason)?;
        }
        writeln!(
            f,
            "  fit on estimation data: {}",
            fits_line(&self.estimation)
        )?;
        if let Some(v) = &self.validation {
            writeln!(
                f,
                "  fit on validation data ({}): {}",
                v.data,
                fits_line(&v.fits)
            )?;
        }
        let w = &self.whiteness;
        writeln!(
            f,
            "  residuals: {} (max |r_ee| {:.3}, 99 % bound {:.3}, lags 1..{}); {} of input (max |r_eu| {:.3}, bound {:.3})",
            if w.white { "white" } else { "NOT white" },
            w.max_autocorr,
            w.bound,
            w.lags,
            if w.independent {
                "independent"
            } else {
                "NOT independent"
            },
            w.max_crosscorr,
            w.cross_bound
        )?;
        for n in &self.notes {
            writeln!(f, "  note: {n}")?;
        }
        writeln!(
            f,
            "  poles ({}): {}",
            if self.stable { "stable" } else { "UNSTABLE" },
            self.poles
                .iter()
                .map(|z| fmt_complex(*z))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
        writeln!(f, "  DC gain {:.6}", self.dc_gain)?;
        for w in &self.warnings {
            writeln!(f, "  warning: {w}")?;
        }
        Ok(())
    }
}

/// A structure candidate that could not be estimated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    /// Its orders.
    pub orders: Orders,
    /// Why (singular, too short).
    pub reason: String,
}

/// The structure table, the recommended structure and its model.
#[derive(Debug, Clone, Serialize)]
pub struct StructReport {
    /// The recommended model's `fts.tf/1` document.
    #[serde(rename = "model")]
    pub model_doc: serde_json::Value,
    /// The recommended orders.
    pub recommended: Orders,
    /// The rule that recommended them.
    pub rule: &'static str,
    /// Minimum validation loss.
    pub best_validation: Option<Orders>,
    /// Maximum validation fit.
    pub best_validation_fit: Option<Orders>,
    /// Minimum AIC.
    pub best_aic: Orders,
    /// Minimum FPE.
    pub best_fpe: Orders,
    /// Minimum MDL.
    pub best_mdl: Orders,
    /// Delay estimate (ARX `[2 2 nk]` over the nk range), samples.
    pub delay_estimate: Option<usize>,
    /// Loss of each delay tried.
    pub delay_losses: Option<Vec<(usize, f64)>>,
    /// Simulation fit of the recommended model on the validation record, %.
    pub validation_fit_percent: Option<f64>,
    /// Its simulation fit on the estimation record, %.
    pub fit_percent: f64,
    /// Every candidate estimated, in grid order.
    pub rows: Vec<StructRow>,
    /// Candidates skipped.
    pub skipped: Vec<Skipped>,
    /// The recommended structure on an edge of the searched grid, one
    /// sentence per edge (printed as warnings).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub grid_edges: Vec<String>,
    /// The recommended model.
    #[serde(skip)]
    pub tf: DiscreteTf,
    #[serde(skip)]
    nk_range: (usize, usize),
    #[serde(skip)]
    top: usize,
    #[serde(skip)]
    prepared: Prepared,
}

impl StructReport {
    /// The recommended model as an `fts.tf/1` transfer function.
    pub fn transfer_function(&self) -> TransferFunction {
        TransferFunction::Discrete(self.tf.clone())
    }

    /// Row indices, best first by the rule.
    fn ranked(&self) -> Vec<usize> {
        let key = |i: usize| {
            let r = &self.rows[i];
            match self.rule {
                "validation_loss" => r.validation_loss.unwrap_or(f64::INFINITY),
                "validation_fit" => -r.validation_fit_percent.unwrap_or(f64::NEG_INFINITY),
                "aic" => r.criteria.naic,
                "fpe" => r.criteria.fpe,
                _ => r.criteria.mdl,
            }
        };
        let mut order: Vec<usize> = (0..self.rows.len()).collect();
        order.sort_by(|&x, &y| key(x).total_cmp(&key(y)));
        order
    }
}

impl fmt::Display for StructReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.prepared;
        writeln!(
            f,
            "ARX structure selection on {} ({} samples, Ts = {} s), {} candidates{}",
            p.est.label,
            p.est.y.len(),
            p.ts,
            self.rows.len(),
            match &p.val {
                Some(v) => format!(", validated on {}", v.label),
                None => ", no validation data (criteria on estimation data)".into(),
            }
        )?;
        let (nk_lo, nk_hi) = self.nk_range;
        if let Some(nk) = self.delay_estimate {
            writeln!(
                f,
                "  delay estimate (ARX [2 2 nk], nk in {nk_lo}..{nk_hi}): {nk} samples"
            )?;
        }
        writeln!(
            f,
            "  {:>3} {:>3} {:>3} {:>13} {:>13} {:>13} {:>10} {:>13} {:>9}",
            "na", "nb", "nk", "loss(est)", "FPE", "MDL", "nAIC", "loss(val)", "fit(val)%"
        )?;
        for &i in self.ranked().iter().take(self.top) {
            let r = &self.rows[i];
            writeln!(
                f,
                "  {:>3} {:>3} {:>3} {:>13.6e} {:>13.6e} {:>13.6e} {:>10.4} {:>13} {:>9}",
                r.orders.na,
                r.orders.nb,
                r.orders.nk,
                r.criteria.loss,
                r.criteria.fpe,
                r.criteria.mdl,
                r.criteria.naic,
                r.validation_loss
                    .map(|v| format!("{v:.6e}"))
                    .unwrap_or_else(|| "-".into()),
                r.validation_fit_percent
                    .map(|v| format!("{v:.2}"))
                    .unwrap_or_else(|| "-".into()),
            )?;
        }
        writeln!(
            f,
            "  best: AIC {}  FPE {}  MDL {}{}",
            self.best_aic,
            self.best_fpe,
            self.best_mdl,
            match (self.best_validation, self.best_validation_fit) {
                (Some(l), Some(v)) => format!("  validation loss {l}  validation fit {v}"),
                _ => String::new(),
            }
        )?;
        write!(f, "  recommended ({}) {}", self.rule, self.recommended)?;
        if let Some(v) = self.validation_fit_percent {
            write!(f, ": validation simulation fit {v:.2} %")?;
        }
        writeln!(f)?;
        if !self.skipped.is_empty() {
            writeln!(
                f,
                "  {} candidates skipped (singular or too short)",
                self.skipped.len()
            )?;
        }
        Ok(())
    }
}
