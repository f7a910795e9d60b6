//! The face-in-front test of the sensor checks (params key `face_in_front`; docs/attribution.md, "The face in
//! front"): a box confirmed by its own evidence whose rays end on that evidence in front of the box, farther than
//! its margin, is displaced away from the sensor. Part of [`Monitor`].
//!
//! The grown region `A_o` is judged in cells, so evidence up to about a cell diagonal beyond the margin still
//! lies "in" it: that is the paper's `dx_min` (1.27 m at 0.5 m cells and 0.1 m uncertainty). The visibility map
//! keeps the range of each direction's nearest return itself, not its cell, so along the rays through the box
//! the sensor tells where the object's face stands to within the spread of that direction's returns.

use super::*;

/// Sample points of the footprint whose rays are looked at, in units of the half length and half width (the
/// free-space test's 3 x 3, [`Monitor::seen_through`]).
const SAMPLES: [f32; 3] = [-0.6, 0.0, 0.6];

/// At least this many sample rays must end on the object's own face in front of the box (one row of the 3 x 3).
const FACE_MIN_RAYS: u32 = 3;

/// Where a ray from `origin` along the unit vector `(ux, uy)` enters the box, metres along the ray; `None` when
/// it misses the box or starts inside it.
fn entry_range(fp: &crate::geometry::OrientedRect, origin: [f32; 2], ux: f32, uy: f32) -> Option<f32> {
    let (px, py) = (origin[0] - fp.cx, origin[1] - fp.cy);
    // Origin and direction in the box's axes.
    let (ou, ov) = (px * fp.cos + py * fp.sin, -px * fp.sin + py * fp.cos);
    let (du, dv) = (ux * fp.cos + uy * fp.sin, -ux * fp.sin + uy * fp.cos);
    let mut enter = f32::NEG_INFINITY;
    let mut exit = f32::INFINITY;
    for (o, d, h) in [(ou, du, fp.half_length), (ov, dv, fp.half_width)] {
        if d.abs() < 1e-9 {
            if o.abs() > h {
                return None;
            }
            continue;
        }
        let (t1, t2) = ((-h - o) / d, (h - o) / d);
        enter = enter.max(t1.min(t2));
        exit = exit.min(t1.max(t2));
    }
    (enter.is_finite() && enter > 0.0 && enter <= exit).then_some(enter)
}

impl Monitor {
    /// For a box confirmed by its own evidence (no cluster, not seen through): the depth (metres) by which its
    /// own face stands in front of it along the rays through it, when the rays prove it. Of the 3 x 3 sample points
    /// of the free-space test, a ray is *judged* when the nearest obstacle return of its direction lies in a hit cell
    /// the object owns, outside every other object's grown region, and farther than `conflict_association_m` from
    /// every object without evidence of its own and without a cluster (that return may be theirs, lying in this
    /// object's cells). A judged ray finds the face *in front* when its return lies in front of where the ray
    /// enters the grown region `A_o` (the object may stand anywhere within it: measured from the box, a sideways
    /// shift within the margin moves a grazing ray's entry by metres), taken as the nearest entry over the
    /// directions the visibility bin spans (its nearest return may come from any of them). The box is displaced
    /// away from the sensor when at least [`FACE_MIN_RAYS`] judged rays, and more than half of them, find the face
    /// in front; the depth returned is the smallest of theirs, from the box. No memory; nine bin look-ups, 54
    /// ray-box entries and a look at the nearby regions for each judged ray.
    pub(super) fn face_in_front(&self, j: usize, region: &Region) -> Option<f32> {
        let fp = &region.footprint;
        let origin = self.visibility.origin();
        // A hit cell the object owns, however few its hits (the first return of a face is often alone in its cell).
        let own = |c: u32| self.owns(j, c);
        // Only cells it owns: a hit cell no region covers, even next to its own, may be a displaced neighbour's
        // evidence (in the paper-conditions street, 50 clean pedestrians blamed for such a neighbour at 1 m).
        // A bin spans at most about 1.41 times 360 / bins degrees (diamond angles); half of it, rounded up.
        let half_bin = 1.5 * core::f32::consts::PI / self.params.visibility_bins.max(1) as f32;
        let (sb, cb) = libm::sincosf(half_bin);
        let bin_rays = |ux: f32, uy: f32| {
            [(ux, uy), (ux * cb - uy * sb, ux * sb + uy * cb), (ux * cb + uy * sb, -ux * sb + uy * cb)]
        };
        let nearest_entry = |rect: &crate::geometry::OrientedRect, ux: f32, uy: f32| {
            bin_rays(ux, uy).iter().filter_map(|&(a, b)| entry_range(rect, origin, a, b)).fold(f32::INFINITY, f32::min)
        };
        // First the rays that end on the object's own evidence, and whether that return lies in front of the grown
        // region (the object may stand anywhere within it: measured from the box, a sideways shift within the
        // margin moves a grazing ray's entry by far more than the margin). A clean box has no such ray: it stops
        // here, before the look at the other objects.
        let mut rays = [(0.0f32, 0.0f32, 0.0f32, false); 9];
        let (mut n, mut candidates) = (0usize, 0u32);
        for u in SAMPLES {
            for v in SAMPLES {
                let (lu, lv) = (u * fp.half_length, v * fp.half_width);
                let (x, y) = (fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos);
                let (dx, dy) = (x - origin[0], y - origin[1]);
                let r = libm::sqrtf(dx * dx + dy * dy);
                if r.is_nan() || r <= 1e-3 {
                    continue;
                }
                let (ux, uy) = (dx / r, dy / r);
                let Some((near, cell)) = self.visibility.nearest_obstacle(x, y) else { continue };
                if !own(cell) {
                    continue;
                }
                let in_front = nearest_entry(&region.grown, ux, uy) - near > 0.0;
                if let Some(slot) = rays.get_mut(n) {
                    *slot = (ux, uy, near, in_front);
                    n += 1;
                    candidates += u32::from(in_front);
                }
            }
        }
        if candidates < FACE_MIN_RAYS {
            return None;
        }
        let (mut judged, mut front) = (0u32, 0u32);
        let mut depth = f32::INFINITY;
        for &(ux, uy, near, in_front) in rays.get(..n).unwrap_or(&[]) {
            let entry = nearest_entry(fp, ux, uy);
            if !entry.is_finite() {
                continue;
            }
            // A return inside another object's grown region may be that object's (a displaced neighbour's
            // evidence in this object's cells): it says nothing about this object's face.
            let (px, py) = (origin[0] + ux * near, origin[1] + uy * near);
            if self.in_other_region(j, px, py) || self.sought_nearby(j, px, py) {
                continue;
            }
            judged += 1;
            if in_front {
                front += 1;
                depth = depth.min(entry - near);
            }
        }
        (front >= FACE_MIN_RAYS && 2 * front > judged).then_some(depth)
    }
}

impl Monitor {
    /// True when an ego-frame point lies in the grown region of an object other than `j` (the regions whose
    /// bounding boxes can reach it along x, by the attribution's sorted sweep).
    pub(super) fn in_other_region(&self, j: usize, x: f32, y: f32) -> bool {
        let (lo, hi) = self.x_window([x, y, x, y], 0.0);
        (lo..hi).any(|m| {
            self.by_x.get(m).is_some_and(|&(_, k)| {
                k as usize != j
                    && self.scratch.get(k as usize).and_then(|s| s.region).is_some_and(|r| r.grown.contains(x, y))
            })
        })
    }
}

impl Monitor {
    /// True when an object other than `j` without evidence of its own and without a cluster (one that may be
    /// displaced and whose evidence is not found) has its grown region within `conflict_association_m` of the
    /// point: the return there may be its evidence, lying in `j`'s cells, and `j` is not blamed for it.
    pub(super) fn sought_nearby(&self, j: usize, x: f32, y: f32) -> bool {
        let gate = self.params.conflict_association_m;
        let tau_tp = self.params.tau_tp;
        let (lo, hi) = self.x_window([x, y, x, y], gate);
        (lo..hi).any(|m| {
            self.by_x.get(m).is_some_and(|&(_, k)| {
                k as usize != j
                    && self.scratch.get(k as usize).is_some_and(|s| {
                        s.cluster.is_none()
                            && s.eta_own < tau_tp
                            && s.region.is_some_and(|r| {
                                let (nx, ny) = r.grown.nearest_point(x, y);
                                (nx - x) * (nx - x) + (ny - y) * (ny - y) <= gate * gate
                            })
                    })
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::entry_range;
    use crate::geometry::OrientedRect;

    #[test]
    fn entry_range_of_an_axis_aligned_box() {
        // A 4 x 2 m box centred 10 m ahead.
        let fp = OrientedRect::new(10.0, 0.0, 0.0, 2.0, 1.0);
        assert_eq!(entry_range(&fp, [0.0, 0.0], 1.0, 0.0), Some(8.0));
        // Sideways: misses.
        assert_eq!(entry_range(&fp, [0.0, 0.0], 0.0, 1.0), None);
        // From inside: none.
        assert_eq!(entry_range(&fp, [10.0, 0.0], 1.0, 0.0), None);
        // Turned by 90 degrees the box is 2 m deep along the ray.
        let turned = OrientedRect::new(10.0, 0.0, core::f32::consts::FRAC_PI_2, 2.0, 1.0);
        let e = entry_range(&turned, [0.0, 0.0], 1.0, 0.0).unwrap();
        assert!((e - 9.0).abs() < 1e-5, "{e}");
        // Parallel to a face, outside it: misses.
        assert_eq!(entry_range(&fp, [0.0, 1.5], 1.0, 0.0), None);
    }
}
