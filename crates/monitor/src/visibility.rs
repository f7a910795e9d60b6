//! A polar visibility map, to tell an empty region (ghost) from a hidden one (occluded).
//!
//! The hit-only occupancy grid cannot say whether a cell without hits is free or merely unseen. Per azimuth
//! bin around the sensor this map keeps the squared range of the nearest obstacle return (points in the
//! height band) and of the farthest return below the band's top (ground or obstacle). A ground position is
//! *visible* when it lies before the nearest obstacle of its bin (not in a shadow) and before the farthest
//! return (some ray reached past it). Cost: one pass over the points, no trigonometry (bins are spaced in
//! [`crate::geometry::diamond_angle`], which is monotonic in the true angle but not uniform: bins are at most
//! about 1.4 times wider than `360 / bins` degrees).

use alloc::vec;
use alloc::vec::Vec;

use crate::geometry::diamond_angle;

/// Cell index meaning "no cell" (outside the grid or no obstacle).
pub const NO_CELL: u32 = u32::MAX;

/// The binning of a [`VisibilityMap`], copied out so that a loop can bin many returns without borrowing the map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BinParams {
    /// Sensor origin, ego frame, metres.
    pub origin: [f32; 2],
    /// Bins per unit of diamond angle.
    pub bins_per_unit: f32,
    /// Index of the last bin.
    pub last_bin: usize,
}

/// What the sensor saw of a position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sight {
    /// Rays passed over it and returned from beyond: it is seen (to be empty, if it has no hits).
    Visible,
    /// It lies behind the nearest obstacle of its direction, whose grid cell is given.
    Shadowed(u32),
    /// No ray of its direction returned from as far: out of the sensor's reach.
    Unreached,
}

/// Nearest-obstacle and farthest-return ranges per azimuth bin.
#[derive(Clone, Debug)]
pub struct VisibilityMap {
    nearest_obstacle_r2: Vec<f32>,
    nearest_obstacle_cell: Vec<u32>,
    farthest_return_r2: Vec<f32>,
    origin: [f32; 2],
    bins_per_unit: f32,
}

impl VisibilityMap {
    /// A map with `bins` azimuth bins (at least 1).
    #[must_use]
    pub fn new(bins: u32) -> Self {
        let n = bins.max(1) as usize;
        Self {
            nearest_obstacle_r2: vec![f32::INFINITY; n],
            nearest_obstacle_cell: vec![NO_CELL; n],
            farthest_return_r2: vec![0.0; n],
            origin: [0.0, 0.0],
            bins_per_unit: n as f32 / 4.0,
        }
    }

    /// Clears the map and sets the sensor origin (ego frame, metres).
    pub fn reset(&mut self, origin: [f32; 2]) {
        self.nearest_obstacle_r2.fill(f32::INFINITY);
        self.nearest_obstacle_cell.fill(NO_CELL);
        self.farthest_return_r2.fill(0.0);
        self.origin = origin;
    }

    /// What the blocked rasteriser needs to bin returns itself (see `crate::rasterize`).
    #[must_use]
    pub(crate) fn bin_params(&self) -> BinParams {
        BinParams {
            origin: self.origin,
            bins_per_unit: self.bins_per_unit,
            last_bin: self.nearest_obstacle_r2.len().saturating_sub(1),
        }
    }

    /// Records a block of returns already binned (see [`BinParams`]), in order. Per return: its bin, its
    /// squared range as a candidate farthest return (`0.0` for a point that is no return: it never wins), as a
    /// candidate nearest obstacle (`f32::INFINITY` for a point that is no obstacle: it never wins), and the
    /// obstacle's grid cell. Same effect as [`VisibilityMap::add_return`] on each return in turn; ties keep the
    /// first, as there.
    #[inline]
    pub(crate) fn add_binned(&mut self, bins: &[u32], far_r2: &[f32], near_r2: &[f32], cells: &[u32]) {
        let returns = bins.iter().zip(far_r2).zip(near_r2).zip(cells);
        for (((&b, &far), &near), &cell) in returns {
            let b = b as usize;
            if let Some(f) = self.farthest_return_r2.get_mut(b) {
                if far > *f {
                    *f = far;
                }
            }
            if let Some(n) = self.nearest_obstacle_r2.get_mut(b) {
                if near < *n {
                    *n = near;
                    if let Some(c) = self.nearest_obstacle_cell.get_mut(b) {
                        *c = cell;
                    }
                }
            }
        }
    }

    /// The three arrays (nearest obstacle r^2, its cell, farthest return r^2), for bit-exact comparisons.
    #[cfg(test)]
    pub(crate) fn arrays(&self) -> (&[f32], &[u32], &[f32]) {
        (&self.nearest_obstacle_r2, &self.nearest_obstacle_cell, &self.farthest_return_r2)
    }

    #[inline]
    fn bin(&self, dx: f32, dy: f32) -> usize {
        let b = (diamond_angle(dx, dy) * self.bins_per_unit) as usize;
        b.min(self.nearest_obstacle_r2.len().saturating_sub(1))
    }

    /// Records a return at an ego-frame position; `obstacle` for points in the height band, with the grid
    /// cell it fell in (`NO_CELL` outside the grid).
    #[inline]
    pub fn add_return(&mut self, x: f32, y: f32, obstacle: bool, cell: u32) {
        let dx = x - self.origin[0];
        let dy = y - self.origin[1];
        let r2 = dx * dx + dy * dy;
        let b = self.bin(dx, dy);
        if let Some(f) = self.farthest_return_r2.get_mut(b) {
            if r2 > *f {
                *f = r2;
            }
        }
        if obstacle {
            if let Some(n) = self.nearest_obstacle_r2.get_mut(b) {
                if r2 < *n {
                    *n = r2;
                    if let Some(c) = self.nearest_obstacle_cell.get_mut(b) {
                        *c = cell;
                    }
                }
            }
        }
    }

    /// What the sensor saw of an ego-frame position.
    #[must_use]
    #[inline]
    pub fn sight(&self, x: f32, y: f32) -> Sight {
        let dx = x - self.origin[0];
        let dy = y - self.origin[1];
        let r2 = dx * dx + dy * dy;
        let b = self.bin(dx, dy);
        let near = self.nearest_obstacle_r2.get(b).copied().unwrap_or(0.0);
        let far = self.farthest_return_r2.get(b).copied().unwrap_or(0.0);
        if r2 >= near {
            Sight::Shadowed(self.nearest_obstacle_cell.get(b).copied().unwrap_or(NO_CELL))
        } else if r2 <= far {
            Sight::Visible
        } else {
            Sight::Unreached
        }
    }

    /// True when the ego-frame position is visible: before the nearest obstacle and the farthest return of
    /// its bin.
    #[must_use]
    #[inline]
    pub fn is_visible(&self, x: f32, y: f32) -> bool {
        self.sight(x, y) == Sight::Visible
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_behind_obstacle_and_reach_of_ground() {
        let mut v = VisibilityMap::new(1024);
        v.reset([0.0, 0.0]);
        v.add_return(10.0, 0.0, true, 42); // obstacle at 10 m straight ahead
        v.add_return(30.0, 0.0, false, NO_CELL); // ground return at 30 m behind it (other beam)
        v.add_return(0.0, 20.0, false, NO_CELL); // ground at 20 m to the left
        assert!(v.is_visible(5.0, 0.0));
        assert_eq!(v.sight(15.0, 0.0), Sight::Shadowed(42), "in the obstacle's shadow");
        assert!(v.is_visible(0.0, 15.0));
        assert_eq!(v.sight(0.0, 25.0), Sight::Unreached, "beyond the farthest return");
        assert!(!v.is_visible(-10.0, 0.0), "no return in that direction");
    }
}
