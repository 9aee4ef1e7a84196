//! Every message of a run is stamped with the time it describes: nothing before the run's
//! start, and the indexed log's chunks cover disjoint time ranges of one flush interval
//! (`CHUNK_INTERVAL_NS`) each, so a viewer seeking to a time reads one chunk.

mod common;

use common::{run_info, run_records, temp_path};
use ipc_types::Heartbeat;
use std::path::Path;
use testbed_log::{CHUNK_INTERVAL_NS, LogRecord, RunLogWriter, WriterOptions, chunk_time_ranges};

/// Writes 25 s of synthetic run (10-ms ticks), then `extra`, as the logger of a lockstep run.
fn write_run(name: &str, extra: &[LogRecord]) -> std::path::PathBuf {
    let path = temp_path(name);
    let mut writer =
        RunLogWriter::create_with(&path, &run_info(), WriterOptions::default()).expect("create");
    for record in run_records(2500, 3).iter().flatten().chain(extra) {
        writer.write_record(record).expect("write");
    }
    writer.finish().expect("finish");
    path
}

/// Whether the chunks' time ranges are as the flush interval makes them: each within one
/// interval, after the previous one (disjoint: no two overlap at all, so a seek to any time
/// reads one chunk). The error names the first chunk that is not.
fn check_chunks(ranges: &[(u64, u64)]) -> Result<(), String> {
    for (i, &(begin, end)) in ranges.iter().enumerate() {
        if end < begin || end - begin >= CHUNK_INTERVAL_NS {
            return Err(format!(
                "chunk {i} spans {begin}..{end} ns: more than one interval"
            ));
        }
        if i > 0 && begin <= ranges[i - 1].1 {
            return Err(format!(
                "chunk {i} starts at {begin} ns, before chunk {} ends ({} ns)",
                i - 1,
                ranges[i - 1].1
            ));
        }
    }
    Ok(())
}

fn log_times(path: &Path) -> Vec<u64> {
    let bytes = std::fs::read(path).expect("read");
    mcap::MessageStream::new(&bytes)
        .expect("mcap")
        .map(|m| m.expect("message").log_time)
        .collect()
}

#[test]
fn no_message_is_stamped_before_the_run_and_chunks_cover_disjoint_intervals() {
    let path = write_run("time_stamps.mcap", &[]);
    let start = run_info().start_time_ns;
    assert!(start > 0, "the synthetic run has a wall-clock start");

    let times = log_times(&path);
    assert!(times.len() > 40_000, "{} messages", times.len());
    let first = *times.iter().min().expect("messages");
    assert!(
        first >= start,
        "a message at {first} before the start {start}"
    );

    let bytes = std::fs::read(&path).expect("read");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("indexed");
    assert_eq!(summary.attachment_indexes.len(), 1);
    for attachment in &summary.attachment_indexes {
        assert_eq!(attachment.log_time, start, "{}", attachment.name);
        assert_eq!(attachment.create_time, start, "{}", attachment.name);
    }

    let ranges = chunk_time_ranges(&path).expect("chunks");
    // 25 s of run: three chunks of one flush interval each, from the start.
    assert_eq!(ranges.len(), 3, "{ranges:?}");
    assert_eq!(ranges[0].0, start);
    assert_eq!(check_chunks(&ranges), Ok(()), "{ranges:?}");
}

#[test]
fn a_heartbeat_stamped_zero_late_in_the_run_is_what_widens_a_chunk_back_to_the_start() {
    // What the logger's and the ground link's heartbeats were before they carried the time of
    // the samples they had handled: the check above fails on such a log.
    let stale = LogRecord::from(Heartbeat::new("logger", 7));
    assert_eq!(stale.header().time_ns, 0);
    let path = write_run("time_stamps_stale.mcap", &[stale]);
    let ranges = chunk_time_ranges(&path).expect("chunks");
    let start = run_info().start_time_ns;
    // It joins the last chunk still open when it comes, which then reaches back to the start.
    assert_eq!(ranges.len(), 3, "{ranges:?}");
    assert_eq!(ranges[1].0, start, "{ranges:?}");
    assert!(check_chunks(&ranges).is_err(), "{ranges:?}");
}
