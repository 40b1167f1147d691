//! The bundled font: plotters draws text with `ab_glyph`, which needs a registered font,
//! and a figure must read the same on a board with no fonts installed.

use std::sync::Once;

use plotters::style::FontStyle;

/// DejaVu Sans (its licence is beside it in `assets/`).
static DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The family every label is drawn in.
pub const FAMILY: &str = "sans-serif";

/// Registers the font as [`FAMILY`] (once; later calls do nothing).
pub fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Registration fails only for a font that does not parse; the bundled one does.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS);
    });
}
