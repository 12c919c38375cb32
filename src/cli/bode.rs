//! `fts bode DATA [--method welch|etfe] [-o response.csv] [--plot bode.svg] [--json]`:
//! the empirical frequency response of an input/output record.

use super::common::{bad, print_json, write_atomic};
use super::identify_linear::{DataArgs, empirical_plot, prepare};
use crate::ident::freq::{WelchParams, etfe, welch};
use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Welch-averaged cross spectra `H1 = P_yu/P_uu` with coherence.
    Welch,
    /// Empirical transfer-function estimate `Y/U` over the whole record.
    Etfe,
}

#[derive(Debug, Args)]
pub struct BodeArgs {
    #[command(flatten)]
    data: DataArgs,
    /// Estimator.
    #[arg(long, value_enum, default_value_t = Method::Welch)]
    method: Method,
    /// Welch segment length in samples (default: power of two near N/8, 64..8192).
    #[arg(long, value_name = "N")]
    segment: Option<usize>,
    /// Welch overlap fraction in [0, 1).
    #[arg(long, default_value_t = 0.5)]
    overlap: f64,
    /// Write the table (freq_hz, magnitude, magnitude_db, phase_deg, coherence, re, im) to this CSV.
    #[arg(short = 'o', long = "out", value_name = "RESPONSE.csv")]
    out: Option<PathBuf>,
    /// Draw magnitude, phase and coherence to this SVG.
    #[arg(long, value_name = "BODE.svg")]
    plot: Option<PathBuf>,
    /// Upper frequency of the printed table and the plot in Hz (default Nyquist).
    #[arg(long, value_name = "HZ", value_parser = super::common::parse_positive)]
    fmax: Option<f64>,
    /// Rows of the printed table.
    #[arg(long, default_value_t = 20)]
    rows: usize,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(a: BodeArgs) -> anyhow::Result<()> {
    if a.data.validate.is_some() || a.data.split.is_some() {
        return Err(bad("fts bode: --validate and --split do not apply"));
    }
    let p = prepare(&a.data)?;
    let h = match a.method {
        Method::Welch => welch(
            &p.est.u,
            &p.est.y,
            p.ts,
            &WelchParams {
                segment: a.segment,
                overlap: a.overlap,
            },
        ),
        Method::Etfe => etfe(&p.est.u, &p.est.y, p.ts),
    }
    .map_err(|e| bad(format!("{}: {e}", p.source)))?;
    let nyq = 0.5 / p.ts;
    let fmax = a.fmax.unwrap_or(nyq).min(nyq);
    let phase = h.phase_deg_unwrapped();
    let coh = |i: usize| h.coherence.as_ref().map(|c| c[i]);
    if let Some(path) = &a.out {
        let mut s = String::from("freq_hz,magnitude,magnitude_db,phase_deg,coherence,re,im\n");
        for (i, f) in h.freq_hz.iter().enumerate() {
            let v = h.response[i];
            s.push_str(&format!(
                "{f},{},{},{},{},{},{}\n",
                v.norm(),
                20.0 * v.norm().log10(),
                phase[i],
                coh(i).map(|c| c.to_string()).unwrap_or_default(),
                v.re,
                v.im
            ));
        }
        write_atomic(path, s.as_bytes())?;
    }
    if let Some(path) = &a.plot {
        empirical_plot(
            path,
            &format!("empirical response of {}", p.source),
            &h,
            fmax,
        )?;
    }
    let idx: Vec<usize> = (0..h.freq_hz.len())
        .filter(|&i| h.freq_hz[i] <= fmax)
        .collect();
    let stride = (idx.len() / a.rows.max(1)).max(1);
    let shown: Vec<usize> = idx.iter().copied().step_by(stride).collect();
    let mean_coh = h.coherence.as_ref().map(|c| {
        let v: Vec<f64> = idx.iter().map(|&i| c[i]).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    });
    if a.json {
        return print_json(&json!({
            "method": match a.method { Method::Welch => "welch", Method::Etfe => "etfe" },
            "ts": p.ts,
            "segments": h.segments,
            "segment_len": h.segment_len,
            "resolution_hz": 1.0 / (h.segment_len as f64 * p.ts),
            "mean_coherence": mean_coh,
            "freq_hz": idx.iter().map(|&i| h.freq_hz[i]).collect::<Vec<_>>(),
            "magnitude": idx.iter().map(|&i| h.response[i].norm()).collect::<Vec<_>>(),
            "phase_deg": idx.iter().map(|&i| phase[i]).collect::<Vec<_>>(),
            "coherence": h.coherence.as_ref().map(|c| idx.iter().map(|&i| c[i]).collect::<Vec<_>>()),
        }));
    }
    say!(
        "{} estimate of {} ({} samples, Ts = {} s): {} segment(s) of {} samples, resolution {:.4} Hz{}",
        match a.method {
            Method::Welch => "Welch",
            Method::Etfe => "ETFE",
        },
        p.source,
        p.est.y.len(),
        p.ts,
        h.segments,
        h.segment_len,
        1.0 / (h.segment_len as f64 * p.ts),
        mean_coh
            .map(|c| format!(", mean coherence {c:.3}"))
            .unwrap_or_default()
    );
    say!(
        "  {:>12} {:>12} {:>10} {:>11} {:>9}",
        "freq (Hz)",
        "magnitude",
        "dB",
        "phase (deg)",
        "coherence"
    );
    for i in shown {
        let v = h.response[i];
        say!(
            "  {:>12.4} {:>12.6} {:>10.3} {:>11.2} {:>9}",
            h.freq_hz[i],
            v.norm(),
            20.0 * v.norm().log10(),
            phase[i],
            coh(i)
                .map(|c| format!("{c:.3}"))
                .unwrap_or_else(|| "-".into())
        );
    }
    if let Some(path) = &a.out {
        say!("wrote {}", path.display());
    }
    if let Some(path) = &a.plot {
        say!("wrote {}", path.display());
    }
    Ok(())
}
