//! Balance plans against their closed forms.

use super::*;
use testbed_model::balance_config::BalanceMass;

const M: f64 = 350.0;

fn estimate(r_m: [f64; 3], se_m: [f64; 3]) -> ComEstimate {
    let mut cov_m2 = [[0.0; 3]; 3];
    for i in 0..3 {
        cov_m2[i][i] = se_m[i] * se_m[i];
    }
    ComEstimate {
        r_m,
        cov_m2,
        covariance_source: "test",
    }
}

fn slider(name: &str, mass_kg: f64, axis: [f64; 3], travel_m: [f64; 2]) -> BalanceMass {
    BalanceMass {
        name: name.into(),
        mass_kg,
        centre_m: [0.0; 3],
        axis,
        travel_m,
        position_m: 0.0,
        position_stddev_m: 0.0,
    }
}

#[test]
fn orthogonal_sliders_move_by_m_over_m_times_the_offset() {
    let config = BalanceConfig::default();
    let e = estimate([14.1e-6, -14.1e-6, -3.0e-6], [0.02e-6, 0.03e-6, 0.1e-6]);
    let p = plan(&e, &config, M, -1e-6).expect("plan");
    // Closed form: Δs = −M (r − r_t) / m per axis (1-kg sliders).
    let expect = [-M * 14.1e-6, M * 14.1e-6, -M * (-3.0e-6 + 1e-6)];
    for (mv, x) in p.moves.iter().zip(expect) {
        assert!((mv.delta_m - x).abs() < 1e-12, "{mv:?} vs {x}");
        assert!(!mv.at_limit);
    }
    for (a, b) in p.predicted_m.iter().zip([0.0, 0.0, -1e-6]) {
        assert!((a - b).abs() < 1e-15, "{:?}", p.predicted_m);
    }
    // Move uncertainty: M σ / m; residual: σ of the estimate plus positioning (2 µm · m / M).
    assert!((p.moves[0].delta_stddev_m - M * 0.02e-6).abs() < 1e-12);
    assert!((p.moves[2].delta_stddev_m - M * 0.1e-6).abs() < 1e-12);
    let pos = 2e-6 / M;
    let sx = (0.02e-6f64.powi(2) + pos * pos).sqrt();
    assert!((p.predicted_stddev_m[0] - sx).abs() < 1e-15);
    let rms = (sx * sx + 0.03e-6f64.powi(2) + pos * pos).sqrt();
    assert!((p.horizontal_rms_m - rms).abs() < 1e-15);
    assert!(p.within_tolerance);
    // An estimate too uncertain for the tolerance says so.
    let vague = estimate([1e-6, 0.0, -1e-6], [0.2e-6, 0.0, 0.0]);
    assert!(!plan(&vague, &config, M, -1e-6).unwrap().within_tolerance);
}

#[test]
fn redundant_masses_take_the_smallest_moves() {
    // Two equal sliders along X share the move equally (minimum norm).
    let mut config = BalanceConfig::default();
    config
        .masses
        .push(slider("x2", 1.0, [1.0, 0.0, 0.0], [-0.05, 0.05]));
    config.validate().unwrap();
    let p = plan(&estimate([4e-6, 0.0, -1e-6], [0.0; 3]), &config, M, -1e-6).unwrap();
    let half = -M * 4e-6 / 2.0;
    assert!((p.moves[0].delta_m - half).abs() < 1e-12, "{:?}", p.moves);
    assert!((p.moves[3].delta_m - half).abs() < 1e-12, "{:?}", p.moves);
    assert!(p.moves[1].delta_m.abs() < 1e-15 && p.moves[2].delta_m.abs() < 1e-15);
    assert!(p.predicted_m[0].abs() < 1e-15);
}

#[test]
fn a_mass_at_its_limit_leaves_the_rest_to_the_others() {
    // X needs −8 mm of 1-kg travel in all; "x" has only ±3 mm, "x2" ±10 mm: min norm would
    // give −4 mm each, so "x" stops at −3 mm and "x2" moves −5 mm.
    let mut config = BalanceConfig::default();
    config.masses[0].travel_m = [-0.003, 0.003];
    config
        .masses
        .push(slider("x2", 1.0, [1.0, 0.0, 0.0], [-0.01, 0.01]));
    let r_x = 0.008 / M;
    let p = plan(&estimate([r_x, 0.0, -1e-6], [1e-8; 3]), &config, M, -1e-6).unwrap();
    assert!((p.moves[0].delta_m + 0.003).abs() < 1e-12, "{:?}", p.moves);
    assert!(p.moves[0].at_limit && p.moves[0].delta_stddev_m == 0.0);
    assert!((p.moves[3].delta_m + 0.005).abs() < 1e-12, "{:?}", p.moves);
    assert!(p.predicted_m[0].abs() < 1e-15);
}

#[test]
fn moves_beyond_travel_are_refused_with_the_partial_move() {
    let config = BalanceConfig::default();
    // 200 µm along X needs −70 mm of a ±50-mm slider.
    let err = plan(&estimate([200e-6, 0.0, -1e-6], [0.0; 3]), &config, M, -1e-6).unwrap_err();
    let msg = err.to_string();
    let BalanceError::BeyondTravel {
        violations,
        partial,
    } = err
    else {
        panic!("{msg}")
    };
    assert_eq!(violations.len(), 1, "{violations:?}");
    let v = &violations[0];
    assert_eq!((v.index, v.name.as_str()), (0, "x"));
    assert!((v.needed_m + 0.07).abs() < 1e-12 && (v.excess_m - 0.02).abs() < 1e-12);
    assert!((v.possible_m + 0.05).abs() < 1e-15);
    // Partial: the other axes balanced, X left at 200 − 50 mm · 1 kg / 350 kg µm.
    let left = 200e-6 - 0.05 / M;
    assert!((partial.predicted_m[0] - left).abs() < 1e-15, "{partial:?}");
    assert!(msg.contains("balance.masses[0] (\"x\")"), "{msg}");
    assert!(
        msg.contains("-70.000 mm") && msg.contains("20.000 mm beyond"),
        "{msg}"
    );
    assert!(msg.contains("can move -50.000 mm"), "{msg}");
    assert!(msg.contains(&format!("{:.3}", left * 1e6)), "{msg}");
}

#[test]
fn a_platform_lighter_than_its_balance_masses_is_refused() {
    let err = plan(
        &estimate([0.0; 3], [0.0; 3]),
        &BalanceConfig::default(),
        2.0,
        -1e-6,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("model.platform.mass_kg") && err.contains("= 2"),
        "{err}"
    );
}

#[test]
fn the_estimate_is_read_from_the_report() {
    let report = serde_json::json!({
        "verdict": "com_offset",
        "causes": [{
            "name": "com_offset",
            "parameters": {"r_m": [1e-6, -2e-6, -1e-6]},
            "stderr": {"r_m": [1e-8, 2e-8, 3e-8]},
        }],
    });
    let e = com_estimate(&report).unwrap();
    assert_eq!(e.r_m, [1e-6, -2e-6, -1e-6]);
    assert!((e.cov_m2[1][1] - 4e-16).abs() < 1e-30);
    assert_eq!(e.cov_m2[0][1], 0.0);
    assert!(e.covariance_source.contains("standard errors"));
    let mut with_cov = report.clone();
    with_cov["causes"][0]["covariance"] =
        serde_json::json!({"r_m": [[1e-16, 5e-17, 0.0], [5e-17, 4e-16, 0.0], [0.0, 0.0, 9e-16]]});
    let e = com_estimate(&with_cov).unwrap();
    assert_eq!(e.cov_m2[0][1], 5e-17);
    assert!(e.covariance_source.contains("covariance"));
    let none = serde_json::json!({"verdict": "earth_rate", "causes": [{"name": "earth_rate"}]});
    let msg = com_estimate(&none).unwrap_err().to_string();
    assert!(
        msg.contains("no com_offset") && msg.contains("earth_rate"),
        "{msg}"
    );
    let mut not_estimated = report.clone();
    not_estimated["causes"][0]["stderr"]["r_m"][2] = serde_json::Value::Null;
    let msg = com_estimate(&not_estimated).unwrap_err().to_string();
    assert!(msg.contains("stderr.r_m"), "{msg}");
    let msg = com_estimate(&serde_json::json!({}))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("causes"), "{msg}");
}
