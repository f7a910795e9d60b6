//! Lane paths: chains of straight lines and circular arcs, parametrised by arc length.

/// One piece of a path.
#[derive(Clone, Copy, Debug)]
enum Seg {
    Line {
        x0: f64,
        y0: f64,
        h0: f64,
        len: f64,
    },
    /// Signed curvature `k` (1/radius, positive turns left).
    Arc {
        x0: f64,
        y0: f64,
        h0: f64,
        k: f64,
        len: f64,
    },
}

impl Seg {
    fn len(&self) -> f64 {
        match *self {
            Self::Line { len, .. } | Self::Arc { len, .. } => len,
        }
    }

    /// Position, heading and curvature at `t` metres into the segment.
    fn pose(&self, t: f64) -> (f64, f64, f64, f64) {
        match *self {
            Self::Line { x0, y0, h0, .. } => {
                let (s, c) = h0.sin_cos();
                (x0 + c * t, y0 + s * t, h0, 0.0)
            }
            Self::Arc { x0, y0, h0, k, .. } => {
                let h = h0 + k * t;
                ((x0 + (h.sin() - h0.sin()) / k), (y0 - (h.cos() - h0.cos()) / k), h, k)
            }
        }
    }
}

/// Sample spacing of the projection table and the speed profile, metres.
const SAMPLE_M: f64 = 1.0;

/// A drivable path with its sampled speed profile.
#[derive(Clone, Debug)]
pub(crate) struct Path {
    segs: Vec<Seg>,
    /// Total length, metres.
    pub length: f64,
    /// Samples every [`SAMPLE_M`]: x, y, heading.
    samples: Vec<[f64; 3]>,
    /// Highest comfortable speed at each sample (curves, braking ahead of curves), m/s.
    vmax: Vec<f64>,
}

/// Builds a path piece by piece from a start pose.
pub(crate) struct PathBuilder {
    x: f64,
    y: f64,
    h: f64,
    segs: Vec<Seg>,
}

impl PathBuilder {
    pub(crate) fn new(x: f64, y: f64, heading: f64) -> Self {
        Self { x, y, h: heading, segs: Vec::new() }
    }

    pub(crate) fn line(mut self, len: f64) -> Self {
        if len > 1e-9 {
            let seg = Seg::Line { x0: self.x, y0: self.y, h0: self.h, len };
            self.advance(seg);
        }
        self
    }

    /// An arc of `radius` turning by `angle` (positive left).
    pub(crate) fn arc(mut self, radius: f64, angle: f64) -> Self {
        let k = angle.signum() / radius;
        let seg = Seg::Arc { x0: self.x, y0: self.y, h0: self.h, k, len: radius * angle.abs() };
        self.advance(seg);
        self
    }

    fn advance(&mut self, seg: Seg) {
        let (x, y, h, _) = seg.pose(seg.len());
        self.x = x;
        self.y = y;
        self.h = h;
        self.segs.push(seg);
    }

    /// Finishes the path; `lateral_accel_mps2` and `brake_mps2` shape the speed profile.
    pub(crate) fn build(self, lateral_accel_mps2: f64, brake_mps2: f64) -> Path {
        let length: f64 = self.segs.iter().map(Seg::len).sum();
        let mut path = Path { segs: self.segs, length, samples: Vec::new(), vmax: Vec::new() };
        let n = (length / SAMPLE_M).ceil() as usize + 1;
        let mut curv = Vec::with_capacity(n);
        for i in 0..n {
            let (x, y, h, k) = path.pose(i as f64 * SAMPLE_M);
            path.samples.push([x, y, h]);
            curv.push(k.abs());
        }
        // Curvature limit, then a backward pass so that the profile can be followed with `brake_mps2`.
        let mut vmax: Vec<f64> =
            curv.iter().map(|k| if *k > 1e-9 { (lateral_accel_mps2 / k).sqrt() } else { f64::INFINITY }).collect();
        for i in (0..n.saturating_sub(1)).rev() {
            let next = vmax[i + 1];
            vmax[i] = vmax[i].min((next * next + 2.0 * brake_mps2 * SAMPLE_M).sqrt());
        }
        path.vmax = vmax;
        path
    }
}

impl Path {
    /// Position, heading (continuous, not wrapped) and signed curvature at arc length `s` (clamped to the path).
    pub(crate) fn pose(&self, s: f64) -> (f64, f64, f64, f64) {
        let mut t = s.clamp(0.0, self.length);
        for seg in &self.segs {
            if t <= seg.len() {
                return seg.pose(t);
            }
            t -= seg.len();
        }
        match self.segs.last() {
            Some(seg) => seg.pose(seg.len()),
            None => (0.0, 0.0, 0.0, 0.0),
        }
    }

    /// Highest comfortable speed at `s`, m/s.
    pub(crate) fn vmax_at(&self, s: f64) -> f64 {
        let i = (s.max(0.0) / SAMPLE_M) as usize;
        let a = self.vmax.get(i).copied().unwrap_or(f64::INFINITY);
        let b = self.vmax.get(i + 1).copied().unwrap_or(f64::INFINITY);
        a.min(b)
    }

    /// Projects `(x, y)` onto the path within `[s_from, s_to]`: `(s, lateral offset (left positive), path heading)`
    /// of the nearest sample refined along its tangent; `None` if the window is empty.
    pub(crate) fn project(&self, x: f64, y: f64, s_from: f64, s_to: f64) -> Option<(f64, f64, f64)> {
        let i0 = (s_from.max(0.0) / SAMPLE_M).floor() as usize;
        let i1 = ((s_to.min(self.length) / SAMPLE_M).ceil() as usize).min(self.samples.len().saturating_sub(1));
        let mut best: Option<(usize, f64)> = None;
        for i in i0..=i1 {
            let Some(p) = self.samples.get(i) else { break };
            let d2 = (p[0] - x).powi(2) + (p[1] - y).powi(2);
            if best.is_none_or(|(_, b)| d2 < b) {
                best = Some((i, d2));
            }
        }
        let (i, _) = best?;
        let p = self.samples.get(i)?;
        let (sn, cs) = p[2].sin_cos();
        let (dx, dy) = (x - p[0], y - p[1]);
        let along = cs * dx + sn * dy;
        let lateral = -sn * dx + cs * dy;
        Some((i as f64 * SAMPLE_M + along, lateral, p[2]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn line_arc_line() {
        let p = PathBuilder::new(0.0, 0.0, 0.0).line(10.0).arc(5.0, FRAC_PI_2).line(10.0).build(2.0, 1.5);
        assert!((p.length - (20.0 + 5.0 * FRAC_PI_2)).abs() < 1e-9);
        let (x, y, h, _) = p.pose(p.length);
        assert!((x - 15.0).abs() < 1e-9 && (y - 15.0).abs() < 1e-9 && (h - FRAC_PI_2).abs() < 1e-9);
        // Speed profile: sqrt(2 * 5) in the arc, higher before it.
        assert!((p.vmax_at(12.0) - 10f64.sqrt()).abs() < 1e-6);
        // 10 m before the arc: sqrt(10 + 2 * 1.5 * 10).
        assert!((p.vmax_at(0.0) - 40f64.sqrt()).abs() < 1e-6, "{}", p.vmax_at(0.0));
        let (s, lat, _) = p.project(5.0, 1.0, 0.0, 30.0).unwrap();
        assert!((s - 5.0).abs() < 1e-9 && (lat - 1.0).abs() < 1e-9);
    }
}
