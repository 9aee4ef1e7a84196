//! Stand-in for the `testbed` executable in the launcher's tests (not part of the pipeline):
//! started under the launcher's name (`testbed-launch`, through a link) it is the launcher, with
//! one role, `launch-test-child`, which is this stand-in child.
//!
//! Runs for `--sleep-s` seconds (forever without it), then exits with `--exit` (default 0) or
//! dies by signal `--die-by`. On SIGINT/SIGTERM it exits 0 at once, like a pipeline process,
//! unless `--ignore-signals` makes it ignore both (only SIGKILL ends it then).
//! Prints `<name>: ready` on stderr once its signal handling is set up.
//! `--mark FILE` appends `<TESTBED_PROCESS_NAME> <pid>` to FILE at start; `--env-out FILE`
//! writes the `TESTBED_*` and `RUST_LOG` variables it got; `--open-bus` opens an iceoryx2 node
//! (named after the process) on the run's bus and keeps it open; `--running` also says
//! `Running` in its heartbeat (a process past its start-up, for the restart rule).

use std::io::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Parser;
use testbed_launch::sys::{self, SignalSet};

#[derive(Debug, Parser)]
struct Args {
    #[arg(long)]
    sleep_s: Option<f64>,
    #[arg(long, default_value_t = 0)]
    exit: u8,
    #[arg(long)]
    die_by: Option<i32>,
    #[arg(long)]
    ignore_signals: bool,
    #[arg(long)]
    mark: Option<PathBuf>,
    #[arg(long)]
    env_out: Option<PathBuf>,
    #[arg(long)]
    open_bus: bool,
    #[arg(long)]
    running: bool,
}

/// One line on stderr in a single write, so that it does not interleave with the launcher's.
fn say(line: &str) {
    let _ = std::io::stderr().write_all(format!("{line}\n").as_bytes());
}

/// The stand-in child's one role.
const CHILD: &str = "launch-test-child";

fn main() -> std::process::ExitCode {
    if testbed_launch::roles::invoked_as().as_deref() == Some(testbed_launch::roles::LAUNCHER) {
        return testbed_launch::main(&[CHILD]);
    }
    std::process::Termination::report(child())
}

fn child() -> anyhow::Result<()> {
    let args = Args::parse();
    let signals = if args.ignore_signals {
        // SAFETY: setting dispositions to SIG_IGN before any thread exists.
        unsafe {
            libc::signal(libc::SIGINT, libc::SIG_IGN);
            libc::signal(libc::SIGTERM, libc::SIG_IGN);
        }
        None
    } else {
        Some(SignalSet::block(&[sys::SIGINT, sys::SIGTERM]).context("blocking signals")?)
    };
    let name = std::env::var("TESTBED_PROCESS_NAME").unwrap_or_else(|_| "?".to_owned());
    // Tests wait for this line before signalling: until now SIGINT would still kill us.
    say(&format!("{name}: ready"));
    if let Some(path) = &args.mark {
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("opening {}", path.display()))?;
        writeln!(file, "{name} {}", std::process::id()).context("writing the mark")?;
    }
    if let Some(path) = &args.env_out {
        let mut vars: Vec<String> = std::env::vars()
            .filter(|(k, _)| k.starts_with("TESTBED_") || k == "RUST_LOG")
            .map(|(k, v)| format!("{k}={v}\n"))
            .collect();
        vars.sort();
        std::fs::write(path, vars.concat())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let bus = if args.open_bus || args.running {
        let config = testbed_bus::BusConfig::from_env().context("bus configuration")?;
        let bus = testbed_bus::Bus::open(&name, &config).context("opening the bus")?;
        let heartbeat = bus.heartbeat(Duration::from_secs(1)).context("heartbeat")?;
        if args.running {
            heartbeat.set_state(ipc_types::ProcessState::Running);
        }
        heartbeat.publish().context("publishing a heartbeat")?;
        say(&format!("{name}: bus open"));
        Some((bus, heartbeat))
    } else {
        None
    };
    let deadline = args
        .sleep_s
        .map(|s| Instant::now() + Duration::from_secs_f64(s));
    loop {
        let left = deadline.map(|d| d.saturating_duration_since(Instant::now()));
        if left.is_some_and(|l| l.is_zero()) {
            break;
        }
        match &signals {
            Some(set) => {
                if let Some(signal) = set.wait(left).context("waiting")? {
                    say(&format!(
                        "{name}: {} received, exiting",
                        sys::signal_name(signal)
                    ));
                    return Ok(());
                }
            }
            None => std::thread::sleep(left.unwrap_or(Duration::from_secs(3600))),
        }
    }
    drop(bus);
    if let Some(signal) = args.die_by {
        // SAFETY: restoring the default action and raising the signal on ourselves.
        unsafe {
            libc::signal(signal, libc::SIG_DFL);
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, signal);
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
            libc::raise(signal);
        }
    }
    std::process::exit(i32::from(args.exit));
}
