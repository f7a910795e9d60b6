//! Looks at every missed-object alarm of a clean dataset check (a development aid):
//! `cargo run -p pmon-campaign --example av2_alarms -- SPEC`, e.g.
//! `av2:../shared/data/av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede`.
//!
//! For each missed-object cluster of each frame with a sweep (the dataset's ROI, the ground levelled as `pmon
//! check` does): its cells, how deep its deepest cell centre lies inside the region of interest (distance to the
//! nearest ROI edge), the returns over its cells in the obstacle band and above it (height over the levelled
//! ground), and the nearest labelled box. `GRAZE=f` checks with the grazing rule at that fraction (`GRAZE=0`: off;
//! unset: the default, 0.5).
use pmon_datasets::roi::RoiOptions;
use pmon_datasets::{open_with, ReadOptions};
use pmon_monitor::{Monitor, MonitorParams};

fn seg_dist(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let spec = args.get(1).ok_or("usage: av2_alarms SPEC")?;
    // `GRAZE=f` checks with the grazing rule at `roi_graze_fraction = f` (docs/datasets.md, "The grazing rule"),
    // `GRAZE=0` without it; unset, the default (0.5).
    let graze = std::env::var("GRAZE").map_or(Ok(MonitorParams::default().roi_graze_fraction), |v| v.parse::<f32>())?;
    let base = MonitorParams { roi_graze_fraction: graze, ..MonitorParams::default() };
    let roi = RoiOptions { grid_half_extent_m: 0.5 * f64::from(base.grid_size_m), ..RoiOptions::default() };
    let ground = pmon_datasets::ground::GroundMode::parse(&std::env::var("GROUND").unwrap_or_else(|_| "auto".into()))?;
    let ds = open_with(spec, &ReadOptions { load_clouds: true, roi, ground })?;
    let params =
        MonitorParams { ground_z_m: ds.info.ground_z_m, ego_footprint_m: ds.info.format.ego_footprint_m(), ..base };
    let mut monitor = Monitor::new(params)?;
    let g = pmon_monitor::GridGeometry::new(params.grid_cells_per_side(), params.cell_size_m);
    let (lo, hi) = params.obstacle_band_m();
    let half = 0.5 * params.cell_size_m;
    for df in ds.frames.iter().filter(|f| f.frame.cloud.is_some()) {
        let mut polys = Vec::new();
        let view = df.frame.as_frame(&mut polys);
        let rep = monitor.check(&view)?;
        let pts = df.points_in_ego();
        for c in rep.clusters.iter().filter(|c| c.is_missed_object()) {
            let inb = |q: &[f32; 3]| {
                q[0] >= c.bounds_m[0] - half
                    && q[0] <= c.bounds_m[2] + half
                    && q[1] >= c.bounds_m[1] - half
                    && q[1] <= c.bounds_m[3] + half
            };
            let mine: Vec<&[f32; 3]> = pts.iter().filter(|q| inb(q)).collect();
            let band = mine.iter().filter(|q| q[2] >= lo && q[2] <= hi).count();
            let band_in_roi = mine
                .iter()
                .filter(|q| q[2] >= lo && q[2] <= hi)
                .filter(|q| df.frame.roi_in_ego.iter().any(|p| pmon_monitor::geometry::polygon_contains(p, q[0], q[1])))
                .count();
            let above = mine.iter().filter(|q| q[2] > hi).count();
            let zmax = mine.iter().map(|q| q[2] - params.ground_z_m).fold(f32::NEG_INFINITY, f32::max);
            // Deepest cell centre (of the cells with band returns) inside the ROI.
            let mut cells: Vec<u32> =
                mine.iter().filter(|q| q[2] >= lo && q[2] <= hi).filter_map(|q| g.point_to_cell(q[0], q[1])).collect();
            cells.sort_unstable();
            cells.dedup();
            let mut depth = f32::NEG_INFINITY;
            for &cell in &cells {
                let (x, y) = g.cell_center(cell);
                for p in &df.frame.roi_in_ego {
                    if !pmon_monitor::geometry::polygon_contains(p, x, y) {
                        continue;
                    }
                    let n = p.len();
                    let d = (0..n).map(|i| seg_dist([x, y], p[i], p[(i + 1) % n])).fold(f32::INFINITY, f32::min);
                    depth = depth.max(d);
                }
            }
            let nearest = df
                .frame
                .objects
                .iter()
                .map(|o| ((o.x_m - c.centroid_m[0]).hypot(o.y_m - c.centroid_m[1]), o.id, o.class.name()))
                .fold((f32::INFINITY, 0, ""), |a, b| if b.0 < a.0 { b } else { a });
            println!(
                "frame {} cluster {} cells at ({:.1}, {:.1}) x {:.1}..{:.1} y {:.1}..{:.1}: deepest cell {:.2} m inside \
                 the ROI; {} band returns ({} inside the ROI), {} above the band, top {:.1} m over the ground; nearest box {} {} at {:.1} m",
                df.frame.index,
                c.cells,
                c.centroid_m[0],
                c.centroid_m[1],
                c.bounds_m[0],
                c.bounds_m[2],
                c.bounds_m[1],
                c.bounds_m[3],
                depth,
                band,
                band_in_roi,
                above,
                zmax,
                nearest.2,
                nearest.1,
                nearest.0
            );
        }
    }
    Ok(())
}
