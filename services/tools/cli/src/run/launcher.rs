//! Starting the launcher for `testbed run` and staying with it to the end: signals forwarded,
//! the run's private bus, the log's lock, the orphans a dead launcher leaves.

use crate::progress;
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::Command;
use testbed_config::RunConfig;
use testbed_launch::profile::Profile;

/// Settings of `testbed run` passed on to the launcher over the profile's.
pub(super) struct LauncherOverrides {
    /// `--max-wall-s`, s.
    pub max_wall_s: Option<f64>,
    /// `--cpu-latency-us`, µs.
    pub cpu_latency_us: Option<u32>,
    /// `--unplaced`.
    pub unplaced: bool,
}

/// Start the launcher (this executable as `testbed-launch`) on the profile and wait for it;
/// with `check`, only its dry run (`--check`: profile, roles, start order).
///
/// While the launcher runs, this process takes SIGINT, SIGTERM and SIGHUP and forwards them to
/// it (the launcher then stops the pipeline and finalises the log); the launcher stops the run
/// as on SIGTERM if this process dies (`--exit-with-parent`), and its own children get SIGTERM
/// when it dies (PR_SET_PDEATHSIG), so the pipeline never outlives `testbed`. This process is
/// the pipeline's subreaper: it waits for every process of the run, even those a killed
/// launcher orphaned, before removing the bus.
pub(super) fn launch(
    profile: &Path,
    config: &RunConfig,
    config_path: Option<&Path>,
    overrides: &LauncherOverrides,
    check: bool,
    follow: Option<progress::Follow>,
    run_lock: Option<&RunLock>,
) -> Result<()> {
    use testbed_launch::roles::{LAUNCHER, RoleLinks, links_dir};
    // Buses of earlier runs whose `testbed` and launcher died (SIGKILL, crash) are collected
    // first.
    let collected = testbed_bus::collect_dead_runs(Path::new(BUS_BASE), BUS_TAG);
    for failed in &collected.failed {
        eprintln!("warning: cannot remove the bus of a dead earlier run: {failed}");
    }
    // One private bus per run: a fresh directory (mode 0700, unpredictable name) as the root,
    // its name as the prefix of every shared-memory file (short: Unix socket paths < 108 bytes).
    let private = RemovedOnDrop(
        testbed_bus::PrivateRun::create(Path::new(BUS_BASE), BUS_TAG)
            .context("creating the run's private bus directory")?,
    );
    let bus = &private.0.bus;
    // The launcher is this executable in its role (see `crate::main`), started through a link
    // named after it, in the directory where it makes the links of the pipeline's roles.
    let exe = std::env::current_exe().context("locating the testbed executable")?;
    let links = RoleLinks::create(&links_dir(bus), &exe, [LAUNCHER])
        .context("making the link the launcher is started by")?;
    let launcher = links.path(LAUNCHER);
    let mut command = Command::new(&launcher);
    if std::env::var_os("RUST_LOG").is_none() {
        // The summary is the output; the processes speak up only for warnings.
        command.env("RUST_LOG", "warn");
    }
    command
        .arg(profile)
        .args(["--mode", config.run.mode.as_str()])
        .args(["--duration-s", &config.run.duration_s.to_string()])
        .args(["--seed", &config.run.seed.to_string()])
        .arg("--log")
        .arg(&config.run.log)
        .args(["--bus-prefix", &bus.prefix])
        .arg("--bus-root")
        .arg(&bus.root);
    if let Some(path) = config_path {
        command.arg("--config").arg(path);
    }
    if let Some(s) = overrides.max_wall_s {
        command.args(["--max-wall-s", &s.to_string()]);
    }
    if let Some(us) = overrides.cpu_latency_us {
        command.args(["--cpu-latency-us", &us.to_string()]);
    }
    if overrides.unplaced {
        command.arg("--unplaced");
    }
    if check {
        command.arg("--check");
        let status = command
            .status()
            .with_context(|| format!("starting {}", launcher.display()))?;
        if !status.success() {
            bail!("the check failed ({status}); the launcher's messages above say what is wrong");
        }
        return Ok(());
    }
    // The ground link: a command token for this run unless one is configured, and the address
    // it serves printed once it listens.
    let ground_info = Profile::load(profile)
        .ok()
        .filter(|p| p.processes.iter().any(|p| p.command == "ground-link"))
        .map(|_| config.run.log.with_extension("ground.json"));
    if let Some(info) = &ground_info {
        let _ = std::fs::remove_file(info);
        if config.ground.token.is_none() {
            command.env(
                testbed_config::ENV_GROUND_TOKEN,
                testbed_config::random_token().context("making the ground command token")?,
            );
        }
    }
    let status = supervise_launcher(&mut command, &launcher, follow, run_lock, ground_info)?;
    if !status.success() {
        bail!(
            "the pipeline failed ({status}); the launcher's messages above say which process and how"
        );
    }
    Ok(())
}

/// A run's private bus, removed when dropped: every process of the run has been reaped by then,
/// and nothing is left in `/dev/shm` or the bus root (the launcher removed it already, unless
/// it died).
struct RemovedOnDrop(testbed_bus::PrivateRun);

impl Drop for RemovedOnDrop {
    fn drop(&mut self) {
        if let Err(e) = self.0.remove() {
            eprintln!("warning: removing the run's iceoryx2 resources: {e}");
        }
    }
}

/// Waits (up to a minute) for the ground link's `<log>.ground.json` and prints the ground
/// page's address and the command token on stderr.
fn print_ground_info(info: &Path) {
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_secs(60) {
        if let Some(v) = std::fs::read(info)
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        {
            let field = |k: &str| v[k].as_str().unwrap_or("?").to_owned();
            eprintln!(
                "ground station: {}  (Foxglove WebSocket {}; command token {})",
                field("url"),
                field("ws"),
                field("token")
            );
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
}

/// Directory of the runs' private bus roots, and the start of their names (`/tmp/tb<pid>_…`).
const BUS_BASE: &str = "/tmp";
const BUS_TAG: &str = "tb";
/// How long the processes a dead launcher left get to end (they got SIGTERM) before SIGKILL.
const ORPHAN_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// Starts the launcher, forwards stop signals to it, waits for it and then for every process
/// it left (see [`launch`]).
fn supervise_launcher(
    command: &mut Command,
    launcher: &Path,
    follow: Option<progress::Follow>,
    run_lock: Option<&RunLock>,
    ground_info: Option<PathBuf>,
) -> Result<std::process::ExitStatus> {
    use std::os::unix::process::CommandExt as _;
    use testbed_launch::sys::{self, SignalSet};
    // SAFETY: prctl(PR_SET_CHILD_SUBREAPER) only changes this process's attributes.
    if unsafe { libc::prctl(libc::PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) } != 0 {
        eprintln!(
            "warning: cannot become the pipeline's subreaper: {}",
            std::io::Error::last_os_error()
        );
    }
    // Before any thread exists (the progress display starts below): signals are taken
    // synchronously; the launcher gets an empty mask (prepare_child).
    let signals = SignalSet::block(&[sys::SIGINT, sys::SIGTERM, sys::SIGHUP, sys::SIGCHLD])
        .context("blocking the stop signals")?;
    // SAFETY: getpid has no preconditions.
    let parent = unsafe { libc::getpid() };
    let lock_fd = run_lock.map(RunLock::raw_fd);
    // The launcher stops the run when this process dies (even by SIGKILL); see
    // sys::stop_when_orphaned for why not PR_SET_PDEATHSIG.
    command.args(["--exit-with-parent", &parent.to_string()]);
    // SAFETY: the closure makes only async-signal-safe calls (sigprocmask, fcntl).
    unsafe {
        command.pre_exec(move || {
            sys::unblock_all()?;
            if let Some(fd) = lock_fd {
                // Inherited across exec by the launcher and its children: the run keeps the
                // log locked until its last process is gone, even if this one dies first.
                if libc::fcntl(fd, libc::F_SETFD, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
            }
            Ok(())
        });
    }
    // Own process group: a Ctrl-C in the terminal reaches this process only, which forwards it
    // once (the launcher takes a second stop signal as "kill the rest at once").
    command.process_group(0);
    let mut child = match command.spawn() {
        Ok(child) => child,
        Err(e) => {
            let _ = signals.unblock();
            return Err(e).with_context(|| format!("starting {}", launcher.display()));
        }
    };
    let launcher_pid = libc::pid_t::try_from(child.id()).unwrap_or(libc::pid_t::MAX);
    let progress = follow.map(progress::Progress::start);
    if let Some(info) = ground_info {
        // Detached: it ends by itself once it printed, or after a minute.
        let _ = std::thread::Builder::new()
            .name("ground-info".into())
            .spawn(move || print_ground_info(&info));
    }
    let status = loop {
        // SIGCHLD ends the wait as soon as the launcher exits: every thread of this process
        // blocks it (the mask is set before any thread starts), so it stays pending until this
        // wait takes it. The timeout is only a fallback, and long: each wake-up of this loop is
        // CPU of the run (a paced run's whole pipeline is some 0.6 % of a core).
        match signals.wait(Some(std::time::Duration::from_secs(10))) {
            Ok(Some(signal)) if signal != sys::SIGCHLD => {
                // SAFETY: kill(2) on our own child, not yet reaped (its pid cannot be reused).
                unsafe { libc::kill(launcher_pid, signal) };
            }
            Ok(_) => {}
            Err(e) => eprintln!("warning: waiting for signals: {e}"),
        }
        match child.try_wait() {
            Ok(Some(status)) => break Ok(status),
            Ok(None) => {}
            Err(e) => break Err(e),
        }
    };
    wait_for_orphans();
    if let Some(progress) = progress {
        progress.finish();
    }
    let _ = signals.unblock();
    status.with_context(|| format!("waiting for {}", launcher.display()))
}

/// Reaps the processes a dead launcher left (reparented to this subreaper; they got SIGTERM
/// from PR_SET_PDEATHSIG), killing those still running after [`ORPHAN_WAIT`].
fn wait_for_orphans() {
    let deadline = std::time::Instant::now() + ORPHAN_WAIT;
    let mut killed = false;
    loop {
        let mut status = 0;
        // SAFETY: waitpid writes the status it is given.
        let pid = unsafe { libc::waitpid(-1, &mut status, libc::WNOHANG) };
        match pid {
            p if p > 0 => continue,
            0 => {}
            _ => return, // ECHILD: no child left
        }
        if !killed && std::time::Instant::now() >= deadline {
            for orphan in own_children() {
                eprintln!("warning: pipeline process {orphan} did not stop; killing it");
                // SAFETY: kill(2) on our own child, not yet reaped (its pid cannot be reused).
                unsafe { libc::kill(orphan, libc::SIGKILL) };
            }
            killed = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// The pids whose parent is this process (from /proc).
fn own_children() -> Vec<libc::pid_t> {
    let me = std::process::id().to_string();
    std::fs::read_dir("/proc")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<libc::pid_t>().ok())
        .filter(|pid| {
            // /proc/<pid>/stat: "pid (comm) state ppid ..."; comm may hold spaces and ')'.
            std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
                stat.rsplit_once(')')
                    .and_then(|(_, rest)| rest.split_whitespace().nth(1).map(|p| p == me))
                    .unwrap_or(false)
            })
        })
        .collect()
}

/// The lock of one run on its log: an exclusive `flock` on the run configuration file beside
/// the log (`<log>.run.toml`), which every run writes anyway, so no extra file is left.
pub struct RunLock {
    file: std::fs::File,
}

impl RunLock {
    /// Locks `config_path` (creating it, not truncating it yet); refuses, naming the log, when
    /// another run holds it.
    pub(super) fn acquire(config_path: &Path, log: &Path) -> Result<Self> {
        use std::os::fd::AsRawFd as _;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(config_path)
            .with_context(|| format!("opening the run configuration {}", config_path.display()))?;
        // SAFETY: flock on a file descriptor this function owns.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
                bail!(
                    "another testbed run is using the log {} (its run configuration {} is locked): wait for it to end, or give this run another --log",
                    log.display(),
                    config_path.display()
                );
            }
            return Err(e).with_context(|| format!("locking {}", config_path.display()));
        }
        Ok(Self { file })
    }

    /// Replaces the file's content (the lock stays: same open file).
    pub(super) fn write(&self, bytes: &[u8]) -> std::io::Result<()> {
        use std::io::Write as _;
        let mut file = &self.file;
        file.set_len(0)?;
        std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(0))?;
        file.write_all(bytes)
    }

    fn raw_fd(&self) -> libc::c_int {
        use std::os::fd::AsRawFd as _;
        self.file.as_raw_fd()
    }
}
