//! The pipeline's speed and latency targets on this machine, measured and judged in one command: the benchmarks that
//! measure them (two pinned lockstep runs and the in-process loop for determinism and
//! bit-identity, `latency` for the chain, the hop and the 10-minute paced run under load,
//! `pipeline_speed` for the lockstep speed and Basilisk, `paced_cpu` for the paced CPU), one
//! after the other, each writing its own report into `--out`; then one verdict per target
//! (`testbed_bench::targets`), printed and written to `targets.md` beside the reports.
//!
//! ```sh
//! cargo build --profile deploy --workspace --bins
//! target/deploy/targets                                     # about 20 min; into out/targets/
//! target/deploy/targets --from out/targets                   # judge saved reports again
//! target/deploy/targets --quick --out /tmp/targets-smoke     # a few minutes; indicative
//! ```
//!
//! Exit status 0 when every target was met, 1 when one was not or had no verdict. Run it on the
//! machine that matters (the platform's computer): the chain is measured with its processes on
//! the CPU the launch profiles give the tick (`--hot-path-cpu`, by default the launcher's
//! choice), and the machine should be otherwise idle (the harness adds its own load).

use anyhow::{Context, Result, bail};
use clap::Parser;
use ipc_types::AttitudeEstimate;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use testbed_bench::binary_dir;
use testbed_bench::latency::model::Report;
use testbed_bench::targets::{self, Verdict};
use testbed_config::RunConfig;
use testbed_log::RunLog;
use testbed_sim::closed_loop;

/// The parts, in the order they run.
const PARTS: [&str; 5] = ["determinism", "chain", "lockstep", "paced-cpu", "paced-run"];

/// Seed of the determinism runs (any fixed seed does).
const DETERMINISM_SEED: u64 = 7;
/// Start time both determinism runs are pinned to, ns since the Unix epoch (2026-11-24 07:00
/// UTC; any fixed value: the log's time stamps are on it).
const PINNED_START_NS: u64 = 1_795_503_600_000_000_000;

#[derive(Parser)]
struct Args {
    /// Directory for the benchmarks' reports and `targets.md`.
    #[arg(long, default_value = "out/targets")]
    out: PathBuf,
    /// Measure nothing: judge the reports an earlier run left in this directory.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["out", "quick", "skip", "hot_path_cpu"])]
    from: Option<PathBuf>,
    /// Shorter measurements, for a smoke test: the verdicts are indicative only, and the paced
    /// run (30 s) is too short for a verdict unless it misses a deadline.
    #[arg(long)]
    quick: bool,
    /// Parts to leave out: determinism, chain, lockstep, paced-cpu, paced-run. A part left out
    /// is judged on the report an earlier run left in `--out`, if there is one.
    #[arg(long, value_delimiter = ',')]
    skip: Vec<String>,
    /// CPU the chain is placed on, as the profiles place the tick [default: the launcher's
    /// choice, the first CPU this process may use].
    #[arg(long)]
    hot_path_cpu: Option<usize>,
}

/// The chain's CPU, kept so that `--from` judges the chain placed where it was measured.
fn hot_path_file(dir: &Path) -> PathBuf {
    dir.join("hot-path-cpu")
}
/// The command lines of the measuring runs, one a line, for `--from`'s header.
fn measured_by_file(dir: &Path) -> PathBuf {
    dir.join("measured-by")
}

/// The command line of one part: a sibling benchmark binary and its arguments.
fn part_command(part: &str, dir: &Path, quick: bool, cpu: usize) -> (String, Vec<String>) {
    let s = |xs: &[&str]| xs.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    match part {
        "chain" => {
            let mut a = s(&["--skip", "sweep,paced,binaries", "--waits", "block"]);
            a.extend(["--chain-cpus".into(), cpu.to_string()]);
            a.extend([
                "--out".into(),
                part_output("chain", dir).display().to_string(),
            ]);
            if quick {
                a.push("--quick".into());
            }
            ("latency".into(), a)
        }
        "paced-run" => {
            let mut a = s(&[
                "--skip",
                "hop,chain,sweep,binaries",
                "--paced-waits",
                "block",
            ]);
            let duration = if quick { "30" } else { "600" };
            a.extend(["--paced-duration".into(), duration.into()]);
            a.extend([
                "--out".into(),
                part_output("paced-run", dir).display().to_string(),
            ]);
            ("latency".into(), a)
        }
        "lockstep" => {
            let mut a = s(&["--no-paced", "--json"]);
            if quick {
                a.extend(s(&["--duration", "60", "--repeats", "1"]));
            }
            ("pipeline_speed".into(), a)
        }
        "paced-cpu" => {
            let mut a = s(&["--json", "--short", "5"]);
            if quick {
                a.extend(s(&["--repeats", "1", "--long", "15"]));
            } else {
                a.extend(s(&["--repeats", "3", "--long", "30"]));
            }
            ("paced_cpu".into(), a)
        }
        other => unreachable!("part {other} is checked against PARTS"),
    }
}

/// The report file or directory a part writes in the output directory.
fn part_output(part: &str, dir: &Path) -> PathBuf {
    dir.join(match part {
        "chain" => "chain",
        "paced-run" => "paced-run",
        "lockstep" => "lockstep.json",
        "paced-cpu" => "paced-cpu.json",
        "determinism" => "determinism.json",
        other => unreachable!("part {other} is checked against PARTS"),
    })
}

/// A benchmark or pipeline binary beside this one.
fn sibling(binary: &str) -> Result<PathBuf> {
    let path = binary_dir()?.join(binary);
    if !path.exists() {
        bail!(
            "{} not found: cargo build --profile deploy --workspace --bins first",
            path.display()
        );
    }
    Ok(path)
}

/// Two lockstep runs of `simulation` with one seed and one pinned start time, compared byte
/// for byte, and the in-process loop of the first run's configuration, compared estimate by
/// estimate: `determinism.json`.
fn determinism(dir: &Path, quick: bool) -> Result<()> {
    let testbed = sibling("testbed")?;
    let scratch = std::env::temp_dir().join(format!("targets-determinism-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| format!("creating {}", scratch.display()))?;
    // Both runs write the same path: the log holds the run configuration, its own path included.
    let log = scratch.join("run.mcap");
    let duration_s = if quick { 40.0 } else { 150.0 };
    let mut logs = Vec::new();
    for _ in 0..2 {
        let args = [
            "run".to_string(),
            "--profile".into(),
            "simulation".into(),
            "--duration".into(),
            duration_s.to_string(),
            "--seed".into(),
            DETERMINISM_SEED.to_string(),
            "--start-time-ns".into(),
            PINNED_START_NS.to_string(),
            "--no-progress".into(),
            "--log".into(),
            log.display().to_string(),
        ];
        eprintln!("targets: determinism: testbed {}", args.join(" "));
        let status = Command::new(&testbed)
            .args(&args)
            .stdout(std::io::stderr())
            .status()
            .with_context(|| format!("running {}", testbed.display()))?;
        if !status.success() {
            bail!("testbed {} ended with {status}", args.join(" "));
        }
        logs.push(std::fs::read(&log).with_context(|| format!("reading {}", log.display()))?);
    }
    let run_log = RunLog::open(&log).with_context(|| format!("opening {}", log.display()))?;
    let config = RunConfig::from_toml_str(run_log.config_toml(), &log.display().to_string())?;
    let trace = closed_loop::run(&closed_loop::Scenario::from_run(&config))?;
    let estimates: Vec<AttitudeEstimate> = run_log
        .samples::<AttitudeEstimate>()?
        .collect::<Result<_, _>>()
        .with_context(|| format!("reading the estimates of {}", log.display()))?;
    let found = targets::Determinism {
        profile: "simulation".into(),
        seed: DETERMINISM_SEED,
        duration_s,
        log_bytes: [logs[0].len() as u64, logs[1].len() as u64],
        first_difference: targets::first_difference(&logs[0], &logs[1]),
        estimates: estimates.len(),
        in_process_ticks: trace.ticks.len(),
        first_mismatch_t_s: trace.first_estimate_mismatch(&estimates),
    };
    let _ = std::fs::remove_dir_all(&scratch);
    let file = part_output("determinism", dir);
    std::fs::write(&file, serde_json::to_string_pretty(&found)?)
        .with_context(|| format!("writing {}", file.display()))
}

/// Runs one part; a JSON-printing benchmark's standard output goes to its report file. An
/// earlier run's report of the part is removed first, so that a failed part is never judged
/// on it.
fn measure(part: &str, dir: &Path, quick: bool, cpu: usize) -> Result<()> {
    let output = part_output(part, dir);
    let removed = if output.is_dir() {
        std::fs::remove_dir_all(&output)
    } else {
        std::fs::remove_file(&output)
    };
    if let Err(e) = removed
        && e.kind() != std::io::ErrorKind::NotFound
    {
        bail!("removing the earlier {}: {e}", output.display());
    }
    if part == "determinism" {
        return determinism(dir, quick);
    }
    let (binary, args) = part_command(part, dir, quick, cpu);
    let path = sibling(&binary)?;
    eprintln!("targets: {part}: {binary} {}", args.join(" "));
    let json_out = matches!(part, "lockstep" | "paced-cpu").then_some(output);
    let mut command = Command::new(&path);
    command.args(&args).stderr(Stdio::inherit());
    let status = match &json_out {
        Some(file) => {
            let out = command
                .output()
                .with_context(|| format!("running {}", path.display()))?;
            if out.status.success() {
                std::fs::write(file, &out.stdout)
                    .with_context(|| format!("writing {}", file.display()))?;
            }
            out.status
        }
        // Its own summary goes with the progress, so that what this command prints is
        // `targets.md`.
        None => command
            .stdout(std::io::stderr())
            .status()
            .with_context(|| format!("running {}", path.display()))?,
    };
    if !status.success() {
        bail!("{binary} {} ended with {status}", args.join(" "));
    }
    Ok(())
}

fn read_json(path: &Path) -> Result<serde_json::Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

fn read_report(dir: &Path) -> Result<Report> {
    let path = dir.join("report.json");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

/// Every target's verdict from the reports in `dir`; a part this run did not measure
/// (`unmeasured`: part, why) or whose report is missing or unreadable gives its targets no
/// verdict, naming why.
fn judge(dir: &Path, cpu: usize, unmeasured: &BTreeMap<&str, String>) -> Vec<Verdict> {
    let missing = |target: &str, e: anyhow::Error| Verdict {
        target: target.into(),
        measured: format!("{e:#}"),
        met: None,
    };
    let report_of = |part: &str| match unmeasured.get(part) {
        Some(why) => Err(anyhow::anyhow!("{why}")),
        None => read_report(&part_output(part, dir)),
    };
    let json_of = |part: &str| match unmeasured.get(part) {
        Some(why) => Err(anyhow::anyhow!("{why}")),
        None => read_json(&part_output(part, dir)),
    };
    let mut verdicts = Vec::new();
    match report_of("chain") {
        Ok(r) => {
            verdicts.extend(targets::chain(&r, cpu));
            verdicts.extend(targets::hop(&r));
        }
        Err(e) => verdicts.push(missing("chain and hop", e)),
    }
    match report_of("paced-run") {
        Ok(r) => verdicts.push(targets::paced_run(&r)),
        Err(e) => verdicts.push(missing("paced run under load", e)),
    }
    match json_of("lockstep") {
        Ok(v) => verdicts.extend(targets::lockstep(&v)),
        Err(e) => verdicts.push(missing("lockstep speed", e)),
    }
    match json_of("paced-cpu") {
        Ok(v) => verdicts.push(targets::paced_cpu(&v)),
        Err(e) => verdicts.push(missing("paced CPU", e)),
    }
    match json_of("determinism").and_then(|v| Ok(serde_json::from_value(v)?)) {
        Ok(d) => verdicts.extend(targets::determinism(&d)),
        Err(e) => verdicts.push(missing("determinism and bit-identity", e)),
    }
    verdicts
}

/// The CPU the launch profiles give the tick here: the launcher's default.
fn launcher_hot_path() -> Result<usize> {
    let available =
        testbed_launch::placement::available_cpus().context("reading this process's CPUs")?;
    let roles =
        testbed_launch::placement::CpuRoles::new(available, None).map_err(anyhow::Error::msg)?;
    Ok(roles.hot_path())
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(part) = args.skip.iter().find(|p| !PARTS.contains(&p.as_str())) {
        bail!("--skip: no part `{part}` (the parts: {})", PARTS.join(", "));
    }
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let mut unmeasured = BTreeMap::new();
    let (dir, cpu, header) = match &args.from {
        Some(dir) => {
            let cpu = match std::fs::read_to_string(hot_path_file(dir)) {
                Ok(text) => text.trim().parse().with_context(|| {
                    format!("{}: not a CPU number", hot_path_file(dir).display())
                })?,
                Err(_) => launcher_hot_path()?,
            };
            let measured_by = std::fs::read_to_string(measured_by_file(dir))
                .map(|c| {
                    let runs: Vec<String> = c.lines().map(|l| format!("`{}`", l.trim())).collect();
                    runs.join(" and ")
                })
                .unwrap_or_else(|_| "an earlier run".into());
            let header = format!("Measured by {measured_by}, judged again by `{command}`");
            (dir.clone(), cpu, header)
        }
        None => {
            let dir = args.out.clone();
            let cpu = match args.hot_path_cpu {
                Some(cpu) => cpu,
                None => launcher_hot_path()?,
            };
            std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
            std::fs::write(hot_path_file(&dir), format!("{cpu}\n"))?;
            // One line per run: a run that leaves parts out keeps the lines of the runs that
            // measured them.
            let mut by = std::fs::read_to_string(measured_by_file(&dir)).unwrap_or_default();
            by.push_str(&format!("{command}\n"));
            std::fs::write(measured_by_file(&dir), by)?;
            for part in PARTS {
                if args.skip.iter().any(|s| s == part) {
                    if !part_output(part, &dir).exists() {
                        let why = format!("{part} left out (--skip), and no earlier report here");
                        unmeasured.insert(part, why);
                    }
                    continue;
                }
                // One part failing leaves its targets without a verdict; the others still run.
                if let Err(e) = measure(part, &dir, args.quick, cpu) {
                    eprintln!("targets: {part} failed: {e:#}");
                    unmeasured.insert(part, format!("{part} failed: {e:#}"));
                }
            }
            let quick = if args.quick {
                " (quick: indicative only)"
            } else {
                ""
            };
            (dir, cpu, format!("`{command}`{quick}"))
        }
    };
    let verdicts = judge(&dir, cpu, &unmeasured);
    let mut md = format!(
        "# The pipeline's speed and latency targets on this machine\n\n{header}; the chain placed on CPU {cpu}. Each \
         benchmark's own report is beside this file.\n\n"
    );
    md.push_str(&targets::markdown(&verdicts));
    let file = dir.join("targets.md");
    std::fs::write(&file, &md).with_context(|| format!("writing {}", file.display()))?;
    print!("{md}");
    let (_, not_met, unjudged) = targets::tally(&verdicts);
    std::process::exit(if not_met + unjudged == 0 { 0 } else { 1 });
}
