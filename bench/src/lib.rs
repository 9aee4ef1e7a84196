//! Shared measurement helpers: repeat, take the median, compare ratios (these machines are
//! shared and noisy, so absolute times only mean something next to a baseline of the same run);
//! the latency harness of `latency` ([`latency`]); and the pipeline's speed and latency targets judged from their
//! reports ([`targets`]).

pub mod latency;
pub mod targets;

use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Median of `xs` (the upper one of an even count); NaN when empty.
pub fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs.get(xs.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The JSON report another build's benchmark `bin` prints for one repeat (`--json --repeats
/// 1`, then `args`): a baseline measured in turn with this build. An error naming the binary
/// when it fails or prints something else.
pub fn baseline_report(
    bin: &std::path::Path,
    args: &[String],
) -> anyhow::Result<serde_json::Value> {
    use anyhow::Context;
    let out = std::process::Command::new(bin)
        .args(["--json", "--repeats", "1"])
        .args(args)
        .output()
        .with_context(|| format!("running the baseline {}", bin.display()))?;
    anyhow::ensure!(
        out.status.success(),
        "the baseline {} failed: {}",
        bin.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout)
        .with_context(|| format!("the baseline {}'s output", bin.display()))
}

/// CPU time (user + system) of this process's waited-for descendants so far.
pub fn children_cpu() -> Duration {
    rusage_cpu(libc::RUSAGE_CHILDREN)
}

/// CPU time (user + system) of this process so far.
pub fn self_cpu() -> Duration {
    rusage_cpu(libc::RUSAGE_SELF)
}

fn rusage_cpu(who: libc::c_int) -> Duration {
    // SAFETY: getrusage writes into the zeroed struct we own.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(who, &mut usage) };
    let tv = |t: libc::timeval| Duration::new(t.tv_sec as u64, t.tv_usec as u32 * 1000);
    tv(usage.ru_utime) + tv(usage.ru_stime)
}

/// The directory of the running bench binary, where cargo also puts the workspace's binaries.
pub fn binary_dir() -> std::io::Result<PathBuf> {
    let exe = std::env::current_exe()?;
    exe.parent()
        .map(PathBuf::from)
        .ok_or_else(|| std::io::Error::other(format!("{} has no directory", exe.display())))
}

/// Median wall time of `repeats` calls of `f` (after one warm-up call).
pub fn median_time(repeats: usize, mut f: impl FnMut()) -> Duration {
    f();
    let mut times: Vec<Duration> = (0..repeats.max(1))
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}

/// The ids of the processes now running (the numeric entries of `/proc`); none where it
/// cannot be read.
pub fn proc_pids() -> Vec<u32> {
    std::fs::read_dir("/proc").map_or_else(
        |_| Vec::new(),
        |dir| {
            dir.flatten()
                .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
                .collect()
        },
    )
}
