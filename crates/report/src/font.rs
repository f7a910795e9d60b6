//! The embedded font, so that PNG text renders on machines without any system font.
//!
//! plotters' `ab_glyph` text backend knows no fonts until one is registered. We embed DejaVu Sans 2.37
//! (Bitstream Vera licence, see `assets/DejaVuSans-LICENSE.txt`) and register it once under the family names
//! plotters uses (`sans-serif`, `serif`, `monospace`), so any text style resolves to it.

use std::sync::OnceLock;

use plotters::style::{register_font, FontStyle};

use crate::ReportError;

/// DejaVu Sans (Book), as shipped by Debian's `fonts-dejavu-core` 2.37.
static DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The font family name every figure of this crate uses for its text.
pub(crate) const FAMILY: &str = "sans-serif";

/// Whether registration succeeded; set once, by the first caller.
static REGISTERED: OnceLock<bool> = OnceLock::new();

/// Registers the embedded font with plotters, once per process; later calls only return the first outcome.
///
/// All renderers of this crate call it themselves: call it directly only if you draw with plotters yourself.
pub fn ensure_font_registered() -> Result<(), ReportError> {
    let ok = *REGISTERED.get_or_init(|| {
        ["sans-serif", "serif", "monospace"]
            .iter()
            .all(|family| register_font(family, FontStyle::Normal, DEJAVU_SANS).is_ok())
    });
    if ok {
        Ok(())
    } else {
        Err(ReportError::Font)
    }
}
