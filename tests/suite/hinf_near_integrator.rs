//! H-infinity mixed sensitivity with a near-integrating performance weight
//! (integral action): the DC servo `G = 11.2 / ((s + 0.12)(s + 1e-6))`,
//! `W_s = (s/1.5 + 20)/(s + p)`, `W_u = 1`, for weight poles `p` from
//! `1e-8` to `0.1` times the weight's bandwidth (20 rad/s). Compared with
//! SLICOT SB10AD's gammas (python-control's `mixsyn`, stored with their
//! generator in `tests/data/near_integrator/`): fts's bisection bound
//! agrees with them to 1e-5, and the controller fts returns achieves, by an
//! independent recomputation of the closed-loop norm, at most the bound
//! times `1 + 2 backoff` and never less than the bound allows (gamma
//! honest). With `p = 2e-7` the weight's Hamiltonian mode pair `+-p` once
//! made the filter Riccati solution's rounding (about `eps / p`) fail the
//! positive-semidefiniteness test, and fts reported 4.8032 (7.6 % above).

use fts::io::ss_json::parse_system;
use fts::lti::ss::StateSpace;
use fts::synth::hinf::{HinfOptions, closed_loop_norm};
use fts::synth::mixsyn::mixsyn;

fn tf(num: &[f64], den: &[f64]) -> StateSpace {
    let text = format!(r#"{{"format": "fts.tf/1", "var": "s", "num": {num:?}, "den": {den:?}}}"#);
    parse_system(&text, "tf").unwrap()
}

fn references() -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/near_integrator/sb10ad.csv"
    ))
    .unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let (p, g) = l.split_once(',').unwrap();
            (p.parse().unwrap(), g.parse().unwrap())
        })
        .collect()
}

#[test]
fn near_integrating_weights_reach_sb10ad_gamma() {
    let g = tf(&[11.2], &[1.0, 0.12 + 1e-6, 0.12e-6]);
    let wu = tf(&[1.0], &[1.0]);
    let refs = references();
    assert_eq!(refs.len(), 8);
    for (p, gamma_sb10ad) in refs {
        let ws = tf(&[1.0 / 1.5, 20.0], &[1.0, p]);
        let opts = HinfOptions::default();
        let (augmented, r) = mixsyn(&g, Some(&ws), Some(&wu), None, opts).unwrap();
        let achieved = closed_loop_norm(&augmented.lft(&r.k).unwrap());
        println!(
            "p {p:e}: bound {:.10}, achieved {achieved:.10}, SB10AD {gamma_sb10ad:.10}",
            r.bisection_bound
        );
        assert!(r.stable, "p {p}");
        assert!(
            (r.bisection_bound / gamma_sb10ad - 1.0).abs() < 1e-5,
            "p {p}: bound {} vs SB10AD {gamma_sb10ad}",
            r.bisection_bound
        );
        assert!((achieved / r.gamma - 1.0).abs() < 1e-6, "p {p}");
        assert!(
            achieved <= r.bisection_bound * (1.0 + 2.0 * opts.backoff),
            "p {p}"
        );
        // The bound is within rtol above the optimum; no controller beats it.
        assert!(achieved >= r.bisection_bound * (1.0 - opts.rtol), "p {p}");
        // Designed at SB10AD's gamma plus 1e-3: a controller that meets it
        // to within the backoff (with a near-integrator the central
        // controller misses its own level by up to 1e-5; the report warns).
        let level = gamma_sb10ad * (1.0 + 1e-3);
        let at = HinfOptions {
            gamma: Some(level),
            ..opts
        };
        let (augmented, r) = mixsyn(&g, Some(&ws), Some(&wu), None, at).unwrap();
        let achieved = closed_loop_norm(&augmented.lft(&r.k).unwrap());
        assert!(
            achieved <= level * (1.0 + opts.backoff),
            "p {p}: {achieved} at {level}"
        );
        assert!((achieved / r.gamma - 1.0).abs() < 1e-6, "p {p}");
    }
}
