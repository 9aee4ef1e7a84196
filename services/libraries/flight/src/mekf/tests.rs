//! Tests of the filter as a whole against the simulated truth of `truth` (gyro at 10 Hz, vector
//! samples at 2.5 Hz, default model configuration): convergence, steady-state accuracy against
//! the paper, Monte Carlo consistency (NEES), and the handling of time stamps, missing and invalid
//! samples. Tests of single pieces sit next to them (`model`, `triad`, `gating`, `config`,
//! [`crate::stats`]).

use super::truth::{Record, Truth, config, nees, normal, rms_and_sigma, run, triad_start};
use super::*;
use crate::stats::chi_square_quantile;
use nalgebra::Vector6;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use testbed_model::config::DEG;

// (a) ------------------------------------------------------------------------------------

/// From a 1° attitude error (about an oblique axis) and a 0.003–0.005 °/s bias error, with
/// gating on, the filter converges: after 300 s every attitude error is inside the filter's
/// own 3σ and below 0.005° (X/Y) and 0.05° (Z), 2.5 and 1.3 orders below the start; the bias
/// error falls below 10% of the initial one. No sample may be gated out on the way (the
/// iterated update removes the second-order error that would otherwise lock the gate).
#[test]
fn converges_from_one_degree_and_bias_error() {
    let q_true = attitude::from_heading_pitch_roll(30.0 * DEG, 2.0 * DEG, -DEG);
    let mut truth = Truth::new(11, q_true);
    let dtheta0 = Vector3::new(1.0, -1.0, 1.0).normalize() * (1.0 * DEG);
    let db0 = Vector3::new(0.004, -0.005, 0.003) * DEG;
    let q_est = attitude::apply_error(&q_true, &(-dtheta0));
    assert!((attitude::attitude_error(&q_true, &q_est) - dtheta0).norm() < 1e-12);
    let cfg = config();
    let p0 = cfg.initial_covariance();
    let mut f = Mekf::with_state(cfg, 0, q_est, truth.bias - db0, p0).expect("valid start");
    let log = run(&mut truth, &mut f, 300.0, |_, _| {});
    for t in [0.4, 2.0, 10.0, 60.0, 300.0] {
        let r = log.iter().find(|r| r.t_s >= t - 1e-9).expect("record");
        println!(
            "t = {:5.1} s: attitude error [deg] {:+.2e} {:+.2e} {:+.2e}, bias error [deg/s] {:+.2e} {:+.2e} {:+.2e}",
            r.t_s,
            r.err[0] / DEG,
            r.err[1] / DEG,
            r.err[2] / DEG,
            r.err[3] / DEG,
            r.err[4] / DEG,
            r.err[5] / DEG
        );
    }
    let last = log.last().expect("records");
    for i in 0..3 {
        let sigma = last.p[(i, i)].sqrt();
        assert!(
            last.err[i].abs() < 3.0 * sigma,
            "axis {i}: |{:e}| rad > 3σ = {:e}",
            last.err[i],
            3.0 * sigma
        );
    }
    assert!(
        last.err[0].abs() < 0.005 * DEG && last.err[1].abs() < 0.005 * DEG,
        "{:?}",
        last.err
    );
    assert!(last.err[2].abs() < 0.05 * DEG, "{:?}", last.err);
    for i in 0..3 {
        assert!(
            last.err[3 + i].abs() < 0.1 * db0[i].abs(),
            "bias axis {i}: {:e} rad/s",
            last.err[3 + i]
        );
    }
    let c = f.counters();
    assert_eq!(c.gravity.rejected + c.magnetic.rejected, 0, "{c:?}");
    assert_eq!(c.updates_applied, log.len() as u64);
    assert_eq!(c.propagations, 3000);
    // The first update had a degree-level correction and was relinearised.
    assert!(log[0].report.iterations >= 2, "{:?}", log[0].report);
}

// (b) ------------------------------------------------------------------------------------

/// Steady-state accuracy against the paper (Fig. 8: 3σ below 0.0012° about X/Y and 0.02°
/// about Z). Started by TRIAD, 900 s, statistics over the last 600 s.
///
/// The paper's figure is read by eye and its bias random walk is illegible (this project
/// assumes 3e-7 °/s^1.5), so the filter's 3σ is required within a factor 2 of the paper's
/// (X/Y in [0.0006°, 0.0024°], Z in [0.01°, 0.04°]); a gross error in Q, R or H moves it by
/// far more. The actual errors (3·RMS) must agree with the filter's 3σ within a factor 1.5
/// either way (about 1500 correlated samples per axis; the RMS estimate is good to ~20%).
#[test]
fn steady_state_three_sigma_matches_paper() {
    let mut truth = Truth::new(
        22,
        attitude::from_heading_pitch_roll(-70.0 * DEG, 1.0 * DEG, 0.5 * DEG),
    );
    let mut f = triad_start(&mut truth, config());
    let log = run(&mut truth, &mut f, 900.0, |_, _| {});
    let paper = [0.0012, 0.0012, 0.02];
    for i in 0..3 {
        let (rms, sigma) = rms_and_sigma(&log, 300.0, i);
        let (three_sigma, three_rms) = (3.0 * sigma / DEG, 3.0 * rms / DEG);
        println!(
            "axis {}: filter 3σ = {three_sigma:.5}°, actual 3·RMS = {three_rms:.5}°, paper < {}°",
            ["X", "Y", "Z"][i],
            paper[i]
        );
        assert!(
            three_sigma > paper[i] / 2.0 && three_sigma < paper[i] * 2.0,
            "axis {i}: 3σ {three_sigma}°"
        );
        assert!(
            three_rms < 1.5 * three_sigma && three_rms > three_sigma / 1.5,
            "axis {i}: 3·RMS {three_rms}°"
        );
    }
    for i in 3..6 {
        let (rms, sigma) = rms_and_sigma(&log, 300.0, i);
        println!(
            "bias {}: filter 1σ = {:.2e} °/s, actual RMS = {:.2e} °/s",
            ["X", "Y", "Z"][i - 3],
            sigma / DEG,
            rms / DEG
        );
        // "Gyro bias well estimated": within 3% of the smallest bias (0.00325 °/s).
        assert!(3.0 * rms < 1e-4 * DEG, "bias axis {i}: RMS {rms:e} rad/s");
    }
    let c = f.counters();
    println!("counters: {c:?}");
    // False alarms at P = 0.9999: about 0.1 expected over 2 × 2250 samples.
    assert!(c.gravity.rejected + c.magnetic.rejected <= 2, "{c:?}");
}

// (c) ------------------------------------------------------------------------------------

/// Consistency: over N = 24 seeds, initial errors drawn from `P₀`, the NEES at t = 150 s
/// summed over runs is chi-square with 6N dof if the filter is consistent; the average must
/// lie in its two-sided 95% interval (quantiles of χ²(144)/N, cross-checked against
/// Wilson–Hilferty). With these seeds the test is deterministic; a filter whose covariance
/// is off by 30% in either direction fails it.
#[test]
fn monte_carlo_nees_is_consistent() {
    let runs = 24;
    let dof = 6.0 * runs as f64;
    let lo = chi_square_quantile(0.025, dof).expect("quantile") / runs as f64;
    let hi = chi_square_quantile(0.975, dof).expect("quantile") / runs as f64;
    let mut sum = 0.0;
    let mut time_averaged = 0.0;
    let mut per_component = [0.0; 6]; // mean e_i² / P_ii over runs and 30–150 s
    for seed in 0..runs {
        let q_true =
            attitude::from_heading_pitch_roll(seed as f64 * 0.7, 0.01 * (seed as f64).sin(), 0.0);
        let mut truth = Truth::new(1000 + seed, q_true);
        let cfg = config();
        let p0 = cfg.initial_covariance();
        let mut rng = ChaCha8Rng::seed_from_u64(5000 + seed);
        let e0: Vector6<f64> = Vector6::from_fn(|i, _| p0[(i, i)].sqrt() * normal(&mut rng));
        let q_est = attitude::apply_error(&q_true, &(-e0.fixed_rows::<3>(0).into_owned()));
        let b_est = truth.bias - e0.fixed_rows::<3>(3);
        let mut f = Mekf::with_state(cfg, 0, q_est, b_est, p0).expect("valid start");
        let log = run(&mut truth, &mut f, 150.0, |_, _| {});
        let last = log.last().expect("records");
        let n = nees(&last.err, &last.p);
        sum += n;
        let tail: Vec<&Record> = log.iter().filter(|r| r.t_s >= 30.0).collect();
        time_averaged += tail.iter().map(|r| nees(&r.err, &r.p)).sum::<f64>() / tail.len() as f64;
        for (i, c) in per_component.iter_mut().enumerate() {
            *c += tail
                .iter()
                .map(|r| r.err[i] * r.err[i] / r.p[(i, i)])
                .sum::<f64>()
                / (tail.len() * runs as usize) as f64;
        }
    }
    let mean = sum / runs as f64;
    // Wilson–Hilferty: χ²_p(k) ≈ k (1 − 2/(9k) + z_p sqrt(2/(9k)))³.
    let wh = |z: f64| {
        dof * (1.0 - 2.0 / (9.0 * dof) + z * (2.0 / (9.0 * dof)).sqrt()).powi(3) / runs as f64
    };
    assert!(
        (wh(-1.959_964) - lo).abs() < 0.01 && (wh(1.959_964) - hi).abs() < 0.01,
        "{lo} {hi}"
    );
    println!(
        "NEES at 150 s averaged over {runs} runs: {mean:.3} (95% interval [{lo:.3}, {hi:.3}]); \
         time-averaged over 30–150 s: {:.3}",
        time_averaged / runs as f64
    );
    println!("per component e²/P [θx θy θz bx by bz], 30–150 s: {per_component:.2?}");
    assert!(
        mean > lo && mean < hi,
        "average NEES {mean} outside [{lo}, {hi}]"
    );
}

// (e) ------------------------------------------------------------------------------------

/// Time handling: an older gyro sample is refused and counted and leaves the state alone; an
/// equal time stamp is accepted; a vector sample older than the tolerance is refused and
/// counted, one within it is used with its lag; a sample ahead extrapolates with the held
/// rate; missing and invalid blocks are skipped and counted; a non-finite gyro sample is
/// refused.
#[test]
fn out_of_order_refused_missing_skipped_all_counted() {
    let cfg = config();
    let q0 = attitude::from_heading_pitch_roll(0.2, 0.01, -0.02);
    let mut f = Mekf::new(cfg.clone(), 0, q0).expect("valid");
    let w = Vector3::from(cfg.initial_bias_rad_s) + Vector3::new(0.0, 0.0, 0.01);
    let s = 1_000_000_000u64;
    f.propagate(s, &w).expect("in order");
    let (q1, p1) = (f.attitude(), f.covariance());
    assert_eq!(
        f.propagate(s / 2, &w),
        Err(MekfError::OutOfOrder {
            t_ns: s / 2,
            state_ns: s
        })
    );
    assert_eq!(f.counters().out_of_order_gyro, 1);
    assert_eq!((f.time_ns(), f.attitude(), f.covariance()), (s, q1, p1));
    f.propagate(s, &w)
        .expect("equal time stamp is not out of order");
    assert_eq!(f.attitude(), q1);
    assert_eq!(f.counters().propagations, 2);
    assert!(matches!(
        f.propagate(2 * s, &Vector3::new(f64::NAN, 0.0, 0.0)),
        Err(MekfError::NonFinite { .. })
    ));
    assert_eq!((f.counters().invalid_gyro, f.time_ns()), (1, s));

    // Both blocks missing: skipped.
    let r = f
        .update(s, &VectorMeasurements::default())
        .expect("in time");
    assert_eq!(
        (r.gravity.status, r.magnetic.status),
        (BlockStatus::Missing, BlockStatus::Missing)
    );
    let c = f.counters();
    assert_eq!(
        (
            c.updates_skipped,
            c.gravity.missing,
            c.magnetic.missing,
            c.updates_applied
        ),
        (1, 1, 1, 0)
    );

    // Exact vectors of the current estimate.
    let field_l = Vector3::from(cfg.field_l_t);
    let exact = |f: &Mekf| {
        let [th, ph] = attitude::tilt_angles(&f.attitude());
        VectorMeasurements {
            tilt_rad: Some([th, ph]),
            field_b_t: Some(f.attitude() * field_l),
        }
    };

    // Stale beyond the 0.1 s tolerance: refused, counted, state untouched.
    let late = s - 300_000_000;
    assert!(matches!(
        f.update(late, &exact(&f)),
        Err(MekfError::Stale { .. })
    ));
    assert_eq!(f.counters().out_of_order_vector, 1);
    assert_eq!(f.covariance(), p1);

    // Within the tolerance: applied with its lag.
    let r = f
        .update(s - 50_000_000, &exact(&f))
        .expect("within tolerance");
    assert!(
        (r.lag_s - 0.05).abs() < 1e-12 && r.gravity.status == BlockStatus::Applied,
        "{r:?}"
    );

    // Ahead, magnetometer only: extrapolated with the held rate, gravity counted missing.
    let q_before = f.attitude();
    let ahead = s + 250_000_000;
    let only_m = VectorMeasurements {
        tilt_rad: None,
        field_b_t: exact(&f).field_b_t,
    };
    let r = f.update(ahead, &only_m).expect("ahead");
    assert_eq!(
        (r.gravity.status, r.magnetic.status),
        (BlockStatus::Missing, BlockStatus::Applied)
    );
    assert_eq!(f.time_ns(), ahead);
    assert_eq!(f.counters().extrapolations, 1);
    let turned = attitude::attitude_error(&f.attitude(), &q_before);
    // 0.01 rad/s about Z for 0.25 s: A' = −[ω×]A gives A(t+Δt) = (I − [ωΔt×]) A(t), so
    // δθ = +ωΔt = 0.0025 rad before the update; the "measured" field was of the
    // pre-extrapolation attitude, so the update pulls part of it back.
    assert!(turned.z > 0.001 && turned.z < 0.0025, "{turned:?}");
    // A gyro sample older than the extrapolated state is now out of order.
    assert!(f.propagate(s + 200_000_000, &w).is_err());
    assert_eq!(f.counters().out_of_order_gyro, 2);

    // Invalid blocks: NaN field, impossible tilt (sin²θ + sin²φ > 1).
    let bad = VectorMeasurements {
        tilt_rad: Some([1.2, 1.2]),
        field_b_t: Some(Vector3::new(f64::NAN, 0.0, 0.0)),
    };
    let r = f.update(ahead, &bad).expect("in time");
    assert_eq!(
        (r.gravity.status, r.magnetic.status),
        (BlockStatus::Invalid, BlockStatus::Invalid)
    );
    let c = f.counters();
    assert_eq!(
        (c.gravity.invalid, c.magnetic.invalid, c.updates_skipped),
        (1, 1, 2)
    );
    assert_eq!(c.updates_applied, 2);
    let est = f.estimate();
    assert_eq!(est.counters, c);
    assert_eq!(est.t_ns, ahead);
}

/// The propagation's block product equals the full `Φ P Φᵀ` (to rounding, relative 1e-14) for
/// transition matrices of slow and fast rates and a dense positive definite covariance.
#[test]
fn block_covariance_propagation_equals_the_full_product() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let m = Matrix6::from_fn(|_, _| normal(&mut rng));
    let p = m * m.transpose() + Matrix6::identity();
    for (w, dt) in [
        (Vector3::new(1e-4, -2e-4, 3e-4), 0.1),
        (Vector3::new(0.3, -0.2, 0.5), 0.4),
    ] {
        let phi = transition_matrix(&w, dt);
        let full = phi * p * phi.transpose();
        let blocks = propagate_covariance(&phi, &p);
        assert!(
            (full - blocks).abs().max() <= 1e-14 * full.abs().max(),
            "{w} {dt}"
        );
    }
}
