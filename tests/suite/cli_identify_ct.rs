//! `fts identify ct` and `fts identify ct-frd` on records made by scipy
//! (tests/data/ct-ident/generate.py): a Karagoz18-like Z axis, the paper's
//! Eq. 4 plant, driven by a multisine with 25 % output noise, and its
//! frequency response with 5 % complex noise. The truth is in
//! zaxis-truth.json; fts never saw it.

use crate::common::cmd::{fts, json_of, predicate};
use fts::ident::ct::{CtModel, periodic_frf};
use fts::lti::c64;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ct-ident")
        .join(name)
}

/// The numbers of a JSON array field.
fn floats(v: &Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("no array `{key}`"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn truth() -> CtModel {
    let t: Value =
        serde_json::from_str(&std::fs::read_to_string(data("zaxis-truth.json")).unwrap()).unwrap();
    let v = |k: &str| floats(&t, k);
    CtModel {
        num: v("num"),
        den: v("den"),
        delay: 0.0,
    }
}

fn model_of(v: &Value) -> CtModel {
    let f = |k: &str| floats(v, k);
    CtModel {
        num: f("num"),
        den: f("den"),
        delay: v["delay_s"].as_f64().unwrap(),
    }
}

/// `t,u,y` columns of the stored record.
fn record() -> (Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(data("zaxis-multisine.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (c[1], c[2])
        })
        .unzip()
}

fn lightly_damped_pole(m: &CtModel) -> c64 {
    *m.poles()
        .iter()
        .find(|p| p.im > 0.0)
        .expect("a complex pair")
}

/// SRIVC on the noisy record: the resonance and the DC gain within 1 % of
/// the truth, and both fits at least those of the true plant on the same
/// noisy data less 0.5 points (the true plant is the noise-limited benchmark).
#[test]
fn srivc_on_the_noisy_multisine_record_matches_the_true_plant() {
    let v = json_of(
        fts()
            .args(["identify", "ct"])
            .arg(data("zaxis-multisine.csv"))
            .args([
                "--np",
                "3",
                "--nz",
                "1",
                "--period",
                "10",
                "--skip-periods",
                "2",
                "--json",
            ]),
    );
    let est = model_of(&v);
    let g = truth();
    let (pe, pt) = (lightly_damped_pole(&est), lightly_damped_pole(&g));
    assert!(
        (pe - pt).norm() < 0.01 * pt.norm(),
        "resonance {pe} vs {pt}"
    );
    let dc = |m: &CtModel| m.num[1] / m.den[3];
    assert!(
        (dc(&est) / dc(&g) - 1.0).abs() < 0.01,
        "DC gain {} vs {}",
        dc(&est),
        dc(&g)
    );
    let (u, y) = record();
    let ts = 0.002;
    let true_time_fit = fts::ident::ct::time_fit_percent(&g, &u, &y, ts);
    let frf = periodic_frf(&u, &y, ts, 5000, 2).unwrap();
    let fit_of = |m: &CtModel| {
        let r: Vec<c64> = frf
            .freq_hz
            .iter()
            .map(|f| m.zoh_response_at_hz(*f, ts))
            .collect();
        let mean = frf.response.iter().sum::<c64>() / frf.response.len() as f64;
        let err: f64 = frf
            .response
            .iter()
            .zip(&r)
            .map(|(a, b)| (a - b).norm_sqr())
            .sum();
        let dev: f64 = frf.response.iter().map(|a| (a - mean).norm_sqr()).sum();
        100.0 * (1.0 - (err / dev).sqrt())
    };
    let time_fit = v["time_fit_percent"].as_f64().unwrap();
    let freq_fit = v["freq_fit_percent"].as_f64().unwrap();
    assert!(
        time_fit > true_time_fit - 0.5,
        "time fit {time_fit} vs the true plant's {true_time_fit}"
    );
    assert!(
        (freq_fit - fit_of(&est)).abs() < 1e-9,
        "reported {freq_fit}"
    );
    assert!(
        freq_fit > fit_of(&g) - 0.5,
        "frequency fit {freq_fit} vs the true plant's {}",
        fit_of(&g)
    );
    assert_eq!(v["stable"], true);
    assert_eq!(v["converged"], true);
}

/// Relative weighting recovers every pole within 1 %; the uniform cost,
/// blind to the small high-frequency response, runs a pole off to the right
/// half plane, and that is reported and exits 1.
#[test]
fn ct_frd_with_relative_weighting_recovers_every_pole() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("bode.svg");
    let v = json_of(
        fts()
            .args(["identify", "ct-frd"])
            .arg(data("zaxis-frd.csv"))
            .args([
                "--np",
                "3",
                "--nz",
                "1",
                "--weighting",
                "relative",
                "--json",
                "--plot",
            ])
            .arg(&svg),
    );
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    let est = model_of(&v);
    let mut pe = est.poles();
    let mut pt = truth().poles();
    for p in [&mut pe, &mut pt] {
        p.sort_by(|a, b| {
            a.re.partial_cmp(&b.re)
                .unwrap()
                .then(a.im.partial_cmp(&b.im).unwrap())
        });
    }
    for (a, b) in pe.iter().zip(&pt) {
        assert!((a - b).norm() < 0.01 * b.norm(), "pole {a} vs {b}");
    }
    fts()
        .args(["identify", "ct-frd"])
        .arg(data("zaxis-frd.csv"))
        .args(["--np", "3", "--nz", "1"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("unstable"));
}

#[test]
fn bad_orders_and_files_exit_2_naming_them() {
    fts()
        .args(["identify", "ct"])
        .arg(data("zaxis-multisine.csv"))
        .args(["--np", "1", "--nz", "2"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--nz"));
    fts()
        .args(["identify", "ct"])
        .arg(data("zaxis-multisine.csv"))
        .args(["--np", "2", "--nz", "1", "--delay", "-1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--delay"));
    fts()
        .args(["identify", "ct-frd"])
        .arg(data("zaxis-truth.json"))
        .args(["--np", "2", "--nz", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("zaxis-truth.json"));
}

/// Median relative error of a `fts bode --json` estimate against the true
/// plant's zero-order-hold response, over its lines below `fmax` Hz.
fn median_error_against_truth(v: &Value, fmax: f64) -> f64 {
    let (g, ts) = (truth(), 0.002);
    let f = |k: &str| floats(v, k);
    let (freq, mag, phase) = (f("freq_hz"), f("magnitude"), f("phase_deg"));
    let mut errors: Vec<f64> = (0..freq.len())
        .filter(|&i| freq[i] > 0.0 && freq[i] <= fmax)
        .map(|i| {
            let estimate = c64::from_polar(mag[i], phase[i].to_radians());
            let true_value = g.zoh_response_at_hz(freq[i], ts);
            (estimate - true_value).norm() / true_value.norm()
        })
        .collect();
    assert!(errors.len() >= 10, "{} lines below {fmax} Hz", errors.len());
    errors.sort_by(f64::total_cmp);
    errors[errors.len() / 2]
}

/// The multisine record repeats every 10 s: `fts bode` finds the period
/// without being told, averages the 3 whole periods after the first, and
/// at the excited lines lands nearer the true plant than Welch's estimate
/// of the same record, which leaks the lines into their neighbours
/// (median relative error 0.07 against 0.22 below 3 Hz).
#[test]
fn bode_averages_a_repeating_record_over_the_period_it_finds() {
    let record = data("zaxis-multisine.csv");
    let periodic = json_of(fts().arg("bode").arg(&record).arg("--json"));
    assert_eq!(periodic["method"], "periodic");
    assert_eq!(periodic["segment_len"], 5000);
    assert_eq!(periodic["segments"], 3);
    let welch = json_of(
        fts()
            .arg("bode")
            .arg(&record)
            .args(["--method", "welch", "--json"]),
    );
    assert_eq!(welch["method"], "welch");
    // Below 3 Hz the plant's output stands above the 25 % noise (above it,
    // three periods average too little for either estimate).
    let fmax = 3.0;
    let (e_periodic, e_welch) = (
        median_error_against_truth(&periodic, fmax),
        median_error_against_truth(&welch, fmax),
    );
    assert!(
        e_periodic < 0.1 && e_periodic < 0.5 * e_welch,
        "median relative error: period average {e_periodic:.4}, Welch {e_welch:.4}"
    );
    // Told the period, it agrees with what it found; a period that is not
    // a whole number of samples is refused naming the option.
    let told = json_of(
        fts()
            .arg("bode")
            .arg(&record)
            .args(["--period", "10", "--json"]),
    );
    assert_eq!(told["magnitude"], periodic["magnitude"]);
    fts()
        .arg("bode")
        .arg(&record)
        .args(["--period", "10.001"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--period"));
    // The identification plot says which estimate it drew.
    let dir = tempfile::tempdir().unwrap();
    fts()
        .args([
            "identify", "arx", "--na", "2", "--nb", "2", "--nk", "1", "--plot",
        ])
        .arg(dir.path().join("bode.png"))
        .arg(&record)
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "average of 3 periods x 5000 samples (period found in the input)",
        ));
}
