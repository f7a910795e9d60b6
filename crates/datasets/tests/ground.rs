//! The ground under each return on the real Argoverse 2 log 7fab2350 (a street on a hill): the local estimate
//! (`GroundMode::Local`, which never looks at the raster) checked against the log's own ground raster, and the
//! levelled sweeps (raster, `GroundMode::Auto`) against the sweeps as recorded.

mod common;

use common::data;
use pmon_datasets::av2::{GroundRaster, PoseTrack};
use pmon_datasets::ground::{GroundMode, SectorGround, SectorGroundOptions, GROUND_NOTE_PREFIX};
use pmon_datasets::{open_with, DatasetFormat, ReadOptions};
use pmon_monitor::geometry::OrientedRect;

const SWEEP_LOG: &str = "av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede";

fn read(mode: GroundMode) -> Option<pmon_datasets::Dataset> {
    let dir = data(SWEEP_LOG)?;
    Some(open_with(&format!("av2:{}", dir.display()), &ReadOptions { ground: mode, ..ReadOptions::default() }).unwrap())
}

/// Returns in the obstacle band (0.3 to 2.5 m above `ground_z_m`) behind the ego on its street, outside every
/// labelled box (grown by 0.5 m): the rising road.
fn band_behind(ds: &pmon_datasets::Dataset) -> usize {
    let z0 = ds.info.ground_z_m;
    let mut n = 0;
    for f in ds.frames.iter().filter(|f| f.frame.cloud.is_some()) {
        let boxes: Vec<OrientedRect> = f
            .frame
            .objects
            .iter()
            .map(|o| OrientedRect::new(o.x_m, o.y_m, o.heading_rad, 0.5 * o.length_m + 0.5, 0.5 * o.width_m + 0.5))
            .collect();
        n += f
            .points_in_ego()
            .iter()
            .filter(|p| p[0] < -24.0 && p[0] > -50.0 && p[1].abs() < 3.0 && p[2] >= z0 + 0.3 && p[2] <= z0 + 2.5)
            .filter(|p| !boxes.iter().any(|b| b.contains(p[0], p[1])))
            .count();
    }
    n
}

#[test]
fn the_local_estimate_agrees_with_the_raster_on_the_road() {
    let Some(ds) = read(GroundMode::AsRecorded) else { return };
    let dir = data(SWEEP_LOG).unwrap();
    let raster = GroundRaster::open(&dir.join("map")).unwrap();
    let poses = PoseTrack::read(&dir.join("city_SE3_egovehicle.feather")).unwrap();
    let mut errors = Vec::new();
    for f in ds.frames.iter().filter(|f| f.frame.cloud.is_some()) {
        let cloud = f.frame.cloud.as_ref().unwrap();
        let t = cloud.ego_from_sensor;
        let pts = f.points_in_ego();
        let g = SectorGround::estimate(
            &pts,
            [t.translation_m[0], t.translation_m[1]],
            ds.info.ground_z_m,
            DatasetFormat::Argoverse2.ego_footprint_m(),
            SectorGroundOptions::default(),
        );
        let ts_ns = (f.frame.timestamp_s * 1e9).round() as i64;
        let (pose, _) = poses.nearest(ts_ns).unwrap();
        // Ground returns by the raster (within 0.1 m of it), up to 50 m.
        for p in pts.iter().filter(|p| p[0].hypot(p[1]) < 50.0) {
            let c = pose.apply([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]);
            let Some(h) = raster.height_at_city(c[0], c[1]) else { continue };
            let above = (c[2] - f64::from(h)) as f32;
            if above.abs() > 0.1 {
                continue;
            }
            let raster_ground = p[2] - above;
            errors.push((g.height_at(p[0], p[1]).unwrap() - raster_ground).abs());
        }
    }
    errors.sort_by(f32::total_cmp);
    let q = |f: f64| errors[((errors.len() - 1) as f64 * f) as usize];
    eprintln!(
        "{} road returns: |local - raster| median {:.3} m, 90 % {:.3} m, 99 % {:.3} m",
        errors.len(),
        q(0.5),
        q(0.9),
        q(0.99)
    );
    assert!(errors.len() > 20_000, "{}", errors.len());
    assert!(q(0.5) < 0.05 && q(0.9) < 0.12, "median {} 90 % {}", q(0.5), q(0.9));
}

#[test]
fn levelled_sweeps_keep_the_rising_road_out_of_the_band() {
    let Some(recorded) = read(GroundMode::AsRecorded) else { return };
    let raster = read(GroundMode::Auto).unwrap();
    let local = read(GroundMode::Local).unwrap();
    let (r, a, l) = (band_behind(&recorded), band_behind(&raster), band_behind(&local));
    eprintln!("returns in the band 24-50 m behind the ego, |y| < 3 m: recorded {r}, raster {a}, local estimate {l}");
    assert!(r > 200, "the hill is in the band as recorded: {r}");
    assert!(a * 10 < r && l * 10 < r, "levelled: raster {a}, local {l}, recorded {r}");
    assert!(raster.info.notes.iter().any(|n| n.starts_with(GROUND_NOTE_PREFIX) && n.contains("raster")));
    assert!(local.info.notes.iter().any(|n| n.starts_with(GROUND_NOTE_PREFIX) && n.contains("local ground")));
    assert!(!recorded.info.notes.iter().any(|n| n.starts_with(GROUND_NOTE_PREFIX)));
    // Labelled boxes keep their returns: the points in each box (as the dataset counts them) stay within a few
    // of the recorded count after levelling (the box's own z is not moved; returns move by the local slope).
    for (fr, fa) in recorded.frames.iter().zip(&raster.frames).filter(|(f, _)| f.frame.cloud.is_some()) {
        let (pr, pa) = (fr.points_in_ego(), fa.points_in_ego());
        assert_eq!(pr.len(), pa.len());
        for (rx, ax) in pr.iter().zip(&pa) {
            assert!((rx[0] - ax[0]).abs() < 1e-3 && (rx[1] - ax[1]).abs() < 1e-3, "only z moves");
        }
    }
}
