//! The pipeline's measured speed and latency targets, each judged from what the benchmarks wrote: one verdict per
//! target, with the numbers it rests on. The measuring is the benchmarks' own (`latency`,
//! `pipeline_speed`, `paced_cpu`, run by `targets`); this module only reads their reports, so a
//! saved set of reports can be judged again (`targets --from DIR`).
//!
//! | target | from |
//! |---|---|
//! | the chain's p99 at or below the Unix-socket chain's, idle and under load | `latency` chain rows placed as the profiles place the tick (`--chain-cpus`) |
//! | the chain's median within 3× the busy-poll floor, idle and under load | the same rows and the floor |
//! | one hop's p50 and p99 at or below a Unix-socket hop's | `latency` hop rows |
//! | a paced run of 10 minutes under load without a deadline miss or a late command | `latency` paced run |
//! | lockstep `testbed run` of `simulation` at ≥ 1000× real time, and faster than Basilisk's dynamics alone | `pipeline_speed --json` |
//! | the paced pipeline at ≤ 0.5 % of one core, all processes | `paced_cpu --json`, steady state |
//! | lockstep determinism, and bit-identity with the in-process loop | two pinned lockstep runs and the in-process loop of the same configuration ([`Determinism`]) |
//!
//! A verdict is pooled over the benchmark's rounds, as the latency report's "Checks" are; the
//! chain's round-by-round median is shown beside it. A target nothing measured, or measured
//! too briefly to judge (a paced run shorter than 10 minutes), has no verdict.

use crate::latency::model::{Kind, Measurement, Report, round_ratios};
use crate::latency::protocol::Transport;
use crate::latency::stats::Percentiles;
use crate::latency::tables::{floor_row, load_name, rounds_cell};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// Lockstep speed the issue asks of the `simulation` profile while it ticks, × real time.
pub const LOCKSTEP_MIN_X: f64 = 1000.0;
/// Paced CPU the issue allows, all processes, fraction of one core.
pub const PACED_CPU_MAX: f64 = 0.005;
/// Length of the paced run under load the issue asks for, s.
pub const PACED_RUN_MIN_S: f64 = 600.0;
/// The chain's median may be at most this many times the busy-poll floor's.
pub const FLOOR_FACTOR: f64 = 3.0;

/// One target and how this machine's measurement met it.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// What the issue asks, in a few words.
    pub target: String,
    /// The numbers the verdict rests on, or why there is none.
    pub measured: String,
    /// `None`: not measured, or not enough to judge.
    pub met: Option<bool>,
}

impl Verdict {
    fn judged(target: impl Into<String>, measured: String, met: bool) -> Self {
        Self {
            target: target.into(),
            measured,
            met: Some(met),
        }
    }

    fn unjudged(target: impl Into<String>, why: impl Into<String>) -> Self {
        Self {
            target: target.into(),
            measured: why.into(),
            met: None,
        }
    }
}

/// "; round by round 0.93× (3 of 4 ≤ 1)": the latency report's round-by-round cell; empty
/// when no round was measured by both rows.
fn rounds_note(ratios: &[f64], bound: f64) -> String {
    if ratios.is_empty() {
        return String::new();
    }
    format!("; round by round {}", rounds_cell(ratios, bound))
}

/// The bus chain (`block`) placed on `cpu`, as the launch profiles place the tick, at `load`.
fn placed_chain(r: &Report, load: bool, cpu: usize) -> Option<&Measurement> {
    r.find_placed(Kind::Chain, Transport::BUS, load, 0, false, Some(cpu))
}

/// The chain's targets from a `latency` report with the chain placed on `cpu`
/// (`--chain-cpus`): p99 against the Unix-socket chain placed alike, median against the floor.
pub fn chain(r: &Report, cpu: usize) -> Vec<Verdict> {
    let mut out = Vec::new();
    for load in [false, true] {
        let when = load_name(load);
        let p99_target = format!("chain p99 ≤ Unix-socket chain's, {when}");
        let p50_target = format!("chain p50 ≤ {FLOOR_FACTOR}× busy-poll floor, {when}");
        let Some(bus) = placed_chain(r, load, cpu) else {
            let why = format!("no bus chain placed on CPU {cpu} in the report");
            out.push(Verdict::unjudged(p99_target, why.clone()));
            out.push(Verdict::unjudged(p50_target, why));
            continue;
        };
        match r.find_placed(Kind::Chain, Transport::Uds, load, 0, false, Some(cpu)) {
            Some(uds) => {
                let (b, u) = (bus.latency.p99, uds.latency.p99);
                out.push(Verdict::judged(
                    p99_target,
                    format!(
                        "{b:.1} against {u:.1} µs ({:.2}×{})",
                        b / u,
                        rounds_note(&round_ratios(bus, uds, |l| l.p99), 1.0)
                    ),
                    b <= u,
                ));
            }
            None => out.push(Verdict::unjudged(
                p99_target,
                format!("no Unix-socket chain placed on CPU {cpu} in the report"),
            )),
        }
        match floor_row(r, Kind::Chain, load, 0) {
            Some((floor_row, idle_floor)) => {
                let (p50, floor) = (bus.latency.p50, floor_row.latency.p50);
                out.push(Verdict::judged(
                    p50_target,
                    format!(
                        "{p50:.1} µs, {:.2}× the floor's {floor:.2} µs{}{}",
                        p50 / floor,
                        if idle_floor { " (idle floor)" } else { "" },
                        rounds_note(&round_ratios(bus, floor_row, |l| l.p50), FLOOR_FACTOR)
                    ),
                    p50 <= FLOOR_FACTOR * floor,
                ));
            }
            None => out.push(Verdict::unjudged(
                p50_target,
                "no busy-poll floor in the report",
            )),
        }
    }
    out
}

/// One hop's targets from a `latency` report: p50 and p99 of each measured bus hop against
/// the Unix-socket hop of the same size and load.
pub fn hop(r: &Report) -> Vec<Verdict> {
    let mut out = Vec::new();
    for bus in r
        .rows(Kind::Hop)
        .filter(|m| m.transport == Transport::BUS && !m.real_binaries && m.error.is_none())
    {
        let when = load_name(bus.load);
        let Some(uds) = r.find(Kind::Hop, Transport::Uds, bus.load, bus.size, false) else {
            out.push(Verdict::unjudged(
                format!("one {} B hop ≤ Unix-socket hop, {when}", bus.size),
                "no Unix-socket hop of that size and load in the report",
            ));
            continue;
        };
        for (name, value) in [
            ("p50", (|l| l.p50) as fn(&Percentiles) -> f64),
            ("p99", |l| l.p99),
        ] {
            let (b, u) = (value(&bus.latency), value(&uds.latency));
            out.push(Verdict::judged(
                format!("one {} B hop {name} ≤ Unix-socket hop's, {when}", bus.size),
                format!(
                    "{b:.2} against {u:.2} µs ({:.2}×{})",
                    b / u,
                    rounds_note(&round_ratios(bus, uds, value), 1.0)
                ),
                b <= u,
            ));
        }
    }
    if out.is_empty() {
        out.push(Verdict::unjudged(
            "one hop ≤ Unix-socket hop",
            "no bus hop in the report",
        ));
    }
    out
}

/// The paced run under load from a `latency` report: no deadline miss and no late or missing
/// wheel command over at least [`PACED_RUN_MIN_S`].
pub fn paced_run(r: &Report) -> Verdict {
    let target = "paced run of 10 min under load: 0 deadline misses, 0 late commands";
    let Some(run) = r.paced.iter().find(|p| p.load && p.error.is_none()) else {
        let why = match r.paced.iter().find_map(|p| p.error.as_deref()) {
            Some(e) => format!("the paced run failed: {e}"),
            None => "no paced run under load in the report".into(),
        };
        return Verdict::unjudged(target, why);
    };
    let measured = format!(
        "{} s (`{}`), {} ticks, {} deadline misses, {} late or missing commands; truth → command p50 {:.0} µs, p99 {:.0} µs",
        run.duration_s,
        run.wait,
        run.ticks,
        run.deadline_misses,
        run.late_commands,
        run.truth_to_command.p50,
        run.truth_to_command.p99
    );
    let clean = run.deadline_misses == 0 && run.late_commands == 0;
    if run.duration_s < PACED_RUN_MIN_S && clean {
        return Verdict::unjudged(
            target,
            format!("{measured}: shorter than the {PACED_RUN_MIN_S} s asked, no verdict"),
        );
    }
    Verdict::judged(target, measured, clean)
}

/// A number at `path` (keys) of a JSON report.
fn number(v: &serde_json::Value, path: &[&str]) -> Option<f64> {
    path.iter().try_fold(v, |v, key| v.get(key))?.as_f64()
}

/// "one run" or "median of N runs", from a report's `repeats`.
fn runs(repeats: Option<f64>) -> String {
    match repeats {
        Some(1.0) => "one run".into(),
        Some(n) => format!("median of {n} runs"),
        None => "runs".into(),
    }
}

/// Lockstep targets from `pipeline_speed --json`: the `simulation` profile's speed while
/// ticking, and that speed over Basilisk's dynamics alone.
pub fn lockstep(v: &serde_json::Value) -> Vec<Verdict> {
    let speed_target = format!("lockstep `simulation` ≥ {LOCKSTEP_MIN_X}× real time, ticking");
    let basilisk_target = "lockstep `simulation` faster than Basilisk's dynamics alone";
    let Some(x) =
        number(v, &["lockstep_pipeline", "x_real_time_ticking"]).filter(|x| x.is_finite())
    else {
        return vec![
            Verdict::unjudged(speed_target, "no lockstep speed in the report"),
            Verdict::unjudged(basilisk_target, "no lockstep speed in the report"),
        ];
    };
    let simulated_s = number(v, &["simulated_s"]).unwrap_or(f64::NAN);
    let speed = Verdict::judged(
        speed_target,
        format!(
            "{x:.0}× ({} of {simulated_s} simulated s)",
            runs(number(v, &["repeats"]))
        ),
        x >= LOCKSTEP_MIN_X,
    );
    let basilisk = v.get("basilisk_dynamics");
    let basilisk = match (
        basilisk.and_then(|b| number(b, &["x_real_time"])),
        basilisk
            .and_then(|b| b.get("bsk_version"))
            .and_then(|s| s.as_str()),
    ) {
        (Some(bsk), version) => Verdict::judged(
            basilisk_target,
            format!(
                "{x:.0}× against {bsk:.0}× for Basilisk {} ({:.2}×)",
                version.unwrap_or("?"),
                x / bsk
            ),
            x > bsk,
        ),
        _ => Verdict::unjudged(
            basilisk_target,
            format!(
                "Basilisk not measured: {}",
                basilisk
                    .and_then(|b| b.get("not_installed"))
                    .and_then(|s| s.as_str())
                    .unwrap_or("not in the report")
            ),
        ),
    };
    vec![speed, basilisk]
}

/// The paced CPU target from `paced_cpu --json`: steady state of all processes of this build's
/// runs.
pub fn paced_cpu(v: &serde_json::Value) -> Verdict {
    let profile = v
        .get("profile")
        .and_then(|p| p.as_str())
        .unwrap_or("simulation");
    let target = format!(
        "paced CPU ≤ {}% of one core, all processes (`{profile}`)",
        100.0 * PACED_CPU_MAX
    );
    let Some(cpu) =
        number(v, &["this_build", "steady_cpu_fraction_of_one_core"]).filter(|c| c.is_finite())
    else {
        return Verdict::unjudged(target, "no steady-state CPU in the report");
    };
    let plant = number(v, &["this_build", "per_process_steady", "plant"]);
    Verdict::judged(
        target,
        format!(
            "{:.3} % steady state ({} of {} s){}",
            100.0 * cpu,
            runs(number(v, &["repeats"])),
            number(v, &["long_s"]).unwrap_or(f64::NAN),
            plant
                .map(|p| format!("; of it the simulated plant {:.3} %", 100.0 * p))
                .unwrap_or_default()
        ),
        cpu <= PACED_CPU_MAX,
    )
}

/// What two lockstep runs of one seed and pinned start time, and the in-process loop of the
/// first run's configuration, gave (`determinism.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Determinism {
    pub profile: String,
    pub seed: u64,
    /// Simulated length of each run, s.
    pub duration_s: f64,
    /// Sizes of the two runs' logs, bytes.
    pub log_bytes: [u64; 2],
    /// Offset of the first byte at which the two logs differ; `None`: identical.
    pub first_difference: Option<u64>,
    /// Attitude estimates in the first run's log.
    pub estimates: usize,
    /// Ticks of the in-process loop.
    pub in_process_ticks: usize,
    /// Time of the first estimate that differs in any bit from the in-process loop's (or that
    /// one of the two lacks), s; `None`: all equal.
    pub first_mismatch_t_s: Option<f64>,
}

/// Offset of the first byte at which `a` and `b` differ (a missing byte differs); `None` when
/// they are equal.
pub fn first_difference(a: &[u8], b: &[u8]) -> Option<u64> {
    let common = a.iter().zip(b).position(|(x, y)| x != y);
    match common {
        Some(i) => Some(i as u64),
        None if a.len() == b.len() => None,
        None => Some(a.len().min(b.len()) as u64),
    }
}

/// The determinism targets from [`Determinism`].
pub fn determinism(d: &Determinism) -> Vec<Verdict> {
    let run = format!(
        "`{}`, seed {}, {} simulated s",
        d.profile, d.seed, d.duration_s
    );
    let identical = Verdict::judged(
        "lockstep determinism: two runs of one seed give byte-identical logs",
        match d.first_difference {
            None => format!("{run}: both logs {} bytes, identical", d.log_bytes[0]),
            Some(at) => format!(
                "{run}: logs of {} and {} bytes differ from byte {at}",
                d.log_bytes[0], d.log_bytes[1]
            ),
        },
        d.first_difference.is_none(),
    );
    let in_process = Verdict::judged(
        "bit-identity: the processes' estimates are the in-process loop's",
        match d.first_mismatch_t_s {
            None => format!(
                "{run}: {} estimates, every one equal in every bit",
                d.estimates
            ),
            Some(t) => format!(
                "{run}: {} estimates against {} ticks, first difference at t = {t} s",
                d.estimates, d.in_process_ticks
            ),
        },
        d.first_mismatch_t_s.is_none(),
    );
    vec![identical, in_process]
}

/// met / not met / no verdict, for the table.
fn verdict_word(met: Option<bool>) -> &'static str {
    match met {
        Some(true) => "**met**",
        Some(false) => "**not met**",
        None => "no verdict",
    }
}

/// How many verdicts were met, not met and missing.
pub fn tally(verdicts: &[Verdict]) -> (usize, usize, usize) {
    verdicts.iter().fold((0, 0, 0), |(y, n, u), v| match v.met {
        Some(true) => (y + 1, n, u),
        Some(false) => (y, n + 1, u),
        None => (y, n, u + 1),
    })
}

/// The verdicts as a Markdown table, with a line that counts them.
pub fn markdown(verdicts: &[Verdict]) -> String {
    let mut out = String::from("| target | measured | verdict |\n|---|---|---|\n");
    for v in verdicts {
        let _ = writeln!(
            out,
            "| {} | {} | {} |",
            v.target,
            v.measured.replace('|', "/").replace('\n', " "),
            verdict_word(v.met)
        );
    }
    let (met, not_met, none) = tally(verdicts);
    let _ = writeln!(
        out,
        "\n{met} met, {not_met} not met, {none} without a verdict."
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::latency::model::{PacedRun, RoundStats};

    /// A row of one round (the pooled distribution), its chain on `cpu`.
    fn row(
        kind: Kind,
        transport: Transport,
        load: bool,
        cpu: Option<usize>,
        p50: f64,
        p99: f64,
    ) -> Measurement {
        let m = Measurement::test_row(kind, transport, load, p50, p99);
        Measurement {
            chain_cpu: cpu,
            rounds: vec![Some(RoundStats {
                latency: m.latency,
                machine_busy: 0.0,
            })],
            ..m
        }
    }

    /// Idle: bus chain on CPU 0 at p50 40 / p99 80 against the socket's 100; under load the
    /// bus chain's p99 is 95 against 90 and its median 50 against an idle floor of 15 (the
    /// loaded busy-poll median is above the socket's, so it is no floor).
    fn report() -> Report {
        Report {
            measurements: vec![
                row(Kind::Chain, Transport::IoxPoll, false, None, 15.0, 30.0),
                row(Kind::Chain, Transport::Uds, false, None, 30.0, 60.0),
                row(Kind::Chain, Transport::IoxPoll, true, None, 400.0, 900.0),
                row(Kind::Chain, Transport::Uds, true, None, 35.0, 70.0),
                row(Kind::Chain, Transport::BUS, false, Some(0), 40.0, 80.0),
                row(Kind::Chain, Transport::Uds, false, Some(0), 45.0, 100.0),
                row(Kind::Chain, Transport::BUS, true, Some(0), 50.0, 95.0),
                row(Kind::Chain, Transport::Uds, true, Some(0), 45.0, 90.0),
                row(Kind::Hop, Transport::BUS, false, None, 7.0, 35.0),
                row(Kind::Hop, Transport::Uds, false, None, 9.0, 21.0),
            ],
            ..Report::default()
        }
    }

    fn met(verdicts: &[Verdict]) -> Vec<Option<bool>> {
        verdicts.iter().map(|v| v.met).collect()
    }

    #[test]
    fn the_placed_chain_is_judged_against_the_socket_chain_placed_alike_and_the_floor() {
        let v = chain(&report(), 0);
        // idle p99 80 ≤ 100; idle p50 40 ≤ 3 × 15; loaded p99 95 > 90; loaded p50 50 > 3 × 15
        // (the idle floor: the loaded busy-poll median is above the loaded socket's).
        assert_eq!(
            met(&v),
            [Some(true), Some(true), Some(false), Some(false)],
            "{v:#?}"
        );
        assert!(v[3].measured.contains("(idle floor)"), "{}", v[3].measured);
        assert!(v[0].measured.contains("0.80×"), "{}", v[0].measured);
    }

    #[test]
    fn a_chain_not_placed_on_the_asked_cpu_has_no_verdict() {
        let v = chain(&report(), 1);
        assert_eq!(met(&v), [None; 4]);
        assert!(v[0].measured.contains("CPU 1"));
    }

    #[test]
    fn a_hop_is_judged_on_its_median_and_its_tail() {
        let v = hop(&report());
        assert_eq!(met(&v), [Some(true), Some(false)], "{v:#?}");
        assert!(hop(&Report::default())[0].met.is_none());
    }

    fn paced(duration_s: f64, misses: u64, late: u64) -> Report {
        Report {
            paced: vec![PacedRun {
                wait: "block".into(),
                load: true,
                duration_s,
                deadline_misses: misses,
                late_commands: late,
                ..PacedRun::default()
            }],
            ..Report::default()
        }
    }

    #[test]
    fn a_paced_run_meets_its_target_only_clean_and_ten_minutes_long() {
        assert_eq!(paced_run(&paced(600.0, 0, 0)).met, Some(true));
        assert_eq!(paced_run(&paced(600.0, 1, 0)).met, Some(false));
        assert_eq!(paced_run(&paced(600.0, 0, 2)).met, Some(false));
        // Too short to show the target, but a miss in it is a miss.
        assert_eq!(paced_run(&paced(60.0, 0, 0)).met, None);
        assert_eq!(paced_run(&paced(60.0, 1, 0)).met, Some(false));
        assert_eq!(paced_run(&Report::default()).met, None);
    }

    #[test]
    fn lockstep_is_judged_on_its_ticking_speed_and_against_basilisk() {
        let v = serde_json::json!({
            "simulated_s": 300.0, "repeats": 3,
            "lockstep_pipeline": { "x_real_time_ticking": 1426.0 },
            "basilisk_dynamics": { "bsk_version": "2.12.1", "x_real_time": 535.0 },
        });
        assert_eq!(met(&lockstep(&v)), [Some(true), Some(true)]);
        let slow = serde_json::json!({
            "lockstep_pipeline": { "x_real_time_ticking": 900.0 },
            "basilisk_dynamics": { "not_installed": "no module named Basilisk" },
        });
        let v = lockstep(&slow);
        assert_eq!(met(&v), [Some(false), None]);
        assert!(v[1].measured.contains("no module named Basilisk"));
        let behind = serde_json::json!({
            "lockstep_pipeline": { "x_real_time_ticking": 1200.0 },
            "basilisk_dynamics": { "x_real_time": 1300.0 },
        });
        assert_eq!(met(&lockstep(&behind)), [Some(true), Some(false)]);
    }

    #[test]
    fn paced_cpu_is_judged_on_the_steady_state_of_all_processes() {
        let at = |cpu: f64| {
            serde_json::json!({
                "profile": "simulation", "repeats": 3, "long_s": 30.0,
                "this_build": { "steady_cpu_fraction_of_one_core": cpu,
                                "per_process_steady": { "plant": 0.0011 } },
            })
        };
        assert_eq!(paced_cpu(&at(0.00466)).met, Some(true));
        assert_eq!(paced_cpu(&at(0.00504)).met, Some(false));
        assert!(paced_cpu(&at(0.00466)).measured.contains("0.466 %"));
        assert_eq!(paced_cpu(&serde_json::json!({})).met, None);
    }

    #[test]
    fn the_first_differing_byte_is_found_and_a_shorter_log_differs_where_it_ends() {
        assert_eq!(first_difference(b"abc", b"abc"), None);
        assert_eq!(first_difference(b"abc", b"abd"), Some(2));
        assert_eq!(first_difference(b"abc", b"ab"), Some(2));
        assert_eq!(first_difference(b"", b""), None);
    }

    #[test]
    fn determinism_is_met_only_by_identical_logs_and_estimates_equal_in_every_bit() {
        let found = Determinism {
            profile: "simulation".into(),
            seed: 7,
            duration_s: 150.0,
            log_bytes: [1000, 1000],
            first_difference: None,
            estimates: 1501,
            in_process_ticks: 1501,
            first_mismatch_t_s: None,
        };
        assert_eq!(met(&determinism(&found)), [Some(true), Some(true)]);
        let differing = Determinism {
            first_difference: Some(17),
            first_mismatch_t_s: Some(0.3),
            ..found
        };
        let v = determinism(&differing);
        assert_eq!(met(&v), [Some(false), Some(false)]);
        assert!(v[0].measured.contains("from byte 17"), "{}", v[0].measured);
        assert!(v[1].measured.contains("t = 0.3 s"), "{}", v[1].measured);
    }

    #[test]
    fn the_table_counts_its_verdicts() {
        let mut v = chain(&report(), 0);
        v.push(paced_run(&Report::default()));
        let md = markdown(&v);
        assert!(
            md.contains("2 met, 2 not met, 1 without a verdict."),
            "{md}"
        );
    }
}
