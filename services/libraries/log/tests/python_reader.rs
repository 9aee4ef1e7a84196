//! A log written by `RunLogWriter` is read by a standard MCAP tool: Python's `mcap` package.

mod common;

use common::{expected_messages, python_read_log, run_info, run_records, temp_path};
use ipc_types::topic;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use testbed_log::{LogRecord, RunLogWriter, WriterOptions, foxglove};

#[test]
fn python_mcap_reads_topics_schemas_messages_and_configuration() {
    let path = temp_path("python_summary.mcap");
    let records: Vec<LogRecord> = run_records(25, 6).into_iter().flatten().collect();
    let mut writer =
        RunLogWriter::create_with(&path, &run_info(), WriterOptions::lockstep()).expect("create");
    for record in &records {
        writer.write_record(record).expect("write");
    }
    let stats = writer.finish().expect("finish");

    let report = python_read_log(&["summary", path.to_str().expect("utf-8 path")]);

    assert!(
        report["library"]
            .as_str()
            .is_some_and(|l| l.starts_with("testbed-log/"))
    );
    // Channels: one per topic, JSON messages, each with its JSON Schema.
    let channels = report["channels"].as_object().expect("channels");
    let topics: Vec<&str> = (1..=topic::ALL.len())
        .map(|id| channels[&id.to_string()]["topic"].as_str().expect("topic"))
        .collect();
    assert_eq!(topics, topic::ALL);
    // Then the channels derived for Foxglove's panels, on Foxglove's schemas.
    let schemas = report["schemas"].as_object().expect("schemas");
    for (offset, (topic, (name, _))) in foxglove::DERIVED_TOPICS
        .iter()
        .zip(foxglove::derived_schemas())
        .enumerate()
    {
        let channel = &channels[&(topic::ALL.len() + 1 + offset).to_string()];
        assert_eq!(channel["topic"], *topic);
        let schema = &schemas[&channel["schema_id"].to_string()];
        assert_eq!(schema["name"], name);
        assert!(name.starts_with("foxglove."), "{name}");
    }
    assert_eq!(
        channels.len(),
        topic::ALL.len() + foxglove::DERIVED_TOPICS.len()
    );
    for channel in channels
        .values()
        .filter(|c| !foxglove::DERIVED_TOPICS.contains(&c["topic"].as_str().unwrap_or("")))
    {
        assert_eq!(channel["message_encoding"], "json");
        let schema = &schemas[&channel["schema_id"].to_string()];
        assert_eq!(schema["encoding"], "jsonschema");
        let name = schema["name"].as_str().expect("name");
        assert!(
            name.starts_with("testbed::")
                && name
                    .rsplit_once(".v")
                    .is_some_and(|(_, v)| v.parse::<u32>().is_ok()),
            "{name}"
        );
        assert_eq!(schema["data"]["type"], "object");
        assert!(schema["data"]["properties"]["header"]["properties"]["time_ns"].is_object());
    }
    let gyro_schema = schemas
        .values()
        .find(|s| s["name"] == "testbed::GyroSample.v1")
        .expect("gyro schema");
    let rate = gyro_schema["data"]["properties"]["rate"]["description"]
        .as_str()
        .expect("desc");
    assert!(rate.contains("rad/s"), "units in the description: {rate}");

    // Messages: every one decoded as JSON by the script (its log time = start time + the
    // header's run time); counts match, with one transform per valid estimate and per truth,
    // a pose per valid estimate, an event per health event, acknowledgement and mode change.
    let expected: BTreeMap<String, u64> = expected_messages(&records, |_| true)
        .into_iter()
        .map(|(t, n)| (t.to_owned(), n))
        .collect();
    let derived: u64 = foxglove::DERIVED_TOPICS
        .iter()
        .map(|t| expected.get(*t).copied().unwrap_or(0))
        .sum();
    assert!(derived > 0, "the synthetic run has estimates and truth");
    let counted: BTreeMap<String, u64> = report["messages"]
        .as_object()
        .expect("messages")
        .iter()
        .map(|(t, n)| (t.clone(), n.as_u64().expect("count")))
        .collect();
    assert_eq!(counted, expected);
    assert_eq!(
        report["statistics"]["message_count"],
        json!(records.len() as u64 + derived)
    );
    // Indexed: chunks with a chunk index, and a reader seeks to the middle of the run through
    // it, reading exactly the messages from there on.
    assert!(report["chunk_indexes"].as_u64().is_some_and(|n| n >= 1));
    assert_eq!(report["from_middle"], report["at_or_after_middle"]);
    assert!(report["from_middle"].as_u64().is_some_and(|n| n > 0));
    assert_eq!(stats.messages, records.len() as u64);
    assert_eq!(report["statistics"]["attachment_count"], 1);
    assert_eq!(report["statistics"]["metadata_count"], 1);

    // Configuration and run metadata.
    let info = run_info();
    assert_eq!(
        report["attachments"],
        json!([{
            "name": "config.toml",
            "media_type": "application/toml",
            "data": info.config_toml,
            // Dated the run's start.
            "log_time": info.start_time_ns,
            "create_time": info.start_time_ns,
        }])
    );
    let metadata: &Value = &report["metadata"][0];
    assert_eq!(metadata["name"], "testbed.run");
    assert_eq!(metadata["metadata"]["profile"], "simulation");
    assert_eq!(metadata["metadata"]["mode"], "lockstep");
    assert_eq!(metadata["metadata"]["seed"], info.seed.to_string());
    assert_eq!(metadata["metadata"]["git"], "abc123");
    assert_eq!(metadata["metadata"]["format"], "testbed-log/1");
    assert_eq!(
        metadata["metadata"]["start_time_ns"],
        info.start_time_ns.to_string()
    );
    assert_eq!(
        metadata["metadata"]["start_time"],
        "2026-11-24T07:00:00.000000000Z"
    );
}
