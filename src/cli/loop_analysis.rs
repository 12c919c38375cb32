//! `fts loop --plant G.json (--controller K.json | --kp KP [--ki KI] [--kd KD]
//! [--tf-derivative N]) [--points-per-decade N] [--fmin HZ] [--fmax HZ]
//! [--plot FILE.svg] [--json]`: margins, sensitivity peaks, bandwidth and
//! closed-loop poles of the negative-feedback loop `L = G K`.

use super::common::{bad, print_json, read_input};
use crate::io::{plot, ss_json, tf_json};
use crate::lti::margins::{LoopError, LoopParams, LoopSystem, analyze_loop};
use crate::lti::ss::SsError;
use crate::lti::tf::{add_descending, convolve};
use crate::lti::{Bode, ContinuousTf, DiscreteTf, TransferFunction, logspace};
use clap::Args;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A PID controller given by its gains, for the plant's time domain.
#[derive(Debug, Args)]
pub struct PidFlags {
    /// PID proportional gain. Continuous plant: C(s) = kp + ki/s + kd N s/(s+N);
    /// discrete plant: the \[Li21\] per-sample form kp + ki/(1 - z^-1) + kd (1 - z^-1).
    #[arg(long, allow_hyphen_values = true)]
    pub kp: Option<f64>,
    /// PID integral gain (1/s for a continuous plant, per sample for a discrete one).
    #[arg(long, allow_hyphen_values = true)]
    pub ki: Option<f64>,
    /// PID derivative gain (s for a continuous plant, per sample for a discrete one).
    #[arg(long, allow_hyphen_values = true)]
    pub kd: Option<f64>,
    /// Derivative filter pole N in rad/s (continuous plants; needed with --kd).
    #[arg(long, value_name = "N")]
    pub tf_derivative: Option<f64>,
}

impl PidFlags {
    /// Whether any gain was given.
    pub fn given(&self) -> bool {
        self.kp.is_some() || self.ki.is_some() || self.kd.is_some()
    }
}

#[derive(Debug, Args)]
pub struct LoopArgs {
    /// The plant G (`fts.tf/1` or `fts.ss/1`, continuous or discrete, SISO).
    #[arg(long, value_name = "G.json")]
    plant: PathBuf,
    /// The controller K (`fts.tf/1` or `fts.ss/1`, same sample time as G).
    #[arg(long, value_name = "K.json", conflicts_with_all = ["kp", "ki", "kd", "tf_derivative"])]
    controller: Option<PathBuf>,
    #[command(flatten)]
    pid: PidFlags,
    /// Grid density used to bracket crossovers and peaks.
    #[arg(long, default_value_t = LoopParams::default().points_per_decade)]
    points_per_decade: usize,
    /// Lowest frequency analysed, Hz (default: 3 decades below the slowest pole or zero).
    #[arg(long, value_name = "HZ")]
    fmin: Option<f64>,
    /// Highest frequency analysed, Hz (default: 3 decades above the fastest; Nyquist at most).
    #[arg(long, value_name = "HZ")]
    fmax: Option<f64>,
    /// Write a Bode plot of L, S and T and a Nyquist plot of L (SVG) here.
    #[arg(long, value_name = "FILE.svg|png", value_parser = super::common::plot_path)]
    plot: Option<PathBuf>,
    /// Print the report as one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// Reads an `fts.tf/1` file as a transfer function, anything else as `fts.ss/1`.
pub fn read_loop_system(path: &Path) -> anyhow::Result<LoopSystem> {
    let text = read_input(path)?;
    let source = path.display().to_string();
    let is_tf = serde_json::from_str::<Value>(&text)
        .ok()
        .and_then(|v| v.get("format").and_then(|f| f.as_str().map(str::to_owned)))
        .is_some_and(|f| f == tf_json::TF_FORMAT);
    Ok(if is_tf {
        LoopSystem::Tf(super::common::parse_tf(&text, &source)?)
    } else {
        LoopSystem::Ss(ss_json::parse_ss(&text, &source)?)
    })
}

/// The PID controller for the plant's time domain, and a description.
pub fn pid(args: &PidFlags, ts: Option<f64>) -> anyhow::Result<(LoopSystem, String)> {
    let (kp, ki, kd) = (
        args.kp.unwrap_or(0.0),
        args.ki.unwrap_or(0.0),
        args.kd.unwrap_or(0.0),
    );
    for (name, v) in [("--kp", kp), ("--ki", ki), ("--kd", kd)] {
        if !v.is_finite() {
            return Err(bad(format!("{name} must be a finite number, got {v}")));
        }
    }
    if kp == 0.0 && ki == 0.0 && kd == 0.0 {
        return Err(bad("the PID gains are all zero: there is no loop"));
    }
    match ts {
        Some(ts) => {
            if args.tf_derivative.is_some() {
                return Err(bad(
                    "--tf-derivative applies to continuous plants; a discrete plant takes the [Li21] per-sample PID kp + ki/(1 - z^-1) + kd (1 - z^-1)",
                ));
            }
            let (num, den) = if ki != 0.0 {
                (vec![kp + ki + kd, -kp - 2.0 * kd, kd], vec![1.0, -1.0])
            } else {
                (vec![kp + kd, -kd], vec![1.0])
            };
            let k = DiscreteTf::new(num, den, 0, ts).map_err(|e| bad(format!("PID: {e}")))?;
            Ok((
                LoopSystem::Tf(TransferFunction::Discrete(k)),
                format!(
                    "PID [Li21] per-sample form K = {kp} + {ki}/(1 - z^-1) + {kd} (1 - z^-1), ts = {ts} s"
                ),
            ))
        }
        None => {
            let n = match (kd != 0.0, args.tf_derivative) {
                (true, None) => {
                    return Err(bad(
                        "--kd on a continuous plant needs --tf-derivative N (rad/s): a pure derivative is improper",
                    ));
                }
                (_, Some(n)) if !(n.is_finite() && n > 0.0) => {
                    return Err(bad(format!(
                        "--tf-derivative must be a positive number of rad/s, got {n}"
                    )));
                }
                (_, n) => n.unwrap_or(0.0),
            };
            let int_den: &[f64] = if ki != 0.0 { &[1.0, 0.0] } else { &[1.0] };
            let der_den: &[f64] = if kd != 0.0 { &[1.0, n] } else { &[1.0] };
            let den = convolve(int_den, der_den);
            let mut num = convolve(&[kp], &den);
            if ki != 0.0 {
                num = add_descending(&num, &convolve(&[ki], der_den));
            }
            if kd != 0.0 {
                num = add_descending(&num, &convolve(&[kd * n, 0.0], int_den));
            }
            let k = ContinuousTf::new(num, den).map_err(|e| bad(format!("PID: {e}")))?;
            let filter = if kd != 0.0 {
                format!(" + {kd} {n} s/(s + {n})")
            } else {
                String::new()
            };
            Ok((
                LoopSystem::Tf(TransferFunction::Continuous(k)),
                format!("PID parallel form C(s) = {kp} + {ki}/s{filter}"),
            ))
        }
    }
}

/// A library setting's message in terms of the options that set it.
fn loop_setting_message(message: &str) -> String {
    let named = [
        ("f_min", "--fmin"),
        ("f_max", "--fmax"),
        ("points per decade", "--points-per-decade"),
        ("frequency range", "--fmin/--fmax: the frequency range"),
    ];
    match named.iter().find(|(lib, _)| message.contains(lib)) {
        Some((lib, flag)) => message.replacen(lib, flag, 1),
        None => message.to_owned(),
    }
}

/// `fts loop`.
pub fn run(args: LoopArgs) -> anyhow::Result<()> {
    let g = read_loop_system(&args.plant)?;
    let (k, controller) = match &args.controller {
        Some(path) => (read_loop_system(path)?, path.display().to_string()),
        None if args.pid.given() => pid(&args.pid, g.ts())?,
        None => {
            return Err(bad(
                "give the controller: --controller K.json, or PID gains --kp/--ki/--kd",
            ));
        }
    };
    let params = LoopParams {
        points_per_decade: args.points_per_decade,
        f_min_hz: args.fmin,
        f_max_hz: args.fmax,
        ..LoopParams::default()
    };
    let plant = args.plant.display().to_string();
    for (sys, source) in [(&g, &plant), (&k, &controller)] {
        crate::lti::margins::check_realisable(sys).map_err(|e| bad(format!("{source}: {e}")))?;
    }
    let report = analyze_loop(&g, &k, &params).map_err(|e| match e {
        // A failed eigenvalue iteration is a computation failure (exit 1).
        LoopError::Ss(SsError::NoConvergence) => anyhow::Error::new(e),
        // Each message names its culprit: the file, or the option.
        LoopError::NotSiso { which: "plant", .. } => bad(format!("{plant}: {e}")),
        LoopError::NotSiso { .. } => bad(format!("{controller}: {e}")),
        LoopError::SampleTimeMismatch { .. } => bad(format!("{plant} and {controller}: {e}")),
        LoopError::BadParams(m) => bad(loop_setting_message(&m)),
        e => bad(e.to_string()),
    })?;
    if let Some(path) = &args.plot {
        let (f_lo, f_hi) = if args.fmin.is_some() || args.fmax.is_some() {
            (report.diagnostics.f_min_hz, report.diagnostics.f_max_hz)
        } else {
            report.plot_span_hz()
        };
        let grid = logspace(f_lo, f_hi, 1000);
        let l = |f: f64| g.response_at_hz(f) * k.response_at_hz(f);
        let bl = Bode::from_fn(&grid, l);
        let bs = Bode::from_fn(&grid, |f| 1.0 / (1.0 + l(f)));
        let bt = Bode::from_fn(&grid, |f| l(f) / (1.0 + l(f)));
        let curves = [
            ("L = G K", &bl, plot::Style::Line),
            ("S = 1/(1 + L)", &bs, plot::Style::Line),
            ("T = L/(1 + L)", &bt, plot::Style::Line),
        ];
        let mags: Vec<Vec<f64>> = curves.iter().map(|(_, b, _)| b.magnitude_db()).collect();
        let [mag, phase] = plot::bode_panels(
            "Loop L = G K, sensitivity S and complementary sensitivity T",
            &curves,
            &mags,
        );
        let nyquist = nyquist_points(&grid, l);
        let panels = [mag, phase, nyquist.panel()];
        super::common::write_plot(path, |f| Ok(plot::render(&panels, f)?))?;
    }
    if args.json {
        let mut v = serde_json::to_value(&report)?;
        if let Value::Object(m) = &mut v {
            m.insert("plant".into(), args.plant.display().to_string().into());
            m.insert("controller".into(), controller.into());
        }
        print_json(&v)
    } else {
        say!("plant:           {}", args.plant.display());
        say!("controller:      {controller}");
        say_part!("{report}");
        Ok(())
    }
}

/// The Nyquist curve of `L` near the critical point: positive and mirrored
/// negative frequencies, cut where `|L|` exceeds [`NYQUIST_RADIUS`] so that
/// an integrator's large low-frequency values do not hide the region that
/// decides stability.
struct NyquistPoints {
    re: Vec<f64>,
    im: Vec<f64>,
    im_mirror: Vec<f64>,
    circle_re: Vec<f64>,
    circle_im: Vec<f64>,
}

const NYQUIST_RADIUS: f64 = 4.0;

fn nyquist_points(grid: &[f64], l: impl Fn(f64) -> crate::lti::c64) -> NyquistPoints {
    let mut p = NyquistPoints {
        re: Vec::new(),
        im: Vec::new(),
        im_mirror: Vec::new(),
        // The unit circle frames -1 and shows where |L| = 1 (gain crossover).
        circle_re: (0..=128)
            .map(|k| (std::f64::consts::TAU * k as f64 / 128.0).cos())
            .collect(),
        circle_im: (0..=128)
            .map(|k| (std::f64::consts::TAU * k as f64 / 128.0).sin())
            .collect(),
    };
    // Denser than the Bode grid: the curve moves fastest near crossover.
    let fine = logspace(grid[0], grid[grid.len() - 1], 8 * grid.len());
    for f in fine {
        let z = l(f);
        // NaN breaks the curve where it leaves the window.
        let (re, im) = if z.norm() <= NYQUIST_RADIUS {
            (z.re, z.im)
        } else {
            (f64::NAN, f64::NAN)
        };
        p.re.push(re);
        p.im.push(im);
        p.im_mirror.push(-im);
    }
    p
}

impl NyquistPoints {
    fn panel(&self) -> plot::Panel<'_> {
        plot::Panel {
            title: "Nyquist plot of L: |L| > 4 clipped, equal axes; dashed: w < 0",
            x_label: "Re L",
            y_label: "Im L",
            series: vec![
                (
                    plot::Series {
                        label: "L(j w), w > 0",
                        x: &self.re,
                        y: &self.im,
                    },
                    plot::Style::Line,
                ),
                (
                    plot::Series {
                        label: "L(j w), w < 0",
                        x: &self.re,
                        y: &self.im_mirror,
                    },
                    plot::Style::Dashed,
                ),
                (
                    plot::Series {
                        label: "unit circle |L| = 1",
                        x: &self.circle_re,
                        y: &self.circle_im,
                    },
                    plot::Style::Dashed,
                ),
                (
                    plot::Series {
                        label: "critical point -1",
                        x: &CRITICAL_X,
                        y: &CRITICAL_Y,
                    },
                    plot::Style::Marker,
                ),
            ],
            equal_aspect: true,
            ..plot::Panel::default()
        }
    }
}

const CRITICAL_X: [f64; 1] = [-1.0];
const CRITICAL_Y: [f64; 1] = [0.0];

/// Checks of this module's private parts (run by `tests/suite/checks.rs`).
#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn the_mixsyn_loop_plot_spans_its_features_not_fourteen_decades() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mixsyn");
        let g = read_loop_system(&root.join("plant.json")).unwrap();
        let k = read_loop_system(&root.join("K.json")).unwrap();
        let report = analyze_loop(&g, &k, &LoopParams::default()).unwrap();
        let (lo, hi) = report.plot_span_hz();
        let (f_lo, f_hi) = crate::lti::margins::feature_band_hz(&g, &k)
            .unwrap()
            .unwrap();
        // A decade beyond the outermost poles/zeros (or the analysed
        // range's edge), and the 1006.5 Hz gain crossover well inside.
        let d = &report.diagnostics;
        assert!(
            (lo - (f_lo / 10.0).max(d.f_min_hz)).abs() <= 1e-9 * lo,
            "{lo} {f_lo}"
        );
        assert!(
            (hi - (f_hi * 10.0).min(d.f_max_hz)).abs() <= 1e-9 * hi,
            "{hi} {f_hi}"
        );
        assert!(lo < 1006.5 / 3.0 && hi > 1006.5 * 3.0, "[{lo}, {hi}]");
        // Narrower than the analysis's search range (14 decades).
        let decades = (hi / lo).log10();
        let searched = (d.f_max_hz / d.f_min_hz).log10();
        assert!(decades <= (f_hi / f_lo).log10() + 2.0 + 1e-9, "{decades}");
        assert!(decades < searched - 3.0, "{decades} of {searched} decades");
    }
}
