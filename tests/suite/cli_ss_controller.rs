//! An H-infinity (mixsyn) controller end to end: `fts weight` -> `fts mixsyn`
//! -> `fts emit --ss` -> `fts simulate --controller --plant-tf`, checked
//! against an independent linear computation of the closed loop; and the
//! `state_space` block's bad inputs.

use crate::common::cmd::{fts, predicate};
use fts::io::controller_file::parse_controller;
use fts::io::tf_json::parse_tf;
use fts::lti::TransferFunction;
use fts::lti::ss::StateSpace;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// Weights, mixsyn (reduced to 3 states) and emit into `dir`; returns the
/// controller file.
fn design(dir: &Path) -> PathBuf {
    let (ws, wu, k, c) = (
        dir.join("ws.json"),
        dir.join("wu.json"),
        dir.join("k.json"),
        dir.join("controller.json"),
    );
    fts()
        .args([
            "weight", "--kind", "ws", "--m", "2", "--w0-rad", "1500", "--a", "1e-4", "-o",
        ])
        .arg(&ws)
        .assert()
        .success();
    fts()
        .args([
            "weight",
            "--kind",
            "makeweight",
            "--dc",
            "0.05",
            "--freq-rad",
            "20000",
            "--mag",
            "1",
            "--hf",
            "20",
            "-o",
        ])
        .arg(&wu)
        .assert()
        .success();
    fts()
        .arg("mixsyn")
        .arg("--plant")
        .arg(fixture("second-order-plant.json"))
        .arg("--ws")
        .arg(&ws)
        .arg("--wu")
        .arg(&wu)
        .args(["--order", "3", "-o"])
        .arg(&k)
        .assert()
        .success();
    fts()
        .arg("emit")
        .arg("--ss")
        .arg(&k)
        .args(["--ts", "1e-4", "-o"])
        .arg(&c)
        .arg("--c-header")
        .arg(dir.join("controller.h"))
        .assert()
        .success();
    c
}

/// The plant's discrete tf as a state-space system (descending powers of z).
fn plant_ss() -> StateSpace {
    let path = fixture("second-order-plant-zoh.json");
    let TransferFunction::Discrete(g) =
        parse_tf(&std::fs::read_to_string(&path).unwrap(), "plant").unwrap()
    else {
        panic!("discrete")
    };
    let (b, a) = (g.num().coeffs(), g.den().coeffs());
    let n = (b.len() - 1 + g.delay()).max(a.len() - 1);
    let mut num = vec![0.0; n + 1];
    let mut den = vec![0.0; n + 1];
    for (i, x) in b.iter().enumerate() {
        num[g.delay() + i] = *x;
    }
    den[..a.len()].copy_from_slice(a);
    StateSpace::from_tf(&num, &den, Some(g.ts())).unwrap()
}

/// `y = T r` by the state recursion of a discrete system.
fn lsim_ss(t: &StateSpace, r: &[f64]) -> Vec<f64> {
    let n = t.nx();
    let mut x = vec![0.0; n];
    r.iter()
        .map(|&u| {
            let y: f64 = (0..n).map(|j| t.c[(0, j)] * x[j]).sum::<f64>() + t.d[(0, 0)] * u;
            let next: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| t.a[(i, j)] * x[j]).sum::<f64>() + t.b[(i, 0)] * u)
                .collect();
            x = next;
            y
        })
        .collect()
}

#[test]
fn mixsyn_controller_emitted_and_simulated_matches_linear_closed_loop() {
    let dir = tempfile::tempdir().unwrap();
    let file = design(dir.path());
    let trace = dir.path().join("trace.csv");
    let out = fts()
        .args(["simulate", "--controller"])
        .arg(&file)
        .arg("--plant-tf")
        .arg(fixture("second-order-plant-zoh.json"))
        .args([
            "--reference",
            "sine",
            "--freq",
            "10",
            "--amplitude",
            "5",
            "--offset",
            "0",
            "--json",
            "-o",
        ])
        .arg(&trace)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["controller"], "ss");
    assert_eq!(v["saturated_samples"], 0);
    let max_err = v["max_abs_error"].as_f64().unwrap();
    // |S(j 2 pi 10)| of this design is about 0.04: 0.2 um on 5 um.
    assert!(max_err < 0.25, "10 Hz tracking error {max_err} um");

    // Independent linear computation: T = (G K) / (1 + G K) from lti
    // series/feedback, run by its state recursion on the same reference.
    let ctrl = parse_controller(&std::fs::read_to_string(&file).unwrap(), "c").unwrap();
    let k = ctrl.state_space().unwrap().to_state_space(ctrl.ts).unwrap();
    let g = plant_ss();
    let l = k.series(&g).unwrap();
    let one = StateSpace::gain(faer::Mat::from_fn(1, 1, |_, _| 1.0), Some(ctrl.ts));
    let t = l.feedback(&one).unwrap();
    assert!(t.is_stable().unwrap());
    let text = std::fs::read_to_string(&trace).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let r: Vec<f64> = rows.iter().map(|row| row[1]).collect();
    let y_sim: Vec<f64> = rows.iter().map(|row| row[5]).collect();
    let y_lin = lsim_ss(&t, &r);
    let dev = y_sim
        .iter()
        .zip(&y_lin)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        dev < 1e-9,
        "simulated loop vs linear closed loop: {dev:e} um"
    );

    // The same through the closed-loop transfer function and lti::lsim.
    let (num, den) = t.to_tf().unwrap();
    let lead = num.iter().position(|x| x.abs() > 1e-12).unwrap();
    let tf = fts::lti::DiscreteTf::new(num[lead..].to_vec(), den.clone(), lead, ctrl.ts).unwrap();
    let y_tf = fts::lti::lsim(&tf, &r);
    let dev_tf = y_sim
        .iter()
        .zip(&y_tf)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        dev_tf < 1e-8,
        "simulated loop vs lsim of T(z): {dev_tf:e} um"
    );
    eprintln!("max |e| {max_err} um; |y_sim - y_ss| {dev:e}; |y_sim - lsim(T)| {dev_tf:e}");
}

#[test]
fn state_space_controller_runs_on_the_virtual_fts() {
    let dir = tempfile::tempdir().unwrap();
    let file = design(dir.path());
    let out = fts()
        .args(["simulate", "--controller"])
        .arg(&file)
        .args([
            "--reference",
            "sine",
            "--freq",
            "10",
            "--amplitude",
            "2",
            "--json",
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["controller"], "ss");
    assert!(v["max_abs_error"].as_f64().unwrap().is_finite());
}

#[test]
fn bad_state_space_blocks_exit_2_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let file = design(dir.path());
    let good: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let pid = serde_json::json!({"type": "pid", "form": "li21", "kp": 0.05, "ki": 0.3,
        "kd": 0.0, "output_min": 0.0, "output_max": 10.0});
    let big: Vec<Vec<f64>> = (0..17)
        .map(|i| (0..17).map(|j| if i == j { 0.5 } else { 0.0 }).collect())
        .collect();
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|d| {
                d["blocks"][0]["b"].as_array_mut().unwrap().pop();
            }),
            "blocks[0].b",
        ),
        (
            Box::new(|d| d["blocks"][0]["a"][1][2] = serde_json::json!("NaN")),
            "blocks[0].a[1][2]",
        ),
        (
            Box::new(|d| d["blocks"][0]["ts"] = serde_json::json!(2e-4)),
            "blocks[0].ts",
        ),
        (
            Box::new(move |d| {
                d["blocks"][0]["a"] = serde_json::json!(big);
                d["blocks"][0]["b"] = serde_json::json!(vec![[1.0]; 17]);
                d["blocks"][0]["c"] = serde_json::json!([vec![1.0; 17]]);
                d["blocks"][0]["states"] = serde_json::json!(17);
            }),
            "state_space.a",
        ),
        (
            Box::new(move |d| {
                d["blocks"].as_array_mut().unwrap().insert(0, pid.clone());
            }),
            "blocks[1].type",
        ),
    ];
    for (i, (edit, field)) in cases.into_iter().enumerate() {
        let mut d = good.clone();
        edit(&mut d);
        let path = dir.path().join(format!("bad{i}.json"));
        std::fs::write(&path, d.to_string()).unwrap();
        let out = fts()
            .args(["simulate", "--controller"])
            .arg(&path)
            .arg("--plant-tf")
            .arg(fixture("second-order-plant-zoh.json"))
            .assert()
            .code(2)
            .get_output()
            .stderr
            .clone();
        let msg = String::from_utf8_lossy(&out);
        assert!(msg.contains(field), "case {i}: expected {field:?} in {msg}");
    }
    // A discrete --ss controller at another rate is refused by emit.
    let k = dir.path().join("k.json");
    let kd = dir.path().join("kd.json");
    fts()
        .arg("c2d")
        .arg(&k)
        .args(["--ts", "2e-4", "-o"])
        .arg(&kd)
        .assert()
        .success();
    fts()
        .arg("emit")
        .arg("--ss")
        .arg(&kd)
        .args(["--ts", "1e-4"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("sample time"));
}
