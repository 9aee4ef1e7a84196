//! The few POSIX calls the supervisor needs, wrapped (Linux).
//!
//! The launcher blocks SIGINT, SIGTERM, SIGHUP and SIGCHLD in its only thread and takes them
//! synchronously with `sigtimedwait`: no signal handler, no self-pipe, no polling. Children
//! start with an empty signal mask ([`prepare_child`], between `fork` and `exec`: the mask is
//! inherited across both, and the standard library does not reset it) and default
//! dispositions ([`SignalSet::block`]).

use std::io;
use std::time::Duration;

pub use libc::{SIGCHLD, SIGHUP, SIGINT, SIGKILL, SIGTERM};

/// The signals the launcher waits for.
pub const WAITED: [libc::c_int; 4] = [SIGINT, SIGTERM, SIGHUP, SIGCHLD];

/// A blocked signal set, taken with [`SignalSet::wait`].
pub struct SignalSet {
    set: libc::sigset_t,
}

impl SignalSet {
    /// Blocks `signals` in the calling thread (call before starting any other thread) and
    /// resets their dispositions to the default.
    ///
    /// The reset matters for children, which inherit ignored dispositions across `exec`: a
    /// launcher started in the background of a non-interactive shell has SIGINT ignored, and
    /// its children would otherwise ignore the SIGINT it sends them. (A blocked signal is
    /// still taken by `sigtimedwait` on Linux even when ignored, but only while blocked.) A
    /// SIGCHLD left ignored would make the kernel reap children by itself.
    pub fn block(signals: &[libc::c_int]) -> io::Result<Self> {
        // SAFETY: sigemptyset/sigaddset initialise and fill the set; pthread_sigmask reads it.
        unsafe {
            let mut set: libc::sigset_t = std::mem::zeroed();
            if libc::sigemptyset(&mut set) != 0 {
                return Err(io::Error::last_os_error());
            }
            for &signal in signals {
                if libc::sigaddset(&mut set, signal) != 0 {
                    return Err(io::Error::last_os_error());
                }
            }
            let rc = libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
            if rc != 0 {
                return Err(io::Error::from_raw_os_error(rc));
            }
            for &signal in signals {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = libc::SIG_DFL;
                if libc::sigaction(signal, &action, std::ptr::null_mut()) != 0 {
                    return Err(io::Error::last_os_error());
                }
            }
            Ok(Self { set })
        }
    }

    /// Unblocks the signals again (their dispositions stay the default): for a program that
    /// takes them synchronously only for a while (`testbed run` while the launcher runs).
    pub fn unblock(&self) -> io::Result<()> {
        // SAFETY: the set is initialised; pthread_sigmask only reads it.
        let rc =
            unsafe { libc::pthread_sigmask(libc::SIG_UNBLOCK, &self.set, std::ptr::null_mut()) };
        if rc != 0 {
            return Err(io::Error::from_raw_os_error(rc));
        }
        Ok(())
    }

    /// Waits up to `timeout` (forever if `None`) for one of the signals; `None` on timeout or
    /// when interrupted by another signal.
    pub fn wait(&self, timeout: Option<Duration>) -> io::Result<Option<libc::c_int>> {
        // SAFETY: the set is initialised; info and timespec are valid for the call.
        let rc = unsafe {
            let mut info: libc::siginfo_t = std::mem::zeroed();
            match timeout {
                None => libc::sigwaitinfo(&self.set, &mut info),
                Some(t) => {
                    let ts = libc::timespec {
                        tv_sec: libc::time_t::try_from(t.as_secs()).unwrap_or(libc::time_t::MAX),
                        // Below 10^9: fits every c_long.
                        tv_nsec: t.subsec_nanos() as libc::c_long,
                    };
                    libc::sigtimedwait(&self.set, &mut info, &ts)
                }
            }
        };
        if rc >= 0 {
            return Ok(Some(rc));
        }
        let err = io::Error::last_os_error();
        match err.raw_os_error() {
            Some(libc::EAGAIN) | Some(libc::EINTR) => Ok(None),
            _ => Err(err),
        }
    }
}

/// How a child ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExitHow {
    /// `exit(code)`.
    Code(i32),
    /// Killed by a signal.
    Signal(i32),
}

impl ExitHow {
    /// Exit code 0.
    pub fn success(self) -> bool {
        self == Self::Code(0)
    }
}

impl std::fmt::Display for ExitHow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::Code(code) => write!(f, "exited with code {code}"),
            Self::Signal(signal) => write!(f, "was killed by signal {}", signal_name(signal)),
        }
    }
}

fn decode(status: libc::c_int) -> Option<ExitHow> {
    if libc::WIFEXITED(status) {
        Some(ExitHow::Code(libc::WEXITSTATUS(status)))
    } else if libc::WIFSIGNALED(status) {
        Some(ExitHow::Signal(libc::WTERMSIG(status)))
    } else {
        None
    }
}

/// Whether child `pid` has ended, without reaping it (it stays a zombie, so its pid and process
/// group id cannot be reused until [`reap`]).
pub fn has_exited(pid: libc::pid_t) -> io::Result<bool> {
    peek_ended(libc::P_PID, pid as libc::id_t)
}

/// Whether any child of this process has ended and waits to be reaped (without reaping it):
/// one system call where asking each child is one per child. `Ok(false)` also when there are
/// no children at all.
pub fn any_exited() -> io::Result<bool> {
    match peek_ended(libc::P_ALL, 0) {
        Err(e) if e.raw_os_error() == Some(libc::ECHILD) => Ok(false),
        other => other,
    }
}

/// `waitid(idtype, id)` for an ended child without reaping it: whether one is there.
fn peek_ended(idtype: libc::idtype_t, id: libc::id_t) -> io::Result<bool> {
    // SAFETY: waitid writes the siginfo it is given.
    unsafe {
        let mut info: libc::siginfo_t = std::mem::zeroed();
        let flags = libc::WEXITED | libc::WNOHANG | libc::WNOWAIT;
        if libc::waitid(idtype, id, &mut info, flags) != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(info.si_pid() != 0)
    }
}

/// CPU time a reaped child used over its life (its own threads plus the descendants it
/// waited for), as `wait4` reports it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CpuTime {
    /// User-mode CPU time, s.
    pub user_s: f64,
    /// Kernel-mode CPU time, s.
    pub system_s: f64,
}

impl CpuTime {
    /// User plus kernel time, s.
    pub fn total_s(self) -> f64 {
        self.user_s + self.system_s
    }
}

impl std::ops::AddAssign for CpuTime {
    fn add_assign(&mut self, other: Self) {
        self.user_s += other.user_s;
        self.system_s += other.system_s;
    }
}

fn seconds(t: libc::timeval) -> f64 {
    t.tv_sec as f64 + t.tv_usec as f64 * 1e-6
}

/// CPU time the calling process used so far (all its threads; not its children).
pub fn own_cpu() -> CpuTime {
    // SAFETY: getrusage writes into the zeroed struct we own.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) };
    CpuTime {
        user_s: seconds(usage.ru_utime),
        system_s: seconds(usage.ru_stime),
    }
}

/// Reaps child `pid` if it has ended: how it ended and the CPU time it used. `wait4` rather
/// than `waitpid` so the launcher can say which process of a run costs what, at no extra cost.
pub fn reap(pid: libc::pid_t) -> io::Result<Option<(ExitHow, CpuTime)>> {
    let mut status = 0;
    // SAFETY: wait4 writes the status and the zeroed rusage it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
    match rc {
        0 => Ok(None),
        r if r == pid => Ok(decode(status).map(|how| {
            (
                how,
                CpuTime {
                    user_s: seconds(usage.ru_utime),
                    system_s: seconds(usage.ru_stime),
                },
            )
        })),
        _ => Err(io::Error::last_os_error()),
    }
}

/// Reaps any ended child not reaped otherwise; `Ok(None)` when none has ended, and
/// `Err(ECHILD)` when there are no children at all.
pub fn reap_any() -> io::Result<Option<(libc::pid_t, Option<ExitHow>)>> {
    let mut status = 0;
    // SAFETY: waitpid writes the status it is given.
    let rc = unsafe { libc::waitpid(-1, &mut status, libc::WNOHANG) };
    match rc {
        0 => Ok(None),
        pid if pid > 0 => Ok(Some((pid, decode(status)))),
        _ => Err(io::Error::last_os_error()),
    }
}

/// Sends `signal` to the process group `pgid` (ESRCH, an empty group, is not an error).
pub fn signal_group(pgid: libc::pid_t, signal: libc::c_int) -> io::Result<()> {
    // SAFETY: plain killpg(2).
    if unsafe { libc::killpg(pgid, signal) } == 0 {
        return Ok(());
    }
    let err = io::Error::last_os_error();
    if err.raw_os_error() == Some(libc::ESRCH) {
        Ok(())
    } else {
        Err(err)
    }
}

/// Name of a signal number (`SIGTERM`), or `signal N`.
pub fn signal_name(signal: libc::c_int) -> String {
    let name = match signal {
        libc::SIGHUP => "SIGHUP",
        libc::SIGINT => "SIGINT",
        libc::SIGQUIT => "SIGQUIT",
        libc::SIGILL => "SIGILL",
        libc::SIGTRAP => "SIGTRAP",
        libc::SIGABRT => "SIGABRT",
        libc::SIGBUS => "SIGBUS",
        libc::SIGFPE => "SIGFPE",
        libc::SIGKILL => "SIGKILL",
        libc::SIGUSR1 => "SIGUSR1",
        libc::SIGSEGV => "SIGSEGV",
        libc::SIGUSR2 => "SIGUSR2",
        libc::SIGPIPE => "SIGPIPE",
        libc::SIGALRM => "SIGALRM",
        libc::SIGTERM => "SIGTERM",
        libc::SIGCHLD => "SIGCHLD",
        libc::SIGXCPU => "SIGXCPU",
        libc::SIGXFSZ => "SIGXFSZ",
        libc::SIGSYS => "SIGSYS",
        _ => return format!("signal {signal}"),
    };
    name.to_owned()
}

/// Sends SIGTERM to this process once `parent` is no longer its parent (it died, even by
/// SIGKILL), so that the run stops in order, as on a stop request. A thread sleeps in
/// `poll` on a pidfd of the parent, which becomes readable when the parent exits: no wake-up
/// until then (it used to check every 100 ms, ten wake-ups a second of a paced run's CPU).
/// Kernels without `pidfd_open` (before 5.3) get the check every 100 ms. Call after
/// [`SignalSet::block`] (the thread inherits the blocked mask, and the signal is taken by the
/// supervisor's wait).
///
/// Not `PR_SET_PDEATHSIG`: that fires when the parent *thread* exits, so a multi-threaded
/// parent (`testbed run` with its progress display) can send it once per thread, and the
/// supervisor takes a second stop signal as "kill everything at once".
pub fn stop_when_orphaned(parent: libc::pid_t) -> io::Result<()> {
    let orphaned = move || {
        // SAFETY: getppid has no preconditions.
        unsafe { libc::getppid() != parent }
    };
    let stop = || {
        // SAFETY: kill(2) on this very process.
        unsafe { libc::kill(libc::getpid(), SIGTERM) };
    };
    // SAFETY: pidfd_open takes a pid and flags; the result is a new descriptor or -1.
    let pidfd = unsafe { libc::syscall(libc::SYS_pidfd_open, parent, 0) } as libc::c_int;
    // Checked after the pidfd exists: a parent that died before it is seen here, one that
    // dies after it makes the pidfd readable.
    if orphaned() {
        if pidfd >= 0 {
            // SAFETY: our own descriptor, closed once.
            unsafe { libc::close(pidfd) };
        }
        stop();
        return Ok(());
    }
    std::thread::Builder::new()
        .name("parent-watch".into())
        .spawn(move || {
            if pidfd >= 0 {
                let mut fds = libc::pollfd {
                    fd: pidfd,
                    events: libc::POLLIN,
                    revents: 0,
                };
                // SAFETY: one valid pollfd; an infinite wait, retried when a signal
                // interrupts it.
                while unsafe { libc::poll(&mut fds, 1, -1) } < 0
                    && io::Error::last_os_error().kind() == io::ErrorKind::Interrupted
                {
                }
            }
            while !orphaned() {
                std::thread::sleep(Duration::from_millis(100));
            }
            stop();
        })?;
    Ok(())
}

/// For `pre_exec`: unblocks every signal, leaving the dispositions as they are (see
/// [`prepare_child`] for the launcher's own children).
pub fn unblock_all() -> io::Result<()> {
    // SAFETY: sigemptyset and sigprocmask are async-signal-safe.
    unsafe {
        let mut empty: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut empty);
        if libc::sigprocmask(libc::SIG_SETMASK, &empty, std::ptr::null_mut()) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

/// For `pre_exec`: unblocks every signal (the launcher's blocked set would otherwise be
/// inherited), makes the child get SIGTERM when the launcher dies (even by SIGKILL), and gives
/// up if the launcher is already gone. Only async-signal-safe calls.
pub fn prepare_child(parent: libc::pid_t) -> io::Result<()> {
    // SAFETY: sigemptyset, sigprocmask, prctl and getppid are async-signal-safe.
    unsafe {
        let mut empty: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut empty);
        if libc::sigprocmask(libc::SIG_SETMASK, &empty, std::ptr::null_mut()) != 0 {
            return Err(io::Error::last_os_error());
        }
        if libc::prctl(
            libc::PR_SET_PDEATHSIG,
            libc::SIGTERM as libc::c_ulong,
            0,
            0,
            0,
        ) != 0
        {
            return Err(io::Error::last_os_error());
        }
        if libc::getppid() != parent {
            return Err(io::Error::other(
                "the launcher exited while starting the process",
            ));
        }
    }
    Ok(())
}
