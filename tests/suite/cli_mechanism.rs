//! `fts mechanism` end to end against the published numbers: [Li21] Eq. 1
//! (0.55 um lost of 10 um), [Tang17]'s home Jacobian rows, the workspace
//! plot, and bad input exiting 2 naming the flag.

use crate::common::cmd::{fts, json_of, predicate};

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
        .stderr(predicate::str::contains("--k"));
    fts()
        .args(["mechanism", "3puu", "--rod-mm", "10"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--rod-mm"));
    fts()
        .args(["mechanism", "hinge", "--width-mm", "0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--width-mm"));
}

/// The inverse question with [Tang17]'s measured 3.87: a rigid bridge needs
/// `acot(3.87)` (14.488203 deg, python math), a rigid lever `L_out = 3.87
/// L_in`; with the [Li21] pivot the lever's ratio is below `L_out/L_in` and
/// [Li21] Eq. 1 scales the stroke by `kp/(kp + k_in)`.
#[test]
fn lever_and_bridge_answer_tang17s_ratio() {
    let b = json_of(fts().args(["mechanism", "bridge", "--json"]));
    assert!((b["angle_for_target_ideal_deg"].as_f64().unwrap() - 14.488203).abs() < 1e-6);
    assert!(b["ideal"].is_null() && b["compliant"].is_null());
    let l = json_of(fts().args([
        "mechanism",
        "lever",
        "--input-arm-mm",
        "5",
        "--output-arm-mm",
        "19.35",
        "--hinge-width-mm",
        "10",
        "--kp",
        "200",
        "--json",
    ]));
    let f = |k: &str| l[k].as_f64().unwrap();
    assert!((f("ideal") - 3.87).abs() < 1e-12);
    assert!(f("compliant") < f("ideal") && f("compliant") > 3.5);
    // The pivot's rotational stiffness is the profile's in series, not
    // [Li21] Eq. 2's sum (4.4996 against 35.1830 N m/rad).
    assert!((f("pivot_k_rot_nm_per_rad") - 4.4996).abs() < 1e-4);
    assert!((f("output_arm_for_target_ideal_mm") - 19.35).abs() < 1e-12);
    let k_in = f("input_stiffness_n_per_um");
    assert!((f("delivered_input_um") - 10.0 * 200.0 / (200.0 + k_in)).abs() < 1e-12);
    assert!((f("output_stroke_um") - f("delivered_input_um") * f("compliant")).abs() < 1e-12);
}

#[test]
fn bad_lever_and_bridge_inputs_exit_2_naming_the_flag() {
    for (args, flag) in [
        (vec!["bridge", "--angle-deg", "90"], "--angle-deg"),
        (vec!["bridge", "--hinge-width-mm", "8"], "--link-mm"),
        (
            vec!["bridge", "--link-mm", "5", "--hinge-width-mm", "-8"],
            "--hinge-width-mm",
        ),
        (vec!["bridge", "--target-ratio", "0"], "--target-ratio"),
        (vec!["lever", "--input-arm-mm", "0"], "--input-arm-mm"),
        (vec!["lever", "--input-arm-mm", "5", "--kp", "100"], "--kp"),
    ] {
        fts()
            .arg("mechanism")
            .args(&args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(flag))
            .stderr(predicate::str::contains("panicked").not());
    }
}

/// The amplifier chain: the angle its inverse prints gives the target back
/// when run; the lever loads the bridge (loaded ratio below the free one);
/// the overall ratio is the loaded bridge times the lever; [Li21] Eq. 1
/// scales the elongation by `kp/(kp + k_in)`.
#[test]
fn amplifier_chain_inverse_and_loading() {
    let geometry = [
        "mechanism",
        "amplifier",
        "--link-mm",
        "12",
        "--hinge-width-mm",
        "8",
        "--hinge-length-mm",
        "1",
        "--hinge-thickness-mm",
        "0.3",
        "--hinge-radius-mm",
        "0.5",
        "--input-arm-mm",
        "5",
        "--output-arm-mm",
        "10",
        "--kp",
        "200",
        "--json",
    ];
    let inverse = json_of(fts().args(geometry));
    let angle = inverse["angle_for_target_deg"].as_f64().unwrap();
    assert!(inverse["overall"].is_null());
    let at = json_of(
        fts()
            .args(geometry)
            .args(["--angle-deg", &format!("{angle:.12}")]),
    );
    let f = |k: &str| at[k].as_f64().unwrap();
    assert!((f("overall") - 3.87).abs() < 1e-8, "{}", f("overall"));
    assert!(f("bridge_loaded") < f("bridge_free") && f("bridge_free") < f("bridge_ideal"));
    assert!((f("overall") - f("bridge_loaded") * f("lever")).abs() < 1e-12);
    let k_in = f("input_stiffness_n_per_um");
    assert!((f("delivered_input_um") - 10.0 * 200.0 / (200.0 + k_in)).abs() < 1e-12);
    assert!(f("peak_ratio") > 3.87 && f("peak_angle_deg") < angle);
    for (args, flag) in [
        (
            vec![
                "--link-mm",
                "12",
                "--input-arm-mm",
                "5",
                "--output-arm-mm",
                "10",
            ],
            "--hinge-width-mm",
        ),
        (
            vec![
                "--link-mm",
                "0",
                "--input-arm-mm",
                "5",
                "--output-arm-mm",
                "10",
                "--hinge-width-mm",
                "8",
            ],
            "--link-mm",
        ),
        (
            vec![
                "--link-mm",
                "12",
                "--input-arm-mm",
                "5",
                "--output-arm-mm",
                "10",
                "--hinge-width-mm",
                "8",
                "--angle-deg",
                "95",
            ],
            "--angle-deg",
        ),
    ] {
        fts()
            .args(["mechanism", "amplifier"])
            .args(&args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(flag))
            .stderr(predicate::str::contains("panicked").not());
    }
}

/// Three-axis control end to end: the two laws agree on a small circle,
/// the uncommanded z axis reports cross-coupling, the trace holds the
/// columns docs/formats.md names, and a pose beyond the sliders' travel
/// exits 2 naming it.
#[test]
fn puu3_track_modes_agree_and_the_workspace_is_enforced() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace.csv");
    let run = |mode: &str| {
        json_of(fts().args([
            "mechanism",
            "3puu-track",
            "--mode",
            mode,
            "--amplitude-um",
            "2,2,0",
            "--duration",
            "1.5",
            "--settle",
            "0.5",
            "--json",
        ]))
    };
    let (joint, task) = (run("joint"), run("task"));
    for i in 0..3 {
        let a = joint["task"][i]["max_um"].as_f64().unwrap();
        let b = task["task"][i]["max_um"].as_f64().unwrap();
        assert!((a - b).abs() < 0.01 * a.max(1e-3), "axis {i}: {a} vs {b}");
    }
    assert!(joint["cross_coupling_percent"].as_f64().unwrap() > 0.0);
    fts()
        .args(["mechanism", "3puu-track", "--duration", "1.5", "-o"])
        .arg(&trace)
        .assert()
        .success();
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(text.starts_with("t,x_ref,y_ref,z_ref,x,y,z,q1_ref,q2_ref,q3_ref,q1,q2,q3,u1,u2,u3\n"));
    assert_eq!(text.lines().count(), 1 + 2501);
    fts()
        .args(["mechanism", "3puu-track", "--amplitude-um", "0,0,60"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(predicate::str::contains("leaves the workspace"));
}
