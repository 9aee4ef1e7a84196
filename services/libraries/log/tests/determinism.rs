//! Same records → same bytes, whatever order they arrive in (lockstep determinism).

mod common;

use common::{Rng, STEP_NS, run_info, run_records, temp_path};
use std::io::Cursor;
use testbed_log::{
    EncodedRecord, LogRecord, RecordOrder, RunLog, RunLogWriter, TickSorter, WriterOptions,
};

/// Feeds `ticks` to a sorted writer as a logger would see them when the processes interleave
/// differently: each tick's records shuffled (seeded by `shuffle_seed`), and some of them
/// arriving only after the next tick's records, with completion lagging one tick behind.
fn sorted_log(ticks: &[Vec<LogRecord>], shuffle_seed: u64) -> Vec<u8> {
    let mut rng = Rng::new(shuffle_seed);
    let mut writer = RunLogWriter::new(
        Cursor::new(Vec::new()),
        &run_info(),
        WriterOptions::lockstep(),
    )
    .expect("create");
    let mut late: Vec<LogRecord> = Vec::new();
    for (k, tick) in ticks.iter().enumerate() {
        let mut tick = tick.clone();
        for i in (1..tick.len()).rev() {
            tick.swap(i, rng.below(i + 1));
        }
        let split = rng.below(tick.len() + 1);
        let delayed = tick.split_off(split);
        for record in tick.iter().chain(&late) {
            writer.write_record(record).expect("write");
        }
        late = delayed;
        if k > 0 {
            // Tick k has started: everything up to tick k - 1 is in.
            writer
                .complete_until((k as u64 - 1) * STEP_NS)
                .expect("complete");
        }
    }
    for record in &late {
        writer.write_record(record).expect("write");
    }
    writer_bytes(writer)
}

fn writer_bytes(writer: RunLogWriter<Cursor<Vec<u8>>>) -> Vec<u8> {
    let (_, cursor) = writer.finish_into_inner().expect("finish");
    cursor.into_inner()
}

#[test]
fn different_arrival_orders_give_identical_files() {
    let ticks = run_records(50, 3);
    let a = sorted_log(&ticks, 11);
    let b = sorted_log(&ticks, 22);
    let c = sorted_log(&ticks, 33);
    assert!(a.len() > 50_000);
    assert!(a == b, "arrival orders 11 and 22 give different bytes");
    assert!(a == c, "arrival orders 11 and 33 give different bytes");

    // The records are in (time, topic order, sequence) order and complete.
    let path = temp_path("det_a.mcap");
    std::fs::write(&path, &a).expect("write");
    let log = RunLog::open(&path).expect("open");
    let read: Vec<LogRecord> = log
        .records()
        .expect("records")
        .map(|r| r.expect("ok"))
        .collect();
    let mut expected: Vec<EncodedRecord> = ticks.iter().flatten().map(EncodedRecord::new).collect();
    expected.sort();
    let read_encoded: Vec<EncodedRecord> = read.iter().map(EncodedRecord::new).collect();
    assert_eq!(read_encoded, expected);
}

#[test]
fn arrival_order_is_kept_without_sorting_and_writing_is_repeatable() {
    let ticks = run_records(20, 4);
    let write = |records: &[LogRecord]| {
        let mut writer = RunLogWriter::new(
            Cursor::new(Vec::new()),
            &run_info(),
            WriterOptions::default(),
        )
        .expect("create");
        for r in records {
            writer.write_record(r).expect("write");
        }
        writer_bytes(writer)
    };
    let records: Vec<LogRecord> = ticks.iter().flatten().copied().collect();
    let mut reversed = records.clone();
    reversed.reverse();
    let first = write(&records);
    assert_eq!(
        first,
        write(&records),
        "same records, same order: same bytes"
    );
    assert_ne!(
        first,
        write(&reversed),
        "arrival order is kept (the test is not vacuous)"
    );
}

#[test]
fn external_sorter_feeding_an_arrival_writer_matches_the_sorted_writer() {
    let ticks = run_records(10, 5);
    let mut sorter = TickSorter::new();
    let mut writer = RunLogWriter::new(
        Cursor::new(Vec::new()),
        &run_info(),
        WriterOptions::default(),
    )
    .expect("create");
    // The whole run buffered in reverse arrival order, released at the end.
    for tick in ticks.iter().rev() {
        for r in tick.iter().rev() {
            sorter.push(EncodedRecord::new(r)).expect("push");
        }
    }
    for r in sorter.drain() {
        writer.write_encoded(&r).expect("write");
    }
    let external = writer_bytes(writer);

    let mut sorted = RunLogWriter::new(
        Cursor::new(Vec::new()),
        &run_info(),
        WriterOptions::lockstep(),
    )
    .expect("create");
    for r in ticks.iter().flatten() {
        sorted.write_record(r).expect("write");
    }
    assert_eq!(external, writer_bytes(sorted));
    assert_eq!(WriterOptions::lockstep().order, RecordOrder::Sorted);
}
