//! \[Li21\] Eq. 11/12 against the published values of docs/reference-values.md.

use fts::lti::{DiscreteTf, c64};
use fts::synth::zpetc::{self, ZpetcParams};

fn li21_eq11() -> DiscreteTf {
    DiscreteTf::new(
        vec![4.154, -9.631, 10.23, -5.511, 1.154],
        vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
        5,
        1e-4,
    )
    .unwrap()
}

/// Every expected root is matched by a distinct computed root within `tol`.
fn assert_roots_match(got: &[c64], expected: &[c64], tol: f64) {
    assert_eq!(got.len(), expected.len(), "{got:?}");
    let mut used = vec![false; got.len()];
    for e in expected {
        let (i, d) = got
            .iter()
            .enumerate()
            .filter(|(i, _)| !used[*i])
            .map(|(i, g)| (i, (g - e).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!(d < tol, "root {e} missed by {d}: {got:?}");
        used[i] = true;
    }
}

#[test]
fn eq11_zeros_poles_dc_gain() {
    let g = li21_eq11();
    // reference-values.md prints 4 decimals: tolerance half a unit of the last digit.
    let zeros = [
        c64::new(0.5475, 0.6748),
        c64::new(0.5475, -0.6748),
        c64::new(0.6912, 0.0),
        c64::new(0.5323, 0.0),
    ];
    assert_roots_match(&g.zeros().unwrap(), &zeros, 1e-4);
    for z in g.zeros().unwrap() {
        assert!(z.norm() < 1.0);
    }
    let poles = [
        c64::new(-0.0490, 0.8669),
        c64::new(-0.0490, -0.8669),
        c64::new(0.7010, 0.0),
        c64::new(0.3622, 0.0),
        c64::new(-0.1801, 0.0),
    ];
    assert_roots_match(&g.poles().unwrap(), &poles, 1e-4);
    // DC gain 0.95026 (5 decimals).
    assert!((g.dc_gain() - 0.95026).abs() < 5e-6, "{}", g.dc_gain());
    assert!(g.is_stable().unwrap());
}

#[test]
fn zpetc_of_eq11_is_z5_ac_over_bc() {
    let g = li21_eq11();
    let f = zpetc::design(&g, &ZpetcParams::default()).unwrap();
    assert_eq!(f.preview, 5);
    // Exactly A_c / b0 and B_c / b0 (Eq. 10): the division is the only rounding.
    for (a, b) in f.num.coeffs().iter().zip(g.den().coeffs()) {
        assert!((a - b / 4.154).abs() <= 2.0 * f64::EPSILON * (b / 4.154).abs());
    }
    for (a, b) in f.den.coeffs().iter().zip(g.num().coeffs()) {
        assert!((a - b / 4.154).abs() <= 2.0 * f64::EPSILON * (b / 4.154).abs());
    }
    let check = f.check(&g, 4001).unwrap();
    assert!((check.dc_gain - 1.0).abs() < 1e-12, "{}", check.dc_gain);
    assert!(check.max_phase_error_rad < 1e-9);
}

#[test]
fn paper_eq12_is_inconsistent_with_eq11() {
    // math.md 3: the printed ZPETC gives G_z G_c a DC gain of 0.60, not 1,
    // and its denominator roots differ from the zeros of B_c.
    let g = li21_eq11();
    let num = [0.2299, -0.1805, 0.1666, -0.1411, 0.01185, 0.007925];
    let den = [1.0, -2.293, 2.495, -1.367, 0.3167];
    let eq12 = DiscreteTf::new(num.to_vec(), den.to_vec(), 0, 1e-4).unwrap();
    // z^5 advance and z^-5 delay cancel at DC.
    let product_dc = eq12.dc_gain() * g.dc_gain();
    assert!((product_dc - 0.60).abs() < 0.01, "{product_dc}");
    let paper_poles = eq12.poles().unwrap();
    let plant_zeros = g.zeros().unwrap();
    let worst = paper_poles
        .iter()
        .map(|p| {
            plant_zeros
                .iter()
                .map(|z| (p - z).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    assert!(
        worst > 0.01,
        "Eq. 12 poles unexpectedly match B_c zeros: {worst}"
    );
    // Numerator 0.2299 A_c instead of A_c / 4.154 = 0.24073 A_c.
    assert!((num[0] - 1.0 / 4.154).abs() > 0.01);
}
