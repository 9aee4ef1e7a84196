//! [`LogTail`]: follows a log while its writer is still appending to it, reading only what was
//! appended since the last look.
//!
//! A progress display or a monitor that reopened the whole log each time (as [`RunLog`] does)
//! would cost in proportion to the log's length, read again and again: minutes into a paced
//! run that is more CPU than the pipeline it watches. The tail keeps its place (the start of the
//! first record it has not read) and the channels it has seen, so each look costs what was
//! written since the one before.
//!
//! [`RunLog`]: crate::RunLog

use crate::LogError;
use crate::reader::{Definitions, Framing, Next, parse};
use crate::record::{LogEncode, LogRecord, TopicJson as _};
use ipc_types::TopicId;
use mcap::records::{Record, op};
use std::fs::File;
use std::os::unix::fs::{FileExt, MetadataExt};
use std::path::{Path, PathBuf};

/// Follows the run log at a path (see the [module](self) documentation).
///
/// The log may not exist yet, may be cut anywhere (a record half written is read at the next
/// look, when it is complete) and may be replaced by a new file at the same path, or the file
/// truncated and written again (the tail then starts over: it checks the file's identity and
/// that the last bytes it read are still there).
#[derive(Debug)]
pub struct LogTail {
    path: PathBuf,
    /// Device, inode and creation time of the file being followed.
    file: Option<FileId>,
    /// The last bytes read (the end of the record before `pos`), to notice a file rewritten
    /// in place.
    anchor: Vec<u8>,
    /// Start of the first record not read yet (0: nothing read, not even the magic).
    pos: u64,
    definitions: Definitions,
    /// The last look ended at a data-end or footer record: the writer had finished the data
    /// section. (Each look still reads from there: a file written again with the same first
    /// bytes goes on differently.)
    finished: bool,
}

impl LogTail {
    /// A tail of the log at `path` (nothing is read until [`latest`](Self::latest)).
    pub fn new(path: impl AsRef<Path>) -> Self {
        Self {
            path: path.as_ref().to_owned(),
            file: None,
            anchor: Vec::new(),
            pos: 0,
            definitions: Definitions::default(),
            finished: false,
        }
    }

    /// Offset up to which the file has been read (the start of the first record not read).
    pub fn position(&self) -> u64 {
        self.pos
    }

    /// Whether the writer has finished the data section (nothing more will be appended).
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// Reads what was appended since the last call and returns the newest complete sample of
    /// type `T` in it (`None`: no new sample of `T`, or no file yet). Only that sample's message
    /// is decoded; the other records' bodies are skipped.
    pub fn latest<T: LogEncode>(&mut self) -> Result<Option<T>, LogError> {
        Ok(self
            .newest(&[T::NAME])?
            .first()
            .and_then(|record| T::from_record(record)))
    }

    /// Reads what was appended since the last call and returns, for each of `topics` (their
    /// `ipc_types::topic` names) that has one in it, its newest complete record, in the order
    /// of `topics`. Only those records' messages are decoded; names of topics the log cannot
    /// have are ignored.
    pub fn newest(&mut self, topics: &[&str]) -> Result<Vec<LogRecord>, LogError> {
        // One open per look: identity, the anchor and the records all come from this file.
        let file = match File::open(&self.path) {
            Ok(file) => file,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(e) => return Err(LogError::io(&self.path, e)),
        };
        let meta = file.metadata().map_err(|e| LogError::io(&self.path, e))?;
        let id = FileId {
            device: meta.dev(),
            inode: meta.ino(),
            created: meta.created().ok(),
        };
        if self.file != Some(id)
            || meta.len() < self.pos
            || self.bytes_before_pos(&file)? != self.anchor
        {
            *self = Self::new(&self.path);
            self.file = Some(id);
        }
        let Ok(mut framing) = Framing::on(&self.path, file, self.pos)? else {
            return Ok(Vec::new());
        };
        let wanted: Vec<TopicId> = topics
            .iter()
            .filter_map(|t| TopicId::from_name(t))
            .collect();
        let mut body = Vec::new();
        // Per wanted topic, the newest message so far: its offset and body.
        let mut newest: Vec<Option<(u64, Vec<u8>)>> = vec![None; wanted.len()];
        loop {
            let (opcode, offset, len) = match framing.next()? {
                Next::Record(f) => (f.opcode, f.offset, f.len),
                Next::Cut { offset } => {
                    self.pos = offset;
                    self.finished = false;
                    break;
                }
            };
            match opcode {
                op::SCHEMA | op::CHANNEL => {
                    framing.body(len, &mut body)?;
                    self.definitions.define(parse(opcode, offset, &body)?);
                }
                op::MESSAGE => {
                    framing.body(len, &mut body)?;
                    let kind = self
                        .definitions
                        .channel_of(&body)
                        .and_then(|c| c.kind.as_ref().ok().copied());
                    if let Some(slot) = kind
                        .and_then(|k| wanted.iter().position(|w| *w == k))
                        .and_then(|i| newest.get_mut(i))
                    {
                        // Keep the body's buffer for the next message rather than copying it.
                        let kept = slot.get_or_insert_with(|| (offset, Vec::new()));
                        kept.0 = offset;
                        std::mem::swap(&mut kept.1, &mut body);
                    }
                }
                op::DATA_END | op::FOOTER => {
                    self.finished = true;
                    self.pos = offset;
                    break;
                }
                _ => framing.skip(len)?,
            }
        }
        self.anchor = self.bytes_before_pos(framing.file())?;
        let mut records = Vec::new();
        for (kind, message) in wanted.iter().zip(newest) {
            let Some((offset, body)) = message else {
                continue;
            };
            let Record::Message { data, .. } = parse(op::MESSAGE, offset, &body)? else {
                continue;
            };
            let record = kind.decode(&data).map_err(|source| LogError::Decode {
                offset,
                topic: kind.name(),
                source,
            })?;
            records.push(record);
        }
        Ok(records)
    }
}

/// What identifies a file beyond its path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct FileId {
    device: u64,
    inode: u64,
    /// Creation time where the file system keeps one (an inode number can be reused at once).
    created: Option<std::time::SystemTime>,
}

/// Bytes before the read position compared at each look.
const ANCHOR_BYTES: u64 = 16;

impl LogTail {
    /// The up to [`ANCHOR_BYTES`] bytes of `file` before the read position (empty if the file
    /// is shorter).
    fn bytes_before_pos(&self, file: &File) -> Result<Vec<u8>, LogError> {
        let start = self.pos.saturating_sub(ANCHOR_BYTES);
        let mut bytes = vec![0; (self.pos - start) as usize];
        match file.read_exact_at(&mut bytes, start) {
            Ok(()) => Ok(bytes),
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Ok(Vec::new()),
            Err(e) => Err(LogError::io(&self.path, e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{RunInfo, RunLog, RunLogWriter, WriterOptions};
    use ipc_types::{SampleHeader, SimTruth};
    use std::collections::BTreeMap;
    use std::io::Write;

    /// A directory of its own for one test, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(name: &str) -> Self {
            let dir = std::env::temp_dir()
                .join(format!("testbed-log-tail-{}-{name}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }

        fn path(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// Time between the truth samples, ns.
    const STEP_NS: u64 = 100_000_000;

    fn truth(time_ns: u64) -> SimTruth {
        SimTruth {
            header: SampleHeader {
                time_ns,
                ..SampleHeader::default()
            },
            quaternion: [1.0, 0.0, 0.0, 0.0],
            ..SimTruth::default()
        }
    }

    /// The bytes of a finished, unchunked log of `n` truth samples every `step_ns` (as the
    /// logger writes during a run).
    fn log_bytes(n: u64, step_ns: u64) -> Vec<u8> {
        let info = RunInfo {
            profile: "test".into(),
            seed: 1,
            mode: "lockstep".into(),
            config_toml: String::new(),
            start_time_ns: 0,
            extra: BTreeMap::new(),
        };
        let file = std::io::Cursor::new(Vec::new());
        let mut writer = RunLogWriter::new(file, &info, WriterOptions::default()).unwrap();
        for i in 0..n {
            writer.write(&truth(i * step_ns)).unwrap();
        }
        writer.finish_into_inner().unwrap().1.into_inner()
    }

    #[test]
    fn each_look_reads_what_was_appended_and_gives_the_newest_sample() {
        let dir = Scratch::new("grows");
        let bytes = log_bytes(50, STEP_NS);
        std::fs::write(dir.path().join("whole.mcap"), &bytes).unwrap();
        let whole = RunLog::open(dir.path().join("whole.mcap")).unwrap();
        let times: Vec<u64> = whole
            .samples::<SimTruth>()
            .unwrap()
            .map(|s| s.unwrap().header.time_ns)
            .collect();
        assert_eq!(times.len(), 50);

        // The log grows in pieces cut at arbitrary bytes, as a reader sees a file being written.
        let path = dir.path().join("growing.mcap");
        let mut file = std::fs::File::create(&path).unwrap();
        let mut tail = LogTail::new(&path);
        let mut last_seen = None;
        let mut written = 0usize;
        for piece in [3usize, 40, 700, 1, 1500, 333, 2048, usize::MAX] {
            let end = written.saturating_add(piece).min(bytes.len());
            file.write_all(&bytes[written..end]).unwrap();
            file.flush().unwrap();
            written = end;
            let before = tail.position();
            if let Some(sample) = tail.latest::<SimTruth>().unwrap() {
                // The newest complete sample of the bytes written so far: the same as a whole
                // read of a log cut there.
                let cut = dir.path().join("cut.mcap");
                std::fs::write(&cut, &bytes[..written]).unwrap();
                let expected = RunLog::open(&cut)
                    .unwrap()
                    .samples::<SimTruth>()
                    .unwrap()
                    .last()
                    .unwrap()
                    .unwrap();
                assert_eq!(sample.header.time_ns, expected.header.time_ns);
                last_seen = Some(sample.header.time_ns);
            }
            assert!(tail.position() >= before, "the tail never goes back");
        }
        assert_eq!(last_seen, times.last().copied());
        assert!(tail.is_finished());
        assert_eq!(tail.latest::<SimTruth>().unwrap(), None, "nothing new");
    }

    #[test]
    fn newest_gives_the_last_record_of_each_topic_asked_for_in_their_order() {
        use ipc_types::{AttitudeEstimate, GyroSample, Topic};
        let dir = Scratch::new("topics");
        let path = dir.path().join("run.mcap");
        let info = RunInfo {
            profile: "test".into(),
            seed: 1,
            mode: "paced".into(),
            config_toml: String::new(),
            start_time_ns: 0,
            extra: BTreeMap::new(),
        };
        let options = WriterOptions {
            buffer_bytes: 0,
            indexed: false,
            ..WriterOptions::default()
        };
        let mut writer = RunLogWriter::create_with(&path, &info, options).unwrap();
        let estimate = |time_ns| AttitudeEstimate {
            header: SampleHeader {
                time_ns,
                ..SampleHeader::default()
            },
            ..AttitudeEstimate::default()
        };
        for i in 0..10 {
            writer.write(&truth(i * STEP_NS)).unwrap();
            writer.write(&estimate(i * STEP_NS + 1)).unwrap();
        }
        writer.flush().unwrap();
        let mut tail = LogTail::new(&path);
        let asked = [AttitudeEstimate::NAME, GyroSample::NAME, SimTruth::NAME];
        let records = tail.newest(&asked).unwrap();
        let got: Vec<(&str, u64)> = records
            .iter()
            .map(|r| (r.topic(), r.header().time_ns))
            .collect();
        assert_eq!(
            got,
            [
                (AttitudeEstimate::NAME, 9 * STEP_NS + 1),
                (SimTruth::NAME, 9 * STEP_NS)
            ],
            "no gyro sample was written"
        );

        writer.write(&estimate(10 * STEP_NS + 1)).unwrap();
        writer.flush().unwrap();
        let records = tail.newest(&asked).unwrap();
        assert_eq!(records.len(), 1, "only an estimate was appended");
        assert_eq!(records[0].header().time_ns, 10 * STEP_NS + 1);
    }

    #[test]
    fn a_new_file_at_the_path_starts_the_tail_over() {
        let dir = Scratch::new("replaced");
        let long = log_bytes(30, STEP_NS);
        let path = dir.path().join("run.mcap");
        std::fs::write(&path, &long).unwrap();
        let mut tail = LogTail::new(&path);
        let first = tail.latest::<SimTruth>().unwrap().unwrap();
        assert_eq!(first.header.time_ns, 29 * STEP_NS);

        let short = log_bytes(5, STEP_NS);
        std::fs::remove_file(&path).unwrap();
        std::fs::write(&path, &short).unwrap();
        let second = tail.latest::<SimTruth>().unwrap().unwrap();
        assert_eq!(second.header.time_ns, 4 * STEP_NS);
    }

    #[test]
    fn a_file_written_again_in_place_starts_the_tail_over() {
        let dir = Scratch::new("rewritten");
        let path = dir.path().join("run.mcap");
        let first_run = log_bytes(30, STEP_NS);
        std::fs::write(&path, &first_run).unwrap();
        let mut tail = LogTail::new(&path);
        tail.latest::<SimTruth>().unwrap().unwrap();

        // Another run truncates the file and writes it again through the same inode, longer
        // than before: only the bytes before the read position tell.
        let second_run = log_bytes(40, STEP_NS / 2);
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .truncate(true)
            .open(&path)
            .unwrap();
        file.write_all(&second_run).unwrap();
        drop(file);
        let sample = tail.latest::<SimTruth>().unwrap().unwrap();
        assert_eq!(sample.header.time_ns, 39 * STEP_NS / 2);
    }

    #[test]
    fn no_file_yet_is_not_an_error_and_a_foreign_file_is() {
        let dir = Scratch::new("missing");
        let path = dir.path().join("later.mcap");
        let mut tail = LogTail::new(&path);
        assert_eq!(tail.latest::<SimTruth>().unwrap(), None);
        std::fs::write(&path, b"not an MCAP file at all").unwrap();
        assert!(matches!(tail.latest::<SimTruth>(), Err(LogError::NotMcap)));
    }
}
