//! [`repair`]: makes a cut log (killed logger, full disk) a complete MCAP file again.
//!
//! A cut log keeps every record before the cut ([`RunLogWriter`](crate::RunLogWriter) writes
//! them unchunked), and streaming readers read it, but readers that start from the footer
//! (Python `mcap`'s `make_reader`, viewers) refuse it. The repair copies every complete record
//! of the data section (header, schemas and channels with their ids, attachments, metadata and
//! messages, in file order) into a new file laid out as the logger leaves a finished one
//! (chunks with message indexes), then adds the summary section (schema, channel, statistics
//! and chunk index records, attachment and metadata indexes) and the footer. The incomplete
//! record at the cut is dropped: it cannot be decoded.

use crate::reader::{Framing, Next};
use crate::{LogEnd, LogError};
use mcap::records::{Record, op};
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
    rewrite(input, output, Accept::CutFile)
}

/// Rewrites the complete log at `path` in place as an indexed MCAP file: the same records
/// (ids, order, bytes of every message) in uncompressed chunks of about
/// [`INDEXED_CHUNK_BYTES`], with a message index after each chunk and a chunk index in the
/// summary, so viewers (Foxglove, `mcap` readers) can seek by time without reading the file
/// from the start. The logger does this when a run ends (see
/// [`WriterOptions::indexed`](crate::WriterOptions::indexed)); a file cut mid-run keeps the
/// unchunked layout, every complete record of which [`repair`] recovers.
///
/// The rewrite goes through a temporary file renamed over `path` once complete and synced, so
/// a crash during it leaves the original. A cut file is refused (repair it first).
pub fn index(path: &Path) -> Result<RepairReport, LogError> {
    rewrite(path, path, Accept::CompleteFile)
}

/// Size of the chunks [`index`] writes, bytes (uncompressed). At the test bed's data rates
/// (a few MB per minute) a chunk holds several seconds of records.
pub const INDEXED_CHUNK_BYTES: u64 = 256 * 1024;

/// What the rewrite accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Accept {
    /// A file cut anywhere: every complete record is kept.
    CutFile,
    /// Only a complete file.
    CompleteFile,
}

fn rewrite(input: &Path, output: &Path, accept: Accept) -> Result<RepairReport, LogError> {
    let mut framing = match Framing::open(input)? {
        Ok(framing) => framing,
        Err(file_len) => {
            return Err(LogError::MissingRunInfo {
                missing: "header",
                end: LogEnd::Truncated {
                    offset: 0,
                    file_len,
                },
            });
        }
    };
    let file_len = framing.file_len();
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "log".to_owned());
    let temporary = output.with_file_name(format!(".{name}.rewriting"));
    let result = copy_records(&mut framing, file_len, &temporary);
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

fn copy_records(framing: &mut Framing, file_len: u64, to: &Path) -> Result<Copied, LogError> {
    let file = File::create(to).map_err(|e| LogError::io(to, e))?;
    let mut writer: Option<mcap::Writer<BufWriter<File>>> = None;
    let mut body = Vec::new();
    let mut messages = 0;
    let mut derived_channels = Vec::new();
    let mut last_time_ns = 0;
    let mut file = Some(file);
    let mut in_data = true;
    let end = loop {
        let (opcode, offset, len) = match framing.next()? {
            Next::Record {
                opcode,
                offset,
                len,
            } => (opcode, offset, len),
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
                    let options = mcap::WriteOptions::new()
                        .use_chunks(true)
                        .chunk_size(Some(INDEXED_CHUNK_BYTES))
                        .compression(None)
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
                    Record::Schema { header, data } => {
                        mcap.add_schema_with_id(header.id, &header.name, &header.encoding, &data)?;
                    }
                    Record::Channel(c) => {
                        if crate::foxglove::DERIVED_TOPICS.contains(&c.topic.as_str()) {
                            derived_channels.push(c.id);
                        }
                        mcap.add_channel_with_id(
                            c.id,
                            c.schema_id,
                            &c.topic,
                            &c.message_encoding,
                            &c.metadata,
                        )?;
                    }
                    Record::Message { header, data } => {
                        mcap.write_to_known_channel(&header, &data)?;
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
    mcap.finish()?;
    let inner = mcap.into_inner();
    let file = inner
        .into_inner()
        .map_err(|e| LogError::io(to, e.into_error()))?;
    file.sync_all().map_err(|e| LogError::io(to, e))?;
    Ok((end, messages, last_time_ns))
}
