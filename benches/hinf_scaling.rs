//! H-infinity synthesis on the random generalised plants of the scaling table
//! in docs/benchmarks.md (issue #19): orders 8, 16, 32 and 48, the plants of
//! `benches/hinf_scaling.py` stored in `tests/data/hinf_scaling/` (the larger
//! orders, 64 to 160, are timed as whole processes by that script beside
//! SLICOT SB10AD). Small sample sizes keep the run to about a minute.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use fts::io::ss_json::parse_ss;
use fts::lti::ss::StateSpace;
use fts::synth::hinf::{HinfOptions, hinfsyn};
use std::hint::black_box;
use std::time::Duration;

const ORDERS: [usize; 4] = [8, 16, 32, 48];

fn plant(n: usize) -> StateSpace {
    let path = format!(
        "{}/../../tests/data/hinf_scaling/P{n}.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    parse_ss(&text, &path).unwrap()
}

fn hinf_scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("hinfsyn_scaling");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    for n in ORDERS {
        let p = plant(n);
        let r = hinfsyn(&p, 1, 1, HinfOptions::default()).unwrap();
        eprintln!(
            "order {n}: gamma (achieved) = {:.6}, stable = {}",
            r.gamma, r.stable
        );
        group.measurement_time(Duration::from_secs(if n >= 32 { 8 } else { 3 }));
        group.bench_with_input(BenchmarkId::from_parameter(n), &p, |b, p| {
            b.iter(|| black_box(hinfsyn(black_box(p), 1, 1, HinfOptions::default()).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, hinf_scaling);
criterion_main!(benches);
