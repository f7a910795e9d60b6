//! A pass over an MCAP file's records before the `mcap` crate parses them, so that no length written in the
//! file makes pmon allocate memory out of proportion to the file's size (issue 15).
//!
//! The `mcap` crate (0.26) reads strings, maps and byte arrays with binrw, which reserves the length a prefix
//! announces before it reads the bytes: a Schema whose encoding claims 1.6 GB in a 10 KB file allocates
//! 1.6 GB, and only then fails. Its streaming reader also buffers a record inside a chunk for the length the
//! record announces, without a limit. This pass walks every record with the crate's own framing
//! ([`mcap::sans_io::LinearReader`], which yields records unparsed), including the records inside chunks after
//! decompression, and checks:
//!
//! - every length prefix inside a record (strings, string and integer maps, arrays, schema, message, chunk and
//!   attachment data) against the bytes left in that record;
//! - every record's length against the bytes left in the file, or in its chunk's declared uncompressed size;
//! - the records of an uncompressed chunk against the chunk's records length (the crate subtracts each record's
//!   size from it unchecked);
//! - the chunks' declared uncompressed sizes, summed over the file, against [`MAX_INFLATION`] times the file's
//!   size (real rosbag2 chunks compress 2 to 10 times; a zip bomb is refused before it is decompressed).
//!
//! A file that passes is then read by the `mcap` crate's [`mcap::MessageStream`] as before: every record it
//! parses has lengths that fit, so no parse reserves more than the record holds.

use mcap::records::op;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// The largest total uncompressed size that a file's compressed chunks may declare, as a multiple of the
/// file's size.
pub const MAX_INFLATION: u64 = 100;

/// Where and why a file was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Invalid {
    /// Byte offset in the file of the record (of the chunk, for a record inside a chunk).
    pub offset: u64,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for Invalid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "record at byte {}: {}", self.offset, self.message)
    }
}

/// The MCAP magic at both ends of a file.
const MAGIC_LEN: u64 = 8;
/// Opcode and length in front of every record.
const RECORD_PREFIX: u64 = 9;

/// Checks every length in `bytes` (a whole MCAP file) as described in the module documentation.
///
/// # Errors
/// [`Invalid`] with the offset of the first record that fails, and what is wrong with it (a framing error of
/// the `mcap` crate, such as a bad magic or a truncated file, is reported the same way).
pub fn check_lengths(bytes: &[u8]) -> Result<(), Invalid> {
    let file_len = bytes.len() as u64;
    let budget = file_len.saturating_mul(MAX_INFLATION);
    let mut inflated = 0u64;
    let opts = LinearReaderOptions::default().with_emit_chunks(true).with_record_length_limit(bytes.len());
    let mut offset = MAGIC_LEN;
    for_each_record(bytes, opts, |opcode, body| {
        let at = |message: String| Invalid { offset, message };
        if opcode == op::CHUNK {
            let chunk = chunk_header(body).map_err(at)?;
            if chunk.compression.is_empty() {
                uncompressed_records(chunk.records).map_err(at)?;
            } else {
                inflated = inflated.saturating_add(chunk.uncompressed_size);
                if inflated > budget {
                    return Err(at(format!(
                        "the chunks up to this one declare {inflated} bytes uncompressed, more than {MAX_INFLATION} \
                         times the file's {file_len} bytes (refused before decompressing)"
                    )));
                }
            }
            // The chunk alone, read by the same reader, which yields the records inside it decompressed.
            let start = usize::try_from(offset).unwrap_or(usize::MAX);
            let end = start.saturating_add(body.len()).saturating_add(RECORD_PREFIX as usize);
            let record = bytes.get(start..end).ok_or_else(|| at("the chunk record is not where it was read".into()))?;
            // Records in an uncompressed chunk are read from the file; in a compressed one, each is buffered
            // whole, so none may be longer than the chunk's declared (and budgeted) uncompressed size.
            let limit = if chunk.compression.is_empty() {
                bytes.len()
            } else {
                usize::try_from(chunk.uncompressed_size).unwrap_or(usize::MAX).max(bytes.len())
            };
            let inner = LinearReaderOptions::default()
                .with_skip_start_magic(true)
                .with_skip_end_magic(true)
                .with_record_length_limit(limit);
            let mut inner_offset = 0u64;
            for_each_record(record, inner, |opcode, body| {
                record_body(opcode, body).map_err(|m| {
                    at(format!("{} record at byte {inner_offset} of the chunk's records: {m}", name(opcode)))
                })?;
                inner_offset += RECORD_PREFIX + body.len() as u64;
                Ok(())
            })
            .map_err(|e| match e {
                Stop::Invalid(i) => i,
                Stop::Mcap(m) => at(format!("in the chunk: {m}")),
            })?;
        } else {
            record_body(opcode, body).map_err(|m| at(format!("{} record: {m}", name(opcode))))?;
        }
        offset += RECORD_PREFIX + body.len() as u64;
        Ok(())
    })
    .map_err(|e| match e {
        Stop::Invalid(i) => i,
        Stop::Mcap(message) => Invalid { offset, message },
    })
}

enum Stop {
    Invalid(Invalid),
    Mcap(String),
}

impl From<Invalid> for Stop {
    fn from(i: Invalid) -> Self {
        Stop::Invalid(i)
    }
}

/// Feeds `bytes` to the `mcap` crate's sans-io reader and calls `f` with each record's opcode and body.
fn for_each_record<F>(mut bytes: &[u8], opts: LinearReaderOptions, mut f: F) -> Result<(), Stop>
where
    F: FnMut(u8, &[u8]) -> Result<(), Invalid>,
{
    let mut reader = LinearReader::new_with_options(opts);
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| Stop::Mcap(e.to_string()))? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(bytes.len());
                reader.insert(n).copy_from_slice(&bytes[..n]);
                reader.notify_read(n);
                bytes = &bytes[n..];
            }
            LinearReadEvent::Record { opcode, data } => f(opcode, data)?,
        }
    }
    Ok(())
}

fn name(opcode: u8) -> &'static str {
    match opcode {
        op::HEADER => "Header",
        op::FOOTER => "Footer",
        op::SCHEMA => "Schema",
        op::CHANNEL => "Channel",
        op::MESSAGE => "Message",
        op::CHUNK => "Chunk",
        op::MESSAGE_INDEX => "Message Index",
        op::CHUNK_INDEX => "Chunk Index",
        op::ATTACHMENT => "Attachment",
        op::ATTACHMENT_INDEX => "Attachment Index",
        op::STATISTICS => "Statistics",
        op::METADATA => "Metadata",
        op::METADATA_INDEX => "Metadata Index",
        op::SUMMARY_OFFSET => "Summary Offset",
        op::DATA_END => "Data End",
        _ => "unknown",
    }
}

/// A record's body, read field by field; every length is checked against what is left.
struct Body<'a> {
    rest: &'a [u8],
}

impl<'a> Body<'a> {
    fn take(&mut self, n: u64, field: &str) -> Result<&'a [u8], String> {
        let left = self.rest.len() as u64;
        if n > left {
            return Err(format!("{field} needs {n} bytes, only {left} are left in the record"));
        }
        let (head, tail) = self.rest.split_at(n as usize);
        self.rest = tail;
        Ok(head)
    }

    fn fixed(&mut self, n: u64, field: &str) -> Result<(), String> {
        self.take(n, field).map(|_| ())
    }

    fn u32(&mut self, field: &str) -> Result<u32, String> {
        let b = self.take(4, field)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, field: &str) -> Result<u64, String> {
        let b = self.take(8, field)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }

    /// A length prefix of `width` bytes and that many bytes after it.
    fn prefixed(&mut self, field: &str, width: u8) -> Result<&'a [u8], String> {
        let len = if width == 4 { u64::from(self.u32(field)?) } else { self.u64(field)? };
        let left = self.rest.len() as u64;
        if len > left {
            return Err(format!("the {field}'s length prefix says {len} bytes, only {left} are left in the record"));
        }
        self.take(len, field)
    }

    fn string(&mut self, field: &str) -> Result<(), String> {
        self.prefixed(field, 4).map(|_| ())
    }

    /// A `map<string, string>` as the `mcap` crate reads it: key and value strings while fewer than the map's
    /// byte length have been read.
    fn string_map(&mut self, field: &str) -> Result<(), String> {
        let len = u64::from(self.u32(field)?);
        let left = self.rest.len() as u64;
        if len > left {
            return Err(format!("the {field}'s length prefix says {len} bytes, only {left} are left in the record"));
        }
        let end = left - len;
        while self.rest.len() as u64 > end {
            self.string(&format!("{field} key"))?;
            self.string(&format!("{field} value"))?;
        }
        Ok(())
    }

    /// A map or array of fixed-size entries behind a byte length, read as the `mcap` crate reads it: whole
    /// entries while fewer than the byte length have been read (so a length that is not a multiple of the
    /// entry size moves the fields after it, for the crate and for this check alike).
    fn entries(&mut self, field: &str, entry: u64) -> Result<(), String> {
        let len = u64::from(self.u32(field)?);
        let left = self.rest.len() as u64;
        if len > left {
            return Err(format!("the {field}'s length prefix says {len} bytes, only {left} are left in the record"));
        }
        let mut read = 0;
        while read < len {
            self.fixed(entry, field)?;
            read += entry;
        }
        Ok(())
    }
}

struct ChunkFields<'a> {
    uncompressed_size: u64,
    compression: Vec<u8>,
    records: &'a [u8],
}

fn chunk_header(body: &[u8]) -> Result<ChunkFields<'_>, String> {
    let mut b = Body { rest: body };
    b.fixed(16, "message start and end times")?;
    let uncompressed_size = b.u64("uncompressed size")?;
    b.fixed(4, "uncompressed CRC")?;
    let compression = b.prefixed("compression", 4)?.to_vec();
    let records = b.prefixed("records", 8)?;
    Ok(ChunkFields { uncompressed_size, compression, records })
}

/// The framing of an uncompressed chunk's records: each record's opcode, length and body must lie within the
/// chunk's records. The `mcap` crate reads them from the file itself and subtracts each record's size from what
/// the chunk declared without a check (0.26, `linear_reader.rs`): a record running past the chunk's end panics
/// in a debug build ("attempt to subtract with overflow") and, in a release build, wraps around and reads the
/// file's next records as the chunk's.
fn uncompressed_records(records: &[u8]) -> Result<(), String> {
    let mut at = 0u64;
    let mut rest = records;
    while !rest.is_empty() {
        let left = rest.len() as u64;
        let Some((head, body)) = rest.split_first_chunk::<9>() else {
            return Err(format!(
                "the chunk's records end with {left} bytes at byte {at}, too few for a record's opcode and length"
            ));
        };
        let mut len = [0u8; 8];
        len.copy_from_slice(&head[1..]);
        let len = u64::from_le_bytes(len);
        let room = body.len() as u64;
        if len > room {
            return Err(format!(
                "{} record at byte {at} of the chunk's records says {len} bytes, only {room} are left in the chunk",
                name(head[0])
            ));
        }
        // `len <= room <= usize::MAX`: the cast is exact.
        rest = &body[len as usize..];
        at += RECORD_PREFIX + len;
    }
    Ok(())
}

/// Checks the lengths inside one record's body, field by field as the `mcap` crate parses it.
fn record_body(opcode: u8, body: &[u8]) -> Result<(), String> {
    let mut b = Body { rest: body };
    match opcode {
        op::HEADER => {
            b.string("profile")?;
            b.string("library")?;
        }
        op::FOOTER => b.fixed(20, "footer")?,
        op::SCHEMA => {
            b.fixed(2, "id")?;
            b.string("name")?;
            b.string("encoding")?;
            b.prefixed("schema data", 4)?;
        }
        op::CHANNEL => {
            b.fixed(4, "ids")?;
            b.string("topic")?;
            b.string("message encoding")?;
            b.string_map("metadata")?;
        }
        op::MESSAGE => b.fixed(22, "message header")?,
        op::CHUNK => {
            chunk_header(body)?;
        }
        op::MESSAGE_INDEX => {
            b.fixed(2, "channel id")?;
            b.entries("records", 16)?;
        }
        op::CHUNK_INDEX => {
            b.fixed(32, "times, chunk offset and length")?;
            b.entries("message index offsets", 10)?;
            b.fixed(8, "message index length")?;
            b.string("compression")?;
            b.fixed(16, "compressed and uncompressed sizes")?;
        }
        op::ATTACHMENT => {
            b.fixed(16, "times")?;
            b.string("name")?;
            b.string("media type")?;
            b.prefixed("attachment data", 8)?;
            b.fixed(4, "CRC")?;
        }
        op::ATTACHMENT_INDEX => {
            b.fixed(40, "offset, length, times and data size")?;
            b.string("name")?;
            b.string("media type")?;
        }
        op::STATISTICS => {
            b.fixed(42, "counts and times")?;
            b.entries("channel message counts", 10)?;
        }
        op::METADATA => {
            b.string("name")?;
            b.string_map("metadata")?;
        }
        op::METADATA_INDEX => {
            b.fixed(16, "offset and length")?;
            b.string("name")?;
        }
        op::SUMMARY_OFFSET => b.fixed(17, "summary offset")?,
        op::DATA_END => b.fixed(4, "data section CRC")?,
        _ => {}
    }
    Ok(())
}
