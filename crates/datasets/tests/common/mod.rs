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
