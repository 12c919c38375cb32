//! `fts demo [--out DIR] [--seed N] [--json]`: the \[Li21\] experiment on the
//! embedded virtual FTS, end to end (identification -> compensation -> ZPETC
//! -> verification), with every intermediate file and plot written to DIR and
//! the tracking table printed beside the paper's.

use super::common::{fmt_complex, print_json, write_atomic};
use crate::io::controller_file::{Provenance, sha256_hex, to_c_header};
use crate::io::hysteresis_json::{ModelFile, SignalInfo, model_to_string};
use crate::io::timeseries::{time_column, write_csv};
use crate::io::{plot, tf_json, zpetc_json};
use crate::lti::{Bode, TransferFunction, logspace, model_check};
use crate::sim::experiment::{self, ExperimentParams, LEARNED_STAGES, Progress, build_controller};
use crate::synth::composite::Stages;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for every intermediate file, plot and the coefficient files.
    #[arg(long, default_value = "fts-demo")]
    out: PathBuf,
    /// Noise seed of the virtual FTS.
    #[arg(long, default_value_t = ExperimentParams::default().seed)]
    seed: u64,
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    json: bool,
}

/// \[Li21\] max tracking errors (um) for 5 um sines: (frequency, PID, PID+HC, PID+HC+ZPEC).
// 0.3926 um is the paper's measurement, not an approximation of pi/8.
#[allow(clippy::approx_constant)]
const LI21_TABLE: [(f64, f64, f64, f64); 3] = [
    (10.0, 0.1975, 0.0641, 0.0849),
    (100.0, 1.714, 0.6934, 0.2968),
    (500.0, 6.922, 6.784, 0.3926),
];

fn write(dir: &Path, name: &str, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomic(&dir.join(name), bytes)
}

pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    prepare_out(&args.out)?;
    let params = ExperimentParams {
        seed: args.seed,
        ..ExperimentParams::default()
    };
    let start = std::time::Instant::now();
    let result = run_experiment(&params)?;
    let elapsed = start.elapsed().as_secs_f64();
    // The ZPETC passed its self-check in the experiment, before any file.
    let check = result
        .models
        .zpetc
        .check(&result.models.closed_loop.tf, 2001)?;
    // Every file is made before the first is written.
    let mut files = model_files(&params, &result.models)?;
    files.push(("tracking.csv", table_csv(&result).into_bytes()));
    if let (Some(learning), Some(model)) = (&result.learning, &result.models.learning) {
        files.extend(learning_files(&params, model, learning, &files)?);
    }
    for (name, bytes) in &files {
        write(&args.out, name, bytes)?;
    }
    if args.json {
        return print_json(&json_summary(&result, &check, elapsed, &args.out));
    }
    print_models(&args, &params, &result.models, &check, elapsed)?;
    print_table(&params, &result)?;
    Ok(())
}

fn prepare_out(out: &Path) -> anyhow::Result<()> {
    if out.exists() && !out.is_dir() {
        return Err(super::common::bad(format!(
            "--out: {} exists and is not a folder; name a folder for the demo's files",
            out.display()
        )));
    }
    std::fs::create_dir_all(out)
        .map_err(|e| anyhow::anyhow!("{}: cannot create the output folder: {e}", out.display()))
}

/// The experiment, its progress on a spinner (stderr).
fn run_experiment(params: &ExperimentParams) -> anyhow::Result<experiment::ExperimentResult> {
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").expect("valid template"),
    );
    let result = experiment::run(params, &mut |p| match p {
        Progress::Step(s) => bar.set_message(s),
        Progress::Tracking { done, total } => {
            bar.set_message(format!("tracking runs {done}/{total}"))
        }
    })?;
    bar.finish_and_clear();
    Ok(result)
}

type DemoFile = (&'static str, Vec<u8>);

/// The records, models, plots and coefficient files, in the order written.
fn model_files(
    params: &ExperimentParams,
    m: &experiment::IdentifiedModels,
) -> anyhow::Result<Vec<DemoFile>> {
    let ts = params.plant.ts;
    let mut files = hysteresis_files(params, m)?;
    let (r, ys) = &m.sweep;
    files.push((
        "sweep.csv",
        write_csv(&["t", "u", "y"], &[&time_column(r.len(), ts), r, ys]).into_bytes(),
    ));
    files.extend(closed_loop_files(m, ts)?);
    let zpetc_text = zpetc_json::zpetc_to_string(&m.zpetc);
    let inverse_text = &files[1].1;
    let controller = demo_controller(params, m, inverse_text, zpetc_text.as_bytes())?;
    files.push(("zpetc.json", zpetc_text.into_bytes()));
    files.push(("controller.json", controller.to_json_string().into_bytes()));
    files.push(("controller.h", to_c_header(&controller).into_bytes()));
    Ok(files)
}

/// Open-loop record, the inverse model (\[Li21\]: displacement to command)
/// and its loop plot.
fn hysteresis_files(
    params: &ExperimentParams,
    m: &experiment::IdentifiedModels,
) -> anyhow::Result<Vec<DemoFile>> {
    let (u, y) = &m.triangle;
    let triangle = write_csv(
        &["t", "u", "y"],
        &[&time_column(u.len(), params.plant.ts), u, y],
    );
    let inverse_file = ModelFile::identified(
        &m.inverse,
        &params.hysteresis,
        SignalInfo {
            quantity: "displacement".into(),
            unit: "um".into(),
        },
        SignalInfo {
            quantity: "voltage".into(),
            unit: "V".into(),
        },
    );
    let inv_out = m.inverse.model.simulate(y);
    let loop_svg = plot::line_chart_svg(
        "open-loop triangles: command vs displacement, and the inverse model",
        "displacement (um)",
        "command (V)",
        &[
            plot::Series {
                label: "measured",
                x: y,
                y: u,
            },
            plot::Series {
                label: "inverse MPI-cbrt model",
                x: y,
                y: &inv_out,
            },
        ],
    )?;
    Ok(vec![
        ("triangle.csv", triangle.into_bytes()),
        (
            "inverse-hysteresis.json",
            model_to_string(&inverse_file).into_bytes(),
        ),
        ("hysteresis-loop.svg", loop_svg.into_bytes()),
    ])
}

/// The identified closed loop and its Bode plot beside \[Li21\] Eq. 11.
fn closed_loop_files(m: &experiment::IdentifiedModels, ts: f64) -> anyhow::Result<Vec<DemoFile>> {
    let cl = &m.closed_loop;
    let cl_text = tf_json::tf_to_string(&TransferFunction::Discrete(cl.tf.clone()));
    let grid = logspace(1.0, 0.5 / ts, 1000);
    let model_bode = Bode::from_fn(&grid, |f| cl.tf.response_at_hz(f));
    let paper = crate::lti::DiscreteTf::new(
        vec![4.154, -9.631, 10.23, -5.511, 1.154],
        vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
        5,
        ts,
    )?;
    let paper_bode = Bode::from_fn(&grid, |f| paper.response_at_hz(f));
    let bode_svg = plot::bode_svg(
        "closed loop PID + HC: identified model vs [Li21] Eq. 11",
        &[
            ("identified (virtual FTS)", &model_bode),
            ("[Li21] Eq. 11", &paper_bode),
        ],
    )?;
    Ok(vec![
        ("closed-loop.json", cl_text.into_bytes()),
        ("closed-loop-bode.svg", bode_svg.into_bytes()),
    ])
}

/// Step 5's files: the wide-band record and the learning model, the error
/// per trial, and the controller with the five-leaved trajectory's learned
/// feedforward as its table (what a real-time loop plays back).
fn learning_files(
    params: &ExperimentParams,
    model: &experiment::LearningModel,
    learning: &experiment::LearningResult,
    files: &[DemoFile],
) -> anyhow::Result<Vec<DemoFile>> {
    let (r, y) = &model.sweep;
    let record = write_csv(
        &["t", "u", "y"],
        &[&time_column(r.len(), params.plant.ts), r, y],
    );
    let tf = TransferFunction::Discrete(model.model.tf.clone());
    let mut out = vec![
        ("learning-sweep.csv", record.into_bytes()),
        (
            "learning-model.json",
            tf_json::tf_to_string(&tf).into_bytes(),
        ),
        ("ilc.svg", ilc_svg(learning)?.into_bytes()),
    ];
    let controller = files.iter().find(|(name, _)| *name == "controller.json");
    let five_leaf = learning
        .references
        .iter()
        .find(|r| r.reference.starts_with("five-leaf"));
    if let (Some((_, bytes)), Some(learned)) = (controller, five_leaf) {
        let file = crate::io::controller_file::parse_controller(
            std::str::from_utf8(bytes)?,
            "controller.json",
        )?
        .with_feedforward(&learned.feedforward);
        out.push((
            "controller-ilc-five-leaf.json",
            file.to_json_string().into_bytes(),
        ));
    }
    Ok(out)
}

/// Max error per trial for every reference, log scale.
fn ilc_svg(learning: &experiment::LearningResult) -> anyhow::Result<String> {
    let trials: Vec<f64> = (0..=learning.trials_run()).map(|t| t as f64).collect();
    let errors: Vec<Vec<f64>> = learning
        .references
        .iter()
        .map(|r| r.trials.iter().map(|m| m.max_error_percent).collect())
        .collect();
    let series = learning
        .references
        .iter()
        .zip(&errors)
        .map(|(r, e)| plot::Series {
            label: &r.reference,
            x: &trials,
            y: e,
        })
        .collect();
    Ok(plot::panels_svg(&[plot::Panel {
        log_y: true,
        ..plot::Panel::lines(
            "iterative learning control on PID + HC + ZPEC: max error per trial",
            "trial (0: no learning)",
            "max |e|, % of the amplitude",
            series,
        )
    }])?)
}

/// The coefficient file, with the hashes of the files it was made from.
fn demo_controller(
    params: &ExperimentParams,
    m: &experiment::IdentifiedModels,
    inverse_text: &[u8],
    zpetc_text: &[u8],
) -> anyhow::Result<crate::io::controller_file::ControllerFile> {
    let hash = |role: &str, file: &str, bytes: &[u8]| crate::io::controller_file::InputHash {
        role: role.into(),
        file: file.into(),
        sha256: sha256_hex(bytes),
    };
    build_controller(
        Stages::parse("pid+hc+zpec").expect("valid"),
        params.plant.ts,
        params.pid,
        Some(&m.inverse.model),
        Some(&m.zpetc),
        Provenance {
            fts_version: env!("CARGO_PKG_VERSION").into(),
            inputs: vec![
                hash(
                    "hysteresis_inverse",
                    "inverse-hysteresis.json",
                    inverse_text,
                ),
                hash("zpetc", "zpetc.json", zpetc_text),
            ],
        },
    )
    .map_err(|e| anyhow::anyhow!("controller: {e}"))
}

/// The tracking table as CSV.
fn table_csv(result: &experiment::ExperimentResult) -> String {
    let mut table_csv = String::from(
        "reference,controller,max_abs_error_um,rms_error_um,max_error_percent,saturated_samples\n",
    );
    for row in &result.table {
        table_csv.push_str(&format!(
            "{},{},{},{},{},{}\n",
            row.reference,
            row.controller,
            row.metrics.max_abs_error,
            row.metrics.rms_error,
            row.metrics.max_error_percent,
            row.metrics.saturated_samples
        ));
    }
    table_csv
}

fn json_summary(
    result: &experiment::ExperimentResult,
    check: &crate::synth::zpetc::ZpetcCheck,
    elapsed: f64,
    dir: &Path,
) -> serde_json::Value {
    let m = &result.models;
    let (info, cl) = (&m.inverse.info, &m.closed_loop);
    json!({
        "seconds": elapsed,
        "inverse_fit": {"rms_percent": info.fit.rms_percent, "max_percent": info.fit.max_percent},
        "closed_loop": {
            "method": cl.method,
            "num": cl.tf.num().coeffs(),
            "den": cl.tf.den().coeffs(),
            "delay": cl.tf.delay(),
            "simulation_fit_percent": cl.arx_fit.simulation_percent,
            "oe_simulation_fit_percent": cl.oe_fit.as_ref().map(|f| f.simulation_percent),
            "reason": cl.reason,
            "trap_poles": model_check::trap_poles(&cl.tf).unwrap_or_default().iter().map(|t| json!({"pole": [t.pole.re, t.pole.im], "freq_hz": t.freq_hz, "gain": t.gain, "median_gain": t.median_gain})).collect::<Vec<_>>(),
            "removed_pole_zero_pairs": cl.removed_pairs.iter().map(|(z, p)| json!({"zero": [z.re, z.im], "pole": [p.re, p.im]})).collect::<Vec<_>>(),
        },
        "zpetc": {
            "preview": m.zpetc.preview,
            "cancelled_zeros": m.zpetc.cancelled_zeros().count(),
            "series_inverted_zeros": m.zpetc.series_inverted_zeros().count(),
            "uncancelled_zeros": m.zpetc.uncancelled_zeros().count(),
            "series_terms": m.zpetc.series_terms,
            "max_phase_error_rad": check.max_phase_error_rad,
            "dc_gain": check.dc_gain,
        },
        "table": result.table.iter().map(|r| json!({
            "reference": r.reference,
            "controller": r.controller,
            "max_abs_error": r.metrics.max_abs_error,
            "rms_error": r.metrics.rms_error,
            "max_error_percent": r.metrics.max_error_percent,
            "saturated_samples": r.metrics.saturated_samples,
        })).collect::<Vec<_>>(),
        "learning": result.learning.as_ref().map(|l| learning_json(l, result.models.learning.as_ref())),
        "out": dir.display().to_string(),

    })
}

/// Step 5 in the JSON summary.
fn learning_json(
    learning: &experiment::LearningResult,
    model: Option<&experiment::LearningModel>,
) -> serde_json::Value {
    let d = &learning.design;
    json!({
        "model": model.map(|m| json!({
            "method": m.model.method,
            "num": m.model.tf.num().coeffs(),
            "den": m.model.tf.den().coeffs(),
            "delay": m.model.tf.delay(),
            "simulation_fit_percent": m.model.chosen_fit().simulation_percent,
        })),
        "gain": d.gain,
        "q_cutoff_hz": d.q_cutoff_hz,
        "rho": d.rho,
        "rho_at_hz": d.rho_at_hz,
        "tolerated_model_error": d.tolerated_model_error,
        "prediction": learning.prediction,
        "references": learning.references.iter().map(|r| json!({
            "reference": r.reference,
            "max_abs_error": r.trials.iter().map(|m| m.max_abs_error).collect::<Vec<_>>(),
            "max_error_percent": r.trials.iter().map(|m| m.max_error_percent).collect::<Vec<_>>(),
            "rms_error": r.trials.iter().map(|m| m.rms_error).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

fn print_models(
    args: &DemoArgs,
    params: &ExperimentParams,
    m: &experiment::IdentifiedModels,
    check: &crate::synth::zpetc::ZpetcCheck,
    elapsed: f64,
) -> anyhow::Result<()> {
    let (info, cl) = (&m.inverse.info, &m.closed_loop);
    say!(
        "Li21 experiment on the embedded virtual FTS (seed {}), {:.2} s",
        args.seed,
        elapsed
    );
    say!(
        "1. inverse MPI-cbrt ({} lower plays) identified from open-loop triangles: fit rms {:.2} %, max {:.2} % (Li21: 2.3 %), condition number {:.3e}",
        m.inverse.model.thresholds.len(),
        info.fit.rms_percent,
        info.fit.max_percent,
        info.condition_number
    );
    say!(
        "2. closed loop PID + HC from the 0-{} Hz sweep: {} [{} {} {}], simulation fit {:.1} % (ARX){} (Li21: 96.5 %)",
        params.sweep_f1,
        cl.method.to_uppercase(),
        params.orders.na,
        params.orders.nb,
        params.orders.nk,
        cl.arx_fit.simulation_percent,
        cl.oe_fit
            .as_ref()
            .map(|f| format!(", {:.1} % (OE)", f.simulation_percent))
            .unwrap_or_default()
    );
    say!("   {}", cl.reason);
    for trap in model_check::trap_poles(&cl.tf).unwrap_or_default() {
        let wide = m.learning.as_ref().map_or(String::new(), |l| {
            format!(" must use learning-model.json (swept to {} Hz)", l.sweep_f1)
        });
        say!(
            "   note: closed-loop.json holds only to {} Hz: its {trap}, where the sweep had no content; the ZPETC inverts it exactly (a notch of the filter), but a design that needs the loop beyond {} Hz (fts repetitive){}",
            params.sweep_f1,
            params.sweep_f1,
            if wide.is_empty() {
                " needs a wider sweep"
            } else {
                &wide
            }
        );
    }
    if !cl.removed_pairs.is_empty() {
        say!(
            "   near pole-zero cancellations removed before the ZPETC (minreal): {}",
            cl.removed_pairs
                .iter()
                .map(|(z, p)| format!(
                    "zero {} / pole {} ({:.0} Hz)",
                    fmt_complex(*z),
                    fmt_complex(*p),
                    p.arg().abs() / (2.0 * std::f64::consts::PI * cl.tf.ts())
                ))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    say!(
        "3. ZPETC: preview {} samples; of {} zeros {} cancelled, {} inverted by an anticausal series of {} terms, {} left to phase cancellation; self-check max phase {:.1e} rad, DC gain {:.12}",
        m.zpetc.preview,
        m.zpetc.zeros.len(),
        m.zpetc.cancelled_zeros().count(),
        m.zpetc.series_inverted_zeros().count(),
        m.zpetc.series_terms,
        m.zpetc.uncancelled_zeros().count(),
        check.max_phase_error_rad,
        check.dc_gain
    );
    // [Li21] Eq. 8 gives the zeros it cannot cancel phase cancellation
    // only: |G_z G_c| = |B_u|^2/B_u(1)^2, not 1.
    let eq8 = &m.zpetc_eq8;
    let tf = &m.closed_loop.tf;
    let gain = |f: f64| {
        let w = 2.0 * std::f64::consts::PI * f * tf.ts();
        (eq8.response_at_omega(w) * tf.response_at_omega(w)).norm()
    };
    say!(
        "   Li21 Eq. 8 on the same model (the Eq.8 column): {} zeros cancelled, {} left to phase cancellation; |G_z G_c| = {:.4} at 500 Hz, {:.4} at 1000 Hz (1 when inverted exactly)",
        eq8.cancelled_zeros().count(),
        eq8.uncancelled_zeros().count(),
        gain(500.0),
        gain(1000.0)
    );
    Ok(())
}

fn print_table(
    params: &ExperimentParams,
    result: &experiment::ExperimentResult,
) -> anyhow::Result<()> {
    let find = |reference: &str, controller: &str| {
        result
            .table
            .iter()
            .find(|r| r.reference == reference && r.controller == controller)
            .map(|r| r.metrics)
    };
    let ilc_header = result
        .learning
        .as_ref()
        .map(|l| format!(" {:>9}", format!("+ILC({})", l.trials_run())))
        .unwrap_or_default();
    say!(
        "4. max tracking error (um), 5 um sines; fts (virtual FTS) | Li21 (paper); ZPEC: fts's exact inversion, Eq.8: Li21's filter (phase cancellation of the zeros it cannot cancel) on the same model:"
    );
    say!(
        "   {:>8} | {:>8} {:>8} {:>11} {:>8}{} | {:>8} {:>8} {:>11}",
        "freq",
        "PID",
        "PID+HC",
        "PID+HC+ZPEC",
        "Eq.8",
        ilc_header,
        "PID",
        "PID+HC",
        "PID+HC+ZPEC"
    );
    for (f, p_pid, p_hc, p_z) in LI21_TABLE {
        let label = format!("sine {} um at {f} Hz", params.sine_amplitude);
        let get = |c: &str| find(&label, c).map_or(f64::NAN, |m| m.max_abs_error);
        let ilc = result
            .learning
            .as_ref()
            .map(|_| format!(" {:>9.4}", get(LEARNED_STAGES)))
            .unwrap_or_default();
        say!(
            "   {:>6} Hz | {:>8.4} {:>8.4} {:>11.4} {:>8.4}{} | {:>8.4} {:>8.4} {:>11.4}",
            f,
            get("pid"),
            get("pid+hc"),
            get("pid+hc+zpec"),
            get(experiment::EQ8_STAGES),
            ilc,
            p_pid,
            p_hc,
            p_z
        );
    }
    for row in result
        .table
        .iter()
        .filter(|r| !r.reference.starts_with("sine"))
    {
        say!(
            "   {:<26} {:<16} max {:.4} um ({:.2} % of amplitude), rms {:.4} um{}",
            row.reference,
            row.controller,
            row.metrics.max_abs_error,
            row.metrics.max_error_percent,
            row.metrics.rms_error,
            if row.metrics.saturated_samples > 0 {
                format!(
                    ", command saturated on {} samples",
                    row.metrics.saturated_samples
                )
            } else {
                String::new()
            }
        );
    }
    say!(
        "   (Li21: 0-1000 Hz sweep below 10 % over the band; five-leaved trajectory below 0.3 um)"
    );
    if let Some(learning) = &result.learning {
        print_learning(learning, result.models.learning.as_ref())?;
    }
    Ok(())
}

/// Step 5: the law, its convergence check and the error per trial.
fn print_learning(
    learning: &experiment::LearningResult,
    model: Option<&experiment::LearningModel>,
) -> anyhow::Result<()> {
    let d = &learning.design;
    if let Some(m) = model {
        say!(
            "5. learning model: the PID + HC loop swept 0-{} Hz at {} um, {} [{} {} {}], simulation fit {:.1} %",
            m.sweep_f1,
            m.sweep_amplitude,
            m.model.method.to_uppercase(),
            m.orders.na,
            m.orders.nb,
            m.orders.nk,
            m.model.chosen_fit().simulation_percent
        );
    }
    say!(
        "   iterative learning control (+ILC): f <- Q (f + {} L e), Q {:.0} Hz; convergence on the learning model: max |Q| |1 - a L G| = {:.3} at {:.0} Hz (< 1), tolerated model error {:.1} %",
        d.gain,
        d.q_cutoff_hz,
        d.rho,
        d.rho_at_hz,
        100.0 * d.tolerated_model_error
    );
    let p = &learning.prediction;
    say!(
        "   prediction with the learning model's error measured on its own sweep record: max |Q| (|1 - a L G| + a |L G| delta) = {:.3} at {:.0} Hz (< 1); verdict: each trial's error watched (stops past {}x the best)",
        p.rho,
        p.at_hz,
        learning.divergence_factor
    );
    say!("   max error per trial, % of the amplitude (trial 0 without learning):");
    for r in &learning.references {
        let per_trial: Vec<String> = r
            .trials
            .iter()
            .map(|m| format!("{:.2}", m.max_error_percent))
            .collect();
        say!("   {:<26} {}", r.reference, per_trial.join(" "));
    }
    Ok(())
}
