//! The report's tables, one function per kind, each generated from the measurements with
//! every number next to its baselines of the same run (the busy-poll floor, the Unix socket,
//! `block`).

use crate::latency::model::{Kind, Measurement, Report, round_ratios};
use crate::latency::protocol::Transport;
use crate::latency::stats::Percentiles;
use crate::median;
use std::fmt::Write as _;

/// More than this many times `block`'s CPU per message disqualifies a polling wait strategy
/// from becoming the pipeline's default.
pub const CPU_LIMIT: f64 = 2.0;

/// A Markdown table: the first `text_columns` columns left-aligned, the rest right-aligned
/// (numbers); rows shorter than the header are padded with empty cells.
pub fn table(
    out: &mut String,
    head: &str,
    text_columns: usize,
    rows: impl IntoIterator<Item = Vec<String>>,
) {
    let width = head.split(" | ").count();
    let align: Vec<&str> = (0..width)
        .map(|i| if i < text_columns { "---" } else { "--:" })
        .collect();
    let _ = writeln!(out, "| {head} |\n|{}|", align.join("|"));
    for mut row in rows {
        row.resize(width, String::new());
        let _ = writeln!(out, "| {} |", row.join(" | "));
    }
}

/// Microseconds with 4 significant digits at most.
pub fn us(x: f64) -> String {
    match x {
        x if x >= 1000.0 => format!("{x:.0}"),
        x if x >= 100.0 => format!("{x:.1}"),
        x => format!("{x:.2}"),
    }
}

pub fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 {
        format!("{:.2}×", a / b)
    } else {
        "–".into()
    }
}

pub fn load_name(load: bool) -> String {
    if load { "load" } else { "idle" }.into()
}

/// A row that failed: its name, then the error in the next cell.
pub fn failed(names: Vec<String>, error: &str) -> Vec<String> {
    let mut row = names;
    row.push(format!(
        "failed: {}",
        error.replace('|', "/").replace('\n', " ")
    ));
    row
}

/// `x (x ÷ y)`.
fn against(x: f64, y: f64) -> String {
    format!("{} ({})", us(x), ratio(x, y))
}

/// The busy-poll floor rows of `kind` at `load` are compared with: that load's median, or
/// the idle one (`true`) where busy-polling is no floor, i.e. its median is above the Unix
/// socket's (more polling processes than CPUs: they take turns at `sched_yield`). `None`
/// where neither is a floor.
pub fn floor_of(r: &Report, kind: Kind, load: bool, size: usize) -> Option<(f64, bool)> {
    floor_row(r, kind, load, size).map(|(floor, idle)| (floor.latency.p50, idle))
}

/// The busy-poll row that is the floor of `load` (see [`floor_of`]), and whether it is the
/// idle one standing in.
pub(crate) fn floor_row(
    r: &Report,
    kind: Kind,
    load: bool,
    size: usize,
) -> Option<(&Measurement, bool)> {
    let is_floor = |load: bool| {
        let floor = r.find(kind, Transport::IoxPoll, load, size, false)?;
        let uds = r
            .find(kind, Transport::Uds, load, size, false)
            .map_or(f64::INFINITY, |u| u.latency.p50);
        (floor.latency.p50 <= uds).then_some(floor)
    };
    match is_floor(load) {
        Some(f) => Some((f, false)),
        None if load => is_floor(false).map(|f| (f, true)),
        None => None,
    }
}

/// Round-by-round ratios: their median and how many are at or below `bound`, e.g.
/// "0.93× (3 of 4 ≤ 1)".
pub(crate) fn rounds_cell(ratios: &[f64], bound: f64) -> String {
    if ratios.is_empty() {
        return "n/a".into();
    }
    let within = ratios.iter().filter(|r| **r <= bound).count();
    format!(
        "{:.2}× ({within} of {} ≤ {bound})",
        median(ratios.to_vec()),
        ratios.len()
    )
}

/// The median ÷ the floor of the same load (or the idle floor, marked).
fn floor_cell(r: &Report, m: &Measurement) -> String {
    match floor_of(r, m.kind, m.load, m.size) {
        Some((f, false)) => ratio(m.latency.p50, f),
        Some((f, true)) => format!("{} (idle floor)", ratio(m.latency.p50, f)),
        None => "n/a".into(),
    }
}

/// Latency distribution of every transport of one kind, idle and under load, with the floor
/// and the Unix-socket row of the same load as baselines.
pub fn distribution_table(out: &mut String, r: &Report, kind: Kind, size: usize) {
    let head = "transport | load | n | p50 µs | p90 µs | p99 µs | p99.9 µs | max µs | p50 ÷ floor | p99 ÷ UDS | CPU µs/msg | run-queue µs/msg | machine busy";
    let rows = r.rows(kind).filter(|m| m.size == size).map(|m| {
        let names = vec![m.label(), load_name(m.load)];
        if let Some(e) = &m.error {
            return failed(names, e);
        }
        let uds = r
            .find_placed(kind, Transport::Uds, m.load, size, false, m.chain_cpu)
            .map_or(0.0, |u| u.latency.p99);
        let l = &m.latency;
        let numbers = [l.p50, l.p90, l.p99, l.p999, l.max].map(us);
        let mut row = names;
        row.push(l.n.to_string());
        row.extend(numbers);
        row.extend([
            floor_cell(r, m),
            ratio(l.p99, uds),
            us(m.cpu_us_per_msg),
            us(m.runqueue_us_per_msg),
            format!("{:.0} %", m.machine_busy * 100.0),
        ]);
        row
    });
    table(out, head, 2, rows);
    if let Some(note) = no_floor_note(r, kind, size) {
        let _ = writeln!(out, "\n*p50 ÷ floor* under load: {note}.");
    }
}

/// Why the busy-poll floor of `kind` under load stands aside, if it does.
fn no_floor_note(r: &Report, kind: Kind, size: usize) -> Option<String> {
    let (_, substituted) = floor_of(r, kind, true, size)?;
    let floor = r.find(kind, Transport::IoxPoll, true, size, false)?;
    let uds = r.find(kind, Transport::Uds, true, size, false)?;
    substituted.then(|| {
        format!(
            "busy-polling is no floor on {} CPUs under load (its median, {} µs, is above the Unix socket's, {} µs: the polling processes and the hog take turns at `sched_yield`), so load rows are compared with the idle floor",
            r.machine.cpus,
            us(floor.latency.p50),
            us(uds.latency.p50)
        )
    })
}

/// The checks the issue asks for: each bus chain's p99 against the Unix socket's, its median
/// against the busy-poll floor (within 3×), one bus hop against one socket hop, and the paced
/// runs' deadline misses.
pub fn checks_table(out: &mut String, r: &Report) {
    let rows = r
        .rows(Kind::Chain)
        .filter(|m| {
            matches!(m.transport, Transport::IoxEvent(_)) && !m.real_binaries && m.error.is_none()
        })
        .filter_map(|m| {
            // A placed chain against the Unix-socket chain placed the same way.
            let uds = r.find_placed(Kind::Chain, Transport::Uds, m.load, 0, false, m.chain_cpu)?;
            let (floor, within) = match floor_of(r, Kind::Chain, m.load, 0) {
                Some((f, idle)) => (
                    format!("{}{}", us(f), if idle { " (idle)" } else { "" }),
                    at_or_below(m.latency.p50, 3.0 * f),
                ),
                None => ("none".into(), "n/a"),
            };
            let p99_rounds = round_ratios(m, uds, |l| l.p99);
            let p50_rounds = floor_row(r, Kind::Chain, m.load, 0)
                .map(|(floor, _)| round_ratios(m, floor, |l| l.p50))
                .unwrap_or_default();
            Some(vec![
                m.label(),
                load_name(m.load),
                us(m.latency.p99),
                us(uds.latency.p99),
                at_or_below(m.latency.p99, uds.latency.p99).into(),
                rounds_cell(&p99_rounds, 1.0),
                us(m.latency.p50),
                floor,
                floor_cell(r, m),
                within.into(),
                rounds_cell(&p50_rounds, 3.0),
            ])
        });
    table(
        out,
        "chain | load | p99 µs | Unix socket p99 µs | p99 at or below the socket's | p99 ÷ socket's, round by round (median) | p50 µs | busy-poll floor p50 µs | p50 ÷ floor | within 3× of the floor | p50 ÷ floor, round by round (median)",
        2,
        rows,
    );
    hop_checks_table(out, r);
    let rows = r.paced.iter().map(|p| match &p.error {
        Some(e) => failed(vec![format!("`{}`", p.wait), load_name(p.load)], e),
        None => vec![
            format!("`{}`", p.wait),
            load_name(p.load),
            p.duration_s.to_string(),
            p.ticks.to_string(),
            format!("**{}**", p.deadline_misses),
            p.late_commands.to_string(),
        ],
    });
    if !r.paced.is_empty() {
        let _ = writeln!(
            out,
            "\nPaced 10 Hz runs (deadline misses: the controller's count, supervised from the first estimate on):\n"
        );
        table(
            out,
            "`TESTBED_BUS_WAIT` | load | duration s | ticks | deadline misses | late or missing wheel commands",
            2,
            rows,
        );
    }
}

/// The verdict of a check that `value` is at or below `bound`, bold.
fn at_or_below(value: f64, bound: f64) -> &'static str {
    if value <= bound { "**yes**" } else { "**no**" }
}

/// One hop of the bus (`block`) against one Unix-socket hop of the same size and load: p50 and
/// p99, pooled and round by round, as the chains are checked.
fn hop_checks_table(out: &mut String, r: &Report) {
    let rows: Vec<Vec<String>> = r
        .rows(Kind::Hop)
        .filter(|m| m.transport == Transport::BUS && !m.real_binaries && m.error.is_none())
        .filter_map(|m| {
            let uds = r.find(Kind::Hop, Transport::Uds, m.load, m.size, false)?;
            let (l, u) = (&m.latency, &uds.latency);
            Some(vec![
                format!("{} B", m.size),
                load_name(m.load),
                us(l.p50),
                us(u.p50),
                at_or_below(l.p50, u.p50).into(),
                rounds_cell(&round_ratios(m, uds, |l| l.p50), 1.0),
                us(l.p99),
                us(u.p99),
                at_or_below(l.p99, u.p99).into(),
                rounds_cell(&round_ratios(m, uds, |l| l.p99), 1.0),
            ])
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\nOne hop of the bus (`block`) against one Unix-socket hop, checked the same way:\n"
    );
    table(
        out,
        "hop | load | p50 µs | Unix socket p50 µs | p50 at or below the socket's | p50 ÷ socket's, round by round (median) | p99 µs | Unix socket p99 µs | p99 at or below the socket's | p99 ÷ socket's, round by round (median)",
        2,
        rows,
    );
}

/// Polling wait strategies (measured rows other than `block` on the bus, placed by the
/// scheduler), by key.
fn polling(r: &Report) -> impl Iterator<Item = &Measurement> {
    r.measurements.iter().filter(|m| {
        m.transport.polls() && m.kind != Kind::Sweep && m.chain_cpu.is_none() && m.error.is_none()
    })
}

/// Each polling wait strategy against `block`, same run, same load, same processes.
pub fn wait_strategy_table(out: &mut String, r: &Report) {
    let rows = polling(r).filter_map(|m| {
        let b = r.find(m.kind, Transport::BUS, m.load, m.size, m.real_binaries)?;
        let Transport::IoxEvent(wait) = m.transport else {
            return None;
        };
        Some(vec![
            format!(
                "{:?}{}",
                m.kind,
                if m.real_binaries {
                    " (real binaries)"
                } else {
                    ""
                }
            )
            .to_lowercase(),
            wait.to_string(),
            load_name(m.load),
            against(m.latency.p50, b.latency.p50),
            against(m.latency.p99, b.latency.p99),
            against(m.latency.p999, b.latency.p999),
            against(m.cpu_us_per_msg, b.cpu_us_per_msg),
        ])
    });
    table(
        out,
        "measurement | strategy | load | p50 µs (÷ block) | p99 µs (÷ block) | p99.9 µs (÷ block) | CPU µs/msg (÷ block)",
        3,
        rows,
    );
}

/// The rule for the pipeline's default, applied row by row: a polling strategy must beat
/// `block` on the chain's p99 in every chain row (idle and load; harness and real binaries)
/// at no more than [`CPU_LIMIT`] times its CPU per cycle.
pub fn rule_table(out: &mut String, r: &Report) {
    let rows = polling(r)
        .filter(|m| m.kind == Kind::Chain)
        .filter_map(|m| {
            let b = r.find(Kind::Chain, Transport::BUS, m.load, 0, m.real_binaries)?;
            let Transport::IoxEvent(wait) = m.transport else {
                return None;
            };
            let (p99, cpu) = (
                m.latency.p99 / b.latency.p99,
                m.cpu_us_per_msg / b.cpu_us_per_msg,
            );
            Some(vec![
                wait.to_string(),
                format!(
                    "{}{}",
                    load_name(m.load),
                    if m.real_binaries {
                        ", real binaries"
                    } else {
                        ""
                    }
                ),
                format!("{p99:.2}×"),
                format!("{cpu:.2}×"),
                if p99 < 1.0 && cpu <= CPU_LIMIT {
                    "passes"
                } else {
                    "**fails**"
                }
                .into(),
            ])
        });
    table(
        out,
        "strategy | chain row | p99 ÷ block | CPU ÷ block | this row",
        2,
        rows,
    );
}

/// The event hop and chain against the Unix socket's, and against the busy-poll floor: the
/// numbers the conclusions argue from.
pub fn event_vs_socket_table(out: &mut String, r: &Report) {
    let mut rows = Vec::new();
    let mut sizes: Vec<usize> = r.rows(Kind::Sweep).map(|m| m.size).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let configs = [(Kind::Chain, 0), (Kind::Hop, 48)]
        .into_iter()
        .chain(sizes.into_iter().map(|s| (Kind::Sweep, s)));
    for (kind, size) in configs {
        for load in [false, true] {
            let get = |t| r.find(kind, t, load, size, false);
            let (Some(e), Some(u)) = (get(Transport::BUS), get(Transport::Uds)) else {
                continue;
            };
            let floor = get(Transport::IoxPoll).map_or("–".into(), |f| us(f.latency.p50));
            rows.push(vec![
                format!("{kind:?}").to_lowercase(),
                if kind == Kind::Chain {
                    "–".into()
                } else {
                    size.to_string()
                },
                load_name(load),
                us(e.latency.p50),
                us(u.latency.p50),
                format!("{:+.1}", e.latency.p50 - u.latency.p50),
                floor,
                us(e.latency.p99),
                us(u.latency.p99),
                us(e.cpu_us_per_msg),
                us(u.cpu_us_per_msg),
                us(e.runqueue_us_per_msg),
                us(u.runqueue_us_per_msg),
            ]);
        }
    }
    let head = "measurement | bytes | load | event p50 µs | socket p50 µs | event − socket p50 µs | busy-poll p50 µs | event p99 µs | socket p99 µs | event CPU µs/msg | socket CPU µs/msg | event run-queue µs/msg | socket run-queue µs/msg";
    table(out, head, 3, rows);
}

/// Each stage of the chain (hops: publish → taken by the next process; compute: input taken
/// → output published), p50 / p99.
pub fn stage_table(out: &mut String, r: &Report) {
    let Some(names) = r.rows(Kind::Chain).find(|m| !m.stages.is_empty()).map(|m| {
        m.stages
            .iter()
            .map(|(n, _)| format!("{n} p50 / p99 µs"))
            .collect::<Vec<_>>()
    }) else {
        return;
    };
    let rows = r
        .rows(Kind::Chain)
        .filter(|m| m.error.is_none() && m.stages.len() == names.len())
        .map(|m| {
            let mut row = vec![m.label(), load_name(m.load)];
            row.extend(
                m.stages
                    .iter()
                    .map(|(_, p)| format!("{} / {}", us(p.p50), us(p.p99))),
            );
            row.push(us(m.stages.iter().map(|(_, p)| p.p50).sum()));
            row.push(us(m.latency.p50));
            row
        });
    let head = format!(
        "transport | load | {} | sum of p50s µs | end-to-end p50 µs",
        names.join(" | ")
    );
    table(out, &head, 2, rows);
}

/// The payload sweep: every size and transport, idle and under load.
pub fn sweep_table(out: &mut String, r: &Report) {
    let mut configs: Vec<(usize, Transport)> = Vec::new();
    for m in r.rows(Kind::Sweep) {
        if !configs.contains(&(m.size, m.transport)) {
            configs.push((m.size, m.transport));
        }
    }
    let rows = configs.into_iter().map(|(size, t)| {
        let idle = r.find(Kind::Sweep, t, false, size, false);
        let load = r.find(Kind::Sweep, t, true, size, false);
        let floor = r
            .find(Kind::Sweep, Transport::IoxPoll, false, size, false)
            .map_or(0.0, |f| f.latency.p50);
        let cell = |m: Option<&Measurement>, f: fn(&Percentiles) -> f64| {
            m.map_or("–".to_string(), |m| us(f(&m.latency)))
        };
        vec![
            size.to_string(),
            t.label(),
            cell(idle, |l| l.p50),
            cell(idle, |l| l.p99),
            cell(idle, |l| l.p999),
            cell(load, |l| l.p50),
            cell(load, |l| l.p99),
            cell(load, |l| l.p999),
            idle.map_or("–".into(), |m| ratio(m.latency.p50, floor)),
            idle.map_or("–".into(), |m| us(m.cpu_us_per_msg)),
        ]
    });
    let head = "size | transport | idle p50 µs | idle p99 µs | idle p99.9 µs | load p50 µs | load p99 µs | load p99.9 µs | idle p50 ÷ floor | CPU µs/msg (idle)";
    table(out, head, 2, rows);
}

/// How the bus processes' event loops woke.
pub fn wakeup_table(out: &mut String, r: &Report) {
    let mut rows = Vec::new();
    for m in r.measurements.iter().filter(|m| {
        matches!(m.transport, Transport::IoxEvent(_)) && m.kind != Kind::Sweep && m.error.is_none()
    }) {
        // Wake-up counts cover warm-up too: per message over all the process handled.
        let handled =
            (m.messages + m.incomplete) as f64 * if m.kind == Kind::Hop { 0.5 } else { 1.0 };
        for (process, w) in &m.wait {
            let per = if handled > 0.0 {
                format!("{:.2}", w.wakeups() as f64 / handled)
            } else {
                "–".into()
            };
            let counts = [w.woken, w.polled].map(|n| n.to_string());
            let mut row = vec![
                format!("{:?} {}", m.kind, m.label()).to_lowercase(),
                load_name(m.load),
                process.clone(),
            ];
            row.extend(counts);
            row.extend([
                per,
                w.empty_windows.to_string(),
                w.stale_notifications.to_string(),
            ]);
            rows.push(row);
        }
    }
    let head = "measurement | load | process | data wake-ups after a ring | by polling | per message | empty poll windows | stale notifications";
    table(out, head, 3, rows);
}
