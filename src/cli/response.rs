//! `fts response step|impulse SYS.json [--controller K.json | --kp KP ...]
//! [--duration S] [--points N] [--csv OUT.csv] [--plot OUT.svg] [--json]`:
//! the time response of a system or of its closed loop with a controller,
//! with rise time, settling time, overshoot and steady-state error.

use super::common::{bad, choice, print_report, read_input, step_error, write_atomic, write_plot};
use super::loop_analysis::{PidFlags, pid, read_loop_system};
use crate::io::{plot, ss_json};
use crate::lti::response::ResponseKind;
use crate::lti::ss::StateSpace;
use crate::workflow::Validate;
use crate::workflow::response::{Response, ResponseInputs, ResponseReport};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ResponseArgs {
    /// Step or impulse.
    #[arg(value_parser = choice::<ResponseKind>())]
    kind: ResponseKind,
    /// The system (`fts.tf/1` or `fts.ss/1`, continuous or discrete; MIMO without a controller).
    #[arg(value_name = "SYS.json")]
    system: PathBuf,
    /// A controller K (`fts.tf/1` or `fts.ss/1`): respond as the closed loop G K / (1 + G K), reference to output.
    #[arg(long, value_name = "K.json", conflicts_with_all = ["kp", "ki", "kd", "tf_derivative"])]
    controller: Option<PathBuf>,
    #[command(flatten)]
    pid: PidFlags,
    /// Horizon in seconds (default: until the slowest pole has decayed to 0.1 %).
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
    /// Grid points of a continuous response (default 2001, at most 1e6); a discrete system runs at its sample time.
    #[arg(long, value_name = "N")]
    points: Option<usize>,
    /// Write the samples (t, then one column per output and input) to this CSV.
    #[arg(short = 'o', long = "out", alias = "csv", value_name = "OUT.csv")]
    csv: Option<PathBuf>,
    /// Plot the response (SVG) here.
    #[arg(long, value_name = "OUT.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// The controller as a state-space system, from a file or PID gains.
fn controller(args: &ResponseArgs, ts: Option<f64>) -> anyhow::Result<Option<StateSpace>> {
    let k = match &args.controller {
        Some(path) => read_loop_system(path)?,
        None if args.pid.given() => pid(&args.pid, ts)?.0,
        None if args.pid.tf_derivative.is_some() => {
            return Err(bad("--tf-derivative needs PID gains --kp/--ki/--kd"));
        }
        None => return Ok(None),
    };
    let source = args
        .controller
        .as_ref()
        .map_or("the PID".to_string(), |p| p.display().to_string());
    let k = k.to_ss().map_err(|e| bad(format!("{source}: {e}")))?;
    let same = match (k.ts, ts) {
        (None, None) => true,
        (Some(a), Some(b)) => (a - b).abs() <= 1e-12 * a.abs().max(b.abs()),
        _ => false,
    };
    if !same {
        let says = |t: Option<f64>| {
            t.map_or("continuous".to_string(), |t| {
                format!("discrete (ts = {t} s)")
            })
        };
        return Err(bad(format!(
            "{source}: the controller is {} and the plant {}: a closed loop needs both continuous or both at one sample time",
            says(k.ts),
            says(ts)
        )));
    }
    Ok(Some(k))
}

/// `fts response`.
pub fn run(args: ResponseArgs) -> anyhow::Result<()> {
    let step = Response {
        kind: args.kind,
        duration: args.duration,
        points: args.points,
    };
    step.validate().map_err(step_error)?;
    let source = args.system.display().to_string();
    let g = ss_json::parse_system(&read_input(&args.system)?, &source)?;
    let k = controller(&args, g.ts)?;
    let report = step
        .run(
            ResponseInputs {
                system: &g,
                controller: k.as_ref(),
            },
            &source,
        )
        .map_err(step_error)?;
    // Outputs are staged and committed together when the command succeeds:
    // a failure leaves nothing behind (docs/formats.md "Exit codes").
    if let Some(p) = &args.csv {
        write_atomic(p, csv_text(&report).as_bytes())?;
    }
    if let Some(p) = &args.plot {
        write_plot(p, |format| plot_bytes(&report, &source, format))?;
    }
    for w in &report.warnings {
        let named = crate::workflow::render_settings(w, super::names::option);
        eprintln!("warning: {source}: {named}");
    }
    print_report(&report, args.json)
}

/// Column name of a channel: `y` for SISO, `y{i}_u{j}` (1-based) otherwise.
fn column(report: &ResponseReport, i: usize, j: usize) -> String {
    if report.channels().len() == 1 {
        "y".into()
    } else {
        format!("y{}_u{}", i + 1, j + 1)
    }
}

fn csv_text(report: &ResponseReport) -> String {
    let channels = report.channels();
    let mut out = String::from("t");
    for &(i, j) in &channels {
        out.push(',');
        out.push_str(&column(report, i, j));
    }
    out.push('\n');
    for (k, t) in report.t.iter().enumerate() {
        out.push_str(&t.to_string());
        for &(i, j) in &channels {
            out.push(',');
            out.push_str(&report.y[i][j][k].to_string());
        }
        out.push('\n');
    }
    out
}

fn plot_bytes(
    report: &ResponseReport,
    source: &str,
    format: plot::PlotFormat,
) -> anyhow::Result<Vec<u8>> {
    let t = &report.t;
    let labels: Vec<(String, usize, usize)> = report
        .channels()
        .into_iter()
        .map(|(i, j)| (column(report, i, j), i, j))
        .collect();
    let mut finals: Vec<(String, Vec<f64>)> = Vec::new();
    if let Some(info) = &report.info {
        for (name, i, j) in &labels {
            if let Ok(s) = &info[*i][*j] {
                finals.push((format!("{name} final value"), vec![s.steady_state; t.len()]));
            }
        }
    }
    let mut series: Vec<plot::Series<'_>> = labels
        .iter()
        .map(|(name, i, j)| plot::Series {
            label: name,
            x: t,
            y: &report.y[*i][*j],
        })
        .collect();
    series.extend(finals.iter().map(|(name, y)| plot::Series {
        label: name,
        x: t,
        y,
    }));
    let what = match report.kind {
        ResponseKind::Step => "Step",
        ResponseKind::Impulse => "Impulse",
    };
    let of = if report.closed_loop {
        format!("closed loop of {source}")
    } else {
        source.to_string()
    };
    // A discrete system's output exists only at the samples and is held
    // between them: drawn as a staircase, a continuous one as lines.
    let style = if report.ts.is_some() {
        plot::Style::Stairs
    } else {
        plot::Style::Line
    };
    let title = format!("{what} response, {of}");
    let panel = plot::Panel {
        series: series.into_iter().map(|s| (s, style)).collect(),
        ..plot::Panel::lines(
            &title,
            "time (s)",
            "output (units of the system's output)",
            vec![],
        )
    };
    Ok(plot::render(&[panel], format)?)
}
