//! CommonRoad XML scenarios, through the whole reader (frames are built, so step gaps are exercised).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if pmon_datasets::commonroad::parse_scenario(text).is_err() {
        return;
    }
    let Ok(dir) = tempfile::tempdir() else { return };
    let path = dir.path().join("fuzz.xml");
    if std::fs::write(&path, data).is_ok() {
        let _ = pmon_datasets::open(&format!("commonroad:{}", path.display()));
    }
});
