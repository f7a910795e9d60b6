//! Argoverse 2 Feather (Arrow IPC) files: decode, then read every column type the readers use. Build with
//! AddressSanitizer (`-s address`, cargo-fuzz's default) so that oversized allocations are reported.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_datasets::av2::FeatherTable;

fuzz_target!(
    // libFuzzer's panic hook aborts before any unwinding, so the reader's catch_unwind around arrow-ipc (which
    // panics on some corrupted files; arrow-ipc 60) could never contain a panic here, unlike in pmon. The default
    // hook restores pmon's behaviour: a panic the reader contains becomes its error; one that escapes pmon's code
    // still reaches the harness's catch_unwind, which aborts, and is reported as a crash.
    init: drop(std::panic::take_hook()),
    |data: &[u8]| {
    let Ok(table) = FeatherTable::from_bytes(std::path::Path::new("fuzz.feather"), data.to_vec()) else { return };
    for name in ["timestamp_ns", "track_uuid", "category", "tx_m", "x", "qw", "length_m", "sensor_name"] {
        let _ = table.f64_column(name);
        let _ = table.f32_column(name);
        let _ = table.i64_column(name);
        let _ = table.string_column(name);
    }
    }
);
