//! Identification cost (regressor + least squares) on long records.
//!
//! `cargo bench --bench hysteresis`. Target (issue 3): 1e6 samples x 10
//! operators in <= 60 ms, scaling linearly in samples (compare the 250k and
//! 1M figures).
//!
//! * `regressor_qr_{pi,mpi_cbrt}` — the identification core: play operators streamed into
//!   the blocked Householder QR (`ident::ls::StreamingQr`) and the solve
//!   (`Regressor::qr` + `solve_from_r`).
//! * `identify` — the whole `identify()` call: the core plus a sample-by-sample
//!   simulation of the identified model for the fit report.
//! * `rows_into_ident_ls` — for comparison, the same regression pushed row by
//!   row into `ident::ls::StreamingLstsq` (the same kernel, rows buffered into
//!   blocks), 250k samples only.

use criterion::{Criterion, criterion_group, criterion_main};
use fts::ident::hysteresis::identify::Regressor;
use fts::ident::hysteresis::lsq::solve_from_r;
use fts::ident::hysteresis::operators::uniform_thresholds;
use fts::ident::hysteresis::{IdentifyParams, ModelKind, PlayOperator, identify};
use fts::ident::ls::{LstsqParams, StreamingLstsq};
use std::hint::black_box;

/// A triangle of growing amplitude (many loops) through a static nonlinearity:
/// every operator is excited.
fn record(n: usize) -> (Vec<f64>, Vec<f64>) {
    let u: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let phase = (t * 40.0).fract();
            let tri = if phase < 0.5 {
                4.0 * phase - 1.0
            } else {
                3.0 - 4.0 * phase
            };
            (0.3 + 0.7 * t) * 10.0 * tri
        })
        .collect();
    let y: Vec<f64> = u
        .iter()
        .map(|x| 0.8 * x + 0.05 * x.cbrt() + 0.01 * x * x.abs())
        .collect();
    (u, y)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("hysteresis_ls");
    group.sample_size(20);
    for &n in &[250_000usize, 1_000_000] {
        let (u, y) = record(n);
        let max_abs = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (name, cbrt) in [("pi", false), ("mpi_cbrt", true)] {
            let regressor = Regressor {
                offset: true,
                cbrt,
                operator: PlayOperator::Lower,
                thresholds: uniform_thresholds(10, max_abs),
                rate: None,
            };
            group.bench_function(format!("regressor_qr_{name}/{n}x10"), |b| {
                b.iter(|| {
                    let acc = regressor.qr(black_box(&u), black_box(&y));
                    solve_from_r(acc.r(), regressor.cols() + 1, regressor.free(), None).unwrap()
                })
            });
        }
        let regressor = Regressor {
            offset: true,
            cbrt: true,
            operator: PlayOperator::Lower,
            thresholds: uniform_thresholds(10, max_abs),
            rate: None,
        };
        let params = IdentifyParams {
            kind: ModelKind::MpiCbrt,
            operators: 10,
            ..Default::default()
        };
        group.bench_function(format!("identify/{n}x10"), |b| {
            b.iter(|| identify(black_box(&u), black_box(&y), &params).unwrap())
        });
        if n > 250_000 {
            continue;
        }
        group.bench_function(format!("rows_into_ident_ls/{n}x10"), |b| {
            b.iter(|| {
                let mut ls = StreamingLstsq::new(regressor.cols(), &LstsqParams::default());
                let mut states = [0.0; 10];
                let mut row = vec![0.0; regressor.cols()];
                for (&x, &yk) in u.iter().zip(&y) {
                    row[0] = 1.0;
                    row[1] = x.cbrt();
                    for (i, (s, &r)) in states.iter_mut().zip(&regressor.thresholds).enumerate() {
                        *s = PlayOperator::Lower.step(r, x, *s);
                        row[2 + i] = *s;
                    }
                    ls.push_row(&row, yk);
                }
                ls.finish().unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
