//! Rate-dependent hysteresis (docs/math.md §1.7) against the rate-dependent
//! virtual FTS (docs/virtual-fts.md): identified from triangles at 1-500 Hz
//! in one fit, judged on other records (other amplitudes, frequencies and
//! noise), beside the rate-independent PI identified from the same record.
//! The simulated records and the model's own step/simulate agreement are in
//! the unit tests of `sim::virtual_fts` and `ident::hysteresis::model`.

use fts::ident::hysteresis::{
    Fit, HysteresisModel, IdentifyParams, ModelKind, PlayOperator, identify,
};
use fts::workflow::{VirtualRecord, VirtualTriangles};

/// The rate dependence of these tests: the loop's `alpha` doubles at 1e5 V/s
/// (a full-stroke 500 Hz triangle of the amplifier's 0-100 V).
const COEFFICIENT: f64 = 1.0;
const REFERENCE: f64 = 1e5;

fn record(seed: u64, amplitudes: &[f64], freqs: &[f64]) -> VirtualRecord {
    VirtualTriangles {
        seed,
        amplitudes: amplitudes.to_vec(),
        freq: freqs.to_vec(),
        rate_coefficient: COEFFICIENT,
        rate_reference: REFERENCE,
    }
    .run()
    .expect("valid settings")
}

/// The identification record: 1 to 500 Hz, three amplitudes, seed 1.
fn identification() -> VirtualRecord {
    record(
        1,
        &[10.0, 8.0, 6.0, 4.0, 2.0],
        &[1.0, 10.0, 50.0, 100.0, 200.0, 500.0],
    )
}

fn params(rate: Option<f64>) -> IdentifyParams {
    IdentifyParams {
        kind: ModelKind::Pi,
        operator: Some(PlayOperator::Lower),
        rate_ts: rate,
        ..IdentifyParams::default()
    }
}

fn fit(model: &HysteresisModel, u: &[f64], y: &[f64]) -> Fit {
    Fit::of(&model.simulate(u), y).expect("same lengths, y moves")
}

#[test]
fn rate_dependent_pi_fits_high_frequency_records_better() {
    let id = identification();
    let ri = identify(&id.u, &id.y, &params(None)).unwrap().model;
    let rd = identify(&id.u, &id.y, &params(Some(id.ts))).unwrap().model;
    assert!(ri.rate.is_none() && rd.rate.is_some());
    // Validation: other amplitudes, frequencies inside and at the top of the
    // band, another noise seed.
    for freq in [300.0, 450.0] {
        let val = record(7, &[9.0, 5.0], &[freq]);
        let (e_ri, e_rd) = (fit(&ri, &val.u, &val.y), fit(&rd, &val.u, &val.y));
        println!(
            "{freq} Hz validation: rate-independent PI rms {:.3} % max {:.3} %, rate-dependent PI rms {:.3} % max {:.3} %",
            e_ri.rms_percent, e_ri.max_percent, e_rd.rms_percent, e_rd.max_percent
        );
        assert!(
            e_rd.rms_percent < 0.8 * e_ri.rms_percent,
            "{freq} Hz: rate-dependent {} % against rate-independent {} %",
            e_rd.rms_percent,
            e_ri.rms_percent
        );
    }
    // At 2 Hz (quasi-static) the rate terms vanish: both fit alike.
    let slow = record(7, &[9.0, 5.0], &[2.0]);
    let (e_ri, e_rd) = (fit(&ri, &slow.u, &slow.y), fit(&rd, &slow.u, &slow.y));
    println!(
        "2 Hz validation: rate-independent rms {:.3} %, rate-dependent rms {:.3} %",
        e_ri.rms_percent, e_rd.rms_percent
    );
    assert!(e_rd.rms_percent < 1.5 * e_ri.rms_percent);
}

/// The regression of §1.7 recovers a rate-dependent model from its own
/// output: triangles at several rates (so `|s|` varies), weights, rate
/// weights and velocity gain to round-off; the rate-independent fit of the
/// same data cannot.
#[test]
fn exact_recovery_of_a_rate_dependent_model() {
    use fts::ident::hysteresis::RateStage;
    use fts::ident::hysteresis::operators::uniform_thresholds;
    let ts = 1e-4;
    let mut u = vec![0.0];
    for (amplitude, per_leg) in [(8.0, 400), (5.0, 40), (9.0, 13), (3.0, 200), (7.0, 25)] {
        for target in [amplitude, -amplitude, 0.0] {
            let last = *u.last().unwrap();
            for k in 1..=per_leg {
                u.push(last + (target - last) * k as f64 / per_leg as f64);
            }
        }
    }
    let scale = u
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0f64, f64::max)
        / ts;
    let n = 6;
    let truth = HysteresisModel {
        kind: ModelKind::MpiCbrt,
        operator: PlayOperator::Lower,
        thresholds: uniform_thresholds(n, 9.0),
        weights: vec![0.9, 0.2, -0.1, 0.15, 0.05, 0.1],
        cbrt_gain: -0.2,
        offset: 0.4,
        input_offset: 0.0,
        dead_zone: None,
        input_dead_zone: None,
        rate: Some(RateStage {
            ts,
            rate_scale: scale,
            weights: vec![0.3, -0.1, 0.2, 0.05, -0.05, 0.1],
            velocity_gain: -0.25,
        }),
    };
    let y = truth.simulate(&u);
    let p = IdentifyParams {
        kind: ModelKind::MpiCbrt,
        operator: Some(PlayOperator::Lower),
        operators: n,
        rate_ts: Some(ts),
        ..IdentifyParams::default()
    };
    let found = identify(&u, &y, &p).unwrap().model;
    let rate = found.rate.as_ref().unwrap();
    let truth_rate = truth.rate.as_ref().unwrap();
    assert!((rate.rate_scale - scale).abs() <= 1e-12 * scale);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    for (a, b) in found.weights.iter().zip(&truth.weights) {
        assert!(close(*a, *b), "w {a} vs {b}");
    }
    for (a, b) in rate.weights.iter().zip(&truth_rate.weights) {
        assert!(close(*a, *b), "w1 {a} vs {b}");
    }
    assert!(close(rate.velocity_gain, truth_rate.velocity_gain));
    assert!(close(found.cbrt_gain, truth.cbrt_gain) && close(found.offset, truth.offset));
    let static_fit = identify(&u, &y, &IdentifyParams { rate_ts: None, ..p })
        .unwrap()
        .info
        .fit;
    assert!(static_fit.rms_percent > 0.1, "{static_fit:?}");
}
