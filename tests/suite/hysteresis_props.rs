//! Properties of the play operators and PI models that must hold for every
//! input (proptest).

use fts::ident::hysteresis::operators::{PlayOperator, play_into};
use fts::ident::hysteresis::{DeadZoneStage, HysteresisModel, ModelKind, analytic_inverse};
use proptest::prelude::*;

/// Round-trip tolerance: 1e-9 of the 16-unit range of the test signals.
const ROUND_TRIP_TOL: f64 = 1e-9 * 16.0;

fn operator() -> impl Strategy<Value = PlayOperator> {
    prop_oneof![Just(PlayOperator::Lower), Just(PlayOperator::Symmetric)]
}

/// Turning points of a signal: a sequence whose consecutive differences are
/// non-zero (any direction).
fn turning_points() -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(-10.0f64..10.0, 2..25)
}

/// Positive first weight and weights whose partial sums stay positive: an
/// invertible PI model, thresholds strictly increasing from 0.
fn invertible_pi() -> impl Strategy<Value = HysteresisModel> {
    (1usize..8)
        .prop_flat_map(|n| {
            (
                prop::collection::vec(0.05f64..2.0, n),
                prop::collection::vec(0.1f64..1.5, n),
                prop::collection::vec(-0.9f64..1.0, n),
                -2.0f64..2.0,
            )
        })
        .prop_map(|(gaps, w0s, fractions, offset)| {
            // r_0 = 0, r_i = r_{i-1} + gap; w_i = f_i * W_{i-1} keeps
            // W_i = W_{i-1} (1 + f_i) > 0 for f_i > -1.
            let n = gaps.len();
            let mut thresholds = vec![0.0];
            for g in &gaps[..n - 1] {
                let last = *thresholds.last().unwrap();
                thresholds.push(last + g);
            }
            let mut weights = vec![w0s[0]];
            let mut partial = w0s[0];
            for f in &fractions[1..] {
                let w = f * partial;
                weights.push(w);
                partial += w;
            }
            HysteresisModel {
                kind: ModelKind::Pi,
                operator: PlayOperator::Symmetric,
                thresholds,
                weights,
                cbrt_gain: 0.0,
                offset,
                input_offset: 0.0,
                dead_zone: None,
                input_dead_zone: None,
                rate: None,
            }
        })
}

/// `n` break points from 0 with the given gaps, and weights whose partial
/// sums stay positive (`w_i = f_i W_{i-1}`, `f_i > -1`).
fn positive_slopes(gaps: &[f64], w0: f64, fractions: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut breaks = vec![0.0];
    for g in &gaps[..gaps.len() - 1] {
        let last = *breaks.last().unwrap();
        breaks.push(last + g);
    }
    let mut weights = vec![w0];
    let mut partial = w0;
    for f in &fractions[1..] {
        let w = f * partial;
        weights.push(w);
        partial += w;
    }
    (breaks, weights)
}

/// An invertible MPI-deadzone model (\[Tang17\] Eq. 40-43): an invertible PI
/// stage, then a dead-zone stage with `d_0 = 0` and positive partial sums
/// `G_j`, its break points inside the PI stage's output range.
fn invertible_mpi_deadzone() -> impl Strategy<Value = HysteresisModel> {
    (invertible_pi(), 1usize..5)
        .prop_flat_map(|(pi, m)| {
            (
                Just(pi),
                prop::collection::vec(0.2f64..2.5, m),
                0.2f64..2.0,
                prop::collection::vec(-0.8f64..1.5, m),
                -3.0f64..3.0,
            )
        })
        .prop_map(|(pi, gaps, g0, fractions, input_offset)| {
            let (thresholds, weights) = positive_slopes(&gaps, g0, &fractions);
            HysteresisModel {
                kind: ModelKind::MpiDeadzone,
                dead_zone: Some(DeadZoneStage {
                    thresholds,
                    weights,
                }),
                input_offset,
                ..pi
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// The output stays in its band: `[u - r, u]` (lower) or `[u - r, u + r]`
    /// (symmetric), from the first sample on (math.md 1.1).
    #[test]
    fn play_output_stays_in_band(
        op in operator(),
        r in 0.0f64..5.0,
        u in prop::collection::vec(-10.0f64..10.0, 1..200),
    ) {
        let mut out = vec![0.0; u.len()];
        play_into(op, r, &u, &mut out);
        for (k, (&x, &f)) in u.iter().zip(&out).enumerate() {
            let (lo, hi) = op.band(r, x);
            prop_assert!(f >= lo && f <= hi, "k={k}: {f} outside [{lo}, {hi}]");
        }
    }

    /// Rate independence: refining the monotone segments between turning
    /// points (any number of intermediate samples, unevenly spaced) does not
    /// change the output at the turning points. Exact equality: on a monotone
    /// segment the output is max(u - r, min(u + r_up, F)) of its end point.
    #[test]
    fn play_is_rate_independent(
        op in operator(),
        r in 0.0f64..5.0,
        points in turning_points(),
        refine in prop::collection::vec(0usize..12, 24),
        spacing in 0.05f64..0.95,
    ) {
        let mut coarse = vec![0.0; points.len()];
        play_into(op, r, &points, &mut coarse);
        // Resample: between points[i-1] and points[i] insert refine[i] samples
        // at uneven fractions (a geometric-ish spacing).
        let mut fine = vec![points[0]];
        let mut at_turn = vec![0];
        for i in 1..points.len() {
            let (a, b) = (points[i - 1], points[i]);
            let m = refine[i % refine.len()];
            let mut t = 0.0;
            for _ in 0..m {
                t += (1.0 - t) * spacing;
                fine.push(a + (b - a) * t);
            }
            fine.push(b);
            at_turn.push(fine.len() - 1);
        }
        let mut fine_out = vec![0.0; fine.len()];
        play_into(op, r, &fine, &mut fine_out);
        for (i, &k) in at_turn.iter().enumerate() {
            prop_assert_eq!(fine_out[k], coarse[i], "turning point {}", i);
        }
    }

    /// `inverse(forward(u)) = u` for invertible PI models (analytic inverse,
    /// math.md 1.6). Tolerance 1e-9 relative to the signal range: the inverse
    /// is exact in exact arithmetic; round-off grows with the number of
    /// operators and the spread of weights, ~1e-13 here.
    #[test]
    fn analytic_inverse_undoes_forward(
        model in invertible_pi(),
        u in prop::collection::vec(-8.0f64..8.0, 1..150),
    ) {
        let inverse = analytic_inverse(&model).unwrap();
        let back = inverse.simulate(&model.simulate(&u));
        for (k, (a, b)) in back.iter().zip(&u).enumerate() {
            prop_assert!((a - b).abs() < ROUND_TRIP_TOL, "k={}: {} vs {}", k, a, b);
        }
    }

    /// The analytic inverse's parameters equal the direct formula of
    /// math.md 1.6, computed here independently from its definition:
    /// `r'_i = sum_{j<=i} w_j (r_i - r_j)`, `w'_0 = 1/w_0`,
    /// `w'_i = -w_i / (W_i W_{i-1})`. And `forward(inverse(y)) = y` too.
    #[test]
    fn analytic_inverse_matches_formula(
        model in invertible_pi(),
        y in prop::collection::vec(-8.0f64..8.0, 1..100),
    ) {
        let inverse = analytic_inverse(&model).unwrap();
        let (r, w) = (&model.thresholds, &model.weights);
        let n = r.len();
        let mut big_w = vec![0.0; n];
        let mut acc = 0.0;
        for i in 0..n {
            acc += w[i];
            big_w[i] = acc;
        }
        for i in 0..n {
            let mut ri = 0.0;
            for j in 0..=i {
                ri += w[j] * (r[i] - r[j]);
            }
            let wi = if i == 0 { 1.0 / w[0] } else { -w[i] / (big_w[i] * big_w[i - 1]) };
            prop_assert!((inverse.thresholds[i] - ri).abs() <= 1e-12 * (1.0 + ri.abs()));
            prop_assert!((inverse.weights[i] - wi).abs() <= 1e-12 * (1.0 + wi.abs()));
        }
        let again = model.simulate(&inverse.simulate(&y));
        for (a, b) in again.iter().zip(&y) {
            prop_assert!((a - b).abs() < ROUND_TRIP_TOL);
        }
    }

    /// MPI-deadzone inverts analytically to a PI model with an input
    /// dead-zone stage (math.md 1.6): `inverse(forward(u)) = u` and
    /// `forward(inverse(y)) = y`, and inverting the inverse gives back the
    /// forward model's parameters.
    #[test]
    fn mpi_deadzone_inverse_undoes_forward(
        model in invertible_mpi_deadzone(),
        u in prop::collection::vec(-8.0f64..8.0, 1..150),
    ) {
        model.validate().unwrap();
        let inverse = analytic_inverse(&model).unwrap();
        inverse.validate().unwrap();
        prop_assert_eq!(inverse.kind, ModelKind::Pi);
        prop_assert!(inverse.input_dead_zone.is_some() && inverse.dead_zone.is_none());
        let back = inverse.simulate(&model.simulate(&u));
        for (k, (a, b)) in back.iter().zip(&u).enumerate() {
            prop_assert!((a - b).abs() < ROUND_TRIP_TOL, "k={}: {} vs {}", k, a, b);
        }
        let y = model.simulate(&u);
        let again = model.simulate(&inverse.simulate(&y));
        for (a, b) in again.iter().zip(&y) {
            prop_assert!((a - b).abs() < ROUND_TRIP_TOL);
        }
        let twice = analytic_inverse(&inverse).unwrap();
        prop_assert_eq!(twice.kind, ModelKind::MpiDeadzone);
        let close = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * (1.0 + y.abs()))
        };
        let (dz, dz2) = (model.dead_zone.as_ref().unwrap(), twice.dead_zone.as_ref().unwrap());
        prop_assert!(close(&twice.thresholds, &model.thresholds));
        prop_assert!(close(&twice.weights, &model.weights));
        prop_assert!(close(&dz2.thresholds, &dz.thresholds));
        prop_assert!(close(&dz2.weights, &dz.weights));
        prop_assert_eq!((twice.offset, twice.input_offset), (model.offset, model.input_offset));
    }
}
