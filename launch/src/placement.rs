//! Where and how a process runs: its CPU affinity and scheduling policy (`cpus`,
//! `scheduling` of a `[[process]]`), applied by the launcher between `fork` and `exec`; and
//! how fast an idle CPU wakes (`[platform] cpu_latency_us`), held by the launcher for the run.
//!
//! A real-time policy (`fifo`, `rr`) needs `CAP_SYS_NICE` (or root); without it the process
//! does not start and the launcher names it with the system's error. Threads the process
//! creates later inherit both settings.

use serde::Deserialize;
use std::io::{self, Read as _, Write as _};
use std::path::Path;

/// The kernel's PM QoS CPU latency interface (`Documentation/power/pm_qos_interface.rst`).
pub const CPU_LATENCY_DEVICE: &str = "/dev/cpu_dma_latency";
/// Largest request the kernel takes, µs (its default value: no constraint).
pub const MAX_CPU_LATENCY_US: u32 = 2_000_000_000;

/// A PM QoS CPU latency request, in force while this value lives: no idle CPU enters an idle
/// state that takes longer than the request to leave. With `0` an idle CPU polls for work
/// instead of halting, so waking a sleeping process skips the halted CPU's wake-up (on a
/// virtual machine, an exit to the hypervisor and an inter-processor interrupt) at the price of
/// the idle CPUs' power. The request ends when the file is closed, also when the process dies.
#[derive(Debug)]
pub struct CpuLatencyRequest {
    /// Open for the request's lifetime: closing it ends the request.
    _file: std::fs::File,
    latency_us: u32,
}

impl CpuLatencyRequest {
    /// Requests at most `latency_us` of idle-state exit latency (`/dev/cpu_dma_latency`, which
    /// needs root). Errors name the device and the system's reason.
    pub fn hold(latency_us: u32) -> io::Result<Self> {
        Self::hold_at(Path::new(CPU_LATENCY_DEVICE), latency_us)
    }

    /// As [`hold`](Self::hold), on `device` instead of [`CPU_LATENCY_DEVICE`] (tests; a
    /// system with the interface elsewhere).
    pub fn hold_at(device: &Path, latency_us: u32) -> io::Result<Self> {
        let context = |e: io::Error| {
            io::Error::new(
                e.kind(),
                format!(
                    "requesting CPU latency {latency_us} µs on {}: {e}",
                    device.display()
                ),
            )
        };
        // The kernel reads a native-endian s32 (the bound fits one).
        let value = i32::try_from(latency_us)
            .ok()
            .filter(|_| latency_us <= MAX_CPU_LATENCY_US)
            .ok_or_else(|| {
                context(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("at most {MAX_CPU_LATENCY_US} µs"),
                ))
            })?;
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .open(device)
            .map_err(context)?;
        file.write_all(&value.to_ne_bytes()).map_err(context)?;
        Ok(Self {
            _file: file,
            latency_us,
        })
    }

    /// The latency requested, µs.
    pub fn latency_us(&self) -> u32 {
        self.latency_us
    }
}

/// The CPU latency in force now, µs: the smallest request any process holds (the kernel's
/// default, [`MAX_CPU_LATENCY_US`], when none does). Needs read access to the device.
pub fn cpu_latency_in_force_us() -> io::Result<u32> {
    let mut value = [0u8; 4];
    std::fs::File::open(CPU_LATENCY_DEVICE)?.read_exact(&mut value)?;
    u32::try_from(i32::from_ne_bytes(value)).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{CPU_LATENCY_DEVICE}: {e}"),
        )
    })
}

/// Largest CPU index a `cpus` list may name (the kernel's `CPU_SETSIZE` minus one).
pub const MAX_CPU: usize = 1023;

/// Where a process may run: `cpus` of a `[[process]]`, either CPU indices or a role that the
/// launcher turns into CPUs when the run starts ([`CpuRoles`]), so that one profile places
/// its processes on any machine.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(try_from = "RawCpus")]
pub enum Cpus {
    /// These CPUs (`cpus = [0, 1]`).
    List(Vec<usize>),
    /// The run's hot-path CPU (`cpus = "hot-path"`): the processes of a tick, which wake one
    /// another in turn, share one CPU, so each wake-up lands on a CPU that is already awake.
    HotPath,
    /// Every CPU the launcher may use but the hot path's (`cpus = "background"`; the hot
    /// path's too on a machine with one CPU): the logger and the ground link, which work beside
    /// the ticks rather than in them.
    Background,
}

impl Cpus {
    /// The names a role may be written with.
    pub const ROLES: [&str; 2] = ["hot-path", "background"];

    /// The CPUs this means on a machine whose CPUs are shared out as `roles`.
    pub fn resolve(&self, roles: &CpuRoles) -> Vec<usize> {
        match self {
            Cpus::List(cpus) => cpus.clone(),
            Cpus::HotPath => vec![roles.hot_path()],
            Cpus::Background => roles.background(),
        }
    }
}

/// `cpus` as written: a list of indices or a role's name.
#[derive(Deserialize)]
#[serde(untagged)]
enum RawCpus {
    List(Vec<usize>),
    Role(String),
}

impl TryFrom<RawCpus> for Cpus {
    type Error = String;

    fn try_from(raw: RawCpus) -> Result<Self, String> {
        match raw {
            RawCpus::List(cpus) => Ok(Cpus::List(cpus)),
            RawCpus::Role(role) => match role.as_str() {
                "hot-path" => Ok(Cpus::HotPath),
                "background" => Ok(Cpus::Background),
                other => Err(format!(
                    "cpus = {other:?}: expected a list of CPU indices or one of {:?}",
                    Cpus::ROLES
                )),
            },
        }
    }
}

/// How a run shares out the CPUs the launcher may use: one for the hot path, the others for
/// the background.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CpuRoles {
    /// The CPUs the launcher may use, ascending.
    available: Vec<usize>,
    /// The hot path's CPU, one of `available`.
    hot_path: usize,
}

impl CpuRoles {
    /// Shares out `available` (ascending, as [`available_cpus`] gives them): the hot path on
    /// `hot_path` (`[platform] hot_path_cpu`), by default the first available CPU. `Err` names
    /// a `hot_path` that is not available.
    pub fn new(available: Vec<usize>, hot_path: Option<usize>) -> Result<Self, String> {
        let hot_path = match hot_path {
            Some(cpu) if available.contains(&cpu) => cpu,
            Some(cpu) => {
                return Err(format!(
                    "CPU {cpu} is not one this launcher may use (CPUs {available:?})"
                ));
            }
            None => *available
                .first()
                .ok_or_else(|| "this launcher may use no CPU".to_string())?,
        };
        Ok(Self {
            available,
            hot_path,
        })
    }

    /// The CPUs the launcher may use.
    pub fn available(&self) -> &[usize] {
        &self.available
    }

    /// The hot path's CPU.
    pub fn hot_path(&self) -> usize {
        self.hot_path
    }

    /// The background's CPUs: every available CPU but the hot path's, or the hot path's alone
    /// when it is the only one.
    pub fn background(&self) -> Vec<usize> {
        match self.available.as_slice() {
            [only] => vec![*only],
            all => all
                .iter()
                .copied()
                .filter(|&c| c != self.hot_path)
                .collect(),
        }
    }
}

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
    fn a_cpu_latency_request_is_in_force_while_held() {
        // Needs root (the device is root-only); CI runs as root. No other test of this crate
        // holds a request, so the value seen is this test's (or a stricter one of another
        // program on the machine, which would make the first check pass and the second fail).
        let request = match CpuLatencyRequest::hold(7) {
            Ok(r) => r,
            Err(e) if e.kind() == io::ErrorKind::PermissionDenied => {
                eprintln!("skipped: {e}");
                return;
            }
            Err(e) => panic!("{e}"),
        };
        assert_eq!(request.latency_us(), 7);
        assert!(cpu_latency_in_force_us().unwrap() <= 7);
        drop(request);
        assert!(
            cpu_latency_in_force_us().unwrap() > 7,
            "the request should end with its file"
        );
    }

    #[test]
    fn a_cpu_latency_request_names_the_device_it_could_not_open() {
        let missing = Path::new("/nonexistent/cpu_dma_latency");
        let e = CpuLatencyRequest::hold_at(missing, 0).unwrap_err();
        assert!(
            e.to_string().contains("/nonexistent/cpu_dma_latency"),
            "{e}"
        );
        let e = CpuLatencyRequest::hold_at(missing, MAX_CPU_LATENCY_US + 1).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{e}");
    }

    #[test]
    fn roles_share_out_the_available_cpus() {
        let roles = CpuRoles::new(vec![0, 1, 2, 3], None).unwrap();
        assert_eq!(roles.hot_path(), 0);
        assert_eq!(roles.background(), vec![1, 2, 3]);
        assert_eq!(Cpus::HotPath.resolve(&roles), vec![0]);
        assert_eq!(Cpus::Background.resolve(&roles), vec![1, 2, 3]);
        assert_eq!(Cpus::List(vec![3]).resolve(&roles), vec![3]);
        // A launcher confined to some CPUs (a cpuset, taskset) shares out those.
        let roles = CpuRoles::new(vec![2, 5], Some(5)).unwrap();
        assert_eq!((roles.hot_path(), roles.background()), (5, vec![2]));
        // One CPU: the background shares it.
        let roles = CpuRoles::new(vec![3], None).unwrap();
        assert_eq!((roles.hot_path(), roles.background()), (3, vec![3]));
        let e = CpuRoles::new(vec![0, 1], Some(4)).unwrap_err();
        assert!(e.contains("CPU 4") && e.contains("[0, 1]"), "{e}");
        assert!(CpuRoles::new(vec![], None).is_err());
    }

    #[test]
    fn cpus_parse_as_a_list_or_a_role() {
        #[derive(Debug, Deserialize)]
        struct T {
            cpus: Cpus,
        }
        let parse = |text: &str| toml::from_str::<T>(text).map(|t| t.cpus);
        assert_eq!(parse("cpus = [0, 2]").unwrap(), Cpus::List(vec![0, 2]));
        assert_eq!(parse("cpus = \"hot-path\"").unwrap(), Cpus::HotPath);
        assert_eq!(parse("cpus = \"background\"").unwrap(), Cpus::Background);
        let e = parse("cpus = \"hotpath\"").unwrap_err().to_string();
        assert!(e.contains("\"hotpath\"") && e.contains("hot-path"), "{e}");
        assert!(parse("cpus = 1").is_err());
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
