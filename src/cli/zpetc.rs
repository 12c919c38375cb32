//! `fts zpetc --tf plant.json [-o zpetc.json] [--json] [--rho R] [--plot bode.svg]`:
//! flags into [`DesignZpetc`], the report rendered.

use super::common::{print_report, read_input, step_error, write_atomic};
use crate::io::{plot, zpetc_json};
use crate::lti::{Bode, logspace};
use crate::workflow::zpetc::DesignZpetc;
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ZpetcArgs {
    /// Closed-loop model `G_c = z^-d B_c/A_c` (`fts.tf/1`, discrete), as `--tf PLANT.json` or the first argument.
    #[arg(
        long = "tf",
        value_name = "PLANT.json",
        required_unless_present = "model"
    )]
    tf: Option<PathBuf>,
    /// The closed-loop model given without `--tf`.
    #[arg(value_name = "PLANT.json", conflicts_with = "tf", hide = true)]
    model: Option<PathBuf>,
    /// Write the filter (`fts.zpetc/1`) here.
    #[arg(short = 'o', long = "out", value_name = "ZPETC.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Zeros with |z| >= RHO are not cancelled (0 < RHO <= 1).
    #[arg(long, value_name = "R", default_value_t = DesignZpetc::default().rho)]
    rho: f64,
    /// Zeros whose equivalent damping ratio is below this are not cancelled (0..1).
    #[arg(long, value_name = "ZETA", default_value_t = DesignZpetc::default().min_damping)]
    min_damping: f64,
    /// Invert zeros with |z| >= RADIUS exactly by an anticausal series (stable
    /// inversion) instead of cancelling only their phase; the preview grows by
    /// the series length. Without it: classical ZPETC (Tomizuka, \[Li21\]).
    #[arg(long, value_name = "RADIUS", num_args = 0..=1, default_missing_value = "1.25")]
    stable_inversion: Option<f64>,
    /// Truncation tolerance of the stable-inversion series (relative).
    #[arg(long, value_name = "TOL", default_value_t = DesignZpetc::default().series_tol, requires = "stable_inversion")]
    series_tol: f64,
    /// Cancel pole/zero pairs of the model closer than TOL (relative) first.
    #[arg(long, value_name = "TOL")]
    minreal: Option<f64>,
    /// Draw |G_c|, |G_z G_c| and their phase to this SVG file.
    #[arg(long, value_name = "BODE.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
}

impl ZpetcArgs {
    fn step(&self) -> DesignZpetc {
        DesignZpetc {
            rho: self.rho,
            min_damping: self.min_damping,
            stable_inversion: self.stable_inversion,
            series_tol: self.series_tol,
            minreal: self.minreal,
        }
    }
}

pub fn run(args: ZpetcArgs) -> anyhow::Result<()> {
    let step = args.step();
    let path = super::common::one_of(&args.tf, &args.model);
    let source = path.display().to_string();
    let text = read_input(path)?;
    let model = super::common::parse_tf(&text, &source)?;
    let report = step.run(&model, &source).map_err(step_error)?;
    if let Some(path) = &args.output {
        write_atomic(path, zpetc_json::zpetc_to_string(&report.filter).as_bytes())?;
    }
    if let Some(path) = &args.plot {
        let nyquist = report.plant.nyquist_hz();
        let grid = logspace(nyquist * 1e-4, nyquist, 1001);
        let g_c = Bode::from_fn(&grid, |f| report.with_filter_at(f).0);
        let product = Bode::from_fn(&grid, |f| report.with_filter_at(f).1);
        let curves = [
            ("G_c (closed loop)", &g_c),
            ("G_z G_c (with ZPETC)", &product),
        ];
        super::common::write_plot(path, |f| {
            Ok(plot::bode(&format!("ZPETC of {source}"), &curves, f)?)
        })?;
    }
    print_report(&report, args.json)?;
    Ok(())
}
