//! SLICOT's synthesis example programs as tests (issue #19): SB10ED
//! (discrete H2), SB10DD (discrete H-inf at a given gamma), SB10HD
//! (continuous H2) and SB10FD (continuous H-inf at a given gamma). The
//! example data and results are copied verbatim into `tests/data/slicot/`
//! (PROVENANCE.md there). A controller's state coordinates are not unique,
//! so what is compared is invariant: the feedthrough `DK`, the closed-loop
//! poles, the closed-loop norms (recomputed here from the printed
//! controllers, which carry 4 decimals), and optimality checked on its own
//! (the optimum formula, perturbations that never lower the cost).

use crate::common::cmd::{fts, predicate};
use faer::Mat;
use fts::lti::c64;
use fts::lti::norms::h2_norm;
use fts::lti::ss::StateSpace;
use fts::synth::dhinf::discrete_central;
use fts::synth::genplant::Partition;
use fts::synth::h2::h2syn;
use fts::synth::hinf::{ControllerForm, HinfOptions, closed_loop_norm, hinf_at_gamma, hinfsyn};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/slicot/");

/// An example's data: the plant `[A B; C D]`, `nmeas`, `ncon`, and the
/// trailing scalars (`GAMMA, TOL` or `TOL`), read in the order of the
/// example program (`TSB10xD.f`: N M NP NCON NMEAS, then A, B, C, D by rows).
struct Example {
    plant: StateSpace,
    nmeas: usize,
    ncon: usize,
    scalars: Vec<f64>,
}

fn read_dat(name: &str, ts: Option<f64>) -> Example {
    let text = std::fs::read_to_string(format!("{DIR}{name}.dat")).unwrap();
    let nums: Vec<f64> = text
        .lines()
        .skip(1)
        .flat_map(|l| l.split_whitespace())
        .map(|t| t.parse().unwrap())
        .collect();
    let dims: Vec<usize> = nums[..5].iter().map(|&x| x as usize).collect();
    let (n, m, np, ncon, nmeas) = (dims[0], dims[1], dims[2], dims[3], dims[4]);
    let mut at = 5;
    let mut take = |r: usize, c: usize| {
        let m = Mat::from_fn(r, c, |i, j| nums[at + i * c + j]);
        at += r * c;
        m
    };
    let (a, b, c, d) = (take(n, n), take(n, m), take(np, n), take(np, m));
    Example {
        plant: StateSpace::new(a, b, c, d, ts).unwrap(),
        nmeas,
        ncon,
        scalars: nums[at..].to_vec(),
    }
}

/// The numbers printed after the heading line containing `heading` in a
/// results file, up to the next heading (Fortran `D` exponents read).
fn read_res(name: &str, heading: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(format!("{DIR}{name}.res")).unwrap();
    let mut lines = text.lines().skip_while(|l| !l.contains(heading)).skip(1);
    let mut rows = Vec::new();
    for l in lines.by_ref() {
        let row: Result<Vec<f64>, _> = l
            .split_whitespace()
            .map(|t| t.replace('D', "e").parse::<f64>())
            .collect();
        match row {
            Ok(r) if !r.is_empty() => rows.push(r),
            Ok(_) if rows.is_empty() => continue,
            _ => break,
        }
    }
    rows
}

fn res_mat(name: &str, heading: &str) -> Mat<f64> {
    let rows = read_res(name, heading);
    Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
}

/// SLICOT's printed controller.
fn slicot_controller(name: &str, ts: Option<f64>) -> StateSpace {
    StateSpace::new(
        res_mat(name, "state matrix AK"),
        res_mat(name, "input matrix BK"),
        res_mat(name, "output matrix CK"),
        res_mat(name, "matrix DK is"),
        ts,
    )
    .unwrap()
}

fn max_abs_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    let mut d = 0.0f64;
    for i in 0..a.nrows() {
        for j in 0..a.ncols() {
            d = d.max((a[(i, j)] - b[(i, j)]).abs());
        }
    }
    d
}

/// The largest entrywise difference of two transfer matrices over 256
/// points of the unit circle (discrete) or of the imaginary axis from
/// 1e-2 to 1e4 rad/s (continuous).
fn max_response_diff(a: &StateSpace, b: &StateSpace) -> f64 {
    let point = |i: usize| match a.ts {
        Some(_) => c64::new(0.0, std::f64::consts::PI * i as f64 / 255.0).exp(),
        None => c64::new(0.0, 10f64.powf(-2.0 + 6.0 * i as f64 / 255.0)),
    };
    (0..256)
        .map(point)
        .map(|z| {
            let (ka, kb) = (a.eval(z).unwrap(), b.eval(z).unwrap());
            let mut d = 0.0f64;
            for i in 0..ka.nrows() {
                for j in 0..ka.ncols() {
                    d = d.max((ka[(i, j)] - kb[(i, j)]).norm());
                }
            }
            d
        })
        .fold(0.0, f64::max)
}

/// Each pole of `a` matched to the nearest unused pole of `b`: the largest
/// distance in units of `rel |a| + rel` (a printed pole's last digit).
fn pole_distance(a: &[c64], b: &[c64], rel: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let mut used = vec![false; b.len()];
    let mut worst = 0.0f64;
    for p in a {
        let (k, d) = b
            .iter()
            .enumerate()
            .filter(|(k, _)| !used[*k])
            .map(|(k, q)| (k, (p - q).norm() / (rel * (1.0 + p.norm()))))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap();
        used[k] = true;
        worst = worst.max(d);
    }
    worst
}

/// A deterministic pseudo-random sequence in [-1, 1) (64-bit LCG).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
    fn perturb(&mut self, m: &Mat<f64>, size: f64) -> Mat<f64> {
        Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)] + size * self.next())
    }
}

// ---------------------------------------------------------------- SB10ED

#[test]
fn sb10ed_discrete_h2_controller_matches_slicot() {
    let ts = Some(1.0);
    let ex = read_dat("SB10ED", ts);
    let r = h2syn(&ex.plant, ex.nmeas, ex.ncon, 1e-6).unwrap();
    assert!(r.stable);
    assert_eq!(r.regularised, (None, None));
    let theirs = slicot_controller("SB10ED", ts);
    // DK is printed to 4 decimals: DK = [-0.2181 -0.2070; 0.1094 0.1159].
    let dk = max_abs_diff(&r.k.d, &theirs.d);
    assert!(dk <= 0.5e-4 + 1e-12, "DK differs by {dk:.2e}: {:?}", r.k.d);
    // The closed-loop poles with SLICOT's printed controller.
    let cl_theirs = ex.plant.lft(&theirs).unwrap();
    let h2_theirs = h2_norm(&cl_theirs).unwrap();
    println!(
        "SB10ED: fts H2 {:.10} (optimum formula {:.10}), SLICOT's printed K {h2_theirs:.10}; \
         closed-loop rho {:.6}; DK within {dk:.2e}",
        r.h2_norm,
        r.h2_optimum.unwrap(),
        r.spectral_radius().unwrap()
    );
    // The transfer functions agree to the printed precision on the unit circle.
    let kd = max_response_diff(&r.k, &theirs);
    println!("SB10ED: max |K_fts(z) - K_slicot(z)| on the unit circle {kd:.2e}");
    assert!(kd < 1e-3, "{kd}");
    // The dominant closed-loop pole agrees (the others are ill-conditioned
    // against the 4-decimal rounding of the printed controller: they move
    // by up to 0.12 while the H2 norm changes by 1e-6).
    let rho_theirs = cl_theirs
        .poles()
        .unwrap()
        .iter()
        .fold(0.0f64, |m, z| m.max(z.norm()));
    let rho = r.spectral_radius().unwrap();
    assert!((rho - rho_theirs).abs() < 1e-3, "{rho} vs {rho_theirs}");
    // The printed (rounded) controller can only be worse than the optimum,
    // and only by the rounding.
    assert!(r.h2_norm <= h2_theirs * (1.0 + 1e-12));
    assert!(
        h2_theirs / r.h2_norm - 1.0 < 1e-4,
        "{h2_theirs} vs {}",
        r.h2_norm
    );
    // The Gramian of the closed loop agrees with the Riccati optimum.
    let opt = r.h2_optimum.unwrap();
    assert!(
        (r.h2_norm / opt - 1.0).abs() < 1e-10,
        "{} vs {opt}",
        r.h2_norm
    );
}

#[test]
fn sb10ed_controller_is_a_stationary_minimum() {
    let ex = read_dat("SB10ED", Some(1.0));
    let r = h2syn(&ex.plant, ex.nmeas, ex.ncon, 1e-6).unwrap();
    let k = &r.k;
    let mut rng = Lcg(19);
    for size in [1e-2, 1e-4] {
        let mut worst_rise = f64::INFINITY;
        for _ in 0..40 {
            let kp = StateSpace::new(
                rng.perturb(&k.a, size),
                rng.perturb(&k.b, size),
                rng.perturb(&k.c, size),
                rng.perturb(&k.d, size),
                k.ts,
            )
            .unwrap();
            let cl = ex.plant.lft(&kp).unwrap();
            let Ok(h) = h2_norm(&cl) else { continue };
            let rise = h / r.h2_norm - 1.0;
            assert!(
                rise > -1e-12,
                "a perturbed controller does better: {h} < {}",
                r.h2_norm
            );
            worst_rise = worst_rise.min(rise);
        }
        // At a minimum the cost rises to second order in the perturbation.
        println!("perturbation {size:e}: smallest rise {worst_rise:.3e}");
        assert!(worst_rise < 100.0 * size, "{worst_rise}");
    }
}

#[test]
fn sb10ed_d11_zero_and_d22_zero_variants_still_optimal() {
    // The same plant with D11 = 0 and D22 = 0: the formula and the Gramian
    // must still agree (the loop shift and the F0 term drop out separately).
    let ex = read_dat("SB10ED", Some(0.5));
    let mut p = ex.plant.clone();
    for i in 0..p.ny() {
        for j in 0..p.nu() {
            let d11 = i < 3 && j < 3;
            let d22 = i >= 3 && j >= 3;
            if d11 || d22 {
                p.d[(i, j)] = 0.0;
            }
        }
    }
    let r = h2syn(&p, 2, 2, 1e-6).unwrap();
    let opt = r.h2_optimum.unwrap();
    assert!(
        (r.h2_norm / opt - 1.0).abs() < 1e-10,
        "{} vs {opt}",
        r.h2_norm
    );
}

// ---------------------------------------------------------------- SB10DD

/// SLICOT's gamma for the SB10DD example (the data file's GAMMA).
fn sb10dd() -> (Example, f64) {
    let ex = read_dat("SB10DD", Some(1.0));
    let gamma = ex.scalars[0];
    assert_eq!(gamma, 111.294);
    (ex, gamma)
}

fn spectral_radius(sys: &StateSpace) -> f64 {
    sys.poles()
        .unwrap()
        .iter()
        .fold(0.0f64, |m, z| m.max(z.norm()))
}

#[test]
fn sb10dd_discrete_hinf_synthesis_matches_slicot_with_a_pole_margin() {
    let (ex, gamma_slicot) = sb10dd();
    let r = hinfsyn(&ex.plant, ex.nmeas, ex.ncon, HinfOptions::default()).unwrap();
    let theirs = slicot_controller("SB10DD", Some(1.0));
    let cl_theirs = ex.plant.lft(&theirs).unwrap();
    let rho_theirs = spectral_radius(&cl_theirs);
    let norm_theirs = closed_loop_norm(&cl_theirs);
    println!(
        "SB10DD: fts gamma {:.6} (bound {:.6}), rho {:.6}, margin {:.4}, {}; SLICOT gamma \
         {gamma_slicot}, its printed K: rho {rho_theirs:.6}, norm {norm_theirs:.6}",
        r.gamma,
        r.bisection_bound,
        r.spectral_radius.unwrap(),
        r.pole_margin.unwrap(),
        r.form.name()
    );
    // The bisection bound lies below SLICOT's gamma (SLICOT's is feasible),
    // and the achieved norm, independently recomputed, is within fts's
    // backoff (1e-4) of it.
    assert!(r.bisection_bound <= gamma_slicot);
    assert!(r.gamma <= gamma_slicot * (1.0 + 1e-4), "{}", r.gamma);
    let recomputed = closed_loop_norm(&ex.plant.lft(&r.k).unwrap());
    assert!((recomputed / r.gamma - 1.0).abs() < 1e-6);
    // The discrete central controller, not the bilinear one (which left a
    // closed-loop pole at z = -0.99997): the loop is as damped as SLICOT's.
    assert_eq!(r.form, ControllerForm::DiscreteCentral);
    let rho = r.spectral_radius.unwrap();
    assert!((rho - rho_theirs).abs() < 5e-3, "{rho} vs {rho_theirs}");
    assert_eq!(r.pole_margin_met, Some(true));
}

#[test]
fn sb10dd_central_controller_matches_slicot_near_its_gamma() {
    // At SLICOT's gamma itself (6e-6 above the optimum) fts's Z Riccati is
    // refused as too ill-conditioned; 5e-5 above it the controller's
    // frequency response on the unit circle agrees with SLICOT's printed one.
    let (ex, gamma_slicot) = sb10dd();
    let p = Partition::new(&ex.plant, ex.nmeas, ex.ncon).unwrap();
    let c = discrete_central(&p, gamma_slicot * (1.0 + 5e-5), 1.0).unwrap();
    assert!(c.x_residual < 1e-10 && c.z_residual < 1e-10_f64.max(c.residual_floor));
    let k = c.k;
    let theirs = slicot_controller("SB10DD", Some(1.0));
    let kd = max_response_diff(&k, &theirs);
    println!("SB10DD: max |K_fts - K_slicot| on the unit circle {kd:.2e}");
    assert!(kd < 1e-3, "{kd}");
    let cl = ex.plant.lft(&k).unwrap();
    assert!(closed_loop_norm(&cl) < gamma_slicot * (1.0 + 5e-5));
}

#[test]
fn sb10dd_unreachable_pole_margin_is_reported() {
    // rho ~0.817 is set by the plant: a margin of 0.5 cannot be met at any
    // level up to 1.1 gamma_opt; the verified controller comes back flagged.
    let (ex, _) = sb10dd();
    let o = HinfOptions {
        pole_margin: 0.5,
        ..HinfOptions::default()
    };
    let r = hinfsyn(&ex.plant, ex.nmeas, ex.ncon, o).unwrap();
    assert_eq!(r.pole_margin_met, Some(false));
    assert!(r.pole_margin.unwrap() < 0.5);
    assert!(r.gamma <= r.bisection_bound * (1.0 + 2e-4));
}

// ---------------------------------------------------------------- SB10FD

#[test]
fn sb10fd_continuous_central_controller_matches_slicot() {
    let ex = read_dat("SB10FD", None);
    let gamma = ex.scalars[0];
    assert_eq!(gamma, 15.0);
    let k = hinf_at_gamma(&ex.plant, ex.nmeas, ex.ncon, gamma, 1e-6).unwrap();
    let theirs = slicot_controller("SB10FD", None);
    let dk = max_abs_diff(&k.d, &theirs.d);
    let kd = max_response_diff(&k, &theirs);
    let published = sb10fd_published_poles();
    let cl = ex.plant.lft(&k).unwrap();
    let ours = cl.poles().unwrap();
    let pd = pole_distance(&published, &ours, 1e-4);
    println!("SB10FD: DK within {dk:.2e}, K(jw) within {kd:.2e}, poles within {pd:.2e} (relative)");
    assert!(dk <= 0.5e-4 + 1e-12, "{:?}", k.d);
    assert!(kd < 1e-3, "{kd}");
    assert!(
        pd < 1.0,
        "poles differ by {pd} units of the printed precision"
    );
    assert!(closed_loop_norm(&cl) < gamma);
}

/// The closed-loop poles SB10FD.res prints (5 significant digits).
fn sb10fd_published_poles() -> Vec<c64> {
    let re = read_res("SB10FD", "real parts");
    let im = read_res("SB10FD", "imaginary parts");
    re.concat()
        .iter()
        .zip(im.concat())
        .map(|(&a, b)| c64::new(a, b))
        .collect()
}

/// `fts hinf --gamma 15` (MATLAB's `hinfsyn(P, ny, nu, gamTry)`) on the
/// SB10FD plant, written as `fixtures/slicot-sb10fd.json`: the twelve
/// closed-loop poles SLICOT prints, to their 5 digits, and a norm below 15.
#[test]
fn sb10fd_cli_at_gamma_15_gives_the_published_closed_loop_poles() {
    let out = fts()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["hinf", "--generalized", "fixtures/slicot-sb10fd.json"])
        .args(["--nmeas", "2", "--ncon", "2", "--gamma", "15", "--json"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["bisection"]["chosen_gamma"], 15.0);
    assert_eq!(v["bisection"]["design_level"], 15.0);
    let gamma = v["gamma"].as_f64().unwrap();
    assert!(gamma < 15.0, "{gamma}");
    let ours: Vec<c64> = v["closed_loop_poles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| c64::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect();
    let published = sb10fd_published_poles();
    let pd = pole_distance(&published, &ours, 1e-4);
    assert!(
        pd < 1.0,
        "poles differ by {pd} units of the printed precision"
    );
    // The plant file is the .dat's plant, exactly.
    let ex = read_dat("SB10FD", None);
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/slicot-sb10fd.json"
    ))
    .unwrap();
    let fixture = fts::io::ss_json::parse_system(&text, "slicot-sb10fd.json").unwrap();
    assert_eq!(fixture.a, ex.plant.a);
    assert_eq!(
        (fixture.b.clone(), fixture.c.clone()),
        (ex.plant.b.clone(), ex.plant.c.clone())
    );
    assert_eq!(fixture.d, ex.plant.d);
}

/// A chosen gamma below the optimum (about 10.18426 on SB10FD's plant) is
/// refused with exit 1, naming the bisection bound.
#[test]
fn chosen_gamma_below_the_optimum_exits_1_naming_the_bound() {
    fts()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["hinf", "--generalized", "fixtures/slicot-sb10fd.json"])
        .args(["--nmeas", "2", "--ncon", "2", "--gamma", "10", "-o"])
        .arg(std::env::temp_dir().join("fts-below-optimum-k.json"))
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "no stabilising controller achieves gamma 10",
        ))
        .stderr(predicate::str::contains("bisection bound 10.18425"));
    assert!(
        !std::env::temp_dir()
            .join("fts-below-optimum-k.json")
            .exists()
    );
}

/// `HinfOptions::gamma` on a discrete plant: SB10DD's discrete central
/// controller at the chosen level (5e-5 above SLICOT's gamma, where fts's
/// Z Riccati is well enough conditioned), verified, no backoff.
#[test]
fn sb10dd_at_a_chosen_gamma_is_the_discrete_central_controller() {
    let (ex, gamma_slicot) = sb10dd();
    let level = gamma_slicot * (1.0 + 5e-5);
    let o = HinfOptions {
        gamma: Some(level),
        ..HinfOptions::default()
    };
    let r = hinfsyn(&ex.plant, ex.nmeas, ex.ncon, o).unwrap();
    assert_eq!(r.form, ControllerForm::DiscreteCentral);
    assert_eq!(r.design_level, level);
    let recomputed = closed_loop_norm(&ex.plant.lft(&r.k).unwrap());
    assert!(
        recomputed <= level * (1.0 + 1e-6),
        "{recomputed} vs {level}"
    );
    let kd = max_response_diff(&r.k, &slicot_controller("SB10DD", Some(1.0)));
    assert!(kd < 1e-3, "{kd}");
}

// ---------------------------------------------------------------- SB10HD

#[test]
fn sb10hd_continuous_h2_controller_matches_slicot() {
    let ex = read_dat("SB10HD", None);
    let r = h2syn(&ex.plant, ex.nmeas, ex.ncon, 1e-6).unwrap();
    let theirs = slicot_controller("SB10HD", None);
    let dk = max_abs_diff(&r.k.d, &theirs.d);
    let kd = max_response_diff(&r.k, &theirs);
    let cl_theirs = ex.plant.lft(&theirs).unwrap();
    let h2_theirs = h2_norm(&cl_theirs).unwrap();
    println!(
        "SB10HD: fts H2 {:.10}, SLICOT's printed K {h2_theirs:.10}; K(jw) within {kd:.2e}",
        r.h2_norm
    );
    assert_eq!(dk, 0.0);
    assert!(kd < 2e-3, "{kd}");
    assert!(r.h2_norm <= h2_theirs * (1.0 + 1e-12));
    assert!(h2_theirs / r.h2_norm - 1.0 < 1e-4);
}

#[test]
fn discrete_h2_with_a_singular_control_channel_is_regularised() {
    // SB10ED's plant with D12 = 0 (no direct control penalty): the control
    // channel gets the weight eps; the achieved norm on the original plant is
    // at most the regularised problem's optimum, and close to it.
    let ex = read_dat("SB10ED", Some(1.0));
    let mut p = ex.plant.clone();
    for i in 0..3 {
        for j in 3..5 {
            p.d[(i, j)] = 0.0;
        }
    }
    for eps in [1e-3, 1e-6] {
        let r = h2syn(&p, 2, 2, eps).unwrap();
        // 1e-6 is raised until the DARE solves (docs/robust.md).
        let weight = r.regularised.0.unwrap();
        assert!(weight >= eps && weight <= 1e6 * eps && r.regularised.1.is_none());
        assert!(r.stable);
        let opt = r.h2_optimum.unwrap();
        println!(
            "D12 = 0, eps {eps:e}: weight {weight:e}, H2 {} (regularised optimum {opt})",
            r.h2_norm
        );
        assert!(r.h2_norm <= opt * (1.0 + 1e-9));
        assert!(opt / r.h2_norm - 1.0 < 1e-3);
    }
}
