//! The per-sample filter, runtime and hysteresis-model steps, and the
//! iterations of gradient identification, must not allocate: a counting global allocator counts the allocations of the
//! current thread (the test harness runs tests on parallel threads, whose
//! allocations must not count). Its own test binary, because the allocator
//! is global.

use fts::ident::hysteresis::gd::{GdParams, Silent, TriangularLeastSquares, gd_lstsq};
use fts::ident::hysteresis::lsq::{ColMajor, qr_of};
use fts::ident::hysteresis::operators::uniform_thresholds;
use fts::ident::hysteresis::{DeadZoneStage, HysteresisModel, ModelKind, PlayOperator, RateStage};
use fts::lti::{DiscreteTf, TdfFilter};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn filter_step_does_not_allocate() {
    let g = DiscreteTf::new(
        vec![4.154, -9.631, 10.23, -5.511, 1.154],
        vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
        5,
        1e-4,
    )
    .unwrap();
    let mut filter = TdfFilter::new(&g);
    let input: Vec<f64> = (0..10_000).map(|k| (k as f64 * 0.01).sin()).collect();
    let mut output = vec![0.0; input.len()];
    let before = allocations();
    let mut acc = 0.0;
    for &x in &input {
        acc += filter.step(x);
    }
    filter.reset();
    filter.run(&input, &mut output);
    let after = allocations();
    assert_eq!(after - before, 0, "the filter allocated");
    assert!(acc.is_finite() && output[9_999].is_finite());
}

#[test]
fn runtime_controller_step_does_not_allocate() {
    use fts::runtime::{
        FeedbackSpec, HysteresisSpec, PidSpec, PlayForm, RuntimeController, RuntimeSpec, ZpetcSpec,
    };
    let thresholds: Vec<f64> = (0..10).map(|i| i as f64).collect();
    let weights = vec![0.1; 10];
    let spec = RuntimeSpec {
        zpetc: Some(ZpetcSpec {
            preview: 5,
            num: &[0.24, -0.19, 0.17, -0.15, 0.012, 0.008],
            den: &[1.0, -2.3, 2.46, -1.33, 0.28],
        }),
        hysteresis: Some(HysteresisSpec {
            form: PlayForm::Lower,
            thresholds: &thresholds,
            weights: &weights,
            cbrt_gain: -0.02,
            offset: 0.0,
            input_offset: 0.0,
            dead_zone_thresholds: &[],
            dead_zone_weights: &[],
            ..HysteresisSpec::EMPTY
        }),
        feedback: FeedbackSpec::Pid(PidSpec {
            kp: 0.05,
            ki: 0.3,
            kd: 0.0,
            output_min: 0.0,
            output_max: 10.0,
        }),
        repetitive: None,
    };
    let mut rt = RuntimeController::new(&spec).unwrap();
    let before = allocations();
    let mut acc = 0.0;
    for k in 0..10_000 {
        let r = 5.0 + (k as f64 * 0.01).sin();
        acc += rt.step(r, r - 0.01);
    }
    rt.reset();
    let after = allocations();
    assert_eq!(after - before, 0, "the runtime step allocated");
    assert!(acc.is_finite());
}

#[test]
fn state_space_controller_step_does_not_allocate() {
    use fts::runtime::{
        FeedbackSpec, RuntimeController, RuntimeSpec, SsAntiWindup, StateSpaceSpec, ZpetcSpec,
    };
    // Order 8, a stable diagonal-plus-coupling A; limits that are hit, so
    // both branches of the conditional update run.
    let n = 8;
    let a: Vec<f64> = (0..n * n)
        .map(|k| {
            let (i, j) = (k / n, k % n);
            if i == j {
                0.9 - 0.05 * i as f64
            } else if j == i + 1 {
                0.02
            } else {
                0.0
            }
        })
        .collect();
    let b: Vec<f64> = (0..n).map(|i| 0.1 * (i + 1) as f64).collect();
    let c: Vec<f64> = (0..n).map(|i| 1.0 - 0.1 * i as f64).collect();
    let spec = RuntimeSpec {
        zpetc: Some(ZpetcSpec {
            preview: 5,
            num: &[0.24, -0.19, 0.17, -0.15, 0.012, 0.008],
            den: &[1.0, -2.3, 2.46, -1.33, 0.28],
        }),
        hysteresis: None,
        feedback: FeedbackSpec::StateSpace(StateSpaceSpec {
            a: &a,
            b: &b,
            c: &c,
            d: 0.3,
            output_min: -1.0,
            output_max: 1.0,
            anti_windup: SsAntiWindup::ConditionalUpdate,
        }),
        repetitive: None,
    };
    let mut rt = RuntimeController::new(&spec).unwrap();
    let before = allocations();
    let mut acc = 0.0;
    for k in 0..10_000 {
        let r = 5.0 * (k as f64 * 0.01).sin();
        acc += rt.step(r, 0.0);
    }
    rt.reset();
    let after = allocations();
    assert_eq!(after - before, 0, "the state-space step allocated");
    assert!(acc.is_finite());
}

/// The repetitive block (period 10 000 samples, fractional, 16 Q taps each
/// side, lead 5) behind a PID, with a learned feedforward table played
/// back: three periods of steps, across every ring's wrap, allocate
/// nothing.
#[test]
fn repetitive_block_and_table_do_not_allocate() {
    use fts::runtime::{
        FeedbackSpec, FeedforwardTable, RepetitiveSpec, RuntimeController, RuntimeSpec,
    };
    use fts::sim::experiment::DEFAULT_PID;
    let q: Vec<f64> = (0..=16).map(|i| 1.0 / (1.0 + i as f64) / 4.0).collect();
    let spec = RuntimeSpec {
        zpetc: None,
        hysteresis: None,
        feedback: FeedbackSpec::Pid(DEFAULT_PID),
        repetitive: Some(RepetitiveSpec {
            period: 10_000,
            fraction: 0.25,
            q: &q,
            lead: 5,
            gain: 0.5,
        }),
    };
    let table_samples: Vec<f64> = (0..20_000)
        .map(|k| 1e-3 * (k as f64 * 1e-3).sin())
        .collect();
    let mut rt = RuntimeController::new(&spec).unwrap();
    let mut table = FeedforwardTable::new(&table_samples).unwrap();
    let before = allocations();
    let mut acc = 0.0;
    for k in 0..30_000 {
        let r = 5.0 + (k as f64 * 2e-3).sin();
        acc += rt.step_signals(r, r - 0.01, table.next_sample()).command;
    }
    rt.reset();
    let after = allocations();
    assert_eq!(after - before, 0, "the repetitive step allocated");
    assert!(acc.is_finite());
}

#[test]
fn solved_rate_dependent_hysteresis_step_does_not_allocate() {
    use fts::runtime::{FeedbackSpec, HysteresisSpec, PlayForm, RuntimeController, RuntimeSpec};
    let thresholds: Vec<f64> = (0..10).map(|i| i as f64).collect();
    let weights = vec![0.1; 10];
    let rate_weights = vec![0.01; 10];
    let spec = RuntimeSpec {
        zpetc: None,
        hysteresis: Some(HysteresisSpec {
            form: PlayForm::Lower,
            thresholds: &thresholds,
            weights: &weights,
            cbrt_gain: 0.2,
            rate_weights: &rate_weights,
            rate_ts: 1e-4,
            rate_scale: 1e4,
            velocity_gain: 0.01,
            solve: Some((-5.0, 20.0)),
            ..HysteresisSpec::EMPTY
        }),
        feedback: FeedbackSpec::None,
        repetitive: None,
    };
    let mut rt = RuntimeController::new(&spec).unwrap();
    let before = allocations();
    let mut acc = 0.0;
    for k in 0..10_000 {
        acc += rt.step(1.0 + (k as f64 * 0.01).sin(), 0.0);
    }
    let after = allocations();
    assert_eq!(after - before, 0, "the solving hysteresis step allocated");
    assert!(acc.is_finite());
}

#[test]
fn model_step_does_not_allocate() {
    let cbrt = HysteresisModel {
        kind: ModelKind::MpiCbrt,
        operator: PlayOperator::Lower,
        thresholds: uniform_thresholds(10, 9.677),
        weights: vec![
            0.29, -0.063, 0.0075, -0.0267, -0.0015, -0.0215, 0.021, -0.0253, 0.0115, -0.047,
        ],
        cbrt_gain: -0.0197,
        offset: 0.0,
        input_offset: 0.0,
        dead_zone: None,
        input_dead_zone: None,
        rate: None,
    };
    let dz = HysteresisModel {
        kind: ModelKind::MpiDeadzone,
        operator: PlayOperator::Symmetric,
        cbrt_gain: 0.0,
        dead_zone: Some(DeadZoneStage {
            thresholds: vec![0.0, 1.0, 2.0],
            weights: vec![1.0, 0.2, 0.1],
        }),
        ..cbrt.clone()
    };
    // Rate-dependent weights (docs/math.md §1.7).
    let rate = HysteresisModel {
        rate: Some(RateStage {
            ts: 1e-4,
            rate_scale: 1e3,
            weights: vec![0.01; 10],
            velocity_gain: 0.1,
        }),
        ..cbrt.clone()
    };
    let input: Vec<f64> = (0..10_000).map(|k| 9.0 * (k as f64 * 0.01).sin()).collect();
    let (mut s1, mut s2, mut s3) = (cbrt.new_state(), dz.new_state(), rate.new_state());
    let before = allocations();
    let mut acc = 0.0;
    for &x in &input {
        acc += cbrt.step(&mut s1, x) + dz.step(&mut s2, x) + rate.step(&mut s3, x);
    }
    s1.reset();
    acc += cbrt.step(&mut s1, 1.0);
    let after = allocations();
    assert_eq!(after - before, 0, "the model step allocated");
    assert!(acc.is_finite());
}

/// A solve capped at 8 iterations allocates exactly as much as one capped
/// at 2 (its buffers, once): the iterations themselves allocate nothing.
#[test]
fn gradient_identification_iterations_do_not_allocate() {
    let (rows, p) = (2000, 24);
    let mut seed = 5u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut a = ColMajor::zeros(rows, p);
    for j in 0..p {
        for v in a.col_mut(j) {
            *v = next() * (1.0 + j as f64);
        }
    }
    let y: Vec<f64> = (0..rows).map(|_| next()).collect();
    let problem = TriangularLeastSquares::from_factor(qr_of(&a, &y).r(), rows);
    let allocations_at = |cap: u64| {
        let params = GdParams {
            max_iters: cap,
            ..Default::default()
        };
        let before = allocations();
        let (_, info) = gd_lstsq(&problem, &params, None, Silent).unwrap();
        let used = allocations() - before;
        assert_eq!(info.iterations, cap, "{info:?}");
        used
    };
    let (short, long) = (allocations_at(2), allocations_at(8));
    assert!(short > 0, "the counter saw nothing");
    assert_eq!(
        long,
        short,
        "6 more iterations allocated {} times",
        long - short
    );
}
