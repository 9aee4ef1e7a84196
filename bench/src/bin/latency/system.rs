//! The machine: clock, CPU accounting of processes, machine-wide busy time, a CPU hog, and the
//! description that goes into the report.

use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;

/// CLOCK_MONOTONIC in ns: one clock for every process of the machine, so a time stamp taken in
/// one process and one taken in another can be subtracted.
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes only the struct it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleeps until CLOCK_MONOTONIC reaches `deadline_ns` (absolute, so delays do not accumulate).
pub fn sleep_until(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: clock_nanosleep reads the request and writes nothing with a null remainder.
        let rc = unsafe {
            libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, std::ptr::null_mut())
        };
        if rc != libc::EINTR {
            return;
        }
    }
}

/// CPU time a process has run and waited to run, from the kernel's scheduler statistics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CpuTime {
    /// Time on a CPU, ns (all threads).
    pub run_ns: u64,
    /// Time runnable but waiting for a CPU, ns (all threads).
    pub wait_ns: u64,
}

impl CpuTime {
    /// Sum over the threads of process `pid` (`/proc/<pid>/task/*/schedstat`); `None` once the
    /// process is gone.
    pub fn of(pid: u32) -> Option<Self> {
        let tasks = std::fs::read_dir(format!("/proc/{pid}/task")).ok()?;
        let mut total = Self::default();
        for task in tasks.flatten() {
            let Ok(text) = std::fs::read_to_string(task.path().join("schedstat")) else { continue };
            let mut fields = text.split_whitespace().map(|f| f.parse::<u64>().unwrap_or(0));
            total.run_ns += fields.next().unwrap_or(0);
            total.wait_ns += fields.next().unwrap_or(0);
        }
        Some(total)
    }

    /// The sum of several.
    pub fn sum(times: impl IntoIterator<Item = Self>) -> Self {
        times.into_iter().fold(Self::default(), |a, b| Self { run_ns: a.run_ns + b.run_ns, wait_ns: a.wait_ns + b.wait_ns })
    }

    pub fn since(self, earlier: Self) -> Self {
        Self { run_ns: self.run_ns.saturating_sub(earlier.run_ns), wait_ns: self.wait_ns.saturating_sub(earlier.wait_ns) }
    }
}

/// CPU time of the calling process's reaped descendants (`RUSAGE_CHILDREN`), ns.
pub fn children_cpu_ns() -> u64 {
    // SAFETY: getrusage writes only the struct it is given.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage);
        usage
    };
    let ns = |t: libc::timeval| t.tv_sec as u64 * 1_000_000_000 + t.tv_usec as u64 * 1000;
    ns(usage.ru_utime) + ns(usage.ru_stime)
}

/// Machine-wide CPU time from `/proc/stat`: (busy, total) in clock ticks.
#[derive(Debug, Clone, Copy, Default)]
pub struct MachineCpu {
    busy: u64,
    total: u64,
}

impl MachineCpu {
    pub fn now() -> Self {
        let text = std::fs::read_to_string("/proc/stat").unwrap_or_default();
        let Some(line) = text.lines().find(|l| l.starts_with("cpu ")) else { return Self::default() };
        let v: Vec<u64> = line.split_whitespace().skip(1).filter_map(|f| f.parse().ok()).collect();
        // user nice system idle iowait irq softirq steal guest guest_nice; guests are in user.
        let total: u64 = v.iter().take(8).sum();
        let idle = v.get(3).copied().unwrap_or(0) + v.get(4).copied().unwrap_or(0);
        Self { busy: total - idle, total }
    }

    /// Share of all CPUs' time that was busy since `earlier` (0 to 1), whoever was busy.
    pub fn busy_since(self, earlier: Self) -> f64 {
        let total = self.total.saturating_sub(earlier.total);
        if total == 0 { 0.0 } else { self.busy.saturating_sub(earlier.busy) as f64 / total as f64 }
    }
}

/// A thread spinning on one CPU until dropped: "the other core busy".
pub struct Hog {
    stop: Arc<AtomicBool>,
    spins: Arc<AtomicU64>,
    thread: Option<JoinHandle<()>>,
}

impl Hog {
    /// Starts spinning, pinned to `cpu`.
    pub fn start(cpu: usize) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let spins = Arc::new(AtomicU64::new(0));
        let thread = {
            let (stop, spins) = (stop.clone(), spins.clone());
            std::thread::Builder::new()
                .name("cpu-hog".into())
                .spawn(move || {
                    pin_current_thread(cpu);
                    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
                    while !stop.load(Ordering::Relaxed) {
                        for _ in 0..10_000 {
                            // xorshift: integer work the optimiser cannot remove.
                            x ^= x << 13;
                            x ^= x >> 7;
                            x ^= x << 17;
                        }
                        spins.fetch_add(1, Ordering::Relaxed);
                    }
                    std::hint::black_box(x);
                })
                .expect("spawning the CPU hog")
        };
        Self { stop, spins, thread: Some(thread) }
    }
}

impl Drop for Hog {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = self.spins.load(Ordering::Relaxed);
    }
}

/// Pins the calling thread to `cpu` (best effort).
pub fn pin_current_thread(cpu: usize) {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; sched_setaffinity reads it.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
    }
}

/// Number of online CPUs.
pub fn cpu_count() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// What the numbers were measured on.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Machine {
    pub cpu_model: String,
    pub cpus: usize,
    pub kernel: String,
    pub hypervisor: String,
    pub clocksource: String,
    pub memory_gib: f64,
    /// 1, 5 and 15 minute load averages when the run started and when it ended.
    pub loadavg_start: String,
    pub loadavg_end: String,
    pub rustc: String,
    pub started: String,
}

impl Machine {
    pub fn describe() -> Self {
        let read = |p: &str| std::fs::read_to_string(p).unwrap_or_default();
        let cpuinfo = read("/proc/cpuinfo");
        let field = |name: &str| {
            cpuinfo
                .lines()
                .find(|l| l.starts_with(name))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
                .unwrap_or_default()
        };
        let flags = field("flags");
        let hypervisor = if flags.split_whitespace().any(|f| f == "hypervisor") {
            let vendor = read("/sys/class/dmi/id/sys_vendor").trim().to_string();
            if vendor.is_empty() { "virtual machine".to_string() } else { format!("virtual machine ({vendor})") }
        } else {
            "none detected".to_string()
        };
        let mem_kib: f64 = read("/proc/meminfo")
            .lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0.0);
        let uname = std::process::Command::new("uname").arg("-srvm").output().map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string()).unwrap_or_default();
        let rustc = std::process::Command::new("rustc").arg("--version").output().map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string()).unwrap_or_default();
        let started = std::process::Command::new("date").args(["-u", "+%Y-%m-%d %H:%M:%S UTC"]).output().map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string()).unwrap_or_default();
        Self {
            cpu_model: field("model name"),
            cpus: cpu_count(),
            kernel: uname,
            hypervisor,
            clocksource: read("/sys/devices/system/clocksource/clocksource0/current_clocksource").trim().to_string(),
            memory_gib: mem_kib / 1024.0 / 1024.0,
            loadavg_start: loadavg(),
            loadavg_end: String::new(),
            rustc,
            started,
        }
    }
}

/// The 1, 5 and 15 minute load averages.
pub fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg").unwrap_or_default().split_whitespace().take(3).collect::<Vec<_>>().join(" ")
}
