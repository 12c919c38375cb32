//! `hinfsyn` on the Karagoz18 X axis (G_xx with the Table 1 weights, the
//! mixed-sensitivity augmented plant of `fts mixsyn`, `W_u = 1`): target <= 10 ms per
//! synthesis including the gamma bisection and the closed-loop H-inf check
//! (python-control + Slycot: ~57 ms on the same machine).

use criterion::{Criterion, criterion_group, criterion_main};
use fts::lti::ss::StateSpace;
use fts::synth::hinf::{HinfOptions, hinfsyn};
use fts::synth::mixsyn::augw;
use fts::synth::weights;
use std::hint::black_box;

fn karagoz_x() -> StateSpace {
    let g = StateSpace::from_tf(&[56930.0, 1389.0], &[1.0, 0.2268, 0.002058], None).unwrap();
    let ws = weights::ws(2.0, 160.0, 0.001).unwrap();
    let wt = weights::wt(2.0, 160.0, 0.001).unwrap();
    // Unit control weight (see docs/robust.md: it reproduces C_xx's fast pole).
    let wu = StateSpace::gain(faer::Mat::from_fn(1, 1, |_, _| 1.0), None);
    augw(&g, Some(&ws), Some(&wu), Some(&wt)).unwrap()
}

fn hinf_karagoz(c: &mut Criterion) {
    let p = karagoz_x();
    let r = hinfsyn(&p, 1, 1, HinfOptions::default()).unwrap();
    eprintln!(
        "Karagoz18 X: gamma (achieved) = {:.9}, bisection bound = {:.9}, stable = {}, {} bisection steps",
        r.gamma, r.bisection_bound, r.stable, r.iterations
    );
    c.bench_function("hinfsyn/karagoz18_x", |b| {
        b.iter(|| black_box(hinfsyn(black_box(&p), 1, 1, HinfOptions::default()).unwrap()))
    });
}

criterion_group!(benches, hinf_karagoz);
criterion_main!(benches);
