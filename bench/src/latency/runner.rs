//! Starting the processes of one measurement, following their [`Signal`]s, sampling their CPU
//! time, and collecting their results.

use crate::latency::protocol::{GO, Line, Signal, WorkerResult, WorkerSpec};
use crate::latency::system::CpuTime;
use anyhow::{Context, Result, bail};
use std::collections::HashSet;
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

/// A process of the group, by index.
pub type Who = usize;

struct Proc {
    name: String,
    child: Child,
    stdin: Option<ChildStdin>,
    pid: u32,
    /// Its result; `reported` once it has sent one (it may have been taken since).
    result: Option<WorkerResult>,
    reported: bool,
}

/// The processes of one measurement.
pub struct Group {
    procs: Vec<Proc>,
    tx: Sender<(Who, Option<String>)>,
    rx: Receiver<(Who, Option<String>)>,
    seen: HashSet<(Who, Signal)>,
}

impl Drop for Group {
    fn drop(&mut self) {
        for p in &mut self.procs {
            let _ = p.child.kill();
            let _ = p.child.wait();
        }
    }
}

impl Default for Group {
    fn default() -> Self {
        let (tx, rx) = channel();
        Self {
            procs: Vec::new(),
            tx,
            rx,
            seen: HashSet::new(),
        }
    }
}

impl Group {
    /// Starts `latency worker <spec>`.
    pub fn worker(&mut self, spec: &WorkerSpec) -> Result<Who> {
        let exe = std::env::current_exe().context("locating the latency executable")?;
        let mut command = Command::new(exe);
        command.arg("worker").arg(serde_json::to_string(spec)?);
        self.spawn(spec.role.name(), command, true)
    }

    /// Starts another program (its stdout is not part of the protocol).
    pub fn program(&mut self, name: &str, command: Command) -> Result<Who> {
        self.spawn(name, command, false)
    }

    pub fn pid(&self, who: Who) -> u32 {
        self.procs[who].pid
    }

    fn spawn(&mut self, name: &str, mut command: Command, protocol: bool) -> Result<Who> {
        command.stdin(Stdio::piped()).stderr(Stdio::inherit());
        command.stdout(if protocol {
            Stdio::piped()
        } else {
            Stdio::null()
        });
        let mut child = command
            .spawn()
            .with_context(|| format!("starting {name}"))?;
        let who = self.procs.len();
        if let Some(stdout) = child.stdout.take() {
            let tx = self.tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stdout).lines() {
                    let Ok(line) = line else { break };
                    if tx.send((who, Some(line))).is_err() {
                        return;
                    }
                }
                let _ = tx.send((who, None));
            });
        }
        let pid = child.id();
        // Programs outside the protocol never report.
        self.procs.push(Proc {
            name: name.to_string(),
            stdin: child.stdin.take(),
            child,
            pid,
            result: None,
            reported: !protocol,
        });
        Ok(who)
    }

    /// Takes the next line of any worker (for at most `timeout`) and files it.
    fn take_line(&mut self, timeout: Duration) -> Result<()> {
        match self.rx.recv_timeout(timeout) {
            Ok((who, Some(line))) => {
                match Line::parse(&line).with_context(|| self.procs[who].name.clone())? {
                    Some(Line::Signal(s)) => {
                        self.seen.insert((who, s));
                    }
                    Some(Line::Result(result)) => {
                        self.procs[who].result = Some(*result);
                        self.procs[who].reported = true;
                    }
                    None => eprintln!("{}: {line}", self.procs[who].name),
                }
            }
            Ok((who, None)) if !self.procs[who].reported => {
                let status = self.procs[who].child.wait().ok();
                bail!(
                    "{} ended without a result ({status:?})",
                    self.procs[who].name
                );
            }
            Ok((_, None)) | Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => bail!("all workers gone"),
        }
        Ok(())
    }

    /// Takes lines until `ready` holds, for at most `timeout`.
    fn until(
        &mut self,
        what: &str,
        timeout: Duration,
        mut ready: impl FnMut(&mut Self) -> bool,
    ) -> Result<()> {
        let end = Instant::now() + timeout;
        while !ready(self) {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                bail!("{what} within {timeout:?}");
            }
            self.take_line(left.min(Duration::from_millis(100)))?;
        }
        Ok(())
    }

    /// Waits until worker `who` has said `signal`.
    pub fn expect(&mut self, who: Who, signal: Signal, timeout: Duration) -> Result<()> {
        let what = format!("{} did not say {signal:?}", self.procs[who].name);
        self.until(&what, timeout, |g| g.seen.remove(&(who, signal)))
    }

    /// Waits until every worker of `workers` is ready (its receiving ports exist), then tells
    /// each of `drivers` to go: nobody sends before everyone can receive.
    pub fn start(&mut self, workers: &[Who], drivers: &[Who], timeout: Duration) -> Result<()> {
        for &w in workers {
            self.expect(w, Signal::Ready, timeout)?;
        }
        for &d in drivers {
            let stdin = self.procs[d].stdin.as_mut().context("no stdin")?;
            writeln!(stdin, "{GO}")?;
            stdin.flush()?;
        }
        Ok(())
    }

    /// CPU time of every process of the group so far.
    pub fn cpu(&self) -> CpuTime {
        CpuTime::sum(self.procs.iter().filter_map(|p| CpuTime::of(p.pid)))
    }

    /// The result of worker `who`, waiting for it.
    pub fn result(&mut self, who: Who, timeout: Duration) -> Result<WorkerResult> {
        let what = format!("{} reported no result", self.procs[who].name);
        self.until(&what, timeout, |g| g.procs[who].result.is_some())?;
        Ok(self.procs[who].result.take().expect("checked"))
    }

    /// Asks `who` to stop (SIGTERM).
    pub fn terminate(&mut self, who: Who) {
        // SAFETY: kill with a pid we started and have not reaped yet.
        unsafe { libc::kill(self.procs[who].pid as i32, libc::SIGTERM) };
    }

    /// Waits for every process to exit (killing what is left after `timeout`); fails if one
    /// exited unsuccessfully.
    pub fn finish(mut self, timeout: Duration) -> Result<()> {
        let end = Instant::now() + timeout;
        let mut failures = Vec::new();
        for p in &mut self.procs {
            loop {
                match p.child.try_wait()? {
                    Some(status) if !status.success() => {
                        failures.push(format!("{} {status}", p.name))
                    }
                    Some(_) => {}
                    None if Instant::now() > end => {
                        let _ = p.child.kill();
                        let _ = p.child.wait();
                        failures.push(format!("{} had to be killed", p.name));
                    }
                    None => {
                        std::thread::sleep(Duration::from_millis(5));
                        continue;
                    }
                }
                break;
            }
        }
        self.procs.clear();
        if failures.is_empty() {
            Ok(())
        } else {
            bail!("{}", failures.join(", "))
        }
    }
}
