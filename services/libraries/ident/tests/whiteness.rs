//! Residual whiteness of the torque channel (`identify::colour`): clean records are not
//! flagged, a slowly wandering (Gauss–Markov) external torque is reported as a coloured
//! disturbance with its rms and correlation time. Seeds fixed; 600 s of the identification
//! experiment each.

mod common;
use common::*;
use testbed_ident::identify::{COLOUR_ALPHA, WhitenessReport, torque_whiteness};

const DURATION_S: f64 = 600.0;
/// The wandering torque of the tests: 0.2 mNm rms per axis, correlation time 5 s.
const RMS_NM: f64 = 2e-4;
const CORRELATION_TIME_S: f64 = 5.0;

fn gauss_markov(seed: u64) -> String {
    format!(
        "[effects.gauss_markov_torque]\nrms_nm = [{RMS_NM:e}, {RMS_NM:e}, {RMS_NM:e}]\ncorrelation_time_s = {CORRELATION_TIME_S}\nseed = {seed}\n"
    )
}

fn print(label: &str, w: &WhitenessReport) {
    for c in &w.channels {
        println!(
            "{label} {}: LR {:.1}, p {:.2e}, coloured {}, rms {:.3e} Nm, T {:.2} s",
            c.channel, c.lr, c.p, c.coloured, c.rms_nm, c.correlation_time_s
        );
    }
}

/// Clean records against the correct (nominal) model, 12 seeds × 3 axes: none flagged. The
/// level is `COLOUR_ALPHA` = 1e-3 per record (Bonferroni over the axes), so the expected number
/// of false alarms in 12 records is at most 0.012 (P(any) ≤ 1.2 %) if the null holds; measured:
/// none, the smallest p 0.59 (Bonferroni over the axes; the largest likelihood ratio 3.2, against
/// 16.0 at the level).
#[test]
fn clean_records_are_not_flagged() {
    let mut flagged = Vec::new();
    let mut min_p: f64 = 1.0;
    let mut min_p_innovations: f64 = 1.0;
    for seed in 1..=12u64 {
        let data = experiment_data(&nominal(), seed, DURATION_S);
        let w = torque_whiteness(&data, &nominal()).expect("test runs");
        print(&format!("clean seed {seed}"), &w);
        assert_eq!(w.channels.len(), 3, "every axis tested");
        assert_eq!(w.innovations.len(), 5, "every innovation component tested");
        for c in &w.innovations {
            println!(
                "clean seed {seed} {}: Ljung–Box {:.1} on {} lags, p {:.2e}, rms {:.2}",
                c.channel, c.ljung_box, c.lags, c.p, c.rms
            );
            min_p_innovations = min_p_innovations.min(c.p);
            if c.coloured {
                flagged.push((seed, c.channel.clone(), c.p));
            }
        }
        for c in &w.channels {
            min_p = min_p.min(c.p);
            if c.coloured {
                flagged.push((seed, c.channel.clone(), c.p));
            }
        }
    }
    println!(
        "smallest p over 12 clean records: torque {min_p:.3}, innovations {min_p_innovations:.3}"
    );
    assert!(flagged.is_empty(), "false alarms: {flagged:?}");
    assert!(min_p > COLOUR_ALPHA && min_p_innovations > COLOUR_ALPHA);
}

/// A Gauss–Markov torque of 0.2 mNm rms and 5 s, 3 seeds: flagged on every axis, its rms
/// within 0.6–1.5 × the truth and its correlation time within a factor 2 (measured on seeds
/// 1–3: rms 0.78–1.05 ×, T 3.6–6.3 s).
#[test]
fn gauss_markov_torque_is_a_coloured_disturbance() {
    for seed in 1..=3u64 {
        let data = experiment_data(&truth(&gauss_markov(seed)), seed, DURATION_S);
        let w = torque_whiteness(&data, &nominal()).expect("test runs");
        print(&format!("gauss-markov seed {seed}"), &w);
        assert_eq!(w.channels.len(), 3);
        for c in &w.channels {
            assert!(c.coloured, "seed {seed} {}: p = {}", c.channel, c.p);
            let ratio = c.rms_nm / RMS_NM;
            assert!(
                (0.6..=1.5).contains(&ratio),
                "seed {seed} {}: rms {:.3e} vs {RMS_NM:e}",
                c.channel,
                c.rms_nm
            );
            let t = c.correlation_time_s / CORRELATION_TIME_S;
            assert!(
                (0.5..=2.0).contains(&t),
                "seed {seed} {}: correlation time {:.2} s vs {CORRELATION_TIME_S}",
                c.channel,
                c.correlation_time_s
            );
        }
    }
}

/// End to end: identify reports the coloured disturbance in its summary and JSON, and nothing on
/// a clean record.
#[test]
fn identify_reports_the_coloured_disturbance() {
    let id = identify_blind(&truth(&gauss_markov(4)), 4, DURATION_S);
    print("identify, gauss-markov seed 4", &id.report.whiteness);
    for l in &id.report.summary {
        println!("    {l}");
    }
    let lines: Vec<&String> = id
        .report
        .summary
        .iter()
        .filter(|l| l.starts_with("coloured disturbance on torque_"))
        .collect();
    assert!(!lines.is_empty(), "{:?}", id.report.summary);
    assert!(lines[0].contains("correlation time") && lines[0].contains("whiteness test p ="));
    let json = serde_json::to_value(&id.report).expect("report serialises");
    let channels = json["whiteness"]["channels"]
        .as_array()
        .expect("whiteness in JSON");
    assert!(channels.iter().any(|c| c["coloured"] == true));

    let clean = identify_blind(&nominal(), 4, DURATION_S);
    print("identify, clean seed 4", &clean.report.whiteness);
    assert!(
        clean.report.whiteness.channels.iter().all(|c| !c.coloured),
        "{:?}",
        clean.report.whiteness
    );
}
