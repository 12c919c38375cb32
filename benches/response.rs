//! Step response of a 20-state continuous system over 1e5 samples: the
//! exact ZOH discretisation at the grid step (one 21 x 21 matrix
//! exponential) and 1e5 state updates. The same system and grid are timed
//! with python-control by `benches/response_python_control.py`; both
//! figures are in docs/benchmarks.md.

mod common;

use common::twenty_states;
use criterion::{Criterion, criterion_group, criterion_main};
use fts::lti::response::{ResponseKind, TimeGrid, time_response};
use std::hint::black_box;

fn step_20_states(c: &mut Criterion) {
    let sys = twenty_states();
    let grid = TimeGrid::continuous(0.1, 100_000).unwrap();
    c.bench_function("step_response/20_states_1e5_samples", |b| {
        b.iter(|| {
            let r = time_response(black_box(&sys), ResponseKind::Step, &grid).unwrap();
            black_box(r.y[0][0][99_999])
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = step_20_states
}
criterion_main!(benches);
