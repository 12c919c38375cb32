//! `fts ding22`: the [Ding22] workflow (docs/math.md §5) on the lumped two-mass
//! FTS: H2 design, PID baseline tuned for the same cost, error budget
//! (printed, `--csv`, `--plot`), and `--sweep k2=LO:HI:N,c2=LO:HI:N`.

use super::common::{bad, print_json, write_atomic};
use crate::io::plot::{Series, line_chart_svg_log_x};
use crate::io::ss_json;
use crate::lti::logspace;
use crate::synth::budget::ErrorBudget;
use crate::synth::ding22::{
    Design, Ding22Error, Ding22Problem, Ding22Weights, Evaluation, PidBaseline, SOURCES, Sweep,
    TwoMassParams, budget, design, sweep, tune_pid,
};
use crate::synth::genplant::SynthError;
use clap::Args;
use serde_json::{Value, json};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct Ding22Args {
    /// m1 + m2 (kg) [Ding22 Table 1: 0.074].
    #[arg(long, allow_hyphen_values = true)]
    m12: Option<f64>,
    /// Flexure stiffness k2 (N/m) [21965].
    #[arg(long, allow_hyphen_values = true)]
    k2: Option<f64>,
    /// Flexure damping c2 (N s/m) [2.28].
    #[arg(long, allow_hyphen_values = true)]
    c2: Option<f64>,
    /// Tool mass m4 (kg) [0.008].
    #[arg(long, allow_hyphen_values = true)]
    m4: Option<f64>,
    /// Tool interface stiffness k4 (N/m) [56285].
    #[arg(long, allow_hyphen_values = true)]
    k4: Option<f64>,
    /// Tool interface damping c4 (N s/m) [6.18].
    #[arg(long, allow_hyphen_values = true)]
    c4: Option<f64>,
    /// Gain of W1, the sensor noise (m) [1.36e-6].
    #[arg(long, allow_hyphen_values = true)]
    sensor_noise: Option<f64>,
    /// Gain of W2, the current-loop force noise (N) [1.64e-7].
    #[arg(long, allow_hyphen_values = true)]
    current_noise: Option<f64>,
    /// Gain of W3, the base vibration (m) [2.83e-9].
    #[arg(long, allow_hyphen_values = true)]
    base_noise: Option<f64>,
    /// w_b of W_e in Hz [1100].
    #[arg(long, value_name = "HZ", allow_hyphen_values = true)]
    wb_hz: Option<f64>,
    /// Re-synthesise over a log-spaced grid: `k2=LO:HI:N,c2=LO:HI:N`
    /// (either part may be left out: that parameter stays fixed).
    #[arg(long, value_name = "SPEC")]
    sweep: Option<String>,
    /// Highest frequency of the budget (Hz).
    #[arg(long, value_name = "HZ", default_value_t = 1e5)]
    fmax: f64,
    /// Log-spaced points of the budget grid (extra points are added around lightly damped poles).
    #[arg(long, default_value_t = 3000, value_parser = super::common::parse_points)]
    points: usize,
    /// Skip the PID baseline.
    #[arg(long)]
    no_pid: bool,
    /// Write the H2 controller (`fts.ss/1`, u = K y) here.
    #[arg(short = 'o', long = "out", value_name = "K.json")]
    output: Option<PathBuf>,
    /// Write an SVG of the cumulative amplitude spectra (per source and total).
    #[arg(long, value_name = "budget.svg")]
    plot: Option<PathBuf>,
    /// Write freq_hz, psd_*, cas_* of the optimal design to this CSV.
    #[arg(long, value_name = "OUT.csv")]
    csv: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// The swept `k2` and `c2` values (`None`: not swept).
pub type SweepAxes = (Option<Vec<f64>>, Option<Vec<f64>>);

/// Parses `k2=LO:HI:N,c2=LO:HI:N` into log-spaced axes.
pub fn parse_sweep(spec: &str) -> anyhow::Result<SweepAxes> {
    let mut k2 = None;
    let mut c2 = None;
    let usage = "expected --sweep k2=LO:HI:N,c2=LO:HI:N (log-spaced, 0 < LO <= HI, N >= 1)";
    if spec.trim().is_empty() {
        return Err(bad(format!("--sweep: empty specification; {usage}")));
    }
    for item in spec.split(',') {
        let (name, range) = item
            .split_once('=')
            .ok_or_else(|| bad(format!("--sweep: '{item}' has no '='; {usage}")))?;
        let parts: Vec<&str> = range.split(':').collect();
        if parts.len() != 3 {
            return Err(bad(format!("--sweep: '{item}': {usage}")));
        }
        let lo: f64 = parts[0].trim().parse().map_err(|_| {
            bad(format!(
                "--sweep: '{item}': LO '{}' is not a number",
                parts[0]
            ))
        })?;
        let hi: f64 = parts[1].trim().parse().map_err(|_| {
            bad(format!(
                "--sweep: '{item}': HI '{}' is not a number",
                parts[1]
            ))
        })?;
        let n: usize = parts[2].trim().parse().map_err(|_| {
            bad(format!(
                "--sweep: '{item}': N '{}' is not a positive integer",
                parts[2]
            ))
        })?;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) || n == 0 || n > 1000 {
            return Err(bad(format!(
                "--sweep: '{item}': need 0 < LO <= HI (finite) and 1 <= N <= 1000"
            )));
        }
        if n == 1 && hi != lo {
            return Err(bad(format!("--sweep: '{item}': N = 1 needs LO = HI")));
        }
        let values = if n == 1 {
            vec![lo]
        } else {
            logspace(lo, hi, n)
        };
        let slot = match name.trim() {
            "k2" => &mut k2,
            "c2" => &mut c2,
            other => {
                return Err(bad(format!(
                    "--sweep: unknown parameter '{other}' (k2 and c2 can be swept)"
                )));
            }
        };
        if slot.is_some() {
            return Err(bad(format!("--sweep: '{}' given twice", name.trim())));
        }
        *slot = Some(values);
    }
    Ok((k2, c2))
}

/// `k2 must be ...` as `--k2 must be ...`: a parameter message names its flag.
fn flag_named(message: &str) -> String {
    let name_len = message
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(0);
    if name_len > 0 && message[name_len..].starts_with(" must") {
        format!(
            "--{}{}",
            message[..name_len].replace('_', "-"),
            &message[name_len..]
        )
    } else {
        message.to_owned()
    }
}

fn d22_err(e: Ding22Error) -> anyhow::Error {
    match e {
        Ding22Error::Param(m) => bad(flag_named(&m)),
        Ding22Error::Synth(SynthError::Numerical(m)) | Ding22Error::Numerical(m) => {
            anyhow::anyhow!("ding22: numerical failure: {m}")
        }
        Ding22Error::Synth(other) => bad(format!("ding22: {other}")),
    }
}

fn problem_of(args: &Ding22Args) -> anyhow::Result<Ding22Problem> {
    let d = TwoMassParams::default();
    let mech = TwoMassParams {
        m12: args.m12.unwrap_or(d.m12),
        k2: args.k2.unwrap_or(d.k2),
        c2: args.c2.unwrap_or(d.c2),
        m4: args.m4.unwrap_or(d.m4),
        k4: args.k4.unwrap_or(d.k4),
        c4: args.c4.unwrap_or(d.c4),
    };
    let mut w = Ding22Weights::default();
    if let Some(x) = args.sensor_noise {
        w.sensor_noise = x;
    }
    if let Some(x) = args.current_noise {
        w.current_noise = x;
    }
    if let Some(x) = args.base_noise {
        w.base_noise = x;
    }
    if let Some(x) = args.wb_hz {
        w.wb = 2.0 * std::f64::consts::PI * x;
    }
    Ding22Problem::new(mech, w).map_err(d22_err)
}

const NM: f64 = 1e9;

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

fn eval_text(label: &str, e: &Evaluation) -> String {
    let mut s = format!(
        "{label}: H2 cost {:.6e}, RMS error {:.4} nm, force RMS {:.4e} N, bandwidth {:.1} Hz\n",
        e.cost,
        e.rms * NM,
        e.u_rms,
        e.bandwidth_hz
    );
    for (name, r) in SOURCES.iter().zip(&e.rms_per_source) {
        s.push_str(&format!(
            "    {name:<26} {:>12.4} nm ({:5.1}% of the power)\n",
            r * NM,
            100.0 * r * r / (e.rms * e.rms).max(1e-300)
        ));
    }
    s
}

fn sweep_json(s: &Sweep) -> Value {
    let (i, j) = s.best;
    json!({
        "k2": s.k2, "c2": s.c2, "rms_m": s.rms, "h2_cost": s.cost,
        "best": {"k2": s.k2[i], "c2": s.c2[j], "rms_m": s.rms[i][j], "index": [i, j]},
        "interior": s.interior,
    })
}

fn sweep_text(s: &Sweep) -> String {
    let mut out = String::from("RMS error (nm), rows k2 (N/m), columns c2 (N s/m):\n");
    out.push_str(&format!("{:>12}", "k2 \\ c2"));
    for c in &s.c2 {
        out.push_str(&format!(" {c:>11.4e}"));
    }
    out.push('\n');
    for (i, k) in s.k2.iter().enumerate() {
        out.push_str(&format!("{k:>12.4e}"));
        for (j, r) in s.rms[i].iter().enumerate() {
            let mark = if (i, j) == s.best { "*" } else { " " };
            out.push_str(&format!(" {:>10.4}{mark}", r * NM));
        }
        out.push('\n');
    }
    let (i, j) = s.best;
    out.push_str(&format!(
        "best: k2 = {:.6e} N/m, c2 = {:.6e} N s/m, RMS {:.4} nm ({})\n",
        s.k2[i],
        s.c2[j],
        s.rms[i][j] * NM,
        if s.interior {
            "interior optimum of the grid"
        } else {
            "on the grid edge: the optimum may lie outside the grid"
        }
    ));
    out
}

fn csv_of(b: &ErrorBudget) -> String {
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

fn plot_of(b: &ErrorBudget, pid: Option<&ErrorBudget>) -> anyhow::Result<String> {
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
    Ok(line_chart_svg_log_x(
        "Ding22 error budget: cumulative amplitude spectrum",
        "frequency (Hz)",
        "CAS (nm)",
        &series,
    )?)
}

/// `fts ding22`.
pub fn run(args: Ding22Args) -> anyhow::Result<()> {
    if !(args.fmax.is_finite() && args.fmax > 1e-3) || args.points < 2 {
        return Err(bad(format!(
            "--fmax: must be above 1e-3 Hz, got {}",
            args.fmax
        )));
    }
    let mut problem = problem_of(&args)?;
    let swept = match &args.sweep {
        None => None,
        Some(spec) => {
            let (k2, c2) = parse_sweep(spec)?;
            let k2 = k2.unwrap_or_else(|| vec![problem.mech.k2]);
            let c2 = c2.unwrap_or_else(|| vec![problem.mech.c2]);
            let bar = indicatif::ProgressBar::new((k2.len() * c2.len()) as u64);
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            let started = std::time::Instant::now();
            let s = sweep(&problem, &k2, &c2, &mut |done, _| {
                bar.set_position(done as u64)
            })
            .map_err(d22_err)?;
            bar.finish_and_clear();
            let secs = started.elapsed().as_secs_f64();
            problem = problem.with_flexure(s.k2[s.best.0], s.c2[s.best.1]);
            Some((s, secs))
        }
    };
    let started = std::time::Instant::now();
    let d: Design = design(&problem).map_err(d22_err)?;
    let synth_secs = started.elapsed().as_secs_f64();
    let b = budget(&d.optimal, args.fmax, args.points).map_err(d22_err)?;
    let pid: Option<(PidBaseline, Evaluation)> = if args.no_pid {
        None
    } else {
        Some(tune_pid(&problem).map_err(d22_err)?)
    };
    let pid_budget = match &pid {
        Some((_, e)) => Some(budget(e, args.fmax, args.points).map_err(d22_err)?),
        None => None,
    };
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&d.h2.k).as_bytes())?;
    }
    if let Some(path) = &args.csv {
        write_atomic(path, csv_of(&b).as_bytes())?;
    }
    if let Some(path) = &args.plot {
        write_atomic(path, plot_of(&b, pid_budget.as_ref())?.as_bytes())?;
    }
    let m = problem.mech;
    let wn = m.natural_frequencies();
    if args.json {
        let mut v = json!({
            "mechanics": {"m12": m.m12, "k2": m.k2, "c2": m.c2, "m4": m.m4, "k4": m.k4, "c4": m.c4,
                "natural_frequencies_hz": [wn[0] / (2.0 * std::f64::consts::PI), wn[1] / (2.0 * std::f64::consts::PI)]},
            "sources": SOURCES,
            "h2": {
                "closed_loop_h2_norm": d.h2.h2_norm,
                "stable": d.h2.stable,
                "riccati_residuals": {"x": d.h2.x_residual, "y": d.h2.y_residual},
                "controller_order": d.h2.k.nx(),
                "controller": ss_json::ss_to_value(&d.h2.k),
                "synthesis_seconds": synth_secs,
            },
            "optimal": eval_json(&d.optimal),
            "budget": {"fmax_hz": args.fmax, "grid_points": b.freq_hz.len(),
                "grid_rms_m": b.rms, "grid_rms_per_source_m": b.rms_per_source},
            "pid": pid.as_ref().map(|(p, e)| {
                let mut v = eval_json(e);
                v["gains"] = json!({"kp": p.kp, "ki": p.ki, "kd": p.kd, "tau": p.tau});
                v
            }),
        });
        if let Some((s, secs)) = &swept {
            v["sweep"] = sweep_json(s);
            v["sweep"]["seconds"] = json!(secs);
        }
        return print_json(&v);
    }
    if let Some((s, secs)) = &swept {
        say_part!("{}", sweep_text(s));
        say!(
            "sweep: {} syntheses in {secs:.2} s; the report below is for the best point\n",
            s.k2.len() * s.c2.len()
        );
    }
    say!(
        "two-mass plant: m12 = {} kg, k2 = {} N/m, c2 = {} N s/m, m4 = {} kg, k4 = {} N/m, c4 = {} N s/m",
        m.m12,
        m.k2,
        m.c2,
        m.m4,
        m.k4,
        m.c4
    );
    say!(
        "undamped modes {:.2} Hz and {:.2} Hz",
        wn[0] / (2.0 * std::f64::consts::PI),
        wn[1] / (2.0 * std::f64::consts::PI)
    );
    say!(
        "H2 controller: {} states, closed loop {}, Riccati residual X {:.1e}, Y {:.1e}, {:.1} ms",
        d.h2.k.nx(),
        if d.h2.stable { "stable" } else { "UNSTABLE" },
        d.h2.x_residual,
        d.h2.y_residual,
        synth_secs * 1e3
    );
    say_part!("{}", eval_text("H2 optimal", &d.optimal));
    if let Some((p, e)) = &pid {
        say!(
            "PID baseline (tuned for the same H2 cost): kp {:.4e}, ki {:.4e}, kd {:.4e}, tau {:.4e}",
            p.kp,
            p.ki,
            p.kd,
            p.tau
        );
        say_part!("{}", eval_text("PID", e));
    }
    say!(
        "budget grid: {} points to {} Hz, CAS(fmax) = {:.4} nm (exact RMS {:.4} nm)",
        b.freq_hz.len(),
        args.fmax,
        b.rms * NM,
        d.optimal.rms * NM
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_spec() {
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
}
