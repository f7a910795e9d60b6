//! Figures and the human-readable report of pmon.
//!
//! - [`LineChart`]: curves with shaded 95 % bands and labelled reference lines (detection and false-alarm rates
//!   over error size or uncertainty, as in the paper's Section IV).
//! - [`BarChart`]: grouped bars with error bars (latency per component).
//! - [`TopView`]: one frame seen from above: grid cells, points, footprints and grown regions, clusters, injected
//!   displacements (for `pmon view`).
//! - [`HtmlReport`] and [`write_csv`]: a static page linking the figures, and the data behind each figure.
//!
//! Every figure renders to SVG ([`LineChart::render_svg`]) and PNG ([`LineChart::render_png`]) with white
//! background and paper-like axes. Text in PNGs is drawn with DejaVu Sans, embedded in the crate and registered
//! with plotters on first use ([`ensure_font_registered`]), so rendering needs no system fonts. Renderers never
//! panic on empty series, NaN values (skipped) or single points; failures are [`ReportError`]s naming the file.
//!
//! This crate draws plain data and depends on no other pmon crate.
//!
//! ```no_run
//! use pmon_report::{LineChart, RefLine, Series};
//! let chart = LineChart::new("Permanent position error", "position error [m]", "detection rate")
//!     .with_y_range(0.0, 1.0)
//!     .with_series(Series::new("sensor check, 0.2 m cells", vec![(0.2, 0.1), (0.5, 0.6), (1.0, 0.98)]).with_markers())
//!     .with_ref_line(RefLine::vertical(0.7, "paper: 0.7 m"));
//! chart.render_svg("detection.svg")?;
//! chart.render_png("detection.png", 1600, 1000)?;
//! chart.write_csv("detection.csv")?;
//! # Ok::<(), pmon_report::ReportError>(())
//! ```

mod axes;
mod bar;
mod csv_out;
mod error;
mod font;
mod html;
mod line;
mod plot;
mod render;
mod style;
mod topview;

pub use bar::{BarChart, BarGroup};
pub use csv_out::write_csv;
pub use error::ReportError;
pub use font::ensure_font_registered;
pub use html::{escape_html, CellClass, HtmlReport, TableCell};
pub use line::{LineChart, Orientation, RefLine, Series};
pub use render::{Figure, MAX_PNG_SIDE_PX};
pub use style::{LegendPosition, SeriesColor, SeriesStyle, PALETTE};
pub use topview::{BoxKind, CellState, TopView, ViewBox, ViewCell, ViewCluster};
