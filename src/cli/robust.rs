//! Robust-control commands:
//!
//! * `fts hinf --generalized P.json --nmeas NY --ncon NU [-o K.json] [--json]`
//! * `fts h2   --generalized P.json --nmeas NY --ncon NU [-o K.json] [--json]`
//! * `fts weight --kind ws|wt|makeweight ... [-o W.json] [--json]`
//! * `fts mixsyn --plant G.json --ws WS.json [--wu WU.json] [--wt WT.json] [-o K.json] [--json]`
//! * `fts c2d K.json --ts SECONDS --method zoh|tustin [--prewarp HZ] [-o KD.json] [--json]`
//! * `fts ss-info SYS.json [--json]`
//! * `fts budget SYS.json [--controller K.json] [--output I] [--fmax HZ] [--csv OUT.csv] [--json]`

use super::common::{bad, complex_pairs, fmt_complex, print_json, read_input, write_atomic};
use crate::io::{InputError, ss_json, tf_json};
use crate::lti::balred::balred;
use crate::lti::c2d::{C2dMethod, c2d};
use crate::lti::norms::{NormError, h2_norm, hinf_norm};
use crate::lti::ss::StateSpace;
use crate::lti::{TransferFunction, c64};
use crate::synth::genplant::SynthError;
use crate::synth::h2::h2syn;
use crate::synth::hinf::{HinfOptions, HinfResult, hinfsyn};
use crate::synth::mixsyn::mixsyn;
use crate::synth::weights;
use clap::{Args, ValueEnum};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Reads an `fts.ss/1` file, or an `fts.tf/1` file realised in controllable canonical form.
pub fn read_system(path: &Path) -> anyhow::Result<StateSpace> {
    let source = path.display().to_string();
    let text = read_input(path)?;
    let format = serde_json::from_str::<Value>(&text)
        .ok()
        .and_then(|v| v.get("format").and_then(|f| f.as_str().map(str::to_owned)));
    if format.as_deref() == Some(tf_json::TF_FORMAT) {
        let g = tf_json::parse_tf(&text, &source)?;
        let sys = match &g {
            TransferFunction::Continuous(c) => StateSpace::from_continuous_tf(c),
            TransferFunction::Discrete(d) => {
                // G = z^-d b(z^-1)/a(z^-1): descending powers of z after multiplying by z^N.
                let (b, a) = (d.num().coeffs(), d.den().coeffs());
                let nn = (b.len() - 1 + d.delay()).max(a.len() - 1);
                let mut num = vec![0.0; nn + 1];
                let mut den = vec![0.0; nn + 1];
                for (i, x) in b.iter().enumerate() {
                    num[d.delay() + i] = *x;
                }
                den[..a.len()].copy_from_slice(a);
                StateSpace::from_tf(&num, &den, Some(d.ts()))
            }
        };
        return sys.map_err(|e| InputError::new(&source, e.to_string()).into());
    }
    Ok(ss_json::parse_ss(&text, &source)?)
}

fn synth_err(source: &str, e: SynthError) -> anyhow::Error {
    match e {
        SynthError::Numerical(m) => anyhow::anyhow!("{source}: numerical failure: {m}"),
        other => bad(format!("{source}: {other}")),
    }
}

#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The generalised plant (`fts.ss/1`): inputs [w; u], outputs [z; y].
    #[arg(long, value_name = "P.json")]
    generalized: PathBuf,
    /// Number of measurements (the last NY outputs).
    #[arg(long, value_name = "NY")]
    nmeas: usize,
    /// Number of controls (the last NU inputs).
    #[arg(long, value_name = "NU")]
    ncon: usize,
    /// Write the controller (`fts.ss/1`) here.
    #[arg(short = 'o', long = "out", value_name = "K.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Smallest weight of the regularising channels added when D12 / D21
    /// lack full rank (raised automatically for conditioning; see docs/robust.md).
    #[arg(long, default_value_t = 1e-6)]
    eps: f64,
    /// Relative tolerance of the gamma bisection (H-inf only).
    #[arg(long, default_value_t = 1e-6)]
    tol: f64,
    /// Largest gamma tried before the problem is declared infeasible (H-inf only).
    #[arg(long, default_value_t = 1e8)]
    gamma_max: f64,
    /// The controller is built for gamma_opt * (1 + BACKOFF) (H-inf only).
    #[arg(long, default_value_t = 1e-4)]
    backoff: f64,
}

fn check_opts(eps: f64, tol: f64, gmax: f64, backoff: f64) -> anyhow::Result<HinfOptions> {
    if !(backoff.is_finite() && (0.0..1.0).contains(&backoff)) {
        return Err(bad(format!(
            "--backoff: expected 0 <= backoff < 1, got {backoff}"
        )));
    }
    if !(eps.is_finite() && eps > 0.0) {
        return Err(bad(format!("--eps: expected a positive number, got {eps}")));
    }
    if !(tol.is_finite() && tol > 0.0 && tol < 0.5) {
        return Err(bad(format!("--tol: expected 0 < tol < 0.5, got {tol}")));
    }
    if !(gmax.is_finite() && gmax > 0.0) {
        return Err(bad(format!(
            "--gamma-max: expected a positive number, got {gmax}"
        )));
    }
    Ok(HinfOptions {
        rtol: tol,
        eps,
        gamma_max: gmax,
        backoff,
    })
}

fn poles_summary(poles: &[c64]) -> String {
    let mut p: Vec<_> = poles.to_vec();
    p.sort_by(|a, b| b.re.total_cmp(&a.re));
    p.iter()
        .take(6)
        .map(|z| fmt_complex(*z))
        .collect::<Vec<_>>()
        .join(", ")
        + if p.len() > 6 { ", ..." } else { "" }
}

fn hinf_json(r: &HinfResult, eps: f64, tol: f64) -> Value {
    json!({
        "gamma": r.gamma,
        "gamma_opt": r.gamma_opt,
        "achieved_hinf_norm": r.achieved,
        "stable": r.stable,
        "closed_loop_poles": complex_pairs(&r.poles),
        "riccati_residuals": {"x": r.x_residual, "y": r.y_residual},
        "controller": ss_json::ss_to_value(&r.k),
        "controller_order": r.k.nx(),
        "regularised": {"d12": r.regularised.0, "d21": r.regularised.1, "eps_min": eps},
        "bisection": {"rtol": tol, "iterations": r.iterations},
    })
}

fn hinf_text(r: &HinfResult) -> String {
    let mut s = format!(
        "gamma            {:.8} (controller level; optimum estimate {:.8})\nachieved ||Tzw|| {:.8} (recomputed, Bruinsma-Steinbuch)\nclosed loop      {} (poles: {})\ncontroller       {} states\nRiccati residual X {:.1e}, Y {:.1e}\n",
        r.gamma,
        r.gamma_opt,
        r.achieved,
        if r.stable { "stable" } else { "UNSTABLE" },
        poles_summary(&r.poles),
        r.k.nx(),
        r.x_residual,
        r.y_residual
    );
    if let Some(e) = r.regularised.0 {
        s.push_str(&format!(
            "note: D12 lacks full column rank: regularised with a control weight {e:e} (eps u added to z)\n"
        ));
    }
    if let Some(e) = r.regularised.1 {
        s.push_str(&format!(
            "note: D21 lacks full row rank: regularised with a sensor-noise weight {e:e}\n"
        ));
    }
    s
}

/// `fts hinf`.
pub fn run_hinf(args: SynthArgs) -> anyhow::Result<()> {
    let opts = check_opts(args.eps, args.tol, args.gamma_max, args.backoff)?;
    let source = args.generalized.display().to_string();
    let p = read_system(&args.generalized)?;
    let r = hinfsyn(&p, args.nmeas, args.ncon, opts).map_err(|e| synth_err(&source, e))?;
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&r.k).as_bytes())?;
    }
    if args.json {
        print_json(&hinf_json(&r, args.eps, args.tol))
    } else {
        print!("{}", hinf_text(&r));
        Ok(())
    }
}

/// `fts h2`.
pub fn run_h2(args: SynthArgs) -> anyhow::Result<()> {
    check_opts(args.eps, args.tol, args.gamma_max, args.backoff)?;
    let source = args.generalized.display().to_string();
    let p = read_system(&args.generalized)?;
    let r = h2syn(&p, args.nmeas, args.ncon, args.eps).map_err(|e| synth_err(&source, e))?;
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&r.k).as_bytes())?;
    }
    if args.json {
        print_json(&json!({
            "h2_norm": r.h2_norm,
            "stable": r.stable,
            "closed_loop_poles": complex_pairs(&r.poles),
            "riccati_residuals": {"x": r.x_residual, "y": r.y_residual},
            "controller": ss_json::ss_to_value(&r.k),
            "controller_order": r.k.nx(),
            "regularised": {"d12": r.regularised.0, "d21": r.regularised.1, "eps_min": args.eps},
        }))
    } else {
        println!(
            "closed-loop H2 norm {:.12}\nclosed loop        {} (poles: {})\ncontroller         {} states\nRiccati residual   X {:.1e}, Y {:.1e}",
            r.h2_norm,
            if r.stable { "stable" } else { "UNSTABLE" },
            poles_summary(&r.poles),
            r.k.nx(),
            r.x_residual,
            r.y_residual
        );
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum WeightKind {
    /// W_s = (s/M + w0)/(s + w0 A) (Karagoz18 Eq. 7).
    Ws,
    /// W_t = (s + w0/M)/(A s + w0) (Karagoz18 Eq. 8).
    Wt,
    /// makeweight(dcgain, [freq, mag], hfgain), first order.
    Makeweight,
}

#[derive(Debug, Args)]
pub struct WeightArgs {
    /// Which weight.
    #[arg(long, value_enum)]
    kind: WeightKind,
    /// Peak sensitivity / gain M (ws, wt).
    #[arg(long)]
    m: Option<f64>,
    /// Corner frequency w0 in rad/s (ws, wt).
    #[arg(long)]
    w0: Option<f64>,
    /// Low/high-frequency gain parameter A (ws, wt).
    #[arg(long)]
    a: Option<f64>,
    /// makeweight: DC gain.
    #[arg(long)]
    dc: Option<f64>,
    /// makeweight: frequency (rad/s) where the gain is --mag.
    #[arg(long)]
    freq: Option<f64>,
    /// makeweight: gain at --freq.
    #[arg(long)]
    mag: Option<f64>,
    /// makeweight: high-frequency gain.
    #[arg(long)]
    hf: Option<f64>,
    /// Write the weight (`fts.ss/1`) here.
    #[arg(short = 'o', long = "out", value_name = "W.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

fn need(v: Option<f64>, flag: &str, kind: &str) -> anyhow::Result<f64> {
    v.ok_or_else(|| bad(format!("--kind {kind} needs --{flag}")))
}

/// `fts weight`.
pub fn run_weight(args: WeightArgs) -> anyhow::Result<()> {
    let w = match args.kind {
        WeightKind::Ws | WeightKind::Wt => {
            let k = if matches!(args.kind, WeightKind::Ws) {
                "ws"
            } else {
                "wt"
            };
            let (m, w0, a) = (
                need(args.m, "m", k)?,
                need(args.w0, "w0", k)?,
                need(args.a, "a", k)?,
            );
            if matches!(args.kind, WeightKind::Ws) {
                weights::ws(m, w0, a)
            } else {
                weights::wt(m, w0, a)
            }
        }
        WeightKind::Makeweight => {
            let k = "makeweight";
            weights::makeweight(
                need(args.dc, "dc", k)?,
                need(args.freq, "freq", k)?,
                need(args.mag, "mag", k)?,
                need(args.hf, "hf", k)?,
            )
        }
    }
    .map_err(|e| bad(e.0))?;
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&w).as_bytes())?;
    }
    let (num, den) = w.to_tf()?;
    let dc = w.dc_gain()?[(0, 0)];
    let hf = w.d[(0, 0)];
    if args.json {
        print_json(
            &json!({"num": num, "den": den, "dc_gain": dc, "hf_gain": hf,
            "weight": ss_json::ss_to_value(&w)}),
        )
    } else {
        println!(
            "W(s) = {num:?} / {den:?} (descending powers of s)\nDC gain {dc:.6e}, HF gain {hf:.6e}"
        );
        Ok(())
    }
}

#[derive(Debug, Args)]
pub struct MixsynArgs {
    /// The plant G (`fts.tf/1` continuous, or `fts.ss/1`).
    #[arg(long, value_name = "G.json")]
    plant: PathBuf,
    /// Sensitivity weight W1 (on S).
    #[arg(long, value_name = "WS.json")]
    ws: PathBuf,
    /// Control weight W2 (on KS).
    #[arg(long, value_name = "WU.json")]
    wu: Option<PathBuf>,
    /// Complementary sensitivity weight W3 (on T).
    #[arg(long, value_name = "WT.json")]
    wt: Option<PathBuf>,
    /// Write the controller (`fts.ss/1`) here.
    #[arg(short = 'o', long = "out", value_name = "K.json")]
    output: Option<PathBuf>,
    /// Write the augmented plant (`fts.ss/1`) here.
    #[arg(long, value_name = "P.json")]
    augmented: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
    /// Smallest weight of the regularising channels added when D12 / D21
    /// lack full rank (raised automatically for conditioning; see docs/robust.md).
    #[arg(long, default_value_t = 1e-6)]
    eps: f64,
    /// Relative tolerance of the gamma bisection.
    #[arg(long, default_value_t = 1e-6)]
    tol: f64,
    /// Reduce the controller to this many states by balanced truncation
    /// (the closed loop is re-checked with the reduced controller).
    #[arg(long, value_name = "N")]
    order: Option<usize>,
}

/// `fts mixsyn`.
pub fn run_mixsyn(args: MixsynArgs) -> anyhow::Result<()> {
    let opts = check_opts(args.eps, args.tol, 1e8, 1e-4)?;
    let g = read_system(&args.plant)?;
    let ws = read_system(&args.ws)?;
    let wu = args.wu.as_deref().map(read_system).transpose()?;
    let wt = args.wt.as_deref().map(read_system).transpose()?;
    let source = args.plant.display().to_string();
    let (p, mut r) =
        mixsyn(&g, Some(&ws), wu.as_ref(), wt.as_ref(), opts).map_err(|e| synth_err(&source, e))?;
    let mut reduction = Value::Null;
    if let Some(order) = args.order {
        let red = balred(&r.k, order).map_err(|e| bad(format!("--order {order}: {e}")))?;
        let cl = p.lft(&red.sys)?;
        let stable = cl.is_stable()?;
        let achieved = if stable {
            hinf_norm(&cl, 1e-8).map(|x| x.0).unwrap_or(f64::INFINITY)
        } else {
            f64::INFINITY
        };
        reduction = json!({"order": red.sys.nx(), "hankel_singular_values": red.hsv,
            "error_bound": red.bound, "full_order": r.k.nx()});
        eprintln!(
            "reduced controller: {} -> {} states (||K - Kr||_inf <= {:.3e}); closed loop {}, ||Tzw|| = {achieved:.6}",
            r.k.nx(),
            red.sys.nx(),
            red.bound,
            if stable { "stable" } else { "UNSTABLE" }
        );
        r.poles = cl.poles()?;
        r.k = red.sys;
        r.closed_loop = cl;
        r.stable = stable;
        r.achieved = achieved;
    }
    if let Some(path) = &args.augmented {
        write_atomic(path, ss_json::ss_to_string(&p).as_bytes())?;
    }
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&r.k).as_bytes())?;
    }
    let lf: Vec<Value> = [0.0, 1.0, 10.0, 100.0, 1000.0]
        .iter()
        .map(|w| json!({"omega": w, "gain": r.k.sigma_at(*w)}))
        .collect();
    if args.json {
        let mut v = hinf_json(&r, args.eps, args.tol);
        v["controller_gain"] = Value::Array(lf);
        v["reduction"] = reduction;
        print_json(&v)
    } else {
        print!("{}", hinf_text(&r));
        for w in [0.0, 1.0, 10.0, 100.0, 1000.0] {
            println!("|K(j{w})| = {:.6e}", r.k.sigma_at(w));
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Method {
    /// Zero-order hold (Van Loan block exponential).
    Zoh,
    /// Tustin / bilinear.
    Tustin,
}

#[derive(Debug, Args)]
pub struct C2dArgs {
    /// The continuous system (`fts.ss/1` or continuous `fts.tf/1`).
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Sample time in seconds.
    #[arg(long)]
    ts: f64,
    /// Discretisation method.
    #[arg(long, value_enum, default_value = "zoh")]
    method: Method,
    /// Tustin prewarp frequency in Hz.
    #[arg(long, value_name = "HZ")]
    prewarp: Option<f64>,
    /// Write the discrete system (`fts.ss/1`) here.
    #[arg(short = 'o', long = "out", value_name = "OUT.json")]
    output: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// `fts c2d`.
pub fn run_c2d(args: C2dArgs) -> anyhow::Result<()> {
    if !(args.ts.is_finite() && args.ts > 0.0) {
        return Err(bad(format!(
            "--ts: expected a positive number of seconds, got {}",
            args.ts
        )));
    }
    let method = match (args.method, args.prewarp) {
        (Method::Zoh, None) => C2dMethod::Zoh,
        (Method::Zoh, Some(_)) => return Err(bad("--prewarp applies to --method tustin only")),
        (Method::Tustin, p) => {
            if let Some(f) = p
                && !(f.is_finite() && f > 0.0 && f < 0.5 / args.ts)
            {
                return Err(bad(format!(
                    "--prewarp: expected 0 < HZ < Nyquist ({} Hz), got {f}",
                    0.5 / args.ts
                )));
            }
            C2dMethod::Tustin {
                prewarp: p.map(|f| 2.0 * std::f64::consts::PI * f),
            }
        }
    };
    let sys = read_system(&args.input)?;
    if sys.is_discrete() {
        return Err(bad(format!(
            "{}: the system is already discrete",
            args.input.display()
        )));
    }
    let d = c2d(&sys, args.ts, method)?;
    if let Some(path) = &args.output {
        write_atomic(path, ss_json::ss_to_string(&d).as_bytes())?;
    }
    let poles = d.poles()?;
    let stable = d.is_stable()?;
    if args.json {
        print_json(
            &json!({"system": ss_json::ss_to_value(&d), "poles": complex_pairs(&poles), "stable": stable}),
        )
    } else {
        println!(
            "discrete system: {} states, ts = {} s, {} (poles: {})",
            d.nx(),
            args.ts,
            if stable { "stable" } else { "not stable" },
            poles_summary(&poles)
        );
        Ok(())
    }
}

#[derive(Debug, Args)]
pub struct SsInfoArgs {
    /// The system (`fts.ss/1` or `fts.tf/1`).
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// `fts ss-info`: poles, stability, H2 and H-infinity norms.
pub fn run_ss_info(args: SsInfoArgs) -> anyhow::Result<()> {
    let sys = read_system(&args.input)?;
    let poles = sys.poles()?;
    let stable = sys.is_stable()?;
    let norm = |r: Result<f64, NormError>| match r {
        Ok(x) if x.is_finite() => json!(x),
        _ => Value::Null,
    };
    let h2 = norm(h2_norm(&sys));
    let hinf = hinf_norm(&sys, 1e-9).ok();
    let zeros = sys.zeros().ok();
    if args.json {
        print_json(&json!({
            "states": sys.nx(), "inputs": sys.nu(), "outputs": sys.ny(), "ts": sys.ts,
            "poles": complex_pairs(&poles), "stable": stable,
            "zeros": zeros.as_ref().map(complex_pairs),
            "h2_norm": h2, "hinf_norm": hinf.map(|h| h.0), "hinf_omega": hinf.map(|h| h.1),
        }))
    } else {
        println!(
            "{} states, {} inputs, {} outputs, {}\npoles: {}\nstable: {stable}\nH2 norm: {h2}\nH-inf norm: {}",
            sys.nx(),
            sys.nu(),
            sys.ny(),
            sys.ts
                .map_or("continuous".to_string(), |t| format!("ts = {t} s")),
            poles_summary(&poles),
            hinf.map_or("infinite (unstable)".to_string(), |h| format!(
                "{:.9} at {:.6} rad/s",
                h.0, h.1
            ))
        );
        Ok(())
    }
}

#[derive(Debug, Args)]
pub struct BudgetArgs {
    /// The system from the white-noise sources to the errors (`fts.ss/1`), or,
    /// with --controller, the generalised plant whose loop is closed first.
    #[arg(value_name = "SYS.json")]
    input: PathBuf,
    /// Controller closing the loop `F_l(P, K)` (the last NU inputs / NY outputs of P).
    #[arg(long, value_name = "K.json")]
    controller: Option<PathBuf>,
    /// Which output of the system is the error (0-based).
    #[arg(long, value_name = "INDEX", default_value_t = 0)]
    output_index: usize,
    /// Highest frequency of the budget in Hz (default: Nyquist, or 10 kHz).
    #[arg(long, value_name = "HZ")]
    fmax: Option<f64>,
    /// Number of grid points (uniform from 0 to fmax).
    #[arg(long, default_value_t = 20001)]
    points: usize,
    /// Write freq_hz, psd_<i>..., psd_total, cas to this CSV.
    #[arg(long, value_name = "OUT.csv")]
    csv: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the summary.
    #[arg(long)]
    json: bool,
}

/// `fts budget`: per-source PSD, cumulative amplitude spectrum and RMS (Ding22 Eq. 7-10).
pub fn run_budget(args: BudgetArgs) -> anyhow::Result<()> {
    let mut sys = read_system(&args.input)?;
    if let Some(kp) = &args.controller {
        let k = read_system(kp)?;
        if k.nu() >= sys.ny() || k.ny() >= sys.nu() {
            return Err(bad(format!(
                "{}: the controller ({} in, {} out) does not fit the plant ({} in, {} out)",
                kp.display(),
                k.nu(),
                k.ny(),
                sys.nu(),
                sys.ny()
            )));
        }
        sys = sys.lft(&k)?;
    }
    if !sys.is_stable()? {
        return Err(bad(format!(
            "{}: the (closed-loop) system is not stable: its error spectrum is unbounded",
            args.input.display()
        )));
    }
    if args.output_index >= sys.ny() {
        return Err(bad(format!(
            "--output-index {}: the system has {} outputs (0-based)",
            args.output_index,
            sys.ny()
        )));
    }
    let fmax = match (args.fmax, sys.ts) {
        (Some(f), _) => f,
        (None, Some(t)) => 0.5 / t,
        (None, None) => 1e4,
    };
    if !(fmax.is_finite() && fmax > 0.0) || args.points < 2 {
        return Err(bad("--fmax must be positive and --points at least 2"));
    }
    let grid = crate::lti::linspace(0.0, fmax, args.points);
    let b = crate::synth::budget::error_budget(&sys, args.output_index, &grid)
        .ok_or_else(|| anyhow::anyhow!("frequency response failed"))?;
    if let Some(path) = &args.csv {
        let mut out = String::from("freq_hz");
        for i in 0..b.psd.len() {
            out.push_str(&format!(",psd_{i}"));
        }
        out.push_str(",psd_total,cas\n");
        for k in 0..grid.len() {
            out.push_str(&format!("{}", grid[k]));
            for p in &b.psd {
                out.push_str(&format!(",{}", p[k]));
            }
            out.push_str(&format!(",{},{}\n", b.total_psd[k], b.cas[k]));
        }
        write_atomic(path, out.as_bytes())?;
    }
    if args.json {
        print_json(&json!({"rms": b.rms, "rms_per_source": b.rms_per_source, "fmax_hz": fmax}))
    } else {
        println!("RMS error up to {fmax} Hz: {:.6e}", b.rms);
        for (i, r) in b.rms_per_source.iter().enumerate() {
            println!(
                "  source {i}: {r:.6e} ({:.1}% of the power)",
                100.0 * r * r / (b.rms * b.rms).max(1e-300)
            );
        }
        Ok(())
    }
}
