//! The machine: clock, CPU accounting of processes, machine-wide busy time, a CPU hog, and the
//! description that goes into the report.

use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

/// CLOCK_MONOTONIC in ns: one clock for every process of the machine, so a time stamp taken in
/// one process and one taken in another can be subtracted.
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes only the struct it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Timer slack of 1 µs for the calling thread (the default 50 µs would make every paced sleep
/// up to 50 µs late).
pub fn precise_timers() {
    // SAFETY: PR_SET_TIMERSLACK takes a value and changes only this thread's slack.
    unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, 1000 as libc::c_ulong) };
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
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
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
            let Ok(text) = std::fs::read_to_string(task.path().join("schedstat")) else {
                continue;
            };
            let mut fields = text
                .split_whitespace()
                .map(|f| f.parse::<u64>().unwrap_or(0));
            total.run_ns += fields.next().unwrap_or(0);
            total.wait_ns += fields.next().unwrap_or(0);
        }
        Some(total)
    }

    /// The sum of several.
    pub fn sum(times: impl IntoIterator<Item = Self>) -> Self {
        times.into_iter().fold(Self::default(), |a, b| Self {
            run_ns: a.run_ns + b.run_ns,
            wait_ns: a.wait_ns + b.wait_ns,
        })
    }

    pub fn since(self, earlier: Self) -> Self {
        Self {
            run_ns: self.run_ns.saturating_sub(earlier.run_ns),
            wait_ns: self.wait_ns.saturating_sub(earlier.wait_ns),
        }
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
        let Some(line) = text.lines().find(|l| l.starts_with("cpu ")) else {
            return Self::default();
        };
        let v: Vec<u64> = line
            .split_whitespace()
            .skip(1)
            .filter_map(|f| f.parse().ok())
            .collect();
        // user nice system idle iowait irq softirq steal guest guest_nice; guests are in user.
        let total: u64 = v.iter().take(8).sum();
        let idle = v.get(3).copied().unwrap_or(0) + v.get(4).copied().unwrap_or(0);
        Self {
            busy: total - idle,
            total,
        }
    }

    /// Share of all CPUs' time that was busy since `earlier` (0 to 1), whoever was busy.
    pub fn busy_since(self, earlier: Self) -> f64 {
        let total = self.total.saturating_sub(earlier.total);
        if total == 0 {
            0.0
        } else {
            self.busy.saturating_sub(earlier.busy) as f64 / total as f64
        }
    }
}

/// A thread spinning on one CPU until dropped: "the other core busy".
pub struct Hog {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Hog {
    /// Starts spinning, pinned to `cpu`.
    pub fn start(cpu: usize) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
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
                    }
                    std::hint::black_box(x);
                })
                .expect("spawning the CPU hog")
        };
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Hog {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Pins the calling thread to `cpu` (best effort).
pub fn pin_current_thread(cpu: usize) {
    let _ = pin(0, cpu);
}

/// Pins the process (its main thread; threads it starts later inherit the CPU) `pid` to `cpu`.
pub fn pin_process(pid: u32, cpu: usize) -> std::io::Result<()> {
    let pid = libc::pid_t::try_from(pid).map_err(std::io::Error::other)?;
    pin(pid, cpu)
}

/// `sched_setaffinity(pid, {cpu})`; pid 0 is the calling thread.
fn pin(pid: libc::pid_t, cpu: usize) -> std::io::Result<()> {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; sched_setaffinity reads it.
    let status = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(pid, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if status == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Number of online CPUs.
pub fn cpu_count() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// What the numbers were measured on.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
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
    /// cpuidle driver and, for `haltpoll`, how long an idle virtual CPU polls before it halts
    /// (a halted one needs the hypervisor to wake it).
    pub cpuidle: String,
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
            // The DMI vendor names the machine's maker where there is one; a microVM such as
            // Firecracker has no DMI tables, and the hypervisor's CPUID signature names it.
            let vendor = read("/sys/class/dmi/id/sys_vendor").trim().to_string();
            let signature = hypervisor_signature().unwrap_or_default();
            let names: Vec<&str> = [vendor.as_str(), signature.as_str()]
                .into_iter()
                .filter(|name| !name.is_empty())
                .collect();
            if names.is_empty() {
                "virtual machine".to_string()
            } else {
                format!("virtual machine ({})", names.join(", "))
            }
        } else {
            "none detected".to_string()
        };
        let mem_kib: f64 = read("/proc/meminfo")
            .lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0.0);
        let uname = std::process::Command::new("uname")
            .arg("-srvm")
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_default();
        let rustc = std::process::Command::new("rustc")
            .arg("--version")
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_default();
        let started = std::process::Command::new("date")
            .args(["-u", "+%Y-%m-%d %H:%M:%S UTC"])
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_default();
        let driver = read("/sys/devices/system/cpu/cpuidle/current_driver")
            .trim()
            .to_string();
        let halt_poll = read("/sys/module/haltpoll/parameters/guest_halt_poll_ns")
            .trim()
            .to_string();
        let cpuidle = match (driver.as_str(), halt_poll.as_str()) {
            ("", _) => "unknown".to_string(),
            (d, "") => d.to_string(),
            (d, ns) => format!("{d}, guest_halt_poll_ns = {ns}"),
        };
        Self {
            cpuidle,
            cpu_model: field("model name"),
            cpus: cpu_count(),
            kernel: uname,
            hypervisor,
            clocksource: read("/sys/devices/system/clocksource/clocksource0/current_clocksource")
                .trim()
                .to_string(),
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
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// The processes of one pipeline run (those whose environment names its bus prefix), with the
/// latest CPU time seen of each.
pub struct RunProcesses {
    needle: Vec<u8>,
    seen: std::collections::BTreeMap<u32, (String, CpuTime)>,
}

impl RunProcesses {
    pub fn new(prefix: &str) -> Self {
        Self {
            needle: format!("TESTBED_BUS_PREFIX={prefix}").into_bytes(),
            seen: Default::default(),
        }
    }

    /// Looks for new processes of the run and updates the CPU time of the known ones.
    pub fn sample(&mut self) {
        for pid in crate::proc_pids() {
            if let Some((_, last)) = self.seen.get_mut(&pid) {
                *last = CpuTime::of(pid).unwrap_or(*last);
                continue;
            }
            let Ok(env) = std::fs::read(format!("/proc/{pid}/environ")) else {
                continue;
            };
            let vars: Vec<&[u8]> = env.split(|b| *b == 0).collect();
            if !vars.contains(&self.needle.as_slice()) {
                continue;
            }
            let name = vars
                .iter()
                .find_map(|v| v.strip_prefix(b"TESTBED_PROCESS_NAME="))
                .map(|n| String::from_utf8_lossy(n).into_owned())
                .unwrap_or_else(|| {
                    std::fs::read_to_string(format!("/proc/{pid}/comm"))
                        .unwrap_or_default()
                        .trim()
                        .to_string()
                });
            // Over the process's whole life (schedstat counts from its start).
            if let Some(now) = CpuTime::of(pid) {
                self.seen.insert(pid, (name, now));
            }
        }
    }

    /// (name, pid) of every process seen.
    pub fn pids(&self) -> Vec<(String, u32)> {
        self.seen
            .iter()
            .map(|(pid, (name, _))| (name.clone(), *pid))
            .collect()
    }

    /// CPU time of each process over its life (as last seen), by name.
    pub fn totals(&self) -> Vec<(String, CpuTime)> {
        let mut out: Vec<(String, CpuTime)> = Vec::new();
        for &(ref name, cpu) in self.seen.values() {
            match out.iter_mut().find(|(n, _)| n == name) {
                Some((_, sum)) => *sum = CpuTime::sum([*sum, cpu]),
                None => out.push((name.clone(), cpu)),
            }
        }
        out
    }
}

/// SCHED_FIFO priority `priority` for every thread of `pid` (best effort; needs privileges).
pub fn set_fifo(pid: u32, priority: i32) {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return;
    };
    for task in tasks.flatten() {
        let Some(tid) = task
            .file_name()
            .to_str()
            .and_then(|n| n.parse::<i32>().ok())
        else {
            continue;
        };
        let param = libc::sched_param {
            sched_priority: priority,
        };
        // SAFETY: sched_setscheduler reads the parameter struct.
        unsafe { libc::sched_setscheduler(tid, libc::SCHED_FIFO, &param) };
    }
}

/// The hypervisor's CPUID signature (leaf 0x4000_0000), by name. `None` off x86-64 or when
/// the leaf names nothing.
fn hypervisor_signature() -> Option<String> {
    #[cfg(target_arch = "x86_64")]
    {
        // CPUID exists on every x86-64 CPU; leaf 0x4000_0000 is reserved for hypervisors and
        // reads as zeros (or as another leaf's values, refused by the name check) without one.
        let leaf = std::arch::x86_64::__cpuid(0x4000_0000);
        let mut bytes = [0u8; 12];
        for (chunk, word) in bytes.chunks_mut(4).zip([leaf.ebx, leaf.ecx, leaf.edx]) {
            chunk.copy_from_slice(&word.to_le_bytes());
        }
        signature_name(&bytes)
    }
    #[cfg(not(target_arch = "x86_64"))]
    None
}

/// The twelve signature bytes of CPUID leaf 0x4000_0000 (EBX, ECX, EDX) read as a name: `KVM`,
/// `Hyper-V`, `VMware`, `Xen`, `QEMU (TCG)`, another printable signature as it is, or `None`.
fn signature_name(bytes: &[u8; 12]) -> Option<String> {
    let raw = std::str::from_utf8(bytes).ok()?.trim_end_matches('\0');
    let name = match raw {
        "KVMKVMKVM" => "KVM",
        "Microsoft Hv" => "Hyper-V",
        "VMwareVMware" => "VMware",
        "XenVMMXenVMM" => "Xen",
        "TCGTCGTCGTCG" => "QEMU (TCG)",
        other if !other.is_empty() && other.chars().all(|c| c.is_ascii_graphic() || c == ' ') => {
            other
        }
        _ => return None,
    };
    Some(name.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hypervisor_signature_reads_as_its_name_and_garbage_as_none() {
        assert_eq!(signature_name(b"KVMKVMKVM\0\0\0").as_deref(), Some("KVM"));
        assert_eq!(signature_name(b"Microsoft Hv").as_deref(), Some("Hyper-V"));
        assert_eq!(
            signature_name(b"ACRNACRNACRN").as_deref(),
            Some("ACRNACRNACRN")
        );
        assert_eq!(signature_name(&[0; 12]), None);
        // Another leaf's values where no hypervisor answers: not a name.
        assert_eq!(
            signature_name(&[0x01, 0x02, 0xff, 7, 0, 0, 0, 0, 0, 0, 0, 0]),
            None
        );
    }

    #[test]
    fn a_process_pinned_by_pid_may_run_on_that_cpu_only() {
        let cpu = cpu_count() - 1;
        let mut child = std::process::Command::new("sleep")
            .arg("5")
            .spawn()
            .expect("sleep");
        let pinned = pin_process(child.id(), cpu);
        let status = std::fs::read_to_string(format!("/proc/{}/status", child.id()));
        let _ = child.kill();
        let _ = child.wait();
        pinned.expect("pin");
        let allowed = status.expect("status").lines().find_map(|l| {
            l.strip_prefix("Cpus_allowed_list:")
                .map(|v| v.trim().to_string())
        });
        assert_eq!(allowed, Some(cpu.to_string()));
        assert!(pin_process(u32::MAX, 0).is_err(), "no such process");
    }
}
