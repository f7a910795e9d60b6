//! The conflict clusters of the sensor checks (eq. conflict; docs/attribution.md, "The rule, step by step", whose
//! steps 3-5 attribute them) and the region of interest decided by returns (docs/datasets.md, "Regions of
//! interest: maps and the corridor"). Part of [`Monitor`]; `monitor.rs` runs the stage, `attribution.rs` gives the
//! clusters to objects.
//!
//! `cluster_conflicts` groups the occupied hit cells no object explains into 8-connected clusters by a flood fill
//! (`visit_conflict`, one branch per neighbour: docs/performance.md, "Issue #10's latency budget"), the queue
//! keeping each cluster's cells contiguous, and decides whether each lies in the frame's region of interest: at
//! once when one of its cells' squares lies inside a polygon (`roi.rs`); a cluster its cells leave undecided has
//! its edge cells marked, and `roi_by_returns` tests their obstacle-band returns against the polygons, or with the
//! grazing rule `roi_by_amount` counts them (`graze.rs`; docs/datasets.md, "The grazing rule"). The returns are
//! found through the cells the rasterizer recorded per point and the byte-map prefilter of the marked cells
//! ([`EDGE_MAP`], [`marked_points`], [`for_each_marked_return`]; docs/performance.md, "The region of interest
//! decided by returns: cost side by side" and "The conflicts and verdicts stages, instruction by instruction").

use super::roi::RoiSide;
use super::*;
use crate::grid::{FLAG_RETURN_IN_ROI, FLAG_VISITED};

/// Bytes of the prefilter of the scan of the recorded cells (`Monitor::edge_map`): one per value of a cell's low 16
/// bits.
pub(super) const EDGE_MAP: usize = 1 << 16;

/// The byte of the prefilter that stands for cell `c` (`NO_CELL`: byte 0xFFFF).
#[inline]
pub(super) const fn edge_slot(c: u32) -> usize {
    (c & 0xFFFF) as usize
}

/// Which of a block's points (at most 64: `cells`, the cells the rasterizer recorded for them) lie in a cell the
/// prefilter `map` marks: bit `i` for point `i`. The block's bytes of the map are read first (a load each, no
/// bounds test: a 16-bit index into 65,536 bytes; `NO_CELL` reads byte 0xFFFF), then packed eight at a time: a
/// map byte is 0 or 1, and the product of eight such bytes (as one little-endian `u64`) with `0x0102_0408_1020_4080`
/// holds byte `i` in bit `56 + i` (no two of the 64 partial products meet in a bit). The scans of
/// `roi_by_returns` and `roi_by_amount` (the grazing rule) go through it.
#[inline]
fn marked_points(map: &[u8; EDGE_MAP], cells: &[u32]) -> u64 {
    let mut bytes = [0u8; 64];
    if let Ok(block) = <&[u32; 64]>::try_from(cells) {
        for (b, &cell) in bytes.iter_mut().zip(block) {
            *b = map.get(edge_slot(cell)).copied().unwrap_or(0);
        }
    } else {
        for (b, &cell) in bytes.iter_mut().zip(cells) {
            *b = map.get(edge_slot(cell)).copied().unwrap_or(0);
        }
    }
    let mut marked = 0u64;
    for (k, eight) in bytes.chunks_exact(8).enumerate() {
        let word = u64::from_le_bytes(<[u8; 8]>::try_from(eight).unwrap_or([0; 8]));
        marked |= (word.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * k);
    }
    marked
}

/// Every obstacle-band return of the sweep that may stand in a cell the prefilter `edge_map` marks, in the order
/// of the sweep, as `visit(cell, point in the sensor frame)`: the scan of `roi_by_returns` and `roi_by_amount`, and
/// of `seen_over`'s returns (`over.rs`, with its own prefilter).
/// Through the cells the rasterizer recorded per point, 64 at a time ([`marked_points`]: no branch per point), when
/// they were recorded for this sweep; else (never with the capacities of `new`) by a pass over the sweep that finds
/// each band return outside the ego footprint and its cell. Either way `visit` tests the cell's flags itself (they
/// may change as it goes, and the prefilter only narrows down) and transforms the point when it wants it.
pub(super) fn for_each_marked_return(
    edge_map: &[u8],
    point_cells: &[u32],
    cloud: Cloud<'_>,
    band: crate::rasterize::Band,
    geometry: GridGeometry,
    mut visit: impl FnMut(u32, [f32; 3]),
) {
    let points = cloud.points;
    let map = <&[u8; EDGE_MAP]>::try_from(edge_map).ok();
    if let Some(map) = map.filter(|_| point_cells.len() == points.len()) {
        for (block_index, cells) in point_cells.chunks(64).enumerate() {
            let mut marked = marked_points(map, cells);
            while marked != 0 {
                let i = marked.trailing_zeros() as usize;
                marked &= marked - 1;
                let (Some(&cell), Some(p)) = (cells.get(i), points.get(block_index * 64 + i)) else { continue };
                visit(cell, p);
            }
        }
    } else {
        for p in (0..points.len()).filter_map(|i| points.get(i)) {
            let q = cloud.ego_from_sensor.transform(p);
            if !(q[2] >= band.lo_m && q[2] <= band.hi_m) || band.in_ego(q[0], q[1]) {
                continue;
            }
            if let Some(cell) = geometry.point_to_cell(q[0], q[1]) {
                visit(cell, p);
            }
        }
    }
}

impl Monitor {
    /// One neighbour of the conflict flood fill: a hit cell whose probability exceeds `tau`, neither explained nor
    /// visited, joins the queue (while it has room) and is marked visited.
    #[inline(always)]
    fn visit_conflict(&mut self, nb: u32, tau: f32) {
        // The three cell tests with `&`, not `&&`: one branch on their outcome instead of three, each as hard to
        // predict as the next (`p > tau` negates the `p <= tau` written before: `P` and the validated `tau_fn`
        // are never NaN).
        let hits = self.grid.hits(nb);
        let joins = (hits != 0)
            & (self.grid.probability_of_hits(hits) > tau)
            & (self.grid.flags(nb) & (FLAG_EXPLAINED | FLAG_VISITED) == 0);
        if !joins || self.queue.len() >= self.queue.capacity() {
            return;
        }
        self.grid.set_flags(nb, FLAG_VISITED);
        self.queue.push(nb);
    }

    /// Conflict cells (`kappa > tau_fn`, eq. conflict) grouped into 8-connected clusters.
    pub(super) fn cluster_conflicts(&mut self, frame: &Frame<'_>, cloud: Option<Cloud<'_>>) {
        let geometry = self.grid.geometry;
        let n = geometry.cells_per_side;
        let tau = self.params.tau_fn;
        let mut edge_clusters = false;
        self.roi.build(frame.roi_in_ego);
        // The grazing rule (`graze.rs`): every cell's side is asked, and a cluster that its whole cells do not put
        // in the ROI with enough of its band returns waits for the amount of its returns inside and its height.
        let graze = self.params.roi_graze_fraction > 0.0 && !frame.roi_in_ego.is_empty();
        let fraction = self.params.roi_graze_fraction;
        let mut pending = false;
        self.roi_amounts.clear();
        let mut k = 0usize;
        while let Some(&idx) = self.grid.touched().get(k) {
            k += 1;
            if self.grid.probability(idx) <= tau {
                continue;
            }
            self.stats.cells_occupied += 1;
            let flags = self.grid.flags(idx);
            if flags & FLAG_EXPLAINED != 0 {
                continue;
            }
            self.stats.cells_conflict += 1;
            if flags & FLAG_VISITED != 0 {
                continue;
            }
            // Flood fill; the queue keeps every cluster's cells contiguous (bounded: each cell enters once).
            let start = self.queue.len();
            self.grid.set_flags(idx, FLAG_VISITED);
            self.queue.push(idx);
            let mut head = start;
            // The 8 neighbours of a cell off the grid's border, in the order of the loops below (same queue).
            let n_i = i64::from(n);
            let offsets = [-n_i - 1, -n_i, -n_i + 1, -1, 1, n_i - 1, n_i, n_i + 1];
            while let Some(&c) = self.queue.get(head) {
                head += 1;
                let (cx, cy) = (c % n, c / n);
                if cx > 0 && cy > 0 && cx + 1 < n && cy + 1 < n {
                    for off in offsets {
                        self.visit_conflict((i64::from(c) + off) as u32, tau);
                    }
                    continue;
                }
                for dy in -1i32..=1 {
                    for dx in -1i32..=1 {
                        if dx == 0 && dy == 0 {
                            continue;
                        }
                        let (nx, ny) = (cx as i64 + i64::from(dx), cy as i64 + i64::from(dy));
                        if nx < 0 || ny < 0 || nx >= i64::from(n) || ny >= i64::from(n) {
                            continue;
                        }
                        self.visit_conflict(ny as u32 * n + nx as u32, tau);
                    }
                }
            }
            let end = self.queue.len();
            let cells = (end - start) as u32;
            if cells < self.params.min_cluster_cells {
                continue;
            }
            self.stats.clusters_total += 1;
            if self.clusters.len() >= self.clusters.capacity() {
                continue;
            }
            let (mut sx, mut sy) = (0.0f32, 0.0f32);
            let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
            // In the region of interest: one of its obstacle-band returns inside the ROI, or no ROI. (Cells of
            // known scenery are explained by the map and never part of a cluster.) A cell whose square lies inside
            // a polygon decides it at once; cells straddling an edge are marked and decided return by return
            // below (`roi_by_returns`).
            let mut in_roi = frame.roi_in_ego.is_empty();
            let mut edge_cells = false;
            let (mut inside_hits, mut all_hits) = (0u32, 0u32);
            let span = self.queue.get(start..end).unwrap_or(&[]);
            for &c in span {
                let (x, y) = geometry.cell_center(c);
                sx += x;
                sy += y;
                b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
                if !in_roi || graze {
                    let hits = if graze { u32::from(self.grid.hits(c)) } else { 0 };
                    all_hits += hits;
                    match self.roi.cell_side(frame.roi_in_ego, c) {
                        RoiSide::Inside => {
                            in_roi = true;
                            inside_hits += hits;
                        }
                        RoiSide::Edge => {
                            edge_cells = true;
                            self.grid.set_flags(c, FLAG_ROI_EDGE);
                        }
                        RoiSide::Outside => {}
                    }
                }
            }
            // With the grazing rule a cluster stays undecided unless its whole cells alone hold the fraction of
            // its band returns inside; one with neither an inside cell nor an edge cell is outside.
            let wait = graze && (in_roi || edge_cells) && (inside_hits as f32) < fraction * all_hits as f32;
            if graze {
                in_roi &= !wait;
                if self.roi_amounts.len() < self.roi_amounts.capacity() {
                    self.roi_amounts.push(RoiAmount { inside: inside_hits, all: all_hits, wait });
                }
                pending |= wait;
            }
            // Only a cluster its cells leave undecided keeps its edge cells marked for the returns (each cell's
            // side asked once: a cluster left undecided had every cell asked above); in the byte map `edge_map` too,
            // which `roi_by_returns` scans the recorded cells with.
            if edge_cells {
                for &c in span {
                    if in_roi || (graze && !wait) {
                        self.grid.clear_flags(c, FLAG_ROI_EDGE);
                    } else if self.grid.flags(c) & FLAG_ROI_EDGE != 0 {
                        if let Some(b) = self.edge_map.get_mut(edge_slot(c)) {
                            *b = 1;
                        }
                    }
                }
                edge_clusters |= if graze { wait } else { !in_roi };
            }
            if in_roi {
                for k in start..end {
                    if let Some(&c) = self.queue.get(k) {
                        self.grid.set_flags(c, FLAG_ROI_CONFLICT);
                    }
                }
            }
            let inv = 1.0 / cells as f32;
            // The reason beside the outcome: a cluster still waiting is `Outside` until `roi_by_amount` decides
            // it (in, out with no return inside, or out by the grazing rule).
            let roi = match (frame.roi_in_ego.is_empty(), in_roi) {
                (true, _) => RoiStatus::NoRoi,
                (false, true) => RoiStatus::Inside,
                (false, false) => RoiStatus::Outside,
            };
            self.clusters.push(ClusterReport {
                cells,
                centroid_m: [sx * inv, sy * inv],
                bounds_m: b,
                in_roi,
                roi,
                object: None,
            });
            self.cluster_spans.push((start as u32, end as u32));
        }
        if graze {
            if pending {
                self.roi_by_amount(frame, cloud, edge_clusters);
            }
        } else if edge_clusters {
            self.roi_by_returns(frame, cloud);
        }
        if edge_clusters {
            // The prefilter is empty again for the next frame (every marked cell is in the queue).
            for &c in &self.queue {
                if let Some(b) = self.edge_map.get_mut(edge_slot(c)) {
                    *b = 0;
                }
            }
        }
    }

    /// Decides the clusters left undecided by their cells (every cell centre outside the ROI or within half a
    /// cell diagonal of its edge): such a cluster is in the ROI when one of the obstacle-band returns in its edge
    /// cells lies inside a polygon. The returns are found through the cells the rasterizer recorded per point (no
    /// second transform of the sweep), and tested against the polygon edges of their row (`roi.rs`), each cell
    /// until one return is inside. A cluster whose cells' centres lie inside while all its returns lie outside (a
    /// tree behind the kerb whose 0.5 m cells straddle the kerb line) is no missed object, and a road user whose
    /// returns reach into the area is one although its cells' centres lie outside.
    fn roi_by_returns(&mut self, frame: &Frame<'_>, cloud: Option<Cloud<'_>>) {
        let Some(cloud) = cloud else { return };
        let (t, roi) = (cloud.ego_from_sensor, frame.roi_in_ego);
        let (band, geometry) = (self.band(), self.grid.geometry);
        let (grid, index) = (&mut self.grid, &self.roi);
        // Each edge cell until one of its returns is inside (then its flag skips the rest of them).
        for_each_marked_return(&self.edge_map, &self.point_cells, cloud, band, geometry, |cell, p| {
            if grid.flags(cell) & (FLAG_ROI_EDGE | FLAG_RETURN_IN_ROI) != FLAG_ROI_EDGE {
                return;
            }
            let q = t.transform(p);
            if index.contains(roi, cell, q[0], q[1]) {
                grid.set_flags(cell, FLAG_RETURN_IN_ROI);
            }
        });
        for (k, &(start, end)) in self.cluster_spans.iter().enumerate() {
            let Some(c) = self.clusters.get_mut(k) else { continue };
            if c.in_roi {
                continue;
            }
            let cells = self.queue.get(start as usize..end as usize).unwrap_or(&[]);
            if cells.iter().any(|&cell| self.grid.flags(cell) & FLAG_RETURN_IN_ROI != 0) {
                c.in_roi = true;
                c.roi = RoiStatus::Inside;
                for &cell in cells {
                    self.grid.set_flags(cell, FLAG_ROI_CONFLICT);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Isometry3, PointCloud, Pose2};

    use super::super::roi::tests::Rng;

    /// `marked_points` sets bit `i` exactly when point `i`'s byte of the prefilter is set, for full and partial
    /// blocks, with `NO_CELL` and cells sharing a byte, on maps from empty to full.
    #[test]
    fn marked_points_is_the_prefilter_bit_by_bit() {
        let mut rng = Rng(0x5EED_0BAD_CAFE_F00D);
        let mut map = alloc::boxed::Box::new([0u8; EDGE_MAP]);
        for case in 0..2000u64 {
            let density = [0u64, 1, 10, 50, 100][(case % 5) as usize];
            for b in map.iter_mut() {
                *b = u8::from(rng.below(100) < density);
            }
            let len = if case % 3 == 0 { 1 + rng.below(64) as usize } else { 64 };
            let cells: Vec<u32> =
                (0..len).map(|_| if rng.below(4) == 0 { NO_CELL } else { rng.below(250_000) as u32 }).collect();
            let mut want = 0u64;
            for (i, &c) in cells.iter().enumerate() {
                if map.get((c & 0xFFFF) as usize).is_some_and(|&b| b != 0) {
                    want |= 1 << i;
                }
            }
            assert_eq!(marked_points(&map, &cells), want, "case {case}");
        }
    }

    /// The returns of the ROI's edge cells found through the recorded cells and the bit set of marked cells (the
    /// optimised path) give the same clusters, reports and cell flags as the straightforward pass over the sweep
    /// (the fallback, forced by a monitor whose per-point buffer has no room), on random clumps of returns around
    /// random polygon edges; and the bit set is empty after every frame.
    #[test]
    fn returns_of_edge_cells_by_recorded_cells_equal_the_pass_over_the_sweep() {
        // 0.5 m cells (40,000: one prefilter byte per cell) and 0.2 m cells (250,000: cells share bytes).
        for cell_size_m in [0.5f32, 0.2] {
            returns_of_edge_cells_equal_with(MonitorParams { cell_size_m, ..MonitorParams::default() });
        }
    }

    fn returns_of_edge_cells_equal_with(params: MonitorParams) {
        let mut fast = Monitor::new(params).unwrap();
        let mut slow = Monitor::new(params).unwrap();
        slow.point_cells = Vec::new();
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut undecided = 0usize;
        for frame_no in 0..40 {
            let mut points = Vec::new();
            for _ in 0..60 {
                let (cx, cy) = (rng.range(-40.0, 40.0), rng.range(-40.0, 40.0));
                let (sx, sy) = (rng.range(0.1, 1.5), rng.range(0.1, 1.5));
                for _ in 0..40 {
                    let z = if rng.range(0.0, 1.0) < 0.3 { rng.range(-0.2, 0.1) } else { rng.range(0.3, 1.8) };
                    points.push([cx + rng.range(-sx, sx), cy + rng.range(-sy, sy), z - 1.8]);
                }
            }
            let polys: Vec<Vec<[f32; 2]>> = (0..4)
                .map(|_| {
                    let (cx, cy, r) = (rng.range(-40.0, 40.0), rng.range(-40.0, 40.0), rng.range(2.0, 25.0));
                    (0..7)
                        .map(|k| {
                            let a = k as f32 * core::f32::consts::TAU / 7.0 + rng.range(0.0, 0.5);
                            let rr = r * rng.range(0.5, 1.0);
                            [cx + rr * libm::cosf(a), cy + rr * libm::sinf(a)]
                        })
                        .collect()
                })
                .collect();
            let roi: Vec<&[[f32; 2]]> = polys.iter().map(Vec::as_slice).collect();
            let frame = Frame {
                timestamp_s: f64::from(frame_no) * 0.1,
                world_from_ego: Pose2::default(),
                objects: &[],
                cloud: Some(PointCloud {
                    points_in_sensor: &points,
                    ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8),
                }),
                roi_in_ego: &roi,
                static_in_ego: &[],
            };
            let a = fast.check(&frame).unwrap();
            let (clusters, stats) = (a.clusters.to_vec(), a.grid);
            assert_eq!(fast.point_cells.len(), points.len());
            let b = slow.check(&frame).unwrap();
            assert_eq!(clusters, b.clusters, "frame {frame_no}");
            assert_eq!(stats, b.grid, "frame {frame_no}");
            assert!(slow.point_cells.is_empty());
            for cell in 0..fast.grid.geometry.cell_count() as u32 {
                assert_eq!(fast.grid.flags(cell), slow.grid.flags(cell), "frame {frame_no}, cell {cell}");
                if fast.grid.flags(cell) & FLAG_ROI_EDGE != 0 {
                    undecided += 1;
                }
            }
            assert!(fast.edge_map.iter().all(|&b| b == 0), "frame {frame_no}: prefilter not emptied");
        }
        // The frames do exercise the path: edge cells of undecided clusters were marked.
        assert!(undecided > 20, "{undecided} marked edge cells");
    }
}
