//! Argoverse 2 Feather (Arrow IPC) files: decode, then read every column type the readers use. Build with
//! AddressSanitizer (`-s address`, cargo-fuzz's default) so that oversized allocations are reported.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_datasets::av2::FeatherTable;

fuzz_target!(|data: &[u8]| {
    let Ok(table) = FeatherTable::from_bytes(std::path::Path::new("fuzz.feather"), data.to_vec()) else { return };
    for name in ["timestamp_ns", "track_uuid", "category", "tx_m", "x", "qw", "length_m", "sensor_name"] {
        let _ = table.f64_column(name);
        let _ = table.f32_column(name);
        let _ = table.i64_column(name);
        let _ = table.string_column(name);
    }
});
