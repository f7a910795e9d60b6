//! nuScenes v1.0 scene slices, differential: the input is split at `\x00` into the tables' JSON texts
//! (`v1_tables.rs`). Whenever reading a scene from the table folder succeeds, cutting the tables into
//! slices must succeed and the scene read from its slice must be the same dataset, every digit (a mismatch
//! panics: a finding). Either may fail on bad input; neither may panic.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_datasets::ReadOptions;

#[path = "v1_tables.rs"]
mod v1_tables;

const SCENES: [&str; 2] = ["scene-0001", "scene-0002"];

fuzz_target!(|data: &[u8]| {
    let Some(dir) = v1_tables::write(data) else { return };
    let opts = ReadOptions { load_clouds: false, ..ReadOptions::default() };
    for scene in SCENES {
        let spec = format!("nuscenes-v1:{}#{scene}", dir.path().display());
        let folder = pmon_datasets::open_with(&spec, &opts);
        let mut slice = None;
        let cut = pmon_datasets::nuscenes_slice::slice_scenes(dir.path(), &[scene.to_string()], |_, text| {
            slice = Some(text);
            Ok(())
        });
        let Ok(folder) = folder else {
            if let Some(text) = &slice {
                let _ = pmon_datasets::open_with_slice(&spec, &opts, text);
            }
            continue;
        };
        assert!(cut.is_ok(), "{scene}: read from the folder, but not cut: {cut:?}");
        let text = slice.expect("a slice for the scene");
        let sliced = pmon_datasets::open_with_slice(&spec, &opts, &text)
            .unwrap_or_else(|e| panic!("{scene}: read from the folder, not from its slice: {e}"));
        assert_eq!(format!("{sliced:?}"), format!("{folder:?}"), "{scene}: the slice reads another dataset");
    }
});
