//! Sets `cfg(pmon_no_data)` when the real data extracts are absent (`PMON_DATA_DIR`, default `../shared/data`
//! beside the repository), so that the tests needing them are listed as `ignored, needs the real data ...` in
//! plain `cargo test` output instead of passing silently (see docs/cli.md).

use std::path::PathBuf;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(pmon_no_data)");
    println!("cargo::rerun-if-env-changed=PMON_DATA_DIR");
    let dir = std::env::var_os("PMON_DATA_DIR").map_or_else(
        || PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default()).join("../../../shared/data"),
        PathBuf::from,
    );
    // A folder that appears or disappears re-runs this script.
    println!("cargo::rerun-if-changed={}", dir.display());
    if !dir.is_dir() {
        println!("cargo::warning=no real data at {}: the real-data tests are ignored", dir.display());
        println!("cargo::rustc-cfg=pmon_no_data");
    }
}
