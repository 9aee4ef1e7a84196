//! The 10 Hz loop: a paced `testbed run` (the whole pipeline) under load, watched by an
//! observer process that time-stamps every tick's samples on arrival.

use crate::latency::measure::{Ctx, testbed_binary};
use crate::latency::model::{PacedRun, ProcessCost};
use crate::latency::protocol::{Role, STARTUP, Transport, WorkerSpec};
use crate::latency::recording::TICK_NS;
use crate::latency::runner::Group;
use crate::latency::stats::{differences, percentiles};
use crate::latency::system::{self, Hog, RunProcesses};
use anyhow::{Context, Result, bail};
use std::collections::HashSet;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The processes a `+fifo` paced run gives SCHED_FIFO priority: the gyro's path to the
/// wheel command.
const FIFO_CHAIN: [&str; 3] = ["sim-gyro", "estimator", "controller"];

/// The processes a `+placed` run puts on CPU 0 at SCHED_FIFO priority 10 through the launch
/// profile's `cpus`/`scheduling` keys: the plant's truth to the wheel command. Every other
/// process (logger, the other simulated gateways) goes to the last CPU, which the CPU hog
/// shares.
const PLACED_CHAIN: [&str; 4] = ["plant", "sim-gyro", "estimator", "controller"];

/// The `simulation` profile with the placement of a `+placed` run, written to `path`.
fn placed_profile(path: &std::path::Path, other_cpu: usize) -> Result<()> {
    let source =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../launch/profiles/simulation.toml");
    let text = std::fs::read_to_string(&source)
        .with_context(|| format!("reading {}", source.display()))?;
    let mut out = String::new();
    // The profile's own placement (`cpus = "hot-path"` …) gives way to this one.
    for line in text.lines().filter(|l| !l.starts_with("cpus = ")) {
        out.push_str(line);
        out.push('\n');
        let Some(name) = line
            .strip_prefix("name = \"")
            .and_then(|rest| rest.strip_suffix('"'))
        else {
            continue;
        };
        if PLACED_CHAIN.contains(&name) {
            out.push_str("cpus = [0]\nscheduling = { policy = \"fifo\", priority = 10 }\n");
        } else {
            out.push_str(&format!("cpus = [{other_cpu}]\n"));
        }
    }
    std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))
}

impl Ctx {
    /// `testbed run --paced` for `duration_s` under load, with `TESTBED_BUS_WAIT=wait`.
    pub fn paced(&mut self, duration_s: f64, wait: &str) -> PacedRun {
        let mut run = PacedRun {
            wait: wait.to_string(),
            load: true,
            duration_s,
            ..PacedRun::default()
        };
        if let Err(e) = self.paced_run(&mut run) {
            run.error = Some(format!("{e:#}"));
        }
        run
    }

    fn paced_run(&mut self, run: &mut PacedRun) -> Result<()> {
        let testbed = testbed_binary().context(
            "`testbed` not found next to this binary: cargo build --profile deploy --workspace --bins",
        )?;
        let log = self.scratch.join(format!("paced-{}.mcap", self.n));
        self.n += 1;
        let _hog = run.load.then(|| Hog::start(self.hog_cpu));
        let cpu_before = system::children_cpu_ns();
        let wall = Instant::now();
        let (wait, fifo) = match run.wait.strip_suffix("+fifo") {
            Some(w) => (w, true),
            None => (run.wait.as_str(), false),
        };
        let (wait, profile) = match wait.strip_suffix("+placed") {
            Some(w) => {
                let path = self.scratch.join(format!("placed-{}.toml", self.n));
                placed_profile(&path, self.hog_cpu)?;
                (w, path.display().to_string())
            }
            None => (wait, "simulation".to_string()),
        };
        let mut child = Command::new(&testbed)
            .args([
                "run",
                "--profile",
                &profile,
                "--paced",
                "--json",
                "--duration",
                &run.duration_s.to_string(),
                "--log",
            ])
            .arg(&log)
            .env(ipc_types::ENV_WAIT, wait)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .spawn()
            .context("starting testbed run")?;
        let pid = child.id();
        // The private bus `testbed run` creates for its run: `/tmp/tb<pid>_<random>/`, prefix
        // `tb<pid>_<random>_` (see testbed_bus::PrivateRun; same user, so readable here).
        let name = run_bus_name(pid)?;
        let spec = WorkerSpec {
            role: Role::Observer,
            transport: Transport::BUS,
            bus_prefix: format!("{name}_"),
            bus_root: format!("/tmp/{name}/"),
            addrs: Vec::new(),
            size: 0,
            warmup: 0,
            count: (run.duration_s * 10.0).round() as usize,
            interval_us: TICK_NS / 1000,
            recording: None,
        };
        let mut group = Group::default();
        let observer = group.worker(&spec)?;
        // The instrument: above everything it watches, so that its time stamps are taken when
        // the samples arrive, not when the loaded CPU gets round to it.
        system::set_fifo(group.pid(observer), 20);
        // Follow the run's processes (found by their bus prefix) for their CPU and run-queue
        // time; with `+fifo`, give the control chain real-time priority once it is up.
        let mut procs = RunProcesses::new(&spec.bus_prefix);
        let mut raised = HashSet::new();
        while child.try_wait()?.is_none() {
            procs.sample();
            for (name, pid) in procs.pids() {
                if fifo && FIFO_CHAIN.contains(&name.as_str()) && raised.insert(pid) {
                    system::set_fifo(pid, 10);
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let output = child
            .wait_with_output()
            .context("waiting for testbed run")?;
        let wall = wall.elapsed().as_secs_f64();
        let ticks_run = (run.duration_s * 10.0).round().max(1.0);
        let per_tick = |ns: u64| ns as f64 / 1e3 / ticks_run;
        run.processes = procs
            .totals()
            .into_iter()
            .map(|(name, cpu)| ProcessCost {
                name,
                cpu_us_per_tick: per_tick(cpu.run_ns),
                runqueue_us_per_tick: per_tick(cpu.wait_ns),
            })
            .collect();
        let observed = group.result(observer, STARTUP + Duration::from_secs(10));
        group.finish(Duration::from_secs(10))?;
        run.pipeline_cpu_percent =
            (system::children_cpu_ns() - cpu_before) as f64 / 1e9 / wall * 100.0;
        for file in [
            log.clone(),
            log.with_extension("run.toml"),
            log.with_extension("svg"),
        ] {
            let _ = std::fs::remove_file(file);
        }
        if !output.status.success() {
            bail!("testbed run failed ({})", output.status);
        }
        run.summary =
            serde_json::from_slice(&output.stdout).context("testbed run --json printed no JSON")?;
        let observed = observed?;
        run.deadline_misses = run.summary["deadline_misses"]
            .as_u64()
            .unwrap_or(0)
            .max(observed.deadline_misses);
        let column = |c: usize| observed.ticks.iter().map(|t| t[c]).collect::<Vec<u64>>();
        let (truths, gyros, estimates, commands) = (column(0), column(1), column(2), column(3));
        run.ticks = commands.iter().filter(|&&t| t != 0).count();
        // Late: the command of tick k came after the truth of tick k+1, or never (for ticks
        // whose next truth was seen, i.e. the run went on).
        run.late_commands = observed
            .ticks
            .windows(2)
            .filter(|w| w[1][0] != 0 && w[0][0] != 0 && (w[0][3] == 0 || w[0][3] > w[1][0]))
            .count() as u64;
        let seen_pairs = |series: &[u64]| -> Vec<u64> {
            series
                .windows(2)
                .filter(|w| w[0] != 0 && w[1] != 0)
                .map(|w| w[1] - w[0])
                .collect()
        };
        let error = |series: &[u64]| -> Vec<u64> {
            seen_pairs(series)
                .into_iter()
                .map(|p| p.abs_diff(TICK_NS))
                .collect()
        };
        let periods = seen_pairs(&commands);
        run.period_min_ms = periods.iter().min().map_or(0.0, |&p| p as f64 / 1e6);
        run.period_max_ms = periods.iter().max().map_or(0.0, |&p| p as f64 / 1e6);
        run.period_error = percentiles(&mut error(&commands));
        run.clock_error = percentiles(&mut error(&truths));
        run.truth_to_command = percentiles(&mut differences(&truths, &commands).0);
        run.stages = [
            (
                "truth → gyro sample (plant, simulated gyro gateway)",
                &truths,
                &gyros,
            ),
            ("gyro sample → estimate (estimator)", &gyros, &estimates),
            (
                "estimate → wheel command (controller)",
                &estimates,
                &commands,
            ),
        ]
        .into_iter()
        .map(|(name, from, to)| (name.to_string(), percentiles(&mut differences(from, to).0)))
        .collect();
        if run.ticks == 0 {
            bail!(
                "the observer saw no wheel command (bus {})",
                spec.bus_prefix
            );
        }
        Ok(())
    }
}

/// The name of the private bus directory `testbed run` (pid `pid`) created in `/tmp`, waiting
/// up to 10 s for it to appear.
fn run_bus_name(pid: u32) -> Result<String> {
    let start = format!("tb{pid}_");
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let found = std::fs::read_dir("/tmp")?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .find(|n| n.starts_with(&start));
        if let Some(name) = found {
            return Ok(name);
        }
        anyhow::ensure!(
            Instant::now() < deadline,
            "testbed run (pid {pid}) created no bus directory /tmp/{start}…"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_launch::placement::Cpus;
    use testbed_launch::profile::Profile;

    /// The `+placed` profile replaces the shipped profile's own placement (a second `cpus`
    /// key would make it invalid TOML) and is a valid profile.
    #[test]
    fn the_placed_profile_replaces_the_shipped_placement() {
        let path = std::env::temp_dir().join(format!("placed-{}.toml", std::process::id()));
        placed_profile(&path, 1).unwrap();
        let profile = Profile::load(&path);
        let _ = std::fs::remove_file(&path);
        let profile = profile.expect("a valid profile");
        for p in &profile.processes {
            let expected = if PLACED_CHAIN.contains(&p.name.as_str()) {
                vec![0]
            } else {
                vec![1]
            };
            assert_eq!(p.cpus, Some(Cpus::List(expected)), "{}", p.name);
        }
    }
}
