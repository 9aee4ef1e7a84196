//! [`RunLogWriter`]: writes one run's MCAP log.

use crate::foxglove;
use crate::record::{LogEncode, LogRecord, TopicJson as _};
use crate::sorter::{EncodedRecord, TickSorter};
use crate::{
    CONFIG_ATTACHMENT, CONFIG_MEDIA_TYPE, FORMAT, LogError, MESSAGE_ENCODING, RESERVED_KEYS,
    RUN_METADATA, RunInfo, SCHEMA_ENCODING, keys,
};
use ipc_types::TopicId;
use mcap::records::{MessageHeader, Metadata};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

/// Order in which [`RunLogWriter`] writes records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RecordOrder {
    /// In the order of the `write` calls, immediately (paced runs and hardware).
    #[default]
    Arrival,
    /// Buffered in a [`TickSorter`] and written sorted by `(time_ns, topic order, sequence, …)`
    /// when [`RunLogWriter::complete_until`] declares their time complete (lockstep runs:
    /// the file's bytes do not depend on how the processes interleaved).
    Sorted,
}

/// Options of [`RunLogWriter`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriterOptions {
    /// Record order.
    pub order: RecordOrder,
    /// Capacity of the write buffer of [`RunLogWriter::create`], bytes. Records in the buffer
    /// are lost if the process dies before the next flush; 0 hands every record to the OS as it
    /// is written (one or more `write` system calls per record).
    pub buffer_bytes: usize,
    /// For a file made by [`RunLogWriter::create`]: on [`finish`](RunLogWriter::finish),
    /// rewrite it as an indexed (chunked) MCAP file with [`index`](crate::index), so viewers
    /// can seek. A file never finished stays unchunked (crash-safe, see the type's docs).
    pub indexed: bool,
}

impl Default for WriterOptions {
    /// Arrival order, 64 KiB buffer, indexed when finished.
    fn default() -> Self {
        Self {
            order: RecordOrder::Arrival,
            buffer_bytes: 64 * 1024,
            indexed: true,
        }
    }
}

impl WriterOptions {
    /// Options for a lockstep run: [`RecordOrder::Sorted`], default buffer.
    pub fn lockstep() -> Self {
        Self {
            order: RecordOrder::Sorted,
            ..Self::default()
        }
    }
}

/// Message counts of a finished log.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LogStats {
    /// Messages written.
    pub messages: u64,
    /// Messages written per topic, in table order ([`TopicId::ALL`], every topic listed).
    pub per_topic: Vec<(&'static str, u64)>,
    /// In [`RecordOrder::Sorted`]: records that arrived after their time was completed,
    /// written at once (out of time order) rather than lost.
    pub late_records: u64,
}

/// The channel id of `topic` in every run log: the table's topics come first, in table order,
/// from 1. The ground link gives its viewers the same ids.
pub const fn channel_id(topic: TopicId) -> u16 {
    topic.index() as u16 + 1
}

/// The channel id of the `i`-th of [`foxglove::DERIVED_TOPICS`](crate::foxglove::DERIVED_TOPICS)
/// in every run log: after the table's topics.
pub const fn derived_channel_id(i: usize) -> u16 {
    (TopicId::ALL.len() + 1 + i) as u16
}

/// Writes one run's log: an MCAP file with every topic, the run's configuration and metadata.
///
/// # File layout
///
/// Header, then one JSON Schema (`jsonschema`) and one channel (`json` messages) per topic of
/// the topic table, in table order (channel ids [`channel_id`]: 1, 2, …), the configuration as
/// attachment
/// [`CONFIG_ATTACHMENT`], the run metadata record [`RUN_METADATA`], then the messages, and on
/// [`finish`](Self::finish) the summary section (schemas, channels, statistics, attachment and
/// metadata indexes) and footer. Every message's `log_time` and `publish_time` is
/// [`RunInfo::start_time_ns`] plus the sample's `header.time_ns`, its MCAP `sequence` the low
/// 32 bits of `header.sequence`. After the sample topics come the derived channels
/// ([`derived_channel_id`], [`foxglove::DERIVED_TOPICS`](crate::foxglove::DERIVED_TOPICS)):
/// each valid attitude estimate is followed by its `foxglove.FrameTransform` and
/// `foxglove.PoseInFrame`, each truth sample by its transform, each health event, ground
/// command acknowledgement and controller mode change by a `foxglove.Log`, and, once a scene is
/// set ([`set_scene`](Self::set_scene)), a `foxglove.SceneUpdate` precedes the first record of
/// every second. Nothing in the file comes from the wall clock but the start time given (the
/// attachment's `log_time` and `create_time` are that start time too), so the same records in
/// the same order with the same start time give the same bytes.
///
/// # Crash safety
///
/// Records are written unchunked, straight into the data section, so a file cut at any byte
/// (a killed logger, a full disk) still holds every record before the cut intact and readable
/// by a streaming reader ([`RunLog`](crate::RunLog), Python `mcap`'s `StreamReader`,
/// `mcap recover`). A record is safe once it has reached the OS: on
/// [`flush`](Self::flush), [`complete_until`](Self::complete_until), when the write buffer
/// fills, or per record with [`WriterOptions::buffer_bytes`] = 0; [`sync`](Self::sync)
/// also survives power loss. Unchunked records have no index and no compression; with
/// [`WriterOptions::indexed`] (the default), [`finish`](Self::finish) rewrites the complete
/// file with zstd-compressed chunks of [`CHUNK_INTERVAL_NS`](crate::CHUNK_INTERVAL_NS) each,
/// message indexes and a chunk index ([`index`](crate::index)), atomically: some a sixth of
/// the unchunked size.
pub struct RunLogWriter<W: Write + Seek = BufWriter<File>> {
    mcap: Option<mcap::Writer<W>>,
    channel_ids: Vec<u16>,
    /// The controller's mode changes, for the events channel.
    modes: foxglove::events::ModeChanges,
    /// The platform's scene, written every [`SCENE_PERIOD_NS`](foxglove::scene::SCENE_PERIOD_NS)
    /// of log time, and when the next is due.
    scene: Option<(foxglove::scene::Scene, u64)>,
    start_time_ns: u64,
    /// The file to index on finish (a file made by `create` with `indexed`).
    index_path: Option<std::path::PathBuf>,
    counts: Vec<u64>,
    sorter: Option<TickSorter>,
    late_records: u64,
    sync_file: Option<File>,
    scratch: Vec<u8>,
}

impl RunLogWriter<BufWriter<File>> {
    /// Creates (or truncates) the log file at `path` with [`WriterOptions::default`] (arrival
    /// order) and writes the header, schemas, channels, configuration and run metadata.
    pub fn create(path: impl AsRef<Path>, info: &RunInfo) -> Result<Self, LogError> {
        Self::create_with(path, info, WriterOptions::default())
    }

    /// As [`create`](Self::create), with `options`.
    pub fn create_with(
        path: impl AsRef<Path>,
        info: &RunInfo,
        options: WriterOptions,
    ) -> Result<Self, LogError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|e| LogError::io(path, e))?;
        let sync_file = file.try_clone().map_err(|e| LogError::io(path, e))?;
        let mut writer = Self::new(
            BufWriter::with_capacity(options.buffer_bytes, file),
            info,
            options,
        )?;
        writer.sync_file = Some(sync_file);
        writer.index_path = options.indexed.then(|| path.to_owned());
        Ok(writer)
    }
}

impl<W: Write + Seek> RunLogWriter<W> {
    /// Starts a log on `writer` and writes the header, schemas, channels, configuration and
    /// run metadata ([`WriterOptions::buffer_bytes`] is not used: buffer `writer` yourself).
    pub fn new(writer: W, info: &RunInfo, options: WriterOptions) -> Result<Self, LogError> {
        if let Some(key) = info
            .extra
            .keys()
            .find(|k| RESERVED_KEYS.contains(&k.as_str()))
        {
            return Err(LogError::ReservedKey(key.clone()));
        }
        let mcap_options = mcap::WriteOptions::new()
            .use_chunks(false)
            .compression(None)
            .profile("")
            .library(format!("testbed-log/{}", env!("CARGO_PKG_VERSION")));
        let mut mcap = mcap_options.create(writer)?;

        let mut channel_ids = Vec::with_capacity(TopicId::ALL.len());
        for &kind in TopicId::ALL {
            let schema = kind.json_schema();
            let schema_id =
                mcap.add_schema(kind.schema_name(), SCHEMA_ENCODING, schema.as_bytes())?;
            let channel_id =
                mcap.add_channel(schema_id, kind.name(), MESSAGE_ENCODING, &BTreeMap::new())?;
            debug_assert_eq!(channel_id, self::channel_id(kind));
            channel_ids.push(channel_id);
        }
        for (i, (topic, (name, schema))) in foxglove::DERIVED_TOPICS
            .iter()
            .zip(foxglove::derived_schemas())
            .enumerate()
        {
            // One schema per name (the two transforms share theirs).
            let schema_id = mcap.add_schema(name, SCHEMA_ENCODING, schema.as_bytes())?;
            let channel_id =
                mcap.add_channel(schema_id, topic, MESSAGE_ENCODING, &BTreeMap::new())?;
            debug_assert_eq!(channel_id, derived_channel_id(i));
        }

        // Dated the run's start, the instant the configuration took effect (not 1970, and no
        // wall-clock reading of its own, so the file stays reproducible).
        mcap.attach(&mcap::Attachment {
            log_time: info.start_time_ns,
            create_time: info.start_time_ns,
            name: CONFIG_ATTACHMENT.to_owned(),
            media_type: CONFIG_MEDIA_TYPE.to_owned(),
            data: Cow::Borrowed(info.config_toml.as_bytes()),
        })?;

        let mut metadata = info.extra.clone();
        metadata.insert(keys::FORMAT.to_owned(), FORMAT.to_owned());
        metadata.insert(keys::PROFILE.to_owned(), info.profile.clone());
        metadata.insert(keys::SEED.to_owned(), info.seed.to_string());
        metadata.insert(keys::MODE.to_owned(), info.mode.clone());
        metadata.insert(
            keys::START_TIME_NS.to_owned(),
            info.start_time_ns.to_string(),
        );
        metadata.insert(
            keys::START_TIME.to_owned(),
            humantime::format_rfc3339_nanos(
                std::time::UNIX_EPOCH + std::time::Duration::from_nanos(info.start_time_ns),
            )
            .to_string(),
        );
        mcap.write_metadata(&Metadata {
            name: RUN_METADATA.to_owned(),
            metadata,
        })?;
        mcap.flush()?;

        Ok(Self {
            mcap: Some(mcap),
            counts: vec![0; channel_ids.len()],
            channel_ids,
            modes: Default::default(),
            scene: None,
            start_time_ns: info.start_time_ns,
            index_path: None,
            sorter: (options.order == RecordOrder::Sorted).then(TickSorter::new),
            late_records: 0,
            sync_file: None,
            scratch: Vec::with_capacity(1024),
        })
    }

    /// Logs `sample` (immediately, or buffered until its time is complete in
    /// [`RecordOrder::Sorted`]).
    pub fn write<T: LogEncode>(&mut self, sample: &T) -> Result<(), LogError> {
        self.write_record(&sample.into_record())
    }

    /// Logs `record` (see [`write`](Self::write)).
    ///
    /// In [`RecordOrder::Sorted`], a record whose time was already completed is written at
    /// once, out of time order, and counted ([`LogStats::late_records`]): never lost.
    pub fn write_record(&mut self, record: &LogRecord) -> Result<(), LogError> {
        if let Some(sorter) = &mut self.sorter {
            let header = record.header();
            if !sorter.is_late(header.time_ns) {
                return sorter.push(EncodedRecord::new(record));
            }
            // Its place in the sorted order is gone; losing it would be worse than writing it
            // out of order (MCAP allows any order; readers that sort by time still place it).
            self.late_records += 1;
            tracing::warn!(
                topic = record.topic_id().name(),
                time_ns = header.time_ns,
                "late record written out of time order"
            );
            return self.write_encoded(&EncodedRecord::new(record));
        }
        let mut data = std::mem::take(&mut self.scratch);
        data.clear();
        record.encode_json(&mut data);
        let header = record.header();
        let result = self.put(
            record.topic_id(),
            header.time_ns,
            header.sequence,
            &data,
            &foxglove::derived_of(record),
        );
        self.scratch = data;
        result
    }

    /// Logs an already encoded record, e.g. one released by an external [`TickSorter`]
    /// (bypasses this writer's sorter).
    pub fn write_encoded(&mut self, record: &EncodedRecord) -> Result<(), LogError> {
        self.put(
            record.topic_id(),
            record.time_ns(),
            record.sequence(),
            record.data(),
            record.derived(),
        )
    }

    /// Draws `scene` (the platform's shape) on the scene channel from the next record on,
    /// every [`SCENE_PERIOD_NS`](foxglove::scene::SCENE_PERIOD_NS) of log time.
    pub fn set_scene(&mut self, scene: foxglove::scene::Scene) {
        self.scene = Some((scene, 0));
    }

    /// Writes one message, and what it derives (taken from the record, never decoded back
    /// from `data`: that was most of the cost of logging an estimate or a truth sample).
    fn put(
        &mut self,
        kind: TopicId,
        time_ns: u64,
        sequence: u64,
        data: &[u8],
        derived: &foxglove::Derived,
    ) -> Result<(), LogError> {
        let index = kind as usize;
        let (Some(mcap), Some(&channel_id)) = (&mut self.mcap, self.channel_ids.get(index)) else {
            return Err(LogError::Finished);
        };
        let log_time = self.start_time_ns.saturating_add(time_ns);
        let header = MessageHeader {
            channel_id,
            // MCAP's sequence is 32 bits; the full sequence is in the JSON header.
            sequence: sequence as u32,
            log_time,
            publish_time: log_time,
        };
        if let Some((scene, due)) = &mut self.scene
            && log_time >= *due
        {
            let text = scene.update_json(log_time);
            *due = log_time.saturating_add(foxglove::scene::SCENE_PERIOD_NS);
            mcap.write_to_known_channel(
                &MessageHeader {
                    channel_id: derived_channel_id(4),
                    ..header
                },
                text.as_bytes(),
            )?;
        }
        mcap.write_to_known_channel(&header, data)?;
        if let Some(count) = self.counts.get_mut(index) {
            *count += 1;
        }
        let mut derive = |i: usize, text: &str| {
            mcap.write_to_known_channel(
                &MessageHeader {
                    channel_id: derived_channel_id(i),
                    ..header
                },
                text.as_bytes(),
            )
        };
        match derived {
            foxglove::Derived::Nothing => {}
            foxglove::Derived::Transform((topic, child, q)) => {
                let estimate = *topic == foxglove::TF_ESTIMATE_TOPIC;
                derive(
                    if estimate { 0 } else { 1 },
                    &foxglove::frame_transform_json(log_time, child, q),
                )?;
                if estimate {
                    derive(2, &foxglove::pose_in_frame_json(log_time, q))?;
                }
            }
            foxglove::Derived::Event(event) => derive(3, &event.log_json(log_time))?,
            foxglove::Derived::Mode(mode) => {
                if let Some(event) = self.modes.event(*mode) {
                    derive(3, &event.log_json(log_time))?;
                }
            }
        }
        Ok(())
    }

    /// Declares every time `<= time_ns` complete: in [`RecordOrder::Sorted`] writes the
    /// buffered records of those times in sorted order. Then flushes (see
    /// [`flush`](Self::flush)). Call once per tick (lockstep: when tick `n + 1` is seen, all
    /// records up to tick `n`'s time are in).
    pub fn complete_until(&mut self, time_ns: u64) -> Result<(), LogError> {
        if let Some(sorter) = &mut self.sorter {
            for record in sorter.complete_until(time_ns) {
                self.write_encoded(&record)?;
            }
        }
        self.flush()
    }

    /// Hands every written record to the OS: from then on it survives the logger being
    /// killed. Records buffered in the sorter are not written (see
    /// [`complete_until`](Self::complete_until)).
    pub fn flush(&mut self) -> Result<(), LogError> {
        match &mut self.mcap {
            Some(mcap) => Ok(mcap.flush()?),
            None => Err(LogError::Finished),
        }
    }

    /// [`flush`](Self::flush), then, for a file made by [`create`](RunLogWriter::create),
    /// `fsync`s it (survives power loss; slow, so not per tick).
    pub fn sync(&mut self) -> Result<(), LogError> {
        self.flush()?;
        if let Some(file) = &self.sync_file {
            file.sync_data().map_err(LogError::Io)?;
        }
        Ok(())
    }

    /// Number of records waiting in the sorter ([`RecordOrder::Sorted`]).
    pub fn pending(&self) -> usize {
        self.sorter.as_ref().map_or(0, TickSorter::len)
    }

    /// Writes the records still in the sorter (sorted), the summary section and the footer,
    /// flushes and (for a file made by [`create`](RunLogWriter::create)) `fsync`s.
    pub fn finish(self) -> Result<LogStats, LogError> {
        self.finish_into_inner().map(|(stats, _)| stats)
    }

    /// As [`finish`](Self::finish), returning the underlying writer too.
    pub fn finish_into_inner(mut self) -> Result<(LogStats, W), LogError> {
        self.drain_sorter()?;
        let Some(mut mcap) = self.mcap.take() else {
            return Err(LogError::Finished);
        };
        mcap.finish()?;
        let mut inner = mcap.into_inner();
        inner.flush().map_err(LogError::Io)?;
        if let Some(file) = &self.sync_file {
            file.sync_all().map_err(LogError::Io)?;
        }
        if let Some(path) = &self.index_path {
            crate::index(path)?;
        }
        let per_topic: Vec<_> = TopicId::ALL
            .iter()
            .map(|k| k.name())
            .zip(self.counts.iter().copied())
            .collect();
        Ok((
            LogStats {
                messages: per_topic.iter().map(|(_, n)| n).sum(),
                per_topic,
                late_records: self.late_records,
            },
            inner,
        ))
    }

    fn drain_sorter(&mut self) -> Result<(), LogError> {
        if let Some(sorter) = &mut self.sorter {
            for record in sorter.drain() {
                self.write_encoded(&record)?;
            }
        }
        Ok(())
    }
}

impl<W: Write + Seek> Drop for RunLogWriter<W> {
    /// Without [`finish`](RunLogWriter::finish): writes the sorter's records; the MCAP writer
    /// then writes the summary and footer on its own drop (errors ignored).
    fn drop(&mut self) {
        if self.mcap.is_some() {
            let _ = self.drain_sorter();
        }
    }
}

impl<W: Write + Seek> std::fmt::Debug for RunLogWriter<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunLogWriter")
            .field("finished", &self.mcap.is_none())
            .field("counts", &self.counts)
            .field("pending", &self.pending())
            .finish_non_exhaustive()
    }
}
