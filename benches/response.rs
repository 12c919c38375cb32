//! Step response of a 20-state continuous system over 1e5 samples: the
//! exact ZOH discretisation at the grid step (one 21 x 21 matrix
//! exponential) and 1e5 state updates. The same system and grid are timed
//! with python-control by `benches/response_python_control.py`; both
//! figures are in docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use faer::Mat;
use fts::lti::StateSpace;
use fts::lti::response::{ResponseKind, TimeGrid, time_response};
use std::hint::black_box;

/// Ten lightly damped modes in parallel: block `[[s, w], [-w, s]]` with
/// `w = 2 pi (50 + 100 i)` rad/s, `s = -0.05 w`; `B` all ones, `C`
/// alternating `1, 0.5` (as in the Python script).
pub fn twenty_states() -> StateSpace {
    let n = 20;
    let mut a = Mat::<f64>::zeros(n, n);
    for i in 0..10 {
        let w = 2.0 * std::f64::consts::PI * (50.0 + 100.0 * i as f64);
        let s = -0.05 * w;
        let k = 2 * i;
        a[(k, k)] = s;
        a[(k + 1, k + 1)] = s;
        a[(k, k + 1)] = w;
        a[(k + 1, k)] = -w;
    }
    let b = Mat::from_fn(n, 1, |_, _| 1.0);
    let c = Mat::from_fn(1, n, |_, j| if j % 2 == 0 { 1.0 } else { 0.5 });
    StateSpace::new(a, b, c, Mat::zeros(1, 1), None).unwrap()
}

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
