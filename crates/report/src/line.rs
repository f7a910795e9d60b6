//! Line charts with shaded confidence bands and labelled reference lines (the paper's Figs. 5-8 kind).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::axes::{self, Axis};
use crate::plot::{
    clip_polyline, de, draw_label, draw_legend, draw_marker, draw_path, draw_title, label_rect, legend_box,
    max_outside_w, nice_step, resolve_range, text_at, text_size, ticks_with_step, DataRect, LegendEntry, Marker,
    Occupancy, Polyline, Px, Swatch,
};
use crate::render::{impl_figure, Draw, Output};
use crate::style::{LegendPosition, Placement, SeriesColor, SeriesStyle, REF_GREY};
use crate::ReportError;

/// One curve of a [`LineChart`].
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text; an empty name keeps the series out of the legend.
    pub name: String,
    /// `(x, y)` points, drawn in the given order. Points with a NaN or infinite coordinate are skipped and break
    /// the line; a point with no finite neighbour is drawn as a marker so it stays visible.
    pub points: Vec<(f64, f64)>,
    /// Optional shaded band `(x, lo, hi)`, e.g. a 95 % confidence interval; drawn sorted by x, `lo`/`hi` swapped
    /// if reversed. Entries with a non-finite `x` are dropped; a non-finite `lo` or `hi` splits the band.
    pub band: Option<Vec<(f64, f64, f64)>>,
    /// Colour, dash and marker.
    pub style: SeriesStyle,
}

impl Series {
    /// A solid line with automatic colour and no band.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self { name: name.into(), points, band: None, style: SeriesStyle::default() }
    }
    /// Adds a shaded band `(x, lo, hi)`.
    #[must_use]
    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>) -> Self {
        self.band = Some(band);
        self
    }
    /// Sets the colour.
    #[must_use]
    pub fn with_color(mut self, color: SeriesColor) -> Self {
        self.style.color = color;
        self
    }
    /// Draws the line dashed.
    #[must_use]
    pub fn dashed(mut self) -> Self {
        self.style.dashed = true;
        self
    }
    /// Draws a marker at every point.
    #[must_use]
    pub fn with_markers(mut self) -> Self {
        self.style.marker = true;
        self
    }
    /// Draws markers only, no connecting line.
    #[must_use]
    pub fn scatter(mut self) -> Self {
        self.style.marker = true;
        self.style.line = false;
        self
    }
}

/// Direction of a [`RefLine`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// A line of constant y across the plot.
    Horizontal,
    /// A line of constant x across the plot.
    Vertical,
}

/// A labelled reference line such as "paper: 0.7 m" or "90 %".
#[derive(Debug, Clone, PartialEq)]
pub struct RefLine {
    /// Horizontal (constant y) or vertical (constant x).
    pub orientation: Orientation,
    /// The y value (horizontal) or x value (vertical), in data units. Non-finite values are not drawn.
    pub value: f64,
    /// Text written next to the line (may be empty).
    pub label: String,
    /// Line and label colour; [`SeriesColor::Auto`] is dark grey.
    pub color: SeriesColor,
    /// Dashed (the default) or solid.
    pub dashed: bool,
}

impl RefLine {
    /// A dashed grey horizontal line at `y`.
    pub fn horizontal(y: f64, label: impl Into<String>) -> Self {
        Self {
            orientation: Orientation::Horizontal,
            value: y,
            label: label.into(),
            color: SeriesColor::Auto,
            dashed: true,
        }
    }
    /// A dashed grey vertical line at `x`.
    pub fn vertical(x: f64, label: impl Into<String>) -> Self {
        Self {
            orientation: Orientation::Vertical,
            value: x,
            label: label.into(),
            color: SeriesColor::Auto,
            dashed: true,
        }
    }
    /// Sets the colour.
    #[must_use]
    pub fn with_color(mut self, color: SeriesColor) -> Self {
        self.color = color;
        self
    }

    pub(crate) fn rgb(&self) -> RGBColor {
        match self.color {
            SeriesColor::Auto => REF_GREY,
            c => c.resolve(0),
        }
    }
}

/// A line chart: several series, optional shaded bands, reference lines and a legend.
///
/// Ranges left at `None` are fitted to the finite data (and reference lines) with 4 % padding. The SVG is
/// 800 x 500 px; PNGs can have any size and scale text with it (800 x 500 reference).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineChart {
    /// Title above the plot (may be empty).
    pub title: String,
    /// X axis label, with unit, e.g. "position error \[m\]".
    pub x_label: String,
    /// Y axis label, with unit.
    pub y_label: String,
    /// Fixed x range `(min, max)`; data outside it is clipped.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range `(min, max)`; data outside it is clipped.
    pub y_range: Option<(f64, f64)>,
    /// The curves, drawn in order (later on top).
    pub series: Vec<Series>,
    /// Labelled reference lines, drawn under the series.
    pub ref_lines: Vec<RefLine>,
    /// Where the legend goes.
    pub legend: LegendPosition,
}

impl LineChart {
    /// An empty chart with a title and axis labels; automatic ranges and legend.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), ..Self::default() }
    }
    /// Fixes the x range.
    #[must_use]
    pub fn with_x_range(mut self, min: f64, max: f64) -> Self {
        self.x_range = Some((min, max));
        self
    }
    /// Fixes the y range.
    #[must_use]
    pub fn with_y_range(mut self, min: f64, max: f64) -> Self {
        self.y_range = Some((min, max));
        self
    }
    /// Adds a series.
    #[must_use]
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }
    /// Adds a reference line.
    #[must_use]
    pub fn with_ref_line(mut self, line: RefLine) -> Self {
        self.ref_lines.push(line);
        self
    }
    /// Sets the legend position.
    #[must_use]
    pub fn with_legend(mut self, legend: LegendPosition) -> Self {
        self.legend = legend;
        self
    }

    /// Writes the chart's data as CSV with columns `series,x,y,lo,hi`: one row per point (`lo`, `hi` empty) and
    /// one per band entry (`y` empty), series in chart order.
    pub fn write_csv(&self, path: impl AsRef<Path>) -> Result<(), ReportError> {
        let mut rows: Vec<[String; 5]> = Vec::new();
        for s in &self.series {
            for &(x, y) in &s.points {
                rows.push([s.name.clone(), x.to_string(), y.to_string(), String::new(), String::new()]);
            }
            for &(x, lo, hi) in s.band.iter().flatten() {
                rows.push([s.name.clone(), x.to_string(), String::new(), lo.to_string(), hi.to_string()]);
            }
        }
        crate::csv_out::write_csv(path, &["series", "x", "y", "lo", "hi"], &rows)
    }

    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let xs = self.series.iter().flat_map(|s| {
            s.points.iter().filter(|p| p.1.is_finite()).map(|p| p.0).chain(s.band.iter().flatten().map(|b| b.0))
        });
        let x_refs = self.ref_lines.iter().filter(|r| r.orientation == Orientation::Vertical).map(|r| r.value);
        let xr = resolve_range(self.x_range, xs.chain(x_refs), 0.04, false);
        // The y range only looks at points whose x is visible, so a fixed x range zooms in y too.
        let in_x = |x: f64| x >= xr.0 && x <= xr.1;
        let ys = self.series.iter().flat_map(|s| {
            s.points
                .iter()
                .filter(move |p| in_x(p.0))
                .map(|p| p.1)
                .chain(s.band.iter().flatten().filter(move |b| in_x(b.0)).flat_map(|b| [b.1, b.2]))
        });
        let y_refs = self.ref_lines.iter().filter(|r| r.orientation == Orientation::Horizontal).map(|r| r.value);
        let yr = resolve_range(self.y_range, ys.chain(y_refs), 0.06, false);
        (xr, yr)
    }

    fn legend_entries(&self) -> Vec<LegendEntry> {
        self.series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.name.is_empty())
            .map(|(i, s)| LegendEntry {
                label: s.name.clone(),
                swatch: Swatch::Line {
                    color: s.style.color.resolve(i),
                    dashed: s.style.dashed,
                    marker: (s.style.marker || !s.style.line).then(|| Marker::for_index(i)),
                    band: s.band.as_ref().is_some_and(|b| !b.is_empty()),
                    line: s.style.line,
                },
            })
            .collect()
    }

    /// Marks where data will be drawn, using a linear map to a `w` x `h` plot.
    fn occupancy(&self, xr: (f64, f64), yr: (f64, f64), (w, h): (i32, i32), px: Px) -> Occupancy {
        let mut occ = Occupancy::new(w, h, px.i(6.0));
        let map = |x: f64, y: f64| {
            ((x - xr.0) / (xr.1 - xr.0) * f64::from(w), f64::from(h) - (y - yr.0) / (yr.1 - yr.0) * f64::from(h))
        };
        let rect = DataRect { x0: xr.0, y0: yr.0, x1: xr.1, y1: yr.1 };
        for s in &self.series {
            let (lines, isolated) = clip_polyline(&s.points, &rect);
            for line in &lines {
                if s.style.line {
                    for seg in line.windows(2) {
                        if let (Some(a), Some(b)) = (seg.first(), seg.get(1)) {
                            occ.mark_segment(map(a.0, a.1), map(b.0, b.1));
                        }
                    }
                }
                if s.style.marker || !s.style.line {
                    for p in line {
                        let (x, y) = map(p.0, p.1);
                        occ.mark_rect((x - 5.0, y - 5.0), (x + 5.0, y + 5.0));
                    }
                }
            }
            for p in isolated {
                let (x, y) = map(p.0, p.1);
                occ.mark_rect((x - 5.0, y - 5.0), (x + 5.0, y + 5.0));
            }
            for poly in band_polygons(s.band.as_deref(), &rect) {
                let (upper, lower) = poly;
                // Fill the band: vertical spans every few pixels between consecutive band entries.
                let pairs: Vec<((f64, f64), (f64, f64))> =
                    upper.iter().zip(lower.iter()).map(|(u, l)| (map(u.0, u.1), map(l.0, l.1))).collect();
                for (u, l) in &pairs {
                    occ.mark_rect(*u, *l);
                }
                for w2 in pairs.windows(2) {
                    let (Some(&(ua, la)), Some(&(ub, lb))) = (w2.first(), w2.get(1)) else { continue };
                    let steps = ((ub.0 - ua.0).abs() / px.f(3.0)).ceil().clamp(1.0, 10_000.0) as usize;
                    for k in 1..steps {
                        let t = k as f64 / steps as f64;
                        let lerp = |a: (f64, f64), b: (f64, f64)| (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                        occ.mark_rect(lerp(ua, ub), lerp(la, lb));
                    }
                }
                for seg in upper.windows(2).chain(lower.windows(2)) {
                    if let (Some(a), Some(b)) = (seg.first(), seg.get(1)) {
                        occ.mark_segment(map(a.0, a.1), map(b.0, b.1));
                    }
                }
            }
        }
        mark_ref_lines(&mut occ, &self.ref_lines, &map, (w, h), xr, yr, px);
        occ
    }
}

/// The band as clipped polygons: for each run of finite entries, the upper and lower edge (same x values).
fn band_polygons(band: Option<&[(f64, f64, f64)]>, r: &DataRect) -> Vec<(Polyline, Polyline)> {
    let Some(band) = band else { return Vec::new() };
    let mut sorted: Vec<(f64, f64, f64)> = band.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let finite = |b: &(f64, f64, f64)| b.0.is_finite() && b.1.is_finite() && b.2.is_finite();
    let mut out = Vec::new();
    for run in sorted.split(|b| !finite(b)) {
        // Clip in x by interpolating at the range edges; clamp in y.
        let mut pts: Vec<(f64, f64, f64)> = Vec::new();
        for w in run.windows(2) {
            let (Some(&a), Some(&b)) = (w.first(), w.get(1)) else { continue };
            if b.0 < r.x0 || a.0 > r.x1 {
                continue;
            }
            let lerp = |x: f64| {
                let t = if b.0 > a.0 { (x - a.0) / (b.0 - a.0) } else { 0.0 };
                (x, a.1 + t * (b.1 - a.1), a.2 + t * (b.2 - a.2))
            };
            let start = if a.0 < r.x0 { lerp(r.x0) } else { a };
            let end = if b.0 > r.x1 { lerp(r.x1) } else { b };
            if pts.last().is_none_or(|l| l.0 != start.0) {
                pts.push(start);
            }
            pts.push(end);
        }
        if run.len() == 1 {
            if let Some(&a) = run.first() {
                if a.0 >= r.x0 && a.0 <= r.x1 {
                    pts.push(a);
                }
            }
        }
        if pts.is_empty() {
            continue;
        }
        let clamp = |v: f64| v.clamp(r.y0, r.y1);
        let upper = pts.iter().map(|p| (p.0, clamp(p.1.max(p.2)))).collect();
        let lower = pts.iter().map(|p| (p.0, clamp(p.1.min(p.2)))).collect();
        out.push((upper, lower));
    }
    out
}

impl Draw for LineChart {
    fn svg_size_px(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, _output: Output) -> Result<(), String> {
        let (w, h) = root.dim_in_pixel();
        let px = Px::new(w, h, 800.0, 500.0);
        root.fill(&WHITE).map_err(de)?;
        let area = draw_title(root, &self.title, px)?;
        let (xr, yr) = self.ranges();
        let entries = self.legend_entries();
        let lb = legend_box(&area, &entries, px);

        let x_axis_for = |plot_w: i32| {
            let step = nice_step(xr.1 - xr.0, (plot_w / px.i(90.0)).clamp(2, 12) as usize);
            Axis { range: xr, ticks: ticks_with_step(xr.0, xr.1, step), label: &self.x_label, names: None, grid: true }
        };
        let (aw, ah) = area.dim_in_pixel();
        let y_step = nice_step(yr.1 - yr.0, (i32::try_from(ah).unwrap_or(0) / px.i(60.0)).clamp(2, 10) as usize);
        let y_axis = Axis {
            range: yr,
            ticks: ticks_with_step(yr.0, yr.1, y_step),
            label: &self.y_label,
            names: None,
            grid: true,
        };
        let inset = px.i(8.0);

        let mut x_axis = x_axis_for(i32::try_from(aw).unwrap_or(0));
        let m = axes::margins(&area, &x_axis, &y_axis, px);
        let placement = match (lb, self.legend.fixed()) {
            (None, _) => Placement::None,
            (Some(_), Some(p)) => p,
            (Some(lb), None) => {
                let plot = axes::predicted_plot_size(aw, ah, m);
                self.occupancy(xr, yr, plot, px).auto_placement((lb.w, lb.h), inset, max_outside_w(aw))
            }
        };

        let (chart_area, legend_area) = match (placement, lb) {
            (Placement::Outside, Some(lb)) => {
                let chart_w = i32::try_from(aw).unwrap_or(0) - lb.w - px.i(12.0);
                let (c, l) = area.split_horizontally(chart_w.max(1));
                (c, Some(l))
            }
            (Placement::Below, Some(lb)) => {
                let below = lb.in_columns(entries.len(), i32::try_from(aw).unwrap_or(0) - px.i(16.0));
                let chart_h = i32::try_from(ah).unwrap_or(0) - below.h - px.i(10.0);
                let (c, l) = area.split_vertically(chart_h.max(1));
                (c, Some(l))
            }
            _ => (area.clone(), None),
        };
        let (cw, _) = chart_area.dim_in_pixel();
        if cw != aw {
            x_axis = x_axis_for(i32::try_from(cw).unwrap_or(0));
        }
        let m = axes::margins(&chart_area, &x_axis, &y_axis, px);
        let chart = axes::build(&chart_area, m, &x_axis, &y_axis, px)?;
        let pa = chart.plotting_area().strip_coord_spec();
        let to_px = axes::mapper(&chart);
        let rect = DataRect { x0: xr.0, y0: yr.0, x1: xr.1, y1: yr.1 };
        let (pw, ph) = axes::plot_size(&chart);

        // Bands first, then reference lines, then the series on top.
        for (i, s) in self.series.iter().enumerate() {
            let color = s.style.color.resolve(i);
            for (upper, lower) in band_polygons(s.band.as_deref(), &rect) {
                if upper.len() == 1 {
                    if let (Some(u), Some(l)) = (upper.first(), lower.first()) {
                        draw_path(&pa, vec![to_px(u.0, u.1), to_px(l.0, l.1)], color.mix(0.45), px.u(3.0), None)?;
                    }
                    continue;
                }
                let poly: Vec<(i32, i32)> = upper.iter().chain(lower.iter().rev()).map(|&(x, y)| to_px(x, y)).collect();
                pa.draw(&Polygon::new(poly, color.mix(0.18).filled())).map_err(de)?;
            }
        }
        draw_ref_lines(&pa, &self.ref_lines, RefPart::Lines, &to_px, (pw, ph), xr, yr, px)?;
        for (i, s) in self.series.iter().enumerate() {
            let color = s.style.color.resolve(i);
            let (lines, isolated) = clip_polyline(&s.points, &rect);
            let dash = s.style.dashed.then(|| (px.i(7.0), px.i(4.0)));
            let marker = Marker::for_index(i);
            for line in &lines {
                if s.style.line {
                    let pts = line.iter().map(|&(x, y)| to_px(x, y)).collect();
                    draw_path(&pa, pts, color.to_rgba(), px.u(2.0), dash)?;
                }
                if s.style.marker || !s.style.line {
                    for &(x, y) in line {
                        draw_marker(&pa, to_px(x, y), marker, px.i(4.0), color)?;
                    }
                }
            }
            for (x, y) in isolated {
                draw_marker(&pa, to_px(x, y), marker, px.i(4.0), color)?;
            }
        }
        draw_ref_lines(&pa, &self.ref_lines, RefPart::Labels, &to_px, (pw, ph), xr, yr, px)?;
        axes::draw_frame(&chart, px)?;

        if let Some(lb) = lb {
            match placement {
                Placement::Inside(corner) => {
                    draw_legend(&pa, corner.place((pw, ph), (lb.w, lb.h), inset), &lb, &entries, px)?;
                }
                Placement::Outside => {
                    if let Some(la) = legend_area {
                        draw_legend(&la, (px.i(4.0), m.top), &lb, &entries, px)?;
                    }
                }
                Placement::Below => {
                    if let Some(la) = legend_area {
                        let (lw, _) = la.dim_in_pixel();
                        let lw = i32::try_from(lw).unwrap_or(0);
                        let below = lb.in_columns(entries.len(), lw - px.i(16.0));
                        draw_legend(&la, ((lw - below.w) / 2, px.i(4.0)), &below, &entries, px)?;
                    }
                }
                Placement::None => {}
            }
        }
        Ok(())
    }
}

/// Which part of the reference lines to draw: lines go under the data, labels on top of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RefPart {
    Lines,
    Labels,
}

/// Draws the reference lines that fall inside the ranges, or their labels, on the plot area `pa`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_ref_lines<DB: DrawingBackend>(
    pa: &DrawingArea<DB, Shift>,
    refs: &[RefLine],
    part: RefPart,
    to_px: &dyn Fn(f64, f64) -> (i32, i32),
    (pw, ph): (i32, i32),
    xr: (f64, f64),
    yr: (f64, f64),
    px: Px,
) -> Result<(), String> {
    let font = px.f(13.0);
    // Labels already drawn (pixel rectangles): a vertical line's label moves down until it overlaps none.
    let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
    for r in refs {
        let color = r.rgb();
        let dash = r.dashed.then(|| (px.i(6.0), px.i(4.0)));
        match r.orientation {
            Orientation::Horizontal => {
                if !(r.value >= yr.0 && r.value <= yr.1) {
                    continue;
                }
                let (_, y) = to_px(xr.0, r.value);
                if part == RefPart::Lines {
                    draw_path(pa, vec![(0, y), (pw - 1, y)], color.to_rgba(), px.u(1.5), dash)?;
                    continue;
                }
                // Label above the right end, or below it when the line is at the top edge.
                let style = text_at(font, color, HPos::Right, VPos::Bottom);
                let (_, th) = text_size(pa, &r.label, &style);
                let above = y - px.i(3.0);
                let ty = if above - i32::try_from(th).unwrap_or(0) < 0 { y + px.i(3.0) } else { above };
                let v = if ty > y { VPos::Top } else { VPos::Bottom };
                draw_label(pa, &r.label, font, color, (pw - px.i(6.0), ty), HPos::Right, v, px)?;
            }
            Orientation::Vertical => {
                if !(r.value >= xr.0 && r.value <= xr.1) {
                    continue;
                }
                let (x, _) = to_px(r.value, yr.0);
                if part == RefPart::Lines {
                    draw_path(pa, vec![(x, 0), (x, ph - 1)], color.to_rgba(), px.u(1.5), dash)?;
                    continue;
                }
                // Label right of the line at the top, or left of it near the right edge.
                let style = text_at(font, color, HPos::Left, VPos::Top);
                let (tw, th) = text_size(pa, &r.label, &style);
                let size = (i32::try_from(tw).unwrap_or(0), i32::try_from(th).unwrap_or(0));
                let fits_right = x + px.i(4.0) + size.0 < pw;
                let (tx, hp) = if fits_right { (x + px.i(4.0), HPos::Left) } else { (x - px.i(4.0), HPos::Right) };
                let overlaps = |a: (i32, i32, i32, i32), b: &(i32, i32, i32, i32)| {
                    a.0 < b.2 + px.i(4.0) && b.0 < a.2 + px.i(4.0) && a.1 < b.3 && b.1 < a.3
                };
                let mut ty = px.i(5.0);
                let mut rect = label_rect((tx, ty), hp, VPos::Top, size);
                for _ in 0..refs.len() {
                    if !placed.iter().any(|b| overlaps(rect, b)) {
                        break;
                    }
                    ty += size.1 + px.i(4.0);
                    rect = label_rect((tx, ty), hp, VPos::Top, size);
                }
                placed.push(rect);
                draw_label(pa, &r.label, font, color, (tx, ty), hp, VPos::Top, px)?;
            }
        }
    }
    Ok(())
}

/// Marks reference lines and the room their labels take in an occupancy mask (`map`: data to pixel).
pub(crate) fn mark_ref_lines(
    occ: &mut Occupancy,
    refs: &[RefLine],
    map: &dyn Fn(f64, f64) -> (f64, f64),
    (w, h): (i32, i32),
    xr: (f64, f64),
    yr: (f64, f64),
    px: Px,
) {
    for r in refs {
        match r.orientation {
            Orientation::Horizontal if r.value >= yr.0 && r.value <= yr.1 => {
                let (_, y) = map(xr.0, r.value);
                occ.mark_segment((0.0, y), (f64::from(w), y));
                occ.mark_rect(
                    (f64::from(w) - px.f(8.0 * r.label.len() as f64 + 10.0), y - px.f(20.0)),
                    (f64::from(w), y),
                );
            }
            Orientation::Vertical if r.value >= xr.0 && r.value <= xr.1 => {
                let (x, _) = map(r.value, yr.0);
                occ.mark_segment((x, 0.0), (x, f64::from(h)));
                occ.mark_rect((x, 0.0), (x + px.f(8.0 * r.label.len() as f64 + 10.0), px.f(22.0)));
            }
            _ => {}
        }
    }
}

impl_figure!(LineChart);
