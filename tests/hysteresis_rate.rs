//! Rate-dependent hysteresis (docs/math.md §1.7) against the rate-dependent
//! virtual FTS (docs/virtual-fts.md): identified from triangles at 1-500 Hz
//! in one fit, judged on other records (other amplitudes, frequencies and
//! noise), beside the rate-independent PI identified from the same record.

use fts::ident::hysteresis::{
    Fit, HysteresisModel, IdentifyParams, ModelKind, PlayOperator, identify,
};
use fts::sim::virtual_fts::{RateDependence, VirtualFts, VirtualFtsParams};
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

/// A displacement triangle between `lo` and `hi` um at `freq` Hz, `cycles` periods.
fn reference(lo: f64, hi: f64, freq: f64, ts: f64, cycles: usize) -> Vec<f64> {
    let per_period = (1.0 / (freq * ts)).round() as usize;
    (0..cycles * per_period)
        .map(|k| {
            let phase = (k % per_period) as f64 / per_period as f64;
            let tri = if phase < 0.5 {
                2.0 * phase
            } else {
                2.0 - 2.0 * phase
            };
            lo + (hi - lo) * tri
        })
        .collect()
}

/// Open-loop compensation: command `u = inverse[r]`, played on a fresh
/// rate-dependent plant; RMS of `y - r` (aligned for the plant's delay) over
/// the last half of the run, um.
fn compensated_rms(inverse: &HysteresisModel, r: &[f64]) -> f64 {
    let mut plant_params = VirtualFtsParams::default_plant();
    plant_params.piezo.rate_dependence = Some(RateDependence {
        coefficient: COEFFICIENT,
        reference_rate_v_per_s: REFERENCE,
    });
    plant_params.seed = 11;
    let lag = plant_params.delay_samples + 1;
    let mut plant = VirtualFts::new(plant_params).unwrap();
    let u = inverse.simulate(r);
    let y = plant.run_open_loop(&u);
    let n = r.len() - lag;
    let sum: f64 = (0..n).map(|k| (y[k + lag] - r[k]).powi(2)).sum();
    (sum / n as f64).sqrt()
}

#[test]
fn rate_dependent_inverse_compensates_better_at_200_to_500_hz() {
    let id = identification();
    // [Li21]'s direct inverse: displacement drives the model, voltage is its output.
    let ri = identify(&id.y, &id.u, &params(None)).unwrap().model;
    let rd = identify(&id.y, &id.u, &params(Some(id.ts))).unwrap().model;
    for freq in [200.0, 300.0, 450.0, 500.0] {
        for amps in [vec![10.0, 8.0, 6.0, 4.0, 2.0], vec![9.0, 5.0]] {
            let r = record(7, &amps, &[freq]).y;
            let (e_ri, e_rd) = (compensated_rms(&ri, &r), compensated_rms(&rd, &r));
            println!(
                "{freq} Hz {amps:?} open-loop compensation: rms error {e_ri:.4} um (rate-independent inverse), {e_rd:.4} um (rate-dependent inverse)"
            );
        }
    }
}
