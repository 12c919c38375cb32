//! The same controller run four ways gives bit-identical commands:
//! (1) in-memory synthesis objects (ZPETC filter, hysteresis model, PID),
//! (2) the runtime step loaded from the emitted JSON after a reload,
//! (3) the runtime step loaded from the emitted C header after parsing,
//! (4) the runtime step loaded directly from the in-memory coefficients.

use fts::ident::hysteresis::HysteresisModel;
use fts::io::controller_file::{
    ControllerFile, Feedback, HysteresisBlock, Provenance, Units, ZpetcBlock, parse_c_header,
    parse_controller, to_c_header,
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
        zpetc: Some(ZpetcBlock::from_zpetc(&z)),
        hysteresis: Some(HysteresisBlock::from_model(&inverse)),
        feedback: Feedback::Pid(PID),
        provenance: Provenance::default(),
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
