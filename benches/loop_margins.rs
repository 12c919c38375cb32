//! Margins, sensitivity peaks, bandwidth and closed-loop poles of a loop
//! with a 20-state plant on 1000 frequencies (1 Hz to 10 kHz, 250 per
//! decade): `fts loop`'s analysis. The same loop is analysed by
//! python-control (`stability_margins`, `bandwidth`, `S` and `T` on the same
//! 1000 frequencies, closed-loop poles) in `benches/loop_python_control.py`;
//! both figures are in docs/benchmarks.md.

mod common;

use common::twenty_states;
use criterion::{Criterion, criterion_group, criterion_main};
use fts::lti::margins::{LoopParams, LoopSystem, analyze_loop};
use fts::lti::{ContinuousTf, TransferFunction};
use std::hint::black_box;

/// The PI controller `K(s) = 0.2 + 100/s` of the Python script.
pub fn pi_controller() -> LoopSystem {
    let k = ContinuousTf::new(vec![0.2, 100.0], vec![1.0, 0.0]).unwrap();
    LoopSystem::Tf(TransferFunction::Continuous(k))
}

fn margins_20_states(c: &mut Criterion) {
    let g = LoopSystem::Ss(twenty_states());
    let k = pi_controller();
    let params = LoopParams {
        points_per_decade: 250,
        f_min_hz: Some(1.0),
        f_max_hz: Some(1e4),
        ..LoopParams::default()
    };
    let report = analyze_loop(&g, &k, &params).unwrap();
    eprintln!(
        "fts: peak |S| {:.9} at {:.6} Hz, bandwidth {:?} Hz, gain margin {:?}",
        report.peak_s.value,
        report.peak_s.freq_hz,
        report.bandwidth_hz,
        report.gain_margin.as_ref().map(|g| g.gain_margin)
    );
    c.bench_function("loop_margins/20_states_1000_frequencies", |b| {
        b.iter(|| {
            let r = analyze_loop(black_box(&g), &k, &params).unwrap();
            black_box(r.peak_s.value)
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = margins_20_states
}
criterion_main!(benches);
