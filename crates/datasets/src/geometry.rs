//! Small 3D geometry for the readers: oriented boxes, points-in-box counting, rigid transforms, quaternions.
//!
//! Computations are in f64 (the datasets' poses are city-scale coordinates); results handed to the monitor
//! are f32.

use pmon_monitor::{Isometry3, Pose2};

/// An oriented 3D box with vertical yaw axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Box3 {
    /// Geometric centre, metres, in the frame of the points it is compared with.
    pub center_m: [f32; 3],
    /// Extent along the heading, metres.
    pub length_m: f32,
    /// Extent across the heading, metres.
    pub width_m: f32,
    /// Vertical extent, metres.
    pub height_m: f32,
    /// Heading about +z from +x, radians.
    pub yaw_rad: f32,
}

impl Box3 {
    /// True when `p` is inside the box or on its surface.
    #[must_use]
    pub fn contains(&self, p: [f32; 3]) -> bool {
        let (s, c) = f64::from(self.yaw_rad).sin_cos();
        let dx = f64::from(p[0]) - f64::from(self.center_m[0]);
        let dy = f64::from(p[1]) - f64::from(self.center_m[1]);
        let dz = f64::from(p[2]) - f64::from(self.center_m[2]);
        let along = c * dx + s * dy;
        let across = -s * dx + c * dy;
        along.abs() <= f64::from(self.length_m) / 2.0
            && across.abs() <= f64::from(self.width_m) / 2.0
            && dz.abs() <= f64::from(self.height_m) / 2.0
    }
}

/// Number of points inside `b` (surface included). Points and box must be in the same frame (the ego frame in
/// the cross-check tests: see [`crate::DatasetFrame::points_in_ego`] and [`crate::DatasetFrame::box_in_ego`]).
#[must_use]
pub fn points_in_box(points_in_ego: &[[f32; 3]], b: &Box3) -> u32 {
    let n = points_in_ego.iter().filter(|p| b.contains(**p)).count();
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Row-major 3x3 matrix.
pub type Mat3 = [[f64; 3]; 3];

/// The identity matrix.
pub const MAT3_IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `a * b`.
#[must_use]
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    m
}

/// `m * v`.
#[must_use]
pub fn mat_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// Transpose.
#[must_use]
pub fn transpose(m: &Mat3) -> Mat3 {
    [[m[0][0], m[1][0], m[2][0]], [m[0][1], m[1][1], m[2][1]], [m[0][2], m[1][2], m[2][2]]]
}

/// Inverse of a general 3x3 matrix; `None` when it is (nearly) singular or not finite.
#[must_use]
pub fn inverse(m: &Mat3) -> Option<Mat3> {
    let c = |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    if !det.is_finite() || det.abs() < 1e-12 {
        return None;
    }
    // inverse = adjugate / det, adjugate = transpose(cofactors)
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = cof[j][i] / det;
        }
    }
    Some(inv)
}

/// Largest deviation of `m * m^T` from the identity (0 for an exact rotation).
#[must_use]
pub fn orthonormality_error(m: &Mat3) -> f64 {
    let p = mat_mul(m, &transpose(m));
    let mut worst: f64 = 0.0;
    for (i, row) in p.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let want = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((v - want).abs());
        }
    }
    if worst.is_finite() {
        worst
    } else {
        f64::INFINITY
    }
}

/// Rotation matrix of a unit quaternion `(w, x, y, z)`; `None` when its norm is not within 1e-3 of 1.
#[must_use]
pub fn quat_to_mat(w: f64, x: f64, y: f64, z: f64) -> Option<Mat3> {
    let n = (w * w + x * x + y * y + z * z).sqrt();
    if !n.is_finite() || (n - 1.0).abs() > 1e-3 {
        return None;
    }
    let (w, x, y, z) = (w / n, x / n, y / n, z / n);
    Some([
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ])
}

/// Yaw of a rotation matrix: the heading of its x axis projected on the xy plane, radians.
#[must_use]
pub fn yaw_of(m: &Mat3) -> f64 {
    m[1][0].atan2(m[0][0])
}

/// Wraps an angle into `[-pi, pi)`.
#[must_use]
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let w = (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI;
    if w.is_finite() {
        w
    } else {
        a
    }
}

/// A rigid 3D transform `a_from_b`: `p_a = rotation * p_b + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid3 {
    /// Rotation.
    pub rotation: Mat3,
    /// Translation, metres.
    pub translation_m: [f64; 3],
}

impl Default for Rigid3 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Rigid3 {
    /// The identity.
    pub const IDENTITY: Self = Self { rotation: MAT3_IDENTITY, translation_m: [0.0; 3] };

    /// From a quaternion `(w, x, y, z)` and a translation; `None` when the quaternion is not a unit one or
    /// anything is not finite.
    #[must_use]
    pub fn from_quat_translation(q_wxyz: [f64; 4], t: [f64; 3]) -> Option<Self> {
        if !t.iter().all(|v| v.is_finite()) {
            return None;
        }
        let r = quat_to_mat(q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3])?;
        Some(Self { rotation: r, translation_m: t })
    }

    /// From a row-major homogeneous 4x4 matrix; `None` when the rotation block is not a rotation (within
    /// 1e-3), the last row is not `0 0 0 1` or anything is not finite.
    #[must_use]
    pub fn from_homogeneous(m: &[[f64; 4]; 4]) -> Option<Self> {
        if !m.iter().flatten().all(|v| v.is_finite()) {
            return None;
        }
        let last = m[3];
        if last[0].abs() > 1e-9 || last[1].abs() > 1e-9 || last[2].abs() > 1e-9 || (last[3] - 1.0).abs() > 1e-9 {
            return None;
        }
        let r = [[m[0][0], m[0][1], m[0][2]], [m[1][0], m[1][1], m[1][2]], [m[2][0], m[2][1], m[2][2]]];
        if orthonormality_error(&r) > 1e-3 {
            return None;
        }
        Some(Self { rotation: r, translation_m: [m[0][3], m[1][3], m[2][3]] })
    }

    /// Applies the transform to a point.
    #[must_use]
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let r = mat_vec(&self.rotation, p);
        [r[0] + self.translation_m[0], r[1] + self.translation_m[1], r[2] + self.translation_m[2]]
    }

    /// Rotates a direction (no translation).
    #[must_use]
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        mat_vec(&self.rotation, v)
    }

    /// The inverse transform (the rotation is assumed orthonormal).
    #[must_use]
    pub fn inverse(&self) -> Self {
        let rt = transpose(&self.rotation);
        let t = mat_vec(&rt, self.translation_m);
        Self { rotation: rt, translation_m: [-t[0], -t[1], -t[2]] }
    }

    /// `self * other` (apply `other` first).
    #[must_use]
    pub fn compose(&self, other: &Self) -> Self {
        Self { rotation: mat_mul(&self.rotation, &other.rotation), translation_m: self.apply(other.translation_m) }
    }

    /// Yaw of the rotation, radians.
    #[must_use]
    pub fn yaw_rad(&self) -> f64 {
        yaw_of(&self.rotation)
    }

    /// The planar part `(x, y, yaw)` as the monitor's [`Pose2`].
    #[must_use]
    pub fn to_pose2(&self) -> Pose2 {
        Pose2 { x_m: self.translation_m[0], y_m: self.translation_m[1], yaw_rad: self.yaw_rad() }
    }

    /// As the monitor's f32 [`Isometry3`].
    #[must_use]
    #[allow(clippy::cast_possible_truncation)] // metres-scale extrinsics: f32 is the monitor's precision
    pub fn to_isometry3(&self) -> Isometry3 {
        let r = &self.rotation;
        let f = |v: f64| v as f32;
        Isometry3 {
            rotation: [
                [f(r[0][0]), f(r[0][1]), f(r[0][2])],
                [f(r[1][0]), f(r[1][1]), f(r[1][2])],
                [f(r[2][0]), f(r[2][1]), f(r[2][2])],
            ],
            translation_m: [f(self.translation_m[0]), f(self.translation_m[1]), f(self.translation_m[2])],
        }
    }

    /// Heading in this transform's target frame of a direction given by `yaw_rad` in its source frame (the
    /// source's x axis rotated by `yaw_rad` about the source z, then rotated into the target and projected).
    #[must_use]
    pub fn map_yaw(&self, yaw_rad: f64) -> f64 {
        let (s, c) = yaw_rad.sin_cos();
        let d = self.rotate([c, s, 0.0]);
        d[1].atan2(d[0])
    }
}

/// Clips a polygon against the axis-aligned square `[-half, half]^2` (Sutherland-Hodgman). Exact for a convex
/// polygon; for a non-convex one (a drivable area) the result covers exactly the clipped area but may run along
/// the square's edge between pieces: zero-width parts that an even-odd point-in-polygon test never counts.
#[must_use]
pub fn clip_to_square(poly: &[[f64; 2]], half: f64) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = poly.to_vec();
    // Each edge: inside test value f(p) >= 0.
    let edges: [fn([f64; 2], f64) -> f64; 4] = [|p, h| h - p[0], |p, h| p[0] + h, |p, h| h - p[1], |p, h| p[1] + h];
    for f in edges {
        let input = std::mem::take(&mut out);
        let Some(&last) = input.last() else { break };
        let mut prev = last;
        for &cur in &input {
            let (fc, fp) = (f(cur, half), f(prev, half));
            if fc >= 0.0 {
                if fp < 0.0 {
                    out.push(lerp_at_zero(prev, cur, fp, fc));
                }
                out.push(cur);
            } else if fp >= 0.0 {
                out.push(lerp_at_zero(prev, cur, fp, fc));
            }
            prev = cur;
        }
    }
    out
}

fn lerp_at_zero(a: [f64; 2], b: [f64; 2], fa: f64, fb: f64) -> [f64; 2] {
    let t = fa / (fa - fb);
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// Signed area of a polygon (positive when counter-clockwise), square metres.
#[must_use]
pub fn polygon_area(poly: &[[f64; 2]]) -> f64 {
    let Some(&last) = poly.last() else { return 0.0 };
    let mut prev = last;
    let mut twice = 0.0;
    for &p in poly {
        twice += prev[0] * p[1] - p[0] * prev[1];
        prev = p;
    }
    0.5 * twice
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_contains_its_corners_and_not_beyond() {
        let b = Box3 { center_m: [10.0, 5.0, 1.0], length_m: 4.0, width_m: 2.0, height_m: 1.5, yaw_rad: 0.5 };
        let (s, c) = 0.5f32.sin_cos();
        let at = |a: f32, w: f32, z: f32| [10.0 + c * a - s * w, 5.0 + s * a + c * w, 1.0 + z];
        assert!(b.contains(at(1.99, 0.99, 0.74)));
        assert!(!b.contains(at(2.01, 0.0, 0.0)));
        assert!(!b.contains(at(0.0, 1.01, 0.0)));
        assert!(!b.contains(at(0.0, 0.0, 0.76)));
        assert_eq!(points_in_box(&[at(0.0, 0.0, 0.0), at(3.0, 0.0, 0.0), at(-1.9, -0.9, -0.7)], &b), 2);
    }

    #[test]
    fn quaternion_yaw_and_inverse() {
        let yaw: f64 = 2.5;
        let t =
            Rigid3::from_quat_translation([(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()], [1.0, 2.0, 3.0]).unwrap();
        assert!((t.yaw_rad() - yaw).abs() < 1e-12);
        let p = [4.0, -1.0, 0.5];
        let back = t.inverse().apply(t.apply(p));
        assert!(p.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-12));
        assert!(Rigid3::from_quat_translation([2.0, 0.0, 0.0, 0.0], [0.0; 3]).is_none());
        let m = [[1.0, 2.0, 0.5], [0.0, 1.0, 3.0], [2.0, 0.0, 1.0]];
        let i = inverse(&m).unwrap();
        let p = mat_mul(&m, &i);
        assert!(orthonormality_error(&p) < 1e-12);
        assert!(inverse(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }

    #[test]
    fn wrap_angle_range() {
        for a in [-10.0, -3.2, 0.0, 3.1, 3.2, 7.0, 100.0] {
            let w = wrap_angle(a);
            assert!((-std::f64::consts::PI..std::f64::consts::PI).contains(&w), "{a} -> {w}");
            let k = (a - w) / (2.0 * std::f64::consts::PI);
            assert!((k - k.round()).abs() < 1e-9, "{a} -> {w}");
        }
    }

    #[test]
    fn clip() {
        let sq = [[-10.0, -1.0], [10.0, -1.0], [10.0, 1.0], [-10.0, 1.0]];
        let c = clip_to_square(&sq, 5.0);
        assert!((polygon_area(&c) - 20.0).abs() < 1e-9);
        let far = [[20.0, 20.0], [30.0, 20.0], [30.0, 30.0]];
        assert!(clip_to_square(&far, 5.0).is_empty());
        // A non-convex U reaching out of the square on both arms keeps exactly its clipped area.
        let u =
            [[-8.0, -8.0], [8.0, -8.0], [8.0, 8.0], [4.0, 8.0], [4.0, -4.0], [-4.0, -4.0], [-4.0, 8.0], [-8.0, 8.0]];
        let c = clip_to_square(&u, 5.0);
        // square 100 minus the notch [-4, 4] x [-4, 5] = 72
        assert!((polygon_area(&c) - (100.0 - 72.0)).abs() < 1e-9, "{}", polygon_area(&c));
    }
}
