//! `fts zpetc --tf plant.json [-o zpetc.json] [--json] [--rho R] [--plot bode.svg]`

use super::common::{bad, complex_pairs, fmt_complex, print_json, read_input, write_atomic};
use crate::io::{plot, tf_json, zpetc_json};
use crate::lti::{Bode, TransferFunction, linspace};
use crate::synth::zpetc::{self, ZpetcParams};
use clap::Args;
use serde_json::json;
use std::path::PathBuf;

/// Frequencies used by the self-check (uniform, 0 to Nyquist).
const CHECK_POINTS: usize = 2001;

#[derive(Debug, Args)]
pub struct ZpetcArgs {
    /// Closed-loop model `G_c = z^-d B_c/A_c` (`fts.tf/1`, discrete).
    #[arg(long = "tf", value_name = "PLANT.json")]
    tf: PathBuf,
    /// Write the filter (`fts.zpetc/1`) here.
    #[arg(short = 'o', long = "out", value_name = "ZPETC.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Zeros with |z| >= RHO are not cancelled (0 < RHO <= 1).
    #[arg(long, value_name = "R", default_value_t = ZpetcParams::default().rho)]
    rho: f64,
    /// Zeros whose equivalent damping ratio is below this are not cancelled (0..1).
    #[arg(long, value_name = "ZETA", default_value_t = ZpetcParams::default().min_damping)]
    min_damping: f64,
    /// Invert zeros with |z| >= RADIUS exactly by an anticausal series (stable
    /// inversion) instead of cancelling only their phase; the preview grows by
    /// the series length. Without it: classical ZPETC (Tomizuka, [Li21]).
    #[arg(long, value_name = "RADIUS", num_args = 0..=1, default_missing_value = "1.25")]
    stable_inversion: Option<f64>,
    /// Truncation tolerance of the stable-inversion series (relative).
    #[arg(long, value_name = "TOL", default_value_t = zpetc::StableInversion::default().tolerance, requires = "stable_inversion")]
    series_tol: f64,
    /// Draw |G_c|, |G_z G_c| and their phase to this SVG file.
    #[arg(long, value_name = "BODE.svg")]
    plot: Option<PathBuf>,
}

pub fn run(args: ZpetcArgs) -> anyhow::Result<()> {
    let source = args.tf.display().to_string();
    let text = read_input(&args.tf)?;
    let plant = match tf_json::parse_tf(&text, &source)? {
        TransferFunction::Discrete(g) => g,
        TransferFunction::Continuous(_) => {
            return Err(bad(format!(
                "{source} field 'var': ZPETC needs a discrete closed loop (\"var\": \"z^-1\"), found a continuous one; discretise it first"
            )));
        }
    };
    let params = ZpetcParams {
        rho: args.rho,
        min_damping: args.min_damping,
        stable_inversion: args
            .stable_inversion
            .map(|min_radius| zpetc::StableInversion {
                min_radius,
                tolerance: args.series_tol,
                ..Default::default()
            }),
    };
    let filter = zpetc::design(&plant, &params).map_err(|e| match e {
        zpetc::ZpetcError::InvalidParams(m) => bad(m),
        e @ zpetc::ZpetcError::SeriesTooLong { .. } => bad(format!("{source}: {e}")),
        e @ (zpetc::ZpetcError::ZeroAtDc | zpetc::ZpetcError::UnstablePlant { .. }) => {
            bad(format!("{source}: {e}"))
        }
        e @ zpetc::ZpetcError::CancelsNearUnitCircle { .. } => bad(format!("--rho: {e}")),
        other => anyhow::Error::new(other),
    })?;
    let check = filter.check(&plant, CHECK_POINTS)?;

    if let Some(path) = &args.output {
        write_atomic(path, zpetc_json::zpetc_to_string(&filter).as_bytes())?;
    }
    if let Some(path) = &args.plot {
        let grid = linspace(0.0, plant.nyquist_hz(), 1001);
        let g_c = Bode::from_fn(&grid, |f| plant.response_at_hz(f));
        let product = Bode::from_fn(&grid, |f| {
            let w = 2.0 * std::f64::consts::PI * f * plant.ts();
            filter.response_at_omega(w) * plant.response_at_omega(w)
        });
        let svg = plot::bode_svg(
            &format!("ZPETC of {source}"),
            &[
                ("G_c (closed loop)", &g_c),
                ("G_z G_c (with ZPETC)", &product),
            ],
            false,
        )?;
        write_atomic(path, svg.as_bytes())?;
    }

    if args.json {
        let mut value = zpetc_json::zpetc_to_value(&filter);
        let obj = value.as_object_mut().expect("object");
        obj.insert(
            "check".into(),
            json!({
                "points": check.points,
                "max_phase_error_rad": check.max_phase_error_rad,
                "dc_gain": check.dc_gain,
                "max_magnitude_error": check.max_magnitude_error,
                "filter_stable": check.filter_stable,
            }),
        );
        obj.insert(
            "zeros".into(),
            serde_json::Value::Array(
                filter
                    .zeros
                    .iter()
                    .map(|z| {
                        json!({
                            "zero": complex_pairs([&z.zero])[0].clone(),
                            "magnitude": z.magnitude,
                            "damping": z.damping,
                            "cancelled": z.status == zpetc::ZeroStatus::Cancelled,
                            "status": z.status.label(),
                        })
                    })
                    .collect(),
            ),
        );
        return print_json(&value);
    }

    let d = plant.delay();
    let s = filter.uncancelled_zeros().count();
    let m = filter.series_inverted_zeros().count();
    say!(
        "closed loop {source}: z^-{d} B_c/A_c, ts = {} s, {} zeros, {} poles, DC gain {:.6}",
        plant.ts(),
        filter.zeros.len(),
        plant.den().trimmed(0.0).degree(),
        plant.dc_gain()
    );
    match params.stable_inversion {
        Some(si) => say!(
            "zero map (invert by series if |z| >= {}; else cancel if |z| < rho = {} and damping >= {}):",
            si.min_radius,
            params.rho,
            params.min_damping
        ),
        None => say!(
            "zero map (cancel if |z| < rho = {} and damping >= {}):",
            params.rho,
            params.min_damping
        ),
    }
    say!("  {:<26} {:>8} {:>8}  status", "zero", "|z|", "damping");
    for z in &filter.zeros {
        say!(
            "  {:<26} {:>8.4} {:>8.3}  {}",
            fmt_complex(z.zero),
            z.magnitude,
            z.damping,
            z.status.label()
        );
    }
    if m > 0 {
        say!(
            "preview: {} samples (delay d = {d}, uncancelled zeros s = {s}, series-inverted zeros m = {m}, series terms N = {}) = {:.3} ms",
            filter.preview,
            filter.series_terms,
            filter.preview as f64 * plant.ts() * 1e3
        );
    } else {
        say!(
            "preview: {} samples (delay d = {d}, uncancelled zeros s = {s}) = {:.3} ms",
            filter.preview,
            filter.preview as f64 * plant.ts() * 1e3
        );
    }
    say!("G_z = z^{} num(z^-1)/den(z^-1)", filter.preview);
    say!("  num = {:?}", filter.num.coeffs());
    say!("  den = {:?}", filter.den.coeffs());
    say!(
        "self-check over 0..{} Hz ({} points): max |phase(G_z G_c)| = {:.3e} rad, DC gain of G_z G_c = {:.12}, filter {}",
        plant.nyquist_hz(),
        check.points,
        check.max_phase_error_rad,
        check.dc_gain,
        if check.filter_stable {
            "stable"
        } else {
            "UNSTABLE"
        }
    );
    if let Some(path) = &args.output {
        say!("wrote {}", path.display());
    }
    if let Some(path) = &args.plot {
        say!("wrote {}", path.display());
    }
    Ok(())
}
