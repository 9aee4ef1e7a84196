//! What one wake-up of a sleeping process costs on this machine, with no bus at all: the floor
//! under the paced pipeline's CPU. Each case runs a process that sleeps and wakes
//! `--wakes` times, one wake-up every `--period-ms` (the pipeline's 10 Hz by default), and
//! reports the CPU (user + system, `getrusage`) per wake-up:
//!
//! - `timer`: the process sleeps on a timer (`nanosleep`), as the plant's pacing interval, the
//!   logger's drain and the launcher's look do;
//! - `futex`: the process waits on a futex word in shared memory and another process, itself
//!   woken by a timer, rings it (`FUTEX_WAKE`), as a publisher rings a subscriber's doorbell;
//!   the ringer's cost beyond its own timer wake-up is the price of waking someone.
//!
//! `cargo run --release -p testbed-bench --bin wake_cost [-- --wakes 100 --period-ms 100 --repeats 3]`

use anyhow::Context as _;
use clap::Parser;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;
use testbed_bench::median;

#[derive(Parser)]
struct Args {
    /// Wake-ups per case and repeat.
    #[arg(long, default_value_t = 100)]
    wakes: u32,
    /// Time between wake-ups, ms.
    #[arg(long, default_value_t = 100)]
    period_ms: u64,
    /// Repeats of each case (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Internal: run as the futex-waiting child on this shared-memory file.
    #[arg(long, hide = true)]
    waiter: Option<std::path::PathBuf>,
    #[arg(long)]
    json: bool,
}

/// CPU time (user + system) this process has used so far, µs.
fn cpu_us() -> f64 {
    testbed_bench::self_cpu().as_secs_f64() * 1e6
}

/// A futex word in a shared file mapping (both processes map the same file).
struct SharedWord {
    ptr: *mut AtomicU32,
}

impl SharedWord {
    fn map(path: &std::path::Path) -> anyhow::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .with_context(|| format!("opening {}", path.display()))?;
        file.set_len(4096)?;
        use std::os::fd::AsRawFd as _;
        // SAFETY: a shared read-write mapping of a 4096-byte file; the mapping outlives the
        // file descriptor (closed on return) and is never unmapped.
        let ptr = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                4096,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        anyhow::ensure!(ptr != libc::MAP_FAILED, "mmap of {}", path.display());
        Ok(Self { ptr: ptr.cast() })
    }

    fn word(&self) -> &AtomicU32 {
        // SAFETY: the mapping is page-aligned, lives for the process and holds an AtomicU32.
        unsafe { &*self.ptr }
    }

    fn wait(&self, seen: u32, timeout: Duration) {
        let ts = libc::timespec {
            tv_sec: timeout.as_secs() as libc::time_t,
            tv_nsec: timeout.subsec_nanos() as libc::c_long,
        };
        // SAFETY: FUTEX_WAIT reads the aligned word and the timespec.
        unsafe {
            libc::syscall(
                libc::SYS_futex,
                self.ptr,
                libc::FUTEX_WAIT,
                seen,
                &ts as *const libc::timespec,
                std::ptr::null::<u32>(),
                0,
            );
        }
    }

    fn wake(&self) {
        // SAFETY: FUTEX_WAKE on the aligned word; it writes nothing.
        unsafe {
            libc::syscall(libc::SYS_futex, self.ptr, libc::FUTEX_WAKE, 1, 0, 0, 0);
        }
    }
}

/// The futex-waiting child: waits for `wakes` rings (a 1 s timeout per wait, as the pipeline's
/// processes wait with a liveness timeout) and prints its CPU per wake-up.
fn waiter(path: &std::path::Path, wakes: u32) -> anyhow::Result<()> {
    let shared = SharedWord::map(path)?;
    let mut seen = shared.word().load(Ordering::SeqCst);
    let start = cpu_us();
    let mut woken = 0;
    while woken < wakes {
        let now = shared.word().load(Ordering::SeqCst);
        if now != seen {
            woken += now.wrapping_sub(seen);
            seen = now;
            continue;
        }
        shared.wait(seen, Duration::from_secs(1));
    }
    println!("{}", (cpu_us() - start) / f64::from(wakes));
    Ok(())
}

/// CPU per wake-up of a process sleeping `wakes` times on a timer, µs.
fn timer_case(wakes: u32, period: Duration) -> f64 {
    let start = cpu_us();
    for _ in 0..wakes {
        std::thread::sleep(period);
    }
    (cpu_us() - start) / f64::from(wakes)
}

/// The futex case: (the waiter's CPU per wake-up, the ringer's CPU per period), µs.
fn futex_case(wakes: u32, period: Duration) -> anyhow::Result<(f64, f64)> {
    let path = std::env::temp_dir().join(format!("wake_cost.{}", std::process::id()));
    let shared = SharedWord::map(&path)?;
    let child = std::process::Command::new(std::env::current_exe()?)
        .arg("--waiter")
        .arg(&path)
        .arg("--wakes")
        .arg(wakes.to_string())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .context("starting the waiter")?;
    // Let the waiter map the word and go to sleep before the first ring.
    std::thread::sleep(Duration::from_millis(300));
    let start = cpu_us();
    for _ in 0..wakes {
        std::thread::sleep(period);
        shared.word().fetch_add(1, Ordering::SeqCst);
        shared.wake();
    }
    let ringer = (cpu_us() - start) / f64::from(wakes);
    let output = child.wait_with_output()?;
    let _ = std::fs::remove_file(&path);
    anyhow::ensure!(output.status.success(), "the waiter failed");
    let waiter: f64 = String::from_utf8_lossy(&output.stdout)
        .trim()
        .parse()
        .context("the waiter's report")?;
    Ok((waiter, ringer))
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if let Some(path) = &args.waiter {
        return waiter(path, args.wakes);
    }
    anyhow::ensure!(
        args.wakes > 0 && args.repeats > 0,
        "--wakes and --repeats must be > 0"
    );
    let period = Duration::from_millis(args.period_ms);
    let (mut timer, mut woken, mut ringer) = (Vec::new(), Vec::new(), Vec::new());
    // Alternated, so both cases see the same machine.
    for _ in 0..args.repeats {
        timer.push(timer_case(args.wakes, period));
        let (w, r) = futex_case(args.wakes, period)?;
        woken.push(w);
        ringer.push(r);
    }
    let (timer, woken, ringer) = (median(timer), median(woken), median(ringer));
    let per_second = 1000.0 / args.period_ms as f64;
    // µs per wake-up × wake-ups per second / 1e6 s, in % of one core.
    let share = |us: f64| us * per_second * 1e-4;
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "period_ms": args.period_ms, "wakes": args.wakes, "repeats": args.repeats,
                "timer_wake_us": timer, "futex_wake_us": woken,
                "ringing_us": ringer - timer,
            })
        );
        return Ok(());
    }
    println!(
        "CPU per wake-up, medians of {} repeats of {} wake-ups every {} ms:",
        args.repeats, args.wakes, args.period_ms
    );
    println!(
        "  woken by a timer          {timer:7.1} µs  ({:.3} % of a core at this rate)",
        share(timer)
    );
    println!(
        "  woken by a futex ring     {woken:7.1} µs  ({:.3} %)",
        share(woken)
    );
    println!(
        "  ringing a sleeper         {:7.1} µs  (the ringer's CPU beyond its own timer wake-up)",
        ringer - timer
    );
    Ok(())
}
