//! The real-time step and the closed-loop simulation.
//!
//! Targets (issue 5): the runtime step for PID + HC (10 operators) + ZPETC
//! (order 5/4) at most 50 ns per sample; the full virtual FTS closed loop
//! (plant with its internal substeps, sensor noise, delay line, plus the
//! controller) at least 10 million controller samples per second, i.e. at
//! most 100 ns per sample. The state-space feedback step (order 8) is
//! measured alone and behind HC + ZPETC.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fts::runtime::{
    FeedbackSpec, HysteresisSpec, PidSpec, PlayForm, RepetitiveSpec, RuntimeController,
    RuntimeSpec, SsAntiWindup, StateSpaceSpec, ZpetcSpec,
};
use fts::sim::closed_loop;
use fts::sim::virtual_fts::{VirtualFts, VirtualFtsParams};
use std::hint::black_box;

fn spec<'a>(thresholds: &'a [f64], weights: &'a [f64]) -> RuntimeSpec<'a> {
    RuntimeSpec {
        // [Li21] Eq. 12-like filter: z^5 A_c / B_c, numerator order 5, denominator order 4.
        zpetc: Some(ZpetcSpec {
            preview: 5,
            num: &[0.24073, -0.18902, 0.17571, -0.14781, 0.012412, 0.008298],
            den: &[1.0, -2.31849, 2.46269, -1.32667, 0.277805],
        }),
        hysteresis: Some(HysteresisSpec {
            form: PlayForm::Lower,
            thresholds,
            weights,
            cbrt_gain: -0.0197,
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
    }
}

/// The plug-in repetitive block at a period of N = 10 000 samples (1 s at
/// 10 kHz), fractional, 16 Q taps each side, lead 5, behind the \[Li21\] PID
/// (issue 16): its cost per sample is the step minus the PID alone.
fn repetitive_benches(c: &mut Criterion) {
    let q: Vec<f64> = (0..=16)
        .map(|i| if i == 0 { 0.5 } else { 0.5 / 32.0 })
        .collect();
    let with_rc = RuntimeSpec {
        zpetc: None,
        hysteresis: None,
        feedback: FeedbackSpec::Pid(fts::sim::experiment::DEFAULT_PID),
        repetitive: Some(RepetitiveSpec {
            period: 10_000,
            fraction: 0.5,
            q: &q,
            lead: 5,
            gain: 0.5,
        }),
    };
    let pid_only = RuntimeSpec {
        repetitive: None,
        ..with_rc
    };
    let refs: Vec<f64> = (0..4096)
        .map(|k| 5.0 + 4.0 * (k as f64 * 0.03).sin())
        .collect();
    for (name, spec) in [
        ("runtime_step/pid+repetitive_N10000", &with_rc),
        ("runtime_step/pid", &pid_only),
    ] {
        let mut rt = RuntimeController::new(spec).unwrap();
        let mut k = 0usize;
        c.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) & 4095;
                black_box(rt.step(black_box(refs[k]), black_box(refs[k] - 0.01)))
            })
        });
    }
}

fn benches(c: &mut Criterion) {
    // [Li21] Table 1 thresholds and weights.
    let thresholds: Vec<f64> = (0..10).map(|i| i as f64 * 0.9677).collect();
    let weights = [
        0.29, -0.063, 0.0075, -0.0267, -0.0015, -0.0215, 0.021, -0.0253, 0.0115, -0.047,
    ];
    let mut rt = RuntimeController::new(&spec(&thresholds, &weights)).unwrap();
    let refs: Vec<f64> = (0..4096)
        .map(|k| 5.0 + 4.0 * (k as f64 * 0.03).sin())
        .collect();
    let mut k = 0usize;
    c.bench_function("runtime_step/pid+hc10+zpetc5_4", |b| {
        b.iter(|| {
            k = (k + 1) & 4095;
            black_box(rt.step(black_box(refs[k]), black_box(refs[k] - 0.01)))
        })
    });

    // A state-space feedback controller of order 8 (an H-infinity design
    // after reduction), alone: x <- A x + B e, u = C x + D e, clamped.
    let order = 8;
    let a: Vec<f64> = (0..order * order)
        .map(|k| {
            let (i, j) = (k / order, k % order);
            if i == j {
                0.9 - 0.05 * i as f64
            } else {
                0.01 / (1.0 + (i as f64 - j as f64).abs())
            }
        })
        .collect();
    let bv: Vec<f64> = (0..order).map(|i| 0.1 * (i + 1) as f64).collect();
    let cv: Vec<f64> = (0..order).map(|i| 1.0 - 0.1 * i as f64).collect();
    let ss_spec = RuntimeSpec {
        zpetc: None,
        hysteresis: None,
        feedback: FeedbackSpec::StateSpace(StateSpaceSpec {
            a: &a,
            b: &bv,
            c: &cv,
            d: 0.3,
            output_min: -10.0,
            output_max: 10.0,
            anti_windup: SsAntiWindup::ConditionalUpdate,
        }),
        repetitive: None,
    };
    let mut ss = RuntimeController::new(&ss_spec).unwrap();
    c.bench_function("runtime_step/ss8", |b| {
        b.iter(|| {
            k = (k + 1) & 4095;
            black_box(ss.step(black_box(refs[k]), black_box(refs[k] - 0.01)))
        })
    });
    // The same behind HC (10 operators) and ZPETC (order 5/4).
    let mut full = spec(&thresholds, &weights);
    full.feedback = ss_spec.feedback;
    let mut ss_full = RuntimeController::new(&full).unwrap();
    c.bench_function("runtime_step/ss8+hc10+zpetc5_4", |b| {
        b.iter(|| {
            k = (k + 1) & 4095;
            black_box(ss_full.step(black_box(refs[k]), black_box(refs[k] - 0.01)))
        })
    });

    let n = 100_000;
    let reference: Vec<f64> = (0..n)
        .map(|k| 7.0 + 5.0 * (2.0 * std::f64::consts::PI * 100.0 * k as f64 * 1e-4).sin())
        .collect();
    let mut group = c.benchmark_group("closed_loop");
    group.throughput(Throughput::Elements(n as u64));
    group.sample_size(20);
    // Plant, controller and the full trace (six signals) per sample; the
    // trace buffers are reused across iterations, so fresh-page faults of a
    // first run are not counted.
    let mut trace = closed_loop::Trace::default();
    group.bench_function("virtual_fts+pid+hc+zpetc/1e5_samples", |b| {
        b.iter(|| {
            let mut plant = VirtualFts::new(VirtualFtsParams::default_plant()).unwrap();
            let mut ctrl = RuntimeController::new(&spec(&thresholds, &weights)).unwrap();
            closed_loop::run_into(
                &mut plant,
                &mut ctrl,
                black_box(&reference),
                &[],
                &mut trace,
            )
            .unwrap();
            black_box(trace.command[n - 1])
        })
    });
    group.finish();
}

criterion_group!(runtime, benches, repetitive_benches);
criterion_main!(runtime);
