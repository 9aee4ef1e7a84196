//! A finished log is read by Foxglove's own MCAP library: `@mcap/core`'s `McapIndexedReader`
//! (through the chunk index, zstd chunks decompressed by `fzstd`) lists every channel and reads
//! a 10-s window, exactly the messages of that window, in time order (tests/js/read_log.mjs).
//!
//! Needs Node.js and `npm ci` in tests/js (.ci/run does it). Outside CI a machine without them
//! skips the test with a message; under CI (`CI` set) it fails.

mod common;

use common::{expected_messages, run_info, run_records, temp_path};
use ipc_types::topic;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use testbed_log::{LogRecord, RunLogWriter, WriterOptions, foxglove};

fn js_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../tests/js")
}

/// Whether the JavaScript reader can run here; `false` (skip) only outside CI.
fn node_ready() -> bool {
    let installed = js_dir().join("node_modules/@mcap/core").is_dir()
        && std::process::Command::new("node")
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success());
    if !installed {
        assert!(
            std::env::var_os("CI").is_none(),
            "under CI, node and tests/js/node_modules are needed (run `npm ci` in tests/js)"
        );
        eprintln!("skipped: needs node and `npm ci` in tests/js");
    }
    installed
}

#[test]
fn mcap_core_lists_every_channel_and_reads_a_ten_second_window() {
    if !node_ready() {
        return;
    }
    let path = temp_path("js_reader.mcap");
    // 25 s of run (10-ms ticks): three chunks.
    let records: Vec<LogRecord> = run_records(2500, 4).into_iter().flatten().collect();
    let mut writer =
        RunLogWriter::create_with(&path, &run_info(), WriterOptions::lockstep()).expect("create");
    for record in &records {
        writer.write_record(record).expect("write");
    }
    writer.finish().expect("finish");

    let out = std::process::Command::new("node")
        .arg(js_dir().join("read_log.mjs"))
        .arg(&path)
        .args(["10", "10"])
        .output()
        .expect("run node");
    assert!(
        out.status.success(),
        "read_log.mjs failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON report");

    let channels = report["channels"].as_object().expect("channels");
    let topics: Vec<&str> = (1..=channels.len())
        .map(|id| channels[&id.to_string()]["topic"].as_str().expect("topic"))
        .collect();
    let expected: Vec<&str> = topic::ALL
        .iter()
        .chain(foxglove::DERIVED_TOPICS)
        .copied()
        .collect();
    assert_eq!(topics, expected);
    assert_eq!(report["compressions"], serde_json::json!(["zstd"]));
    assert_eq!(report["chunks"], 3);

    // The window [10 s, 20 s) after the first message: every sample of those times, and what
    // they derive (every truth sample's transform, every valid estimate's transform and pose,
    // an event per health event, acknowledgement and mode change).
    let window = &report["window"];
    let per_topic = expected_messages(&records, |t| (10_000_000_000..20_000_000_000).contains(&t));
    let read: BTreeMap<&str, u64> = window["per_topic"]
        .as_object()
        .expect("per topic")
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_u64().expect("count")))
        .collect();
    assert_eq!(read, per_topic);
    assert_eq!(window["in_time_order"], true);
    let start = run_info().start_time_ns;
    assert_eq!(window["first_ns"], (start + 10_000_000_000).to_string());
    assert_eq!(window["last_ns"], (start + 19_990_000_000).to_string());
    assert_eq!(
        window["json_decoded"].as_u64(),
        Some(per_topic.values().sum::<u64>()),
        "every message of the window is JSON"
    );
}
