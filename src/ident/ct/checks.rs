//! Recovery of known continuous systems. The records are made by
//! `lti::c2d` (ZOH, Van Loan) and a state-space loop, a path independent of
//! the estimator's own `zoh` module; the multisine is `fts excite multisine`'s.

use super::*;
use crate::ident::excite::{MultisineParams, multisine};
use crate::ident::testutil::noise;
use crate::lti::StateSpace;
use crate::lti::c2d::{C2dMethod, c2d};
use std::f64::consts::PI;

/// A third-order FTS-like axis: a 600 Hz resonance (damping 0.15), a real
/// pole at 1.5 kHz and a zero at 3 kHz, DC gain 2:
/// `G = 2 w^2 p (s/z + 1) / ((s^2 + 2 zeta w s + w^2)(s + p))`.
fn third_order() -> CtModel {
    let (w, zeta, p, z) = (2.0 * PI * 600.0, 0.15, 2.0 * PI * 1500.0, 2.0 * PI * 3000.0);
    let k = 2.0 * w * w * p;
    CtModel {
        num: vec![k / z, k],
        den: vec![
            1.0,
            2.0 * zeta * w + p,
            w * w + 2.0 * zeta * w * p,
            w * w * p,
        ],
        delay: 0.0,
    }
}

const TS: f64 = 1e-4;

/// Schroeder multisine, lines every 10 Hz from 10 Hz to 2 kHz.
fn excitation(periods: usize) -> Vec<f64> {
    let p = MultisineParams {
        freqs_hz: (1..=200).map(|i| 10.0 * i as f64).collect(),
        period: 0.1,
        periods,
        amplitude: 1.0,
        offset: 0.0,
        ts: TS,
    };
    multisine(&p).unwrap().0
}

/// ZOH-sampled output of the model, delayed by `delay_samples`, through
/// `c2d` and a state-space recursion.
fn record(g: &CtModel, u: &[f64], delay_samples: usize) -> Vec<f64> {
    record_at(g, u, delay_samples, TS)
}

fn record_at(g: &CtModel, u: &[f64], delay_samples: usize, ts: f64) -> Vec<f64> {
    let ss = StateSpace::from_continuous_tf(&g.tf().unwrap()).unwrap();
    let d = c2d(&ss, ts, C2dMethod::Zoh).unwrap();
    let n = d.nx();
    let mut x = vec![0.0; n];
    let mut y = Vec::with_capacity(u.len());
    for k in 0..u.len() {
        let uk = if k >= delay_samples {
            u[k - delay_samples]
        } else {
            0.0
        };
        y.push((0..n).map(|i| d.c[(0, i)] * x[i]).sum::<f64>() + d.d[(0, 0)] * uk);
        x = (0..n)
            .map(|i| (0..n).map(|j| d.a[(i, j)] * x[j]).sum::<f64>() + d.b[(i, 0)] * uk)
            .collect();
    }
    y
}

fn max_rel_coeff_error(est: &CtModel, truth: &CtModel) -> f64 {
    let rel = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| ((x - y) / y).abs())
            .fold(0.0, f64::max)
    };
    rel(&est.num, &truth.num).max(rel(&est.den, &truth.den))
}

/// Largest relative error of the frequency response over 10 Hz..2 kHz.
fn max_rel_response_error(est: &CtModel, truth: &CtModel) -> f64 {
    (1..=200)
        .map(|i| {
            let f = 10.0 * i as f64;
            let g = truth.response_at_hz(f);
            (est.response_at_hz(f) - g).norm() / g.norm()
        })
        .fold(0.0, f64::max)
}

pub fn srivc_recovers_a_third_order_system_from_noise_free_multisine_data() {
    let g = third_order();
    let u = excitation(3);
    let y = record(&g, &u, 0);
    let est = srivc(&u, &y, &SrivcParams::new(3, 1, TS)).unwrap();
    let err = max_rel_coeff_error(&est.model, &g);
    assert!(err < 1e-6, "coefficient error {err:e}: {:?}", est.model);
    assert!(est.converged && est.fit_percent > 99.9999, "{est:?}");
}

pub fn srivc_recovers_a_whole_sample_input_delay() {
    let mut g = third_order();
    let u = excitation(3);
    let y = record(&g, &u, 3);
    g.delay = 3.0 * TS;
    let mut p = SrivcParams::new(3, 1, TS);
    p.delay = g.delay;
    let est = srivc(&u, &y, &p).unwrap();
    let err = max_rel_coeff_error(&est.model, &g);
    assert!(err < 1e-6, "coefficient error {err:e}");
}

/// A delay of 2.3 samples: the record is simulated on a grid ten times
/// finer (input held over each coarse sample, delay 23 fine samples) and
/// decimated, so the fractional delay is exact without the estimator's
/// own delayed discretisation.
pub fn srivc_recovers_a_fractional_input_delay() {
    let mut g = third_order();
    let u = excitation(3);
    let fine_u: Vec<f64> = u.iter().flat_map(|v| std::iter::repeat_n(*v, 10)).collect();
    let fine_y = record_at(&g, &fine_u, 23, TS / 10.0);
    let y: Vec<f64> = fine_y.iter().step_by(10).copied().collect();
    g.delay = 2.3 * TS;
    let mut p = SrivcParams::new(3, 1, TS);
    p.delay = g.delay;
    let est = srivc(&u, &y, &p).unwrap();
    let err = max_rel_coeff_error(&est.model, &g);
    assert!(err < 1e-6, "coefficient error {err:e}");
}

/// Output noise of 20 % of the output's RMS: the estimate is consistent,
/// its error shrinks as the record grows and is small on a long record.
pub fn srivc_is_consistent_under_output_noise() {
    let g = third_order();
    let errors: Vec<f64> = [4usize, 32]
        .iter()
        .map(|&periods| {
            let u = excitation(periods);
            let y0 = record(&g, &u, 0);
            let sd = 0.2 * crate::ident::metrics::rms(&y0);
            let y: Vec<f64> = y0
                .iter()
                .zip(noise(u.len(), 7))
                .map(|(y, e)| y + sd * e)
                .collect();
            let est = srivc(&u, &y, &SrivcParams::new(3, 1, TS)).unwrap();
            max_rel_response_error(&est.model, &g)
        })
        .collect();
    assert!(
        errors[1] < 0.01,
        "long record: response error {:.4}",
        errors[1]
    );
    assert!(
        errors[1] < errors[0] / 1.5,
        "errors {errors:?} do not shrink with the record"
    );
}

pub fn zoh_response_matches_the_periodic_frf_of_sampled_data() {
    let mut g = third_order();
    let u = excitation(3);
    let y = record(&g, &u, 2);
    g.delay = 2.0 * TS;
    let frf = periodic_frf(&u, &y, TS, 1000, 1).unwrap();
    assert_eq!(frf.freq_hz.len(), 200);
    for (f, h) in frf.freq_hz.iter().zip(&frf.response) {
        let m = g.zoh_response_at_hz(*f, TS);
        assert!((h - m).norm() < 1e-9 * m.norm(), "{f} Hz: {h} vs {m}");
    }
}

fn log_grid(k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| 10.0 * 400f64.powf(i as f64 / (k - 1) as f64))
        .collect()
}

pub fn freq_fit_recovers_a_delayed_third_order_system_from_its_response() {
    let mut g = third_order();
    g.delay = 1.3e-4;
    let f = log_grid(120);
    let h: Vec<c64> = f.iter().map(|f| g.response_at_hz(*f)).collect();
    for weighting in [FreqWeighting::Uniform, FreqWeighting::LogFrequency] {
        let mut p = FreqFitParams::new(3, 1);
        p.delay = g.delay;
        p.weighting = weighting;
        let est = freq_fit(&f, &h, &p).unwrap();
        let err = max_rel_coeff_error(&est.model, &g);
        assert!(err < 1e-6, "{weighting:?}: coefficient error {err:e}");
        assert!(est.fit_percent > 99.9999);
    }
}

/// Complex noise of 5 % of each point's magnitude: the nonlinear
/// least-squares estimate stays within 1 % of the true response.
pub fn freq_fit_under_noise_stays_close_to_the_truth() {
    let g = third_order();
    let f = log_grid(400);
    let (nr, ni) = (noise(f.len(), 3), noise(f.len(), 4));
    let h: Vec<c64> = f
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let v = g.response_at_hz(*f);
            v + c64::new(nr[i], ni[i]) * (0.05 * v.norm() / 2f64.sqrt())
        })
        .collect();
    let mut p = FreqFitParams::new(3, 1);
    p.weighting = FreqWeighting::LogFrequency;
    let est = freq_fit(&f, &h, &p).unwrap();
    let err = max_rel_response_error(&est.model, &g);
    assert!(err < 0.01, "response error {err:.4}");
}

pub fn bad_orders_and_delays_are_named() {
    let u = excitation(1);
    let e = srivc(&u, &u, &SrivcParams::new(1, 2, TS)).unwrap_err();
    assert!(e.to_string().starts_with("nz:"), "{e}");
    let mut p = FreqFitParams::new(2, 0);
    p.delay = -1.0;
    let e = freq_fit(&[1.0, 2.0], &[c64::new(1.0, 0.0); 2], &p).unwrap_err();
    assert!(e.to_string().starts_with("delay:"), "{e}");
}
