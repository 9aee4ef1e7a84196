//! [`repair`]: makes a cut log (killed logger, full disk) a complete MCAP file again.
//!
//! A cut log keeps every record before the cut ([`RunLogWriter`](crate::RunLogWriter) writes
//! them unchunked), and streaming readers read it, but readers that start from the footer
//! (Python `mcap`'s `make_reader`, viewers) refuse it. The repair copies every complete record
//! of the data section (header, schemas and channels with their ids, attachments, metadata and
//! messages) into a new file laid out as the logger leaves a finished one ([`index`]:
//! compressed chunks with message indexes), then adds the summary section (schema, channel, statistics
//! and chunk index records, attachment and metadata indexes) and the footer. The incomplete
//! record at the cut is dropped: it cannot be decoded.

use crate::reader::{Framing, Next};
use crate::{LogEnd, LogError};
use mcap::records::{MessageHeader, Record, op};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// What [`repair`] found and wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RepairReport {
    /// How the input ended (where it was cut).
    pub end: LogEnd,
    /// Sample messages copied (every complete one; the derived transforms of
    /// [`foxglove`](crate::foxglove) are copied too but not counted, as in
    /// [`RunLog::message_count`](crate::RunLog::message_count)).
    pub messages: u64,
    /// `log_time` of the last message copied, ns (0 if none).
    pub last_time_ns: u64,
    /// Bytes of the input after the last complete record (dropped).
    pub dropped_bytes: u64,
    /// The file written.
    pub output: PathBuf,
}

/// Reads every complete record of the log `input` and writes them, with a summary section and
/// footer, to `output` (which may be `input`: the repaired file replaces it atomically, via a
/// temporary file in the same directory, once it is complete).
pub fn repair(input: &Path, output: &Path) -> Result<RepairReport, LogError> {
    rewrite(input, output, Accept::CutFile, CHUNK_ZSTD_LEVEL)
}

/// Rewrites the complete log at `path` in place as an indexed, compressed MCAP file: the same
/// records (ids, every message's header and bytes) in zstd-compressed chunks
/// ([`CHUNK_ZSTD_LEVEL`]), one per [`CHUNK_INTERVAL_NS`] of log time, with a message index
/// after each chunk and a chunk index in the summary, so viewers (Foxglove, `mcap` readers) can
/// seek by time without reading the file from the start. The logger does this when a run ends
/// (see [`WriterOptions::indexed`](crate::WriterOptions::indexed)); a file cut mid-run keeps
/// the unchunked layout, every complete record of which [`repair`] recovers.
///
/// A chunk holds the messages whose `log_time` falls in its interval (counted from the first
/// message's), grouped by channel in channel-id order, each channel's in file order: a
/// channel's messages side by side compress better than interleaved, and a frame transform in
/// the same chunk as the sample it is derived from costs little more than its header.
/// Readers that sort by time ([`RunLog`](crate::RunLog), `mcap` readers) give them back in time
/// order. A message whose interval was already written (it came more than one interval after
/// later messages in the file) goes into the oldest chunk still open, which then starts earlier.
///
/// The rewrite goes through a temporary file renamed over `path` once complete and synced, so
/// a crash during it leaves the original. A cut file is refused (repair it first). The output
/// depends only on the input's bytes (single-threaded compression), so two identical logs give
/// identical indexed files.
pub fn index(path: &Path) -> Result<RepairReport, LogError> {
    index_with_level(path, CHUNK_ZSTD_LEVEL)
}

/// As [`index`], compressing at zstd `level` (1–22) rather than [`CHUNK_ZSTD_LEVEL`]: for
/// measuring the choice (bench `log_size`).
pub fn index_with_level(path: &Path, level: u32) -> Result<RepairReport, LogError> {
    rewrite(path, path, Accept::CompleteFile, level)
}

/// The flush interval of the indexed log: the span of log time one chunk holds, ns. Chunks do
/// not overlap in time (but for a message more than one interval late, see [`index`]); a
/// reader of a time window decompresses the chunks of at most one interval more than it
/// asked for. At the test bed's rates (13 channels at 10 Hz) a chunk holds some 400 KB of
/// JSON, compressed to some 70 KB: long enough to compress well, short enough to seek.
pub const CHUNK_INTERVAL_NS: u64 = 10_000_000_000;

/// zstd level of the indexed log's chunks. Measured on a 3000-s lockstep log (bench
/// `log_size`, bench/README.md): level 1 writes about the size of level 6 (the JSON numbers'
/// digits are what is left, and no level finds more in them) in a fraction of the time, and
/// a smaller file than level 3.
pub const CHUNK_ZSTD_LEVEL: u32 = 1;

/// What the rewrite accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Accept {
    /// A file cut anywhere: every complete record is kept.
    CutFile,
    /// Only a complete file.
    CompleteFile,
}

fn rewrite(
    input: &Path,
    output: &Path,
    accept: Accept,
    level: u32,
) -> Result<RepairReport, LogError> {
    let mut framing = Framing::open_log(input)?;
    let file_len = framing.file_len();
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "log".to_owned());
    let temporary = output.with_file_name(format!(".{name}.rewriting"));
    let result = copy_records(&mut framing, file_len, &temporary, level);
    let result = match result {
        Ok((LogEnd::Truncated { offset, .. }, ..)) if accept == Accept::CompleteFile => {
            Err(LogError::Unsupported {
                offset,
                what: "indexing a cut log (repair it first)",
            })
        }
        other => other,
    };
    let (end, messages, last_time_ns) = match result {
        Ok(done) => done,
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            return Err(e);
        }
    };
    std::fs::rename(&temporary, output).map_err(|e| LogError::io(output, e))?;
    let dropped_bytes = match end {
        LogEnd::Complete => 0,
        LogEnd::Truncated { offset, file_len } => file_len - offset,
    };
    Ok(RepairReport {
        end,
        messages,
        last_time_ns,
        dropped_bytes,
        output: output.to_owned(),
    })
}

type Copied = (LogEnd, u64, u64);

fn copy_records(
    framing: &mut Framing,
    file_len: u64,
    to: &Path,
    level: u32,
) -> Result<Copied, LogError> {
    let file = File::create(to).map_err(|e| LogError::io(to, e))?;
    let mut writer: Option<mcap::Writer<BufWriter<File>>> = None;
    let mut body = Vec::new();
    let mut messages = 0;
    let mut derived_channels = Vec::new();
    let mut last_time_ns = 0;
    let mut file = Some(file);
    let mut in_data = true;
    let mut windows = Windows::default();
    let end = loop {
        let (opcode, offset, len) = match framing.next()? {
            Next::Record(f) => (f.opcode, f.offset, f.len),
            Next::Cut { offset } => break LogEnd::Truncated { offset, file_len },
        };
        match opcode {
            op::DATA_END => {
                in_data = false;
                framing.skip(len)?;
            }
            op::FOOTER => {
                framing.skip(len)?;
                break framing.end_after_footer()?;
            }
            op::HEADER | op::SCHEMA | op::CHANNEL | op::MESSAGE | op::ATTACHMENT | op::METADATA
                if in_data =>
            {
                framing.body(len, &mut body)?;
                let record = mcap::parse_record(opcode, &body)
                    .map_err(|source| LogError::Corrupt { offset, source })?;
                if let Record::Header(header) = &record {
                    let Some(file) = file.take() else {
                        continue; // a second header: not valid MCAP, keep the first
                    };
                    // Chunks are closed by `Windows`, never by size; one compression thread
                    // (zstd's multi-threaded output differs from its single-threaded one, and
                    // the number of threads would depend on the machine).
                    let options = mcap::WriteOptions::new()
                        .use_chunks(true)
                        .chunk_size(None)
                        .compression(Some(mcap::Compression::Zstd))
                        .compression_level(level)
                        .compression_threads(0)
                        .profile(header.profile.clone())
                        .library(header.library.clone());
                    writer = Some(options.create(BufWriter::new(file))?);
                    continue;
                }
                let Some(mcap) = writer.as_mut() else {
                    return Err(LogError::Unsupported {
                        offset,
                        what: "a record before the header",
                    });
                };
                match record {
                    // Written with the first chunk: in a chunked file the writer puts them in
                    // the chunk being written, and one written now would be a chunk of its own,
                    // closed by the attachment, with no messages and no time range.
                    Record::Schema { .. } => windows.definitions.push(record.into_owned()),
                    Record::Channel(c) => {
                        if crate::foxglove::DERIVED_TOPICS.contains(&c.topic.as_str()) {
                            derived_channels.push(c.id);
                        }
                        windows.definitions.push(Record::Channel(c).into_owned());
                    }
                    Record::Message { header, data } => {
                        windows.push(mcap, header, &data)?;
                        if !derived_channels.contains(&header.channel_id) {
                            messages += 1;
                        }
                        last_time_ns = header.log_time;
                    }
                    Record::Attachment { header, data, .. } => {
                        mcap.attach(&mcap::Attachment {
                            log_time: header.log_time,
                            create_time: header.create_time,
                            name: header.name,
                            media_type: header.media_type,
                            data,
                        })?;
                    }
                    Record::Metadata(m) => mcap.write_metadata(&m)?,
                    _ => {}
                }
            }
            _ => framing.skip(len)?,
        }
    };
    let Some(mut mcap) = writer else {
        return Err(LogError::MissingRunInfo {
            missing: "header",
            end,
        });
    };
    windows.write_all(&mut mcap)?;
    mcap.finish()?;
    let inner = mcap.into_inner();
    let file = inner
        .into_inner()
        .map_err(|e| LogError::io(to, e.into_error()))?;
    file.sync_all().map_err(|e| LogError::io(to, e))?;
    Ok((end, messages, last_time_ns))
}

/// One interval's messages: channel id → its messages (header, data) in file order.
type Interval = BTreeMap<u16, Vec<(MessageHeader, Vec<u8>)>>;

/// The messages of the chunks not yet written, by interval of [`CHUNK_INTERVAL_NS`].
#[derive(Default)]
struct Windows {
    /// Schemas and channels not yet written (they go before the next chunk's messages).
    definitions: Vec<Record<'static>>,
    /// `log_time` the intervals are counted from (the first message's).
    origin: Option<u64>,
    /// Open intervals: interval number → channel id → its messages in file order.
    open: BTreeMap<u64, Interval>,
}

impl Windows {
    /// Takes in a message; writes (as one chunk each) the intervals that ended more than one
    /// interval before this message's: a file's messages come in time order but for the
    /// logger's drain delays (well under an interval), so no more messages come for those.
    fn push<W: std::io::Write + std::io::Seek>(
        &mut self,
        mcap: &mut mcap::Writer<W>,
        header: MessageHeader,
        data: &[u8],
    ) -> Result<(), LogError> {
        let origin = *self.origin.get_or_insert(header.log_time);
        let interval = header.log_time.saturating_sub(origin) / CHUNK_INTERVAL_NS;
        while let Some(entry) = self.open.first_entry() {
            if *entry.key() + 1 >= interval {
                break;
            }
            let channels = entry.remove();
            self.define(mcap)?;
            Self::write(mcap, channels)?;
        }
        // A message for an interval already written joins the oldest open one.
        let interval = match self.open.first_key_value() {
            Some((&oldest, _)) if interval < oldest => oldest,
            _ => interval,
        };
        self.open
            .entry(interval)
            .or_default()
            .entry(header.channel_id)
            .or_default()
            .push((header, data.to_vec()));
        Ok(())
    }

    /// Writes every open interval, in order.
    fn write_all<W: std::io::Write + std::io::Seek>(
        &mut self,
        mcap: &mut mcap::Writer<W>,
    ) -> Result<(), LogError> {
        self.define(mcap)?;
        for (_, channels) in std::mem::take(&mut self.open) {
            Self::write(mcap, channels)?;
        }
        Ok(())
    }

    /// Writes the definitions not yet written.
    fn define<W: std::io::Write + std::io::Seek>(
        &mut self,
        mcap: &mut mcap::Writer<W>,
    ) -> Result<(), LogError> {
        for record in self.definitions.drain(..) {
            match record {
                Record::Schema { header, data } => {
                    mcap.add_schema_with_id(header.id, &header.name, &header.encoding, &data)?;
                }
                Record::Channel(c) => {
                    mcap.add_channel_with_id(
                        c.id,
                        c.schema_id,
                        &c.topic,
                        &c.message_encoding,
                        &c.metadata,
                    )?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Writes one interval as one chunk: channel by channel.
    fn write<W: std::io::Write + std::io::Seek>(
        mcap: &mut mcap::Writer<W>,
        channels: Interval,
    ) -> Result<(), LogError> {
        for (header, data) in channels.into_values().flatten() {
            mcap.write_to_known_channel(&header, &data)?;
        }
        // Closes the chunk (its message indexes follow it).
        mcap.flush()?;
        Ok(())
    }
}

/// The time range (`message_start_time`, `message_end_time`, ns of log time) of every chunk of
/// the indexed log at `path`, in file order, from its chunk index (empty for an unchunked log).
pub fn chunk_time_ranges(path: &Path) -> Result<Vec<(u64, u64)>, LogError> {
    let bytes = std::fs::read(path).map_err(|e| LogError::io(path, e))?;
    let summary = mcap::Summary::read(&bytes)?;
    Ok(summary
        .map(|s| {
            s.chunk_indexes
                .iter()
                .map(|c| (c.message_start_time, c.message_end_time))
                .collect()
        })
        .unwrap_or_default())
}
