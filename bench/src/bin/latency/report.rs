//! The Markdown report: every number next to its baselines of the same run.

use crate::{Measurement, PacedRun, Report};
use std::fmt::Write as _;

/// The rows of one kind, load and size, in measurement order.
fn rows<'a>(r: &'a Report, kind: &'a str) -> impl Iterator<Item = &'a Measurement> + 'a {
    r.measurements.iter().filter(move |m| m.kind == kind)
}

fn find<'a>(r: &'a Report, kind: &str, transport: &str, load: bool, size: usize, binaries: bool) -> Option<&'a Measurement> {
    r.measurements
        .iter()
        .find(|m| m.kind == kind && m.transport == transport && m.load == load && m.size == size && m.real_binaries == binaries && m.error.is_none())
}

fn us(x: f64) -> String {
    if x >= 1000.0 {
        format!("{x:.0}")
    } else if x >= 100.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.2}")
    }
}

fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 { format!("{:.2}×", a / b) } else { "–".into() }
}

fn load_name(load: bool) -> &'static str {
    if load { "load" } else { "idle" }
}

fn label(m: &Measurement) -> String {
    if m.real_binaries { format!("{} — real `estimator` + `controller` binaries", m.label) } else { m.label.clone() }
}

/// Distribution table of one kind (hop, chain), every transport idle and under load, with the
/// floor and the Unix-socket row of the same load as baselines.
fn distribution_table(out: &mut String, r: &Report, kind: &str, size: usize) {
    let _ = writeln!(
        out,
        "| transport | load | n | p50 µs | p90 µs | p99 µs | p99.9 µs | max µs | p50 ÷ floor | p99 ÷ UDS | CPU µs/msg | run-queue µs/msg | machine busy |"
    );
    let _ = writeln!(out, "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|");
    for m in rows(r, kind).filter(|m| m.size == size) {
        if let Some(e) = &m.error {
            let _ = writeln!(out, "| {} | {} | failed: {} |||||||||||", label(m), load_name(m.load), e.replace('|', "/").replace('\n', " "));
            continue;
        }
        let floor = find(r, kind, "iox-poll", m.load, size, false).map_or(0.0, |f| f.latency.p50);
        let uds = find(r, kind, "uds", m.load, size, false).map_or(0.0, |f| f.latency.p99);
        let l = &m.latency;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.0} % |",
            label(m),
            load_name(m.load),
            l.n,
            us(l.p50),
            us(l.p90),
            us(l.p99),
            us(l.p999),
            us(l.max),
            ratio(l.p50, floor),
            ratio(l.p99, uds),
            us(m.cpu_us_per_msg),
            us(m.runqueue_us_per_msg),
            m.machine_busy * 100.0
        );
    }
}

/// The verdicts the issue asks for, per bus wait strategy and load.
pub fn checks(r: &Report) -> Vec<String> {
    let mut lines = Vec::new();
    let waits: Vec<&Measurement> = rows(r, "chain").filter(|m| m.transport.starts_with("iox-event") && !m.real_binaries && m.error.is_none()).collect();
    for m in waits {
        let (Some(uds), Some(floor)) = (find(r, "chain", "uds", m.load, 0, false), find(r, "chain", "iox-poll", m.load, 0, false)) else {
            continue;
        };
        let p99_ok = m.latency.p99 <= uds.latency.p99;
        let median_ok = m.latency.p50 <= 3.0 * floor.latency.p50;
        let no_floor = floor.latency.p50 > uds.latency.p50;
        lines.push(format!(
            "{} chain, {}: p99 {} µs vs Unix socket {} µs → {}; median {} µs vs busy-poll floor {} µs = {} → {}{}",
            m.label,
            load_name(m.load),
            us(m.latency.p99),
            us(uds.latency.p99),
            if p99_ok { "**at or below**" } else { "**above**" },
            us(m.latency.p50),
            us(floor.latency.p50),
            ratio(m.latency.p50, floor.latency.p50),
            if median_ok { "**within 3×**" } else { "**not within 3×**" },
            if no_floor { " (busy-polling is no floor here: four spinning processes and the hog starve each other on two CPUs)" } else { "" },
        ));
    }
    for p in &r.paced {
        lines.push(match &p.error {
            None => format!(
                "Paced 10 Hz run, {} s, {}, `TESTBED_BUS_WAIT={}`: **{} deadline misses during the run** ({} counted by the controller, {} of them before its first cycle while the pipeline started), {} late or missing wheel commands over {} ticks",
                p.duration_s,
                if p.load { "under load" } else { "idle" },
                p.wait,
                p.deadline_misses - p.deadline_misses_at_start,
                p.deadline_misses,
                p.deadline_misses_at_start,
                p.late_commands,
                p.ticks
            ),
            Some(e) => format!("Paced 10 Hz run, `TESTBED_BUS_WAIT={}`: failed: {e}", p.wait),
        });
    }
    lines
}

/// A short table for the terminal and the README: chain and hop, idle and load.
pub fn headline(r: &Report) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "| | transport | idle p50 µs | idle p99 µs | load p50 µs | load p99 µs | CPU µs/msg (idle) |");
    let _ = writeln!(out, "|---|---|--:|--:|--:|--:|--:|");
    for (kind, size, name) in [("chain", 0, "chain"), ("hop", 48, "hop (48 B)")] {
        let mut seen = Vec::new();
        for m in rows(r, kind).filter(|m| m.size == size && m.error.is_none()) {
            let key = (m.transport.clone(), m.real_binaries);
            if seen.contains(&key) {
                continue;
            }
            seen.push(key);
            let idle = find(r, kind, &m.transport, false, size, m.real_binaries);
            let load = find(r, kind, &m.transport, true, size, m.real_binaries);
            let cell = |m: Option<&Measurement>, f: fn(&Measurement) -> f64| m.map_or("–".to_string(), |m| us(f(m)));
            let _ = writeln!(
                out,
                "| {name} | {} | {} | {} | {} | {} | {} |",
                label(m),
                cell(idle, |m| m.latency.p50),
                cell(idle, |m| m.latency.p99),
                cell(load, |m| m.latency.p50),
                cell(load, |m| m.latency.p99),
                cell(idle, |m| m.cpu_us_per_msg),
            );
        }
    }
    for p in &r.paced {
        if p.error.is_none() {
            let _ = writeln!(
                out,
                "| 10 Hz paced, {} s under load | `TESTBED_BUS_WAIT={}` | truth→command p50 {} | p99 {} | period error p99 {} | max {} | {} deadline misses during the run ({} at start-up) |",
                p.duration_s,
                p.wait,
                us(p.truth_to_command.p50),
                us(p.truth_to_command.p99),
                us(p.period_error.p99),
                us(p.period_error.max),
                p.deadline_misses - p.deadline_misses_at_start,
                p.deadline_misses_at_start
            );
        }
    }
    out
}

fn paced_table(out: &mut String, runs: &[PacedRun]) {
    let _ = writeln!(
        out,
        "| wait strategy | load | duration s | ticks | deadline misses (at start-up) | late commands | truth→command p50 / p99 / p99.9 / max µs | command period error p50 / p99 / p99.9 / max µs | period min / max ms | plant clock error p99 / max µs | pipeline CPU % of a core |"
    );
    let _ = writeln!(out, "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|");
    for p in runs {
        if let Some(e) = &p.error {
            let _ = writeln!(out, "| {} | {} | {} | failed: {} ||||||||", p.wait, load_name(p.load), p.duration_s, e.replace('|', "/").replace('\n', " "));
            continue;
        }
        let t = &p.truth_to_command;
        let e = &p.period_error;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} ({}) | {} | {} / {} / {} / {} | {} / {} / {} / {} | {:.3} / {:.3} | {} / {} | {:.1} |",
            p.wait,
            load_name(p.load),
            p.duration_s,
            p.ticks,
            p.deadline_misses,
            p.deadline_misses_at_start,
            p.late_commands,
            us(t.p50),
            us(t.p99),
            us(t.p999),
            us(t.max),
            us(e.p50),
            us(e.p99),
            us(e.p999),
            us(e.max),
            p.period_min_ms,
            p.period_max_ms,
            us(p.clock_error.p99),
            us(p.clock_error.max),
            p.pipeline_cpu_percent
        );
    }
}

fn stage_table(out: &mut String, r: &Report) {
    let Some(names) = rows(r, "chain").find(|m| !m.stages.is_empty()).map(|m| m.stages.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>()) else {
        return;
    };
    let _ = write!(out, "| transport | load |");
    for n in &names {
        let _ = write!(out, " {n} p50 / p99 µs |");
    }
    let _ = writeln!(out, " sum of p50s µs | end-to-end p50 µs |");
    let _ = writeln!(out, "|---|---|{}--:|--:|", "--:|".repeat(names.len()));
    for m in rows(r, "chain").filter(|m| m.error.is_none() && m.stages.len() == names.len()) {
        let _ = write!(out, "| {} | {} |", label(m), load_name(m.load));
        for (_, p) in &m.stages {
            let _ = write!(out, " {} / {} |", us(p.p50), us(p.p99));
        }
        let sum: f64 = m.stages.iter().map(|(_, p)| p.p50).sum();
        let _ = writeln!(out, " {} | {} |", us(sum), us(m.latency.p50));
    }
}

/// Each polling wait strategy against plain event waiting (block), same run, same load.
fn wait_verdict(out: &mut String, r: &Report) {
    let strategies: Vec<&Measurement> = r
        .measurements
        .iter()
        .filter(|m| m.transport.starts_with("iox-event") && m.transport != "iox-event-block" && m.kind != "sweep" && m.error.is_none())
        .collect();
    if strategies.is_empty() {
        return;
    }
    let _ = writeln!(out, "## Wait strategies against plain event waiting\n");
    let _ = writeln!(out, "Each polling `WaitStrategy` of the bus's `EventLoop` next to `block` (the default) of the same run and load; ratios below 1 are better.\n");
    let _ = writeln!(out, "| measurement | strategy | load | p50 µs (÷ block) | p99 µs (÷ block) | p99.9 µs (÷ block) | CPU µs/msg (÷ block) |");
    let _ = writeln!(out, "|---|---|---|--:|--:|--:|--:|");
    for m in strategies {
        let Some(b) = find(r, &m.kind, "iox-event-block", m.load, m.size, m.real_binaries) else { continue };
        let cell = |x: f64, y: f64| format!("{} ({})", us(x), ratio(x, y));
        let _ = writeln!(
            out,
            "| {}{} | {} | {} | {} | {} | {} | {} |",
            m.kind,
            if m.real_binaries { " (real binaries)" } else { "" },
            m.transport.trim_start_matches("iox-event-"),
            load_name(m.load),
            cell(m.latency.p50, b.latency.p50),
            cell(m.latency.p99, b.latency.p99),
            cell(m.latency.p999, b.latency.p999),
            cell(m.cpu_us_per_msg, b.cpu_us_per_msg),
        );
    }
    if let Some(b) = r.paced.iter().find(|p| p.wait == "block" && p.error.is_none()) {
        for p in r.paced.iter().filter(|p| p.wait != "block" && p.error.is_none()) {
            let cell = |x: f64, y: f64| format!("{} ({})", us(x), ratio(x, y));
            let _ = writeln!(
                out,
                "| paced 10 Hz, truth → wheel command | {} | {} | {} | {} | {} | {:.1} % of a core ({}) |",
                p.wait,
                load_name(p.load),
                cell(p.truth_to_command.p50, b.truth_to_command.p50),
                cell(p.truth_to_command.p99, b.truth_to_command.p99),
                cell(p.truth_to_command.p999, b.truth_to_command.p999),
                p.pipeline_cpu_percent,
                ratio(p.pipeline_cpu_percent, b.pipeline_cpu_percent),
            );
        }
    }
    let _ = writeln!(out);
}

fn wait_table(out: &mut String, r: &Report) {
    let _ = writeln!(out, "| measurement | load | process | data wake-ups after sleeping | by polling | per message | empty poll windows | stale notifications |");
    let _ = writeln!(out, "|---|---|---|--:|--:|--:|--:|--:|");
    for m in r.measurements.iter().filter(|m| m.transport.starts_with("iox-event") && m.kind != "sweep" && m.error.is_none()) {
        // Wake-up counts cover warm-up too: per message over all the process handled.
        let per = |w: &crate::worker::WaitStatsJson| {
            let handled = (m.messages + m.incomplete) as f64 * if m.kind == "hop" { 0.5 } else { 1.0 };
            if handled > 0.0 { format!("{:.2}", (w.woken + w.polled) as f64 / handled) } else { "–".into() }
        };
        for (process, w) in &m.wait {
            let _ = writeln!(
                out,
                "| {} {} | {} | {} | {} | {} | {} | {} | {} |",
                m.kind,
                label(m),
                load_name(m.load),
                process,
                w.woken,
                w.polled,
                per(w),
                w.empty_windows,
                w.stale_notifications
            );
        }
    }
}

fn sweep_table(out: &mut String, r: &Report) {
    let _ = writeln!(out, "| size | transport | idle p50 µs | idle p99 µs | idle p99.9 µs | load p50 µs | load p99 µs | load p99.9 µs | idle p50 ÷ floor | CPU µs/msg (idle) |");
    let _ = writeln!(out, "|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|");
    let mut sizes: Vec<usize> = rows(r, "sweep").map(|m| m.size).collect();
    sizes.dedup();
    for size in sizes {
        let mut transports: Vec<&str> = rows(r, "sweep").filter(|m| m.size == size).map(|m| m.transport.as_str()).collect();
        transports.dedup();
        for t in transports {
            let idle = find(r, "sweep", t, false, size, false);
            let load = find(r, "sweep", t, true, size, false);
            let floor = find(r, "sweep", "iox-poll", false, size, false).map_or(0.0, |f| f.latency.p50);
            let Some(any) = idle.or(load) else {
                let _ = writeln!(out, "| {size} | {t} | failed |||||||");
                continue;
            };
            let cell = |m: Option<&Measurement>, f: fn(&Measurement) -> f64| m.map_or("–".to_string(), |m| us(f(m)));
            let _ = writeln!(
                out,
                "| {size} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                any.label,
                cell(idle, |m| m.latency.p50),
                cell(idle, |m| m.latency.p99),
                cell(idle, |m| m.latency.p999),
                cell(load, |m| m.latency.p50),
                cell(load, |m| m.latency.p99),
                cell(load, |m| m.latency.p999),
                idle.map_or("–".into(), |m| ratio(m.latency.p50, floor)),
                cell(idle, |m| m.cpu_us_per_msg),
            );
        }
    }
}

/// The whole report.
pub fn markdown(r: &Report) -> String {
    let s = &r.settings;
    let mut out = String::new();
    let _ = writeln!(out, "# Latency of the test bed's pipeline\n");
    let _ = writeln!(
        out,
        "Measured by `{}` on {}, {:.0} s of wall time{}. Every number below was measured in this run, next to its baselines (busy-poll floor, Unix socket) of the same run and load. Figure: [latency.svg](latency.svg); every number: `report.json`.\n",
        r.command,
        r.machine.started,
        r.wall_s,
        if r.quick { " — **quick mode: a smoke check of the harness, too few samples for the tails to mean anything**" } else { "" }
    );
    let _ = writeln!(out, "## Machine\n");
    let m = &r.machine;
    let _ = writeln!(out, "| | |\n|---|---|");
    let _ = writeln!(out, "| CPU | {} |", m.cpu_model);
    let _ = writeln!(out, "| cores | {} |", m.cpus);
    let _ = writeln!(out, "| virtualisation | {} |", m.hypervisor);
    let _ = writeln!(out, "| kernel | {} |", m.kernel);
    let _ = writeln!(out, "| clock source | {} |", m.clocksource);
    if !m.cpuidle.is_empty() {
        let _ = writeln!(out, "| idle states | {} |", m.cpuidle);
    }
    let _ = writeln!(out, "| memory | {:.1} GiB |", m.memory_gib);
    let _ = writeln!(out, "| load average 1/5/15 min, start → end | {} → {} |", m.loadavg_start, m.loadavg_end);
    let _ = writeln!(out, "| toolchain | {} |", m.rustc);
    let _ = writeln!(
        out,
        "| \"under load\" | one thread spinning on CPU {} for the whole measurement (the other core busy); the machine is shared, so \"idle\" only means no hog of ours (the *machine busy* column shows everyone's CPU use) |",
        s["hog_cpu"]
    );
    let _ = writeln!(out);
    let _ = writeln!(out, "## Headline\n");
    out.push_str(&headline(r));
    let _ = writeln!(out);
    let _ = writeln!(out, "## Checks\n");
    for line in checks(r) {
        let _ = writeln!(out, "- {line}");
    }
    let _ = writeln!(out);
    wait_verdict(&mut out, r);
    let _ = writeln!(out, "## Chain: gyro gateway → estimator → controller → wheel gateway\n");
    let _ = writeln!(
        out,
        "{} measured cycles per row in {} interleaved rounds (each after {} warm-up cycles), a gyro sample every {} µs of wall time; latency from the gyro sample entering its gateway to the wheel command leaving the wheel gateway. Four processes with the pipeline's own logic (`EstimatorNode`, `ControllerNode`: MEKF propagation and 2.5 Hz vector updates, PD + friction compensation) replaying a recorded closed-loop run; rows marked *real binaries* run the pipeline's `estimator` and `controller` executables. CPU is the four processes' together, per cycle.\n",
        s["cycles"], s["rounds"], s["warmup_cycles"], s["period_us"]
    );
    distribution_table(&mut out, r, "chain", 0);
    let _ = writeln!(out);
    let _ = writeln!(out, "Where the time goes: each stage of the chain (hops: publish → taken by the next process; compute: input taken → output published), from the same cycles.\n");
    stage_table(&mut out, r);
    let _ = writeln!(out);
    let _ = writeln!(out, "## One hop (48 B: `GyroSample` out, `WheelCommand` back)\n");
    let _ = writeln!(
        out,
        "{} measured hops per row in {} interleaved rounds, ping-pong between two processes with a {} µs pause before each exchange (both sides go to sleep, as between the pipeline's ticks); each direction is one hop. CPU is both processes' together, per hop.\n",
        s["hops"], s["rounds"], s["gap_us"]
    );
    distribution_table(&mut out, r, "hop", 48);
    let _ = writeln!(out);
    let _ = writeln!(out, "## Payload sweep (one hop, back-to-back ping-pong)\n");
    let _ = writeln!(
        out,
        "{} measured hops per row, no pause between exchanges. Sizes are whole samples (24-byte header included). Every transport copies the sample in and out once (the bus hands samples out by value); UDP sends 64 KiB as two datagrams (at most 65 507 bytes fit in one).\n",
        s["sweep_hops"]
    );
    sweep_table(&mut out, r);
    let _ = writeln!(out);
    let _ = writeln!(out, "## 10 Hz loop, paced `testbed run` under load\n");
    let _ = writeln!(
        out,
        "`testbed run --profile simulation --paced --duration N` (the whole pipeline: plant, simulated gateways, estimator, controller, logger) with the CPU hog running, watched by an extra subscriber process that time-stamps every tick's samples on arrival (its own wake-up adds to each stamp). Deadline misses are the controller's count (`ControllerStatus.deadline_misses`, deadline 100 ms + 50 ms slack); *late commands* are ticks whose wheel command reached the observer after the next tick's truth (the plant then holds the previous command).\n"
    );
    paced_table(&mut out, &r.paced);
    let _ = writeln!(out);
    if r.paced.iter().any(|p| !p.stages.is_empty()) {
        let _ = writeln!(out, "Stages of truth → wheel command, as the observer saw them arrive (p50 / p99 µs):\n");
        let _ = writeln!(out, "| wait strategy | {} |", r.paced.iter().find(|p| !p.stages.is_empty()).map(|p| p.stages.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(" | ")).unwrap_or_default());
        let n = r.paced.iter().map(|p| p.stages.len()).max().unwrap_or(0);
        let _ = writeln!(out, "|---|{}", "--:|".repeat(n));
        for p in r.paced.iter().filter(|p| !p.stages.is_empty()) {
            let cells: Vec<String> = p.stages.iter().map(|(_, s)| format!("{} / {}", us(s.p50), us(s.p99))).collect();
            let _ = writeln!(out, "| {} | {} |", p.wait, cells.join(" | "));
        }
        let _ = writeln!(out);
    }
    if r.paced.iter().any(|p| !p.processes.is_empty()) {
        let _ = writeln!(out, "What each process of the paced runs cost per tick (CPU / time runnable but waiting for a CPU, µs; the whole run including start-up):\n");
        let mut names: Vec<String> = Vec::new();
        for p in &r.paced {
            for c in &p.processes {
                if !names.contains(&c.name) {
                    names.push(c.name.clone());
                }
            }
        }
        let _ = writeln!(out, "| wait strategy | {} |", names.join(" | "));
        let _ = writeln!(out, "|---|{}", "--:|".repeat(names.len()));
        for p in r.paced.iter().filter(|p| !p.processes.is_empty()) {
            let cells: Vec<String> = names
                .iter()
                .map(|n| p.processes.iter().find(|c| &c.name == n).map_or("–".into(), |c| format!("{} / {}", us(c.cpu_us_per_tick), us(c.runqueue_us_per_tick))))
                .collect();
            let _ = writeln!(out, "| {} | {} |", p.wait, cells.join(" | "));
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(out, "## How the event loops woke\n");
    let _ = writeln!(out, "Data wake-ups of the bus processes' event loops: after sleeping in the WaitSet (a scheduler wake-up) or by polling (none); *per message* is per hop or chain cycle the process took part in (warm-up included, so slightly high). The bus has one event service per topic, so a process is woken once per topic that has news; a socket process takes every datagram that has arrived in one wake-up.\n");
    wait_table(&mut out, r);
    let _ = writeln!(out);
    let _ = writeln!(out, "## Method\n");
    for line in [
        "Latency = CLOCK_MONOTONIC when the receiver has the sample (copied out) − CLOCK_MONOTONIC just before the sender publishes; both processes on the same machine read the same clock. Percentiles by nearest rank over every sample; no sample is dropped or binned.",
        "`iceoryx2 event (block)` is the pipeline as it runs: `testbed-bus` publish (send + notify on the paired event service) and an `EventLoop` sleeping in its WaitSet. `(anticipate…)`, `(spin:…)` are the same with a polling `WaitStrategy` (`TESTBED_BUS_WAIT`).",
        "`iceoryx2 busy-poll (floor)` is iceoryx2 publish/subscribe without the event service, the receiver polling its subscribers and calling `sched_yield` between polls (with more processes than cores, pure spinning would hand the core over only at the end of a time slice).",
        "Unix datagram socket and UDP on loopback: one receiving socket per process, blocking `recv`, samples sent as their bytes (chain: with a topic tag).",
        "CPU = the processes' on-CPU time from `/proc/<pid>/task/*/schedstat` over the measured window, divided by the messages; run-queue = time they were runnable but had no CPU. *Machine busy* = everyone's CPU use from `/proc/stat` over the same window.",
    ] {
        let _ = writeln!(out, "- {line}");
    }
    out
}
