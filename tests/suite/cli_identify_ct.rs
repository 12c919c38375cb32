//! `fts identify ct` and `fts identify ct-frd` on records made by scipy
//! (tests/data/ct-ident/generate.py): a Karagoz18-like Z axis, the paper's
//! Eq. 4 plant, driven by a multisine with 25 % output noise, and its
//! frequency response with 5 % complex noise. The truth is in
//! zaxis-truth.json; fts never saw it.

use assert_cmd::Command;
use fts::ident::ct::{CtModel, periodic_frf};
use fts::lti::c64;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn fts() -> Command {
    Command::cargo_bin("fts").unwrap()
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ct-ident")
        .join(name)
}

fn truth() -> CtModel {
    let t: Value =
        serde_json::from_str(&std::fs::read_to_string(data("zaxis-truth.json")).unwrap()).unwrap();
    let v = |k: &str| -> Vec<f64> {
        t[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    CtModel {
        num: v("num"),
        den: v("den"),
        delay: 0.0,
    }
}

fn json_of(cmd: &mut Command) -> Value {
    let out = cmd.assert().success().get_output().stdout.clone();
    serde_json::from_slice(&out).expect("one JSON object on stdout")
}

fn model_of(v: &Value) -> CtModel {
    let f = |k: &str| -> Vec<f64> {
        v[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
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
        .stderr(predicates::str::contains("unstable"));
}

#[test]
fn bad_orders_and_files_exit_2_naming_them() {
    fts()
        .args(["identify", "ct"])
        .arg(data("zaxis-multisine.csv"))
        .args(["--np", "1", "--nz", "2"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--nz"));
    fts()
        .args(["identify", "ct"])
        .arg(data("zaxis-multisine.csv"))
        .args(["--np", "2", "--nz", "1", "--delay", "-1"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--delay"));
    fts()
        .args(["identify", "ct-frd"])
        .arg(data("zaxis-truth.json"))
        .args(["--np", "2", "--nz", "1"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("zaxis-truth.json"));
}
