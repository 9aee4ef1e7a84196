//! Latency of the pipeline's process chain against the alternatives, on the same machine, in
//! the same run: one hop and the gyro → estimator → controller → wheel-command chain over the
//! bus (iceoryx2 + event service, with each `WaitStrategy`), over Unix datagram sockets and UDP
//! on loopback (blocking reads), and over iceoryx2 with busy-polling (the floor); idle and with
//! a CPU hog on the last core; across payload sizes from 64 B to 64 KiB; and the 10 Hz loop's
//! period jitter and deadline misses in a paced `testbed run`.
//!
//! ```sh
//! cargo build --release --workspace --bins      # the paced run needs `testbed` and the pipeline
//! cargo run --release -p testbed-bench --bin latency -- --out bench/report
//! cargo run --release -p testbed-bench --bin latency -- --quick --out /tmp/latency-smoke
//! ```
//!
//! Writes `report.md` (tables), `latency.svg` (figure) and `report.json` (every number) to
//! `--out`. Never use these numbers without their baselines: the machine is shared.

mod chain;
mod figure;
mod payload;
mod report;
mod runner;
mod stats;
mod system;
mod transport;
mod worker;

use anyhow::{Context, Result, bail};
use clap::Parser;
use serde::{Deserialize, Serialize};
use stats::Percentiles;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use system::{CpuTime, Hog, Machine, MachineCpu};
use transport::{Addr, Transport};
use worker::{Role, WaitStatsJson, WorkerSpec};

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
    waits: Option<Vec<String>>,
    /// Simulated (= wall) seconds of each paced run [default: 30; --quick: 3].
    #[arg(long)]
    paced_duration: Option<f64>,
    /// Wait strategies of the paced runs (all under load), `;`-separated, each a
    /// `TESTBED_BUS_WAIT` value for the whole pipeline; `+fifo` at the end also gives sim-gyro,
    /// estimator and controller SCHED_FIFO priority 10 (needs the privilege).
    #[arg(long, value_delimiter = ';', default_value = "block;block+fifo;anticipate@sim-gyro,estimator,controller")]
    paced_waits: Vec<String>,
    /// Parts to leave out: hop, chain, sweep, paced, binaries.
    #[arg(long, value_delimiter = ',')]
    skip: Vec<String>,
    /// Measure nothing: write report.md and latency.svg to --out from this report.json.
    #[arg(long)]
    render: Option<PathBuf>,
}

/// One measured configuration.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Measurement {
    /// `hop`, `chain` or `sweep`.
    pub kind: String,
    pub transport: String,
    pub label: String,
    pub load: bool,
    /// Sample size, bytes (hop and sweep).
    pub size: usize,
    /// The chain ran the real `estimator` and `controller` binaries.
    pub real_binaries: bool,
    pub latency: Percentiles,
    /// Messages measured (hops or cycles).
    pub messages: usize,
    /// Samples that never arrived or whose time stamps were unusable.
    pub incomplete: usize,
    /// CPU time of all the measurement's processes per message, µs.
    pub cpu_us_per_msg: f64,
    /// Time those processes were runnable but waited for a CPU, per message, µs.
    pub runqueue_us_per_msg: f64,
    pub wall_s: f64,
    /// Share of the machine's CPU time that was busy during the measurement (anyone's).
    pub machine_busy: f64,
    /// How the event loops' data wake-ups came about: (process, stats).
    pub wait: Vec<(String, WaitStatsJson)>,
    /// Chain: where the time goes, stage by stage (hops and compute).
    pub stages: Vec<(String, Percentiles)>,
    pub error: Option<String>,
}

/// One paced `testbed run`.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PacedRun {
    pub wait: String,
    pub load: bool,
    pub duration_s: f64,
    /// Ticks whose wheel command the observer saw.
    pub ticks: usize,
    /// Deadline misses the controller counted (ControllerStatus.deadline_misses, supervised
    /// from the first estimate on): the run summary's, or the observer's last status if that
    /// says more.
    pub deadline_misses: u64,
    /// Ticks whose wheel command arrived after the next tick's truth (the plant held the old
    /// command), or never.
    pub late_commands: u64,
    /// |period − 100 ms| of consecutive wheel-command arrivals, µs.
    pub period_error: Percentiles,
    pub period_min_ms: f64,
    pub period_max_ms: f64,
    /// |period − 100 ms| of the plant's truth samples (the clock that drives the loop), µs.
    pub clock_error: Percentiles,
    /// Truth published → wheel command seen (through gyro gateway, estimator, controller), µs.
    pub truth_to_command: Percentiles,
    /// CPU of the whole pipeline (launcher, logger, plant, gateways, estimator, controller)
    /// in % of one core.
    pub pipeline_cpu_percent: f64,
    /// Stages of truth → command: (name, distribution in µs).
    pub stages: Vec<(String, Percentiles)>,
    /// CPU and run-queue time of each process of the run, per tick.
    pub processes: Vec<ProcessCost>,
    pub summary: serde_json::Value,
    pub error: Option<String>,
}

/// What one process of a paced run cost.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ProcessCost {
    pub name: String,
    pub cpu_us_per_tick: f64,
    /// Time runnable but waiting for a CPU.
    pub runqueue_us_per_tick: f64,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Report {
    pub machine: Machine,
    pub command: String,
    pub quick: bool,
    pub settings: serde_json::Value,
    pub measurements: Vec<Measurement>,
    pub paced: Vec<PacedRun>,
    pub wall_s: f64,
    /// The run measured everything it planned (false in the reports saved along the way, so
    /// an interrupted run's report says so).
    #[serde(default)]
    pub complete: bool,
}

fn main() -> Result<()> {
    let argv: Vec<String> = std::env::args().collect();
    if argv.get(1).map(String::as_str) == Some("worker") {
        let spec: WorkerSpec = serde_json::from_str(argv.get(2).context("worker spec")?)?;
        return worker::run(&spec).with_context(|| format!("worker {:?} over {:?}", spec.role, spec.transport));
    }
    let args = Args::parse();
    if let Some(json) = &args.render {
        let report: Report = serde_json::from_str(&std::fs::read_to_string(json).with_context(|| format!("reading {}", json.display()))?)?;
        std::fs::create_dir_all(&args.out)?;
        figure::write(&args.out.join("latency.svg"), &report)?;
        std::fs::write(args.out.join("report.md"), report::markdown(&report))?;
        println!("{}", report::headline(&report));
        return Ok(());
    }
    let started = Instant::now();
    let quick = args.quick;
    let hops = args.hops.unwrap_or(if quick { 2_000 } else { 100_000 });
    let sweep_hops = args.sweep_hops.unwrap_or(if quick { 1_000 } else { 20_000 });
    let cycles = args.cycles.unwrap_or(if quick { 400 } else { 20_000 });
    let paced_duration = args.paced_duration.unwrap_or(if quick { 3.0 } else { 30.0 });
    let skip = |part: &str| args.skip.iter().any(|s| s == part);
    let sizes = args.sizes.clone().unwrap_or_else(|| if quick { vec![64, 65_536] } else { vec![64, 1024, 8192, 65_536] });
    let waits: Vec<String> = args.waits.clone().unwrap_or_else(|| {
        let w: &[&str] = if quick { &["block", "anticipate"] } else { &["block", "anticipate", "spin:50"] };
        w.iter().map(|s| s.to_string()).collect()
    });
    for w in &waits {
        w.parse::<testbed_bus::WaitStrategy>().with_context(|| format!("--waits: {w}"))?;
    }
    for w in &args.paced_waits {
        let strategy = w.trim_end_matches("+fifo").to_string();
        testbed_bus::WaitStrategy::from_lookup(|_| Some(strategy.clone())).with_context(|| format!("--paced-waits: {w}"))?;
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let hog_cpu = system::cpu_count() - 1;

    let rounds = if quick { 2 } else { 4 };
    let mut report = Report {
        machine: Machine::describe(),
        command: std::env::args().collect::<Vec<_>>().join(" "),
        quick,
        settings: serde_json::json!({
            "hops": hops, "sweep_hops": sweep_hops, "cycles": cycles,
            "rounds": rounds,
            "warmup_hops": warmup(hops / rounds), "warmup_cycles": warmup(cycles / rounds),
            "gap_us": args.gap_us, "period_us": args.period_us, "sizes": sizes,
            "waits": waits, "paced_duration_s": paced_duration, "paced_waits": args.paced_waits,
            "hog_cpu": hog_cpu,
        }),
        ..Report::default()
    };
    let mut ctx = Ctx { n: 0, hog_cpu, scratch: scratch_dir()? };
    let bus_transports: Vec<Transport> = waits.iter().map(|w| Transport::IoxEvent(w.clone())).collect();
    let transports: Vec<Transport> = bus_transports.iter().cloned().chain([Transport::IoxPoll, Transport::Uds, Transport::Udp]).collect();

    // Every configuration runs in `rounds` interleaved rounds (transports and loads taking
    // turns), so that slow changes in the shared machine's background load hit all alike.
    let mut plan: Vec<Plan> = Vec::new();
    if !skip("hop") {
        for t in &transports {
            for load in [false, true] {
                plan.push(Plan { kind: "hop", transport: t.clone(), size: 48, count: hops, gap_us: args.gap_us, load, binaries: false });
            }
        }
    }
    let recording = ctx.scratch.join("recording.bin");
    if !skip("chain") {
        let total = warmup(cycles / rounds) + cycles / rounds + 8;
        eprintln!("recording a {total}-tick closed-loop run for the gateways to replay ...");
        chain::Recording::record(&recording, total)?;
        for t in &transports {
            for load in [false, true] {
                plan.push(Plan { kind: "chain", transport: t.clone(), size: 0, count: cycles, gap_us: args.period_us, load, binaries: false });
            }
        }
        if !skip("binaries") && pipeline_binary("estimator").is_some() {
            // Every bus wait strategy: the decision on the pipeline's default weighs these rows.
            for t in &bus_transports {
                for load in [false, true] {
                    plan.push(Plan { kind: "chain", transport: t.clone(), size: 0, count: cycles, gap_us: args.period_us, load, binaries: true });
                }
            }
        }
    }
    if !skip("sweep") {
        let sweep_transports = [Transport::IoxEvent("block".into()), Transport::IoxPoll, Transport::Uds, Transport::Udp];
        for &size in &sizes {
            for t in &sweep_transports {
                for load in [false, true] {
                    plan.push(Plan { kind: "sweep", transport: t.clone(), size, count: sweep_hops, gap_us: 0, load, binaries: false });
                }
            }
        }
    }
    let mut parts: Vec<Vec<Part>> = vec![Vec::new(); plan.len()];
    for round in 0..rounds {
        eprintln!("round {} of {rounds} ({} configurations) ...", round + 1, plan.len());
        for (p, parts) in plan.iter().zip(parts.iter_mut()) {
            let count = (p.count / rounds).max(1);
            let part = match p.kind {
                "chain" => ctx.chain(&p.transport, count, p.gap_us, p.load, p.binaries, &recording),
                _ => ctx.hop(&p.transport, p.size, count, p.gap_us, p.load),
            };
            if let Err(e) = &part.result {
                eprintln!("  {} {} {}: {e:#}", p.kind, p.transport.label(), if p.load { "load" } else { "idle" });
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
    let save = |report: &Report| -> Result<()> {
        std::fs::write(args.out.join("report.json"), serde_json::to_string_pretty(report)?)?;
        figure::write(&args.out.join("latency.svg"), report)?;
        std::fs::write(args.out.join("report.md"), report::markdown(report))?;
        Ok(())
    };
    report.wall_s = started.elapsed().as_secs_f64();
    save(&report)?;
    if !skip("paced") {
        for wait in &args.paced_waits {
            eprintln!("paced run: {paced_duration} s at 10 Hz under load, TESTBED_BUS_WAIT={wait} ...");
            let run = ctx.paced(paced_duration, wait, true);
            eprintln!(
                "  → {} ticks, {} deadline misses, {} late commands, period error p99 {:.0} µs{}",
                run.ticks,
                run.deadline_misses,
                run.late_commands,
                run.period_error.p99,
                run.error.as_deref().map(|e| format!(" (error: {e})")).unwrap_or_default()
            );
            report.paced.push(run);
            report.wall_s = started.elapsed().as_secs_f64();
            save(&report)?;
        }
    }
    report.machine.loadavg_end = system::loadavg();
    report.wall_s = started.elapsed().as_secs_f64();
    report.complete = true;
    let _ = std::fs::remove_dir_all(&ctx.scratch);

    save(&report)?;
    println!("{}", report::headline(&report));
    println!("report: {}", args.out.join("report.md").display());
    let failed: Vec<String> = report
        .measurements
        .iter()
        .filter_map(|m| m.error.as_ref().map(|e| format!("{} {} load={}: {e}", m.kind, m.label, m.load)))
        .chain(report.paced.iter().filter_map(|p| p.error.as_ref().map(|e| format!("paced {}: {e}", p.wait))))
        .collect();
    if !failed.is_empty() {
        bail!("{} measurement(s) failed:\n{}", failed.len(), failed.join("\n"));
    }
    Ok(())
}

fn progress(m: &Measurement) {
    match &m.error {
        None => eprintln!(
            "{:<6} {:>6} B {:<34} {:<5} n={:<7} p50 {:>8.1} µs  p99 {:>8.1} µs  p99.9 {:>8.1} µs  max {:>9.1} µs  CPU {:>6.1} µs/msg",
            m.kind,
            m.size,
            format!("{}{}", m.label, if m.real_binaries { " [binaries]" } else { "" }),
            if m.load { "load" } else { "idle" },
            m.latency.n,
            m.latency.p50,
            m.latency.p99,
            m.latency.p999,
            m.latency.max,
            m.cpu_us_per_msg
        ),
        Some(e) => eprintln!("{:<6} {} {}: FAILED: {e}", m.kind, m.label, if m.load { "load" } else { "idle" }),
    }
}

/// The processes a `+fifo` paced run gives SCHED_FIFO priority: the gyro's path to the
/// wheel command.
const FIFO_CHAIN: [&str; 3] = ["sim-gyro", "estimator", "controller"];

/// Warm-up samples before the measured ones.
fn warmup(n: usize) -> usize {
    (n / 20).clamp(50, 2_000)
}

fn scratch_dir() -> Result<PathBuf> {
    let dir = PathBuf::from(format!("/tmp/latency-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// A pipeline binary next to this one (target/<profile>/).
fn pipeline_binary(name: &str) -> Option<PathBuf> {
    let path = std::env::current_exe().ok()?.parent()?.join(name);
    path.exists().then_some(path)
}

/// A free UDP port on loopback.
fn free_udp_port() -> Result<std::net::SocketAddr> {
    Ok(std::net::UdpSocket::bind("127.0.0.1:0")?.local_addr()?)
}

struct Ctx {
    n: usize,
    hog_cpu: usize,
    scratch: PathBuf,
}

/// Per-measurement resources: a bus of its own and socket addresses.
struct Setup {
    prefix: String,
    root: String,
    sock_dir: PathBuf,
}

impl Setup {
    fn bus(&self) -> testbed_bus::BusConfig {
        testbed_bus::BusConfig::new(self.prefix.clone(), self.root.clone())
    }
}

impl Drop for Setup {
    fn drop(&mut self) {
        let _ = testbed_bus::remove_all(&self.bus());
        let _ = std::fs::remove_dir_all(&self.sock_dir);
    }
}

impl Ctx {
    fn setup(&mut self) -> Result<Setup> {
        self.n += 1;
        let pid = std::process::id();
        let sock_dir = self.scratch.join(format!("s{}", self.n));
        std::fs::create_dir_all(&sock_dir)?;
        Ok(Setup { prefix: format!("lt{pid}x{}_", self.n), root: format!("/tmp/lt-{pid}-{}/", self.n), sock_dir })
    }

    fn addrs(&self, t: &Transport, setup: &Setup, names: &[&str]) -> Result<Vec<Addr>> {
        names
            .iter()
            .map(|n| {
                Ok(match t {
                    Transport::Udp => Addr::Udp(free_udp_port()?),
                    _ => Addr::Uds(setup.sock_dir.join(format!("{n}.sock"))),
                })
            })
            .collect()
    }

    fn spec(&self, setup: &Setup, t: &Transport, role: Role) -> WorkerSpec {
        WorkerSpec {
            role,
            transport: t.clone(),
            bus_prefix: setup.prefix.clone(),
            bus_root: setup.root.clone(),
            addrs: Vec::new(),
            size: 0,
            warmup: 0,
            count: 0,
            gap_us: 0,
            period_us: 0,
            recording: None,
        }
    }

    /// Ping-pong over `t`: `hops` measured hops, half each way.
    fn hop(&mut self, t: &Transport, size: usize, hops: usize, gap_us: u64, load: bool) -> Part {
        let mut part = Part::default();
        part.result = self.hop_inner(&mut part, t, size, hops, gap_us, load).map_err(|e| format!("{e:#}"));
        part
    }

    fn hop_inner(&mut self, m: &mut Part, t: &Transport, size: usize, hops: usize, gap_us: u64, load: bool) -> Result<()> {
        let setup = self.setup()?;
        let exchanges = hops.div_ceil(2);
        let mut spec = self.spec(&setup, t, Role::Pong);
        spec.addrs = self.addrs(t, &setup, &["ping", "pong"])?;
        spec.size = size;
        spec.warmup = warmup(exchanges);
        spec.count = exchanges;
        spec.gap_us = gap_us;
        let _hog = load.then(|| Hog::start(self.hog_cpu));
        let mut group = runner::Group::new();
        let pong = group.worker("pong", &spec)?;
        let ping = group.worker("ping", &WorkerSpec { role: Role::Ping, ..spec.clone() })?;
        let startup = Duration::from_secs(20);
        group.expect(pong, "ready", startup)?;
        group.expect(ping, "ready", startup)?;
        group.send(ping, "go")?;
        group.expect(ping, "measuring", startup)?;
        let (cpu0, busy0, t0) = (group.cpu(), MachineCpu::now(), Instant::now());
        let budget = Duration::from_secs(60) + Duration::from_micros((gap_us + 2_000) * exchanges as u64);
        group.expect(ping, "done", budget)?;
        let (cpu1, busy1, wall) = (group.cpu(), MachineCpu::now(), t0.elapsed());
        let ping_result = group.result(ping, startup)?;
        let pong_result = group.result(pong, startup)?;
        group.finish(Duration::from_secs(10))?;
        let (mut there, a) = stats::differences(&ping_result.sent, &pong_result.received);
        let (back, b) = stats::differences(&pong_result.sent, &ping_result.received);
        there.extend(back);
        m.incomplete = a + b;
        m.latencies = there;
        m.cpu = cpu1.since(cpu0);
        m.busy = busy1.busy_since(busy0);
        m.wall = wall;
        m.wait = [("ping", ping_result.wait), ("pong", pong_result.wait)]
            .into_iter()
            .filter_map(|(n, w)| w.map(|w| (n.to_string(), w)))
            .collect();
        Ok(())
    }

    /// The chain over `t` (with the real estimator and controller binaries if `binaries`).
    fn chain(&mut self, t: &Transport, cycles: usize, period_us: u64, load: bool, binaries: bool, recording: &Path) -> Part {
        let mut part = Part::default();
        part.result = self.chain_inner(&mut part, t, cycles, period_us, load, binaries, recording).map_err(|e| format!("{e:#}"));
        part
    }

    #[allow(clippy::too_many_arguments)]
    fn chain_inner(&mut self, m: &mut Part, t: &Transport, cycles: usize, period_us: u64, load: bool, binaries: bool, recording: &Path) -> Result<()> {
        let setup = self.setup()?;
        let mut spec = self.spec(&setup, t, Role::Estimator);
        spec.addrs = self.addrs(t, &setup, &["estimator", "controller", "wheels"])?;
        spec.warmup = warmup(cycles);
        spec.count = cycles;
        spec.period_us = period_us;
        spec.recording = Some(recording.to_path_buf());
        let _hog = load.then(|| Hog::start(self.hog_cpu));
        let mut group = runner::Group::new();
        let startup = Duration::from_secs(20);
        let mut mirrors = Vec::new();
        let mut programs = Vec::new();
        if binaries {
            let Transport::IoxEvent(wait) = t else { bail!("the binaries use the bus") };
            let config_path = setup.sock_dir.join("run.toml");
            let mut config = chain::run_config();
            config.run.mode = testbed_runtime::ClockMode::Paced;
            std::fs::write(&config_path, config.to_toml_string())?;
            for name in ["estimator", "controller"] {
                let mut command = Command::new(pipeline_binary(name).context("pipeline binary")?);
                command
                    .env(testbed_bus::ENV_PREFIX, &setup.prefix)
                    .env(testbed_bus::ENV_ROOT, &setup.root)
                    .env(testbed_bus::ENV_DELIVERY, "overflow")
                    .env(testbed_bus::ENV_WAIT, wait)
                    .env(testbed_runtime::ENV_RUN_CONFIG, &config_path)
                    .env("RUST_LOG", "warn");
                programs.push(group.program(name, command)?);
            }
        } else {
            for role in [Role::Estimator, Role::Controller] {
                mirrors.push((format!("{role:?}").to_lowercase(), group.worker(&format!("{role:?}"), &WorkerSpec { role, ..spec.clone() })?));
            }
        }
        let wheels = group.worker("wheel-gateway", &WorkerSpec { role: Role::Wheels, ..spec.clone() })?;
        let gyro = group.worker("gyro-gateway", &WorkerSpec { role: Role::Gyro, ..spec.clone() })?;
        for &(_, w) in &mirrors {
            group.expect(w, "ready", startup)?;
        }
        group.expect(wheels, "ready", startup)?;
        group.expect(gyro, "ready", startup)?;
        group.send(wheels, "go")?;
        group.send(gyro, "go")?;
        group.expect(gyro, "measuring", startup + Duration::from_micros(period_us * spec.warmup as u64))?;
        let (cpu0, busy0, t0) = (group.cpu(), MachineCpu::now(), Instant::now());
        let budget = Duration::from_secs(60) + Duration::from_micros(period_us * 3 * cycles as u64);
        group.expect(wheels, "done", budget)?;
        let (cpu1, busy1, wall) = (group.cpu(), MachineCpu::now(), t0.elapsed());
        let gyro_result = group.result(gyro, startup)?;
        let wheels_result = group.result(wheels, startup)?;
        let mut waits = Vec::new();
        let mut stage_times = Vec::new();
        for (name, w) in &mirrors {
            let result = group.result(*w, startup)?;
            if let Some(stats) = result.wait {
                waits.push((name.clone(), stats));
            }
            stage_times.push(result);
        }
        if let [estimator, controller] = &stage_times[..] {
            let stage = |from: &[u64], to: &[u64]| stats::differences(from, to).0;
            m.stages = vec![
                ("gyro gateway → estimator".into(), stage(&gyro_result.sent, &estimator.received)),
                ("estimator (MEKF)".into(), stage(&estimator.received, &estimator.sent)),
                ("estimator → controller".into(), stage(&estimator.sent, &controller.received)),
                ("controller".into(), stage(&controller.received, &controller.sent)),
                ("controller → wheel gateway".into(), stage(&controller.sent, &wheels_result.received)),
            ];
        }
        for &p in &programs {
            group.terminate(p);
        }
        group.finish(Duration::from_secs(10))?;
        let (latencies, incomplete) = stats::differences(&gyro_result.sent, &wheels_result.received);
        m.incomplete = incomplete;
        m.latencies = latencies;
        m.cpu = cpu1.since(cpu0);
        m.busy = busy1.busy_since(busy0);
        m.wall = wall;
        if let Some(w) = wheels_result.wait {
            waits.push(("wheel-gateway".into(), w));
        }
        m.wait = waits;
        if wheels_result.out_of_range > 0 {
            bail!("{} wheel commands out of range", wheels_result.out_of_range);
        }
        Ok(())
    }

    /// `testbed run --paced` for `duration_s`, watched by an observer process.
    fn paced(&mut self, duration_s: f64, wait: &str, load: bool) -> PacedRun {
        let mut run = PacedRun { wait: wait.to_string(), load, duration_s, ..PacedRun::default() };
        if let Err(e) = self.paced_inner(&mut run, duration_s, wait, load) {
            run.error = Some(format!("{e:#}"));
        }
        run
    }

    fn paced_inner(&mut self, run: &mut PacedRun, duration_s: f64, wait: &str, load: bool) -> Result<()> {
        let testbed = pipeline_binary("testbed").context("`testbed` not found next to this binary: cargo build --release --workspace --bins")?;
        let log = self.scratch.join(format!("paced-{}.mcap", self.n));
        self.n += 1;
        let _hog = load.then(|| Hog::start(self.hog_cpu));
        let cpu_before = system::children_cpu_ns();
        let wall = Instant::now();
        let mut command = Command::new(&testbed);
        command
            .args(["run", "--profile", "simulation", "--paced", "--json", "--duration", &duration_s.to_string(), "--log"])
            .arg(&log)
            .env(testbed_bus::ENV_WAIT, wait.trim_end_matches("+fifo"))
            .env("RUST_LOG", "warn")
            .stdout(std::process::Stdio::piped());
        let child = command.spawn().context("starting testbed run")?;
        let pid = child.id();
        // The bus `testbed run` creates for its run (see services/tools/cli/src/run.rs).
        let spec = WorkerSpec {
            role: Role::Observer,
            transport: Transport::IoxEvent("block".into()),
            bus_prefix: format!("tb{pid}_"),
            bus_root: format!("/tmp/tb{pid}/"),
            addrs: Vec::new(),
            size: 0,
            warmup: 0,
            count: (duration_s * 10.0).round() as usize,
            gap_us: 0,
            period_us: chain::TICK_NS / 1000,
            recording: None,
        };
        let mut group = runner::Group::new();
        let observer = group.worker("observer", &spec)?;
        // The instrument: above everything it watches, so that its time stamps are taken when
        // the samples arrive, not when the loaded CPU gets round to it.
        system::set_fifo(group.pid(observer), 20);
        // Follow the run's processes (found by their bus prefix) for their CPU and run-queue
        // time; with `+fifo`, give the control chain real-time priority once it is up.
        let (wait, fifo) = match wait.strip_suffix("+fifo") {
            Some(w) => (w, true),
            None => (wait, false),
        };
        let _ = wait;
        let mut child = child;
        let mut procs = system::RunProcesses::new(&spec.bus_prefix);
        let mut raised = std::collections::HashSet::new();
        while child.try_wait()?.is_none() {
            procs.sample();
            if fifo {
                for (name, pid) in procs.pids() {
                    if FIFO_CHAIN.contains(&name.as_str()) && raised.insert(pid) {
                        system::set_fifo(pid, 10);
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let output = child.wait_with_output().context("waiting for testbed run")?;
        let wall = wall.elapsed().as_secs_f64();
        let ticks_run = (duration_s * 10.0).round().max(1.0);
        run.processes = procs
            .totals()
            .into_iter()
            .map(|(name, cpu)| ProcessCost { name, cpu_us_per_tick: cpu.run_ns as f64 / 1e3 / ticks_run, runqueue_us_per_tick: cpu.wait_ns as f64 / 1e3 / ticks_run })
            .collect();
        let observed = group.result(observer, Duration::from_secs(30));
        group.finish(Duration::from_secs(10))?;
        run.pipeline_cpu_percent = (system::children_cpu_ns() - cpu_before) as f64 / 1e9 / wall * 100.0;
        let _ = std::fs::remove_file(&log);
        let _ = std::fs::remove_file(log.with_extension("run.toml"));
        let _ = std::fs::remove_file(log.with_extension("svg"));
        if !output.status.success() {
            bail!("testbed run failed ({})", output.status);
        }
        run.summary = serde_json::from_slice(&output.stdout).context("testbed run --json printed no JSON")?;
        run.deadline_misses = run.summary["deadline_misses"].as_u64().unwrap_or(0);
        let observed = observed?;
        run.deadline_misses = run.deadline_misses.max(observed.deadline_misses);
        let ticks = &observed.ticks;
        let period = chain::TICK_NS;
        let commands: Vec<u64> = ticks.iter().map(|t| t[3]).collect();
        run.ticks = commands.iter().filter(|&&t| t != 0).count();
        // Late: the command of tick k came after the truth of tick k+1, or never (for ticks
        // whose next truth was seen, i.e. the run went on).
        run.late_commands = ticks.windows(2).filter(|w| w[1][0] != 0 && w[0][0] != 0 && (w[0][3] == 0 || w[0][3] > w[1][0])).count() as u64;
        let error = |series: &[u64]| -> Vec<u64> {
            series.windows(2).filter(|w| w[0] != 0 && w[1] != 0).map(|w| (w[1] - w[0]).abs_diff(period)).collect()
        };
        let mut command_error = error(&commands);
        let periods: Vec<u64> = commands.windows(2).filter(|w| w[0] != 0 && w[1] != 0).map(|w| w[1] - w[0]).collect();
        run.period_min_ms = periods.iter().min().map_or(0.0, |&p| p as f64 / 1e6);
        run.period_max_ms = periods.iter().max().map_or(0.0, |&p| p as f64 / 1e6);
        run.period_error = stats::percentiles(&mut command_error);
        let truths: Vec<u64> = ticks.iter().map(|t| t[0]).collect();
        run.clock_error = stats::percentiles(&mut error(&truths));
        let (mut chain, _) = stats::differences(&truths, &commands);
        run.truth_to_command = stats::percentiles(&mut chain);
        let column = |c: usize| ticks.iter().map(|t| t[c]).collect::<Vec<u64>>();
        let (gyros, estimates) = (column(1), column(2));
        run.stages = [
            ("truth → gyro sample (plant, simulated gyro gateway)", &truths, &gyros),
            ("gyro sample → estimate (estimator)", &gyros, &estimates),
            ("estimate → wheel command (controller)", &estimates, &commands),
        ]
        .into_iter()
        .map(|(name, from, to)| (name.to_string(), stats::percentiles(&mut stats::differences(from, to).0)))
        .collect();
        if run.ticks == 0 {
            bail!("the observer saw no wheel command (bus {})", spec.bus_prefix);
        }
        Ok(())
    }
}

/// One configuration of the plan.
struct Plan {
    kind: &'static str,
    transport: Transport,
    size: usize,
    /// Hops or cycles over all rounds.
    count: usize,
    /// Hop: pause before each exchange; chain: period; µs.
    gap_us: u64,
    load: bool,
    binaries: bool,
}

/// One round of one configuration.
#[derive(Debug, Clone)]
pub struct Part {
    latencies: Vec<u64>,
    incomplete: usize,
    cpu: CpuTime,
    busy: f64,
    wall: Duration,
    wait: Vec<(String, WaitStatsJson)>,
    /// Chain: time of each stage (hops and compute), ns.
    stages: Vec<(String, Vec<u64>)>,
    result: Result<(), String>,
}

impl Default for Part {
    fn default() -> Self {
        Self { latencies: Vec::new(), incomplete: 0, cpu: CpuTime::default(), busy: 0.0, wall: Duration::ZERO, wait: Vec::new(), stages: Vec::new(), result: Ok(()) }
    }
}

impl Plan {
    /// The measurement of all rounds together (a failed round is reported; the others count).
    fn merge(&self, parts: Vec<Part>) -> Measurement {
        let mut m = Measurement {
            kind: self.kind.into(),
            transport: self.transport.key(),
            label: self.transport.label(),
            load: self.load,
            size: self.size,
            real_binaries: self.binaries,
            ..Measurement::default()
        };
        let mut all = Vec::new();
        let mut stages: Vec<(String, Vec<u64>)> = Vec::new();
        let (mut cpu, mut busy, mut wall) = (CpuTime::default(), 0.0, Duration::ZERO);
        let mut errors = Vec::new();
        for part in parts {
            if let Err(e) = &part.result {
                errors.push(e.clone());
                continue;
            }
            all.extend(part.latencies);
            for (name, times) in part.stages {
                match stages.iter_mut().find(|(n, _)| *n == name) {
                    Some((_, all)) => all.extend(times),
                    None => stages.push((name, times)),
                }
            }
            m.incomplete += part.incomplete;
            cpu = CpuTime::sum([cpu, part.cpu]);
            busy += part.busy * part.wall.as_secs_f64();
            wall += part.wall;
            for (process, w) in part.wait {
                match m.wait.iter_mut().find(|(p, _)| *p == process) {
                    Some((_, sum)) => {
                        sum.woken += w.woken;
                        sum.polled += w.polled;
                        sum.empty_windows += w.empty_windows;
                        sum.stale_notifications += w.stale_notifications;
                        sum.swept += w.swept;
                    }
                    None => m.wait.push((process, w)),
                }
            }
        }
        if !errors.is_empty() {
            m.error = Some(format!("{} of the rounds failed: {}", errors.len(), errors.join("; ")));
        }
        if all.is_empty() {
            m.error.get_or_insert_with(|| "nothing measured".into());
            return m;
        }
        m.messages = all.len();
        m.latency = stats::percentiles(&mut all);
        m.stages = stages.into_iter().map(|(name, mut times)| (name, stats::percentiles(&mut times))).collect();
        let n = m.messages as f64;
        m.cpu_us_per_msg = cpu.run_ns as f64 / 1e3 / n;
        m.runqueue_us_per_msg = cpu.wait_ns as f64 / 1e3 / n;
        m.wall_s = wall.as_secs_f64();
        m.machine_busy = if m.wall_s > 0.0 { busy / m.wall_s } else { 0.0 };
        m
    }
}
