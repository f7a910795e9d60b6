//! The region-of-interest row index of the cluster stage (`pmon_monitor::monitor::roi_index_mismatch`) gives the
//! answers of the test against every polygon on the real Argoverse 2 map frames: the side of every cell of the
//! grid (0.5 m and 0.2 m cells) and the containment of every return of the sweep, with the log's vector map as
//! the bench reads it and with a 3 m sidewalk band (many more polygons, many more edges).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use pmon_bench::frames;
use pmon_datasets::roi::{RoiMode, RoiOptions};
use pmon_datasets::ReadOptions;
use pmon_monitor::monitor::roi_index_mismatch;
use pmon_monitor::GridGeometry;

fn check(what: &str, roi: &[Vec<[f32; 2]>], points: &[[f32; 2]]) {
    let roi: Vec<&[[f32; 2]]> = roi.iter().map(Vec::as_slice).collect();
    assert!(!roi.is_empty(), "{what}: no ROI polygons");
    for (cells, cell) in [(200, 0.5), (500, 0.2)] {
        let (indexed, mismatch) = roi_index_mismatch(&roi, GridGeometry::new(cells, cell), points);
        assert_eq!(mismatch, None, "{what}, {cell} m cells");
        assert!(indexed, "{what}, {cell} m cells: the frame was not indexed (the reference answered)");
    }
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn the_row_index_agrees_with_the_polygon_tests_on_the_argoverse_2_maps() {
    let dir = frames::data_dir();
    let logs = pmon_bench::av2::logs(&dir).expect("readable Argoverse 2 logs");
    if logs.is_empty() {
        eprintln!("skipped: no Argoverse 2 sweeps under {} (set PMON_DATA_DIR)", dir.display());
        return;
    }
    for log in &logs {
        for sweep in &log.sweeps {
            let t = sweep.ego_from_sensor;
            let points: Vec<[f32; 2]> = sweep
                .points_in_sensor
                .iter()
                .map(|p| {
                    let q = t.transform(*p);
                    [q[0], q[1]]
                })
                .collect();
            check(&sweep.label, &sweep.roi_in_ego, &points);
        }
        // The same log with a 3 m sidewalk band along every drivable area (object lists and map only).
        let roi = RoiOptions { mode: RoiMode::Auto, sidewalk_width_m: 3.0, ..RoiOptions::default() };
        let dataset =
            pmon_datasets::av2::open_log(&log.dir, &ReadOptions { load_clouds: false, roi, ..ReadOptions::default() })
                .expect("readable log");
        let points: Vec<[f32; 2]> = (0..4000).map(|i| [-50.0 + 0.025 * i as f32, 30.0 - 0.0151 * i as f32]).collect();
        for (i, frame) in dataset.frames.iter().enumerate().step_by(20) {
            check(&format!("{} frame {i}, 3 m sidewalk", log.name()), &frame.frame.roi_in_ego, &points);
        }
    }
}
