//! Argoverse 2 vector maps as the region of interest, and the corridor fallback: parsing (synthetic files
//! written here, and the real files when the shared data folder is there), the city -> ego transform against
//! the independent cross-check CSVs, bad input, and the ROI reaching the frames through `open_with`.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{data, f, read_csv};
use pmon_datasets::av2::PoseTrack;
use pmon_datasets::av2_map::{find_vector_map, MapRoiOptions, VectorMap};
use pmon_datasets::roi::{RoiMode, RoiOptions};
use pmon_datasets::{open_with, DatasetError, ReadOptions};
use pmon_monitor::geometry::polygon_contains;

const SWEEP_LOG: &str = "av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede";
const TRACK_LOG: &str = "av2/sensor/val/3b3570b4-7b0b-3268-a571-b0889dbf40b6";

fn pt(x: f64, y: f64) -> String {
    ptz(x, y, 0.0)
}

fn ptz(x: f64, y: f64, z: f64) -> String {
    format!("{{\"x\": {x}, \"y\": {y}, \"z\": {z}}}")
}

/// A map with one 20 m x 10 m drivable area, one crossing and one lane, plus the given extra areas.
fn synthetic(extra_areas: &str) -> String {
    format!(
        r#"{{"pedestrian_crossings": {{"7": {{"id": 7, "edge1": [{}, {}], "edge2": [{}, {}]}}}},
            "lane_segments": {{"3": {{"id": 3, "is_intersection": false, "lane_type": "VEHICLE",
                "left_lane_boundary": [{}, {}], "right_lane_boundary": [{}, {}], "successors": []}}}},
            "drivable_areas": {{"1": {{"id": 1, "area_boundary": [{}, {}, {}, {}]}}{extra_areas}}}}}"#,
        // crossing at x in [12, 15], y in [0, 10], its edges pointing opposite ways
        pt(12.0, 0.0),
        pt(12.0, 10.0),
        pt(15.0, 10.0),
        pt(15.0, 0.0),
        pt(0.0, 5.0),
        pt(20.0, 5.0),
        pt(0.0, 0.0),
        pt(20.0, 0.0),
        pt(0.0, 0.0),
        pt(20.0, 0.0),
        pt(20.0, 10.0),
        pt(0.0, 10.0),
    )
}

fn contains(roi: &[Vec<[f32; 2]>], x: f32, y: f32) -> bool {
    roi.iter().any(|p| polygon_contains(p, x, y))
}

#[test]
fn synthetic_map_parses_and_becomes_the_roi() {
    let m = VectorMap::parse(Path::new("synthetic.json"), &synthetic("")).unwrap();
    assert_eq!((m.drivable_areas.len(), m.crossings.len(), m.lane_segments.len()), (1, 1, 1));
    assert_eq!(m.lane_segments[0].lane_type, "VEHICLE");
    // Ego at city (10, 5), heading +y: city (x, y) -> ego (y - 5, 10 - x).
    let city_from_ego = pmon_datasets::geometry::Rigid3::from_quat_translation(
        [std::f64::consts::FRAC_PI_4.cos(), 0.0, 0.0, std::f64::consts::FRAC_PI_4.sin()],
        [10.0, 5.0, 0.0],
    )
    .unwrap();
    let no_band = MapRoiOptions { sidewalk_width_m: 0.0, clip_half_extent_m: 50.0 };
    let roi = m.roi_in_ego(&city_from_ego.inverse(), &no_band);
    assert_eq!(roi.len(), 2, "the area and the crossing");
    // city (19, 9) is in the area: ego (4, -9); city (19, 12) is not: ego (7, -9)
    assert!(contains(&roi, 4.0, -9.0));
    assert!(!contains(&roi, 7.0, -9.0));
    // The band: 2 m around the area (city y in (10, 12)), not beyond.
    let band = MapRoiOptions { sidewalk_width_m: 2.0, ..no_band };
    let roi = m.roi_in_ego(&city_from_ego.inverse(), &band);
    assert_eq!(roi.len(), 2 + 4);
    assert!(contains(&roi, 6.5, -9.0)); // city (19, 11.5)
    assert!(!contains(&roi, 7.5, -9.0)); // city (19, 12.5)
    assert!(contains(&roi, -6.5, 11.5)); // city (-1.5, -1.5): the convex corner is filled
                                         // A small grid square keeps only what reaches it.
    let small = MapRoiOptions { sidewalk_width_m: 2.0, clip_half_extent_m: 1.0 };
    let roi = m.roi_in_ego(&city_from_ego.inverse(), &small);
    assert_eq!(roi.len(), 1, "only the drivable area reaches the 2 m square around the ego");
    assert!(roi[0].iter().all(|p| p[0].abs() <= 1.0 + 1e-5 && p[1].abs() <= 1.0 + 1e-5));
}

#[test]
fn bad_map_files_are_errors_naming_the_file_or_skipped_and_counted() {
    let path = Path::new("/tmp/pmon-test/log_map_archive_x.json");
    let good = synthetic("");
    // Truncated JSON: an error naming the file and the line.
    let err = VectorMap::parse(path, &good[..good.len() / 2]).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, DatasetError::Malformed { .. }));
    assert!(text.contains("log_map_archive_x.json") && text.contains("line"), "{text}");
    // NaN is not JSON; a number too large for f64 is refused too.
    for bad in ["NaN", "1e999"] {
        let err = VectorMap::parse(path, &good.replacen("\"x\": 12", &format!("\"x\": {bad}"), 1)).unwrap_err();
        assert!(err.to_string().contains("log_map_archive_x.json"), "{bad}: {err}");
    }
    // A missing key.
    let err = VectorMap::parse(path, &good.replace("\"drivable_areas\"", "\"drivable\"")).unwrap_err();
    assert!(err.to_string().contains("drivable_areas"), "{err}");
    // Areas with fewer than 3 distinct points are skipped and counted; a crossing edge with 3 points too.
    let extra = format!(
        r#", "2": {{"id": 2, "area_boundary": [{}, {}]}}, "4": {{"id": 4, "area_boundary": [{}, {}, {}, {}]}}"#,
        pt(0.0, 0.0),
        pt(1.0, 1.0),
        pt(5.0, 5.0),
        pt(6.0, 5.0),
        pt(5.0, 5.0),
        pt(5.0, 5.0),
    );
    let text = synthetic(&extra).replace(
        &format!("\"edge1\": [{}, {}]", pt(12.0, 0.0), pt(12.0, 10.0)),
        &format!("\"edge1\": [{}, {}, {}]", pt(12.0, 0.0), pt(12.0, 5.0), pt(12.0, 10.0)),
    );
    let m = VectorMap::parse(path, &text).unwrap();
    assert_eq!((m.drivable_areas.len(), m.skipped_areas), (1, 2));
    assert_eq!((m.crossings.len(), m.skipped_crossings), (0, 1));
    // A missing file names itself.
    let err = VectorMap::read(Path::new("/nonexistent/log_map_archive_y.json")).unwrap_err();
    assert!(err.to_string().contains("/nonexistent/log_map_archive_y.json"), "{err}");
}

#[test]
fn two_map_files_in_one_folder_are_an_error() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(find_vector_map(dir.path()).unwrap(), None);
    std::fs::write(dir.path().join("log_map_archive_a.json"), "{}").unwrap();
    assert!(find_vector_map(dir.path()).unwrap().is_some());
    std::fs::write(dir.path().join("log_map_archive_b.json"), "{}").unwrap();
    let err = find_vector_map(dir.path()).unwrap_err().to_string();
    assert!(err.contains("2 log_map_archive"), "{err}");
}

#[test]
fn real_maps_parse() {
    for log in [SWEEP_LOG, TRACK_LOG] {
        let Some(dir) = data(log) else { return };
        let path = find_vector_map(&dir.join("map")).unwrap().expect("the log has a vector map");
        let m = VectorMap::read(&path).unwrap();
        eprintln!(
            "{}: {} drivable areas ({} skipped), {} crossings ({} skipped), {} lane segments",
            path.display(),
            m.drivable_areas.len(),
            m.skipped_areas,
            m.crossings.len(),
            m.skipped_crossings,
            m.lane_segments.len()
        );
        assert!(m.drivable_areas.len() >= 5 && m.crossings.len() >= 6 && m.lane_segments.len() >= 150);
        assert_eq!(m.skipped_areas + m.skipped_crossings, 0);
    }
}

/// The city -> ego transform the ROI uses, checked against the independent cross-check conversion: a tiny
/// triangle around each box's city-frame centre must land on the same box's ego-frame centre.
#[test]
fn city_to_ego_matches_the_crosscheck_boxes() {
    let Some(dir) = data(SWEEP_LOG) else { return };
    let Some(cc) = data("av2/crosscheck/7fab2350-7eaf-3b7e-a39d-6937a4c1bede") else { return };
    let ego_rows = read_csv(&cc.join("annotations_ego_frame.csv"));
    let city_rows = read_csv(&cc.join("tracks_city_frame.csv"));
    let key = |r: &BTreeMap<String, String>| (r["timestamp_ns"].clone(), r["track_uuid"].clone());
    let ego: BTreeMap<_, _> = ego_rows.iter().map(|r| (key(r), (f(r, "tx_m"), f(r, "ty_m")))).collect();
    let poses = PoseTrack::read(&dir.join("city_SE3_egovehicle.feather")).unwrap();
    let opts = MapRoiOptions { sidewalk_width_m: 0.0, clip_half_extent_m: 60.0 };
    let (mut checked, mut worst) = (0usize, 0.0f64);
    for r in city_rows.iter().step_by(7) {
        let Some(&(ex, ey)) = ego.get(&key(r)) else { continue };
        if ex.abs() > 55.0 || ey.abs() > 55.0 {
            continue;
        }
        let (cx, cy, cz) = (f(r, "x_city_m"), f(r, "y_city_m"), f(r, "z_city_m"));
        let tri =
            format!("[{}, {}, {}]", ptz(cx - 0.1, cy - 0.1, cz), ptz(cx + 0.1, cy - 0.1, cz), ptz(cx, cy + 0.2, cz));
        let json = format!(
            r#"{{"pedestrian_crossings": {{}}, "lane_segments": {{}}, "drivable_areas": {{"1": {{"area_boundary": {tri}}}}}}}"#
        );
        let m = VectorMap::parse(Path::new("tri.json"), &json).unwrap();
        let ts: i64 = r["timestamp_ns"].parse().unwrap();
        let (city_from_ego, _) = poses.nearest(ts).unwrap();
        let roi = m.roi_in_ego(&city_from_ego.inverse(), &opts);
        assert_eq!(roi.len(), 1);
        let n = roi[0].len() as f64;
        let mx = roi[0].iter().map(|p| f64::from(p[0])).sum::<f64>() / n;
        let my = roi[0].iter().map(|p| f64::from(p[1])).sum::<f64>() / n;
        // The triangle's vertex mean is the box centre exactly.
        let d = (mx - ex).hypot(my - ey);
        worst = worst.max(d);
        checked += 1;
    }
    eprintln!("city -> ego: {checked} boxes, worst distance {worst:.4} m");
    assert!(checked > 500, "{checked}");
    assert!(worst < 0.05, "worst {worst} m");
}

#[test]
fn the_map_reaches_the_frames_and_other_modes_replace_it() {
    let Some(dir) = data(SWEEP_LOG) else { return };
    let spec = format!("av2:{}", dir.display());
    let read = |mode| {
        let roi = RoiOptions { mode, ..RoiOptions::default() };
        open_with(&spec, &ReadOptions { load_clouds: false, roi, ..ReadOptions::default() }).unwrap()
    };
    let with_map = read(RoiMode::Auto);
    assert!(with_map.roi_note().is_some_and(|n| n.contains("vector map")), "{:?}", with_map.roi_note());
    let counts: Vec<usize> = with_map.frames.iter().map(|f| f.frame.roi_in_ego.len()).collect();
    assert!(counts.iter().all(|&n| n > 0 && n < 400), "{counts:?}");
    // The ego stands on the drivable area in every frame.
    assert!(with_map.frames.iter().all(|f| contains(&f.frame.roi_in_ego, 0.0, 0.0)));
    // Polygons are clipped to the 100 m grid.
    let all_in = |ds: &pmon_datasets::Dataset| {
        ds.frames
            .iter()
            .flat_map(|f| f.frame.roi_in_ego.iter().flatten())
            .all(|p| p[0].abs() <= 50.001 && p[1].abs() <= 50.001)
    };
    assert!(all_in(&with_map));
    let none = read(RoiMode::WholeGrid);
    assert!(none.frames.iter().all(|f| f.frame.roi_in_ego.is_empty()));
    assert!(none.roi_note().is_some_and(|n| n.starts_with("none")));
    let corridor = read(RoiMode::Corridor { width_m: 10.0 });
    assert!(corridor.roi_note().is_some_and(|n| n.contains("10 m corridor")));
    assert!(all_in(&corridor));
    for f in &corridor.frames {
        // The ego is on its own path; 30 m to the side of it is not (the log's path is a straight-ish street).
        assert!(contains(&f.frame.roi_in_ego, 0.0, 0.0) && contains(&f.frame.roi_in_ego, 0.0, 4.5));
        assert!(!contains(&f.frame.roi_in_ego, 0.0, 30.0) && !contains(&f.frame.roi_in_ego, 0.0, -30.0));
    }
}

#[test]
fn datasets_without_a_map_say_so() {
    if let Some(dir) = data("nuscenes") {
        let ds = open_with(&format!("nuscenes:{}", dir.display()), &ReadOptions::default()).unwrap();
        assert!(ds.frames.iter().all(|f| f.frame.roi_in_ego.is_empty()));
        let note = ds.roi_note().unwrap();
        assert!(note.contains("no map") && note.contains("corridor"), "{note}");
    }
    let Some(dir) = data("kitti/object/training") else { return };
    // KITTI's labels cover camera 2's image: that field of view is the default ROI, and the note says so.
    let ds = open_with(&format!("kitti:{}", dir.display()), &ReadOptions::default()).unwrap();
    let note = ds.roi_note().unwrap();
    assert!(note.starts_with("the labelled field of view") && note.contains("--roi none"), "{note}");
    for f in &ds.frames {
        assert!(contains(&f.frame.roi_in_ego, 30.0, 0.0) && contains(&f.frame.roi_in_ego, 30.0, 25.0));
        assert!(!contains(&f.frame.roi_in_ego, -10.0, 0.0) && !contains(&f.frame.roi_in_ego, 10.0, -30.0));
    }
    let roi = RoiOptions { mode: RoiMode::WholeGrid, ..RoiOptions::default() };
    let ds = open_with(&format!("kitti:{}", dir.display()), &ReadOptions { roi, ..ReadOptions::default() }).unwrap();
    assert!(ds.frames.iter().all(|f| f.frame.roi_in_ego.is_empty()));
    let roi = RoiOptions { mode: RoiMode::Corridor { width_m: 20.0 }, ..RoiOptions::default() };
    let ds = open_with(&format!("kitti:{}", dir.display()), &ReadOptions { roi, ..ReadOptions::default() }).unwrap();
    for f in &ds.frames {
        // Unknown ego poses: the straight band |y| <= 10 along the ego's x axis.
        assert!(contains(&f.frame.roi_in_ego, 45.0, 9.5) && contains(&f.frame.roi_in_ego, -45.0, -9.5));
        assert!(!contains(&f.frame.roi_in_ego, 0.0, 10.5));
    }
}
