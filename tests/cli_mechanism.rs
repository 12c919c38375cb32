//! `fts mechanism` end to end against the published numbers: [Li21] Eq. 1
//! (0.55 um lost of 10 um), [Tang17]'s home Jacobian rows, the workspace
//! plot, and bad input exiting 2 naming the flag.

use assert_cmd::Command;
use serde_json::Value;

fn fts() -> Command {
    Command::cargo_bin("fts").unwrap()
}

fn json_of(cmd: &mut Command) -> Value {
    let out = cmd.assert().success().get_output().stdout.clone();
    serde_json::from_slice(&out).expect("one JSON object on stdout")
}

#[test]
fn flexure_loss_defaults_are_li21_and_lose_0_55_um() {
    let v = json_of(fts().args(["mechanism", "flexure-loss", "--json"]));
    let lost = v["lost_um"].as_f64().unwrap();
    assert_eq!(format!("{lost:.2}"), "0.55");
    assert!((lost - 10.0 * 11.6 / 211.6).abs() < 1e-12);
}

#[test]
fn tang17_home_jacobian_and_workspace_plot() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("ws.svg");
    let v = json_of(
        fts()
            .args([
                "mechanism",
                "3puu",
                "--samples",
                "20000",
                "--json",
                "--plot",
            ])
            .arg(&svg),
    );
    let j = &v["jacobian"];
    let published = [
        [-1.0276, 0.0, 1.0],
        [0.5138, -0.8899, 1.0],
        [0.5138, 0.8899, 1.0],
    ];
    for (i, row) in published.iter().enumerate() {
        for (k, b) in row.iter().enumerate() {
            let a = j[i][k].as_f64().unwrap();
            assert!((a - b).abs() < 5e-5, "J[{i}][{k}] = {a}, published {b}");
        }
    }
    let w = &v["workspace_um"];
    // Linearised bounds of a 250 um stroke: |x| <= 250/1.5414, |y| <= 250/1.7798.
    assert!(
        w[0][1].as_f64().unwrap() < 162.5 && w[1][1].as_f64().unwrap() < 141.0,
        "{w}"
    );
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
}

#[test]
fn bad_mechanism_inputs_exit_2_naming_the_flag() {
    fts()
        .args(["mechanism", "flexure-loss", "--k", "-1"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--k"));
    fts()
        .args(["mechanism", "3puu", "--rod-mm", "10"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--rod-mm"));
    fts()
        .args(["mechanism", "hinge", "--width-mm", "0"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--width-mm"));
}
