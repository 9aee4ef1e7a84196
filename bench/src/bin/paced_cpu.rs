//! Where the CPU of a paced (1× wall time) run goes, process by process (target: at most 0.5 %
//! of one core per second of run, all processes):
//! - per-process CPU of a short and a long paced `testbed run`, from the launcher's `wait4`
//!   accounting (`TESTBED_CPU_REPORT`): the marginal cost per second of run (the slope between
//!   the two runs) and the long run's total over its wall time, medians of `--repeats` pairs;
//!   the `testbed` command itself (the launcher's parent, summary included) is counted from
//!   this process's `RUSAGE_CHILDREN`;
//! - the steady state of the long run, exactly: the CPU time every process of the run (and
//!   `testbed run`) spent from 5 s after its start to 2 s before its end, from the kernel's
//!   per-thread run time (`/proc/<pid>/task/<tid>/schedstat`, nanoseconds). The rusage times
//!   above are sampled at the scheduler tick, coarse for processes that run 50 µs at a time,
//!   and the marginal cost also holds what grows with the run's length after it (the summary
//!   reading the log); this column is the running pipeline alone;
//! - with `--baseline-bin-dir DIR` (the binaries of another build, e.g. the commit before),
//!   the same runs of that build interleaved with this one's, and the ratio of the two;
//! - with `--cpu-latency-us N` instead, this build with the launcher holding a PM QoS CPU
//!   latency request of N µs (`testbed run --cpu-latency-us`; 0 keeps idle CPUs polling)
//!   interleaved with this build without it (the "baseline" columns), and for both the share
//!   of the steady-state window the CPUs spent idle polling and idle halted
//!   (`/sys/devices/system/cpu/cpu*/cpuidle`): what the request costs in power;
//! - with `--baseline-profile P`, this build's runs (on `--profile`, default `simulation`)
//!   interleaved with this build's runs on launch profile `P` (e.g. the simulated gateways in
//!   one process against five: `--profile simulation-grouped --baseline-profile simulation`);
//! - what following the run costs `testbed run`'s progress display, side by side: one look at
//!   a log being written, reading the whole log again (before) against a [`LogTail`] reading
//!   what was appended since its last look (after), on a `--progress-run-s` log made of the
//!   paced run's records repeated, with a look every [`PROGRESS_LOOK_S`] of simulated time (a
//!   terminal's refresh), medians;
//! - the logger's per-record cost, side by side in one process: the log writer on records as
//!   it has them (the transform taken from the record) against the same records encoded first
//!   and decoded back for their transform (what every record paid in the logger's
//!   earlier design), records per second, medians.
//!
//! `cargo build --profile deploy --workspace --bins && target/deploy/paced_cpu [--repeats 3]
//!  [--short 5 --long 60] [--profile P] [--baseline-bin-dir DIR | --cpu-latency-us N |
//!  --baseline-profile P] [--json]`
//! (the pipeline as `launch/launch.sh` builds it; `--release` works alike, and
//! `--baseline-bin-dir target/release` compares the two builds)

use anyhow::{Context, Result, bail};
use clap::Parser;
use ipc_types::{AttitudeEstimate, SimTruth, Topic};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use testbed_bench::{binary_dir, children_cpu, median, median_time};
use testbed_log::{
    EncodedRecord, LogRecord, LogTail, RunInfo, RunLog, RunLogWriter, WriterOptions,
};

/// Simulated time between two looks of the progress display at its log, s (what a terminal
/// shows: `testbed run` looks every 0.5 s of wall time).
const PROGRESS_LOOK_S: f64 = 0.5;

#[derive(Parser)]
struct Args {
    /// Wall seconds of the short paced run.
    #[arg(long, default_value_t = 5.0)]
    short: f64,
    /// Wall seconds of the long paced run.
    #[arg(long, default_value_t = 60.0)]
    long: f64,
    /// Pairs of runs per build (medians are reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Directory with the executables of a baseline build to measure side by side: `testbed`
    /// (and, in builds from before the pipeline was one executable, `testbed-launch` and the
    /// processes beside it); its launcher must write the CPU report, `TESTBED_CPU_REPORT`.
    #[arg(long)]
    baseline_bin_dir: Option<PathBuf>,
    /// Compare this build run with a PM QoS CPU latency request of this many µs (held by the
    /// launcher; needs root) against this build without it (the baseline).
    #[arg(long, value_name = "US", conflicts_with = "baseline_bin_dir")]
    cpu_latency_us: Option<u32>,
    /// Launch profile of this build's runs (`testbed run --profile`; default: `simulation`).
    #[arg(long)]
    profile: Option<String>,
    /// Compare this build's runs with runs of this build on another launch profile (the
    /// baseline), e.g. `--profile simulation-grouped --baseline-profile simulation`.
    #[arg(long, value_name = "PROFILE", conflicts_with_all = ["baseline_bin_dir", "cpu_latency_us"])]
    baseline_profile: Option<String>,
    /// Simulated length of the log on which the progress display's look is measured, s.
    #[arg(long, default_value_t = 600.0)]
    progress_run_s: f64,
    #[arg(long)]
    json: bool,
}

/// CPU seconds of one paced run: per process (launcher included), plus `testbed` itself.
struct PacedRun {
    wall_s: f64,
    per_process: BTreeMap<String, f64>,
    /// Steady state (long runs): fraction of one core per process, from schedstat.
    steady: BTreeMap<String, f64>,
    /// Steady state (long runs): time the CPUs spent in idle states, fraction of one CPU
    /// summed over CPUs, by kind.
    idle: IdleShare,
}

/// Time in the CPUs' idle states over a window, fraction of one CPU summed over the CPUs.
#[derive(Clone, Copy, Default)]
struct IdleShare {
    /// In the polling state (`POLL`): the CPU spins, awake, until there is work.
    polling: f64,
    /// In every other state (halted: woken by an interrupt).
    halted: f64,
}

/// Microseconds every CPU has spent in its idle states so far: (polling, halted), summed over
/// CPUs. Zero where the kernel has no cpuidle driver.
fn idle_state_us() -> (u64, u64) {
    let (mut polling, mut halted) = (0, 0);
    let Ok(cpus) = std::fs::read_dir("/sys/devices/system/cpu") else {
        return (0, 0);
    };
    for cpu in cpus.flatten() {
        let Ok(states) = std::fs::read_dir(cpu.path().join("cpuidle")) else {
            continue;
        };
        for state in states.flatten() {
            let read = |f: &str| std::fs::read_to_string(state.path().join(f)).unwrap_or_default();
            let Ok(us) = read("time").trim().parse::<u64>() else {
                continue;
            };
            if read("name").trim() == "POLL" {
                polling += us;
            } else {
                halted += us;
            }
        }
    }
    (polling, halted)
}

/// Where the steady-state window of a paced run of `seconds` lies: from 5 s after its start
/// to 2 s before its end (none for runs shorter than 12 s).
fn steady_window(seconds: f64) -> Option<(Duration, Duration)> {
    (seconds >= 12.0).then(|| {
        (
            Duration::from_secs(5),
            Duration::from_secs_f64(seconds - 2.0),
        )
    })
}

/// Run time (ns, all threads) of every process descended from `root`, by the name it was
/// started under (its role: `testbed-launch` as "launcher", `testbed` as "testbed run", as the
/// CPU report names them).
fn schedstat_tree(root: u32) -> BTreeMap<String, u64> {
    let parent_of: Vec<(u32, u32)> = testbed_bench::proc_pids()
        .into_iter()
        .filter_map(|pid| {
            // Field 4 of /proc/<pid>/stat, after the parenthesised command name.
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
            let after = &stat[stat.rfind(')')? + 1..];
            Some((pid, after.split_whitespace().nth(1)?.parse::<u32>().ok()?))
        })
        .collect();
    let mut tree = vec![root];
    let mut i = 0;
    while i < tree.len() {
        let parent = tree[i];
        tree.extend(
            parent_of
                .iter()
                .filter(|(_, p)| *p == parent)
                .map(|(c, _)| *c),
        );
        i += 1;
    }
    let mut by_name = BTreeMap::new();
    for pid in tree {
        let proc_dir = PathBuf::from(format!("/proc/{pid}"));
        let Some(program) = std::fs::read(proc_dir.join("cmdline")).ok().and_then(|c| {
            let argv0 = c.split(|&b| b == 0).next()?.to_vec();
            let path = PathBuf::from(String::from_utf8(argv0).ok()?);
            Some(path.file_name()?.to_string_lossy().into_owned())
        }) else {
            continue;
        };
        let name = match program.as_str() {
            "testbed-launch" => "launcher".to_owned(),
            "testbed" => "testbed run".to_owned(),
            _ => program,
        };
        let mut ns = 0;
        if let Ok(tasks) = std::fs::read_dir(proc_dir.join("task")) {
            for task in tasks.flatten() {
                ns += std::fs::read_to_string(task.path().join("schedstat"))
                    .ok()
                    .and_then(|t| t.split_whitespace().next()?.parse::<u64>().ok())
                    .unwrap_or(0);
            }
        }
        *by_name.entry(name).or_default() += ns;
    }
    by_name
}

impl PacedRun {
    fn total_s(&self) -> f64 {
        self.per_process.values().sum()
    }
}

/// A build under test: where its binaries are.
struct Build {
    name: &'static str,
    bin_dir: PathBuf,
    /// Extra arguments of `testbed run`.
    extra_args: Vec<String>,
}

fn paced_run(build: &Build, scratch: &Path, seconds: f64) -> Result<PacedRun> {
    let mut idle = IdleShare::default();
    let log = scratch.join(format!("{}.mcap", build.name));
    let report = scratch.join(format!("{}.cpu.tsv", build.name));
    let _ = std::fs::remove_file(&report);
    let testbed = build.bin_dir.join("testbed");
    let stderr_path = scratch.join(format!("{}.stderr", build.name));
    let before = children_cpu().as_secs_f64();
    let start = Instant::now();
    let mut child = Command::new(&testbed)
        .args([
            "run",
            "--paced",
            "--duration",
            &seconds.to_string(),
            "--log",
        ])
        .arg(&log)
        .args(&build.extra_args)
        .env("RUST_LOG", "warn")
        .env("TESTBED_CPU_REPORT", &report)
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(&stderr_path)?)
        .spawn()
        .with_context(|| format!("running {}", testbed.display()))?;
    let mut steady = BTreeMap::new();
    if let Some((from, to)) = steady_window(seconds) {
        std::thread::sleep(from.saturating_sub(start.elapsed()));
        let first = schedstat_tree(child.id());
        let first_idle = idle_state_us();
        let first_at = Instant::now();
        std::thread::sleep(to.saturating_sub(start.elapsed()));
        let last = schedstat_tree(child.id());
        let last_idle = idle_state_us();
        let window_s = first_at.elapsed().as_secs_f64();
        idle = IdleShare {
            polling: last_idle.0.saturating_sub(first_idle.0) as f64 * 1e-6 / window_s,
            halted: last_idle.1.saturating_sub(first_idle.1) as f64 * 1e-6 / window_s,
        };
        for (name, ns) in &last {
            // A process that (re)started inside the window counts from zero.
            let used = ns.saturating_sub(first.get(name).copied().unwrap_or(0));
            steady.insert(name.clone(), used as f64 * 1e-9 / window_s);
        }
    }
    let status = child.wait()?;
    let wall_s = start.elapsed().as_secs_f64();
    if !status.success() {
        bail!(
            "{} run failed: {}",
            build.name,
            std::fs::read_to_string(&stderr_path).unwrap_or_default()
        );
    }
    let all_s = children_cpu().as_secs_f64() - before;
    let text = std::fs::read_to_string(&report)
        .with_context(|| format!("reading the launcher's CPU report {}", report.display()))?;
    let mut per_process = BTreeMap::new();
    for line in text.lines().skip(1) {
        let cols: Vec<&str> = line.split('\t').collect();
        let [name, user, system, ..] = cols[..] else {
            bail!("bad CPU report line {line:?}");
        };
        let cpu: f64 = user.parse::<f64>()? + system.parse::<f64>()?;
        *per_process.entry(name.to_owned()).or_default() += cpu;
    }
    // What the launcher's report does not hold: `testbed run` itself (start, summary of the log).
    let reported: f64 = per_process.values().sum();
    per_process.insert("testbed run".to_owned(), (all_s - reported).max(0.0));
    Ok(PacedRun {
        wall_s,
        per_process,
        steady,
        idle,
    })
}

/// Per-process medians of a build: (marginal fraction of one core, long run's fraction).
struct BuildResult {
    marginal: BTreeMap<String, f64>,
    total_over_wall: BTreeMap<String, f64>,
    marginal_all: f64,
    total_over_wall_all: f64,
    long_wall_s: f64,
    /// Steady state of the long runs (schedstat), fraction of one core.
    steady: BTreeMap<String, f64>,
    steady_all: f64,
    /// Idle states over the long runs' steady state, medians.
    idle: IdleShare,
}

fn summarise(pairs: &[(PacedRun, PacedRun)]) -> BuildResult {
    let names: Vec<String> = pairs
        .iter()
        .flat_map(|(s, l)| s.per_process.keys().chain(l.per_process.keys()).cloned())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let slope = |s: &PacedRun, l: &PacedRun, f: &dyn Fn(&PacedRun) -> f64| {
        (f(l) - f(s)) / (l.wall_s - s.wall_s)
    };
    let mut marginal = BTreeMap::new();
    let mut total_over_wall = BTreeMap::new();
    for name in &names {
        let cpu = |r: &PacedRun| r.per_process.get(name).copied().unwrap_or(0.0);
        marginal.insert(
            name.clone(),
            median(pairs.iter().map(|(s, l)| slope(s, l, &cpu)).collect()),
        );
        total_over_wall.insert(
            name.clone(),
            median(pairs.iter().map(|(_, l)| cpu(l) / l.wall_s).collect()),
        );
    }
    BuildResult {
        marginal,
        total_over_wall,
        marginal_all: median(
            pairs
                .iter()
                .map(|(s, l)| slope(s, l, &PacedRun::total_s))
                .collect(),
        ),
        total_over_wall_all: median(pairs.iter().map(|(_, l)| l.total_s() / l.wall_s).collect()),
        long_wall_s: median(pairs.iter().map(|(_, l)| l.wall_s).collect()),
        steady: names
            .iter()
            .map(|name| {
                let of = |l: &PacedRun| l.steady.get(name).copied().unwrap_or(0.0);
                (
                    name.clone(),
                    median(pairs.iter().map(|(_, l)| of(l)).collect()),
                )
            })
            .collect(),
        steady_all: median(
            pairs
                .iter()
                .map(|(_, l)| l.steady.values().sum::<f64>())
                .collect(),
        ),
        idle: IdleShare {
            polling: median(pairs.iter().map(|(_, l)| l.idle.polling).collect()),
            halted: median(pairs.iter().map(|(_, l)| l.idle.halted).collect()),
        },
    }
}

/// The run information of the logs this bench writes.
fn bench_run_info() -> RunInfo {
    RunInfo {
        profile: "bench".to_owned(),
        seed: 1,
        mode: "paced".to_owned(),
        config_toml: String::new(),
        start_time_ns: 0,
        extra: Default::default(),
    }
}

/// Records/s of the log writer, new path against old, on `records` (medians of `repeats`).
fn writer_speed(records: &[LogRecord], repeats: usize) -> Result<(f64, f64)> {
    let info = bench_run_info();
    let options = WriterOptions::default();
    let mut check = RunLogWriter::new(std::io::Cursor::new(Vec::new()), &info, options)?;
    for r in records {
        check.write_record(r)?;
    }
    let new_time = median_time(repeats, || {
        let mut w = RunLogWriter::new(std::io::Cursor::new(Vec::new()), &info, options)
            .expect("in-memory writer");
        for r in records {
            w.write_record(r).expect("in-memory write");
        }
        std::hint::black_box(w.finish().expect("in-memory finish"));
    });
    let old_time = median_time(repeats, || {
        let mut w = RunLogWriter::new(std::io::Cursor::new(Vec::new()), &info, options)
            .expect("in-memory writer");
        for r in records {
            // As the writer's earlier design took every record: encoded first, then decoded back for
            // its transform.
            let encoded = EncodedRecord::new(r);
            if matches!(r, LogRecord::AttitudeEstimate(_) | LogRecord::SimTruth(_)) {
                std::hint::black_box(LogRecord::decode_json(encoded.topic(), encoded.data()));
            }
            w.write_encoded(&encoded).expect("in-memory write");
        }
        std::hint::black_box(w.finish().expect("in-memory finish"));
    });
    let n = records.len() as f64;
    Ok((n / new_time.as_secs_f64(), n / old_time.as_secs_f64()))
}

/// One look of the progress display at a log being written, as it was and as it is.
struct ProgressLook {
    /// Simulated length of the log, s.
    run_s: f64,
    /// Reading the whole log for its newest truth sample, at the end of the run, s (median).
    whole_at_end_s: f64,
    /// The tail reading what was appended since its last look, s (median over the run).
    tail_s: f64,
    looks: usize,
}

/// Writes a `run_s` log of `records` repeated (shifted in time) as the logger does during a
/// run (unchunked), timing a [`LogTail`] look every [`PROGRESS_LOOK_S`] of it, then the whole
/// read the progress display did before at the end.
fn progress_look(records: &[LogRecord], run_s: f64, scratch: &Path) -> Result<ProgressLook> {
    let span_ns = records
        .iter()
        .map(|r| r.header().time_ns)
        .max()
        .context("the paced run logged nothing")?
        + 100_000_000;
    let path = scratch.join("progress.mcap");
    let info = bench_run_info();
    let options = WriterOptions {
        indexed: false,
        ..WriterOptions::default()
    };
    let mut writer = RunLogWriter::create_with(&path, &info, options)?;
    let mut tail = LogTail::new(&path);
    let look_ns = (PROGRESS_LOOK_S * 1e9) as u64;
    let end_ns = (run_s * 1e9) as u64;
    let mut next_look_ns = look_ns;
    let mut tail_times = Vec::new();
    'run: for repeat in 0.. {
        for record in records {
            let mut record = *record;
            let t = record.header().time_ns + repeat * span_ns;
            if t >= end_ns {
                break 'run;
            }
            record.header_mut().time_ns = t;
            if t >= next_look_ns {
                writer.flush()?;
                let started = Instant::now();
                // What the display asks for (the truth, and the estimate for runs without).
                let newest = tail.newest(&[SimTruth::NAME, AttitudeEstimate::NAME])?;
                tail_times.push(started.elapsed());
                std::hint::black_box(newest);
                next_look_ns += look_ns;
            }
            writer.write_record(&record)?;
        }
    }
    writer.flush()?;
    let whole = median_time(5, || {
        let log = RunLog::open(&path).expect("the log being written opens");
        let newest = log
            .samples::<SimTruth>()
            .expect("its samples")
            .filter_map(Result::ok)
            .last();
        std::hint::black_box(newest);
    });
    drop(writer);
    let _ = std::fs::remove_file(&path);
    let looks = tail_times.len();
    Ok(ProgressLook {
        run_s,
        whole_at_end_s: whole.as_secs_f64(),
        tail_s: median(tail_times.iter().map(Duration::as_secs_f64).collect()),
        looks,
    })
}

/// A copy of the baseline's executables (`testbed` finds the programs of its run beside itself
/// or in itself), so that a rebuild during the measurement does not change the baseline.
fn baseline_bins(dir: &Path, scratch: &Path) -> Result<PathBuf> {
    use std::os::unix::fs::PermissionsExt as _;
    let out = scratch.join("baseline-bin");
    std::fs::create_dir_all(&out)?;
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("--baseline-bin-dir {}", dir.display()))?;
    for entry in entries {
        let entry = entry?;
        let meta = entry.metadata()?;
        if !meta.is_file() || meta.permissions().mode() & 0o111 == 0 {
            continue;
        }
        std::fs::copy(entry.path(), out.join(entry.file_name()))?;
    }
    if !out.join("testbed").exists() {
        bail!(
            "--baseline-bin-dir {}: no testbed executable",
            dir.display()
        );
    }
    Ok(out)
}

fn main() -> Result<()> {
    let args = Args::parse();
    let bin_dir = binary_dir()?;
    if !bin_dir.join("testbed").exists() {
        bail!(
            "{} not found: cargo build --profile deploy --workspace --bins first",
            bin_dir.join("testbed").display()
        );
    }
    let scratch = std::env::temp_dir().join(format!("paced-cpu-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let profile_args = |profile: &Option<String>| -> Vec<String> {
        profile
            .iter()
            .flat_map(|p| ["--profile".to_owned(), p.clone()])
            .collect()
    };
    let mut this_args = profile_args(&args.profile);
    if let Some(us) = args.cpu_latency_us {
        this_args.extend(["--cpu-latency-us".to_owned(), us.to_string()]);
    }
    let mut builds = vec![Build {
        name: "this build",
        bin_dir: bin_dir.clone(),
        extra_args: this_args,
    }];
    if let Some(profile) = &args.baseline_profile {
        eprintln!(
            "this build on profile {}; baseline: this build on profile {profile}",
            args.profile.as_deref().unwrap_or("simulation")
        );
        builds.push(Build {
            name: "baseline",
            bin_dir: bin_dir.clone(),
            extra_args: profile_args(&args.baseline_profile),
        });
    }
    if let Some(dir) = &args.baseline_bin_dir {
        builds.push(Build {
            name: "baseline",
            bin_dir: baseline_bins(dir, &scratch)?,
            extra_args: profile_args(&args.profile),
        });
    }
    if let Some(us) = args.cpu_latency_us {
        eprintln!("this build with a CPU latency request of {us} µs; baseline: without it");
        builds.push(Build {
            name: "baseline",
            bin_dir,
            extra_args: profile_args(&args.profile),
        });
    }
    let mut pairs: Vec<Vec<(PacedRun, PacedRun)>> = builds.iter().map(|_| Vec::new()).collect();
    for repeat in 0..args.repeats.max(1) {
        // Interleaved, so both builds see the same load on a shared machine.
        for (build, runs) in builds.iter().zip(&mut pairs) {
            eprintln!(
                "repeat {} of {}: {} ({} s and {} s paced)",
                repeat + 1,
                args.repeats.max(1),
                build.name,
                args.short,
                args.long
            );
            let short = paced_run(build, &scratch, args.short)?;
            let long = paced_run(build, &scratch, args.long)?;
            runs.push((short, long));
        }
    }
    let results: Vec<BuildResult> = pairs.iter().map(|p| summarise(p)).collect();

    // The writer micro-bench on the records of this build's last long run.
    let log = RunLog::open(scratch.join("this build.mcap"))?;
    let records: Vec<LogRecord> = log.records()?.collect::<Result<_, _>>()?;
    let (new_rate, old_rate) = writer_speed(&records, 5)?;
    let look = progress_look(&records, args.progress_run_s, &scratch)?;
    let _ = std::fs::remove_dir_all(&scratch);

    let this = &results[0];
    let base = results.get(1);
    if args.json {
        let table = |r: &BuildResult| {
            serde_json::json!({
                "long_run_wall_s": r.long_wall_s,
                "marginal_cpu_fraction_of_one_core": r.marginal_all,
                "cpu_fraction_of_one_core_over_wall": r.total_over_wall_all,
                "per_process_marginal": r.marginal,
                "per_process_over_wall": r.total_over_wall,
                "steady_cpu_fraction_of_one_core": r.steady_all,
                "per_process_steady": r.steady,
                "steady_idle_polling_fraction_of_one_cpu": r.idle.polling,
                "steady_idle_halted_fraction_of_one_cpu": r.idle.halted,
            })
        };
        let report = serde_json::json!({
            "short_s": args.short,
            "long_s": args.long,
            "repeats": args.repeats,
            "cpu_latency_us": args.cpu_latency_us,
            "profile": args.profile.as_deref().unwrap_or("simulation"),
            "baseline_profile": args.baseline_profile,
            "this_build": table(this),
            "baseline": base.map(table),
            "log_writer": {
                "records": records.len(),
                "records_per_s": new_rate,
                "records_per_s_decoding_transforms": old_rate,
                "speed_ratio": new_rate / old_rate,
            },
            "progress_look": {
                "run_s": look.run_s,
                "looks": look.looks,
                "look_every_s": PROGRESS_LOOK_S,
                "whole_log_at_end_s": look.whole_at_end_s,
                "tail_median_s": look.tail_s,
            },
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "paced runs of {} s and {} s, {} pairs per build; CPU in % of one core, medians",
        args.short, args.long, args.repeats
    );
    print!(
        "{:<20} {:>12} {:>12} {:>8}",
        "process", "marginal", "over wall", "steady"
    );
    if base.is_some() {
        print!(
            " {:>14} {:>14} {:>15}",
            "baseline marg.", "baseline wall", "baseline steady"
        );
    }
    println!();
    // Every process of either run (two profiles may run different processes).
    let names: std::collections::BTreeSet<&String> = this
        .marginal
        .keys()
        .chain(base.iter().flat_map(|b| b.marginal.keys()))
        .collect();
    for name in names {
        let m = this.marginal.get(name).unwrap_or(&f64::NAN);
        print!(
            "{name:<20} {:>12.3} {:>12.3} {:>8.3}",
            100.0 * m,
            100.0 * this.total_over_wall.get(name).copied().unwrap_or(f64::NAN),
            100.0 * this.steady.get(name).copied().unwrap_or(f64::NAN)
        );
        if let Some(b) = base {
            print!(
                " {:>14.3} {:>14.3} {:>15.3}",
                100.0 * b.marginal.get(name).copied().unwrap_or(f64::NAN),
                100.0 * b.total_over_wall.get(name).copied().unwrap_or(f64::NAN),
                100.0 * b.steady.get(name).copied().unwrap_or(f64::NAN)
            );
        }
        println!();
    }
    print!(
        "{:<20} {:>12.3} {:>12.3} {:>8.3}",
        "all",
        100.0 * this.marginal_all,
        100.0 * this.total_over_wall_all,
        100.0 * this.steady_all
    );
    if let Some(b) = base {
        print!(
            " {:>14.3} {:>14.3} {:>15.3}",
            100.0 * b.marginal_all,
            100.0 * b.total_over_wall_all,
            100.0 * b.steady_all
        );
    }
    println!();
    let pipeline = |r: &BuildResult| r.steady_all - r.steady.get("testbed run").unwrap_or(&0.0);
    println!(
        "steady state without `testbed run` (the launcher and its processes): {:.3} %",
        100.0 * pipeline(this)
    );
    // The plant integrates the simulated physics; on the platform the physics is real and the
    // plant does not run, while the simulated gateways stand where the CAN gateways run.
    let without_plant = |r: &BuildResult| pipeline(r) - r.steady.get("plant").unwrap_or(&0.0);
    println!(
        "steady state of the launcher and its processes but the plant (the simulated physics, \
         not run on the platform): {:.3} %",
        100.0 * without_plant(this)
    );
    let idle = |r: &BuildResult| {
        format!(
            "CPUs idle polling {:.1} %, idle halted {:.1} % (of one CPU, summed over CPUs)",
            100.0 * r.idle.polling,
            100.0 * r.idle.halted
        )
    };
    println!("steady state, this build: {}", idle(this));
    if let Some(b) = base {
        println!("steady state, baseline:   {}", idle(b));
        println!(
            "baseline / this build: {:.2}× (marginal), {:.2}× (over wall), {:.2}× (steady), \
             {:.2}× (steady, launcher and its processes: {:.3} % vs {:.3} %)",
            b.marginal_all / this.marginal_all,
            b.total_over_wall_all / this.total_over_wall_all,
            b.steady_all / this.steady_all,
            pipeline(b) / pipeline(this),
            100.0 * pipeline(b),
            100.0 * pipeline(this)
        );
    }
    println!(
        "log writer, {} records of a paced run: {:.0} records/s, {:.0} records/s decoding each \
         transform back (before): {:.2}×",
        records.len(),
        new_rate,
        old_rate,
        new_rate / old_rate
    );
    println!(
        "progress display, one look every {PROGRESS_LOOK_S} s at a {:.0} s log being written: \
         whole log read again at its end (before) {:.2} ms, tail of what was appended (after) \
         {:.1} µs (median of {} looks): {:.0}×",
        look.run_s,
        1e3 * look.whole_at_end_s,
        1e6 * look.tail_s,
        look.looks,
        look.whole_at_end_s / look.tail_s
    );
    Ok(())
}
