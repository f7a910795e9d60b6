//! Shared helpers of the integration tests: where the real data is, a tiny CSV reader for cross-check files.

#![allow(dead_code)] // each test binary uses a different subset

use std::collections::BTreeMap;
use std::path::PathBuf;

/// `PMON_DATA_DIR`, or `<workspace root>/../shared/data`.
pub fn data_dir() -> PathBuf {
    match std::env::var_os("PMON_DATA_DIR") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    }
}

/// The data sub-folder `rel`, or `None` (after printing why the test is skipped) when it is absent.
pub fn data(rel: &str) -> Option<PathBuf> {
    let p = data_dir().join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("SKIPPED: real data {} not found (set PMON_DATA_DIR to the shared data folder)", p.display());
        None
    }
}

/// Reads a CSV file with a header into rows of `column -> value` (no quoting: the cross-check files have none).
pub fn read_csv(path: &std::path::Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| header.iter().cloned().zip(l.split(',').map(str::to_string)).collect())
        .collect()
}

/// A float field of a CSV row.
pub fn f(row: &BTreeMap<String, String>, key: &str) -> f64 {
    row.get(key).unwrap_or_else(|| panic!("no column {key}")).parse().unwrap()
}

/// Angle difference modulo `period` (pi for symmetric boxes, 2 pi otherwise), in `[0, period/2]`.
pub fn angle_diff_mod(a: f64, b: f64, period: f64) -> f64 {
    let d = (a - b).rem_euclid(period);
    d.min(period - d)
}

/// `open_deferred` then each frame's sweep read when asked gives the frames of `open_with` bit for bit (the
/// campaign streams them this way), with the dataset's ground surface and with the local estimate.
pub fn assert_deferred_same(spec: &str) {
    use pmon_datasets::ground::GroundMode;
    use pmon_datasets::{DatasetFormat, ReadOptions};
    for ground in [GroundMode::Auto, GroundMode::Local] {
        let opts = ReadOptions { ground, ..ReadOptions::default() };
        let whole = pmon_datasets::open_with(spec, &opts).unwrap();
        let (mut ds, sweeps) = pmon_datasets::open_deferred(spec, &opts).unwrap();
        assert!(ds.frames.iter().all(|f| f.frame.cloud.is_none()), "{spec}");
        let mut with_sweep = 0;
        for (i, f) in ds.frames.iter_mut().enumerate() {
            assert_eq!(sweeps.has_sweep(i), whole.frames[i].frame.cloud.is_some(), "{spec} frame {i}");
            f.frame.cloud = sweeps.cloud(i).unwrap();
            with_sweep += usize::from(f.frame.cloud.is_some());
        }
        assert!(with_sweep > 0, "{spec}");
        assert!(ds.frames == whole.frames, "{spec} {ground:?}: the frames differ");
        if ds.info.format != DatasetFormat::Argoverse2 {
            assert_eq!(ds.info, whole.info, "{spec} {ground:?}");
        }
    }
}
