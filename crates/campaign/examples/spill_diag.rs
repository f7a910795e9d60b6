//! Looks at the position errors of boxes confirmed by their own evidence (spill-over, docs/attribution.md step 5)
//! on a clean dataset check (a development aid): `cargo run --release -p pmon-campaign --example spill_diag -- SPEC`.
//!
//! For each such box: its size and margins, and every occupied cell within 2 m of its grown region in the box's
//! axes (`u` along, `v` across, metres from its centre), with its hits, whether it lies in the footprint or only
//! in the grown region, and whether it belongs to the attributed cluster. `SPILL=occupied`: with
//! `SpillOverFit::Occupied` (the default is `EveryReturn`).
use pmon_datasets::roi::RoiOptions;
use pmon_datasets::{open_with, ReadOptions};
use pmon_monitor::{Monitor, MonitorParams, SensorVerdict};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let spec = args.get(1).ok_or("usage: spill_diag SPEC")?;
    let base = MonitorParams::default();
    let roi = RoiOptions { grid_half_extent_m: 0.5 * f64::from(base.grid_size_m), ..RoiOptions::default() };
    let ground = pmon_datasets::ground::GroundMode::Auto;
    let ds = open_with(spec, &ReadOptions { load_clouds: true, roi, ground })?;
    let params =
        MonitorParams { ground_z_m: ds.info.ground_z_m, ego_footprint_m: ds.info.format.ego_footprint_m(), ..base };
    let mut monitor = Monitor::new(params)?;
    if std::env::var("SPILL").is_ok_and(|v| v == "occupied") {
        monitor.set_spill_over_fit(pmon_monitor::SpillOverFit::Occupied);
    }
    let g = pmon_monitor::GridGeometry::new(params.grid_cells_per_side(), params.cell_size_m);
    for df in ds.frames.iter().filter(|f| f.frame.cloud.is_some()) {
        let mut polys = Vec::new();
        let view = df.frame.as_frame(&mut polys);
        let rep = monitor.check(&view)?;
        let mut found = Vec::new();
        for (j, r) in rep.objects.iter().enumerate() {
            if r.sensor.verdict == SensorVerdict::PositionError && r.sensor.eta_own >= params.tau_tp {
                let c = r.sensor.cluster.and_then(|k| rep.clusters.get(usize::from(k))).copied();
                found.push((j, r.id, r.sensor.offset_m, c));
            }
        }
        for (j, id, offset, cluster) in found {
            let o = &df.frame.objects[j];
            let Some(region) = monitor.region_of(o) else { continue };
            let fp = region.footprint;
            println!(
                "frame {} {} {} at ({:.2}, {:.2}) {:.2} x {:.2} m, margins {:.2} / {:.2}, offset ({:.2}, {:.2}); cluster {:?}",
                df.frame.index,
                o.class.name(),
                id,
                o.x_m,
                o.y_m,
                2.0 * fp.half_length,
                2.0 * fp.half_width,
                region.margin_length_m,
                region.margin_width_m,
                offset[0],
                offset[1],
                cluster.map(|c| (c.cells, c.centroid_m, c.bounds_m))
            );
            let grid = monitor.grid();
            let b = region.grown.aabb();
            let Some((x0, y0, x1, y1)) = g.cell_range_clipped([b[0] - 2.0, b[1] - 2.0, b[2] + 2.0, b[3] + 2.0]) else {
                continue;
            };
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    let idx = iy * g.cells_per_side + ix;
                    if grid.hits(idx) == 0 {
                        continue;
                    }
                    let (x, y) = g.cell_center(idx);
                    let (u, v) = fp.local(x, y);
                    let in_cluster = cluster.is_some_and(|c| {
                        x >= c.bounds_m[0] - 1e-3
                            && x <= c.bounds_m[2] + 1e-3
                            && y >= c.bounds_m[1] - 1e-3
                            && y <= c.bounds_m[3] + 1e-3
                    });
                    let place = if fp.contains(x, y) {
                        "footprint"
                    } else if region.grown.overlaps_square(x, y, 0.5 * params.cell_size_m) {
                        "grown"
                    } else {
                        "outside"
                    };
                    println!(
                        "  cell ({x:.2}, {y:.2}) u {u:+.2} v {v:+.2} hits {} p {:.2} {place}{}",
                        grid.hits(idx),
                        grid.probability(idx),
                        if in_cluster { " CLUSTER" } else { "" }
                    );
                }
            }
        }
    }
    Ok(())
}
