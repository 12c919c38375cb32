//! `fts tf info plant.json [--bode out.csv] [--freq HZ ...] [--json]`

use super::common::{complex_pairs, fmt_complex, print_json, read_input, write_atomic};
use crate::io::tf_json;
use crate::lti::{Bode, TransferFunction, linspace, logspace};
use clap::{Args, Subcommand};
use serde_json::json;
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
    #[arg(long, value_name = "OUT.csv")]
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
    let g = tf_json::parse_tf(&read_input(&args.tf)?, &source)?;
    if let Some(f) = args.freq.iter().find(|f| !(f.is_finite() && **f >= 0.0)) {
        return Err(super::common::bad(format!(
            "--freq: expected a non-negative frequency in Hz, got {f}"
        )));
    }
    let zeros = g.zeros()?;
    let poles = g.poles()?;
    let stable = g.is_stable()?;
    // The verdict is exact on the stored coefficients; say so where the
    // computed poles (clustered: accurate to about eps^(1/k)) suggest
    // otherwise.
    let by_roots = match &g {
        TransferFunction::Discrete(_) => poles.iter().all(|p| p.norm() < 1.0),
        TransferFunction::Continuous(_) => poles.iter().all(|p| p.re < 0.0),
    };
    let disagreement = (stable != by_roots).then(|| {
        format!(
            "the exact test on the stored denominator says {}, the computed poles below say {}: \
             clustered poles are computed to about eps^(1/k) for a k-fold pole; the exact verdict holds",
            if stable { "stable" } else { "unstable" },
            if by_roots { "stable" } else { "unstable" }
        )
    });
    let (kind, top) = match &g {
        TransferFunction::Discrete(d) => ("discrete", d.nyquist_hz()),
        TransferFunction::Continuous(_) => ("continuous", 1000.0),
    };
    let freqs = if args.freq.is_empty() {
        // 0 Hz, then fractions of the top frequency up to the top itself
        // (Nyquist for a discrete model, 1 kHz for a continuous one).
        let mut f = vec![0.0];
        f.extend([0.02, 0.04, 0.1, 0.2, 0.4, 1.0].iter().map(|r| r * top));
        f
    } else {
        args.freq.clone()
    };
    let points = args.points.max(2);
    let grid = match &g {
        TransferFunction::Discrete(d) => linspace(0.0, d.nyquist_hz(), points),
        TransferFunction::Continuous(_) => logspace(1e-2, 1e5, points),
    };
    let bode = Bode::from_fn(&grid, |f| g.response_at_hz(f));
    if let Some(path) = &args.bode {
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
        write_atomic(path, out.as_bytes())?;
    }
    let responses: Vec<_> = freqs.iter().map(|&f| (f, g.response_at_hz(f))).collect();
    if args.json {
        let mut doc = tf_json::tf_to_value(&g);
        let obj = doc.as_object_mut().expect("object");
        obj.insert("poles".into(), complex_pairs(&poles));
        obj.insert("zeros".into(), complex_pairs(&zeros));
        obj.insert("dc_gain".into(), json!(g.dc_gain()));
        obj.insert("stable".into(), json!(stable));
        if let Some(note) = &disagreement {
            obj.insert("stability_note".into(), json!(note));
        }
        obj.insert(
            "response".into(),
            serde_json::Value::Array(
                responses
                    .iter()
                    .map(|(f, v)| json!({"freq_hz": f, "magnitude": v.norm(), "phase_deg": v.arg().to_degrees(), "re": v.re, "im": v.im}))
                    .collect(),
            ),
        );
        return print_json(&doc);
    }
    match &g {
        TransferFunction::Discrete(d) => say!(
            "{source}: discrete, ts = {} s, delay {} samples, {} zeros, {} poles",
            d.ts(),
            d.delay(),
            zeros.len(),
            poles.len()
        ),
        TransferFunction::Continuous(_) => {
            say!(
                "{source}: {kind}, {} zeros, {} poles",
                zeros.len(),
                poles.len()
            )
        }
    }
    let plane = if kind == "discrete" { "|z|" } else { "|s|" };
    say!("poles ({}):", if stable { "stable" } else { "UNSTABLE" });
    if let Some(note) = &disagreement {
        say!("  note: {note}");
    }
    for p in &poles {
        say!("  {:<26} {plane} = {:.6}", fmt_complex(*p), p.norm());
    }
    say!("zeros:");
    for z in &zeros {
        say!("  {:<26} {plane} = {:.6}", fmt_complex(*z), z.norm());
    }
    say!("DC gain: {:.6}", g.dc_gain());
    say!("frequency response:");
    say!(
        "  {:>12} {:>12} {:>10} {:>10}",
        "freq (Hz)",
        "magnitude",
        "dB",
        "phase (deg)"
    );
    for (f, v) in responses {
        say!(
            "  {f:>12.3} {:>12.6} {:>10.3} {:>10.2}",
            v.norm(),
            20.0 * v.norm().log10(),
            v.arg().to_degrees()
        );
    }
    if let Some(path) = &args.bode {
        say!("wrote {}", path.display());
    }
    Ok(())
}
