//! Robust-control commands:
//!
//! * `fts hinf --generalized P.json --nmeas NY --ncon NU [-o K.json] [--json]`
//! * `fts h2   --generalized P.json --nmeas NY --ncon NU [-o K.json] [--json]`
//! * `fts weight --kind ws|wt|makeweight ... [-o W.json] [--json]`
//! * `fts mixsyn --plant G.json --ws WS.json [--wu WU.json] [--wt WT.json] [-o K.json] [--json]`
//! * `fts c2d K.json --ts SECONDS --method zoh|tustin [--prewarp HZ] [-o KD.json] [--json]`
//! * `fts ss-info SYS.json [--json]`
//! * `fts budget SYS.json [--controller K.json] [--output-index I] [--fmax HZ] [-o OUT.csv] [--json]`

use super::common::{
    bad, choice, complex_pairs, name, print_json, print_report, read_input, step_error,
    write_atomic,
};
use crate::io::ss_json;
use crate::lti::info::{SystemInfo, system_info};
use crate::lti::norms::HinfNorm;
use crate::lti::ss::StateSpace;
use crate::workflow::robust::poles_summary;
use crate::workflow::{
    C2d, C2dMethodChoice, H2, Hinf, Mixsyn, MixsynInputs, Named, Validate, Weight, WeightShape,
};
use clap::Args;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Reads an `fts.ss/1` file, or an `fts.tf/1` file realised in controllable canonical form.
pub fn read_system(path: &Path) -> anyhow::Result<StateSpace> {
    let text = read_input(path)?;
    Ok(ss_json::parse_system(&text, &path.display().to_string())?)
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
    #[arg(long, default_value_t = Hinf::default().eps)]
    eps: f64,
}

/// `fts hinf`: the common synthesis options and the gamma search's own
/// (kept out of `fts h2`, which has no gamma).
#[derive(Debug, Args)]
pub struct HinfArgs {
    #[command(flatten)]
    synth: SynthArgs,
    /// Relative tolerance of the gamma bisection (H-inf only).
    #[arg(long, default_value_t = Hinf::default().tol)]
    tol: f64,
    /// Largest gamma tried before the problem is declared infeasible (H-inf only).
    #[arg(long, default_value_t = Hinf::default().gamma_max)]
    gamma_max: f64,
    /// The controller is built for the bisection bound * (1 + BACKOFF) (H-inf only).
    #[arg(long, default_value_t = Hinf::default().backoff)]
    backoff: f64,
    /// Discrete plants (H-inf only): the smallest 1 - |z| accepted for a
    /// closed-loop pole the controller moves; the synthesis backs off from
    /// the optimum to meet it and warns when it cannot.
    #[arg(long, default_value_t = Hinf::default().pole_margin)]
    pole_margin: f64,
    /// Design the central controller at exactly this gamma instead of
    /// searching for the optimum (H-inf only; refused, exit 1, naming the
    /// optimum, when below it).
    #[arg(long, value_name = "G")]
    gamma: Option<f64>,
}

impl HinfArgs {
    fn hinf(&self) -> Hinf {
        Hinf {
            nmeas: self.synth.nmeas,
            ncon: self.synth.ncon,
            eps: self.synth.eps,
            tol: self.tol,
            gamma_max: self.gamma_max,
            backoff: self.backoff,
            pole_margin: self.pole_margin,
            gamma: self.gamma,
        }
    }
}

/// Writes a system to `path`, when given.
fn write_system(path: Option<&Path>, sys: &StateSpace) -> anyhow::Result<()> {
    match path {
        Some(path) => write_atomic(path, ss_json::ss_to_string(sys).as_bytes()),
        None => Ok(()),
    }
}

/// `fts hinf`.
pub fn run_hinf(hinf_args: HinfArgs) -> anyhow::Result<()> {
    let step = hinf_args.hinf();
    let args = hinf_args.synth;
    step.validate().map_err(step_error)?;
    let p = read_system(&args.generalized)?;
    let source = args.generalized.display().to_string();
    let report = step.run(&p, &source).map_err(step_error)?;
    // The summary carries the warnings; JSON output repeats them on stderr.
    if args.json {
        for w in report.warnings() {
            note!("fts: warning: {w}");
        }
    }
    write_system(args.output.as_deref(), &report.result.k)?;
    print_report(&report, args.json)
}

/// `fts h2`.
pub fn run_h2(args: SynthArgs) -> anyhow::Result<()> {
    let step = H2 {
        nmeas: args.nmeas,
        ncon: args.ncon,
        eps: args.eps,
    };
    step.validate().map_err(step_error)?;
    let p = read_system(&args.generalized)?;
    let source = args.generalized.display().to_string();
    let report = step.run(&p, &source).map_err(step_error)?;
    write_system(args.output.as_deref(), &report.result.k)?;
    print_report(&report, args.json)
}

#[derive(Debug, Args)]
pub struct WeightArgs {
    /// Which weight (`shape` in a manifest, where `kind` names the step's kind).
    #[arg(id = "shape", long = "kind", value_name = "KIND", value_parser = choice::<WeightShape>(), visible_alias = "shape")]
    kind: WeightShape,
    /// Peak sensitivity / gain M (ws, wt).
    #[arg(long)]
    m: Option<f64>,
    /// Corner frequency w0 in Hz (ws, wt).
    #[arg(long, value_name = "HZ")]
    w0: Option<f64>,
    /// Corner frequency w0 in rad/s, instead of --w0.
    #[arg(long, value_name = "RAD_PER_S", conflicts_with = "w0")]
    w0_rad: Option<f64>,
    /// Low/high-frequency gain parameter A (ws, wt).
    #[arg(long)]
    a: Option<f64>,
    /// makeweight: DC gain.
    #[arg(long)]
    dc: Option<f64>,
    /// makeweight: frequency in Hz where the gain is --mag.
    #[arg(long, value_name = "HZ")]
    freq: Option<f64>,
    /// makeweight: that frequency in rad/s, instead of --freq.
    #[arg(long, value_name = "RAD_PER_S", conflicts_with = "freq")]
    freq_rad: Option<f64>,
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

/// `fts weight`.
pub fn run_weight(args: WeightArgs) -> anyhow::Result<()> {
    let step = Weight {
        shape: Some(args.kind),
        m: args.m,
        w0: args.w0,
        w0_rad: args.w0_rad,
        a: args.a,
        dc: args.dc,
        freq: args.freq,
        freq_rad: args.freq_rad,
        mag: args.mag,
        hf: args.hf,
    };
    let report = step.run().map_err(step_error)?;
    write_system(args.output.as_deref(), &report.weight)?;
    print_report(&report, args.json)
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
    #[arg(long, default_value_t = Mixsyn::default().eps)]
    eps: f64,
    /// Relative tolerance of the gamma bisection.
    #[arg(long, default_value_t = Mixsyn::default().tol)]
    tol: f64,
    /// Reduce the controller to this many states by balanced truncation
    /// (the closed loop is re-checked with the reduced controller; refused,
    /// exit 1, when its H-inf norm exceeds 1.1 times the full controller's).
    #[arg(long, value_name = "N", value_parser = parse_order)]
    order: Option<usize>,
    /// Accept a reduced controller (--order) whatever its degradation.
    #[arg(long)]
    allow_degradation: bool,
    /// Design the central controller at exactly this gamma instead of
    /// searching for the optimum (refused, exit 1, naming the optimum, when
    /// below it).
    #[arg(long, value_name = "G")]
    gamma: Option<f64>,
}

/// `--order`: at least one state (a static gain is not a reduction of a
/// mixed-sensitivity controller) and at most a system file's.
fn parse_order(text: &str) -> Result<usize, String> {
    let max = ss_json::MAX_STATES;
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!("expected a whole number of states from 1 to {max}")),
    }
}

/// `fts mixsyn`.
pub fn run_mixsyn(args: MixsynArgs) -> anyhow::Result<()> {
    let step = Mixsyn {
        eps: args.eps,
        tol: args.tol,
        order: args.order,
        allow_degradation: args.allow_degradation,
        gamma: args.gamma,
    };
    step.validate().map_err(step_error)?;
    let g = read_system(&args.plant)?;
    let named = |path: &Path| -> anyhow::Result<(StateSpace, String)> {
        Ok((read_system(path)?, path.display().to_string()))
    };
    let ws = named(&args.ws)?;
    let wu = args.wu.as_deref().map(named).transpose()?;
    let wt = args.wt.as_deref().map(named).transpose()?;
    let source = args.plant.display().to_string();
    let report = step
        .run(MixsynInputs {
            plant: &g,
            ws: Named::from(&ws),
            wu: wu.as_ref().map(Named::from),
            wt: wt.as_ref().map(Named::from),
            source: &source,
        })
        .map_err(step_error)?;
    // The summary carries the note and the warnings; JSON output repeats them on stderr.
    if args.json {
        if let Some(note) = report.reduction_note() {
            note!("{note}");
        }
        for w in report.hinf.warnings() {
            note!("fts: warning: {w}");
        }
    }
    write_system(args.augmented.as_deref(), &report.augmented)?;
    write_system(args.output.as_deref(), report.controller())?;
    print_report(&report, args.json)
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
    #[arg(long, value_parser = choice::<C2dMethodChoice>(), default_value = name(C2d::default().method))]
    method: C2dMethodChoice,
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
    let step = C2d {
        ts: Some(args.ts),
        method: args.method,
        prewarp: args.prewarp,
    };
    step.validate().map_err(step_error)?;
    let sys = read_system(&args.input)?;
    let report = step
        .run(&sys, &args.input.display().to_string())
        .map_err(step_error)?;
    write_system(args.output.as_deref(), &report.system)?;
    print_report(&report, args.json)
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

/// `fts ss-info`: poles, invariant zeros (with the normal rank), stability,
/// H2 and H-infinity norms.
pub fn run_ss_info(args: SsInfoArgs) -> anyhow::Result<()> {
    let sys = read_system(&args.input)?;
    crate::workflow::convert::check_analysed_states(
        &sys,
        &args.input.display().to_string(),
        "ss-info",
    )
    .map_err(step_error)?;
    let SystemInfo {
        poles,
        stable,
        zeros,
        h2_norm,
        hinf_norm: hinf,
    } = system_info(&sys)?;
    let h2 = h2_norm.map_or(Value::Null, |x| json!(x));
    if args.json {
        print_json(&json!({
            "states": sys.nx(), "inputs": sys.nu(), "outputs": sys.ny(), "ts": sys.ts,
            "poles": complex_pairs(&poles), "stable": stable,
            "zeros": complex_pairs(&zeros.finite), "normal_rank": zeros.normal_rank,
            "h2_norm": h2, "hinf_norm": hinf.map(|h| h.peak), "hinf_omega": hinf.map(|h| h.omega),
            "hinf_freq_hz": hinf.map(|h| h.freq_hz()), "hinf_upper_bound": hinf.map(|h| h.upper),
        }))
    } else {
        say!(
            "{} states, {} inputs, {} outputs, {}\npoles: {}\nzeros: {} (normal rank {})\nstable: {stable}\nH2 norm: {h2}\nH-inf norm: {}",
            sys.nx(),
            sys.nu(),
            sys.ny(),
            sys.ts
                .map_or("continuous".to_string(), |t| format!("ts = {t} s")),
            poles_summary(&poles),
            if zeros.finite.is_empty() {
                "none".to_string()
            } else {
                poles_summary(&zeros.finite)
            },
            zeros.normal_rank,
            hinf.map_or("infinite (unstable)".to_string(), hinf_summary)
        );
        Ok(())
    }
}

/// `peak at f Hz (w rad/s), <= upper`: the attained value, where, and the
/// certified bound.
fn hinf_summary(h: HinfNorm) -> String {
    let at = if h.omega.is_finite() {
        format!("at {:.6} Hz ({:.6} rad/s)", h.freq_hz(), h.omega)
    } else {
        "at infinite frequency".to_string()
    };
    let bound = if h.upper.is_finite() {
        format!("certified <= {:.12}", h.upper)
    } else {
        "upper bound not certified".to_string()
    };
    format!("{:.12} {at}, {bound}", h.peak)
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
    #[arg(long, default_value_t = 20001, value_parser = super::common::parse_points)]
    points: usize,
    /// Write `freq_hz, psd_<i>..., psd_total, cas` to this CSV.
    #[arg(short = 'o', long = "out", alias = "csv", value_name = "OUT.csv")]
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
        return Err(bad(format!("--fmax: must be positive, got {fmax}")));
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
        say!("RMS error up to {fmax} Hz: {:.6e}", b.rms);
        for (i, r) in b.rms_per_source.iter().enumerate() {
            say!(
                "  source {i}: {r:.6e} ({:.1}% of the power)",
                100.0 * r * r / (b.rms * b.rms).max(1e-300)
            );
        }
        Ok(())
    }
}
