//! A certified H-infinity synthesis family (issue #29): 41 mixed-sensitivity
//! problems with near-integrating performance weights (poles at 1e-9 to
//! 1e-3 times the bandwidth) and cheap-control weights (`W_u` 1e-6 to 1),
//! continuous and discrete, described and certified by
//! `tests/data/hinf_certified/generate.py` (mpmath at 40 digits; no Python
//! is needed here). Each problem is the stored augmented plant itself; its
//! optimum lies in `[g_lo, g_hi]` (`g_hi / g_lo - 1 <= 1e-7`, the Riccati
//! conditions of Zhou, Doyle & Glover Thm 17.1 failing at `g_lo` and holding
//! at `g_hi`), and a central controller at `g_hi (1 + 5e-5)` was verified at
//! 40 digits to achieve `controller_norm`.
//!
//! Per problem, `hinfsyn` on the stored plant (and, for a continuous one,
//! `mixsyn` from the weights, whose `augw` must rebuild the same plant):
//! * the controller stabilises, and the gamma fts reports is at least the
//!   closed loop's norm recomputed here ("gamma honest"): `lft`, then the
//!   peaks found by Bruinsma–Steinbuch and by a dense sweep, each evaluated
//!   again in double-double (attained values, so lower bounds);
//! * achieved `>= g_lo (1 - 1e-9)`: no controller beats the certified optimum;
//! * achieved `<= g_hi (1 + 1e-4 + 1e-6)`: fts is within 1e-4 of the
//!   optimum (the 1e-6 is the tolerance within which fts accepts a
//!   controller as meeting its design level, see `WITHIN`);
//! * `bisection_bound` lies in `[g_lo (1 - 1e-9), g_hi (1 + 1e-4)]`.
//!
//! `KNOWN` lists the problems fts does not meet yet, with the reason; a
//! family's test fails on any other failure, and when a known one passes.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::reference_cases;

use faer::Mat;
use fts::lti::c64;
use fts::lti::norms::{hinf_norm, sigma_extended};
use fts::lti::ss::StateSpace;
use fts::synth::hinf::{HinfOptions, HinfResult, hinfsyn};
use fts::synth::mixsyn::mixsyn;
use serde::Deserialize;

/// `(problem [path], reason)` for the checks fts misses today: none of the
/// 68 syntheses. There were 46 before closed-loop norms were confirmed in
/// double-double and a controller missing its level was replaced by the
/// best of a ladder of levels; 31 before the central controller's
/// descriptor form was tried where the explicit one misses its level or
/// fails to stabilise; 13 before the filter Riccati equation of a
/// mixed-sensitivity problem was solved by `Y = 0` directly (its
/// Hamiltonian's pair `+-p` at a weight pole of 1e-9 times the bandwidth
/// had landed on the axis); 10, all cheap control (`W_u` of 1e-4 and below
/// on Karagoz18 Y, 1e-6 on the DC servo), before the central controller
/// was also formed in double-double from Riccati solutions refined on the
/// unreduced equations and returned in modal coordinates (its state matrix
/// has entries of 1e13 beside the weight's pole at 1e-3). None was ever
/// dishonest (every reported gamma is at least the recomputed norm).
const KNOWN: &[(&str, &str)] = &[];

/// How far above the certified optimum fts's controller may lie: the
/// issue's 1e-4, plus the 1e-6 within which fts accepts a controller as
/// meeting the level it was built for (its default backoff puts that level
/// at most 1e-4 above the optimum).
const WITHIN: f64 = 1e-4 + 1e-6;

#[derive(Deserialize)]
struct Case {
    name: String,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
    ts: Option<f64>,
    nmeas: usize,
    ncon: usize,
    g_num: Vec<f64>,
    g_den: Vec<f64>,
    ws_num: Vec<f64>,
    ws_den: Vec<f64>,
    wu: f64,
    g_lo: f64,
    g_hi: f64,
    controller_level: f64,
    controller_norm: f64,
    sb10ad_gamma: Option<f64>,
}

fn cases() -> Vec<Case> {
    reference_cases::load("hinf_certified")
}

fn mat(rows: &[Vec<f64>]) -> Mat<f64> {
    Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
}

fn plant(c: &Case) -> StateSpace {
    StateSpace::new(mat(&c.a), mat(&c.b), mat(&c.c), mat(&c.d), c.ts).unwrap()
}

fn tf(num: &[f64], den: &[f64]) -> StateSpace {
    StateSpace::from_tf(num, den, None).unwrap()
}

/// The weights' `mixsyn` on a continuous problem.
fn by_mixsyn(c: &Case) -> Result<(StateSpace, HinfResult), String> {
    let g = tf(&c.g_num, &c.g_den);
    let ws = tf(&c.ws_num, &c.ws_den);
    let wu = StateSpace::gain(Mat::from_fn(1, 1, |_, _| c.wu), None);
    mixsyn(&g, Some(&ws), Some(&wu), None, HinfOptions::default()).map_err(|e| e.to_string())
}

/// Largest singular value over a log sweep spanning the closed loop's poles
/// (a discrete pole `z` counts as `ln(z) / ts`, up to the Nyquist
/// frequency): a lower bound on the norm, without the Hamiltonian.
fn sweep_peak(cl: &StateSpace) -> f64 {
    let bal = cl.balanced();
    let mag = |z: &c64| match bal.ts {
        None => z.norm(),
        Some(t) => (z.ln() / t).norm(),
    };
    let mags: Vec<f64> = bal
        .poles()
        .unwrap()
        .iter()
        .map(mag)
        .filter(|&w| w > 0.0)
        .collect();
    let lo = mags.iter().cloned().fold(f64::INFINITY, f64::min) / 100.0;
    let mut hi = mags.iter().cloned().fold(0.0, f64::max) * 100.0;
    if let Some(t) = bal.ts {
        hi = hi.min(std::f64::consts::PI / t);
    }
    let (w, _) = (0..5000)
        .map(|i| lo * (hi / lo).powf(i as f64 / 4999.0))
        .map(|w| (w, bal.sigma_at(w)))
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    // The double sweep only locates the peak: on the cheap-control loops its
    // value there is off by up to 1e-3, so the point is evaluated again in
    // double-double.
    sigma_extended(&bal, w)
}

/// One row of the table.
struct Row {
    bound: f64,
    achieved: f64,
}

/// The checks on one synthesis result; failures are pushed as
/// `"{label}: ..."`.
fn check(c: &Case, label: &str, p: &StateSpace, r: &HinfResult, fail: &mut Vec<String>) -> Row {
    let mut bad = |m: String| fail.push(format!("{label}: {m}"));
    let cl = p.lft(&r.k).unwrap();
    if !r.stable || !cl.is_stable().unwrap() {
        bad("closed loop unstable".into());
        return Row {
            bound: r.bisection_bound,
            achieved: f64::INFINITY,
        };
    }
    let bs = hinf_norm(&cl.balanced(), 1e-9)
        .map_or(f64::INFINITY, |h| sigma_extended(&cl.balanced(), h.omega));
    let peak = sweep_peak(&cl);
    // The peak frequency fts reports is one more place to look (the value
    // there is evaluated here, in double-double): on a flat low-frequency
    // plateau beside a pole at 1e-6 rad/s the double sweep's values are off
    // by 3e-4, and its best point can miss the plateau.
    let reported = if r.peak_omega.is_finite() {
        sigma_extended(&cl.balanced(), r.peak_omega)
    } else {
        0.0
    };
    let achieved = bs.max(peak).max(reported);
    if !(r.gamma >= achieved * (1.0 - 1e-6)) {
        bad(format!(
            "gamma not honest: reported {} vs recomputed {achieved} (sweep {peak})",
            r.gamma
        ));
    }
    if achieved < c.g_lo * (1.0 - 1e-9) {
        bad(format!(
            "achieved {achieved} below the certified optimum's lower end {}: the certificate or the norm is wrong",
            c.g_lo
        ));
    }
    if !(achieved <= c.g_hi * (1.0 + WITHIN)) {
        bad(format!(
            "achieved {achieved} is {:+.2e} above the certified optimum {} (allowed {WITHIN:e})",
            achieved / c.g_hi - 1.0,
            c.g_hi
        ));
    }
    let bb = r.bisection_bound;
    if !(bb >= c.g_lo * (1.0 - 1e-9) && bb <= c.g_hi * (1.0 + 1e-4)) {
        bad(format!(
            "bisection bound {bb} outside [g_lo (1 - 1e-9), g_hi (1 + 1e-4)] = [{}, {}] ({:+.2e} rel. to g_hi)",
            c.g_lo,
            c.g_hi,
            bb / c.g_hi - 1.0
        ));
    }
    Row {
        bound: bb,
        achieved,
    }
}

fn fmt(x: Option<f64>) -> String {
    x.map_or("refused".into(), |v| format!("{v:.8}"))
}

/// Runs a family (problems whose name starts with `prefix`), prints its
/// table, and checks the failures against `KNOWN`.
fn family(prefix: &str) {
    let cases: Vec<Case> = cases()
        .into_iter()
        .filter(|c| c.name.starts_with(prefix))
        .collect();
    let mut fail = Vec::new();
    let mut rows = Vec::new();
    for c in &cases {
        let p = plant(c);
        let label = format!("{} [hinfsyn]", c.name);
        match hinfsyn(&p, c.nmeas, c.ncon, HinfOptions::default()) {
            Ok(r) => rows.push((label.clone(), c, Some(check(c, &label, &p, &r, &mut fail)))),
            Err(e) => {
                fail.push(format!("{label}: hinfsyn refused: {e}"));
                rows.push((label, c, None));
            }
        }
        if c.ts.is_some() {
            continue;
        }
        let label = format!("{} [mixsyn]", c.name);
        match by_mixsyn(c) {
            Ok((aug, r)) => {
                same_plant(c, &aug);
                rows.push((
                    label.clone(),
                    c,
                    Some(check(c, &label, &aug, &r, &mut fail)),
                ));
            }
            Err(e) => {
                fail.push(format!("{label}: mixsyn refused: {e}"));
                rows.push((label, c, None));
            }
        }
    }
    println!("| problem | certified bracket | fts bound | fts achieved | rel. to g_hi | SB10AD |");
    println!("|---|---|---|---|---|---|");
    for (label, c, row) in &rows {
        let (bound, achieved, rel) = match row {
            Some(r) => (
                format!("{:.8}", r.bound),
                format!("{:.8}", r.achieved),
                format!("{:+.1e}", r.achieved / c.g_hi - 1.0),
            ),
            None => ("refused".into(), "refused".into(), "n/a".into()),
        };
        println!(
            "| {label} | [{:.8}, {:.8}] | {bound} | {achieved} | {rel} | {} |",
            c.g_lo,
            c.g_hi,
            fmt(c.sb10ad_gamma)
        );
    }
    for f in &fail {
        println!("FAIL {f}");
    }
    check_known(prefix, &fail);
}

/// fts's `augw` rebuilds the stored (certified) plant from the weights.
fn same_plant(c: &Case, aug: &StateSpace) {
    let p = plant(c);
    for (x, y, what) in [
        (&p.a, &aug.a, "A"),
        (&p.b, &aug.b, "B"),
        (&p.c, &aug.c, "C"),
        (&p.d, &aug.d, "D"),
    ] {
        assert_eq!((x.nrows(), x.ncols()), (y.nrows(), y.ncols()), "{}", c.name);
        for i in 0..x.nrows() {
            for j in 0..x.ncols() {
                assert!(
                    x[(i, j)] == y[(i, j)],
                    "{}: augw's {what}[{i},{j}] {} != stored {}",
                    c.name,
                    y[(i, j)],
                    x[(i, j)]
                );
            }
        }
    }
}

/// Every failure of the family is a `KNOWN` case, and every `KNOWN` case of
/// the family still fails.
fn check_known(prefix: &str, failures: &[String]) {
    let known = |f: &String| KNOWN.iter().any(|(n, _)| f.starts_with(&format!("{n}:")));
    let unexpected: Vec<&String> = failures.iter().filter(|f| !known(f)).collect();
    assert!(
        unexpected.is_empty(),
        "unexpected failures:\n{unexpected:#?}"
    );
    for (name, why) in KNOWN.iter().filter(|(n, _)| n.starts_with(prefix)) {
        assert!(
            failures.iter().any(|f| f.starts_with(&format!("{name}:"))),
            "{name} now passes: remove it from KNOWN ({why})"
        );
    }
}

#[test]
fn certificates_are_consistent() {
    let cases = cases();
    assert!(cases.len() >= 40, "{} problems", cases.len());
    for (prefix, at_least) in [("A ", 13), ("B ", 14), ("C ", 10)] {
        let n = cases.iter().filter(|c| c.name.starts_with(prefix)).count();
        assert!(n >= at_least, "family {prefix}: {n} problems");
    }
    for c in &cases {
        assert!(
            c.g_lo > 0.0 && c.g_hi / c.g_lo - 1.0 <= 1.1e-7,
            "{}",
            c.name
        );
        // The verified controller: at its level, and no better than the optimum.
        assert!(
            c.controller_norm >= c.g_lo && c.controller_norm < c.controller_level,
            "{}",
            c.name
        );
        assert!((c.controller_level / c.g_hi - 1.0 - 5e-5).abs() < 1e-12);
    }
}

#[test]
fn near_integrating_weights_continuous() {
    family("A ");
}

#[test]
fn cheap_control_continuous() {
    family("B ");
}

#[test]
fn discrete_by_zero_order_hold() {
    family("C ");
}
