//! The Markdown report: a hand-written template (`report.md` beside this file: the sections,
//! what each measures, the conclusions and the method) with the run's tables ([`tables`]) and
//! numbers filled in.

use crate::latency::model::{Kind, Measurement, PacedRun, Report};
use crate::latency::stats::Percentiles;
use crate::latency::tables::*;
use std::fmt::Write as _;

/// The report's text, hand-written: its sections, what each measures, the conclusions and the
/// method, with `{{placeholders}}` for the tables and numbers of the run ([`fill`]).
const TEMPLATE: &str = include_str!("report.md");

/// The machine the numbers were measured on.
pub fn machine_table(out: &mut String, r: &Report) {
    let m = &r.machine;
    let rows = [
        ("CPU", m.cpu_model.clone()),
        ("cores", m.cpus.to_string()),
        ("virtualisation", m.hypervisor.clone()),
        ("kernel", m.kernel.clone()),
        ("clock source", m.clocksource.clone()),
        ("idle states", m.cpuidle.clone()),
        (
            "CPU latency request",
            match r.settings["cpu_latency_us"].as_u64() {
                Some(0) => "0 µs, held for the whole measurement (`--cpu-latency-us 0`): idle CPUs poll instead of halting".to_string(),
                Some(us) => format!("{us} µs, held for the whole measurement (`--cpu-latency-us`)"),
                None => "none (the system's default: idle CPUs may halt)".to_string(),
            },
        ),
        ("memory", format!("{:.1} GiB", m.memory_gib)),
        (
            "load average 1/5/15 min, start → end",
            format!("{} → {}", m.loadavg_start, m.loadavg_end),
        ),
        ("toolchain", m.rustc.clone()),
        (
            "\"under load\"",
            format!(
                "one thread spinning on CPU {} for the whole measurement (the other core busy); the machine is shared, so \"idle\" only means no hog of ours (the *machine busy* column shows everyone's CPU use)",
                r.settings["hog_cpu"]
            ),
        ),
    ];
    table(
        out,
        " | ",
        2,
        rows.into_iter()
            .filter(|(_, v)| !v.is_empty())
            .map(|(k, v)| vec![k.to_string(), v]),
    );
}

/// A short table for the terminal and the README: chain and hop, idle and load, and the
/// paced runs.
pub fn headline(r: &Report) -> String {
    let mut out = String::new();
    let mut rows = Vec::new();
    for (kind, size, name) in [(Kind::Chain, 0, "chain"), (Kind::Hop, 48, "hop (48 B)")] {
        let mut seen = Vec::new();
        for m in r.rows(kind).filter(|m| m.size == size && m.error.is_none()) {
            let key = (m.transport, m.real_binaries, m.chain_cpu);
            if seen.contains(&key) {
                continue;
            }
            seen.push(key);
            let find =
                |load| r.find_placed(kind, m.transport, load, size, m.real_binaries, m.chain_cpu);
            let (idle, load) = (find(false), find(true));
            let cell = |m: Option<&Measurement>, f: fn(&Measurement) -> f64| {
                m.map_or("–".to_string(), |m| us(f(m)))
            };
            rows.push(vec![
                name.to_string(),
                m.label(),
                cell(idle, |m| m.latency.p50),
                cell(idle, |m| m.latency.p99),
                cell(load, |m| m.latency.p50),
                cell(load, |m| m.latency.p99),
                cell(idle, |m| m.cpu_us_per_msg),
            ]);
        }
    }
    for p in r.paced.iter().filter(|p| p.error.is_none()) {
        rows.push(vec![
            format!("10 Hz paced, {} s under load", p.duration_s),
            format!("`TESTBED_BUS_WAIT={}`", p.wait),
            format!("truth→command p50 {}", us(p.truth_to_command.p50)),
            format!("p99 {}", us(p.truth_to_command.p99)),
            format!("period error p99 {}", us(p.period_error.p99)),
            format!("max {}", us(p.period_error.max)),
            format!("{} deadline misses", p.deadline_misses),
        ]);
    }
    table(
        &mut out,
        " | transport | idle p50 µs | idle p99 µs | load p50 µs | load p99 µs | CPU µs/msg (idle)",
        2,
        rows,
    );
    out
}

/// The paced runs: deadlines, latency and jitter of the 10 Hz loop.
pub fn paced_table(out: &mut String, runs: &[PacedRun]) {
    let ladder = |p: &Percentiles| {
        format!(
            "{} / {} / {} / {}",
            us(p.p50),
            us(p.p99),
            us(p.p999),
            us(p.max)
        )
    };
    let rows = runs.iter().map(|p| {
        let names = vec![p.wait.clone(), load_name(p.load), p.duration_s.to_string()];
        match &p.error {
            Some(e) => failed(names, e),
            None => {
                let mut row = names;
                row.extend([
                    p.ticks.to_string(),
                    p.deadline_misses.to_string(),
                    p.late_commands.to_string(),
                    ladder(&p.truth_to_command),
                    ladder(&p.period_error),
                ]);
                row.extend([
                    format!("{:.3} / {:.3}", p.period_min_ms, p.period_max_ms),
                    format!("{} / {}", us(p.clock_error.p99), us(p.clock_error.max)),
                    format!("{:.1}", p.pipeline_cpu_percent),
                ]);
                row
            }
        }
    });
    let head = "wait strategy | load | duration s | ticks | deadline misses | late commands | truth→command p50 / p99 / p99.9 / max µs | command period error p50 / p99 / p99.9 / max µs | period min / max ms | plant clock error p99 / max µs | pipeline CPU % of a core";
    table(out, head, 2, rows);
}

/// Stages of truth → wheel command of the paced runs, as the observer saw them arrive.
pub fn paced_stage_table(out: &mut String, runs: &[PacedRun]) {
    let Some(first) = runs.iter().find(|p| !p.stages.is_empty()) else {
        return;
    };
    let _ = writeln!(
        out,
        "\nStages of truth → wheel command, as the observer saw them arrive (p50 / p99 µs):\n"
    );
    let names: Vec<&str> = first.stages.iter().map(|(n, _)| n.as_str()).collect();
    let head = format!("wait strategy | {}", names.join(" | "));
    let rows = runs.iter().filter(|p| !p.stages.is_empty()).map(|p| {
        let mut row = vec![p.wait.clone()];
        row.extend(
            p.stages
                .iter()
                .map(|(_, s)| format!("{} / {}", us(s.p50), us(s.p99))),
        );
        row
    });
    table(out, &head, 1, rows);
}

/// What each process of the paced runs cost per tick.
pub fn paced_process_table(out: &mut String, runs: &[PacedRun]) {
    let mut names: Vec<&str> = Vec::new();
    for c in runs.iter().flat_map(|p| &p.processes) {
        if !names.contains(&c.name.as_str()) {
            names.push(&c.name);
        }
    }
    if names.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\nWhat each process of the paced runs cost per tick (CPU / time runnable but waiting for a CPU, µs; the whole run including the pipeline's start):\n"
    );
    let rows = runs.iter().filter(|p| !p.processes.is_empty()).map(|p| {
        let mut row = vec![p.wait.clone()];
        row.extend(names.iter().map(|n| {
            p.processes
                .iter()
                .find(|c| c.name == *n)
                .map_or("–".into(), |c| {
                    format!("{} / {}", us(c.cpu_us_per_tick), us(c.runqueue_us_per_tick))
                })
        }));
        row
    });
    table(
        out,
        &format!("wait strategy | {}", names.join(" | ")),
        1,
        rows,
    );
}

/// What an unfinished run's report lacks (it is saved after every phase).
fn unfinished(r: &Report) -> String {
    if r.complete {
        return String::new();
    }
    let planned = r.settings["paced_waits"].as_array().map_or(0, Vec::len);
    let paced = if planned > r.paced.len() {
        format!(": {} of {planned} paced runs done", r.paced.len())
    } else {
        String::new()
    };
    format!(" — **the run did not finish{paced}; this is what it had measured**")
}

/// The whole report: the hand-written template (`report.md` beside this file: the sections,
/// what each measures, the conclusions, the method) with its `{{placeholders}}` filled.
pub fn markdown(r: &Report) -> String {
    let (mut out, mut rest) = (String::new(), TEMPLATE);
    while let Some((text, after)) = rest.split_once("{{") {
        let (key, after) = after
            .split_once("}}")
            .expect("a placeholder of the template is not closed");
        out.push_str(text);
        fill(&mut out, r, key);
        rest = after;
    }
    out.push_str(rest);
    // A table ends its own line; the template puts a blank line after it.
    out.replace("|\n\n\n", "|\n\n")
}

/// The text of placeholder `key`: a table, a fact of the run, or one of its settings.
fn fill(out: &mut String, r: &Report, key: &str) {
    match key {
        "command" => out.push_str(&r.command),
        "started" => out.push_str(&r.machine.started),
        "wall_s" => {
            let _ = write!(out, "{:.0}", r.wall_s);
        }
        "quick" if r.quick => out.push_str(" — **quick mode: a smoke check of the harness, too few samples for the tails to mean anything**"),
        "quick" => {}
        "unfinished" => out.push_str(&unfinished(r)),
        "machine" => machine_table(out, r),
        "headline" => out.push_str(&headline(r)),
        "checks" => checks_table(out, r),
        "wait strategies" => wait_strategy_table(out, r),
        "rule" => rule_table(out, r),
        "event vs socket" => event_vs_socket_table(out, r),
        "chain" => distribution_table(out, r, Kind::Chain, 0),
        "stages" => stage_table(out, r),
        "hop" => distribution_table(out, r, Kind::Hop, 48),
        "sweep" => sweep_table(out, r),
        "paced" => paced_table(out, &r.paced),
        "paced stages" => paced_stage_table(out, &r.paced),
        "paced processes" => paced_process_table(out, &r.paced),
        "wake-ups" => wakeup_table(out, r),
        setting => {
            let _ = write!(out, "{}", r.settings[setting]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::latency::model::RoundStats;
    use crate::latency::protocol::Transport;
    use ipc_types::WaitStrategy;

    fn row(
        kind: Kind,
        transport: Transport,
        load: bool,
        p50: f64,
        p99: f64,
        cpu: f64,
    ) -> Measurement {
        Measurement {
            cpu_us_per_msg: cpu,
            ..Measurement::test_row(kind, transport, load, p50, p99)
        }
    }

    /// A chain idle and under load: block, a polling strategy, the floor (no floor under load:
    /// above the socket), the socket.
    fn report() -> Report {
        let mut r = Report::default();
        r.machine.cpus = 2;
        for load in [false, true] {
            r.measurements.extend([
                row(Kind::Chain, Transport::BUS, load, 60.0, 200.0, 100.0),
                row(
                    Kind::Chain,
                    Transport::IoxEvent(WaitStrategy::ANTICIPATE),
                    load,
                    30.0,
                    if load { 4000.0 } else { 150.0 },
                    300.0,
                ),
                row(
                    Kind::Chain,
                    Transport::IoxPoll,
                    load,
                    if load { 1500.0 } else { 15.0 },
                    5000.0,
                    900.0,
                ),
                row(Kind::Chain, Transport::Uds, load, 45.0, 100.0, 80.0),
            ]);
        }
        r
    }

    /// `m` with one round per p99 given (p50 a quarter of it).
    fn with_rounds(mut m: Measurement, p99s: &[f64]) -> Measurement {
        m.rounds = p99s
            .iter()
            .map(|&p99| {
                Some(RoundStats {
                    latency: Percentiles {
                        n: 25,
                        p50: p99 / 4.0,
                        p99,
                        ..Percentiles::default()
                    },
                    machine_busy: 0.1,
                })
            })
            .collect();
        m
    }

    #[test]
    fn the_checks_compare_the_chains_round_by_round_too() {
        let mut r = report();
        for m in &mut r.measurements {
            let p99s: &[f64] = match (m.transport, m.load) {
                (Transport::BUS, false) => &[90.0, 110.0, 95.0, 300.0],
                (Transport::Uds, false) => &[100.0, 100.0, 100.0, 100.0],
                (Transport::IoxPoll, false) => &[40.0, 40.0, 40.0, 40.0],
                _ => continue,
            };
            *m = with_rounds(m.clone(), p99s);
        }
        let mut out = String::new();
        checks_table(&mut out, &r);
        let idle = out
            .lines()
            .find(|l| l.contains("| idle |") && l.contains("doorbell (block)"))
            .expect("the idle bus row");
        // p99 ratios 0.9, 1.1, 0.95, 3.0: the median of four is the higher middle one.
        assert!(idle.contains("| 1.10× (2 of 4 ≤ 1) |"), "{idle}");
        // p50 ratios against the floor's rounds (p50 10): 2.25, 2.75, 2.375, 7.5.
        assert!(idle.contains("| 2.75× (3 of 4 ≤ 3) |"), "{idle}");
        let loaded = out
            .lines()
            .find(|l| l.contains("| load |") && l.contains("doorbell (block)"))
            .expect("the loaded bus row");
        assert!(loaded.contains("| n/a |"), "no rounds recorded: {loaded}");
    }

    /// A hop is checked against the socket hop of the same load, pooled and round by round; one
    /// slow round can put the pooled p99 above the socket's while most rounds are below.
    #[test]
    fn a_hop_is_checked_against_the_socket_hop_pooled_and_round_by_round() {
        let mut r = report();
        r.measurements.extend([
            with_rounds(
                row(Kind::Hop, Transport::BUS, false, 7.0, 35.0, 25.0),
                &[17.0, 16.0, 17.0, 47.0],
            ),
            with_rounds(
                row(Kind::Hop, Transport::Uds, false, 10.0, 21.0, 26.0),
                &[22.0, 20.0, 23.0, 16.0],
            ),
            row(Kind::Hop, Transport::BUS, true, 6.0, 17.0, 24.0),
        ]);
        let mut out = String::new();
        checks_table(&mut out, &r);
        let idle = out
            .lines()
            .find(|l| l.starts_with("| 48 B | idle |"))
            .expect("the idle hop row");
        // p50 7 against 10; p99 35 against 21 pooled, round by round 0.77, 0.80, 0.74, 2.94
        // (median of four: the higher middle one); the p50s are a quarter of the p99s.
        assert_eq!(
            idle,
            "| 48 B | idle | 7.00 | 10.00 | **yes** | 0.80× (3 of 4 ≤ 1) | 35.00 | 21.00 | **no** | 0.80× (3 of 4 ≤ 1) |"
        );
        assert!(
            !out.contains("| 48 B | load |"),
            "no socket hop under load, no check: {out}"
        );
    }

    #[test]
    fn under_load_a_busy_poll_slower_than_the_socket_is_no_floor() {
        let r = report();
        assert_eq!(floor_of(&r, Kind::Chain, false, 0), Some((15.0, false)));
        assert_eq!(
            floor_of(&r, Kind::Chain, true, 0),
            Some((15.0, true)),
            "the idle floor stands in"
        );
        let mut out = String::new();
        checks_table(&mut out, &r);
        assert!(out.contains("| 4.00× (idle floor) |"), "{out}");
        assert!(
            !out.contains("0.04×"),
            "never a ratio to a floor above the socket: {out}"
        );
    }

    #[test]
    fn a_placed_chain_is_checked_against_the_socket_placed_alike_and_the_free_floor() {
        let mut r = report();
        let placed = |transport, p50, p99| Measurement {
            chain_cpu: Some(0),
            ..row(Kind::Chain, transport, false, p50, p99, 50.0)
        };
        r.measurements.extend([
            placed(Transport::BUS, 24.0, 90.0),
            placed(Transport::Uds, 30.0, 80.0),
        ]);
        let mut out = String::new();
        checks_table(&mut out, &r);
        // p99 90 against the placed socket's 80 (not the free socket's 100), p50 against the
        // free floor's 15.
        assert!(
            out.contains(
                "| iceoryx2 + doorbell (block) — chain on CPU 0 | idle | 90.00 | 80.00 | **no** | n/a | 24.00 | 15.00 | 1.60× | **yes** | n/a |"
            ),
            "{out}"
        );
        // The free rows keep their own baselines.
        assert!(
            out.contains("| iceoryx2 + doorbell (block) | idle | 200.0 | 100.0 | **no** |"),
            "{out}"
        );
        let headline = headline(&r);
        assert!(
            headline.contains(
                "| chain | iceoryx2 + doorbell (block) — chain on CPU 0 | 24.00 | 90.00 | – | – |"
            ),
            "{headline}"
        );
    }

    #[test]
    fn the_rule_fails_a_strategy_that_costs_too_much_or_loses_on_the_tail() {
        let mut out = String::new();
        rule_table(&mut out, &report());
        assert!(
            out.contains("| anticipate:200,300 | idle | 0.75× | 3.00× | **fails** |"),
            "{out}"
        );
        assert!(
            out.contains("| anticipate:200,300 | load | 20.00× | 3.00× | **fails** |"),
            "{out}"
        );
    }

    #[test]
    fn every_table_row_has_the_headers_cells() {
        let mut r = report();
        r.measurements.push(Measurement {
            error: Some("broken | pipe".into()),
            ..row(Kind::Hop, Transport::Uds, false, 1.0, 1.0, 1.0)
        });
        let text = markdown(&r);
        let mut columns = None;
        for line in text.lines() {
            match (line.starts_with('|'), columns) {
                (true, None) => columns = Some(line.matches('|').count()),
                (true, Some(c)) => assert_eq!(line.matches('|').count(), c, "{line}"),
                (false, _) => columns = None,
            }
        }
        assert!(text.contains("## Decision on the wait strategy") && text.contains("## Method"));
    }
}
