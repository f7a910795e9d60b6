//! Helpers shared by the `pmon` command's integration tests (`cli.rs`, `evaluate.rs`, `trust.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `pmon` binary built for these tests.
pub fn pmon(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pmon")).args(args).output().expect("pmon runs")
}

/// Standard output and standard error of a run, together.
pub fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// The real data extracts (`$PMON_DATA_DIR`, else `../shared/data`), or `None` with a `SKIPPED:` line.
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("PMON_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    if dir.exists() {
        Some(dir)
    } else {
        eprintln!("SKIPPED: no real data at {} (set PMON_DATA_DIR)", dir.display());
        None
    }
}
