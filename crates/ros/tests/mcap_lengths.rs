//! Lengths in an MCAP file that point past their record, file or chunk are errors naming the file and the
//! record's offset, never an allocation of the size they announce (issue 15; the `mcap` crate 0.26 reserves a
//! string's announced length before reading it, and buffers a record inside a compressed chunk for its
//! announced length without a limit). Bags with correct lengths read as before (`bag_behaviour.rs`).

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

use pmon_monitor::MonitorParams;
use pmon_ros::bag::{check_bag, BagConfig, BagError};
use pmon_ros::cdr::encode;
use pmon_ros::mcap_check::{check_lengths, MAX_INFLATION};
use pmon_ros::msg::{Header, Time, TrackedObjects};

const MAGIC: &[u8] = b"\x89MCAP0\r\n";
const TRACKED: &str = "autoware_perception_msgs/msg/TrackedObjects";

fn run(bytes: &[u8]) -> Result<pmon_ros::bag::BagSummary, BagError> {
    check_bag(Path::new("bad.mcap"), bytes, &BagConfig::default(), &MonitorParams::default(), &mut |_| Ok(()))
}

fn string(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend_from_slice(s);
    v
}

fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut v = vec![opcode];
    v.extend_from_slice(&(body.len() as u64).to_le_bytes());
    v.extend_from_slice(body);
    v
}

/// A whole file: magic, Header, `records`, Data End, Footer, magic.
fn file(records: &[Vec<u8>]) -> Vec<u8> {
    let mut v = MAGIC.to_vec();
    v.extend(record(0x01, &[string(b"ros2"), string(b"test")].concat()));
    for r in records {
        v.extend_from_slice(r);
    }
    v.extend(record(0x0F, &0u32.to_le_bytes()));
    v.extend(record(0x02, &[0u8; 20]));
    v.extend_from_slice(MAGIC);
    v
}

/// A Schema record whose name claims `name_len` bytes (the name itself is `name`).
fn schema(name_len: u32, name: &[u8]) -> Vec<u8> {
    let mut body = 1u16.to_le_bytes().to_vec();
    body.extend_from_slice(&name_len.to_le_bytes());
    body.extend_from_slice(name);
    body.extend(string(b"ros2msg"));
    body.extend(string(b""));
    record(0x03, &body)
}

/// A chunk record around `records` (already compressed as `compression` says).
fn chunk(compression: &[u8], uncompressed_size: u64, records: &[u8]) -> Vec<u8> {
    let mut body = [0u64.to_le_bytes(), 0u64.to_le_bytes(), uncompressed_size.to_le_bytes()].concat();
    body.extend_from_slice(&0u32.to_le_bytes());
    body.extend(string(compression));
    body.extend_from_slice(&(records.len() as u64).to_le_bytes());
    body.extend_from_slice(records);
    record(0x06, &body)
}

fn err(bytes: &[u8]) -> String {
    let e = run(bytes).expect_err("a bad length must be an error").to_string();
    assert!(e.starts_with("bad.mcap: not a readable MCAP file: record at byte "), "{e}");
    e
}

/// The fuzz finding itself: `fuzz/known/`, a mutated bag whose third Schema (at byte 5310) gives its encoding
/// a length prefix of 1,634,235,424 bytes; the mcap crate allocated that much before the read failed.
#[test]
fn mcap_schema_encoding_length_from_the_fuzz_finding_is_an_error() {
    let bytes = include_bytes!("../../../fuzz/known/mcap_bag-oom-schema-name-length.mcap");
    let e = err(bytes);
    assert!(
        e.contains("record at byte 5310: Schema record: the encoding's length prefix says 1634235424 bytes"),
        "{e}"
    );
}

#[test]
fn mcap_schema_name_length_beyond_record_is_an_error() {
    let good = file(&[schema(4, b"abcd")]);
    assert_eq!(check_lengths(&good), Ok(()));
    let e = err(&file(&[schema(0x6000_0000, b"abcd")]));
    assert!(e.contains("record at byte 33: Schema record: the name's length prefix says 1610612736 bytes"), "{e}");
}

#[test]
fn mcap_schema_name_length_beyond_record_inside_an_uncompressed_chunk_is_an_error() {
    let inner = schema(0x6000_0000, b"abcd");
    let e = err(&file(&[chunk(b"", inner.len() as u64, &inner)]));
    assert!(
        e.contains("record at byte 33: Schema record at byte 0 of the chunk's records: the name's length prefix"),
        "{e}"
    );
}

/// The mcap crate buffers a record inside a compressed chunk for the length the record announces, with no
/// limit: a 2^40-byte Message inside a 50-byte zstd chunk would be a 1 TiB allocation.
#[test]
fn mcap_record_in_a_zstd_chunk_longer_than_the_chunk_is_an_error() {
    let mut inner = vec![0x05];
    inner.extend_from_slice(&(1u64 << 40).to_le_bytes());
    inner.extend_from_slice(&[0; 22]);
    let z = zstd::bulk::compress(&inner, 3).unwrap();
    let e = err(&file(&[chunk(b"zstd", inner.len() as u64, &z)]));
    assert!(e.contains("record at byte 33: in the chunk: "), "{e}");
}

#[test]
fn mcap_string_inside_a_zstd_chunk_beyond_its_record_is_an_error() {
    let inner = schema(u32::MAX, b"abcd");
    let z = zstd::bulk::compress(&inner, 3).unwrap();
    let e = err(&file(&[chunk(b"zstd", inner.len() as u64, &z)]));
    assert!(
        e.contains("Schema record at byte 0 of the chunk's records: the name's length prefix says 4294967295"),
        "{e}"
    );
}

#[test]
fn mcap_chunks_declaring_more_than_the_inflation_limit_are_an_error_before_decompressing() {
    let records = [0u8; 64];
    let e = err(&file(&[chunk(b"zstd", 1 << 40, &records)]));
    assert!(e.contains(&format!("more than {MAX_INFLATION} times the file's")), "{e}");
}

/// The mcap crate slices an Attachment's data up to 4 bytes before the record's end (its CRC) and panics when
/// the header leaves less than that.
#[test]
fn mcap_attachment_without_room_for_its_crc_is_an_error() {
    let mut body = [0u64.to_le_bytes(), 0u64.to_le_bytes()].concat();
    body.extend(string(b"a"));
    body.extend(string(b"b"));
    body.extend_from_slice(&0u64.to_le_bytes());
    body.extend_from_slice(&[0, 0]);
    let e = err(&file(&[record(0x09, &body)]));
    assert!(e.contains("Attachment record: CRC needs 4 bytes, only 2 are left"), "{e}");
}

#[test]
fn mcap_channel_metadata_value_beyond_record_is_an_error() {
    let mut body = [1u16.to_le_bytes(), 0u16.to_le_bytes()].concat();
    body.extend(string(b"/t"));
    body.extend(string(b"cdr"));
    let map = [string(b"k"), (0x7000_0000u32).to_le_bytes().to_vec()].concat();
    body.extend(string(&map));
    let e = err(&file(&[record(0x04, &body)]));
    assert!(e.contains("Channel record: the metadata value's length prefix says 1879048192 bytes"), "{e}");
}

#[test]
fn mcap_record_longer_than_the_file_is_an_error() {
    let mut bytes = file(&[]);
    let r = record(0x80, &[1, 2, 3]);
    let mut long = r.clone();
    long[1..9].copy_from_slice(&(1u64 << 50).to_le_bytes());
    bytes.splice(MAGIC.len()..MAGIC.len(), long);
    let e = err(&bytes);
    assert!(e.contains("record at byte 8: "), "{e}");
}

/// Bags as pmon and the mcap crate write them (zstd chunks, summary, indexes) pass, and read as before.
#[test]
fn mcap_bags_with_correct_lengths_pass_the_check() {
    for compression in [Some(mcap::Compression::Zstd), Some(mcap::Compression::Lz4), None] {
        let mut w = mcap::WriteOptions::new().compression(compression).create(Cursor::new(Vec::new())).unwrap();
        let s = w.add_schema(TRACKED, "ros2msg", b"").unwrap();
        let meta = BTreeMap::from([("offered_qos_profiles".to_string(), "- history: 3".to_string())]);
        let c = w.add_channel(s, &BagConfig::default().objects_topic, "cdr", &meta).unwrap();
        for i in 0..3u32 {
            let list = TrackedObjects {
                header: Header { stamp: Time { sec: i as i32, nanosec: 0 }, frame_id: "base_link".into() },
                objects: vec![],
            };
            let t = u64::from(i) * 100_000_000;
            let h = mcap::records::MessageHeader { channel_id: c, sequence: i, log_time: t, publish_time: t };
            w.write_to_known_channel(&h, &encode(&list).unwrap()).unwrap();
        }
        w.attach(&mcap::Attachment {
            log_time: 0,
            create_time: 0,
            name: "a".into(),
            media_type: "text/plain".into(),
            data: std::borrow::Cow::Borrowed(b"hello"),
        })
        .unwrap();
        w.write_metadata(&mcap::records::Metadata { name: "m".into(), metadata: meta.clone() }).unwrap();
        w.finish().unwrap();
        let bytes = w.into_inner().into_inner();
        assert_eq!(check_lengths(&bytes), Ok(()), "{compression:?}");
        let summary = run(&bytes).unwrap();
        assert_eq!(summary.frames, 3, "{compression:?}");
    }
}

/// The second fuzz finding (`fuzz/known/`): a mutated bag whose uncompressed chunk (at byte 39) declares 8 bytes
/// of records, too few for one record's opcode and length. The mcap crate (0.26) reads a record's 9-byte head
/// anyway and subtracts its size from the chunk's remaining bytes unchecked: "attempt to subtract with
/// overflow" in a debug build, a wrap-around in a release one.
#[test]
fn mcap_record_past_its_uncompressed_chunk_from_the_fuzz_finding_is_an_error() {
    let bytes = include_bytes!("../../../fuzz/known/mcap_bag-overflow-uncompressed-chunk-record.mcap");
    let e = err(bytes);
    assert!(
        e.contains("record at byte 39: the chunk's records end with 8 bytes at byte 0, too few for a record's"),
        "{e}"
    );
}

#[test]
fn mcap_record_longer_than_its_uncompressed_chunk_is_an_error() {
    // A Header record (opcode 0x01) inside the chunk whose length runs 10 bytes past the chunk's records, with
    // the file's own records after the chunk for the crate to read on into.
    let mut inner = record(0x01, &[string(b"ros2"), string(b"x")].concat());
    let n = inner.len();
    let announced = (n - 9 + 10) as u64;
    inner[1..9].copy_from_slice(&announced.to_le_bytes());
    let e = err(&file(&[chunk(b"", n as u64, &inner)]));
    assert!(
        e.contains("record at byte 33: Header record at byte 0 of the chunk's records says 23 bytes, only 13 are"),
        "{e}"
    );
    // Fewer than 9 bytes left at the chunk's end: no room for a record's opcode and length.
    let good = record(0x0F, &0u32.to_le_bytes());
    let mut short = good.clone();
    short.extend_from_slice(&[0x05, 1, 0]);
    let e = err(&file(&[chunk(b"", short.len() as u64, &short)]));
    assert!(e.contains("the chunk's records end with 3 bytes at byte 13, too few for a record's opcode"), "{e}");
    // The same chunk with whole records reads.
    assert_eq!(check_lengths(&file(&[chunk(b"", good.len() as u64, &good)])), Ok(()));
}
