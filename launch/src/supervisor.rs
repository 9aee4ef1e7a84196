//! Starting, supervising and stopping the processes of a run.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use std::os::unix::process::CommandExt as _;

use testbed_bus::cleanup_dead_nodes;

use ipc_types::HealthEventKind;

use crate::placement;
use crate::plan::Plan;
use crate::profile::{ClockMode, OnExit, ProcessSpec};
use crate::restart::{self, Restart, StartFailure};
use crate::sys::{self, ExitHow, SignalSet};
use crate::watchdog::{self, Watchdog};

/// How long to wait for a process to disappear after SIGKILL before giving up on it.
const KILL_WAIT: Duration = Duration::from_secs(5);

/// Environment variable with the process's profile name.
pub const ENV_PROCESS_NAME: &str = "TESTBED_PROCESS_NAME";
/// Environment variable with the run mode (`lockstep` / `paced`).
pub const ENV_RUN_MODE: &str = "TESTBED_RUN_MODE";
/// Environment variable with the run's simulated duration in seconds (absent: unlimited).
pub const ENV_RUN_DURATION_S: &str = "TESTBED_RUN_DURATION_S";
/// Environment variable with the run's random seed.
pub const ENV_RUN_SEED: &str = "TESTBED_RUN_SEED";
/// Environment variable with the run log path (absent: no log requested).
pub const ENV_RUN_LOG: &str = "TESTBED_RUN_LOG";
/// Environment variable with the profile file.
pub const ENV_RUN_PROFILE: &str = "TESTBED_RUN_PROFILE";
/// Environment variable with the run configuration file (`[run] config`), when there is one.
pub const ENV_RUN_CONFIG: &str = "TESTBED_RUN_CONFIG";
/// Environment variable naming a file the launcher writes, at the end of the run, with the CPU
/// time each process used (tab-separated: `process`, `user_s`, `system_s`, `starts`; a last
/// row `launcher` for the launcher itself): benches measure per-process cost with it.
pub const ENV_CPU_REPORT: &str = "TESTBED_CPU_REPORT";
/// Environment variable with how often the process was restarted in this run (0 at first).
pub const ENV_RESTART_COUNT: &str = ipc_types::ENV_RESTART_COUNT;
/// Prefix of the per-device variables (`TESTBED_DEVICE_GYRO=real|simulated`).
pub const ENV_DEVICE_PREFIX: &str = "TESTBED_DEVICE_";

/// How a run ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outcome {
    /// The launcher's exit status: 0 when the run completed or was stopped on request and every
    /// process ended cleanly; 1 when a required process failed or a process had to be killed.
    pub exit_code: i32,
    /// Why the run ended.
    pub reason: String,
}

struct Proc<'p> {
    spec: &'p ProcessSpec,
    program: PathBuf,
    pid: Option<libc::pid_t>,
    restarts: u32,
    restart_at: Option<Instant>,
    /// CPU time of every life of the process that ended so far (restarts add up).
    cpu: sys::CpuTime,
    /// How often the process was started.
    starts: u32,
    /// How its last life ended, if it failed its start-up ([`restart`]).
    start_failure: Option<StartFailure>,
}

/// Supervises one run.
pub struct Supervisor<'p> {
    plan: &'p Plan,
    signals: &'p SignalSet,
    procs: Vec<Proc<'p>>,
    env: Vec<(String, String)>,
    stop_reason: Option<String>,
    failed: bool,
    killed: bool,
    wall_deadline: Option<Instant>,
    watchdog: Option<Watchdog>,
}

fn secs(s: f64) -> Duration {
    Duration::try_from_secs_f64(s).unwrap_or(Duration::MAX)
}

impl<'p> Supervisor<'p> {
    /// A supervisor for `plan`; `signals` must block [`sys::WAITED`].
    pub fn new(plan: &'p Plan, signals: &'p SignalSet) -> Self {
        let procs = plan
            .profile
            .processes
            .iter()
            .map(|spec| Proc {
                spec,
                program: plan.program(spec),
                pid: None,
                restarts: 0,
                restart_at: None,
                cpu: sys::CpuTime::default(),
                starts: 0,
                start_failure: None,
            })
            .collect();
        Self {
            plan,
            signals,
            procs,
            env: plan.run_env(),
            stop_reason: None,
            failed: false,
            killed: false,
            wall_deadline: None,
            watchdog: None,
        }
    }

    /// Runs the plan to the end: clean stale bus resources, start in dependency order,
    /// supervise, stop in reverse order, reap everything.
    pub fn run(mut self) -> Outcome {
        self.cleanup("before the run");
        self.watchdog = self.open_watchdog();
        self.wall_deadline = self.plan.run.max_wall_s.map(|s| Instant::now() + secs(s));
        let order = self.plan.profile.start_order.clone();
        for &index in &order {
            self.handle_events(Some(Duration::ZERO));
            if self.stop_reason.is_some() {
                break;
            }
            self.start(index);
        }
        while self.stop_reason.is_none() {
            let running = self
                .procs
                .iter()
                .any(|p| p.pid.is_some() || p.restart_at.is_some());
            if !running {
                self.request_stop("no process left running".to_owned());
                break;
            }
            let timeout = self
                .next_deadline()
                .map(|t| t.saturating_duration_since(Instant::now()));
            let timeout = match &self.watchdog {
                Some(_) => {
                    Some(timeout.map_or(watchdog::POLL_PERIOD, |t| t.min(watchdog::POLL_PERIOD)))
                }
                None => timeout,
            };
            self.handle_events(timeout);
            self.check_heartbeats();
            self.start_due_restarts();
            if let Some(deadline) = self.wall_deadline
                && Instant::now() >= deadline
            {
                let limit = self.plan.run.max_wall_s.unwrap_or_default();
                self.request_stop(format!("wall-time limit of {limit} s reached"));
            }
        }
        self.shutdown();
        self.reap_strays();
        // The bus node goes before the cleanup, which would otherwise find it alive.
        self.watchdog = None;
        self.cleanup("after the run");
        self.report_cpu();
        let exit_code = i32::from(self.failed || self.killed);
        let reason = self.stop_reason.unwrap_or_default();
        tracing::info!("run ended: {reason}; exit status {exit_code}");
        Outcome { exit_code, reason }
    }

    /// Logs the CPU time each process used over the run (all its lives), and writes it to the
    /// file named by [`ENV_CPU_REPORT`] if set: which process costs what is the first question
    /// of any CPU budget, and `wait4` answers it for free when the launcher reaps.
    fn report_cpu(&self) {
        let launcher = sys::own_cpu();
        let rows: Vec<(&str, sys::CpuTime, u32)> = self
            .procs
            .iter()
            .map(|p| (p.spec.name.as_str(), p.cpu, p.starts))
            .chain(std::iter::once((watchdog::LAUNCHER, launcher, 1)))
            .collect();
        let total: f64 = rows.iter().map(|(_, cpu, _)| cpu.total_s()).sum();
        tracing::info!("CPU time per process (user + system), {total:.3} s in all:");
        for (name, cpu, _) in &rows {
            tracing::info!(
                "  {name:<20} {:>9.3} s (user {:.3} s, system {:.3} s)",
                cpu.total_s(),
                cpu.user_s,
                cpu.system_s
            );
        }
        let Some(path) = std::env::var_os(ENV_CPU_REPORT) else {
            return;
        };
        let mut text = String::from("process\tuser_s\tsystem_s\tstarts\n");
        for (name, cpu, starts) in &rows {
            text.push_str(&format!(
                "{name}\t{}\t{}\t{starts}\n",
                cpu.user_s, cpu.system_s
            ));
        }
        if let Err(e) = std::fs::write(&path, text) {
            tracing::warn!(
                "cannot write the CPU report {}: {e}",
                Path::new(&path).display()
            );
        }
    }

    fn cleanup(&self, when: &str) {
        match cleanup_dead_nodes(&self.plan.bus) {
            Ok(report) if report.cleaned.is_empty() && report.failed.is_empty() => {}
            Ok(report) => tracing::info!(
                "bus cleanup {when}: removed {:?}, could not remove {:?}",
                report.cleaned,
                report.failed
            ),
            Err(e) => tracing::warn!("bus cleanup {when} failed: {e}"),
        }
    }

    /// The heartbeat watchdog, unless `supervision.heartbeat_timeout_s` is 0. A launcher that
    /// cannot join the bus runs without it (and says so): the processes will fail to join too.
    fn open_watchdog(&self) -> Option<Watchdog> {
        let timeout_s = self.plan.supervision.heartbeat_timeout_s;
        if timeout_s <= 0.0 {
            tracing::warn!("supervision.heartbeat_timeout_s = 0: hung processes go unnoticed");
            return None;
        }
        match Watchdog::open(&self.plan.bus, secs(timeout_s)) {
            Ok(w) => Some(w),
            Err(e) => {
                tracing::error!("cannot watch heartbeats (joining the bus failed): {e}");
                None
            }
        }
    }

    /// Kills every process whose heartbeat stopped for `supervision.heartbeat_timeout_s`: a
    /// hung process is treated as a dead one (its exit policy applies once it is reaped).
    fn check_heartbeats(&mut self) {
        let Some(watchdog) = self.watchdog.as_mut() else {
            return;
        };
        if self.stop_reason.is_some() {
            return;
        }
        watchdog.poll();
        let now = Instant::now();
        for proc in &self.procs {
            let Some(pid) = proc.pid else { continue };
            let Some(silent) = watchdog.hung(pid as u32, now) else {
                continue;
            };
            let name = &proc.spec.name;
            tracing::error!(
                "process {name:?} (pid {pid}) sent no heartbeat for {:.2} s (limit {} s): hung; killing it",
                silent.as_secs_f64(),
                self.plan.supervision.heartbeat_timeout_s
            );
            watchdog.report(HealthEventKind::ProcessHung, name, 0, silent.as_secs_f64());
            watchdog.forget(pid as u32);
            if let Err(e) = sys::signal_group(pid, sys::SIGKILL) {
                tracing::error!("cannot kill {name:?} (pid {pid}): {e}");
            }
        }
    }

    fn report(&self, kind: HealthEventKind, subject: &str, detail: u32, value: f64) {
        if let Some(w) = &self.watchdog {
            w.report(kind, subject, detail, value);
        }
    }

    fn next_deadline(&self) -> Option<Instant> {
        self.procs
            .iter()
            .filter_map(|p| p.restart_at)
            .chain(self.wall_deadline)
            .min()
    }

    fn request_stop(&mut self, reason: String) {
        if self.stop_reason.is_none() {
            tracing::info!("stopping the run: {reason}");
            self.stop_reason = Some(reason);
        }
    }

    fn start(&mut self, index: usize) {
        let proc = &self.procs[index];
        let spec = proc.spec;
        let mut command = Command::new(&proc.program);
        command
            .args(&spec.args)
            .envs(self.env.iter().map(|(k, v)| (k, v)))
            .env(ENV_PROCESS_NAME, &spec.name)
            .env(ENV_RESTART_COUNT, proc.restarts.to_string())
            .envs(&spec.env)
            .stdin(Stdio::null())
            // Own process group: a Ctrl-C in the terminal reaches only the launcher, which
            // then stops the children in order; signals to the group reach helpers too.
            .process_group(0);
        if !spec.device.is_empty() {
            let names: Vec<&str> = spec.device.iter().map(|d| d.name()).collect();
            command.env(ipc_types::ENV_SERVED_DEVICES, names.join(","));
        }
        // SAFETY: getpid is async-signal-safe and called here in the parent.
        let parent = unsafe { libc::getpid() };
        let affinity = self.plan.affinity(spec).as_deref().map(placement::cpu_set);
        let scheduling = spec.scheduling;
        // SAFETY: prepare_child and the placement calls are async-signal-safe system calls.
        unsafe {
            command.pre_exec(move || {
                sys::prepare_child(parent)?;
                if let Some(set) = &affinity {
                    placement::apply_affinity(set)?;
                }
                if let Some(scheduling) = &scheduling {
                    scheduling.apply()?;
                }
                Ok(())
            });
        }
        match command.spawn() {
            Ok(child) => {
                let pid = libc::pid_t::try_from(child.id()).unwrap_or(libc::pid_t::MAX);
                // Dropping `Child` neither waits nor kills: the supervisor reaps by pid.
                drop(child);
                tracing::info!(
                    "started {:?} (pid {pid}): {} {}",
                    spec.name,
                    proc.program.display(),
                    spec.args.join(" ")
                );
                self.procs[index].pid = Some(pid);
                self.procs[index].starts += 1;
            }
            Err(e) => {
                let placement = if spec.cpus.is_some() || spec.scheduling.is_some() {
                    " (or apply its cpus/scheduling: a real-time policy or a negative nice value \
                     needs CAP_SYS_NICE or root)"
                } else {
                    ""
                };
                tracing::error!(
                    "cannot start {:?} ({}){placement}: {e}",
                    spec.name,
                    proc.program.display()
                );
                if spec.required {
                    self.failed = true;
                }
                self.request_stop(format!("{:?} could not be started", spec.name));
            }
        }
    }

    fn start_due_restarts(&mut self) {
        let now = Instant::now();
        for index in self.plan.profile.start_order.clone() {
            if self.stop_reason.is_some() {
                return;
            }
            if self.procs[index].restart_at.is_some_and(|t| t <= now) {
                self.procs[index].restart_at = None;
                // The dead process's ports still count against the services' limits (16
                // publishers, 16 subscribers): free them before its successor opens new ones.
                let name = self.procs[index].spec.name.clone();
                self.cleanup(&format!("before restarting {name:?}"));
                self.start(index);
            }
        }
    }

    /// Waits for one signal (up to `timeout`), then acts on stop requests and exited children.
    fn handle_events(&mut self, timeout: Option<Duration>) {
        match self.signals.wait(timeout) {
            Ok(Some(signal)) if signal != sys::SIGCHLD => {
                self.request_stop(format!("received {}", sys::signal_name(signal)));
            }
            Ok(_) => {}
            Err(e) => {
                tracing::error!("waiting for signals failed: {e}");
                self.failed = true;
                self.request_stop("signal handling failed".to_owned());
            }
        }
        // Most looks find no child ended: one system call says so, instead of one per process
        // (each a few microseconds on a virtual machine, twice a second). A failed
        // query falls back to asking each process.
        if matches!(sys::any_exited(), Ok(false)) {
            return;
        }
        for index in 0..self.procs.len() {
            if let Some((pid, how)) = self.collect(index) {
                self.on_exit(index, pid, how);
            }
        }
    }

    /// Reaps process `index` if it has ended, after killing whatever it left running in its
    /// process group (the unreaped leader keeps the group id from being reused).
    fn collect(&mut self, index: usize) -> Option<(libc::pid_t, ExitHow)> {
        let pid = self.procs[index].pid?;
        match sys::has_exited(pid) {
            Ok(true) => {}
            Ok(false) => return None,
            Err(e) => {
                tracing::error!(
                    "cannot query {:?} (pid {pid}): {e}",
                    self.procs[index].spec.name
                );
                self.procs[index].pid = None;
                return None;
            }
        }
        let _ = sys::signal_group(pid, sys::SIGKILL);
        match sys::reap(pid) {
            Ok(Some((how, cpu))) => {
                self.procs[index].pid = None;
                self.procs[index].cpu += cpu;
                Some((pid, how))
            }
            Ok(None) => None,
            Err(e) => {
                tracing::error!(
                    "cannot reap {:?} (pid {pid}): {e}",
                    self.procs[index].spec.name
                );
                self.procs[index].pid = None;
                None
            }
        }
    }

    /// Applies the exit policy to a process that ended while the run goes on.
    fn on_exit(&mut self, index: usize, pid: libc::pid_t, how: ExitHow) {
        let spec = self.procs[index].spec;
        let name = &spec.name;
        if self.stop_reason.is_some() {
            tracing::info!("process {name:?} (pid {pid}) {how} while stopping");
            return;
        }
        if spec.ends_run && how.success() {
            tracing::info!("process {name:?} (pid {pid}) {how}: it ends the run");
            self.request_stop(format!("{name:?} completed the run"));
            return;
        }
        // Whether it ever reported Running, its last heartbeats included (taken now: the
        // watchdog only looks every POLL_PERIOD).
        let ran = self.watchdog.as_mut().map(|w| {
            w.poll();
            let ran = w.ran(pid as u32);
            w.forget(pid as u32);
            ran
        });
        let start_failure = StartFailure::of(how, ran);
        let status = match how {
            ExitHow::Code(code) => code as u32,
            ExitHow::Signal(signal) => 128 + signal as u32,
        };
        self.report(HealthEventKind::ProcessExited, name, status, 0.0);
        if self.plan.run.mode == ClockMode::Lockstep && !spec.observer {
            // In lockstep every process takes part in every tick: without this one the run
            // would wait for it forever. End it, named, rather than freeze.
            let at = self.watchdog.as_ref().map_or(String::new(), |w| {
                format!(" at t = {:.1} s", w.run_time_s())
            });
            tracing::error!(
                "process {name:?} (pid {pid}) {how}{at}; a lockstep run cannot go on without it (restarts apply to paced runs only): stopping all"
            );
            self.report(HealthEventKind::RunAborted, name, status, 0.0);
            self.failed = true;
            self.request_stop(format!(
                "{name:?} {how}{at}: a lockstep run cannot go on without it"
            ));
            return;
        }
        match spec.on_exit {
            OnExit::StopAll => {
                if spec.required {
                    tracing::error!("required process {name:?} (pid {pid}) {how}; stopping all");
                    self.failed = true;
                } else {
                    tracing::warn!(
                        "process {name:?} (pid {pid}) {how}; stopping all (on_exit = stop_all)"
                    );
                }
                self.request_stop(format!("{name:?} {how}"));
            }
            OnExit::Restart => {
                let proc = &mut self.procs[index];
                let previous = std::mem::replace(&mut proc.start_failure, start_failure);
                let decision =
                    restart::decide(proc.restarts, spec.max_restarts, previous, start_failure);
                if decision == Restart::Again {
                    proc.restarts += 1;
                    let delay = secs(self.plan.supervision.restart_delay_s);
                    proc.restart_at = Some(Instant::now() + delay);
                    let restarts = proc.restarts;
                    tracing::warn!(
                        "process {name:?} (pid {pid}) {how}; restarting in {delay:?} (restart {restarts} of {})",
                        spec.max_restarts
                    );
                    self.report(HealthEventKind::ProcessRestarted, name, restarts, 0.0);
                    return;
                }
                let why = match decision {
                    Restart::SameStartFailure => {
                        "before it ever ran, as its previous start did: not restarted (it would fail the same way again)".to_owned()
                    }
                    _ => format!("with no restarts left (max_restarts = {})", spec.max_restarts),
                };
                if spec.required {
                    tracing::error!(
                        "required process {name:?} (pid {pid}) {how} {why}; stopping all"
                    );
                    self.failed = true;
                    self.request_stop(format!("{name:?} {how} {why}"));
                } else {
                    tracing::warn!("process {name:?} (pid {pid}) {how} {why}; left stopped");
                }
            }
            OnExit::Ignore => {
                tracing::warn!("process {name:?} (pid {pid}) {how}; ignored (on_exit = ignore)");
            }
        }
    }

    /// Stops every running process in reverse start order: SIGINT, wait, SIGTERM, wait,
    /// SIGKILL. A second stop signal kills what is left without further waiting.
    fn shutdown(&mut self) {
        for proc in &mut self.procs {
            proc.restart_at = None;
        }
        let mut forced = false;
        let order: Vec<usize> = self
            .plan
            .profile
            .start_order
            .iter()
            .rev()
            .copied()
            .collect();
        for index in order {
            self.stop_one(index, &mut forced);
        }
    }

    fn stop_one(&mut self, index: usize, forced: &mut bool) {
        let supervision = self.plan.supervision;
        let steps = [
            (sys::SIGINT, secs(supervision.stop_timeout_s)),
            (sys::SIGTERM, secs(supervision.term_timeout_s)),
            (sys::SIGKILL, KILL_WAIT),
        ];
        let name = self.procs[index].spec.name.clone();
        let mut previous: Option<(libc::c_int, Duration)> = None;
        for (signal, wait) in steps {
            let Some(pid) = self.procs[index].pid else {
                return;
            };
            if *forced && signal != sys::SIGKILL {
                continue;
            }
            let signal_name = sys::signal_name(signal);
            match previous {
                _ if *forced => {
                    tracing::warn!("{name:?} (pid {pid}): sending {signal_name} at once")
                }
                None => tracing::info!("stopping {name:?} (pid {pid}): sending {signal_name}"),
                Some((prev, waited)) => tracing::warn!(
                    "{name:?} (pid {pid}) did not stop within {waited:?} after {}; sending {signal_name}",
                    sys::signal_name(prev)
                ),
            }
            previous = Some((signal, wait));
            if signal == sys::SIGKILL {
                self.killed = true;
            }
            if let Err(e) = sys::signal_group(pid, signal) {
                tracing::error!("cannot signal {name:?} (pid {pid}): {e}");
            }
            let deadline = Instant::now() + wait;
            loop {
                if let Some((pid, how)) = self.collect(index) {
                    tracing::info!("reaped {name:?} (pid {pid}): {how}");
                    return;
                }
                let left = deadline.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    break;
                }
                match self.signals.wait(Some(left)) {
                    Ok(Some(s)) if s != sys::SIGCHLD && !*forced => {
                        tracing::warn!(
                            "received {} while stopping: killing the remaining processes",
                            sys::signal_name(s)
                        );
                        *forced = true;
                        break;
                    }
                    _ => self.collect_others(index),
                }
            }
        }
        if let Some(pid) = self.procs[index].pid {
            tracing::error!("{name:?} (pid {pid}) did not end after SIGKILL; giving up on it");
        }
    }

    /// Reaps (and reports) processes other than `stopping` that ended meanwhile.
    fn collect_others(&mut self, stopping: usize) {
        for index in 0..self.procs.len() {
            if index != stopping
                && let Some((pid, how)) = self.collect(index)
            {
                tracing::info!(
                    "reaped {:?} (pid {pid}): {how}",
                    self.procs[index].spec.name
                );
            }
        }
    }

    /// Reaps any child the launcher did not track (none expected) and checks none is left.
    fn reap_strays(&mut self) {
        loop {
            match sys::reap_any() {
                Ok(Some((pid, how))) => {
                    tracing::warn!("reaped untracked child pid {pid}: {how:?}");
                }
                Ok(None) => {
                    tracing::error!("children are still running after the shutdown");
                    self.failed = true;
                    return;
                }
                Err(e) if e.raw_os_error() == Some(libc::ECHILD) => {
                    tracing::info!("all children reaped");
                    return;
                }
                Err(e) => {
                    tracing::error!("checking for remaining children failed: {e}");
                    return;
                }
            }
        }
    }
}
