//! Bird's-eye view of one frame in the ego frame: grid cells, LiDAR points, object footprints with their grown
//! regions, conflict clusters and injected displacements (for `pmon view`).
//!
//! This is plain data: the caller converts monitor output into it, so this crate does not depend on the monitor.
//! Axes: x (forward) to the right, y (left) up, so the picture is the ego frame seen from above; metres on both
//! axes with equal scale.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::axes::{self, Axis, Margins};
use crate::plot::{
    clip_polyline, clip_segment, de, draw_arrow_px, draw_label, draw_legend, draw_path, draw_title, label_rect,
    label_size, legend_box, nice_step, ticks_with_step, DataRect, LegendEntry, Px, Swatch,
};
use crate::render::{impl_figure, Draw, Output};

/// What the monitor knows about one grid cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum CellState {
    /// Occupied by LiDAR points and explained by an object.
    Occupied,
    /// Occupied by LiDAR points but not explained by any object (a conflict, a possible missed object).
    Conflict,
    /// Observed free.
    Free,
    /// No information (occluded or out of sensor range).
    Unknown,
}

impl CellState {
    const ALL: [Self; 4] = [Self::Occupied, Self::Conflict, Self::Free, Self::Unknown];
    /// Drawing order: background states first so conflicts stay visible.
    const DRAW_ORDER: [Self; 4] = [Self::Unknown, Self::Free, Self::Occupied, Self::Conflict];

    fn color(self) -> RGBColor {
        match self {
            Self::Occupied => RGBColor(120, 120, 120),
            Self::Conflict => RGBColor(250, 128, 100),
            Self::Free => RGBColor(222, 240, 222),
            Self::Unknown => RGBColor(232, 232, 232),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Occupied => "occupied cell",
            Self::Conflict => "conflict cell",
            Self::Free => "free cell",
            Self::Unknown => "unknown cell",
        }
    }
}

/// One grid cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewCell {
    /// Cell centre, forward, in the ego frame \[m\].
    pub x_m: f32,
    /// Cell centre, left, in the ego frame \[m\].
    pub y_m: f32,
    /// The cell's state.
    pub state: CellState,
}

/// What a drawn footprint stands for; chooses its colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BoxKind {
    /// An object the monitor found consistent with the sensor data.
    Consistent,
    /// An object with no sensor evidence (a false positive).
    Ghost,
    /// An object whose position disagrees with the sensor data.
    PositionError,
    /// An object whose motion history is implausible.
    Implausible,
    /// An object only the plausibility checks judged (plausible motion, the sensor could not say).
    MotionOnly,
    /// An object the monitor did not judge (out of range, occluded, ...).
    NotMonitored,
    /// Where an object really was before a fault was injected (drawn as a thin black dashed outline).
    InjectedTruth,
}

impl BoxKind {
    const ALL: [Self; 7] = [
        Self::Consistent,
        Self::MotionOnly,
        Self::Ghost,
        Self::PositionError,
        Self::Implausible,
        Self::NotMonitored,
        Self::InjectedTruth,
    ];

    fn color(self) -> RGBColor {
        match self {
            Self::Consistent => RGBColor(0, 140, 60),
            Self::Ghost => RGBColor(150, 50, 180),
            Self::PositionError => RGBColor(215, 25, 28),
            Self::Implausible => RGBColor(235, 125, 0),
            Self::MotionOnly => RGBColor(60, 120, 200),
            Self::NotMonitored => RGBColor(125, 125, 125),
            Self::InjectedTruth => RGBColor(25, 25, 25),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Consistent => "consistent",
            Self::Ghost => "ghost",
            Self::PositionError => "position error",
            Self::Implausible => "implausible",
            Self::MotionOnly => "motion only (plausible, not seen)",
            Self::NotMonitored => "not monitored",
            Self::InjectedTruth => "injected truth",
        }
    }
}

/// An object footprint: an oriented box and the grown region the sensor check searched.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewBox {
    /// Box centre, forward, in the ego frame \[m\].
    pub x_m: f32,
    /// Box centre, left, in the ego frame \[m\].
    pub y_m: f32,
    /// Heading, counter-clockwise from the ego x axis \[rad\].
    pub heading_rad: f32,
    /// Footprint length along the heading \[m\].
    pub length_m: f32,
    /// Footprint width across the heading \[m\].
    pub width_m: f32,
    /// Length of the grown region (footprint plus uncertainty and safety margins) \[m\]; drawn dashed when larger
    /// than `length_m` or `width_m` is smaller than `grown_width_m`.
    pub grown_length_m: f32,
    /// Width of the grown region \[m\].
    pub grown_width_m: f32,
    /// Text written next to the box (e.g. the object id); may be empty.
    pub label: String,
    /// What the box stands for.
    pub kind: BoxKind,
}

/// A cluster of conflict cells, drawn as a dashed rectangle.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewCluster {
    /// Bounds `[min_x, min_y, max_x, max_y]` in the ego frame \[m\].
    pub bounds_m: [f32; 4],
    /// Text written at the cluster (may be empty).
    pub label: String,
}

/// A top view of one frame. The ego vehicle is drawn at the origin, pointing along +x.
///
/// Everything outside `extent_m` is clipped. The extent is widened along one axis so that both axes have the
/// same metres per pixel. Cells are not drawn when `cell_size_m` is not positive and finite. In SVG output at most
/// [`TopView::MAX_SVG_POINTS`] points are drawn (every k-th point), PNG draws all.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TopView {
    /// Title above the plot (may be empty).
    pub title: String,
    /// Shown region `(min_x, min_y, max_x, max_y)` in the ego frame \[m\]; if not finite or empty, the region is
    /// fitted to the data.
    pub extent_m: (f32, f32, f32, f32),
    /// Grid cell edge length \[m\].
    pub cell_size_m: f32,
    /// Grid cells to draw (any subset; unlisted cells stay white).
    pub cells: Vec<ViewCell>,
    /// LiDAR points `[x, y]` in the ego frame \[m\].
    pub points: Vec<[f32; 2]>,
    /// Object footprints.
    pub boxes: Vec<ViewBox>,
    /// Conflict clusters.
    pub clusters: Vec<ViewCluster>,
    /// Injected displacements `(from, to)` `[x, y]` \[m\], drawn as arrows (e.g. from the true to the reported
    /// position).
    pub arrows: Vec<([f32; 2], [f32; 2])>,
    /// Region-of-interest polygons `[x, y]` in the ego frame \[m\], filled light green (overlaps look darker).
    /// The caller clips them to the extent: vertices outside it are drawn where they fall.
    pub regions: Vec<Vec<[f32; 2]>>,
}

impl TopView {
    /// Upper bound on LiDAR points written to an SVG.
    pub const MAX_SVG_POINTS: usize = 20_000;

    /// An empty view of `extent_m` with `cell_size_m` cells.
    pub fn new(title: impl Into<String>, extent_m: (f32, f32, f32, f32), cell_size_m: f32) -> Self {
        Self { title: title.into(), extent_m, cell_size_m, ..Self::default() }
    }

    /// The usable extent as f64 `(x0, y0, x1, y1)`.
    fn extent(&self) -> (f64, f64, f64, f64) {
        let (x0, y0, x1, y1) = self.extent_m;
        let (x0, y0, x1, y1) = (f64::from(x0), f64::from(y0), f64::from(x1), f64::from(y1));
        if [x0, y0, x1, y1].iter().all(|v| v.is_finite()) && x1 > x0 && y1 > y0 {
            return (x0, y0, x1, y1);
        }
        // Fit to the data, with the ego vehicle always in view.
        let mut xs = vec![-3.0, 3.0];
        let mut ys = vec![-3.0, 3.0];
        let mut push = |x: f32, y: f32| {
            if x.is_finite() && y.is_finite() {
                xs.push(f64::from(x));
                ys.push(f64::from(y));
            }
        };
        self.cells.iter().for_each(|c| push(c.x_m, c.y_m));
        self.points.iter().for_each(|p| push(p[0], p[1]));
        self.boxes.iter().for_each(|b| push(b.x_m, b.y_m));
        self.clusters.iter().for_each(|c| {
            push(c.bounds_m[0], c.bounds_m[1]);
            push(c.bounds_m[2], c.bounds_m[3]);
        });
        let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let pad = 2.0;
        (min(&xs) - pad, min(&ys) - pad, max(&xs) + pad, max(&ys) + pad)
    }

    fn legend_entries(&self) -> Vec<LegendEntry> {
        let mut e = vec![LegendEntry { label: "ego".into(), swatch: Swatch::Triangle { color: EGO } }];
        for s in CellState::ALL {
            if self.cells.iter().any(|c| c.state == s) {
                e.push(LegendEntry { label: s.name().into(), swatch: Swatch::Filled { color: s.color() } });
            }
        }
        if !self.points.is_empty() {
            e.push(LegendEntry { label: "LiDAR point".into(), swatch: Swatch::Dot { color: POINT } });
        }
        for k in BoxKind::ALL {
            if self.boxes.iter().any(|b| b.kind == k) {
                let swatch = Swatch::Outline {
                    color: k.color(),
                    dashed: k == BoxKind::InjectedTruth,
                    fill: k != BoxKind::InjectedTruth,
                };
                e.push(LegendEntry { label: k.name().into(), swatch });
            }
        }
        if self.boxes.iter().any(has_grown) {
            e.push(LegendEntry {
                label: "grown region".into(),
                swatch: Swatch::Outline { color: RGBColor(90, 90, 90), dashed: true, fill: false },
            });
        }
        if !self.regions.is_empty() {
            e.push(LegendEntry {
                label: "region of interest".into(),
                swatch: Swatch::Outline { color: ROI, dashed: false, fill: true },
            });
        }
        if !self.clusters.is_empty() {
            e.push(LegendEntry {
                label: "conflict cluster".into(),
                swatch: Swatch::Outline { color: CLUSTER, dashed: true, fill: false },
            });
        }
        if !self.arrows.is_empty() {
            e.push(LegendEntry { label: "injected displacement".into(), swatch: Swatch::Arrow { color: ARROW } });
        }
        e
    }
}

const EGO: RGBColor = RGBColor(30, 30, 30);
const POINT: RGBColor = RGBColor(25, 60, 175);
const CLUSTER: RGBColor = RGBColor(190, 0, 0);
const ROI: RGBColor = RGBColor(40, 160, 60);
const ARROW: RGBColor = RGBColor(0, 0, 0);

fn has_grown(b: &ViewBox) -> bool {
    b.kind != BoxKind::InjectedTruth
        && b.grown_length_m.is_finite()
        && b.grown_width_m.is_finite()
        && (b.grown_length_m > b.length_m || b.grown_width_m > b.width_m)
}

/// Corners of an oriented box (front-left, front-right, rear-right, rear-left), or None if not finite.
fn corners(x: f32, y: f32, heading: f32, length: f32, width: f32) -> Option<[(f64, f64); 4]> {
    let (x, y, h, l, w) = (f64::from(x), f64::from(y), f64::from(heading), f64::from(length), f64::from(width));
    if ![x, y, h, l, w].iter().all(|v| v.is_finite()) {
        return None;
    }
    let (s, c) = h.sin_cos();
    let p = |a: f64, b: f64| (x + a * c - b * s, y + a * s + b * c);
    let (hl, hw) = (l.abs() / 2.0, w.abs() / 2.0);
    Some([p(hl, hw), p(hl, -hw), p(-hl, -hw), p(-hl, hw)])
}

/// Merged horizontal runs of equal-state cells as rectangles `(x0, y0, x1, y1)` in metres.
fn cell_rects(cells: &[ViewCell], state: CellState, size: f64) -> Vec<(f64, f64, f64, f64)> {
    let mut cs: Vec<(f64, f64)> = cells
        .iter()
        .filter(|c| c.state == state && c.x_m.is_finite() && c.y_m.is_finite())
        .map(|c| (f64::from(c.x_m), f64::from(c.y_m)))
        .collect();
    cs.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.total_cmp(&b.0)));
    let tol = size * 1e-3;
    let half = size / 2.0;
    let mut out = Vec::new();
    let mut run: Option<(f64, f64, f64)> = None; // (y, x_start, x_end) of cell centres
    for (x, y) in cs {
        run = match run {
            Some((ry, xs, xe)) if (y - ry).abs() <= tol && x - xe <= size + tol => Some((ry, xs, xe.max(x))),
            Some((ry, xs, xe)) => {
                out.push((xs - half, ry - half, xe + half, ry + half));
                Some((y, x, x))
            }
            None => Some((y, x, x)),
        };
    }
    if let Some((ry, xs, xe)) = run {
        out.push((xs - half, ry - half, xe + half, ry + half));
    }
    out
}

impl TopView {
    /// The axes for an extent, with the same tick step on both.
    fn axes_for(ext: (f64, f64, f64, f64), plot_w: i32, px: Px) -> (Axis<'static>, Axis<'static>) {
        let step = nice_step(ext.2 - ext.0, (plot_w / px.i(85.0)).clamp(2, 14) as usize);
        let x = Axis {
            range: (ext.0, ext.2),
            ticks: ticks_with_step(ext.0, ext.2, step),
            label: "x (forward) [m]",
            names: None,
            grid: true,
        };
        let y = Axis {
            range: (ext.1, ext.3),
            ticks: ticks_with_step(ext.1, ext.3, step),
            label: "y (left) [m]",
            names: None,
            grid: true,
        };
        (x, y)
    }
}

/// Widens `ext` along one axis so that a `w` x `h` pixel plot shows it at equal scale.
fn equal_aspect(ext: (f64, f64, f64, f64), (w, h): (i32, i32)) -> (f64, f64, f64, f64) {
    let (dx, dy) = (ext.2 - ext.0, ext.3 - ext.1);
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    if dx / dy < w / h {
        let nd = dy * w / h;
        let c = (ext.0 + ext.2) / 2.0;
        (c - nd / 2.0, ext.1, c + nd / 2.0, ext.3)
    } else {
        let nd = dx * h / w;
        let c = (ext.1 + ext.3) / 2.0;
        (ext.0, c - nd / 2.0, ext.2, c + nd / 2.0)
    }
}

impl Draw for TopView {
    fn svg_size_px(&self) -> (u32, u32) {
        let (x0, y0, x1, y1) = self.extent();
        let plot_w = 640.0;
        let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(300.0, 900.0);
        (920, (plot_h + 110.0).round() as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, output: Output) -> Result<(), String> {
        let (w, h) = root.dim_in_pixel();
        let px = Px::new(w, h, 920.0, 600.0);
        root.fill(&WHITE).map_err(de)?;
        let area = draw_title(root, &self.title, px)?;
        let entries = self.legend_entries();
        let lb = legend_box(&area, &entries, px);
        let (aw, _) = area.dim_in_pixel();
        let (chart_area, legend_area) = match lb {
            Some(lb) => {
                let chart_w = i32::try_from(aw).unwrap_or(0) - lb.w - px.i(14.0);
                let (c, l) = area.split_horizontally(chart_w.max(1));
                (c, Some(l))
            }
            None => (area.clone(), None),
        };
        let (cw, ch) = chart_area.dim_in_pixel();

        // Equal scale: settle margins (which depend on tick labels) and the widened extent together.
        let ext0 = self.extent();
        let margins_for = |ext: (f64, f64, f64, f64)| {
            let guess_w = i32::try_from(cw).unwrap_or(0) - px.i(100.0);
            let (xa, ya) = Self::axes_for(ext, guess_w, px);
            axes::margins(&chart_area, &xa, &ya, px)
        };
        let mut m: Margins = margins_for(ext0);
        let mut ext = equal_aspect(ext0, axes::predicted_plot_size(cw, ch, m));
        for _ in 0..2 {
            m = margins_for(ext);
            ext = equal_aspect(ext0, axes::predicted_plot_size(cw, ch, m));
        }
        let plot_w = axes::predicted_plot_size(cw, ch, m).0;
        let (xa, ya) = Self::axes_for(ext, plot_w, px);
        let chart = axes::build(&chart_area, m, &xa, &ya, px)?;
        let pa = chart.plotting_area().strip_coord_spec();
        let to_px = axes::mapper(&chart);
        let rect = DataRect { x0: ext.0, y0: ext.1, x1: ext.2, y1: ext.3 };
        let tp = |p: (f64, f64)| to_px(p.0, p.1);

        // Cells.
        let cell = f64::from(self.cell_size_m);
        if cell.is_finite() && cell > 0.0 {
            for state in CellState::DRAW_ORDER {
                let color = state.color();
                for (x0, y0, x1, y1) in cell_rects(&self.cells, state, cell) {
                    let (x0, x1) = (x0.max(rect.x0), x1.min(rect.x1));
                    let (y0, y1) = (y0.max(rect.y0), y1.min(rect.y1));
                    if x0 >= x1 || y0 >= y1 {
                        continue;
                    }
                    pa.draw(&Rectangle::new([to_px(x0, y1), to_px(x1, y0)], color.filled())).map_err(de)?;
                }
            }
        }

        // Region of interest, translucent over the cells.
        for poly in &self.regions {
            let pts: Vec<(i32, i32)> = poly
                .iter()
                .filter(|p| p[0].is_finite() && p[1].is_finite())
                .map(|p| tp((f64::from(p[0]), f64::from(p[1]))))
                .collect();
            if pts.len() >= 3 {
                pa.draw(&Polygon::new(pts, ROI.mix(0.10).filled())).map_err(de)?;
            }
        }

        // Footprint fills, grown regions (dashed), footprint outlines.
        let outline =
            |pts: &[(f64, f64); 4], color: RGBAColor, width: u32, dash: Option<(i32, i32)>| -> Result<(), String> {
                let closed: Vec<(f64, f64)> = pts.iter().chain(pts.first()).copied().collect();
                let (lines, _) = clip_polyline(&closed, &rect);
                for line in lines {
                    draw_path(&pa, line.into_iter().map(tp).collect(), color, width, dash)?;
                }
                Ok(())
            };
        for b in self.boxes.iter().filter(|b| b.kind != BoxKind::InjectedTruth) {
            let Some(c) = corners(b.x_m, b.y_m, b.heading_rad, b.length_m, b.width_m) else { continue };
            if c.iter().all(|&p| rect.contains(p)) {
                let poly: Vec<(i32, i32)> = c.iter().map(|&p| tp(p)).collect();
                pa.draw(&Polygon::new(poly, b.kind.color().mix(0.18).filled())).map_err(de)?;
            }
        }
        for b in self.boxes.iter().filter(|b| has_grown(b)) {
            if let Some(c) = corners(b.x_m, b.y_m, b.heading_rad, b.grown_length_m, b.grown_width_m) {
                outline(&c, b.kind.color().to_rgba(), px.u(1.2), Some((px.i(5.0), px.i(4.0))))?;
            }
        }
        for b in &self.boxes {
            let Some(c) = corners(b.x_m, b.y_m, b.heading_rad, b.length_m, b.width_m) else { continue };
            let color = b.kind.color();
            if b.kind == BoxKind::InjectedTruth {
                outline(&c, color.to_rgba(), px.u(1.2), Some((px.i(3.0), px.i(3.0))))?;
                continue;
            }
            outline(&c, color.to_rgba(), px.u(2.0), None)?;
            // Heading tick: centre to the middle of the front edge.
            let centre = (f64::from(b.x_m), f64::from(b.y_m));
            let front = ((c[0].0 + c[1].0) / 2.0, (c[0].1 + c[1].1) / 2.0);
            if let Some((a, z)) = clip_segment(centre, front, &rect) {
                draw_path(&pa, vec![tp(a), tp(z)], color.to_rgba(), px.u(1.5), None)?;
            }
        }

        // Conflict clusters.
        for cl in &self.clusters {
            let [x0, y0, x1, y1] = cl.bounds_m.map(f64::from);
            if [x0, y0, x1, y1].iter().all(|v| v.is_finite()) {
                let pts = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)];
                outline(&pts, CLUSTER.to_rgba(), px.u(1.8), Some((px.i(6.0), px.i(4.0))))?;
            }
        }

        // Points on top of the shapes: they are the evidence the view is about (thinned in SVG).
        let stride = match output {
            Output::Svg => self.points.len().div_ceil(Self::MAX_SVG_POINTS).max(1),
            Output::Png => 1,
        };
        let r = px.i(1.5) / 2 + 1;
        for p in self.points.iter().step_by(stride) {
            let q = (f64::from(p[0]), f64::from(p[1]));
            if !rect.contains(q) {
                continue;
            }
            let (x, y) = tp(q);
            pa.draw(&Rectangle::new([(x - r + 1, y - r + 1), (x + r - 1, y + r - 1)], POINT.filled())).map_err(de)?;
        }

        // Injected displacements.
        for (from, to) in &self.arrows {
            let a = (f64::from(from[0]), f64::from(from[1]));
            let z = (f64::from(to[0]), f64::from(to[1]));
            if !(a.0.is_finite() && a.1.is_finite() && z.0.is_finite() && z.1.is_finite()) {
                continue;
            }
            if rect.contains(z) {
                if let Some((ca, _)) = clip_segment(a, z, &rect) {
                    draw_arrow_px(&pa, tp(ca), tp(z), ARROW, px)?;
                }
            } else if let Some((ca, cz)) = clip_segment(a, z, &rect) {
                draw_path(&pa, vec![tp(ca), tp(cz)], ARROW.to_rgba(), px.u(1.5), None)?;
            }
        }

        // Ego vehicle at the origin, pointing along +x.
        // Sized with the view (about 5 % of its larger side, 0.8..4 m) so it marks the origin without hiding it.
        let l = (0.05 * (ext0.2 - ext0.0).max(ext0.3 - ext0.1)).clamp(0.8, 4.0);
        let ego = [(l * 2.0 / 3.0, 0.0), (-l / 3.0, l / 3.0), (-l / 3.0, -l / 3.0)];
        if ego.iter().all(|&p| rect.contains(p)) {
            pa.draw(&Polygon::new(ego.iter().map(|&p| tp(p)).collect::<Vec<_>>(), EGO.filled())).map_err(de)?;
        }

        self.draw_labels(&pa, &tp, &rect, axes::plot_size(&chart), px)?;
        axes::draw_frame(&chart, px)?;
        if let (Some(lb), Some(la)) = (lb, legend_area) {
            draw_legend(&la, (px.i(4.0), m.top), &lb, &entries, px)?;
        }
        Ok(())
    }
}

/// Greedy label placement: the first candidate position that stays inside the plot and overlaps no label
/// placed before; the first candidate if none does.
struct LabelPlacer {
    taken: Vec<(i32, i32, i32, i32)>,
    plot: (i32, i32),
}

impl LabelPlacer {
    fn place(&mut self, candidates: &[((i32, i32), HPos, VPos)], size: (i32, i32)) -> Option<((i32, i32), HPos, VPos)> {
        let fits = |r: &(i32, i32, i32, i32)| r.0 >= 0 && r.1 >= 0 && r.2 <= self.plot.0 && r.3 <= self.plot.1;
        let free =
            |r: &(i32, i32, i32, i32)| self.taken.iter().all(|t| r.2 <= t.0 || r.0 >= t.2 || r.3 <= t.1 || r.1 >= t.3);
        let chosen = candidates
            .iter()
            .find(|&&(p, h, v)| {
                let r = label_rect(p, h, v, size);
                fits(&r) && free(&r)
            })
            .or_else(|| candidates.first())
            .copied()?;
        self.taken.push(label_rect(chosen.0, chosen.1, chosen.2, size));
        Some(chosen)
    }
}

/// Pixel bounding box `(x0, y0, x1, y1)` of data points.
fn pixel_bbox(pts: impl Iterator<Item = (i32, i32)>) -> Option<(i32, i32, i32, i32)> {
    pts.fold(None, |acc, (x, y)| match acc {
        None => Some((x, y, x, y)),
        Some((x0, y0, x1, y1)) => Some((x0.min(x), y0.min(y), x1.max(x), y1.max(y))),
    })
}

impl TopView {
    /// Box and cluster labels, placed so they do not overlap each other, on translucent white.
    fn draw_labels<DB: DrawingBackend>(
        &self,
        pa: &DrawingArea<DB, Shift>,
        tp: &dyn Fn((f64, f64)) -> (i32, i32),
        rect: &DataRect,
        plot: (i32, i32),
        px: Px,
    ) -> Result<(), String> {
        let font = px.f(12.0);
        let g = px.i(4.0);
        let mut placer = LabelPlacer { taken: Vec::new(), plot };
        for b in &self.boxes {
            let centre = (f64::from(b.x_m), f64::from(b.y_m));
            if b.label.is_empty() || !rect.contains(centre) {
                continue;
            }
            let (gl, gw) = if has_grown(b) { (b.grown_length_m, b.grown_width_m) } else { (b.length_m, b.width_m) };
            let Some(c) = corners(b.x_m, b.y_m, b.heading_rad, gl, gw) else { continue };
            let Some((x0, y0, x1, y1)) = pixel_bbox(c.iter().map(|&p| tp(p))) else { continue };
            let (cx, cy) = ((x0 + x1) / 2, (y0 + y1) / 2);
            let candidates = [
                ((cx, y0 - g), HPos::Center, VPos::Bottom),
                ((cx, y1 + g), HPos::Center, VPos::Top),
                ((x1 + g, cy), HPos::Left, VPos::Center),
                ((x0 - g, cy), HPos::Right, VPos::Center),
            ];
            let size = label_size(pa, &b.label, font);
            if let Some((p, h, v)) = placer.place(&candidates, size) {
                let color = b.kind.color();
                let dark = RGBColor(color.0 / 3 * 2, color.1 / 3 * 2, color.2 / 3 * 2);
                draw_label(pa, &b.label, font, dark, p, h, v, px)?;
            }
        }
        for cl in &self.clusters {
            let [x0, y0, x1, y1] = cl.bounds_m.map(f64::from);
            let centre = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
            if cl.label.is_empty() || !rect.contains(centre) {
                continue;
            }
            let Some((px0, py0, px1, py1)) = pixel_bbox([(x0, y0), (x1, y1)].into_iter().map(tp)) else { continue };
            let cy = (py0 + py1) / 2;
            let candidates = [
                ((px0, py0 - g), HPos::Left, VPos::Bottom),
                ((px0, py1 + g), HPos::Left, VPos::Top),
                ((px1 + g, cy), HPos::Left, VPos::Center),
                ((px0 - g, cy), HPos::Right, VPos::Center),
            ];
            let size = label_size(pa, &cl.label, font);
            if let Some((p, h, v)) = placer.place(&candidates, size) {
                draw_label(pa, &cl.label, font, CLUSTER, p, h, v, px)?;
            }
        }
        Ok(())
    }
}

impl_figure!(TopView);
