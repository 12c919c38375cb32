//! `fts tf info plant.json [--bode out.csv] [--freq HZ ...] [--json]`

use super::common::{complex_pairs, fmt_complex, print_report, read_input, write_atomic};
use crate::io::tf_json;
use crate::lti::stability::{StabilityTest, Verdict};
use crate::lti::{Bode, TransferFunction, c64, linspace, logspace, model_check};
use clap::{Args, Subcommand};
use serde::Serialize;
use std::path::PathBuf;

#[derive(Debug, Subcommand)]
pub enum TfCommand {
    /// Poles, zeros, DC gain, stability and frequency response of a transfer function.
    Info(InfoArgs),
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The transfer function (`fts.tf/1`).
    #[arg(value_name = "PLANT.json")]
    tf: PathBuf,
    /// Frequencies (Hz, comma-separated or repeated) at which to print the response; default: a few up to Nyquist (discrete) or 1 kHz.
    #[arg(long = "freq", value_name = "HZ", value_delimiter = ',')]
    freq: Vec<f64>,
    /// Write a Bode table (freq_hz, magnitude, magnitude_db, phase_deg, re, im) to this CSV.
    #[arg(short = 'o', long = "out", alias = "bode", value_name = "OUT.csv")]
    bode: Option<PathBuf>,
    /// Points of the Bode table.
    #[arg(long, default_value_t = 1001, value_parser = super::common::parse_points)]
    points: usize,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: TfCommand) -> anyhow::Result<()> {
    match cmd {
        TfCommand::Info(args) => info(args),
    }
}

fn info(args: InfoArgs) -> anyhow::Result<()> {
    let source = args.tf.display().to_string();
    let g = super::common::parse_tf(&read_input(&args.tf)?, &source)?;
    if let Some(f) = args.freq.iter().find(|f| !(f.is_finite() && **f >= 0.0)) {
        return Err(super::common::bad(format!(
            "--freq: expected a non-negative frequency in Hz, got {f}"
        )));
    }
    let report = TfInfo::new(&g, &source, &args.freq)?;
    if let Some(path) = &args.bode {
        write_atomic(path, bode_csv(&g, args.points).as_bytes())?;
    }
    print_report(&report, args.json)?;
    Ok(())
}

/// What `fts tf info` reports: the model's document with its poles,
/// zeros, DC gain, stability and response at a few frequencies.
#[derive(Debug, Serialize)]
struct TfInfo {
    /// The `fts.tf/1` document of the model.
    #[serde(flatten)]
    model: serde_json::Value,
    #[serde(serialize_with = "pairs")]
    poles: Vec<c64>,
    #[serde(serialize_with = "pairs")]
    zeros: Vec<c64>,
    dc_gain: f64,
    stable: bool,
    /// `exact`, `certified` or `computed-roots` (too close to call).
    stability_test: StabilityTest,
    /// Set where the computed poles contradict the exact verdict, or where
    /// neither test on the coefficients could decide.
    #[serde(skip_serializing_if = "Option::is_none")]
    stability_note: Option<String>,
    response: Vec<ResponseAt>,
    /// Model checks that failed (docs/formats.md "Model checks"): near
    /// pole-zero cancellations on the unit circle and trap poles.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    warnings: Vec<String>,
    /// The summary's first line: source, kind, sample time and delay, sizes.
    #[serde(skip)]
    heading: String,
    /// `|z|` or `|s|`.
    #[serde(skip)]
    plane: &'static str,
}

/// The response at one frequency.
#[derive(Debug, Serialize)]
struct ResponseAt {
    freq_hz: f64,
    magnitude: f64,
    phase_deg: f64,
    re: f64,
    im: f64,
}

fn pairs<S: serde::Serializer>(values: &[c64], s: S) -> Result<S::Ok, S::Error> {
    complex_pairs(values).serialize(s)
}

impl TfInfo {
    /// The report on `g` with its response at `freq` (default: a few up to
    /// Nyquist for a discrete model, 1 kHz for a continuous one).
    fn new(g: &TransferFunction, source: &str, freq: &[f64]) -> anyhow::Result<Self> {
        let zeros = g.zeros()?;
        let poles = g.poles()?;
        let verdict = g.stability()?;
        let stable = verdict.stable;
        let (heading, plane, top) = match g {
            TransferFunction::Discrete(d) => (
                format!(
                    "{source}: discrete, ts = {} s, delay {} samples, {} zeros, {} poles",
                    d.ts(),
                    d.delay(),
                    zeros.len(),
                    poles.len()
                ),
                "|z|",
                d.nyquist_hz(),
            ),
            TransferFunction::Continuous(c) => (
                format!(
                    "{source}: continuous, input delay {} s, {} zeros, {} poles",
                    c.delay(),
                    zeros.len(),
                    poles.len()
                ),
                "|s|",
                1000.0,
            ),
        };
        let freqs = if freq.is_empty() {
            // 0 Hz, then fractions of the top frequency up to the top itself.
            let mut f = vec![0.0];
            f.extend([0.02, 0.04, 0.1, 0.2, 0.4, 1.0].iter().map(|r| r * top));
            f
        } else {
            freq.to_vec()
        };
        Ok(Self {
            warnings: match g {
                TransferFunction::Discrete(d) => model_check::warnings(d),
                TransferFunction::Continuous(_) => Vec::new(),
            },
            model: tf_json::tf_to_value(g),
            stability_note: stability_note(g, &poles, verdict),
            stability_test: verdict.test,
            zeros,
            poles,
            dc_gain: g.dc_gain(),
            stable,
            response: freqs.iter().map(|&f| response_at(g, f)).collect(),
            heading,
            plane,
        })
    }
}

/// The verdict is exact or certified on the stored coefficients; a note
/// says so where the computed poles (clustered: accurate to about
/// eps^(1/k)) suggest otherwise, and says when neither test could decide.
fn stability_note(g: &TransferFunction, poles: &[c64], verdict: Verdict) -> Option<String> {
    let word = |s: bool| if s { "stable" } else { "unstable" };
    if verdict.test == StabilityTest::ComputedRoots {
        return Some(format!(
            "too close to call on the stored denominator (a pole on or within its accuracy of the \
             stability boundary): the verdict {} is the computed poles' and may be wrong",
            word(verdict.stable)
        ));
    }
    let by_roots = match g {
        TransferFunction::Discrete(_) => poles.iter().all(|p| p.norm() < 1.0),
        TransferFunction::Continuous(_) => poles.iter().all(|p| p.re < 0.0),
    };
    (verdict.stable != by_roots).then(|| {
        format!(
            "the {} test on the stored denominator says {}, the computed poles below say {}: \
             clustered poles are computed to about eps^(1/k) for a k-fold pole; the {} verdict holds",
            test_name(verdict.test),
            word(verdict.stable),
            word(by_roots),
            test_name(verdict.test),
        )
    })
}

fn test_name(test: StabilityTest) -> &'static str {
    match test {
        StabilityTest::Exact => "exact",
        StabilityTest::Certified => "certified",
        StabilityTest::ComputedRoots => "computed-roots",
    }
}

fn response_at(g: &TransferFunction, freq_hz: f64) -> ResponseAt {
    let v = g.response_at_hz(freq_hz);
    ResponseAt {
        freq_hz,
        magnitude: v.norm(),
        phase_deg: v.arg().to_degrees(),
        re: v.re,
        im: v.im,
    }
}

impl std::fmt::Display for TfInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let plane = self.plane;
        writeln!(f, "{}", self.heading)?;
        writeln!(
            f,
            "poles ({}, {} test):",
            if self.stable { "stable" } else { "UNSTABLE" },
            test_name(self.stability_test)
        )?;
        if let Some(note) = &self.stability_note {
            writeln!(f, "  note: {note}")?;
        }
        for p in &self.poles {
            writeln!(f, "  {:<26} {plane} = {:.6}", fmt_complex(*p), p.norm())?;
        }
        writeln!(f, "zeros:")?;
        for z in &self.zeros {
            writeln!(f, "  {:<26} {plane} = {:.6}", fmt_complex(*z), z.norm())?;
        }
        writeln!(f, "DC gain: {:.6}", self.dc_gain)?;
        for w in &self.warnings {
            writeln!(f, "warning: {w}")?;
        }
        writeln!(f, "frequency response:")?;
        writeln!(
            f,
            "  {:>12} {:>12} {:>10} {:>10}",
            "freq (Hz)", "magnitude", "dB", "phase (deg)"
        )?;
        for r in &self.response {
            writeln!(
                f,
                "  {:>12.3} {:>12.6} {:>10.3} {:>10.2}",
                r.freq_hz,
                r.magnitude,
                20.0 * r.magnitude.log10(),
                r.phase_deg
            )?;
        }
        Ok(())
    }
}

/// The Bode table: `freq_hz, magnitude, magnitude_db, phase_deg, re, im`
/// on `points` frequencies (linear to Nyquist, or log from 0.01 Hz to
/// 100 kHz for a continuous model).
fn bode_csv(g: &TransferFunction, points: usize) -> String {
    let points = points.max(2);
    let grid = match g {
        TransferFunction::Discrete(d) => linspace(0.0, d.nyquist_hz(), points),
        TransferFunction::Continuous(_) => logspace(1e-2, 1e5, points),
    };
    let bode = Bode::from_fn(&grid, |f| g.response_at_hz(f));
    let mut out = String::from("freq_hz,magnitude,magnitude_db,phase_deg,re,im\n");
    for (i, f) in bode.freq_hz.iter().enumerate() {
        let v = g.response_at_hz(*f);
        out.push_str(&format!(
            "{f},{},{},{},{},{}\n",
            bode.magnitude[i],
            20.0 * bode.magnitude[i].log10(),
            bode.phase_deg[i],
            v.re,
            v.im
        ));
    }
    out
}
