//! A log cut at any byte (logger killed mid-run) still yields every complete record.

mod common;

use common::{Framed, framing, python_read_log, run_info, run_records, temp_path};
use std::collections::BTreeSet;
use testbed_log::{LogEnd, LogError, LogRecord, RunLog, RunLogWriter, WriterOptions};

const METADATA: u8 = 0x0C;

/// Writes a finished log of a short run as it stands before the indexed rewrite (unchunked,
/// the layout a run's log has until it ends); returns its bytes and records.
fn finished_log(name: &str) -> (Vec<u8>, Vec<LogRecord>) {
    let path = temp_path(name);
    let records: Vec<LogRecord> = run_records(30, 2).into_iter().flatten().collect();
    let options = WriterOptions {
        indexed: false,
        ..WriterOptions::default()
    };
    let mut writer = RunLogWriter::create_with(&path, &run_info(), options).expect("create");
    for record in &records {
        writer.write_record(record).expect("write");
    }
    writer.finish().expect("finish");
    (std::fs::read(&path).expect("read back"), records)
}

/// Offsets to cut at: around every record boundary, inside every record header, a stride
/// through the file, and every byte of the footer and trailing magic.
fn cut_offsets(frames: &[Framed], len: u64) -> BTreeSet<u64> {
    let mut cuts: BTreeSet<u64> = (0..=16).collect();
    for f in frames {
        for c in [
            f.start - 1,
            f.start,
            f.start + 1,
            f.start + 8,
            f.start + 9,
            f.end - 1,
            f.end,
        ] {
            cuts.insert(c);
        }
    }
    cuts.extend((0..len).step_by(61));
    let footer = frames.last().expect("footer");
    cuts.extend(footer.start - 1..=len);
    cuts.retain(|&c| c <= len);
    cuts
}

#[test]
fn every_complete_record_before_a_cut_is_recovered() {
    let (bytes, records) = finished_log("truncation_full_rust.mcap");
    let len = bytes.len() as u64;
    let frames = framing(&bytes);
    let message_ends: Vec<u64> = frames
        .iter()
        .filter(|f| f.is_sample_message())
        .map(|f| f.end)
        .collect();
    assert_eq!(message_ends.len(), records.len());
    let run_info_end = frames
        .iter()
        .find(|f| f.opcode == METADATA)
        .expect("metadata")
        .end;
    assert!(
        run_info_end < message_ends[0],
        "run information precedes the messages"
    );

    let cut_path = temp_path("truncation_cut.mcap");
    let cuts = cut_offsets(&frames, len);
    let mut checked_with_messages = 0;
    for &cut in &cuts {
        std::fs::write(&cut_path, &bytes[..cut as usize]).expect("write prefix");
        let opened = RunLog::open(&cut_path);
        if cut < run_info_end {
            // Cut before the run information was complete: no message could precede it.
            match opened {
                Err(LogError::MissingRunInfo {
                    end: LogEnd::Truncated { file_len, .. },
                    ..
                }) => {
                    assert_eq!(file_len, cut)
                }
                other => panic!("cut at {cut}: expected MissingRunInfo, got {other:?}"),
            }
            continue;
        }
        let log = opened.unwrap_or_else(|e| panic!("cut at {cut}: {e}"));
        let complete_end = frames
            .iter()
            .map(|f| f.end)
            .filter(|&e| e <= cut)
            .max()
            .unwrap_or(8);
        let expected_end = if cut == len {
            LogEnd::Complete
        } else {
            LogEnd::Truncated {
                offset: complete_end,
                file_len: cut,
            }
        };
        assert_eq!(log.end(), expected_end, "cut at {cut}");
        let n = message_ends.partition_point(|&e| e <= cut);
        assert_eq!(log.message_count(), n as u64, "cut at {cut}");
        assert_eq!(log.info(), &run_info(), "cut at {cut}");
        let read: Vec<LogRecord> = log
            .records()
            .expect("records")
            .map(|r| r.unwrap_or_else(|e| panic!("cut at {cut}: {e}")))
            .collect();
        assert_eq!(read.len(), n, "cut at {cut}");
        // The cut file is unchunked: its records in the order written.
        assert!(read == records[..n], "cut at {cut}: records differ");
        if n > 0 {
            checked_with_messages += 1;
        }
    }
    assert!(
        cuts.len() > 2000 && checked_with_messages > 1000,
        "{} cuts",
        cuts.len()
    );
}

#[test]
fn python_stream_reader_recovers_the_complete_records_of_a_cut_log() {
    let (bytes, records) = finished_log("truncation_full_python.mcap");
    let frames = framing(&bytes);
    let messages: Vec<&Framed> = frames.iter().filter(|f| f.is_sample_message()).collect();
    // Inside a message body, inside a record's length field, and exactly between two records.
    let mid = messages[messages.len() * 3 / 5];
    let cuts = [
        (mid.start + mid.end) / 2,
        messages[messages.len() / 3].start + 5,
        messages[messages.len() / 2].start,
    ];
    for (i, &cut) in cuts.iter().enumerate() {
        let path = temp_path(&format!("truncation_python_{i}.mcap"));
        std::fs::write(&path, &bytes[..cut as usize]).expect("write prefix");
        let n = messages.iter().filter(|f| f.end <= cut).count();

        let report = python_read_log(&["stream", path.to_str().expect("utf-8 path")]);
        let got = report["messages"].as_array().expect("messages");
        let expected: Vec<serde_json::Value> = records[..n]
            .iter()
            .map(|r| serde_json::json!([r.topic(), r.header().time_ns, r.header().sequence]))
            .collect();
        assert_eq!(got, &expected, "cut at {cut}: Python's StreamReader");
        assert_ne!(
            report["ended"], "footer",
            "cut at {cut}: Python must see the cut"
        );

        let log = RunLog::open(&path).expect("open");
        assert_eq!(
            log.records().expect("records").count(),
            n,
            "cut at {cut}: RunLog"
        );
    }
}

#[test]
fn a_repaired_cut_log_is_complete_and_holds_every_complete_record() {
    let (bytes, records) = finished_log("truncation_full_repair.mcap");
    let frames = framing(&bytes);
    let messages: Vec<&Framed> = frames.iter().filter(|f| f.is_sample_message()).collect();
    let mid = messages[messages.len() / 2];
    // Inside a message body, exactly between two records, inside the footer, and complete.
    let footer = frames.last().expect("footer");
    let cuts = [
        (mid.start + mid.end) / 2,
        messages[messages.len() / 4].start,
        footer.start + 3,
        bytes.len() as u64,
    ];
    for (i, &cut) in cuts.iter().enumerate() {
        let path = temp_path(&format!("truncation_repair_{i}.mcap"));
        std::fs::write(&path, &bytes[..cut as usize]).expect("write prefix");
        let n = messages.iter().filter(|f| f.end <= cut).count();
        let cut_log = RunLog::open(&path).expect("open the cut log");
        assert_eq!(cut_log.message_count(), n as u64, "cut at {cut}");

        // In place: the repaired file replaces the cut one.
        // The repair copies every complete message record, the derived transforms included
        // (counted in the file's statistics), and reports the samples.
        let n_records = frames
            .iter()
            .filter(|f| f.opcode == 0x05 && f.end <= cut)
            .count();
        let report = testbed_log::repair(&path, &path).expect("repair");
        assert_eq!(report.messages, n as u64, "cut at {cut}: {report:?}");
        assert_eq!(report.end == LogEnd::Complete, cut == bytes.len() as u64);
        let repaired = RunLog::open(&path).expect("open the repaired log");
        assert!(repaired.is_complete(), "cut at {cut}: {:?}", repaired.end());
        assert_eq!(repaired.info(), &run_info());
        let read: Vec<LogRecord> = repaired
            .records()
            .expect("records")
            .map(|r| r.expect("decodes"))
            .collect();
        // Repaired, the log is indexed: its records in time order.
        assert!(
            read == common::in_log_order(&records[..n]),
            "cut at {cut}: records differ"
        );

        // Python's make_reader (reads from the footer) now accepts it.
        let summary = python_read_log(&["summary", path.to_str().expect("utf-8 path")]);
        assert_eq!(
            summary["statistics"]["message_count"], n_records as u64,
            "cut at {cut}: {summary}"
        );
    }
    // A file that is not a log is refused, and the output is not created.
    let junk = temp_path("truncation_repair_junk.mcap");
    let out = temp_path("truncation_repair_junk_out.mcap");
    std::fs::write(&junk, b"not an mcap file").expect("write");
    let _ = std::fs::remove_file(&out);
    assert!(matches!(
        testbed_log::repair(&junk, &out),
        Err(LogError::NotMcap)
    ));
    assert!(!out.exists());
}
