//! Property tests of the ordered real Schur form: factorisation and
//! orthogonality to a small multiple of `n eps`, standardised quasi-triangular
//! `T`, selected eigenvalues leading and equal to faer's eigenvalues.
//! Inputs: dense random matrices, and `U D U^T` with `U` random orthogonal
//! and `D` quasi-diagonal with many complex pairs and near-repeated
//! eigenvalues (normal, so the eigenvalues stay well conditioned).

// `!(x <= y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use faer::Mat;
use fts::lti::c64;
use fts::lti::schur::{OrderedRealSchur, ordered_real_schur, real_schur};
use proptest::prelude::*;

use crate::common;
use common::proptest_config as config;

/// Checks everything about an ordered Schur form of `a` with `select`.
fn check(a: &Mat<f64>, s: &OrderedRealSchur, select: &dyn Fn(c64) -> bool) -> Result<(), String> {
    let n = a.nrows();
    let eps = f64::EPSILON;
    let bound = 50.0 * (n as f64) * eps;
    let an = a.norm_l2().max(f64::MIN_POSITIVE);
    let fact = (&(&s.q * &s.t * s.q.transpose()) - a).norm_l2() / an;
    if !(fact <= bound && s.residual <= bound) {
        return Err(format!(
            "factorisation {fact:e} (reported {:e})",
            s.residual
        ));
    }
    let orth = (&(s.q.transpose() * &s.q) - Mat::<f64>::identity(n, n)).norm_l2();
    if !(orth <= bound) {
        return Err(format!("orthogonality {orth:e}"));
    }
    // Quasi-triangular with standardised 2x2 blocks.
    let t = &s.t;
    let mut i = 0;
    let mut eig = Vec::new();
    while i < n {
        for r in i + 2..n {
            if t[(r, i)] != 0.0 {
                return Err(format!("T[{r},{i}] = {}", t[(r, i)]));
            }
        }
        if i + 1 < n && t[(i + 1, i)] != 0.0 {
            if i + 2 < n && t[(i + 2, i + 1)] != 0.0 {
                return Err(format!("adjacent nonzero subdiagonals at {i}"));
            }
            let (a11, a12, a21, a22) = (t[(i, i)], t[(i, i + 1)], t[(i + 1, i)], t[(i + 1, i + 1)]);
            if a11 != a22 || !(a12 * a21 < 0.0) {
                return Err(format!(
                    "2x2 block at {i} not standard: {a11} {a12} {a21} {a22}"
                ));
            }
            let im = a12.abs().sqrt() * a21.abs().sqrt();
            eig.push((c64::new(a11, im), i));
            eig.push((c64::new(a11, -im), i));
            i += 2;
        } else {
            eig.push((c64::new(t[(i, i)], 0.0), i));
            i += 1;
        }
    }
    // Selected eigenvalues lead.
    for (l, pos) in &eig {
        let sel = select(c64::new(l.re, l.im.abs()));
        if sel != (*pos < s.n_selected) {
            return Err(format!(
                "eigenvalue {l} at {pos}, n_selected {}",
                s.n_selected
            ));
        }
    }
    // Same eigenvalues as faer's (greedy matching).
    let mut reference = a.eigenvalues().map_err(|e| format!("{e:?}"))?;
    for (l, _) in &eig {
        let (k, d) = reference
            .iter()
            .enumerate()
            .map(|(k, r)| (k, (r - l).norm()))
            .fold((0, f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
        if !(d <= 1e-10 * an) {
            return Err(format!("eigenvalue {l} off faer's by {d:e}"));
        }
        reference.swap_remove(k);
    }
    Ok(())
}

/// Random orthogonal matrix (Q factor of a random matrix).
fn orthogonal(n: usize, v: &[f64]) -> Mat<f64> {
    let g = Mat::from_fn(n, n, |i, j| {
        v[(7 * i + 3 * j + 1) % v.len()] + if i == j { 0.5 } else { 0.0 }
    });
    g.qr().compute_Q()
}

type Selector = Box<dyn Fn(c64) -> bool>;

fn selectors() -> [(&'static str, Selector); 3] {
    [
        ("re<0", Box::new(|l: c64| l.re < 0.0)),
        ("|l|<1", Box::new(|l: c64| l.norm() < 1.0)),
        ("im!=0", Box::new(|l: c64| l.im != 0.0)),
    ]
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn dense_random(n in 1usize..17, v in prop::collection::vec(-1.5f64..1.5, 300)) {
        let a = Mat::from_fn(n, n, |i, j| v[(i * n + j) % v.len()] * (1.0 + 0.01 * ((i + 2 * j) % 5) as f64));
        for (name, sel) in selectors() {
            let s = ordered_real_schur(&a, &sel).map_err(|e| TestCaseError::fail(format!("{name}: {e}")))?;
            check(&a, &s, &sel).map_err(|e| TestCaseError::fail(format!("{name}: {e}")))?;
        }
    }

    #[test]
    fn pairs_and_clusters(nb in 1usize..9, kinds in prop::collection::vec(0u8..4, 9),
                          vals in prop::collection::vec(-2.0f64..2.0, 40),
                          u in prop::collection::vec(-1.0f64..1.0, 300)) {
        // Blocks: 0 = complex pair, 1 = real, 2 = pair nearly equal to the
        // previous pair, 3 = real nearly equal to the previous real value.
        let mut d = Vec::new(); // (re, im) with im = 0 for real
        for b in 0..nb {
            let (re, im) = (vals[2 * b], vals[2 * b + 1].abs() + 0.05);
            let last = d.last().copied();
            match (kinds[b], last) {
                (0, _) => d.push((re, im)),
                (2, Some((r0, i0))) if i0 > 0.0 => d.push((r0 + 1e-9, i0 * (1.0 + 1e-9))),
                (3, Some((r0, 0.0))) => d.push((r0 * (1.0 + 1e-9) + 1e-12, 0.0)),
                (2, _) => d.push((re, im)),
                _ => d.push((re, 0.0)),
            }
        }
        let n: usize = d.iter().map(|(_, im)| if *im > 0.0 { 2 } else { 1 }).sum();
        let mut dm = Mat::<f64>::zeros(n, n);
        let mut i = 0;
        for (k, (re, im)) in d.iter().enumerate() {
            if *im > 0.0 {
                // Scaled rotation with unequal off-diagonals, still normal up to a diagonal similarity.
                let r = 1.0 + 0.3 * (k % 3) as f64;
                dm[(i, i)] = *re;
                dm[(i + 1, i + 1)] = *re;
                dm[(i, i + 1)] = im * r;
                dm[(i + 1, i)] = -im / r;
                i += 2;
            } else {
                dm[(i, i)] = *re;
                i += 1;
            }
        }
        let q = orthogonal(n, &u);
        let a = &q * &dm * q.transpose();
        for (name, sel) in selectors() {
            let s = ordered_real_schur(&a, &sel).map_err(|e| TestCaseError::fail(format!("{name}: {e}")))?;
            check(&a, &s, &sel).map_err(|e| TestCaseError::fail(format!("{name}: {e}")))?;
        }
    }
}

#[test]
fn unordered_form_and_trivial_sizes() {
    let a = Mat::from_fn(2, 2, |i, j| [[0.0, 1.0], [-1.0, 0.0]][i][j]);
    let s = real_schur(&a).unwrap();
    assert!(s.t[(1, 0)] != 0.0 && s.t[(0, 0)] == s.t[(1, 1)]);
    let e = ordered_real_schur(&Mat::zeros(0, 0), |_| true).unwrap();
    assert_eq!(e.n_selected, 0);
    let one = Mat::from_fn(1, 1, |_, _| -3.0);
    assert_eq!(
        ordered_real_schur(&one, |l| l.re < 0.0).unwrap().n_selected,
        1
    );
}

/// The fixed cases of the forms and their fallbacks (the complex QZ with
/// reordering, the real Schur form made triangular, the real QZ).
mod fixed {
    use faer::Mat;
    use fts::lti::c64;
    use fts::lti::schur::{
        GenSchur, cplx, gen_schur, pencil_residual, quasi_triangular_eigenvalues, real_qz,
        real_schur, real_to_complex_schur, schur, triangular_part,
    };

    fn dist(a: &Mat<c64>, b: &Mat<c64>) -> f64 {
        (a - b).norm_l2()
    }

    #[test]
    fn pencil_reordering_keeps_the_factorisation() {
        let n = 7;
        let m = Mat::from_fn(n, n, |i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0 + (i == j) as u8 as f64
        });
        let l = Mat::from_fn(n, n, |i, j| {
            if i == j {
                2.0
            } else {
                ((i + 2 * j) % 5) as f64 * 0.1
            }
        });
        let mut gs = gen_schur(&m, &l).unwrap();
        let check = |gs: &GenSchur| {
            let e1 = dist(&(&gs.q * &gs.s * gs.z.adjoint()), &cplx(&m));
            let e2 = dist(&(&gs.q * &gs.t * gs.z.adjoint()), &cplx(&l));
            assert!(e1 < 1e-12 * 50.0 && e2 < 1e-12 * 50.0, "{e1} {e2}");
        };
        check(&gs);
        let k = gs.reorder(|a, b| (a / b).re < 0.0);
        check(&gs);
        for (i, (a, b)) in gs.pairs().into_iter().enumerate() {
            assert_eq!((a / b).re < 0.0, i < k);
        }
    }

    /// The fallback of `schur` (real Schur form made triangular by one
    /// rotation per 2x2 block) on a matrix with three complex pairs and two
    /// real eigenvalues: `U` unitary, `U^H A U` upper triangular to
    /// rounding, and its diagonal the eigenvalues of the blocks.
    #[test]
    fn real_schur_made_triangular() {
        let n = 8;
        let a = Mat::from_fn(n, n, |i, j| {
            ((i * 5 + j * 3) % 7) as f64 - 3.0 + if i + 1 == j { 4.0 } else { 0.0 }
                - if j + 1 == i { 4.0 } else { 0.0 }
        });
        let rs = real_schur(&a).unwrap();
        let blocks = rs.t.clone();
        let (u, (r, dropped)) = triangular_part(&a, real_to_complex_schur(rs));
        let scale = cplx(&a).norm_l2();
        assert!(dropped < 1e-14 * scale, "{dropped}");
        assert!(dist(&(u.adjoint() * &u), &Mat::identity(n, n)) < 1e-14);
        assert!(dist(&(&u * &r * u.adjoint()), &cplx(&a)) < 1e-13 * scale);
        let want = quasi_triangular_eigenvalues(&blocks);
        let mut got: Vec<c64> = (0..n).map(|i| r[(i, i)]).collect();
        assert!(want.iter().filter(|z| z.im != 0.0).count() >= 2);
        // Each block eigenvalue matched to (and removed from) the nearest diagonal entry.
        for w in &want {
            let (k, d) = got
                .iter()
                .enumerate()
                .map(|(k, g)| (k, (g - w).norm()))
                .fold((0, f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
            assert!(d < 1e-12 * scale, "{w} vs {got:?}");
            got.remove(k);
        }
    }

    /// The real-QZ fallback of `gen_schur` on a pencil with complex pairs:
    /// both factors triangular, `Q`, `Z` unitary, the pencil reproduced,
    /// and `det(M - lambda L) = 0` at every `lambda = s_ii / t_ii`.
    #[test]
    fn real_qz_made_triangular() {
        let n = 7;
        let m = Mat::from_fn(n, n, |i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i + 1 == j { 6.0 } else { 0.0 }
                - if j + 1 == i { 6.0 } else { 0.0 }
        });
        let l = Mat::from_fn(n, n, |i, j| {
            if i == j {
                2.0 + i as f64 * 0.1
            } else {
                ((i + 2 * j) % 5) as f64 * 0.1
            }
        });
        let gs = real_qz(&m, &l).unwrap();
        assert!(pencil_residual(&gs, &m, &l) < 1e-13);
        assert!(dist(&(gs.q.adjoint() * &gs.q), &Mat::identity(n, n)) < 1e-13);
        assert!(dist(&(gs.z.adjoint() * &gs.z), &Mat::identity(n, n)) < 1e-13);
        let pairs = gs.pairs();
        assert!(
            pairs
                .iter()
                .filter(|(a, b)| (a / b).im.abs() > 1e-6)
                .count()
                >= 2
        );
        for (a, b) in pairs {
            let lam = a / b;
            let pencil = Mat::from_fn(n, n, |i, j| c64::new(m[(i, j)], 0.0) - lam * l[(i, j)]);
            let sv = pencil.singular_values().unwrap();
            let (lo, hi) = sv.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
            assert!(lo < 1e-12 * hi, "{lam}: {lo} vs {hi}");
        }
    }

    #[test]
    fn schur_of_rotation() {
        let a = Mat::from_fn(2, 2, |i, j| [[0.0, 1.0], [-1.0, 0.0]][i][j]);
        let (u, r) = schur(&a).unwrap();
        let back = &u * &r * u.adjoint();
        assert!(dist(&back, &cplx(&a)) < 1e-14);
        assert!((r[(0, 0)].norm() - 1.0).abs() < 1e-14);
    }
}

/// From `MULTISHIFT_FROM` (64) on the Schur form comes from the multishift
/// QR algorithm with aggressive early deflation (faer's, vendored), which
/// works in the lower triangle and switches to its blocked sweep at 75:
/// the same checks on dense random matrices and on Hamiltonians
/// `[A, -B B'; -C' C, -A']` (eigenvalues in pairs `+-lambda`, the stable
/// half selected, as the Riccati solvers use it) across those sizes.
#[test]
fn multishift_sizes_factor_and_order_correctly() {
    assert_eq!(fts::lti::schur::MULTISHIFT_FROM, 64);
    let mut uniform = common::unit_uniform(20261129);
    let mut next = move || 2.0 * uniform() - 1.0;
    for n in [63, 64, 74, 75, 76, 100, 160] {
        let a = Mat::from_fn(n, n, |_, _| next() / (n as f64).sqrt());
        for (name, sel) in selectors() {
            let s = ordered_real_schur(&a, &sel).unwrap_or_else(|e| panic!("n {n} {name}: {e}"));
            check(&a, &s, &sel).unwrap_or_else(|e| panic!("n {n} {name}: {e}"));
        }
    }
    for half in [32, 38, 50, 80] {
        let a = Mat::from_fn(half, half, |_, _| next() / (half as f64).sqrt());
        let b = Mat::from_fn(half, 2, |_, _| next());
        let c = Mat::from_fn(2, half, |_, _| next());
        let (g, q) = (&b * b.transpose(), c.transpose() * &c);
        let h = Mat::from_fn(2 * half, 2 * half, |i, j| match (i < half, j < half) {
            (true, true) => a[(i, j)],
            (true, false) => -g[(i, j - half)],
            (false, true) => -q[(i - half, j)],
            (false, false) => -a[(j - half, i - half)],
        });
        let stable = |l: c64| l.re < 0.0;
        let s = ordered_real_schur(&h, stable).unwrap_or_else(|e| panic!("H {half}: {e}"));
        check(&h, &s, &stable).unwrap_or_else(|e| panic!("H {half}: {e}"));
        assert_eq!(s.n_selected, half, "H {half}: half the spectrum is stable");
    }
}
