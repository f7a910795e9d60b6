//! The grazing rule of the region of interest (params keys `roi_graze_fraction` and `roi_graze_height_m`;
//! docs/datasets.md, "The grazing rule"). Part of [`Monitor`]; `clusters.rs` keeps the cluster stage that asks.
//!
//! Without the rule a conflict cluster is in the ROI when one of its obstacle-band returns lies inside it. A tree
//! or a post standing behind the kerb line then raises a missed-object alarm as soon as a few of its branches'
//! returns hang over the drivable area. With the rule such a cluster is in the ROI only when
//! - at least the fraction `f = roi_graze_fraction` of its band returns lie inside, or
//! - some lie inside and no return over its cells stands higher than `roi_graze_height_m` over the ground
//!   (no road user reaches 4.5 m; a tree, a lamp post or a sign gantry does).
//!
//! So a cluster leaves the ROI only when most of its evidence (by `f`) lies outside the area *and* something
//! over it is taller than any road user: a pedestrian stepping off the kerb (few returns inside, nothing tall
//! over them) and a road user under a canopy with at least `f` of its returns in the road both stay missed
//! objects. A road user sharing a cluster with a tree behind the kerb, with less than `f` of the cluster's band
//! returns inside, does not: that is what the rule gives up. It is reported as before, as unexplained evidence
//! outside the ROI (`ClusterReport::in_roi` false, `ClusterReport::roi` = `RoiStatus::Grazing`), not dropped.
//!
//! The amount: the band returns of the cluster's cells wholly inside the ROI ([`RoiSide::Inside`]: all of them,
//! the cell's hit count), plus those of its edge cells found inside one by one (through the cells the rasterizer
//! recorded per point, as `roi_by_returns` finds them), against all its band returns (hit counts, each capped at
//! `MAX_HITS` like the occupancy). The height: a bit per cell the rasterizer sets for each return above the
//! threshold as it transforms the sweep (`OccupancyGrid::with_tall`: a separate instantiation of its loop, only
//! with the rule on), read over the cells of the clusters the amount left undecided.
//!
//! [`RoiSide::Inside`]: super::roi::RoiSide::Inside

use super::clusters::for_each_marked_return;
use super::*;

/// A reported cluster's band returns for the grazing rule (index: the cluster's).
#[derive(Clone, Copy, Debug)]
pub(super) struct RoiAmount {
    /// Band returns in the cluster's cells wholly inside the ROI.
    pub(super) inside: u32,
    /// All its band returns.
    pub(super) all: u32,
    /// Still undecided: its whole cells did not hold the fraction, and some cell is inside or on the edge.
    pub(super) wait: bool,
}

impl Monitor {
    /// Decides the clusters the grazing rule left waiting (see the module documentation): counts their edge
    /// cells' band returns inside the ROI (when `edges`), then looks for tall returns over the clusters that have
    /// some but too few returns inside.
    pub(super) fn roi_by_amount(&mut self, frame: &Frame<'_>, cloud: Option<Cloud<'_>>, edges: bool) {
        let Some(cloud) = cloud else { return };
        let t = cloud.ego_from_sensor;
        let roi = frame.roi_in_ego;
        if edges {
            let (band, geometry) = (self.band(), self.grid.geometry);
            let (grid, index, counts) = (&self.grid, &self.roi, &mut self.roi_cell_counts);
            // Every return of an edge cell, counted when inside.
            for_each_marked_return(&self.edge_map, &self.point_cells, cloud, band, geometry, |cell, p| {
                if grid.flags(cell) & FLAG_ROI_EDGE == 0 {
                    return;
                }
                let q = t.transform(p);
                if index.contains(roi, cell, q[0], q[1]) {
                    if let Some(n) = counts.get_mut(cell as usize) {
                        *n = n.saturating_add(1);
                    }
                }
            });
        }
        // The amount: in with the fraction, out with none inside, else tall or not decides.
        let fraction = self.params.roi_graze_fraction;
        let mut grazing = false;
        for (k, &(start, end)) in self.cluster_spans.iter().enumerate() {
            let Some(amount) = self.roi_amounts.get_mut(k) else { break };
            if !amount.wait {
                continue;
            }
            let cells = self.queue.get(start as usize..end as usize).unwrap_or(&[]);
            let mut inside = amount.inside;
            for &cell in cells {
                if self.grid.flags(cell) & FLAG_ROI_EDGE != 0 {
                    if let Some(n) = self.roi_cell_counts.get_mut(cell as usize) {
                        inside += u32::from((*n).min(u8::try_from(self.grid.hits(cell)).unwrap_or(u8::MAX)));
                        *n = 0;
                    }
                }
            }
            amount.inside = inside;
            if inside == 0 {
                amount.wait = false;
            } else if inside as f32 >= fraction * amount.all as f32 {
                amount.wait = false;
                if let Some(c) = self.clusters.get_mut(k) {
                    c.in_roi = true;
                    c.roi = RoiStatus::Inside;
                }
                for &cell in cells {
                    self.grid.set_flags(cell, FLAG_ROI_CONFLICT);
                }
            } else {
                grazing = true;
            }
        }
        if !grazing {
            return;
        }
        for (k, &(start, end)) in self.cluster_spans.iter().enumerate() {
            let Some(amount) = self.roi_amounts.get_mut(k) else { break };
            if !amount.wait {
                continue;
            }
            amount.wait = false;
            // The height: a return above the threshold over one of its cells (the bits the rasterizer kept,
            // `OccupancyGrid::tall`).
            let cells = self.queue.get(start as usize..end as usize).unwrap_or(&[]);
            if cells.iter().any(|&cell| self.grid.tall(cell)) {
                // Outside by the grazing rule: the reason is kept for the report.
                if let Some(c) = self.clusters.get_mut(k) {
                    c.roi = RoiStatus::Grazing;
                }
                continue;
            }
            if let Some(c) = self.clusters.get_mut(k) {
                c.in_roi = true;
                c.roi = RoiStatus::Inside;
            }
            for &cell in cells {
                self.grid.set_flags(cell, FLAG_ROI_CONFLICT);
            }
        }
    }
}
