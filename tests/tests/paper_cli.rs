//! `testbed paper` as a user runs it: a real process, its JSON and its figures.

use std::process::Command;
use testbed_e2e::{Scratch, binary};

#[test]
fn paper_json_holds_every_key_and_meets_the_papers_bounds() {
    let scratch = Scratch::new("paper");
    let out = Command::new(binary("testbed"))
        .args(["paper", "--json", "--runs", "6", "--out"])
        .arg(scratch.path())
        .output()
        .expect("running testbed paper");
    assert!(
        out.status.success(),
        "testbed paper failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("--json prints one JSON object");
    let number = |path: &str| -> f64 {
        json.pointer(path)
            .and_then(|v| v.as_f64())
            .unwrap_or_else(|| panic!("{path} missing in {json}"))
    };
    // Bounds from the paper (DIGEST.md); the EKF's within 30 % of its 3σ with 6 runs.
    assert!((number("/ekf/err3s_xy_deg") / 0.0012 - 1.0).abs() < 0.3);
    assert!((number("/ekf/err3s_z_deg") / 0.02 - 1.0).abs() < 0.3);
    assert_eq!(number("/ekf/nees_dof"), 6.0);
    let nees = number("/ekf/nees_mean");
    assert!(nees >= number("/ekf/nees_interval/0") && nees <= number("/ekf/nees_interval/1"));
    assert!(number("/control/settle_s") < 120.0);
    assert!(number("/control/steady_xy_deg") < 0.02);
    assert!(number("/control/steady_z_deg") < 0.05);
    assert!(number("/control/steady_xy_deg_no_compensation") > number("/control/steady_xy_deg"));
    assert!(number("/cmg/slew_s") > 0.0);
    for figure in json["figures"].as_array().expect("figures listed") {
        let path = figure.as_str().expect("figure path");
        let svg = std::fs::read_to_string(path).expect("figure written");
        assert!(
            svg.starts_with("<svg") && svg.contains("time (s)"),
            "{path} is not a figure"
        );
    }
}

#[test]
fn a_bad_model_file_is_refused_naming_key_and_value() {
    let scratch = Scratch::new("badmodel");
    let model = scratch.path().join("model.toml");
    std::fs::write(&model, "[platform]\nmass_kg = -350.0\n").unwrap();
    let out = Command::new(binary("testbed"))
        .args(["paper", "--runs", "2", "--model"])
        .arg(&model)
        .output()
        .expect("running testbed paper");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("platform.mass_kg") && stderr.contains("-350"),
        "{stderr}"
    );
}
