//! The per-sample hysteresis model step must not allocate: a counting global
//! allocator sees every allocation of this test binary.

use fts::ident::hysteresis::operators::uniform_thresholds;
use fts::ident::hysteresis::{DeadZoneStage, HysteresisModel, ModelKind, PlayOperator, RateStage};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

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
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let mut acc = 0.0;
    for &x in &input {
        acc += cbrt.step(&mut s1, x) + dz.step(&mut s2, x) + rate.step(&mut s3, x);
    }
    s1.reset();
    acc += cbrt.step(&mut s1, 1.0);
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert_eq!(after - before, 0, "the model step allocated");
    assert!(acc.is_finite());
}
