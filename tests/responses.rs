//! Step and impulse responses and `step_info` figures against python-control
//! (tests/data/responses/cases.json, written by gen_step_info.py in the same
//! folder): continuous and discrete, SISO and MIMO, open and closed loops.
//! Every figure must agree to 1e-6 (relative for values, absolute in
//! seconds for times on the same grid).

use faer::Mat;
use fts::io::tf_json;
use fts::lti::StateSpace;
use fts::lti::response::{
    NoStepInfo, ResponseKind, StepInfo, TimeGrid, step_info_of, time_response,
};
use serde::Deserialize;

#[derive(Deserialize)]
struct Ss {
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
    ts: Option<f64>,
}

#[derive(Deserialize)]
struct Grid {
    t_final: f64,
    n: usize,
}

#[derive(Deserialize)]
struct Info {
    rise_time: Option<f64>,
    settling_time: Option<f64>,
    settling_min: Option<f64>,
    settling_max: Option<f64>,
    overshoot: Option<f64>,
    undershoot: Option<f64>,
    peak: Option<f64>,
    peak_time: Option<f64>,
    steady_state: Option<f64>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    g: Ss,
    k: Option<Ss>,
    grid: Grid,
    stride: usize,
    stable: bool,
    step_info: Option<Vec<Vec<Info>>>,
    step: Vec<Vec<Vec<f64>>>,
    impulse: Vec<Vec<Vec<f64>>>,
    closed_loop_poles: Option<Vec<[f64; 2]>>,
}

#[derive(Deserialize)]
struct Cases {
    cases: Vec<Case>,
}

fn cases() -> Vec<Case> {
    let text = std::fs::read_to_string("tests/data/responses/cases.json").unwrap();
    serde_json::from_str::<Cases>(&text).unwrap().cases
}

fn mat(rows: &[Vec<f64>], ncols: usize) -> Mat<f64> {
    Mat::from_fn(rows.len(), ncols, |i, j| rows[i][j])
}

fn system(s: &Ss) -> StateSpace {
    let n = s.a.len();
    let m = s.d[0].len();
    StateSpace::new(mat(&s.a, n), mat(&s.b, m), mat(&s.c, n), mat(&s.d, m), s.ts).unwrap()
}

/// The system of a case: G, or the closed loop G K / (1 + G K) built by fts.
fn case_system(c: &Case) -> StateSpace {
    let g = system(&c.g);
    match &c.k {
        None => g,
        Some(k) => fts::lti::response::closed_loop(&g, &system(k)).unwrap(),
    }
}

fn grid(c: &Case, sys: &StateSpace) -> TimeGrid {
    match sys.ts {
        None => TimeGrid::continuous(c.grid.t_final, c.grid.n).unwrap(),
        Some(ts) => TimeGrid::discrete(c.grid.t_final, ts).unwrap(),
    }
}

fn close(name: &str, what: &str, got: Option<f64>, want: Option<f64>, scale: f64) {
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => assert!(
            (g - w).abs() <= 1e-6 * scale.max(w.abs()),
            "{name}: {what} = {g}, python-control {w}"
        ),
        _ => panic!("{name}: {what} = {got:?}, python-control {want:?}"),
    }
}

fn compare_info(name: &str, got: &StepInfo, want: &Info) {
    // Times on a shared grid: absolute 1e-6 s (the grids here are >= 1e-6 s apart,
    // so a figure one sample off fails); values relative to max(1, |value|).
    let t = 1.0;
    close(name, "rise_time", got.rise_time, want.rise_time, 0.0);
    close(
        name,
        "settling_time",
        got.settling_time,
        want.settling_time,
        0.0,
    );
    close(name, "settling_min", got.settling_min, want.settling_min, t);
    close(name, "settling_max", got.settling_max, want.settling_max, t);
    close(name, "overshoot", Some(got.overshoot), want.overshoot, t);
    close(name, "undershoot", Some(got.undershoot), want.undershoot, t);
    close(name, "peak", Some(got.peak), want.peak, t);
    close(name, "peak_time", Some(got.peak_time), want.peak_time, 0.0);
    close(
        name,
        "steady_state",
        Some(got.steady_state),
        want.steady_state,
        t,
    );
    let ss = want.steady_state.unwrap();
    assert!((got.steady_state_error - (1.0 - ss)).abs() < 1e-9);
}

#[test]
fn step_info_equals_python_control() {
    let cases = cases();
    assert!(cases.len() >= 12);
    let mut compared = 0;
    for c in &cases {
        let sys = case_system(c);
        let r = time_response(&sys, ResponseKind::Step, &grid(c, &sys)).unwrap();
        let infos = step_info_of(&sys, &r).unwrap();
        match &c.step_info {
            Some(want) => {
                assert!(c.stable);
                for (i, row) in want.iter().enumerate() {
                    for (j, w) in row.iter().enumerate() {
                        let name = format!("{} [y{i} <- u{j}]", c.name);
                        let got = infos[i][j]
                            .as_ref()
                            .unwrap_or_else(|e| panic!("{name}: {e}"));
                        compare_info(&name, got, w);
                        compared += 1;
                    }
                }
            }
            None => {
                assert!(!c.stable);
                assert!(
                    infos
                        .iter()
                        .flatten()
                        .all(|i| *i == Err(NoStepInfo::Unstable)),
                    "{}: an unstable system must have no step figures",
                    c.name
                );
            }
        }
    }
    // 4 channels for the MIMO case, one for each other stable case.
    assert!(compared >= 15, "{compared}");
}

fn compare_samples(c: &Case, kind: ResponseKind, want: &[Vec<Vec<f64>>]) {
    let sys = case_system(c);
    let r = time_response(&sys, kind, &grid(c, &sys)).unwrap();
    let peak = want
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, row) in want.iter().enumerate() {
        for (j, samples) in row.iter().enumerate() {
            for (m, w) in samples.iter().enumerate() {
                let g = r.y[i][j][m * c.stride];
                assert!(
                    (g - w).abs() <= 1e-9 * peak.max(1.0),
                    "{} {kind:?} [y{i} <- u{j}] sample {}: {g} vs python-control {w}",
                    c.name,
                    m * c.stride
                );
            }
        }
    }
}

#[test]
fn step_and_impulse_samples_equal_python_control() {
    for c in &cases() {
        compare_samples(c, ResponseKind::Step, &c.step);
        compare_samples(c, ResponseKind::Impulse, &c.impulse);
    }
}

#[test]
fn closed_loops_have_python_controls_poles() {
    for c in cases().iter().filter(|c| c.k.is_some()) {
        let mut got = case_system(c).poles().unwrap();
        let mut want: Vec<_> = c
            .closed_loop_poles
            .as_ref()
            .unwrap()
            .iter()
            .map(|p| fts::lti::c64::new(p[0], p[1]))
            .collect();
        let key = |z: &fts::lti::c64| (z.re, z.im);
        got.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
        want.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
        assert_eq!(got.len(), want.len(), "{}", c.name);
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (g - w).norm() < 1e-6 * w.norm().max(1.0),
                "{}: {g} vs {w}",
                c.name
            );
        }
    }
}

/// The [Li21] Eq. 11 closed loop read from its fts.tf/1 fixture (delay
/// as states) gives python-control's figures too.
#[test]
fn li21_fixture_read_as_tf_matches() {
    let c = cases()
        .into_iter()
        .find(|c| c.name.contains("Li21"))
        .unwrap();
    let text = std::fs::read_to_string("fixtures/li21-closed-loop.json").unwrap();
    let sys = fts::io::ss_json::parse_system(&text, "li21").unwrap();
    assert!(matches!(
        tf_json::parse_tf(&text, "li21").unwrap(),
        fts::lti::TransferFunction::Discrete(_)
    ));
    let r = time_response(&sys, ResponseKind::Step, &grid(&c, &sys)).unwrap();
    let info = step_info_of(&sys, &r).unwrap()[0][0].clone().unwrap();
    compare_info("li21 fixture", &info, &c.step_info.as_ref().unwrap()[0][0]);
}
