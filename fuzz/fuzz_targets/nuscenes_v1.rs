//! nuScenes v1.0 tables: the input is split at `\x00` into the tables' JSON texts, in this order.
#![no_main]
use libfuzzer_sys::fuzz_target;

const TABLES: [&str; 9] = [
    "sample.json",
    "sample_data.json",
    "sample_annotation.json",
    "instance.json",
    "category.json",
    "ego_pose.json",
    "calibrated_sensor.json",
    "sensor.json",
    "scene.json",
];

fuzz_target!(|data: &[u8]| {
    let Ok(dir) = tempfile::tempdir() else { return };
    let tables = dir.path().join("v1.0-mini");
    if std::fs::create_dir(&tables).is_err() {
        return;
    }
    for (name, part) in TABLES.iter().zip(data.split(|b| *b == 0)) {
        if std::fs::write(tables.join(name), part).is_err() {
            return;
        }
    }
    let _ = pmon_datasets::open(&format!("nuscenes-v1:{}", dir.path().display()));
});
