//! nuScenes v1.0 tables: the input is split at `\x00` into the tables' JSON texts (`v1_tables.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "v1_tables.rs"]
mod v1_tables;

fuzz_target!(|data: &[u8]| {
    let Some(dir) = v1_tables::write(data) else { return };
    let _ = pmon_datasets::open(&format!("nuscenes-v1:{}", dir.path().display()));
});
