//! Where and how a process runs: its CPU affinity and scheduling policy (`cpus`,
//! `scheduling` of a `[[process]]`), applied by the launcher between `fork` and `exec`.
//!
//! A real-time policy (`fifo`, `rr`) needs `CAP_SYS_NICE` (or root); without it the process
//! does not start and the launcher names it with the system's error. Threads the process
//! creates later inherit both settings.

use serde::Deserialize;
use std::io;

/// Largest CPU index a `cpus` list may name (the kernel's `CPU_SETSIZE` minus one).
pub const MAX_CPU: usize = 1023;

/// Scheduling policy of a process (`scheduling = { policy = "fifo", priority = 10 }`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(tag = "policy", rename_all = "lowercase", deny_unknown_fields)]
pub enum Scheduling {
    /// `SCHED_OTHER` (the default time-sharing policy) at nice value `nice` (−20 ..= 19;
    /// below 0 needs the privilege).
    Other {
        #[serde(default)]
        nice: i32,
    },
    /// `SCHED_FIFO` at `priority` (1 ..= 99): runs until it blocks, ahead of every
    /// time-sharing process.
    Fifo { priority: i32 },
    /// `SCHED_RR` at `priority` (1 ..= 99): as `fifo`, round-robin among equal priorities.
    Rr { priority: i32 },
}

impl Scheduling {
    /// Why the setting is impossible, if it is.
    pub fn check(&self) -> Result<(), String> {
        match *self {
            Scheduling::Other { nice } if !(-20..=19).contains(&nice) => {
                Err(format!("nice = {nice}: must be within -20 ..= 19"))
            }
            Scheduling::Fifo { priority } | Scheduling::Rr { priority }
                if !(1..=99).contains(&priority) =>
            {
                Err(format!("priority = {priority}: must be within 1 ..= 99"))
            }
            _ => Ok(()),
        }
    }

    /// Applies the policy to the calling thread. Only async-signal-safe calls (for `pre_exec`).
    pub fn apply(&self) -> io::Result<()> {
        let (policy, priority) = match *self {
            Scheduling::Other { nice } => {
                // SAFETY: setpriority is async-signal-safe; `0` is the calling process.
                if unsafe { libc::setpriority(libc::PRIO_PROCESS, 0, nice) } != 0 {
                    return Err(io::Error::last_os_error());
                }
                (libc::SCHED_OTHER, 0)
            }
            Scheduling::Fifo { priority } => (libc::SCHED_FIFO, priority),
            Scheduling::Rr { priority } => (libc::SCHED_RR, priority),
        };
        let param = libc::sched_param {
            sched_priority: priority,
        };
        // SAFETY: sched_setscheduler is async-signal-safe; `param` lives across the call.
        if unsafe { libc::sched_setscheduler(0, policy, &param) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }
}

/// The CPU set of `cpus`. Panics on an index above [`MAX_CPU`] (profiles are checked first).
pub fn cpu_set(cpus: &[usize]) -> libc::cpu_set_t {
    // SAFETY: an all-zero cpu_set_t is the empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &cpu in cpus {
        assert!(cpu <= MAX_CPU, "CPU {cpu} beyond CPU_SETSIZE");
        // SAFETY: `cpu` is below CPU_SETSIZE.
        unsafe { libc::CPU_SET(cpu, &mut set) };
    }
    set
}

/// Pins the calling thread to `set`. Async-signal-safe (for `pre_exec`).
pub fn apply_affinity(set: &libc::cpu_set_t) -> io::Result<()> {
    // SAFETY: `set` is a valid cpu_set_t of the size passed.
    if unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), set) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// The CPUs this process may run on (its own affinity), ascending.
pub fn available_cpus() -> io::Result<Vec<usize>> {
    // SAFETY: an all-zero cpu_set_t is valid; sched_getaffinity fills it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: `set` is a valid cpu_set_t of the size passed.
    if unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) } != 0
    {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: `set` was filled by the kernel; every index is below CPU_SETSIZE.
    Ok((0..=MAX_CPU)
        .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_are_checked() {
        assert!(Scheduling::Fifo { priority: 10 }.check().is_ok());
        assert!(Scheduling::Rr { priority: 0 }.check().is_err());
        assert!(Scheduling::Fifo { priority: 100 }.check().is_err());
        assert!(Scheduling::Other { nice: 19 }.check().is_ok());
        assert!(Scheduling::Other { nice: -21 }.check().is_err());
    }

    #[test]
    fn policies_parse_from_toml() {
        #[derive(Deserialize)]
        struct T {
            scheduling: Scheduling,
        }
        let t: T = toml::from_str("scheduling = { policy = \"fifo\", priority = 10 }").unwrap();
        assert_eq!(t.scheduling, Scheduling::Fifo { priority: 10 });
        let t: T = toml::from_str("scheduling = { policy = \"other\" }").unwrap();
        assert_eq!(t.scheduling, Scheduling::Other { nice: 0 });
        assert!(toml::from_str::<T>("scheduling = { policy = \"fifo\" }").is_err());
        assert!(toml::from_str::<T>("scheduling = { policy = \"deadline\" }").is_err());
    }

    #[test]
    fn this_process_has_at_least_one_cpu_and_the_set_round_trips() {
        let cpus = available_cpus().unwrap();
        assert!(!cpus.is_empty());
        let set = cpu_set(&cpus);
        // SAFETY: indices below CPU_SETSIZE.
        let back: Vec<usize> = (0..=MAX_CPU)
            .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
            .collect();
        assert_eq!(back, cpus);
    }
}
