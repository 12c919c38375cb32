//! Properties of ZPETC and of polynomial roots on random plants.

use fts::lti::{DiscreteTf, Poly, c64};
use fts::synth::zpetc::{self, ZeroStatus, ZpetcParams};
use proptest::prelude::*;
use std::f64::consts::PI;

/// A zero (or conjugate pair) by polar coordinates; radius 0.1..1.8 so both
/// cancellable and uncancellable zeros occur.
fn zero_set() -> impl Strategy<Value = Vec<c64>> {
    prop::collection::vec((0.1f64..1.8, 0.0f64..PI, any::<bool>()), 1..4).prop_map(|specs| {
        let mut out = Vec::new();
        for (r, theta, complex) in specs {
            if complex && theta > 0.05 && theta < PI - 0.05 {
                out.push(c64::from_polar(r, theta));
                out.push(c64::from_polar(r, -theta));
            } else {
                // Keep away from z = 1 (no DC gain) and z = -1 exactly.
                let x = if theta < PI / 2.0 { r } else { -r };
                let x = if (x - 1.0).abs() < 0.05 { x + 0.1 } else { x };
                out.push(c64::new(x, 0.0));
            }
        }
        out
    })
}

/// Stable denominators from poles of radius < 0.9.
fn pole_set() -> impl Strategy<Value = Vec<c64>> {
    prop::collection::vec((0.0f64..0.9, 0.0f64..PI), 1..4).prop_map(|specs| {
        let mut out = Vec::new();
        for (r, theta) in specs {
            out.push(c64::from_polar(r, theta));
            if theta.sin().abs() > 1e-3 {
                out.push(c64::from_polar(r, -theta));
            }
        }
        out
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn zpetc_zero_phase_unit_dc(zeros in zero_set(), poles in pole_set(),
                                gain in 0.2f64..5.0, delay in 0usize..6) {
        let b = Poly::from_z_roots(&zeros, gain);
        let a = Poly::from_z_roots(&poles, 1.0);
        let g = DiscreteTf::new(b.coeffs().to_vec(), a.coeffs().to_vec(), delay, 1e-4).unwrap();
        let f = zpetc::design(&g, &ZpetcParams::default()).unwrap();
        let s = f.uncancelled_zeros().count();
        prop_assert_eq!(f.preview, delay + s);
        prop_assert!(f.cancelled_zeros().all(|z| z.magnitude < 0.95));
        prop_assert!(f.zeros.iter().filter(|z| z.magnitude >= 0.95).all(|z| z.status == ZeroStatus::OutsideRadius));

        // |G_z G_c| must equal |B_u(e^jw)|^2 / B_u(1)^2 and the phase must vanish.
        let kept: Vec<c64> = f.uncancelled_zeros().map(|z| z.zero).collect();
        let b_u = Poly::from_z_roots(&kept, gain);
        let dc2 = b_u.sum().powi(2);
        let scale = (0..=200).map(|i| b_u.eval_unit_circle(PI * i as f64 / 200.0).norm_sqr() / dc2).fold(0.0, f64::max);
        for i in 0..=200 {
            let w = PI * i as f64 / 200.0;
            let p = f.response_at_omega(w) * g.response_at_omega(w);
            let expected = b_u.eval_unit_circle(w).norm_sqr() / dc2;
            // Relative to the largest value of the product: where |B_u| has a
            // near-null the phase is meaningless and the magnitude is ~0.
            prop_assert!((p.norm() - expected).abs() <= 1e-9 * scale.max(1.0), "w={} |p|={} expected={}", w, p.norm(), expected);
            if expected > 1e-6 * scale {
                prop_assert!(p.arg().abs() < 1e-9, "phase {} at w={}", p.arg(), w);
            }
        }
        let dc = f.response_at_omega(0.0) * g.response_at_omega(0.0);
        prop_assert!((dc.re - 1.0).abs() < 1e-9 && dc.im.abs() < 1e-12);
        prop_assert!(f.check(&g, 257).unwrap().filter_stable);
    }

    #[test]
    fn stable_inversion_makes_the_product_one(zeros in zero_set(), poles in pole_set(),
                                              gain in 0.2f64..5.0, delay in 0usize..6) {
        // Every zero outside radius 1.1 inverted by its series: G_z G_c is then
        // |B_u|^2/B_u(1)^2 for the ZPETC-kept zeros (inside 1.1) and otherwise 1,
        // to the series tolerance.
        let b = Poly::from_z_roots(&zeros, gain);
        let a = Poly::from_z_roots(&poles, 1.0);
        let g = DiscreteTf::new(b.coeffs().to_vec(), a.coeffs().to_vec(), delay, 1e-4).unwrap();
        let tol = 1e-10;
        let params = ZpetcParams {
            stable_inversion: Some(zpetc::StableInversion { min_radius: 1.1, tolerance: tol, max_terms: 5000 }),
            ..Default::default()
        };
        let f = zpetc::design(&g, &params).unwrap();
        let m = f.series_inverted_zeros().count();
        prop_assert!(f.series_inverted_zeros().all(|z| z.magnitude >= 1.1));
        prop_assert_eq!(f.preview, delay + f.uncancelled_zeros().count() + m + f.series_terms);
        let kept: Vec<c64> = f.uncancelled_zeros().map(|z| z.zero).collect();
        let b_u = Poly::from_z_roots(&kept, 1.0);
        let dc2 = b_u.sum().powi(2);
        let scale = (0..=200).map(|i| b_u.eval_unit_circle(PI * i as f64 / 200.0).norm_sqr() / dc2).fold(1.0, f64::max);
        // The truncation error is relative to the series' l1 norm, which the
        // inverse's peak gain 1/min|B_o| can exceed: bound by both.
        let inverted: Vec<c64> = f.series_inverted_zeros().map(|z| z.zero).collect();
        let b_o = Poly::from_z_roots(&inverted, 1.0);
        let peak_inverse = (0..=400).map(|i| 1.0 / b_o.eval_unit_circle(PI * i as f64 / 400.0).norm()).fold(1.0, f64::max);
        let dc_o = b_o.sum().abs();
        for i in 0..=200 {
            let w = PI * i as f64 / 200.0;
            let p = f.response_at_omega(w) * g.response_at_omega(w);
            let expected = b_u.eval_unit_circle(w).norm_sqr() / dc2;
            let bound = 1e3 * tol * scale * peak_inverse * dc_o.max(1.0) * (1 + m) as f64;
            prop_assert!((p - expected).norm() <= bound, "w={} p={} expected={} bound={}", w, p, expected, bound);
        }
        let dc = f.response_at_omega(0.0) * g.response_at_omega(0.0);
        prop_assert!((dc.re - 1.0).abs() < 1e-9 && dc.im.abs() < 1e-12);
    }

    #[test]
    fn roots_accurate_to_their_condition_number(raw in prop::collection::vec((0.2f64..2.0, 0.1f64..PI - 0.1), 1..8)) {
        // Backward stability plus polishing: each root's error is bounded by
        // a modest multiple of eps times its condition number
        // kappa = sum_k |c_k| |r|^k / (|r| |p'(r)|) (Wilkinson), so the
        // tolerance is scaled by the problem, not picked by hand.
        let mut roots = Vec::new();
        for (i, (r, theta)) in raw.iter().enumerate() {
            let theta = theta + 0.37 * i as f64;
            roots.push(c64::from_polar(*r, theta));
            roots.push(c64::from_polar(*r, -theta));
        }
        let min_sep = roots.iter().enumerate().flat_map(|(i, a)| roots[i + 1..].iter().map(move |b| (a - b).norm())).fold(f64::INFINITY, f64::min);
        prop_assume!(min_sep > 1e-3);
        let p = Poly::from_z_roots(&roots, 1.0);
        // Descending coefficients in z: c_0 z^n + ... + c_n.
        let desc: Vec<f64> = p.coeffs().to_vec();
        let n = desc.len() - 1;
        let got = p.z_roots().unwrap();
        prop_assert_eq!(got.len(), roots.len());
        for e in &roots {
            let mut magnitude_sum = 0.0;
            let mut derivative = c64::new(0.0, 0.0);
            for (k, c) in desc.iter().enumerate() {
                let power = (n - k) as i32;
                magnitude_sum += c.abs() * e.norm().powi(power);
                if power > 0 {
                    derivative += *c * power as f64 * e.powi(power - 1);
                }
            }
            let kappa = magnitude_sum / (e.norm() * derivative.norm());
            let d = got.iter().map(|g| (g - e).norm()).fold(f64::INFINITY, f64::min);
            prop_assert!(d <= 100.0 * n as f64 * f64::EPSILON * kappa * e.norm() + 1e-15, "root {} missed by {} (kappa {})", e, d, kappa);
        }
    }
}

#[test]
fn roots_well_conditioned_to_1e12() {
    // Distinct real and complex roots of moderate size, degree 6.
    let roots = [
        c64::new(0.5, 0.0),
        c64::new(-0.3, 0.0),
        c64::new(0.2, 0.7),
        c64::new(0.2, -0.7),
        c64::new(-0.6, 0.4),
        c64::new(-0.6, -0.4),
    ];
    let got = Poly::from_z_roots(&roots, 3.0).z_roots().unwrap();
    for e in &roots {
        let d = got
            .iter()
            .map(|g| (g - e).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(d < 1e-12, "{e}: {d}");
    }
}

#[test]
fn roots_degree_fifty() {
    // 50 roots on three circles with distinct angles: the coefficients span
    // many orders of magnitude, which balancing must handle. Tolerance: the
    // roots of radius 1.2 of this degree-50 polynomial have a condition number
    // near 1e7 (Horner's rounding error grows like 1.2^50 ~ 9e3 times eps times
    // the coefficient norm), so 1e-8 is what any backward-stable method attains.
    let mut roots = Vec::new();
    for k in 0..25 {
        let r = [0.4, 0.8, 1.2][k % 3];
        let theta = PI * (k as f64 + 0.5) / 25.0;
        roots.push(c64::from_polar(r, theta));
        roots.push(c64::from_polar(r, -theta));
    }
    let p = Poly::from_z_roots(&roots, 1.0);
    assert_eq!(p.degree(), 50);
    let got = p.z_roots().unwrap();
    assert_eq!(got.len(), 50);
    let worst = roots
        .iter()
        .map(|e| {
            got.iter()
                .map(|g| (g - e).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    eprintln!("degree-50 worst root error {worst:e}");
    assert!(worst < 1e-8, "worst root error {worst}");
}
