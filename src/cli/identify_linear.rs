//! `fts identify arx|oe|iv|arx-struct DATA ...`: linear models from
//! input/output records (docs/math.md §2).
//!
//! Column options (`--input-col`, `--output-col`, `--time-col`, the layout
//! options) are shared with every record-reading command (`columns.rs`); the
//! result file is `-o/--out FILE`.

use super::columns::ColumnArgs;
use super::common::{bad, complex_pairs, fmt_complex, print_json, write_atomic};
use crate::ident::arx::{ArxParams, Orders, arx, arx_residuals};
use crate::ident::data::{Detrend, detrend, split_point};
use crate::ident::freq::{FreqError, FreqResponse, WelchParams, welch};
use crate::ident::iv::{IvParams, iv};
use crate::ident::linear::{
    Criteria, Fits, IdentError, NoiseModel, PolyModel, Whiteness, fits, whiteness,
};
use crate::ident::oe::{OeParams, OeStart, oe};
use crate::ident::structure::{
    SelectionRule, StructParams, StructSearch, arx_struct_observed, delay_estimate,
};
use crate::io::plot::{Series, stacked_charts_svg};
use crate::io::tf_json;
use crate::io::timeseries::Timing;
use crate::lti::{Bode, TransferFunction};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Lags of the residual tests (MATLAB `resid` default).
const RESID_LAGS: usize = 25;

#[derive(Debug, Subcommand)]
pub enum IdentifyLinear {
    /// ARX model `A y = B u(k-nk) + e` by QR least squares.
    Arx(ArxArgs),
    /// Output-error model `y = B/F u(k-nk) + e` by Levenberg-Marquardt (unbiased under measurement noise).
    Oe(OeArgs),
    /// Instrumental-variable estimate of `B/A` (refined IV; unbiased under measurement noise).
    Iv(IvArgs),
    /// ARX structure selection over ranges of na, nb, nk (AIC, FPE, MDL, validation loss) and delay estimate.
    ArxStruct(StructArgs),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DetrendArg {
    /// Keep the data as they are.
    None,
    /// Remove each signal's mean.
    Mean,
    /// Remove each signal's least-squares line.
    Linear,
}

impl From<DetrendArg> for Detrend {
    fn from(d: DetrendArg) -> Self {
        match d {
            DetrendArg::None => Detrend::None,
            DetrendArg::Mean => Detrend::Mean,
            DetrendArg::Linear => Detrend::Linear,
        }
    }
}

/// Data options shared by every linear identification command.
#[derive(Debug, Args)]
pub struct DataArgs {
    /// Input/output record (CSV or whitespace-separated, e.g. DaISy .dat).
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    #[command(flatten)]
    pub columns: ColumnArgs,
    /// Sample time in seconds (required when the file has no time column).
    #[arg(long, value_name = "SECONDS")]
    pub ts: Option<f64>,
    /// Remove a trend from each data set (estimation and validation separately, as MATLAB's example does).
    #[arg(long, value_enum, default_value_t = DetrendArg::None)]
    pub detrend: DetrendArg,
    /// Validation record (same columns).
    #[arg(long, value_name = "OTHER.csv", conflicts_with = "split")]
    pub validate: Option<PathBuf>,
    /// Use the first FRACTION of the record for estimation, the rest for validation.
    #[arg(long, value_name = "FRACTION")]
    pub split: Option<f64>,
}

/// Output options shared by the model-producing commands.
#[derive(Debug, Args)]
pub struct OutArgs {
    /// Write the model (`fts.tf/1`) here.
    #[arg(short = 'o', long = "out", value_name = "PLANT.json")]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Draw the model's Bode plot against the empirical (Welch) estimate with coherence.
    #[arg(long, value_name = "BODE.svg")]
    pub plot: Option<PathBuf>,
    /// Upper frequency of the plot in Hz (default Nyquist).
    #[arg(long, value_name = "HZ", value_parser = super::common::parse_positive)]
    pub plot_fmax: Option<f64>,
    /// Draw measured vs simulated output (MATLAB `compare`) and the error, on the validation data when given.
    #[arg(long, value_name = "COMPARE.svg")]
    pub plot_compare: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct ArxArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of poles (A coefficients after the leading 1).
    #[arg(long, required_unless_present = "auto")]
    pub na: Option<usize>,
    /// Number of B coefficients.
    #[arg(long, required_unless_present = "auto")]
    pub nb: Option<usize>,
    /// Input delay in samples.
    #[arg(long, required_unless_present = "auto")]
    pub nk: Option<usize>,
    /// Choose na, nb, nk by structure selection (grid 1..10 x 1..10 x 0..10; validation loss when validation data exist, otherwise MDL).
    #[arg(long)]
    pub auto: bool,
    /// Selection rule for --auto.
    #[arg(long, value_enum, default_value_t = RuleArg::Auto, requires = "auto")]
    pub rule: RuleArg,
    #[command(flatten)]
    pub out: OutArgs,
}

#[derive(Debug, Args)]
pub struct OeArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of B coefficients.
    #[arg(long)]
    pub nb: usize,
    /// Number of F coefficients after the leading 1 (poles).
    #[arg(long, visible_alias = "na")]
    pub nf: usize,
    /// Input delay in samples.
    #[arg(long)]
    pub nk: usize,
    /// Start estimate of the iteration.
    #[arg(long, value_enum, default_value_t = StartArg::Best)]
    pub start: StartArg,
    /// Initial conditions of the simulation: estimated with the model (MATLAB default) or zero.
    #[arg(long, value_enum, default_value_t = InitialArg::Estimate)]
    pub initial: InitialArg,
    /// Maximum Levenberg-Marquardt iterations.
    #[arg(long, default_value_t = OeParams::new(Orders::new(1, 1, 1)).max_iterations)]
    pub max_iter: usize,
    #[command(flatten)]
    pub out: OutArgs,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RuleArg {
    /// Validation loss when validation data exist, otherwise MDL.
    Auto,
    /// Minimum one-step prediction loss on the validation data (MATLAB arxstruc/selstruc).
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

impl From<RuleArg> for SelectionRule {
    fn from(r: RuleArg) -> Self {
        match r {
            RuleArg::Auto => SelectionRule::Auto,
            RuleArg::Loss => SelectionRule::ValidationLoss,
            RuleArg::Fit => SelectionRule::ValidationFit,
            RuleArg::Aic => SelectionRule::Aic,
            RuleArg::Fpe => SelectionRule::Fpe,
            RuleArg::Mdl => SelectionRule::Mdl,
        }
    }
}

/// The structure `rule` picks, with the rule's name; a validation rule
/// without validation data is bad usage.
fn pick(s: &StructSearch, rule: RuleArg) -> anyhow::Result<(Orders, &'static str)> {
    let name = match (rule, s.best_validation.is_some()) {
        (RuleArg::Auto, true) | (RuleArg::Loss, _) => "validation_loss",
        (RuleArg::Auto, false) | (RuleArg::Mdl, _) => "mdl",
        (RuleArg::Fit, _) => "validation_fit",
        (RuleArg::Aic, _) => "aic",
        (RuleArg::Fpe, _) => "fpe",
    };
    s.pick(rule.into()).map(|o| (o, name)).ok_or_else(|| {
        bad(format!(
            "--rule {name} needs validation data: give --validate FILE or --split FRACTION"
        ))
    })
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InitialArg {
    /// Estimate the initial state together with B and F.
    Estimate,
    /// Start the simulation from rest.
    Zero,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StartArg {
    /// Whichever of IV and ARX simulates the data better.
    Best,
    /// Refined instrumental variables.
    Iv,
    /// Least-squares ARX.
    Arx,
}

#[derive(Debug, Args)]
pub struct IvArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Number of poles.
    #[arg(long)]
    pub na: usize,
    /// Number of B coefficients.
    #[arg(long)]
    pub nb: usize,
    /// Input delay in samples.
    #[arg(long)]
    pub nk: usize,
    #[command(flatten)]
    pub out: OutArgs,
}

#[derive(Debug, Args)]
pub struct StructArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Range of na: `LO:HI`, a list `1,2,4`, or one value.
    #[arg(long, default_value = "1:10")]
    pub na: String,
    /// Range of nb.
    #[arg(long, default_value = "1:10")]
    pub nb: String,
    /// Range of nk.
    #[arg(long, default_value = "0:10")]
    pub nk: String,
    /// Rows of the table to print (best first by the rule).
    #[arg(long, default_value_t = 15)]
    pub top: usize,
    /// Which structure to recommend (and write with -o).
    #[arg(long, value_enum, default_value_t = RuleArg::Auto)]
    pub rule: RuleArg,
    /// Write the recommended model (`fts.tf/1`) here.
    #[arg(short = 'o', long = "out", value_name = "PLANT.json")]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
}

pub fn run(cmd: IdentifyLinear) -> anyhow::Result<()> {
    match cmd {
        IdentifyLinear::Arx(a) => run_arx(a),
        IdentifyLinear::Oe(a) => run_oe(a),
        IdentifyLinear::Iv(a) => run_iv(a),
        IdentifyLinear::ArxStruct(a) => run_struct(a),
    }
}

/// One prepared record.
pub struct Record {
    pub u: Vec<f64>,
    pub y: Vec<f64>,
    pub label: String,
}

/// Estimation and (optional) validation records, detrended, with `ts`.
pub struct Prepared {
    pub est: Record,
    pub val: Option<Record>,
    pub ts: f64,
    /// The estimation record's time column, when it has one.
    pub timing: Option<Timing>,
    pub detrend: Detrend,
    pub source: String,
}

/// The sample time: `--ts` when given (checked against a time column, which
/// may deviate by its jitter tolerance), else the time column's mean step.
fn resolve_ts(timing: Option<&Timing>, arg: Option<f64>, source: &str) -> anyhow::Result<f64> {
    match (timing, arg) {
        (_, Some(ts)) if !(ts.is_finite() && ts > 0.0) => Err(bad(format!(
            "--ts: expected a positive number of seconds, got {ts}"
        ))),
        (Some(t), Some(ts)) if ((t.ts - ts) / ts).abs() > t.tolerance.max(1e-6) => {
            Err(bad(format!(
                "{source}: the time column '{}' gives a sample time of {} s but --ts is {ts} s",
                t.column, t.ts
            )))
        }
        (_, Some(ts)) => Ok(ts),
        (Some(t), None) => Ok(t.ts),
        (None, None) => Err(bad(format!(
            "{source}: no time column, so the sample time is unknown; give --ts SECONDS"
        ))),
    }
}

/// Reads, splits and detrends the data as the options say.
pub fn prepare(d: &DataArgs) -> anyhow::Result<Prepared> {
    let source = d.data.display().to_string();
    let io = d.columns.read(&d.data, 2)?;
    let timing = io.timing.clone();
    let ts = resolve_ts(timing.as_ref(), d.ts, &source)?;
    let how: Detrend = d.detrend.into();
    let (mut est, mut val) = match (&d.validate, d.split) {
        (Some(path), _) => {
            let vsource = path.display().to_string();
            let v = d.columns.read(path, 2)?;
            if let Some(vt) = &v.timing
                && ((vt.ts - ts) / ts).abs() > vt.tolerance.max(1e-6)
            {
                let vts = vt.ts;
                return Err(bad(format!(
                    "{vsource}: sample time {vts} s differs from the estimation data's {ts} s"
                )));
            }
            (
                Record {
                    u: io.input,
                    y: io.output,
                    label: source.clone(),
                },
                Some(Record {
                    u: v.input,
                    y: v.output,
                    label: vsource,
                }),
            )
        }
        (None, Some(f)) => {
            if !(f > 0.0 && f < 1.0) {
                return Err(bad(format!(
                    "--split: expected a fraction strictly between 0 and 1, got {f}"
                )));
            }
            let n = io.input.len();
            let k = split_point(n, f);
            if k < 2 || n - k < 2 {
                return Err(bad(format!(
                    "{source}: --split {f} leaves {k} estimation and {} validation samples",
                    n - k
                )));
            }
            let (ue, uv) = io.input.split_at(k);
            let (ye, yv) = io.output.split_at(k);
            (
                Record {
                    u: ue.to_vec(),
                    y: ye.to_vec(),
                    label: format!("{source} samples 1..{k}"),
                },
                Some(Record {
                    u: uv.to_vec(),
                    y: yv.to_vec(),
                    label: format!("{source} samples {}..{n}", k + 1),
                }),
            )
        }
        (None, None) => (
            Record {
                u: io.input,
                y: io.output,
                label: source.clone(),
            },
            None,
        ),
    };
    for r in std::iter::once(&mut est).chain(val.as_mut()) {
        detrend(&mut r.u, how);
        detrend(&mut r.y, how);
    }
    Ok(Prepared {
        est,
        val,
        ts,
        timing,
        detrend: how,
        source,
    })
}

/// Structure search with a progress bar on stderr (hidden when stderr is
/// not a terminal).
fn search(p: &Prepared, sp: &StructParams) -> anyhow::Result<StructSearch> {
    let bar = indicatif::ProgressBar::new(0);
    bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
    let s = arx_struct_observed(
        &p.est.u,
        &p.est.y,
        p.val.as_ref().map(|v| (&v.u[..], &v.y[..])),
        sp,
        &mut |done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
    )
    .map_err(|e| ident_err(&p.source, e))?;
    bar.finish_and_clear();
    Ok(s)
}

/// Maps identification errors to exit codes: everything about the data or
/// the structure is bad input (2) and names the file.
pub fn ident_err(source: &str, e: IdentError) -> anyhow::Error {
    match e {
        IdentError::Numerical(_) => anyhow::Error::new(e),
        other => bad(format!("{source}: {other}")),
    }
}

/// Everything the summary of one estimate shows.
struct Report {
    method: &'static str,
    orders_label: String,
    orders: Value,
    model: PolyModel,
    std_den: Vec<f64>,
    std_num: Vec<f64>,
    criteria: Criteria,
    noise_variance: f64,
    condition_number: f64,
    noise: NoiseModel,
    extra: Value,
}

fn fits_value(f: &Fits) -> Value {
    json!({
        "simulation_fit_percent": f.simulation_percent,
        "simulation_fit_zero_ic_percent": f.simulation_zero_ic_percent,
        "prediction_fit_percent": f.prediction_percent,
        "prediction_mse": f.prediction_mse,
    })
}

fn residuals(r: &Report, u: &[f64], y: &[f64]) -> Vec<f64> {
    let start = r.model.memory();
    match r.noise {
        NoiseModel::Arx => arx_residuals(&r.model, u, y, start),
        NoiseModel::OutputError => {
            let s = r.model.simulate_fit_ic(u, y);
            y.iter().zip(&s).map(|(a, b)| a - b).collect()
        }
    }
}

fn poly_string(c: &[f64], sd: Option<&[f64]>, first_power: usize, skip_first_sd: bool) -> String {
    let mut out = String::new();
    for (i, v) in c.iter().enumerate() {
        let power = first_power + i;
        let sd_i = sd.and_then(|s| {
            let idx = if skip_first_sd { i.checked_sub(1)? } else { i };
            s.get(idx).copied()
        });
        let term = match sd_i {
            Some(s) => format!("{:.6} (±{:.2e})", v.abs(), s),
            None => format!("{:.6}", v.abs()),
        };
        let sign = if v.is_sign_negative() { "-" } else { "+" };
        if i == 0 {
            if v.is_sign_negative() {
                out.push('-');
            }
        } else {
            out.push_str(&format!(" {sign} "));
        }
        out.push_str(&term);
        if power > 0 {
            out.push_str(&format!(" z^-{power}"));
        }
    }
    out
}

fn welch_for_plot(u: &[f64], y: &[f64], ts: f64) -> Result<FreqResponse, FreqError> {
    welch(u, y, ts, &WelchParams::default())
}

/// Model vs empirical Bode (magnitude, phase) and coherence, stacked.
fn bode_plot_svg(
    title: &str,
    model: Option<&crate::lti::DiscreteTf>,
    emp: &FreqResponse,
    fmax: f64,
) -> anyhow::Result<String> {
    let keep: Vec<usize> = (0..emp.freq_hz.len())
        .filter(|&i| emp.freq_hz[i] <= fmax && emp.response[i].re.is_finite())
        .collect();
    let ef: Vec<f64> = keep.iter().map(|&i| emp.freq_hz[i]).collect();
    let all_phase = emp.phase_deg_unwrapped();
    let ephase: Vec<f64> = keep.iter().map(|&i| all_phase[i]).collect();
    let emag: Vec<f64> = keep
        .iter()
        .map(|&i| 20.0 * emp.response[i].norm().log10())
        .collect();
    let coh: Vec<f64> = match &emp.coherence {
        Some(c) => keep.iter().map(|&i| c[i]).collect(),
        None => Vec::new(),
    };
    let grid = crate::lti::linspace(0.0, fmax, 1001);
    let mb = model.map(|g| Bode::from_fn(&grid, |f| g.response_at_hz(f)));
    let mmag = mb.as_ref().map(|b| b.magnitude_db());
    let mut mag = vec![Series {
        label: "empirical (Welch H1)",
        x: &ef,
        y: &emag,
    }];
    let mut phase = vec![Series {
        label: "empirical (Welch H1)",
        x: &ef,
        y: &ephase,
    }];
    if let (Some(b), Some(m)) = (&mb, &mmag) {
        mag.push(Series {
            label: "model",
            x: &b.freq_hz,
            y: m,
        });
        phase.push(Series {
            label: "model",
            x: &b.freq_hz,
            y: &b.phase_deg,
        });
    }
    let mut panels = vec![
        (title, "frequency (Hz)", "magnitude (dB)", mag),
        ("", "frequency (Hz)", "phase (deg)", phase),
    ];
    if !coh.is_empty() {
        panels.push((
            "",
            "frequency (Hz)",
            "coherence",
            vec![Series {
                label: "coherence |P_yu|^2/(P_uu P_yy)",
                x: &ef,
                y: &coh,
            }],
        ));
    }
    Ok(stacked_charts_svg(&panels)?)
}

fn finish(p: &Prepared, r: Report, out: &OutArgs) -> anyhow::Result<()> {
    let tf = r.model.tf().map_err(|e| ident_err(&p.source, e))?;
    let est_fits = fits(&r.model, r.noise, &p.est.u, &p.est.y);
    let val_fits = p.val.as_ref().map(|v| fits(&r.model, r.noise, &v.u, &v.y));
    let white: Whiteness = whiteness(&residuals(&r, &p.est.u, &p.est.y), &p.est.u, RESID_LAGS);
    let val_white = p
        .val
        .as_ref()
        .map(|v| whiteness(&residuals(&r, &v.u, &v.y), &v.u, RESID_LAGS));
    let stable = r.model.is_stable();
    let poles = tf.poles().unwrap_or_default();
    let zeros = tf.zeros().unwrap_or_default();
    let g = TransferFunction::Discrete(tf.clone());

    if let Some(path) = &out.out {
        write_atomic(path, tf_json::tf_to_string(&g).as_bytes())?;
    }
    if let Some(path) = &out.plot {
        let emp = welch_for_plot(&p.est.u, &p.est.y, p.ts)
            .map_err(|e| bad(format!("{}: --plot: {e}", p.source)))?;
        let fmax = out.plot_fmax.unwrap_or(0.5 / p.ts).min(0.5 / p.ts);
        let svg = bode_plot_svg(
            &format!(
                "{} {} of {}",
                r.method.to_uppercase(),
                r.orders_label,
                p.source
            ),
            Some(&tf),
            &emp,
            fmax,
        )?;
        write_atomic(path, svg.as_bytes())?;
    }

    if let Some(path) = &out.plot_compare {
        let rec = p.val.as_ref().unwrap_or(&p.est);
        let sim = r.model.simulate_fit_ic(&rec.u, &rec.y);
        let t: Vec<f64> = (0..rec.y.len()).map(|k| k as f64 * p.ts).collect();
        let err: Vec<f64> = rec.y.iter().zip(&sim).map(|(a, b)| a - b).collect();
        let fit = crate::ident::metrics::nrmse_fit_percent(&rec.y, &sim);
        let title = format!(
            "{} {}: simulation fit {fit:.2} % on {}",
            r.method.to_uppercase(),
            r.orders_label,
            rec.label
        );
        let svg = stacked_charts_svg(&[
            (
                title.as_str(),
                "time (s)",
                "output",
                vec![
                    Series {
                        label: "measured",
                        x: &t,
                        y: &rec.y,
                    },
                    Series {
                        label: "simulated (initial conditions estimated)",
                        x: &t,
                        y: &sim,
                    },
                ],
            ),
            (
                "",
                "time (s)",
                "measured - simulated",
                vec![Series {
                    label: "simulation error",
                    x: &t,
                    y: &err,
                }],
            ),
        ])?;
        write_atomic(path, svg.as_bytes())?;
    }
    let noise_note = match (r.noise, white.white) {
        (_, true) => None,
        (NoiseModel::Arx, false) => Some(
            "ARX residuals are not white: the noise is not equation error 1/A e, so the ARX estimate is biased; use `fts identify oe` or `fts identify iv`, or raise the orders",
        ),
        (NoiseModel::OutputError, false) => Some(
            "residuals are not white: the measurement noise is coloured (the B/F estimate stays consistent, its standard deviations are optimistic)",
        ),
    };
    if out.json {
        let mut doc = tf_json::tf_to_value(&g);
        let obj = doc.as_object_mut().expect("object");
        obj.insert("method".into(), json!(r.method));
        obj.insert("orders".into(), r.orders.clone());
        obj.insert("fit_percent".into(), json!(est_fits.simulation_percent));
        obj.insert(
            "prediction_fit_percent".into(),
            json!(est_fits.prediction_percent),
        );
        obj.insert("estimation".into(), fits_value(&est_fits));
        obj.insert(
            "validation".into(),
            match (&val_fits, &p.val) {
                (Some(f), Some(v)) => {
                    let mut fv = fits_value(f);
                    fv.as_object_mut()
                        .expect("object")
                        .insert("data".into(), json!(v.label));
                    fv.as_object_mut()
                        .expect("object")
                        .insert("whiteness".into(), serde_json::to_value(&val_white)?);
                    fv
                }
                _ => Value::Null,
            },
        );
        obj.insert(
            "validation_fit_percent".into(),
            json!(val_fits.map(|f| f.simulation_percent)),
        );
        obj.insert("std_den".into(), json!(r.std_den));
        obj.insert("std_num".into(), json!(r.std_num));
        obj.insert("loss".into(), json!(r.criteria.loss));
        obj.insert("mse".into(), json!(r.criteria.mse));
        obj.insert("fpe".into(), json!(r.criteria.fpe));
        obj.insert("aic".into(), json!(r.criteria.aic));
        obj.insert("naic".into(), json!(r.criteria.naic));
        obj.insert("mdl".into(), json!(r.criteria.mdl));
        obj.insert("noise_variance".into(), json!(r.noise_variance));
        obj.insert("condition_number".into(), json!(r.condition_number));
        obj.insert("samples".into(), json!(p.est.y.len()));
        obj.insert("timing".into(), serde_json::to_value(&p.timing)?);
        obj.insert("detrend".into(), json!(p.detrend));
        obj.insert("whiteness".into(), serde_json::to_value(&white)?);
        obj.insert("stable".into(), json!(stable));
        obj.insert("poles".into(), complex_pairs(&poles));
        obj.insert("zeros".into(), complex_pairs(&zeros));
        obj.insert("dc_gain".into(), json!(tf.dc_gain()));
        obj.insert(
            "notes".into(),
            json!(noise_note.into_iter().collect::<Vec<_>>()),
        );
        if let Value::Object(extra) = r.extra {
            // The note is for the human summary; JSON has the raw fields.
            obj.extend(extra.into_iter().filter(|(k, _)| k != "iterations_note"));
        }
        return print_json(&doc);
    }
    say!(
        "{} {} from {} ({} samples, Ts = {} s, detrend {})",
        r.method.to_uppercase(),
        r.orders_label,
        p.est.label,
        p.est.y.len(),
        p.ts,
        match p.detrend {
            Detrend::None => "none",
            Detrend::Mean => "mean",
            Detrend::Linear => "linear",
        }
    );
    if let Some(t) = &p.timing {
        say!("  {t}");
    }
    let den_name = if r.noise == NoiseModel::OutputError {
        "F"
    } else {
        "A"
    };
    say!(
        "  {den_name}(z^-1) = {}",
        poly_string(&r.model.a, Some(&r.std_den), 0, true)
    );
    say!(
        "  B(z^-1) = {}    (input delay z^-{})",
        poly_string(&r.model.b, Some(&r.std_num), 0, false),
        r.model.nk
    );
    say!(
        "  loss {:.6e}  FPE {:.6e}  AIC {:.4} (nAIC {:.4})  MDL {:.6e}  cond(Phi) {:.3e}",
        r.criteria.loss,
        r.criteria.fpe,
        r.criteria.aic,
        r.criteria.naic,
        r.criteria.mdl,
        r.condition_number
    );
    if let Some(Value::String(s)) = r.extra.get("iterations_note") {
        say!("  {s}");
    }
    say!(
        "  fit on estimation data: simulation {:.2} % (zero IC {:.2} %), one-step prediction {:.2} %",
        est_fits.simulation_percent,
        est_fits.simulation_zero_ic_percent,
        est_fits.prediction_percent
    );
    if let (Some(f), Some(v)) = (&val_fits, &p.val) {
        say!(
            "  fit on validation data ({}): simulation {:.2} % (zero IC {:.2} %), one-step prediction {:.2} %",
            v.label,
            f.simulation_percent,
            f.simulation_zero_ic_percent,
            f.prediction_percent
        );
    }
    say!(
        "  residuals: {} (max |r_ee| {:.3}, 99 % bound {:.3}, lags 1..{}); {} of input (max |r_eu| {:.3}, bound {:.3})",
        if white.white { "white" } else { "NOT white" },
        white.max_autocorr,
        white.bound,
        white.lags,
        if white.independent {
            "independent"
        } else {
            "NOT independent"
        },
        white.max_crosscorr,
        white.cross_bound
    );
    if let Some(n) = noise_note {
        say!("  note: {n}");
    }
    say!(
        "  poles ({}): {}",
        if stable { "stable" } else { "UNSTABLE" },
        poles
            .iter()
            .map(|z| fmt_complex(*z))
            .collect::<Vec<_>>()
            .join(", ")
    );
    say!("  DC gain {:.6}", tf.dc_gain());
    if let Some(path) = &out.out {
        say!("wrote {}", path.display());
    }
    for path in out.plot.iter().chain(&out.plot_compare) {
        say!("wrote {}", path.display());
    }
    Ok(())
}

fn orders_json(o: Orders, oe: bool) -> Value {
    if oe {
        json!({"nb": o.nb, "nf": o.na, "nk": o.nk})
    } else {
        json!({"na": o.na, "nb": o.nb, "nk": o.nk})
    }
}

fn run_arx(a: ArxArgs) -> anyhow::Result<()> {
    let p = prepare(&a.data)?;
    let mut extra = json!({});
    let mut start = None;
    let o = if a.auto {
        let sp = StructParams {
            ts: p.ts,
            ..Default::default()
        };
        let s = search(&p, &sp)?;
        let (o, rule) = pick(&s, a.rule)?;
        start = Some(s.start);
        eprintln!(
            "structure selection over {} candidates chose {o} (rule {rule})",
            s.rows.len()
        );
        extra = json!({"selection": {
            "candidates": s.rows.len(),
            "rule": rule,
            "best_aic": s.best_aic, "best_fpe": s.best_fpe, "best_mdl": s.best_mdl,
            "best_validation": s.best_validation,
            "best_validation_fit": s.best_validation_fit,
        }});
        o
    } else {
        // clap guarantees the three orders without --auto.
        Orders::new(a.na.unwrap_or(0), a.nb.unwrap_or(1), a.nk.unwrap_or(0))
    };
    let mut ap = ArxParams::new(o);
    ap.ts = p.ts;
    ap.start = start;
    let est = arx(&p.est.u, &p.est.y, &ap).map_err(|e| ident_err(&p.source, e))?;
    let r = Report {
        method: "arx",
        orders_label: o.to_string(),
        orders: orders_json(o, false),
        model: est.model,
        std_den: est.std_a,
        std_num: est.std_b,
        criteria: est.criteria,
        noise_variance: est.noise_variance,
        condition_number: est.condition_number,
        noise: NoiseModel::Arx,
        extra,
    };
    finish(&p, r, &a.out)
}

fn run_iv(a: IvArgs) -> anyhow::Result<()> {
    let p = prepare(&a.data)?;
    let o = Orders::new(a.na, a.nb, a.nk);
    let mut ip = IvParams::new(o);
    ip.ts = p.ts;
    let est = iv(&p.est.u, &p.est.y, &ip).map_err(|e| ident_err(&p.source, e))?;
    let note = format!(
        "refined IV: {} iterations, {}",
        est.iterations,
        if est.converged {
            "converged"
        } else {
            "NOT converged (iteration cap)"
        }
    );
    let r = Report {
        method: "iv",
        orders_label: o.to_string(),
        orders: orders_json(o, false),
        model: est.model,
        std_den: est.std_a,
        std_num: est.std_b,
        criteria: est.criteria,
        noise_variance: est.noise_variance,
        condition_number: est.condition_number,
        noise: NoiseModel::OutputError,
        extra: json!({"iterations": est.iterations, "converged": est.converged, "iterations_note": note}),
    };
    finish(&p, r, &a.out)
}

fn run_oe(a: OeArgs) -> anyhow::Result<()> {
    let p = prepare(&a.data)?;
    let o = Orders::new(a.nf, a.nb, a.nk);
    let mut op = OeParams::new(o);
    op.ts = p.ts;
    op.max_iterations = a.max_iter;
    op.start = match a.start {
        StartArg::Best => OeStart::Best,
        StartArg::Iv => OeStart::Iv,
        StartArg::Arx => OeStart::Arx,
    };
    op.estimate_initial = a.initial == InitialArg::Estimate;
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
    let est = oe(&p.est.u, &p.est.y, &op, &mut |pr| {
        bar.set_message(format!(
            "OE iteration {}: loss {:.6e}, damping {:.1e}",
            pr.iteration, pr.loss, pr.damping
        ));
        bar.tick();
    })
    .map_err(|e| ident_err(&p.source, e))?;
    bar.finish_and_clear();
    let note = format!(
        "Levenberg-Marquardt: {} iterations, {}, loss {:.6e} -> {:.6e} from the {} start",
        est.iterations,
        if est.converged {
            "converged"
        } else {
            "NOT converged (iteration cap)"
        },
        est.start_loss,
        est.criteria.loss,
        match a.start {
            StartArg::Best => "best of IV/ARX",
            StartArg::Iv => "IV",
            StartArg::Arx => "ARX",
        }
    );
    let r = Report {
        method: "oe",
        orders_label: format!("[nb nf nk] = [{} {} {}]", o.nb, o.na, o.nk),
        orders: orders_json(o, true),
        model: est.model,
        std_den: est.std_f,
        std_num: est.std_b,
        criteria: est.criteria,
        noise_variance: est.noise_variance,
        condition_number: est.condition_number,
        noise: NoiseModel::OutputError,
        extra: json!({"iterations": est.iterations, "converged": est.converged, "start_loss": est.start_loss, "initial_conditions": est.initial_conditions, "iterations_note": note}),
    };
    finish(&p, r, &a.out)
}

/// Parses `LO:HI`, `A,B,C` or `N`.
fn parse_range(text: &str, name: &str) -> anyhow::Result<Vec<usize>> {
    let err = || {
        bad(format!(
            "--{name}: expected LO:HI, a comma list or a number, got {text:?}"
        ))
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

fn run_struct(a: StructArgs) -> anyhow::Result<()> {
    let p = prepare(&a.data)?;
    let sp = StructParams {
        na: parse_range(&a.na, "na")?,
        nb: parse_range(&a.nb, "nb")?,
        nk: parse_range(&a.nk, "nk")?,
        ts: p.ts,
    };
    let s: StructSearch = search(&p, &sp)?;
    let nk_lo = *sp.nk.iter().min().unwrap_or(&0);
    let nk_hi = *sp.nk.iter().max().unwrap_or(&0);
    // One ARX fit per delay from the lowest to the highest: only for a span
    // as short as a LO:HI range may be.
    let delay = (nk_hi - nk_lo <= 200)
        .then(|| delay_estimate(&p.est.u, &p.est.y, 2, 2, nk_lo..=nk_hi).ok())
        .flatten();
    let (best, rule) = pick(&s, a.rule)?;
    let mut ap = ArxParams::new(best);
    ap.ts = p.ts;
    ap.start = Some(s.start);
    let est = arx(&p.est.u, &p.est.y, &ap).map_err(|e| ident_err(&p.source, e))?;
    let g = TransferFunction::Discrete(est.model.tf().map_err(|e| ident_err(&p.source, e))?);
    if let Some(path) = &a.out {
        write_atomic(path, tf_json::tf_to_string(&g).as_bytes())?;
    }
    let val_fit = p
        .val
        .as_ref()
        .map(|v| fits(&est.model, NoiseModel::Arx, &v.u, &v.y).simulation_percent);
    let mut order: Vec<usize> = (0..s.rows.len()).collect();
    let key = |i: usize| {
        let r = &s.rows[i];
        match rule {
            "validation_loss" => r.validation_loss.unwrap_or(f64::INFINITY),
            "validation_fit" => -r.validation_fit_percent.unwrap_or(f64::NEG_INFINITY),
            "aic" => r.criteria.naic,
            "fpe" => r.criteria.fpe,
            _ => r.criteria.mdl,
        }
    };
    order.sort_by(|&x, &y| key(x).total_cmp(&key(y)));
    if a.json {
        let mut doc = json!({
            "recommended": best,
            "rule": rule,
            "best_validation": s.best_validation,
            "best_validation_fit": s.best_validation_fit,
            "best_aic": s.best_aic,
            "best_fpe": s.best_fpe,
            "best_mdl": s.best_mdl,
            "delay_estimate": delay.as_ref().map(|d| d.0),
            "delay_losses": delay.as_ref().map(|d| &d.1),
            "validation_fit_percent": val_fit,
            "fit_percent": fits(&est.model, NoiseModel::Arx, &p.est.u, &p.est.y).simulation_percent,
            "rows": s.rows,
            "skipped": s.skipped.iter().map(|(o, m)| json!({"orders": o, "reason": m})).collect::<Vec<_>>(),
        });
        let obj = doc.as_object_mut().expect("object");
        if let Value::Object(tf) = tf_json::tf_to_value(&g) {
            obj.insert("model".into(), Value::Object(tf));
        }
        return print_json(&doc);
    }
    say!(
        "ARX structure selection on {} ({} samples, Ts = {} s), {} candidates{}",
        p.est.label,
        p.est.y.len(),
        p.ts,
        s.rows.len(),
        match &p.val {
            Some(v) => format!(", validated on {}", v.label),
            None => ", no validation data (criteria on estimation data)".into(),
        }
    );
    if let Some((nk, _)) = &delay {
        say!("  delay estimate (ARX [2 2 nk], nk in {nk_lo}..{nk_hi}): {nk} samples");
    }
    say!(
        "  {:>3} {:>3} {:>3} {:>13} {:>13} {:>13} {:>10} {:>13} {:>9}",
        "na",
        "nb",
        "nk",
        "loss(est)",
        "FPE",
        "MDL",
        "nAIC",
        "loss(val)",
        "fit(val)%"
    );
    for &i in order.iter().take(a.top) {
        let r = &s.rows[i];
        say!(
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
        );
    }
    say!(
        "  best: AIC {}  FPE {}  MDL {}{}",
        s.best_aic,
        s.best_fpe,
        s.best_mdl,
        match (s.best_validation, s.best_validation_fit) {
            (Some(l), Some(f)) => format!("  validation loss {l}  validation fit {f}"),
            _ => String::new(),
        }
    );
    say_part!("  recommended ({rule}) {best}");
    if let Some(f) = val_fit {
        say_part!(": validation simulation fit {f:.2} %");
    }
    say!();
    if !s.skipped.is_empty() {
        say!(
            "  {} candidates skipped (singular or too short)",
            s.skipped.len()
        );
    }
    if let Some(path) = &a.out {
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// Used by `fts bode`: the empirical response of a prepared record.
pub fn empirical_plot(
    path: &Path,
    title: &str,
    emp: &FreqResponse,
    fmax: f64,
) -> anyhow::Result<()> {
    let svg = bode_plot_svg(title, None, emp, fmax)?;
    write_atomic(path, svg.as_bytes())
}
