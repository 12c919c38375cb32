//! Property tests: CARE / DARE / Lyapunov on random stabilisable systems.
//! Random Gaussian (A, B) are controllable with probability one, so the
//! stabilising solution exists; we require residual < 1e-10 (relative, the
//! acceptance bound of the test plan) and a stable closed loop.

use faer::Mat;
use fts::lti::lyapunov::{dlyap, lyap, sylvester};
use fts::lti::riccati::{care, dare};
use proptest::prelude::*;

fn mat(n: usize, m: usize, v: &[f64]) -> Mat<f64> {
    Mat::from_fn(n, m, |i, j| v[(i * m + j) % v.len()])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    #[test]
    fn care_random(n in 1usize..7, m in 1usize..3, v in prop::collection::vec(-2.0f64..2.0, 64),
                   w in prop::collection::vec(-1.0f64..1.0, 16)) {
        let a = mat(n, n, &v);
        let b = mat(n, m, &v[7..]);
        let c = mat(n, n, &w);
        let q = c.transpose() * &c + Mat::<f64>::identity(n, n) * 0.1;
        let r = Mat::<f64>::identity(m, m);
        match care(&a, &b, &q, &r, None) {
            Ok(s) => {
                prop_assert!(s.residual < 1e-10, "residual {}", s.residual);
                prop_assert!(s.closed_loop.iter().all(|l| l.re < 0.0));
            }
            // A non-generic draw (e.g. repeated rows making (A,B) uncontrollable
            // with an unstable mode) must be reported, never mis-solved.
            Err(e) => prop_assert!(e.to_string().contains("stabilising"), "{e}"),
        }
    }

    #[test]
    fn dare_random(n in 1usize..7, m in 1usize..3, v in prop::collection::vec(-1.5f64..1.5, 64)) {
        let a = mat(n, n, &v);
        let b = mat(n, m, &v[5..]);
        let q = Mat::<f64>::identity(n, n);
        let r = Mat::<f64>::identity(m, m) * 0.5;
        match dare(&a, &b, &q, &r, None) {
            Ok(s) => {
                prop_assert!(s.residual < 1e-10, "residual {}", s.residual);
                prop_assert!(s.closed_loop.iter().all(|l| l.norm() < 1.0));
            }
            Err(e) => prop_assert!(e.to_string().contains("stabilising"), "{e}"),
        }
    }

    #[test]
    fn lyapunov_random(n in 1usize..8, v in prop::collection::vec(-1.0f64..1.0, 64)) {
        // Shift to make A Hurwitz (continuous) or Schur (discrete).
        let a0 = mat(n, n, &v);
        let a = &a0 - Mat::<f64>::identity(n, n) * (n as f64 + 1.0);
        let q = Mat::<f64>::identity(n, n);
        let s = lyap(&a, &q).unwrap();
        prop_assert!(s.residual < 1e-12, "{}", s.residual);
        let ad = &a0 * (0.9 / (n as f64));
        let s = dlyap(&ad, &q).unwrap();
        prop_assert!(s.residual < 1e-12, "{}", s.residual);
        let s = sylvester(&a, &(&a0 * 0.1), &mat(n, n, &v[3..])).unwrap();
        prop_assert!(s.residual < 1e-12, "{}", s.residual);
    }
}
