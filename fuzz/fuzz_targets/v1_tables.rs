//! The input layout of the nuScenes v1.0 targets (`nuscenes_v1`, `nuscenes_slice`): split at `\x00` into the
//! tables' JSON texts, in this order, written into `v1.0-mini` of a temporary dataroot.

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

/// The temporary dataroot holding the tables `data` gives (`None` when it cannot be written).
pub fn write(data: &[u8]) -> Option<tempfile::TempDir> {
    let dir = tempfile::tempdir().ok()?;
    let tables = dir.path().join("v1.0-mini");
    std::fs::create_dir(&tables).ok()?;
    for (name, part) in TABLES.iter().zip(data.split(|b| *b == 0)) {
        std::fs::write(tables.join(name), part).ok()?;
    }
    Some(dir)
}
