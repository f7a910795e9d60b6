//! nuScenes, converted layout: `sample_annotations.json` (the fuzz input) beside a small fixed sweep.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(dir) = tempfile::tempdir() else { return };
    let json = dir.path().join("sample_annotations.json");
    if std::fs::write(&json, data).is_err() {
        return;
    }
    // A 3-point sweep under every name the file may reference is not possible; names it gives are resolved in
    // the folder, which holds nothing else.
    let _ = pmon_datasets::open(&format!("nuscenes:{}", dir.path().display()));
});
