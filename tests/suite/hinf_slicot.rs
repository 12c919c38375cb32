//! H-infinity synthesis on badly scaled mixed-sensitivity problems against
//! SLICOT SB10AD (issue #13, items 1 and 8). The reference values were made
//! once by `tests/data/hinf_slicot/gen_cases.py` (python-control + slycot)
//! and are read from `cases.json`; no Python is needed here.
//!
//! SLICOT's gamma is its bisection's claim, not proof: the generator also
//! recomputed the norm its own controller achieves. So, per case:
//! * fts's controller achieves the gamma fts reports: the closed loop is
//!   rebuilt here (`augw` + `lft`) and its norm recomputed by
//!   Bruinsma–Steinbuch and bounded below by a dense sweep, always;
//! * where SLICOT's controller achieves its claim, fts's gamma is within
//!   1e-4 of it once fts's deliberate backoff is accounted for: fts reports
//!   the norm its controller achieves, and builds that controller at its
//!   bisection bound times `1 + backoff` (1e-4), whereas SLICOT reports its
//!   bisection estimate; fts's bisection bound is also checked against
//!   SLICOT's gamma to 1e-4. A verified fts gamma *below* SLICOT's claim is
//!   not a failure (SLICOT's bisection stopped above the optimum);
//! * where it does not, fts's controller is no worse than SLICOT's.
//!
//! `KNOWN` lists the cases fts does not yet meet, with the reason; the test
//! fails if any other case fails, and if a known case starts passing (so the
//! list cannot go stale).

use crate::reference_cases;

use faer::Mat;
use fts::lti::norms::{hinf_norm, sigma_extended};
use fts::lti::ss::StateSpace;
use fts::synth::hinf::HinfOptions;
use fts::synth::mixsyn::{augw, mixsyn};
use serde::Deserialize;

/// Cases fts does not meet yet, with the reason (docs/robust.md, "SLICOT
/// comparison"). None today: the last two (a cheap-control controller
/// 1 % above SLICOT's, and gamma rising as W2 shrinks) went when the
/// verification accepted controllers within twice the backoff of the
/// bisection bound.
const KNOWN: &[(&str, &str)] = &[];

#[derive(Deserialize)]
struct Case {
    name: String,
    g_num: Vec<f64>,
    g_den: Vec<f64>,
    w1_num: Vec<f64>,
    w1_den: Vec<f64>,
    w2: f64,
    w3_num: Vec<f64>,
    w3_den: Vec<f64>,
    slicot_gamma: Option<f64>,
    slicot_achieved_sweep: Option<f64>,
    slicot_achieves: bool,
}

fn cases() -> Vec<Case> {
    reference_cases::load("hinf_slicot")
}

fn tf(num: &[f64], den: &[f64]) -> StateSpace {
    StateSpace::from_tf(num, den, None).unwrap()
}

/// The largest singular value over a log sweep spanning the closed loop's
/// poles: a lower bound on the H-inf norm, computed without the Hamiltonian.
/// The sweep runs in double precision; its best point is evaluated again
/// in double-double (`sigma_extended`), which is what is returned: on the
/// cheap-control loops (`w2 = 1e-6`) the double evaluation near the peak
/// is 2e-6 too high (a 40-digit evaluation of the same loop agrees with the
/// double-double one to 1e-11).
fn sweep_peak(cl: &StateSpace) -> f64 {
    let bal = cl.balanced();
    let mags: Vec<f64> = bal
        .poles()
        .unwrap()
        .iter()
        .map(|z| z.norm())
        .filter(|&w| w > 0.0)
        .collect();
    let lo = mags.iter().cloned().fold(f64::INFINITY, f64::min) / 100.0;
    let hi = mags.iter().cloned().fold(0.0, f64::max) * 100.0;
    let (w, _) = (0..5000)
        .map(|i| lo * (hi / lo).powf(i as f64 / 4999.0))
        .map(|w| (w, bal.sigma_at(w)))
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    sigma_extended(&bal, w)
}

fn fmt(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.6}"),
        Some(_) => "unstable".into(),
        None => "refused".into(),
    }
}

#[test]
fn mixed_sensitivity_gamma_matches_slicot_and_is_achieved() {
    let cases = cases();
    assert!(cases.len() >= 30, "{} cases", cases.len());
    let mut worst_vs_slicot = 0.0f64;
    let mut worst_claim = 0.0f64;
    let mut compared = 0;
    let mut worst_bound = 0.0f64;
    let mut failures: Vec<String> = Vec::new();
    println!(
        "| case | SLICOT gamma | SLICOT's K achieves | fts gamma (achieved) | fts - SLICOT (rel.) | fts check |"
    );
    println!("|---|---|---|---|---|---|");
    for c in &cases {
        let g = tf(&c.g_num, &c.g_den);
        let w1 = tf(&c.w1_num, &c.w1_den);
        let w2 = StateSpace::gain(Mat::from_fn(1, 1, |_, _| c.w2), None);
        let w3 = tf(&c.w3_num, &c.w3_den);
        let (_, r) = mixsyn(&g, Some(&w1), Some(&w2), Some(&w3), HinfOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", c.name));
        // Independent closed loop and norm.
        let p = augw(&g, Some(&w1), Some(&w2), Some(&w3)).unwrap();
        let cl = p.lft(&r.k).unwrap();
        assert!(cl.is_stable().unwrap(), "{}: closed loop unstable", c.name);
        let bs = hinf_norm(&cl.balanced(), 1e-9).unwrap();
        let bs = sigma_extended(&cl.balanced(), bs.omega);
        let peak = sweep_peak(&cl);
        // A sampled singular value is a true lower bound: where it exceeds
        // the Hamiltonian's answer, the latter missed the peak.
        let recomputed = bs.max(peak);
        let claim = (r.gamma / recomputed - 1.0).abs();
        worst_claim = worst_claim.max(claim);
        if claim.is_nan() || claim >= 1e-6 {
            failures.push(format!(
                "{}: reported {} vs recomputed {recomputed}",
                c.name, r.gamma
            ));
        }
        if peak > r.gamma * (1.0 + 1e-6) {
            failures.push(format!("{}: sweep {peak} > {}", c.name, r.gamma));
        }
        let rel = c.slicot_gamma.map(|s| r.gamma / s - 1.0);
        let rel_bound = c.slicot_gamma.map(|s| r.bisection_bound / s - 1.0);
        if c.slicot_achieves {
            // fts's controller is built at bound (1 + backoff) on purpose.
            let backoff = HinfOptions::default().backoff;
            let s = c.slicot_gamma.unwrap();
            let rel_b = r.gamma / (s * (1.0 + backoff)) - 1.0;
            compared += 1;
            worst_vs_slicot = worst_vs_slicot.max(rel_b);
            worst_bound = worst_bound.max(rel_bound.unwrap());
            if rel_b >= 1e-4 || rel_bound.unwrap() >= 1e-4 {
                failures.push(format!(
                    "{}: fts {} vs SLICOT {s} (gamma vs SLICOT (1 + backoff) {rel_b:+.2e}; bisection bound {:+.2e})",
                    c.name,
                    r.gamma,
                    rel_bound.unwrap()
                ));
            }
        } else if let Some(a) = c.slicot_achieved_sweep.filter(|a| a.is_finite())
            && r.gamma > a * (1.0 + 1e-4)
        {
            failures.push(format!("{}: fts {} vs SLICOT's K {a}", c.name, r.gamma));
        }
        println!(
            "| {} | {} | {}{} | {:.6} | {} | {:.1e} |",
            c.name,
            fmt(c.slicot_gamma),
            fmt(c
                .slicot_achieved_sweep
                .or(c.slicot_gamma.map(|_| f64::INFINITY))),
            if c.slicot_achieves { "" } else { " (misses)" },
            r.gamma,
            rel.filter(|_| c.slicot_achieves)
                .map_or("n/a".to_string(), |x| format!("{x:+.1e}")),
            claim
        );
    }
    println!(
        "worst fts gamma / (SLICOT (1 + backoff)) - 1 over {compared} cases where SLICOT's controller achieves its claim: {worst_vs_slicot:+.2e} (bisection bound / SLICOT - 1: {worst_bound:+.2e}); worst |reported/recomputed - 1|: {worst_claim:.2e}"
    );
    check_known(&failures);
    // SLICOT's own controller achieves its claim in 15 of the 32 cases (in
    // the others it misses by up to 80% or is unstable, and fts is checked
    // against what it achieves instead).
    assert!(compared >= 15, "only {compared} comparable cases");
}

/// Every failure is a `KNOWN` case, and every `KNOWN` case still fails.
fn check_known(failures: &[String]) {
    let known = |f: &String| KNOWN.iter().any(|(n, _)| f.starts_with(&format!("{n}:")));
    let unexpected: Vec<&String> = failures.iter().filter(|f| !known(f)).collect();
    assert!(
        unexpected.is_empty(),
        "unexpected failures:\n{unexpected:#?}"
    );
    for (name, why) in KNOWN {
        assert!(
            failures.iter().any(|f| f.starts_with(&format!("{name}:"))),
            "{name} now passes: remove it from KNOWN ({why})"
        );
    }
}

#[test]
fn gamma_does_not_grow_as_the_control_weight_shrinks() {
    // A smaller W2 weighs the same loop's KS less, so the optimum cannot
    // rise; fts's achieved norms may only rise within the backoff.
    let cases = cases();
    let mut rises = Vec::new();
    for pair in cases.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if a.g_num != b.g_num || b.w2 >= a.w2 {
            continue;
        }
        let run = |c: &Case| {
            let w2 = StateSpace::gain(Mat::from_fn(1, 1, |_, _| c.w2), None);
            let (w1, w3) = (tf(&c.w1_num, &c.w1_den), tf(&c.w3_num, &c.w3_den));
            mixsyn(
                &tf(&c.g_num, &c.g_den),
                Some(&w1),
                Some(&w2),
                Some(&w3),
                HinfOptions::default(),
            )
            .unwrap()
            .1
            .gamma
        };
        let (ga, gb) = (run(a), run(b));
        if gb > ga * (1.0 + 2e-4) {
            rises.push(format!("{}: {gb} > {ga} ({})", b.name, a.name));
        }
    }
    for r in &rises {
        println!("{r}");
    }
    assert!(rises.is_empty(), "gamma rises as W2 shrinks: {rises:#?}");
}
