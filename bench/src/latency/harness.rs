//! The command line and the run: plan every configuration, measure them in interleaved
//! rounds, then the paced runs, saving the report after every phase.

use crate::latency::measure::{Ctx, testbed_binary, warmup};
use crate::latency::model::{Kind, Measurement, Plan, Report};
use crate::latency::protocol::{Transport, WorkerSpec};
use crate::latency::recording::Recording;
use crate::latency::system::{self, Machine};
use crate::latency::{figure, report, worker};
use anyhow::{Context, Result, bail};
use clap::Parser;
use ipc_types::WaitStrategy;
use std::path::{Path, PathBuf};
use std::time::Instant;
use testbed_bus::WaitFromEnv;

#[derive(Parser, Debug, Clone)]
#[command(about = "Latency of the pipeline against sockets and busy-polling, idle and under load")]
struct Args {
    /// Report directory (report.md, latency.svg, report.json).
    #[arg(long, default_value = "bench/report")]
    out: PathBuf,
    /// CI smoke check: few samples, a 3 s paced run (checks that the harness runs, not speed).
    #[arg(long)]
    quick: bool,
    /// Measured hops per hop configuration (ping-pong: half each way).
    #[arg(long)]
    hops: Option<usize>,
    /// Measured hops per payload-sweep configuration.
    #[arg(long)]
    sweep_hops: Option<usize>,
    /// Measured chain cycles per configuration.
    #[arg(long)]
    cycles: Option<usize>,
    /// Pause before each ping-pong exchange of the hop benchmark, µs (lets both sides sleep).
    #[arg(long, default_value_t = 100)]
    gap_us: u64,
    /// Period of the chain's gyro samples, µs of wall time.
    #[arg(long, default_value_t = 500)]
    period_us: u64,
    /// Payload sizes of the sweep, bytes, of 64, 1024, 8192, 65536 [default: all; --quick:
    /// 64,65536].
    #[arg(long, value_delimiter = ',')]
    sizes: Option<Vec<usize>>,
    /// Wait strategies of the bus rows, `;`-separated (`TESTBED_BUS_WAIT` syntax) [default:
    /// block;anticipate;spin:50; --quick: block;anticipate].
    #[arg(long, value_delimiter = ';')]
    waits: Option<Vec<WaitStrategy>>,
    /// Simulated (= wall) seconds of each paced run [default: 30; --quick: 3].
    #[arg(long)]
    paced_duration: Option<f64>,
    /// Wait strategies of the paced runs (all under load), `;`-separated, each a
    /// `TESTBED_BUS_WAIT` value for the whole pipeline; `+fifo` at the end also gives sim-gyro,
    /// estimator and controller SCHED_FIFO priority 10 (needs the privilege), set on their pids
    /// once they run; `+placed` instead places them through the launch profile (`cpus`,
    /// `scheduling`): plant, sim-gyro, estimator and controller on CPU 0 at SCHED_FIFO 10, the
    /// other processes on the hog's CPU.
    #[arg(
        long,
        value_delimiter = ';',
        default_value = "block;block+fifo;anticipate@sim-gyro,estimator,controller"
    )]
    paced_waits: Vec<String>,
    /// Hold a PM QoS CPU latency request of this many µs for the whole measurement
    /// (`/dev/cpu_dma_latency`, needs root): 0 keeps idle CPUs polling instead of halting, as
    /// a launch profile's `[platform] cpu_latency_us = 0` does for a run [default: none].
    #[arg(long, value_name = "US")]
    cpu_latency_us: Option<u32>,
    /// Also measure the chain with its four processes placed on one CPU, once per CPU listed
    /// (`,`-separated): the bus's wait strategies that sleep and the socket chains, next to the
    /// same chains placed by the scheduler. Under load the hog runs on the last CPU. The
    /// busy-poll floor is never placed (four pollers on one CPU would take turns).
    #[arg(long, value_delimiter = ',', value_name = "CPU")]
    chain_cpus: Vec<usize>,
    /// Parts to leave out: hop, chain, sweep, paced, binaries.
    #[arg(long, value_delimiter = ',')]
    skip: Vec<String>,
    /// Measure nothing: write report.md and latency.svg to --out from this report.json.
    #[arg(long)]
    render: Option<PathBuf>,
}

/// `latency`, or `latency worker <spec>` for one of its processes.
/// Tries of one round of a configuration before it counts as failed.
const ROUND_TRIES: usize = 3;

pub fn main() -> Result<()> {
    let argv: Vec<String> = std::env::args().collect();
    if argv.get(1).map(String::as_str) == Some("worker") {
        let spec: WorkerSpec = serde_json::from_str(argv.get(2).context("worker spec")?)?;
        return worker::run(&spec)
            .with_context(|| format!("worker {:?} over {}", spec.role, spec.transport));
    }
    let args = Args::parse();
    if let Some(json) = &args.render {
        let report: Report = serde_json::from_str(
            &std::fs::read_to_string(json)
                .with_context(|| format!("reading {}", json.display()))?,
        )?;
        save(&args.out, &report)?;
        println!("{}", report::headline(&report));
        return Ok(());
    }
    run(&args, argv.join(" "))
}

/// Writes report.json, latency.svg and report.md.
fn save(out: &Path, report: &Report) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(report)?,
    )?;
    figure::write(&out.join("latency.svg"), report)?;
    std::fs::write(out.join("report.md"), report::markdown(report))?;
    Ok(())
}

fn run(args: &Args, command: String) -> Result<()> {
    let started = Instant::now();
    let quick = args.quick;
    let hops = args.hops.unwrap_or(if quick { 2_000 } else { 100_000 });
    let sweep_hops = args
        .sweep_hops
        .unwrap_or(if quick { 1_000 } else { 20_000 });
    let cycles = args.cycles.unwrap_or(if quick { 400 } else { 20_000 });
    let paced_duration = args
        .paced_duration
        .unwrap_or(if quick { 3.0 } else { 30.0 });
    let skip = |part: &str| args.skip.iter().any(|s| s == part);
    let sizes = args.sizes.clone().unwrap_or_else(|| {
        if quick {
            vec![64, 65_536]
        } else {
            vec![64, 1024, 8192, 65_536]
        }
    });
    let waits = args.waits.clone().unwrap_or_else(|| {
        let spin = WaitStrategy::SpinAfterWake {
            spin: std::time::Duration::from_micros(50),
        };
        if quick {
            vec![WaitStrategy::Block, WaitStrategy::ANTICIPATE]
        } else {
            vec![WaitStrategy::Block, WaitStrategy::ANTICIPATE, spin]
        }
    });
    for w in &args.paced_waits {
        let strategy = w
            .trim_end_matches("+fifo")
            .trim_end_matches("+placed")
            .to_string();
        WaitStrategy::from_lookup(|_| Some(strategy.clone()))
            .with_context(|| format!("--paced-waits: {w}"))?;
    }
    // Held until this function returns: every row of the run measures under the same request.
    let _cpu_latency = args
        .cpu_latency_us
        .map(testbed_launch::placement::CpuLatencyRequest::hold)
        .transpose()
        .context("--cpu-latency-us")?;
    let rounds = if quick { 2 } else { 4 };
    let hog_cpu = system::cpu_count() - 1;
    if let Some(cpu) = args.chain_cpus.iter().find(|&&c| c > hog_cpu) {
        bail!("--chain-cpus: CPU {cpu} does not exist (this machine has CPUs 0 to {hog_cpu})");
    }
    let scratch = PathBuf::from(format!("/tmp/latency-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let mut report = Report {
        machine: Machine::describe(),
        command,
        quick,
        settings: serde_json::json!({
            "hops": hops, "sweep_hops": sweep_hops, "cycles": cycles, "rounds": rounds,
            "warmup_hops": warmup(hops / rounds), "warmup_cycles": warmup(cycles / rounds),
            "gap_us": args.gap_us, "period_us": args.period_us, "sizes": sizes,
            "waits": waits.iter().map(ToString::to_string).collect::<Vec<_>>(),
            "paced_duration_s": paced_duration, "paced_waits": args.paced_waits, "hog_cpu": hog_cpu,
            "cpu_latency_us": args.cpu_latency_us, "chain_cpus": args.chain_cpus,
        }),
        ..Report::default()
    };
    let mut ctx = Ctx {
        n: 0,
        hog_cpu,
        recording: scratch.join("recording.bin"),
        scratch,
    };
    let bus: Vec<Transport> = waits.iter().map(|&w| Transport::IoxEvent(w)).collect();
    let all: Vec<Transport> = bus
        .iter()
        .copied()
        .chain([Transport::IoxPoll, Transport::Uds, Transport::Udp])
        .collect();

    // Every configuration runs in `rounds` interleaved rounds (transports and loads taking
    // turns), so that slow changes in the shared machine's background load hit all alike.
    let mut plan: Vec<Plan> = Vec::new();
    let mut add = |kind,
                   transports: &[Transport],
                   size,
                   count,
                   interval_us,
                   binaries,
                   chain_cpu: Option<usize>| {
        for &transport in transports {
            for load in [false, true] {
                plan.push(Plan {
                    kind,
                    transport,
                    size,
                    count,
                    interval_us,
                    load,
                    binaries,
                    chain_cpu,
                });
            }
        }
    };
    if !skip("hop") {
        add(Kind::Hop, &all, 48, hops, args.gap_us, false, None);
    }
    if !skip("chain") {
        let total = warmup(cycles / rounds) + cycles / rounds + 8;
        eprintln!("recording a {total}-tick closed-loop run for the gateways to replay ...");
        Recording::record(&ctx.recording, total)?;
        add(Kind::Chain, &all, 0, cycles, args.period_us, false, None);
        if !skip("binaries") && testbed_binary().is_some() {
            // Every bus wait strategy: the decision on the pipeline's default weighs these rows.
            add(Kind::Chain, &bus, 0, cycles, args.period_us, true, None);
        }
        let sleepers: Vec<Transport> = all
            .iter()
            .copied()
            .filter(|t| *t != Transport::IoxPoll && !t.polls())
            .collect();
        for &cpu in &args.chain_cpus {
            add(
                Kind::Chain,
                &sleepers,
                0,
                cycles,
                args.period_us,
                false,
                Some(cpu),
            );
        }
    }
    if !skip("sweep") {
        for &size in &sizes {
            add(
                Kind::Sweep,
                &[
                    Transport::BUS,
                    Transport::IoxPoll,
                    Transport::Uds,
                    Transport::Udp,
                ],
                size,
                sweep_hops,
                0,
                false,
                None,
            );
        }
    }
    let mut parts: Vec<Vec<Result<_, String>>> = vec![Vec::new(); plan.len()];
    for round in 0..rounds {
        eprintln!(
            "round {} of {rounds} ({} configurations) ...",
            round + 1,
            plan.len()
        );
        for (p, parts) in plan.iter().zip(parts.iter_mut()) {
            // A round that fails (a worker slow to start on a loaded machine, say) is tried
            // again on fresh processes, ports and sockets, up to ROUND_TRIES in all; only a
            // configuration that fails every time is reported as failed.
            let mut part = ctx.round(p, (p.count / rounds).max(1));
            for attempt in 2..=ROUND_TRIES {
                let Err(e) = &part else { break };
                eprintln!(
                    "  {:?} {} {}: {e} (trying again, {attempt} of {ROUND_TRIES})",
                    p.kind,
                    p.transport.label(),
                    if p.load { "load" } else { "idle" }
                );
                part = ctx.round(p, (p.count / rounds).max(1));
            }
            if let Err(e) = &part {
                eprintln!(
                    "  {:?} {} {}: {e}",
                    p.kind,
                    p.transport.label(),
                    if p.load { "load" } else { "idle" }
                );
            }
            parts.push(part);
        }
    }
    for (p, parts) in plan.iter().zip(parts) {
        let m = p.merge(parts);
        progress(&m);
        report.measurements.push(m);
    }
    // Saved after every phase: an interrupted run keeps what it measured.
    report.wall_s = started.elapsed().as_secs_f64();
    save(&args.out, &report)?;
    if !skip("paced") {
        for wait in &args.paced_waits {
            eprintln!(
                "paced run: {paced_duration} s at 10 Hz under load, TESTBED_BUS_WAIT={wait} ..."
            );
            let run = ctx.paced(paced_duration, wait);
            let error = run
                .error
                .as_deref()
                .map(|e| format!(" (error: {e})"))
                .unwrap_or_default();
            eprintln!(
                "  → {} ticks, {} deadline misses, {} late commands, period error p99 {:.0} µs{error}",
                run.ticks, run.deadline_misses, run.late_commands, run.period_error.p99
            );
            report.paced.push(run);
            report.wall_s = started.elapsed().as_secs_f64();
            save(&args.out, &report)?;
        }
    }
    report.machine.loadavg_end = system::loadavg();
    report.wall_s = started.elapsed().as_secs_f64();
    report.complete = true;
    let _ = std::fs::remove_dir_all(&ctx.scratch);
    save(&args.out, &report)?;
    println!("{}", report::headline(&report));
    println!("report: {}", args.out.join("report.md").display());
    let failed: Vec<String> = report
        .measurements
        .iter()
        .filter_map(|m| {
            m.error
                .as_ref()
                .map(|e| format!("{:?} {} load={}: {e}", m.kind, m.label(), m.load))
        })
        .chain(
            report
                .paced
                .iter()
                .filter_map(|p| p.error.as_ref().map(|e| format!("paced {}: {e}", p.wait))),
        )
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} measurement(s) failed:\n{}",
            failed.len(),
            failed.join("\n")
        );
    }
    Ok(())
}

fn progress(m: &Measurement) {
    let load = if m.load { "load" } else { "idle" };
    match &m.error {
        None => eprintln!(
            "{:<6} {:>6} B {:<34} {load:<5} n={:<7} p50 {:>8.1} µs  p99 {:>8.1} µs  p99.9 {:>8.1} µs  max {:>9.1} µs  CPU {:>6.1} µs/msg",
            format!("{:?}", m.kind).to_lowercase(),
            m.size,
            format!(
                "{}{}",
                m.transport.label(),
                if m.real_binaries { " [binaries]" } else { "" }
            ),
            m.latency.n,
            m.latency.p50,
            m.latency.p99,
            m.latency.p999,
            m.latency.max,
            m.cpu_us_per_msg
        ),
        Some(e) => eprintln!("{:?} {} {load}: FAILED: {e}", m.kind, m.label()),
    }
}
