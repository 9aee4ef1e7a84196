//! Size and finish time of a run log, the indexed layout against its baseline, in one run on
//! the same records: a finished log's records (e.g. a 3000-s lockstep run's) are written again
//! as the logger writes them (unchunked, uncompressed: crash-safe while the run goes on), then
//! finished two ways:
//! - baseline: the earlier rewrite, uncompressed chunks of 256 KiB of records as they come
//!   (interleaved), a message index after each;
//! - indexed: [`testbed_log::index`], the logger's finish: zstd chunks of
//!   [`testbed_log::CHUNK_INTERVAL_NS`] of log time, grouped by channel.
//!
//! Prints the unchunked size and the time to write it, then for each finish its size, its
//! time (median of `--repeats`, from the unchunked file in the page cache to the renamed
//! result) and the ratios; `--json` for one JSON object.
//!
//! With `--levels`, the indexed finish at other zstd levels too (the choice of
//! `CHUNK_ZSTD_LEVEL`).
//!
//! With `--run TESTBED`, the log is first made by a lockstep run of that executable
//! (`TESTBED run --duration 3000 --log DIR/run.mcap --no-progress`), timed from start to exit.
//! Both encodings write the same unchunked file while the run goes on and differ only in the
//! finish, so the run's wall time with the baseline finish is its measured wall time less the
//! indexed finish plus the baseline one, each as measured here.
//!
//! `target/release/log_size --run target/release/testbed --dir /tmp/x [--repeats 3]`, or on a
//! log made before: `target/release/log_size --log /tmp/x/run.mcap [--levels 3,6]`

use anyhow::{Context, Result};
use clap::Parser;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use testbed_log::{LogRecord, RunLog, RunLogWriter, WriterOptions};

#[derive(Parser)]
struct Args {
    /// A finished log whose records are written again.
    #[arg(long, required_unless_present = "run", conflicts_with = "run")]
    log: Option<PathBuf>,
    /// Make the log first by a lockstep run of this `testbed` executable, timed.
    #[arg(long)]
    run: Option<PathBuf>,
    /// Simulated seconds of the `--run` run.
    #[arg(long, default_value_t = 3000)]
    duration: u64,
    /// Repetitions of each finish (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Where the files go (default: beside `--log`; needed with `--run`).
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Further zstd levels to measure the indexed finish at, beside the logger's
    /// (`CHUNK_ZSTD_LEVEL`), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "3,6")]
    levels: Vec<u32>,
    /// One JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// The earlier finish: the unchunked file's records into uncompressed 256-KiB chunks, in file
/// order, through a temporary file renamed over `path`.
fn baseline_index(path: &Path) -> Result<()> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let temporary = path.with_extension("rewriting");
    let file = std::fs::File::create(&temporary)
        .with_context(|| format!("creating {}", temporary.display()))?;
    let mut writer = mcap::WriteOptions::new()
        .use_chunks(true)
        .chunk_size(Some(256 * 1024))
        .compression(None)
        .profile("")
        .create(std::io::BufWriter::new(file))?;
    let summary = mcap::Summary::read(&bytes)?;
    if let Some(summary) = &summary {
        for attachment in &summary.attachment_indexes {
            writer.attach(&mcap::read::attachment(&bytes, attachment)?)?;
        }
        for metadata in &summary.metadata_indexes {
            writer.write_metadata(&mcap::read::metadata(&bytes, metadata)?)?;
        }
    }
    for message in mcap::MessageStream::new(&bytes)? {
        writer.write(&message?)?;
    }
    writer.finish()?;
    let file = writer
        .into_inner()
        .into_inner()
        .map_err(|e| e.into_error())?;
    file.sync_all()?;
    std::fs::rename(&temporary, path)?;
    Ok(())
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// Copies `unchunked` to `to` and times `finish` on the copy, `repeats` times: the median
/// time and the size of the result.
fn measure(
    unchunked: &Path,
    to: &Path,
    repeats: usize,
    finish: impl Fn(&Path) -> Result<()>,
) -> Result<(Duration, u64)> {
    let mut times = Vec::new();
    for _ in 0..repeats.max(1) {
        std::fs::copy(unchunked, to).with_context(|| format!("copying to {}", to.display()))?;
        let start = Instant::now();
        finish(to)?;
        times.push(start.elapsed());
    }
    Ok((median(times), std::fs::metadata(to)?.len()))
}

/// Runs `testbed run --duration D --log PATH --no-progress` and returns its wall time.
fn timed_run(testbed: &Path, duration: u64, log: &Path) -> Result<Duration> {
    let start = Instant::now();
    let status = std::process::Command::new(testbed)
        .args([
            "run",
            "--duration",
            &duration.to_string(),
            "--no-progress",
            "--log",
        ])
        .arg(log)
        .stdout(std::process::Stdio::null())
        .status()
        .with_context(|| format!("starting {}", testbed.display()))?;
    let wall = start.elapsed();
    anyhow::ensure!(
        status.success(),
        "{} run exited with {status}",
        testbed.display()
    );
    Ok(wall)
}

fn main() -> Result<()> {
    let args = Args::parse();
    let (log_path, run_wall) = match (&args.run, &args.log) {
        (Some(testbed), _) => {
            let dir = args.dir.as_deref().context("--run needs --dir")?;
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            let log = dir.join("run.mcap");
            (log.clone(), Some(timed_run(testbed, args.duration, &log)?))
        }
        (None, Some(log)) => (log.clone(), None),
        (None, None) => anyhow::bail!("give --log or --run"),
    };
    let log = RunLog::open(&log_path).with_context(|| format!("opening {}", log_path.display()))?;
    let records: Vec<LogRecord> = log.records()?.collect::<Result<_, _>>()?;
    let dir = args
        .dir
        .clone()
        .or_else(|| log_path.parent().map(Path::to_path_buf))
        .unwrap_or_default();
    let unchunked = dir.join("log_size.unchunked.mcap");

    // As the logger writes them: unchunked, into the page cache, unsynced.
    let start = Instant::now();
    let options = WriterOptions {
        indexed: false,
        ..WriterOptions::default()
    };
    let mut writer = RunLogWriter::create_with(&unchunked, log.info(), options)?;
    for record in &records {
        writer.write_record(record)?;
    }
    writer.finish()?;
    let write_time = start.elapsed();
    let unchunked_size = std::fs::metadata(&unchunked)?.len();

    let (baseline_time, baseline_size) = measure(
        &unchunked,
        &dir.join("log_size.baseline.mcap"),
        args.repeats,
        baseline_index,
    )?;
    let (indexed_time, indexed_size) = measure(
        &unchunked,
        &dir.join("log_size.indexed.mcap"),
        args.repeats,
        |p| Ok(testbed_log::index(p).map(|_| ())?),
    )?;
    // The indexed log holds the same samples.
    let again = RunLog::open(dir.join("log_size.indexed.mcap"))?;
    anyhow::ensure!(
        again.message_count() == records.len() as u64,
        "the indexed log has {} samples, the input {}",
        again.message_count(),
        records.len()
    );
    let mut levels = Vec::new();
    for &level in &args.levels {
        let (time, size) = measure(
            &unchunked,
            &dir.join("log_size.indexed.mcap"),
            args.repeats,
            |p| Ok(testbed_log::index_with_level(p, level).map(|_| ())?),
        )?;
        levels.push((level, time, size));
    }
    let mb = |b: u64| b as f64 / 1e6;
    // The run's wall time with either finish: the same run, its finish swapped.
    let run_walls = run_wall.map(|wall| {
        let indexed = wall.as_secs_f64();
        let baseline = indexed - indexed_time.as_secs_f64() + baseline_time.as_secs_f64();
        (indexed, baseline)
    });
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "records": records.len(),
                "unchunked_bytes": unchunked_size,
                "unchunked_write_s": write_time.as_secs_f64(),
                "baseline_bytes": baseline_size,
                "baseline_finish_s": baseline_time.as_secs_f64(),
                "indexed_level": testbed_log::CHUNK_ZSTD_LEVEL,
                "indexed_bytes": indexed_size,
                "indexed_finish_s": indexed_time.as_secs_f64(),
                "size_ratio": baseline_size as f64 / indexed_size as f64,
                "finish_time_ratio": indexed_time.as_secs_f64() / baseline_time.as_secs_f64(),
                "run_wall_s": run_walls.map(|w| w.0),
                "run_wall_baseline_finish_s": run_walls.map(|w| w.1),
                "other_levels": levels.iter().map(|(l, t, b)| serde_json::json!({
                    "level": l, "bytes": b, "finish_s": t.as_secs_f64(),
                })).collect::<Vec<_>>(),
            })
        );
    } else {
        println!(
            "{} samples; unchunked (while running) {:.1} MB, written in {:.2} s",
            records.len(),
            mb(unchunked_size),
            write_time.as_secs_f64()
        );
        println!(
            "baseline finish (uncompressed 256-KiB chunks): {:.1} MB in {:.2} s",
            mb(baseline_size),
            baseline_time.as_secs_f64()
        );
        println!(
            "indexed finish (zstd {} chunks of {} s, by channel): {:.1} MB in {:.2} s",
            testbed_log::CHUNK_ZSTD_LEVEL,
            testbed_log::CHUNK_INTERVAL_NS / 1_000_000_000,
            mb(indexed_size),
            indexed_time.as_secs_f64()
        );
        println!(
            "indexed / baseline: {:.3}× the size ({:.1}× smaller), {:.2}× the finish time",
            indexed_size as f64 / baseline_size as f64,
            baseline_size as f64 / indexed_size as f64,
            indexed_time.as_secs_f64() / baseline_time.as_secs_f64()
        );
        if let Some((indexed, baseline)) = run_walls {
            println!(
                "testbed run --duration {}: {indexed:.2} s wall with the indexed finish, \
                 {baseline:.2} s with the baseline finish ({:.2}×)",
                args.duration,
                indexed / baseline
            );
        }
        for (level, time, size) in &levels {
            println!(
                "  at zstd level {level}: {:.1} MB in {:.2} s",
                mb(*size),
                time.as_secs_f64()
            );
        }
    }
    for name in ["unchunked", "baseline", "indexed"] {
        let _ = std::fs::remove_file(dir.join(format!("log_size.{name}.mcap")));
    }
    Ok(())
}
