//! The dense kernels against LAPACK (issue #30: every Schur / QZ / Riccati /
//! Lyapunov kernel within 3x of LAPACK's time for the same factorisation,
//! n = 50 to 320). `benches/kernels_lapack.py` times scipy's LAPACK calls on
//! the same matrices (the same generator and seed; see its header); both
//! are one-thread, and docs/benchmarks.md quotes the two from one run.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::Mat;
use fts::lti::lyapunov::lyap;
use fts::lti::riccati::care;
use fts::lti::schur::{gen_schur, ordered_real_schur, real_qz, real_schur};
use std::hint::black_box;
use std::time::Duration;

const SIZES: [usize; 5] = [50, 100, 160, 200, 320];

/// `A` and `B` of benches/kernels_lapack.py: entries uniform in [-1, 1) /
/// sqrt(n) from the 64-bit LCG seeded 20261129 + n, column by column.
fn matrices(n: usize) -> (Mat<f64>, Mat<f64>) {
    let mut x = 20261129 + n as u64;
    let mut next = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) / (n as f64).sqrt()
    };
    let mut fill = || {
        let mut m = Mat::zeros(n, n);
        for j in 0..n {
            for i in 0..n {
                m[(i, j)] = next();
            }
        }
        m
    };
    let a = fill();
    let b = fill();
    (a, b)
}

/// `[A, -I; -I, -A']`: the Hamiltonian of `A'X + XA - X X + I = 0`.
fn hamiltonian(a: &Mat<f64>) -> Mat<f64> {
    let n = a.nrows();
    Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
        (true, true) => a[(i, j)],
        (false, false) => -a[(j - n, i - n)],
        _ => -f64::from(u8::from(i % n == j % n)),
    })
}

fn kernels(c: &mut Criterion) {
    let mut group = c.benchmark_group("kernels");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    for n in SIZES {
        let (a, b) = matrices(n);
        let eye = Mat::<f64>::identity(n, n);
        let h = hamiltonian(&a);
        let shifted = &a - &eye * faer::Scale(2.0);
        let q = &b * b.transpose();
        group.bench_with_input(BenchmarkId::new("real_schur", n), &a, |bench, a| {
            bench.iter(|| black_box(real_schur(black_box(a)).unwrap()))
        });
        group.bench_with_input(
            BenchmarkId::new("ordered_real_schur_hamiltonian", n),
            &h,
            |bench, h| bench.iter(|| black_box(ordered_real_schur(h, |l| l.re < 0.0).unwrap())),
        );
        group.bench_function(BenchmarkId::new("qz_real", n), |bench| {
            bench.iter(|| black_box(real_qz(black_box(&a), black_box(&b)).unwrap()))
        });
        group.bench_function(BenchmarkId::new("qz_complex", n), |bench| {
            bench.iter(|| black_box(gen_schur(black_box(&a), black_box(&b)).unwrap()))
        });
        group.bench_function(BenchmarkId::new("care", n), |bench| {
            bench.iter(|| black_box(care(&a, &eye, &eye, &eye, None).unwrap()))
        });
        group.bench_function(BenchmarkId::new("lyap", n), |bench| {
            bench.iter(|| black_box(lyap(&shifted, &q).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, kernels);
criterion_main!(benches);
