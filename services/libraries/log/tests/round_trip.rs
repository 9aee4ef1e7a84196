//! Every sample type written by `RunLogWriter` reads back identical through `RunLog`.

mod common;

use common::{in_log_order, run_info, run_records, temp_path};
use ipc_types::{
    AttitudeEstimate, GyroSample, Heartbeat, MagnetometerSample, SampleHeader, SimClockTick, topic,
};
use std::collections::BTreeSet;
use testbed_log::{
    CONFIG_ATTACHMENT, LogEnd, LogError, LogRecord, RunLog, RunLogWriter, WriterOptions,
};

#[test]
fn every_sample_type_round_trips() {
    let path = temp_path("round_trip.mcap");
    let records: Vec<LogRecord> = run_records(40, 1).into_iter().flatten().collect();
    let topics: BTreeSet<_> = records.iter().map(LogRecord::topic).collect();
    assert_eq!(
        topics.len(),
        topic::ALL.len(),
        "the synthetic run covers every topic"
    );

    let mut writer = RunLogWriter::create(&path, &run_info()).expect("create");
    for record in &records {
        writer.write_record(record).expect("write");
    }
    let stats = writer.finish().expect("finish");
    assert_eq!(stats.messages, records.len() as u64);
    assert_eq!(stats.per_topic.len(), topic::ALL.len());

    let log = RunLog::open(&path).expect("open");
    assert_eq!(log.info(), &run_info());
    assert_eq!(log.config_toml(), run_info().config_toml);
    assert_eq!(log.end(), LogEnd::Complete);
    assert!(log.is_complete());
    assert_eq!(log.message_count(), records.len() as u64);
    assert_eq!(log.topics(), topic::ALL);
    assert!(log.library().starts_with("testbed-log/"));

    let read: Vec<LogRecord> = log
        .records()
        .expect("records")
        .map(|r| r.expect("decodes"))
        .collect();
    // Finished, the log is indexed: its records come back in time order.
    assert_eq!(read, in_log_order(&records));

    // Filters.
    let gyros: Vec<GyroSample> = log
        .samples::<GyroSample>()
        .expect("samples")
        .map(|r| r.expect("decodes"))
        .collect();
    let expected: Vec<GyroSample> = records
        .iter()
        .filter_map(|r| match r {
            LogRecord::Gyro(g) => Some(*g),
            _ => None,
        })
        .collect();
    assert_eq!(gyros, expected);
    assert_eq!(gyros.len(), 40);

    let on: Vec<LogRecord> = log
        .records_on(&[topic::MAGNETOMETER, topic::SIM_CLOCK, "no/such/topic"])
        .expect("records")
        .map(|r| r.expect("decodes"))
        .collect();
    let expected: Vec<LogRecord> = in_log_order(&records)
        .iter()
        .filter(|r| [topic::MAGNETOMETER, topic::SIM_CLOCK].contains(&r.topic()))
        .copied()
        .collect();
    assert_eq!(on, expected);
}

#[test]
fn edge_values_round_trip() {
    let path = temp_path("edge_values.mcap");
    let mut estimate = AttitudeEstimate {
        header: SampleHeader::new(u64::MAX, u64::MAX, u32::MAX).with_source(u32::MAX),
        innovation: [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            5e-324,
            f64::MAX,
        ],
        ..AttitudeEstimate::default()
    };
    estimate.covariance[35] = f64::MIN_POSITIVE;
    let mut garbage_name = Heartbeat::new("gateway", 42);
    garbage_name.name[20] = 0xFF; // bytes after the NUL, not UTF-8: stored raw
    let full_name = Heartbeat::new(&"x".repeat(32), 7);
    let unicode = Heartbeat::new("magnétomètre", 9);
    let tick = SimClockTick::new(u64::MAX, u64::MAX, 1);

    let mut writer = RunLogWriter::create(&path, &run_info()).expect("create");
    writer.write(&estimate).expect("write");
    writer.write(&garbage_name).expect("write");
    writer.write(&full_name).expect("write");
    writer.write(&unicode).expect("write");
    writer.write(&tick).expect("write");
    writer.finish().expect("finish");

    let log = RunLog::open(&path).expect("open");
    let read: Vec<LogRecord> = log
        .records()
        .expect("records")
        .map(|r| r.expect("decodes"))
        .collect();
    // The indexed log gives records in time order: the heartbeats (time 0) in the order
    // written, then the estimate and the tick (both at the latest time, in topic order).
    assert_eq!(read.len(), 5, "{read:?}");
    let LogRecord::AttitudeEstimate(e) = read[3] else {
        panic!("the estimate after the heartbeats: {read:?}")
    };
    assert_eq!(e.header, estimate.header);
    // Non-finite values are written as null and read back as NaN.
    for i in 0..3 {
        assert!(e.innovation[i].is_nan(), "innovation[{i}]");
    }
    for i in 3..6 {
        assert_eq!(
            e.innovation[i].to_bits(),
            estimate.innovation[i].to_bits(),
            "innovation[{i}]"
        );
    }
    assert_eq!(e.covariance, estimate.covariance);
    assert_eq!(read[0], LogRecord::Heartbeat(garbage_name));
    assert_eq!(read[1], LogRecord::Heartbeat(full_name));
    assert_eq!(read[2], LogRecord::Heartbeat(unicode));
    assert_eq!(read[4], LogRecord::SimClock(tick));
    assert_eq!(unicode.name(), "magnétomètre");
}

#[test]
fn writer_checks_its_inputs() {
    let mut info = run_info();
    info.extra.insert("seed".into(), "1".into());
    assert!(matches!(
        RunLogWriter::create(temp_path("reserved.mcap"), &info),
        Err(LogError::ReservedKey(k)) if k == "seed"
    ));

    let path = temp_path("late.mcap");
    let mut writer =
        RunLogWriter::create_with(&path, &run_info(), WriterOptions::lockstep()).expect("create");
    let gyro = |t| GyroSample::new(SampleHeader::new(t, 0, 1), [0.0; 3]);
    writer.write(&gyro(20)).expect("buffered");
    writer.write(&gyro(10)).expect("buffered");
    assert_eq!(writer.pending(), 2);
    writer.complete_until(15).expect("complete");
    assert_eq!(writer.pending(), 1);
    // A late record is never lost: written at once, out of time order, and counted.
    writer.write(&gyro(15)).expect("a late record is written");
    writer
        .write(&MagnetometerSample::default())
        .expect("time 0 is late too, and written");
    let stats = writer.finish().expect("finish writes the pending record");
    assert_eq!(stats.late_records, 2);
    let log = RunLog::open(&path).expect("open");
    let times: Vec<u64> = log
        .records()
        .expect("records")
        .map(|r| r.expect("decodes").header().time_ns)
        .collect();
    // Written in arrival order (10, the late 15 and 0, then the pending 20), the records
    // of the indexed log read back in time order.
    assert_eq!(times, [0, 10, 15, 20], "no late record lost");

    assert!(matches!(
        RunLog::open(temp_path("missing.mcap")),
        Err(LogError::File { .. })
    ));
    let not_mcap = temp_path("not.mcap");
    std::fs::write(&not_mcap, b"hello, world").expect("write");
    assert!(matches!(RunLog::open(&not_mcap), Err(LogError::NotMcap)));
}

#[test]
fn dropping_an_unfinished_writer_still_completes_the_file() {
    let path = temp_path("dropped.mcap");
    {
        let mut writer = RunLogWriter::create_with(&path, &run_info(), WriterOptions::lockstep())
            .expect("create");
        writer
            .write(&GyroSample::new(SampleHeader::new(5, 0, 1), [1.0; 3]))
            .expect("write");
    }
    let log = RunLog::open(&path).expect("open");
    assert!(log.is_complete());
    assert_eq!(log.message_count(), 1);
    assert_eq!(CONFIG_ATTACHMENT, "config.toml");
}

#[test]
fn a_finished_log_is_indexed_and_reads_back_as_the_unchunked_one() {
    let records: Vec<LogRecord> = run_records(40, 9).into_iter().flatten().collect();
    let write = |name: &str, indexed: bool| {
        let path = temp_path(name);
        let options = WriterOptions {
            indexed,
            ..WriterOptions::default()
        };
        let mut writer = RunLogWriter::create_with(&path, &run_info(), options).expect("create");
        for record in &records {
            writer.write_record(record).expect("write");
        }
        writer.finish().expect("finish");
        path
    };
    let plain = write("index_plain.mcap", false);
    let indexed = write("index_indexed.mcap", true);
    let opcodes = |path: &std::path::Path| -> Vec<u8> {
        common::framing(&std::fs::read(path).expect("read"))
            .iter()
            .map(|f| f.opcode)
            .collect()
    };
    const CHUNK: u8 = 0x06;
    const MESSAGE_INDEX: u8 = 0x07;
    const CHUNK_INDEX: u8 = 0x08;
    let plain_ops = opcodes(&plain);
    let indexed_ops = opcodes(&indexed);
    assert!(!plain_ops.contains(&CHUNK) && !plain_ops.contains(&CHUNK_INDEX));
    assert!(indexed_ops.contains(&CHUNK));
    assert!(indexed_ops.contains(&MESSAGE_INDEX));
    assert!(indexed_ops.contains(&CHUNK_INDEX));

    let read = |path: &std::path::Path| {
        let log = RunLog::open(path).expect("open");
        assert!(log.is_complete());
        let records: Vec<LogRecord> = log
            .records()
            .expect("records")
            .map(|r| r.expect("decodes"))
            .collect();
        (log.message_count(), log.info().clone(), records)
    };
    let (plain_count, plain_info, plain_records) = read(&plain);
    let (indexed_count, indexed_info, indexed_records) = read(&indexed);
    assert_eq!(plain_count, records.len() as u64);
    assert_eq!(indexed_count, plain_count);
    assert_eq!(indexed_info, plain_info);
    assert!(plain_records == records);
    assert!(indexed_records == in_log_order(&records));

    // Indexing is idempotent (the same bytes) and refuses a cut file.
    let once = std::fs::read(&indexed).expect("read");
    testbed_log::index(&indexed).expect("index again");
    assert_eq!(std::fs::read(&indexed).expect("read"), once);
    let bytes = std::fs::read(&plain).expect("read");
    let cut = temp_path("index_cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).expect("write");
    assert!(matches!(
        testbed_log::index(&cut),
        Err(testbed_log::LogError::Unsupported { .. })
    ));
}
