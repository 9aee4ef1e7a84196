//! `testbed balance` on an identify report: the moves per mass in millimetres against their
//! closed form, the JSON form, and the refusals (a mass without travel, moves beyond travel).

use std::path::PathBuf;
use std::process::{Command, Output};

fn testbed(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_testbed"))
        .args(args)
        .output()
        .expect("testbed runs")
}

fn scratch(tag: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("testbed-cli-balance-{}-{tag}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// An identify report naming a centre-of-mass offset of `r_m` ± `se_m`.
fn report(dir: &std::path::Path, r_m: [f64; 3], se_m: [f64; 3]) -> String {
    let path = dir.join("report.json");
    let value = serde_json::json!({
        "verdict": "com_offset",
        "causes": [{"name": "com_offset", "parameters": {"r_m": r_m}, "stderr": {"r_m": se_m}}],
    });
    std::fs::write(&path, value.to_string()).expect("write report");
    path.display().to_string()
}

#[test]
fn moves_per_mass_in_millimetres() {
    let dir = scratch("moves");
    let path = report(&dir, [10e-6, -5e-6, -3e-6], [0.01e-6, 0.01e-6, 0.02e-6]);
    let out = testbed(&[
        "balance",
        "--identification",
        &path,
        "--vertical-um",
        "-2",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    // Default sliders: 1 kg on 350 kg, Δs = −350 (r − r_t), m → mm.
    let expect_mm = [
        -350.0 * 10e-6 * 1e3,
        350.0 * 5e-6 * 1e3,
        -350.0 * (-3e-6 + 2e-6) * 1e3,
    ];
    for (i, x) in expect_mm.iter().enumerate() {
        let got = v["moves"][i]["move_mm"].as_f64().expect("move_mm");
        assert!((got - x).abs() < 1e-9, "mass {i}: {got} mm vs {x} mm");
    }
    let z = v["predicted_um"][2].as_f64().expect("predicted_um");
    assert!((z + 2.0).abs() < 1e-9, "{z}");
    assert_eq!(v["within_tolerance"], serde_json::json!(true));
    let text = testbed(&["balance", "--identification", &path]);
    let text = String::from_utf8_lossy(&text.stdout).to_string();
    assert!(text.contains("x           -3.500 ± 0.004 mm"), "{text}");
    assert!(text.contains("within"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_masses_and_short_travel_are_refused() {
    let dir = scratch("refused");
    let path = report(&dir, [200e-6, 0.0, -1e-6], [0.01e-6; 3]);
    let out = testbed(&["balance", "--identification", &path]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        err.contains("balance.masses[0] (\"x\") needs -70.000 mm, 20.000 mm beyond its travel; it can move -50.000 mm"),
        "{err}"
    );
    let config = dir.join("run.toml");
    let mass = "[[balance.masses]]\nname = \"a\"\nmass_kg = 1.0\ncentre_m = [0.0, 0.0, 0.0]\n\
                axis = [1.0, 0.0, 0.0]\ntravel_m = [0.02, 0.02]\nposition_m = 0.02\nposition_stddev_m = 0.0\n";
    std::fs::write(&config, format!("[balance]\n{mass}")).expect("write config");
    let out = testbed(&[
        "balance",
        "--identification",
        &path,
        "--config",
        &config.display().to_string(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        err.contains("balance.masses[0].travel_m") && err.contains("no travel"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
