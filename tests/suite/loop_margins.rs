//! `fts::lti::margins` against python-control (tests/data/loop/cases.json,
//! written by tests/data/loop/make_loop_cases.py), plus properties that hold
//! whatever the peer says.
//!
//! Where the two disagree the test checks the loop itself and says which is
//! right:
//!
//! * python-control counts `w = 0` as a phase crossover of a discrete loop
//!   with an integrator (`d_multi_gain_crossover`: gm 4e-11 at w = 0, from
//!   `L(z = 1)` evaluated next to the pole). `L(1)` is infinite there, so
//!   there is no crossover at DC: fts reports none at 0 Hz.
//! * python-control ignores the Nyquist frequency (`z = -1`) as a phase
//!   crossover; `L(-1)` is real, and when it is negative it is one (MATLAB's
//!   `allmargin` reports it). fts includes it; the test checks `L(-1) < 0`.
//! * python-control's continuous modulus margin is the smallest *interior*
//!   local minimum of `|1 + L|`; when the minimum sits at DC
//!   (`biproper_loop`: `|1 + L(0)| = 1.375 < 1.478`) or is approached at high
//!   frequency (`multi_gain_crossover`: `|1 + L| -> 1 < 1.005`) fts reports
//!   that end of its range, and the test checks the value there.
//! * where python-control falls back to its coarse "frd" method (discrete
//!   loops it deems ill-conditioned) its crossovers are interpolated, good to
//!   about 1e-5: those are compared to 1e-4, and the test checks that fts's
//!   crossover lies closer to the negative real axis than python-control's.
//! * for discrete loops python-control finds the modulus margin with one
//!   local minimiser of loose tolerance over the whole unit circle: the
//!   value is compared to 1e-6, and fts's frequency must give a `|1 + L|`
//!   no larger than python-control's frequency does.
//! * python-control's `bandwidth` evaluates a discrete `T` at `z = jw`
//!   instead of `z = e^{jw dt}` (and then fails to bracket); the discrete
//!   cases use `bandwidth_checked`, its definition on the unit circle.
//! * peaks of `|S|`, `|T|` come from a 2e5-point sweep refined by a bounded
//!   minimiser: compared to 1e-6. When the sup is the sweep's end (`|S| -> 1`
//!   as `w -> inf`) the two ranges differ, so only 1e-4 is asked.

use fts::lti::margins::{LoopParams, LoopReport, LoopSystem, analyze_loop};
use fts::lti::{ContinuousTf, DiscreteTf, TransferFunction, c64};
use serde_json::Value;
use std::f64::consts::PI;

const REL: f64 = 1e-6;

fn cases() -> Vec<Value> {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/loop/cases.json"
    ))
    .unwrap();
    serde_json::from_str::<Vec<Value>>(&text).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn system(v: &Value) -> LoopSystem {
    let (num, den) = (floats(&v["num"]), floats(&v["den"]));
    LoopSystem::Tf(match v["var"].as_str().unwrap() {
        "s" => TransferFunction::Continuous(ContinuousTf::new(num, den).unwrap()),
        _ => TransferFunction::Discrete(
            DiscreteTf::new(num, den, 0, v["ts"].as_f64().unwrap()).unwrap(),
        ),
    })
}

fn opt(v: &Value) -> Option<f64> {
    v.as_f64()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
}

fn hz(w: f64) -> f64 {
    w / (2.0 * PI)
}

struct Case {
    name: String,
    v: Value,
    g: LoopSystem,
    k: LoopSystem,
    r: LoopReport,
}

impl Case {
    fn l(&self, f: f64) -> c64 {
        self.g.response_at_hz(f) * self.k.response_at_hz(f)
    }
    fn nyquist(&self) -> Option<f64> {
        self.r.ts.map(|t| 0.5 / t)
    }
}

fn analysed() -> Vec<Case> {
    cases()
        .into_iter()
        .map(|v| {
            let (g, k) = (system(&v["g"]), system(&v["k"]));
            let r = analyze_loop(&g, &k, &LoopParams::default())
                .unwrap_or_else(|e| panic!("{}: {e}", v["name"]));
            Case {
                name: v["name"].as_str().unwrap().to_owned(),
                v,
                g,
                k,
                r,
            }
        })
        .collect()
}

#[test]
fn at_least_twenty_cases_of_every_kind() {
    let c = cases();
    assert!(c.len() >= 20);
    let discrete = c.iter().filter(|v| v["g"]["var"] == "z^-1").count();
    assert!(discrete >= 5 && c.len() - discrete >= 5);
}

#[test]
fn gain_margin_matches_python_control() {
    for c in analysed() {
        let (gm, wpc) = (opt(&c.v["gm"]), opt(&c.v["wpc"]));
        let mine = c.r.gain_margin;
        match (gm, mine) {
            (None, None) => {}
            (None, Some(m)) => {
                // Only the Nyquist crossover python-control does not look at.
                assert_eq!(Some(m.freq_hz), c.nyquist(), "{}", c.name);
                let l = c.l(m.freq_hz);
                assert!(l.re < 0.0 && l.im.abs() <= 1e-9 * l.norm(), "{}", c.name);
            }
            (Some(gm), _) if c.name == "d_multi_gain_crossover" => {
                // python-control: w = 0 next to the integrator's pole.
                assert!(gm < 1e-6 && wpc == Some(0.0));
                assert!(c.r.phase_crossovers.iter().all(|p| p.freq_hz > 0.0));
            }
            (Some(gm), Some(m)) => {
                let wpc = hz(wpc.unwrap());
                let frd = c.v["py_method"] == "frd";
                let tol = if frd { 1e-4 } else { REL };
                // python-control's crossover is one of ours...
                let same = c.r.phase_crossovers.iter().find(|p| {
                    close(p.gain_margin, gm, tol)
                        && (close(p.freq_hz, wpc, tol) || p.freq_hz.abs() + wpc.abs() < 1e-12)
                });
                if let (true, Some(p)) = (frd, same) {
                    let off = |f: f64| c.l(f).arg().abs() - PI;
                    assert!(off(p.freq_hz).abs() <= off(wpc).abs(), "{}", c.name);
                }
                assert!(
                    same.is_some(),
                    "{}: python gm {gm} at {wpc} Hz; fts {:?}",
                    c.name,
                    c.r.phase_crossovers
                );
                // ...and ours is that one unless a Nyquist crossover is worse.
                if Some(m.freq_hz) != c.nyquist() {
                    assert!(close(m.gain_margin, gm, tol), "{}: {m:?} vs {gm}", c.name);
                } else {
                    assert!(m.gain_margin.ln().abs() <= gm.ln().abs(), "{}", c.name);
                }
            }
            (Some(gm), None) => panic!("{}: python gm {gm}, fts none", c.name),
        }
    }
}

#[test]
fn phase_margin_and_crossovers_match_python_control() {
    for c in analysed() {
        let pm = opt(&c.v["pm"]);
        match (pm, c.r.phase_margin) {
            (None, None) => {}
            (Some(pm), Some(m)) => {
                let wgc = hz(c.v["wgc"].as_f64().unwrap());
                assert!(
                    (m.phase_margin_deg - pm).abs() <= REL * pm.abs().max(1.0),
                    "{}: pm {} vs {pm}",
                    c.name,
                    m.phase_margin_deg
                );
                assert!(
                    close(m.freq_hz, wgc, REL),
                    "{}: {} vs {wgc}",
                    c.name,
                    m.freq_hz
                );
            }
            (pm, mine) => panic!("{}: python {pm:?}, fts {mine:?}", c.name),
        }
        let n = c.v["n_gain_crossovers"].as_u64().unwrap() as usize;
        assert_eq!(c.r.gain_crossovers.len(), n, "{}", c.name);
        for (w, g) in floats(&c.v["all_wgc"]).iter().zip(&c.r.gain_crossovers) {
            assert!(close(g.freq_hz, hz(*w), REL), "{}", c.name);
        }
    }
}

#[test]
fn modulus_margin_matches_python_control() {
    for c in analysed() {
        let (sm, wms) = (c.v["sm"].as_f64().unwrap(), c.v["wms"].as_f64().unwrap());
        let mm = c.r.modulus_margin;
        let tol = if c.v["py_method"] == "frd" { 1e-4 } else { REL };
        if mm.value < sm * (1.0 - tol) {
            // python-control only looks at interior local minima: a smaller
            // |1 + L| of fts must sit at an end of the range (DC, or the top
            // where |1 + L| tends to |1 + L(inf)|), and be what it says.
            assert!(
                mm.freq_hz == 0.0 || mm.freq_hz == c.r.diagnostics.f_max_hz,
                "{}: {mm:?} vs python {sm} at {}",
                c.name,
                hz(wms)
            );
            assert!(
                close(mm.value, (1.0 + c.l(mm.freq_hz)).norm(), 1e-9),
                "{}",
                c.name
            );
            continue;
        }
        assert!(close(mm.value, sm, tol), "{}: {} vs {sm}", c.name, mm.value);
        match c.r.ts {
            None => assert!(
                close(mm.freq_hz, hz(wms), REL),
                "{}: {} vs {}",
                c.name,
                mm.freq_hz,
                hz(wms)
            ),
            // python-control's discrete search is one bounded local
            // minimisation over the whole circle: it can answer with the
            // mirror image above Nyquist (vfts_pid: 7991 Hz for 2009 Hz at
            // 10 kHz sampling), or stop short of a minimum at Nyquist
            // (d_multi_gain_crossover: 24.40 Hz for 25 Hz). fts's frequency
            // must minimise |1 + L| at least as well.
            Some(_) => assert!(
                (1.0 + c.l(mm.freq_hz)).norm() <= (1.0 + c.l(hz(wms))).norm() * (1.0 + 1e-12),
                "{}: {} vs {}",
                c.name,
                mm.freq_hz,
                hz(wms)
            ),
        }
        assert!(close(c.r.peak_s.value, 1.0 / sm, tol), "{}", c.name);
    }
}

#[test]
fn peaks_and_bandwidth_match_the_sweep() {
    for c in analysed() {
        let lohi = floats(&c.v["sweep_rad_s"]);
        for (which, mine) in [("s", c.r.peak_s), ("t", c.r.peak_t)] {
            let value = c.v[format!("peak_{which}")].as_f64().unwrap();
            let w = c.v[format!("w_peak_{which}")].as_f64().unwrap();
            let at_end = close(w, lohi[0], 1e-9) || close(w, lohi[1], 1e-9);
            let tol = if at_end { 1e-4 } else { REL };
            assert!(
                close(mine.value, value, tol),
                "{} |{which}|: {} vs {value}",
                c.name,
                mine.value
            );
        }
        let bw = opt(&c.v["bandwidth_checked"]);
        match (bw, c.r.bandwidth_hz) {
            (None, None) => {}
            (Some(bw), Some(m)) => assert!(close(m, hz(bw), REL), "{}: {m} vs {}", c.name, hz(bw)),
            (bw, m) => panic!("{}: bandwidth python {bw:?}, fts {m:?}", c.name),
        }
    }
}

#[test]
fn closed_loop_poles_and_stability_match_python_control() {
    for c in analysed() {
        assert_eq!(
            c.r.closed_loop_stable,
            c.v["cl_stable"].as_bool().unwrap(),
            "{}",
            c.name
        );
        let theirs: Vec<c64> = c.v["cl_poles"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| c64::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
            .collect();
        let mut mine: Vec<c64> =
            c.r.closed_loop_poles
                .iter()
                .map(|p| c64::new(p[0], p[1]))
                .collect();
        // Poles of python-control's polynomial that are exactly at the
        // origin of the z-plane are delay states in both.
        assert_eq!(mine.len(), theirs.len(), "{}", c.name);
        for p in theirs {
            let (i, d) = mine
                .iter()
                .enumerate()
                .map(|(i, q)| (i, (q - p).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            assert!(
                d <= 1e-6 * p.norm().max(1.0),
                "{}: pole {p} off by {d}",
                c.name
            );
            mine.swap_remove(i);
        }
    }
}

#[test]
fn margins_are_what_they_claim() {
    // Independent evaluation: through the state-space realisation.
    for c in analysed() {
        let (gs, ks) = (
            LoopSystem::Ss(c.g.to_ss().unwrap()),
            LoopSystem::Ss(c.k.to_ss().unwrap()),
        );
        let l = |f: f64| gs.response_at_hz(f) * ks.response_at_hz(f);
        for g in &c.r.gain_crossovers {
            assert!((l(g.freq_hz).norm() - 1.0).abs() < 1e-9, "{}", c.name);
        }
        for p in &c.r.phase_crossovers {
            let v = l(p.freq_hz);
            let deg = v.arg().to_degrees().abs();
            assert!((deg - 180.0).abs() < 1e-7, "{}: {deg}", c.name);
            assert!(close(1.0 / v.norm(), p.gain_margin, 1e-9), "{}", c.name);
        }
        let mm = c.r.modulus_margin;
        assert!(
            close((1.0 + l(mm.freq_hz)).norm(), mm.value, 1e-9),
            "{}",
            c.name
        );
        // No grid point beats the refined modulus margin.
        for f in fts::lti::logspace(c.r.diagnostics.f_min_hz, c.r.diagnostics.f_max_hz, 5000) {
            assert!(
                (1.0 + l(f)).norm() >= mm.value * (1.0 - 1e-12),
                "{}",
                c.name
            );
        }
        if let Some(d) = c.r.delay_margin {
            // The delay rotates L onto -1 at that crossover.
            let rot = c64::from_polar(1.0, -2.0 * PI * d.freq_hz * d.delay_margin_s);
            assert!((l(d.freq_hz) * rot + 1.0).norm() < 1e-9, "{}", c.name);
        }
    }
}

#[test]
fn an_unstable_open_loop_is_flagged() {
    for c in analysed() {
        let expect = c.name.contains("unstable_plant");
        assert_eq!(c.r.diagnostics.open_loop_unstable, expect, "{}", c.name);
        if expect {
            assert!(c.r.diagnostics.notes.iter().any(|n| n.contains("Nyquist")));
        }
    }
}
