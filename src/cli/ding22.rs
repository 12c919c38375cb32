//! `fts ding22`: the \[Ding22\] workflow (docs/math.md §5) on the lumped two-mass
//! FTS: H2 design, PID baseline tuned for the same cost, error budget
//! (printed, `--csv`, `--plot`), and `--sweep k2=LO:HI:N,c2=LO:HI:N`.

use super::common::{choice, name, print_report, step_error, write_atomic, write_plot};
use crate::io::ss_json;
use crate::workflow::ding22::SensorChoice;
use crate::workflow::{Ding22Report, Ding22Study, Validate};
use clap::Args;
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
    /// Body the displacement sensor (and the tool) sits on.
    #[arg(long, value_parser = choice::<SensorChoice>(), default_value = name(SensorChoice::default()))]
    sensor: SensorChoice,
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
    #[arg(long, value_name = "budget.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Write freq_hz, psd_*, cas_* of the optimal design to this CSV.
    #[arg(long, value_name = "OUT.csv")]
    csv: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

impl Ding22Args {
    /// The step these flags ask for.
    fn step(&self) -> Ding22Study {
        let d = Ding22Study::default();
        Ding22Study {
            m12: self.m12.unwrap_or(d.m12),
            k2: self.k2.unwrap_or(d.k2),
            c2: self.c2.unwrap_or(d.c2),
            m4: self.m4.unwrap_or(d.m4),
            k4: self.k4.unwrap_or(d.k4),
            c4: self.c4.unwrap_or(d.c4),
            sensor: self.sensor,
            sensor_noise: self.sensor_noise.unwrap_or(d.sensor_noise),
            current_noise: self.current_noise.unwrap_or(d.current_noise),
            base_noise: self.base_noise.unwrap_or(d.base_noise),
            wb_hz: self.wb_hz,
            sweep: self.sweep.clone(),
            fmax: self.fmax,
            points: self.points,
            pid: !self.no_pid,
        }
    }
}

/// Runs the study, with a progress bar on stderr during a sweep.
fn run_study(step: &Ding22Study) -> anyhow::Result<Ding22Report> {
    let bar = step.sweep.is_some().then(|| {
        let bar = indicatif::ProgressBar::new(0);
        bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        bar
    });
    let report = step.run_with_progress(&mut |done, total| {
        if let Some(bar) = &bar {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            if done == total {
                bar.finish_and_clear();
            }
        }
    });
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    report.map_err(step_error)
}

/// `fts ding22`.
pub fn run(args: Ding22Args) -> anyhow::Result<()> {
    let step = args.step();
    step.validate().map_err(step_error)?;
    let report = run_study(&step)?;
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&report.design.h2.k).as_bytes())?;
    }
    if let Some(path) = &args.csv {
        write_atomic(path, report.budget_csv().as_bytes())?;
    }
    if let Some(path) = &args.plot {
        write_plot(path, |f| Ok(report.budget_plot(f)?))?;
    }
    print_report(&report, args.json)
}
