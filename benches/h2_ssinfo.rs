//! H2 synthesis and the analysis of `fts ss-info` in process, beside SLICOT
//! (issue #30): orders 10, 50, 100 and 200, the plants written by
//! `python3 benches/h2_ssinfo_slicot.py write DIR`, read from the folder
//! named by `FTS_H2_PLANTS` (default `target/h2-plants`). The peers,
//! SB10HD and AB13DD + AB13BD + AB08ND + dgeev called directly through
//! slycot on one thread, are timed by `OPENBLAS_NUM_THREADS=1 python3
//! benches/h2_ssinfo_slicot.py inprocess DIR`; docs/benchmarks.md quotes
//! both from one session.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use fts::io::ss_json::parse_ss;
use fts::lti::info::system_info;
use fts::lti::ss::StateSpace;
use fts::synth::h2::h2syn;
use std::hint::black_box;
use std::time::Duration;

const ORDERS: [usize; 4] = [10, 50, 100, 200];

fn system(kind: &str, n: usize) -> StateSpace {
    let dir = std::env::var("FTS_H2_PLANTS")
        .unwrap_or_else(|_| format!("{}/../../target/h2-plants", env!("CARGO_MANIFEST_DIR")));
    let path = format!("{dir}/{kind}{n}.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!("{path}: {e} (write the plants: python3 benches/h2_ssinfo_slicot.py write {dir})")
    });
    parse_ss(&text, &path).unwrap()
}

fn h2_synthesis(c: &mut Criterion) {
    let mut group = c.benchmark_group("h2syn");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    for n in ORDERS {
        let p = system("H", n);
        let r = h2syn(&p, 1, 1, 1e-6).unwrap();
        eprintln!("order {n}: closed-loop H2 norm {:.10}", r.h2_norm);
        group.measurement_time(Duration::from_secs(if n >= 100 { 10 } else { 3 }));
        group.bench_with_input(BenchmarkId::from_parameter(n), &p, |b, p| {
            b.iter(|| black_box(h2syn(black_box(p), 1, 1, 1e-6).unwrap()))
        });
    }
    group.finish();
}

fn analysis(c: &mut Criterion) {
    let mut group = c.benchmark_group("ss_info");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    for n in ORDERS {
        let s = system("S", n);
        let info = system_info(&s).unwrap();
        let hinf = info.hinf_norm.unwrap();
        eprintln!(
            "order {n}: {} poles, {} zeros, H2 {:.10}, H-inf {:.10} at {:.6} rad/s",
            info.poles.len(),
            info.zeros.finite.len(),
            info.h2_norm.unwrap_or(f64::NAN),
            hinf.peak,
            hinf.omega
        );
        group.measurement_time(Duration::from_secs(if n >= 100 { 10 } else { 3 }));
        group.bench_with_input(BenchmarkId::from_parameter(n), &s, |b, s| {
            b.iter(|| black_box(system_info(black_box(s)).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, h2_synthesis, analysis);
criterion_main!(benches);
