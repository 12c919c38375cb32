//! Identification cost (regressor + least squares) on long records.
//!
//! `cargo bench --bench hysteresis`. Target (issue 3): 1e6 samples x 10
//! operators in <= 60 ms, scaling linearly in samples.

use criterion::{Criterion, criterion_group, criterion_main};
use fts::ident::hysteresis::{IdentifyParams, ModelKind, identify};
use std::hint::black_box;

/// A record from a known MPI-cbrt model driven by a triangle of growing
/// amplitude (many loops), so every operator is excited.
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
    let mut group = c.benchmark_group("identify_ls");
    group.sample_size(20);
    for &n in &[250_000usize, 1_000_000] {
        let (u, y) = record(n);
        let params = IdentifyParams {
            kind: ModelKind::MpiCbrt,
            operators: 10,
            ..Default::default()
        };
        group.bench_function(format!("mpi_cbrt_10ops_{n}"), |b| {
            b.iter(|| identify(black_box(&u), black_box(&y), &params).expect("identifies"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
