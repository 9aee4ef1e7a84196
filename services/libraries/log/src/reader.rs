//! [`RunLog`]: reads a run log back, tolerating a file cut at any byte.

use crate::record::{LogEncode, LogRecord, TopicJson as _};
use crate::{
    CONFIG_ATTACHMENT, LogError, MESSAGE_ENCODING, RUN_METADATA, RunInfo, SCHEMA_ENCODING, keys,
};
use ipc_types::TopicId;
use mcap::records::{Record, op};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

/// How a log file ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogEnd {
    /// The file ends with the footer and magic: the writer finished it.
    Complete,
    /// The file was cut (writer killed or not finished): every record before `offset` is
    /// complete, the bytes from `offset` on (to `file_len`) are an incomplete record or missing
    /// the rest of the file.
    Truncated {
        /// End of the last complete record (= start of the incomplete one).
        offset: u64,
        /// Length of the file.
        file_len: u64,
    },
}

impl std::fmt::Display for LogEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Complete => write!(f, "file complete"),
            Self::Truncated { offset, file_len } => {
                write!(
                    f,
                    "file cut: complete records end at byte {offset} of {file_len}"
                )
            }
        }
    }
}

/// What a channel of the file decodes to.
#[derive(Debug, Clone)]
pub(crate) struct ChannelEntry {
    pub(crate) topic: String,
    pub(crate) kind: Result<TopicId, String>,
}

/// The schemas and channels a file's records define. The first definition of an id is kept.
#[derive(Debug, Clone, Default)]
pub(crate) struct Definitions {
    schemas: BTreeMap<u16, (String, String)>,
    pub(crate) channels: BTreeMap<u16, ChannelEntry>,
}

impl Definitions {
    /// Takes in a schema or channel record: `None` (it is kept), or the record given back if
    /// it is neither.
    pub(crate) fn define<'a>(&mut self, record: Record<'a>) -> Option<Record<'a>> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas
                    .entry(header.id)
                    .or_insert((header.name, header.encoding));
                None
            }
            Record::Channel(c) => {
                let kind = channel_kind(&c, &self.schemas);
                self.channels.entry(c.id).or_insert(ChannelEntry {
                    topic: c.topic,
                    kind,
                });
                None
            }
            other => Some(other),
        }
    }

    /// The channel a message record's body (its first two bytes: the channel id) is on.
    pub(crate) fn channel_of(&self, message_body: &[u8]) -> Option<&ChannelEntry> {
        let id = message_body.get(..2)?;
        self.channels.get(&u16::from_le_bytes([id[0], id[1]]))
    }
}

impl ChannelEntry {
    /// A channel the writer derives from the samples ([`foxglove`](crate::foxglove)).
    fn is_derived(&self) -> bool {
        crate::foxglove::DERIVED_TOPICS.contains(&self.topic.as_str())
    }
}

/// An opened run log: its run information, how it ends, and iterators over its records.
///
/// [`open`](Self::open) scans the file's record structure once (message bodies are skipped),
/// so it knows the channels, the run information and whether and where the file was cut;
/// the iterators then decode messages in file order (within a chunk by log time, see
/// [`index`](crate::index)), up to the end of the data section or the
/// cut.
#[derive(Debug, Clone)]
pub struct RunLog {
    path: PathBuf,
    info: RunInfo,
    library: String,
    channels: BTreeMap<u16, ChannelEntry>,
    /// Messages are read from the start up to this offset (data end or cut).
    data_end: u64,
    end: LogEnd,
    message_count: u64,
}

/// Outcome of reading the next record's framing.
pub(crate) enum Next {
    /// A complete record.
    Record(Frame),
    /// The bytes from `offset` on do not hold a complete record.
    Cut { offset: u64 },
}

/// The framing of one complete record.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Frame {
    pub(crate) opcode: u8,
    /// Offset of the opcode byte.
    pub(crate) offset: u64,
    /// Body length.
    pub(crate) len: u64,
}

/// Reads MCAP record framing (opcode, length) from a file of known length.
///
/// Chunks (uncompressed or zstd) are opened transparently: the records inside a chunk are
/// returned one by one as if they were in the data section, each with the chunk's offset, its
/// messages in log-time order ([`chunk_order`]).
pub(crate) struct Framing {
    reader: BufReader<File>,
    pos: u64,
    file_len: u64,
    chunk: Option<ChunkCursor>,
}

/// The records of the chunk being read.
struct ChunkCursor {
    /// Offset of the chunk record in the file.
    offset: u64,
    /// The chunk's records (decompressed).
    records: Vec<u8>,
    /// Where each record is in `records` (opcode, body), in the order they are returned: the
    /// definitions first, then the messages by log time (see [`chunk_order`]).
    order: Vec<(u8, std::ops::Range<usize>)>,
    /// Index in `order` of the next record to return.
    next: usize,
    /// Body of the record last returned by [`Framing::next`], if it came from this chunk.
    body: Option<std::ops::Range<usize>>,
}

/// The records of a chunk's `records` (opcode, body range), in the order a reader of samples
/// wants them: schemas, channels and other records in chunk order, then the messages by
/// `log_time` (stable: messages of one time keep their chunk order). The indexed log groups a
/// chunk's messages by channel ([`index`](crate::index)), which compresses better; ordered by
/// time again, a lockstep log's samples come in the order the logger sorted them (time, then
/// topic order: the channel ids follow the topic table), as in the unchunked file.
fn chunk_order(offset: u64, records: &[u8]) -> Result<Vec<(u8, std::ops::Range<usize>)>, LogError> {
    let mut definitions = Vec::new();
    let mut messages = Vec::new();
    let mut next = 0;
    while next < records.len() {
        let frame = records.get(next..next + 9).ok_or(LogError::Unsupported {
            offset,
            what: "a chunk whose last record is cut",
        })?;
        let opcode = frame[0];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&frame[1..9]);
        let start = next + 9;
        let end = usize::try_from(u64::from_le_bytes(len_bytes))
            .ok()
            .and_then(|len| start.checked_add(len))
            .filter(|end| *end <= records.len())
            .ok_or(LogError::Unsupported {
                offset,
                what: "a chunk whose records overrun it",
            })?;
        // A message body: channel id (2), sequence (4), log time (8), …
        match records.get(start + 6..start + 14) {
            Some(time) if opcode == op::MESSAGE => {
                let mut t = [0u8; 8];
                t.copy_from_slice(time);
                messages.push((u64::from_le_bytes(t), (opcode, start..end)));
            }
            _ => definitions.push((opcode, start..end)),
        }
        next = end;
    }
    messages.sort_by_key(|(time, _)| *time);
    definitions.extend(messages.into_iter().map(|(_, record)| record));
    Ok(definitions)
}

impl Framing {
    /// Opens the log at `path` and checks the leading magic; a file too short to hold it is a
    /// log without its header.
    pub(crate) fn open_log(path: &Path) -> Result<Self, LogError> {
        Self::open(path)?.map_err(|file_len| LogError::MissingRunInfo {
            missing: "header",
            end: LogEnd::Truncated {
                offset: 0,
                file_len,
            },
        })
    }

    /// Opens `path` and checks the leading magic. `Err(file_len)`: the file is shorter than
    /// the magic but a prefix of it.
    pub(crate) fn open(path: &Path) -> Result<Result<Self, u64>, LogError> {
        let file = File::open(path).map_err(|e| LogError::io(path, e))?;
        Self::on(path, file, 0)
    }

    /// Reads `file` (opened from `path`, named in errors) from `pos`, the start of a record
    /// found by an earlier reading; from 0 the magic is checked as by [`open`](Self::open).
    /// `Err(file_len)`: the file is shorter than `pos` (or than the magic).
    pub(crate) fn on(path: &Path, file: File, pos: u64) -> Result<Result<Self, u64>, LogError> {
        let file_len = file.metadata().map_err(|e| LogError::io(path, e))?.len();
        let mut reader = BufReader::with_capacity(64 * 1024, file);
        if pos > 0 {
            if file_len < pos {
                return Ok(Err(file_len));
            }
            reader
                .seek(SeekFrom::Start(pos))
                .map_err(|e| LogError::io(path, e))?;
            return Ok(Ok(Self {
                reader,
                pos,
                file_len,
                chunk: None,
            }));
        }
        let magic_len = mcap::MAGIC.len() as u64;
        let head_len = file_len.min(magic_len) as usize;
        let mut head = [0u8; 8];
        let head = head.get_mut(..head_len).ok_or(LogError::NotMcap)?;
        reader.read_exact(head).map_err(|e| LogError::io(path, e))?;
        if !mcap::MAGIC.starts_with(head) {
            return Err(LogError::NotMcap);
        }
        if file_len < magic_len {
            return Ok(Err(file_len));
        }
        Ok(Ok(Self {
            reader,
            pos: magic_len,
            file_len,
            chunk: None,
        }))
    }

    /// The file read.
    pub(crate) fn file(&self) -> &File {
        self.reader.get_ref()
    }

    /// Length of the file.
    pub(crate) fn file_len(&self) -> u64 {
        self.file_len
    }

    /// After the footer's body: whether the closing magic follows (the file is complete).
    pub(crate) fn end_after_footer(&mut self) -> Result<LogEnd, LogError> {
        let rest = self.file_len - self.pos;
        let mut magic = [0u8; 8];
        let n = rest.min(8) as usize;
        let tail = magic.get_mut(..n).ok_or(LogError::NotMcap)?;
        self.reader.read_exact(tail)?;
        Ok(if n == 8 && *tail == *mcap::MAGIC {
            LogEnd::Complete
        } else {
            LogEnd::Truncated {
                offset: self.pos,
                file_len: self.file_len,
            }
        })
    }

    /// Whether the last record returned by [`next`](Self::next) came from inside a chunk
    /// (the file position is then past the whole chunk).
    pub(crate) fn in_chunk(&self) -> bool {
        self.chunk.as_ref().is_some_and(|c| c.body.is_some())
    }

    pub(crate) fn next(&mut self) -> Result<Next, LogError> {
        loop {
            if let Some(chunk) = &mut self.chunk {
                chunk.body = None;
                if let Some((opcode, range)) = chunk.order.get(chunk.next).cloned() {
                    chunk.next += 1;
                    let len = (range.end - range.start) as u64;
                    chunk.body = Some(range);
                    return Ok(Next::Record(Frame {
                        opcode,
                        offset: chunk.offset,
                        len,
                    }));
                }
                self.chunk = None;
            }
            let next = self.next_in_file()?;
            match next {
                Next::Record(Frame {
                    opcode: op::CHUNK,
                    offset,
                    len,
                }) => {
                    let mut body = Vec::new();
                    self.body(len, &mut body)?;
                    let Record::Chunk { header, data } = parse(op::CHUNK, offset, &body)? else {
                        continue;
                    };
                    let records = match header.compression.as_str() {
                        "" => data.into_owned(),
                        "zstd" => {
                            let size = usize::try_from(header.uncompressed_size).map_err(|_| {
                                LogError::Unsupported {
                                    offset,
                                    what: "a chunk larger than memory",
                                }
                            })?;
                            zstd::bulk::decompress(&data, size)
                                .map_err(|source| LogError::Decompress { offset, source })?
                        }
                        _ => {
                            return Err(LogError::Unsupported {
                                offset,
                                what: "a chunk compressed other than with zstd",
                            });
                        }
                    };
                    let order = chunk_order(offset, &records)?;
                    self.chunk = Some(ChunkCursor {
                        offset,
                        records,
                        order,
                        next: 0,
                        body: None,
                    });
                }
                other => return Ok(other),
            }
        }
    }

    fn next_in_file(&mut self) -> Result<Next, LogError> {
        let offset = self.pos;
        if self.file_len - offset < 9 {
            return Ok(Next::Cut { offset });
        }
        let mut frame = [0u8; 9];
        self.reader.read_exact(&mut frame)?;
        let [opcode, len @ ..] = frame;
        let len = u64::from_le_bytes(len);
        if len > self.file_len - offset - 9 {
            // Put the reader back at the record start (callers stop here anyway).
            self.reader.seek(SeekFrom::Start(offset))?;
            return Ok(Next::Cut { offset });
        }
        self.pos = offset + 9 + len;
        Ok(Next::Record(Frame {
            opcode,
            offset,
            len,
        }))
    }

    pub(crate) fn body(&mut self, len: u64, buf: &mut Vec<u8>) -> Result<(), LogError> {
        buf.clear();
        if let Some(ChunkCursor {
            records,
            body: Some(range),
            ..
        }) = &self.chunk
        {
            buf.extend_from_slice(records.get(range.clone()).unwrap_or_default());
            return Ok(());
        }
        // `len` fits the file (checked in `next`), so it fits memory as a file read would.
        buf.resize(
            usize::try_from(len).map_err(|_| std::io::Error::other("record too large"))?,
            0,
        );
        self.reader.read_exact(buf)?;
        Ok(())
    }

    pub(crate) fn skip(&mut self, len: u64) -> Result<(), LogError> {
        if self.in_chunk() {
            return Ok(());
        }
        match i64::try_from(len) {
            Ok(len) => self.reader.seek_relative(len)?,
            Err(_) => {
                self.reader.seek(SeekFrom::Start(self.pos))?;
            }
        }
        Ok(())
    }
}

pub(crate) fn parse(opcode: u8, offset: u64, body: &[u8]) -> Result<Record<'_>, LogError> {
    mcap::parse_record(opcode, body).map_err(|source| LogError::Corrupt { offset, source })
}

impl RunLog {
    /// Opens the log at `path`: reads its run information and channels and finds where it
    /// ends. A file cut at any byte after the run information opens fine (see
    /// [`end`](Self::end)).
    pub fn open(path: impl AsRef<Path>) -> Result<Self, LogError> {
        let path = path.as_ref();
        let mut framing = Framing::open_log(path)?;
        let file_len = framing.file_len;
        let mut definitions = Definitions::default();
        let mut library = String::new();
        let mut config = None;
        let mut metadata = None;
        let mut message_count = 0;
        let mut data_end = None;
        let mut end = None;
        let mut body = Vec::new();

        while end.is_none() {
            let (opcode, offset, len) = match framing.next()? {
                Next::Record(f) => (f.opcode, f.offset, f.len),
                Next::Cut { offset } => {
                    end = Some(LogEnd::Truncated { offset, file_len });
                    break;
                }
            };
            let in_data = data_end.is_none();
            match opcode {
                op::MESSAGE if in_data => {
                    // Samples only: the derived transforms are not counted.
                    framing.body(len, &mut body)?;
                    let derived = definitions
                        .channel_of(&body)
                        .is_some_and(ChannelEntry::is_derived);
                    if !derived {
                        message_count += 1;
                    }
                }
                // A chunked file's channels without messages are only in the summary.
                // Schemas and channels are also read from the summary: a chunked file's channels
                // without messages are only there. The first definition of an id is kept.
                op::HEADER | op::SCHEMA | op::CHANNEL | op::ATTACHMENT | op::METADATA
                    if in_data || matches!(opcode, op::SCHEMA | op::CHANNEL) =>
                {
                    framing.body(len, &mut body)?;
                    match definitions.define(parse(opcode, offset, &body)?) {
                        Some(Record::Header(h)) => library = h.library,
                        Some(Record::Attachment { header, data, .. })
                            if header.name == CONFIG_ATTACHMENT =>
                        {
                            let text = String::from_utf8(data.into_owned()).map_err(|_| {
                                LogError::BadRunInfo {
                                    key: "config.toml",
                                    problem: "not UTF-8".to_owned(),
                                }
                            })?;
                            config = Some(text);
                        }
                        Some(Record::Metadata(m)) if m.name == RUN_METADATA => {
                            metadata = Some(m.metadata);
                        }
                        _ => {}
                    }
                }
                op::DATA_END if in_data => {
                    data_end = Some(offset);
                    framing.skip(len)?;
                }
                op::FOOTER => {
                    framing.skip(len)?;
                    end = Some(framing.end_after_footer()?);
                }
                _ => framing.skip(len)?,
            }
        }
        let end = end.unwrap_or(LogEnd::Truncated {
            offset: framing.pos,
            file_len,
        });
        let data_end = match (data_end, end) {
            (Some(d), _) => d,
            (None, LogEnd::Truncated { offset, .. }) => offset,
            (None, LogEnd::Complete) => framing.pos,
        };

        let config_toml = config.ok_or(LogError::MissingRunInfo {
            missing: "configuration attachment (config.toml)",
            end,
        })?;
        let metadata = metadata.ok_or(LogError::MissingRunInfo {
            missing: "run metadata record (testbed.run)",
            end,
        })?;
        let info = run_info(metadata, config_toml)?;
        Ok(Self {
            path: path.to_owned(),
            info,
            library,
            channels: definitions.channels,
            data_end,
            end,
            message_count,
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The run information: profile, seed, mode, configuration text, further entries.
    pub fn info(&self) -> &RunInfo {
        &self.info
    }

    /// The configuration text (the `config.toml` attachment).
    pub fn config_toml(&self) -> &str {
        &self.info.config_toml
    }

    /// The library that wrote the file (MCAP header).
    pub fn library(&self) -> &str {
        &self.library
    }

    /// Whether the file is complete, or where it was cut.
    pub fn end(&self) -> LogEnd {
        self.end
    }

    /// Whether the writer finished the file.
    pub fn is_complete(&self) -> bool {
        self.end == LogEnd::Complete
    }

    /// Number of complete sample messages in the data section (the derived transforms of
    /// [`foxglove`](crate::foxglove) not counted).
    pub fn message_count(&self) -> u64 {
        self.message_count
    }

    /// The topics of the file's sample channels, in channel-id order (the derived transforms
    /// of [`foxglove`](crate::foxglove) left out).
    pub fn topics(&self) -> Vec<&str> {
        self.channels
            .values()
            .filter(|c| !c.is_derived())
            .map(|c| c.topic.as_str())
            .collect()
    }

    /// Every record in file order.
    pub fn records(&self) -> Result<Records<'_>, LogError> {
        self.records_filtered(None)
    }

    /// The records on the given topics (`ipc_types::topic` names), in file order. Names of
    /// topics the log does not have are ignored.
    pub fn records_on(&self, topics: &[&str]) -> Result<Records<'_>, LogError> {
        let kinds = topics
            .iter()
            .filter_map(|t| TopicId::from_name(t))
            .collect();
        self.records_filtered(Some(kinds))
    }

    /// The samples of type `T` (its topic), in file order.
    pub fn samples<T: LogEncode>(&self) -> Result<Samples<'_, T>, LogError> {
        Ok(Samples {
            records: self.records_on(&[T::NAME])?,
            _type: PhantomData,
        })
    }

    fn records_filtered(&self, filter: Option<Vec<TopicId>>) -> Result<Records<'_>, LogError> {
        let framing = Framing::open(&self.path)?.map_err(|_| LogError::NotMcap)?;
        Ok(Records {
            log: self,
            framing,
            filter,
            body: Vec::new(),
            stopped: false,
        })
    }
}

/// The topic kind a channel decodes to, or why it cannot be decoded.
fn channel_kind(
    channel: &mcap::records::Channel,
    schemas: &BTreeMap<u16, (String, String)>,
) -> Result<TopicId, String> {
    let kind =
        TopicId::from_name(&channel.topic).ok_or_else(|| "not an ipc-types topic".to_owned())?;
    if channel.message_encoding != MESSAGE_ENCODING {
        return Err(format!(
            "message encoding {:?}, expected json",
            channel.message_encoding
        ));
    }
    match schemas.get(&channel.schema_id) {
        Some((name, encoding)) if name == kind.schema_name() && encoding == SCHEMA_ENCODING => {
            Ok(kind)
        }
        Some((name, encoding)) => Err(format!(
            "schema {name:?} ({encoding}), this reader reads {:?} ({SCHEMA_ENCODING})",
            kind.schema_name()
        )),
        None => Err(format!("schema {} is not defined", channel.schema_id)),
    }
}

fn run_info(
    mut metadata: BTreeMap<String, String>,
    config_toml: String,
) -> Result<RunInfo, LogError> {
    let mut take = |key: &'static str| {
        metadata.remove(key).ok_or(LogError::BadRunInfo {
            key,
            problem: "missing".to_owned(),
        })
    };
    let _format = take(keys::FORMAT)?;
    let profile = take(keys::PROFILE)?;
    let mode = take(keys::MODE)?;
    let seed_text = take(keys::SEED)?;
    let seed = seed_text.parse().map_err(|e| LogError::BadRunInfo {
        key: keys::SEED,
        problem: format!("{seed_text:?} is not a u64: {e}"),
    })?;
    metadata.remove(keys::START_TIME);
    let start_time_ns = match metadata.remove(keys::START_TIME_NS) {
        None => 0,
        Some(text) => text.parse().map_err(|e| LogError::BadRunInfo {
            key: keys::START_TIME_NS,
            problem: format!("{text:?} is not a u64: {e}"),
        })?,
    };
    Ok(RunInfo {
        profile,
        seed,
        mode,
        config_toml,
        start_time_ns,
        extra: metadata,
    })
}

/// Iterator over a log's records, in file order (see [`RunLog::records`]).
///
/// Yields every complete message up to the end of the data section or the cut
/// ([`RunLog::end`]). A message that cannot be decoded yields an error and iteration goes on
/// with the next record; an I/O error ends the iteration.
pub struct Records<'a> {
    log: &'a RunLog,
    framing: Framing,
    filter: Option<Vec<TopicId>>,
    body: Vec<u8>,
    stopped: bool,
}

impl Records<'_> {
    fn step(&mut self) -> Result<Option<LogRecord>, LogError> {
        loop {
            if !self.framing.in_chunk() && self.framing.pos >= self.log.data_end {
                return Ok(None);
            }
            let (opcode, offset, len) = match self.framing.next()? {
                Next::Record(f) => (f.opcode, f.offset, f.len),
                Next::Cut { .. } => return Ok(None),
            };
            if opcode != op::MESSAGE {
                self.framing.skip(len)?;
                continue;
            }
            self.framing.body(len, &mut self.body)?;
            let Record::Message { header, data } = parse(opcode, offset, &self.body)? else {
                continue;
            };
            let channel =
                self.log
                    .channels
                    .get(&header.channel_id)
                    .ok_or(LogError::UnknownChannel {
                        offset,
                        channel: header.channel_id,
                    })?;
            let kind = match &channel.kind {
                Ok(kind) => *kind,
                Err(problem) => {
                    if self.filter.is_some() || channel.is_derived() {
                        continue; // not one of the wanted ipc-types topics
                    }
                    return Err(LogError::Undecodable {
                        offset,
                        topic: channel.topic.clone(),
                        problem: problem.clone(),
                    });
                }
            };
            if self.filter.as_ref().is_some_and(|f| !f.contains(&kind)) {
                continue;
            }
            return kind
                .decode(&data)
                .map(Some)
                .map_err(|source| LogError::Decode {
                    offset,
                    topic: kind.name(),
                    source,
                });
        }
    }
}

impl Iterator for Records<'_> {
    type Item = Result<LogRecord, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.stopped {
            return None;
        }
        match self.step() {
            Ok(Some(record)) => Some(Ok(record)),
            Ok(None) => {
                self.stopped = true;
                None
            }
            Err(e) => {
                // Framing/I-O errors leave the position unknown; message-level errors do not.
                if matches!(e, LogError::Io(_) | LogError::File { .. }) {
                    self.stopped = true;
                }
                Some(Err(e))
            }
        }
    }
}

/// Iterator over the samples of one type (see [`RunLog::samples`]).
pub struct Samples<'a, T> {
    records: Records<'a>,
    _type: PhantomData<fn() -> T>,
}

impl<T: LogEncode> Iterator for Samples<'_, T> {
    type Item = Result<T, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.records.next()? {
                Ok(record) => match T::from_record(&record) {
                    Some(sample) => return Some(Ok(sample)),
                    None => continue,
                },
                Err(e) => return Some(Err(e)),
            }
        }
    }
}
