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

/// More than this many times `block`'s CPU per message disqualifies a polling wait strategy
/// from becoming the pipeline's default.
const CPU_LIMIT: f64 = 2.0;

/// The busy-poll floor rows of `kind` at `load` are compared with: that load's median, or
/// the idle one (`true`) where busy-polling is no floor, i.e. its median is above the Unix
/// socket's (more polling processes than CPUs: they take turns at `sched_yield`). `None`
/// where neither is a floor.
fn floor_of(r: &Report, kind: &str, load: bool, size: usize) -> Option<(f64, bool)> {
    let is_floor = |load: bool| {
        let floor = find(r, kind, "iox-poll", load, size, false)?.latency.p50;
        let uds = find(r, kind, "uds", load, size, false).map_or(f64::INFINITY, |u| u.latency.p50);
        (floor <= uds).then_some(floor)
    };
    match is_floor(load) {
        Some(f) => Some((f, false)),
        None if load => is_floor(false).map(|f| (f, true)),
        None => None,
    }
}

/// Why the busy-poll floor of `kind` under load stands aside, if it does (for notes).
fn no_floor_note(r: &Report, kind: &str, size: usize) -> Option<String> {
    let (_, substituted) = floor_of(r, kind, true, size)?;
    if !substituted {
        return None;
    }
    let floor = find(r, kind, "iox-poll", true, size, false)?;
    let uds = find(r, kind, "uds", true, size, false)?;
    Some(format!(
        "under load busy-polling is no floor on {} CPUs: the polling processes and the hog take turns at `sched_yield`, so its median ({} µs) is above the Unix socket's ({} µs); load rows are compared with the idle floor instead",
        r.machine.cpus,
        us(floor.latency.p50),
        us(uds.latency.p50)
    ))
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
        let floor = match floor_of(r, kind, m.load, size) {
            Some((f, false)) => ratio(m.latency.p50, f),
            Some((f, true)) => format!("{} (idle floor)", ratio(m.latency.p50, f)),
            None => "n/a".into(),
        };
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
            floor,
            ratio(l.p99, uds),
            us(m.cpu_us_per_msg),
            us(m.runqueue_us_per_msg),
            m.machine_busy * 100.0
        );
    }
    if let Some(note) = no_floor_note(r, kind, size) {
        let mut note = note;
        note[..1].make_ascii_uppercase();
        let _ = writeln!(out, "\n{note} (*p50 ÷ floor*).");
    }
}

/// The verdicts the issue asks for, per bus wait strategy and load.
pub fn checks(r: &Report) -> Vec<String> {
    let mut lines = Vec::new();
    let waits: Vec<&Measurement> = rows(r, "chain").filter(|m| m.transport.starts_with("iox-event") && !m.real_binaries && m.error.is_none()).collect();
    for m in waits {
        let Some(uds) = find(r, "chain", "uds", m.load, 0, false) else {
            continue;
        };
        let p99_ok = m.latency.p99 <= uds.latency.p99;
        let median = match floor_of(r, "chain", m.load, 0) {
            Some((floor, substituted)) => format!(
                "median {} µs vs {}busy-poll floor {} µs = {} → {}",
                us(m.latency.p50),
                if substituted { "the *idle* " } else { "" },
                us(floor),
                ratio(m.latency.p50, floor),
                if m.latency.p50 <= 3.0 * floor { "**within 3×**" } else { "**not within 3×**" },
            ),
            None => "median: **not applicable**, busy-polling was slower than the Unix socket idle and under load (no floor in this run)".into(),
        };
        lines.push(format!(
            "{} chain, {}: p99 {} µs vs Unix socket {} µs → {}; {median}",
            m.label,
            load_name(m.load),
            us(m.latency.p99),
            us(uds.latency.p99),
            if p99_ok { "**at or below**" } else { "**above** (reason below)" },
        ));
    }
    if let Some(note) = no_floor_note(r, "chain", 0) {
        lines.push(format!("The busy-poll floor of the chain: {note}."));
    }
    for p in &r.paced {
        lines.push(match &p.error {
            None => format!(
                "Paced 10 Hz run, {} s, {}, `TESTBED_BUS_WAIT={}`: **{} deadline misses** (the controller's count, supervised from the first estimate on), {} late or missing wheel commands over {} ticks",
                p.duration_s,
                if p.load { "under load" } else { "idle" },
                p.wait,
                p.deadline_misses,
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
                "| 10 Hz paced, {} s under load | `TESTBED_BUS_WAIT={}` | truth→command p50 {} | p99 {} | period error p99 {} | max {} | {} deadline misses |",
                p.duration_s,
                p.wait,
                us(p.truth_to_command.p50),
                us(p.truth_to_command.p99),
                us(p.period_error.p99),
                us(p.period_error.max),
                p.deadline_misses
            );
        }
    }
    out
}

fn paced_table(out: &mut String, runs: &[PacedRun]) {
    let _ = writeln!(
        out,
        "| wait strategy | load | duration s | ticks | deadline misses | late commands | truth→command p50 / p99 / p99.9 / max µs | command period error p50 / p99 / p99.9 / max µs | period min / max ms | plant clock error p99 / max µs | pipeline CPU % of a core |"
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
            "| {} | {} | {} | {} | {} | {} | {} / {} / {} / {} | {} / {} / {} / {} | {:.3} / {:.3} | {} / {} | {:.1} |",
            p.wait,
            load_name(p.load),
            p.duration_s,
            p.ticks,
            p.deadline_misses,
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

/// The bus wait strategies measured on the chain besides `block`, in measurement order.
fn polling_strategies(r: &Report) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for m in rows(r, "chain").filter(|m| m.transport.starts_with("iox-event-") && m.transport != "iox-event-block") {
        let wait = m.transport.trim_start_matches("iox-event-").to_string();
        if !out.contains(&wait) {
            out.push(wait);
        }
    }
    out
}

/// Whether a polling strategy should become the pipeline's default, computed from the chain
/// rows: it must beat `block` on p99 in every chain row (idle and load; harness and, where
/// measured, the real binaries) at no more than [`CPU_LIMIT`] times its CPU per cycle.
pub fn decision(r: &Report) -> String {
    let mut out = String::new();
    let default = testbed_bus::WaitStrategy::default();
    let _ = writeln!(out, "## Decision on the wait strategy\n");
    let strategies = polling_strategies(r);
    if strategies.is_empty() {
        let _ = writeln!(out, "Only `block` was measured on the chain: nothing to decide; the pipeline's default (`WaitStrategy::default()`) is `{default}`.\n");
        return out;
    }
    let _ = writeln!(
        out,
        "Rule: a polling strategy becomes the pipeline's default only if it beats `block` on the chain's p99 both idle and under load — in every chain row measured, the harness's and the real binaries' — for at most {CPU_LIMIT}× `block`'s CPU per cycle. Ratios are to `block` of the same run, load and processes.\n"
    );
    // (strategy, worst p99 ratio, worst CPU ratio) of those that pass.
    let mut passed: Vec<(String, f64, f64)> = Vec::new();
    let mut best_median: Option<(String, bool, f64)> = None;
    for wait in &strategies {
        let key = format!("iox-event-{wait}");
        let mut cells = Vec::new();
        let mut failures = Vec::new();
        let (mut worst_p99, mut worst_cpu) = (0.0_f64, 0.0_f64);
        let mut loads = [false; 2];
        for m in rows(r, "chain").filter(|m| m.transport == key && m.error.is_none()) {
            let Some(b) = find(r, "chain", "iox-event-block", m.load, 0, m.real_binaries) else { continue };
            if b.latency.p99 <= 0.0 || b.cpu_us_per_msg <= 0.0 {
                continue;
            }
            loads[usize::from(m.load)] = true;
            let where_ = format!("{}{}", load_name(m.load), if m.real_binaries { ", real binaries" } else { "" });
            let (p99, cpu, p50) = (m.latency.p99 / b.latency.p99, m.cpu_us_per_msg / b.cpu_us_per_msg, m.latency.p50 / b.latency.p50);
            cells.push(format!("{where_}: p99 {} ({} vs {} µs), CPU {}", ratio(m.latency.p99, b.latency.p99), us(m.latency.p99), us(b.latency.p99), ratio(m.cpu_us_per_msg, b.cpu_us_per_msg)));
            if p99 >= 1.0 {
                failures.push(format!("p99 {:.2}× block ({where_})", p99));
            }
            if cpu > CPU_LIMIT {
                failures.push(format!("CPU {:.2}× block ({where_})", cpu));
            }
            worst_p99 = worst_p99.max(p99);
            worst_cpu = worst_cpu.max(cpu);
            if best_median.as_ref().is_none_or(|(_, _, r)| p50 < *r) {
                best_median = Some((wait.clone(), m.load, p50));
            }
        }
        if !loads[0] || !loads[1] {
            failures.push("not measured both idle and under load".into());
        }
        let verdict = if failures.is_empty() {
            passed.push((wait.clone(), worst_p99, worst_cpu));
            "**passes**".to_string()
        } else {
            format!("**fails**: {}", failures.join(", "))
        };
        let _ = writeln!(out, "- `{wait}`: {} → {verdict}", if cells.is_empty() { "no chain row".into() } else { cells.join("; ") });
    }
    let _ = writeln!(out);
    passed.sort_by(|a, b| a.1.total_cmp(&b.1));
    match passed.first() {
        Some((wait, p99, cpu)) => {
            let is_default = wait.parse::<testbed_bus::WaitStrategy>().is_ok_and(|w| w == default);
            let _ = writeln!(
                out,
                "**Adopt `{wait}`**: its chain p99 is at most {p99:.2}× `block`'s in every row, for at most {cpu:.2}× the CPU. {}\n",
                if is_default {
                    "It is the pipeline's default (`WaitStrategy::default()`).".to_string()
                } else {
                    format!("**The pipeline's default (`WaitStrategy::default()`) is still `{default}`**: this run argues for switching it; until then `TESTBED_BUS_WAIT={wait}` selects it for a run. One run on a shared machine: confirm with a second before switching.")
                }
            );
        }
        None => {
            let median = best_median.map_or(String::new(), |(wait, load, p50)| {
                format!(" What polling does buy is the median where a process is already polling when the sample lands (best: `{wait}`, {}, chain p50 {:.2}× `block`'s), not the tail, and it pays for it in CPU.", load_name(load), p50)
            });
            let _ = writeln!(
                out,
                "**Keep `block`** (the pipeline's default, `WaitStrategy::default()` = `{default}`): no polling strategy beats it on the chain's p99 both idle and under load within {CPU_LIMIT}× its CPU.{median}\n"
            );
        }
    }
    out
}

/// Why the event chain's p99 is where it is against the Unix-socket chain, from the chain's
/// stages, the single hop and the payload sweep of the same run.
pub fn event_vs_socket(r: &Report) -> String {
    let mut out = String::new();
    let pairs: Vec<(bool, &Measurement, &Measurement)> = [false, true]
        .into_iter()
        .filter_map(|load| Some((load, find(r, "chain", "iox-event-block", load, 0, false)?, find(r, "chain", "uds", load, 0, false)?)))
        .collect();
    if pairs.is_empty() {
        return out;
    }
    let above = pairs.iter().any(|(_, e, u)| e.latency.p99 > u.latency.p99);
    let _ = writeln!(
        out,
        "## {}\n",
        if above { "Why the event chain's p99 is above the Unix socket's" } else { "The event chain against the Unix-socket chain" }
    );
    let chain: Vec<String> = pairs
        .iter()
        .map(|(load, e, u)| format!("{} {} vs {} µs ({})", load_name(*load), us(e.latency.p99), us(u.latency.p99), ratio(e.latency.p99, u.latency.p99)))
        .collect();
    let _ = writeln!(out, "Chain p99, iceoryx2 event (`block`) vs Unix datagram socket: {}.\n", chain.join("; "));
    let _ = writeln!(
        out,
        "**The mechanism** (iceoryx2 0.10 source): `ipc::Service`'s event concept is `iceoryx2_cal::event::recommended::Ipc` = `UnixDatagramShmCountingBitSet`. A notifier sets the event id in a counting bit set in shared memory and sends a one-byte datagram to each listener's Unix datagram socket (`event/trigger/unix_datagram_socket.rs`: `notify` → `try_send(&[0u8])`); the WaitSet sleeps in `epoll_wait` on those sockets (`reactor::recommended::Ipc` = `Epoll` on Linux) and the listener reads the datagram and the bit set. So one bus hop is the sample copied into and out of shared memory (the bus hands samples over by value: `send_copy`, a copy of the payload out) **plus** the kernel path of a Unix datagram — send, wake-up of the sleeping receiver, receive — **plus** `epoll`, the bit set and the WaitSet's and the bus's bookkeeping. A Unix-socket hop is that kernel path alone, its copies of a 48-byte sample negligible. With small samples an event hop is a socket hop with extra work: it cannot be faster, and the chain, three hops, pays that three times.\n"
    );
    let mut measured = Vec::new();
    let hop_pairs: Vec<(bool, &Measurement, &Measurement)> = [false, true]
        .into_iter()
        .filter_map(|load| Some((load, find(r, "hop", "iox-event-block", load, 48, false)?, find(r, "hop", "uds", load, 48, false)?)))
        .collect();
    if !hop_pairs.is_empty() {
        let cells: Vec<String> = hop_pairs
            .iter()
            .map(|(load, e, u)| {
                format!(
                    "{} p50 {} vs {} µs ({:+.1} µs), p99 {} vs {} µs, CPU {} vs {} µs per hop",
                    load_name(*load),
                    us(e.latency.p50),
                    us(u.latency.p50),
                    e.latency.p50 - u.latency.p50,
                    us(e.latency.p99),
                    us(u.latency.p99),
                    us(e.cpu_us_per_msg),
                    us(u.cpu_us_per_msg)
                )
            })
            .collect();
        measured.push(format!("One hop of 48 B, event vs socket: {}.", cells.join("; ")));
        for (load, e, u) in &pairs {
            if let Some((_, he, hu)) = hop_pairs.iter().find(|(l, _, _)| l == load) {
                let per_hop = he.latency.p50 - hu.latency.p50;
                measured.push(format!(
                    "Chain, {}: three hops × {:+.1} µs = {:+.1} µs against {:+.1} µs between the chains' medians.",
                    load_name(*load),
                    per_hop,
                    3.0 * per_hop,
                    e.latency.p50 - u.latency.p50
                ));
            }
        }
    }
    for (load, e, u) in &pairs {
        measured.push(format!(
            "Per chain cycle, {}: {} µs of CPU against the sockets' {} µs ({}), and {} µs runnable but waiting for a CPU against {} µs: on {} CPUs the extra work of every hop is time the chain's other processes can queue behind, and queueing is what a tail is made of.",
            load_name(*load),
            us(e.cpu_us_per_msg),
            us(u.cpu_us_per_msg),
            ratio(e.cpu_us_per_msg, u.cpu_us_per_msg),
            us(e.runqueue_us_per_msg),
            us(u.runqueue_us_per_msg),
            r.machine.cpus
        ));
        if e.stages.len() == u.stages.len() && !e.stages.is_empty() {
            let excess: Vec<(String, f64)> = e.stages.iter().zip(&u.stages).map(|((name, pe), (_, pu))| (name.clone(), pe.p99 - pu.p99)).collect();
            let cells: Vec<String> = excess.iter().map(|(name, d)| format!("{name} {d:+.1}")).collect();
            let largest = excess.iter().max_by(|a, b| a.1.total_cmp(&b.1));
            measured.push(format!(
                "Stage p99, event − socket, {} (µs): {}{}.",
                load_name(*load),
                cells.join(", "),
                largest.map_or(String::new(), |(name, d)| format!("; the largest excess is {name} ({d:+.1} µs)"))
            ));
        }
        if let Some((_, w)) = e.wait.iter().find(|(p, _)| p == "controller") {
            let handled = (e.messages + e.incomplete) as f64;
            if handled > 0.0 {
                measured.push(format!(
                    "The bus wakes a process once per topic with news: the controller {:.2} times per cycle {} (estimate, wheel and CMG telemetry each have their own event service), where a socket process takes every datagram that has arrived in one wake-up.",
                    (w.woken + w.polled + w.swept) as f64 / handled,
                    load_name(*load)
                ));
            }
        }
    }
    // The payload sweep: does the event hop catch up where copying dominates?
    let mut sizes: Vec<usize> = rows(r, "sweep").map(|m| m.size).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let gaps: Vec<String> = sizes
        .iter()
        .filter_map(|&size| {
            let e = find(r, "sweep", "iox-event-block", false, size, false)?;
            let u = find(r, "sweep", "uds", false, size, false)?;
            Some(format!("{} {:+.1}", size_name(size), e.latency.p50 - u.latency.p50))
        })
        .collect();
    if !gaps.is_empty() {
        measured.push(format!("Payload sweep, idle p50 event − socket (µs): {}.", gaps.join(", ")));
    }
    if let (Some(&smallest), Some(&largest)) = (sizes.first(), sizes.last()) {
        for load in [false, true] {
            let (Some(e), Some(u)) = (find(r, "sweep", "iox-event-block", load, largest, false), find(r, "sweep", "uds", load, largest, false)) else {
                continue;
            };
            let verdict = if e.latency.p50 < u.latency.p50 {
                "the event hop is faster than the socket there: copying dominates and shared memory saves the kernel's copies".to_string()
            } else {
                let notification = |size: usize| {
                    let e = find(r, "sweep", "iox-event-block", load, size, false)?;
                    let f = find(r, "sweep", "iox-poll", load, size, false)?;
                    Some((e.latency.p50 - f.latency.p50, f.latency.p50))
                };
                match (notification(largest), notification(smallest)) {
                    (Some((big, floor)), Some((small, _))) => format!(
                        "the event hop does not catch up: without its notification (busy-poll) the shared-memory hop takes {} µs, {} the socket's {} µs, but the notification and the wake-up it brings add {big:+.1} µs here ({small:+.1} µs at {}). Nor does shared memory save a copy in the bus: it hands samples over by value (`send_copy` in, a copy out), the socket's two copies",
                        us(floor),
                        if floor < u.latency.p50 { "less than" } else { "no less than" },
                        us(u.latency.p50),
                        size_name(smallest)
                    ),
                    _ => "the event hop does not catch up: the bus copies each sample in and out by value, as the socket does, and the notification comes on top".to_string(),
                }
            };
            measured.push(format!(
                "At {}, {}: event p50 {} µs vs socket {} µs — {verdict}.",
                size_name(largest),
                load_name(load),
                us(e.latency.p50),
                us(u.latency.p50)
            ));
        }
    }
    let _ = writeln!(out, "**Measured** (same run):\n");
    for line in measured {
        let _ = writeln!(out, "- {line}");
    }
    let _ = writeln!(out);
    out.push_str(&event_vs_floor(r));
    out
}

/// Why the event chain's median is where it is against the busy-poll floor (idle: under
/// load on a small machine busy-polling is no floor, see [`floor_of`]).
fn event_vs_floor(r: &Report) -> String {
    let mut out = String::new();
    let (Some(e), Some(f)) = (find(r, "chain", "iox-event-block", false, 0, false), find(r, "chain", "iox-poll", false, 0, false)) else {
        return out;
    };
    let within = e.latency.p50 <= 3.0 * f.latency.p50;
    let _ = writeln!(
        out,
        "## {}\n",
        if within { "The event chain's median against the busy-poll floor" } else { "Why the event chain's median is not within 3× of the busy-poll floor" }
    );
    let mut lines = vec![format!(
        "Chain p50, idle: event (`block`) {} µs vs busy-poll {} µs ({}), for {} vs {} µs of CPU per cycle ({}): the floor's processes never sleep.",
        us(e.latency.p50),
        us(f.latency.p50),
        ratio(e.latency.p50, f.latency.p50),
        us(e.cpu_us_per_msg),
        us(f.cpu_us_per_msg),
        ratio(f.cpu_us_per_msg, e.cpu_us_per_msg)
    )];
    if let (Some(he), Some(hf)) = (find(r, "hop", "iox-event-block", false, 48, false), find(r, "hop", "iox-poll", false, 48, false)) {
        let per_hop = he.latency.p50 - hf.latency.p50;
        lines.push(format!(
            "One hop of 48 B, idle: event p50 {} µs vs busy-poll {} µs: the notification and the wake-up of a sleeping receiver cost {per_hop:+.1} µs per hop, {:+.1} µs over the chain's three hops, against {:+.1} µs between the chains' medians. A receiver that sleeps pays them; only one already polling when the sample lands does not.",
            us(he.latency.p50),
            us(hf.latency.p50),
            3.0 * per_hop,
            e.latency.p50 - f.latency.p50
        ));
    }
    let best = rows(r, "chain")
        .filter(|m| m.transport.starts_with("iox-event-") && !m.load && !m.real_binaries && m.error.is_none())
        .min_by(|a, b| a.latency.p50.total_cmp(&b.latency.p50));
    if let Some(b) = best.filter(|b| b.transport != "iox-event-block") {
        lines.push(format!(
            "The closest a wait strategy came: {} at {} µs, {} the floor, for {} `block`'s CPU per cycle (see the decision above).",
            b.label,
            us(b.latency.p50),
            ratio(b.latency.p50, f.latency.p50),
            ratio(b.cpu_us_per_msg, e.cpu_us_per_msg)
        ));
    }
    for line in lines {
        let _ = writeln!(out, "- {line}");
    }
    let _ = writeln!(out);
    out
}

fn size_name(size: usize) -> String {
    if size >= 1024 && size.is_multiple_of(1024) { format!("{} KiB", size / 1024) } else { format!("{size} B") }
}

fn wait_table(out: &mut String, r: &Report) {
    let _ = writeln!(out, "| measurement | load | process | data wake-ups after sleeping | by polling | by the listener sweep | per message | empty poll windows | stale notifications |");
    let _ = writeln!(out, "|---|---|---|--:|--:|--:|--:|--:|--:|");
    for m in r.measurements.iter().filter(|m| m.transport.starts_with("iox-event") && m.kind != "sweep" && m.error.is_none()) {
        // Wake-up counts cover warm-up too: per message over all the process handled.
        let per = |w: &crate::worker::WaitStatsJson| {
            let handled = (m.messages + m.incomplete) as f64 * if m.kind == "hop" { 0.5 } else { 1.0 };
            if handled > 0.0 { format!("{:.2}", (w.woken + w.polled + w.swept) as f64 / handled) } else { "–".into() }
        };
        for (process, w) in &m.wait {
            let _ = writeln!(
                out,
                "| {} {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                m.kind,
                label(m),
                load_name(m.load),
                process,
                w.woken,
                w.polled,
                w.swept,
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

/// What an unfinished run's report lacks (it is saved after every phase).
fn unfinished(r: &Report) -> String {
    let planned = r.settings["paced_waits"].as_array().map_or(0, Vec::len);
    let paced = if planned > r.paced.len() { format!(": {} of {planned} paced runs done", r.paced.len()) } else { String::new() };
    format!(" — **the run did not finish{paced}; this is what it had measured**")
}

/// The whole report.
pub fn markdown(r: &Report) -> String {
    let s = &r.settings;
    let mut out = String::new();
    let _ = writeln!(out, "# Latency of the test bed's pipeline\n");
    let _ = writeln!(
        out,
        "Measured by `{}` on {}, {:.0} s of wall time{}{}. Every number below was measured in this run, next to its baselines (busy-poll floor, Unix socket) of the same run and load. Figure: [latency.svg](latency.svg); every number: `report.json`.\n",
        r.command,
        r.machine.started,
        r.wall_s,
        if r.quick { " — **quick mode: a smoke check of the harness, too few samples for the tails to mean anything**" } else { "" },
        if r.complete { String::new() } else { unfinished(r) }
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
    out.push_str(&decision(r));
    out.push_str(&event_vs_socket(r));
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
        "`testbed run --profile simulation --paced --duration N` (the whole pipeline: plant, simulated gateways, estimator, controller, logger) with the CPU hog running, watched by an extra subscriber process that time-stamps every tick's samples on arrival (its own wake-up adds to each stamp). Deadline misses are the controller's count (`ControllerStatus.deadline_misses`: no estimate for 100 ms + 50 ms slack, supervised from the first estimate on); *late commands* are ticks whose wheel command reached the observer after the next tick's truth (the plant then holds the previous command).\n"
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Percentiles;

    fn row(kind: &str, transport: &str, load: bool, p50: f64, p99: f64, cpu: f64) -> Measurement {
        Measurement {
            kind: kind.into(),
            transport: transport.into(),
            label: transport.into(),
            load,
            size: if kind == "hop" { 48 } else { 0 },
            latency: Percentiles { n: 100, p50, p90: p99, p99, p999: p99, max: p99, mean: p50 },
            messages: 100,
            cpu_us_per_msg: cpu,
            ..Measurement::default()
        }
    }

    /// A chain idle and under load: block, two polling strategies, the floor (no floor under
    /// load: above the socket), the socket.
    fn report(spin_load_p99: f64, spin_cpu: f64) -> Report {
        let mut r = Report::default();
        r.machine.cpus = 2;
        for load in [false, true] {
            r.measurements.extend([
                row("chain", "iox-event-block", load, 60.0, 200.0, 100.0),
                row("chain", "iox-event-anticipate", load, 30.0, if load { 4000.0 } else { 150.0 }, 300.0),
                row("chain", "iox-event-spin:50", load, 60.0, if load { spin_load_p99 } else { 150.0 }, spin_cpu),
                row("chain", "iox-poll", load, if load { 1500.0 } else { 15.0 }, 5000.0, 900.0),
                row("chain", "uds", load, 45.0, 100.0, 80.0),
            ]);
        }
        r
    }

    #[test]
    fn a_polling_strategy_is_adopted_only_if_it_beats_block_idle_and_under_load_within_the_cpu_limit() {
        let text = decision(&report(100.0, 150.0));
        assert!(text.contains("**Adopt `spin:50`**"), "{text}");
        assert!(text.contains("`anticipate`") && text.contains("**fails**"), "{text}");
        assert!(text.contains("still `block`"), "the default is block: {text}");

        let worse_under_load = decision(&report(250.0, 150.0));
        assert!(worse_under_load.contains("**Keep `block`**"), "{worse_under_load}");
        let too_costly = decision(&report(100.0, 250.0));
        assert!(too_costly.contains("**Keep `block`**") && too_costly.contains("CPU 2.50× block"), "{too_costly}");
    }

    #[test]
    fn under_load_a_busy_poll_slower_than_the_socket_is_no_floor() {
        let r = report(100.0, 150.0);
        assert_eq!(floor_of(&r, "chain", false, 0), Some((15.0, false)));
        assert_eq!(floor_of(&r, "chain", true, 0), Some((15.0, true)), "the idle floor stands in");
        let checks = checks(&r).join("\n");
        assert!(checks.contains("vs the *idle* busy-poll floor 15.00 µs = 4.00×"), "{checks}");
        assert!(checks.contains("no floor on 2 CPUs"), "{checks}");
        assert!(!checks.contains("0.04×"), "never a ratio to a floor above the socket: {checks}");
    }

    #[test]
    fn the_event_chain_against_the_socket_is_explained_from_the_numbers() {
        let mut r = report(100.0, 150.0);
        for load in [false, true] {
            r.measurements.push(row("hop", "iox-event-block", load, 10.0, 21.0, 20.0));
            r.measurements.push(row("hop", "uds", load, 6.0, 20.0, 16.0));
            r.measurements.push(row("hop", "iox-poll", load, 1.0, 3.0, 75.0));
        }
        let text = event_vs_socket(&r);
        assert!(text.contains("## Why the event chain's p99 is above the Unix socket's"), "{text}");
        assert!(text.contains("UnixDatagramShmCountingBitSet"), "{text}");
        assert!(text.contains("three hops × +4.0 µs = +12.0 µs against +15.0 µs"), "{text}");
        assert!(text.contains("## Why the event chain's median is not within 3× of the busy-poll floor"), "{text}");
    }
}
