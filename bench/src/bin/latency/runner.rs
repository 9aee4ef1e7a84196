//! Starting the processes of one measurement, following their protocol lines, sampling their
//! CPU time, and collecting their results.

use crate::system::CpuTime;
use crate::worker::{WorkerResult, WorkerSpec};
use anyhow::{Context, Result, bail};
use std::collections::HashSet;
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

struct Proc {
    name: String,
    child: Child,
    stdin: Option<ChildStdin>,
    pid: u32,
    exited: bool,
}

/// The processes of one measurement.
pub struct Group {
    procs: Vec<Proc>,
    tx: Sender<(usize, Option<String>)>,
    rx: Receiver<(usize, Option<String>)>,
    seen: HashSet<(usize, String)>,
    results: Vec<Option<WorkerResult>>,
    /// The worker has sent its result (it may have been taken since).
    reported: Vec<bool>,
}

impl Drop for Group {
    fn drop(&mut self) {
        for p in &mut self.procs {
            let _ = p.child.kill();
            let _ = p.child.wait();
        }
    }
}

impl Group {
    pub fn new() -> Self {
        let (tx, rx) = channel();
        Self { procs: Vec::new(), tx, rx, seen: HashSet::new(), results: Vec::new(), reported: Vec::new() }
    }

    /// Starts `latency worker <spec>`.
    pub fn worker(&mut self, name: &str, spec: &WorkerSpec) -> Result<usize> {
        let exe = std::env::current_exe().context("locating the latency executable")?;
        let mut command = Command::new(exe);
        command.arg("worker").arg(serde_json::to_string(spec)?);
        self.spawn(name, command, true)
    }

    pub fn pid(&self, who: usize) -> u32 {
        self.procs[who].pid
    }

    /// Starts another program (its stdout is not part of the protocol).
    pub fn program(&mut self, name: &str, command: Command) -> Result<usize> {
        self.spawn(name, command, false)
    }

    fn spawn(&mut self, name: &str, mut command: Command, protocol: bool) -> Result<usize> {
        command.stdin(Stdio::piped()).stderr(Stdio::inherit());
        command.stdout(if protocol { Stdio::piped() } else { Stdio::null() });
        let mut child = command.spawn().with_context(|| format!("starting {name}"))?;
        let index = self.procs.len();
        if let Some(stdout) = child.stdout.take() {
            let tx = self.tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stdout).lines() {
                    let Ok(line) = line else { break };
                    if tx.send((index, Some(line))).is_err() {
                        return;
                    }
                }
                let _ = tx.send((index, None));
            });
        }
        let pid = child.id();
        self.procs.push(Proc { name: name.to_string(), stdin: child.stdin.take(), child, pid, exited: false });
        self.results.push(None);
        // Programs outside the protocol never report.
        self.reported.push(!protocol);
        Ok(index)
    }

    fn take_line(&mut self, timeout: Duration) -> Result<Option<(usize, String)>> {
        match self.rx.recv_timeout(timeout) {
            Ok((who, Some(line))) => {
                if let Some(json) = line.strip_prefix("result ") {
                    let result = serde_json::from_str(json).with_context(|| format!("{}: unreadable result", self.procs[who].name))?;
                    self.results[who] = Some(result);
                    self.reported[who] = true;
                    return Ok(None);
                }
                Ok(Some((who, line)))
            }
            Ok((who, None)) => {
                self.procs[who].exited = true;
                if !self.reported[who] {
                    let status = self.procs[who].child.wait().ok();
                    bail!("{} ended without a result ({status:?})", self.procs[who].name);
                }
                Ok(None)
            }
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => bail!("all workers gone"),
        }
    }

    /// Waits until worker `who` has said `line`.
    pub fn expect(&mut self, who: usize, line: &str, timeout: Duration) -> Result<()> {
        let end = Instant::now() + timeout;
        loop {
            if self.seen.remove(&(who, line.to_string())) {
                return Ok(());
            }
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                bail!("{} did not say `{line}` within {timeout:?}", self.procs[who].name);
            }
            if let Some((from, text)) = self.take_line(left.min(Duration::from_millis(100)))? {
                self.seen.insert((from, text));
            }
        }
    }

    pub fn send(&mut self, who: usize, line: &str) -> Result<()> {
        let stdin = self.procs[who].stdin.as_mut().context("no stdin")?;
        writeln!(stdin, "{line}")?;
        stdin.flush()?;
        Ok(())
    }

    /// CPU time of every process of the group so far.
    pub fn cpu(&self) -> CpuTime {
        CpuTime::sum(self.procs.iter().filter_map(|p| CpuTime::of(p.pid)))
    }

    /// The result of worker `who`, waiting for it.
    pub fn result(&mut self, who: usize, timeout: Duration) -> Result<WorkerResult> {
        let end = Instant::now() + timeout;
        while self.results[who].is_none() {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                bail!("{} reported no result within {timeout:?}", self.procs[who].name);
            }
            if let Some((from, text)) = self.take_line(left.min(Duration::from_millis(100)))? {
                self.seen.insert((from, text));
            }
        }
        Ok(self.results[who].take().expect("checked"))
    }

    /// Asks `who` to stop (SIGTERM).
    pub fn terminate(&mut self, who: usize) {
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
                    Some(status) => {
                        if !status.success() {
                            failures.push(format!("{} {status}", p.name));
                        }
                        break;
                    }
                    None if Instant::now() > end => {
                        let _ = p.child.kill();
                        let _ = p.child.wait();
                        failures.push(format!("{} had to be killed", p.name));
                        break;
                    }
                    None => std::thread::sleep(Duration::from_millis(5)),
                }
            }
            p.exited = true;
        }
        self.procs.clear();
        if failures.is_empty() { Ok(()) } else { bail!("{}", failures.join(", ")) }
    }
}
