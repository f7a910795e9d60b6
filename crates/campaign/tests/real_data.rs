//! The real-data experiments on the shared data extracts (see the data folder's README). Every test that needs
//! the data prints a SKIPPED message and returns when the folder is absent (`PMON_DATA_DIR`, default
//! `<workspace>/../shared/data`).
//!
//! The full experiment (every magnitude, ten seeds) is `#[ignore]`d; run it with
//! `cargo test -p pmon-campaign --release --test real_data -- --ignored --nocapture`.

use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::Instant;

use pmon_campaign::experiments::{Curve, Figure};
use pmon_campaign::real_data::{real_data_experiments_with, RealDataOptions, RealDataResults};
use pmon_monitor::MonitorParams;

mod common;

const SEED: u64 = 20_240_611;

/// The data folder ([`common::data_dir`]), or `None` after printing why the test is skipped.
fn data() -> Option<PathBuf> {
    let d = common::data_dir();
    common::require(&d.join("nuscenes"), || format!("real data not found at {}", d.display()))?;
    Some(d)
}

/// The smoke-sized run, computed once for all tests of this file.
fn smoke() -> Option<&'static RealDataResults> {
    static RESULT: OnceLock<Option<RealDataResults>> = OnceLock::new();
    RESULT
        .get_or_init(|| {
            let dir = data()?;
            let t0 = Instant::now();
            let r = real_data_experiments_with(&dir, &MonitorParams::PAPER, SEED, &RealDataOptions::smoke())
                .unwrap_or_else(|e| panic!("real-data experiments failed: {e}"));
            eprintln!("smoke real-data experiments: {:.1} s", t0.elapsed().as_secs_f64());
            Some(r)
        })
        .as_ref()
}

fn figure<'a>(r: &'a RealDataResults, id: &str) -> &'a Figure {
    r.figures.iter().find(|f| f.spec.id == id).unwrap_or_else(|| panic!("no figure {id}"))
}

fn curve<'a>(f: &'a Figure, prefix: &str) -> &'a Curve {
    f.curves.iter().find(|c| c.label.starts_with(prefix)).unwrap_or_else(|| panic!("{}: no curve {prefix}", f.spec.id))
}

fn print(r: &RealDataResults) {
    for (title, headers, rows) in &r.tables {
        eprintln!("\n## {title}\n| {} |", headers.join(" | "));
        for row in rows {
            eprintln!("| {} |", row.join(" | "));
        }
    }
    for f in &r.figures {
        eprintln!("\n# figure {}: {}", f.spec.id, f.spec.title);
        for c in &f.curves {
            let pts: Vec<String> =
                c.points.iter().map(|p| format!("{:.1}:{:.2}(n{})", p.x, p.rate.value, p.rate.n)).collect();
            eprintln!("  {:<60} {}", c.label, pts.join(" "));
        }
    }
    for c in &r.claims {
        eprintln!("\nCLAIM {:?}: {}\n   pmon: {}", c.met, c.paper, c.pmon);
    }
    for n in &r.notes {
        eprintln!("NOTE {n}");
    }
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn every_dataset_gives_figures_with_samples() {
    let Some(r) = smoke() else { return };
    for id in [
        "real_position_nuscenes",
        "real_position_kitti",
        "real_position_av2",
        "real_speed_errors_av2",
        "real_speed_errors_commonroad",
        "real_random_position_av2",
        "real_random_position_commonroad",
    ] {
        let f = figure(r, id);
        assert!(!f.curves.is_empty(), "{id} has no curves");
        for c in &f.curves {
            assert!(c.points.iter().any(|p| p.rate.n > 0), "{id}: curve {} has no samples", c.label);
            assert!(c.points.windows(2).all(|w| w[0].x < w[1].x), "{id}: {} not sorted by x", c.label);
        }
    }
    assert!(r.notes.iter().all(|n| !n.contains("skipped, not found")), "{:?}", r.notes);
    // nuScenes: one keyframe of 69 boxes; the all-boxes run displaces every box in scope.
    let f = figure(r, "real_position_nuscenes");
    let all = curve(f, "sensor recall, all boxes");
    assert!(all.points.iter().all(|p| p.rate.n > 0 && p.rate.n <= 69), "{all:?}");
    // Clean frames: one verdict row per sensor dataset, and flagged boxes come with a reason.
    let (_, headers, rows) =
        r.tables.iter().find(|t| t.0.starts_with("Clean real frames: sensor-check verdicts")).expect("clean table");
    assert_eq!(rows.len(), 3, "nuScenes, KITTI, AV2");
    assert!(rows.iter().all(|row| row.len() == headers.len()));
    let (_, _, flagged) = r.tables.iter().find(|t| t.0.starts_with("Clean real frames: every box")).expect("flagged");
    assert!(flagged.iter().all(|row| row.last().is_some_and(|why| why.len() > 20)));
    // Claims: the nuScenes saturation claim is decided, the clean-data claim is informational.
    let sat = r.claims.iter().find(|c| c.paper.starts_with("Real sensor (nuScenes)")).expect("saturation claim");
    assert!(sat.met.is_some());
    let clean = r.claims.iter().find(|c| c.paper.starts_with("Clean real data")).expect("clean claim");
    assert!(clean.met.is_none());
    assert!(r.claims.iter().filter(|c| c.paper.starts_with("Clean real tracks")).count() == 2);
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn nuscenes_verifiable_recall_grows_with_the_error() {
    let Some(r) = smoke() else { return };
    let c = curve(figure(r, "real_position_nuscenes"), "sensor recall, verifiable boxes");
    let at = |x: f64| c.points.iter().find(|p| (p.x - x).abs() < 1e-9).expect("magnitude present").rate;
    let (small, large) = (at(0.1), at(2.0));
    assert!(small.n > 0 && large.n > 0);
    assert!(large.value > small.value, "recall at 2.0 m ({large:?}) must exceed recall at 0.1 m ({small:?})");
    // The verifiable boxes are a subset of all boxes in scope, and their count is reported.
    let all = curve(figure(r, "real_position_nuscenes"), "sensor recall, all boxes");
    for (a, v) in all.points.iter().zip(&c.points) {
        assert!((a.x - v.x).abs() < 1e-12 && v.rate.n <= a.rate.n && v.rate.k <= a.rate.k, "{a:?} vs {v:?}");
    }
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn plausibility_detects_large_transient_speed_errors_better_than_small_ones() {
    let Some(r) = smoke() else { return };
    for fam in ["av2", "commonroad"] {
        let c = curve(figure(r, &format!("real_speed_errors_{fam}")), "transient 10 %: recall");
        let (first, last) = (c.points.first().expect("points"), c.points.last().expect("points"));
        assert!(last.rate.value > first.rate.value, "{fam}: {c:?}");
    }
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn same_seed_gives_the_same_json() {
    let Some(first) = smoke() else { return };
    let Some(dir) = data() else { return };
    let again = real_data_experiments_with(&dir, &MonitorParams::PAPER, SEED, &RealDataOptions::smoke())
        .unwrap_or_else(|e| panic!("{e}"));
    let a = serde_json::to_string(first).expect("serialisable");
    let b = serde_json::to_string(&again).expect("serialisable");
    assert_eq!(a, b, "same seed, same results");
}

#[test]
fn malformed_data_is_an_error_naming_the_file() {
    let dir = std::env::temp_dir().join(format!("pmon-real-data-malformed-{}", std::process::id()));
    let nus = dir.join("nuscenes");
    std::fs::create_dir_all(&nus).expect("temp dir");
    std::fs::write(nus.join("sample_annotations.json"), b"{ not json").expect("write");
    let r = real_data_experiments_with(&dir, &MonitorParams::PAPER, 1, &RealDataOptions::smoke());
    let _ = std::fs::remove_dir_all(&dir);
    let err = r.expect_err("malformed nuScenes file must be an error");
    assert!(err.contains("sample_annotations.json") || err.contains("nuscenes"), "{err}");
}

/// The whole experiment, printed. Slow in the debug profile: run with
/// `cargo test -p pmon-campaign --release --test real_data -- --ignored --nocapture`.
#[test]
#[ignore = "full sweep: run in release with --ignored --nocapture"]
fn full_real_data_experiments() {
    let Some(dir) = data() else { return };
    let t0 = Instant::now();
    let r = real_data_experiments_with(&dir, &MonitorParams::PAPER, SEED, &RealDataOptions::full())
        .unwrap_or_else(|e| panic!("{e}"));
    let secs = t0.elapsed().as_secs_f64();
    print(&r);
    eprintln!("\nfull real-data experiments: {secs:.1} s");
}

/// The smoke run, printed (fast; for looking at the tables).
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn print_smoke_tables() {
    let Some(r) = smoke() else { return };
    print(r);
}

/// One box displaced at a time (a condition beside the paper's): every dataset has the curve; a box moved 0.1 m
/// is not flagged (no false alarm from a shift far below a cell); moved 2 m, more boxes are flagged than at 0.1 m.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn one_box_displaced_at_a_time_is_measured_on_every_lidar_dataset() {
    let Some(r) = smoke() else { return };
    for key in ["nuscenes", "kitti", "av2"] {
        let c = curve(
            figure(r, &format!("real_position_{key}")),
            "sensor recall, boxes consistent on the clean frame (one",
        );
        let at = |x: f64| c.points.iter().find(|p| (p.x - x).abs() < 1e-9).expect("magnitude present").rate;
        let (small, large) = (at(0.1), at(2.0));
        eprintln!("{key}: one box at a time, recall at 0.1 m {small:?}, at 2.0 m {large:?}");
        // The same boxes at every magnitude, less those moved out of the grid.
        assert!(large.n > 0 && small.n >= large.n, "{key}: {small:?} {large:?}");
        assert_eq!(small.k, 0, "{key}: a box moved 0.1 m alone must not be flagged");
        assert!(large.k > 0, "{key}: {large:?}");
    }
    let sat = r.claims.iter().find(|c| c.paper.starts_with("Real sensor (av2")).expect("av2 claim");
    assert!(sat.pmon.contains("one box displaced at a time"), "{}", sat.pmon);
}

/// One box displaced after a clean sweep (the previous sweep checked clean before each displaced box): measured
/// where a frame follows another sweep within `max_time_step_s` (the two AV2 sweeps), at 1 m and 2 m, on fewer
/// boxes than the single sweep (only the second sweep counts); KITTI's object frames and the nuScenes keyframe have
/// no such sweep: no curve, and the table and the note say n/a rather than 0 %.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn one_box_after_a_clean_sweep_is_measured_where_a_sweep_follows_another() {
    let Some(r) = smoke() else { return };
    let label = "sensor recall, boxes consistent on the clean frame (one box displaced after a clean sweep)";
    let av2 = figure(r, "real_position_av2");
    let after = curve(av2, label);
    let single = curve(av2, "sensor recall, boxes consistent on the clean frame (one box displaced at a time)");
    assert_eq!(after.points.iter().map(|p| p.x).collect::<Vec<_>>(), vec![1.0, 2.0], "{after:?}");
    for p in &after.points {
        let one = single.points.iter().find(|q| (q.x - p.x).abs() < 1e-9).expect("magnitude present").rate;
        eprintln!("av2 {} m: after a clean sweep {:?}, single sweep {one:?}", p.x, p.rate);
        assert!(p.rate.n > 0 && p.rate.n < one.n, "{:?} vs {one:?}", p.rate);
    }
    for key in ["nuscenes", "kitti"] {
        let f = figure(r, &format!("real_position_{key}"));
        assert!(f.curves.iter().all(|c| c.label != label), "{key}: a curve without a previous sweep");
    }
    let (_, headers, rows) = r.tables.iter().find(|t| t.0.starts_with("Real sensor: permanent position")).unwrap();
    let column = headers.iter().position(|h| h.contains("one box displaced after a clean sweep"));
    let column = column.unwrap_or_else(|| panic!("no column: {headers:?}"));
    for row in rows {
        let cell = &row[column];
        assert_eq!(row.len(), headers.len(), "{row:?}");
        if row[0].starts_with("Argoverse") {
            assert!(cell.starts_with("1.0 m: ") && cell.contains("2.0 m: "), "{cell}");
        } else {
            assert_eq!(cell, "n/a (no previous sweep within max_time_step_s)", "{row:?}");
        }
    }
    let note = r.notes.iter().find(|n| n.contains("recall over the boxes consistent on the clean frame: nuScenes"));
    let note = note.unwrap_or_else(|| panic!("no note on the condition after a clean sweep: {:?}", r.notes));
    assert_eq!(note.matches("boxes): n/a (no previous sweep within max_time_step_s)").count(), 2, "{note}");
    assert!(note.contains("KITTI object frames (") && note.contains("(log 7fab2350)"), "{note}");
    assert!(note.contains("boxes): 1.0 m: "), "{note}");
    // Not a claim row (the README's generated table shows those).
    assert!(r.claims.iter().all(|c| !c.pmon.contains("after a clean sweep")));
}

/// Every box displaced at once after a clean sweep (the paper's form of that condition): measured where a frame
/// follows another sweep (the two AV2 sweeps) at 1 m and 2 m, over the same boxes as the one-box condition after a
/// clean sweep (consistent on their clean frame); at 2 m it catches at least as many as at 1 m. KITTI and nuScenes:
/// no curve, n/a in the table's last column and the note; not a claim row.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn every_box_after_a_clean_sweep_is_measured_where_a_sweep_follows_another() {
    let Some(r) = smoke() else { return };
    let label = "sensor recall, boxes consistent on the clean frame (every box displaced at once after a clean sweep)";
    let av2 = figure(r, "real_position_av2");
    let every = curve(av2, label);
    let one = curve(av2, "sensor recall, boxes consistent on the clean frame (one box displaced after a clean sweep)");
    assert_eq!(every.points.iter().map(|p| p.x).collect::<Vec<_>>(), vec![1.0, 2.0], "{every:?}");
    for (p, q) in every.points.iter().zip(&one.points) {
        eprintln!("av2 {} m: every box after a clean sweep {:?}, one box {:?}", p.x, p.rate, q.rate);
        // The same boxes counted: consistent on their clean frame, in the grid once displaced.
        assert!(p.rate.n > 0 && p.rate.n == q.rate.n && p.rate.k <= p.rate.n, "{:?} vs {:?}", p.rate, q.rate);
        assert!(p.rate.lo <= p.rate.value && p.rate.value <= p.rate.hi, "{:?}", p.rate);
    }
    assert!(every.points[0].rate.k > 0 && every.points[1].rate.k >= every.points[0].rate.k, "{every:?}");
    for key in ["nuscenes", "kitti"] {
        let f = figure(r, &format!("real_position_{key}"));
        assert!(f.curves.iter().all(|c| c.label != label), "{key}: a curve without a previous sweep");
    }
    let (_, headers, rows) = r.tables.iter().find(|t| t.0.starts_with("Real sensor: permanent position")).unwrap();
    assert!(
        headers.last().is_some_and(|h| h.contains("every box displaced at once after a clean sweep")),
        "{headers:?}"
    );
    for row in rows {
        let cell = row.last().unwrap();
        assert_eq!(row.len(), headers.len(), "{row:?}");
        if row[0].starts_with("Argoverse") {
            assert!(cell.starts_with("1.0 m: ") && cell.contains(") [") && cell.contains("; 2.0 m: "), "{cell}");
            assert!(!cell.contains("collateral"), "{cell}");
        } else {
            assert_eq!(cell, "n/a (no previous sweep within max_time_step_s)", "{row:?}");
        }
    }
    let note = r.notes.iter().find(|n| {
        n.starts_with("Real sensor, every box displaced at once after a clean sweep")
            && n.contains("recall over the boxes consistent on the clean frame: nuScenes")
    });
    let note = note.unwrap_or_else(|| panic!("no note on the every-box condition after a clean sweep: {:?}", r.notes));
    assert_eq!(note.matches("boxes): n/a (no previous sweep within max_time_step_s)").count(), 2, "{note}");
    assert!(note.contains("(log 7fab2350)") && note.contains("boxes): 1.0 m: "), "{note}");
    assert!(r.notes.iter().any(|n| n.contains("the paper displaces every box of the frame at once")), "{:?}", r.notes);
    assert!(r.claims.iter().all(|c| !c.pmon.contains("after a clean sweep")));
}

/// Distance from a point to a segment, metres.
fn seg_dist(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// The AV2 sweeps with the log's map and ground raster (as `pmon check`): no clean box flagged, at most 6
/// missed-object alarms per sweep (6 and 3 measured; the goal is 5), and every one of them is a structure at the
/// drivable area's edge with an obstacle-band return inside the ROI (a cluster is in the ROI when one of its returns
/// is), none reaching 1 m into it (docs/datasets.md, "The missed-object alarms that remain"), with the grazing rule
/// off (`roi_graze_fraction = 0`). With the default parameters, which carry the grazing rule since issue #10
/// (`roi_graze_fraction = 0.5`: docs/datasets.md, "The grazing rule", "Made the default"), at most 2 (2 and 1
/// measured: issue #10's goal of at most 5), none of them with fewer than half its band returns inside and a
/// return over it higher than 4.5 m.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn av2_missed_object_alarms_with_the_map_are_kerb_side_structures() {
    use pmon_datasets::roi::RoiOptions;
    use pmon_datasets::{open_with, ReadOptions};
    let Some(dir) = data() else { return };
    let log = dir.join(pmon_campaign::real_data::AV2_SWEEP_LOG);
    if !log.exists() {
        eprintln!("SKIPPED: {} not found", log.display());
        return;
    }
    let base = MonitorParams::default();
    let roi = RoiOptions { grid_half_extent_m: 0.5 * f64::from(base.grid_size_m), ..RoiOptions::default() };
    let opts = ReadOptions { load_clouds: true, roi, ground: pmon_datasets::ground::GroundMode::Auto };
    let ds = open_with(&format!("av2:{}", log.display()), &opts).unwrap_or_else(|e| panic!("{e}"));
    let params =
        MonitorParams { ground_z_m: ds.info.ground_z_m, ego_footprint_m: ds.info.format.ego_footprint_m(), ..base };
    assert!((params.roi_graze_fraction - 0.5).abs() < f32::EPSILON, "the default carries the grazing rule");
    let off = MonitorParams { roi_graze_fraction: 0.0, ..params };
    for (params, most) in [(off, 6), (params, 2)] {
        kerb_side_alarms(&ds, params, most);
    }
}

/// The sweeps of `ds` checked with `params`: no clean box flagged, at most `most` missed-object alarms per sweep,
/// each a cluster with a band return inside the ROI, none deeper than 1 m; with the grazing rule on, none that
/// the rule should have put outside the ROI (fewer than the fraction of its band returns inside, a return over its
/// cells above `roi_graze_height_m`: here over its bounding box widened by half a cell).
fn kerb_side_alarms(ds: &pmon_datasets::Dataset, params: MonitorParams, most: usize) {
    use pmon_monitor::{Monitor, SensorVerdict};
    let mut monitor = Monitor::new(params).expect("params");
    let half = 0.5 * params.cell_size_m;
    let (lo, hi) = params.obstacle_band_m();
    let mut sweeps = 0;
    for df in ds.frames.iter().filter(|f| f.frame.cloud.is_some()) {
        sweeps += 1;
        let mut polygons = Vec::new();
        let view = df.frame.as_frame(&mut polygons);
        let rep = monitor.check(&view).expect("check");
        let flagged = rep
            .objects
            .iter()
            .filter(|r| matches!(r.sensor.verdict, SensorVerdict::Ghost | SensorVerdict::PositionError))
            .count();
        assert_eq!(flagged, 0, "frame {}: clean boxes flagged", df.frame.index);
        let missed: Vec<_> = rep.clusters.iter().filter(|c| c.is_missed_object()).collect();
        eprintln!("frame {}: {} missed-object alarms", df.frame.index, missed.len());
        assert!(missed.len() <= most, "frame {}: {} missed-object alarms", df.frame.index, missed.len());
        let pts = df.points_in_ego();
        for c in missed {
            // The deepest band return within the cluster's cells inside the ROI.
            let mut depth = f32::NEG_INFINITY;
            let within = |q: &&[f32; 3]| {
                q[0] >= c.bounds_m[0] - half
                    && q[0] <= c.bounds_m[2] + half
                    && q[1] >= c.bounds_m[1] - half
                    && q[1] <= c.bounds_m[3] + half
            };
            let (mut band, mut inside) = (0usize, 0usize);
            let tall = pts.iter().filter(within).any(|q| q[2] > params.ground_z_m + params.roi_graze_height_m);
            for q in pts.iter().filter(|q| q[2] >= lo && q[2] <= hi).filter(within) {
                band += 1;
                inside += usize::from(
                    df.frame.roi_in_ego.iter().any(|p| pmon_monitor::geometry::polygon_contains(p, q[0], q[1])),
                );
                for p in df.frame.roi_in_ego.iter().filter(|p| pmon_monitor::geometry::polygon_contains(p, q[0], q[1]))
                {
                    let n = p.len();
                    let d = (0..n).map(|i| seg_dist([q[0], q[1]], p[i], p[(i + 1) % n])).fold(f32::INFINITY, f32::min);
                    depth = depth.max(d);
                }
            }
            assert!(
                (0.0..1.0).contains(&depth),
                "frame {}: cluster at {:?}: its deepest return {depth} m into the ROI",
                df.frame.index,
                c.centroid_m
            );
            let f = params.roi_graze_fraction;
            assert!(
                f == 0.0 || !tall || inside as f32 >= f * band as f32,
                "frame {}: cluster at {:?}: {inside} of {band} band returns inside, a return above {} m",
                df.frame.index,
                c.centroid_m,
                params.roi_graze_height_m
            );
        }
    }
    assert_eq!(sweeps, 2, "the log has two sweeps");
}
