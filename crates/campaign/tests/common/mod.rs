//! What the campaign's real-data test files share (the usual `tests/common/mod.rs`: a module of each test file that
//! declares `mod common;`, not a test target of its own): where the shared data extracts are, and the skip when
//! they are absent.

use std::path::{Path, PathBuf};

/// `PMON_DATA_DIR`, or `<workspace root>/../shared/data`.
pub fn data_dir() -> PathBuf {
    std::env::var_os("PMON_DATA_DIR")
        .map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"), PathBuf::from)
}

/// `Some(())` when `path` exists; otherwise `None` after printing "SKIPPED: `absent` (set PMON_DATA_DIR to the
/// shared data folder)", for the test to return.
pub fn require(path: &Path, absent: impl FnOnce() -> String) -> Option<()> {
    if path.exists() {
        Some(())
    } else {
        eprintln!("SKIPPED: {} (set PMON_DATA_DIR to the shared data folder)", absent());
        None
    }
}
