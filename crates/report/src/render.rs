//! Turning a figure description into SVG text or PNG bytes and files.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::IN_MEMORY;
use crate::font::ensure_font_registered;
use crate::plot::de;
use crate::ReportError;

/// The largest PNG side this crate renders, in pixels (larger requests are an error, not a huge allocation).
pub const MAX_PNG_SIDE_PX: u32 = 16_384;

/// Which kind of output is being drawn (vector output thins very dense point clouds).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Output {
    Svg,
    Png,
}

/// What every figure implements: its default size and how it draws itself on any plotters backend.
pub(crate) trait Draw {
    /// Size of the SVG output in pixels.
    fn svg_size_px(&self) -> (u32, u32);
    /// Draws the whole figure on `root` (which is not yet filled).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, output: Output) -> Result<(), String>;
}

/// A figure that can be rendered; implemented by every chart of this crate, so figures of different kinds can be
/// kept in one `Vec<Box<dyn Figure>>`. The same methods exist as inherent methods on each chart.
pub trait Figure {
    /// Renders as SVG text (text stays text; viewers use their own sans-serif font).
    fn render_svg_string(&self) -> Result<String, ReportError>;
    /// Renders as an SVG file at `path` (overwritten if it exists; its folder must exist).
    fn render_svg(&self, path: &Path) -> Result<(), ReportError>;
    /// Renders as PNG bytes of `width_px` x `height_px` (text and line widths scale with the size).
    fn render_png_bytes(&self, width_px: u32, height_px: u32) -> Result<Vec<u8>, ReportError>;
    /// Renders as a PNG file at `path` of `width_px` x `height_px`.
    fn render_png(&self, path: &Path, width_px: u32, height_px: u32) -> Result<(), ReportError>;
}

fn draw_error(target: &str, message: String) -> ReportError {
    ReportError::Draw { target: target.to_string(), message }
}

pub(crate) fn svg_string<F: Draw>(fig: &F, target: &str) -> Result<String, ReportError> {
    ensure_font_registered()?;
    let size = fig.svg_size_px();
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        fig.draw(&root, Output::Svg).map_err(|m| draw_error(target, m))?;
        root.present().map_err(|e| draw_error(target, de(e)))?;
    }
    Ok(out)
}

pub(crate) fn png_bytes<F: Draw>(fig: &F, width_px: u32, height_px: u32, target: &str) -> Result<Vec<u8>, ReportError> {
    if width_px == 0 || height_px == 0 || width_px > MAX_PNG_SIDE_PX || height_px > MAX_PNG_SIDE_PX {
        return Err(ReportError::InvalidSize { target: target.to_string(), width_px, height_px });
    }
    ensure_font_registered()?;
    // Both sides are at most 16 384, so the product fits comfortably in usize on 64-bit targets.
    let len = (width_px as usize) * (height_px as usize) * 3;
    let mut rgb = vec![255u8; len];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width_px, height_px)).into_drawing_area();
        fig.draw(&root, Output::Png).map_err(|m| draw_error(target, m))?;
        root.present().map_err(|e| draw_error(target, de(e)))?;
    }
    encode_png(&rgb, width_px, height_px)
        .map_err(|e| ReportError::Encode { target: target.to_string(), message: e.to_string() })
}

fn encode_png(rgb: &[u8], width_px: u32, height_px: u32) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, width_px, height_px);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(rgb)?;
        writer.finish()?;
    }
    Ok(out)
}

pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    std::fs::write(path, bytes).map_err(|source| ReportError::Io { path: path.to_path_buf(), source })
}

pub(crate) fn render_svg<F: Draw>(fig: &F, path: &Path) -> Result<(), ReportError> {
    let svg = svg_string(fig, &path.display().to_string())?;
    write_file(path, svg.as_bytes())
}

pub(crate) fn render_png<F: Draw>(fig: &F, path: &Path, width_px: u32, height_px: u32) -> Result<(), ReportError> {
    let png = png_bytes(fig, width_px, height_px, &path.display().to_string())?;
    write_file(path, &png)
}

pub(crate) fn in_memory() -> &'static str {
    IN_MEMORY
}

/// Adds the inherent `render_*` methods and the [`Figure`] impl to a chart type.
macro_rules! impl_figure {
    ($t:ty) => {
        impl $t {
            /// Renders as an SVG file at `path` (overwritten if it exists; its folder must exist).
            /// Errors name the path.
            pub fn render_svg(&self, path: impl AsRef<std::path::Path>) -> Result<(), $crate::ReportError> {
                $crate::render::render_svg(self, path.as_ref())
            }
            /// Renders as SVG text.
            pub fn render_svg_string(&self) -> Result<String, $crate::ReportError> {
                $crate::render::svg_string(self, $crate::render::in_memory())
            }
            /// Renders as a PNG file at `path`, `width_px` x `height_px` (each side 1..=16 384; text and line widths
            /// scale with the size). Errors name the path.
            pub fn render_png(
                &self,
                path: impl AsRef<std::path::Path>,
                width_px: u32,
                height_px: u32,
            ) -> Result<(), $crate::ReportError> {
                $crate::render::render_png(self, path.as_ref(), width_px, height_px)
            }
            /// Renders as PNG bytes, `width_px` x `height_px`.
            pub fn render_png_bytes(&self, width_px: u32, height_px: u32) -> Result<Vec<u8>, $crate::ReportError> {
                $crate::render::png_bytes(self, width_px, height_px, $crate::render::in_memory())
            }
        }

        impl $crate::Figure for $t {
            fn render_svg_string(&self) -> Result<String, $crate::ReportError> {
                <$t>::render_svg_string(self)
            }
            fn render_svg(&self, path: &std::path::Path) -> Result<(), $crate::ReportError> {
                <$t>::render_svg(self, path)
            }
            fn render_png_bytes(&self, width_px: u32, height_px: u32) -> Result<Vec<u8>, $crate::ReportError> {
                <$t>::render_png_bytes(self, width_px, height_px)
            }
            fn render_png(
                &self,
                path: &std::path::Path,
                width_px: u32,
                height_px: u32,
            ) -> Result<(), $crate::ReportError> {
                <$t>::render_png(self, path, width_px, height_px)
            }
        }
    };
}
pub(crate) use impl_figure;
