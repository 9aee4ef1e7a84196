//! Deterministic record order for lockstep runs: [`EncodedRecord`] and [`TickSorter`].

use crate::LogError;
use crate::foxglove::{self, Derived};
use crate::record::LogRecord;
use ipc_types::TopicId;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A record encoded for the log: its sort key and its JSON message.
///
/// Ordered by `(time_ns, topic order, sequence, source_id, message bytes)`: a total order that
/// depends only on the record's content, so any arrival order sorts to the same sequence.
/// The topic order is that of [`ipc_types::topic::ALL`]. The message bytes break the remaining
/// ties (e.g. two processes' heartbeats with equal time, sequence and source); records equal in
/// all of these are byte-identical, so their relative order does not matter.
#[derive(Debug, Clone)]
pub struct EncodedRecord {
    time_ns: u64,
    kind: TopicId,
    sequence: u64,
    source_id: u32,
    data: Vec<u8>,
    /// What the record derives ([`foxglove::derived_of`]), taken when it was encoded: the
    /// writer needs it when the record leaves the sorter, and decoding the message back for it
    /// was most of a lockstep logger's CPU. A function of the record, as `data` is, so not part
    /// of the order.
    derived: Derived,
}

impl EncodedRecord {
    /// Encodes `record`.
    pub fn new(record: &LogRecord) -> Self {
        let mut data = Vec::with_capacity(256);
        record.encode_json(&mut data);
        let header = record.header();
        Self {
            time_ns: header.time_ns,
            kind: record.topic_id(),
            sequence: header.sequence,
            source_id: header.source_id,
            data,
            derived: foxglove::derived_of(record),
        }
    }

    /// What orders records (see the type's documentation).
    fn order_key(&self) -> (u64, TopicId, u64, u32, &[u8]) {
        (
            self.time_ns,
            self.kind,
            self.sequence,
            self.source_id,
            &self.data,
        )
    }

    /// The sample's `header.time_ns`.
    pub fn time_ns(&self) -> u64 {
        self.time_ns
    }

    /// The sample's `header.sequence`.
    pub fn sequence(&self) -> u64 {
        self.sequence
    }

    /// The topic name.
    pub fn topic(&self) -> &'static str {
        self.kind.name()
    }

    /// The JSON message.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    pub(crate) fn topic_id(&self) -> TopicId {
        self.kind
    }

    /// What the record derives ([`foxglove::derived_of`]).
    pub(crate) fn derived(&self) -> &Derived {
        &self.derived
    }
}

impl PartialEq for EncodedRecord {
    fn eq(&self, other: &Self) -> bool {
        self.order_key() == other.order_key()
    }
}

impl Eq for EncodedRecord {}

impl PartialOrd for EncodedRecord {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for EncodedRecord {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.order_key().cmp(&other.order_key())
    }
}

/// Buffers records and releases them in a deterministic order once their time is complete.
///
/// Processes of a lockstep run publish in an order the OS scheduler decides, so a logger sees
/// the records of one tick in varying order. The sorter holds records until it is told that no
/// more records with `time_ns <= t` will come ([`complete_until`](Self::complete_until)), then
/// releases those records sorted by `(time_ns, topic order, sequence, …)` (see
/// [`EncodedRecord`]). Two runs that produce the same records therefore produce the same
/// record sequence, however their processes interleave.
///
/// A record arriving for a time already completed cannot be placed deterministically and is
/// refused with [`LogError::LateRecord`].
#[derive(Debug, Default)]
pub struct TickSorter {
    pending: BinaryHeap<Reverse<EncodedRecord>>,
    completed_until: Option<u64>,
}

impl TickSorter {
    /// An empty sorter; no time completed yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether a record of `time_ns` comes too late: that time is already completed.
    pub fn is_late(&self, time_ns: u64) -> bool {
        self.completed_until.is_some_and(|done| time_ns <= done)
    }

    /// Buffers `record`. Fails with [`LogError::LateRecord`] (record not buffered) if its time
    /// was already completed.
    pub fn push(&mut self, record: EncodedRecord) -> Result<(), LogError> {
        match self.completed_until {
            Some(done) if record.time_ns <= done => {
                return Err(LogError::LateRecord {
                    topic: record.topic(),
                    time_ns: record.time_ns,
                    completed_until_ns: done,
                });
            }
            _ => {}
        }
        self.pending.push(Reverse(record));
        Ok(())
    }

    /// Declares every time `<= time_ns` complete and returns the buffered records of those
    /// times, sorted. A `time_ns` below an earlier one releases nothing new.
    pub fn complete_until(&mut self, time_ns: u64) -> Vec<EncodedRecord> {
        let done = self.completed_until.map_or(time_ns, |d| d.max(time_ns));
        self.completed_until = Some(done);
        let mut out = Vec::new();
        while let Some(Reverse(next)) = self.pending.peek() {
            if next.time_ns > done {
                break;
            }
            if let Some(Reverse(record)) = self.pending.pop() {
                out.push(record);
            }
        }
        out
    }

    /// Returns every buffered record, sorted, and completes their times (end of run).
    pub fn drain(&mut self) -> Vec<EncodedRecord> {
        match self.pending.iter().map(|Reverse(r)| r.time_ns).max() {
            Some(last) => self.complete_until(last),
            None => Vec::new(),
        }
    }

    /// Number of buffered records.
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    /// Whether no record is buffered.
    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// The latest completed time, if any.
    pub fn completed_until(&self) -> Option<u64> {
        self.completed_until
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::{GyroSample, Heartbeat, SampleHeader, SimClockTick, WheelCommand};

    fn gyro(t: u64, seq: u64) -> LogRecord {
        GyroSample::new(SampleHeader::new(t, seq, 1), [0.0; 3]).into()
    }

    #[test]
    fn releases_sorted_by_time_topic_sequence() {
        let records = [
            LogRecord::from(WheelCommand::new(SampleHeader::new(10, 0, 1), [1.0; 3])),
            gyro(10, 2),
            LogRecord::from(SimClockTick::new(1, 10, 10)),
            gyro(10, 1),
            gyro(5, 0),
            gyro(20, 3),
        ];
        let mut sorter = TickSorter::new();
        for r in &records {
            sorter.push(EncodedRecord::new(r)).expect("not late");
        }
        let out = sorter.complete_until(10);
        let keys: Vec<_> = out
            .iter()
            .map(|r| (r.time_ns(), r.topic(), r.sequence()))
            .collect();
        assert_eq!(
            keys,
            [
                (5, ipc_types::topic::GYRO, 0),
                (10, ipc_types::topic::GYRO, 1),
                (10, ipc_types::topic::GYRO, 2),
                (10, ipc_types::topic::WHEEL_COMMAND, 0),
                (10, ipc_types::topic::SIM_CLOCK, 1),
            ]
        );
        assert_eq!(sorter.len(), 1);
        assert!(matches!(
            sorter.push(EncodedRecord::new(&gyro(10, 9))),
            Err(LogError::LateRecord {
                time_ns: 10,
                completed_until_ns: 10,
                ..
            })
        ));
        assert!(
            sorter.complete_until(3).is_empty(),
            "completion never goes back"
        );
        assert_eq!(sorter.drain().len(), 1);
        assert!(sorter.is_empty());
    }

    #[test]
    fn content_breaks_ties() {
        let a = LogRecord::from(Heartbeat::new("estimator", 1));
        let b = LogRecord::from(Heartbeat::new("controller", 2));
        let mut one = TickSorter::new();
        let mut two = TickSorter::new();
        for r in [a, b] {
            one.push(EncodedRecord::new(&r)).expect("not late");
        }
        for r in [b, a] {
            two.push(EncodedRecord::new(&r)).expect("not late");
        }
        assert_eq!(one.drain(), two.drain());
    }
}
