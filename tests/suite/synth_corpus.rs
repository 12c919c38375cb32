//! Synthesis corpus (issue #19): random continuous and discrete generalised
//! plants, orders 2 to 40, MIMO channels, `D11` / `D22` != 0, badly scaled
//! ones (state scalings 1e-2..1e2, control weights 1e-3..1e-2), with
//! reference figures made once by `tests/data/synth_corpus/generate.py`
//! (SciPy, fixed seed; stored in `cases.json`, no Python needed here). How
//! each reference is established is in the generator's docstring and in
//! docs/robust.md ("Synthesis corpus"); in short:
//! * H2 (`h2_c`, `h2_d`): the closed-loop Gramian H2 norm of the optimal
//!   controller built with SciPy's CARE / DARE, equal to the Riccati trace
//!   formula to 1e-9: fts's achieved H2 norm must equal it to 1e-8, and on
//!   discrete plants also fts's optimum formula and a trapezoidal
//!   integration of `||Tzw||_F^2` over the unit circle done here;
//! * H-inf (`hinf_c`, `hinf_d`): `gamma_opt`, the infimum of the levels at
//!   which the Glover-Doyle conditions hold (Thm 17.1 general form with
//!   D11; discrete plants through the norm-preserving bilinear map,
//!   cross-checked with the discrete Riccati conditions), by bisection to
//!   1e-8; the conditions hold at `gamma_opt (1 + 1e-4)` and fail at
//!   `gamma_opt (1 - 1e-4)` for a stated reason. fts's bisection bound must
//!   lie within 1e-4 of it, and the gamma it reports (the norm its
//!   controller achieves) at most `1e-4` (its backoff) above it; the
//!   closed loop must be
//!   stable and its norm, recomputed by fts and by a dense frequency sweep
//!   of `P11 + P12 K (I - P22 K)^-1 P21` done here, at most
//!   `gamma (1 + 1e-6)`; and no controller may beat the optimum (the sweep
//!   is at least `gamma_opt (1 - 1e-6)`).

use crate::reference_cases;

use faer::Mat;
use faer::linalg::solvers::Solve;
use fts::lti::c64;
use fts::lti::norms::hinf_norm;
use fts::lti::ss::{StateSpace, sigma_max_c};
use fts::synth::h2::h2syn;
use fts::synth::hinf::{HinfOptions, hinfsyn};
use serde::Deserialize;

#[derive(Deserialize)]
struct Case {
    name: String,
    family: String,
    ts: Option<f64>,
    scaled: bool,
    nmeas: usize,
    ncon: usize,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
    h2_reference: Option<f64>,
    gamma_opt: Option<f64>,
    below_fails: Option<String>,
    cross_gamma_opt: Option<f64>,
}

fn corpus() -> Vec<Case> {
    reference_cases::load("synth_corpus")
}

fn family(name: &str) -> Vec<Case> {
    corpus().into_iter().filter(|c| c.family == name).collect()
}

fn mat(rows: &[Vec<f64>]) -> Mat<f64> {
    Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
}

fn plant(c: &Case) -> StateSpace {
    StateSpace::new(mat(&c.a), mat(&c.b), mat(&c.c), mat(&c.d), c.ts).unwrap()
}

fn has_d(c: &Case, rows_from: usize, cols_from: bool) -> bool {
    let (p1, m1) = (c.d.len() - c.nmeas, c.d[0].len() - c.ncon);
    let (r0, r1) = if rows_from == 0 {
        (0, p1)
    } else {
        (p1, c.d.len())
    };
    c.d[r0..r1].iter().any(|row| {
        let (c0, c1) = if cols_from { (m1, row.len()) } else { (0, m1) };
        row[c0..c1].iter().any(|&x| x != 0.0)
    })
}

#[test]
fn corpus_covers_the_issue() {
    let cases = corpus();
    assert!(cases.len() >= 40, "{} cases", cases.len());
    for f in ["h2_c", "h2_d", "hinf_c", "hinf_d"] {
        let of: Vec<&Case> = cases.iter().filter(|c| c.family == f).collect();
        assert!(of.len() >= 8, "{f}: {} cases", of.len());
        assert!(of.iter().any(|c| c.scaled), "{f}: no badly scaled case");
        assert!(
            of.iter().any(|c| c.ncon > 1 && c.nmeas > 1),
            "{f}: no MIMO case"
        );
        assert!(of.iter().filter(|c| c.a.len() >= 20).count() >= 3, "{f}");
    }
    let orders: Vec<usize> = cases.iter().map(|c| c.a.len()).collect();
    assert_eq!(orders.iter().min(), Some(&2));
    assert_eq!(orders.iter().max(), Some(&40));
    assert!(cases.iter().any(|c| has_d(c, 0, false)), "no D11");
    assert!(cases.iter().any(|c| has_d(c, 1, true)), "no D22");
}

/// The closed loop's response at `s` (or `z`), formed here from the plant's
/// and the controller's responses: `P11 + P12 K (I - P22 K)^-1 P21`
/// (`u = K y`), independent of any closed-loop realisation.
fn lft_at(p: &StateSpace, k: &StateSpace, nmeas: usize, ncon: usize, s: c64) -> Mat<c64> {
    let g = p.eval(s).unwrap();
    let kk = k.eval(s).unwrap();
    let (p1, m1) = (p.ny() - nmeas, p.nu() - ncon);
    let blk = |r0, r1, c0, c1| g.as_ref().submatrix(r0, c0, r1 - r0, c1 - c0).to_owned();
    let (p11, p12) = (blk(0, p1, 0, m1), blk(0, p1, m1, p.nu()));
    let (p21, p22) = (blk(p1, p.ny(), 0, m1), blk(p1, p.ny(), m1, p.nu()));
    let i_minus = Mat::<c64>::identity(nmeas, nmeas) - &p22 * &kk;
    let y = i_minus.partial_piv_lu().solve(&p21);
    &p11 + &p12 * (&kk * &y)
}

/// A dense sweep of the closed loop's largest singular value: 3000 points
/// (log-spaced from 1e-3 of the slowest to 1e3 times the fastest pole of
/// plant and controller, or uniform on the upper unit circle), then 400
/// points between the neighbours of the best one. A lower bound on the
/// H-inf norm; also returns where it peaked.
fn sweep_peak(p: &StateSpace, k: &StateSpace, nmeas: usize, ncon: usize) -> f64 {
    let at = |w: f64| {
        let s = match p.ts {
            None => c64::new(0.0, w),
            Some(_) => c64::from_polar(1.0, w),
        };
        sigma_max_c(&lft_at(p, k, nmeas, ncon, s))
    };
    let grid: Vec<f64> = match p.ts {
        Some(_) => (0..3000)
            .map(|i| std::f64::consts::PI * i as f64 / 2999.0)
            .collect(),
        None => {
            let mut mags: Vec<f64> = p.poles().unwrap().into_iter().map(|z| z.norm()).collect();
            mags.extend(k.poles().unwrap().into_iter().map(|z| z.norm()));
            mags.retain(|&m| m > 0.0);
            let lo = (mags.iter().cloned().fold(f64::INFINITY, f64::min) * 1e-3).log10();
            let hi = (mags.iter().cloned().fold(0.0, f64::max) * 1e3).log10();
            let mut g: Vec<f64> = (0..3000)
                .map(|i| 10f64.powf(lo + (hi - lo) * i as f64 / 2999.0))
                .collect();
            g.insert(0, 0.0);
            g
        }
    };
    let vals: Vec<f64> = grid.iter().map(|&w| at(w)).collect();
    let i = (0..vals.len()).fold(0, |b, i| if vals[i] > vals[b] { i } else { b });
    let (a, b) = (grid[i.saturating_sub(1)], grid[(i + 1).min(grid.len() - 1)]);
    (0..=400)
        .map(|j| at(a + (b - a) * j as f64 / 400.0))
        .fold(vals[i], f64::max)
}

/// `||T||_2^2 = (1/N) sum ||T(e^{j 2 pi k / N})||_F^2`, the trapezoidal rule
/// on the unit circle, exact up to `rho^N` for a stable discrete closed loop
/// of spectral radius `rho`; `None` when `rho` needs more than 8192 points.
fn h2_by_quadrature(p: &StateSpace, k: &StateSpace, c: &Case, rho: f64) -> Option<f64> {
    let n = (-28.0 / rho.ln()).ceil();
    if rho.is_nan() || rho >= 1.0 || n > 8192.0 {
        return None;
    }
    let n = (n as usize).max(64);
    let total: f64 = (0..n)
        .map(|i| {
            let z = c64::from_polar(1.0, 2.0 * std::f64::consts::PI * i as f64 / n as f64);
            let t = lft_at(p, k, c.nmeas, c.ncon, z);
            (0..t.ncols())
                .flat_map(|j| (0..t.nrows()).map(move |r| (r, j)))
                .map(|(r, j)| t[(r, j)].norm_sqr())
                .sum::<f64>()
        })
        .sum();
    Some((total / n as f64).sqrt())
}

/// H2: fts's achieved norm against the SciPy closed-loop Gramian value of
/// the optimal controller; returns the worst relative error.
fn check_h2(cases: &[Case]) -> f64 {
    let mut worst = 0.0f64;
    for c in cases {
        let p = plant(c);
        let r = h2syn(&p, c.nmeas, c.ncon, 1e-6).unwrap_or_else(|e| panic!("{}: {e}", c.name));
        assert!(r.stable, "{}", c.name);
        let reference = c.h2_reference.unwrap();
        let rel = r.h2_norm / reference - 1.0;
        let quad = r
            .spectral_radius()
            .and_then(|rho| h2_by_quadrature(&p, &r.k, c, rho));
        println!(
            "{}: fts {:.12} reference {reference:.12} ({rel:+.2e}){}{}",
            c.name,
            r.h2_norm,
            r.h2_optimum
                .map_or(String::new(), |o| format!(", optimum formula {o:.12}")),
            quad.map_or(String::new(), |q| format!(", quadrature {q:.12}"))
        );
        assert!(rel.abs() < 1e-8, "{}: {rel:e}", c.name);
        if let Some(opt) = r.h2_optimum {
            assert!((r.h2_norm / opt - 1.0).abs() < 1e-9, "{}", c.name);
        }
        if let Some(q) = quad {
            assert!(
                (q / reference - 1.0).abs() < 1e-9,
                "{}: quadrature {q}",
                c.name
            );
        }
        worst = worst.max(rel.abs());
    }
    worst
}

#[test]
fn continuous_h2_corpus_matches_scipy() {
    let cases = family("h2_c");
    assert!(cases.len() >= 10, "{}", cases.len());
    println!("worst relative error {:.2e}", check_h2(&cases));
}

#[test]
fn discrete_h2_corpus_matches_scipy() {
    let cases = family("h2_d");
    assert!(cases.len() >= 9, "{}", cases.len());
    println!("worst relative error {:.2e}", check_h2(&cases));
}

/// Worst figures of an H-inf family.
#[derive(Default)]
struct Worst {
    bound_error: f64,
    gamma_error: f64,
    norm_ratio: f64,
}

/// H-inf: fts's gamma against the certified optimum, its controller's
/// closed loop recomputed two ways.
fn check_hinf(c: &Case, worst: &mut Worst) {
    let p = plant(c);
    let opts = HinfOptions::default();
    let r = hinfsyn(&p, c.nmeas, c.ncon, opts).unwrap_or_else(|e| panic!("{}: {e}", c.name));
    let opt = c.gamma_opt.unwrap();
    let cl = p.lft(&r.k).unwrap();
    assert!(cl.is_stable().unwrap(), "{}: closed loop unstable", c.name);
    let peak = sweep_peak(&p, &r.k, c.nmeas, c.ncon);
    let recomputed = hinf_norm(&cl.balanced(), 1e-8).unwrap().peak;
    let (bound_err, gamma_err) = (r.bisection_bound / opt - 1.0, r.gamma / opt - 1.0);
    println!(
        "{}: optimum {opt:.8}, fts bound {:.8} ({bound_err:+.2e}), gamma {:.8} ({gamma_err:+.2e}), \
         recomputed {recomputed:.8}, sweep {peak:.8} ({}; below: {})",
        c.name,
        r.bisection_bound,
        r.gamma,
        r.form.name(),
        c.below_fails.as_deref().unwrap_or("-")
    );
    // (a) The gamma reported, the norm of the controller built at the
    // search's infeasible end times `1 + backoff`: within the backoff
    // (1e-4) of the optimum, and never below it (checked by the sweep
    // below). The search bound, a diagnostic, within 1e-4 above the
    // optimum; where the optimum is the level at which a Hamiltonian's
    // eigenvalues reach the axis, rounding blurs that level on cheap-control
    // plants and levels up to 1.05e-4 below it pass the numerical
    // feasibility test (`hinf_c_30_n24_scaled`, docs/robust.md), so 2e-4 is
    // allowed below.
    assert!(
        (-2e-4..=1e-4).contains(&bound_err),
        "{}: bound {bound_err:e}",
        c.name
    );
    assert!(gamma_err <= opts.backoff, "{}: gamma {gamma_err:e}", c.name);
    // The optimum is certified from below by a genuine violation, not by
    // an inaccurate Riccati solution.
    let below = c.below_fails.as_deref().unwrap_or("none");
    assert!(
        below.contains("rho(XY)") || below.contains("imaginary-axis") || below.contains("PSD"),
        "{}: below the optimum the conditions fail by {below}",
        c.name
    );
    // (b) the controller achieves the gamma it reports, two ways.
    assert!(
        recomputed <= r.gamma * (1.0 + 1e-6),
        "{}: {recomputed}",
        c.name
    );
    assert!(peak <= r.gamma * (1.0 + 1e-6), "{}: sweep {peak}", c.name);
    // No controller beats the optimum: a swept value below it would prove
    // the reference wrong.
    assert!(
        peak >= opt * (1.0 - 1e-6),
        "{}: sweep {peak} < optimum",
        c.name
    );
    worst.bound_error = worst.bound_error.max(bound_err.abs());
    worst.gamma_error = worst.gamma_error.max(gamma_err.abs());
    worst.norm_ratio = worst.norm_ratio.max(recomputed.max(peak) / r.gamma);
}

fn check_hinf_family(cases: &[Case]) {
    let mut worst = Worst::default();
    for c in cases {
        check_hinf(c, &mut worst);
    }
    println!(
        "{} cases: worst |bound / optimum - 1| {:.2e}, |gamma / optimum - 1| {:.2e}, \
         closed-loop norm / gamma - 1 {:+.2e}",
        cases.len(),
        worst.bound_error,
        worst.gamma_error,
        worst.norm_ratio - 1.0
    );
}

#[test]
fn continuous_hinf_corpus_against_certified_optimum() {
    let cases = family("hinf_c");
    assert!(cases.len() >= 10, "{}", cases.len());
    check_hinf_family(&cases);
}

#[test]
fn discrete_hinf_corpus_against_certified_optimum() {
    let cases = family("hinf_d");
    assert!(cases.len() >= 8, "{}", cases.len());
    for c in &cases {
        // The discrete Riccati conditions' own bisection agrees.
        let cross = c.cross_gamma_opt.unwrap();
        assert!(
            (cross / c.gamma_opt.unwrap() - 1.0).abs() < 1e-5,
            "{}",
            c.name
        );
    }
    check_hinf_family(&cases);
}
