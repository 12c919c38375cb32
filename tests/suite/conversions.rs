//! Model conversions against python-control, slycot and scipy
//! (tests/data/responses/conversions.json, written by gen_conversions.py):
//! tf -> ss and ss -> tf per channel by frequency response (realisations
//! are not unique), zpk zeros/poles/gain, minreal orders, balred Hankel
//! singular values, error bound and reduced responses, d2c against scipy's
//! logm of the augmented ZOH matrix.

use faer::Mat;
use fts::lti::c2d::{C2dMethod, c2d};
use fts::lti::convert::{self, Zpk};
use fts::lti::{ContinuousTf, DiscreteTf, StateSpace, TransferFunction, c64};
use serde::Deserialize;

#[derive(Deserialize, Clone)]
struct Ss {
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    c: Vec<Vec<f64>>,
    d: Vec<Vec<f64>>,
    ts: Option<f64>,
}

#[derive(Deserialize)]
struct TfCase {
    name: String,
    num: Vec<f64>,
    den: Vec<f64>,
    ts: Option<f64>,
    w: Vec<f64>,
    response: Vec<Vec<Vec<[f64; 2]>>>,
    zeros: Vec<[f64; 2]>,
    poles: Vec<[f64; 2]>,
    gain: f64,
}

#[derive(Deserialize)]
struct ZpkChannel {
    output: usize,
    input: usize,
    zeros: Vec<[f64; 2]>,
    poles: Vec<[f64; 2]>,
    gain: f64,
}

#[derive(Deserialize)]
struct SsCase {
    name: String,
    sys: Ss,
    w: Vec<f64>,
    response: Vec<Vec<Vec<[f64; 2]>>>,
    zpk: Vec<ZpkChannel>,
}

#[derive(Deserialize)]
struct MinrealCase {
    name: String,
    sys: Ss,
    order: usize,
    w: Vec<f64>,
    response: Vec<Vec<Vec<[f64; 2]>>>,
}

#[derive(Deserialize)]
struct BalredCase {
    name: String,
    sys: Ss,
    order: usize,
    hsv: Vec<f64>,
    bound: f64,
    w: Vec<f64>,
    response: Option<Vec<Vec<Vec<[f64; 2]>>>>,
}

#[derive(Deserialize)]
struct D2cCase {
    name: String,
    discrete: Ss,
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
}

#[derive(Deserialize)]
struct Data {
    tf: Vec<TfCase>,
    ss: Vec<SsCase>,
    minreal: Vec<MinrealCase>,
    balred: Vec<BalredCase>,
    d2c: Vec<D2cCase>,
}

fn data() -> Data {
    let text = std::fs::read_to_string("tests/data/responses/conversions.json").unwrap();
    serde_json::from_str(&text).unwrap()
}

fn mat(rows: &[Vec<f64>], nrows: usize, ncols: usize) -> Mat<f64> {
    Mat::from_fn(nrows, ncols, |i, j| rows[i][j])
}

fn system(s: &Ss) -> StateSpace {
    let (n, p, m) = (s.a.len(), s.d.len(), s.d[0].len());
    StateSpace::new(
        mat(&s.a, n, n),
        mat(&s.b, n, m),
        mat(&s.c, p, n),
        mat(&s.d, p, m),
        s.ts,
    )
    .unwrap()
}

fn point(w: f64, ts: Option<f64>) -> c64 {
    match ts {
        None => c64::new(0.0, w),
        Some(t) => c64::from_polar(1.0, w * t),
    }
}

fn check_response(name: &str, sys: &StateSpace, w: &[f64], want: &[Vec<Vec<[f64; 2]>>], tol: f64) {
    for (k, &wk) in w.iter().enumerate() {
        let g = sys.eval(point(wk, sys.ts)).unwrap();
        for (i, row) in want.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let want = c64::new(v[k][0], v[k][1]);
                let got = g[(i, j)];
                assert!(
                    (got - want).norm() <= tol * want.norm().max(1e-3),
                    "{name} [y{i} <- u{j}] at w = {wk}: {got} vs {want}"
                );
            }
        }
    }
}

/// `G(jw)` or `G(e^{jw ts})` of a transfer function (w in rad/s).
fn tf_response(t: &TransferFunction, w: f64) -> c64 {
    t.response_at_hz(w / (2.0 * std::f64::consts::PI))
}

/// Each list sorted the way the generator sorted it, then compared.
fn check_roots(name: &str, what: &str, got: &[c64], want: &[[f64; 2]]) {
    let mut got: Vec<c64> = got.to_vec();
    got.sort_by(|a, b| {
        let ka = ((a.re * 1e9).round(), a.im);
        let kb = ((b.re * 1e9).round(), b.im);
        ka.partial_cmp(&kb).unwrap()
    });
    assert_eq!(got.len(), want.len(), "{name}: {what} {got:?} vs {want:?}");
    for (g, w) in got.iter().zip(want) {
        let w = c64::new(w[0], w[1]);
        // 1e-6: the MIMO cases have a double (defective) pole at -1.5,
        // which any root finder only resolves to about sqrt(eps).
        assert!(
            (g - w).norm() <= 1e-6 * w.norm().max(1.0),
            "{name}: {what} {g} vs {w}"
        );
    }
}

fn check_zpk(name: &str, z: &Zpk, zeros: &[[f64; 2]], poles: &[[f64; 2]], gain: f64) {
    check_roots(name, "zeros", &z.zeros, zeros);
    check_roots(name, "poles", &z.poles, poles);
    assert!(
        (z.gain - gain).abs() <= 1e-9 * gain.abs(),
        "{name}: gain {} vs {gain}",
        z.gain
    );
}

/// python-control's descending coefficients as an fts transfer function.
fn tf_of(c: &TfCase) -> TransferFunction {
    match c.ts {
        None => {
            TransferFunction::Continuous(ContinuousTf::new(c.num.clone(), c.den.clone()).unwrap())
        }
        Some(ts) => {
            // Descending powers of z over deg(den) = ascending powers of z^-1.
            let mut num = vec![0.0; c.den.len() - c.num.len()];
            num.extend(&c.num);
            TransferFunction::Discrete(DiscreteTf::new(num, c.den.clone(), 0, ts).unwrap())
        }
    }
}

#[test]
fn tf_to_ss_and_back_keep_the_frequency_response() {
    for c in &data().tf {
        let g = tf_of(c);
        let ss = fts::lti::margins::LoopSystem::Tf(g.clone())
            .to_ss()
            .unwrap();
        check_response(&c.name, &ss, &c.w, &c.response, 1e-9);
        let back = convert::siso_tf(&ss).unwrap();
        for (k, &w) in c.w.iter().enumerate() {
            let want = c64::new(c.response[0][0][k][0], c.response[0][0][k][1]);
            let got = tf_response(&back, w);
            assert!(
                (got - want).norm() <= 1e-9 * want.norm(),
                "{}: {got} vs {want}",
                c.name
            );
        }
        check_zpk(
            &c.name,
            &convert::zpk(&g).unwrap(),
            &c.zeros,
            &c.poles,
            c.gain,
        );
        // The round trip keeps the zpk form too (no spurious zeros or poles).
        check_zpk(
            &c.name,
            &convert::zpk(&back).unwrap(),
            &c.zeros,
            &c.poles,
            c.gain,
        );
    }
}

#[test]
fn ss_to_tf_per_channel_matches_python_control() {
    for c in &data().ss {
        let sys = system(&c.sys);
        check_response(&c.name, &sys, &c.w, &c.response, 1e-12);
        let tfs = convert::ss_to_tfs(&sys).unwrap();
        for ch in &c.zpk {
            let (i, j) = (ch.output - 1, ch.input - 1);
            let t = tfs[i][j].as_ref().unwrap();
            for (k, &w) in c.w.iter().enumerate() {
                let want = c64::new(c.response[i][j][k][0], c.response[i][j][k][1]);
                let got = tf_response(t, w);
                assert!(
                    (got - want).norm() <= 1e-8 * want.norm().max(1e-3),
                    "{} [y{i} <- u{j}] w = {w}: {got} vs {want}",
                    c.name
                );
            }
            let z = convert::zpk(t).unwrap();
            let name = format!("{} [y{i} <- u{j}]", c.name);
            check_zpk(&name, &z, &ch.zeros, &ch.poles, ch.gain);
        }
    }
}

#[test]
fn minreal_finds_slycots_order_and_keeps_the_response() {
    for c in &data().minreal {
        let sys = system(&c.sys);
        let m = convert::minreal(&sys, f64::EPSILON.sqrt()).unwrap();
        assert_eq!(m.nx(), c.order, "{}", c.name);
        assert!(m.nx() < sys.nx(), "{}: nothing removed", c.name);
        check_response(&c.name, &m, &c.w, &c.response, 1e-9);
    }
}

#[test]
fn balred_matches_hankel_singular_values_and_bound() {
    for c in &data().balred {
        let sys = system(&c.sys);
        let red = convert::balred_any(&sys, c.order).unwrap();
        assert_eq!(red.sys.nx(), c.order);
        assert_eq!(red.hsv.len(), c.hsv.len());
        for (g, w) in red.hsv.iter().zip(&c.hsv) {
            // Relative 1e-6, or 1e-9 of the largest for the tiny ones.
            assert!(
                (g - w).abs() <= 1e-6 * w + 1e-9 * c.hsv[0],
                "{}: hsv {g} vs {w}",
                c.name
            );
        }
        let e = (red.bound - c.bound).abs();
        assert!(
            e <= 1e-6 * c.bound + 1e-8 * c.hsv[0],
            "{}: bound {} vs {}",
            c.name,
            red.bound,
            c.bound
        );
        assert_eq!(red.sys.ts, sys.ts);
        match (&c.response, sys.ts) {
            (Some(resp), None) => check_response(&c.name, &red.sys, &c.w, resp, 1e-6),
            // Discrete: fts truncates the bilinear image (same Hankel singular
            // values and bound), slycot the discrete balanced realisation; the
            // two reduced models differ, each within the bound of G, so within
            // twice the bound of each other.
            (Some(resp), Some(_)) => {
                for (k, &w) in c.w.iter().enumerate() {
                    let want = c64::new(resp[0][0][k][0], resp[0][0][k][1]);
                    let got = red.sys.eval(point(w, sys.ts)).unwrap()[(0, 0)];
                    assert!((got - want).norm() <= 2.0 * c.bound, "{}: w = {w}", c.name);
                }
            }
            (None, _) => {}
        }
        // The a-priori bound holds on a dense grid.
        let top = sys.ts.map_or(1e3, |t| std::f64::consts::PI / t);
        for k in 0..2000 {
            let w = 1e-3 * (top / 1e-3f64).powf(k as f64 / 1999.0);
            let p = point(w, sys.ts);
            let e = (sys.eval(p).unwrap()[(0, 0)] - red.sys.eval(p).unwrap()[(0, 0)]).norm();
            assert!(
                e <= red.bound * (1.0 + 1e-9),
                "{}: error {e} > bound {}",
                c.name,
                red.bound
            );
        }
    }
}

#[test]
fn d2c_equals_scipy_logm_and_inverts_c2d() {
    for c in &data().d2c {
        let d = system(&c.discrete);
        let cont = convert::d2c(&d).unwrap();
        let n = d.nx();
        let (a, b) = (mat(&c.a, n, n), mat(&c.b, n, d.nu()));
        let scale = a.norm_l2() + b.norm_l2();
        let err = (&cont.a - &a).norm_l2() + (&cont.b - &b).norm_l2();
        assert!(err <= 1e-9 * scale, "{}: |d2c - logm| = {err}", c.name);
        let again = c2d(&cont, d.ts.unwrap(), C2dMethod::Zoh).unwrap();
        assert!(
            (&again.a - &d.a).norm_l2() < 1e-12 * d.a.norm_l2().max(1.0),
            "{}",
            c.name
        );
        assert!(
            (&again.b - &d.b).norm_l2() < 1e-12 * d.b.norm_l2().max(1.0),
            "{}",
            c.name
        );
    }
}
