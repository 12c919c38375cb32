//! LTI core speed: the per-sample filter step (target: a few ns for order 5,
//! no allocation) and polynomial roots for degree 5, 20, 50 (target: about a
//! millisecond at degree 50, so zero maps of any identified model are
//! instant; faer's general eigenvalue solver on the 50 x 50 companion matrix
//! accounts for about 0.9 ms of it, balancing and Newton polishing for the rest).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use fts::lti::{DiscreteTf, Poly, TdfFilter, c64};
use std::f64::consts::PI;
use std::hint::black_box;

fn li21() -> DiscreteTf {
    DiscreteTf::new(
        vec![4.154, -9.631, 10.23, -5.511, 1.154],
        vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
        5,
        1e-4,
    )
    .unwrap()
}

fn filter_step(c: &mut Criterion) {
    let mut f = TdfFilter::new(&li21());
    let inputs: Vec<f64> = (0..1024).map(|k| (k as f64 * 1e-2).sin()).collect();
    let mut k = 0usize;
    c.bench_function("filter_step/order5_delay5", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            black_box(f.step(black_box(inputs[k])))
        })
    });
    let input: Vec<f64> = (0..100_000).map(|k| (k as f64 * 1e-3).sin()).collect();
    let mut output = vec![0.0; input.len()];
    c.bench_function("filter_run/order5_delay5_1e5_samples", |b| {
        b.iter(|| {
            f.reset();
            f.run(black_box(&input), &mut output);
            black_box(output[output.len() - 1])
        })
    });
}

fn roots(c: &mut Criterion) {
    let mut group = c.benchmark_group("roots");
    for degree in [5usize, 20, 50] {
        // Roots spread over two circles with distinct angles (well separated).
        let mut r = Vec::new();
        let pairs = degree / 2;
        for k in 0..pairs {
            let radius = if k % 2 == 0 { 0.6 } else { 0.9 };
            let theta = PI * (k as f64 + 0.5) / pairs as f64;
            r.push(c64::from_polar(radius, theta));
            r.push(c64::from_polar(radius, -theta));
        }
        if degree % 2 == 1 {
            r.push(c64::new(0.3, 0.0));
        }
        let p = Poly::from_z_roots(&r, 1.0);
        group.bench_with_input(BenchmarkId::from_parameter(degree), &p, |b, p| {
            b.iter(|| black_box(p.z_roots().unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, filter_step, roots);
criterion_main!(benches);
