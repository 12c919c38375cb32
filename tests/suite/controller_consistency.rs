//! The same controller run four ways gives bit-identical commands:
//! (1) in-memory synthesis objects (ZPETC filter, hysteresis model, PID),
//! (2) the runtime step loaded from the emitted JSON after a reload,
//! (3) the runtime step loaded from the emitted C header after parsing,
//! (4) the runtime step loaded directly from the in-memory coefficients.
//! The learning blocks (a repetitive compensator and a learned feedforward
//! table) too, with (1) an implementation of the repetitive equation on
//! whole arrays written here.

use fts::ident::hysteresis::{
    DeadZoneStage, HysteresisModel, ModelKind, PlayOperator, analytic_inverse,
};
use fts::io::controller_file::{
    ControllerFile, Feedback, FeedforwardTableBlock, HysteresisBlock, Provenance, RepetitiveBlock,
    Units, ZpetcBlock, parse_c_header, parse_controller, to_c_header,
};
use fts::io::hysteresis_json::parse_model;
use fts::lti::DiscreteTf;
use fts::runtime::{PidSpec, RuntimeController};
use fts::sim::virtual_fts::{VirtualFts, VirtualFtsParams};
use fts::synth::pid::{Li21Pid, OutputLimits, PidGains};
use fts::synth::zpetc::{self, ZpetcParams};

fn models() -> (HysteresisModel, zpetc::Zpetc) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/li21-inverse-mpi.json"
    ))
    .unwrap();
    let inverse = parse_model(&text, "li21-inverse-mpi.json").unwrap().model;
    let g = DiscreteTf::new(
        vec![4.154, -9.631, 10.23, -5.511, 1.154],
        vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
        5,
        1e-4,
    )
    .unwrap();
    // rho 0.8 keeps the complex pair: the filter then has both cancelled and
    // uncancelled parts (order 7/2) and a preview of 7.
    let z = zpetc::design(
        &g,
        &ZpetcParams {
            rho: 0.8,
            ..Default::default()
        },
    )
    .unwrap();
    (inverse, z)
}

const PID: PidSpec = PidSpec {
    kp: 0.05,
    ki: 0.3,
    kd: 0.02,
    output_min: 0.0,
    output_max: 10.0,
};

/// Drives a plant with `controller`, where `controller(r_ahead, y)` returns u.
fn run(mut controller: impl FnMut(f64, f64) -> f64, preview: usize) -> Vec<u64> {
    let mut plant = VirtualFts::new(VirtualFtsParams::default_plant()).unwrap();
    let r = |k: usize| {
        6.0 + 4.0
            * (2.0 * std::f64::consts::PI * 300.0 * k as f64 * 1e-4).sin()
            * (k as f64 / 3000.0).min(1.0)
    };
    (0..6000)
        .map(|k| {
            let y = plant.measure();
            let u = controller(r(k + preview), y);
            plant.advance(u);
            u.to_bits()
        })
        .collect()
}

#[test]
fn four_ways_bit_identical() {
    let (inverse, z) = models();
    four_ways(&inverse, &z);
}

/// The analytic inverse of an MPI-deadzone model (a PI stage behind an input
/// dead-zone stage, docs/math.md §1.6) in the HC block, four ways.
#[test]
fn mpi_deadzone_analytic_inverse_four_ways_bit_identical() {
    let (_, z) = models();
    let forward = HysteresisModel {
        kind: ModelKind::MpiDeadzone,
        operator: PlayOperator::Symmetric,
        thresholds: (0..8).map(|i| i as f64 * 1.2).collect(),
        weights: vec![0.8, 0.1, 0.06, -0.03, 0.05, 0.02, 0.03, 0.01],
        cbrt_gain: 0.0,
        offset: -0.2,
        input_offset: 0.5,
        dead_zone: Some(DeadZoneStage {
            thresholds: vec![0.0, 2.5, 5.0, 7.5],
            weights: vec![1.0, 0.15, -0.1, 0.08],
        }),
        input_dead_zone: None,
        rate: None,
    };
    let inverse = analytic_inverse(&forward).unwrap();
    assert!(inverse.input_dead_zone.is_some());
    four_ways(&inverse, &z);
}

fn four_ways(inverse: &HysteresisModel, z: &zpetc::Zpetc) {
    let preview = z.preview;
    assert_eq!(preview, 7);

    // (1) in-memory objects.
    let mut filter = z.causal_filter();
    let mut hyst_state = inverse.new_state();
    let mut pid = Li21Pid::new(
        PidGains {
            kp: PID.kp,
            ki: PID.ki,
            kd: PID.kd,
        },
        OutputLimits {
            min: 0.0,
            max: 10.0,
        },
    )
    .unwrap();
    let in_memory = run(
        |r, y| {
            let rf = filter.step(r);
            let uff = inverse.step(&mut hyst_state, rf);
            pid.step(rf, y, uff)
        },
        preview,
    );

    let file = ControllerFile {
        ts: 1e-4,
        units: Units::default(),
        zpetc: Some(ZpetcBlock::from_zpetc(z)),
        hysteresis: Some(HysteresisBlock::from_model(inverse)),
        feedback: Feedback::Pid(PID),
        provenance: Provenance::default(),
        repetitive: None,
        feedforward_table: None,
    };
    let runtime_of = |f: &ControllerFile| {
        let mut rt = RuntimeController::new(&f.runtime_spec()).unwrap();
        assert_eq!(rt.preview(), preview);
        run(move |r, y| rt.step(r, y), preview)
    };
    // (4) runtime from in-memory coefficients.
    let direct = runtime_of(&file);
    // (2) emitted JSON, reloaded.
    let json = parse_controller(&file.to_json_string(), "c.json").unwrap();
    let from_json = runtime_of(&json);
    // (3) emitted C header, parsed.
    let header = parse_c_header(&to_c_header(&file), "c.h").unwrap();
    let from_header = runtime_of(&header);

    assert_eq!(
        in_memory, direct,
        "runtime differs from the synthesis objects"
    );
    assert_eq!(in_memory, from_json, "JSON reload changed a command");
    assert_eq!(in_memory, from_header, "C header changed a command");
    // The run is not trivial: the command moves and never saturates for long.
    let commands: Vec<f64> = in_memory.iter().map(|b| f64::from_bits(*b)).collect();
    let (lo, hi) = commands[3000..]
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &u| (a.min(u), b.max(u)));
    assert!(hi - lo > 3.0, "command range {lo}..{hi}");
}

/// A discrete H-infinity controller from the synthesis chain (mixsyn on the
/// second-order example plant, reduced to 4 states, Tustin at 10 kHz), run
/// behind the ZPETC and HC stages. Four ways again: (1) a loop written here
/// on the synthesis objects (the `StateSpace` matrices indexed directly),
/// (2) JSON reload, (3) C header, (4) runtime from the in-memory block.
#[test]
// Indexed loops on purpose: an implementation independent of the runtime's iterators.
#[allow(clippy::needless_range_loop)]
fn state_space_four_ways_bit_identical() {
    use fts::io::controller_file::StateSpaceBlock;
    use fts::lti::c2d::{C2dMethod, c2d};
    use fts::lti::ss::StateSpace;
    use fts::sim::{ModelPlant, Plant};
    use fts::synth::hinf::HinfOptions;

    let (inverse, z) = models();
    let preview = z.preview;
    let wn = 2.0 * std::f64::consts::PI * 300.0;
    let g = StateSpace::from_tf(&[wn * wn], &[1.0, 0.6 * wn, wn * wn], None).unwrap();
    let ws = fts::synth::weights::ws(2.0, 1500.0, 1e-4).unwrap();
    let wu = fts::synth::weights::makeweight(0.05, 20000.0, 1.0, 20.0).unwrap();
    let (_, r) =
        fts::synth::mixsyn::mixsyn(&g, Some(&ws), Some(&wu), None, HinfOptions::default()).unwrap();
    let kc = fts::lti::balred::balred(&r.k, 4).unwrap().sys;
    let k = c2d(&kc, 1e-4, C2dMethod::Tustin { prewarp: None })
        .unwrap()
        .balanced();
    let n = k.nx();
    assert_eq!(n, 4);
    let (lo, hi) = (-50.0, 50.0);
    let mut block = StateSpaceBlock::from_discrete(&k, 1e-4, "tustin").unwrap();
    block.output_min = Some(lo);
    block.output_max = Some(hi);

    // The discrete version of the same plant, as a ModelPlant.
    let gd = c2d(&g, 1e-4, C2dMethod::Zoh).unwrap();
    let (num, den) = gd.to_tf().unwrap();
    let plant_tf = DiscreteTf::new(num[1..].to_vec(), den, 1, 1e-4).unwrap();
    let run = |mut controller: Box<dyn FnMut(f64, f64) -> f64 + '_>| -> Vec<u64> {
        let mut plant = ModelPlant::new(&plant_tf, None, (lo, hi), 0.0, 1).unwrap();
        let r = |k: usize| {
            3.0 * (2.0 * std::f64::consts::PI * 50.0 * k as f64 * 1e-4).sin()
                * (k as f64 / 1000.0).min(1.0)
        };
        (0..4000)
            .map(|i| {
                let y = plant.measure();
                let u = controller(r(i + preview), y);
                plant.advance(u);
                u.to_bits()
            })
            .collect()
    };

    // (1) synthesis objects: filter, hysteresis model, StateSpace matrices.
    let mut filter = z.causal_filter();
    let mut hyst_state = inverse.new_state();
    let mut x = vec![0.0; n];
    let in_memory = run(Box::new(|rr, y| {
        let rf = filter.step(rr);
        let uff = inverse.step(&mut hyst_state, rf);
        let e = rf - y;
        let mut cx = 0.0;
        for j in 0..n {
            cx += k.c[(0, j)] * x[j];
        }
        let u = uff + (cx + k.d[(0, 0)] * e);
        let mut next = vec![0.0; n];
        for i in 0..n {
            let mut acc = 0.0;
            for j in 0..n {
                acc += k.a[(i, j)] * x[j];
            }
            next[i] = acc + k.b[(i, 0)] * e;
        }
        x = next;
        assert!(u > lo && u < hi, "this run must not saturate: {u}");
        u
    }));

    let file = ControllerFile {
        ts: 1e-4,
        units: Units::default(),
        zpetc: Some(ZpetcBlock::from_zpetc(&z)),
        hysteresis: Some(HysteresisBlock::from_model(&inverse)),
        feedback: Feedback::StateSpace(block),
        provenance: Provenance::default(),
        repetitive: None,
        feedforward_table: None,
    };
    assert_eq!(file.stages_name(), "ss+hc+zpec");
    let runtime_of = |f: &ControllerFile| {
        let mut rt = RuntimeController::new(&f.runtime_spec()).unwrap();
        assert_eq!(rt.preview(), preview);
        run(Box::new(move |r, y| rt.step(r, y)))
    };
    let direct = runtime_of(&file);
    let json = parse_controller(&file.to_json_string(), "c.json").unwrap();
    assert_eq!(json.feedback, file.feedback, "JSON changed a coefficient");
    let header = parse_c_header(&to_c_header(&file), "c.h").unwrap();
    assert_eq!(
        header.feedback, file.feedback,
        "C header changed a coefficient"
    );
    let from_json = runtime_of(&json);
    let from_header = runtime_of(&header);
    assert_eq!(
        in_memory, direct,
        "runtime differs from the synthesis objects"
    );
    assert_eq!(in_memory, from_json, "JSON reload changed a command");
    assert_eq!(in_memory, from_header, "C header changed a command");
    let commands: Vec<f64> = in_memory.iter().map(|b| f64::from_bits(*b)).collect();
    let (a, b) = commands[2000..]
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &u| (a.min(u), b.max(u)));
    assert!(b - a > 1.0, "command range {a}..{b}");
}

/// `v(k)` of the repetitive equation from the whole histories of `v` and
/// `e` (every signal 0 before sample 0), independently of the runtime's
/// rings: `v(k) = sum_{i=-h..h} q_|i| D(k - i - N0)`,
/// `D(j) = (1 - f) s(j) + f s(j - 1)`, `s(j) = v(j) + k_r e(j + m)`.
fn repetitive_equation(rc: &RepetitiveBlock, v: &[f64], e: &[f64]) -> f64 {
    let k = v.len() as isize;
    let h = rc.q.len() as isize - 1;
    let at = |x: &[f64], j: isize| if j < 0 { 0.0 } else { x[j as usize] };
    let s = |j: isize| at(v, j) + rc.gain * at(e, j + rc.lead as isize);
    let mut acc = 0.0;
    for i in -h..=h {
        let j = k - i - rc.period as isize;
        let d = if rc.fraction == 0.0 {
            s(j)
        } else {
            (1.0 - rc.fraction) * s(j) + rc.fraction * s(j - 1)
        };
        acc += rc.q[i.unsigned_abs()] * d;
    }
    acc
}

/// The [Li21] loop of `four_ways_bit_identical` with a repetitive
/// compensator of the reference's period (300 Hz at 10 kHz: 33 1/3
/// samples, a fractional period) and a learned feedforward table shorter
/// than the run, four ways: (1) the synthesis objects plus
/// [`repetitive_equation`], (2) JSON reload, (3) C header, (4) runtime from
/// the in-memory blocks. The header and the JSON give back the same blocks.
#[test]
fn learning_blocks_four_ways_bit_identical() {
    let (inverse, z) = models();
    let preview = z.preview;
    let rc = RepetitiveBlock {
        period: 33,
        fraction: 1.0 / 3.0,
        q: vec![0.5, 0.2, 0.05],
        lead: 4,
        gain: 0.2,
    };
    let table = FeedforwardTableBlock {
        samples: (0..4000)
            .map(|k| 0.05 * (2.0 * std::f64::consts::PI * 300.0 * k as f64 * 1e-4 + 0.3).sin())
            .collect(),
    };
    let file = ControllerFile {
        ts: 1e-4,
        units: Units::default(),
        zpetc: Some(ZpetcBlock::from_zpetc(&z)),
        hysteresis: Some(HysteresisBlock::from_model(&inverse)),
        feedback: Feedback::Pid(PID),
        provenance: Provenance::default(),
        repetitive: Some(rc.clone()),
        feedforward_table: Some(table.clone()),
    };

    // (1) in-memory objects; the repetitive error is r(k) - y(k) with r(k)
    // the reference `preview` samples after it was passed ahead (the first
    // value passed before that).
    let mut filter = z.causal_filter();
    let mut hyst_state = inverse.new_state();
    let mut pid = Li21Pid::new(
        PidGains {
            kp: PID.kp,
            ki: PID.ki,
            kd: PID.kd,
        },
        OutputLimits {
            min: 0.0,
            max: 10.0,
        },
    )
    .unwrap();
    let (mut ahead, mut v, mut e) = (Vec::new(), Vec::new(), Vec::new());
    let in_memory = run(
        |r, y| {
            let k = ahead.len();
            ahead.push(r);
            let rf = filter.step(r);
            let rk = ahead[k.saturating_sub(preview)];
            let vk = repetitive_equation(&rc, &v, &e);
            v.push(vk);
            e.push(rk - y);
            let learned = table.samples.get(k).copied().unwrap_or(0.0);
            let loop_reference = rf + (vk + learned);
            let uff = inverse.step(&mut hyst_state, loop_reference);
            pid.step(loop_reference, y, uff)
        },
        preview,
    );

    let runtime_of = |f: &ControllerFile| {
        let mut rt = RuntimeController::new(&f.runtime_spec()).unwrap();
        let mut player = f.feedforward_player().unwrap();
        assert_eq!(player.len(), 4000);
        run(
            move |r, y| rt.step_signals(r, y, player.next_sample()).command,
            preview,
        )
    };
    let direct = runtime_of(&file);
    let json = parse_controller(&file.to_json_string(), "c.json").unwrap();
    assert_eq!(json, file, "JSON changed a block");
    let header = parse_c_header(&to_c_header(&file), "c.h").unwrap();
    // The header has no model name, units or provenance; every number is there.
    let numbers = ControllerFile {
        hysteresis: file.hysteresis.clone().map(|h| HysteresisBlock {
            model: String::new(),
            ..h
        }),
        ..file.clone()
    };
    assert_eq!(header, numbers, "C header changed a block");
    let from_json = runtime_of(&json);
    let from_header = runtime_of(&header);

    assert_eq!(
        in_memory, direct,
        "runtime differs from the synthesis objects"
    );
    assert_eq!(in_memory, from_json, "JSON reload changed a command");
    assert_eq!(in_memory, from_header, "C header changed a command");
    // The learning blocks act: without them the commands differ.
    let plain = runtime_of(&ControllerFile {
        repetitive: None,
        ..file.clone()
    });
    assert_ne!(plain, direct);
    assert!(v.iter().filter(|x| **x != 0.0).count() > 5000);
}

/// The header of every combination of the learning blocks reads back to
/// the same file (a table over many lines; a whole and a fractional period).
#[test]
fn c_header_round_trips_the_learning_blocks() {
    let base = ControllerFile {
        ts: 1e-4,
        units: Units::default(),
        zpetc: Some(ZpetcBlock {
            preview: 2,
            num: vec![0.5, -0.25, 0.1 + 0.2],
            den: vec![1.0, -0.5],
        }),
        hysteresis: None,
        feedback: Feedback::Pid(PID),
        provenance: Provenance::default(),
        repetitive: None,
        feedforward_table: None,
    };
    let rc = |period, fraction| RepetitiveBlock {
        period,
        fraction,
        q: vec![0.45, 0.2, 0.05, 1.0 / 30.0],
        lead: 7,
        gain: 1.0 / 3.0,
    };
    let table = FeedforwardTableBlock {
        samples: (0..1001).map(|k| (k as f64 * 0.01).sin() / 7.0).collect(),
    };
    for repetitive in [None, Some(rc(400, 0.0)), Some(rc(12, 0.123456789))] {
        for feedforward_table in [None, Some(table.clone())] {
            for feedback in [Feedback::Pid(PID), Feedback::None] {
                let f = ControllerFile {
                    repetitive: repetitive.clone(),
                    feedforward_table: feedforward_table.clone(),
                    feedback,
                    ..base.clone()
                };
                let text = to_c_header(&f);
                let back = parse_c_header(&text, "c.h").unwrap_or_else(|e| panic!("{e}\n{text}"));
                assert_eq!(back, f);
                assert_eq!(parse_controller(&f.to_json_string(), "c.json").unwrap(), f);
                assert_eq!(
                    text.contains("#define FTS_HAS_REPETITIVE 1"),
                    f.repetitive.is_some()
                );
                assert_eq!(
                    text.contains("#define FTS_HAS_FEEDFORWARD_TABLE 1"),
                    f.feedforward_table.is_some()
                );
            }
        }
    }
}
