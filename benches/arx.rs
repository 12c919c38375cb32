//! ARX 5/5/5 on 1e6 samples (target <= 70 ms; and on 1e5 to show linear
//! scaling) and OE 5/5/5 on 1e5 samples
//! (target < 1 s), on the \[Li21\] Eq. 11 closed loop with white input and
//! white measurement noise.

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fts::ident::arx::{ArxParams, Orders, arx};
use fts::ident::linear::filter_ab;
use fts::ident::oe::{OeParams, oe};
use std::hint::black_box;
use std::time::Duration;

fn signals(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut uni = common::uniform();
    let u: Vec<f64> = (0..n).map(|_| uni()).collect();
    let b = [4.154, -9.631, 10.23, -5.511, 1.154];
    let a = [1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447];
    let y = filter_ab(&b, &a, 5, &u)
        .into_iter()
        .map(|v| v + 1e-3 * uni())
        .collect();
    (u, y)
}

fn bench(c: &mut Criterion) {
    let (u, y) = signals(1_000_000);
    let params = ArxParams::new(Orders::new(5, 5, 5));
    let mut g = c.benchmark_group("arx");
    g.sample_size(20).measurement_time(Duration::from_secs(5));
    g.bench_function("arx_5_5_5_1e6", |b| {
        b.iter(|| arx(black_box(&u), black_box(&y), &params).unwrap())
    });
    // A tenth of the samples: the time should scale by a tenth (linear).
    let (u5, y5) = (&u[..100_000], &y[..100_000]);
    g.bench_function("arx_5_5_5_1e5", |b| {
        b.iter(|| arx(black_box(u5), black_box(y5), &params).unwrap())
    });
    g.finish();

    let (u, y) = signals(100_000);
    let params = OeParams::new(Orders::new(5, 5, 5));
    let mut g = c.benchmark_group("oe");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("oe_5_5_5_1e5", |b| {
        b.iter(|| oe(black_box(&u), black_box(&y), &params, &mut |_| {}).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
