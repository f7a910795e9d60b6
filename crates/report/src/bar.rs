//! Grouped bar charts with optional error bars (the paper's latency figure kind).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::axes::{self, Axis};
use crate::line::{draw_ref_lines, mark_ref_lines, Orientation, RefLine, RefPart};
use crate::plot::{
    de, draw_legend, draw_path, draw_title, legend_box, max_outside_w, nice_step, resolve_range, ticks_with_step,
    LegendEntry, Occupancy, Px, Swatch, Ticks,
};
use crate::render::{impl_figure, Draw, Output};
use crate::style::{LegendPosition, Placement, SeriesColor, INK};
use crate::ReportError;

/// One group of bars: one value per category of the [`BarChart`], drawn side by side with the other groups.
#[derive(Debug, Clone, PartialEq)]
pub struct BarGroup {
    /// Legend text; an empty name keeps the group out of the legend.
    pub name: String,
    /// One value per category (same order as [`BarChart::categories`]); missing or non-finite values draw no bar.
    pub values: Vec<f64>,
    /// Optional error bars as absolute `(lo, hi)` per category (e.g. a 95 % interval or the 5th/95th
    /// percentile), not half-widths; non-finite entries draw no error bar.
    pub errors: Option<Vec<(f64, f64)>>,
    /// Bar colour; [`SeriesColor::Auto`] takes the palette entry of the group's index.
    pub color: SeriesColor,
}

impl BarGroup {
    /// A group with automatic colour and no error bars.
    pub fn new(name: impl Into<String>, values: Vec<f64>) -> Self {
        Self { name: name.into(), values, errors: None, color: SeriesColor::Auto }
    }
    /// Adds error bars `(lo, hi)` per category.
    #[must_use]
    pub fn with_errors(mut self, errors: Vec<(f64, f64)>) -> Self {
        self.errors = Some(errors);
        self
    }
    /// Sets the colour.
    #[must_use]
    pub fn with_color(mut self, color: SeriesColor) -> Self {
        self.color = color;
        self
    }
}

/// A grouped bar chart: categories along x, one bar per group in each category, bars starting at 0.
///
/// The automatic y range contains 0, every value and error bar, and the horizontal reference lines (vertical
/// ones are ignored). SVG is 800 x 500 px.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarChart {
    /// Title above the plot (may be empty).
    pub title: String,
    /// Label under the category axis.
    pub x_label: String,
    /// Y axis label, with unit, e.g. "latency \[ms\]".
    pub y_label: String,
    /// Fixed y range `(min, max)`; bars and error bars are clipped to it.
    pub y_range: Option<(f64, f64)>,
    /// Category names along the x axis.
    pub categories: Vec<String>,
    /// The bar groups, drawn left to right within each category.
    pub groups: Vec<BarGroup>,
    /// Horizontal reference lines, e.g. a latency budget.
    pub ref_lines: Vec<RefLine>,
    /// Where the legend goes.
    pub legend: LegendPosition,
}

impl BarChart {
    /// An empty chart with a title, axis labels and categories.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        categories: Vec<String>,
    ) -> Self {
        Self { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), categories, ..Self::default() }
    }
    /// Adds a group.
    #[must_use]
    pub fn with_group(mut self, group: BarGroup) -> Self {
        self.groups.push(group);
        self
    }
    /// Fixes the y range.
    #[must_use]
    pub fn with_y_range(mut self, min: f64, max: f64) -> Self {
        self.y_range = Some((min, max));
        self
    }
    /// Adds a horizontal reference line.
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

    /// Writes the chart's data as CSV with columns `category,group,value,err_lo,err_hi` (error columns empty
    /// without error bars), categories outer, groups inner.
    pub fn write_csv(&self, path: impl AsRef<Path>) -> Result<(), ReportError> {
        let mut rows: Vec<[String; 5]> = Vec::new();
        for (c, cat) in self.categories.iter().enumerate() {
            for g in &self.groups {
                let value = g.values.get(c).map(f64::to_string).unwrap_or_default();
                let (lo, hi) = match g.errors.as_ref().and_then(|e| e.get(c)) {
                    Some(&(lo, hi)) => (lo.to_string(), hi.to_string()),
                    None => (String::new(), String::new()),
                };
                rows.push([cat.clone(), g.name.clone(), value, lo, hi]);
            }
        }
        crate::csv_out::write_csv(path, &["category", "group", "value", "err_lo", "err_hi"], &rows)
    }

    fn n_categories(&self) -> usize {
        self.categories.len().max(1)
    }

    fn y_range(&self) -> (f64, f64) {
        let n = self.categories.len();
        let values = self.groups.iter().flat_map(|g| g.values.iter().take(n).copied());
        let errors = self.groups.iter().flat_map(|g| g.errors.iter().flatten().take(n).flat_map(|&(lo, hi)| [lo, hi]));
        let refs = self.ref_lines.iter().filter(|r| r.orientation == Orientation::Horizontal).map(|r| r.value);
        resolve_range(self.y_range, values.chain(errors).chain(refs), 0.08, true)
    }

    /// Bar `(x0, x1)` in data units for group `g` in category `c`.
    fn bar_x(&self, c: usize, g: usize) -> (f64, f64) {
        let n = self.groups.len().max(1) as f64;
        let bw = 0.8 / n;
        let gap = bw * 0.08;
        let x0 = c as f64 + 0.1 + g as f64 * bw;
        (x0 + gap / 2.0, x0 + bw - gap / 2.0)
    }

    /// Every bar with a finite value or error bar.
    fn bars(&self) -> Vec<Bar> {
        let mut out = Vec::new();
        for (gi, g) in self.groups.iter().enumerate() {
            for ci in 0..self.categories.len() {
                let v = g.values.get(ci).copied().filter(|v| v.is_finite());
                let e =
                    g.errors.as_ref().and_then(|e| e.get(ci)).copied().filter(|e| e.0.is_finite() && e.1.is_finite());
                if v.is_none() && e.is_none() {
                    continue;
                }
                let (x0, x1) = self.bar_x(ci, gi);
                out.push(Bar { group: gi, x0, x1, value: v, error: e });
            }
        }
        out
    }

    fn legend_entries(&self) -> Vec<LegendEntry> {
        self.groups
            .iter()
            .enumerate()
            .filter(|(_, g)| !g.name.is_empty())
            .map(|(i, g)| LegendEntry { label: g.name.clone(), swatch: Swatch::Filled { color: g.color.resolve(i) } })
            .collect()
    }
}

/// One bar to draw: its group, x extent in data units, value and error bar (either may be missing).
struct Bar {
    group: usize,
    x0: f64,
    x1: f64,
    value: Option<f64>,
    error: Option<(f64, f64)>,
}

impl Draw for BarChart {
    fn svg_size_px(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, _output: Output) -> Result<(), String> {
        let (w, h) = root.dim_in_pixel();
        let px = Px::new(w, h, 800.0, 500.0);
        root.fill(&WHITE).map_err(de)?;
        let area = draw_title(root, &self.title, px)?;
        let n = self.n_categories();
        let xr = (0.0, n as f64);
        let yr = self.y_range();
        let (aw, ah) = area.dim_in_pixel();

        let names = |v: f64| {
            let i = v.floor();
            if i >= 0.0 {
                self.categories.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        let centres: Vec<f64> = (0..self.categories.len()).map(|i| i as f64 + 0.5).collect();
        let x_axis = Axis {
            range: xr,
            ticks: Ticks { values: centres, decimals: 0, sci: None },
            label: &self.x_label,
            names: Some(&names),
            grid: false,
        };
        let y_step = nice_step(yr.1 - yr.0, (i32::try_from(ah).unwrap_or(0) / px.i(60.0)).clamp(2, 10) as usize);
        let y_axis = Axis {
            range: yr,
            ticks: ticks_with_step(yr.0, yr.1, y_step),
            label: &self.y_label,
            names: None,
            grid: true,
        };

        let entries = self.legend_entries();
        let lb = legend_box(&area, &entries, px);
        let inset = px.i(8.0);
        let bars = self.bars();
        let base = 0.0f64.clamp(yr.0, yr.1);
        let m = axes::margins(&area, &x_axis, &y_axis, px);
        let placement = match (lb, self.legend.fixed()) {
            (None, _) => Placement::None,
            (Some(_), Some(p)) => p,
            (Some(lb), None) => {
                let (pw, ph) = axes::predicted_plot_size(aw, ah, m);
                let mut occ = Occupancy::new(pw, ph, px.i(6.0));
                let map = |x: f64, y: f64| {
                    (
                        (x - xr.0) / (xr.1 - xr.0) * f64::from(pw),
                        f64::from(ph) - (y.clamp(yr.0, yr.1) - yr.0) / (yr.1 - yr.0) * f64::from(ph),
                    )
                };
                for &Bar { x0, x1, value: v, error: e, .. } in &bars {
                    let top = v.unwrap_or(base).max(e.map_or(f64::NEG_INFINITY, |e| e.0.max(e.1)));
                    let bottom = v.unwrap_or(base).min(base).min(e.map_or(f64::INFINITY, |e| e.0.min(e.1)));
                    occ.mark_rect(map(x0, bottom), map(x1, top));
                }
                mark_ref_lines(&mut occ, &self.ref_lines, &map, (pw, ph), xr, yr, px);
                occ.auto_placement((lb.w, lb.h), inset, max_outside_w(aw))
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
        let m = axes::margins(&chart_area, &x_axis, &y_axis, px);
        let chart = axes::build(&chart_area, m, &x_axis, &y_axis, px)?;
        let pa = chart.plotting_area().strip_coord_spec();
        let to_px = axes::mapper(&chart);
        let (pw, ph) = axes::plot_size(&chart);
        let clamp_y = |y: f64| y.clamp(yr.0, yr.1);

        for &Bar { group: gi, x0, x1, value: v, .. } in &bars {
            let Some(v) = v else { continue };
            let color = self.groups.get(gi).map_or(INK, |g| g.color.resolve(gi));
            let a = to_px(x0, clamp_y(base));
            let b = to_px(x1, clamp_y(v));
            if a.1 == b.1 {
                continue;
            }
            pa.draw(&Rectangle::new([a, b], color.filled())).map_err(de)?;
            pa.draw(&Rectangle::new([a, b], RGBColor(60, 60, 60).stroke_width(px.u(1.0)))).map_err(de)?;
        }
        for &Bar { x0, x1, error: e, .. } in &bars {
            let Some((lo, hi)) = e else { continue };
            let (lo, hi) = (clamp_y(lo.min(hi)), clamp_y(lo.max(hi)));
            let xc = (x0 + x1) / 2.0;
            let cap = (x1 - x0) * 0.25;
            let color = INK.to_rgba();
            let lw = px.u(1.5);
            draw_path(&pa, vec![to_px(xc, lo), to_px(xc, hi)], color, lw, None)?;
            draw_path(&pa, vec![to_px(xc - cap, lo), to_px(xc + cap, lo)], color, lw, None)?;
            draw_path(&pa, vec![to_px(xc - cap, hi), to_px(xc + cap, hi)], color, lw, None)?;
        }
        draw_ref_lines(&pa, &self.ref_lines, RefPart::Lines, &to_px, (pw, ph), xr, yr, px)?;
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

impl_figure!(BarChart);
