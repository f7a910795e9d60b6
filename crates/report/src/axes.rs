//! Paper-style axes: white plot area, light grid, a black frame, ticks on our own nice positions.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::plot::{de, text, text_size, Px, Ticks};
use crate::style::{GRID, INK};

/// A linear f64 axis whose ticks (grid lines, labels) are exactly the given values.
///
/// plotters' own `WithKeyPoints` wrapper cannot be used with `configure_mesh` on f64 axes (no value formatter),
/// so this is the same linear map as `RangedCoordf64` with our tick list.
#[derive(Debug, Clone)]
pub(crate) struct Linear {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
}

impl Ranged for Linear {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let span = self.hi - self.lo;
        let actual = limit.1 - limit.0;
        if span.is_nan() || span <= 0.0 || actual == 0 {
            return limit.0 + actual / 2;
        }
        let t = (*v - self.lo) / span;
        let p = f64::from(limit.0) + f64::from(actual) * t;
        // Saturating conversion; NaN maps to the start of the axis (callers skip NaN anyway).
        if p.is_nan() {
            limit.0
        } else {
            p.round().clamp(-1.0e7, 1.0e7) as i32
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

/// The coordinate system of every chart: f64 on both axes with explicit tick positions.
pub(crate) type Coords = Cartesian2d<Linear, Linear>;

/// One axis: its range, ticks, label and how tick values are printed.
pub(crate) struct Axis<'a> {
    pub range: (f64, f64),
    pub ticks: Ticks,
    pub label: &'a str,
    /// Custom tick text (bar chart categories); `None` prints the value with the ticks' decimals.
    pub names: Option<&'a dyn Fn(f64) -> String>,
    /// Draw grid lines at the ticks.
    pub grid: bool,
}

impl Axis<'_> {
    fn tick_text(&self, v: f64) -> String {
        match self.names {
            Some(f) => f(v),
            None => self.ticks.format(v),
        }
    }
}

/// Space around the plot area inside a chart area, in pixels.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Margins {
    pub left: i32,
    pub right: i32,
    pub top: i32,
    pub bottom: i32,
}

/// Font sizes of the axes, in pixels.
pub(crate) fn tick_font(px: Px) -> f64 {
    px.f(14.0)
}
pub(crate) fn desc_font(px: Px) -> f64 {
    px.f(16.0)
}

/// The margins the axes need on `area`: room for the widest y tick label and both axis labels.
pub(crate) fn margins<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    x: &Axis<'_>,
    y: &Axis<'_>,
    px: Px,
) -> Margins {
    let tick_style = text(tick_font(px), INK);
    let desc_style = text(desc_font(px), INK);
    let widest = y.ticks.values.iter().map(|&v| text_size(area, &y.tick_text(v), &tick_style).0).max().unwrap_or(0);
    let tick_h = text_size(area, "0123456789", &tick_style).1;
    let desc_h = |s: &str| if s.is_empty() { 0 } else { text_size(area, s, &desc_style).1.max(1) };
    let to_i = |v: u32| i32::try_from(v).unwrap_or(0);
    let tick_len = px.i(5.0);
    Margins {
        left: px.i(10.0) + to_i(desc_h(y.label)) + px.i(8.0) + to_i(widest) + 2 * tick_len,
        right: px.i(18.0),
        top: px.i(6.0),
        bottom: 2 * tick_len + to_i(tick_h) + px.i(8.0) + to_i(desc_h(x.label)) + px.i(8.0),
    }
}

/// Builds the chart on `area` with the given margins, draws grid, ticks, labels and the frame.
pub(crate) fn build<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    m: Margins,
    x: &Axis<'_>,
    y: &Axis<'_>,
    px: Px,
) -> Result<ChartContext<'a, DB, Coords>, String> {
    let x_label_area = m.bottom - px.i(8.0);
    let y_label_area = m.left - px.i(10.0);
    let mut chart = ChartBuilder::on(area)
        .margin_left(px.i(10.0))
        .margin_bottom(px.i(8.0))
        .margin_top(m.top)
        .margin_right(m.right)
        .x_label_area_size(x_label_area.max(0))
        .y_label_area_size(y_label_area.max(0))
        .build_cartesian_2d(
            Linear { lo: x.range.0, hi: x.range.1, ticks: x.ticks.values.clone() },
            Linear { lo: y.range.0, hi: y.range.1, ticks: y.ticks.values.clone() },
        )
        .map_err(de)?;
    let x_fmt = |v: &f64| x.tick_text(*v);
    let y_fmt = |v: &f64| y.tick_text(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style(text(tick_font(px), INK))
        .axis_desc_style(text(desc_font(px), INK))
        .bold_line_style(GRID.stroke_width(px.u(1.0)))
        .light_line_style(TRANSPARENT)
        .axis_style(INK.stroke_width(px.u(1.0)))
        .set_all_tick_mark_size(px.i(5.0));
    if !x.label.is_empty() {
        mesh.x_desc(x.label);
    }
    if !y.label.is_empty() {
        mesh.y_desc(y.label);
    }
    if !x.grid {
        mesh.disable_x_mesh();
    }
    if !y.grid {
        mesh.disable_y_mesh();
    }
    mesh.draw().map_err(de)?;
    Ok(chart)
}

/// Draws the black frame around the plot area (after the data, so data never covers it).
pub(crate) fn draw_frame<DB: DrawingBackend>(chart: &ChartContext<'_, DB, Coords>, px: Px) -> Result<(), String> {
    let pa = chart.plotting_area().strip_coord_spec();
    let (w, h) = pa.dim_in_pixel();
    let (w, h) = (i32::try_from(w).unwrap_or(0) - 1, i32::try_from(h).unwrap_or(0) - 1);
    pa.draw(&PathElement::new(vec![(0, 0), (w, 0), (w, h), (0, h), (0, 0)], INK.stroke_width(px.u(1.0)))).map_err(de)
}

/// Maps data coordinates to pixel coordinates relative to the plot area's top-left corner.
pub(crate) fn mapper<'c, 'a: 'c, DB: DrawingBackend + 'c>(
    chart: &'c ChartContext<'a, DB, Coords>,
) -> impl Fn(f64, f64) -> (i32, i32) + use<'c, 'a, DB> {
    let (bx, by) = chart.plotting_area().get_base_pixel();
    move |x, y| {
        let (px, py) = chart.backend_coord(&(x, y));
        (px - bx, py - by)
    }
}

/// Pixel size of the plot area (width, height).
pub(crate) fn plot_size<DB: DrawingBackend>(chart: &ChartContext<'_, DB, Coords>) -> (i32, i32) {
    let (w, h) = chart.plotting_area().dim_in_pixel();
    (i32::try_from(w).unwrap_or(0), i32::try_from(h).unwrap_or(0))
}

/// The plot area size a chart on an `area_w` x `area_h` area with margins `m` will get (as [`build`] lays it out).
pub(crate) fn predicted_plot_size(area_w: u32, area_h: u32, m: Margins) -> (i32, i32) {
    let w = i32::try_from(area_w).unwrap_or(0) - m.left - m.right;
    let h = i32::try_from(area_h).unwrap_or(0) - m.top - m.bottom;
    (w.max(1), h.max(1))
}
