//! Properties of the loop analysis on random loops (third-order plant with a
//! resonance, PI controller; continuous, and ZOH-discretised with the
//! \[Li21\] per-sample PI): what each margin claims holds when checked
//! through the state-space realisation, and scaling the controller by the
//! reported gain margin puts a closed-loop pole on the stability boundary.

use fts::lti::c2d::{C2dMethod, c2d};
use fts::lti::margins::{LoopParams, LoopSystem, analyze_loop};
use fts::lti::{ContinuousTf, DiscreteTf, TransferFunction, c64};
use proptest::prelude::*;

fn continuous(num: Vec<f64>, den: Vec<f64>) -> LoopSystem {
    LoopSystem::Tf(TransferFunction::Continuous(
        ContinuousTf::new(num, den).unwrap(),
    ))
}

/// `k0 a w^2 / ((s + a)(s^2 + 2 z w s + w^2))`.
fn plant(k0: f64, a: f64, w: f64, z: f64) -> LoopSystem {
    let den = [1.0, a + 2.0 * z * w, w * w + 2.0 * z * w * a, a * w * w];
    continuous(vec![k0 * a * w * w], den.to_vec())
}

fn check(g: &LoopSystem, k: &LoopSystem, scale_k: &dyn Fn(f64) -> LoopSystem) {
    let r = analyze_loop(g, k, &LoopParams::default()).unwrap();
    let (gs, ks) = (
        LoopSystem::Ss(g.to_ss().unwrap()),
        LoopSystem::Ss(k.to_ss().unwrap()),
    );
    let l = |f: f64| gs.response_at_hz(f) * ks.response_at_hz(f);
    for c in &r.gain_crossovers {
        assert!((l(c.freq_hz).norm() - 1.0).abs() < 1e-9, "{c:?}");
    }
    for p in &r.phase_crossovers {
        let v = l(p.freq_hz);
        assert!((v.arg().to_degrees().abs() - 180.0).abs() < 1e-7, "{p:?}");
        assert!((v.norm() * p.gain_margin - 1.0).abs() < 1e-9);
    }
    let mm = r.modulus_margin;
    assert!(((1.0 + l(mm.freq_hz)).norm() - mm.value).abs() < 1e-9 * mm.value.max(1.0));
    assert!((mm.value * r.peak_s.value - 1.0).abs() < 1e-12);
    // K * GM puts a closed-loop pole on the boundary (at the crossover).
    if let Some(gm) = r.gain_margin
        && gm.freq_hz > 0.0
        && gm.gain_margin < 1e6
    {
        let r2 = analyze_loop(g, &scale_k(gm.gain_margin), &LoopParams::default()).unwrap();
        let boundary = r2
            .closed_loop_poles
            .iter()
            .map(|p| {
                let p = c64::new(p[0], p[1]);
                match r.ts {
                    None => p.re.abs() / p.norm().max(1.0),
                    Some(_) => (p.norm() - 1.0).abs(),
                }
            })
            .fold(f64::INFINITY, f64::min);
        assert!(boundary < 1e-6, "GM {gm:?}: nearest pole {boundary}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn continuous_pi_loops(k0 in 0.2f64..5.0, a in 0.5f64..50.0, w in 1.0f64..100.0,
                           z in 0.02f64..0.7, kp in 0.05f64..3.0, ki in 0.0f64..5.0) {
        let g = plant(k0, a, w, z);
        let pi = |s: f64| if ki == 0.0 {
            continuous(vec![s * kp], vec![1.0])
        } else {
            continuous(vec![s * kp, s * ki], vec![1.0, 0.0])
        };
        check(&g, &pi(1.0), &pi);
    }

    #[test]
    fn discrete_pi_loops(k0 in 0.2f64..5.0, a in 0.5f64..50.0, w in 1.0f64..100.0,
                         z in 0.02f64..0.7, kp in 0.05f64..3.0, ki in 0.0f64..0.5,
                         per_decade in 20.0f64..200.0) {
        let LoopSystem::Tf(TransferFunction::Continuous(c)) = plant(k0, a, w, z) else { unreachable!() };
        let ss = fts::lti::StateSpace::from_continuous_tf(&c).unwrap();
        // Sampled well above the fastest pole: per_decade samples per radian.
        let ts = 1.0 / (per_decade * a.max(w));
        let g = LoopSystem::Ss(c2d(&ss, ts, C2dMethod::Zoh).unwrap());
        let pi = |s: f64| {
            let (num, den) = if ki == 0.0 {
                (vec![s * kp], vec![1.0])
            } else {
                (vec![s * (kp + ki), -s * kp], vec![1.0, -1.0])
            };
            LoopSystem::Tf(TransferFunction::Discrete(DiscreteTf::new(num, den, 0, ts).unwrap()))
        };
        check(&g, &pi(1.0), &pi);
    }
}
