//! Colours, line styles and legend placement shared by all figures.

use plotters::style::RGBColor;

/// The qualitative palette used for [`SeriesColor::Auto`] and [`SeriesColor::Palette`]: matplotlib's "tab10",
/// the colours most paper figures are drawn with.
pub const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),  // blue
    (255, 127, 14),  // orange
    (44, 160, 44),   // green
    (214, 39, 40),   // red
    (148, 103, 189), // purple
    (140, 86, 75),   // brown
    (227, 119, 194), // pink
    (127, 127, 127), // grey
    (188, 189, 34),  // olive
    (23, 190, 207),  // cyan
];

/// The colour of a series, a bar group or a reference line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SeriesColor {
    /// The palette entry of the item's position in its chart (series 0 is blue, 1 orange, ...);
    /// for reference lines a dark grey.
    #[default]
    Auto,
    /// A fixed palette entry (wraps around after [`PALETTE`]'s ten colours).
    Palette(usize),
    /// A fixed colour, 8 bits per channel.
    Rgb(u8, u8, u8),
}

impl SeriesColor {
    /// The concrete colour for the item at `index` in its chart.
    pub(crate) fn resolve(self, index: usize) -> RGBColor {
        let (r, g, b) = match self {
            Self::Auto => palette(index),
            Self::Palette(i) => palette(i),
            Self::Rgb(r, g, b) => (r, g, b),
        };
        RGBColor(r, g, b)
    }
}

fn palette(index: usize) -> (u8, u8, u8) {
    PALETTE.get(index % PALETTE.len()).copied().unwrap_or((0, 0, 0))
}

/// How one line series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeriesStyle {
    /// Line, marker and band colour.
    pub color: SeriesColor,
    /// Draw the line dashed instead of solid.
    pub dashed: bool,
    /// Draw a marker at every point (the shape cycles with the series index: circle, square, triangle, diamond,
    /// so figures stay readable in black and white).
    pub marker: bool,
    /// Connect the points with a line (switch off for a scatter plot).
    pub line: bool,
}

impl Default for SeriesStyle {
    /// Automatic colour, solid line, no markers.
    fn default() -> Self {
        Self { color: SeriesColor::Auto, dashed: false, marker: false, line: true }
    }
}

/// Where the legend of a chart goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// Inside the plot, in the corner where it covers no data (tried in the order upper right, upper left,
    /// lower right, lower left); to the right of the plot if every corner would cover data.
    #[default]
    Auto,
    /// Inside the plot, upper left corner.
    UpperLeft,
    /// Inside the plot, upper right corner.
    UpperRight,
    /// Inside the plot, lower left corner.
    LowerLeft,
    /// Inside the plot, lower right corner.
    LowerRight,
    /// To the right of the plot area (never covers data; the plot gets narrower).
    OutsideRight,
    /// No legend.
    Hidden,
}

/// A corner of the plot area.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Corner {
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
}

impl Corner {
    /// The order in which [`LegendPosition::Auto`] tries the corners.
    pub(crate) const AUTO_ORDER: [Self; 4] = [Self::UpperRight, Self::UpperLeft, Self::LowerRight, Self::LowerLeft];

    /// Top-left pixel of a `size` box in this corner of a `plot` box (both in pixels), `inset` away from the edges.
    pub(crate) fn place(self, plot: (i32, i32), size: (i32, i32), inset: i32) -> (i32, i32) {
        let left = inset;
        let right = plot.0 - inset - size.0;
        let top = inset;
        let bottom = plot.1 - inset - size.1;
        match self {
            Self::UpperRight => (right, top),
            Self::UpperLeft => (left, top),
            Self::LowerRight => (right, bottom),
            Self::LowerLeft => (left, bottom),
        }
    }
}

/// Where a legend ends up after [`LegendPosition::Auto`] has been resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Placement {
    Inside(Corner),
    Outside,
    /// Under the plot, in as many columns as fit: for a legend too wide to go beside the plot and that would
    /// hide data in every corner.
    Below,
    None,
}

impl LegendPosition {
    /// The placement for the explicit positions; `None` for [`LegendPosition::Auto`], which needs the data.
    pub(crate) fn fixed(self) -> Option<Placement> {
        match self {
            Self::Auto => None,
            Self::UpperLeft => Some(Placement::Inside(Corner::UpperLeft)),
            Self::UpperRight => Some(Placement::Inside(Corner::UpperRight)),
            Self::LowerLeft => Some(Placement::Inside(Corner::LowerLeft)),
            Self::LowerRight => Some(Placement::Inside(Corner::LowerRight)),
            Self::OutsideRight => Some(Placement::Outside),
            Self::Hidden => Some(Placement::None),
        }
    }
}

/// Near-black used for text and axes.
pub(crate) const INK: RGBColor = RGBColor(20, 20, 20);
/// Light grey for grid lines.
pub(crate) const GRID: RGBColor = RGBColor(225, 225, 225);
/// Dark grey, the default colour of reference lines.
pub(crate) const REF_GREY: RGBColor = RGBColor(90, 90, 90);
