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
