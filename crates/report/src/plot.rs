//! Drawing helpers shared by the charts: scaling, ranges, ticks, clipping, markers, legends, and the
//! occupancy mask that lets the legend avoid the data.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::font::FAMILY;
use crate::style::{Corner, Placement, INK};

/// Turns a plotters error into the message stored in [`crate::ReportError::Draw`].
pub(crate) fn de<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Pixel scale of a figure: all sizes are given for a reference canvas and multiplied by `s`, so a 2x larger
/// PNG looks the same, only sharper.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Px {
    pub s: f64,
}

impl Px {
    /// The scale of a `w` x `h` canvas relative to a `ref_w` x `ref_h` reference canvas. Never below 0.8, so
    /// text in small images stays readable (small images get relatively larger text, as in matplotlib).
    pub fn new(w: u32, h: u32, ref_w: f64, ref_h: f64) -> Self {
        let s = (f64::from(w) / ref_w).min(f64::from(h) / ref_h).clamp(0.8, 20.0);
        Self { s }
    }
    /// `v` reference pixels, scaled, as a float.
    pub fn f(self, v: f64) -> f64 {
        v * self.s
    }
    /// `v` reference pixels, scaled and rounded, at least 1.
    pub fn i(self, v: f64) -> i32 {
        round_i32(v * self.s).max(1)
    }
    /// `v` reference pixels, scaled and rounded, at least 1.
    pub fn u(self, v: f64) -> u32 {
        self.i(v).unsigned_abs()
    }
}

/// Rounds to the nearest `i32`, saturating (NaN gives 0).
pub(crate) fn round_i32(v: f64) -> i32 {
    // `as` saturates for out-of-range floats and maps NaN to 0, which is what we want for pixel coordinates.
    v.round() as i32
}

/// A text style of the embedded font.
pub(crate) fn text(size_px: f64, color: RGBColor) -> TextStyle<'static> {
    TextStyle { font: (FAMILY, size_px).into_font(), color: color.to_backend_color(), pos: Pos::default() }
}

/// A text style anchored at `h`, `v`.
pub(crate) fn text_at(size_px: f64, color: RGBColor, h: HPos, v: VPos) -> TextStyle<'static> {
    text(size_px, color).pos(Pos::new(h, v))
}

/// Width and height in pixels of `s` drawn with `style` on `area` (0 x 0 on error).
pub(crate) fn text_size<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s: &str,
    style: &TextStyle<'_>,
) -> (u32, u32) {
    if s.is_empty() {
        return (0, 0);
    }
    area.estimate_text_size(s, style).unwrap_or((0, 0))
}

/// Axis range: `given` if it is usable (finite; reversed bounds are swapped, equal bounds widened), else the
/// range of the finite `data` padded by `pad_frac` of its span on both sides (`(0, 1)` without data).
/// `include_zero` makes the automatic range contain 0 and leaves no padding below a zero bound (bar charts).
pub(crate) fn resolve_range(
    given: Option<(f64, f64)>,
    data: impl Iterator<Item = f64>,
    pad_frac: f64,
    include_zero: bool,
) -> (f64, f64) {
    if let Some((a, b)) = given {
        if a.is_finite() && b.is_finite() {
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            return widen_if_flat(lo, hi);
        }
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in data.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if include_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    if lo == hi {
        return widen_if_flat(lo, hi);
    }
    let pad = (hi - lo) * pad_frac;
    let lo = if include_zero && lo == 0.0 { lo } else { lo - pad };
    let hi = if include_zero && hi == 0.0 { hi } else { hi + pad };
    (lo, hi)
}

fn widen_if_flat(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo {
        return (lo, hi);
    }
    let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
    (lo - d, hi + d)
}

/// Tick positions on an axis, and how many decimals their labels need.
#[derive(Debug, Clone)]
pub(crate) struct Ticks {
    pub values: Vec<f64>,
    pub decimals: usize,
    /// Scientific notation with this many mantissa decimals, for very large or very small values.
    pub sci: Option<usize>,
}

impl Ticks {
    /// The label of tick value `v`.
    pub fn format(&self, v: f64) -> String {
        match self.sci {
            Some(p) => format!("{v:.p$e}"),
            None => format_tick(v, self.decimals),
        }
    }
}

/// A "nice" tick step (1, 2 or 5 times a power of ten) giving about `target` ticks over `span`.
pub(crate) fn nice_step(span: f64, target: usize) -> f64 {
    let target = target.max(2) as f64;
    if !(span.is_finite() && span > 0.0) {
        return 1.0;
    }
    let raw = span / target;
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let m = if norm <= 1.0 {
        1.0
    } else if norm <= 2.0 {
        2.0
    } else if norm <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// The multiples of `step` inside `[lo, hi]` (at most 200).
pub(crate) fn ticks_with_step(lo: f64, hi: f64, step: f64) -> Ticks {
    let mut values = Vec::new();
    if !(step.is_finite() && step > 0.0 && lo.is_finite() && hi.is_finite()) {
        return Ticks { values, decimals: 0, sci: None };
    }
    let first = (lo / step - 1e-9).ceil();
    let mut k = first;
    while values.len() < 200 {
        let v = k * step;
        if v > hi + step * 1e-9 {
            break;
        }
        // Normalise -0 so it prints as "0".
        values.push(if v == 0.0 { 0.0 } else { v });
        k += 1.0;
    }
    let decimals = (-(step.log10() + 1e-9).floor()).clamp(0.0, 9.0) as usize;
    let max_abs = lo.abs().max(hi.abs());
    let sci = (max_abs >= 1e6 || step < 1e-4).then(|| {
        // Enough mantissa digits to tell neighbouring ticks apart.
        let digits = ((max_abs.log10() + 1e-9).floor() - (step.log10() + 1e-9).floor()).clamp(0.0, 6.0);
        digits as usize
    });
    Ticks { values, decimals, sci }
}

/// Formats a tick value with `decimals` decimals, never as "-0".
pub(crate) fn format_tick(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// A rectangle in data coordinates.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DataRect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl DataRect {
    pub fn contains(&self, (x, y): (f64, f64)) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }
}

/// A sequence of points in data coordinates.
pub(crate) type Polyline = Vec<(f64, f64)>;

/// Liang-Barsky: the part of segment `a`-`b` inside `r`, if any.
pub(crate) fn clip_segment(a: (f64, f64), b: (f64, f64), r: &DataRect) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0 = 0.0f64;
    let mut t1 = 1.0f64;
    for (p, q) in [(-dx, a.0 - r.x0), (dx, r.x1 - a.0), (-dy, a.1 - r.y0), (dy, r.y1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    Some(((a.0 + t0 * dx, a.1 + t0 * dy), (a.0 + t1 * dx, a.1 + t1 * dy)))
}

/// Splits a polyline at non-finite points and at exits from `r`, keeping only the parts inside `r`.
/// Runs of a single finite point (no neighbour to connect to) are returned in the second vector if inside.
pub(crate) fn clip_polyline(points: &[(f64, f64)], r: &DataRect) -> (Vec<Polyline>, Polyline) {
    let mut lines: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut isolated = Vec::new();
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    for run in points.split(|p| !finite(p)) {
        if run.len() == 1 {
            if let Some(&p) = run.first() {
                if r.contains(p) {
                    isolated.push(p);
                }
            }
            continue;
        }
        let mut current: Vec<(f64, f64)> = Vec::new();
        for w in run.windows(2) {
            let (Some(&a), Some(&b)) = (w.first(), w.get(1)) else { continue };
            match clip_segment(a, b, r) {
                Some((ca, cb)) => {
                    let continues = current.last().is_some_and(|&l| l == ca);
                    if !continues {
                        if current.len() > 1 {
                            lines.push(std::mem::take(&mut current));
                        }
                        current.clear();
                        current.push(ca);
                    }
                    current.push(cb);
                }
                None => {
                    if current.len() > 1 {
                        lines.push(std::mem::take(&mut current));
                    }
                    current.clear();
                }
            }
        }
        if current.len() > 1 {
            lines.push(current);
        }
    }
    (lines, isolated)
}

/// Marker shapes, cycled by series index so that series stay apart in black and white.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

impl Marker {
    pub fn for_index(i: usize) -> Self {
        match i % 4 {
            0 => Self::Circle,
            1 => Self::Square,
            2 => Self::Triangle,
            _ => Self::Diamond,
        }
    }
}

/// Draws a filled marker of radius `r` pixels centred at pixel `c` of `area`.
pub(crate) fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    c: (i32, i32),
    marker: Marker,
    r: i32,
    color: RGBColor,
) -> Result<(), String> {
    let style = color.filled();
    let (x, y) = c;
    match marker {
        Marker::Circle => area.draw(&Circle::new(c, r, style)).map_err(de),
        Marker::Square => area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], style)).map_err(de),
        Marker::Triangle => {
            let h = r + r / 3;
            area.draw(&Polygon::new(vec![(x, y - h), (x + h, y + r), (x - h, y + r)], style)).map_err(de)
        }
        Marker::Diamond => {
            let h = r + r / 3;
            area.draw(&Polygon::new(vec![(x, y - h), (x + h, y), (x, y + h), (x - h, y)], style)).map_err(de)
        }
    }
}

/// Draws a polyline of pixel points, solid or dashed (dash and gap lengths scale with the line width).
pub(crate) fn draw_path<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    pts: Vec<(i32, i32)>,
    color: RGBAColor,
    width: u32,
    dash: Option<(i32, i32)>,
) -> Result<(), String> {
    if pts.len() < 2 {
        return Ok(());
    }
    let style = ShapeStyle { color, filled: false, stroke_width: width.max(1) };
    match dash {
        None => area.draw(&PathElement::new(pts, style)).map_err(de),
        Some((on, off)) => area.draw(&DashedPathElement::new(pts, on.max(1), off.max(1), style)).map_err(de),
    }
}

/// What a legend row shows left of its label.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Swatch {
    /// A line sample, optionally dashed, with an optional marker and a shaded band behind it.
    Line { color: RGBColor, dashed: bool, marker: Option<Marker>, band: bool, line: bool },
    /// A filled square.
    Filled { color: RGBColor },
    /// A rectangle outline with an optional light fill.
    Outline { color: RGBColor, dashed: bool, fill: bool },
    /// A small dot.
    Dot { color: RGBColor },
    /// A short arrow.
    Arrow { color: RGBColor },
    /// A filled triangle pointing right (the ego vehicle).
    Triangle { color: RGBColor },
}

/// One legend row.
#[derive(Debug, Clone)]
pub(crate) struct LegendEntry {
    pub label: String,
    pub swatch: Swatch,
}

/// Geometry of a legend box, in pixels.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LegendBox {
    pub w: i32,
    pub h: i32,
    pad: i32,
    row_h: i32,
    sample_w: i32,
    gap: i32,
    font: f64,
    /// Entries per row (1: one column).
    cols: i32,
    /// Width of one column.
    col_w: i32,
}

impl LegendBox {
    /// The same legend in as many columns as fit in `max_w` pixels (entries run left to right, then down).
    pub fn in_columns(self, n_entries: usize, max_w: i32) -> Self {
        let n = i32::try_from(n_entries).unwrap_or(i32::MAX).max(1);
        let col_w = self.col_w + self.pad;
        let cols = ((max_w - self.pad) / col_w.max(1)).clamp(1, n);
        let rows = (n + cols - 1) / cols;
        let w = self.pad + cols * col_w;
        // The one-column box is 2 pad + n rows minus a small trim; keep the trim.
        let trim = 2 * self.pad + n.saturating_mul(self.row_h) - self.h;
        let h = 2 * self.pad + rows.saturating_mul(self.row_h) - trim;
        Self { w, h, cols, col_w, ..self }
    }
}

/// Measures the legend for `entries` (None if there are none).
pub(crate) fn legend_box<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    px: Px,
) -> Option<LegendBox> {
    if entries.is_empty() {
        return None;
    }
    let font = px.f(14.0);
    let style = text(font, INK);
    let text_w = entries.iter().map(|e| text_size(area, &e.label, &style).0).max().unwrap_or(0);
    let pad = px.i(8.0);
    let row_h = round_i32(font * 1.45).max(1);
    let sample_w = px.i(30.0);
    let gap = px.i(7.0);
    let n = i32::try_from(entries.len()).unwrap_or(i32::MAX / 2 / row_h.max(1));
    let col_w = sample_w + gap + i32::try_from(text_w).unwrap_or(0);
    let w = pad + col_w + pad;
    let h = pad + n.saturating_mul(row_h) + pad - px.i(2.0);
    Some(LegendBox { w, h, pad, row_h, sample_w, gap, font, cols: 1, col_w })
}

/// Draws the legend with its top-left corner at pixel `at` of `area`.
pub(crate) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    lb: &LegendBox,
    entries: &[LegendEntry],
    px: Px,
) -> Result<(), String> {
    let (x0, y0) = at;
    area.draw(&Rectangle::new([(x0, y0), (x0 + lb.w, y0 + lb.h)], WHITE.mix(0.92).filled())).map_err(de)?;
    area.draw(&Rectangle::new([(x0, y0), (x0 + lb.w, y0 + lb.h)], RGBColor(190, 190, 190).stroke_width(1)))
        .map_err(de)?;
    let style = text_at(lb.font, INK, HPos::Left, VPos::Center);
    let lw = px.u(2.0);
    for (i, e) in entries.iter().enumerate() {
        let i = i32::try_from(i).unwrap_or(0);
        let (row, col) = (i / lb.cols.max(1), i % lb.cols.max(1));
        let cy = y0 + lb.pad + row * lb.row_h + lb.row_h / 2 - px.i(1.0);
        let sx0 = x0 + lb.pad + col * (lb.col_w + lb.pad);
        let sx1 = sx0 + lb.sample_w;
        let cx = (sx0 + sx1) / 2;
        let half = (lb.row_h / 2 - px.i(2.0)).max(2);
        match e.swatch {
            Swatch::Line { color, dashed, marker, band, line } => {
                if band {
                    area.draw(&Rectangle::new([(sx0, cy - half), (sx1, cy + half)], color.mix(0.2).filled()))
                        .map_err(de)?;
                }
                if line {
                    let dash = dashed.then(|| (px.i(6.0), px.i(4.0)));
                    draw_path(area, vec![(sx0, cy), (sx1, cy)], color.to_rgba(), lw, dash)?;
                }
                if let Some(m) = marker {
                    draw_marker(area, (cx, cy), m, px.i(4.0), color)?;
                }
            }
            Swatch::Filled { color } => {
                area.draw(&Rectangle::new([(cx - half, cy - half), (cx + half, cy + half)], color.filled()))
                    .map_err(de)?;
                area.draw(&Rectangle::new([(cx - half, cy - half), (cx + half, cy + half)], RGBColor(150, 150, 150)))
                    .map_err(de)?;
            }
            Swatch::Outline { color, dashed, fill } => {
                let r = [(sx0 + px.i(3.0), cy - half), (sx1 - px.i(3.0), cy + half)];
                if fill {
                    area.draw(&Rectangle::new(r, color.mix(0.15).filled())).map_err(de)?;
                }
                let pts =
                    vec![(r[0].0, r[0].1), (r[1].0, r[0].1), (r[1].0, r[1].1), (r[0].0, r[1].1), (r[0].0, r[0].1)];
                let dash = dashed.then(|| (px.i(4.0), px.i(3.0)));
                draw_path(area, pts, color.to_rgba(), px.u(1.5), dash)?;
            }
            Swatch::Dot { color } => {
                area.draw(&Circle::new((cx, cy), px.i(2.0), color.filled())).map_err(de)?;
            }
            Swatch::Arrow { color } => {
                draw_arrow_px(area, (sx0, cy), (sx1, cy), color, px)?;
            }
            Swatch::Triangle { color } => {
                let h = half;
                area.draw(&Polygon::new(vec![(cx + h, cy), (cx - h, cy - h), (cx - h, cy + h)], color.filled()))
                    .map_err(de)?;
            }
        }
        area.draw_text(&e.label, &style, (sx1 + lb.gap, cy)).map_err(de)?;
    }
    Ok(())
}

/// Draws an arrow from pixel `a` to pixel `b` with a head at `b`.
pub(crate) fn draw_arrow_px<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    a: (i32, i32),
    b: (i32, i32),
    color: RGBColor,
    px: Px,
) -> Result<(), String> {
    let w = px.u(1.5);
    draw_path(area, vec![a, b], color.to_rgba(), w, None)?;
    let (dx, dy) = (f64::from(b.0 - a.0), f64::from(b.1 - a.1));
    let len = dx.hypot(dy);
    if len < 1.0 {
        return Ok(());
    }
    let head = px.f(7.0).min(len * 0.6);
    let (ux, uy) = (dx / len, dy / len);
    let base = (f64::from(b.0) - ux * head, f64::from(b.1) - uy * head);
    let side = head * 0.45;
    let p1 = (round_i32(base.0 - uy * side), round_i32(base.1 + ux * side));
    let p2 = (round_i32(base.0 + uy * side), round_i32(base.1 - ux * side));
    area.draw(&Polygon::new(vec![b, p1, p2], color.filled())).map_err(de)
}

/// A coarse mask of the plot area's pixels that data is drawn on, to place the legend where it hides nothing.
pub(crate) struct Occupancy {
    w: i32,
    h: i32,
    cell: i32,
    cols: usize,
    rows: usize,
    mask: Vec<bool>,
}

impl Occupancy {
    /// An empty mask of a `w` x `h` pixel plot with `cell`-pixel resolution.
    pub fn new(w: i32, h: i32, cell: i32) -> Self {
        let cell = cell.max(1);
        let cols = usize::try_from((w.max(1) + cell - 1) / cell).unwrap_or(1);
        let rows = usize::try_from((h.max(1) + cell - 1) / cell).unwrap_or(1);
        Self { w, h, cell, cols, rows, mask: vec![false; cols * rows] }
    }

    fn idx(&self, x: f64, y: f64) -> Option<usize> {
        if !(x.is_finite() && y.is_finite()) || x < 0.0 || y < 0.0 || x >= f64::from(self.w) || y >= f64::from(self.h) {
            return None;
        }
        let c = (x / f64::from(self.cell)) as usize;
        let r = (y / f64::from(self.cell)) as usize;
        (c < self.cols && r < self.rows).then_some(r * self.cols + c)
    }

    /// Marks the pixel `(x, y)`.
    pub fn mark(&mut self, x: f64, y: f64) {
        if let Some(i) = self.idx(x, y) {
            if let Some(m) = self.mask.get_mut(i) {
                *m = true;
            }
        }
    }

    /// Marks the pixels along a segment.
    pub fn mark_segment(&mut self, a: (f64, f64), b: (f64, f64)) {
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        if !len.is_finite() {
            return;
        }
        let steps = ((len / f64::from(self.cell) * 2.0).ceil() as usize).clamp(1, 100_000);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            self.mark(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        }
    }

    /// Marks every cell of a pixel rectangle.
    pub fn mark_rect(&mut self, a: (f64, f64), b: (f64, f64)) {
        let (x0, x1) = (a.0.min(b.0).max(0.0), a.0.max(b.0).min(f64::from(self.w) - 1.0));
        let (y0, y1) = (a.1.min(b.1).max(0.0), a.1.max(b.1).min(f64::from(self.h) - 1.0));
        if !(x0 <= x1 && y0 <= y1) {
            return;
        }
        let step = f64::from(self.cell) / 2.0;
        let mut y = y0;
        while y <= y1 + step {
            let mut x = x0;
            while x <= x1 + step {
                self.mark(x.min(x1), y.min(y1));
                x += step;
            }
            y += step;
        }
    }

    /// The fraction of cells under the pixel rectangle at `at` of size `size` that are marked.
    pub fn covered_fraction(&self, at: (i32, i32), size: (i32, i32)) -> f64 {
        let mut hit = 0usize;
        let mut total = 0usize;
        let c = self.cell;
        let mut y = at.1;
        while y < at.1 + size.1 {
            let mut x = at.0;
            while x < at.0 + size.0 {
                total += 1;
                if let Some(i) = self.idx(f64::from(x), f64::from(y)) {
                    if self.mask.get(i).copied().unwrap_or(false) {
                        hit += 1;
                    }
                }
                x += c;
            }
            y += c;
        }
        if total == 0 {
            0.0
        } else {
            hit as f64 / total as f64
        }
    }

    /// The first corner (in [`Corner::AUTO_ORDER`]) where a `size` legend covers no data; else the least covered
    /// corner if it covers under 3 % of the legend; else outside.
    pub fn best_placement(&self, size: (i32, i32), inset: i32) -> Placement {
        if size.0 + 2 * inset > self.w || size.1 + 2 * inset > self.h {
            return Placement::Outside;
        }
        let mut best: Option<(Corner, f64)> = None;
        for corner in Corner::AUTO_ORDER {
            let f = self.covered_fraction(corner.place((self.w, self.h), size, inset), size);
            if f == 0.0 {
                return Placement::Inside(corner);
            }
            if best.is_none_or(|(_, bf)| f < bf) {
                best = Some((corner, f));
            }
        }
        match best {
            Some((corner, f)) if f < 0.03 => Placement::Inside(corner),
            _ => Placement::Outside,
        }
    }

    /// [`Self::best_placement`], except that a legend wider than `max_outside_w` pixels is never put beside the
    /// plot (it would squeeze it): it goes under the plot instead, in columns, where it hides nothing.
    pub fn auto_placement(&self, size: (i32, i32), inset: i32, max_outside_w: i32) -> Placement {
        match self.best_placement(size, inset) {
            Placement::Outside if size.0 > max_outside_w => Placement::Below,
            p => p,
        }
    }
}

/// The widest legend [`crate::LegendPosition::Auto`] may put beside a plot on an area `area_w` pixels wide.
pub(crate) fn max_outside_w(area_w: u32) -> i32 {
    i32::try_from(area_w / 3).unwrap_or(i32::MAX)
}

/// Draws a centred figure title at the top of `root` and returns the area below it.
pub(crate) fn draw_title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    px: Px,
) -> Result<DrawingArea<DB, Shift>, String> {
    let (w, _) = root.dim_in_pixel();
    if title.trim().is_empty() {
        let (_, rest) = root.split_vertically(px.i(8.0));
        return Ok(rest);
    }
    // A title wider than the figure is shrunk to fit, and below 14 px split into two lines at the middle space.
    let pad = px.i(9.0);
    let avail = f64::from(w) - 2.0 * f64::from(pad);
    let width_at = |t: &str, f: f64| f64::from(text_size(root, t, &text_at(f, INK, HPos::Center, VPos::Top)).0);
    let full = px.f(19.0);
    let fit = |lines: &[&str]| {
        let widest = lines.iter().map(|l| width_at(l, full)).fold(1.0, f64::max);
        (full * avail / widest).min(full)
    };
    let one = fit(&[title]);
    let lines: Vec<&str> = if one >= px.f(14.0) {
        vec![title]
    } else {
        let mid = title.len() / 2;
        let split = title.match_indices(' ').map(|(i, _)| i).min_by_key(|&i| i.abs_diff(mid)).unwrap_or(title.len());
        let (a, b) = title.split_at(split);
        vec![a.trim(), b.trim()]
    };
    let font = fit(&lines).max(px.f(10.0));
    let style = text_at(font, INK, HPos::Center, VPos::Top);
    let mut y = pad;
    for line in lines.iter().filter(|l| !l.is_empty()) {
        let (_, th) = text_size(root, line, &style);
        root.draw_text(line, &style, (i32::try_from(w / 2).unwrap_or(0), y)).map_err(de)?;
        y += i32::try_from(th).unwrap_or(0) + px.i(2.0);
    }
    let used = y + px.i(4.0);
    let (_, rest) = root.split_vertically(used);
    Ok(rest)
}

/// The pixel rectangle `(x0, y0, x1, y1)` of a `size` text anchored at `pos` with `h`, `v`.
pub(crate) fn label_rect(pos: (i32, i32), h: HPos, v: VPos, size: (i32, i32)) -> (i32, i32, i32, i32) {
    let x0 = match h {
        HPos::Left => pos.0,
        HPos::Center => pos.0 - size.0 / 2,
        HPos::Right => pos.0 - size.0,
    };
    let y0 = match v {
        VPos::Top => pos.1,
        VPos::Center => pos.1 - size.1 / 2,
        VPos::Bottom => pos.1 - size.1,
    };
    (x0, y0, x0 + size.0, y0 + size.1)
}

/// Size of `s` in the label font of `size_px`, as i32.
pub(crate) fn label_size<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, s: &str, size_px: f64) -> (i32, i32) {
    let (w, h) = text_size(area, s, &text(size_px, INK));
    (i32::try_from(w).unwrap_or(0), i32::try_from(h).unwrap_or(0))
}

/// Draws a label on a translucent white background so it stays readable over data.
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_label<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s: &str,
    size_px: f64,
    color: RGBColor,
    pos: (i32, i32),
    h: HPos,
    v: VPos,
    px: Px,
) -> Result<(), String> {
    if s.is_empty() {
        return Ok(());
    }
    let (x0, y0, x1, y1) = label_rect(pos, h, v, label_size(area, s, size_px));
    let pad = px.i(2.0);
    area.draw(&Rectangle::new([(x0 - pad, y0 - pad), (x1 + pad, y1 + pad)], WHITE.mix(0.88).filled())).map_err(de)?;
    area.draw_text(s, &text_at(size_px, color, h, v), pos).map_err(de)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ticks_are_round_and_inside() {
        let step = nice_step(1.0, 5);
        assert!((step - 0.2).abs() < 1e-12, "step {step}");
        let t = ticks_with_step(-0.04, 1.04, step);
        assert_eq!(t.values.len(), 6);
        assert_eq!(t.decimals, 1);
        let labels: Vec<String> = t.values.iter().map(|&v| format_tick(v, t.decimals)).collect();
        assert_eq!(labels, ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        assert_eq!(format_tick(-0.0001, 2), "0.00");
        assert_eq!(ticks_with_step(0.0, 0.5, 0.1).decimals, 1);
        assert_eq!(ticks_with_step(0.0, 50.0, 10.0).decimals, 0);
        assert_eq!(ticks_with_step(0.0, 0.05, 0.01).decimals, 2);
        assert_eq!(ticks_with_step(0.0, 1.0, f64::NAN).values.len(), 0);
        let big = ticks_with_step(0.0, 3e9, 1e9);
        assert_eq!(big.values.iter().map(|&v| big.format(v)).collect::<Vec<_>>(), ["0e0", "1e9", "2e9", "3e9"]);
        let small = ticks_with_step(1e-5, 3e-5, 1e-5);
        assert_eq!(small.format(2e-5), "2e-5");
        let fine = ticks_with_step(1.0, 1.0002, 0.0001);
        assert_eq!(fine.format(1.0001), "1.0001");
        let finer = ticks_with_step(1.0, 1.00002, 0.00001);
        assert_eq!(finer.format(1.00001), "1.00001e0");
        assert!(ticks_with_step(0.0, 1e300, 1e-300).values.len() <= 200);
    }

    #[test]
    fn ranges_fall_back_sensibly() {
        assert_eq!(resolve_range(None, std::iter::empty(), 0.05, false), (0.0, 1.0));
        assert_eq!(resolve_range(None, [f64::NAN, f64::INFINITY].into_iter(), 0.05, false), (0.0, 1.0));
        assert_eq!(resolve_range(Some((2.0, 1.0)), std::iter::empty(), 0.05, false), (1.0, 2.0));
        assert_eq!(resolve_range(Some((f64::NAN, 1.0)), [0.0, 10.0].into_iter(), 0.0, false), (0.0, 10.0));
        let (lo, hi) = resolve_range(None, [3.0].into_iter(), 0.05, false);
        assert!(lo < 3.0 && hi > 3.0);
        let (lo, hi) = resolve_range(None, [2.0, 4.0].into_iter(), 0.1, true);
        assert_eq!(lo, 0.0);
        assert!((hi - 4.4).abs() < 1e-12);
    }

    #[test]
    fn clipping_keeps_the_inside_part() {
        let r = DataRect { x0: 0.0, y0: 0.0, x1: 1.0, y1: 1.0 };
        let (a, b) = clip_segment((-1.0, 0.5), (2.0, 0.5), &r).expect("crosses");
        assert_eq!((a, b), ((0.0, 0.5), (1.0, 0.5)));
        assert!(clip_segment((-1.0, 2.0), (2.0, 2.0), &r).is_none());
        let pts =
            [(0.1, 0.1), (0.5, 5.0), (0.9, 0.1), (f64::NAN, 0.5), (0.5, 0.5), (f64::NAN, 0.0), (0.2, 0.2), (0.3, 0.3)];
        let (lines, isolated) = clip_polyline(&pts, &r);
        assert_eq!(lines.len(), 3, "{lines:?}");
        assert_eq!(isolated, vec![(0.5, 0.5)]);
        assert!(lines.iter().flatten().all(|&p| r.contains(p)));
    }

    #[test]
    fn legend_avoids_marked_corners() {
        let mut occ = Occupancy::new(400, 300, 4);
        // Data along the top edge: both upper corners are taken.
        occ.mark_segment((0.0, 20.0), (400.0, 20.0));
        assert_eq!(occ.best_placement((100, 50), 8), Placement::Inside(Corner::LowerRight));
        // Data everywhere: nothing fits inside.
        occ.mark_rect((0.0, 0.0), (400.0, 300.0));
        assert_eq!(occ.best_placement((100, 50), 8), Placement::Outside);
        // ... and one too wide to sit beside the plot goes under it.
        assert_eq!(occ.auto_placement((100, 50), 8, 90), Placement::Below);
        assert_eq!(occ.auto_placement((100, 50), 8, 110), Placement::Outside);
        // A legend larger than the plot goes outside.
        assert_eq!(Occupancy::new(50, 50, 4).best_placement((100, 50), 8), Placement::Outside);
    }
}
